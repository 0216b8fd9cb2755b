//! Board support for the BBC micro:bit (v1: nRF51822, Cortex-M0, 16 MHz, 256 KiB of flash,
//! 16 KiB of RAM) as QEMU 7.2's `microbit` models it: the UART, TIMER0's milliseconds, the
//! stack measurement, and the runtime glue of the firmware (`src/main.rs`):
//!
//! - from `board-support` (`boards/support`, with its `semihosting` feature): the stack
//!   measurement ([`stack`]), defmt over semihosting (`defmt-semihosting`): frames go to QEMU's stdout for
//!   `defmt-print` (RTT needs a probe; QEMU has none);
//! - a panic handler and a HardFault handler that log what they can and end the emulator with
//!   a failing exit code ([`EXIT_PANIC`], [`EXIT_HARDFAULT`]).
//!
//! No SysTick: the nRF51's Cortex-M0 has none (QEMU's model adds one anyway; code that used
//! it would not run on the part). Time comes from TIMER0 ([`timer`]).
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[allow(unsafe_code)]
pub mod timer;
#[allow(unsafe_code)]
pub mod uart;

pub use board_support::runtime::{exit, EXIT_FAILURE, EXIT_HARDFAULT, EXIT_PANIC, EXIT_SUCCESS};
pub use board_support::stack;

/// A HardFault ends the run ([`board_support::runtime::hard_fault`]: logged, exit code
/// [`EXIT_HARDFAULT`]).
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board_support::runtime::hard_fault(frame)
}
