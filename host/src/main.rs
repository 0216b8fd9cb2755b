//! `pyramid`: the main computer's command-line tool for terrain-pyramid.
//!
//! Each subcommand lives in its own module of the `terrain_pyramid_host` library with an
//! `Args` struct (clap) and a `run(args) -> ExitCode` function.
use clap::{Parser, Subcommand};
use std::process::ExitCode;
use terrain_pyramid_host::{decode, design, listen, record, record3dtk, replay, rigfile, run};

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
    /// Record a laser's bytes from a serial port (or a raw capture) into a recording, with
    /// the rig's sensor and mount and optionally the actuator's angles from a CSV.
    Record(record::Args),
    /// Receive the device's map stream over a serial port or TCP and write the maps.
    Listen(listen::Args),
    /// Play a recording through the co-processor (in process or on the emulated board) and
    /// write the maps it builds.
    Run(run::Args),
    /// Decode a captured laser byte stream: packets, returns and framing errors.
    #[command(alias = "sick-decode")]
    Decode(decode::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Design(args) => match rigfile::asked_design(&args) {
            Ok((asked, fit_layers)) => design::run(&args, &asked, fit_layers),
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
        Command::Replay(args) => replay::run(&args),
        Command::Decode(args) => decode::run(&args),
        Command::Record3dtk(args) => record3dtk::run(&args),
        Command::Run(args) => run::run(&args),
        Command::Record(args) => record::run(&args),
        Command::Listen(args) => listen::run(&args),
    }
}
