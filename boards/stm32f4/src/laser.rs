//! The laser the host's Setup names, at run time: USART1 set to its baud rate and its stream
//! started; and the nodding servo on TIM2's channel 1 (PA0).
//!
//! When the core reports a change ([`terrain_pyramid::app::CoProcessor::take_laser_change`]:
//! once at boot, then after each Setup that changes the sensor or its rate), [`switch`] sets
//! USART1's divider ([`crate::hw::set_usart1_baud`]; the receive interrupt and its queue
//! stay as they are) and sends what starts the sensor's stream on USART1's TX:
//!
//! | sensor | start |
//! | --- | --- |
//! | SICK LMS2xx | "continuous output" (`02 00 02 00 20 24 34 08`; the 500 kBd switch is the boot bring-up's) |
//! | LD06 / LD19 | nothing: it streams once powered |
//! | RPLIDAR | STOP, then SCAN (`A5 20`) or EXPRESS_SCAN (`A5 82 05 …`) by the Setup's mode |
//! | YDLIDAR X4 | STOP (`A5 65`), then SCAN (`A5 60`) (an X2 streams once powered and ignores both) |

use embedded_io::Write;
use stm32f4xx_hal::gpio::PA0;
use stm32f4xx_hal::pac::TIM2;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::timer::{PwmChannel, PwmExt};
use terrain_pyramid::app::LaserPort;
use terrain_pyramid::drivers::lidar::send;
use terrain_pyramid::drivers::servo::{Servo, ServoCalibration};
use terrain_pyramid::laser::Sensor;
use terrain_pyramid::wire::rplidar::{RplidarRequest, RplidarScanMode};
use terrain_pyramid::wire::ydlidar::YdlidarCommand;

use crate::scanner::START_CONTINUOUS;

/// The servo's PWM: TIM2 channel 1 on PA0.
pub type ServoPwm = PwmChannel<TIM2, 0>;

/// The servo's PWM period: 20 ms (50 Hz), TIM2 counting microseconds.
pub const SERVO_PERIOD_US: u32 = 20_000;

/// The servo as mounted: −90° at 1 000 µs, +90° at 2 000 µs (measure the servo's own ends and
/// the sign of its turn on the tilt axis before trusting it: a positive tilt looks down).
pub const SERVO_CALIBRATION: ServoCalibration = ServoCalibration::STANDARD;

/// TIM2 as a 50 Hz PWM on PA0 (Arduino A0, CN8), the servo's signal: a 1 MHz count, so the
/// duty cycle's maximum is 20 000 and a duty step is 1 µs of pulse.
pub fn servo(tim2: TIM2, pa0: PA0, rcc: &mut Rcc) -> Servo<ServoPwm> {
    let (_manager, (ch1, ..)) = tim2.pwm_us(SERVO_PERIOD_US.micros(), rcc);
    let mut ch1 = ch1.with(pa0);
    ch1.enable();
    Servo::new(ch1, SERVO_CALIBRATION)
}

/// Sets USART1 up for `port` and starts the sensor's stream; `pclk2_hz` is USART1's clock.
pub fn switch<W: Write>(port: LaserPort, pclk2_hz: u32, tx: &mut W) -> Result<(), W::Error> {
    crate::hw::set_usart1_baud(pclk2_hz, port.baud);
    match port.sensor {
        Sensor::Sick => {
            tx.write_all(&START_CONTINUOUS)?;
            tx.flush()
        }
        Sensor::Ld06 => Ok(()),
        Sensor::Rplidar(mode) => {
            send(tx, &RplidarRequest::Stop)?;
            // The RPLIDAR wants 1 ms after STOP before the next request.
            cortex_m::asm::delay(pclk2_hz / 500);
            match mode {
                RplidarScanMode::Standard => send(tx, &RplidarRequest::Scan),
                RplidarScanMode::Express => send(tx, &RplidarRequest::EXPRESS_SCAN),
            }
        }
        Sensor::Ydlidar(_) => {
            send(tx, &YdlidarCommand::Stop)?;
            cortex_m::asm::delay(pclk2_hz / 500);
            send(tx, &YdlidarCommand::Scan)
        }
    }
}
