//! Sources of the actuator (pan or tilt) angle: the [`AngleSource`] trait that supplies it, the
//! mounting of an encoder ([`EncoderMount`]), and [`HostSuppliedAngle`] for boards that get
//! the angle over the host link instead of from an encoder. The angle type itself,
//! [`Angle`], lives in [`crate::angle`].

use core::fmt;

use crate::angle::{Angle, COUNT_MASK};

/// Something that supplies the current pan angle (defined in [`crate::angle`], where the
/// co-processor, which takes any source, can name it from below the drivers).
pub use crate::angle::AngleSource;

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
    use crate::angle::COUNTS_PER_TURN;
    extern crate std;
    use super::*;
    use std::format;

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
