//! Poses on the laser's clock: the same recording through the co-processor three ways, in
//! three scenes, and how far the maps of the two ways a robot can deliver its poses stay from
//! the recording's own lock-step.
//!
//! # The runs
//! Each scene's recording goes through the library's [`CoProcessor`] in this process, the
//! device's µs clock being the recording's time (the laser's bytes handed over with their
//! recorded time, the actuator angle as the host's PanAngle before each telegram or chunk,
//! as `pyramid run` sends it):
//! - **lock-step**: the reference, every return at its true pose. The simulator casts each
//!   SICK beam and each lidar sample from the true pose at its own moment
//!   ([`SimConfig::beam_times`], [`LidarSimConfig::sample_poses`](terrain_pyramid_host_tests::sim::lidar::LidarSimConfig::sample_poses)),
//!   so the recording's one pose per telegram or chunk is no longer every return's pose: the
//!   trajectory every [`TRUTH_PERIOD_US`] (1 kHz), stamped and delivered the moment it is
//!   stamped, to a co-processor whose track holds [`TRUTH_TRACK`] poses (64 ms, past a SICK
//!   line's first beam); the device interpolates between two true poses 1 ms apart (exact for
//!   the scenes' constant speeds and yaw rates) at each return's time, re-evaluated every
//!   millisecond (`POSE_QUANTUM_US`).
//! - **timed**: the recording's poses are not used; the trajectory is sampled at
//!   [`PoseFeed::rate_hz`] (50 Hz), each pose stamped with its true time and delivered
//!   [`PoseFeed::late_ms`] ± [`PoseFeed::jitter_ms`] (30 ± 10 ms, uniform) after it, through
//!   [`CoProcessor::stamped_pose`]: the device places each return with the pose interpolated
//!   at its measurement time (`docs/core.md`).
//! - **latest pose**: the same late poses, unstamped, each applied when it arrives
//!   ([`CoProcessor::set_pose`]): version 3's rule, for contrast.
//!
//! # The scenes
//! - **stairs**: the paper's stairs approach at 1 m/s with the SICK on its panned mount
//!   ([`super::stairs`]'s setup and its soft-gated pyramid, every layer at 0.1 m).
//! - **turning**: the same SICK turning in place at 1 rad/s in a room (8 m × 6 m, 2 m walls,
//!   two pillars: `Scene::room`), the paper's pyramid out to 10 m.
//! - **ld19**: an LD19 nodding on its servo on the robot driving up the stairs at 1 m/s
//!   ([`super::lidar`]'s setup and soft-gated pyramid).
//!
//! # The figures
//! - cells equal: for every layer, the cells known (not unknown) in either map, by world cell
//!   index; of them, the share holding exactly the lock-step map's value (and, looser, the
//!   share on the same side of zero: both obstacle, both navigable);
//! - the first step seen: [`super::stairs`]'s definition (at least half the first riser's
//!   cells obstacle in the fused query), looked at after every observation; the robot's
//!   distance to the first riser then;
//! - the device's counters: returns placed with an extrapolated pose, returns refused for want
//!   of a pose, stamped poses refused.

use super::designs;
use super::lidar::{ld19_sim, Ld19Design, StairsSetup as Ld19Setup};
use super::stairs::{self, round3, round4, Cell, FIRST_STEP_SHARE};
use serde::Serialize;
use std::collections::HashMap;
use terrain_pyramid::app::{CoProcessor, NoAngleSource};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::link::convert::{frontend_config, setup_message_with_sensor};
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{Message, PanAngle};
use terrain_pyramid::{Clamp, Config, Design, GateShape, Meters};
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::link::HostLink;
use terrain_pyramid_host::play::{steps, Step, Steps};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::lidar::{simulate_lidar, LidarSimConfig};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// The link's outgoing queue of the in-process co-processors, bytes.
const QUEUE: usize = 8192;

/// How the late poses come: rate, delay and its jitter.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct PoseFeed {
    /// Poses a second (the trajectory sampled every 1 / rate s from t = 0).
    pub rate_hz: f64,
    /// The mean delay from a pose's time to its arrival at the device, ms.
    pub late_ms: f64,
    /// The delay's jitter: uniform in ± this, ms.
    pub jitter_ms: f64,
    /// The jitter's seed.
    pub seed: u64,
}

impl PoseFeed {
    /// 50 Hz, 30 ± 10 ms late.
    pub const ROBOT: Self = Self {
        rate_hz: 50.0,
        late_ms: 30.0,
        jitter_ms: 10.0,
        seed: 29,
    };
}

