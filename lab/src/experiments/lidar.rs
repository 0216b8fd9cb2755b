//! The stairs and coverage experiments for an LDROBOT LD19 on a nodding servo, beside the
//! SICK on the paper's panned mount ([`super::stairs`], [`super::coverage`]).
//!
//! # The LD19 and its design
//! From the LD19's datasheet (LDROBOT "LD19 product manual", performance table): ranging
//! 0.02–12 m at 70 % reflectivity, scan rate 5–13 Hz (10 Hz typical), a fixed 4 500
//! measurements per second, ranging accuracy ±45 mm and standard deviation 10 mm over
//! 0.3–12 m, angular resolution "1°" typical (4 500 / 10 Hz = 450 per turn: 0.8°). The lidar
//! lies flat on a servo that nods it from 2° to 35° (positive looks down) at 15 °/s, 20 ms
//! behind its command, its spin centre 1.0 m above the ground (the paper's h).
//!
//! # The nod
//! Each rig nods at the rate its plan gives ([`nod`]: φ = 1.5° between two revolutions; LD19
//! 15 °/s, RPLIDAR A1 standard scan 8.25 °/s, YDLIDAR X4 10.5 °/s).
//!
//! The design's sensor model (`terrain_pyramid::SensorModel`) takes φ as the *vertical*
//! resolution and ψ as the *horizontal* one. On the nodding servo they swap roles against
//! the paper's panned SICK:
//! - **φ = 1.5°**: the tilt between successive revolutions (15 °/s ÷ 10 Hz), the vertical
//!   spacing of the scan lines;
//! - **ψ = 0.8°**: the spacing of the returns within a revolution (360° ÷ 450);
//! - **σ = 0.045 m**: the datasheet's ±45 mm accuracy (the simulator draws the 10 mm standard
//!   deviation; the design takes the larger, systematic bound);
//! - h = 1.0 m, maximum range 12 m (stairs) or 10 m (coverage, as for the SICK).
//!
//! # Why the design's resolutions
//! The paper's stairs experiment runs every layer at 0.1 m (the SICK keeps that pyramid):
//! its panned SICK draws vertical lines, and one 0.1 m cell holds a riser's whole profile. A
//! nodding lidar's lines run across the range instead, one tilt a revolution: on flat ground
//! they lie `d²·φ/h` apart (0.1 m at 2 m for the LD19, 0.42 m at 4 m), on a riser `d·φ`
//! apart in height (0.10 m at 4 m). Beyond 2 m a 0.1 m cell holds at most one line a
//! sweep, at one height, which looks flat on the ground, on a tread and on a riser alike: a
//! riser cell is marked only when two lines land on its 0.17 m face in the same sweep
//! (certain within `H/(2φ)` = 3.2 m, never beyond `H/φ` = 6.5 m), and takes free evidence
//! otherwise. The design's bound `δ(d)` grows with that spacing (its term `φ·(d² + h²)/h`):
//! a cell of the design's own resolution `r_k = k·γ·Δd` holds, in one sweep, the ground
//! before a riser, the riser and the tread behind it, and the plane rule sees the rise. The
//! rigs therefore run the design's own pyramid (the library's default schedule, up to 64
//! layers: more than a board holds, which [`on_board`] measures); the uniform one is
//! [`StairsSetup::uniform_layers`].
//!
//! The SICK's design is the paper's (φ = 0.5°, ψ = 2°, σ = 0.15 m). The recording carries one
//! actuator angle per packet (the angle at its mean sample time), which is what the host's
//! PanAngle gives the co-processor.

pub mod after_sweep;
pub mod nod;
pub mod on_board;
mod rig_table;
pub mod riser_sight;

pub use nod::{
    nod_period_s, rig_servo, PLANNED_STEP_M, RIG_PHI_DEG, SERVO, SERVO_ENDS_DEG, SERVO_LATENCY_MS,
    SURE_FROM_M,
};

use super::coverage::{self, Holes};
use super::designs;
use super::engine::{decode, Decoded, Map, Runner};
use super::picture;
use super::stairs::{self, MapResult, Watched};
use after_sweep::AfterSweep;
use serde::Serialize;
use std::path::Path;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{Config, Design, DesignError, GateShape, SensorModel};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::lidar::{
    simulate_lidar, LidarActuator, LidarKind, LidarSimConfig, LidarSimulation,
};
use terrain_pyramid_host_tests::sim::record::SimConfig;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// The spin centre's height, metres.
pub const HEIGHT_M: f64 = 1.0;
/// Window of the LD19's stairs maps: 12 m at 0.1 m (2 · 12 / 0.1 + 2 = 242, rounded up).
pub const STAIRS_CELLS: usize = 248;
/// Layer capacity of the LD19's maps.
pub const LAYERS: usize = 32;
/// Layer capacity of the nodding rigs' stairs maps: the RPLIDAR A1's φ = 3.64° needs 49
/// layers to reach 12 m.
pub const RIG_LAYERS: usize = 64;

