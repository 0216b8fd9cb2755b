//! The bodies of the host's commands that have no module of their own: Pose, PanAngle,
//! Configure (with its clamp and gate requests) and the snapshot's scope, and their lengths
//! and flags.

use super::MAX_LAYERS;
use crate::angle::Angle;

/// Bytes of a Pose body: the six pose fields, the stamp and the flags.
pub(crate) const POSE_LEN: usize = 29;
/// Pose's `flags` bit 0: `stamp_us` is valid and the pose joins the device's pose track;
/// clear, the pose applies to every return from now on (version 3's latest-pose rule).
pub const POSE_STAMPED: u8 = 1;
/// Pose's `flags` bits a receiver knows; any other bit set is out of range.
pub const POSE_FLAGS_KNOWN: u8 = POSE_STAMPED;
/// Bytes of a PanAngle body.
pub(crate) const PAN_LEN: usize = 6;
/// Bytes of a Configure body: 61 of version 2, the decay mode and 32 time-constant codes.
pub(crate) const CONFIGURE_LEN: usize = 61 + 1 + MAX_LAYERS;
/// Configure's `flags` bit 0: every layer at the base cell size ([`Configure::uniform_resolution`]).
pub const CONFIGURE_UNIFORM_RESOLUTION: u8 = 1;
/// Configure's `flags` bits a receiver knows; any other bit set is refused.
pub(crate) const CONFIGURE_FLAGS_KNOWN: u8 = CONFIGURE_UNIFORM_RESOLUTION;

/// `f32`s: the device converts it with the geometry's own rule,
/// [`crate::geometry::Pose::from_f32`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseReport {
    /// x, metres; |x| < 30 000.
    pub x_m: f32,
    /// y, metres; |y| < 30 000.
    pub y_m: f32,
    /// z, metres; |z| < 1 000.
    pub z_m: f32,
    /// Roll about x, radians; finite, |v| < 32 768.
    pub roll_rad: f32,
    /// Pitch about y, radians; finite, |v| < 32 768.
    pub pitch_rad: f32,
    /// Yaw about z, radians, counter-clockwise from +x; finite, |v| < 32 768.
    pub yaw_rad: f32,
    /// The device's µs clock (wrapping) at which the robot was at this pose; read only when
    /// `flags` has [`POSE_STAMPED`].
    pub stamp_us: u32,
    /// Bit 0 [`POSE_STAMPED`]; every other bit must be 0 (the device refuses the pose).
    pub flags: u8,
}

impl PoseReport {
    /// An unstamped pose (`stamp_us` and `flags` 0) from `[x, y, z]` in metres and
    /// `[roll, pitch, yaw]` in radians, in that order; each within its field's bounds for the
    /// device to take it.
    #[must_use]
    pub const fn unstamped(pose: [f32; 6]) -> Self {
        let [x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad] = pose;
        Self {
            x_m,
            y_m,
            z_m,
            roll_rad,
            pitch_rad,
            yaw_rad,
            stamp_us: 0,
            flags: 0,
        }
    }

    /// Whether the pose is stamped ([`POSE_STAMPED`]): it joins the device's pose track.
    #[must_use]
    pub const fn is_stamped(&self) -> bool {
        self.flags & POSE_STAMPED != 0
    }
}

/// Host to device: the pan angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PanAngle {
    /// The angle, `turns / 65 536` of a turn.
    pub turns: u16,
    /// The host's clock, ms.
    pub timestamp_ms: u32,
}

impl PanAngle {
    /// The angle as an [`Angle`].
    #[must_use]
    pub const fn angle(&self) -> Angle {
        Angle::from_bits(self.turns)
    }
}

/// Clamping as a Configure asks for it, nats (validated by [`crate::Clamp::bounds`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ClampRequest {
    /// No clamping.
    Off,
    /// Bounds, nats.
    Bounds {
        /// The lower bound, < 0.
        min: f32,
        /// The upper bound, > 0.
        max: f32,
    },
}

/// The gate as a Configure asks for it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GateRequest {
    /// The top-hat over each band (tag 0).
    Hard,
    /// The Gaussian around each band's centre (tag 1), its σ this factor of the band's width.
    Soft {
        /// σ_g / band width.
        width_factor: f32,
    },
}

/// Host to device: a new design and configuration, as the wire carries it (unvalidated: the
/// device checks it with the library's own rules, [`crate::link::convert`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Configure {
    /// φ, the vertical angular resolution, radians.
    pub phi_rad: f32,
    /// ψ, the horizontal angular resolution, radians.
    pub psi_rad: f32,
    /// σ, the range noise, metres.
    pub sigma_m: f32,
    /// h, the sensor's height above the ground, metres.
    pub height_m: f32,
    /// The sensor's maximum range, metres.
    pub max_range_m: f32,
    /// Δd, the base cell size, metres.
    pub base_m: f32,
    /// γ, the linear scaling of the resolution schedule.
    pub gamma: f32,
    /// The gate.
    pub gate: GateRequest,
    /// W, cells per side.
    pub cells_per_side: u16,
    /// p(x | obstacle seen).
    pub p_obstacle: f32,
    /// p(x | navigable seen).
    pub p_free: f32,
    /// The prior p(x).
    pub prior: f32,
    /// Clamping.
    pub clamp: ClampRequest,
    /// The fused query's margin, nats.
    pub fused_margin: f32,
    /// Every layer at the base cell size (`flags` bit 0).
    pub uniform_resolution: bool,
    /// The decay mode: 0 off, 1 all evidence, 2 obstacle evidence only, 3 free evidence only
    /// (*checked*; `crate::decay::DecayMode`).
    pub decay_mode: u8,
    /// Each layer's decay time constant as a code: 0 = none, c = τ of 8 · ⌊(125 · 2^q · T_r +
    /// 2¹⁵) / 2¹⁶⌋ ms with c − 1 = 16q + r (`crate::decay::TimeConstant`).
    pub decay_tau: [u8; MAX_LAYERS],
}

/// Which layers a snapshot covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SnapshotScope {
    /// Every layer (`0xFF` on the wire).
    All,
    /// One layer, 0 ..= 254.
    Layer(u8),
}
