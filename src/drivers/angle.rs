//! The pan angle: its fixed-point type, the [`AngleSource`] trait that supplies it, the
//! mounting of an encoder ([`EncoderMount`]), and [`HostSuppliedAngle`] for boards that get
//! the angle over the host link instead of from an encoder.
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
/// supplies it (for an encoder: after its [`EncoderMount`]); angles grow in the direction the
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

/// Something that supplies the current pan angle: an encoder driver, the host link, a test.
///
/// A reading is the angle at the time of the call; the source never blocks longer than one
/// bus transaction and never panics. Errors are the source's own (bus, protocol, staleness).
pub trait AngleSource {
    /// Why a reading failed.
    type Error: fmt::Debug;

    /// Reads the current angle, with any mounting already applied.
    ///
    /// # Errors
    /// The source's error when no trustworthy angle is available; the caller should drop
    /// or hold the scan line rather than use a stale or corrupt angle.
    fn read_angle(&mut self) -> Result<Angle, Self::Error>;
}

impl<T: AngleSource + ?Sized> AngleSource for &mut T {
    type Error = T::Error;

    fn read_angle(&mut self) -> Result<Angle, Self::Error> {
        T::read_angle(self)
    }
}

/// How an absolute 14-bit encoder is mounted on its axis: where its zero is and which way it
/// counts.
///
/// [`EncoderMount::apply`] maps a raw count to the axis angle as
/// `(raw − zero_offset_counts) mod 2¹⁴`, negated modulo 2¹⁴ when `reversed`. Everything wraps
/// modulo 2¹⁴; nothing saturates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EncoderMount {
    /// The raw count the encoder reads at the axis' mechanical zero, `0 ..= 16 383`; bits above
    /// the 14th are ignored (the value is taken modulo 2¹⁴). Default 0.
    pub zero_offset_counts: u16,
    /// `true` when the encoder counts up in the axis' negative direction (e.g. the magnet is
    /// read from the other side of the shaft). Default `false`.
    pub reversed: bool,
}

impl EncoderMount {
    /// The identity mounting: zero at raw count 0, counting in the axis' positive direction.
    pub const IDENTITY: Self = Self::new(0, false);

    /// A mounting with its zero at raw count `zero_offset_counts` (taken modulo 2¹⁴) and the
    /// given direction.
    #[must_use]
    pub const fn new(zero_offset_counts: u16, reversed: bool) -> Self {
        Self {
            zero_offset_counts,
            reversed,
        }
    }

    /// The axis angle, as a 14-bit count `0 ..= 16 383`, of a raw encoder count (bits above
    /// the 14th ignored): `(raw − zero) mod 2¹⁴`, negated modulo 2¹⁴ when reversed.
    #[must_use]
    pub const fn apply(self, raw_count: u16) -> u16 {
        let relative = raw_count.wrapping_sub(self.zero_offset_counts);
        let directed = if self.reversed {
            relative.wrapping_neg()
        } else {
            relative
        };
        // 2¹⁴ divides 2¹⁶, so wrapping in u16 and masking is arithmetic modulo 2¹⁴.
        directed & COUNT_MASK
    }

    /// The axis [`Angle`] of a raw encoder count: [`EncoderMount::apply`], then
    /// [`Angle::from_counts14`].
    #[must_use]
    pub const fn angle(self, raw_count: u16) -> Angle {
        Angle::from_counts14(self.apply(raw_count))
    }
}

/// Why [`HostSuppliedAngle`] refused a reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum HostAngleError {
    /// No angle has been set since creation or since the last [`HostSuppliedAngle::clear`].
    NotSet,
}

impl fmt::Display for HostAngleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotSet => f.write_str("no pan angle received from the host yet"),
        }
    }
}

impl core::error::Error for HostAngleError {}

/// The pan angle as the host supplies it over the link, for boards with no encoder.
///
/// The link handler calls [`HostSuppliedAngle::set`] with each angle it receives; readings
/// return the latest one. Until the first `set`, and after [`HostSuppliedAngle::clear`] (call
/// it when the link is lost or the host declares the angle invalid), readings are refused
/// with [`HostAngleError::NotSet`], so no scan line is ever placed with an angle nobody gave.
/// Time-based staleness belongs to the caller, who holds the clock: it calls `clear` when
/// the last `set` is too old.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HostSuppliedAngle {
    latest: Option<Angle>,
}

