//! A long drive for soak tests: the robot drives laps of a closed route past a row of scenes
//! for as long as asked (an hour is 270 000 lines at 75 lines/s), its lines generated one at a
//! time, never held in memory as a whole recording.
//!
//! # The route
//! A circle of radius [`DriveConfig::radius_m`] (default 25 m, a lap of 157 m) centred at
//! (0, R), driven counter-clockwise from the origin heading +x: at arc length s the robot is
//! at `(R sin(s/R), R − R cos(s/R))` with yaw `s/R`. It drives at
//! [`DriveConfig::speed_mps`] for [`DriveConfig::drive_s`], stands for
//! [`DriveConfig::stand_s`], and so on (default 1 m/s, 60 s driving, 5 s standing).
//!
//! # The scenes
//! Flat ground (an exact ray cast) and, at [`STATIONS`] points spread around the lap, one of
//! six scenes in turn beside or over the track: a curb (a low box beside the track), a step
//! (a 17 cm block), a post, a gate (two posts either side and a bar at 2.0 m over the track), a
//! branch (a box at 1.6 – 1.8 m over the track) and a wall. Only the solids within reach of the
//! laser are handed to the ray cast (the local scene is rebuilt every metre or so).
//!
//! # The laser
//! The paper's panned vertical plane at h = 1.0 m (±45° at 75°/s) in the 180° field at 1°
//! ([`Variant::Fov180Step1`]): one full-scan telegram per mirror turn, **75 lines/s**, 8 lines
//! per observation. With [`DriveConfig::hold_lines`] = n > 1 the actuator angle and the pose
//! are held for n lines at a time (a pan unit that steps between bursts): the emulated board's
//! soak sends them once per burst.
//!
//! Deterministic: the same configuration gives the same lines.

use super::laser::{angle_to_u16, measuring_mode_code, Actuator, Laser, LaserConfig};
use super::record::PAN_LINES_PER_OBSERVATION;
use super::scene::{Scene, Solid};
use super::trajectory::Pose;
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::sick::Variant;

/// Scenes around one lap.
pub const STATIONS: usize = 24;

/// The drive's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveConfig {
    /// How long the drive lasts, seconds.
    pub duration_s: f64,
    /// The route's radius, metres.
    pub radius_m: f64,
    /// Driving speed, m/s.
    pub speed_mps: f64,
    /// Seconds of driving between stops.
    pub drive_s: f64,
    /// Seconds of each stop.
    pub stand_s: f64,
    /// Lines that share one actuator angle and pose (1: every line has its own).
    pub hold_lines: u32,
    /// The seed of the range noise.
    pub seed: u64,
}

impl DriveConfig {
    /// A drive of `duration_s` seconds with the defaults: R = 25 m, 1 m/s, 60 s driving then
    /// 5 s standing, every line its own angle and pose, seed 1.
    #[must_use]
    pub const fn new(duration_s: f64) -> Self {
        Self {
            duration_s,
            radius_m: 25.0,
            speed_mps: 1.0,
            drive_s: 60.0,
            stand_s: 5.0,
            hold_lines: 1,
            seed: 1,
        }
    }

    /// The laser: the paper's pan at h = 1.0 m, 180° at 1° (75 lines/s).
    #[must_use]
    pub const fn laser() -> LaserConfig {
        LaserConfig {
            variant: Variant::Fov180Step1,
            actuator: Actuator::PAPER_PAN,
            ..LaserConfig::paper()
        }
    }

    /// Lines per second (75).
    #[must_use]
    pub fn line_rate_hz(&self) -> f64 {
        Self::laser().line_rate_hz()
    }

