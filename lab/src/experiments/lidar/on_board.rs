//! The nodding rigs' stairs on a board's sizes: the library's default 8 layers of 64² cells
//! and 1 024 classifier slots, what the `qemu-mps2` and `stm32f4` firmware hold. A rig's
//! design at γ = 2 needs 28 (LD19) to 49 (RPLIDAR A1) layers to reach its 12 m, which the
//! rig table's maps hold and no board does. Here each rig runs through a board's pyramid
//! with the design a board boots with (until a host sends a Configure: `pyramid listen`
//! sends none) and with its own, γ the smallest in steps of 0.5 from the schedule's default
//! that a board takes at the range asked (`pyramid design --fit-layers`; `docs/lidars.md`,
//! "On a board").

use super::{
    nod_period_s, packets_per_check, pct, Ld19Design, StairsSetup, LONG_STAND_NODS, PHASES, RIGS,
};
use crate::experiments::engine::{Map, Runner};
use crate::experiments::stairs::{self, Watched};
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{
    Config, Design, GateShape, Schedule, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS,
    DEFAULT_LAYERS,
};
use terrain_pyramid_host::design::{firmware_design, fit, DesignArgs};
use terrain_pyramid_host_tests::sim::lidar::LidarKind;

/// A board's layers, cells per side and classifier slots: the library's defaults.
pub const BOARD: (usize, usize, usize) = (
    DEFAULT_LAYERS,
    DEFAULT_CELLS_PER_SIDE,
    DEFAULT_CLASSIFIER_SLOTS,
);

/// The rigs measured on a board: the rig table's ([`RIGS`]) and the RPLIDAR A1 in express
/// scan (10 revolutions a second, φ 2° on the same servo; `[sensor] mode = 1` in a rig file),
/// which a robot builder can choose over the standard scan's 5.5.
pub const BOARD_RIGS: [(LidarKind, &str); 4] = [
    RIGS[0],
    RIGS[1],
    RIGS[2],
    (LidarKind::RplidarExpress, "RPLIDAR A1 (express scan)"),
];

/// The designs' ranges measured, metres: `None` is the rig's own (12 m, the YDLIDAR's 10 m).
pub const RANGES_M: [Option<f64>; 3] = [None, Some(8.0), Some(6.0)];

/// A design a board runs.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub enum BoardDesign {
    /// The design the firmware boots with until a Configure comes: the library's default
    /// sensor (the SICK's φ 0.5°, σ 0.15 m, 10 m) and schedule (γ 2).
    Boot,
    /// The rig's own sensor to this range, metres, with [`fitted`]'s γ.
    Fitted(f64),
}

/// The stairs as a board's soft-gated pyramid sees them.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct OnBoard {
    /// γ of the design: the boot design's 2, or the smallest in steps of 0.5 from 2 that a
    /// board takes.
    pub gamma: f32,
    /// Layers of that design.
    pub layers: usize,
    /// Step cells obstacle at the stop, the observation in progress flushed (4 decimals).
    pub at_stop: f64,
    /// Step cells obstacle in the map a device shows at arrival, without that flush
    /// ([`stairs::MapResult::arrived_fraction`], 4 decimals).
    pub at_arrival: f64,
    /// Distance at which the first step was first seen, metres (null: never).
    pub first_seen_m: Option<f64>,
    /// Flat ground before the stairs obstacle at the stop (4 decimals).
    pub false_obstacles: f64,
    /// Flat ground 0.5–2.5 m before the first riser obstacle when the first step was first
    /// seen (null: never seen).
    pub ground_at_first_sight: Option<f64>,
    /// Point-to-cell additions the classifier's full scratch dropped.
    pub dropped: u64,
}

/// The design of `setup`'s rig that a board holds: `pyramid design --fit-layers 8`'s γ (the
/// smallest from 2 in steps of 0.5 whose design fits [`BOARD`]'s layers and windows), with
/// the soft gate.
///
/// # Errors
/// No γ fits: `pyramid design`'s refusal, or the library's.
pub fn fitted(setup: &StairsSetup) -> Result<(f32, Design<DEFAULT_LAYERS>), String> {
    let rig = Ld19Design::for_kind_at(setup.kind, setup.nod().2);
    let schedule = Schedule::default();
    let args = DesignArgs {
        phi_deg: rig.phi_deg,
        psi_deg: rig.psi_deg,
        sigma_m: rig.sigma_m,
        height_m: rig.height_m,
        base_m: f64::from(schedule.base_m),
        gamma: f64::from(schedule.gamma),
        max_range_m: setup.range_m,
        cells: DEFAULT_CELLS_PER_SIDE,
        ..DesignArgs::default()
    };
    let (args, _) = fit(&args, DEFAULT_LAYERS)?;
    #[allow(clippy::cast_possible_truncation)]
    let gamma = args.gamma as f32;
    let schedule = Schedule {
        gamma,
        gate: GateShape::default(),
        ..schedule
    };
    let design = Design::new(rig.sensor(setup.range_m), schedule, DEFAULT_CELLS_PER_SIDE)
        .map_err(|e| e.to_string())?;
    Ok((gamma, design))
}