impl HostSuppliedAngle {
    /// A source with no angle yet: readings fail until [`HostSuppliedAngle::set`].
    #[must_use]
    pub const fn new() -> Self {
        Self { latest: None }
    }

    /// Records the angle the host sent; it is returned by every reading until the next `set`
    /// or [`HostSuppliedAngle::clear`].
    pub fn set(&mut self, angle: Angle) {
        self.latest = Some(angle);
    }

    /// Forgets the angle: readings fail with [`HostAngleError::NotSet`] until the next `set`.
    pub fn clear(&mut self) {
        self.latest = None;
    }

    /// The latest angle set, if any, without the error of a reading.
    #[must_use]
    pub const fn get(&self) -> Option<Angle> {
        self.latest
    }
}

impl AngleSource for HostSuppliedAngle {
    type Error = HostAngleError;

    fn read_angle(&mut self) -> Result<Angle, Self::Error> {
        self.latest.ok_or(HostAngleError::NotSet)
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

    #[test]
    fn mount_offset_and_reversal_wrap_modulo_2_14() {
        let id = EncoderMount::IDENTITY;
        assert_eq!(id, EncoderMount::default());
        assert_eq!(id.apply(1234), 1234);
        assert_eq!(id.apply(0xFFFF), COUNT_MASK);

        let offset = EncoderMount::new(16_000, false);
        assert_eq!(offset.apply(16_000), 0);
        assert_eq!(offset.apply(16_383), 383);
        assert_eq!(offset.apply(100), 100 + 16_384 - 16_000);

        let reversed = EncoderMount::new(0, true);
        assert_eq!(reversed.apply(0), 0);
        assert_eq!(reversed.apply(1), COUNT_MASK);
        assert_eq!(reversed.apply(8_192), 8_192);

        let both = EncoderMount::new(100, true);
        assert_eq!(both.apply(100), 0);
        assert_eq!(both.apply(99), 1);
        assert_eq!(both.apply(101), COUNT_MASK);
        assert_eq!(both.apply(0), 100);

        // An offset beyond 14 bits is taken modulo 2¹⁴.
        assert_eq!(EncoderMount::new(16_384 + 10, false).apply(10), 0);

        // The mapping agrees with plain modular arithmetic on every count and a few mounts.
        for zero in [0_u16, 1, 8_191, 16_383, 40_000] {
            for reversed in [false, true] {
                let m = EncoderMount::new(zero, reversed);
                for raw in (0..COUNTS_PER_TURN).step_by(7) {
                    let rel = (i32::from(raw) - i32::from(zero)).rem_euclid(16_384);
                    let want = if reversed {
                        (-rel).rem_euclid(16_384)
                    } else {
                        rel
                    };
                    assert_eq!(i32::from(m.apply(raw)), want);
                    assert_eq!(m.angle(raw), Angle::from_counts14(m.apply(raw)));
                }
            }
        }
    }

    #[test]
    fn host_supplied_angle_refuses_until_set() {
        let mut host = HostSuppliedAngle::new();
        assert_eq!(host.read_angle(), Err(HostAngleError::NotSet));
        assert_eq!(host.get(), None);

        let a = Angle::from_bits(0x1234);
        host.set(a);
        assert_eq!(host.read_angle(), Ok(a));
        assert_eq!(host.read_angle(), Ok(a));
        // Through the blanket impl for `&mut T`.
        fn read_by_value<S: AngleSource>(mut source: S) -> Result<Angle, S::Error> {
            source.read_angle()
        }
        assert_eq!(read_by_value(&mut host), Ok(a));

        host.clear();
        assert_eq!(host.read_angle(), Err(HostAngleError::NotSet));
        assert_eq!(
            format!("{}", HostAngleError::NotSet),
            "no pan angle received from the host yet"
        );
    }
}
