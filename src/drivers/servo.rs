//! A hobby servo (or any position-commanded actuator) on one PWM channel, through
//! embedded-hal's [`SetDutyCycle`]: an angle in, a pulse width out.
//!
//! A servo reads the width of a pulse repeated every period (classically 20 ms, 50 Hz):
//! 1 000 µs at one end of its travel, 2 000 µs at the other for most, 500 ..= 2 500 µs for
//! wide-travel ones. [`ServoCalibration`] holds two (angle, pulse) points of the servo as
//! mounted (measured on the axis: the angle the geometry uses, [`crate::geometry::ScanPlane`])
//! and the PWM's period; [`Servo::set_angle`] maps an angle linearly between them, clamped to
//! the calibrated range, and sets the duty cycle `pulse / period · max_duty`, rounded. One
//! 64-bit division per command; the core ([`crate::app::CoProcessor::actuator_command`])
//! gives the angle, the board calls this every main-loop step.

use core::fmt;

use embedded_hal::pwm::SetDutyCycle;

use crate::angle::FineAngle;

/// Two points of a servo's angle-to-pulse line and its PWM period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoCalibration {
    /// The PWM period, µs (20 000 for 50 Hz); 1 ..= 65 535.
    pub period_us: u32,
    /// One end: an angle (read as signed, ±180°) …
    pub angle_a: FineAngle,
    /// … and its pulse width, µs.
    pub pulse_a_us: u32,
    /// The other end: an angle (not `angle_a`) …
    pub angle_b: FineAngle,
    /// … and its pulse width, µs.
    pub pulse_b_us: u32,
}

impl ServoCalibration {
    /// A standard servo at 50 Hz: −90° at 1 000 µs, +90° at 2 000 µs (check the servo's own
    /// figures, and the sign of its turn as mounted, before trusting it).
    pub const STANDARD: Self = Self {
        period_us: 20_000,
        angle_a: FineAngle::from_bits(3 << 30),
        pulse_a_us: 1_000,
        angle_b: FineAngle::QUARTER,
        pulse_b_us: 2_000,
    };

    /// The pulse width for `angle`, µs: linear between the two points, `angle` clamped to
    /// the range between them; `pulse_a_us` when the two angles coincide.
    #[must_use]
    pub fn pulse_us(&self, angle: FineAngle) -> u32 {
        #[allow(clippy::cast_possible_wrap)]
        let signed = |a: FineAngle| i64::from(a.to_bits() as i32);
        let (a, b, x) = (signed(self.angle_a), signed(self.angle_b), signed(angle));
        if a == b {
            return self.pulse_a_us;
        }
        let x = x.clamp(a.min(b), a.max(b));
        let (pa, pb) = (i128::from(self.pulse_a_us), i128::from(self.pulse_b_us));
        // |x − a| < 2³², |pb − pa| < 2³²: the product needs up to 65 bits.
        let num = i128::from(x - a) * (pb - pa);
        let den = i128::from(b - a);
        // Rounded to nearest (the sign of den is folded in).
        let (num, den) = if den < 0 { (-num, -den) } else { (num, den) };
        let offset = (2 * num + den).div_euclid(2 * den);
        u32::try_from(pa + offset).unwrap_or(0)
    }
}

/// Why a servo command failed: the PWM's own error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoError<E>(pub E);

impl<E: fmt::Debug> fmt::Display for ServoError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "servo PWM error: {:?}", self.0)
    }
}

/// A servo on a PWM channel.
#[derive(Debug)]
pub struct Servo<P> {
    pwm: P,
    calibration: ServoCalibration,
}

impl<P: SetDutyCycle> Servo<P> {
    /// A servo on `pwm` (its period already set to `calibration.period_us`).
    pub const fn new(pwm: P, calibration: ServoCalibration) -> Self {
        Self { pwm, calibration }
    }

    /// The calibration.
    pub const fn calibration(&self) -> &ServoCalibration {
        &self.calibration
    }

    /// The duty cycle that gives the pulse of `angle`, out of the channel's maximum:
    /// `pulse / period · max`, rounded, at most `max`.
    pub fn duty_for(&self, angle: FineAngle) -> u16 {
        let max = u64::from(self.pwm.max_duty_cycle());
        let period = u64::from(self.calibration.period_us.max(1));
        let pulse = u64::from(self.calibration.pulse_us(angle)).min(period);
        let duty = (pulse * max + period / 2) / period;
        u16::try_from(duty.min(max)).unwrap_or(u16::MAX)
    }

