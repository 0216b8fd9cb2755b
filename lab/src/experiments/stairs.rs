//! The stairs experiment (the paper's Figures 5-7): the robot stands in front of a flight of
//! stairs for minutes, then drives up to 1.0 m from the first step. Four maps see the same
//! recording: the flat grid without clamping (the paper's "standard evidence grid"), the flat
//! grid with OctoMap's clamping, and the pyramid (every layer at 0.1 m, only the range banding
//! differs from the flat grid, as in the paper) with the hard and with the soft gate.

use super::designs;
use super::engine::{decode, Decoded, Map, Runner};
use super::picture::{self, Panel, Region};
use serde::Serialize;
use std::path::Path;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::wire::sick::Unit;
use terrain_pyramid::{Fused, GateShape};
use terrain_pyramid_host_tests::sim::laser::{Actuator, LaserConfig};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
use terrain_pyramid_host_tests::sim::scene::{GroundTruthSpec, Scene, StairsSpec};
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// Window of the stairs maps, cells per side: holds a 24 m band at 0.1 m (2 · 24 / 0.1 + 2). The same as the stairs
/// firmware's (`boards/qemu-mps2 --features paper-stairs`), so that the two run the same maps.
pub const CELLS: usize = 488;
/// Layer capacity of the uniform pyramid (the linear schedule needs 32 layers for 24 m).
pub const LAYERS: usize = 48;
/// Classifier slots: a soft-gated point feeds several 0.1 m layers at once.
pub const SLOTS: usize = 16_384;
/// The cell of every stairs map, metres.
pub const CELL_M: f64 = 0.1;
/// The share of the first riser's cells that must be obstacle for "the first step is seen".
pub const FIRST_STEP_SHARE: f64 = 0.5;

/// The experiment's settings.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Setup {
    /// Distance from the robot's standing place to the first riser, metres.
    pub stand_distance_m: f64,
    /// Seconds the robot stands there.
    pub stand_s: f64,
    /// Driving speed, m/s.
    pub speed_mps: f64,
    /// Where the robot stops: this far from the first riser, metres.
    pub stop_distance_m: f64,
    /// The maps' (and the laser's) maximum range, metres.
    pub range_m: f64,
    /// The laser's unit: "mm" (8.19 m mode) or "cm" (81.9 m mode).
    pub unit: &'static str,
    /// The pan rate, degrees per second (the sweep is ±45°). The simulator's default, 75°/s,
    /// puts the 0.5° lines (37.5 per second) exactly 2° apart, so that every sweep repeats the
    /// same 46 pan angles forever and a robot standing still only ever sees the same few
    /// cells far away. A real pan unit is not locked to the laser's mirror; 74°/s
    /// (ψ = 1.97°) lets successive sweeps interleave, as the paper's robot standing "for
    /// several minutes" did.
    pub pan_rate_deg_s: f64,
    /// The simulator's seed.
    pub seed: u64,
    /// The classifier's thresholds and navigability rule, for every map (`--rule`).
    #[serde(skip)]
    pub classifier: ClassifierConfig,
}

impl Setup {
    /// The full experiment: 20 m from the stairs for 3 minutes, maps out to 24 m (32 layers of
    /// 488² cells: what the stairs firmware holds in the emulated board's 16 MiB of PSRAM).
    pub const FULL: Self = Self {
        stand_distance_m: 20.05,
        stand_s: 180.0,
        speed_mps: 1.0,
        stop_distance_m: 1.0,
        range_m: 24.0,
        unit: "cm",
        pan_rate_deg_s: 74.0,
        seed: 1,
        classifier: ClassifierConfig::DEFAULT,
    };

    /// `--quick`: the same place, 2 minutes of standing.
    pub const QUICK: Self = Self {
        stand_s: 120.0,
        ..Self::FULL
    };

