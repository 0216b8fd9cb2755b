//! The pan encoder: the library's AS5047P driver on SPI1, with the device's minimum chip-select
//! high time between frames enforced here.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Error as _, ErrorKind, ErrorType, Operation, SpiDevice};

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
