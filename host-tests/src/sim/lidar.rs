//! The spinning lidars: an LDROBOT LD06/LD19, a Slamtec RPLIDAR (standard scan or express
//! scan) or a YDLIDAR X4 on a nodding servo or on the paper's panned mount, ray-cast into a
//! [`Scene`] in `f64` and written as the byte streams the sensors send, in a recording of
//! version 2 with its sensor event (`docs/recording.md`, `docs/lidars.md`).
//!
//! # Timing
//! The sensor measures at a constant rate ([`LidarKind::sample_hz`]) while its head turns at
//! a constant rotation rate ([`LidarKind::rotation_hz`]): sample n is measured at
//! `t_n = n / sample_hz`, clockwise angle `φ_n = 360° · rotation_hz · t_n` (mod 360°). The
//! samples are grouped into the sensor's packets as the makers' manuals describe them:
//! - **LD06/LD19**: 12 consecutive samples per 47-byte packet (start and end angle of the
//!   first and last, 0.01°; speed in °/s; a millisecond time stamp wrapping at 30 000); about
//!   37.5 packets per revolution at 10 Hz; a packet crosses 360° where the head does.
//! - **RPLIDAR standard scan**: the response descriptor first, then one 5-byte node per
//!   sample, the S flag on the first node of each revolution, quality 47 for an echo.
//! - **RPLIDAR express scan**: the express descriptor, then 84-byte capsules of 32 samples;
//!   a capsule's angles are its start angle ωᵢ plus k/32 of the way to the next capsule's,
//!   less each cabin's dθ (the simulator sets dθ = (k mod 4)/8°, the sample's true angle
//!   being that compensated one); S on the stream's first capsule only (a revolution starts
//!   where the capsules' angles pass 360°).
//! - **YDLIDAR X4**: the scan descriptor first, then `AA 55` packets of up to 40 samples;
//!   every revolution begins with its start packet (CT bit 0 set, one sample). The angles on
//!   the wire (FSA, LSA) are first-level angles; the manual's second-level correction
//!   `atan(21.8·(155.3 − d)/(155.3·d))` is added by a reader, so the simulator casts each
//!   sample at its first-level angle plus that correction (found by iterating: the correction
//!   depends on the distance it gives).
//!
//! A packet leaves the sensor when its last sample is measured and arrives after its
//! transmission time at the sensor's baud rate (10 bits a byte). The recording's laser events
//! are **chunks** of bytes: one per packet, or for the RPLIDAR's standard scan the nodes of
//! [`LidarSimConfig::chunk_us`] together, stamped with the arrival of their last byte.
//!
//! # The actuator
//! - [`LidarActuator::Servo`]: a nodding servo driven along the library's sweep model
//!   ([`ServoSweep`]: triangle wave from min to max and back, after a 500 ms hold at min, the
//!   servo `latency` behind its command). The sweep begins at t = 0; during the hold the
//!   servo is taken to be at min. Tilted horizontal mount (`docs/lidars.md`).
//! - [`LidarActuator::Pan`]: the paper's panned vertical mount, a triangle wave ±half width.
//!
//! Each sample is cast at the actuator's angle at its own time (the servo moves during a
//! packet). A recording carries one actuator angle per chunk (an angle event before the
//! chunk's bytes, 2⁻¹⁶ turn): the angle at the mean time of the samples the chunk completes.
//! A co-processor that takes the recording's angles (the host's PanAngle) thus places a
//! chunk's samples at its mean angle, off by at most `rate × chunk span / 2` (0.07° for an
//! LD19 packet at 60 °/s; `docs/lidars.md`, "Error budget").
//!
//! # Ranges
//! The true range gets Gaussian noise of σ ([`LidarSimConfig::sigma_m`]) and is rounded to the
//! sensor's unit (1 mm; ¼ mm for the RPLIDAR node and the YDLIDAR); no echo within the
//! maximum range, or a measured range below the minimum, is sent as 0 (no return).
//!
//! # Pose
//! The robot's pose (trajectory, `f32`-rounded) is taken at each chunk's time; a pose event is
//! written before a chunk when it changed. The samples of a chunk are cast from that pose, or
//! with [`LidarSimConfig::sample_poses`] each from the true pose at its own time.

use super::laser::{angle_to_u16, u16_to_angle_deg};
use super::rng::Rng;
use super::scene::{GroundTruthSpec, ObstacleCell, Ray, Scene};
use super::trajectory::{Pose, Trajectory};
use core::fmt;
use terrain_pyramid::actuator::{ServoProfile, ServoSweep};
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::laser::{Sensor, SensorKind};
use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{
    emit_header_version, Event, MountKind, Payload, RigEvent, SensorEvent,
};
use terrain_pyramid::wire::rplidar::RplidarScanMode;
use terrain_pyramid::wire::rplidar::{RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarNodeRepr};
use terrain_pyramid::wire::ydlidar::{YdlidarAngleCorrection, YdlidarDescriptorRepr, YdlidarRepr};

/// Which lidar, and how it scans.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LidarKind {
    /// LDROBOT LD06: 4 500 samples/s at 10 Hz, 0.02–12 m, 230 400 Bd.
    Ld06,
    /// LDROBOT LD19 (the LD06's protocol): 4 500 samples/s at 10 Hz, 0.02–12 m, 230 400 Bd.
    Ld19,
    /// Slamtec RPLIDAR A1 in standard scan: 2 000 samples/s at 5.5 Hz, 0.15–12 m, 115 200 Bd.
    RplidarStandard,
    /// Slamtec RPLIDAR A2 in express scan: 4 000 samples/s at 10 Hz, 0.15–12 m, 115 200 Bd.
    RplidarExpress,
    /// YDLIDAR X4: 5 000 samples/s at 7 Hz, 0.12–10 m, 128 000 Bd, second-level correction.
    YdlidarX4,
}

impl LidarKind {
    /// Every kind, in order.
    pub const ALL: [Self; 5] = [
        Self::Ld06,
        Self::Ld19,
        Self::RplidarStandard,
        Self::RplidarExpress,
        Self::YdlidarX4,
    ];