/// One pose of the late feed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatePose {
    /// When the robot was there: the recording's time, µs.
    pub stamp_us: u64,
    /// When it reaches the device: the recording's time, µs (≥ `stamp_us`).
    pub arrival_us: u64,
    /// x, y, z (m), roll, pitch, yaw (rad), as the recording's pose events carry them.
    pub pose: [f32; 6],
}

/// The trajectory over `scene` sampled at `feed.rate_hz` for `duration_us`, each pose with its
/// late arrival; in the order of arrival (a pose overtaken by the next keeps its place after
/// it, as a transport that reorders would deliver it).
pub fn late_poses(
    trajectory: &Trajectory,
    scene: &Scene,
    duration_us: u64,
    feed: &PoseFeed,
) -> Vec<LatePose> {
    let mut rng = Rng::new(feed.seed);
    let period_us = 1e6 / feed.rate_hz;
    let mut out = Vec::new();
    for k in 0_u32.. {
        let t_us = (f64::from(k) * period_us).round();
        #[allow(clippy::cast_precision_loss)]
        if t_us > duration_us as f64 {
            break;
        }
        let late_us = 1e3 * (feed.late_ms + feed.jitter_ms * (2.0 * rng.uniform() - 1.0));
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        out.push(LatePose {
            stamp_us: t_us as u64,
            arrival_us: (t_us + late_us.max(0.0)).round() as u64,
            pose: trajectory.pose_at(t_us * 1e-6, scene).to_f32(),
        });
    }
    out.sort_by_key(|p| p.arrival_us);
    out
}

/// The trajectory every [`ON_TIME_PERIOD_US`] for `duration_us`, each pose arriving at its
/// stamp.
pub fn on_time_poses(trajectory: &Trajectory, scene: &Scene, duration_us: u64) -> Vec<LatePose> {
    poses_every(trajectory, scene, duration_us, ON_TIME_PERIOD_US)
}

/// The trajectory every [`TRUTH_PERIOD_US`] for `duration_us`, each pose arriving at its
/// stamp: the reference's.
pub fn true_poses(trajectory: &Trajectory, scene: &Scene, duration_us: u64) -> Vec<LatePose> {
    poses_every(trajectory, scene, duration_us, TRUTH_PERIOD_US)
}

/// The trajectory every `period_us` (> 0) for `duration_us`, each pose arriving at its stamp.
fn poses_every(
    trajectory: &Trajectory,
    scene: &Scene,
    duration_us: u64,
    period_us: u64,
) -> Vec<LatePose> {
    let period_us = period_us.max(1);
    (0..=duration_us / period_us)
        .map(|k| {
            let t_us = k * period_us;
            #[allow(clippy::cast_precision_loss)]
            let pose = trajectory.pose_at(t_us as f64 * 1e-6, scene).to_f32();
            LatePose {
                stamp_us: t_us,
                arrival_us: t_us,
                pose,
            }
        })
        .collect()
}

/// How a run gives the device its poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseRule {
    /// The recording's poses, interleaved with the laser's bytes.
    LockStep,
    /// The late feed, stamped.
    Timed,
    /// The late feed, unstamped, applied on arrival.
    Latest,
    /// The trajectory at 250 Hz ([`ON_TIME_PERIOD_US`]), stamped and delivered the moment
    /// it is stamped: the device's placement with perfect poses, the control that tells the late
    /// feed's effect from the difference between the simulator's timing of a return and the
    /// device's.
    OnTime,
}

/// The period of the on-time feed, µs: 250 Hz, so that the device's track of 16 poses
/// reaches back 64 ms, past a SICK line's first beam (its beams are 15–35 ms old when its
/// telegram is in). Between two poses the device interpolates: exact for the scenes' motions
/// (constant speed, constant yaw rate) but at the start of the drive.
pub const ON_TIME_PERIOD_US: u64 = 4_000;

/// The period of the reference's true poses, µs: 1 kHz, the device's pose quantum.
pub const TRUTH_PERIOD_US: u64 = 1_000;

/// The reference co-processor's track of stamped poses: 64 at 1 kHz, 64 ms.
pub const TRUTH_TRACK: usize = 64;

/// What one run left: its maps, its first-step distance and the device's counters.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// The maps at the end.
    pub snapshot: MapSnapshot,
    /// The robot's distance to the first riser when the first step was first seen, metres
    /// (a scene with stairs).
    pub first_step_m: Option<f64>,
    /// Returns placed with an extrapolated pose.
    pub returns_extrapolated: u64,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u64,
    /// Stamped poses the device took.
    pub poses_stamped: u64,
    /// Stamped poses the device refused.
    pub poses_refused: u64,
    /// Observations applied.
    pub observations: u64,
}

