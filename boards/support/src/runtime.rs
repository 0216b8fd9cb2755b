//! The runtime glue of a firmware run under QEMU:
//!
//! - defmt over semihosting (`defmt-semihosting`): frames go to QEMU's stdout (or the
//!   semihosting chardev) for `defmt-print` (RTT needs a probe; QEMU has none);
//! - a panic handler and a HardFault report ([`hard_fault`]) that log what they can and end the
//!   emulator with a failing exit code ([`EXIT_PANIC`], [`EXIT_HARDFAULT`]), so that a broken
//!   firmware or a failed on-target test fails the shell command that ran QEMU.

// The global defmt logger.
use defmt_semihosting as _;

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
/// extended call is missing). On a part without a debugger a semihosting call halts the core.
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

/// A HardFault ends the run: logs the stacked program counter and link register, and exits
/// with [`EXIT_HARDFAULT`]. The board's `#[cortex_m_rt::exception] HardFault` calls it (the
/// handler stays in the board crate, so that the linker always finds it there; this is
/// inlined into it, as it was written there).
#[inline(always)]
pub fn hard_fault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault at pc {=u32:#010x} (lr {=u32:#010x}, xpsr {=u32:#010x})",
        frame.pc(),
        frame.lr(),
        frame.xpsr()
    );
    exit(EXIT_HARDFAULT)
}
