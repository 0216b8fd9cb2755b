//! Coverage (the paper's Figures 8-9) and cost: the robot approaches a gate; a fixed-resolution
//! grid (one layer, 0.1 m) and the multi-resolution pyramid (the default linear schedule, soft
//! gate, the firmware's 8 × 64² windows) see the same recording. Holes are the places within
//! the sensor's reach that the fused query still calls unknown. The cost is the wall-clock
//! time per scan line of each map over the same lines.

use super::designs;
use super::engine::{decode, Decoded, Map, Runner};
use super::picture::{self, Region};
use super::stairs::round4;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{Config, Fused, GateShape, DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// The fixed grid's window: holds 10 m at 0.1 m.
pub const FIXED_CELLS: usize = 256;
/// Classifier slots of both pipelines.
pub const SLOTS: usize = 8192;
/// The sensor's reach counted for holes, metres (the SICK's mm mode ends at 8.19 m).
pub const REACH_M: f64 = 8.0;
/// The rings holes are counted in, metres.
pub const RINGS: [(f64, f64); 4] = [(0.0, 2.0), (2.0, 4.0), (4.0, 6.0), (6.0, 8.0)];
/// Half the pan sweep, degrees: the sensor sees this wedge ahead.
pub const HALF_FIELD_DEG: f64 = 45.0;

/// The experiment's settings.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Setup {
    /// x of the gate, metres (the robot starts at 0).
    pub gate_x: f64,
    /// Seconds standing at the start.
    pub stand_s: f64,
    /// Driving speed, m/s.
    pub speed_mps: f64,
    /// The robot stops this far before the gate, metres.
    pub stop_distance_m: f64,
    /// Timed repetitions of the cost measurement.
    pub repetitions: usize,
    /// The simulator's seed.
    pub seed: u64,
    /// The classifier's thresholds and navigability rule, for every map (`--rule`).
    #[serde(skip)]
    pub classifier: ClassifierConfig,
}

impl Setup {
    /// The full experiment.
    pub const FULL: Self = Self {
        gate_x: 5.05,
        stand_s: 2.4,
        speed_mps: 1.0,
        stop_distance_m: 2.0,
        repetitions: 51,
        seed: 1,
        classifier: ClassifierConfig::DEFAULT,
    };

    /// `--quick`: the same run, fewer timed repetitions.
    pub const QUICK: Self = Self {
        repetitions: 15,
        ..Self::FULL
    };

    /// The simulator's configuration.
    pub fn sim(&self) -> SimConfig {
        let mut sim = SimConfig::new(
            Scene::gate(self.gate_x, 1.5, 2.0),
            LaserConfig::paper(),
            Trajectory::approach(
                self.stand_s,
                self.speed_mps,
                self.gate_x,
                self.stop_distance_m,
            ),
        );
        sim.seed = self.seed;
        sim
    }
}

/// One map's holes.
#[derive(Debug, Clone, Serialize)]
pub struct Holes {
    /// Share of the 0.1 m places within reach that are unknown.
    pub holes_fraction: f64,
    /// The same per ring of distance from the sensor: (inner, outer, share).
    pub rings: Vec<(f64, f64, f64)>,
    /// Places counted.
    pub places: usize,
}

/// The coverage result.
#[derive(Debug, Clone, Serialize)]
pub struct CoverageResult {
    /// The fixed-resolution grid (0.1 m).
    pub fixed: Holes,
    /// The multi-resolution pyramid.
    pub pyramid: Holes,
    /// The settings.
    pub setup: Setup,
}

/// The cost result.
#[derive(Debug, Clone, Serialize)]
pub struct CostResult {
    /// Median wall-clock time per line of the pyramid over that of the single grid.
    pub pyramid_over_flat: f64,
    /// Median microseconds per line, single grid.
    pub flat_us_per_line: f64,
    /// Median microseconds per line, pyramid.
    pub pyramid_us_per_line: f64,
    /// Evidence records the classifier produced per line (deterministic), single grid.
    pub flat_records_per_line: f64,
    /// The same for the pyramid.
    pub pyramid_records_per_line: f64,
    /// Records of the pyramid over records of the single grid (deterministic).
    pub records_ratio: f64,
    /// Lines timed per repetition.
    pub lines: usize,
    /// Timed repetitions (the median is taken).
    pub repetitions: usize,
    /// Whether this binary was built with optimisations (a debug build's times mean little).
    pub optimised: bool,
}

/// The fixed grid and the pyramid.
type Pair = (Box<dyn Map>, Box<dyn Map>);

fn maps(decoded: &Decoded) -> Result<Pair, String> {
    let e = |e: terrain_pyramid::DesignError| e.to_string();
    let config = Config::default();
    let fixed: Box<dyn Map> = Box::new(Runner::<FIXED_CELLS, 1, SLOTS>::new(
        "fixed",
        designs::flat(10.0, 0.1, FIXED_CELLS).map_err(e)?,
        config,
        decoded.frontend,
    )?);
    let pyramid: Box<dyn Map> = Box::new(
        Runner::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, SLOTS>::new(
            "pyramid",
            designs::pyramid(10.0, GateShape::default(), false, DEFAULT_CELLS_PER_SIDE)
                .map_err(e)?,
            config,
            decoded.frontend,
        )?,
    );
    Ok((fixed, pyramid))
}

