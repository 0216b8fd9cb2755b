//! How the scanner sits on the robot: the plane it scans in and how its actuator moves that
//! plane ([`ScanPlane`]), and where its scan centre is in the robot frame ([`Mount`]).

use crate::units::Point3;

/// The scan plane and the actuator that sweeps it. θ is the beam angle (0° right, 90°
/// ahead, 180° left, see [`super::beams`]); the actuator angle is p (pan) or τ (tilt).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScanPlane {
    /// The paper's robot: the scan plane is vertical and an actuator pans it about the
    /// vertical (z) axis. Before panning, beam θ points along `(sin θ, 0, −cos θ)` (θ = 0°
    /// straight down, 90° forward, 180° straight up); panned by p (counter-clockwise seen
    /// from above, so p = 90° turns forward into left) it points along
    /// `(sin θ cos p, sin θ sin p, −cos θ)`.
    PannedVertical,
    /// The 3DTK data: the scan plane is horizontal and an actuator tilts it about the
    /// sideways (y) axis. Before tilting, beam θ points along `(sin θ, −cos θ, 0)` (θ = 0°
    /// right, 90° forward, 180° left); tilted by τ, positive looking *down*, through
    /// `R_y(τ)`: `x' = x cos τ + z sin τ`, `z' = −x sin τ + z cos τ`, it points along
    /// `(sin θ cos τ, −cos θ, −sin θ sin τ)`.
    TiltedHorizontal,
}

/// The scanner's mounting on the robot: its scan plane and actuator, and the position of its
/// scan centre in the robot frame.
///
/// The actuator's axis is taken to pass through the scan centre (the mirror): the actuator
/// turns the beams, not the centre. A lever arm between the axis and the mirror is not
/// modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mount {
    /// The scan plane and the actuator.
    pub plane: ScanPlane,
    /// The scan centre in the robot frame, metres (x forward, y left, z up; z is the mounting
    /// height above the robot's ground contact). Any value; world coordinates saturate.
    pub position: Point3,
}

impl Mount {
    /// A mount with the given plane and scan-centre position.
    #[must_use]
    pub const fn new(plane: ScanPlane, position: Point3) -> Self {
        Self { plane, position }
    }
}
