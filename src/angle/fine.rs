//! Fixed-point angles and trigonometry: [`FineAngle`] (a fraction of a turn, Q0.32) and its
//! sine and cosine in signed Q2.30 ([`SinCos`]), all in integer arithmetic, so the host and a
//! Cortex-M0 produce the same bits.
//!
//! # Method
//! A quarter-wave table `QUARTER_SINE[k] = round(sin(k·(π/2)/256) · 2³⁰)`, k = 0 ..= 256
//! (1 KiB of flash), is evaluated by the compiler (const evaluation, IEEE soft-float, the same
//! on every target). An angle is reduced to its quadrant and the nearest table node a, with
//! |δ| = |x − a| ≤ π/1024 ≈ 3.07·10⁻³ rad, and
//!
//! ```text
//! sin(a + δ) = sin a · cos δ + cos a · sin δ,   cos(a + δ) = cos a · cos δ − sin a · sin δ,
//! cos δ ≈ 1 − δ²/2 (error ≤ δ⁴/24 < 4·10⁻¹²),   sin δ ≈ δ − δ³/6 (error ≤ δ⁵/120 < 3·10⁻¹⁵),
//! ```
//!
//! in `i64`. The table's rounding (≤ 2⁻³¹) dominates: the unit tests hold both functions
//! within 3·2⁻³¹ ≈ 1.4·10⁻⁹ of `f64` over a sweep of angles, and exact at multiples of 90°.
//! Cost: two table reads, eight 64-bit multiplies, no division. This runs per scan line (the
//! actuator angle) or per pose change, never per point.

use core::fmt;

use fixed::types::{I16F48, I2F30};

use super::Angle;

/// Segments per quarter turn in the sine table (a power of two).
const SEGMENTS_LOG2: u32 = 8;
/// Segments per quarter turn: 256, so nodes are 90°/256 ≈ 0.35° apart.
const SEGMENTS: usize = 1 << SEGMENTS_LOG2;
/// Bits of a Q0.32 turn below the table index within a quadrant: 32 − 2 − 8 = 22.
const NODE_SHIFT: u32 = 30 - SEGMENTS_LOG2;

/// One in Q2.30, raw.
const ONE_Q30: i32 = 1 << 30;

/// `sin(k·(π/2)/256)` in Q2.30, raw, for k = 0 ..= 256: `QUARTER_SINE[0] = 0`,
/// `QUARTER_SINE[256] = 2³⁰`. Rounded to nearest (error ≤ 2⁻³¹).
const QUARTER_SINE: [i32; SEGMENTS + 1] = quarter_sine_table();

/// 2π in Q3.29, raw, rounded down: 3 373 259 426 (relative error < 3·10⁻¹⁰, on δ only).
const TAU_Q29: i64 = (fixed::consts::TAU.to_bits() >> (125 - 29)) as i64;

/// 1/(2π) in Q0.64, raw, rounded down (relative error < 10⁻¹⁸).
const FRAC_1_TAU_Q64: u64 = (fixed::consts::FRAC_1_TAU.to_bits() >> 64) as u64;

/// 1/6 in Q0.32, raw: round(2³²/6).
const SIXTH_Q32: i64 = 715_827_883;

/// Builds [`QUARTER_SINE`] at compile time: the Taylor series of sine in `f64` (terms to
/// x²⁵/25!, below 10⁻¹⁸ at π/2), rounded to Q2.30.
const fn quarter_sine_table() -> [i32; SEGMENTS + 1] {
    let mut table = [0_i32; SEGMENTS + 1];
    let mut k = 0;
    while k <= SEGMENTS {
        let x = (k as f64) * (core::f64::consts::FRAC_PI_2 / SEGMENTS as f64);
        let x2 = x * x;
        let mut term = x;
        let mut sum = 0.0_f64;
        let mut n = 1.0_f64;
        let mut i = 0;
        while i < 13 {
            sum += term;
            term = -term * x2 / ((n + 1.0) * (n + 2.0));
            n += 2.0;
            i += 1;
        }
        // 0 ≤ sum ≤ 1 + 10⁻¹⁵, so the rounded value lies in 0 ..= 2³⁰.
        let raw = (sum * (ONE_Q30 as f64) + 0.5) as i32;
        let raw = if raw > ONE_Q30 { ONE_Q30 } else { raw };
        if let Some((_, rest)) = table.split_at_mut_checked(k) {
            if let Some(slot) = rest.first_mut() {
                *slot = raw;
            }
        }
        k += 1;
    }
    table
}