/// Runs `setup`'s recording through a board's soft-gated pyramid of each of `designs`
/// (`setup.range_m` is not read), all in one pass.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn run(
    setup: &StairsSetup,
    designs: &[BoardDesign],
    classifier: &ClassifierConfig,
) -> Result<Vec<OnBoard>, String> {
    let scene_config = setup.scene_config();
    let (decoded, _) = setup.decoded(classifier)?;
    let watched = Watched::of(&scene_config);
    let mut fits = Vec::new();
    let mut maps: Vec<Box<dyn Map>> = Vec::new();
    for &designed in designs {
        let (gamma, design) = match designed {
            BoardDesign::Boot => {
                let design = firmware_design()?;
                (design.schedule().gamma, design)
            }
            BoardDesign::Fitted(range_m) => fitted(&StairsSetup { range_m, ..*setup })?,
        };
        fits.push((gamma, design.layers().len()));
        maps.push(Box::new(Runner::<
            DEFAULT_CELLS_PER_SIDE,
            DEFAULT_LAYERS,
            DEFAULT_CLASSIFIER_SLOTS,
        >::new(
            "board",
            design,
            Config::default(),
            decoded.frontend,
        )?));
    }
    let pass = stairs::watch(
        &decoded,
        &mut maps,
        &watched,
        packets_per_check(&decoded),
        false,
        |_, _| {},
    );
    Ok(maps
        .iter()
        .zip(fits)
        .enumerate()
        .map(|(k, (map, (gamma, layers)))| {
            let result = watched.result(map.as_ref(), &pass, k);
            OnBoard {
                gamma,
                layers,
                at_stop: result.detected_fraction,
                at_arrival: result.arrived_fraction,
                first_seen_m: result.detect_distance_m,
                false_obstacles: result.false_obstacle_fraction,
                ground_at_first_sight: result.false_obstacle_at_first_sight,
                dropped: map.dropped(),
            }
        })
        .collect())
}

/// A rig on a board with one design: its nod's phases.
#[derive(Debug, Clone, Serialize)]
pub struct BoardRig {
    /// The rig's name.
    pub rig: &'static str,
    /// The design.
    pub design: BoardDesign,
    /// Distance from the standing place to the first riser, metres: the rig's own range less
    /// 0.95 m, as in the rig table, whatever the design's range.
    pub stand_distance_m: f64,
    /// One row per phase of the nod after 120 s of standing ([`PHASES`]; the first alone
    /// with `quick`).
    pub phases: Vec<OnBoard>,
    /// The same phases [`LONG_STAND_NODS`] nods later (empty with `quick`): row i differs
    /// from `phases`' row i in the standing alone.
    pub phases_long: Vec<OnBoard>,
}

/// Every rig on a board, with its boot design and with its own fitted to every range of
/// [`RANGES_M`], the approach started at the nod's phases after 120 s of standing.
///
/// # Errors
/// As [`run`].
pub fn run_rigs(
    quick: bool,
    seed: u64,
    classifier: &ClassifierConfig,
) -> Result<Vec<BoardRig>, String> {
    let phases = if quick { 1 } else { PHASES };
    let mut out = Vec::new();
    for (kind, name) in BOARD_RIGS {
        let (_, own) = kind.range_m();
        let designs: Vec<BoardDesign> = core::iter::once(BoardDesign::Boot)
            .chain(
                RANGES_M
                    .iter()
                    .map(|r| BoardDesign::Fitted(r.unwrap_or(own))),
            )
            .collect();
        // Row i: phase i's runs, one per range.
        let rows_after = |from: f64, count: usize| {
            #[allow(clippy::cast_precision_loss)]
            (0..count)
                .map(|i| {
                    let t = from + nod_period_s(kind) * i as f64 / PHASES as f64;
                    let setup = StairsSetup {
                        stand_s: (t * 1000.0).round() / 1000.0,
                        seed,
                        kind,
                        stand_distance_m: own - 0.95,
                        ..StairsSetup::FULL
                    };
                    run(&setup, &designs, classifier)
                })
                .collect::<Result<Vec<_>, _>>()
        };
        let rows = rows_after(120.0, phases)?;
        let long = if quick {
            Vec::new()
        } else {
            rows_after(
                120.0 + f64::from(LONG_STAND_NODS) * nod_period_s(kind),
                PHASES,
            )?
        };
        let column = |rows: &[Vec<OnBoard>], j: usize| -> Vec<OnBoard> {
            rows.iter().filter_map(|row| row.get(j).copied()).collect()
        };
        for (j, &design) in designs.iter().enumerate() {
            out.push(BoardRig {
                rig: name,
                design,
                stand_distance_m: own - 0.95,
                phases: column(&rows, j),
                phases_long: column(&long, j),
            });
        }
    }
    Ok(out)
}

