//! How the scanner sits on the robot: the sensor's own frame placed on its actuator by a
//! rotation (roll, pitch, yaw), the actuator's axis, zero and sense, and the scan centre's
//! position in the robot frame ([`Mount`]); the two classic mounts are named presets
//! ([`ScanPlane`]).
//!
//! # Frames
//! - **The sensor's frame**, as its manual defines it: x its 0° direction, z its top (for a
//!   SICK LMS2xx x is its centre beam, 90°, and z its top). Beam θ (the geometry's angle,
//!   `θ = 90° − clockwise` for a spinning lidar, [`beam_angle_of_clockwise`]) has the
//!   sensor-frame direction `(sin θ, −cos θ, 0)`: θ = 90° along x, θ = 0° along −y (the
//!   sensor's right).
//! - **The actuator's frame at actuator zero**: x forward, y left, z up (the robot's axes).
//!   The sensor's frame sits in it rotated by `M = R_z(yaw)·R_y(pitch)·R_x(roll)` (REP-103,
//!   a URDF joint's `rpy`), its columns m₀, m₁, m₂ the images of the sensor's x, y, z.
//! - **The actuator** turns the sensor about an axis through the scan centre: [`ActuatorAxis::Pan`]
//!   about z (counter-clockwise seen from above, `R_z(a)`), [`ActuatorAxis::Tilt`] about y
//!   (positive looks down ahead, `R_y(a)`), or [`ActuatorAxis::Fixed`] (none). The angle the
//!   geometry uses is `a = sense·(reported − zero)` ([`Mount::actuator_angle`]).
//! - **The scan centre** sits at [`Mount::position`] in the robot frame at actuator zero; the
//!   actuator's axis passes through it (a lever arm is not modelled).
//!
//! With R the robot's rotation, beam θ at actuator angle a points in the world along
//! `cos θ·C(a) + sin θ·S(a)` with `C(a) = −R·A(a)·m₁` and `S(a) = R·A(a)·m₀`
//! ([`super::SweepTransform`]).
//!
//! # Presets
//! - [`ScanPlane::PannedVertical`] = rpy (90°, 0°, 0°), pan: the paper's robot; beam θ points
//!   along `(sin θ cos p, sin θ sin p, −cos θ)`.
//! - [`ScanPlane::TiltedHorizontal`] = rpy (0°, 0°, 0°), tilt: the 3DTK data and a lidar on a
//!   nodding servo; beam θ points along `(sin θ cos τ, −cos θ, −sin θ sin τ)`.
//!
//! Both have zero 0 and sense +1; their rotations are exact (entries 0 and ±2³⁰), so the
//! geometry of a preset gives the same bits as the two fixed mounts it generalises.

use crate::angle::FineAngle;
use crate::units::Point3;

use super::pose::Rotation;

/// One in Q2.30.
const ONE: i32 = 1 << 30;

/// The two classic mounts, as named presets of [`Mount`]. θ is the beam angle (0° right, 90°
/// ahead, 180° left, see [`super::beams`]); the actuator angle is p (pan) or τ (tilt).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScanPlane {
    /// The paper's robot: rpy (90°, 0°, 0°) on a pan actuator. The scan plane is vertical
    /// and the actuator pans it about the vertical (z) axis. Before panning, beam θ points
    /// along `(sin θ, 0, −cos θ)` (θ = 0° straight down, 90° forward, 180° straight up);
    /// panned by p (counter-clockwise seen from above, so p = 90° turns forward into left)
    /// it points along `(sin θ cos p, sin θ sin p, −cos θ)`.
    PannedVertical,
    /// The 3DTK data: rpy (0°, 0°, 0°) on a tilt actuator. The scan plane is horizontal and
    /// the actuator tilts it about the sideways (y) axis. Before tilting, beam θ points along
    /// `(sin θ, −cos θ, 0)` (θ = 0° right, 90° forward, 180° left); tilted by τ, positive
    /// looking *down*, through `R_y(τ)`: `x' = x cos τ + z sin τ`, `z' = −x sin τ + z cos τ`,
    /// it points along `(sin θ cos τ, −cos θ, −sin θ sin τ)`.
    TiltedHorizontal,
}

impl ScanPlane {
    /// The preset's roll, pitch and yaw.
    #[must_use]
    pub const fn rpy(self) -> [FineAngle; 3] {
        match self {
            Self::PannedVertical => [FineAngle::QUARTER, FineAngle::ZERO, FineAngle::ZERO],
            Self::TiltedHorizontal => [FineAngle::ZERO; 3],
        }
    }

