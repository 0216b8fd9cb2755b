//! The host link's transmit side as a blocking `embedded-io` writer.
//!
//! stm32f4xx-hal 0.23 implements `embedded_io::Write` for `Tx` by returning `Ok(0)` when the
//! data register is busy, which embedded-io 0.6 forbids (`write_all` panics on `Ok(0)`). This
//! adapter blocks until the first byte is taken instead, as embedded-io specifies, so the
//! library's link writer can use USART2 directly.

use embedded_hal_nb::serial::Write as NbWrite;
use stm32f4xx_hal::serial::{Error, Instance, Tx};

/// A USART transmitter that blocks per embedded-io's contract.
pub struct BlockingTx<U: Instance> {
    tx: Tx<U>,
}

impl<U: Instance> BlockingTx<U> {
    /// Wraps a transmitter.
    pub fn new(tx: Tx<U>) -> Self {
        Self { tx }
    }
}

impl<U: Instance> embedded_io::ErrorType for BlockingTx<U> {
    type Error = Error;
}

impl<U: Instance> embedded_io::Write for BlockingTx<U> {
    /// Blocks until the first byte is taken, then sends what the USART takes without waiting.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Error> {
        let mut sent = 0;
        for &byte in buf {
            match NbWrite::write(&mut self.tx, byte) {
                Ok(()) => sent += 1,
                Err(nb::Error::WouldBlock) if sent > 0 => break,
                Err(nb::Error::WouldBlock) => {
                    nb::block!(NbWrite::write(&mut self.tx, byte))?;
                    sent += 1;
                }
                Err(nb::Error::Other(e)) => return Err(e),
            }
        }
        Ok(sent)
    }

    fn flush(&mut self) -> Result<(), Error> {
        nb::block!(NbWrite::flush(&mut self.tx))
    }
}
