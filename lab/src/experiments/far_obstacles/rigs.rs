//! The street of [`super`] (the far-obstacles experiment) seen by the paper's SICK on its pan
//! unit and by the nodding lidars of [`crate::experiments::lidar`] (LD19, RPLIDAR A1 in its
//! standard and express scans, YDLIDAR X4 on the 2°..35° servo), each on a robot driving down
//! the road through the library's pipeline as a board runs it.
//!
//! The run: the robot stands 2 s at 2 m before the first place of the street experiment
//! (x = −6 m, y = 0), then drives along the road at 1 m/s to 0.5 m past the last place. One
//! map per rig, design and rule, fed the whole recording line by line
//! ([`crate::experiments::engine`]), the configuration a board boots with
//! (`Config::default()`). As the robot passes each place, the map as it stands then is
//! scored, as the car's revolutions are ([`terrain_pyramid_host_tests::navigability::rings`]),
//! at the true points of the returns of the last sweep the map has integrated (one period of
//! the actuator before the end of the map's last observation: the SICK's pan 2.43 s, the
//! servo's nod 3.3 s), each ring counted from where the laser was when it measured the
//! return: clear ground read navigable, obstacles marked within 0.2 m, by ring and kind. A
//! return the pipeline has not yet integrated is not scored: the map cannot know it yet.
//!
//! The designs, all with the soft gate:
//! - the rigs' own, the default schedule (γ 2, `r_k = k·γ·Δd`), as many layers as that
//!   takes: the SICK the paper's (φ 0.5°, ψ 2°, σ 0.15 m, h 1 m) to 20 m, in centimetres and
//!   panned at 74°/s as in the stairs experiment; the nodding lidars [`Ld19Design::for_kind`]
//!   to their ranges (12 m; the X4 10 m);
//! - for the nodding lidars, what a board runs (8 layers of 64² cells, 1 024 classifier
//!   slots): the design it boots with (the library's default sensor, the SICK's, to 10 m) and
//!   the rig's own fitted to 8 m ([`on_board::fitted`], `pyramid design --fit-layers 8`).
//!   Beyond a design's range the map knows nothing, which the score counts as wrong.

use super::witnessed::{Bounds, Witnessed};
use super::{rule_result, Hit, RuleResult, Setup, CLEAR_M, ROBOT_HEIGHT_M, RULES};
use crate::experiments::engine::{decode, Decoded, Map, Runner};
use crate::experiments::lidar::on_board::{self, BOARD_RIGS};
use crate::experiments::lidar::{self, Ld19Design, StairsSetup, RIG_LAYERS, STAIRS_CELLS};
use crate::experiments::{designs, stairs};
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::wire::sick::Unit;
use terrain_pyramid::{
    Config, Design, GateShape, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS,
};
use terrain_pyramid_host::design::firmware_design;
use terrain_pyramid_host_tests::navigability::rings::{far_obstacles_with, RingTally};
use terrain_pyramid_host_tests::sim::cloud::Observation;
use terrain_pyramid_host_tests::sim::laser::{Actuator, LaserConfig};
use terrain_pyramid_host_tests::sim::lidar::{simulate_lidar, HitBox, LidarKind};
use terrain_pyramid_host_tests::sim::record::{simulate_with, SimConfig};
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// The SICK's range and its design's, metres.
const SICK_RANGE_M: f64 = 20.0;
/// The SICK's pan rate, degrees per second (±45°): as the stairs experiment, not locked to
/// the mirror so that sweeps interleave.
const SICK_PAN_DEG_S: f64 = 74.0;
/// Cells per layer side of the SICK's pyramid: every layer's window holds the whole 20 m
/// range on either side of the robot, as the nodding rigs' [`STAIRS_CELLS`] do their 12 m
/// (2 · 20 / 0.1 + 2 = 402, rounded up to a multiple of 8).
const SICK_CELLS: usize = 408;
/// Layer capacity of the SICK's pyramid.
const SICK_LAYERS: usize = 64;
/// Seconds standing before driving.
const STAND_S: f64 = 2.0;
/// Metres driven before the first place.
const LEAD_M: f64 = 2.0;
/// Driving speed, m/s.
const SPEED_MPS: f64 = 1.0;

