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
//!
//! [`CoProcessor`]: terrain_pyramid::app::CoProcessor
//! [`CoProcessor::stamped_pose`]: terrain_pyramid::app::CoProcessor::stamped_pose
//! [`CoProcessor::set_pose`]: terrain_pyramid::app::CoProcessor::set_pose

mod agreement;
mod poses;
mod runner;

pub use agreement::{agreement, Agreement, LayerAgreement};
pub use poses::{late_poses, on_time_poses, true_poses, LatePose, PoseFeed};
pub use runner::{
    pan_angle_frame, run, Input, PoseRule, RunCounters, RunOutcome, ON_TIME_PERIOD_US,
    TRUTH_PERIOD_US, TRUTH_TRACK,
};

use super::designs;
use super::lidar::{ld19_sim, Ld19Design, StairsSetup as Ld19Setup};
use super::stairs::{self, round3, Cell};
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::{frontend_config, setup_message_with_sensor};
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::{Config, Design, GateShape};
use terrain_pyramid_host::play::{steps, Step, Steps};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::lidar::{simulate_lidar, LidarSimConfig};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// One run's figures.
#[derive(Debug, Clone, Serialize)]
pub struct RunFigures {
    /// Its cells against the lock-step run's (the lock-step run: all equal).
    pub cells: Agreement,
    /// Its first-step distance and the device's counters (in the JSON beside `cells`).
    #[serde(flatten)]
    pub counters: RunCounters,
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
        counters: o.counters,
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
    let delta = |o: &RunOutcome| match (o.counters.first_step_m, lock.counters.first_step_m) {
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

/// A scene's decoded recording and the three pose feeds drawn from its trajectory.
struct Feeds {
    /// The decoded recording.
    steps: Steps,
    /// The late feed ([`late_poses`]).
    late: Vec<LatePose>,
    /// The on-time control's feed ([`on_time_poses`]).
    on_time: Vec<LatePose>,
    /// The reference's true poses ([`true_poses`]).
    truth: Vec<LatePose>,
}

impl Feeds {
    /// Decodes a simulated recording (`bytes`, `duration_us` µs long) and samples the robot's
    /// `motion` (its trajectory through the scene) for the three feeds.
    fn of(
        bytes: &[u8],
        duration_us: u64,
        motion: (&Trajectory, &Scene),
        feed: &PoseFeed,
    ) -> Result<Self, String> {
        let (trajectory, scene) = motion;
        Ok(Self {
            steps: steps(bytes)?,
            late: late_poses(trajectory, scene, duration_us, feed),
            on_time: on_time_poses(trajectory, scene, duration_us),
            truth: true_poses(trajectory, scene, duration_us),
        })
    }
}

/// Runs a scene's four runs on a `W`-cell, `L`-layer, `C`-slot co-processor booted with
/// `design` and `config` (the observation under way applied at the end) and gathers its
/// figures; `first_riser` as [`Input::first_riser`].
fn measure<const W: usize, const L: usize, const C: usize>(
    scene: &str,
    description: String,
    feeds: &Feeds,
    design: &Design<L>,
    config: &Config,
    first_riser: Option<(&[Cell], f64)>,
) -> Result<SceneResult, String> {
    let input = Input {
        steps: &feeds.steps,
        late: &feeds.late,
        on_time: &feeds.on_time,
        truth: &feeds.truth,
        design,
        config,
        frontend: frontend_of(&feeds.steps)?,
        first_riser,
        end_observation: true,
    };
    let runs = four::<W, L, C>(&input)?;
    Ok(scene_result(
        scene,
        description,
        &feeds.steps,
        &feeds.late,
        &runs,
    ))
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
    let motion = (&sim_config.trajectory, &sim_config.scene);
    let feeds = Feeds::of(&sim.bytes, sim.duration_us, motion, feed)?;
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
    let config = designs::unclamped();
    let description = format!(
        "SICK LMS291 panned ±45° at {}°/s, standing {} s {:.2} m from the stairs, then \
         driving at {} m/s to {} m; soft-gated pyramid, every layer 0.1 m, to {} m",
        setup.pan_rate_deg_s,
        setup.stand_s,
        setup.stand_distance_m,
        setup.speed_mps,
        setup.stop_distance_m,
        setup.range_m
    );
    measure::<{ stairs::CELLS }, { stairs::LAYERS }, { stairs::SLOTS }>(
        "stairs",
        description,
        &feeds,
        &design,
        &config,
        Some((&first, riser_x)),
    )
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
    let motion = (&sim_config.trajectory, &sim_config.scene);
    let feeds = Feeds::of(&sim.bytes, sim.duration_us, motion, feed)?;
    let design = designs::pyramid::<TURN_LAYERS>(8.0, GateShape::default(), false, TURN_CELLS)
        .map_err(|e| e.to_string())?;
    let config = Config::default();
    let description = format!(
        "SICK LMS291 panned ±45° at 75°/s, turning in place at {TURN_RAD_S} rad/s for \
         {:.0} s in a {} m × {} m room (2 m walls, two pillars); the paper's pyramid to 8 m",
        sim_config.trajectory.duration_s(),
        2.0 * ROOM_HALF_M.0,
        2.0 * ROOM_HALF_M.1
    );
    measure::<TURN_CELLS, TURN_LAYERS, { stairs::SLOTS }>(
        "turning",
        description,
        &feeds,
        &design,
        &config,
        None,
    )
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
    let motion = (&sim_config.trajectory, &sim_config.scene);
    let feeds = Feeds::of(&sim.bytes, sim.duration_us, motion, feed)?;
    let design = Ld19Design::from_datasheet()
        .pyramid::<L>(setup.range_m, GateShape::default(), true, W)
        .map_err(|e| e.to_string())?;
    let (_, first) = stairs::step_cells(&scene_config);
    let riser_x = scene_config.scene.target_x.unwrap_or(0.0);
    let config = designs::unclamped();
    let description = format!(
        "LD19 nodding {}°–{}° at {}°/s on a servo, standing {} s {:.2} m from the stairs, \
         then driving at {} m/s to {} m; soft-gated pyramid, every layer 0.1 m, to {} m",
        super::lidar::SERVO.0,
        super::lidar::SERVO.1,
        super::lidar::SERVO.2,
        setup.stand_s,
        setup.stand_distance_m,
        setup.speed_mps,
        setup.stop_distance_m,
        setup.range_m
    );
    measure::<W, L, { stairs::SLOTS }>(
        "ld19",
        description,
        &feeds,
        &design,
        &config,
        Some((&first, riser_x)),
    )
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
                metres(f.counters.first_step_m),
                delta.map_or_else(|| "-".into(), |d| format!("{d:+.2} m")),
                f.counters.returns_extrapolated,
                f.counters.returns_without_pose,
                f.counters.poses_refused
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
                if !terrain_pyramid_host::json_line::print(&r, "error: ") {
                    return std::process::ExitCode::FAILURE;
                }
            } else {
                eprint!("{}", report(&r));
            }
            std::process::ExitCode::SUCCESS
        }
        Err(e) => crate::command_failed(e),
    }
}
