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
use terrain_pyramid::{Config, Design, DesignError, Fused, GateShape};
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
        let mut sim = approach_config(
            self.stand_distance_m,
            self.stand_s,
            self.speed_mps,
            self.stop_distance_m,
            laser,
        );
        sim.seed = self.seed;
        sim
    }
}

/// A run in front of the default stairs seen by `laser`: standing `stand_distance_m` metres
/// from the first riser for `stand_s` seconds, then driving at `speed_mps` (m/s) up to
/// `stop_distance_m` metres before it. The ground truth covers the stairs at [`CELL_M`] with
/// 0.5 m to spare on every side; the seed is the simulator's default.
pub fn approach_config(
    stand_distance_m: f64,
    stand_s: f64,
    speed_mps: f64,
    stop_distance_m: f64,
    laser: LaserConfig,
) -> SimConfig {
    let spec = StairsSpec {
        first_riser_x: stand_distance_m,
        ..StairsSpec::default()
    };
    let mut sim = SimConfig::new(
        Scene::stairs(spec),
        laser,
        Trajectory::approach(stand_s, speed_mps, spec.first_riser_x, stop_distance_m),
    );
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
    /// Share of the step cells marked obstacle when the robot is at the stop (1.0 m), the
    /// observation in progress flushed into the map.
    pub detected_fraction: f64,
    /// Share of the step cells marked obstacle in the map a device shows at the stop: the
    /// observations ended on or before the arrival's line, without the one in progress (a
    /// device ends an observation only when its actuator turns or its revolutions are counted,
    /// never on arrival).
    pub arrived_fraction: f64,
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
    /// riser) marked obstacle at the stop, the observation in progress flushed into the map:
    /// false obstacles.
    pub false_obstacle_fraction: f64,
    /// The same ground's share marked obstacle in the map a device shows at the stop (as
    /// [`MapResult::arrived_fraction`]): the false obstacles a robot arriving would meet.
    pub arrived_false_obstacle_fraction: f64,
    /// Share of the flat ground 0.5–2.5 m before the first riser (|y| ≤ 1.5 m) marked obstacle
    /// when the first step was first seen: how much of the sighting is a coarse cell that
    /// also covers the ground before the stairs; null when never seen.
    pub false_obstacle_at_first_sight: Option<f64>,
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

impl StairsResult {
    /// The four maps, in the order the report names them: the flat grid, the clamped flat
    /// grid, the pyramid with the hard gate and with the soft one.
    #[must_use]
    pub const fn maps(&self) -> [&MapResult; 4] {
        [
            &self.flat,
            &self.flat_clamped,
            &self.pyramid,
            &self.pyramid_soft,
        ]
    }
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

/// The four maps of a stairs run, in this order: the flat grid without clamping
/// ("flat"), the flat grid with OctoMap's clamping ("flat_clamped"), and the pyramid `pyramid`
/// designs for a gate, with the hard gate ("pyramid") and the soft one ("pyramid_soft"), both
/// in `pyramid_config` (the paper's stairs: [`designs::unclamped`], the paper's baseline; the
/// nodding rigs: the library's default). Every map has windows of `W` cells a side at
/// [`CELL_M`], reaches `range_m` metres and has [`SLOTS`] classifier slots; the pyramids hold
/// at most `L` layers.
///
/// # Errors
/// The library refused a design or a configuration.
pub fn four_maps<const W: usize, const L: usize>(
    decoded: &Decoded,
    range_m: f64,
    pyramid: impl Fn(GateShape) -> Result<Design<L>, DesignError>,
    pyramid_config: Config,
) -> Result<Vec<Box<dyn Map>>, String> {
    #[allow(clippy::cast_possible_truncation)]
    let (range, cell) = (range_m as f32, CELL_M as f32);
    let off = designs::unclamped();
    let clamped = designs::octomap_clamped();
    let fc = decoded.frontend;
    let e = |e: DesignError| e.to_string();
    let flat = |name: &str, config| -> Result<Box<dyn Map>, String> {
        let design = designs::flat(range, cell, W).map_err(e)?;
        Ok(Box::new(Runner::<W, 1, SLOTS>::new(
            name, design, config, fc,
        )?))
    };
    let gated = |name: &str, gate| -> Result<Box<dyn Map>, String> {
        let design = pyramid(gate).map_err(e)?;
        Ok(Box::new(Runner::<W, L, SLOTS>::new(
            name,
            design,
            pyramid_config,
            fc,
        )?))
    };
    Ok(vec![
        flat("flat", off)?,
        flat("flat_clamped", clamped)?,
        gated("pyramid", GateShape::Hard)?,
        gated("pyramid_soft", GateShape::default())?,
    ])
}

/// The four results of [`four_maps`], in their order.
///
/// # Errors
/// There are not exactly four.
pub fn four<T>(results: Vec<T>) -> Result<[T; 4], String> {
    results.try_into().map_err(|_| "missing map".to_string())
}

/// The cells and the moment a stairs run is measured by, from its simulator configuration.
#[derive(Debug, Clone)]
pub struct Watched {
    /// The first riser's x, metres.
    pub riser_x: f64,
    /// The step cells (world cell indices at [`CELL_M`]).
    pub steps: Vec<Cell>,
    /// The first riser's cells.
    pub first: Vec<Cell>,
    /// The flat ground before the stairs, |y| ≤ 1.5 m, from x = 0 to 0.5 m before the first
    /// riser: no cell there is an obstacle.
    pub ground: Vec<Cell>,
    /// The part of [`Watched::ground`] within 2.5 m of the first riser.
    pub ground_before: Vec<Cell>,
    /// When the robot starts driving, microseconds of the recording's clock (whole).
    pub drive_start_us: f64,
}

impl Watched {
    /// The step cells, the ground and the start of driving of the run `sim`.
    pub fn of(sim: &SimConfig) -> Self {
        let (steps, first) = step_cells(sim);
        let riser_x = sim.scene.target_x.unwrap_or(0.0);
        #[allow(clippy::cast_possible_truncation)]
        let ground: Vec<Cell> = (0..((riser_x - 0.5) / CELL_M).floor() as i32)
            .flat_map(|ix| (-15..15).map(move |iy| (ix, iy)))
            .collect();
        #[allow(clippy::cast_possible_truncation)]
        let from = ((riser_x - 2.5) / CELL_M).floor() as i32;
        let ground_before = ground.iter().copied().filter(|c| c.0 >= from).collect();
        Self {
            riser_x,
            steps,
            first,
            ground,
            ground_before,
            drive_start_us: (sim.trajectory.drive_start_s() * 1e6).round(),
        }
    }

    /// The pictures' region: 6 m before the first riser to 2.5 m past it, |y| ≤ 3 m, at
    /// [`CELL_M`].
    pub fn region(&self) -> Region {
        Region {
            x0: self.riser_x - 6.05,
            y0: -3.0,
            x1: self.riser_x + 2.45,
            y1: 3.0,
            cell: CELL_M,
        }
    }

    /// What `map` (map `k` of `pass`) shows at the end of a run: the step cells' shares and
    /// the false obstacles (rounded to 4 decimals), the first riser's shares and the
    /// pipeline's counts, with the pass's detection distance, ground at that moment and `far`
    /// shares. No series and no final map.
    pub fn result(&self, map: &dyn Map, pass: &Pass, k: usize) -> MapResult {
        let detect_distance_m = pass.detect.get(k).copied().flatten();
        let far = pass.far.get(k).copied().unwrap_or_default();
        let near = shares(map, &self.steps);
        let arrived = pass.arrived.get(k).copied().unwrap_or_default();
        MapResult {
            detected_fraction: round4(near.obstacle),
            arrived_fraction: round4(arrived.steps.obstacle),
            detect_distance_m,
            far,
            near,
            first_step_near: shares(map, &self.first),
            false_obstacle_fraction: round4(shares(map, &self.ground).obstacle),
            arrived_false_obstacle_fraction: round4(arrived.ground.obstacle),
            false_obstacle_at_first_sight: pass.ground_at_detect.get(k).copied().flatten(),
            records: map.records(),
            applied: u64::from(map.stats().applied),
            layers: map.layer_count(),
            series: Vec::new(),
            final_map: None,
        }
    }
}

/// What one pass over a stairs recording saw, one entry a map.
#[derive(Debug, Clone)]
pub struct Pass {
    /// Distance to the first riser when the first step was first seen (metres, to 1 mm), or
    /// `None`.
    pub detect: Vec<Option<f64>>,
    /// The share of [`Watched::ground_before`] obstacle at that moment (4 decimals), or `None`.
    pub ground_at_detect: Vec<Option<f64>>,
    /// The step cells' shares at the end of standing.
    pub far: Vec<Shares>,
    /// (distance to the first riser, share of step cells obstacle) while driving; empty
    /// unless the pass was asked for it.
    pub series: Vec<Vec<(f64, f64)>>,
    /// The recording's times (seconds) of the lines on which each map ended an observation
    /// and integrated it (the last line's for the flush at the end).
    pub integrated_s: Vec<Vec<f64>>,
    /// The map a device shows at arrival: after the last line, before the flush.
    pub arrived: Vec<Arrived>,
}

/// What one map shows at arrival ([`Pass::arrived`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Arrived {
    /// The step cells' shares ([`Watched::steps`]).
    pub steps: Shares,
    /// The flat ground's shares ([`Watched::ground`]).
    pub ground: Shares,
}

/// Feeds every line of `decoded` to every map of `maps` (flushing them after the last), and
/// looks at them: once at the end of standing (the far shares, and `at_standing_end` with
/// each map and the robot's position), and after every `check_every` lines and the last
/// (whether the first step is seen, and the series when `series`), and after the last line
/// before the flush (the map a device shows at arrival, [`Pass::arrived`]).
pub fn watch(
    decoded: &Decoded,
    maps: &mut [Box<dyn Map>],
    watched: &Watched,
    check_every: usize,
    series: bool,
    mut at_standing_end: impl FnMut(&dyn Map, (f64, f64)),
) -> Pass {
    let n = maps.len();
    let mut pass = Pass {
        detect: vec![None; n],
        ground_at_detect: vec![None; n],
        far: vec![Shares::default(); n],
        series: vec![Vec::new(); n],
        integrated_s: vec![Vec::new(); n],
        arrived: vec![Arrived::default(); n],
    };
    let mut standing_done = false;
    let count = decoded.lines.len();
    for (i, line) in decoded.lines.iter().enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let driving = line.time_us as f64 >= watched.drive_start_us;
        if driving && !standing_done {
            standing_done = true;
            for (k, map) in maps.iter().enumerate() {
                pass.far[k] = shares(map.as_ref(), &watched.steps);
                at_standing_end(map.as_ref(), line.robot_xy);
            }
        }
        let last = i + 1 == count;
        for ((map, ends), arrived) in maps
            .iter_mut()
            .zip(pass.integrated_s.iter_mut())
            .zip(pass.arrived.iter_mut())
        {
            let before = map.observations();
            map.line(line);
            if last {
                *arrived = Arrived {
                    steps: shares(map.as_ref(), &watched.steps),
                    ground: shares(map.as_ref(), &watched.ground),
                };
                map.flush();
            }
            if map.observations() > before {
                #[allow(clippy::cast_precision_loss)]
                ends.push(line.time_us as f64 * 1e-6);
            }
        }
        if (i + 1) % check_every == 0 || last {
            let distance = watched.riser_x - line.robot_xy.0;
            for (k, map) in maps.iter().enumerate() {
                if pass.detect[k].is_none()
                    && shares(map.as_ref(), &watched.first).obstacle >= FIRST_STEP_SHARE
                {
                    pass.detect[k] = Some(round3(distance));
                    pass.ground_at_detect[k] = Some(round4(
                        shares(map.as_ref(), &watched.ground_before).obstacle,
                    ));
                }
                if driving && series {
                    pass.series[k].push((distance, shares(map.as_ref(), &watched.steps).obstacle));
                }
            }
        }
    }
    pass
}