/// One rig's outcome on the street with one design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RigResult {
    /// The rig: `SICK LMS2xx (panned)` or a nodding lidar's name ([`BOARD_RIGS`]).
    pub rig: &'static str,
    /// The design: `own` (the rig's own to its range, γ 2, as many layers as it needs),
    /// `board, boot` (what a board runs until a host configures it: the library's default
    /// sensor, 10 m, γ 2, 8 layers of 64²) or `board, own to 8 m` (the rig's own fitted to
    /// a board's 8 layers, `pyramid design --fit-layers 8`).
    pub design: &'static str,
    /// The laser's range, metres.
    pub range_m: f64,
    /// The design's range, metres.
    pub design_range_m: f64,
    /// The design's γ.
    pub gamma: f32,
    /// The design's layers.
    pub layers: usize,
    /// The window scored at each place: the actuator's period, seconds.
    pub window_s: f64,
    /// Per rule, as the car's.
    pub rules: Vec<RuleResult>,
    /// The most any rule could mark on the same returns ([`super::witnessed`]), on the rig's
    /// first design only (the same for every design: the observations are the pipeline's).
    pub bounds: Option<Bounds>,
}

/// Builds a rig's map for a decoded recording (its pipeline configuration).
type MapBuilder = Box<dyn Fn(&Decoded) -> Result<Box<dyn Map>, String>>;

/// One design a rig's maps run, for [`rig_results`]: what [`RigResult`] says of it and how
/// to build its map.
struct DesignRow {
    /// [`RigResult::design`].
    name: &'static str,
    /// The design's range, metres.
    range_m: f64,
    /// Its γ.
    gamma: f32,
    /// Its layers.
    layers: usize,
    /// Builds the map for a decoded recording.
    map: MapBuilder,
}

impl DesignRow {
    /// `design` in a pyramid of `L` layers of `W × W` cells behind `C` classifier slots, with
    /// the configuration a board boots with.
    fn of<const W: usize, const L: usize, const C: usize>(
        name: &'static str,
        rig: &'static str,
        design: Design<L>,
    ) -> Self {
        Self {
            name,
            range_m: f64::from(design.sensor().max_range_m),
            gamma: design.schedule().gamma,
            layers: design.layers().len(),
            map: Box::new(move |d: &Decoded| -> Result<Box<dyn Map>, String> {
                Ok(Box::new(Runner::<W, L, C>::new(
                    rig,
                    design.clone(),
                    Config::default(),
                    d.frontend,
                )?))
            }),
        }
    }
}

/// The range a board's own design of a nodding rig is fitted to, metres (the rig file
/// `examples/rigs/ld19-nodding.toml`'s).
const BOARD_RANGE_M: f64 = 8.0;

/// The robot's run along the street for `setup`'s places.
fn trajectory(setup: &Setup) -> Trajectory {
    let first = setup.xs.iter().copied().fold(f64::INFINITY, f64::min);
    let last = setup.xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Trajectory {
        start_x: first - LEAD_M,
        y: 0.0,
        stand_s: STAND_S,
        speed_mps: SPEED_MPS,
        stop_x: last + 0.5,
        dwell_s: 0.0,
        yaw_rate_rad_s: 0.0,
    }
}

/// The SICK's recording of the run and its returns' true points within its range.
fn sick_run(setup: &Setup) -> Result<(Vec<u8>, Vec<Hit>), String> {
    let laser = LaserConfig {
        unit: Unit::Centimetre,
        max_range_m: Some(SICK_RANGE_M),
        actuator: Actuator::Pan {
            half_width_deg: 45.0,
            rate_deg_s: SICK_PAN_DEG_S,
        },
        ..LaserConfig::paper()
    };
    let mut config = SimConfig::new(Scene::street(setup.swell_m), laser, trajectory(setup));
    config.seed = setup.seed;
    let mut hits = Vec::new();
    let sim = simulate_with(&config, &|_| None, &mut |line| {
        let range = line.laser.config().max_range();
        for ray in line.laser.rays(line.pose, line.angle) {
            if let Some(hit) = line.scene.cast(&ray, range) {
                hits.push((line.t_s, hit.point));
            }
        }
    })
    .map_err(|e| format!("the SICK on the street: {e}"))?;
    Ok((sim.bytes, hits))
}

/// Nodding lidar `kind`'s recording of the run and its returns' true points.
fn lidar_run(setup: &Setup, kind: LidarKind) -> Result<(Vec<u8>, Vec<Hit>), String> {
    let mut config = lidar::rig_sim(
        kind,
        Scene::street(setup.swell_m),
        trajectory(setup),
        setup.seed,
    );
    // A box around every return the rigs can make on this run (x from −6 − 12 to 14.5 + 12 m,
    // |y| ≤ 12 m).
    config.hit_box = Some(HitBox {
        min: [-40.0, -30.0, -5.0],
        max: [50.0, 30.0, 5.0],
    });
    let sim = simulate_lidar(&config).map_err(|e| format!("{kind:?} on the street: {e}"))?;
    Ok((
        sim.bytes,
        sim.hits.iter().map(|h| (h.t_s, h.point_m)).collect(),
    ))
}

