//! A diagnostic of the stairs run of a nodding lidar: which layers hold the step cells'
//! evidence over time, what each observation adds to them (obstacle or free, in which layer,
//! from how far), and which layer the fused query answers from as the robot approaches.
//!
//! It watches the step cells of every layer between packets (each change is one observation's
//! increment to that layer's cell), so it needs nothing from the library beyond its maps.

use super::engine::{decode, Map, Runner};
use super::lidar::{self, StairsSetup, RIG_LAYERS as LAYERS, STAIRS_CELLS};
use super::stairs::{self, CELL_M};
use std::fmt::Write as _;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{Config, Design, Fused};
use terrain_pyramid_host_tests::sim::lidar::simulate_lidar;

/// Packets between two looks at the step cells (a fifteenth of an LD19's second).
const LOOK_EVERY: usize = 25;

#[derive(Default, Clone, Copy)]
struct Counts {
    obstacle: u32,
    free: u32,
}

impl Counts {
    /// One look's increment: obstacle evidence when it raised the cell.
    fn add(&mut self, delta: f32) {
        if delta > 0.0 {
            self.obstacle += 1;
        } else {
            self.free += 1;
        }
    }
}

/// The increment between two readings of a layer's cell, when there was one (the cell
/// observed now, and first observed or changed since).
fn look(now: Option<f32>, before: Option<f32>) -> Option<f32> {
    let delta = now.unwrap_or(0.0) - before.unwrap_or(0.0);
    (now.is_some() && (before.is_none() || delta.abs() > 1e-6)).then_some(delta)
}

