//! Saturation of an `i32` to a narrower signed range.
//!
//! ARMv7-M clamps in one instruction (`ssat`, `qadd16`), and there the plain `clamp` compiles
//! to it. ARMv6-M (Cortex-M0/M0+) has no saturating instruction: a clamp is two compares with
//! two literal constants, which the compiler keeps in registers through a loop (and so spills
//! others). There the common case, a value already in range, is tested with a shift, an add
//! of 1 and a compare (`v >> (B − 1)` is −1 or 0 exactly when `v` fits `B` signed bits), and
//! the clamp is out of line. The range-test forms are compiled on every target so that the
//! host tests check them against the plain clamps; both give the same value everywhere.

use crate::wide::HALVES;

/// `v` saturated to `i16`.
#[inline(always)]
#[must_use]
pub(crate) fn to_i16(v: i32) -> i16 {
    let fitted = to_signed_bits::<16>(v);
    // Within the i16 range: the cast is exact.
    #[allow(clippy::cast_possible_truncation)]
    let narrow = fitted as i16;
    narrow
}

/// `v` clamped to the `B`-bit signed range `−2^(B−1) ..= 2^(B−1) − 1` (`2 ≤ B ≤ 31`).
#[inline(always)]
#[must_use]
pub(crate) fn to_signed_bits<const B: u32>(v: i32) -> i32 {
    if HALVES {
        by_range_test::<B>(v)
    } else {
        v.clamp(min::<B>(), max::<B>())
    }
}

/// The range's lower end, `−2^(B−1)`.
const fn min<const B: u32>() -> i32 {
    -max::<B>() - 1
}

/// The range's upper end, `2^(B−1) − 1`.
const fn max<const B: u32>() -> i32 {
    (1 << (B - 1)) - 1
}

/// [`to_signed_bits`] by the range test, the clamp out of line.
#[inline(always)]
fn by_range_test<const B: u32>(v: i32) -> i32 {
    // v >> (B − 1) is −1 or 0: adding 1 makes it 0 or 1 exactly then.
    #[allow(clippy::cast_sign_loss)]
    if ((v >> (B - 1)) + 1) as u32 <= 1 {
        return v;
    }
    clamp_beyond::<B>(v)
}

/// [`to_signed_bits`] of a value beyond the range (rare).
#[cold]
#[inline(never)]
fn clamp_beyond<const B: u32>(v: i32) -> i32 {
    v.clamp(min::<B>(), max::<B>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::XorShift;
    extern crate std;
    use std::vec::Vec;

    fn values() -> Vec<i32> {
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D);
        let mut values = std::vec![i32::MIN, i32::MAX, 0, -1, 1];
        for edge in [1 << 13, 1 << 15, 1 << 30] {
            for d in -3..=3 {
                values.push(edge + d);
                values.push(-edge + d);
            }
        }
        values.extend((-70_000..=70_000).step_by(7));
        #[allow(clippy::cast_possible_truncation)]
        values.extend((0..10_000).map(|_| rng.next() as i32));
        values
    }

    #[test]
    fn the_range_tests_are_the_clamps() {
        for v in values() {
            assert_eq!(by_range_test::<14>(v), v.clamp(-8192, 8191), "{v}");
            assert_eq!(by_range_test::<16>(v), v.clamp(-32_768, 32_767), "{v}");
            assert_eq!(
                by_range_test::<31>(v),
                v.clamp(-(1 << 30), (1 << 30) - 1),
                "{v}"
            );
            assert_eq!(
                i32::from(to_i16(v)),
                v.clamp(i32::from(i16::MIN), i32::from(i16::MAX))
            );
        }
    }
}