/// What the runs of a scene need besides the co-processor's shape.
pub struct Input<'a, const L: usize> {
    /// The decoded recording.
    pub steps: &'a Steps,
    /// The late feed.
    pub late: &'a [LatePose],
    /// The on-time feed.
    pub on_time: &'a [LatePose],
    /// The reference's true poses ([`true_poses`]).
    pub truth: &'a [LatePose],
    /// The design the co-processor boots with.
    pub design: &'a Design<L>,
    /// Its configuration.
    pub config: &'a Config,
    /// The pipeline's configuration (the recording's setup).
    pub frontend: FrontendConfig,
    /// The first riser's cells (0.1 m world cells) and its x, for the first-step distance.
    pub first_riser: Option<(&'a [Cell], f64)>,
    /// Whether the observation under way is applied at the end (a host's EndObservation).
    pub end_observation: bool,
}

fn pose_of(p: &[f32; 6]) -> Option<Pose> {
    Pose::from_f32(p[0], p[1], p[2], p[3], p[4], p[5]).ok()
}

/// The recording's time as the device's wrapping µs clock.
#[allow(clippy::cast_possible_truncation)]
fn device_us(t: u64) -> u32 {
    t as u32
}

/// Hands the device a late pose by `rule`.
fn deliver<const W: usize, const L: usize, const C: usize, const N: usize>(
    core: &mut CoProcessor<W, L, C, QUEUE, N>,
    rule: PoseRule,
    late: &LatePose,
) {
    let Some(pose) = pose_of(&late.pose) else {
        return;
    };
    match rule {
        PoseRule::Latest => core.set_pose(pose),
        PoseRule::LockStep | PoseRule::Timed | PoseRule::OnTime => {
            core.stamped_pose(device_us(late.stamp_us), pose);
        }
    }
}

/// Runs the recording through a co-processor of `W`² cells, `L` layers and `C` classifier
/// slots with poses by `rule`. Run it on a thread whose stack holds the co-processor.
///
/// # Errors
/// The boot was refused.
pub fn run<const W: usize, const L: usize, const C: usize>(
    input: &Input<'_, L>,
    rule: PoseRule,
) -> Result<RunOutcome, String> {
    if rule == PoseRule::LockStep {
        run_with::<W, L, C, TRUTH_TRACK>(input, rule)
    } else {
        run_with::<W, L, C, 16>(input, rule)
    }
}

/// [`run`] with a track of `N` stamped poses.
fn run_with<const W: usize, const L: usize, const C: usize, const N: usize>(
    input: &Input<'_, L>,
    rule: PoseRule,
) -> Result<RunOutcome, String> {
    let mut core: Box<CoProcessor<W, L, C, QUEUE, N>> = Box::new(CoProcessor::new());
    core.boot(
        LinkConfig::DEFAULT,
        input.design,
        input.config,
        input.frontend,
    )
    .map_err(|e| e.to_string())?;
    let mut host = HostLink::new();
    let feed = match rule {
        PoseRule::OnTime => input.on_time,
        PoseRule::LockStep => input.truth,
        PoseRule::Timed | PoseRule::Latest => input.late,
    };
    let mut late = feed.iter().peekable();
    let mut robot_x = 0.0_f64;
    let mut robot_xy = (0.0, 0.0);
    let mut angle: Option<u16> = None;
    let mut first_step_m = None;
    let mut observations = core.counters().frontend.observations;
    let mut scratch = [0_u8; 1024];
    for step in &input.steps.steps {
        let (bytes, time_us) = match step {
            Step::Setup(_) => continue,
            Step::Angle(turns) => {
                angle = Some(*turns);
                continue;
            }
            Step::Pose(p) => {
                robot_x = f64::from(p[0]);
                robot_xy = (f64::from(p[0]), f64::from(p[1]));
                continue;
            }
            // The simulator stamps a telegram or chunk with its last byte's arrival.
            Step::Telegram { bytes, time_us, .. } | Step::Laser { bytes, time_us, .. } => {
                (bytes, *time_us)
            }
        };
        while let Some(p) = late.next_if(|p| p.arrival_us <= time_us) {
            deliver(&mut core, rule, p);
        }
        if let Some(turns) = angle.take() {
            let frame = host
                .command(&Message::PanAngle(PanAngle {
                    turns,
                    timestamp_ms: 0,
                }))
                .map_err(|e| e.to_string())?;
            core.host(&frame);
        }
        core.laser(bytes, device_us(time_us), &mut NoAngleSource);
        // Nothing reads the link here: keep its queue from filling.
        while core.take_output(&mut scratch) > 0 {}
        let now = core.counters().frontend.observations;
        if now != observations {
            observations = now;
            if let (None, Some((cells, riser_x))) = (first_step_m, input.first_riser) {
                let p = core.pyramid();
                let seen = stairs::shares_by(
                    |x, y| {
                        p.fused(
                            Meters::saturating_from_num(x),
                            Meters::saturating_from_num(y),
                        )
                    },
                    cells,
                );
                if seen.obstacle >= FIRST_STEP_SHARE {
                    first_step_m = Some(round3(riser_x - robot_x));
                }
            }
        }
    }
    if input.end_observation {
        core.end_observation();
    }
    let counters = core.counters();
    let snapshot = MapSnapshot::from_pyramid(core.pyramid(), input.design, input.config, robot_xy);
    let track = track_counters(&core);
    Ok(RunOutcome {
        snapshot,
        first_step_m,
        returns_extrapolated: track.0,
        returns_without_pose: track.1,
        poses_stamped: track.2,
        poses_refused: track.3,
        observations: u64::from(counters.frontend.observations),
    })
}

