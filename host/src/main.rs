//! `pyramid`: the main computer's command-line tool for terrain-pyramid.
//!
//! Each subcommand lives in its own module with an `Args` struct (clap) and a
//! `run(args) -> ExitCode` function.
use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod demo;
mod design;
mod experiments;
mod export;
mod faults;
mod listen;
mod publish;
mod qemu;
mod record3dtk;
mod replay;
mod run;
mod sick_decode;
mod size;
mod soak;
mod uos;

/// The main computer's side of terrain-pyramid.
#[derive(Parser)]
#[command(name = "pyramid", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Derive a pyramid design (bound, bands, layers) from a sensor and a schedule.
    Design(design::Args),
    /// Integrate a recorded 3-D point file (3DTK format) as one observation and write the maps.
    Replay(replay::Args),
    /// Turn a structured 3DTK tilt scan into a recording of SICK telegrams and tilt angles.
    #[command(name = "record-3dtk")]
    Record3dtk(record3dtk::Args),
    /// Reproduce the paper's experiments on the simulator: Figure 2, stairs, coverage, cost.
    Experiments(experiments::Args),
    /// Receive the device's map stream over a serial port or TCP and write the maps.
    Listen(listen::Args),
    /// Play a recording through the co-processor's pipeline and write the maps it builds.
    Run(run::Args),
    /// Decode a captured SICK LMS2xx byte stream: measured values and framing errors.
    SickDecode(sick_decode::Args),
    /// Flash, static RAM and stack high-water mark of each board's firmware.
    Size(size::Args),
    /// The main job: the 3DTK scan through the emulated co-processor, maps and pictures.
    Demo(demo::Args),
    /// Fault injection through the emulated board: every fault kind against the reference.
    Faults(faults::Args),
    /// A long simulated drive through the host pipeline and the emulated board: counters,
    /// memory, map bounds, throughput.
    Soak(soak::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Design(args) => design::run(&args),
        Command::Replay(args) => replay::run(&args),
        Command::SickDecode(args) => sick_decode::run(&args),
        Command::Record3dtk(args) => record3dtk::run(&args),
        Command::Run(args) => run::run(&args),
        Command::Listen(args) => listen::run(&args),
        Command::Experiments(args) => experiments::run(&args),
        Command::Size(args) => size::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Faults(args) => faults::run(&args),
        Command::Soak(args) => soak::run(&args),
    }
}