/// The LD19's design inputs, from its datasheet (see the module documentation).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Ld19Design {
    /// φ, the vertical resolution: the tilt between revolutions, degrees.
    pub phi_deg: f64,
    /// ψ, the horizontal resolution: the return spacing, degrees.
    pub psi_deg: f64,
    /// σ, metres.
    pub sigma_m: f64,
    /// h, metres.
    pub height_m: f64,
}

impl Ld19Design {
    /// φ = 15 °/s ÷ 10 Hz = 1.5°, ψ = 360° ÷ (4 500 / 10) = 0.8°, σ = 0.045 m, h = 1.0 m.
    pub fn from_datasheet() -> Self {
        Self::for_kind(LidarKind::Ld19)
    }

    /// The same derivation for any lidar on its own nod ([`rig_servo`]): φ = the servo's rate
    /// ÷ the revolutions per second, 1.5° for every rig (RPLIDAR A1 standard scan:
    /// 8.25 ÷ 5.5; YDLIDAR X4: 10.5 ÷ 7), ψ = 360° ÷ returns per revolution (A1: 0.99°, X4: 0.50°), σ = 0.045 m
    /// for all (the LD19's ±45 mm; the RPLIDAR's and X4's "about 1 %" of range is 0.03 m at
    /// 3 m, and the noise term is the smallest of the bound's three beyond 1 m), h = 1.0 m.
    pub fn for_kind(kind: LidarKind) -> Self {
        Self::for_kind_at(kind, rig_servo(kind).2)
    }

    /// [`Ld19Design::for_kind`] on a servo nodding at `rate_deg_s`.
    pub fn for_kind_at(kind: LidarKind, rate_deg_s: f64) -> Self {
        Self {
            phi_deg: rate_deg_s / kind.rotation_hz(),
            psi_deg: 360.0 * kind.rotation_hz() / kind.sample_hz(),
            sigma_m: 0.045,
            height_m: HEIGHT_M,
        }
    }

    /// The library's sensor model with maximum range `range_m`.
    #[allow(clippy::cast_possible_truncation)]
    pub fn sensor(&self, range_m: f64) -> SensorModel {
        SensorModel {
            phi_rad: self.phi_deg.to_radians() as f32,
            psi_rad: self.psi_deg.to_radians() as f32,
            sigma_m: self.sigma_m as f32,
            height_m: self.height_m as f32,
            max_range_m: range_m as f32,
        }
    }

    /// The pyramid of this sensor (linear schedule, Δd = 0.1 m, γ = 2), every layer at Δd
    /// when `uniform`.
    ///
    /// # Errors
    /// The library's refusal.
    pub fn pyramid<const L: usize>(
        &self,
        range_m: f64,
        gate: GateShape,
        uniform: bool,
        cells: usize,
    ) -> Result<Design<L>, DesignError> {
        designs::pyramid_of(self.sensor(range_m), gate, uniform, cells)
    }
}

/// The LD19 on its servo, for a run over `scene` along `trajectory`.
pub fn ld19_sim(scene: Scene, trajectory: Trajectory, seed: u64) -> LidarSimConfig {
    rig_sim(LidarKind::Ld19, scene, trajectory, seed)
}

/// Lidar `kind` on its own nod ([`rig_servo`]; the LD19's sweep and height), for a run over
/// `scene` along `trajectory`.
pub fn rig_sim(kind: LidarKind, scene: Scene, trajectory: Trajectory, seed: u64) -> LidarSimConfig {
    servo_sim(kind, rig_servo(kind), scene, trajectory, seed)
}

/// Lidar `kind` on a servo `(lowest, highest tilt °, rate °/s, latency ms)`.
pub fn servo_sim(
    kind: LidarKind,
    servo: (f64, f64, f64, f64),
    scene: Scene,
    trajectory: Trajectory,
    seed: u64,
) -> LidarSimConfig {
    let (lo, hi, rate, latency) = servo;
    let mut c = LidarSimConfig::new(
        scene,
        kind,
        LidarActuator::servo(lo, hi, rate, latency),
        [0.0, 0.0, HEIGHT_M],
        trajectory,
    );
    c.seed = seed;
    c
}