/// The pose track's counters: returns extrapolated, returns without a pose, poses stamped,
/// poses refused.
fn track_counters<const W: usize, const L: usize, const C: usize, const N: usize>(
    core: &CoProcessor<W, L, C, QUEUE, N>,
) -> (u64, u64, u64, u64) {
    let c = core.counters();
    (
        u64::from(c.frontend.returns_extrapolated),
        u64::from(c.frontend.returns_without_pose),
        u64::from(c.app.poses_stamped),
        u64::from(c.app.poses_refused),
    )
}

/// How much of one map equals another, cell by cell.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct LayerAgreement {
    /// The layer.
    pub layer: usize,
    /// Cells known (not unknown) in either map.
    pub known: u64,
    /// Of them, cells with exactly the same value in both.
    pub equal: u64,
    /// Of them, cells on the same side of zero in both (both obstacle evidence, both
    /// navigable, or both exactly zero); unknown in one counts as different.
    pub same_side: u64,
}

/// A map against the reference.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Agreement {
    /// Known cells over every layer.
    pub known: u64,
    /// Share of them equal to the reference's.
    pub equal_share: f64,
    /// Share on the same side of zero.
    pub same_side_share: f64,
    /// The lowest per-layer share of equal cells (layers with known cells).
    pub worst_layer_equal_share: f64,
    /// Per layer.
    pub layers: Vec<LayerAgreement>,
}

/// Compares `map` with `reference`, layer by layer, by world cell index.
pub fn agreement(map: &MapSnapshot, reference: &MapSnapshot) -> Agreement {
    let mut layers = Vec::new();
    for (a, b) in map.layers.iter().zip(&reference.layers) {
        let cells = |l: &terrain_pyramid_host::export::LayerSnapshot| {
            let n = l.cells_per_side;
            let mut m: HashMap<(i64, i64), i16> = HashMap::new();
            for (i, &v) in l.cells.iter().enumerate() {
                if v == i16::MIN {
                    continue;
                }
                #[allow(clippy::cast_possible_wrap)]
                let (cx, cy) = ((i % n) as i64, (i / n) as i64);
                m.insert(
                    (
                        i64::from(l.origin_cells.0) + cx,
                        i64::from(l.origin_cells.1) + cy,
                    ),
                    v,
                );
            }
            m
        };
        let (ma, mb) = (cells(a), cells(b));
        let mut la = LayerAgreement {
            layer: a.index,
            ..LayerAgreement::default()
        };
        for (k, va) in &ma {
            la.known += 1;
            if let Some(vb) = mb.get(k) {
                la.equal += u64::from(va == vb);
                la.same_side += u64::from(va.signum() == vb.signum());
            }
        }
        la.known += mb.keys().filter(|k| !ma.contains_key(k)).count() as u64;
        layers.push(la);
    }
    let known: u64 = layers.iter().map(|l| l.known).sum();
    let share = |n: u64, d: u64| {
        #[allow(clippy::cast_precision_loss)]
        if d == 0 {
            1.0
        } else {
            round4(n as f64 / d as f64)
        }
    };
    Agreement {
        known,
        equal_share: share(layers.iter().map(|l| l.equal).sum(), known),
        same_side_share: share(layers.iter().map(|l| l.same_side).sum(), known),
        worst_layer_equal_share: layers
            .iter()
            .filter(|l| l.known > 0)
            .map(|l| share(l.equal, l.known))
            .fold(1.0, f64::min),
        layers,
    }
}

/// One run's figures.
#[derive(Debug, Clone, Serialize)]
pub struct RunFigures {
    /// Its cells against the lock-step run's (the lock-step run: all equal).
    pub cells: Agreement,
    /// The robot's distance to the first riser when the first step was seen, metres.
    pub first_step_m: Option<f64>,
    /// Returns placed with an extrapolated pose.
    pub returns_extrapolated: u64,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u64,
    /// Stamped poses taken.
    pub poses_stamped: u64,
    /// Stamped poses refused.
    pub poses_refused: u64,
    /// Observations applied.
    pub observations: u64,
}

