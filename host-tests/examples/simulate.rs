//! Writes the paper's stairs recording (Figs 5-7) and prints its size and telegram count.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example simulate -- stairs.rec [stand_s]
//! ```
//!
//! The scene is the default stairs (first riser 5.05 m ahead of the robot, 5 steps of
//! 0.17 m × 0.30 m); the laser is the paper's (vertical scan plane at 1.0 m, panned ±45° at
//! 75°/s, 180° at 0.5°, mm, σ = 1 cm, 37.5 lines/s). The robot stands for `stand_s` seconds
//! (default 120: "several minutes" in the paper, shortened), then drives at 0.5 m/s until it
//! is 1.0 m from the first riser. Seed 1: every run writes the same bytes.

use std::process::ExitCode;
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: simulate OUT.rec [stand_s]");
        return ExitCode::from(2);
    };
    let stand_s = match args.next().map(|s| s.parse::<f64>()) {
        None => 120.0,
        Some(Ok(v)) if v.is_finite() && v >= 0.0 => v,
        Some(_) => {
            eprintln!("error: stand_s must be a number of seconds ≥ 0");
            return ExitCode::from(2);
        }
    };
    let config = SimConfig::paper_stairs(stand_s, 0.5, 1.0);
    let sim = match simulate(&config) {
        Ok(sim) => sim,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = std::fs::write(&path, &sim.bytes) {
        eprintln!("error: cannot write {path}: {e}");
        return ExitCode::FAILURE;
    }
    println!("wrote {path}");
    println!("size: {} bytes", sim.bytes.len());
    println!(
        "telegrams: {} (in {} laser events), {:.3} s, {} pose events, {} markers",
        sim.lines,
        sim.laser_events,
        sim.duration_us as f64 / 1e6,
        sim.pose_events,
        sim.markers.len()
    );
    println!(
        "ground truth: {} obstacle cells of {} m",
        sim.ground_truth.len(),
        config.truth.cell_m
    );
    ExitCode::SUCCESS
}
