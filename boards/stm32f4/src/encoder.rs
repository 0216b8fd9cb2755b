//! The pan encoder: the library's AS5047P driver on SPI1, with the device's minimum chip-select
//! high time between frames enforced here.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Error as _, ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_bus::spi::ExclusiveDevice;
use stm32f4xx_hal::gpio::{Output, Pin, PinState, Speed, PA5, PA6, PA7, PB6};
use stm32f4xx_hal::pac::SPI1;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::spi::Spi;
use terrain_pyramid::drivers::angle::EncoderMount;
use terrain_pyramid::drivers::as5047::{self, As5047};

use crate::clock::Clock;

/// The encoder's SPI clock: well below the AS5047P's 10 MHz, for jumper wires.
const ENCODER_SPI_HZ: u32 = 1_000_000;

/// The encoder on SPI1, with its chip select on PB6.
pub type Encoder =
    As5047<CsHighTime<ExclusiveDevice<Spi<SPI1>, Pin<'B', 6, Output>, Clock>, Clock>>;

/// The AS5047P on SPI1: PA5 (SCK), PA6 (MISO), PA7 (MOSI), chip select PB6; diagnostics
/// checked on every reading, the axis' zero at the encoder's.
pub fn connect(
    spi1: SPI1,
    (sck, miso, mosi, cs): (PA5, PA6, PA7, PB6),
    clock: Clock,
    rcc: &mut Rcc,
) -> Encoder {
    let spi = Spi::new(
        spi1,
        (
            Some(sck.into_alternate().speed(Speed::VeryHigh)),
            Some(miso.into_alternate().speed(Speed::VeryHigh)),
            Some(mosi.into_alternate().speed(Speed::VeryHigh)),
        ),
        as5047::MODE,
        ENCODER_SPI_HZ.Hz(),
        rcc,
    );
    let cs = cs.into_push_pull_output_in_state(PinState::High);
    let Ok(device) = ExclusiveDevice::new(spi, cs, clock);
    As5047::new(CsHighTime::new(device, clock), EncoderMount::IDENTITY).with_diagnostics_check(true)
}

/// The AS5047P's minimum CSn high time between frames, nanoseconds (datasheet: 350 ns).
pub const CS_HIGH_NS: u32 = 350;

/// An [`SpiDevice`] that waits `CS_HIGH_NS` after every transaction, so that back-to-back
/// frames (the driver's command + NOP pipeline) respect the device's CSn high time. Its errors
/// are the bus's [`ErrorKind`], which defmt can log.
/// `embedded-hal-bus`'s `ExclusiveDevice` raises CS and returns at once: at 180 MHz the next
/// transaction could lower it again about 100 ns later.
pub struct CsHighTime<D, T> {
    device: D,
    delay: T,
}

impl<D, T> CsHighTime<D, T> {
    /// Wraps `device`; `delay` waits out the CS high time.
    pub fn new(device: D, delay: T) -> Self {
        Self { device, delay }
    }
}

impl<D: ErrorType, T> ErrorType for CsHighTime<D, T> {
    type Error = ErrorKind;
}

impl<D: SpiDevice, T: DelayNs> SpiDevice for CsHighTime<D, T> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        let result = self.device.transaction(operations);
        self.delay.delay_ns(CS_HIGH_NS);
        result.map_err(|e| e.kind())
    }
}