/// A scene's figures.
#[derive(Debug, Clone, Serialize)]
pub struct SceneResult {
    /// The scene: `stairs`, `turning`, `ld19`.
    pub scene: String,
    /// What it is, in words.
    pub description: String,
    /// Seconds of recording.
    pub duration_s: f64,
    /// Telegrams or lidar chunks.
    pub laser_events: usize,
    /// Poses of the late feed.
    pub late_poses: usize,
    /// The reference.
    pub lock_step: RunFigures,
    /// Stamped late poses.
    pub timed: RunFigures,
    /// Unstamped late poses on arrival.
    pub latest: RunFigures,
    /// The control: stamped poses at 250 Hz, on time.
    pub on_time: RunFigures,
    /// The timed run's cells against the on-time run's: the late feed's own effect.
    pub timed_vs_on_time: Agreement,
    /// The latest-pose run's cells against the on-time run's.
    pub latest_vs_on_time: Agreement,
    /// `timed.first_step_m − lock_step.first_step_m`, metres (stairs scenes).
    pub timed_first_step_delta_m: Option<f64>,
    /// `latest.first_step_m − lock_step.first_step_m`, metres.
    pub latest_first_step_delta_m: Option<f64>,
}

/// The whole measurement.
#[derive(Debug, Clone, Serialize)]
pub struct TimingResult {
    /// The late feed.
    pub feed: PoseFeed,
    /// Whether the quick sizes ran.
    pub quick: bool,
    /// The scenes.
    pub scenes: Vec<SceneResult>,
}

fn figures(o: &RunOutcome, reference: &RunOutcome) -> RunFigures {
    RunFigures {
        cells: agreement(&o.snapshot, &reference.snapshot),
        first_step_m: o.first_step_m,
        returns_extrapolated: o.returns_extrapolated,
        returns_without_pose: o.returns_without_pose,
        poses_stamped: o.poses_stamped,
        poses_refused: o.poses_refused,
        observations: o.observations,
    }
}

/// The four runs of one scene (lock-step, timed, latest, on time), two at a time on threads
/// with stacks for the co-processor.
fn four<const W: usize, const L: usize, const C: usize>(
    input: &Input<'_, L>,
) -> Result<[RunOutcome; 4], String> {
    let mut outcomes = Vec::new();
    for rules in [
        [PoseRule::LockStep, PoseRule::Timed],
        [PoseRule::Latest, PoseRule::OnTime],
    ] {
        outcomes.extend(two::<W, L, C>(input, rules));
    }
    let mut it = outcomes.into_iter();
    let mut next = || it.next().ok_or_else(|| "missing run".to_string())?;
    Ok([next()?, next()?, next()?, next()?])
}

