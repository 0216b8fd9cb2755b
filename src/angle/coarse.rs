//! The actuator angle of an encoder or a host: [`Angle`], a fraction of a turn in Q0.16.
//!
//! An [`Angle`] is a fraction of a turn in `[0, 1)`, unsigned Q0.16 ([`U0F16`]): resolution
//! 2⁻¹⁶ turn ≈ 0.0055° ≈ 96 µrad, four times finer than a 14-bit encoder count, so a 14-bit
//! reading converts exactly. Angles wrap: arithmetic on them is modulo one turn, never
//! saturating and never panicking.
//!
//! The conversions for the rest of the pipeline are to radians as [`I16F16`] (the crate's
//! [`crate::units::Meters`] format), in `[0, 2π)` or `[−π, π)`, and to `f32` degrees for
//! display and logs.

use core::fmt;

use fixed::types::{I16F16, U0F16, U0F32, U32F32};

/// Counts per turn of a 14-bit absolute encoder: 2¹⁴ = 16 384 (≈ 0.022° per count).
pub const COUNTS_PER_TURN: u16 = 1 << 14;

/// The mask of a 14-bit count: `COUNTS_PER_TURN − 1` = `0x3FFF`.
pub const COUNT_MASK: u16 = COUNTS_PER_TURN - 1;

/// τ = 2π in unsigned Q32.32, truncated: 26 986 075 409 (relative error < 4·10⁻¹¹).
const TAU_Q32: u64 = U32F32::TAU.to_bits();

/// 1/τ = 1/(2π) in unsigned Q0.32, truncated: 683 565 275 (relative error < 9·10⁻¹⁰).
const FRAC_1_TAU_Q32: u32 = U0F32::FRAC_1_TAU.to_bits();

/// An angle as a fraction of a turn in `[0, 1)`, unsigned Q0.16.
///
/// Resolution 2⁻¹⁶ turn (≈ 0.0055°, ≈ 95.9 µrad); every value of the type is a valid angle,
/// and all arithmetic on it wraps modulo one turn. Zero is the mechanical zero of whatever
/// supplies it (for an encoder: after its [`EncoderMount`](crate::drivers::angle::EncoderMount)); angles grow in the direction the
/// source defines as positive (for the pan axis: counter-clockwise seen from above, by the
/// convention of the board's mounting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Angle(U0F16);

impl Angle {
    /// The zero angle.
    pub const ZERO: Self = Self(U0F16::ZERO);

    /// An angle from a fraction of a turn, unsigned Q0.16 in `[0, 1)`. Every value is valid.
    #[must_use]
    pub const fn from_turns(turns: U0F16) -> Self {
        Self(turns)
    }

    /// An angle from the raw bits of a Q0.16 fraction of a turn: `bits / 65 536` turn.
    #[must_use]
    pub const fn from_bits(bits: u16) -> Self {
        Self(U0F16::from_bits(bits))
    }

    /// An angle from a 14-bit encoder count, `count / 16 384` turn. Bits above the 14th are
    /// ignored (the count is taken modulo 2¹⁴); the conversion is exact.
    #[must_use]
    pub const fn from_counts14(count: u16) -> Self {
        Self::from_bits((count & COUNT_MASK) << 2)
    }

    /// An angle from radians in any range, reduced modulo 2π.
    ///
    /// Rounded to the nearest 2⁻¹⁶ turn; for |`radians`| below a few turns the result is the
    /// correctly rounded value, and over the whole range of [`I16F16`] (±32 768 rad) it stays
    /// within one 2⁻¹⁶ turn of it.
    #[must_use]
    pub fn from_radians(radians: I16F16) -> Self {
        // turns · 2¹⁶ = radians · 2¹⁶ / 2π = bits · (1/2π); with 1/2π in Q0.32:
        // |bits| ≤ 2³¹ and 1/2π < 2³⁰ in Q0.32, so the product fits an i64.
        let scaled = i64::from(radians.to_bits()) * i64::from(FRAC_1_TAU_Q32);
        let rounded = (scaled + (1_i64 << 31)) >> 32;
        // Modulo one turn: the low 16 bits of the two's-complement value.
        Self::from_bits((rounded & 0xFFFF) as u16)
    }