/// Seconds of returns scored from one place of the laser: the robot moves 0.1 m meanwhile.
const SLICE_S: f64 = 0.1;

/// Feeds `decoded` into `map` and scores the map, as it stands when the robot passes each
/// of `places`, at the returns of the last `window_s` seconds the map has integrated (up to
/// the end of its last observation), each ring counted from where the laser was when it
/// measured the return (`trajectory`, within [`SLICE_S`]). With `witnessed`, scores its bounds
/// at the same returns.
#[allow(clippy::too_many_arguments)]
fn score(
    map: &mut dyn Map,
    decoded: &Decoded,
    hits: &[Hit],
    places: &[f64],
    window_s: f64,
    trajectory: &Trajectory,
    scene: &Scene,
    mut witnessed: Option<&mut Witnessed>,
) -> RingTally {
    let mut places: Vec<f64> = places.to_vec();
    places.sort_by(f64::total_cmp);
    let mut next = places.iter().peekable();
    let mut tally = RingTally::default();
    // The end of the last observation integrated, seconds.
    let mut integrated: Option<f64> = None;
    let mut observations = map.observations();
    for line in &decoded.lines {
        map.line(line);
        if map.observations() != observations {
            observations = map.observations();
            #[allow(clippy::cast_precision_loss)]
            let t = line.time_us as f64 * 1e-6;
            if let Some(w) = witnessed.as_deref_mut() {
                w.observation_ended(hits, t);
            }
            integrated = Some(t);
        }
        while next.next_if(|&&x| line.robot_xy.0 >= x).is_some() {
            let Some(t) = integrated else {
                continue;
            };
            // The window's returns in slices, each seen from the laser's place at its middle.
            let window: Vec<&Hit> = hits
                .iter()
                .filter(|(th, _)| *th > t - window_s && *th <= t)
                .collect();
            for slice in window.chunk_by(|a, b| {
                (a.0 / SLICE_S).floor().total_cmp(&(b.0 / SLICE_S).floor())
                    == std::cmp::Ordering::Equal
            }) {
                let Some(first) = slice.first() else {
                    continue;
                };
                let at = ((first.0 / SLICE_S).floor() + 0.5) * SLICE_S;
                let pose = trajectory.pose_at(at, scene);
                let obs = Observation {
                    sensor: [pose.x, pose.y, pose.z + lidar::HEIGHT_M],
                    ground_z: pose.z,
                    points: slice.iter().map(|h| h.1).collect(),
                };
                tally.add(&far_obstacles_with(
                    |qx, qy| map.fused(qx, qy),
                    |k, qx, qy| map.cell_footprint(k, qx, qy),
                    scene,
                    std::slice::from_ref(&obs),
                    CLEAR_M,
                    ROBOT_HEIGHT_M,
                ));
                if let Some(w) = witnessed.as_deref_mut() {
                    w.score(&obs, scene);
                }
            }
        }
    }
    tally
}

/// What the street of `setup` is and how the robot drives it, shared by every rig.
struct Street<'a> {
    /// Its places, seed and swell.
    setup: &'a Setup,
    /// `Scene::street` of its swell.
    scene: Scene,
    /// [`trajectory`] of its places.
    trajectory: Trajectory,
}

/// One rig (its laser's range, the actuator's period, its run) with each of `designs` under
/// every rule: one result per design, in their order. The recording is decoded once per rule.
fn rig_results(
    rig: &'static str,
    (range_m, window_s): (f64, f64),
    designs: &[DesignRow],
    (bytes, hits): &(Vec<u8>, Vec<Hit>),
    street: &Street<'_>,
) -> Result<Vec<RigResult>, String> {
    let mut results: Vec<RigResult> = designs
        .iter()
        .map(|design| RigResult {
            rig,
            design: design.name,
            range_m,
            design_range_m: design.range_m,
            gamma: design.gamma,
            layers: design.layers,
            window_s,
            rules: Vec::new(),
            bounds: None,
        })
        .collect();
    let mut bounded = false;
    for (name, rule) in RULES {
        let decoded = decode(
            bytes,
            &ClassifierConfig {
                rule,
                ..ClassifierConfig::default()
            },
        )?;
        for (design, result) in designs.iter().zip(&mut results) {
            let mut m = (design.map)(&decoded)?;
            // The bounds once a rig: with its first map.
            let mut witnessed = (!bounded).then(Witnessed::default);
            let tally = score(
                m.as_mut(),
                &decoded,
                hits,
                &street.setup.xs,
                window_s,
                &street.trajectory,
                &street.scene,
                witnessed.as_mut(),
            );
            if let Some(w) = witnessed {
                result.bounds = Some(w.bounds());
                bounded = true;
            }
            if m.dropped() != 0 {
                return Err(format!(
                    "{rig}, {}, {name}: the classifier's scratch overflowed",
                    design.name
                ));
            }
            result.rules.push(rule_result(name, &tally, tally.total()));
        }
    }
    Ok(results)
}

