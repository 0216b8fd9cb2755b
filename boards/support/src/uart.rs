//! A polled UART's error and its blocking `read`: the part of `embedded_io::Read` that does
//! not depend on the peripheral. The registers stay in each board's `uart` module, which
//! implements [`PolledRx`] for its UART, [`impl_polled_read!`] the `embedded_io` traits on
//! top, and claims its registers once with [`claim_once`].

use core::sync::atomic::{AtomicBool, Ordering};

/// What a UART can report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum UartError {
    /// A received byte was lost: it arrived while the receive buffer (the CMSDK UART's one
    /// byte, the nRF51's six-byte FIFO) was full.
    Overrun,
}

impl embedded_io::Error for UartError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// A receiver read by polling.
pub trait PolledRx {
    /// Checks and clears the receiver's overrun flag: whether a byte was lost since the last
    /// call.
    fn take_overrun(&mut self) -> bool;
    /// Takes the received byte if there is one.
    fn try_read_byte(&mut self) -> Option<u8>;
    /// Whether a received byte is waiting (a read would not block).
    fn rx_ready(&mut self) -> bool;
}

/// Whether this is the first claim of what `taken` guards (a UART's registers): `true` once,
/// `false` on every later call. The load and the store happen inside a critical section:
/// ARMv6-M has no compare-and-swap.
pub fn claim_once(taken: &AtomicBool) -> bool {
    cortex_m::interrupt::free(|_| {
        let was_taken = taken.load(Ordering::Relaxed);
        taken.store(true, Ordering::Relaxed);
        !was_taken
    })
}

/// Implements `embedded_io`'s `ErrorType` ([`UartError`]), `ReadReady`
/// ([`PolledRx::rx_ready`]) and `Read` ([`read_polled`]) for a board's UART type that
/// implements [`PolledRx`]: `impl_polled_read!([] Uart)`, or with its generic parameters in
/// the brackets, `impl_polled_read!([const BASE: usize] CmsdkUart<BASE>)`. The board crate
/// depends on `embedded-io` 0.6.
#[macro_export]
macro_rules! impl_polled_read {
    ([$($generics:tt)*] $uart:ty) => {
        impl<$($generics)*> embedded_io::ErrorType for $uart {
            type Error = $crate::uart::UartError;
        }

        impl<$($generics)*> embedded_io::ReadReady for $uart {
            fn read_ready(&mut self) -> Result<bool, Self::Error> {
                Ok($crate::uart::PolledRx::rx_ready(self))
            }
        }

        impl<$($generics)*> embedded_io::Read for $uart {
            /// Blocks until at least one byte is available (unless `buf` is empty), then
            /// returns the bytes available without waiting further.
            fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
                $crate::uart::read_polled(self, buf)
            }
        }
    };
}

/// `embedded_io::Read::read` of a polled receiver: blocks until at least one byte is
/// available (unless `buf` is empty), then returns the bytes available without waiting
/// further. A lost byte is reported once, as [`UartError::Overrun`], before any byte is read.
///
/// Out of line: one copy per UART type rather than one per call site (the qemu-mps2 image
/// is 440 bytes smaller for it than when both UARTs inlined their own).
///
/// # Errors
/// [`UartError::Overrun`] when a byte was lost since the last call.
#[inline(never)]
pub fn read_polled(rx: &mut impl PolledRx, buf: &mut [u8]) -> Result<usize, UartError> {
    if buf.is_empty() {
        return Ok(0);
    }
    if rx.take_overrun() {
        return Err(UartError::Overrun);
    }
    let mut n = 0;
    for slot in buf.iter_mut() {
        let byte = if n == 0 {
            loop {
                if let Some(b) = rx.try_read_byte() {
                    break b;
                }
            }
        } else {
            match rx.try_read_byte() {
                Some(b) => b,
                None => break,
            }
        };
        *slot = byte;
        n += 1;
    }
    Ok(n)
}