/// Two runs at once.
fn two<const W: usize, const L: usize, const C: usize>(
    input: &Input<'_, L>,
    rules: [PoseRule; 2],
) -> Vec<Result<RunOutcome, String>> {
    std::thread::scope(|s| {
        let handles: Vec<_> = rules
            .iter()
            .map(|&rule| {
                std::thread::Builder::new()
                    .stack_size(256 << 20)
                    .spawn_scoped(s, move || run::<W, L, C>(input, rule))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| match h {
                Ok(h) => h
                    .join()
                    .unwrap_or_else(|_| Err("a run's thread panicked".into())),
                Err(e) => Err(format!("cannot start a run's thread: {e}")),
            })
            .collect()
    })
}

fn scene_result(
    scene: &str,
    description: String,
    steps: &Steps,
    late: &[LatePose],
    runs: &[RunOutcome; 4],
) -> SceneResult {
    let [lock, timed, latest, on_time] = runs;
    let laser_events = steps
        .steps
        .iter()
        .filter(|s| matches!(s, Step::Telegram { .. } | Step::Laser { .. }))
        .count();
    let end_us = steps
        .steps
        .iter()
        .filter_map(|s| match s {
            Step::Telegram { time_us, .. } | Step::Laser { time_us, .. } => Some(*time_us),
            _ => None,
        })
        .max()
        .unwrap_or(0);
    let delta = |o: &RunOutcome| match (o.first_step_m, lock.first_step_m) {
        (Some(a), Some(b)) => Some(round3(a - b)),
        _ => None,
    };
    #[allow(clippy::cast_precision_loss)]
    SceneResult {
        scene: scene.to_string(),
        description,
        duration_s: end_us as f64 * 1e-6,
        laser_events,
        late_poses: late.len(),
        lock_step: figures(lock, lock),
        timed: figures(timed, lock),
        latest: figures(latest, lock),
        on_time: figures(on_time, lock),
        timed_vs_on_time: agreement(&timed.snapshot, &on_time.snapshot),
        latest_vs_on_time: agreement(&latest.snapshot, &on_time.snapshot),
        timed_first_step_delta_m: delta(timed),
        latest_first_step_delta_m: delta(latest),
    }
}

fn frontend_of(steps: &Steps) -> Result<FrontendConfig, String> {
    let setup = steps.setup().ok_or("the recording has no setup")?;
    frontend_config(&setup_message_with_sensor(
        &setup,
        &steps.sensor,
        &ClassifierConfig::DEFAULT,
    ))
    .map_err(|e| format!("the recording's setup: {e}"))
}

fn no_clamp() -> Config {
    Config {
        clamp: Clamp::Off,
        ..Config::default()
    }
}

/// The stairs scene's simulator setup (SICK, the stairs experiment's), quick or full.
pub fn stairs_setup(quick: bool) -> stairs::Setup {
    if quick {
        stairs::Setup {
            stand_distance_m: 14.05,
            stand_s: 2.0,
            range_m: 16.0,
            ..stairs::Setup::FULL
        }
    } else {
        stairs::Setup::QUICK
    }
}

/// The stairs approach.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn stairs_scene(quick: bool, feed: &PoseFeed) -> Result<SceneResult, String> {
    let setup = stairs_setup(quick);
    let sim_config = SimConfig {
        beam_times: true,
        ..setup.sim()
    };
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let steps = steps(&sim.bytes)?;
    let late = late_poses(
        &sim_config.trajectory,
        &sim_config.scene,
        sim.duration_us,
        feed,
    );
    let on_time = on_time_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let truth = true_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    #[allow(clippy::cast_possible_truncation)]
    let design = designs::pyramid::<{ stairs::LAYERS }>(
        setup.range_m as f32,
        GateShape::default(),
        true,
        stairs::CELLS,
    )
    .map_err(|e| e.to_string())?;
    let (_, first) = stairs::step_cells(&sim_config);
    let riser_x = sim_config.scene.target_x.unwrap_or(0.0);
    let config = no_clamp();
    let input = Input {
        steps: &steps,
        late: &late,
        on_time: &on_time,
        truth: &truth,
        design: &design,
        config: &config,
        frontend: frontend_of(&steps)?,
        first_riser: Some((&first, riser_x)),
        end_observation: true,
    };
    let runs = four::<{ stairs::CELLS }, { stairs::LAYERS }, { stairs::SLOTS }>(&input)?;
    Ok(scene_result(
        "stairs",
        format!(
            "SICK LMS291 panned ±45° at {}°/s, standing {} s {:.2} m from the stairs, then \
             driving at {} m/s to {} m; soft-gated pyramid, every layer 0.1 m, to {} m",
            setup.pan_rate_deg_s,
            setup.stand_s,
            setup.stand_distance_m,
            setup.speed_mps,
            setup.stop_distance_m,
            setup.range_m
        ),
        &steps,
        &late,
        &runs,
    ))
}

/// The turning scene's room: half extents, metres.
pub const ROOM_HALF_M: (f64, f64) = (4.0, 3.0);
/// The turning scene's rate, rad/s.
pub const TURN_RAD_S: f64 = 1.0;
/// The turning scene's window, cells per side.
pub const TURN_CELLS: usize = 128;
/// The turning scene's layer capacity.
pub const TURN_LAYERS: usize = 16;

/// The turning scene's simulator setup: the paper's SICK on its pan, turning in place.
pub fn turning_sim(quick: bool, seed: u64) -> SimConfig {
    let seconds = if quick { 8.0 } else { 30.0 };
    let mut sim = SimConfig::new(
        Scene::room(ROOM_HALF_M.0, ROOM_HALF_M.1),
        LaserConfig {
            max_range_m: Some(8.0),
            ..LaserConfig::paper()
        },
        Trajectory::turning(seconds, TURN_RAD_S),
    );
    sim.seed = seed;
    sim.beam_times = true;
    sim
}

