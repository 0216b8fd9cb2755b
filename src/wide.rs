//! 32 × 32 → 64-bit products and 64-bit shifts without the 64-bit library routines of
//! cores that lack them.
//!
//! ARMv7-M (and every host) multiplies two 32-bit words into 64 bits in one instruction
//! (`smull`/`umull`). ARMv6-M (Cortex-M0/M0+) has only the 32 × 32 → 32 `muls`, and an `i64`
//! product there is a call to `__aeabi_lmul` (a general 64 × 64 multiply), a variable 64-bit
//! shift one to `__aeabi_llsr`/`__aeabi_llsl`. On ARMv6-M the helpers here build a product
//! from two to four 16 × 16 products of the halves instead (inline, exact), and the shifts
//! from two 32-bit words. Elsewhere they are the plain `i64`/`u64`
//! operations. The half-word forms are compiled on every target so that the host tests
//! check them against the plain ones.
//!
//! The cfg tells ARMv6-M from ARMv7-M by `target_has_atomic = "32"` (ARMv6-M has no
//! compare-and-swap), as the classifier's cell indices do.

/// Whether the target lacks a 32 × 32 → 64 multiply (ARMv6-M).
pub(crate) const HALVES: bool = cfg!(all(target_arch = "arm", not(target_has_atomic = "32")));

/// `a · b` exactly, as `u64` (the plane rule's sums).
#[cfg(any(feature = "plane-rule", test))]
#[inline(always)]
#[must_use]
pub(crate) const fn umul(a: u32, b: u32) -> u64 {
    if HALVES {
        umul_halves(a, b)
    } else {
        a as u64 * b as u64
    }
}

/// `a · b` exactly, as `i64` (|a·b| ≤ 2⁶²).
#[inline(always)]
#[must_use]
pub(crate) const fn smul(a: i32, b: i32) -> i64 {
    if HALVES {
        smul_halves(a, b)
    } else {
        a as i64 * b as i64
    }
}

/// `a · b` exactly, as `i64` (|a·b| < 2⁶³): a signed word times an unsigned one.
#[inline(always)]
#[must_use]
pub(crate) const fn smul_u32(a: i32, b: u32) -> i64 {
    if HALVES {
        smul_u32_halves(a, b)
    } else {
        a as i64 * b as i64
    }
}

/// `a · b` exactly for `b < 2¹⁷` (a range in millimetres), as `i64`: on ARMv6-M two 16 × 16
/// products instead of four. For a larger `b` the result is unspecified (no panic).
#[inline(always)]
#[must_use]
pub(crate) fn smul_u17(a: i32, b: u32) -> i64 {
    if HALVES {
        smul_u17_halves(a, b)
    } else {
        i64::from(a) * i64::from(b)
    }
}

/// `a²` exactly, as `u64`: on ARMv6-M three 16 × 16 products instead of four.
#[inline(always)]
#[must_use]
pub(crate) fn square(a: i32) -> u64 {
    if HALVES {
        square_halves(a)
    } else {
        // smull; a square is non-negative.
        #[allow(clippy::cast_sign_loss)]
        let square = (i64::from(a) * i64::from(a)) as u64;
        square
    }
}

/// [`umul`] from the 16-bit halves (every partial product fits a `u32`; their middle sum is
/// below 2³³).
#[inline(always)]
#[must_use]
pub(crate) const fn umul_halves(a: u32, b: u32) -> u64 {
    let (ah, bh) = (a >> 16, b >> 16);
    let (al, bl) = (a & 0xFFFF, b & 0xFFFF);
    let mid = (ah * bl) as u64 + (al * bh) as u64;
    (((ah * bh) as u64) << 32) + (mid << 16) + (al * bl) as u64
}

/// [`smul`] from the magnitudes' [`umul_halves`] (at most 2⁶², so the signed result fits).
#[inline(always)]
#[must_use]
pub(crate) const fn smul_halves(a: i32, b: i32) -> i64 {
    #[allow(clippy::cast_possible_wrap)]
    let magnitude = umul_halves(a.unsigned_abs(), b.unsigned_abs()) as i64;
    if (a < 0) == (b < 0) {
        magnitude
    } else {
        -magnitude
    }
}