    /// Commands `angle` (clamped to the calibrated range).
    ///
    /// # Errors
    /// The PWM's error.
    pub fn set_angle(&mut self, angle: FineAngle) -> Result<(), ServoError<P::Error>> {
        let duty = self.duty_for(angle);
        self.pwm.set_duty_cycle(duty).map_err(ServoError)
    }

    /// Gives the PWM channel back.
    pub fn release(self) -> P {
        self.pwm
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use embedded_hal::pwm::{ErrorKind, ErrorType};
    use std::vec::Vec;

    /// A PWM channel that records its duties (a 16-bit timer at 50 Hz: max 60 000).
    struct Pwm {
        max: u16,
        duties: Vec<u16>,
        fail: bool,
    }

    impl ErrorType for Pwm {
        type Error = ErrorKind;
    }

    impl SetDutyCycle for Pwm {
        fn max_duty_cycle(&self) -> u16 {
            self.max
        }
        fn set_duty_cycle(&mut self, duty: u16) -> Result<(), ErrorKind> {
            if self.fail {
                return Err(ErrorKind::Other);
            }
            self.duties.push(duty);
            Ok(())
        }
    }

    fn deg(d: f64) -> FineAngle {
        FineAngle::from_bits((d / 360.0 * 4_294_967_296.0).round() as i64 as u32)
    }

    #[test]
    fn angles_become_pulses_and_duties() {
        let cal = ServoCalibration::STANDARD;
        assert_eq!(cal.pulse_us(deg(-90.0)), 1_000);
        assert_eq!(cal.pulse_us(deg(0.0)), 1_500);
        assert_eq!(cal.pulse_us(deg(90.0)), 2_000);
        assert_eq!(cal.pulse_us(deg(45.0)), 1_750);
        assert_eq!(cal.pulse_us(deg(-30.0)), 1_333);
        // Clamped to the calibrated range.
        assert_eq!(cal.pulse_us(deg(120.0)), 2_000);
        assert_eq!(cal.pulse_us(deg(-179.0)), 1_000);
        // A servo mounted the other way round: the line falls.
        let reversed = ServoCalibration {
            pulse_a_us: 2_000,
            pulse_b_us: 1_000,
            ..cal
        };
        assert_eq!(reversed.pulse_us(deg(30.0)), 1_333);
        let degenerate = ServoCalibration {
            angle_b: cal.angle_a,
            ..cal
        };
        assert_eq!(degenerate.pulse_us(deg(10.0)), 1_000);

        let mut servo = Servo::new(
            Pwm {
                max: 60_000,
                duties: Vec::new(),
                fail: false,
            },
            cal,
        );
        servo.set_angle(deg(0.0)).unwrap();
        servo.set_angle(deg(90.0)).unwrap();
        servo.set_angle(deg(-45.0)).unwrap();
        assert_eq!(servo.duty_for(deg(-90.0)), 3_000);
        let pwm = servo.release();
        // 1 500 µs of 20 000 is 7.5 % of 60 000.
        assert_eq!(pwm.duties, [4_500, 6_000, 3_750]);
        let mut failing = Servo::new(
            Pwm {
                max: 100,
                duties: Vec::new(),
                fail: true,
            },
            cal,
        );
        assert_eq!(
            failing.set_angle(deg(0.0)),
            Err(ServoError(ErrorKind::Other))
        );
        assert_eq!(failing.duty_for(deg(0.0)), 8);
    }

    #[test]
    fn any_calibration_and_angle_is_safe() {
        let mut bits = 0x1234_5678_u32;
        for _ in 0..20_000 {
            bits ^= bits << 13;
            bits ^= bits >> 17;
            bits ^= bits << 5;
            let cal = ServoCalibration {
                period_us: bits >> 16,
                angle_a: FineAngle::from_bits(bits),
                pulse_a_us: bits.rotate_left(7),
                angle_b: FineAngle::from_bits(bits.rotate_left(11)),
                pulse_b_us: bits.rotate_left(3),
            };
            let servo = Servo::new(
                Pwm {
                    max: (bits >> 8) as u16,
                    duties: Vec::new(),
                    fail: false,
                },
                cal,
            );
            let d = servo.duty_for(FineAngle::from_bits(bits.rotate_left(17)));
            assert!(d <= servo.pwm.max);
        }
    }
}
