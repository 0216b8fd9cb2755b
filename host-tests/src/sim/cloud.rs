//! Point clouds straight from the ray cast (`f64`, no telegrams): the observations the
//! navigability rules are measured on.
//!
//! - [`RingLaser`]: a car's 3-D laser, a spinning fan of beams at fixed elevations (φ between
//!   beams, ψ between firings), every return in firing order (all beams of one azimuth, then
//!   the next azimuth): one revolution is one observation.
//! - [`pan_observations`]: the paper's robot, a vertical SICK plane panned about z
//!   ([`super::laser`]), along a [`Trajectory`], N lines per observation.
//!
//! The range noise is the design's sensor model ([`terrain_pyramid::SensorModel`]): Gaussian
//! along the beam with a standard deviation σ that does not depend on the range, the returned
//! range rounded to the millimetre. A ray that meets nothing within the maximum range gives no
//! point.

use super::laser::{angle_to_u16, Laser, LaserConfig};
use super::rng::Rng;
use super::scene::{Ray, Scene};
use super::trajectory::{Pose, Trajectory};

/// One observation: the sensor's position, the robot's ground plane and the returns in the
/// order the sensor produced them, world frame, metres.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The scan centre.
    pub sensor: [f64; 3],
    /// The z of the robot's ground contact point.
    pub ground_z: f64,
    /// The returns.
    pub points: Vec<[f64; 3]>,
}

/// `points` in a spinning laser's firing order about `sensor` (metres): by azimuth in steps
/// of `psi_rad` (> 0) counted from −π, then by elevation from the lowest; a stable sort, as
/// `pyramid replay --order firing` sorts a point file.
#[must_use]
pub fn firing_order(points: &[[f64; 3]], sensor: [f64; 3], psi_rad: f64) -> Vec<[f64; 3]> {
    #[allow(clippy::cast_possible_truncation)]
    let key = |p: &[f64; 3]| {
        let (x, y, z) = (p[0] - sensor[0], p[1] - sensor[1], p[2] - sensor[2]);
        let step = ((y.atan2(x) + std::f64::consts::PI) / psi_rad).floor() as i64;
        (step, z.atan2(x.hypot(y)))
    };
    let mut keyed: Vec<([f64; 3], (i64, f64))> = points.iter().map(|p| (*p, key(p))).collect();
    keyed.sort_by(|a, b| a.1 .0.cmp(&b.1 .0).then(a.1 .1.total_cmp(&b.1 .1)));
    keyed.into_iter().map(|(p, _)| p).collect()
}

/// A spinning multi-beam laser on a car.
#[derive(Debug, Clone, PartialEq)]
pub struct RingLaser {
    /// The scan centre's height above the ground contact, metres.
    pub height_m: f64,
    /// The beams' elevations, degrees (negative looks down), in firing order.
    pub elevations_deg: Vec<f64>,
    /// The azimuth step between firings, degrees.
    pub azimuth_step_deg: f64,
    /// The range noise σ, metres.
    pub sigma_m: f64,
    /// The maximum range, metres.
    pub max_range_m: f64,
    /// The standard deviation of each beam's elevation error (a calibration error, drawn
    /// once per beam when the laser is made and kept), degrees. 0 for a perfect laser.
    pub elevation_bias_deg: f64,
    /// The standard deviation of each beam's range offset (drawn once per beam), metres.
    pub range_bias_m: f64,
    /// The seed of the beams' calibration errors.
    pub calibration_seed: u64,
}

impl RingLaser {
    /// The car laser of the street measurements: h = 1.3 m, beams every φ = 0.4° from −24.8°
    /// to +2.0° (68 beams), ψ = 0.2°, σ = `sigma_m`, 20 m.
    #[must_use]
    pub fn car(sigma_m: f64) -> Self {
        Self {
            height_m: 1.3,
            elevations_deg: (0..68).map(|i| -24.8 + 0.4 * f64::from(i)).collect(),
            azimuth_step_deg: 0.2,
            sigma_m,
            max_range_m: 20.0,
            elevation_bias_deg: 0.0,
            range_bias_m: 0.0,
            calibration_seed: 1,
        }
    }

    /// Each beam's (elevation error, degrees; range offset, metres).
    #[must_use]
    pub fn calibration(&self) -> Vec<(f64, f64)> {
        let mut rng = Rng::new(self.calibration_seed);
        self.elevations_deg
            .iter()
            .map(|_| {
                (
                    self.elevation_bias_deg * rng.gaussian(),
                    self.range_bias_m * rng.gaussian(),
                )
            })
            .collect()
    }

    /// One revolution from `pose` (level), noise from `rng`.
    #[must_use]
    pub fn scan(&self, scene: &Scene, pose: &Pose, rng: &mut Rng) -> Observation {
        self.scan_with_truth(scene, pose, rng).0
    }