/// The stairs run's settings for the LD19.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StairsSetup {
    /// Distance from the standing place to the first riser, metres (within the 12 m range).
    pub stand_distance_m: f64,
    /// Seconds standing there.
    pub stand_s: f64,
    /// Driving speed, m/s.
    pub speed_mps: f64,
    /// Where the robot stops, metres from the first riser.
    pub stop_distance_m: f64,
    /// The maps' range, metres.
    pub range_m: f64,
    /// The simulator's seed.
    pub seed: u64,
    /// Revolutions per observation; 0 (the recording's setup, the default): one observation
    /// per sweep of the servo.
    pub revolutions_per_observation: u32,
    /// The lidar on the servo (default the LD19).
    #[serde(skip)]
    pub kind: LidarKind,
    /// Another servo than the rig's own ([`rig_servo`], the default `None`): lowest and
    /// highest tilt (degrees), rate (°/s), latency (ms). The design's φ follows its rate.
    pub servo: Option<(f64, f64, f64, f64)>,
    /// Every pyramid layer at 0.1 m (the paper's stairs pyramid, which the SICK runs) when
    /// true; the design's own resolutions `r_k = k·γ·Δd` (the library's default schedule,
    /// up to [`RIG_LAYERS`] layers) when false, the default. See the module documentation,
    /// "Why the design's resolutions".
    pub uniform_layers: bool,
    /// Seconds the robot stands at the stop before the recording ends, ≥ 0 (default 0: the
    /// recording ends as the robot arrives).
    pub dwell_s: f64,
}

impl StairsSetup {
    /// 11.05 m from the stairs for 2 minutes (the LD19 reaches 12 m), then up to 1.0 m.
    pub const FULL: Self = Self {
        stand_distance_m: 11.05,
        stand_s: 120.0,
        speed_mps: 1.0,
        stop_distance_m: 1.0,
        range_m: 12.0,
        seed: 1,
        revolutions_per_observation: 0,
        kind: LidarKind::Ld19,
        servo: None,
        uniform_layers: false,
        dwell_s: 0.0,
    };
    /// `--quick`: 30 s of standing.
    pub const QUICK: Self = Self {
        stand_s: 30.0,
        ..Self::FULL
    };

    /// The servo the setup's lidar nods on: [`StairsSetup::servo`], else the rig's own.
    #[must_use]
    pub fn nod(&self) -> (f64, f64, f64, f64) {
        self.servo.unwrap_or_else(|| rig_servo(self.kind))
    }

    /// The SICK-shaped configuration of the same scene and trajectory (for the step cells).
    pub fn scene_config(&self) -> SimConfig {
        let mut config = stairs::approach_config(
            self.stand_distance_m,
            self.stand_s,
            self.speed_mps,
            self.stop_distance_m,
            LaserConfig::paper(),
        );
        config.trajectory.dwell_s = self.dwell_s.max(0.0);
        config
    }

    /// The setup's recording, simulated and decoded (its observations grouped as the setup
    /// asks), and the echoes it holds.
    ///
    /// # Errors
    /// The simulator's or the library's refusal.
    pub fn decoded(&self, classifier: &ClassifierConfig) -> Result<(Decoded, u64), String> {
        let (decoded, sim) = self.simulated(classifier)?;
        Ok((decoded, sim.echoes))
    }

    /// The setup's recording, simulated and decoded as [`StairsSetup::decoded`], with the
    /// simulation, which keeps the true points of [`riser_sight::hit_box`].
    ///
    /// # Errors
    /// The simulator's or the library's refusal.
    pub fn simulated(
        &self,
        classifier: &ClassifierConfig,
    ) -> Result<(Decoded, LidarSimulation), String> {
        let sim_config = LidarSimConfig {
            hit_box: Some(riser_sight::hit_box(self)),
            ..self.sim()
        };
        let sim = simulate_lidar(&sim_config).map_err(|e| e.to_string())?;
        let mut decoded = decode(&sim.bytes, classifier)?;
        if self.revolutions_per_observation > 0 {
            decoded.frontend.lines_per_observation = self.revolutions_per_observation;
        }
        Ok((decoded, sim))
    }

    /// The pyramid of the setup's rig (its design's resolutions unless `uniform_layers`) with
    /// the gate `gate`.
    ///
    /// # Errors
    /// The library's refusal of the design.
    pub fn pyramid<const L: usize>(&self, gate: GateShape) -> Result<Design<L>, DesignError> {
        Ld19Design::for_kind_at(self.kind, self.nod().2).pyramid(
            self.range_m,
            gate,
            self.uniform_layers,
            STAIRS_CELLS,
        )
    }

