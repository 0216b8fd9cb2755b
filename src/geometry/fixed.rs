//! The fixed-point arithmetic the two transforms share ([`super::transform`] for a SICK's
//! lines, [`super::sweep`] for a spinning lidar's returns): the range bound, the per-mm scale
//! of a Q2.30 direction, the Q40 → Q16.16 roundings, the integer square root and the
//! horizontal distance, and the two point types they produce. Formats and error bounds are in
//! [`super::transform`]'s documentation.

use crate::units::{Meters, Point3};
use crate::wide;

/// The longest range [`super::LineTransform::point`] places, millimetres: 2¹⁷ − 1 = 131 071
/// (131.071 m, beyond every LMS2xx mode: 81.91 m in the 80 m mode). Longer ranges give
/// `None`; this bound keeps every product within 64 bits.
pub const MAX_RANGE_MM: u32 = (1 << 17) - 1;

/// 2⁴⁰/1 000, rounded: the largest magnitude of a per-mm matrix entry (a unit component).
const MM_Q40: i64 = 1_099_511_628;

/// 1.024 = 2¹⁰/1 000 in Q32, rounded: turns a Q2.30 unit component into Q40 per mm.
const Q30_TO_MM_Q40: i64 = 4_398_046_511;

/// A Q2.30 unit component as Q40 metres per millimetre, clamped to ±2⁴⁰/1 000: the `i64`
/// form that [`per_mm_words`] is tested against.
#[cfg(test)]
pub(super) fn per_mm(q30: i64) -> i32 {
    // A unit vector's component: |q30| ≤ 2³⁰ up to rounding; clamped, the product with the
    // factor (< 2³²·⁰⁴) stays below 2⁶²·⁰⁴.
    let unit = q30.clamp(-(1 << 30), 1 << 30);
    let q40 = (unit * Q30_TO_MM_Q40 + (1 << 31)) >> 32;
    // ±MM_Q40 fits an i32.
    sat_i32(q40.clamp(-MM_Q40, MM_Q40))
}

/// [`per_mm`] in 32-bit words and one 32 × 32 → 64 product ([`wide::smul`], no library
/// call on ARMv6-M): the factor is 2³² + 103 079 215, so
/// `⌊(u·(2³² + f) + 2³¹) / 2³²⌋ = u + ⌊(u·f + 2³¹) / 2³²⌋` exactly (u·2³² is a multiple of
/// 2³²), with |u| ≤ 2³⁰ and f < 2²⁷.
pub(super) fn per_mm_words(q30: i64) -> i32 {
    const FRACTION: i32 = (Q30_TO_MM_Q40 - (1 << 32)) as i32;
    // |unit| ≤ 2³⁰ fits an i32.
    #[allow(clippy::cast_possible_truncation)]
    let unit = q30.clamp(-(1 << 30), 1 << 30) as i32;
    let q40 = i64::from(unit) + ((wide::smul(unit, FRACTION) + (1 << 31)) >> 32);
    sat_i32(q40.clamp(-MM_Q40, MM_Q40))
}

/// Saturates an `i64` to the `i32` range.
#[inline]
pub(super) fn sat_i32(value: i64) -> i32 {
    i32::try_from(value).unwrap_or(if value < 0 { i32::MIN } else { i32::MAX })
}

/// A Q40 metres coordinate rounded to Q16.16 [`Meters`], saturating.
#[inline]
pub(super) fn meters_q40(value: i64) -> Meters {
    Meters::from_bits(sat_i32(value.saturating_add(1 << 23) >> 24))
}

/// The point of Q40 metres coordinates `[x, y, z]`, each rounded to Q16.16 ([`meters_q40`],
/// saturating at ±32 768 m).
#[inline]
pub(super) fn point_q40([x, y, z]: [i64; 3]) -> Point3 {
    Point3 {
        x: meters_q40(x),
        y: meters_q40(y),
        z: meters_q40(z),
    }
}

