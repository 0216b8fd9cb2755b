//! Where defmt's log goes and how a run ends, by feature.
//!
//! - `log-rtt` (the default, the board on a probe): defmt over RTT (`defmt-rtt`), and
//!   `panic-probe` (a panic halts; probe-rs prints it). [`stopped`] returns: the firmware
//!   parks until it is reset.
//! - `log-semihosting` (QEMU, which cannot read RTT): defmt over semihosting
//!   (`defmt-semihosting`; QEMU writes the frames to its stdout for `defmt-print`), a panic
//!   ends the emulator with [`EXIT_PANIC`], a HardFault with [`EXIT_HARDFAULT`] (its handler
//!   is in [`crate::hw`]), and [`stopped`] (after Shutdown) ends it with [`EXIT_SUCCESS`], as
//!   the `qemu-mps2` board does.

#[cfg(feature = "log-rtt")]
use defmt_rtt as _;
#[cfg(feature = "log-rtt")]
use panic_probe as _;

#[cfg(feature = "log-semihosting")]
use defmt_semihosting as _;

/// The exit code of a run that ended well.
#[cfg(feature = "log-semihosting")]
pub const EXIT_SUCCESS: i32 = 0;
/// The exit code of a panic.
#[cfg(feature = "log-semihosting")]
pub const EXIT_PANIC: i32 = 101;
/// The exit code of a HardFault.
#[cfg(feature = "log-semihosting")]
pub const EXIT_HARDFAULT: i32 = 102;

/// The firmware stopped after Shutdown: under `log-semihosting` the emulator exits with
/// [`EXIT_SUCCESS`]; on the board this returns and the caller parks.
pub fn stopped() {
    #[cfg(feature = "log-semihosting")]
    semihosting::process::exit(EXIT_SUCCESS);
}

/// Panics that went through `defmt::panic!` have logged their message already: only exit.
#[cfg(feature = "log-semihosting")]
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    semihosting::process::exit(EXIT_PANIC)
}

#[cfg(feature = "log-semihosting")]
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
    semihosting::process::exit(EXIT_PANIC)
}