    /// The run of the setup's lidar.
    pub fn sim(&self) -> LidarSimConfig {
        let s = self.scene_config();
        let mut c = servo_sim(self.kind, self.nod(), s.scene, s.trajectory, self.seed);
        c.truth = s.truth;
        c
    }
}

/// The LD19's stairs result (the same measures as the SICK's).
#[derive(Debug, Clone, Serialize)]
pub struct StairsResult {
    /// The flat grid, no clamping.
    pub flat: MapResult,
    /// The flat grid with OctoMap's clamping.
    pub flat_clamped: MapResult,
    /// The LD19's pyramid (its design's resolutions unless the setup asks for uniform
    /// layers), hard gate.
    pub pyramid: MapResult,
    /// The same with the soft gate.
    pub pyramid_soft: MapResult,
    /// The settings.
    pub setup: StairsSetup,
    /// The design's inputs.
    pub design: Ld19Design,
    /// Layers of the LD19's pyramid.
    pub layers: usize,
    /// Step cells.
    pub step_cells: usize,
    /// Packets in the recording.
    pub packets: usize,
    /// Returns with an echo in the recording.
    pub echoes: u64,
    /// What the laser put on the first step, in brief ([`riser_sight`]).
    pub lit: riser_sight::Lit,
    /// The same, line by line.
    #[serde(skip)]
    pub sight: riser_sight::RiserSight,
}

/// Seconds of the recording between two looks at the maps: 0.1 m of driving at 1 m/s, the
/// resolution of "first step seen at".
const CHECK_PERIOD_S: f64 = 0.1;

/// Packets in [`CHECK_PERIOD_S`] of `decoded` (its packet rate over the whole recording; at
/// least 1): an LD19 sends 375 packets a second (4 500 samples, 12 a packet), an RPLIDAR in
/// standard scan 2 000 nodes (one a sample), a YDLIDAR X4 about 130 (5 000 samples at 7 Hz in
/// packets of up to 40, each turn opened by a one-sample packet).
pub(super) fn packets_per_check(decoded: &super::engine::Decoded) -> usize {
    let span_s = match (decoded.lines.first(), decoded.lines.last()) {
        #[allow(clippy::cast_precision_loss)]
        (Some(a), Some(b)) => b.time_us.saturating_sub(a.time_us) as f64 * 1e-6,
        _ => 0.0,
    };
    if span_s <= 0.0 {
        return 1;
    }
    #[allow(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss
    )]
    let n = (decoded.lines.len() as f64 / span_s * CHECK_PERIOD_S).round() as usize;
    n.max(1)
}

/// Runs the LD19's stairs with the classifier's thresholds and rule `classifier`; writes
/// `stairs-ld19.png` into `out` when given.
///
/// # Errors
/// The simulator or the library refused the setup, or the picture could not be written.
pub fn run_stairs(
    setup: &StairsSetup,
    classifier: &ClassifierConfig,
    out: Option<&Path>,
) -> Result<StairsResult, String> {
    let scene_config = setup.scene_config();
    let (decoded, sim) = setup.simulated(classifier)?;
    let watched = Watched::of(&scene_config);
    let design = Ld19Design::for_kind_at(setup.kind, setup.nod().2);
    let mut maps = stairs::four_maps::<STAIRS_CELLS, RIG_LAYERS>(
        &decoded,
        setup.range_m,
        |gate| setup.pyramid(gate),
        Config::default(),
    )?;
    let layers = maps.get(2).map_or(0, |m| m.layer_count());
    let pass = stairs::watch(
        &decoded,
        &mut maps,
        &watched,
        packets_per_check(&decoded),
        false,
        |_, _| {},
    );
    let count = decoded.lines.len();
    let robot = decoded.lines.last().map_or((0.0, 0.0), |l| l.robot_xy);
    let mut results = Vec::new();
    let mut panels = Vec::new();
    let region = watched.region();
    let names = [
        "LD19: flat grid, no clamping",
        "LD19: flat grid, OctoMap clamping",
        "LD19: pyramid, hard gate",
        "LD19: pyramid, soft gate",
    ];
    for (k, map) in maps.iter().enumerate() {
        let result = watched.result(map.as_ref(), &pass, k);
        let mut p = picture::panel(map.as_ref(), &region, robot, &watched.steps);
        p.title = format!(
            "{}: at {:.1} m, {:.0} % of step cells obstacle",
            names.get(k).copied().unwrap_or(""),
            setup.stop_distance_m,
            100.0 * result.near.obstacle
        );
        results.push(result);
        panels.push(p);
    }
    if let Some(dir) = out {
        picture::draw_panels(
            &dir.join("stairs-ld19.png"),
            "Stairs, an LD19 on a nodding servo (2°..35° at 15 °/s, h = 1.0 m): at 1.0 m from the first step",
            &panels,
            4,
        )?;
    }
    let [flat, flat_clamped, pyramid, pyramid_soft] = stairs::four(results)?;
    // Every map ends its observations on the same lines; the soft-gated pyramid's are read.
    let sight = riser_sight::sight(
        setup,
        classifier,
        &sim.hits,
        pass.integrated_s.get(3).map_or(&[], Vec::as_slice),
    );
    Ok(StairsResult {
        flat,
        flat_clamped,
        pyramid,
        pyramid_soft,
        setup: *setup,
        design,
        layers,
        step_cells: watched.steps.len(),
        packets: count,
        echoes: sim.echoes,
        lit: sight.summary(),
        sight,
    })
}

