//! The placement rule in `f64`, written from its statement (the library's
//! `geometry::pose_track` documentation and `docs/lidars.md`), not from the fixed-point code:
//! a list of stamped poses, the pose at a time by interpolation between the bracketing pair
//! or extrapolation along the last two, and the pose in force kept while returns stay within
//! the quantum of the time it was evaluated at.
//!
//! - Times are the device's µs clock (`u32`, wrapping); "b later than a" is
//!   `(b − a) mod 2³²` read as a signed 32-bit number, > 0.
//! - A pose stamped s is refused when s is not later than the newest, or more than 1 s later
//!   than the device's clock; more than 500 ms after the newest it restarts the list; else it
//!   is appended, the oldest dropped past the capacity.
//! - At t: between the oldest and the newest, linear between the pair around t; up to 100 ms
//!   after the newest, linear along the last two (one pose: that pose); else none.
//! - Angles change along the shorter arc: the difference is taken into (−π, π].
//! - The pose in force is re-evaluated when a return's time lies 1 ms or more from the time it
//!   was evaluated at.

use std::collections::VecDeque;

use crate::geometry::Pose;

/// The quantum, µs.
pub const QUANTUM_US: i64 = 1_000;
/// The extrapolation bound, µs.
pub const EXTRAPOLATION_US: i64 = 100_000;
/// The gap that restarts the list, µs.
pub const GAP_US: i64 = 500_000;
/// The lead over the device's clock, µs.
pub const LEAD_US: i64 = 1_000_000;

/// How much later `b` is than `a`, µs (the wrapping difference, signed).
#[must_use]
pub fn later(b: u32, a: u32) -> i64 {
    i64::from(b.wrapping_sub(a) as i32)
}

/// The angle `b − a` taken into (−π, π].
#[must_use]
pub fn arc(a: f64, b: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let d = (b - a).rem_euclid(tau);
    if d > std::f64::consts::PI {
        d - tau
    } else {
        d
    }
}

/// `a + f·(b − a)` for every component, angles along the shorter arc.
#[must_use]
pub fn lerp(a: &Pose, b: &Pose, f: f64) -> Pose {
    Pose {
        x: a.x + f * (b.x - a.x),
        y: a.y + f * (b.y - a.y),
        z: a.z + f * (b.z - a.z),
        roll: a.roll + f * arc(a.roll, b.roll),
        pitch: a.pitch + f * arc(a.pitch, b.pitch),
        yaw: a.yaw + f * arc(a.yaw, b.yaw),
    }
}

/// How a pose was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Found {
    /// Between two stamps (or at one).
    Between,
    /// After the newest: extrapolated, or the one pose held.
    After,
}

/// The stamped poses.
#[derive(Debug, Clone)]
pub struct RefTrack {
    capacity: usize,
    poses: VecDeque<(u32, Pose)>,
}

impl RefTrack {
    /// An empty list that keeps up to `capacity` poses.
    #[must_use]
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
            poses: VecDeque::new(),
        }
    }

    /// Takes a pose: `Some(true)` restarted, `Some(false)` appended, `None` refused.
    pub fn push(&mut self, stamp: u32, pose: Pose, now: u32) -> Option<bool> {
        let newest = self.poses.back().map(|&(s, _)| later(stamp, s));
        if newest.is_some_and(|d| d <= 0) || later(stamp, now) > LEAD_US {
            return None;
        }
        let restart = newest.is_some_and(|d| d > GAP_US);
        if restart {
            self.poses.clear();
        }
        self.poses.push_back((stamp, pose));
        while self.poses.len() > self.capacity {
            self.poses.pop_front();
        }
        Some(restart)
    }

    /// The pose at `t`.
    #[must_use]
    pub fn at(&self, t: u32) -> Option<(Pose, Found)> {
        let &(s_new, newest) = self.poses.back()?;
        let (s_old, _) = *self.poses.front()?;
        let after = later(t, s_new);
        if after > EXTRAPOLATION_US || later(t, s_old) < 0 {
            return None;
        }
        let n = self.poses.len();
        let (i, found) = if after > 0 {
            if n == 1 {
                return Some((newest, Found::After));
            }
            (n - 2, Found::After)
        } else {
            // The last pose at or before t, and the next one.
            let i = (0..n).rev().find(|&i| later(t, self.poses[i].0) >= 0)?;
            if i + 1 == n {
                return Some((newest, Found::Between));
            }
            (i, Found::Between)
        };
        let (sa, a) = self.poses[i];
        let (sb, b) = self.poses[i + 1];
        let f = later(t, sa) as f64 / later(sb, sa) as f64;
        Some((lerp(&a, &b, f), found))
    }
}

/// The pose in force, re-evaluated by the quantum.
#[derive(Debug, Clone, Copy, Default)]
pub struct InForce {
    at: Option<(u32, Pose, Found)>,
}

impl InForce {
    /// The pose a return measured at `t` is placed with, `None` when the track has none.
    pub fn pose(&mut self, track: &RefTrack, t: u32) -> Option<(Pose, Found)> {
        if let Some((at, pose, found)) = self.at {
            if later(t, at).abs() < QUANTUM_US {
                return Some((pose, found));
            }
        }
        let (pose, found) = track.at(t)?;
        self.at = Some((t, pose, found));
        Some((pose, found))
    }

    /// Forgets the pose in force (the track changed).
    pub fn forget(&mut self) {
        self.at = None;
    }
}