/// Runs the experiment; writes the pictures into `out` when given.
///
/// # Errors
/// The simulator or the library refused the setup, or a picture could not be written.
pub fn run(setup: &Setup, out: Option<&Path>) -> Result<StairsResult, String> {
    let sim_config = setup.sim();
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let decoded = decode(&sim.bytes, &setup.classifier)?;
    let watched = Watched::of(&sim_config);
    let riser_x = watched.riser_x;
    #[allow(clippy::cast_possible_truncation)]
    let mut maps = four_maps::<CELLS, LAYERS>(
        &decoded,
        setup.range_m,
        |gate| designs::pyramid(setup.range_m as f32, gate, true, CELLS),
        designs::unclamped(),
    )?;
    let per = decoded.frontend.lines_per_observation.max(1) as usize;
    let region = watched.region();
    let mut far_panels: Vec<Panel> = Vec::new();
    let mut pass = watch(&decoded, &mut maps, &watched, per, true, |map, robot_xy| {
        // The end of standing: the far picture (Fig. 5).
        far_panels.push(picture::panel(map, &region, robot_xy, &watched.steps));
    });
    let count = decoded.lines.len();
    let robot = decoded.lines.last().map_or((0.0, 0.0), |l| l.robot_xy);
    let mut results = Vec::new();
    let mut near_panels = Vec::new();
    for (k, map) in maps.iter().enumerate() {
        results.push(MapResult {
            series: std::mem::take(&mut pass.series[k]),
            final_map: Some(map.snapshot(robot)),
            ..watched.result(map.as_ref(), &pass, k)
        });
        near_panels.push(picture::panel(map.as_ref(), &region, robot, &watched.steps));
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
    let [flat, flat_clamped, pyramid, pyramid_soft] = four(results)?;
    Ok(StairsResult {
        flat,
        flat_clamped,
        pyramid,
        pyramid_soft,
        setup: *setup,
        step_cells: watched.steps.len(),
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