    /// [`Self::scan`], and the true points of its returns, in the same order: where each
    /// beam, as it really points, met the scene.
    #[must_use]
    pub fn scan_with_truth(
        &self,
        scene: &Scene,
        pose: &Pose,
        rng: &mut Rng,
    ) -> (Observation, Observation) {
        let origin = pose.to_world([0.0, 0.0, self.height_m]);
        let r = pose.rotation();
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let firings = (360.0 / self.azimuth_step_deg).round() as u32;
        // The beams as they really point (the calibration error), with their range offsets;
        // the returns are placed where the nominal beam says.
        let calibration = self.calibration();
        type Beam = ((f64, f64), (f64, f64), f64);
        let beams: Vec<Beam> = self
            .elevations_deg
            .iter()
            .zip(&calibration)
            .map(|(e, (de, dr))| {
                (
                    (e + de).to_radians().sin_cos(),
                    e.to_radians().sin_cos(),
                    *dr,
                )
            })
            .collect();
        let mut points = Vec::new();
        let mut truth = Vec::new();
        for a in 0..firings {
            let (sa, ca) = (f64::from(a) * self.azimuth_step_deg)
                .to_radians()
                .sin_cos();
            for &((se, ce), (sn, cn), dr) in &beams {
                let world = |d: [f64; 3]| -> [f64; 3] {
                    core::array::from_fn(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2])
                };
                let ray = Ray {
                    origin,
                    dir: world([ce * ca, ce * sa, se]),
                };
                if let Some(hit) = scene.cast(&ray, self.max_range_m) {
                    let range =
                        ((hit.t + dr + self.sigma_m * rng.gaussian()) * 1000.0).round() / 1000.0;
                    if range > 0.0 {
                        let nominal = Ray {
                            origin,
                            dir: world([cn * ca, cn * sa, sn]),
                        };
                        points.push(nominal.at(range));
                        truth.push(hit.point);
                    }
                }
            }
        }
        (
            Observation {
                sensor: origin,
                ground_z: pose.z,
                points,
            },
            Observation {
                sensor: origin,
                ground_z: pose.z,
                points: truth,
            },
        )
    }
}

/// The paper's robot along `trajectory` over `scene`: `laser` (a panned vertical plane) at
/// its line rate, `lines_per_observation` lines per observation, σ = `laser.sigma_m`, ranges
/// to the millimetre. The robot stands level at the ground's height under it.
#[must_use]
pub fn pan_observations(
    scene: &Scene,
    laser: LaserConfig,
    trajectory: &Trajectory,
    lines_per_observation: usize,
    seed: u64,
) -> Vec<Observation> {
    let sim = Laser::new(laser, seed);
    let mut rng = Rng::new(seed ^ 0x5EED);
    let rate = laser.line_rate_hz();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let lines = (trajectory.duration_s() * rate).ceil() as u64 + 1;
    let max_range = laser.max_range();
    let mut out = Vec::new();
    let mut current: Option<Observation> = None;
    let mut in_obs = 0;
    for i in 0..lines {
        #[allow(clippy::cast_precision_loss)]
        let t = i as f64 / rate;
        let pose = trajectory.pose_at(t, scene);
        let angle = angle_to_u16(laser.actuator.angle_deg(t));
        let obs = current.get_or_insert_with(|| Observation {
            sensor: pose.to_world(laser.position_m),
            ground_z: pose.z,
            points: Vec::new(),
        });
        for ray in sim.rays(&pose, angle) {
            if let Some(hit) = scene.cast(&ray, max_range) {
                let range = ((hit.t + laser.sigma_m * rng.gaussian()) * 1000.0).round() / 1000.0;
                if range > 0.0 {
                    obs.points.push(ray.at(range));
                }
            }
        }
        in_obs += 1;
        if in_obs >= lines_per_observation.max(1) {
            out.extend(current.take());
            in_obs = 0;
        }
    }
    out.extend(current.take());
    out
}

/// The design of the car laser's street measurements (the laser of [`RingLaser::car`]:
/// h 1.3 m, φ 0.4°, ψ 0.2°, 20 m; 0.1 m at the base, γ 3, the default gate) with a range
/// noise of `sigma_m` metres and windows of `cells` per side.
///
/// # Errors
/// The library's refusal of the design.
pub fn car_design<const L: usize>(
    sigma_m: f32,
    cells: usize,
) -> Result<terrain_pyramid::Design<L>, terrain_pyramid::DesignError> {
    terrain_pyramid::Design::new(
        terrain_pyramid::SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: 0.2_f32.to_radians(),
            sigma_m,
            height_m: 1.3,
            max_range_m: 20.0,
        },
        terrain_pyramid::Schedule {
            base_m: 0.1,
            gamma: 3.0,
            gate: terrain_pyramid::GateShape::default(),
            ..terrain_pyramid::Schedule::default()
        },
        cells,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_noise_free_ring_meets_flat_ground_at_h_over_tan() {
        let laser = RingLaser {
            elevations_deg: vec![-10.0, 5.0],
            azimuth_step_deg: 90.0,
            ..RingLaser::car(0.0)
        };
        let obs = laser.scan(&Scene::flat(), &Pose::default(), &mut Rng::new(1));
        // Four azimuths, the upward beam never returns.
        assert_eq!(obs.points.len(), 4);
        let d = 1.3 / 10f64.to_radians().tan();
        for p in &obs.points {
            assert!((p[0].hypot(p[1]) - d).abs() < 2e-3, "{p:?}");
            assert!(p[2].abs() < 1e-3);
        }
        assert_eq!(obs.sensor, [0.0, 0.0, 1.3]);
    }

    #[test]
    fn pan_observations_group_lines() {
        let traj = Trajectory::standing(0.5);
        let laser = LaserConfig {
            sigma_m: 0.0,
            ..LaserConfig::paper()
        };
        let obs = pan_observations(&Scene::flat(), laser, &traj, 8, 1);
        // ⌈0.5 · 37.5⌉ + 1 = 20 lines: two of 8 and one of 4.
        assert_eq!(obs.len(), 3);
        assert!(obs
            .iter()
            .all(|o| o.points.iter().all(|p| p[2].abs() < 1e-3)));
    }
}