/// `round(√x)` for any `u64`, by the bit-by-bit (restoring) method: no multiply, no divide.
/// One iteration per result bit.
pub(crate) fn isqrt_round(x: u64) -> u64 {
    if x >> 50 == 0 {
        return u64::from(isqrt_round_below_2_50(x));
    }
    // The highest power of four not above x.
    let mut bit: u64 = 1 << ((63 - x.leading_zeros()) & !1);
    let mut rem = x;
    let mut root: u64 = 0;
    while bit != 0 {
        let trial = root + bit;
        if rem >= trial {
            rem -= trial;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    // Now root = ⌊√x⌋ and rem = x − root²; √x ≥ root + ½ exactly when rem > root.
    if rem > root {
        root + 1
    } else {
        root
    }
}

/// [`isqrt_round`] for `x < 2⁵⁰` (every horizontal distance of the per-line path), the same
/// restoring method one result bit at a time, but with 32-bit words only: the root stays
/// below 2²⁵ and the partial remainder below 2²⁸, so `x` is shifted in two bits at a time
/// from its two halves and no 64-bit arithmetic is left in the loop.
#[inline]
fn isqrt_round_below_2_50(x: u64) -> u32 {
    #[allow(clippy::cast_possible_truncation)]
    let (hi, lo) = ((x >> 32) as u32, x as u32);
    let mut root = 0_u32;
    let mut rem = 0_u32;
    // One step: bring down the next two bits of x (`pair`), try the next root bit.
    let step = |root: &mut u32, rem: &mut u32, pair: u32| {
        *rem = (*rem << 2) | pair;
        let trial = (*root << 2) | 1;
        *root <<= 1;
        if *rem >= trial {
            *rem -= trial;
            *root |= 1;
        }
    };
    if hi != 0 {
        // The pairs of `hi` from its highest non-zero one (hi < 2¹⁸: at most 9 pairs).
        let mut shift = (31 - hi.leading_zeros()) & !1;
        loop {
            step(&mut root, &mut rem, (hi >> shift) & 3);
            if shift == 0 {
                break;
            }
            shift -= 2;
        }
        let mut bits = lo;
        for _ in 0..16 {
            step(&mut root, &mut rem, bits >> 30);
            bits <<= 2;
        }
    } else if lo != 0 {
        let lead = lo.leading_zeros() & !1;
        let mut bits = lo << lead;
        for _ in 0..(32 - lead) / 2 {
            step(&mut root, &mut rem, bits >> 30);
            bits <<= 2;
        }
    }
    // root = ⌊√x⌋, rem = x − root²; round up exactly when rem > root.
    if rem > root {
        root + 1
    } else {
        root
    }
}

/// A world point and its horizontal distance from the scanner.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinePoint {
    /// The point in the world frame, metres (saturated at ±32 768 m).
    pub point: Point3,
    /// The horizontal distance from the scanner's centre to the point, `√(Δx² + Δy²)`,
    /// metres, 0 ..= 131.071 m.
    pub horizontal: Meters,
}

#[cfg(feature = "defmt")]
impl defmt::Format for LinePoint {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "LinePoint({}, d {=i32} raw Q16.16)",
            self.point,
            self.horizontal.to_bits()
        );
    }
}

/// A world point and the square of its horizontal distance from the scanner: what
/// [`super::LineTransform::locate_squared`] gives for the per-point path, which needs the distance
/// only to find its gate bin ([`crate::gate::DistanceBins::bin_of_squared`]), not the
/// distance itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinePointSquared {
    /// The point in the world frame, metres (saturated at ±32 768 m).
    pub point: Point3,
    /// `Δx² + Δy²` with Δx, Δy the point's offsets from the scanner's centre rounded to
    /// Q16.16 metres: raw units squared (2⁻³² m²), below 2⁵⁰ (the range is at most
    /// 131.071 m). [`LinePoint::horizontal`] is its rounded square root.
    pub horizontal_squared: u64,
}

/// `round(√sum)` as Q16.16 [`Meters`] of a sum of squared raw units, saturating at 32 768 m.
#[inline]
pub(super) fn root_meters(sum: u64) -> Meters {
    Meters::from_bits(sat_i32(i64::try_from(isqrt_round(sum)).unwrap_or(i64::MAX)))
}

/// `Δx² + Δy²` of two Q40 offsets (each below 2⁴⁸) rounded to Q16: raw Q16.16 units squared.
#[inline]
pub(super) fn horizontal_squared(dx: i64, dy: i64) -> u64 {
    // Q40 → Q16, rounded: |Δ| < 2²⁴ (an i32), so each square is < 2⁴⁸ and their sum < 2⁴⁹.
    #[allow(clippy::cast_possible_truncation)]
    let round = |d: i64| ((d + (1 << 23)) >> 24) as i32;
    let (dx, dy) = (round(dx), round(dy));
    wide::square(dx) + wide::square(dy)
}

/// `√(Δx² + Δy²)` of two Q40 offsets (each below 2⁴⁸), as Q16.16 metres.
#[inline]
pub(super) fn horizontal(dx: i64, dy: i64) -> Meters {
    // The root of a sum below 2⁴⁹ is below 2²⁵: it fits an i32.
    root_meters(horizontal_squared(dx, dy))
}