/// The LD19's coverage: the same gate and approach as the SICK's ([`coverage::Setup`]), the
/// LD19 on its servo standing 4 s (the 0.5 s hold and one sweep) instead of 2.4 s.
#[derive(Debug, Clone, Serialize)]
pub struct CoverageResult {
    /// The fixed 0.1 m grid.
    pub fixed: Holes,
    /// The pyramid of the LD19's design (default schedule, soft gate, 64² windows).
    pub pyramid: Holes,
    /// Layers of that pyramid.
    pub layers: usize,
    /// Packets in the recording.
    pub packets: usize,
}

/// The recording of the LD19's coverage run (the gate scene, standing 4 s then driving to
/// 2 m before the gate).
///
/// # Errors
/// The simulator's refusal.
pub fn coverage_recording(setup: &coverage::Setup) -> Result<LidarSimulation, String> {
    let sick = setup.sim();
    let trajectory =
        Trajectory::approach(4.0, setup.speed_mps, setup.gate_x, setup.stop_distance_m);
    simulate_lidar(&ld19_sim(sick.scene, trajectory, setup.seed)).map_err(|e| e.to_string())
}

/// Runs the LD19's coverage.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn run_coverage(setup: &coverage::Setup) -> Result<CoverageResult, String> {
    const SLOTS: usize = coverage::SLOTS;
    let sim = coverage_recording(setup)?;
    let decoded = decode(&sim.bytes, &setup.classifier)?;
    let e = |e: DesignError| e.to_string();
    let config = Config::default();
    let mut fixed: Box<dyn Map> = Box::new(Runner::<{ coverage::FIXED_CELLS }, 1, SLOTS>::new(
        "fixed",
        super::designs::flat(10.0, 0.1, coverage::FIXED_CELLS).map_err(e)?,
        config,
        decoded.frontend,
    )?);
    let mut pyramid: Box<dyn Map> = Box::new(Runner::<64, LAYERS, SLOTS>::new(
        "pyramid",
        Ld19Design::from_datasheet()
            .pyramid(10.0, GateShape::default(), false, 64)
            .map_err(e)?,
        config,
        decoded.frontend,
    )?);
    for line in &decoded.lines {
        fixed.line(line);
        pyramid.line(line);
    }
    fixed.flush();
    pyramid.flush();
    let robot = decoded.lines.last().map_or((0.0, 0.0), |l| l.robot_xy);
    let (sx, sy) = (
        robot.0 + f64::from(sim.setup.sensor_m[0]),
        robot.1 + f64::from(sim.setup.sensor_m[1]),
    );
    Ok(CoverageResult {
        fixed: coverage::holes(fixed.as_ref(), sx, sy),
        pyramid: coverage::holes(pyramid.as_ref(), sx, sy),
        layers: pyramid.layer_count(),
        packets: decoded.lines.len(),
    })
}

/// The nodding rigs of the simulator the stairs are measured on, each on the LD19's servo.
pub const RIGS: [(LidarKind, &str); 3] = [
    (LidarKind::Ld19, "LD19"),
    (LidarKind::RplidarStandard, "RPLIDAR A1 (standard scan)"),
    (LidarKind::YdlidarX4, "YDLIDAR X4"),
];

/// Phases of the nod sampled at the start of the approach (full runs).
pub const PHASES: usize = 8;