    /// The simulator's configuration for this setup.
    pub fn sim(&self) -> SimConfig {
        let spec = StairsSpec {
            first_riser_x: self.stand_distance_m,
            ..StairsSpec::default()
        };
        let laser = LaserConfig {
            unit: if self.unit == "cm" {
                Unit::Centimetre
            } else {
                Unit::Millimetre
            },
            max_range_m: Some(self.range_m),
            actuator: Actuator::Pan {
                half_width_deg: 45.0,
                rate_deg_s: self.pan_rate_deg_s,
            },
            ..LaserConfig::paper()
        };
        let mut sim = SimConfig::new(
            Scene::stairs(spec),
            laser,
            Trajectory::approach(
                self.stand_s,
                self.speed_mps,
                spec.first_riser_x,
                self.stop_distance_m,
            ),
        );
        sim.seed = self.seed;
        sim.truth = GroundTruthSpec {
            cell_m: CELL_M,
            x_min: spec.first_riser_x - 0.5,
            x_max: spec.riser_x(spec.steps - 1) + 0.5,
            y_min: -0.5 * spec.width_m - 0.5,
            y_max: 0.5 * spec.width_m + 0.5,
            ..GroundTruthSpec::default()
        };
        sim
    }
}

/// What the fused query says about a set of cells.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct Shares {
    /// Share of the cells marked obstacle.
    pub obstacle: f64,
    /// Share marked navigable.
    pub free: f64,
    /// Share unknown.
    pub unknown: f64,
}

/// One map's result.
#[derive(Debug, Clone, Serialize)]
pub struct MapResult {
    /// Share of the step cells marked obstacle when the robot is at the stop (1.0 m).
    pub detected_fraction: f64,
    /// Distance from the robot to the first riser when at least half of the first riser's
    /// cells first became obstacle, metres; null when never.
    pub detect_distance_m: Option<f64>,
    /// The step cells at the end of standing (far away).
    pub far: Shares,
    /// The step cells at the stop.
    pub near: Shares,
    /// The first riser's cells at the stop.
    pub first_step_near: Shares,
    /// Share of the flat ground before the stairs (|y| ≤ 1.5 m, up to 0.5 m before the first
    /// riser) marked obstacle at the stop: false obstacles.
    pub false_obstacle_fraction: f64,
    /// Evidence records the pipeline produced.
    pub records: u64,
    /// Records that changed a cell.
    pub applied: u64,
    /// Layers of the map.
    pub layers: usize,
    /// (distance to the first riser, share of step cells obstacle) while driving.
    #[serde(skip)]
    pub series: Vec<(f64, f64)>,
    /// The map at the end of the run, for comparison with the firmware's.
    #[serde(skip)]
    pub final_map: Option<terrain_pyramid_host::export::MapSnapshot>,
}

/// The experiment's result.
#[derive(Debug, Clone, Serialize)]
pub struct StairsResult {
    /// The flat grid, no clamping (the paper's baseline).
    pub flat: MapResult,
    /// The flat grid with OctoMap's clamping (−2 ..= 3.5 nats).
    pub flat_clamped: MapResult,
    /// The pyramid, every layer at 0.1 m, hard gate, no clamping.
    pub pyramid: MapResult,
    /// The same with the paper's soft gate.
    pub pyramid_soft: MapResult,
    /// The settings.
    pub setup: Setup,
    /// Step cells (the risers' cells, from the simulator's ground truth).
    pub step_cells: usize,
    /// Lines in the recording.
    pub lines: usize,
}

/// A world cell index at 0.1 m.
pub type Cell = (i32, i32);

/// The step cells: the simulator's obstacle cells on the risers' lines (world cell indices).
pub fn step_cells(sim: &SimConfig) -> (Vec<Cell>, Vec<Cell>) {
    let truth = sim.scene.obstacle_cells(&sim.truth);
    let spec = StairsSpec {
        first_riser_x: sim.scene.target_x.unwrap_or(0.0),
        ..StairsSpec::default()
    };
    #[allow(clippy::cast_possible_truncation)]
    let riser_ix: Vec<i32> = (0..spec.steps)
        .map(|i| (spec.riser_x(i) / CELL_M).floor() as i32)
        .collect();
    let half = 0.5 * spec.width_m;
    #[allow(clippy::cast_possible_truncation)]
    let (lo, hi) = (
        (-half / CELL_M).floor() as i32,
        (half / CELL_M).floor() as i32,
    );
    let steps: Vec<(i32, i32)> = truth
        .iter()
        .filter(|c| riser_ix.contains(&c.ix) && (lo..=hi).contains(&c.iy))
        .map(|c| (c.ix, c.iy))
        .collect();
    let first = steps
        .iter()
        .copied()
        .filter(|c| Some(&c.0) == riser_ix.first())
        .collect();
    (steps, first)
}