/// A hand-run diagnostic's setting: environment variable `name` parsed as `T` (surrounding
/// spaces ignored), or `default` when it is unset or does not parse.
pub fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// Runs `setup` through a pyramid of `design` and describes where the step cells' evidence
/// goes: a Markdown report. With `at_arrival` the stop is read as a device shows it, without
/// the sweep still in progress; otherwise that sweep is flushed into the map at the last line.
///
/// # Errors
/// The simulator's or the library's refusal.
pub fn diagnose(
    setup: &StairsSetup,
    design: Design<LAYERS>,
    classifier: &ClassifierConfig,
    at_arrival: bool,
) -> Result<String, String> {
    let scene = setup.scene_config();
    let sim = simulate_lidar(&setup.sim()).map_err(|e| e.to_string())?;
    let decoded = decode(&sim.bytes, classifier)?;
    let (steps, first) = stairs::step_cells(&scene);
    let riser_x = scene.scene.target_x.unwrap_or(0.0);
    // The library's default configuration, as the rig table's pyramids.
    let config = Config::default();
    let layers_text: Vec<String> = design
        .layers()
        .iter()
        .enumerate()
        .map(|(k, l)| {
            format!(
                "{k}: {:.2}..{:.2} ({:.2} m)",
                l.band_inner_m, l.band_outer_m, l.resolution_m
            )
        })
        .collect();
    let mut map: Box<dyn Map> = Box::new(Runner::<STAIRS_CELLS, LAYERS, { stairs::SLOTS }>::new(
        "diag",
        design,
        config,
        decoded.frontend,
    )?);
    let n_layers = map.layer_count();
    let centre = |c: (i32, i32)| {
        (
            (f64::from(c.0) + 0.5) * CELL_M,
            (f64::from(c.1) + 0.5) * CELL_M,
        )
    };
    let mut last: Vec<Vec<Option<f32>>> = vec![vec![None; n_layers]; steps.len()];
    // The ground before the stairs, watched alike: each observation's verdict on its cells.
    let ground = stairs::Watched::of(&scene).ground;
    let mut ground_last: Vec<Vec<Option<f32>>> = vec![vec![None; n_layers]; ground.len()];
    let mut ground_looks = vec![Counts::default(); n_layers];
    // Increments per layer while standing and while driving; per distance (1 m rings of the
    // step cell's distance from the robot) while driving.
    let mut standing = vec![Counts::default(); n_layers];
    let mut driving = vec![Counts::default(); n_layers];
    let mut by_distance = [Counts::default(); 14];
    let drive_start_us = (scene.trajectory.drive_start_s() * 1e6).round();
    let mut out = String::new();
    let _ = writeln!(out, "bands: {}\n", layers_text.join(", "));
    let _ = writeln!(
        out,
        "| t s | robot to riser m | fused: obstacle/free/unknown | answering layers (k:obst/free) | first riser obstacle |\n| --- | --- | --- | --- | --- |"
    );
    let count = decoded.lines.len();
    let trace_layers: Vec<usize> = std::env::var("STAIRS_DIAG_TRACE")
        .unwrap_or_default()
        .split(',')
        .filter_map(|v| v.trim().parse().ok())
        .collect();
    let trace_row: i32 = env_or("STAIRS_DIAG_ROW", 0);
    let mut trace = String::new();
    let mut next_report_s = 0.0_f64;
    for (i, line) in decoded.lines.iter().enumerate() {
        map.line(line);
        let is_last = i + 1 == count;
        let flushed = is_last && !at_arrival;
        if flushed {
            map.flush();
        }
        if (i + 1) % LOOK_EVERY != 0 && !is_last {
            continue;
        }
        #[allow(clippy::cast_precision_loss)]
        let t_us = line.time_us as f64;
        let is_driving = t_us >= drive_start_us;
        let robot_x = line.robot_xy.0;
        for (c, prev) in steps.iter().zip(last.iter_mut()) {
            let (x, y) = centre(*c);
            for (k, p) in prev.iter_mut().enumerate() {
                let now = map.layer_log_odds(k, x, y);
                if let Some(delta) = look(now, *p) {
                    let table = if is_driving {
                        &mut driving
                    } else {
                        &mut standing
                    };
                    if trace_layers.contains(&k) && (c.1 == trace_row) && is_driving {
                        let _ = writeln!(
                            trace,
                            "t {:.3} robot->cell {:.2} m cell ({}, {}) layer {k}: {delta:+.2} -> {:.2}{}",
                            t_us * 1e-6,
                            x - robot_x,
                            c.0,
                            c.1,
                            now.unwrap_or(0.0),
                            if flushed { " (flush)" } else { "" }
                        );
                    }
                    if let Some(e) = table.get_mut(k) {
                        e.add(delta);
                    }
                    if is_driving {
                        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                        let ring = ((x - robot_x).max(0.0).floor() as usize).min(13);
                        if let Some(e) = by_distance.get_mut(ring) {
                            e.add(delta);
                        }
                    }
                }
                *p = now;
            }
        }
        for (c, prev) in ground.iter().zip(ground_last.iter_mut()) {
            let (x, y) = centre(*c);
            for (k, p) in prev.iter_mut().enumerate() {
                let now = map.layer_log_odds(k, x, y);
                if let (Some(delta), Some(e)) = (look(now, *p), ground_looks.get_mut(k)) {
                    e.add(delta);
                }
                *p = now;
            }
        }
        let t_s = t_us * 1e-6;
        if t_s >= next_report_s || is_last {
            // Every 10 s while standing, every 0.5 s from the start of the drive.
            next_report_s = if is_driving {
                t_s + 0.5
            } else {
                (t_s + 10.0).min(drive_start_us * 1e-6)
            };
            let mut answer: Vec<Counts> = vec![Counts::default(); n_layers];
            let mut shares = (0, 0, 0);
            for c in &steps {
                let (x, y) = centre(*c);
                match map.fused(x, y) {
                    Fused::Obstacle { layer } => {
                        shares.0 += 1;
                        if let Some(a) = answer.get_mut(usize::from(layer)) {
                            a.obstacle += 1;
                        }
                    }
                    Fused::Navigable { layer } => {
                        shares.1 += 1;
                        if let Some(a) = answer.get_mut(usize::from(layer)) {
                            a.free += 1;
                        }
                    }
                    Fused::Unknown => shares.2 += 1,
                }
            }
            let answering: Vec<String> = answer
                .iter()
                .enumerate()
                .filter(|(_, a)| a.obstacle + a.free > 0)
                .map(|(k, a)| format!("{k}:{}/{}", a.obstacle, a.free))
                .collect();
            let _ = writeln!(
                out,
                "| {t_s:.1} | {:.2} | {}/{}/{} | {} | {:.2} |",
                riser_x - robot_x,
                shares.0,
                shares.1,
                shares.2,
                answering.join(" "),
                stairs::shares(map.as_ref(), &first).obstacle
            );
        }
    }
    if !trace.is_empty() {
        let _ = writeln!(
            out,
            "\nincrements while driving, row y = {trace_row} only:\n{trace}"
        );
    }
    let _ = writeln!(
        out,
        "\nincrements to step cells per layer (obstacle/free): standing | driving"
    );
    for (k, (s, d)) in standing.iter().zip(&driving).enumerate() {
        if s.obstacle + s.free + d.obstacle + d.free > 0 {
            let _ = writeln!(
                out,
                "layer {k}: {}/{} | {}/{}",
                s.obstacle, s.free, d.obstacle, d.free
            );
        }
    }
    // The classifier's verdicts per look, as the inverse sensor model reads them: the share of
    // obstacle verdicts on cells that hold a step (its hit rate) and on the flat ground before
    // the stairs (its false alarms).
    let share = |c: &[Counts]| {
        let (o, f) = c.iter().fold((0_u64, 0_u64), |(o, f), e| {
            (o + u64::from(e.obstacle), f + u64::from(e.free))
        });
        #[allow(clippy::cast_precision_loss)]
        let v = if o + f == 0 {
            0.0
        } else {
            100.0 * o as f64 / (o + f) as f64
        };
        (o, o + f, v)
    };
    let all_steps: Vec<Counts> = standing.iter().chain(&driving).copied().collect();
    let (so, sn, sv) = share(&all_steps);
    let (go, gn, gv) = share(&ground_looks);
    let _ = writeln!(
        out,
        "\nlooks that called a cell obstacle, every layer: step cells {so} of {sn} ({sv:.1} %), the ground before the stairs {go} of {gn} ({gv:.2} %)"
    );
    let _ = writeln!(
        out,
        "\nwhile driving, increments by the step cell's distance ahead (m): obstacle/free"
    );
    for (m, c) in by_distance.iter().enumerate() {
        if c.obstacle + c.free > 0 {
            let _ = writeln!(out, "{m}..{}: {}/{}", m + 1, c.obstacle, c.free);
        }
    }
    let _ = writeln!(
        out,
        "\nat the stop, per riser (its centre cell): the fused answer and each observed layer's L (k:nats)"
    );
    // Each observed layer's log-odds at a point, `k:nats` apart by spaces.
    let layers_at = |x: f64, y: f64| {
        (0..n_layers)
            .filter_map(|k| map.layer_log_odds(k, x, y).map(|l| format!("{k}:{l:.2}")))
            .collect::<Vec<String>>()
            .join(" ")
    };
    let robot_x = decoded.lines.last().map_or(0.0, |l| l.robot_xy.0);
    let risers: std::collections::BTreeSet<i32> = steps.iter().map(|c| c.0).collect();
    for ix in risers {
        let (x, y) = centre((ix, 0));
        let _ = writeln!(
            out,
            "riser at {:.2} m: {:?}; {}",
            x - robot_x,
            map.fused(x, y),
            layers_at(x, y)
        );
    }
    let _ = writeln!(
        out,
        "\nat the stop, every step cell the fused map does not read as obstacle: its answer and each observed layer's L (k:nats)"
    );
    for c in &steps {
        let (x, y) = centre(*c);
        let answer = map.fused(x, y);
        if matches!(answer, Fused::Obstacle { .. }) {
            continue;
        }
        let _ = writeln!(
            out,
            "cell ({}, {}) at {:.2} m: {answer:?}; {}",
            c.0,
            c.1,
            x - robot_x,
            layers_at(x, y)
        );
    }
    // The false obstacles at the stop: where on the ground before the stairs, and which layer
    // answered for them.
    let mut false_by_distance: std::collections::BTreeMap<i32, Vec<u8>> =
        std::collections::BTreeMap::new();
    for c in &ground {
        let (x, y) = centre(*c);
        if let Fused::Obstacle { layer } = map.fused(x, y) {
            // Quarter metres before the first riser.
            #[allow(clippy::cast_possible_truncation)]
            let bin = ((riser_x - x) / 0.25).floor() as i32;
            false_by_distance.entry(bin).or_default().push(layer);
        }
    }
    let _ = writeln!(
        out,
        "\nat the stop ({:.2} m from the first riser), the ground before the stairs read as obstacle, {} of {} cells, by distance before the riser (m): cells (answering layers)",
        riser_x - robot_x,
        false_by_distance.values().map(Vec::len).sum::<usize>(),
        ground.len()
    );
    for (bin, layers) in &false_by_distance {
        // The answering layers, once each and in order.
        let answering: Vec<&u8> = layers
            .iter()
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        let _ = writeln!(
            out,
            "{:.2}..{:.2}: {} ({:?})",
            f64::from(*bin) * 0.25,
            f64::from(*bin + 1) * 0.25,
            layers.len(),
            answering
        );
    }
    let _ = writeln!(
        out,
        "\nsimulated packets {}, echoes {}; the datasheet design's φ = {}°",
        sim.packets,
        sim.echoes,
        lidar::Ld19Design::from_datasheet().phi_deg
    );
    Ok(out)
}

