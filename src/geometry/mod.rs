//! Scan geometry in fixed point: from a SICK range reading (beam index, millimetres), the
//! actuator angle and the robot's pose to a world point and its horizontal distance from
//! the scanner.
//!
//! # Conventions (fixed)
//! - **Frames.** The robot frame and the world frame are right-handed, x forward, y left,
//!   z up, metres ([`crate::Point3`] of [`crate::Meters`], Q16.16). The robot frame's origin is its
//!   ground contact point.
//! - **Beam angle θ**, the scanner's own, in its scan plane: 0° = the scanner's right, 90° =
//!   straight ahead, 180° = its left. In the 180° field the first beam is at 0° and the last
//!   at 180°; in the 100° field they are at 40° and 140° ([`beams`]).
//!   A spinning lidar's own angle (clockwise from its 0°) becomes θ = 90° − angle
//!   ([`beam_angle_of_clockwise`], which also states how such a lidar is mounted).
//! - **Mounts** ([`Mount`], its presets [`ScanPlane`]): any orientation of the sensor's frame
//!   (x its 0°, z its top; beam θ along `(sin θ, −cos θ, 0)`) by roll, pitch, yaw on a pan, tilt
//!   or no actuator, with the actuator's zero and sense ([`mount`]). The presets:
//!   - *panned vertical plane* (the paper's robot): beam θ has the sensor-frame direction
//!     `(sin θ, 0, −cos θ)` (0° straight down, 90° forward, 180° straight up), panned about z
//!     by p: `(sin θ cos p, sin θ sin p, −cos θ)`;
//!   - *tilted horizontal plane* (the 3DTK data): `(sin θ, −cos θ, 0)` (0° right, 90°
//!     forward, 180° left), tilted about y by τ, positive looking down, through `R_y(τ)`
//!     (`x' = x cos τ + z sin τ`, `z' = −x sin τ + z cos τ`):
//!     `(sin θ cos τ, −cos θ, −sin θ sin τ)`;
//!   - the scan centre sits at [`Mount::position`] in the robot frame (z = mounting height
//!     above the ground contact); the actuator axis passes through it.
//! - **Pose** ([`Pose`]): world = T + `R_z(yaw)·R_y(pitch)·R_x(roll)`·robot, T = (x, y, z).
//!   Positive angles turn counter-clockwise about their axis: positive yaw turns forward into
//!   left, positive pitch puts the nose down.
//! - **Angles** are [`FineAngle`](crate::angle::FineAngle)s, a Q0.32 fraction of a turn (an encoder's
//!   [`crate::angle::Angle`] converts exactly); wrap-around is free.
//! - **Ranges** are millimetres as `u32` (the 80 m mode's centimetres × 10), up to
//!   [`MAX_RANGE_MM`]. "No echo" is filtered out before geometry.
//!
//! # Where the work happens
//! | when | what | maths |
//! | --- | --- | --- |
//! | configuration (or compile time) | [`BeamTable::new`]: (cos θ, sin θ) per beam, Q1.15 | integer trig |
//! | pose change | [`Pose::frame`]: the rotation matrix, Q2.30 | 3 × integer sin/cos |
//! | scan line | [`LineTransform::new`]: pose × actuator × mount, one 3 × 2 matrix | 1 × integer sin/cos, about 60 multiplies |
//! | point | [`LineTransform::point`] / [`LineTransform::locate`] / [`LineTransform::locate_squared`] | 2 multiplies and 6 multiply-accumulates into 64 bits, 2 squares (+ √ for d with `locate`; the pipeline bins d² instead) |
//! | spinning lidar: pose change | [`SweepTransform::new`]: the pose and the mount | about 40 multiplies beyond the pose's |
//! | spinning lidar: actuator angle | [`SweepTransform::at`]: the plane at that angle | 1 × integer sin/cos, 12 multiplies |
//! | spinning lidar: return | [`ActuatedPlane::locate_squared`]: its own beam angle θ | 1 × integer sin/cos, 12 multiplies |
//!
//! No float runs per point or per line: the trigonometry is a quarter-wave table with a
//! short Taylor correction in integers ([`crate::angle`]), so the host and every Cortex-M produce the
//! same bits. Floats appear only in [`Pose::from_f32`], which takes the host's values apart
//! exactly into fixed point, in display helpers, and in the compiler's evaluation of the sine
//! table.
//!
//! # Error
//! A world point is within **0.03 mm + 3.1·10⁻⁵ × range** of the exact point of the same
//! inputs: 0.28 mm at 8 m, 0.96 mm at 30 m, 2.6 mm at 81.91 m; the horizontal distance obeys
//! the same bound. The beam table's Q1.15 rounding is nearly all of it (see [`transform`]).
//! A spinning lidar's return, placed from its own angle in Q2.30 ([`sweep`]), is within
//! **0.03 mm + 10⁻⁸ × range** (0.03 mm at 12 m and at 40 m).
//! `host-tests` checks the bound against an independent f64 reference (property tests) and
//! its example `geometry_error` measures the actual maximum and 99.9th percentile.
//!
//! # Panic contract
//! Nothing here panics or wraps on any input: beam indices past the table and ranges above
//! [`MAX_RANGE_MM`] give `None`, world coordinates saturate at ±32 768 m, angles wrap by
//! definition.

pub mod beams;
mod fixed;
pub mod mount;
pub mod pose;
pub mod pose_track;
pub mod sweep;
pub mod transform;

pub use beams::{BeamDir, BeamTable};
pub use mount::{beam_angle_of_clockwise, ActuatorAxis, Mount, ScanPlane};
pub use pose::{Pose, PoseError, PoseField, PoseFrame, Rotation};
pub use pose_track::{
    NoPose, Placement, PoseRefusal, PoseTrack, Taken, MAX_EXTRAPOLATION_US, MAX_POSE_AGE_US,
    MAX_POSE_GAP_US, MAX_POSE_LEAD_US, POSE_QUANTUM_US,
};
pub use sweep::{ActuatedPlane, SweepTransform};
pub use transform::{
    horizontal_distance, LinePoint, LinePointSquared, LineTransform, MAX_RANGE_MM,
};