fn centre(c: (i32, i32)) -> (f64, f64) {
    (
        (f64::from(c.0) + 0.5) * CELL_M,
        (f64::from(c.1) + 0.5) * CELL_M,
    )
}

/// The fused answers over `cells`.
pub fn shares(map: &dyn Map, cells: &[(i32, i32)]) -> Shares {
    shares_by(|x, y| map.fused(x, y), cells)
}

/// The answers of `fused` (a fused query at world point x, y, metres) at the centres of
/// `cells`.
pub fn shares_by(fused: impl Fn(f64, f64) -> Fused, cells: &[(i32, i32)]) -> Shares {
    let mut s = Shares::default();
    if cells.is_empty() {
        return s;
    }
    for &c in cells {
        let (x, y) = centre(c);
        match fused(x, y) {
            Fused::Obstacle { .. } => s.obstacle += 1.0,
            Fused::Navigable { .. } => s.free += 1.0,
            Fused::Unknown => s.unknown += 1.0,
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let n = cells.len() as f64;
    Shares {
        obstacle: s.obstacle / n,
        free: s.free / n,
        unknown: s.unknown / n,
    }
}

fn maps(decoded: &Decoded, range_m: f64) -> Result<Vec<Box<dyn Map>>, String> {
    #[allow(clippy::cast_possible_truncation)]
    let r = range_m as f32;
    #[allow(clippy::cast_possible_truncation)]
    let cell = CELL_M as f32;
    let off = designs::unclamped();
    let clamped = designs::octomap_clamped();
    let fc = decoded.frontend;
    let e = |e: terrain_pyramid::DesignError| e.to_string();
    Ok(vec![
        Box::new(Runner::<CELLS, 1, SLOTS>::new(
            "flat",
            designs::flat(r, cell, CELLS).map_err(e)?,
            off,
            fc,
        )?),
        Box::new(Runner::<CELLS, 1, SLOTS>::new(
            "flat_clamped",
            designs::flat(r, cell, CELLS).map_err(e)?,
            clamped,
            fc,
        )?),
        Box::new(Runner::<CELLS, LAYERS, SLOTS>::new(
            "pyramid",
            designs::pyramid(r, GateShape::Hard, true, CELLS).map_err(e)?,
            off,
            fc,
        )?),
        Box::new(Runner::<CELLS, LAYERS, SLOTS>::new(
            "pyramid_soft",
            designs::pyramid(r, GateShape::default(), true, CELLS).map_err(e)?,
            off,
            fc,
        )?),
    ])
}

/// Runs the experiment; writes the pictures into `out` when given.
///
/// # Errors
/// The simulator or the library refused the setup, or a picture could not be written.
pub fn run(setup: &Setup, out: Option<&Path>) -> Result<StairsResult, String> {
    let sim_config = setup.sim();
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let decoded = decode(&sim.bytes, &setup.classifier)?;
    let (steps, first) = step_cells(&sim_config);
    let riser_x = sim_config.scene.target_x.unwrap_or(0.0);
    let mut maps = maps(&decoded, setup.range_m)?;
    let per = decoded.frontend.lines_per_observation.max(1) as usize;
    let drive_start_us = (sim_config.trajectory.drive_start_s() * 1e6).round();
    let n = maps.len();
    let mut detect: Vec<Option<f64>> = vec![None; n];
    let mut far: Vec<Shares> = vec![Shares::default(); n];
    let mut series: Vec<Vec<(f64, f64)>> = vec![Vec::new(); n];
    let mut far_panels: Vec<Panel> = Vec::new();
    let region = Region {
        x0: riser_x - 6.05,
        y0: -3.0,
        x1: riser_x + 2.45,
        y1: 3.0,
        cell: CELL_M,
    };
    // Flat ground before the stairs, |y| ≤ 1.5 m, from the start to 0.5 m before the first
    // riser: no cell there is an obstacle.
    #[allow(clippy::cast_possible_truncation)]
    let ground: Vec<(i32, i32)> = (0..((riser_x - 0.5) / CELL_M).floor() as i32)
        .flat_map(|ix| (-15..15).map(move |iy| (ix, iy)))
        .collect();
    let mut standing_done = false;
    let count = decoded.lines.len();
    for (i, line) in decoded.lines.iter().enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let driving = line.time_us as f64 >= drive_start_us;
        if driving && !standing_done {
            // The end of standing: the far picture (Fig. 5).
            standing_done = true;
            for (k, map) in maps.iter_mut().enumerate() {
                far[k] = shares(map.as_ref(), &steps);
                far_panels.push(picture::panel(map.as_ref(), &region, line.robot_xy, &steps));
            }
        }
        for map in &mut maps {
            map.line(line);
        }
        let last = i + 1 == count;
        if last {
            for map in &mut maps {
                map.flush();
            }
        }
        if (i + 1) % per == 0 || last {
            let distance = riser_x - line.robot_xy.0;
            for (k, map) in maps.iter().enumerate() {
                if detect[k].is_none() && shares(map.as_ref(), &first).obstacle >= FIRST_STEP_SHARE
                {
                    detect[k] = Some(round3(distance));
                }
                if driving {
                    series[k].push((distance, shares(map.as_ref(), &steps).obstacle));
                }
            }
        }
    }
    let robot = decoded.lines.last().map_or((0.0, 0.0), |l| l.robot_xy);
    let mut results = Vec::new();
    let mut near_panels = Vec::new();
    for (k, map) in maps.iter().enumerate() {
        let near = shares(map.as_ref(), &steps);
        let false_obstacle = shares(map.as_ref(), &ground).obstacle;
        let stats = map.stats();
        results.push(MapResult {
            detected_fraction: round4(near.obstacle),
            detect_distance_m: detect[k],
            far: far[k],
            near,
            first_step_near: shares(map.as_ref(), &first),
            false_obstacle_fraction: round4(false_obstacle),
            records: map.records(),
            applied: u64::from(stats.applied),
            layers: map.layer_count(),
            series: std::mem::take(&mut series[k]),
            final_map: Some(map.snapshot(robot)),
        });
        near_panels.push(picture::panel(map.as_ref(), &region, robot, &steps));
    }
    if let Some(dir) = out {
        let names = [
            "flat grid, no clamping",
            "flat grid, OctoMap clamping",
            "pyramid (0.1 m), hard gate",
            "pyramid (0.1 m), soft gate",
        ];
        let mut panels = Vec::new();
        for (k, name) in names.iter().enumerate() {
            let mut p = far_panels.get(k).cloned().unwrap_or_default();
            p.title = format!("{name}: after {:.0} s at {:.2} m", setup.stand_s, riser_x);
            panels.push(p);
        }
        for (k, name) in names.iter().enumerate() {
            let mut p = near_panels.get(k).cloned().unwrap_or_default();
            p.title = format!(
                "{name}: at {:.1} m, {:.0} % of step cells obstacle",
                setup.stop_distance_m,
                100.0 * results.get(k).map_or(0.0, |r| r.detected_fraction)
            );
            panels.push(p);
        }
        picture::draw_panels(
            &dir.join("stairs.png"),
            "Stairs (Figs 5-7): standing far (top), at 1.0 m from the first step (bottom); step cells outlined in blue",
            &panels,
            4,
        )?;
        let curves: Vec<(String, Vec<(f64, f64)>)> = names
            .iter()
            .zip(&results)
            .map(|(n, r)| ((*n).to_string(), r.series.clone()))
            .collect();
        picture::draw_curves(
            &dir.join("stairs-detection.png"),
            "Share of step cells marked obstacle while driving up to the stairs",
            "distance to the first step, m",
            "share of step cells obstacle",
            &curves,
        )?;
    }
    let mut it = results.into_iter();
    let mut next = || it.next().ok_or_else(|| "missing map".to_string());
    Ok(StairsResult {
        flat: next()?,
        flat_clamped: next()?,
        pyramid: next()?,
        pyramid_soft: next()?,
        setup: *setup,
        step_cells: steps.len(),
        lines: count,
    })
}

/// Writes the stairs recording of `setup` (the paper's robot in front of the stairs, then
/// driving up to them) to `path`, for `lab demo`. Returns the number of lines.
///
/// # Errors
/// The simulator refused the setup, or the file could not be written.
pub fn write_recording(setup: &Setup, path: &Path) -> Result<u32, String> {
    let sim = simulate(&setup.sim()).map_err(|e| e.to_string())?;
    terrain_pyramid_host::export::write_file(path, &sim.bytes)?;
    Ok(sim.lines)
}

/// Rounded to 1 mm.
pub fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Rounded to 4 decimals.
pub fn round4(v: f64) -> f64 {
    (v * 10_000.0).round() / 10_000.0
}
