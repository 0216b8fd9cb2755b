//! Board support for QEMU's `mps2-an386` (Cortex-M4F; the same code runs on the `mps2-an385`
//! Cortex-M3 for ARMv6-M builds): the UARTs, the stack measurement, and the runtime glue
//! that the firmware (`src/main.rs`) and the on-target tests (`tests/`) share:
//!
//! - defmt over semihosting (`defmt-semihosting`): frames go to QEMU's stdout (or the
//!   semihosting chardev), for `defmt-print` to decode;
//! - a panic handler and a HardFault handler that log what they can and end the emulator with
//!   a failing exit code ([`EXIT_PANIC`], [`EXIT_HARDFAULT`]), so that a broken firmware or a
//!   failed on-target test fails the shell command that ran QEMU.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

// The global defmt logger.
use defmt_semihosting as _;

#[allow(unsafe_code)]
pub mod clock;
#[allow(unsafe_code)]
pub mod stack;
#[allow(unsafe_code)]
pub mod uart;

/// The exit code of a run that ended well.
pub const EXIT_SUCCESS: i32 = 0;
/// The exit code of a run that ended with an error the firmware caught.
pub const EXIT_FAILURE: i32 = 1;
/// The exit code of a panic (including a failed on-target test).
pub const EXIT_PANIC: i32 = 101;
/// The exit code of a HardFault.
pub const EXIT_HARDFAULT: i32 = 102;

/// Ends the emulator with `code` (semihosting `SYS_EXIT_EXTENDED`, which QEMU turns into its
/// own exit status; `SYS_EXIT` with "application exit" or "run-time error" where the
/// extended call is missing).
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// Panics that went through `defmt::panic!` (and defmt's `assert!`s) have logged their
/// message already: only exit.
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    exit(EXIT_PANIC)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    // Without `core::fmt` (which costs kilobytes of flash): the static message if there is
    // one, and where.
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