/// Turning in place in the room.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn turning_scene(quick: bool, feed: &PoseFeed) -> Result<SceneResult, String> {
    let sim_config = turning_sim(quick, 1);
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let steps = steps(&sim.bytes)?;
    let late = late_poses(
        &sim_config.trajectory,
        &sim_config.scene,
        sim.duration_us,
        feed,
    );
    let on_time = on_time_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let truth = true_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let design = designs::pyramid::<TURN_LAYERS>(8.0, GateShape::default(), false, TURN_CELLS)
        .map_err(|e| e.to_string())?;
    let config = Config::default();
    let input = Input {
        steps: &steps,
        late: &late,
        on_time: &on_time,
        truth: &truth,
        design: &design,
        config: &config,
        frontend: frontend_of(&steps)?,
        first_riser: None,
        end_observation: true,
    };
    let runs = four::<TURN_CELLS, TURN_LAYERS, { stairs::SLOTS }>(&input)?;
    Ok(scene_result(
        "turning",
        format!(
            "SICK LMS291 panned ±45° at 75°/s, turning in place at {TURN_RAD_S} rad/s for \
             {:.0} s in a {} m × {} m room (2 m walls, two pillars); the paper's pyramid to 8 m",
            sim_config.trajectory.duration_s(),
            2.0 * ROOM_HALF_M.0,
            2.0 * ROOM_HALF_M.1
        ),
        &steps,
        &late,
        &runs,
    ))
}

/// The LD19 scene's setup: its stairs run, quick or full.
pub fn ld19_setup(quick: bool) -> Ld19Setup {
    if quick {
        Ld19Setup {
            stand_distance_m: 6.05,
            stand_s: 2.0,
            ..Ld19Setup::FULL
        }
    } else {
        Ld19Setup::QUICK
    }
}

/// The LD19 nodding on the robot driving up the stairs.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn ld19_scene(quick: bool, feed: &PoseFeed) -> Result<SceneResult, String> {
    const W: usize = super::lidar::STAIRS_CELLS;
    const L: usize = super::lidar::LAYERS;
    let setup = ld19_setup(quick);
    let scene_config = setup.scene_config();
    let sim_config = LidarSimConfig {
        sample_poses: true,
        ..ld19_sim(
            scene_config.scene.clone(),
            scene_config.trajectory,
            setup.seed,
        )
    };
    let sim = simulate_lidar(&sim_config).map_err(|e| e.to_string())?;
    let steps = steps(&sim.bytes)?;
    let late = late_poses(
        &sim_config.trajectory,
        &sim_config.scene,
        sim.duration_us,
        feed,
    );
    let on_time = on_time_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let truth = true_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let design = Ld19Design::from_datasheet()
        .pyramid::<L>(setup.range_m, GateShape::default(), true, W)
        .map_err(|e| e.to_string())?;
    let (_, first) = stairs::step_cells(&scene_config);
    let riser_x = scene_config.scene.target_x.unwrap_or(0.0);
    let config = no_clamp();
    let input = Input {
        steps: &steps,
        late: &late,
        on_time: &on_time,
        truth: &truth,
        design: &design,
        config: &config,
        frontend: frontend_of(&steps)?,
        first_riser: Some((&first, riser_x)),
        end_observation: true,
    };
    let runs = four::<W, L, { stairs::SLOTS }>(&input)?;
    Ok(scene_result(
        "ld19",
        format!(
            "LD19 nodding 2°–35° at 20°/s on a servo, standing {} s {:.2} m from the stairs, \
             then driving at {} m/s to {} m; soft-gated pyramid, every layer 0.1 m, to {} m",
            setup.stand_s,
            setup.stand_distance_m,
            setup.speed_mps,
            setup.stop_distance_m,
            setup.range_m
        ),
        &steps,
        &late,
        &runs,
    ))
}

/// The three scenes.
///
/// # Errors
/// A scene's setup was refused.
pub fn run_all(quick: bool, feed: &PoseFeed) -> Result<TimingResult, String> {
    Ok(TimingResult {
        feed: *feed,
        quick,
        scenes: vec![
            stairs_scene(quick, feed)?,
            turning_scene(quick, feed)?,
            ld19_scene(quick, feed)?,
        ],
    })
}

/// Arguments of `lab timing`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The directory `timing.json` and `timing.md` are written into.
    #[arg(long, value_name = "DIR", default_value = "target/lab/timing")]
    pub out: std::path::PathBuf,
    /// Print the results as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Short scenes (the stairs 8 m away after 2 s, 8 s of turning, the LD19 6 m from the
    /// stairs after 2 s), for the tests.
    #[arg(long)]
    pub quick: bool,
    /// Poses a second of the late feed.
    #[arg(long, default_value_t = PoseFeed::ROBOT.rate_hz)]
    pub pose_hz: f64,
    /// The late feed's mean delay, ms.
    #[arg(long, default_value_t = PoseFeed::ROBOT.late_ms)]
    pub late_ms: f64,
    /// The late feed's jitter, ± ms (uniform).
    #[arg(long, default_value_t = PoseFeed::ROBOT.jitter_ms)]
    pub jitter_ms: f64,
}

fn pct(v: f64) -> String {
    format!("{:.2} %", 100.0 * v)
}

