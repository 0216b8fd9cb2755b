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
//! Masks and filters: each laser's recording is run a second time with a rig event (recording
//! version 3) that sets every test the device can make before geometry, at bounds that refuse
//! no return of this scene: 8 masked sectors one centidegree wide, a minimum range of 1 cm,
//! a maximum of 655.35 m and a minimum quality of 1 ([`all_filters`]). The returns must come
//! out the same (else the row says how many were refused); the difference in instructions per
//! return (and per sample judged: every sample's angle meets the masks, a return's range and
//! quality the filters) is what the masks and filters cost when they pass everything, the
//! most they cost.
//!
//! Instructions per return = instructions ÷ returns with a distance (the frontend's count,
//! as for the SICK). Instructions per sample = instructions ÷ every sample decoded (with or
//! without a distance). The CPU share at full rate = samples per second (the maker's rate)
//! × instructions per sample ÷ clock, taking **one instruction per cycle**: a lower bound
//! on a real part (an M0+ at 48 MHz runs flash with a wait state, loads and taken branches
//! take 2 cycles; an STM32F4 at 168 MHz has 5 wait states behind its ART cache).

use super::{root, run_loud, trace, write_if_changed, Result, Run, M0, M4F};
use std::fs;
use std::process::Command;
use terrain_pyramid::wire::link::{FilterSetup, MountSetup, SETUP_SECTORS};
use terrain_pyramid::wire::recording::{
    emit_header_version, Event, MountKind, Payload, Reader, RigEvent, VERSION,
};
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
        "| laser | samples/s | M4F instr/return | M0 instr/return | M4F instr/sample | M0 instr/sample | CPU M4F @168 MHz | CPU M0+ @48 MHz | masks+filters M4F / M0 instr/return | masks+filters M4F / M0 instr/sample |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
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
        let filtered_rec = work.join(format!(
            "{}{}-filtered.rec",
            kind.name(),
            if quick { "-quick" } else { "" }
        ));
        write_if_changed(&filtered_rec, &with_rig(&sim.bytes, &all_filters(&config))?)?;
        let mut per = Vec::new();
        for (target, rec) in [
            (M4F, &rec),
            (M0, &rec),
            (M4F, &filtered_rec),
            (M0, &filtered_rec),
        ] {
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
                    .env("BENCH_RECORDING", rec)
                    .env_remove("CARGO_TARGET_DIR"),
            )?;
            let elf = crate::install::boards_target_dir()
                .join(target)
                .join("release")
                .join("lidar");
            let r = trace(&elf, &work.join("trace.fifo"), false)?;
            let by_line = super::lines::profile(&elf, &r, &root)?;
            write_if_changed(
                &work.join(format!(
                    "lines-{target}-lidar-{}{}.txt",
                    kind.name(),
                    if rec == &filtered_rec {
                        "-filtered"
                    } else {
                        ""
                    }
                )),
                by_line.as_bytes(),
            )?;
            eprintln!(
                "xtask bench: {target} lidar {}{}: {} instructions, {} returns, {} without a distance, {} packets, stack {} B",
                kind.name(),
                if rec == &filtered_rec { " (masks and filters)" } else { "" },
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
        let m4_filtered = per.get(2).cloned().unwrap_or_default();
        let m0_filtered = per.get(3).cloned().unwrap_or_default();
        // What a passing return pays for the masks and filters; returns refused (there should
        // be none) are reported beside it.
        let refused = m4.returns.saturating_sub(m4_filtered.returns);
        let filter_cost = |with: &Run, without: &Run| with.per_return() - without.per_return();
        let (filter4, filter0) = (
            filter_cost(&m4_filtered, &m4),
            filter_cost(&m0_filtered, &m0),
        );
        // Every sample is judged (its angle against the masks; with a distance, its range
        // and quality too): the cost per sample judged.
        let filter_sample = |with: &Run, without: &Run| {
            (with.instructions as f64 - without.instructions as f64) / samples.max(1) as f64
        };
        let (filter4s, filter0s) = (
            filter_sample(&m4_filtered, &m4),
            filter_sample(&m0_filtered, &m0),
        );
        let per_sample = |i: u64| i as f64 / samples.max(1) as f64;
        let rate = kind.sample_hz();
        let (m4s, m0s) = (per_sample(m4.instructions), per_sample(m0.instructions));
        let (share4, share0) = (rate * m4s / 168e6, rate * m0s / 48e6);
        table.push_str(&format!(
            "| {} | {rate:.0} | {:.1} | {:.1} | {m4s:.1} | {m0s:.1} | {:.2} % | {:.1} % | {filter4:+.1} / {filter0:+.1}{} | {filter4s:+.1} / {filter0s:+.1} |\n",
            kind.name(),
            m4.per_return(),
            m0.per_return(),
            100.0 * share4,
            100.0 * share0,
            if refused == 0 { String::new() } else { format!(" ({refused} refused)") }
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
            "m4f_filter_instructions_per_return": filter4,
            "m0_filter_instructions_per_return": filter0,
            "m4f_filter_instructions_per_sample": filter4s,
            "m0_filter_instructions_per_sample": filter0s,
            "filter_refused_returns": refused,
        }));
    }
    eprintln!("\n{table}");
    Ok(serde_json::Value::Array(out))
}

/// A rig event of `config`'s preset mount with every mask and filter on, at bounds that
/// refuse none of the simulator's returns: 8 sectors of one centidegree spread round the
/// circle, ranges 1 cm ..= 655.35 m, quality at least 1.
fn all_filters(config: &LidarSimConfig) -> RigEvent {
    let mut sectors = [(0_u16, 0_u16); SETUP_SECTORS];
    for (k, s) in (0_u16..).zip(sectors.iter_mut()) {
        // 0.01° wide, at 22.505° + k·45°: between the angles a simulated lidar samples.
        let start = 2_250 + k * 4_500;
        *s = (start, start + 1);
    }
    RigEvent {
        mount: match config.actuator.mount_kind() {
            MountKind::PannedVertical => 0,
            MountKind::TiltedHorizontal => 1,
        },
        mount_block: MountSetup::PRESET,
        filter: FilterSetup {
            min_range_cm: 1,
            max_range_cm: u16::MAX,
            min_quality: 1,
            sector_count: 8,
            sectors,
        },
    }
}

/// `recording` again as version 3 with `rig` after its sensor event (or its setup event).
fn with_rig(recording: &[u8], rig: &RigEvent) -> Result<Vec<u8>> {
    let mut out = vec![0_u8; 16];
    emit_header_version(&mut out, VERSION).map_err(|e| e.to_string())?;
    let reader = Reader::new(recording).map_err(|e| e.to_string())?;
    let mut placed = false;
    let push = |out: &mut Vec<u8>, event: &Event<'_>| -> Result<()> {
        let start = out.len();
        out.resize(start + event.buffer_len(), 0);
        let tail = out.get_mut(start..).unwrap_or_default();
        event.emit(tail).map_err(|e| e.to_string())?;
        Ok(())
    };
    let mut events = reader.peekable();
    while let Some(event) = events.next() {
        let event = event.map_err(|e| e.to_string())?;
        push(&mut out, &event)?;
        let next_is_sensor = matches!(
            events.peek(),
            Some(Ok(Event {
                payload: Payload::Sensor(_),
                ..
            }))
        );
        if !placed
            && matches!(event.payload, Payload::Setup(_) | Payload::Sensor(_))
            && !next_is_sensor
        {
            push(
                &mut out,
                &Event {
                    time_us: event.time_us,
                    payload: Payload::Rig(*rig),
                },
            )?;
            placed = true;
        }
    }
    Ok(out)
}