/// [`smul_u32`] from [`umul_halves`] of the magnitude (`|a|·b < 2³¹·2³² = 2⁶³`, so the
/// signed result fits).
#[inline(always)]
#[must_use]
pub(crate) const fn smul_u32_halves(a: i32, b: u32) -> i64 {
    #[allow(clippy::cast_possible_wrap)]
    let magnitude = umul_halves(a.unsigned_abs(), b) as i64;
    if a < 0 {
        -magnitude
    } else {
        magnitude
    }
}

/// [`smul_u17`] from the halves: `a = ah·2¹⁶ + al`, `b = bh·2¹⁶ + bl` with `bh` 0 or 1, so
/// `a·b = ah·bl·2¹⁶ + al·bl + bh·a·2¹⁶` (`|ah·bl| < 2³¹`, `al·bl < 2³²`).
#[inline(always)]
#[must_use]
pub(crate) fn smul_u17_halves(a: i32, b: u32) -> i64 {
    let (ah, al) = (a >> 16, a & 0xFFFF);
    let bl = b & 0xFFFF;
    // bl < 2¹⁶ fits an i32; al ≥ 0.
    #[allow(clippy::cast_possible_wrap, clippy::cast_sign_loss)]
    let (high, low) = (ah.wrapping_mul(bl as i32), (al as u32).wrapping_mul(bl));
    let product = (i64::from(high) << 16) + i64::from(low);
    if b >> 16 == 0 {
        product
    } else {
        product + (i64::from(a) << 16)
    }
}

/// [`square`] from the halves of `|a| = h·2¹⁶ + l`: `h²·2³² + h·l·2¹⁷ + l²`.
#[inline(always)]
#[must_use]
pub(crate) fn square_halves(a: i32) -> u64 {
    let x = a.unsigned_abs();
    let (h, l) = (x >> 16, x & 0xFFFF);
    (u64::from(h * h) << 32) + (u64::from(h * l) << 17) + u64::from(l * l)
}

/// Whether the target divides 32-bit words in hardware but has no 64-bit division
/// (ARMv7-M: `udiv`; a `u64` division there is a call to `__aeabi_uldivmod`).
pub(crate) const DIVIDES_WORDS: bool = cfg!(all(target_arch = "arm", target_has_atomic = "32"));

/// `(n / d, n % d)` for a 32-bit divisor `d > 0`; `(0, 0)` for `d = 0` (no panic). On ARMv7-M
/// by [`div_rem_words`] (two or three `udiv`); elsewhere the plain `u64` division (ARMv6-M
/// has no divide instruction at all: its library call stays the cheaper way).
#[inline]
#[must_use]
pub(crate) fn div_rem_u64_u32(n: u64, d: u32) -> (u64, u32) {
    if d == 0 {
        return (0, 0);
    }
    if DIVIDES_WORDS {
        div_rem_words(n, d)
    } else {
        // The remainder is below d.
        #[allow(clippy::cast_possible_truncation)]
        (n / u64::from(d), (n % u64::from(d)) as u32)
    }
}

/// `n / d` for `d > 0`; 0 for `d = 0` (no panic). On ARMv7-M in 32-bit divisions: by
/// [`div_rem_words`] for a divisor below 2³², else from the quotient of `n / 2` by the
/// divisor's top 32 bits, normalised, and one correction (Hacker's Delight, 2nd ed.,
/// `divdu`, Fig. 9–5): a few `udiv` where the library's `__aeabi_uldivmod` loops over the
/// bits. Elsewhere the plain `u64` division.
#[cfg(any(feature = "plane-rule", test))]
#[inline]
#[must_use]
pub(crate) fn div_u64(n: u64, d: u64) -> u64 {
    if d == 0 {
        return 0;
    }
    if DIVIDES_WORDS {
        div_words_u64(n, d)
    } else {
        n / d
    }
}

