//! How ghosts fade: a changing scene ([`crate::sim::changing`]) through the application core
//! ([`terrain_pyramid::app::CoProcessor`], in process, polled at every laser event with the
//! recording's clock, as a board polls with its own), with and without decay, and what its
//! maps say about the cells a mover left and about the static obstacles.
//!
//! # What is measured
//! - **Clearing time** of a mover's cells: the cells of the 0.1 m truth grid that a mover
//!   covered for at least [`MIN_PRESENCE_S`] and had left at least [`MIN_PRESENCE_S`] before
//!   the end. A cell *leaves* at the first line after the last one that saw the mover cover
//!   it. For the fused map (queried at the cell's centre) and for each layer (the layer's cell
//!   that contains the centre), a cell counts if the map read it as an obstacle at that first
//!   line (a ghost); it *clears* at the first line from which it reads unknown or navigable
//!   until the end. Layer cells that also hold a static obstacle are left out for that layer;
//!   in the fused map, an obstacle answered by such a layer cell counts as not a ghost.
//!   Reported: cells, cleared, median, 90th percentile and largest time from leaving to
//!   clearing, seconds.
//! - **False clearing** of static obstacles at the end of the run: the static obstacles' truth
//!   cells the laser hit at least once; *in view* when a line hit them within the last
//!   [`SWEEP_S`] (one back-and-forth of the pan), *out of view* otherwise. Wrongly cleared: the
//!   fused map reads unknown or navigable at the cell's centre.

use serde::Serialize;
use terrain_pyramid as tp;
use tp::angle::Angle;
use tp::app::CoProcessor;
use tp::classify::ClassifierConfig;
use tp::drivers::angle::HostSuppliedAngle;
use tp::geometry::Pose;
use tp::link::convert::frontend_config_of_event;
use tp::link::LinkConfig;
use tp::pipeline::FrontendConfig;
use tp::wire::recording::{Payload, Reader};
use tp::{Config, Decay, DecayMode, Fused, Meters, TimeConstant};

use crate::sim::changing::{simulate_changing, CellIndex, ChangingScene, ChangingSimulation};

/// A mover must have covered a cell (and have left it) for this long to count, seconds.
pub const MIN_PRESENCE_S: f64 = 1.0;

/// One back-and-forth of the paper's pan (±45° at 74°/s), seconds, rounded up: a static cell
/// hit within this much of the end is in view.
pub const SWEEP_S: f64 = 2.5;

/// The co-processor the measurement drives: the default firmware's.
type Core = CoProcessor<
    { tp::DEFAULT_CELLS_PER_SIDE },
    { tp::DEFAULT_LAYERS },
    { tp::DEFAULT_CLASSIFIER_SLOTS },
    4096,
>;

/// Decay as a run is configured with it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecaySetting {
    /// `off`, `all`, `obstacle` or `free`.
    pub mode: &'static str,
    /// Every layer's time constant, seconds (the code's exact value); `None` when off.
    pub tau_s: Option<f64>,
}

impl DecaySetting {
    /// No decay.
    pub const OFF: Self = Self {
        mode: "off",
        tau_s: None,
    };

    /// `mode` with every layer at the time constant nearest `tau_s`.
    #[must_use]
    pub fn every_layer(mode: DecayMode, tau_s: f32) -> Self {
        Self {
            mode: mode.name(),
            tau_s: TimeConstant::from_seconds(tau_s)
                .and_then(TimeConstant::seconds)
                .map(f64::from),
        }
    }

    /// The library's decay for a design of `layers` layers.
    #[must_use]
    pub fn decay(&self, layers: usize) -> Decay {
        let mode = match self.mode {
            "all" => DecayMode::All,
            "obstacle" => DecayMode::Obstacle,
            "free" => DecayMode::Free,
            _ => return Decay::OFF,
        };
        #[allow(clippy::cast_possible_truncation)]
        let tau = self
            .tau_s
            .and_then(|s| TimeConstant::from_seconds(s as f32))
            .unwrap_or(TimeConstant::NONE);
        Decay::uniform(mode, tau, layers)
    }
}

/// The decay settings every scene is run with: off, and all evidence at τ = 2, 5 and 20 s.
#[must_use]
pub fn settings() -> Vec<DecaySetting> {
    vec![
        DecaySetting::OFF,
        DecaySetting::every_layer(DecayMode::All, 2.0),
        DecaySetting::every_layer(DecayMode::All, 5.0),
        DecaySetting::every_layer(DecayMode::All, 20.0),
    ]
}