    /// A short name: `ld06`, `ld19`, `rplidar`, `rplidar-express`, `ydlidar`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Ld06 => "ld06",
            Self::Ld19 => "ld19",
            Self::RplidarStandard => "rplidar",
            Self::RplidarExpress => "rplidar-express",
            Self::YdlidarX4 => "ydlidar",
        }
    }

    /// The library's sensor (kind and mode) this stream is read with.
    #[must_use]
    pub const fn sensor(self) -> Sensor {
        match self {
            Self::Ld06 | Self::Ld19 => Sensor::Ld06,
            Self::RplidarStandard => Sensor::Rplidar(RplidarScanMode::Standard),
            Self::RplidarExpress => Sensor::Rplidar(RplidarScanMode::Express),
            Self::YdlidarX4 => Sensor::Ydlidar(YdlidarAngleCorrection::SecondLevel),
        }
    }

    /// The recording's sensor event.
    #[must_use]
    pub const fn sensor_event(self) -> SensorEvent {
        let sensor = self.sensor();
        SensorEvent {
            sensor: sensor.kind().code(),
            mode: sensor.mode(),
        }
    }

    /// Samples per second.
    #[must_use]
    pub const fn sample_hz(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 => 4_500.0,
            Self::RplidarStandard => 2_000.0,
            Self::RplidarExpress => 4_000.0,
            Self::YdlidarX4 => 5_000.0,
        }
    }

    /// Revolutions per second.
    #[must_use]
    pub const fn rotation_hz(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 | Self::RplidarExpress => 10.0,
            Self::RplidarStandard => 5.5,
            Self::YdlidarX4 => 7.0,
        }
    }

    /// The UART's baud rate.
    #[must_use]
    pub const fn baud(self) -> u32 {
        match self {
            Self::Ld06 | Self::Ld19 => 230_400,
            Self::RplidarStandard | Self::RplidarExpress => 115_200,
            Self::YdlidarX4 => 128_000,
        }
    }

    /// The shortest and longest range, metres.
    #[must_use]
    pub const fn range_m(self) -> (f64, f64) {
        match self {
            Self::Ld06 | Self::Ld19 => (0.02, 12.0),
            Self::RplidarStandard | Self::RplidarExpress => (0.15, 12.0),
            Self::YdlidarX4 => (0.12, 10.0),
        }
    }

    /// The range noise the makers state, metres (σ): LD19 10 mm (its datasheet's standard
    /// deviation, 0.3–12 m); RPLIDAR and X4 about 1 % of 1–3 m, taken as 15 mm.
    #[must_use]
    pub const fn sigma_m(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 => 0.010,
            Self::RplidarStandard | Self::RplidarExpress | Self::YdlidarX4 => 0.015,
        }
    }

    /// Samples per packet (the largest for the X4; one node for the RPLIDAR standard scan).
    #[must_use]
    pub const fn samples_per_packet(self) -> usize {
        match self {
            Self::Ld06 | Self::Ld19 => 12,
            Self::RplidarStandard => 1,
            Self::RplidarExpress => 32,
            Self::YdlidarX4 => 40,
        }
    }
}

/// What moves the lidar's scan plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LidarActuator {
    /// A nodding servo on the library's sweep model; the lidar lies flat (tilted horizontal
    /// mount).
    Servo(ServoProfile),
    /// The paper's panned vertical mount: ±`half_width_cdeg` (0.01°) at `rate_cdeg_s`.
    Pan {
        /// Half the sweep, 0.01°, 1 ..= 17 999.
        half_width_cdeg: u32,
        /// Rate, 0.01° per second, > 0.
        rate_cdeg_s: u32,
    },
}

impl LidarActuator {
    /// A servo nodding from `min_deg` to `max_deg` at `rate_deg_s`, `latency_ms` behind its
    /// command (the degrees rounded to 2⁻³² turn, the rate to 0.001 °/s, the latency to 1 µs).
    #[must_use]
    pub fn servo(min_deg: f64, max_deg: f64, rate_deg_s: f64, latency_ms: f64) -> Self {
        let fine = |deg: f64| {
            #[allow(clippy::cast_possible_truncation)]
            let bits = (deg / 360.0 * 4_294_967_296.0).round() as i64;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            FineAngle::from_bits(bits as u32)
        };
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Self::Servo(ServoProfile {
            min: fine(min_deg),
            max: fine(max_deg),
            rate_mdeg_per_s: (rate_deg_s * 1000.0).round() as u32,
            latency_us: (latency_ms * 1000.0).round() as u32,
        })
    }

    /// The mount a recording's setup names.
    #[must_use]
    pub const fn mount_kind(&self) -> MountKind {
        match self {
            Self::Servo(_) => MountKind::TiltedHorizontal,
            Self::Pan { .. } => MountKind::PannedVertical,
        }
    }

    /// The sweep rate, degrees per second.
    #[must_use]
    pub fn rate_deg_s(&self) -> f64 {
        match *self {
            Self::Servo(p) => f64::from(p.rate_mdeg_per_s) / 1000.0,
            Self::Pan { rate_cdeg_s, .. } => f64::from(rate_cdeg_s) / 100.0,
        }
    }
}

/// A lidar mounted otherwise than the preset of its actuator (`docs/lidars.md`, "The mount"):
/// its own frame (x its 0°, z its top) rotated by `R_z(yaw)·R_y(pitch)·R_x(roll)` relative to
/// the actuator's frame at zero, on the actuator of [`LidarActuator`] (a servo tilts about y,
/// the pan turns about z), which reports `zero + sense·a` for its angle a. The samples are
/// cast along the mounted sensor's directions and the recording's angle events carry the
/// reported angle: the bytes are what that sensor sends on that mount, untouched. The
/// recording (version 3) carries the rig event (`docs/recording.md`), which `pyramid run`
/// writes into the Setup's mount block; the setup event names the actuator's preset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimRig {
    /// Roll, pitch, yaw, degrees.
    pub rpy_deg: [f64; 3],
    /// The reported angle at the actuator's zero, degrees.
    pub zero_deg: f64,
    /// The actuator reports against its axis's positive sense.
    pub reversed: bool,
}

