//! PoseReport ⇄ [`Pose`]: the pose by the geometry's rule ([`pose_of`]), its stamp and flags
//! ([`stamp_of`]), and the `param` codes of a refused pose's fields.

use super::reply::refusal;
use crate::geometry::{Pose, PoseError, PoseField};
use crate::wire::link::{Header, PoseReport, Reply, ReplyCode, POSE_FLAGS_KNOWN, POSE_STAMPED};

/// The pose a report gives, by the geometry's own rule ([`Pose::from_f32`]): every field
/// finite, |x|, |y| < 30 000 m, |z| < 1 000 m, |roll|, |pitch|, |yaw| < 32 768 rad.
///
/// # Errors
/// The first bad field, in the order x, y, z, roll, pitch, yaw.
pub fn pose_of(report: &PoseReport) -> Result<Pose, PoseError> {
    Pose::from_f32(
        report.x_m,
        report.y_m,
        report.z_m,
        report.roll_rad,
        report.pitch_rad,
        report.yaw_rad,
    )
}

/// The Reply `param` of a Pose's `flags` (protocol version 4): a bit other than
/// [`POSE_STAMPED`] set is refused with OutOfRange, the flags as the value, limits 0 and 1.
pub const PARAM_POSE_FLAGS: u8 = 38;

/// A Pose's stamp: `Some(stamp_us)` (the device's µs clock) when the pose is stamped,
/// `None` for an unstamped pose (the latest-pose rule).
///
/// # Errors
/// A flag bit other than [`POSE_STAMPED`] set: the flags byte.
pub const fn stamp_of(report: &PoseReport) -> Result<Option<u32>, u8> {
    if report.flags & !POSE_FLAGS_KNOWN != 0 {
        Err(report.flags)
    } else if report.flags & POSE_STAMPED != 0 {
        Ok(Some(report.stamp_us))
    } else {
        Ok(None)
    }
}

/// The refusal of a Pose's `flags` (a bit other than [`POSE_STAMPED`]): OutOfRange,
/// [`PARAM_POSE_FLAGS`], the flags byte, limits 0 and 1.
#[must_use]
pub fn pose_flags_refusal(to: Header, flags: u8) -> Reply {
    refusal(
        to,
        ReplyCode::OutOfRange,
        PARAM_POSE_FLAGS,
        f32::from(flags),
        0.0,
        1.0,
    )
}

/// The Reply `param` code of a pose field: 32 ..= 37 for x, y, z, roll, pitch, yaw.
#[must_use]
pub const fn pose_field_code(field: PoseField) -> u8 {
    match field {
        PoseField::X => 32,
        PoseField::Y => 33,
        PoseField::Z => 34,
        PoseField::Roll => 35,
        PoseField::Pitch => 36,
        PoseField::Yaw => 37,
    }
}
