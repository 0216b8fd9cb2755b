//! Board support for QEMU's `mps2-an386` (Cortex-M4F; the same code runs on the `mps2-an385`
//! Cortex-M3 for ARMv6-M builds): the UARTs, the stack measurement, and the runtime glue
//! that the firmware (`src/main.rs`) and the on-target tests (`tests/`) share:
//!
//! - from `board-support` (`boards/support`, with its `semihosting` feature): the stack
//!   measurement ([`stack`]), defmt over semihosting (`defmt-semihosting`): frames go to
//!   QEMU's stdout (or the semihosting chardev), for `defmt-print` to decode;
//! - a panic handler and a HardFault handler that log what they can and end the emulator with
//!   a failing exit code ([`EXIT_PANIC`], [`EXIT_HARDFAULT`]), so that a broken firmware or a
//!   failed on-target test fails the shell command that ran QEMU.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[allow(unsafe_code)]
pub mod clock;
pub mod sizes;
#[allow(unsafe_code)]
pub mod uart;

pub use board_support::runtime::{exit, EXIT_FAILURE, EXIT_HARDFAULT, EXIT_PANIC, EXIT_SUCCESS};
pub use board_support::stack;

/// An interrupt: a UART's receive interrupt (enabled by [`uart::Uarts::wake_on_receive`] to
/// wake the core from `wfi`) is cleared and the main loop goes on; any other ends the run with
/// a failing exit code ([`EXIT_FAILURE`]).
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn DefaultHandler(irqn: i16) {
    if !uart::acknowledge_receive(irqn) {
        defmt::error!("unexpected interrupt or exception, IRQn {=i16}", irqn);
        exit(EXIT_FAILURE);
    }
}

/// A HardFault ends the run ([`board_support::runtime::hard_fault`]: logged, exit code
/// [`EXIT_HARDFAULT`]).
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board_support::runtime::hard_fault(frame)
}