    /// The fraction of a turn, unsigned Q0.16 in `[0, 1)`.
    #[must_use]
    pub const fn to_turns(self) -> U0F16 {
        self.0
    }

    /// The raw bits of the Q0.16 fraction of a turn, `0 ..= 65 535`.
    #[must_use]
    pub const fn to_bits(self) -> u16 {
        self.0.to_bits()
    }

    /// The angle as a 14-bit count `0 ..= 16 383`, rounded to the nearest count (a value
    /// within half a count below a full turn rounds to 0).
    #[must_use]
    pub const fn to_counts14(self) -> u16 {
        // (bits + 2) / 4 can reach 16 384, which wraps to 0 under the mask.
        ((self.to_bits() as u32 + 2) >> 2) as u16 & COUNT_MASK
    }

    /// The angle in radians, `[0, 2π)`, signed Q16.16, rounded to the nearest 2⁻¹⁶ rad.
    #[must_use]
    pub fn to_radians(self) -> I16F16 {
        // bits · 2π in Q32 is < 2¹⁶ · 2³⁵; the rounded result is < 2π · 2¹⁶ < 2¹⁹.
        let scaled = u64::from(self.to_bits()) * TAU_Q32;
        let rounded = (scaled + (1_u64 << 31)) >> 32;
        I16F16::from_bits(rounded as i32)
    }

    /// The angle in radians, `[−π, π)`, signed Q16.16, rounded to the nearest 2⁻¹⁶ rad:
    /// turns at or past one half map to negative angles.
    #[must_use]
    pub fn to_radians_signed(self) -> I16F16 {
        // The bits read as a two's-complement i16 are the signed fraction of a turn.
        let signed_bits = i64::from(self.to_bits() as i16);
        // |signed_bits · 2π in Q32| < 2¹⁵ · 2³⁵; the result's magnitude is ≤ π · 2¹⁶.
        let scaled = signed_bits * TAU_Q32 as i64;
        let rounded = (scaled + (1_i64 << 31)) >> 32;
        I16F16::from_bits(rounded as i32)
    }

    /// The angle in degrees, `[0, 360)`, for display and logs. Exact: `bits · 45 / 8 192` needs
    /// at most 22 significant bits.
    #[must_use]
    pub fn to_degrees_f32(self) -> f32 {
        f32::from(self.to_bits()) * (360.0 / 65_536.0)
    }

    /// The sum of two angles, modulo one turn.
    #[must_use]
    pub const fn wrapping_add(self, other: Self) -> Self {
        Self::from_bits(self.to_bits().wrapping_add(other.to_bits()))
    }

    /// The difference `self − other`, modulo one turn (in `[0, 1)`; use
    /// [`Angle::to_radians_signed`] on the result for the shorter signed difference).
    #[must_use]
    pub const fn wrapping_sub(self, other: Self) -> Self {
        Self::from_bits(self.to_bits().wrapping_sub(other.to_bits()))
    }

    /// The angle measured in the opposite direction: `−self` modulo one turn.
    #[must_use]
    pub const fn reversed(self) -> Self {
        Self::from_bits(self.to_bits().wrapping_neg())
    }
}

