//! `cargo xtask bench --lidars`: the whole pipeline per return for each spinning lidar on the
//! emulated Cortex-M4F and M0, and the CPU share at each laser's full rate.
//!
//! Per laser, the simulator (`host-tests/src/sim/lidar.rs`) drives the paper's stairs run
//! (stand 1 s, 1 m/s to 1 m from the first riser; `--quick`: stand 0.2 s, to 4.2 m) with the
//! lidar 1.0 m up on a servo nodding 2°..35° at 20 °/s, into `target/bench/<laser>.rec`; the
//! bench firmware's `lidar` bin (`boards/bench/src/bin/lidar.rs`: the default co-processor
//! booted with the recording's sensor, every event through `CoProcessor::laser` with the
//! recording's clock and angle, the link polled and drained) is built with it embedded and
//! counted between `bench_start` and `bench_end`, as the SICK rows are.
//!
//! Instructions per return = instructions ÷ returns with a distance (the frontend's count,
//! as for the SICK). Instructions per sample = instructions ÷ every sample decoded (with or
//! without a distance). The CPU share at full rate = samples per second (the maker's rate)
//! × instructions per sample ÷ clock, taking **one instruction per cycle**: a lower bound
//! on a real part (an M0+ at 48 MHz runs flash with a wait state, loads and taken branches
//! take 2 cycles; an STM32F4 at 168 MHz has 5 wait states behind its ART cache).

use super::{root, run_loud, trace, write_if_changed, Result, M0, M4F};
use std::fs;
use std::process::Command;
use terrain_pyramid_host_tests::sim::lidar::{
    simulate_lidar, LidarActuator, LidarKind, LidarSimConfig,
};
use terrain_pyramid_host_tests::sim::scene::{Scene, StairsSpec};
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// The lasers measured.
const LASERS: [LidarKind; 4] = [
    LidarKind::Ld06,
    LidarKind::RplidarStandard,
    LidarKind::RplidarExpress,
    LidarKind::YdlidarX4,
];

/// Runs the lidar rows (`BENCH_ONLY=ld06,ydlidar` restricts them); prints a table on stderr
/// and returns the rows as JSON.
///
/// # Errors
/// A simulator refusal, a build or a run that failed.
pub fn rows(quick: bool) -> Result<serde_json::Value> {
    let root = root();
    let work = root.join("target").join("bench");
    fs::create_dir_all(&work).map_err(|e| e.to_string())?;
    let board = root.join("boards").join("bench");
    let (stand_s, distance_m) = if quick { (0.2, 4.2) } else { (1.0, 1.0) };
    let spec = StairsSpec::default();
    let only = std::env::var("BENCH_ONLY").ok();
    let mut out = Vec::new();
    let mut table = String::from(
        "| laser | samples/s | M4F instr/return | M0 instr/return | M4F instr/sample | M0 instr/sample | CPU M4F @168 MHz | CPU M0+ @48 MHz |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for kind in LASERS {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|v| v == kind.name()))
        {
            continue;
        }
        let config = LidarSimConfig::new(
            Scene::stairs(spec),
            kind,
            LidarActuator::servo(2.0, 35.0, 20.0, 20.0),
            [0.0, 0.0, 1.0],
            Trajectory::approach(stand_s, 1.0, spec.first_riser_x, distance_m),
        );
        let sim = simulate_lidar(&config).map_err(|e| e.0)?;
        let rec = work.join(format!(
            "{}{}.rec",
            kind.name(),
            if quick { "-quick" } else { "" }
        ));
        write_if_changed(&rec, &sim.bytes)?;
        eprintln!(
            "xtask bench: {} recording {} ({} packets, {} samples, {} bytes)",
            kind.name(),
            rec.display(),
            sim.packets,
            sim.samples,
            sim.bytes.len()
        );
        let mut per = Vec::new();
        for target in [M4F, M0] {
            run_loud(
                Command::new("cargo")
                    .current_dir(&board)
                    .args([
                        "build",
                        "--release",
                        "--quiet",
                        "--bin",
                        "lidar",
                        "--target",
                        target,
                    ])
                    .env("BENCH_RECORDING", &rec)
                    .env_remove("CARGO_TARGET_DIR"),
            )?;
            let elf = board
                .join("target")
                .join(target)
                .join("release")
                .join("lidar");
            let r = trace(&elf, &work, false)?;
            let by_line = super::lines::profile(&elf, &r, &root)?;
            write_if_changed(
                &work.join(format!("lines-{target}-lidar-{}.txt", kind.name())),
                by_line.as_bytes(),
            )?;
            eprintln!(
                "xtask bench: {target} lidar {}: {} instructions, {} returns, {} without a distance, {} packets, stack {} B",
                kind.name(),
                r.instructions,
                r.returns,
                r.cells,
                r.lines,
                r.stack
            );
            per.push(r);
        }
        let m4 = per.first().cloned().unwrap_or_default();
        let m0 = per.get(1).cloned().unwrap_or_default();
        // The firmware reports the samples without a distance in the "cells" slot.
        let samples = m4.returns + m4.cells;
        let per_sample = |i: u64| i as f64 / samples.max(1) as f64;
        let rate = kind.sample_hz();
        let (m4s, m0s) = (per_sample(m4.instructions), per_sample(m0.instructions));
        let (share4, share0) = (rate * m4s / 168e6, rate * m0s / 48e6);
        table.push_str(&format!(
            "| {} | {rate:.0} | {:.1} | {:.1} | {m4s:.1} | {m0s:.1} | {:.2} % | {:.1} % |\n",
            kind.name(),
            m4.per_return(),
            m0.per_return(),
            100.0 * share4,
            100.0 * share0
        ));
        out.push(serde_json::json!({
            "laser": kind.name(),
            "samples_per_second": rate,
            "samples": samples,
            "returns": m4.returns,
            "packets": m4.lines,
            "m4f_instructions_per_return": m4.per_return(),
            "m0_instructions_per_return": m0.per_return(),
            "m4f_instructions_per_sample": m4s,
            "m0_instructions_per_sample": m0s,
            "m4f_168mhz_cpu_share": share4,
            "m0plus_48mhz_cpu_share": share0,
            "stack_bytes": [m4.stack, m0.stack],
        }));
    }
    eprintln!("\n{table}");
    Ok(serde_json::Value::Array(out))
}