impl SimRig {
    /// An LD19 (or any lidar) upside down, its 0° to the left: roll 180°, yaw 90°.
    pub const UPSIDE_DOWN_ZERO_LEFT: Self = Self {
        rpy_deg: [180.0, 0.0, 90.0],
        zero_deg: 0.0,
        reversed: false,
    };
    /// A lidar standing with its 0° up and its top to the right: roll 90°, pitch −90°
    /// (sensor x to robot z, sensor y to robot −x, sensor z to robot −y).
    pub const STANDING_ZERO_UP: Self = Self {
        rpy_deg: [90.0, -90.0, 0.0],
        zero_deg: 0.0,
        reversed: false,
    };

    /// The sensor frame's rotation in the actuator's frame at zero.
    fn rotation(&self) -> [[f64; 3]; 3] {
        let [r, p, y] = self.rpy_deg.map(f64::to_radians);
        mat3(&rot(2, y), &mat3(&rot(1, p), &rot(0, r)))
    }

    /// The recording's rig event of this rig on `actuator` (a servo tilts, the pan pans): the
    /// general mount, no filter.
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn event(&self, actuator: &LidarActuator) -> RigEvent {
        RigEvent {
            mount: 2,
            mount_block: terrain_pyramid::wire::link::MountSetup {
                axis: match actuator {
                    LidarActuator::Servo(_) => 1,
                    LidarActuator::Pan { .. } => 0,
                },
                sense: if self.reversed { -1 } else { 1 },
                zero_deg: self.zero_deg as f32,
                rpy_deg: self.rpy_deg.map(|v| v as f32),
            },
            filter: terrain_pyramid::wire::link::FilterSetup::NONE,
        }
    }

    /// The reported angle of the actuator at `a` degrees.
    fn reported_deg(&self, a: f64) -> f64 {
        self.zero_deg + if self.reversed { -a } else { a }
    }
}

/// The rotation by `a` radians about axis `k` (0 x, 1 y, 2 z), right-handed.
fn rot(k: usize, a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    match k {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// The product of two 3 × 3 matrices.
fn mat3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    core::array::from_fn(|i| core::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// A signed [`FineAngle`] in degrees.
fn fine_deg(a: FineAngle) -> f64 {
    #[allow(clippy::cast_possible_wrap)]
    let signed = a.to_bits() as i32;
    f64::from(signed) * 360.0 / 4_294_967_296.0
}

/// The actuator's angle over time, degrees.
#[derive(Debug, Clone)]
struct Sweep {
    actuator: LidarActuator,
    servo: ServoSweep,
    lead_s: f64,
}

impl Sweep {
    fn new(actuator: LidarActuator, lead_s: f64) -> Self {
        let servo = match actuator {
            LidarActuator::Servo(profile) => {
                let mut s = ServoSweep::new(profile);
                s.begin(0);
                s
            }
            LidarActuator::Pan { .. } => ServoSweep::OFF,
        };
        Self {
            actuator,
            servo,
            lead_s: lead_s.max(0.0),
        }
    }

    /// The angle at `t` seconds, degrees.
    fn angle_deg(&mut self, t: f64) -> f64 {
        let t = t + self.lead_s;
        match self.actuator {
            LidarActuator::Servo(profile) => {
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let us = (t * 1e6).round() as u64;
                #[allow(clippy::cast_possible_truncation)]
                let us32 = us as u32;
                // Keeps the model's clock (the board's `track`), then asks for the angle.
                self.servo.track(us32);
                self.servo
                    .estimate(us32)
                    .map_or_else(|| fine_deg(profile.min), fine_deg)
            }
            LidarActuator::Pan {
                half_width_cdeg,
                rate_cdeg_s,
            } => {
                let w = f64::from(half_width_cdeg) / 100.0;
                let rate = f64::from(rate_cdeg_s) / 100.0;
                let s = (rate * t).rem_euclid(4.0 * w);
                -w + if s <= 2.0 * w { s } else { 4.0 * w - s }
            }
        }
    }
}

/// A simulated lidar run.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarSimConfig {
    /// The world.
    pub scene: Scene,
    /// The sensor.
    pub kind: LidarKind,
    /// Its actuator.
    pub actuator: LidarActuator,
    /// The spin centre in the robot frame, metres.
    pub position_m: [f64; 3],
    /// The range noise, metres (default: the kind's).
    pub sigma_m: f64,
    /// The robot's motion.
    pub trajectory: Trajectory,
    /// Revolutions per observation (the setup's lines per observation); 0 = one per sweep.
    /// Default: 0 on a servo, 2 on the pan.
    pub revolutions_per_observation: u32,
    /// RPLIDAR standard scan: nodes sent within this many µs make one chunk. Default 5 000.
    pub chunk_us: u32,
    /// Every `split_every`-th chunk is cut in two at a random byte; 0 = never. Default 10.
    pub split_every: u32,
    /// The seed of every random draw.
    pub seed: u64,
    /// The ground truth's grid and rule.
    pub truth: GroundTruthSpec,
    /// Seconds the servo's sweep had run before t = 0 (0, the default: it begins at t = 0
    /// with its 500 ms hold at min; 0.5 or more: it is already sweeping).
    pub servo_lead_s: f64,
    /// The lidar mounted otherwise than the actuator's preset (`None`, the default: the
    /// preset).
    pub rig: Option<SimRig>,
    /// Each sample cast from the robot's true pose at its own time (default `false`: every
    /// sample of a chunk from the pose at the chunk's first sample, the one its pose event
    /// gives).
    pub sample_poses: bool,
}

impl LidarSimConfig {
    /// A run of `kind` on `actuator` at `position_m` over `scene` along `trajectory`, with the
    /// defaults.
    #[must_use]
    pub fn new(
        scene: Scene,
        kind: LidarKind,
        actuator: LidarActuator,
        position_m: [f64; 3],
        trajectory: Trajectory,
    ) -> Self {
        Self {
            scene,
            kind,
            actuator,
            position_m,
            sigma_m: kind.sigma_m(),
            trajectory,
            revolutions_per_observation: match actuator.mount_kind() {
                MountKind::TiltedHorizontal => 0,
                MountKind::PannedVertical => 2,
            },
            chunk_us: 5_000,
            split_every: 10,
            seed: 1,
            truth: GroundTruthSpec::default(),
            servo_lead_s: 0.0,
            rig: None,
            sample_poses: false,
        }
    }

    /// The setup event (the variant fields, which a lidar ignores, say 180° at 0.5°).
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn setup(&self) -> Setup {
        Setup {
            mount: self.actuator.mount_kind(),
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: self.position_m.map(|v| v as f32),
            lines_per_observation: self.revolutions_per_observation,
        }
    }

    /// Checks the fields.
    ///
    /// # Errors
    /// The first one out of bounds.
    pub fn validate(&self) -> Result<(), LidarSimError> {
        self.trajectory.validate().map_err(LidarSimError)?;
        if !(self.sigma_m >= 0.0 && self.sigma_m.is_finite()) {
            return Err(LidarSimError("lidar: σ must be ≥ 0".into()));
        }
        if !self.position_m.iter().all(|v| v.is_finite()) {
            return Err(LidarSimError("lidar: the position must be finite".into()));
        }
        match self.actuator {
            LidarActuator::Servo(p) => {
                if p.span_bits() == 0 || p.rate_mdeg_per_s == 0 {
                    return Err(LidarSimError("lidar: the servo's sweep is empty".into()));
                }
            }
            LidarActuator::Pan {
                half_width_cdeg,
                rate_cdeg_s,
            } => {
                if !(1..18_000).contains(&half_width_cdeg) || rate_cdeg_s == 0 {
                    return Err(LidarSimError("lidar: the pan is out of bounds".into()));
                }
            }
        }
        Ok(())
    }
}

/// A configuration the lidar simulator refuses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LidarSimError(pub String);

impl fmt::Display for LidarSimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LidarSimError {}

/// A simulated lidar run: the recording and what is known about it.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarSimulation {
    /// The recording (version 2), header included.
    pub bytes: Vec<u8>,
    /// Its setup event.
    pub setup: Setup,
    /// Its sensor event.
    pub sensor: SensorEvent,
    /// Packets sent (nodes and capsules for the RPLIDAR, start packets for the X4).
    pub packets: u64,
    /// Samples measured (returns in packets, echoes or not).
    pub samples: u64,
    /// Samples with an echo (a range other than 0).
    pub echoes: u64,
    /// Revolutions begun (the sensor's start flags; the LD06 has none and counts wraps).
    pub revolutions: u64,
    /// Laser-byte events.
    pub laser_events: u64,
    /// Laser bytes.
    pub laser_bytes: u64,
    /// The time of the last event, µs.
    pub duration_us: u64,
    /// The obstacle cells of the scene.
    pub ground_truth: Vec<ObstacleCell>,
}

/// One measured sample.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    /// The clockwise angle on the wire (first-level for the X4, uncompensated for a capsule),
    /// degrees in [0, 360).
    wire_deg: f64,
    /// The range in the sensor's units (mm; mm·4 for RPLIDAR nodes and the X4), 0 = none.
    units: u32,
    /// The capsule's dθ, degrees·8 (express only).
    dtheta_q3: u8,
}

