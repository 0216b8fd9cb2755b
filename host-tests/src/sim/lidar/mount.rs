//! How the simulated lidar is mounted and moved: its actuator (a nodding servo or the
//! paper's pan), a rig mounted otherwise than the actuator's preset, and the actuator's
//! angle over time.
use terrain_pyramid::actuator::{ServoProfile, ServoSweep};
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::wire::recording::{MountKind, RigEvent};

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
    pub(super) fn rotation(&self) -> [[f64; 3]; 3] {
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
    pub(super) fn reported_deg(&self, a: f64) -> f64 {
        self.zero_deg + if self.reversed { -a } else { a }
    }
}

/// The rotation by `a` radians about axis `k` (0 x, 1 y, 2 z), right-handed.
pub(super) fn rot(k: usize, a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    match k {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// The product of two 3 × 3 matrices.
pub(super) fn mat3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
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
pub(super) struct Sweep {
    actuator: LidarActuator,
    servo: ServoSweep,
    lead_s: f64,
}

impl Sweep {
    pub(super) fn new(actuator: LidarActuator, lead_s: f64) -> Self {
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
    pub(super) fn angle_deg(&mut self, t: f64) -> f64 {
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