    /// The preset's actuator axis.
    #[must_use]
    pub const fn axis(self) -> ActuatorAxis {
        match self {
            Self::PannedVertical => ActuatorAxis::Pan,
            Self::TiltedHorizontal => ActuatorAxis::Tilt,
        }
    }

    /// The preset's m₀ and m₁ (the images of the sensor's x and y), exact Q2.30.
    const fn columns(self) -> [[i32; 3]; 2] {
        match self {
            // R_x(90°): y → z.
            Self::PannedVertical => [[ONE, 0, 0], [0, 0, ONE]],
            Self::TiltedHorizontal => [[ONE, 0, 0], [0, ONE, 0]],
        }
    }
}

/// The axis the actuator turns the sensor about (through its scan centre).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ActuatorAxis {
    /// About the robot's z axis, counter-clockwise seen from above (`R_z(a)`).
    Pan,
    /// About the robot's y axis, positive looking down ahead (`R_y(a)`, REP-103).
    Tilt,
    /// No actuator: the actuator angle is ignored.
    Fixed,
}

impl ActuatorAxis {
    /// The axis of a wire code: 0 pan, 1 tilt, 2 none.
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Pan),
            1 => Some(Self::Tilt),
            2 => Some(Self::Fixed),
            _ => None,
        }
    }

    /// The wire code: 0 pan, 1 tilt, 2 none.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Pan => 0,
            Self::Tilt => 1,
            Self::Fixed => 2,
        }
    }
}

/// The scanner's mounting on the robot: the sensor's frame on its actuator (a rotation
/// given as roll, pitch, yaw), the actuator's axis, zero and sense, and the position of its
/// scan centre in the robot frame (see the [module documentation](self) for the frames).
///
/// The rotation is kept as the two columns the geometry reads (m₀, m₁, Q2.30), computed
/// once at configuration ([`Mount::general`]); nothing per return uses a float.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mount {
    /// The scan centre in the robot frame at actuator zero, metres (x forward, y left, z up;
    /// z is the mounting height above the robot's ground contact). Any value; world
    /// coordinates saturate.
    pub position: Point3,
    /// m₀ and m₁: the images of the sensor's x and y axes in the actuator's frame at zero,
    /// Q2.30 (entries within ±2³⁰).
    columns: [[i32; 3]; 2],
    axis: ActuatorAxis,
    /// The reported actuator angle at which the geometry's angle is 0.
    zero: FineAngle,
    /// The actuator's sense is reversed: the geometry's angle is `zero − reported`.
    reversed: bool,
}

impl Mount {
    /// A placeholder of zero bits (no direction at all): an unconfigured pipeline's, so that
    /// its `static` stays in `.bss`; replaced before any return uses it.
    pub const ZERO: Self = Self {
        position: Point3 {
            x: crate::units::Meters::ZERO,
            y: crate::units::Meters::ZERO,
            z: crate::units::Meters::ZERO,
        },
        columns: [[0; 3]; 2],
        axis: ActuatorAxis::Pan,
        zero: FineAngle::ZERO,
        reversed: false,
    };

    /// A preset mount ([`ScanPlane`]) with the given scan-centre position: zero 0, sense +1.
    #[must_use]
    pub const fn new(plane: ScanPlane, position: Point3) -> Self {
        Self {
            position,
            columns: plane.columns(),
            axis: plane.axis(),
            zero: FineAngle::ZERO,
            reversed: false,
        }
    }

    /// A mount of any orientation: the sensor's frame rotated by `R_z(yaw)·R_y(pitch)·R_x(roll)`
    /// relative to the actuator's frame at zero, on an actuator about `axis` whose reported
    /// angle `zero` is the geometry's 0, `reversed` when the reported angle grows the other
    /// way. Three [`FineAngle::sin_cos`] and a dozen products (configuration time). The
    /// rotation's entries are within 10⁻⁸ of exact ([`Rotation::from_rpy`]), exact at
    /// multiples of 90°, so `general` of a preset's values equals the preset.
    #[must_use]
    pub fn general(
        position: Point3,
        rpy: [FineAngle; 3],
        axis: ActuatorAxis,
        zero: FineAngle,
        reversed: bool,
    ) -> Self {
        let [roll, pitch, yaw] = rpy;
        let [r0, r1, r2] = Rotation::from_rpy(roll, pitch, yaw).to_bits();
        let [a, b, _] = r0;
        let [d, e, _] = r1;
        let [g, h, _] = r2;
        Self {
            position,
            columns: [[a, d, g], [b, e, h]],
            axis,
            zero,
            reversed,
        }
    }