/// [`div_u64`] in 32-bit divisions, for `d > 0` (0 for `d = 0`).
#[cfg(any(feature = "plane-rule", test))]
#[must_use]
fn div_words_u64(n: u64, d: u64) -> u64 {
    #[allow(clippy::cast_possible_truncation)]
    let d_hi = (d >> 32) as u32;
    if d_hi == 0 {
        #[allow(clippy::cast_possible_truncation)]
        return div_rem_words(n, d as u32).0;
    }
    // d ≥ 2³²: the quotient is below 2³². With d's top bit at 63 − s, v = its top 32 bits
    // (v ≥ 2³¹) and n/2 (high word below 2³¹ ≤ v): q₁ = ⌊(n/2) / v⌋ fits 32 bits, and
    // q₀ = ⌊q₁·2ˢ / 2³¹⌋ − 1 (not below 0) is the quotient or one below it.
    let s = d_hi.leading_zeros();
    #[allow(clippy::cast_possible_truncation)]
    let v = ((d << s) >> 32) as u32;
    let half = n >> 1;
    #[allow(clippy::cast_possible_truncation)]
    let (q1, _) = div_two_words((half >> 32) as u32, half as u32, v);
    let mut q0 = (u64::from(q1) << s) >> 31;
    q0 = q0.saturating_sub(1);
    // q₀ ≤ n / d: the product does not pass n.
    if n.wrapping_sub(q0.wrapping_mul(d)) >= d {
        q0 += 1;
    }
    q0
}

/// [`div_rem_u64_u32`] in 32-bit divisions: the high word by `d`, then the remainder and the
/// low word by [`div_two_words`]. `d > 0`; `d = 0` gives `(0, 0)`.
#[must_use]
fn div_rem_words(n: u64, d: u32) -> (u64, u32) {
    #[allow(clippy::cast_possible_truncation)]
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    let Some(q_hi) = hi.checked_div(d) else {
        return (0, 0);
    };
    let r = hi - q_hi * d;
    let (q_lo, rem) = div_two_words(r, lo, d);
    ((u64::from(q_hi) << 32) | u64::from(q_lo), rem)
}

