//! Board support for the BBC micro:bit (v1: nRF51822, Cortex-M0, 16 MHz, 256 KiB of flash,
//! 16 KiB of RAM) as QEMU 7.2's `microbit` models it: the UART, TIMER0's milliseconds, the
//! stack measurement, and the runtime glue of the firmware (`src/main.rs`):
//!
//! - defmt over semihosting (`defmt-semihosting`): frames go to QEMU's stdout for
//!   `defmt-print` (RTT needs a probe; QEMU has none);
//! - a panic handler and a HardFault handler that log what they can and end the emulator with
//!   a failing exit code ([`EXIT_PANIC`], [`EXIT_HARDFAULT`]).
//!
//! No SysTick: the nRF51's Cortex-M0 has none (QEMU's model adds one anyway; code that used
//! it would not run on the part). Time comes from TIMER0 ([`timer`]).
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

// The global defmt logger.
use defmt_semihosting as _;

#[allow(unsafe_code)]
pub mod stack;
#[allow(unsafe_code)]
pub mod timer;
#[allow(unsafe_code)]
pub mod uart;

/// The exit code of a run that ended well.
pub const EXIT_SUCCESS: i32 = 0;
/// The exit code of a run that ended with an error the firmware caught.
pub const EXIT_FAILURE: i32 = 1;
/// The exit code of a panic.
pub const EXIT_PANIC: i32 = 101;
/// The exit code of a HardFault.
pub const EXIT_HARDFAULT: i32 = 102;

/// Ends the emulator with `code` (semihosting `SYS_EXIT`; QEMU turns it into its own exit
/// status). On a micro:bit without a debugger a semihosting call halts the core.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// Panics that went through `defmt::panic!` have logged their message already: only exit.
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    exit(EXIT_PANIC)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    // Without `core::fmt` (kilobytes of flash): the static message if there is one, and where.
    let message = info.message().as_str().unwrap_or("(formatted message)");
    match info.location() {
        Some(l) => defmt::error!(
            "panicked at {=str}:{=u32}: {=str}",
            l.file(),
            l.line(),
            message
        ),
        None => defmt::error!("panicked: {=str}", message),
    }
    exit(EXIT_PANIC)
}

/// A HardFault ends the run: log the stacked program counter and link register, and fail.
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault at pc {=u32:#010x} (lr {=u32:#010x}, xpsr {=u32:#010x})",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    exit(EXIT_HARDFAULT)
}