/// One stairs run of a rig: the pyramids' figures.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StandingRow {
    /// Seconds of standing before the approach.
    pub stand_s: f64,
    /// The flat grid (no clamping): step cells obstacle at the stop.
    pub flat_at_stop: f64,
    /// The hard-gated pyramid: step cells obstacle at the stop.
    pub hard_at_stop: f64,
    /// The hard-gated pyramid: distance at which the first step was first seen (null: never).
    pub hard_first_seen_m: Option<f64>,
    /// The soft-gated pyramid: step cells obstacle at the stop.
    pub soft_at_stop: f64,
    /// The soft-gated pyramid: distance at which the first step was first seen (null: never).
    pub soft_first_seen_m: Option<f64>,
    /// The soft-gated pyramid: step cells obstacle in the map a device shows at the stop
    /// ([`stairs::MapResult::arrived_fraction`]).
    pub soft_at_arrival: f64,
    /// The soft-gated pyramid: share of the flat ground before the stairs (|y| ≤ 1.5 m, up
    /// to 0.5 m before the first riser) obstacle at the stop, the observation in progress
    /// flushed into the map.
    pub soft_false_obstacles: f64,
    /// The same share in the map a device shows at the stop
    /// ([`stairs::MapResult::arrived_false_obstacle_fraction`]).
    pub soft_false_obstacles_at_arrival: f64,
    /// The soft-gated pyramid: share of the flat ground 0.5–2.5 m before the first riser
    /// obstacle when the first step was first seen (null: never seen).
    pub soft_ground_at_first_sight: Option<f64>,
    /// The soft-gated pyramid after the robot stood at the stop until the observation in
    /// progress ended ([`after_sweep::run`]; null: none ended within a nod).
    pub soft_after_sweep: Option<AfterSweep>,
    /// What the laser itself put on the first step ([`riser_sight::sight`]): the bound on
    /// any map's first sighting from the first step's own returns.
    pub lit: riser_sight::Lit,
}

/// A rig's stairs: standing 30 s, 120 s (and 300 s) and, in a full run, the approach started
/// at [`PHASES`] phases of one nod (120 s plus a fraction of the nod's period).
#[derive(Debug, Clone, Serialize)]
pub struct RigStairs {
    /// The rig's name.
    pub rig: &'static str,
    /// Its design's inputs.
    pub design: Ld19Design,
    /// Distance from the standing place to the first riser, metres.
    pub stand_distance_m: f64,
    /// One row per standing time.
    pub standing: Vec<StandingRow>,
    /// One row per phase of the nod (empty with `--quick`).
    pub phases: Vec<StandingRow>,
    /// The same phases after [`LONG_STAND_NODS`] more nods of standing (318 s and more; empty
    /// with `--quick`): row i starts the approach at the nod's phase and the lines' tilts of
    /// [`RigStairs::phases`]' row i, so the two differ in how long the robot stood (and in
    /// the range noise's draws).
    pub phases_long: Vec<StandingRow>,
}

/// Whole nods between the phase rows after 120 s and the long ones: 45 nods of 44
/// revolutions each (LD19 198 s, RPLIDAR A1 360 s, YDLIDAR X4 283 s), so each long row's
/// lines fall at its phase row's tilts (to the millisecond its start is rounded to); the long
/// rows stand 318 s and more.
pub const LONG_STAND_NODS: u32 = 45;

fn standing_row(
    kind: LidarKind,
    stand_s: f64,
    seed: u64,
    classifier: &ClassifierConfig,
) -> Result<StandingRow, String> {
    let (_, range) = kind.range_m();
    let setup = StairsSetup {
        stand_s,
        seed,
        kind,
        range_m: range,
        stand_distance_m: range - 0.95,
        ..StairsSetup::FULL
    };
    let r = run_stairs(&setup, classifier, None)?;
    let after = after_sweep::run(&setup, classifier)?;
    Ok(StandingRow {
        stand_s,
        flat_at_stop: r.flat.detected_fraction,
        hard_at_stop: r.pyramid.detected_fraction,
        hard_first_seen_m: r.pyramid.detect_distance_m,
        soft_at_stop: r.pyramid_soft.detected_fraction,
        soft_at_arrival: r.pyramid_soft.arrived_fraction,
        soft_first_seen_m: r.pyramid_soft.detect_distance_m,
        soft_false_obstacles: r.pyramid_soft.false_obstacle_fraction,
        soft_false_obstacles_at_arrival: r.pyramid_soft.arrived_false_obstacle_fraction,
        soft_ground_at_first_sight: r.pyramid_soft.false_obstacle_at_first_sight,
        soft_after_sweep: after,
        lit: r.lit,
    })
}

