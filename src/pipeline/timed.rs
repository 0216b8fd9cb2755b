//! Timed placement: the pose in force and when it was evaluated, the observation's span of
//! times ([`ObservedSpan`]), and the rule that re-evaluates the pose of a return's moment
//! only [`POSE_QUANTUM_US`] or more from where it was evaluated.

use super::Frontend;
use crate::geometry::{NoPose, Placement, Pose, PoseFrame, PoseTrack, POSE_QUANTUM_US};

/// The times of the returns an observation placed, for the host to stamp the maps it
/// publishes ([`Frontend::take_observed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObservedSpan {
    /// The observation count (the counters' `observations`) after this one.
    pub observation: u32,
    /// The measurement time of the earliest return it placed, µs (device clock, wrapping).
    pub first_us: u32,
    /// The measurement time of the latest return it placed, µs.
    pub last_us: u32,
}

/// Timed placement's state: the pose in force and when it was evaluated, and the span of
/// the observation's placed returns. Zero bits: nothing in force, no span.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct TimedPose {
    /// The time the pose in force was evaluated at, µs (meaningful when `in_force`).
    pub(super) at_us: u32,
    /// Whether a timed pose is in force.
    pub(super) in_force: bool,
    /// Whether it was extrapolated (or held) past the newest stamped pose.
    pub(super) extrapolated: bool,
    /// The earliest and latest times of the observation's placed returns (when `spanned`).
    pub(super) first_us: u32,
    pub(super) last_us: u32,
    pub(super) spanned: bool,
}

impl TimedPose {
    pub(super) const NONE: Self = Self {
        at_us: 0,
        in_force: false,
        extrapolated: false,
        first_us: 0,
        last_us: 0,
        spanned: false,
    };

    /// Notes a return placed at `t_us` in the observation's span.
    pub(super) fn placed(&mut self, t_us: u32) {
        if !self.spanned {
            (self.first_us, self.last_us, self.spanned) = (t_us, t_us, true);
        } else if later_by(self.first_us, t_us) > 0 {
            self.first_us = t_us;
        } else if later_by(t_us, self.last_us) > 0 {
            self.last_us = t_us;
        }
    }
}

/// How much later `b` is than `a`, µs: the wrapping difference as an `i32`.
#[allow(clippy::cast_possible_wrap)]
pub(super) const fn later_by(b: u32, a: u32) -> i32 {
    b.wrapping_sub(a) as i32
}

/// Where the poses of a timed line's returns come from: a track of stamped poses, evaluated
/// at each return's time (a trait, so that the rule's code does not depend on the track's
/// capacity's instantiation more than it must).
pub(super) trait Poses {
    /// Whether returns take the pose of their own times.
    const TIMED: bool;
    /// The pose at `t_us`.
    fn pose_at(&self, t_us: u32) -> Result<(Pose, Placement), NoPose>;
}

impl<const N: usize> Poses for PoseTrack<N> {
    const TIMED: bool = true;
    fn pose_at(&self, t_us: u32) -> Result<(Pose, Placement), NoPose> {
        self.at(t_us)
    }
}

impl<const C: usize, const L: usize> Frontend<C, L> {
    /// The pose for a return measured at `t_us`, by the placement rule: the pose in force
    /// when it was evaluated less than [`POSE_QUANTUM_US`] from `t_us` (`Ok(false)`), else the
    /// track's at `t_us`, now in force (`Ok(true)`: the caller rebuilds its transform).
    pub(super) fn timed_pose<P: Poses>(
        timed: &mut TimedPose,
        pose: &mut Pose,
        frame: &mut PoseFrame,
        poses: &P,
        t_us: u32,
    ) -> Result<bool, NoPose> {
        if timed.in_force && later_by(t_us, timed.at_us).unsigned_abs() < POSE_QUANTUM_US {
            return Ok(false);
        }
        let (p, how) = poses.pose_at(t_us)?;
        timed.at_us = t_us;
        timed.in_force = true;
        timed.extrapolated = how != Placement::Interpolated;
        // A robot standing still keeps its frame: nothing to rebuild.
        if p == *pose {
            return Ok(false);
        }
        *pose = p;
        *frame = p.frame();
        Ok(true)
    }
}