fn metres(v: Option<f64>) -> String {
    v.map_or_else(|| "never".to_string(), |d| format!("{d:.2} m"))
}

/// The results as a Markdown section (`timing.md`, and `lab experiments`' report).
pub fn report(r: &TimingResult) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Poses on the laser's clock\n\nEach scene's recording through the co-processor \
         (in process, its clock the recording's time) three ways: **lock-step** (the \
         reference: the simulator casts each SICK beam and lidar sample from the true pose at \
         its own moment; the trajectory at 1 kHz, stamped and delivered at once, places every \
         return at its true pose), **timed** \
         (the trajectory at {} Hz, each pose stamped with its time and delivered {} ± {} ms \
         late through `CoProcessor::stamped_pose`) and **latest pose** (the same late poses, \
         unstamped, applied on arrival: version 3's rule), and a control, **on time** (the \
         trajectory at 250 Hz, stamped and delivered at once: the device's placement \
         with perfect poses). Cells: every layer's cells known \
         in either map, by world index; equal = the lock-step map's value exactly, same side \
         = both obstacle evidence or both navigable. First step: the stairs experiment's \
         definition (half the first riser's cells obstacle), looked at after every \
         observation.{}\n",
        r.feed.rate_hz,
        r.feed.late_ms,
        r.feed.jitter_ms,
        if r.quick { " Quick sizes." } else { "" }
    );
    for sc in &r.scenes {
        let _ = writeln!(
            s,
            "### {}\n\n{} ({:.1} s, {} laser events, {} late poses).\n\n| poses | cells equal \
             (worst layer) | same side | known cells | first step seen at | Δ vs lock-step | \
             returns extrapolated | returns refused | poses refused |\n| --- | --- | --- | --- \
             | --- | --- | --- | --- | --- |",
            sc.scene, sc.description, sc.duration_s, sc.laser_events, sc.late_poses
        );
        for (name, f, delta) in [
            ("lock-step", &sc.lock_step, Some(0.0)),
            ("timed", &sc.timed, sc.timed_first_step_delta_m),
            ("latest pose", &sc.latest, sc.latest_first_step_delta_m),
            ("on time (control)", &sc.on_time, None),
        ] {
            let _ = writeln!(
                s,
                "| {name} | {} ({}) | {} | {} | {} | {} | {} | {} | {} |",
                pct(f.cells.equal_share),
                pct(f.cells.worst_layer_equal_share),
                pct(f.cells.same_side_share),
                f.cells.known,
                metres(f.first_step_m),
                delta.map_or_else(|| "-".into(), |d| format!("{d:+.2} m")),
                f.returns_extrapolated,
                f.returns_without_pose,
                f.poses_refused
            );
        }
        let _ = writeln!(
            s,
            "\nAgainst the on-time control (the late feed's own effect): timed {} equal \
             (worst layer {}), latest pose {} equal (worst layer {}).\n",
            pct(sc.timed_vs_on_time.equal_share),
            pct(sc.timed_vs_on_time.worst_layer_equal_share),
            pct(sc.latest_vs_on_time.equal_share),
            pct(sc.latest_vs_on_time.worst_layer_equal_share)
        );
    }
    s
}

/// Runs `lab timing`.
pub fn run_command(args: &Args) -> std::process::ExitCode {
    let feed = PoseFeed {
        rate_hz: args.pose_hz,
        late_ms: args.late_ms,
        jitter_ms: args.jitter_ms,
        ..PoseFeed::ROBOT
    };
    let quick = args.quick;
    let worker = std::thread::Builder::new()
        .name("timing".into())
        .stack_size(64 << 20)
        .spawn(move || run_all(quick, &feed));
    let result = match worker {
        Ok(h) => h
            .join()
            .unwrap_or_else(|_| Err("the timing thread panicked".into())),
        Err(e) => Err(format!("cannot start the timing thread: {e}")),
    };
    let written = result.and_then(|r| {
        std::fs::create_dir_all(&args.out)
            .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
        let json = serde_json::to_string_pretty(&r).map_err(|e| e.to_string())?;
        terrain_pyramid_host::export::write_file(&args.out.join("timing.json"), json.as_bytes())?;
        terrain_pyramid_host::export::write_file(
            &args.out.join("timing.md"),
            report(&r).as_bytes(),
        )?;
        Ok(r)
    });
    match written {
        Ok(r) => {
            if args.json {
                match serde_json::to_string(&r) {
                    Ok(j) => println!("{j}"),
                    Err(e) => {
                        eprintln!("error: {e}");
                        return std::process::ExitCode::FAILURE;
                    }
                }
            } else {
                eprint!("{}", report(&r));
            }
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