/// The smallest and largest of `v`, formatted by `f`, or "–" when empty.
fn span(v: &[f64], f: impl Fn(f64) -> String) -> String {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if v.is_empty() {
        "–".to_string()
    } else if (hi - lo).abs() < 1e-9 {
        f(lo)
    } else {
        format!("{}–{}", f(lo), f(hi))
    }
}

/// What standing [`LONG_STAND_NODS`] nods longer did at the same phases: "lower N; nearer
/// M" (or "–" without long rows).
fn longer(r: &BoardRig) -> String {
    if r.phases_long.is_empty() {
        return "–".to_string();
    }
    let pairs = || r.phases.iter().zip(&r.phases_long);
    let lower = pairs().filter(|(a, b)| b.at_arrival < a.at_arrival).count();
    let nearer = pairs()
        .filter(|(a, b)| match (a.first_seen_m, b.first_seen_m) {
            (Some(x), Some(y)) => y < x - 0.1,
            (Some(_), None) => true,
            _ => false,
        })
        .count();
    format!("{lower} of {}; {nearer}", r.phases_long.len())
}

/// Appends the board table to `s`.
pub fn report(s: &mut String, rows: &[BoardRig]) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "On a board: the same rigs and approach through the soft-gated pyramid a board holds ({} layers of {}² cells, {} classifier slots: the `qemu-mps2` and `stm32f4` firmware), with the design it boots with (until the host sends a Configure: `pyramid listen` sends a rig file's `[design]`) or with the rig's design at the range given and the smallest γ (in steps of 0.5 from 2) that fits (`pyramid design --fit-layers 8`); the nod's phases after 120 s. Step cells obstacle at arrival in the map a device shows, and with the observation in progress flushed into it, where the first step was first seen (the phases meeting 95 % and 4 m), the most flat ground before the stairs obstacle at the stop and 0.5–2.5 m before the first riser when the first step was first seen, the point additions the classifier's scratch dropped, and the phases where standing {} nods longer lowered the step cells at arrival or brought the first sighting more than 0.1 m nearer.\n\n| rig | design | γ, layers | step cells at arrival (≥ 95 %) | flushed (≥ 95 %) | first step seen (≥ 4 m) | false obstacles at the stop | ground at first sight | dropped | standing longer: lower at arrival; seen nearer |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        BOARD.0, BOARD.1, BOARD.2, LONG_STAND_NODS
    );
    for r in rows {
        let at_stop: Vec<f64> = r.phases.iter().map(|p| p.at_stop).collect();
        let at_arrival: Vec<f64> = r.phases.iter().map(|p| p.at_arrival).collect();
        let met_arrival = at_arrival.iter().filter(|&&v| v >= 0.95).count();
        let seen: Vec<f64> = r.phases.iter().filter_map(|p| p.first_seen_m).collect();
        let never = r.phases.len() - seen.len();
        let met = at_stop.iter().filter(|&&v| v >= 0.95).count();
        let far = seen.iter().filter(|&&d| d >= 4.0).count();
        let worst = |v: Vec<f64>| v.into_iter().fold(0.0_f64, f64::max);
        let (gamma, layers) = r.phases.first().map_or((0.0, 0), |p| (p.gamma, p.layers));
        let n = r.phases.len();
        let never = if never > 0 {
            format!(", never in {never}")
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| {} | {} | {gamma}, {layers} | {} ({met_arrival} of {n}) | {} ({met} of {n}) | {}{never} ({far} of {n}) | ≤ {} | ≤ {} | {} | {} |",
            r.rig,
            match r.design {
                BoardDesign::Boot => "boot (SICK's φ 0.5°, 10 m)".to_string(),
                BoardDesign::Fitted(range_m) => format!("rig's, {range_m:.0} m"),
            },
            span(&at_arrival, pct),
            span(&at_stop, pct),
            span(&seen, |d| format!("{d:.2} m")),
            pct(worst(r.phases.iter().map(|p| p.false_obstacles).collect())),
            pct(worst(
                r.phases
                    .iter()
                    .filter_map(|p| p.ground_at_first_sight)
                    .collect()
            )),
            r.phases
                .iter()
                .chain(&r.phases_long)
                .map(|p| p.dropped)
                .sum::<u64>(),
            longer(r),
        );
    }
    let _ = writeln!(s);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::lidar::{nod_period_s, PHASES};

    #[test]
    fn every_rig_s_design_fits_a_board_at_some_gamma() {
        for (kind, _) in BOARD_RIGS {
            let (_, range) = kind.range_m();
            let setup = StairsSetup {
                kind,
                range_m: range,
                ..StairsSetup::FULL
            };
            let (gamma, design) = fitted(&setup).unwrap();
            assert!(design.layers().len() <= BOARD.0);
            // The next smaller γ does not fit, unless γ is the schedule's own.
            if gamma > Schedule::default().gamma {
                let smaller = Schedule {
                    gamma: gamma - 0.5,
                    ..Schedule::default()
                };
                let sensor = Ld19Design::for_kind(kind).sensor(range);
                assert!(
                    Design::<DEFAULT_LAYERS>::new(sensor, smaller, DEFAULT_CELLS_PER_SIDE).is_err()
                );
            }
        }
        assert_eq!(
            fitted(&StairsSetup {
                kind: LidarKind::Ld19,
                ..StairsSetup::FULL
            })
            .unwrap()
            .0,
            6.0
        );
    }

    #[test]
    fn the_nodding_example_rig_is_the_ld19_rig_measured_here_with_its_8_m_design() {
        use crate::experiments::lidar::{HEIGHT_M, SERVO};
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../examples/rigs/ld19-nodding.toml");
        let rig = terrain_pyramid_host::rigfile::read_rig_file(&path).unwrap();
        let servo = rig.actuator.servo.unwrap();
        assert_eq!(
            (
                servo.min_deg,
                servo.max_deg,
                servo.rate_deg_s,
                servo.latency_ms
            ),
            SERVO
        );
        assert!((rig.mount.xyz_m[2] - HEIGHT_M).abs() < 1e-12);
        let (gamma, design) = rig.design.unwrap().design(DEFAULT_CELLS_PER_SIDE).unwrap();
        let (lab_gamma, lab_design) = fitted(&StairsSetup {
            kind: LidarKind::Ld19,
            range_m: 8.0,
            ..StairsSetup::FULL
        })
        .unwrap();
        assert!((gamma - f64::from(lab_gamma)).abs() < 1e-9);
        assert_eq!(design.layers(), lab_design.layers());
        assert_eq!(design.sensor(), lab_design.sensor());
    }

    /// Prints every rig's 8 phases after 120 s on a board, with the boot design and the rig's
    /// fitted to `ON_BOARD_RANGE_M` (default the rig's range), standing `ON_BOARD_STAND_M`
    /// away (default that range less 0.95 m), `ON_BOARD_RPO` revolutions an observation
    /// (default 0: one per sweep; 1 was the rig file's default for a lidar until 2026-12-06),
    /// (every rig of [`BOARD_RIGS`]); `ON_BOARD_SEED`
    /// the simulator's seed, `ON_BOARD_LONGER_NODS` whole nods more of standing (the
    /// experiments' `phases_long` stand 60 more).
    #[test]
    #[ignore = "a diagnostic, a minute long: run by hand"]
    fn on_board_phases() {
        use crate::experiments::stairs_diag::env_or;
        let classifier = ClassifierConfig::default();
        for (kind, name) in BOARD_RIGS {
            let (_, full) = kind.range_m();
            let range = env_or("ON_BOARD_RANGE_M", full);
            #[allow(clippy::cast_precision_loss)]
            for i in 0..PHASES {
                let longer = env_or("ON_BOARD_LONGER_NODS", 0.0);
                let stand_s = 120.0 + nod_period_s(kind) * (longer + i as f64 / PHASES as f64);
                let setup = StairsSetup {
                    stand_s: (stand_s * 1000.0).round() / 1000.0,
                    kind,
                    seed: env_or("ON_BOARD_SEED", StairsSetup::FULL.seed),
                    stand_distance_m: env_or("ON_BOARD_STAND_M", full - 0.95),
                    revolutions_per_observation: env_or("ON_BOARD_RPO", 0),
                    ..StairsSetup::FULL
                };
                let r = run(
                    &setup,
                    &[BoardDesign::Boot, BoardDesign::Fitted(range)],
                    &classifier,
                )
                .unwrap();
                println!("{name} {:.3} s: {r:?}", setup.stand_s);
            }
        }
    }
}