/// The ray-caster: sensor geometry, sweep, noise.
struct Caster<'a> {
    config: &'a LidarSimConfig,
    sweep: Sweep,
    rng: Rng,
    pose: Pose,
}

impl Caster<'_> {
    /// The true range along clockwise angle `phi_deg` at time `t`, metres (`None`: no echo).
    fn true_range(&mut self, t: f64, phi_deg: f64) -> Option<f64> {
        let a = self.sweep.angle_deg(t).to_radians();
        let theta = (90.0 - phi_deg).to_radians();
        let (s, c) = theta.sin_cos();
        let (sa, ca) = a.sin_cos();
        let d = match (self.config.rig, self.config.actuator.mount_kind()) {
            (None, MountKind::PannedVertical) => [s * ca, s * sa, -c],
            (None, MountKind::TiltedHorizontal) => [s * ca, -c, -s * sa],
            (Some(rig), kind) => {
                let axis = match kind {
                    MountKind::PannedVertical => 2,
                    MountKind::TiltedHorizontal => 1,
                };
                let m = mat3(&rot(axis, a), &rig.rotation());
                let v = [s, -c, 0.0];
                core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
            }
        };
        let pose = if self.config.sample_poses {
            self.config.trajectory.pose_at(t, &self.config.scene)
        } else {
            self.pose
        };
        let r = pose.rotation();
        let dir = core::array::from_fn(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]);
        let origin = pose.to_world(self.config.position_m);
        let (_, max) = self.config.kind.range_m();
        self.config
            .scene
            .cast(&Ray { origin, dir }, max)
            .map(|h| h.t)
    }

    /// A measured range in `per_m` units per metre, 0 for none or below the minimum.
    fn measure(&mut self, truth: Option<f64>, per_m: f64, max_units: u32) -> u32 {
        let Some(t) = truth else {
            return 0;
        };
        let (min, _) = self.config.kind.range_m();
        let m = t + self.config.sigma_m * self.rng.gaussian();
        if m < min {
            return 0;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let u = (m * per_m).round() as u32;
        u.min(max_units)
    }

    /// Measures sample `n`.
    fn sample(&mut self, n: u64) -> Sample {
        let kind = self.config.kind;
        #[allow(clippy::cast_precision_loss)]
        let t = n as f64 / kind.sample_hz();
        let wire_deg = (360.0 * kind.rotation_hz() * t).rem_euclid(360.0);
        match kind {
            LidarKind::Ld06 | LidarKind::Ld19 => {
                let truth = self.true_range(t, wire_deg);
                let units = self.measure(truth, 1000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3: 0,
                }
            }
            LidarKind::RplidarStandard => {
                // The node's angle is quantised to 1/64°: cast along what a reader sees.
                let q6 = (wire_deg * 64.0).round().rem_euclid(23_040.0);
                let truth = self.true_range(t, q6 / 64.0);
                let units = self.measure(truth, 4000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg: q6 / 64.0,
                    units,
                    dtheta_q3: 0,
                }
            }
            LidarKind::RplidarExpress => {
                #[allow(clippy::cast_possible_truncation)]
                let dtheta_q3 = (n % 4) as u8;
                let phi = (wire_deg - f64::from(dtheta_q3) / 8.0).rem_euclid(360.0);
                let truth = self.true_range(t, phi);
                let units = self.measure(truth, 1000.0, 0x3FFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3,
                }
            }
            LidarKind::YdlidarX4 => {
                // The true direction is the first-level angle plus the correction of the
                // distance it gives: iterate from the first-level angle.
                let mut truth = self.true_range(t, wire_deg);
                for _ in 0..3 {
                    let Some(d) = truth else { break };
                    let corr = ydlidar_correction_deg(d * 1000.0);
                    truth = self.true_range(t, wire_deg + corr);
                }
                let units = self.measure(truth, 4000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3: 0,
                }
            }
        }
    }
}