/// Clearing times of one map view (the fused map, or one layer).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ClearTimes {
    /// Ghost cells: the mover's cells the view read as obstacle when the mover left them.
    pub cells: usize,
    /// Of those, the cells that read unknown or navigable from some line until the end.
    pub cleared: usize,
    /// Median time from leaving to clearing, seconds (`None` when nothing cleared).
    pub median_s: Option<f64>,
    /// 90th percentile, seconds.
    pub p90_s: Option<f64>,
    /// The longest, seconds.
    pub max_s: Option<f64>,
}

impl ClearTimes {
    fn of(cells: usize, mut times: Vec<f64>) -> Self {
        times.sort_by(f64::total_cmp);
        let at = |q: f64| {
            if times.is_empty() {
                None
            } else {
                let i = ((times.len() - 1) as f64 * q).round() as usize;
                times.get(i).copied()
            }
        };
        Self {
            cells,
            cleared: times.len(),
            median_s: at(0.5),
            p90_s: at(0.9),
            max_s: times.last().copied(),
        }
    }
}

/// Static obstacles wrongly cleared.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct FalseClearing {
    /// Static obstacle cells (of those the laser hit at least once).
    pub cells: usize,
    /// Of those, the cells the fused map reads as unknown or navigable at the end.
    pub cleared: usize,
    /// `cleared / cells` (0 when there are none).
    pub share: f64,
}

impl FalseClearing {
    fn of(cells: usize, cleared: usize) -> Self {
        Self {
            cells,
            cleared,
            share: if cells == 0 {
                0.0
            } else {
                cleared as f64 / cells as f64
            },
        }
    }
}

/// One run of a scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunResult {
    /// The decay.
    pub decay: DecaySetting,
    /// The fused map.
    pub fused: ClearTimes,
    /// Each layer, finest first.
    pub layers: Vec<ClearTimes>,
    /// Static obstacles in view at the end.
    pub static_in_view: FalseClearing,
    /// Static obstacles seen before, out of view at the end.
    pub static_out_of_view: FalseClearing,
    /// Cells the decay made unknown over the run (the pyramid's counter).
    pub cells_faded: u64,
}

/// One changing scene, every decay setting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneResult {
    /// The scene's name.
    pub scene: &'static str,
    /// The recording's length, seconds.
    pub duration_s: f64,
    /// Scan lines.
    pub lines: u32,
    /// The mover cells tracked (covered and left, each for at least [`MIN_PRESENCE_S`]).
    pub mover_cells: usize,
    /// When the first and the last of them was left, seconds.
    pub left_s: Option<(f64, f64)>,
    /// The runs, in the order of [`settings`].
    pub runs: Vec<RunResult>,
}

/// A tracked mover cell and what each view made of it.
struct Tracked {
    cell: CellIndex,
    /// The first line time at which the mover no longer covers it.
    leave: f64,
    /// Per view (fused, then each layer): `None` before the leave time; `Some(false)` not a
    /// ghost or excluded; `Some(true)` a ghost.
    ghost: Vec<Option<bool>>,
    /// Per view: the first sample time of the current run of non-obstacle readings.
    clear_since: Vec<Option<f64>>,
}

/// The cells of the truth grid a 0.1 m cell maps to in a layer of `r_m`: the layer cells
/// its square touches.
fn layer_cells(c: CellIndex, cell_m: f64, r_m: f64) -> Vec<(i32, i32)> {
    let span = |i: i32| {
        let lo = (f64::from(i) * cell_m / r_m).floor() as i32;
        let hi = ((f64::from(i + 1) * cell_m - 1e-9) / r_m).floor() as i32;
        lo..=hi
    };
    let mut out = Vec::new();
    for x in span(c.0) {
        for y in span(c.1) {
            out.push((x, y));
        }
    }
    out
}