/// Runs every rig on the street of `setup` (its places, seed and swell). Needs a large stack,
/// as [`super::run`].
///
/// # Errors
/// A design the library refused, the simulator's refusal, or a classifier whose scratch
/// overflowed.
pub fn run(setup: &Setup) -> Result<Vec<RigResult>, String> {
    let street = Street {
        setup,
        scene: Scene::street(setup.swell_m),
        trajectory: trajectory(setup),
    };
    #[allow(clippy::cast_possible_truncation)]
    let sick: Design<SICK_LAYERS> =
        designs::pyramid(SICK_RANGE_M as f32, GateShape::default(), false, SICK_CELLS)
            .map_err(|e| format!("the SICK's street design: {e}"))?;
    let sick_name = "SICK LMS2xx (panned)";
    let mut out = rig_results(
        sick_name,
        (SICK_RANGE_M, 2.0 * 90.0 / SICK_PAN_DEG_S),
        &[DesignRow::of::<SICK_CELLS, SICK_LAYERS, { stairs::SLOTS }>(
            "own", sick_name, sick,
        )],
        &sick_run(setup)?,
        &street,
    )?;
    let boot = firmware_design()?;
    for (kind, name) in BOARD_RIGS {
        let (_, range) = kind.range_m();
        let own: Design<RIG_LAYERS> = Ld19Design::for_kind(kind)
            .pyramid(range, GateShape::default(), false, STAIRS_CELLS)
            .map_err(|e| format!("{name}'s design: {e}"))?;
        let (_, fitted) = on_board::fitted(&StairsSetup {
            kind,
            range_m: BOARD_RANGE_M,
            ..StairsSetup::FULL
        })?;
        let board = |design_name, design| {
            DesignRow::of::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, DEFAULT_CLASSIFIER_SLOTS>(
                design_name,
                name,
                design,
            )
        };
        out.extend(rig_results(
            name,
            (range, lidar::nod_period_s(kind)),
            &[
                DesignRow::of::<STAIRS_CELLS, RIG_LAYERS, { stairs::SLOTS }>("own", name, own),
                board("board, boot", boot.clone()),
                board("board, own to 8 m", fitted),
            ],
            &lidar_run(setup, kind)?,
            &street,
        )?);
    }
    Ok(out)
}

/// The report's heading and paragraph of one rig's tables (Markdown, after a blank line).
pub(crate) fn heading(rig: &RigResult, setup: &Setup) -> String {
    format!(
        "\n### The street from a driving robot: {}, {} design\n\nThe robot stands {STAND_S} s \
         at x = {} m and drives along the road at {SPEED_MPS} m/s; one map (γ {}, {} layers, \
         {} m, the board's boot configuration; the laser reaches {} m) fed the whole run; \
         scored as the robot passes each place at the returns of the last {:.2} s (one sweep \
         of its actuator) the map has integrated.\n",
        rig.rig,
        rig.design,
        trajectory(setup).start_x,
        rig.gamma,
        rig.layers,
        rig.design_range_m,
        rig.range_m,
        rig.window_s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_layer_of_the_sicks_window_holds_its_whole_range() {
        #[allow(clippy::cast_possible_truncation)]
        let design: Design<SICK_LAYERS> =
            designs::pyramid(SICK_RANGE_M as f32, GateShape::default(), false, SICK_CELLS)
                .expect("the SICK's design");
        #[allow(clippy::cast_precision_loss)]
        let half = |r: f32| f64::from(r) * SICK_CELLS as f64 / 2.0;
        for layer in design.layers() {
            assert!(half(layer.resolution_m) >= SICK_RANGE_M, "{layer:?}");
        }
    }
}