/// Every rig's stairs: standing 30 s and 120 s (`quick`), or 30, 120 and 300 s and
/// [`PHASES`] phases of the nod after 120 s.
///
/// # Errors
/// As [`run_stairs`].
pub fn run_rigs(
    quick: bool,
    seed: u64,
    classifier: &ClassifierConfig,
) -> Result<Vec<RigStairs>, String> {
    let times: &[f64] = if quick {
        &[30.0, 120.0]
    } else {
        &[30.0, 120.0, 300.0]
    };
    let mut out = Vec::new();
    for (kind, name) in RIGS {
        let standing = times
            .iter()
            .map(|&t| standing_row(kind, t, seed, classifier))
            .collect::<Result<Vec<_>, _>>()?;
        // The nod's phases after `from` seconds of standing.
        let phases_after = |from: f64| {
            if quick {
                return Ok(Vec::new());
            }
            #[allow(clippy::cast_precision_loss)]
            let step = nod_period_s(kind) / PHASES as f64;
            #[allow(clippy::cast_precision_loss)]
            (0..PHASES)
                .map(|i| {
                    let t = from + step * i as f64;
                    standing_row(kind, (t * 1000.0).round() / 1000.0, seed, classifier)
                })
                .collect::<Result<Vec<_>, _>>()
        };
        let phases = phases_after(120.0)?;
        let phases_long = phases_after(120.0 + f64::from(LONG_STAND_NODS) * nod_period_s(kind))?;
        let (_, range) = kind.range_m();
        out.push(RigStairs {
            rig: name,
            design: Ld19Design::for_kind(kind),
            stand_distance_m: range - 0.95,
            standing,
            phases,
            phases_long,
        });
    }
    Ok(out)
}

/// Both LD19 experiments, and every nodding rig's stairs.
#[derive(Debug, Clone, Serialize)]
pub struct Ld19Results {
    /// The stairs.
    pub stairs: StairsResult,
    /// The coverage.
    pub coverage: CoverageResult,
    /// The nodding rigs' stairs against standing time and the nod's phase.
    pub rigs: Vec<RigStairs>,
    /// The same rigs through the pyramid a board holds ([`on_board`]).
    pub on_board: Vec<on_board::BoardRig>,
}

/// Runs both, `quick` with 30 s of standing before the stairs.
///
/// # Errors
/// As [`run_stairs`] and [`run_coverage`].
pub fn run(
    quick: bool,
    seed: u64,
    coverage_setup: &coverage::Setup,
    out: Option<&Path>,
) -> Result<Ld19Results, String> {
    let mut setup = if quick {
        StairsSetup::QUICK
    } else {
        StairsSetup::FULL
    };
    setup.seed = seed;
    Ok(Ld19Results {
        stairs: run_stairs(&setup, &coverage_setup.classifier, out)?,
        coverage: run_coverage(coverage_setup)?,
        rigs: run_rigs(quick, seed, &coverage_setup.classifier)?,
        on_board: on_board::run_rigs(quick, seed, &coverage_setup.classifier)?,
    })
}