/// Runs one simulated scene through the co-processor with one decay setting.
///
/// # Errors
/// The recording could not be read or the co-processor refused its configuration.
pub fn run(sim: &ChangingSimulation, decay: DecaySetting) -> Result<RunResult, String> {
    let design = tp::DefaultDesign::new(
        tp::SensorModel::default(),
        tp::Schedule::default(),
        tp::DEFAULT_CELLS_PER_SIDE,
    )
    .map_err(|e| e.to_string())?;
    let layers = design.layers().len();
    let config = Config {
        decay: decay.decay(layers),
        ..Config::default()
    };
    let cell_m = sim.truth.cell_m;
    let resolutions: Vec<f64> = design
        .layers()
        .iter()
        .map(|l| f64::from(l.resolution_m))
        .collect();
    let end = sim.line_times.last().copied().unwrap_or(0.0);
    let period = sim.line_times.get(1).copied().unwrap_or(0.0);
    // The layer cells that hold a static obstacle, per layer.
    let static_layer_cells: Vec<std::collections::BTreeSet<(i32, i32)>> = resolutions
        .iter()
        .map(|&r| {
            sim.static_cells
                .iter()
                .flat_map(|&c| layer_cells(c, cell_m, r))
                .collect()
        })
        .collect();
    let views = 1 + layers;
    let mut tracked: Vec<Tracked> = Vec::new();
    for cells in &sim.mover_cells {
        for (&cell, &(first, last)) in cells {
            let leave = last + period;
            if last - first + period >= MIN_PRESENCE_S && leave <= end - MIN_PRESENCE_S {
                tracked.push(Tracked {
                    cell,
                    leave,
                    ghost: vec![None; views],
                    clear_since: vec![None; views],
                });
            }
        }
    }

    let mut core: Box<Core> = Box::new(CoProcessor::new());
    let boot_setup = FrontendConfig::lms291_boot(tp::geometry::ScanPlane::PannedVertical);
    core.boot(LinkConfig::DEFAULT, &design, &config, boot_setup)
        .map_err(|e| e.to_string())?;
    let mut angle = HostSuppliedAngle::new();
    let reader = Reader::new(&sim.simulation.bytes).map_err(|e| e.to_string())?;
    let mut sink = [0_u8; 1024];
    let mut last_eval = f64::NEG_INFINITY;
    for event in reader {
        let event = event.map_err(|e| e.to_string())?;
        let t = event.time_us as f64 / 1e6;
        match event.payload {
            Payload::Setup(setup) => {
                let frontend = frontend_config_of_event(&setup, &ClassifierConfig::default())
                    .map_err(|e| e.to_string())?;
                core.setup(frontend);
            }
            Payload::Pose([x, y, z, roll, pitch, yaw]) => {
                if let Ok(pose) = Pose::from_f32(x, y, z, roll, pitch, yaw) {
                    core.set_pose(pose);
                }
            }
            Payload::Angle(turns) => angle.set(Angle::from_bits(turns)),
            Payload::Laser(bytes) => {
                // The board's clocks: µs for the laser (wrapping), ms for the poll.
                #[allow(clippy::cast_possible_truncation)]
                let (now_us, now_ms) = (event.time_us as u32, (event.time_us / 1000) as u32);
                core.laser(bytes, now_us, &mut angle);
                core.poll(now_ms);
                while core.take_output(&mut sink) > 0 {}
                if t > last_eval {
                    last_eval = t;
                    evaluate(
                        core.pyramid(),
                        t,
                        cell_m,
                        &resolutions,
                        &static_layer_cells,
                        &mut tracked,
                    );
                }
            }
            // The simulated scenes are a SICK's: no sensor event to follow.
            Payload::Marker(_) | Payload::Sensor(_) | Payload::Rig(_) | Payload::Unknown { .. } => {
            }
        }
    }

    let pyramid = core.pyramid();
    let mut per_view: Vec<(usize, Vec<f64>)> = vec![(0, Vec::new()); views];
    for t in &tracked {
        for (v, (ghost, since)) in t.ghost.iter().zip(&t.clear_since).enumerate() {
            if *ghost == Some(true) {
                per_view[v].0 += 1;
                if let Some(since) = since {
                    per_view[v].1.push(since - t.leave);
                }
            }
        }
    }
    let mut times = per_view.into_iter().map(|(n, t)| ClearTimes::of(n, t));
    let fused = times.next().unwrap_or_default();
    let layer_times: Vec<ClearTimes> = times.collect();

    let (mut in_view, mut out_view) = ((0, 0), (0, 0));
    for (&c, hits) in &sim.static_hits {
        let Some(&last) = hits.last() else { continue };
        let (x, y) = centre(c, cell_m);
        let cleared = !matches!(pyramid.fused(x, y), Fused::Obstacle { .. });
        let bucket = if last >= end - SWEEP_S {
            &mut in_view
        } else {
            &mut out_view
        };
        bucket.0 += 1;
        bucket.1 += usize::from(cleared);
    }
    Ok(RunResult {
        decay,
        fused,
        layers: layer_times,
        static_in_view: FalseClearing::of(in_view.0, in_view.1),
        static_out_of_view: FalseClearing::of(out_view.0, out_view.1),
        cells_faded: u64::from(pyramid.stats().cells_faded),
    })
}

/// The centre of a truth cell, as the library's coordinates.
fn centre(c: CellIndex, cell_m: f64) -> (Meters, Meters) {
    (
        Meters::from_num((f64::from(c.0) + 0.5) * cell_m),
        Meters::from_num((f64::from(c.1) + 0.5) * cell_m),
    )
}

