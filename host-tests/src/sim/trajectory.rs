//! Trajectories: where the robot is at each line time.
//!
//! A [`Trajectory`] stands still at its start for a while, then drives at a constant speed
//! along +x to a stop position and stays there (acceleration is not modelled: the speed
//! jumps). It may also turn about the vertical axis at a constant rate the whole time
//! ([`Trajectory::turning`]: turning in place); the path stays along +x. The robot's body stays level (roll = pitch = 0: the paper's Segway RMP balances
//! itself upright whatever the ground's slope) and its height is the ground's under its
//! ground contact point ([`Trajectory::pose_at`] asks the scene).

use super::scene::Scene;

/// A robot pose (the one of [`crate::geometry`]): z is the ground contact point's here.
pub use crate::geometry::Pose;

impl Pose {
    /// The rotation `R_z(yaw)·R_y(pitch)·R_x(roll)`, row-major.
    #[must_use]
    pub fn rotation(&self) -> [[f64; 3]; 3] {
        let (sr, cr) = self.roll.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    }

    /// A robot-frame point in the world.
    #[must_use]
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let r = self.rotation();
        let t = [self.x, self.y, self.z];
        core::array::from_fn(|i| t[i] + r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2])
    }

    /// The pose as a recording's pose event carries it: x, y, z, roll, pitch, yaw as `f32`.
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn to_f32(&self) -> [f32; 6] {
        [
            self.x as f32,
            self.y as f32,
            self.z as f32,
            self.roll as f32,
            self.pitch as f32,
            self.yaw as f32,
        ]
    }

    /// The pose a reader of the recording sees: every field rounded through `f32`.
    #[must_use]
    pub fn rounded_f32(&self) -> Self {
        let [x, y, z, roll, pitch, yaw] = self.to_f32().map(f64::from);
        Self {
            x,
            y,
            z,
            roll,
            pitch,
            yaw,
        }
    }
}

/// What the robot is doing at a given time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Standing at the start.
    Standing,
    /// Driving towards the stop position.
    Driving,
    /// Standing at the stop position.
    Stopped,
}

/// Stand at `start_x` for `stand_s`, drive at `speed_mps` along +x to `stop_x`, then stay
/// there for `dwell_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trajectory {
    /// Start position along x, metres.
    pub start_x: f64,
    /// The (constant) y, metres.
    pub y: f64,
    /// Time standing still at the start, seconds, ≥ 0.
    pub stand_s: f64,
    /// Driving speed, m/s, > 0 (unused when `stop_x == start_x`).
    pub speed_mps: f64,
    /// Where the robot stops, metres, ≥ `start_x`.
    pub stop_x: f64,
    /// Time standing at the stop position before the recording ends, seconds, ≥ 0.
    pub dwell_s: f64,
    /// The yaw rate, rad/s (positive turns left), the whole run: yaw = rate · t, wrapped
    /// into (−π, π]. 0 (every constructor but [`Trajectory::turning`]): facing +x.
    pub yaw_rate_rad_s: f64,
}

impl Trajectory {
    /// Standing still at the origin for `duration_s` seconds.
    #[must_use]
    pub const fn standing(duration_s: f64) -> Self {
        Self {
            start_x: 0.0,
            y: 0.0,
            stand_s: duration_s,
            speed_mps: 1.0,
            stop_x: 0.0,
            dwell_s: 0.0,
            yaw_rate_rad_s: 0.0,
        }
    }

    /// Turning in place at the origin at `rate_rad_s` for `duration_s` seconds.
    #[must_use]
    pub const fn turning(duration_s: f64, rate_rad_s: f64) -> Self {
        Self {
            yaw_rate_rad_s: rate_rad_s,
            ..Self::standing(duration_s)
        }
    }

    /// From the origin: stand for `stand_s`, then drive at `speed_mps` until the robot's
    /// ground contact point is `distance_m` short of `target_x` (the recording ends there).
    #[must_use]
    pub fn approach(stand_s: f64, speed_mps: f64, target_x: f64, distance_m: f64) -> Self {
        Self {
            start_x: 0.0,
            y: 0.0,
            stand_s,
            speed_mps,
            stop_x: (target_x - distance_m).max(0.0),
            dwell_s: 0.0,
            yaw_rate_rad_s: 0.0,
        }
    }

    /// Seconds of driving.
    #[must_use]
    pub fn drive_s(&self) -> f64 {
        let distance = self.stop_x - self.start_x;
        if distance > 0.0 {
            distance / self.speed_mps
        } else {
            0.0
        }
    }

    /// The time the robot starts driving, seconds.
    #[must_use]
    pub fn drive_start_s(&self) -> f64 {
        self.stand_s
    }