fn pct(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

/// The report's section: the LD19 beside the SICK.
pub fn report(
    r: &Ld19Results,
    sick: &stairs::StairsResult,
    sick_coverage: Option<&coverage::CoverageResult>,
) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let st = &r.stairs.setup;
    let d = &r.stairs.design;
    let _ = writeln!(
        s,
        "## An LD19 on a nodding servo, beside the SICK\n\nAn LDROBOT LD19 (4 500 returns/s at 10 Hz, 0.02–12 m, σ = 10 mm in the simulator) lies flat on a servo nodding it from {}° to {}° at {} °/s ({} ms behind its command), its spin centre h = {} m up; its 47-byte packets go through the library's decoder and `Frontend::packet`, one actuator angle per packet (`host-tests/src/sim/lidar.rs`). The design comes from its datasheet (`lab/src/experiments/lidar.rs`): φ = {:.1}° (the tilt between revolutions: 15 °/s ÷ 10 Hz, the plan for 0.17 m steps sure from 4 m), ψ = {:.1}° (360° ÷ 450 returns), σ = {} m (the datasheet's ±45 mm accuracy), h = {} m; its pyramid (the design's own resolutions, `r_k = k·γ·Δd`: on a nodding lidar uniform 0.1 m cells hold at most one scan line beyond 2 m) has {} layers. Stairs: the robot stands {:.2} m from the first step (the LD19 reaches 12 m) for {:.0} s, then drives at {} m/s to {} m; {} packets, {} echoes.\n",
        SERVO.0,
        SERVO.1,
        SERVO.2,
        SERVO.3,
        HEIGHT_M,
        d.phi_deg,
        d.psi_deg,
        d.sigma_m,
        d.height_m,
        r.stairs.layers,
        st.stand_distance_m,
        st.stand_s,
        st.speed_mps,
        st.stop_distance_m,
        r.stairs.packets,
        r.stairs.echoes
    );
    let _ = writeln!(
        s,
        "| map | LD19: step cells obstacle at {} m | LD19: first step seen at | LD19: false obstacles | SICK (paper's mount): step cells obstacle | SICK: first step seen at | SICK: false obstacles |\n| --- | --- | --- | --- | --- | --- | --- |",
        st.stop_distance_m
    );
    let m = |v: Option<f64>| v.map_or_else(|| "never".to_string(), |d| format!("{d:.2} m"));
    for (name, l, k) in [
        ("flat grid, no clamping", &r.stairs.flat, &sick.flat),
        (
            "flat grid, OctoMap clamping",
            &r.stairs.flat_clamped,
            &sick.flat_clamped,
        ),
        ("pyramid, hard gate", &r.stairs.pyramid, &sick.pyramid),
        (
            "pyramid, soft gate",
            &r.stairs.pyramid_soft,
            &sick.pyramid_soft,
        ),
    ] {
        let _ = writeln!(
            s,
            "| {name} | {} | {} | {} | {} | {} | {} |",
            pct(l.detected_fraction),
            m(l.detect_distance_m),
            pct(l.false_obstacle_fraction),
            pct(k.detected_fraction),
            m(k.detect_distance_m),
            pct(k.false_obstacle_fraction)
        );
    }
    let c = &r.coverage;
    let _ = writeln!(
        s,
        "\n![stairs, LD19](stairs-ld19.png)\n\nCoverage: the same gate and approach, the LD19 standing 4 s (its 0.5 s hold and one sweep) instead of 2.4 s; the pyramid of its design ({} layers, soft gate, 64² windows) against the fixed 0.1 m grid; {} packets.\n\n| map | LD19 holes | SICK holes |\n| --- | --- | --- |",
        c.layers, c.packets
    );
    let sick_holes =
        |h: Option<&Holes>| h.map_or_else(|| "n/a".to_string(), |h| pct(h.holes_fraction));
    let _ = writeln!(
        s,
        "| fixed 0.1 m grid | {} | {} |\n| pyramid | {} | {} |\n",
        pct(c.fixed.holes_fraction),
        sick_holes(sick_coverage.map(|k| &k.fixed)),
        pct(c.pyramid.holes_fraction),
        sick_holes(sick_coverage.map(|k| &k.pyramid)),
    );
    rig_table::rigs_report(&mut s, &r.rigs);
    on_board::report(&mut s, &r.on_board);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_design_comes_from_the_datasheet() {
        let d = Ld19Design::from_datasheet();
        assert!((d.phi_deg - 1.5).abs() < 1e-12);
        assert!((d.psi_deg - 0.8).abs() < 1e-12);
        assert!(d
            .pyramid::<LAYERS>(12.0, GateShape::Hard, true, STAIRS_CELLS)
            .is_ok());
        assert!(d
            .pyramid::<LAYERS>(10.0, GateShape::default(), false, 64)
            .is_ok());
    }

    /// The engine takes an LD19 recording's packets through `Frontend::packet`: a short run
    /// in front of the stairs gives packets, evidence and obstacle cells at the risers.
    #[test]
    fn the_engine_maps_an_ld19_recording() {
        let setup = StairsSetup {
            stand_distance_m: 3.05,
            stand_s: 2.0,
            ..StairsSetup::QUICK
        };
        let sim = simulate_lidar(&setup.sim()).unwrap();
        let decoded = decode(&sim.bytes, &ClassifierConfig::default()).unwrap();
        assert_eq!(decoded.lines.len() as u64, sim.packets);
        assert!(decoded.lines.iter().all(|l| l.packet.is_some()));
        let mut map = Runner::<64, LAYERS, 2048>::new(
            "pyramid",
            Ld19Design::from_datasheet()
                .pyramid(8.0, GateShape::default(), false, 64)
                .unwrap(),
            Config::default(),
            decoded.frontend,
        )
        .unwrap();
        for line in &decoded.lines {
            map.line(line);
        }
        map.flush();
        assert!(map.records() > 1000, "{}", map.records());
        let (steps, _) = stairs::step_cells(&setup.scene_config());
        assert!(stairs::shares(&map, &steps).obstacle > 0.5);
    }
}
