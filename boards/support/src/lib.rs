//! What the board crates share (`boards/microbit`, `boards/qemu-mps2`, `boards/stm32f4`):
//!
//! - [`stack`]: the stack's high-water mark, from the words `cortex-m-rt`'s `paint-stack`
//!   painted (the board enables that feature);
//! - [`uart`]: the error of a polled UART, the blocking `read` every board's UART
//!   implements `embedded_io::Read` with ([`impl_polled_read!`] writes the `embedded_io`
//!   read traits), and [`uart::claim_once`], the one-time claim of a UART's registers (each
//!   board's registers stay in its own `uart` module);
//! - [`runtime`] (feature `semihosting`, a run under QEMU): defmt over semihosting, the panic
//!   handlers, and [`runtime::exit`] with the exit codes a test harness reads. A board's
//!   HardFault handler calls [`runtime::hard_fault`].
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(feature = "semihosting")]
pub mod runtime;
#[allow(unsafe_code)]
pub mod stack;
pub mod uart;