/// The table entry k (0 for an index past the end, which the callers never form).
const fn node(k: usize) -> i64 {
    match QUARTER_SINE.split_at_checked(k) {
        Some((_, rest)) => match rest.first() {
            Some(&v) => v as i64,
            None => 0,
        },
        None => 0,
    }
}

/// A Q2.30 value as the fixed type.
const fn q30(raw: i32) -> I2F30 {
    I2F30::from_bits(raw)
}

/// The sine and cosine of an angle, signed Q2.30 (range ±2, used within −1 ..= +1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SinCos {
    /// sin, −1 ..= +1, within 1.4·10⁻⁹ of the exact value.
    pub sin: I2F30,
    /// cos, −1 ..= +1, within 1.4·10⁻⁹ of the exact value.
    pub cos: I2F30,
}

#[cfg(feature = "defmt")]
defmt_raw!(
    SinCos,
    "SinCos(sin {=i32}, cos {=i32}) raw Q2.30",
    [sin, cos]
);

/// An angle as a fraction of a turn in `[0, 1)`, unsigned Q0.32 (the "binary angle").
///
/// Resolution 2⁻³² turn ≈ 1.46 nrad (at 80 m: 0.12 µm); every value is a valid angle and all
/// arithmetic wraps modulo one turn. Angles grow counter-clockwise about the axis they turn
/// about (right-hand rule). An encoder [`Angle`] (Q0.16) converts exactly with
/// [`FineAngle::from`]; radians from the host convert with [`FineAngle::from_radians_f32`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct FineAngle(u32);

impl FineAngle {
    /// The zero angle.
    pub const ZERO: Self = Self(0);
    /// A quarter turn, 90°.
    pub const QUARTER: Self = Self(1 << 30);
    /// Half a turn, 180°.
    pub const HALF: Self = Self(1 << 31);

    /// An angle from the raw bits of a Q0.32 fraction of a turn: `bits / 2³²` turn.
    #[must_use]
    pub const fn from_bits(bits: u32) -> Self {
        Self(bits)
    }

    /// The raw bits of the Q0.32 fraction of a turn.
    #[must_use]
    pub const fn to_bits(self) -> u32 {
        self.0
    }

    /// An angle of `quarter_degrees / 4` degrees (any u32, taken modulo 1 440, one turn),
    /// rounded to the nearest 2⁻³² turn (error ≤ 2⁻³³ turn ≈ 0.73 nrad).
    #[must_use]
    pub const fn from_quarter_degrees(quarter_degrees: u32) -> Self {
        let q = (quarter_degrees % 1_440) as u64;
        // q·2³²/1 440 = q·2²⁷/45; q < 1 440 so q·2²⁷ < 2³⁸, and the quotient < 2³².
        Self((((q << 27) + 22) / 45) as u32)
    }

    /// An angle from radians as `f32`, reduced modulo 2π.
    ///
    /// The `f32` value is taken exactly (as Q16.48, which holds every `f32` below 2¹⁵ in
    /// magnitude to within 2⁻⁴⁹ rad), then multiplied by 1/(2π) and rounded to the nearest
    /// 2⁻³² turn: the error is below 10⁻⁹ rad. Integer arithmetic only, so every target gets
    /// the same bits.
    ///
    /// Returns `None` for NaN, ±∞ and |`radians`| ≥ 32 768 (≈ 5 215 turns: an angle that large
    /// is a host bug; `f32` itself has only ≈ 4 mrad resolution there).
    #[must_use]
    pub fn from_radians_f32(radians: f32) -> Option<Self> {
        let fixed = I16F48::checked_from_num(radians)?;
        // |bits| < 2⁶³ and 1/(2π) in Q0.64 < 2⁶¹·⁴, so the product fits an i128.
        let product = i128::from(fixed.to_bits()) * i128::from(FRAC_1_TAU_Q64);
        // Q48 · Q64 = Q112; turns in Q32 are the product >> 80, rounded to nearest.
        let turns = (product + (1_i128 << 79)) >> 80;
        // Modulo one turn: the low 32 bits of the two's-complement value.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let bits = turns as u32;
        Some(Self(bits))
    }

    /// The angle in degrees, `[0, 360)`, for display and logs (not for computation).
    #[must_use]
    pub fn to_degrees_f32(self) -> f32 {
        // An f32 holds 24 significant bits: the display loses the low 8 bits of the angle.
        #[allow(clippy::cast_precision_loss)]
        let bits = self.0 as f32;
        bits * (360.0 / 4_294_967_296.0)
    }