/// `((u1·2³² + u0) / v, (u1·2³² + u0) % v)` for `u1 < v` (the quotient fits 32 bits), by
/// 16-bit digits and two 32-bit divisions with at most two corrections each (Hacker's
/// Delight, 2nd ed., `divlu`, Fig. 9–3). For `u1 ≥ v` or `v = 0` some value, never a panic.
#[must_use]
fn div_two_words(u1: u32, u0: u32, v: u32) -> (u32, u32) {
    const B: u32 = 1 << 16;
    if v == 0 || u1 >= v {
        return (u32::MAX, 0);
    }
    // Normalise: v's top bit set.
    let s = v.leading_zeros();
    let v = v << s;
    let (vn1, vn0) = (v >> 16, v & 0xFFFF);
    let un32 = if s == 0 {
        u1
    } else {
        (u1 << s) | (u0 >> (32 - s))
    };
    let un10 = u0 << s;
    let (un1, un0) = (un10 >> 16, un10 & 0xFFFF);
    // vn1 ≥ 2¹⁵ > 0: the divisions cannot fail.
    let digit = |num: u32, low: u32| -> u32 {
        let mut q = num / vn1;
        let mut rhat = num - q * vn1;
        while q >= B || q.wrapping_mul(vn0) > B.wrapping_mul(rhat).wrapping_add(low) {
            q -= 1;
            rhat += vn1;
            if rhat >= B {
                break;
            }
        }
        q
    };
    let q1 = digit(un32, un1);
    let un21 = un32
        .wrapping_mul(B)
        .wrapping_add(un1)
        .wrapping_sub(q1.wrapping_mul(v));
    let q0 = digit(un21, un0);
    let rem = un21
        .wrapping_mul(B)
        .wrapping_add(un0)
        .wrapping_sub(q0.wrapping_mul(v))
        >> s;
    (q1.wrapping_mul(B).wrapping_add(q0), rem)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::XorShift;

    #[test]
    fn the_wide_word_division_is_the_u64_division() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let check = |n: u64, d: u64| {
            assert_eq!(
                div_words_u64(n, d),
                n.checked_div(d).unwrap_or(0),
                "{n} / {d}"
            );
            assert_eq!(div_u64(n, d), n.checked_div(d).unwrap_or(0), "{n} / {d}");
        };
        let edges = [
            0_u64,
            1,
            2,
            0xFFFF_FFFF,
            0x1_0000_0000,
            0x1_0000_0001,
            0x7FFF_FFFF_FFFF_FFFF,
            0x8000_0000_0000_0000,
            u64::MAX - 1,
            u64::MAX,
        ];
        for &n in &edges {
            for &d in &edges {
                check(n, d);
            }
        }
        for _ in 0..200_000 {
            let (a, b) = (rng.next(), rng.next());
            let n = a >> (b % 64);
            let d = b >> ((a >> 7) % 64);
            check(n, d);
            // Quotients next to an integer: d·q and its neighbours.
            if let Some(most) = u64::MAX.checked_div(d) {
                let q = (a >> 40) % most.max(1);
                let base = d.wrapping_mul(q);
                for n in [base.wrapping_sub(1), base, base.wrapping_add(1)] {
                    check(n, d);
                }
            }
        }
    }

    #[test]
    fn the_word_division_is_the_u64_division() {
        let mut rng = XorShift(0xD1B5_4A32_D192_ED03_u64);
        let mut next = || rng.next();
        let divisors = [
            1_u32, 2, 3, 7, 255, 256, 0xFFFF, 0x1_0000, 0x1_0001, 36_000, 396_000,
        ];
        let extremes = [
            0_u64,
            1,
            u64::from(u32::MAX),
            1 << 32,
            u64::MAX,
            u64::MAX - 1,
        ];
        for d in divisors
            .into_iter()
            .chain([u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1])
        {
            for n in extremes {
                let want = (n / u64::from(d), (n % u64::from(d)) as u32);
                assert_eq!(div_rem_words(n, d), want, "{n} / {d}");
            }
        }
        for i in 0..2_000_000_u64 {
            let n = next() >> (next() % 64);
            // Divisors of every width, the small ones often.
            let d = (next() >> (32 + i % 32)) as u32;
            if d == 0 {
                continue;
            }
            let want = (n / u64::from(d), (n % u64::from(d)) as u32);
            assert_eq!(div_rem_words(n, d), want, "{n} / {d}");
            assert_eq!(div_rem_u64_u32(n, d), want, "{n} / {d}");
        }
        assert_eq!(div_rem_words(5, 0), (0, 0));
        assert_eq!(div_rem_u64_u32(5, 0), (0, 0));
    }

    const EDGES: [u32; 14] = [
        0,
        1,
        2,
        0x1_FFFF,
        0x2_0000,
        0x7FFF,
        0x8000,
        0xFFFF,
        0x1_0000,
        0x1_0001,
        0x7FFF_FFFF,
        0x8000_0000,
        0x8000_0001,
        0xFFFF_FFFF,
    ];

    #[test]
    fn products_from_halves_are_exact() {
        #[allow(clippy::cast_possible_wrap)]
        let check = |a: u32, b: u32| {
            assert_eq!(umul_halves(a, b), u64::from(a) * u64::from(b), "{a} {b}");
            assert_eq!(umul(a, b), u64::from(a) * u64::from(b));
            let (sa, b17) = (a as i32, b & 0x1_FFFF);
            assert_eq!(
                smul_u17_halves(sa, b17),
                i64::from(sa) * i64::from(b17),
                "{sa} {b17}"
            );
            assert_eq!(smul_u17(sa, b17), i64::from(sa) * i64::from(b17));
            #[allow(clippy::cast_possible_wrap)]
            let sb = b as i32;
            assert_eq!(
                smul_halves(sa, sb),
                i64::from(sa) * i64::from(sb),
                "{sa} {sb}"
            );
            assert_eq!(smul(sa, sb), i64::from(sa) * i64::from(sb));
            let su = i64::from(sa) * i64::from(b);
            assert_eq!(smul_u32_halves(sa, b), su, "{sa} {b}");
            assert_eq!(smul_u32(sa, b), su);
            let sq = u64::from(sa.unsigned_abs()).pow(2);
            assert_eq!(square_halves(sa), sq, "{sa}");
            assert_eq!(square(sa), sq);
        };
        for a in EDGES {
            for b in EDGES {
                check(a, b);
                check(a.wrapping_neg(), b);
            }
        }
        let mut x = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        for i in 0..1_000_000_u32 {
            let v = x.next();
            #[allow(clippy::cast_possible_truncation)]
            let (a, b) = ((v >> 32) as u32, v as u32);
            // Every magnitude of both operands.
            check(a >> (i % 32), b >> ((i / 32) % 32));
        }
    }
}
