//! `lab`: the terrain-pyramid lab's command-line tool: the paper's experiments on the
//! simulator, fault injection and the soak through the emulated board, the firmware's size,
//! and the demo.
//!
//! Each subcommand lives in its own module of the `terrain_pyramid_lab` library with an `Args`
//! struct (clap) and a `run(args) -> ExitCode` function. With `--json` a command prints exactly
//! one JSON object on stdout; progress goes to stderr.
use clap::{Parser, Subcommand};
use std::process::ExitCode;
use terrain_pyramid_lab::{demo, experiments, faults, latency, live, size, soak};

/// The terrain-pyramid lab.
#[derive(Parser)]
#[command(name = "lab", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Reproduce the paper's experiments on the simulator: Figure 2, stairs, coverage, cost.
    Experiments(experiments::Args),
    /// Flash, static RAM and stack high-water mark of each board's firmware.
    Size(size::Args),
    /// The main job: the 3DTK scan and the simulated stairs through the emulated co-processor,
    /// maps and pictures.
    Demo(demo::Args),
    /// Fault injection through the emulated board: every fault kind against the reference.
    Faults(faults::Args),
    /// A long simulated drive through the in-process co-processor and the emulated board:
    /// counters, memory, map bounds, throughput.
    Soak(soak::Args),
    /// Telegram into the emulated board → each live output's message out of the host, at the
    /// SICK's full rate with every output on (median, p99).
    Latency(latency::Args),
    /// Poses on the laser's clock: three scenes with the poses in lock-step, stamped and late
    /// (50 Hz, 30 ± 10 ms), and late on arrival; the maps against the lock-step run's.
    Timing(experiments::timing::Args),
    /// A recording played as a robot lives: the laser paced into the emulated board, the poses
    /// published late as ROS 2 Odometry, `pyramid listen` forwarding them; the maps against
    /// the lock-step run's.
    Live(live::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Experiments(args) => experiments::run(&args),
        Command::Size(args) => size::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Faults(args) => faults::run(&args),
        Command::Soak(args) => soak::run(&args),
        Command::Latency(args) => latency::run(&args),
        Command::Timing(args) => experiments::timing::run_command(&args),
        Command::Live(args) => live::run(&args),
    }
}