    /// The sum of two angles, modulo one turn.
    #[must_use]
    pub const fn wrapping_add(self, other: Self) -> Self {
        Self(self.0.wrapping_add(other.0))
    }

    /// The difference `self − other`, modulo one turn.
    #[must_use]
    pub const fn wrapping_sub(self, other: Self) -> Self {
        Self(self.0.wrapping_sub(other.0))
    }

    /// The angle measured the other way round: `−self` modulo one turn.
    #[must_use]
    pub const fn reversed(self) -> Self {
        Self(self.0.wrapping_neg())
    }

    /// The sine and cosine of the angle, signed Q2.30, each within 1.4·10⁻⁹ of the exact
    /// value, exact (0 or ±1) at multiples of 90°. Never panics.
    ///
    /// Every product has two 32-bit factors (the crate's `wide` helpers): one `smull` on
    /// ARMv7-M, three or four 16 × 16 products on ARMv6-M instead of a 64 × 64 library
    /// multiply.
    #[must_use]
    pub const fn sin_cos(self) -> SinCos {
        use crate::wide::{smul, smul_u32};
        let quadrant = self.0 >> 30;
        let within = self.0 & (ONE_Q30 as u32 - 1);
        // The nearest node, 0 ..= 256, and the signed offset from it in 2⁻³² turn,
        // |offset| ≤ 2²¹ (within < 2³⁰ and k·2²² ≤ 2³⁰: both fit an i32).
        let k = ((within + (1 << (NODE_SHIFT - 1))) >> NODE_SHIFT) as usize;
        let offset = within as i32 - ((k as i32) << NODE_SHIFT);
        // δ in radians, Q32: offset · 2π; |δ| ≤ π/1 024, i.e. < 1.4·10⁷ raw (2π in Q3.29 is
        // below 2³²).
        let delta = ((smul_u32(offset, TAU_Q29 as u32) + (1 << 28)) >> 29) as i32;
        // δ² in Q32 (< 4.1·10⁴ raw), 1 − cos δ ≈ δ²/2, and sin δ ≈ δ − δ³/6, Q32; |δ³| < 2³⁹,
        // so δ³/2¹⁶ fits an i32, as 1/6 in Q0.32 does.
        let delta2 = ((smul(delta, delta) + (1 << 31)) >> 32) as i32;
        let one_minus_cos = (delta2 + 1) >> 1;
        let delta3 = smul(delta, delta2);
        let sin_delta = (delta as i64
            - ((smul((delta3 >> 16) as i32, SIXTH_Q32 as i32) + (1 << 47)) >> 48))
            as i32;
        let s = node(k) as i32;
        let c = node(SEGMENTS - k) as i32;
        // |s|, |c| ≤ 2³⁰, |1 − cos δ| < 2¹⁵, |sin δ| < 2²⁴: every product is below 2⁵⁵.
        let sin_r = s as i64 + ((smul(c, sin_delta) - smul(s, one_minus_cos) + (1 << 31)) >> 32);
        let cos_r = c as i64 + ((-smul(s, sin_delta) - smul(c, one_minus_cos) + (1 << 31)) >> 32);
        in_quadrant(quadrant, sin_r, cos_r)
    }
}

/// The sine and cosine of an angle in quadrant `quadrant` (0 ..= 3) from those of its offset
/// within the quadrant (Q2.30, each clamped to −1 ..= +1 first).
const fn in_quadrant(quadrant: u32, sin_r: i64, cos_r: i64) -> SinCos {
    let sin_r = clamp_unit(sin_r);
    let cos_r = clamp_unit(cos_r);
    let (sin, cos) = match quadrant {
        0 => (sin_r, cos_r),
        1 => (cos_r, -sin_r),
        2 => (-sin_r, -cos_r),
        _ => (-cos_r, sin_r),
    };
    SinCos {
        sin: q30(sin),
        cos: q30(cos),
    }
}

/// Clamps a Q2.30 value to −1 ..= +1 (rounding can step one LSB past ±1 near the nodes 0
/// and 256).
const fn clamp_unit(raw: i64) -> i32 {
    if raw > ONE_Q30 as i64 {
        ONE_Q30
    } else if raw < -(ONE_Q30 as i64) {
        -ONE_Q30
    } else {
        raw as i32
    }
}