/// `STAIRS_SERVO` = `lo,hi,rate` (degrees, °/s) when set, else `None`: the rig's own nod.
fn servo_from_env() -> Option<(f64, f64, f64, f64)> {
    std::env::var("STAIRS_SERVO").ok().and_then(|v| {
        let f: Vec<f64> = v.split(',').filter_map(|x| x.trim().parse().ok()).collect();
        match f[..] {
            [lo, hi, rate] => Some((lo, hi, rate, lidar::SERVO_LATENCY_MS)),
            _ => None,
        }
    })
}

/// One run of the LD19's stairs for the standing-time sweep: the four maps' figures.
///
/// # Errors
/// As [`lidar::run_stairs`].
pub fn stand_sweep(
    stand_s: &[f64],
    revolutions_per_observation: u32,
    classifier: &ClassifierConfig,
) -> Result<String, String> {
    let mut out = String::from(
        "| stand s | flat: at 1 m / first seen | hard: at 1 m / first seen | soft: at 1 m / first seen |\n| --- | --- | --- | --- |\n",
    );
    let m = |v: Option<f64>| v.map_or_else(|| "never".to_string(), |d| format!("{d:.2} m"));
    for &s in stand_s {
        let setup = StairsSetup {
            stand_s: s,
            revolutions_per_observation,
            servo: servo_from_env(),
            ..StairsSetup::FULL
        };
        let r = lidar::run_stairs(&setup, classifier, None)?;
        let _ = writeln!(
            out,
            "| {s:.1} | {:.1} % / {} | {:.1} % / {} | {:.1} % / {} |",
            100.0 * r.flat.detected_fraction,
            m(r.flat.detect_distance_m),
            100.0 * r.pyramid.detected_fraction,
            m(r.pyramid.detect_distance_m),
            100.0 * r.pyramid_soft.detected_fraction,
            m(r.pyramid_soft.detect_distance_m),
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::classify::NavigabilityRule;
    use terrain_pyramid::GateShape;

    /// `cargo test --release -p terrain-pyramid-lab --lib stairs_diag -- --ignored --nocapture`
    /// with `STAIRS_DIAG_STAND_S` (default 120), `STAIRS_DIAG_GATE` (`hard` or `soft`),
    /// `STAIRS_DIAG_RIG` (`ld19`, the default, `rplidar` or `ydlidar`), `STAIRS_DIAG_TRACE`
    /// (the layers whose increments to the step cells are listed, e.g. `1,2,3`) and
    /// `STAIRS_DIAG_ROW` (the row of step cells traced, default 0; the cells missed at the
    /// stop are listed with their rows) and `STAIRS_DIAG_RULE` (`paper` for the spread rule;
    /// the plane rule otherwise); `STAIRS_SERVO` = `lo,hi,rate` for another nod;
    /// `STAIRS_DIAG_SEED` the simulator's seed (default 1); `STAIRS_DIAG_AT_ARRIVAL` set reads
    /// the stop as a device shows it, without flushing the sweep in progress.
    #[test]
    #[ignore = "a diagnostic, minutes long: run by hand"]
    fn stairs_diagnostic() {
        let stand_s: f64 = env_or("STAIRS_DIAG_STAND_S", 120.0);
        let gate = match std::env::var("STAIRS_DIAG_GATE").as_deref() {
            Ok("hard") => GateShape::Hard,
            _ => GateShape::default(),
        };
        let handle = std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn(move || {
                let kind = match std::env::var("STAIRS_DIAG_RIG").as_deref() {
                    Ok("rplidar") => lidar::RIGS[1].0,
                    Ok("ydlidar") => lidar::RIGS[2].0,
                    _ => lidar::RIGS[0].0,
                };
                let (_, range_m) = kind.range_m();
                let setup = StairsSetup {
                    stand_s,
                    kind,
                    range_m,
                    stand_distance_m: range_m - 0.95,
                    servo: servo_from_env(),
                    seed: env_or("STAIRS_DIAG_SEED", StairsSetup::FULL.seed),
                    ..StairsSetup::FULL
                };
                let design = setup.pyramid::<LAYERS>(gate).map_err(|e| e.to_string())?;
                let classifier = match std::env::var("STAIRS_DIAG_RULE").as_deref() {
                    Ok("paper") => ClassifierConfig {
                        rule: NavigabilityRule::Spread,
                        ..ClassifierConfig::default()
                    },
                    _ => ClassifierConfig::default(),
                };
                let at_arrival = std::env::var("STAIRS_DIAG_AT_ARRIVAL").is_ok();
                diagnose(&setup, design, &classifier, at_arrival)
            })
            .unwrap();
        let report = handle.join().unwrap().unwrap();
        println!("{report}");
    }

    /// `STAIRS_SWEEP` = comma-separated standing times, seconds; `STAIRS_REVOLUTIONS` =
    /// revolutions per observation (default 0: one per sweep); `STAIRS_SERVO` = `lo,hi,rate`
    /// (degrees, °/s) instead of the LD19's servo.
    #[test]
    #[ignore = "a diagnostic, minutes long: run by hand"]
    fn stairs_stand_sweep() {
        let times: Vec<f64> = std::env::var("STAIRS_SWEEP")
            .unwrap_or_else(|_| "30,31,32,33,120,300".to_string())
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        let revolutions: u32 = env_or("STAIRS_REVOLUTIONS", 0);
        let handle = std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn(move || stand_sweep(&times, revolutions, &ClassifierConfig::default()))
            .unwrap();
        println!("{}", handle.join().unwrap().unwrap());
    }

    /// Every nodding rig's stairs against standing time and the nod's phase (the table of
    /// `lab experiments`), as JSON; `STAIRS_RIGS_QUICK=1` for 30 s and 120 s only;
    /// `STAIRS_RIGS_SEED` the simulator's seed (default 1).
    #[test]
    #[ignore = "a diagnostic, minutes long: run by hand"]
    fn stairs_rigs() {
        let quick = std::env::var("STAIRS_RIGS_QUICK").is_ok();
        let seed: u64 = env_or("STAIRS_RIGS_SEED", 1);
        let handle = std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn(move || lidar::run_rigs(quick, seed, &ClassifierConfig::default()))
            .unwrap();
        let rigs = handle.join().unwrap().unwrap();
        println!("{}", serde_json::to_string(&rigs).unwrap());
    }
}