    /// The time the robot stops, seconds.
    #[must_use]
    pub fn stop_s(&self) -> f64 {
        self.stand_s + self.drive_s()
    }

    /// The whole duration, seconds: standing, driving and dwelling.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.stop_s() + self.dwell_s
    }

    /// What the robot is doing at `t_s` seconds.
    #[must_use]
    pub fn phase(&self, t_s: f64) -> Phase {
        if t_s < self.stand_s {
            Phase::Standing
        } else if t_s < self.stop_s() {
            Phase::Driving
        } else {
            Phase::Stopped
        }
    }

    /// x at `t_s` seconds, metres.
    #[must_use]
    pub fn x_at(&self, t_s: f64) -> f64 {
        match self.phase(t_s) {
            Phase::Standing => self.start_x,
            Phase::Driving => self.start_x + (t_s - self.stand_s) * self.speed_mps,
            Phase::Stopped => self.stop_x.max(self.start_x),
        }
    }

    /// The yaw at `t_s` seconds, radians in (−π, π]: `yaw_rate_rad_s · t_s`, wrapped.
    #[must_use]
    pub fn yaw_at(&self, t_s: f64) -> f64 {
        if self.yaw_rate_rad_s == 0.0 {
            return 0.0;
        }
        let tau = core::f64::consts::TAU;
        let yaw = (self.yaw_rate_rad_s * t_s).rem_euclid(tau);
        if yaw > core::f64::consts::PI {
            yaw - tau
        } else {
            yaw
        }
    }

    /// The pose at `t_s` seconds over `scene`: on the trajectory, level, at the ground's
    /// height, facing [`yaw_at`](Self::yaw_at) (+x unless it turns).
    #[must_use]
    pub fn pose_at(&self, t_s: f64, scene: &Scene) -> Pose {
        let x = self.x_at(t_s);
        Pose {
            x,
            y: self.y,
            z: scene.ground_height(x, self.y),
            yaw: self.yaw_at(t_s),
            ..Pose::default()
        }
    }

    /// Checks the fields' bounds.
    ///
    /// # Errors
    /// A message naming the first field out of bounds.
    pub fn validate(&self) -> Result<(), String> {
        let finite = [
            self.start_x,
            self.y,
            self.stand_s,
            self.speed_mps,
            self.stop_x,
            self.dwell_s,
            self.yaw_rate_rad_s,
        ]
        .iter()
        .all(|v| v.is_finite());
        if !finite {
            return Err("trajectory: every field must be finite".into());
        }
        if self.stand_s < 0.0 || self.dwell_s < 0.0 {
            return Err("trajectory: stand and dwell times must be ≥ 0".into());
        }
        if self.stop_x < self.start_x {
            return Err("trajectory: the stop position must not be behind the start".into());
        }
        if self.stop_x > self.start_x && self.speed_mps <= 0.0 {
            return Err("trajectory: the speed must be > 0".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stand_drive_stop() {
        let t = Trajectory::approach(2.0, 0.5, 5.05, 1.05);
        assert_eq!(t.stop_x, 4.0);
        assert_eq!(t.duration_s(), 10.0);
        assert_eq!(t.x_at(1.0), 0.0);
        assert_eq!(t.phase(1.0), Phase::Standing);
        assert!((t.x_at(4.0) - 1.0).abs() < 1e-12);
        assert_eq!(t.phase(4.0), Phase::Driving);
        assert_eq!(t.x_at(10.0), 4.0);
        assert_eq!(t.phase(10.0), Phase::Stopped);
        let p = t.pose_at(12.0, &Scene::slope(3.05, 10.0));
        assert!((p.z - 0.95 * 10f64.to_radians().tan()).abs() < 1e-12);
    }

    #[test]
    fn turning_wraps_the_yaw() {
        let t = Trajectory::turning(10.0, 1.0);
        assert_eq!(t.yaw_at(0.0), 0.0);
        assert!((t.yaw_at(1.0) - 1.0).abs() < 1e-12);
        // 4 rad is past π: 4 − 2π.
        assert!((t.yaw_at(4.0) - (4.0 - core::f64::consts::TAU)).abs() < 1e-12);
        assert_eq!(t.x_at(5.0), 0.0);
        assert_eq!(Trajectory::standing(3.0).yaw_at(2.0), 0.0);
    }

    #[test]
    fn rotation_follows_the_convention() {
        let nose_down = Pose {
            pitch: 0.1,
            ..Pose::default()
        };
        let p = nose_down.to_world([1.0, 0.0, 0.0]);
        assert!(p[2] < 0.0);
        let left = Pose {
            yaw: core::f64::consts::FRAC_PI_2,
            ..Pose::default()
        };
        let p = left.to_world([1.0, 0.0, 0.0]);
        assert!((p[1] - 1.0).abs() < 1e-12);
    }
}