/// The holes of `map` seen from the sensor at `(sx, sy)` looking along +x.
pub fn holes(map: &dyn Map, sx: f64, sy: f64) -> Holes {
    let cell = 0.1;
    #[allow(clippy::cast_possible_truncation)]
    let n = (REACH_M / cell).ceil() as i32 + 1;
    let mut total = 0_usize;
    let mut unknown = 0_usize;
    let mut ring_counts = [(0_usize, 0_usize); RINGS.len()];
    let (cx, cy) = ((sx / cell).floor(), (sy / cell).floor());
    for i in -n..=n {
        for j in -n..=n {
            let x = (cx + f64::from(i) + 0.5) * cell;
            let y = (cy + f64::from(j) + 0.5) * cell;
            let (dx, dy) = (x - sx, y - sy);
            let d = dx.hypot(dy);
            if d > REACH_M || dx <= 0.0 || dy.atan2(dx).abs().to_degrees() > HALF_FIELD_DEG {
                continue;
            }
            let hole = map.fused(x, y) == Fused::Unknown;
            total += 1;
            unknown += usize::from(hole);
            for (k, &(lo, hi)) in RINGS.iter().enumerate() {
                if d >= lo && d < hi {
                    if let Some(c) = ring_counts.get_mut(k) {
                        c.0 += 1;
                        c.1 += usize::from(hole);
                    }
                }
            }
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let share = |h: usize, t: usize| {
        if t == 0 {
            0.0
        } else {
            round4(h as f64 / t as f64)
        }
    };
    Holes {
        holes_fraction: share(unknown, total),
        rings: RINGS
            .iter()
            .zip(ring_counts)
            .map(|(&(lo, hi), (t, h))| (lo, hi, share(h, t)))
            .collect(),
        places: total,
    }
}

/// Feeds every line to `map` (after a reset) and returns the seconds it took and the
/// evidence records the run produced.
fn timed(map: &mut dyn Map, decoded: &Decoded) -> (f64, u64) {
    map.reset();
    let before = map.records();
    let start = Instant::now();
    for line in &decoded.lines {
        map.line(line);
    }
    map.flush();
    let seconds = start.elapsed().as_secs_f64();
    (seconds, map.records().saturating_sub(before))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Runs coverage and cost; writes the pictures into `out` when given.
///
/// # Errors
/// The simulator or the library refused the setup, or a picture could not be written.
pub fn run(setup: &Setup, out: Option<&Path>) -> Result<(CoverageResult, CostResult), String> {
    let sim_config = setup.sim();
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let decoded = decode(&sim.bytes, &setup.classifier)?;
    let (mut fixed, mut pyramid) = maps(&decoded)?;
    // Cost: the same lines through each map, interleaved repetitions, median.
    let mut t_fixed = Vec::new();
    let mut t_pyramid = Vec::new();
    let (mut rf, mut rp) = (0, 0);
    for _ in 0..setup.repetitions.max(1) {
        let (t, r) = timed(fixed.as_mut(), &decoded);
        t_fixed.push(t);
        rf = r;
        let (t, r) = timed(pyramid.as_mut(), &decoded);
        t_pyramid.push(t);
        rp = r;
    }
    // After the last repetition both maps hold the whole run: coverage is measured on them.
    let robot = decoded.lines.last().map_or((0.0, 0.0), |l| l.robot_xy);
    let sensor = (
        robot.0 + f64::from(sim.setup.sensor_m[0]),
        robot.1 + f64::from(sim.setup.sensor_m[1]),
    );
    let coverage = CoverageResult {
        fixed: holes(fixed.as_ref(), sensor.0, sensor.1),
        pyramid: holes(pyramid.as_ref(), sensor.0, sensor.1),
        setup: *setup,
    };
    #[allow(clippy::cast_precision_loss)]
    let lines = decoded.lines.len().max(1) as f64;
    let (tf, tp) = (median(t_fixed), median(t_pyramid));
    #[allow(clippy::cast_precision_loss)]
    let (rf, rp) = (rf as f64, rp as f64);
    let cost = CostResult {
        pyramid_over_flat: round4(if tf > 0.0 { tp / tf } else { 0.0 }),
        flat_us_per_line: round4(tf / lines * 1e6),
        pyramid_us_per_line: round4(tp / lines * 1e6),
        flat_records_per_line: round4(rf / lines),
        pyramid_records_per_line: round4(rp / lines),
        records_ratio: round4(if rf > 0.0 { rp / rf } else { 0.0 }),
        lines: decoded.lines.len(),
        repetitions: setup.repetitions.max(1),
        optimised: !cfg!(debug_assertions),
    };
    if let Some(dir) = out {
        let region = Region {
            x0: sensor.0 - 1.0,
            y0: -6.0,
            x1: sensor.0 + REACH_M + 0.5,
            y1: 6.0,
            cell: 0.1,
        };
        let mut a = picture::panel(fixed.as_ref(), &region, sensor, &[]);
        a.title = format!(
            "Fig. 8: fixed 0.1 m grid, {:.0} % holes within {REACH_M} m",
            100.0 * coverage.fixed.holes_fraction
        );
        let mut b = picture::panel(pyramid.as_ref(), &region, sensor, &[]);
        b.title = format!(
            "Fig. 9: multi-resolution pyramid, {:.0} % holes within {REACH_M} m",
            100.0 * coverage.pyramid.holes_fraction
        );
        picture::draw_panels(
            &dir.join("coverage.png"),
            "Approaching a gate (posts at x = 5.05 m, y = ±0.75 m): fused maps sampled at 0.1 m",
            &[a, b],
            2,
        )?;
        // The maps themselves as `pyramid run` writes them (PGM/YAML per layer, maps.png).
        for (name, map) in [("coverage-fixed", &fixed), ("coverage-pyramid", &pyramid)] {
            let snapshot = map.snapshot(sensor);
            terrain_pyramid_host::export::write_maps(&dir.join(name), &snapshot, name)?;
        }
    }
    Ok((coverage, cost))
}