    /// The actuator's axis.
    #[must_use]
    pub const fn axis(&self) -> ActuatorAxis {
        self.axis
    }

    /// The reported actuator angle that the geometry takes as 0.
    #[must_use]
    pub const fn zero(&self) -> FineAngle {
        self.zero
    }

    /// Whether the actuator's reported angle grows against the axis's positive sense.
    #[must_use]
    pub const fn reversed(&self) -> bool {
        self.reversed
    }

    /// m₀ and m₁, the images of the sensor's x and y axes in the actuator's frame at zero,
    /// raw Q2.30.
    #[must_use]
    pub const fn columns(&self) -> [[i32; 3]; 2] {
        self.columns
    }

    /// The preset this mount is, if it is one (its rotation, axis, zero and sense those of
    /// the preset; any position).
    #[must_use]
    pub fn preset(&self) -> Option<ScanPlane> {
        [ScanPlane::PannedVertical, ScanPlane::TiltedHorizontal]
            .into_iter()
            .find(|&p| *self == Self::new(p, self.position))
    }

    /// The geometry's actuator angle of a reported one: `sense·(reported − zero)`, exact (a
    /// wrapping subtraction and, when reversed, a negation).
    #[must_use]
    pub const fn actuator_angle(&self, reported: FineAngle) -> FineAngle {
        let a = reported.wrapping_sub(self.zero);
        if self.reversed {
            a.reversed()
        } else {
            a
        }
    }
}

/// The geometry's beam angle θ of a spinning lidar's return at `clockwise`, the sensor's own
/// angle (clockwise seen from the sensor's top, from the manual's 0°; see
/// [`crate::wire::laser`]): `θ = 90° − clockwise`, exact (a wrapping subtraction).
///
/// With θ's sensor-frame direction `(sin θ, −cos θ, 0)`, the lidar's 0° is along its own x
/// and its 90° (clockwise seen from its top) along its −y. How it sits on the robot is the
/// [`Mount`]'s rotation; the presets fix two:
/// - [`ScanPlane::TiltedHorizontal`] (a lidar on a nodding servo): the lidar lies flat, top
///   up, its 0° pointing forward (robot +x) at actuator angle 0: its 0° is θ = 90° (ahead),
///   its 90° (clockwise from above) θ = 0° (to the right), its 180° behind, its 270° to the
///   left. The servo tilts it about the robot's y axis, positive looking down ahead (and up
///   behind).
/// - [`ScanPlane::PannedVertical`]: the lidar stands on its side with its top facing right
///   (robot −y) and its 0° pointing forward: its 90° points straight down (θ = 0°), its 270°
///   straight up; the actuator pans that plane about z.
///
/// A lidar mounted otherwise (upside down, its 0° elsewhere) takes [`Mount::general`] with
/// its roll, pitch and yaw.
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

    #[test]
    fn the_presets_general_form_is_the_preset() {
        let p = Point3::default();
        for plane in [ScanPlane::PannedVertical, ScanPlane::TiltedHorizontal] {
            let general = Mount::general(p, plane.rpy(), plane.axis(), FineAngle::ZERO, false);
            assert_eq!(general, Mount::new(plane, p));
            assert_eq!(general.preset(), Some(plane));
        }
        let turned = Mount::general(
            p,
            [FineAngle::HALF, FineAngle::ZERO, FineAngle::QUARTER],
            ActuatorAxis::Tilt,
            FineAngle::ZERO,
            false,
        );
        assert_eq!(turned.preset(), None);
        // Upside down (roll 180°) and 0° to the left (yaw 90°): the sensor's x is the robot's
        // y, its y the robot's x (R_z(90°)·R_x(180°)).
        assert_eq!(turned.columns(), [[0, ONE, 0], [ONE, 0, 0]]);
    }

    #[test]
    fn the_actuator_angle_takes_zero_and_sense() {
        let m = Mount::general(
            Point3::default(),
            [FineAngle::ZERO; 3],
            ActuatorAxis::Pan,
            FineAngle::QUARTER,
            true,
        );
        assert_eq!(m.actuator_angle(FineAngle::QUARTER), FineAngle::ZERO);
        assert_eq!(
            m.actuator_angle(FineAngle::HALF),
            FineAngle::QUARTER.reversed()
        );
        assert_eq!(m.actuator_angle(FineAngle::ZERO), FineAngle::QUARTER);
    }
}