/// The X4's second-level correction of a distance in mm, degrees (the manual's formula).
#[must_use]
pub fn ydlidar_correction_deg(d_mm: f64) -> f64 {
    if d_mm <= 0.0 {
        return 0.0;
    }
    (21.8 * (155.3 - d_mm) / (155.3 * d_mm)).atan().to_degrees()
}

/// One unit of bytes the sensor sends: a packet (or a descriptor) and its samples.
struct Sent {
    bytes: Vec<u8>,
    /// The time its last byte left the sensor... plus the transmission: its arrival, s.
    arrival_s: f64,
    /// The samples it carries (their measurement times).
    sample_times: Vec<f64>,
    /// Its samples with an echo.
    echoes: u64,
    starts_revolution: bool,
}

/// Degrees to 0.01° on the wire, 0 ..= 35 999.
fn centideg(deg: f64) -> u16 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = ((deg * 100.0).round() as u32) % 36_000;
    #[allow(clippy::cast_possible_truncation)]
    let v = v as u16;
    v
}

/// Degrees to degrees·64 on the wire, 0 ..= 23 039.
fn q6(deg: f64) -> u16 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = ((deg * 64.0).round() as u32) % 23_040;
    #[allow(clippy::cast_possible_truncation)]
    let v = v as u16;
    v
}

fn u16_units(v: u32) -> u16 {
    u16::try_from(v).unwrap_or(u16::MAX)
}

/// The sensor's packets, one at a time.
struct Packets<'a> {
    caster: Caster<'a>,
    next_sample: u64,
    /// The X4's or the capsule's sample held back (the next capsule's first).
    pending: Vec<Sample>,
    byte_s: f64,
    header_sent: bool,
    last_deg: f64,
}

impl Packets<'_> {
    /// The time of the next sample to be measured, s.
    fn next_time(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let t = self.next_sample as f64 / self.caster.config.kind.sample_hz();
        t
    }

    fn take_sample(&mut self) -> Sample {
        let s = self.caster.sample(self.next_sample);
        self.next_sample += 1;
        s
    }

    fn sent(&self, bytes: Vec<u8>, samples: &[Sample], starts: bool) -> Sent {
        let last_t = samples.last().map_or(0.0, |s| s.t);
        #[allow(clippy::cast_precision_loss)]
        let tx = bytes.len() as f64 * self.byte_s;
        Sent {
            arrival_s: last_t + tx,
            sample_times: samples.iter().map(|s| s.t).collect(),
            echoes: samples.iter().filter(|s| s.units != 0).count() as u64,
            bytes,
            starts_revolution: starts,
        }
    }

    /// Whether the head passed 0° since the previous sample.
    fn wrapped(&mut self, deg: f64) -> bool {
        let w = deg < self.last_deg;
        self.last_deg = deg;
        w
    }

    fn next_packet(&mut self) -> Result<Sent, LidarSimError> {
        let kind = self.caster.config.kind;
        let err = |e: &dyn fmt::Debug| LidarSimError(format!("emit: {e:?}"));
        if !self.header_sent {
            self.header_sent = true;
            let mut buf = vec![0_u8; 7];
            let n = match kind {
                LidarKind::Ld06 | LidarKind::Ld19 => 0,
                LidarKind::RplidarStandard => RplidarDescriptorRepr::SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
                LidarKind::RplidarExpress => RplidarDescriptorRepr::EXPRESS_SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
                LidarKind::YdlidarX4 => YdlidarDescriptorRepr::SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
            };
            if n > 0 {
                buf.truncate(n);
                return Ok(self.sent(buf, &[], false));
            }
        }
        match kind {
            LidarKind::Ld06 | LidarKind::Ld19 => {
                let samples: Vec<Sample> = (0..12).map(|_| self.take_sample()).collect();
                let mut starts = false;
                let mut points = [Ld06Point::default(); 12];
                for (p, s) in points.iter_mut().zip(&samples) {
                    starts |= self.wrapped(s.wire_deg);
                    p.distance_mm = u16_units(s.units);
                    p.intensity = if s.units == 0 { 0 } else { 200 };
                }
                let first = samples.first().map_or(0.0, |s| s.wire_deg);
                let last = samples.last().map_or(0.0, |s| s.wire_deg);
                let t = samples.first().map_or(0.0, |s| s.t);
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let repr = Ld06Repr {
                    speed_deg_per_s: (360.0 * kind.rotation_hz()).round() as u16,
                    start_angle_centideg: centideg(first),
                    end_angle_centideg: centideg(last),
                    timestamp_ms: ((t * 1000.0).round() as u64 % 30_000) as u16,
                    points,
                };
                let mut buf = vec![0_u8; repr.buffer_len()];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &samples, starts))
            }
            LidarKind::RplidarStandard => {
                let s = self.take_sample();
                let start = self.wrapped(s.wire_deg);
                let repr = RplidarNodeRepr {
                    quality: if s.units == 0 { 0 } else { 47 },
                    start,
                    angle_q6: q6(s.wire_deg),
                    distance_q2: u16_units(s.units),
                };
                let mut buf = vec![0_u8; 5];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &[s], start))
            }
            LidarKind::RplidarExpress => {
                // A capsule is sent when its 32 samples are measured; its angles are read with
                // the next capsule's start angle (the reader waits for it).
                let samples: Vec<Sample> = (0..32).map(|_| self.take_sample()).collect();
                let mut starts = false;
                let mut repr = RplidarCapsuleRepr {
                    start_angle_q6: samples.first().map_or(0, |s| q6(s.wire_deg)),
                    ..RplidarCapsuleRepr::default()
                };
                for (k, s) in samples.iter().enumerate() {
                    starts |= self.wrapped(s.wire_deg);
                    if let (Some(d), Some(o)) = (
                        repr.distances_mm.get_mut(k),
                        repr.angle_offsets_q3.get_mut(k),
                    ) {
                        *d = u16_units(s.units);
                        *o = s.dtheta_q3;
                    }
                }
                // S marks the first capsule of the stream only (the SDK resets its pairing
                // there); a revolution starts where the angles pass 360°.
                repr.start_flag = self.next_sample == 32;
                let mut buf = vec![0_u8; repr.buffer_len()];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &samples, starts))
            }
            LidarKind::YdlidarX4 => {
                // A revolution begins with its start packet (one sample); then up to 40
                // samples, cut where the head passes 0°.
                let mut samples = std::mem::take(&mut self.pending);
                if samples.is_empty() {
                    let s = self.take_sample();
                    samples.push(s);
                }
                let first_wraps = samples.first().is_some_and(|s| s.wire_deg < self.last_deg);
                if first_wraps {
                    if let Some(s) = samples.first() {
                        self.last_deg = s.wire_deg;
                    }
                    return self.x4_packet(&samples, true);
                }
                if let Some(s) = samples.first() {
                    self.last_deg = s.wire_deg;
                }
                while samples.len() < 40 {
                    let s = self.take_sample();
                    if s.wire_deg < self.last_deg {
                        self.pending.push(s);
                        break;
                    }
                    self.last_deg = s.wire_deg;
                    samples.push(s);
                }
                self.x4_packet(&samples, false)
            }
        }
    }

    fn x4_packet(&self, samples: &[Sample], start: bool) -> Result<Sent, LidarSimError> {
        let raw: Vec<u16> = samples.iter().map(|s| u16_units(s.units)).collect();
        let repr = YdlidarRepr {
            packet_type: u8::from(start),
            first_angle_q6: samples.first().map_or(0, |s| q6(s.wire_deg)),
            last_angle_q6: samples.last().map_or(0, |s| q6(s.wire_deg)),
            samples: &raw,
        };
        let mut buf = vec![0_u8; repr.buffer_len()];
        repr.emit(&mut buf)
            .map_err(|e| LidarSimError(format!("emit: {e:?}")))?;
        Ok(self.sent(buf, samples, start))
    }
}