impl fmt::Display for Angle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}°", self.to_degrees_f32())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Angle {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=f32}°", self.to_degrees_f32());
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use core::f64::consts::{PI, TAU};
    use std::format;

    /// Radians of a Q16.16 value, as f64.
    fn rad_f64(r: I16F16) -> f64 {
        f64::from(r.to_bits()) / 65_536.0
    }

    #[test]
    fn counts14_convert_exactly_and_round_trip() {
        for count in 0..COUNTS_PER_TURN {
            let a = Angle::from_counts14(count);
            assert_eq!(a.to_bits(), count * 4);
            assert_eq!(a.to_counts14(), count);
        }
        // Bits above the 14th are ignored.
        assert_eq!(Angle::from_counts14(0xC000 | 5), Angle::from_counts14(5));
        // Half a count below a full turn rounds to zero, not to 16 384.
        assert_eq!(Angle::from_bits(0xFFFE).to_counts14(), 0);
        assert_eq!(Angle::from_bits(0xFFFD).to_counts14(), COUNT_MASK);
    }

    #[test]
    fn radians_are_correctly_rounded_over_every_angle() {
        for bits in 0..=u16::MAX {
            let a = Angle::from_bits(bits);
            let exact = f64::from(bits) / 65_536.0 * TAU;
            let r = a.to_radians();
            assert!(r >= I16F16::ZERO && r < I16F16::TAU, "{bits}");
            assert!(
                (rad_f64(r) - exact).abs() <= 0.5 / 65_536.0 + 1e-12,
                "{bits}"
            );

            let signed = a.to_radians_signed();
            let exact_signed = if bits >= 0x8000 { exact - TAU } else { exact };
            assert!(
                rad_f64(signed) >= -PI - 1e-9 && rad_f64(signed) < PI,
                "{bits}"
            );
            assert!((rad_f64(signed) - exact_signed).abs() <= 0.5 / 65_536.0 + 1e-12);

            // And back: within one 2⁻¹⁶ turn (two radians LSBs are far below it).
            let back = Angle::from_radians(r);
            let diff = back.wrapping_sub(a).to_bits();
            assert!(diff <= 1 || diff == u16::MAX, "{bits}: {}", back.to_bits());
            assert_eq!(Angle::from_radians(signed), back);
        }
    }

    #[test]
    fn from_radians_wraps_any_value() {
        let quarter = Angle::from_bits(0x4000);
        let half_pi = I16F16::FRAC_PI_2;
        assert_eq!(Angle::from_radians(half_pi), quarter);
        assert_eq!(Angle::from_radians(-half_pi), Angle::from_bits(0xC000));
        // Whole turns away (I16F16::TAU is itself truncated, so within one 2⁻¹⁶ turn).
        for turns in [1, 3, -1, -5] {
            let a = Angle::from_radians(half_pi + I16F16::TAU * turns);
            let diff = a.wrapping_sub(quarter).to_bits();
            assert!(diff <= 1 || diff == u16::MAX, "{turns}: {}", a.to_bits());
        }
        // The extremes of the type do not overflow, and land within one LSB of the truth.
        for r in [
            I16F16::MIN,
            I16F16::MAX,
            I16F16::from_bits(-1),
            I16F16::ZERO,
        ] {
            let exact = (rad_f64(r) / TAU).rem_euclid(1.0) * 65_536.0;
            let got = f64::from(Angle::from_radians(r).to_bits());
            let err = (got - exact).abs();
            assert!(
                err <= 1.0 || (65_536.0 - err) <= 1.0,
                "{r}: {got} vs {exact}"
            );
        }
    }

    #[test]
    fn degrees_are_exact_and_display() {
        assert_eq!(Angle::ZERO.to_degrees_f32(), 0.0);
        assert_eq!(Angle::from_bits(0x4000).to_degrees_f32(), 90.0);
        assert_eq!(Angle::from_counts14(1).to_degrees_f32(), 360.0 / 16_384.0);
        assert_eq!(
            Angle::from_bits(u16::MAX).to_degrees_f32(),
            65_535.0 * 360.0 / 65_536.0
        );
        assert_eq!(format!("{}", Angle::from_bits(0x8000)), "180°");
    }

    #[test]
    fn angle_arithmetic_wraps() {
        let a = Angle::from_bits(0xF000);
        let b = Angle::from_bits(0x2000);
        assert_eq!(a.wrapping_add(b), Angle::from_bits(0x1000));
        assert_eq!(b.wrapping_sub(a), Angle::from_bits(0x3000));
        assert_eq!(b.reversed(), Angle::from_bits(0xE000));
        assert_eq!(Angle::ZERO.reversed(), Angle::ZERO);
    }
}
