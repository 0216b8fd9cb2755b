//! How the scanner sits on the robot: the plane it scans in and how its actuator moves that
//! plane ([`ScanPlane`]), and where its scan centre is in the robot frame ([`Mount`]).

use crate::angle::FineAngle;
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

/// The geometry's beam angle θ of a spinning lidar's return at `clockwise`, the sensor's own
/// angle (clockwise seen from the sensor's top, from the manual's 0°; see
/// [`crate::wire::laser`]): `θ = 90° − clockwise`, exact (a wrapping subtraction).
///
/// The mounting this fixes, for both scan planes (the lidar's spin centre is the scan centre,
/// [`Mount::position`], on the actuator's axis):
/// - [`ScanPlane::TiltedHorizontal`] (a lidar on a nodding servo): the lidar lies flat, top
///   up, its 0° pointing forward (robot +x) at actuator angle 0: its 0° is θ = 90° (ahead),
///   its 90° (clockwise from above) θ = 0° (to the right), its 180° behind, its 270° to the
///   left. The servo tilts it about the robot's y axis, positive looking down ahead (and up
///   behind).
/// - [`ScanPlane::PannedVertical`]: the lidar stands on its side with its top facing right
///   (robot −y) and its 0° pointing forward: its 90° points straight down (θ = 0°), its 270°
///   straight up; the actuator pans that plane about z.
///
/// A lidar mounted otherwise (0° backwards, top facing left) gives mirrored or rotated maps:
/// mount it as above.
#[must_use]
pub const fn beam_angle_of_clockwise(clockwise: FineAngle) -> FineAngle {
    FineAngle::QUARTER.wrapping_sub(clockwise)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clockwise_angles_map_onto_the_beam_angle() {
        assert_eq!(beam_angle_of_clockwise(FineAngle::ZERO), FineAngle::QUARTER);
        assert_eq!(beam_angle_of_clockwise(FineAngle::QUARTER), FineAngle::ZERO);
        assert_eq!(
            beam_angle_of_clockwise(FineAngle::HALF),
            FineAngle::QUARTER.reversed()
        );
        assert_eq!(
            beam_angle_of_clockwise(FineAngle::from_bits(3 << 30)),
            FineAngle::HALF
        );
    }
}