    /// The number of lines: `⌊duration · rate⌋`.
    #[must_use]
    pub fn lines(&self) -> u64 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = (self.duration_s * self.line_rate_hz()).floor().max(0.0) as u64;
        n
    }

    /// The recording setup of the drive (the pipeline is configured from it).
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn setup(&self) -> Setup {
        let laser = Self::laser();
        Setup {
            mount: laser.actuator.mount_kind(),
            measuring_mode: measuring_mode_code(laser.mode),
            field_deg: laser.variant.scan_angle_deg(),
            resolution_cdeg: laser.variant.resolution_centideg(),
            sensor_m: laser.position_m.map(|v| v as f32),
            lines_per_observation: PAN_LINES_PER_OBSERVATION,
        }
    }

    /// Arc length driven at `t`, metres.
    #[must_use]
    pub fn distance_at(&self, t: f64) -> f64 {
        let period = self.drive_s + self.stand_s;
        if period <= 0.0 {
            return 0.0;
        }
        let laps = (t / period).floor();
        let within = t - laps * period;
        (laps * self.drive_s + within.min(self.drive_s)) * self.speed_mps
    }

    /// The robot's pose at `t` (flat ground: z, roll and pitch 0).
    #[must_use]
    pub fn pose_at(&self, t: f64) -> Pose {
        let r = self.radius_m;
        let theta = self.distance_at(t) / r;
        Pose {
            x: r * theta.sin(),
            y: r - r * theta.cos(),
            yaw: (theta + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI,
            ..Pose::default()
        }
    }

    /// Every solid of the route: one scene per station, in turn.
    #[must_use]
    pub fn solids(&self) -> Vec<Solid> {
        let r = self.radius_m;
        let mut solids = Vec::new();
        #[allow(clippy::cast_precision_loss)]
        for i in 0..STATIONS {
            let phi = (i as f64 + 0.5) * std::f64::consts::TAU / STATIONS as f64;
            // The track point and the outward normal there.
            let (s, c) = phi.sin_cos();
            let (px, py) = (r * s, r - r * c);
            let (nx, ny) = (s, -c);
            let at = |d: f64| (px + d * nx, py + d * ny);
            let square = |(x, y): (f64, f64), half: f64, z0: f64, z1: f64| Solid::Box {
                min: [x - half, y - half, z0],
                max: [x + half, y + half, z1],
            };
            let post = |(x, y): (f64, f64)| Solid::Cylinder {
                centre: [x, y],
                radius_m: 0.06,
                z_min: 0.0,
                z_max: 2.1,
            };
            match i % 6 {
                // A curb beside the track, outside.
                0 => solids.push(square(at(1.6), 0.5, 0.0, 0.10)),
                // A step-high block inside.
                1 => solids.push(square(at(-1.8), 0.4, 0.0, 0.17)),
                // A post outside.
                2 => solids.push(post(at(1.2))),
                // A gate: posts either side, a bar over the track at 2.0 m.
                3 => {
                    solids.push(post(at(-0.9)));
                    solids.push(post(at(0.9)));
                    solids.push(square(at(0.0), 0.35, 2.0, 2.1));
                }
                // A branch over the track.
                4 => solids.push(square(at(0.0), 0.5, 1.6, 1.8)),
                // A wall segment outside.
                _ => solids.push(square(at(3.0), 0.8, 0.0, 1.0)),
            }
        }
        solids
    }
}

/// One line of the drive.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveLine {
    /// Its index, from 0.
    pub index: u64,
    /// Its time, microseconds.
    pub time_us: u64,
    /// The pose in force, as the link carries it (x, y, z, roll, pitch, yaw).
    pub pose: [f32; 6],
    /// The actuator angle in force, 2⁻¹⁶ turn.
    pub angle: u16,
    /// Whether the angle and pose are new at this line (the first of a hold).
    pub new_hold: bool,
    /// The measured-values telegram.
    pub telegram: Vec<u8>,
}

/// The drive's lines, one at a time.
#[derive(Debug, Clone)]
pub struct Drive {
    config: DriveConfig,
    laser: Laser,
    solids: Vec<Solid>,
    scene: Scene,
    scene_at: Option<(f64, f64)>,
    next: u64,
    lines: u64,
    held: Option<(Pose, u16)>,
}

/// How far from the robot a solid is still handed to the ray cast, metres (the laser's
/// 8.191 m, plus the largest solid's half-diagonal and the distance between rebuilds).
const REACH_M: f64 = 11.0;

