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

use heapless::spsc::Consumer;
use stm32f4xx_hal::pac::USART1;
use terrain_pyramid::app::CoProcessor;
use terrain_pyramid::drivers::angle::AngleSource;

use crate::clock::micros;
use crate::link::BlockingTx;
use crate::rx;
use crate::scanner::{FAST_BAUD, START_CONTINUOUS};

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

/// The laser's half of the main loop: USART1's transmit side, its receive queue, the laser
/// in force and the receive interrupt's drops seen so far.
pub struct LaserSide {
    tx: BlockingTx<USART1>,
    rx: Consumer<'static, u8>,
    /// USART1's clock, hertz, for the divider of the laser a Setup names.
    pclk2_hz: u32,
    /// The laser streaming now: the bring-up leaves a SICK at 500 kBd.
    streaming: LaserPort,
    dropped: u32,
}

impl LaserSide {
    /// The laser's side after the SICK bring-up: `tx` and `rx` are USART1's halves (the
    /// receive half already installed in its interrupt), `pclk2_hz` its clock.
    pub fn new(tx: BlockingTx<USART1>, rx: Consumer<'static, u8>, pclk2_hz: u32) -> Self {
        Self {
            tx,
            rx,
            pclk2_hz,
            streaming: LaserPort {
                sensor: Sensor::Sick,
                baud: FAST_BAUD,
            },
            dropped: 0,
        }
    }

    /// One main-loop step: switches to the laser the core names when it differs from the one
    /// streaming, hands the core what the interrupt queued (with its arrival time) and reports
    /// the interrupt's new drops as an overrun.
    pub fn step<const W: usize, const L: usize, const C: usize, const Q: usize>(
        &mut self,
        core: &mut CoProcessor<W, L, C, Q>,
        buf: &mut [u8],
        angle: &mut impl AngleSource,
    ) {
        if let Some(port) = core.take_laser_change().filter(|p| *p != self.streaming) {
            defmt::info!("laser: {} at {=u32} Bd", port.sensor, port.baud);
            if let Err(e) = switch(port, self.pclk2_hz, &mut self.tx) {
                defmt::warn!("USART1: {}", defmt::Debug2Format(&e));
            }
            self.streaming = port;
        }
        let n = rx::take(&mut self.rx, buf);
        if n > 0 {
            // The chunk's last byte arrived before the bytes still queued (at the line rate)
            // and the last byte the interrupt queued.
            let queued = u32::try_from(self.rx.len()).unwrap_or(u32::MAX);
            let byte_us = 10_000_000 / core.laser_baud().max(1);
            let arrival = rx::laser_last_us().wrapping_sub(queued.saturating_mul(byte_us));
            core.laser_timed(buf.get(..n).unwrap_or(&[]), arrival, micros(), angle);
        }
        let lost = rx::laser_stats().dropped;
        if lost != self.dropped {
            self.dropped = lost;
            core.laser_overrun();
        }
    }
}
