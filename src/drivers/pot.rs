//! A potentiometer on the actuator's axis, read through an ADC: the servo's feedback when it
//! has no encoder. Most hobby servos carry one; its wiper, brought out to an ADC input, gives
//! the axis' real angle, lag and all.
//!
//! embedded-hal 1.0 has no ADC trait, so this module defines the one it needs,
//! [`AdcChannel`]: one conversion of one channel, its raw value. A board implements it over
//! its HAL's one-shot conversion. [`Potentiometer`] maps the raw value linearly through two
//! calibration points to an [`Angle`] and refuses a reading beyond the calibrated range by
//! more than a sixteenth of it (a broken wiper or supply reads 0 or full scale).

use core::fmt;

use super::angle::AngleSource;
use crate::angle::{Angle, FineAngle};

/// One channel of an analog-to-digital converter, read one conversion at a time.
pub trait AdcChannel {
    /// Why a conversion failed.
    type Error: fmt::Debug;

    /// Converts once and returns the raw value (right-aligned, `0 ..= 2^bits − 1`).
    ///
    /// # Errors
    /// The converter's error.
    fn read_raw(&mut self) -> Result<u16, Self::Error>;
}

impl<T: AdcChannel + ?Sized> AdcChannel for &mut T {
    type Error = T::Error;

    fn read_raw(&mut self) -> Result<u16, Self::Error> {
        T::read_raw(self)
    }
}

/// Two points of a potentiometer's raw-to-angle line, measured on the axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PotCalibration {
    /// The raw value at `angle_a`.
    pub raw_a: u16,
    /// An angle of the axis (read as signed, ±180°).
    pub angle_a: FineAngle,
    /// The raw value at `angle_b` (not `raw_a`).
    pub raw_b: u16,
    /// Another angle of the axis.
    pub angle_b: FineAngle,
}

/// Why a potentiometer reading was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PotError<E> {
    /// The converter failed.
    Adc(E),
    /// The raw value lies beyond the calibrated range by more than a sixteenth of it.
    OutOfRange {
        /// The raw value read.
        raw: u16,
    },
    /// The calibration's two raw values are equal.
    BadCalibration,
}

impl<E: fmt::Debug> fmt::Display for PotError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Adc(e) => write!(f, "potentiometer ADC error: {e:?}"),
            Self::OutOfRange { raw } => {
                write!(f, "potentiometer reads {raw}, beyond its calibrated range")
            }
            Self::BadCalibration => f.write_str("potentiometer calibration has one raw value"),
        }
    }
}

/// A potentiometer on the axis as an [`AngleSource`].
#[derive(Debug)]
pub struct Potentiometer<A> {
    adc: A,
    calibration: PotCalibration,
}

impl<A: AdcChannel> Potentiometer<A> {
    /// A potentiometer read through `adc`.
    pub const fn new(adc: A, calibration: PotCalibration) -> Self {
        Self { adc, calibration }
    }

    /// The angle of a raw value, or why it is refused.
    ///
    /// # Errors
    /// [`PotError::OutOfRange`] or [`PotError::BadCalibration`].
    pub fn angle_of(&self, raw: u16) -> Result<FineAngle, PotError<A::Error>> {
        let c = &self.calibration;
        let (ra, rb) = (i64::from(c.raw_a), i64::from(c.raw_b));
        if ra == rb {
            return Err(PotError::BadCalibration);
        }
        let margin = (ra - rb).abs() / 16;
        let r = i64::from(raw);
        if r < ra.min(rb) - margin || r > ra.max(rb) + margin {
            return Err(PotError::OutOfRange { raw });
        }
        #[allow(clippy::cast_possible_wrap)]
        let signed = |a: FineAngle| i64::from(a.to_bits() as i32);
        let (aa, ab) = (signed(c.angle_a), signed(c.angle_b));
        // |r − ra| < 2¹⁷ and |ab − aa| < 2³²: the product is below 2⁴⁹.
        let num = (r - ra) * (ab - aa);
        let den = rb - ra;
        let (num, den) = if den < 0 { (-num, -den) } else { (num, den) };
        let offset = (2 * num + den).div_euclid(2 * den);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Ok(FineAngle::from_bits((aa + offset) as u32))
    }

    /// Gives the converter back.
    pub fn release(self) -> A {
        self.adc
    }
}

impl<A: AdcChannel> AngleSource for Potentiometer<A> {
    type Error = PotError<A::Error>;

    /// Converts once and maps the value: the angle rounded to the [`Angle`]'s 2⁻¹⁶ turn.
    fn read_angle(&mut self) -> Result<Angle, Self::Error> {
        let raw = self.adc.read_raw().map_err(PotError::Adc)?;
        let fine = self.angle_of(raw)?;
        // Rounded to Q0.16 (wrapping like the angle).
        #[allow(clippy::cast_possible_truncation)]
        let bits = (fine.to_bits().wrapping_add(1 << 15) >> 16) as u16;
        Ok(Angle::from_bits(bits))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Adc(Result<u16, ()>);

    impl AdcChannel for Adc {
        type Error = ();
        fn read_raw(&mut self) -> Result<u16, ()> {
            self.0
        }
    }

    fn deg(d: f64) -> FineAngle {
        FineAngle::from_bits((d / 360.0 * 4_294_967_296.0).round() as i64 as u32)
    }

    #[test]
    fn raw_values_become_angles() {
        // A 12-bit ADC: −45° at 1 000, +45° at 3 000.
        let cal = PotCalibration {
            raw_a: 1_000,
            angle_a: deg(-45.0),
            raw_b: 3_000,
            angle_b: deg(45.0),
        };
        let pot = Potentiometer::new(Adc(Ok(2_000)), cal);
        assert_eq!(pot.angle_of(2_000), Ok(deg(0.0)));
        assert_eq!(pot.angle_of(1_000), Ok(deg(-45.0)));
        assert_eq!(pot.angle_of(2_500), Ok(deg(22.5)));
        // A sixteenth of the span beyond either end is allowed, more is refused.
        assert!(pot.angle_of(875).is_ok());
        assert_eq!(pot.angle_of(874), Err(PotError::OutOfRange { raw: 874 }));
        assert_eq!(
            pot.angle_of(4_095),
            Err(PotError::OutOfRange { raw: 4_095 })
        );
        let mut pot = pot;
        assert_eq!(pot.read_angle(), Ok(Angle::ZERO));
        let mut pot = Potentiometer::new(Adc(Ok(2_500)), cal);
        assert_eq!(pot.read_angle(), Ok(Angle::from_bits(0x1000)));
        let mut pot = Potentiometer::new(Adc(Err(())), cal);
        assert_eq!(pot.read_angle(), Err(PotError::Adc(())));
        let flat = PotCalibration {
            raw_b: 1_000,
            ..cal
        };
        assert_eq!(
            Potentiometer::new(Adc(Ok(1)), flat).angle_of(1),
            Err(PotError::BadCalibration)
        );
        // Reversed wiring: the angle falls as the value rises.
        let reversed = PotCalibration {
            angle_a: deg(45.0),
            angle_b: deg(-45.0),
            ..cal
        };
        let pot = Potentiometer::new(Adc(Ok(0)), reversed);
        assert_eq!(pot.angle_of(2_500), Ok(deg(-22.5)));
        assert_eq!(pot.release().0, Ok(0));
    }
}