impl Drive {
    /// The drive of `config`.
    #[must_use]
    pub fn new(config: DriveConfig) -> Self {
        let laser_config = DriveConfig::laser();
        // The laser sits where the setup says (f32), as the recorder does.
        let setup = config.setup();
        let laser_config = LaserConfig {
            position_m: setup.sensor_m.map(f64::from),
            ..laser_config
        };
        Self {
            config,
            laser: Laser::new(laser_config, config.seed),
            solids: config.solids(),
            scene: Scene::flat(),
            scene_at: None,
            next: 0,
            lines: config.lines(),
            held: None,
        }
    }

    /// The number of lines.
    #[must_use]
    pub const fn lines(&self) -> u64 {
        self.lines
    }

    fn local_scene(&mut self, x: f64, y: f64) {
        if self
            .scene_at
            .is_some_and(|(sx, sy)| (sx - x).hypot(sy - y) < 1.0)
        {
            return;
        }
        self.scene_at = Some((x, y));
        self.scene.solids = self
            .solids
            .iter()
            .copied()
            .filter(|solid| {
                let (cx, cy) = match *solid {
                    Solid::Box { min, max } => (0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])),
                    Solid::Cylinder { centre, .. } => (centre[0], centre[1]),
                };
                (cx - x).hypot(cy - y) < REACH_M
            })
            .collect();
    }
}

impl Iterator for Drive {
    type Item = DriveLine;

    fn next(&mut self) -> Option<DriveLine> {
        if self.next >= self.lines {
            return None;
        }
        let i = self.next;
        self.next += 1;
        let rate = self.config.line_rate_hz();
        let hold = u64::from(self.config.hold_lines.max(1));
        let new_hold = i.is_multiple_of(hold) || self.held.is_none();
        if new_hold {
            #[allow(clippy::cast_precision_loss)]
            let t = i as f64 / rate;
            let pose = self.config.pose_at(t).rounded_f32();
            let angle = angle_to_u16(DriveConfig::laser().actuator.angle_deg(t));
            self.held = Some((pose, angle));
        }
        let (pose, angle) = self.held?;
        self.local_scene(pose.x, pose.y);
        let line = self.laser.scan(&self.scene, &pose, angle);
        let telegram = self.laser.telegram(&line).ok()?;
        #[allow(clippy::cast_precision_loss, clippy::cast_possible_truncation)]
        let time_us = (i as f64 * 1e6 / rate).round() as u64;
        Some(DriveLine {
            index: i,
            time_us,
            pose: pose.to_f32(),
            angle,
            new_hold,
            telegram,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_hour_is_270_000_lines_and_laps_close() {
        let config = DriveConfig::new(3600.0);
        assert_eq!(config.lines(), 270_000);
        let lap_s = std::f64::consts::TAU * config.radius_m / config.speed_mps;
        // After a whole number of laps (counting stops), the robot is back at the origin.
        let p = config.pose_at(0.0);
        assert!(p.x.abs() < 1e-9 && p.y.abs() < 1e-9);
        let q = config.pose_at(lap_s + (lap_s / config.drive_s).floor() * config.stand_s);
        assert!(q.x.hypot(q.y) < 1.0, "{q:?}");
    }

    #[test]
    fn lines_are_deterministic_and_hold_their_angle() {
        let config = DriveConfig {
            hold_lines: 4,
            ..DriveConfig::new(2.0)
        };
        let a: Vec<DriveLine> = Drive::new(config).collect();
        let b: Vec<DriveLine> = Drive::new(config).collect();
        assert_eq!(a.len(), 150);
        assert_eq!(a, b);
        for chunk in a.chunks(4) {
            assert!(chunk[0].new_hold);
            assert!(chunk
                .iter()
                .all(|l| l.angle == chunk[0].angle && l.pose == chunk[0].pose));
            assert!(chunk[1..].iter().all(|l| !l.new_hold));
        }
    }
}
