//! The terrain-pyramid lab: what measures and stresses the co-processor rather than uses it.
//!
//! - [`experiments`]: the paper's claims on the simulator (Figure 2, stairs, coverage, cost),
//!   and the stairs through the firmware on the emulated board;
//! - [`faults`]: fault injection through the emulated board, against a reference co-processor
//!   fed exactly the intact telegrams;
//! - [`soak`]: a long simulated drive through the in-process co-processor and the firmware;
//! - [`latency`]: telegram into the emulated board → each live output's message out of the host;
//! - [`live`]: a recording played as a robot lives: the laser paced into the emulated board, the
//!   poses published late over ROS 2, `pyramid listen` forwarding them;
//! - [`size`]: the firmware's flash, static RAM and stack;
//! - [`demo`]: the main job end to end, on the emulated board.
//!
//! Everything drives the library's application core ([`terrain_pyramid::app::CoProcessor`])
//! through the host tool's devices ([`terrain_pyramid_host::device`]) and its recording player
//! ([`terrain_pyramid_host::play`]); the timing experiment alone feeds pipelines directly.

pub mod demo;
pub mod experiments;
pub mod faults;
pub mod latency;
pub mod live;
pub mod size;
pub mod soak;

/// Ends a lab command that failed: says `error: {e}` on stderr; the failing exit status.
pub fn command_failed(e: impl std::fmt::Display) -> std::process::ExitCode {
    eprintln!("error: {e}");
    std::process::ExitCode::FAILURE
}