/// Appends one event to `out`.
fn push(out: &mut Vec<u8>, event: &Event<'_>) -> Result<(), LidarSimError> {
    let start = out.len();
    out.resize(start + event.buffer_len(), 0);
    let tail = out.get_mut(start..).unwrap_or_default();
    event
        .emit(tail)
        .map_err(|e| LidarSimError(format!("emit: {e}")))?;
    Ok(())
}

/// Salt of the split-point generator's seed.
const SPLIT_SALT: u64 = 0x11DA_C0DE_11DA_C0DE;

/// Runs the simulation and writes the recording: header, setup and sensor events at t = 0,
/// then per chunk (pose when changed, angle, bytes) until the trajectory's end.
///
/// # Errors
/// A configuration [`LidarSimConfig::validate`] refuses, or an emitter's refusal.
pub fn simulate_lidar(config: &LidarSimConfig) -> Result<LidarSimulation, LidarSimError> {
    config.validate()?;
    let setup = config.setup();
    let sensor = config.kind.sensor_event();
    // The lidar sits where the setup says (f32).
    let config = &LidarSimConfig {
        position_m: setup.sensor_m.map(f64::from),
        ..config.clone()
    };
    let duration = config.trajectory.duration_s();
    let mut bytes = vec![0_u8; 16];
    // A rig needs version 3 (its rig event); without one the file stays version 2.
    let version = if config.rig.is_some() {
        terrain_pyramid::wire::recording::VERSION
    } else {
        terrain_pyramid::wire::recording::VERSION_WITHOUT_RIG
    };
    emit_header_version(&mut bytes, version).map_err(|e| LidarSimError(format!("emit: {e}")))?;
    push(
        &mut bytes,
        &Event {
            time_us: 0,
            payload: Payload::Setup(setup),
        },
    )?;
    push(
        &mut bytes,
        &Event {
            time_us: 0,
            payload: Payload::Sensor(sensor),
        },
    )?;
    if let Some(rig) = config.rig {
        push(
            &mut bytes,
            &Event {
                time_us: 0,
                payload: Payload::Rig(rig.event(&config.actuator)),
            },
        )?;
    }
    let mut packets = Packets {
        caster: Caster {
            config,
            sweep: Sweep::new(config.actuator, config.servo_lead_s),
            rng: Rng::new(config.seed),
            pose: config.trajectory.pose_at(0.0, &config.scene).rounded_f32(),
        },
        next_sample: 0,
        pending: Vec::new(),
        byte_s: 10.0 / f64::from(config.kind.baud()),
        header_sent: false,
        last_deg: 0.0,
    };
    let mut angle_sweep = Sweep::new(config.actuator, config.servo_lead_s);
    let mut splits = Rng::new(config.seed ^ SPLIT_SALT);
    let mut sim = LidarSimulation {
        bytes: Vec::new(),
        setup,
        sensor,
        packets: 0,
        samples: 0,
        echoes: 0,
        revolutions: 0,
        laser_events: 0,
        laser_bytes: 0,
        duration_us: 0,
        ground_truth: config.scene.obstacle_cells(&config.truth),
    };
    let mut last_pose: Option<[f32; 6]> = None;
    let mut last_time_us = 0_u64;
    let mut chunks = 0_u64;
    let chunk_s = if config.kind == LidarKind::RplidarStandard {
        f64::from(config.chunk_us) * 1e-6
    } else {
        0.0
    };
    loop {
        // Gather one chunk: the packets that arrive within chunk_s of the first.
        let mut chunk: Vec<u8> = Vec::new();
        let mut times: Vec<f64> = Vec::new();
        let mut arrival = 0.0;
        let pose = config
            .trajectory
            .pose_at(packets.next_time(), &config.scene)
            .rounded_f32();
        packets.caster.pose = pose;
        loop {
            let sent = packets.next_packet()?;
            if chunk.is_empty() {
                arrival = sent.arrival_s;
            }
            let counted = !sent.sample_times.is_empty();
            sim.packets += u64::from(counted);
            sim.revolutions += u64::from(sent.starts_revolution);
            sim.samples += sent.sample_times.len() as u64;
            sim.echoes += sent.echoes;
            chunk.extend_from_slice(&sent.bytes);
            times.extend_from_slice(&sent.sample_times);
            let end = sent.arrival_s;
            arrival = arrival.max(end);
            if chunk_s <= 0.0 || end - times.first().copied().unwrap_or(end) >= chunk_s {
                break;
            }
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let now = ((arrival * 1e6).round() as u64).max(last_time_us);
        last_time_us = now;
        let pose_f32 = pose.to_f32();
        if last_pose != Some(pose_f32) {
            push(
                &mut bytes,
                &Event {
                    time_us: now,
                    payload: Payload::Pose(pose_f32),
                },
            )?;
            last_pose = Some(pose_f32);
        }
        if !times.is_empty() {
            #[allow(clippy::cast_precision_loss)]
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            push(
                &mut bytes,
                &Event {
                    time_us: now,
                    payload: Payload::Angle(angle_to_u16({
                        let a = angle_sweep.angle_deg(mean);
                        config.rig.map_or(a, |rig| rig.reported_deg(a))
                    })),
                },
            )?;
        }
        chunks += 1;
        let split = config.split_every != 0 && chunks.is_multiple_of(u64::from(config.split_every));
        let cut = if split && chunk.len() > 1 {
            usize::try_from(1 + splits.below(chunk.len() as u64 - 1)).unwrap_or(1)
        } else {
            chunk.len()
        };
        for part in [chunk.get(..cut), chunk.get(cut..)]
            .into_iter()
            .flatten()
            .filter(|p| !p.is_empty())
        {
            push(
                &mut bytes,
                &Event {
                    time_us: now,
                    payload: Payload::Laser(part),
                },
            )?;
            sim.laser_events += 1;
            sim.laser_bytes += part.len() as u64;
        }
        if arrival >= duration {
            break;
        }
    }
    sim.duration_us = last_time_us;
    sim.bytes = bytes;
    Ok(sim)
}

/// Echoes the decoder of the library finds in a simulated stream, with their decoded angle
/// (degrees, clockwise) and range (mm): the test's view of what a reader gets.
///
/// # Errors
/// A recording the reader refuses.
pub fn decoded_returns(bytes: &[u8]) -> Result<Vec<(f64, u32)>, String> {
    use terrain_pyramid::laser::{LaserDecoder, LaserItem};
    use terrain_pyramid::wire::recording::Reader;
    use terrain_pyramid::wire::FeedResult;
    let reader = Reader::new(bytes).map_err(|e| e.to_string())?;
    let mut decoder: Option<Box<LaserDecoder>> = None;
    let mut out = Vec::new();
    for event in reader {
        match event.map_err(|e| e.to_string())?.payload {
            Payload::Sensor(s) => {
                let sensor = SensorKind::from_code(s.sensor)
                    .and_then(|k| Sensor::from_kind_and_mode(k, s.mode))
                    .ok_or("bad sensor")?;
                decoder = Some(Box::new(LaserDecoder::new(sensor)));
            }
            Payload::Laser(mut rest) => {
                let d = decoder.as_mut().ok_or("laser bytes before the sensor")?;
                loop {
                    rest = match d.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: LaserItem::Packet(p),
                            remaining,
                            ..
                        } => {
                            for r in p.returns() {
                                out.push((
                                    f64::from(r.angle.to_bits()) * 360.0 / 4_294_967_296.0,
                                    r.range_mm,
                                ));
                            }
                            remaining
                        }
                        other => other.remaining(),
                    };
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

/// The recording's angle events in degrees, in order (for tests).
///
/// # Errors
/// A recording the reader refuses.
pub fn angle_events_deg(bytes: &[u8]) -> Result<Vec<f64>, String> {
    let reader = terrain_pyramid::wire::recording::Reader::new(bytes).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for event in reader {
        if let Payload::Angle(a) = event.map_err(|e| e.to_string())?.payload {
            out.push(u16_to_angle_deg(a));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A servo that stays at `deg` (after its hold at min = `deg`): 1 milli-degree per second.
    fn still(deg: f64) -> LidarActuator {
        LidarActuator::servo(deg, deg + 1.0, 0.001, 0.0)
    }

    fn run(kind: LidarKind, actuator: LidarActuator, seconds: f64, sigma: f64) -> LidarSimulation {
        let mut config = LidarSimConfig::new(
            Scene::flat(),
            kind,
            actuator,
            [0.0, 0.0, 1.0],
            Trajectory::standing(seconds),
        );
        config.sigma_m = sigma;
        simulate_lidar(&config).unwrap()
    }

    #[test]
    fn every_packet_decodes_at_the_makers_rates() {
        for kind in LidarKind::ALL {
            let sim = run(kind, still(20.0), 2.0, kind.sigma_m());
            let returns = decoded_returns(&sim.bytes).unwrap();
            // Every sample comes out of the library's decoder (an express capsule waits for
            // the next one: the last capsule's 32 stay in the reader).
            let held = if kind == LidarKind::RplidarExpress {
                32
            } else {
                0
            };
            assert_eq!(returns.len() as u64 + held, sim.samples, "{kind:?}");
            let expected = 2.0 * kind.sample_hz();
            let per_packet = kind.samples_per_packet() as f64;
            assert!(
                (sim.samples as f64 - expected).abs() <= per_packet + 12.0,
                "{kind:?}: {} samples in 2 s",
                sim.samples
            );
            // Revolutions: one start per turn (none before the first wrap).
            let turns = 2.0 * kind.rotation_hz();
            assert!(
                (sim.revolutions as f64 - turns).abs() <= 1.0,
                "{kind:?}: {} revolutions",
                sim.revolutions
            );
            // Echoes: what the simulator sent is what the decoder reads (all but the held
            // capsule's, which lie ahead on the floor at 20° of tilt).
            let echoes = returns.iter().filter(|r| r.1 != 0).count() as u64;
            assert!(echoes > 0 && echoes <= sim.echoes && echoes + held >= sim.echoes);
        }
    }

    /// The RPLIDAR's plausibility rule (`docs/lidars.md`) refuses no intact node: over the
    /// stairs while driving, on a nodding servo, panned, and standing still, with the
    /// sensor's noise, every sample the simulator sent comes out of the library's decoder
    /// with its angle and range, and the decoder counts none implausible.
    #[test]
    fn no_intact_rplidar_node_is_refused_as_implausible() {
        use terrain_pyramid::laser::{LaserDecoder, LaserItem};
        use terrain_pyramid::wire::recording::Reader;
        use terrain_pyramid::wire::FeedResult;
        let spec = super::super::scene::StairsSpec::default();
        let actuators = [
            LidarActuator::servo(2.0, 35.0, 20.0, 0.0),
            LidarActuator::Pan {
                half_width_cdeg: 4_500,
                rate_cdeg_s: 7_500,
            },
            still(20.0),
        ];
        for actuator in actuators {
            let config = LidarSimConfig::new(
                Scene::stairs(spec),
                LidarKind::RplidarStandard,
                actuator,
                [0.0, 0.0, 1.0],
                Trajectory::approach(1.0, 0.5, spec.first_riser_x, 3.0),
            );
            let sim = simulate_lidar(&config).unwrap();
            let returns = decoded_returns(&sim.bytes).unwrap();
            assert_eq!(returns.len() as u64, sim.samples, "{actuator:?}");
            assert_eq!(
                returns.iter().filter(|r| r.1 != 0).count() as u64,
                sim.echoes,
                "{actuator:?}"
            );
            let mut decoder = LaserDecoder::new(LidarKind::RplidarStandard.sensor());
            for event in Reader::new(&sim.bytes).unwrap() {
                if let Payload::Laser(mut rest) = event.unwrap().payload {
                    loop {
                        rest = match decoder.feed(rest) {
                            FeedResult::Consumed => break,
                            FeedResult::Item {
                                item: LaserItem::Packet(_),
                                remaining,
                                ..
                            } => remaining,
                            other => other.remaining(),
                        };
                    }
                }
            }
            let counts = decoder.counts();
            assert_eq!(counts.implausible, 0, "{actuator:?}");
            assert_eq!(u64::from(counts.ok), sim.samples, "{actuator:?}");
        }
    }

    #[test]
    fn ld06_packets_are_12_points_375_a_second() {
        let sim = run(LidarKind::Ld19, still(20.0), 1.0, 0.0);
        // 47-byte packets, one event each (some split in two).
        assert_eq!(sim.laser_bytes, 47 * sim.packets);
        assert!((374..=377).contains(&sim.packets), "{}", sim.packets);
    }

    /// With no noise, a still tilt of 20° and a flat floor 1 m down, every decoded return
    /// lies on the floor: the decoded angle (the library's reading of the stream, including
    /// the X4's correction and the capsules' dθ) and range place it at z = 0 in f64.
    #[test]
    fn decoded_returns_lie_on_the_floor() {
        let tau = 20.0_f64.to_radians();
        for kind in LidarKind::ALL {
            let sim = run(kind, still(20.0), 1.2, 0.0);
            let returns = decoded_returns(&sim.bytes).unwrap();
            let mut echoes = 0;
            let mut worst = 0.0_f64;
            for (phi, r) in returns {
                if r == 0 {
                    continue;
                }
                echoes += 1;
                let z = 1.0 - f64::from(r) / 1000.0 * phi.to_radians().cos() * tau.sin();
                worst = worst.max(z.abs());
            }
            assert!(echoes > 100, "{kind:?}: {echoes}");
            // Range rounding (≤ 0.5 mm) and angle quantisation (1/64° at 12 m: ≈ 2 mm of z).
            assert!(worst < 0.004, "{kind:?}: {worst} m off the floor");
        }
    }

    #[test]
    fn the_servo_nods_through_the_librarys_model() {
        let act = LidarActuator::servo(-5.0, 35.0, 40.0, 20.0);
        let sim = run(LidarKind::Ld19, act, 4.0, 0.01);
        let angles = angle_events_deg(&sim.bytes).unwrap();
        // The 500 ms hold at min, then up to 35° in 1 s, down in 1 s, ...
        let lo = angles.iter().copied().fold(f64::MAX, f64::min);
        let hi = angles.iter().copied().fold(f64::MIN, f64::max);
        assert!((lo + 5.0).abs() < 0.01, "{lo}");
        assert!((hi - 35.0).abs() < 0.2, "{hi}");
        // At 375 angle events a second and 40 °/s, consecutive angles differ by ≤ 0.11°.
        let step = angles
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(step < 0.12, "{step}");
    }

    #[test]
    fn the_pan_mount_looks_down_at_90_degrees() {
        let act = LidarActuator::Pan {
            half_width_cdeg: 4500,
            rate_cdeg_s: 2000,
        };
        let sim = run(LidarKind::Ld06, act, 0.5, 0.0);
        assert_eq!(sim.setup.mount, MountKind::PannedVertical);
        let returns = decoded_returns(&sim.bytes).unwrap();
        // Straight down (90° on the panned mount) is the floor, 1 m away.
        let down: Vec<u32> = returns
            .iter()
            .filter(|(phi, _)| (phi - 90.0).abs() < 0.5)
            .map(|&(_, r)| r)
            .collect();
        assert!(!down.is_empty());
        assert!(down.iter().all(|&r| (999..=1001).contains(&r)), "{down:?}");
    }

    #[test]
    fn deterministic() {
        let a = run(LidarKind::YdlidarX4, still(10.0), 0.5, 0.01);
        let b = run(LidarKind::YdlidarX4, still(10.0), 0.5, 0.01);
        assert_eq!(a, b);
    }
}
