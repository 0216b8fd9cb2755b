//! Where defmt's log goes and how a run ends, by feature.
//!
//! - `log-rtt` (the default, the board on a probe): defmt over RTT (`defmt-rtt`), and
//!   `panic-probe` (a panic halts; probe-rs prints it). [`stopped`] returns: the firmware
//!   parks until it is reset.
//! - `log-semihosting` (QEMU, which cannot read RTT): defmt over semihosting
//!   (`defmt-semihosting`; QEMU writes the frames to its stdout for `defmt-print`), a panic
//!   ends the emulator with [`EXIT_PANIC`], a HardFault with [`EXIT_HARDFAULT`] (its handler
//!   is in [`crate::hw`]), and [`stopped`] (after Shutdown) ends it with [`EXIT_SUCCESS`], as
//!   the `qemu-mps2` board does: all of it `board-support`'s `semihosting` feature
//!   (`boards/support`), as the other boards have it.
//!
//! [`EXIT_PANIC`]: board_support::runtime::EXIT_PANIC
//! [`EXIT_HARDFAULT`]: board_support::runtime::EXIT_HARDFAULT

#[cfg(feature = "log-rtt")]
use defmt_rtt as _;
#[cfg(feature = "log-rtt")]
use panic_probe as _;

#[cfg(feature = "log-semihosting")]
use board_support::runtime::EXIT_SUCCESS;

/// The firmware stopped after Shutdown: under `log-semihosting` the emulator exits with
/// [`EXIT_SUCCESS`]; on the board this returns and the caller parks.
pub fn stopped() {
    #[cfg(feature = "log-semihosting")]
    board_support::runtime::exit(EXIT_SUCCESS);
}