impl From<Angle> for FineAngle {
    /// Exact: a Q0.16 turn is a Q0.32 turn with 16 zero bits appended.
    fn from(angle: Angle) -> Self {
        Self(u32::from(angle.to_bits()) << 16)
    }
}

impl fmt::Display for FineAngle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}°", self.to_degrees_f32())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for FineAngle {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "FineAngle({=u32}) raw Q0.32 turn", self.0);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use core::f64::consts::TAU;

    /// `sin_cos` as it was computed before: the same formula in 64 × 64-bit products (the
    /// quadrant's signs and the clamp shared: they have no products).
    fn sin_cos_i64(angle: FineAngle) -> SinCos {
        let this = angle;
        let quadrant = this.0 >> 30;
        let within = this.0 & (ONE_Q30 as u32 - 1);
        // The nearest node, 0 ..= 256, and the signed offset from it in 2⁻³² turn,
        // |offset| ≤ 2²¹.
        let k = ((within + (1 << (NODE_SHIFT - 1))) >> NODE_SHIFT) as usize;
        let offset = within as i64 - ((k as i64) << NODE_SHIFT);
        // δ in radians, Q32: offset · 2π; |δ| ≤ π/1 024, i.e. < 1.4·10⁷ raw.
        let delta = (offset * TAU_Q29 + (1 << 28)) >> 29;
        // δ² in Q32 (< 4.1·10⁴ raw), 1 − cos δ ≈ δ²/2, and sin δ ≈ δ − δ³/6, Q32.
        let delta2 = (delta * delta + (1 << 31)) >> 32;
        let one_minus_cos = (delta2 + 1) >> 1;
        let delta3 = delta * delta2;
        let sin_delta = delta - (((delta3 >> 16) * SIXTH_Q32 + (1 << 47)) >> 48);
        let s = node(k);
        let c = node(SEGMENTS - k);
        // |s|, |c| ≤ 2³⁰, |1 − cos δ| < 2¹⁵, |sin δ| < 2²⁴: every product is below 2⁵⁵.
        let sin_r = s + ((c * sin_delta - s * one_minus_cos + (1 << 31)) >> 32);
        let cos_r = c + ((-s * sin_delta - c * one_minus_cos + (1 << 31)) >> 32);
        in_quadrant(quadrant, sin_r, cos_r)
    }

    fn f(raw: I2F30) -> f64 {
        f64::from(raw.to_bits()) / f64::from(ONE_Q30)
    }

    fn rad(a: FineAngle) -> f64 {
        f64::from(a.to_bits()) / 4_294_967_296.0 * TAU
    }

    #[test]
    fn table_is_correctly_rounded() {
        for (k, &v) in QUARTER_SINE.iter().enumerate() {
            let x = k as f64 * core::f64::consts::FRAC_PI_2 / SEGMENTS as f64;
            let want = (x.sin() * f64::from(ONE_Q30)).round();
            assert!((f64::from(v) - want).abs() <= 0.0, "{k}: {v} vs {want}");
        }
        assert_eq!(QUARTER_SINE[0], 0);
        assert_eq!(QUARTER_SINE[SEGMENTS], ONE_Q30);
    }

    #[test]
    fn sin_cos_in_32_bit_factors_is_the_64_bit_formula() {
        // Every node and its neighbourhood in every quadrant, the quadrant edges, and random
        // angles.
        let mut angles = std::vec::Vec::new();
        for quadrant in 0..4_u32 {
            for k in 0..=256_u32 {
                let node = (quadrant << 30).wrapping_add(k << NODE_SHIFT);
                for d in [0, 1, 2, (1 << 21) - 1, 1 << 21] {
                    angles.push(node.wrapping_add(d));
                    angles.push(node.wrapping_sub(d));
                }
            }
        }
        let mut x = 0x9E37_79B9_u32;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            angles.push(x);
        }
        angles.extend([0, u32::MAX, 1 << 31, (1 << 30) - 1, 3 << 30]);
        for bits in angles {
            let a = FineAngle::from_bits(bits);
            assert_eq!(a.sin_cos(), sin_cos_i64(a), "{bits:#x}");
        }
    }

    #[test]
    fn sin_cos_exact_at_right_angles() {
        let one = I2F30::from_bits(ONE_Q30);
        let cases = [
            (FineAngle::ZERO, I2F30::ZERO, one),
            (FineAngle::QUARTER, one, I2F30::ZERO),
            (FineAngle::HALF, I2F30::ZERO, -one),
            (FineAngle::from_bits(3 << 30), -one, I2F30::ZERO),
        ];
        for (a, s, c) in cases {
            assert_eq!(a.sin_cos(), SinCos { sin: s, cos: c }, "{a}");
        }
    }

    #[test]
    fn sin_cos_within_bound_over_a_sweep() {
        let bound = 3.0 / f64::from(1_u32 << 31);
        let mut worst = 0.0_f64;
        // The larger error of sine and cosine at `bits`, into `worst`.
        let mut check = |bits: u32| {
            let a = FineAngle::from_bits(bits);
            let sc = a.sin_cos();
            let x = rad(a);
            worst = worst
                .max((f(sc.sin) - x.sin()).abs())
                .max((f(sc.cos) - x.cos()).abs());
        };
        // A prime stride visits every offset from a node, both signs, every quadrant.
        let mut bits = 0_u32;
        for _ in 0..400_000 {
            check(bits);
            bits = bits.wrapping_add(10_737_467);
        }
        // Around every node, just inside and just outside the half-segment boundaries.
        for k in 0..=(4 * SEGMENTS as u32) {
            for d in [0_i64, 1, -1, (1 << 21) - 1, -(1 << 21), 1 << 21] {
                check(((i64::from(k) << NODE_SHIFT) + d) as u32);
            }
        }
        assert!(worst <= bound, "worst {worst:e} > {bound:e}");
    }

    #[test]
    fn angle_conversions() {
        assert_eq!(
            FineAngle::from(Angle::from_bits(0x4000)),
            FineAngle::QUARTER
        );
        assert_eq!(FineAngle::from(Angle::from_bits(1)).to_bits(), 1 << 16);
        assert_eq!(FineAngle::from_quarter_degrees(360), FineAngle::QUARTER);
        assert_eq!(FineAngle::from_quarter_degrees(720), FineAngle::HALF);
        assert_eq!(FineAngle::from_quarter_degrees(1_440), FineAngle::ZERO);
        for q in 0..1_440_u32 {
            let exact = f64::from(q) / 1_440.0 * 4_294_967_296.0;
            let got = f64::from(FineAngle::from_quarter_degrees(q).to_bits());
            assert!((got - exact).abs() <= 0.5, "{q}");
        }
    }

    #[test]
    fn radians_from_f32_are_exact_and_wrap() {
        assert_eq!(FineAngle::from_radians_f32(0.0), Some(FineAngle::ZERO));
        assert_eq!(FineAngle::from_radians_f32(-0.0), Some(FineAngle::ZERO));
        for x in [
            1.0_f32,
            -1.0,
            core::f32::consts::PI,
            -core::f32::consts::PI,
            0.53,
            -0.53,
            7.5,
            -100.25,
            1.0e-7,
            32_767.9,
            -32_767.9,
        ] {
            let a = FineAngle::from_radians_f32(x).unwrap();
            let turns = (f64::from(x) / TAU).rem_euclid(1.0) * 4_294_967_296.0;
            let got = f64::from(a.to_bits());
            let err = (got - turns)
                .abs()
                .min(4_294_967_296.0 - (got - turns).abs());
            // The f64 reference itself carries ~x·10⁻¹⁶ turns of error.
            assert!(
                err <= 0.5 + f64::from(x).abs() * 1e-5,
                "{x}: {got} vs {turns}"
            );
        }
        assert_eq!(FineAngle::from_radians_f32(f32::NAN), None);
        assert_eq!(FineAngle::from_radians_f32(f32::INFINITY), None);
        assert_eq!(FineAngle::from_radians_f32(f32::NEG_INFINITY), None);
        assert_eq!(FineAngle::from_radians_f32(32_768.0), None);
        assert_eq!(FineAngle::from_radians_f32(-32_768.5), None);
        assert_eq!(FineAngle::from_radians_f32(f32::MAX), None);
    }

    #[test]
    fn wrapping_arithmetic() {
        let a = FineAngle::from_bits(0xF000_0000);
        let b = FineAngle::from_bits(0x2000_0000);
        assert_eq!(a.wrapping_add(b), FineAngle::from_bits(0x1000_0000));
        assert_eq!(b.wrapping_sub(a), FineAngle::from_bits(0x3000_0000));
        assert_eq!(FineAngle::QUARTER.reversed(), FineAngle::from_bits(3 << 30));
        assert_eq!(std::format!("{}", FineAngle::HALF), "180°");
    }
}