/// One sample of the maps at `t`: what each view says about each tracked cell.
fn evaluate<const W: usize, const L: usize>(
    pyramid: &tp::Pyramid<W, L>,
    t: f64,
    cell_m: f64,
    resolutions: &[f64],
    static_layer_cells: &[std::collections::BTreeSet<(i32, i32)>],
    tracked: &mut [Tracked],
) {
    for tr in tracked.iter_mut().filter(|tr| t >= tr.leave) {
        let (x, y) = centre(tr.cell, cell_m);
        let mut obstacle = Vec::with_capacity(1 + resolutions.len());
        // The fused map: an obstacle answered by a layer whose cell holds a static obstacle
        // is that obstacle, not a ghost.
        let ghost =
            match pyramid.fused(x, y) {
                Fused::Obstacle { layer } => {
                    let k = usize::from(layer);
                    let holds_static = pyramid.layer(k).zip(static_layer_cells.get(k)).is_some_and(
                        |(l, statics)| {
                            let r = l.resolution();
                            statics.contains(&(r.cell_of(x), r.cell_of(y)))
                        },
                    );
                    !holds_static
                }
                _ => false,
            };
        obstacle.push(Some(ghost));
        for (k, statics) in static_layer_cells.iter().enumerate() {
            let Some(layer) = pyramid.layer(k) else {
                obstacle.push(None);
                continue;
            };
            let r = layer.resolution();
            let lc = (r.cell_of(x), r.cell_of(y));
            if statics.contains(&lc) {
                obstacle.push(None);
                continue;
            }
            obstacle.push(Some(
                layer
                    .get(lc.0, lc.1)
                    .is_some_and(|c| c.class() == tp::CellClass::Obstacle),
            ));
        }
        for (v, o) in obstacle.into_iter().enumerate() {
            let (Some(ghost), Some(since)) = (tr.ghost.get_mut(v), tr.clear_since.get_mut(v))
            else {
                continue;
            };
            let Some(is_obstacle) = o else {
                *ghost = Some(false);
                continue;
            };
            if ghost.is_none() {
                *ghost = Some(is_obstacle);
            }
            if is_obstacle {
                *since = None;
            } else if since.is_none() {
                *since = Some(t);
            }
        }
    }
}

/// Simulates a changing scene and runs it with every setting of [`settings`].
///
/// # Errors
/// The simulator or the co-processor refused something.
pub fn measure(scene: &ChangingScene) -> Result<SceneResult, String> {
    let sim = simulate_changing(scene).map_err(|e| e.to_string())?;
    measure_simulated(scene.name, &sim, &settings())
}

/// Runs an already simulated scene with the given settings.
///
/// # Errors
/// The co-processor refused something.
pub fn measure_simulated(
    name: &'static str,
    sim: &ChangingSimulation,
    settings: &[DecaySetting],
) -> Result<SceneResult, String> {
    let runs = settings
        .iter()
        .map(|&s| run(sim, s))
        .collect::<Result<Vec<_>, _>>()?;
    let end = sim.line_times.last().copied().unwrap_or(0.0);
    let period = sim.line_times.get(1).copied().unwrap_or(0.0);
    let mut left: Vec<f64> = sim
        .mover_cells
        .iter()
        .flat_map(|cells| cells.values())
        .filter(|(first, last)| {
            last - first + period >= MIN_PRESENCE_S && last + period <= end - MIN_PRESENCE_S
        })
        .map(|(_, last)| last + period)
        .collect();
    left.sort_by(f64::total_cmp);
    Ok(SceneResult {
        scene: name,
        duration_s: end,
        lines: sim.simulation.lines,
        mover_cells: left.len(),
        left_s: left.first().copied().zip(left.last().copied()),
        runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_cells_cover_the_square() {
        assert_eq!(layer_cells((3, -1), 0.1, 0.1), vec![(3, -1)]);
        assert_eq!(layer_cells((3, -1), 0.1, 0.4), vec![(0, -1)]);
        assert_eq!(layer_cells((7, 7), 0.1, 0.6), vec![(1, 1)]);
        assert_eq!(layer_cells((2, 0), 0.1, 0.25), vec![(0, 0), (1, 0)]);
    }

    #[test]
    fn clear_times_quantiles() {
        let t = ClearTimes::of(5, vec![3.0, 1.0, 2.0, 4.0]);
        assert_eq!((t.cells, t.cleared), (5, 4));
        assert_eq!(t.median_s, Some(3.0)); // index round(1.5) = 2
        assert_eq!(t.max_s, Some(4.0));
        assert_eq!(ClearTimes::of(2, Vec::new()).median_s, None);
    }
}
