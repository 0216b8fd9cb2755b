//! Scenes: a ground height function plus solid primitives, and the exact ray cast against
//! them; and the ground truth (which map cells hold an obstacle).
//!
//! # Frame
//! World frame, metres: x forward (the robot starts at the origin facing +x), y left, z up;
//! the ground around the start is at z = 0.
//!
//! # What a scene is made of
//! - **Ground**: a height field `z = ground(x, y)`, the sum of [`GroundTerm`]s (a slope, a
//!   flight of stairs, a step such as a curb, a trench). Terms may be discontinuous (risers,
//!   trench walls): the ray cast marches along the ray in steps of [`MARCH_STEP_M`] and
//!   refines the first crossing by bisection, so a vertical face is hit where it stands and
//!   at the height the ray has there. A ray that clips a corner by less than one march step
//!   between two samples may miss that corner (at most 1 cm of the edge).
//! - **Solids**: axis-aligned boxes and vertical cylinders ([`Solid`]), intersected
//!   analytically.
//! - **Features** ([`Feature`]): the truth about what is an obstacle, as 2-D footprints with
//!   the height of their lowest part above the ground and their height. They are not seen by
//!   the laser; [`Scene::obstacle_cells`] turns them into the cells a map should mark.
//!
//! # Scenarios ([`Scenario`], [`Scene::scenario`])
//! All layouts put their obstacle a few metres ahead of the origin, at an x ending in .05 m
//! so that its edge never lies on a boundary of the 0.1 m, 0.2 m, … grids:
//!
//! | scenario | layout |
//! | --- | --- |
//! | flat | z = 0 everywhere |
//! | stairs ([`StairsSpec`], default) | first riser at x = 5.05 m, 5 steps of 0.17 m rise and 0.30 m run rising away from the robot (risers at 5.05, 5.35, …, 6.25 m), 3.1 m wide (\|y\| ≤ 1.55 m, edges off the grid lines); the top landing (0.85 m) goes on without end in +x; beside the stairs the ground stays at 0 |
//! | curb | the ground steps up 0.10 m at x = 4.05 m, across all y |
//! | gate | two posts (radius 0.06 m, 2.1 m tall) at (5.05, ±0.75) m, 1.5 m apart; a bar 0.1 m × 0.1 m between them, from z = 2.0 to 2.1 m, x ∈ [5.0, 5.1] m, \|y\| ≤ 0.81 m |
//! | ditch | a trench 0.5 m deep, x ∈ [4.05, 4.65] m (0.6 m wide), across all y, vertical walls |
//! | branch | an overhanging box x ∈ [4.05, 5.05] m, \|y\| ≤ 1 m, z ∈ [1.6, 1.8] m (no trunk) |
//! | slope | the ground rises at 10° from x = 3.05 m on, without end |

mod ground;
mod layouts;
mod solid;
mod truth;

pub use ground::{GroundTerm, StairsSpec};
pub use layouts::Scenario;
pub use solid::Solid;
pub use truth::{Feature, FeatureKind, Footprint, GroundTruthSpec, ObstacleCell};

/// A 3-vector, metres (or a unit direction).
pub type Vec3 = [f64; 3];

/// The march step of the height-field ray cast, metres along the ray.
pub const MARCH_STEP_M: f64 = 0.01;

/// Bisection iterations that refine a height-field crossing: 1 cm / 2³⁰ ≈ 10⁻¹¹ m.
const BISECTION_STEPS: u32 = 30;

/// A ray: origin and unit direction, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where it starts, metres.
    pub origin: Vec3,
    /// Its direction, a unit vector.
    pub dir: Vec3,
}

impl Ray {
    /// The point at distance `t` (metres) along the ray.
    #[must_use]
    pub fn at(&self, t: f64) -> Vec3 {
        [
            self.origin[0] + t * self.dir[0],
            self.origin[1] + t * self.dir[1],
            self.origin[2] + t * self.dir[2],
        ]
    }
}

/// A scene: ground, solids, the truth about obstacles, and the x the approach counts down to.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// A short name ("stairs", …).
    pub name: &'static str,
    /// The ground: the sum of these terms (none: flat at z = 0).
    pub ground: Vec<GroundTerm>,
    /// The solids.
    pub solids: Vec<Solid>,
    /// The obstacles' truth.
    pub features: Vec<Feature>,
    /// The x of the obstacle the robot approaches (the first riser, the curb, …), metres;
    /// the recorder's distance markers count down to it. `None` for flat ground.
    pub target_x: Option<f64>,
}

/// A surface a ray hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// The ground.
    Ground,
    /// The solid with this index in [`Scene::solids`].
    Solid(usize),
}

/// The first hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray, metres.
    pub t: f64,
    /// The point hit, metres.
    pub point: Vec3,
    /// What was hit.
    pub surface: Surface,
}

impl Scene {
    /// The ground height at `(x, y)`, metres.
    #[must_use]
    pub fn ground_height(&self, x: f64, y: f64) -> f64 {
        self.ground.iter().map(|g| g.height(x, y)).sum()
    }

    /// The first hit of `ray` within `t_max` metres, or `None` (no echo).
    #[must_use]
    pub fn cast(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let mut best: Option<(f64, Surface)> =
            self.cast_ground(ray, t_max).map(|t| (t, Surface::Ground));
        for (i, solid) in self.solids.iter().enumerate() {
            let limit = best.map_or(t_max, |(t, _)| t);
            if let Some(t) = solid.intersect(ray, limit) {
                if best.is_none_or(|(b, _)| t < b) {
                    best = Some((t, Surface::Solid(i)));
                }
            }
        }
        best.map(|(t, surface)| Hit {
            t,
            point: ray.at(t),
            surface,
        })
    }

    /// The distance to the ground along `ray`, within `t_max`: march, then bisect.
    fn cast_ground(&self, ray: &Ray, t_max: f64) -> Option<f64> {
        let [ox, oy, oz] = ray.origin;
        let [dx, dy, dz] = ray.dir;
        let (ex, ey) = (ox + t_max * dx, oy + t_max * dy);
        let z_max = self
            .ground
            .iter()
            .map(|g| g.max_over(ox.min(ex), ox.max(ex), oy.min(ey), oy.max(ey)))
            .sum::<f64>();
        // Before the ray comes down to the highest ground it can meet, it meets nothing.
        let t_start = if oz > z_max {
            if dz >= 0.0 {
                return None;
            }
            (oz - z_max) / -dz
        } else {
            0.0
        };
        if t_start > t_max {
            return None;
        }
        let above = |t: f64| oz + t * dz - self.ground_height(ox + t * dx, oy + t * dy);
        if above(t_start) <= 0.0 {
            return Some(t_start);
        }
        let mut a = t_start;
        while a < t_max {
            let b = (a + MARCH_STEP_M).min(t_max);
            if above(b) <= 0.0 {
                // above(a) > 0 ≥ above(b): bisect to the crossing.
                let (mut lo, mut hi) = (a, b);
                for _ in 0..BISECTION_STEPS {
                    let mid = 0.5 * (lo + hi);
                    if above(mid) <= 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(hi);
            }
            a = b;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray from `origin` along +x.
    fn along_x(origin: Vec3) -> Ray {
        Ray {
            origin,
            dir: [1.0, 0.0, 0.0],
        }
    }

    fn down_ray(origin: Vec3, depression_deg: f64) -> Ray {
        let a = depression_deg.to_radians();
        Ray {
            origin,
            dir: [a.cos(), 0.0, -a.sin()],
        }
    }

    #[test]
    fn flat_ground_is_hit_at_h_over_sin() {
        let scene = Scene::flat();
        for deg in [2.0, 10.0, 45.0, 89.0] {
            let hit = scene.cast(&down_ray([0.0, 0.0, 1.0], deg), 80.0).unwrap();
            let expected = 1.0 / f64::to_radians(deg).sin();
            assert!((hit.t - expected).abs() < 1e-9, "{deg}: {}", hit.t);
            assert!(hit.point[2].abs() < 1e-9);
        }
        let up = along_x([0.0, 0.0, 1.0]);
        assert_eq!(scene.cast(&up, 80.0), None);
    }

    #[test]
    fn a_riser_is_hit_on_its_face() {
        let scene = Scene::scenario(Scenario::Stairs);
        // Horizontal rays at 0.1 m and 0.3 m hit the first riser's face at x = 5.05 and the
        // second's at 5.35 (steps at 0.17, 0.34).
        for (z, riser_x) in [(0.1, 5.05), (0.3, 5.35)] {
            let hit = scene.cast(&along_x([0.0, 0.0, z]), 20.0).unwrap();
            assert!((hit.point[0] - riser_x).abs() < 1e-9, "{z}: {hit:?}");
        }
        // Beside the flight: nothing.
        let ray = along_x([0.0, 2.0, 0.3]);
        assert_eq!(scene.cast(&ray, 20.0), None);
    }

    #[test]
    fn posts_and_bars_are_hit() {
        let scene = Scene::scenario(Scenario::Gate);
        let ray = along_x([0.0, 0.75, 1.0]);
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[0] - (5.05 - 0.06)).abs() < 1e-9, "{:?}", hit);
        assert_eq!(hit.surface, Surface::Solid(1));
        // Straight up under the bar: its underside.
        let ray = Ray {
            origin: [5.05, 0.0, 1.0],
            dir: [0.0, 0.0, 1.0],
        };
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.t - 1.0).abs() < 1e-9, "{:?}", hit);
        // Straight down onto a post's top cap.
        let ray = Ray {
            origin: [5.05, -0.75, 3.0],
            dir: [0.0, 0.0, -1.0],
        };
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[2] - 2.1).abs() < 1e-9, "{:?}", hit);
    }

    #[test]
    fn ditch_walls_and_floor() {
        let scene = Scene::scenario(Scenario::Ditch);
        // Steep ray into the trench: the floor at −0.5.
        let ray = down_ray([4.0, 0.0, 1.0], 80.0);
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[2] + 0.5).abs() < 1e-9, "{:?}", hit);
        // Shallow ray: over the near edge, onto the far wall.
        let ray = down_ray([0.0, 0.0, 1.0], f64::atan(1.0 / 4.3).to_degrees());
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[0] - 4.65).abs() < 1e-9, "{:?}", hit);
        assert!(hit.point[2] < 0.0 && hit.point[2] > -0.5, "{:?}", hit);
    }

    #[test]
    fn slope_is_met_by_a_rising_ray() {
        let scene = Scene::scenario(Scenario::Slope);
        let ray = along_x([0.0, 0.0, 1.0]);
        let hit = scene.cast(&ray, 20.0).unwrap();
        let x = 3.05 + 1.0 / 10f64.to_radians().tan();
        assert!((hit.point[0] - x).abs() < 1e-6, "{:?}", hit);
    }

    #[test]
    fn ground_truth_cells() {
        let spec = GroundTruthSpec::default();
        let stairs = Scene::scenario(Scenario::Stairs).obstacle_cells(&spec);
        // Risers at 5.05 … 6.25 → cells 50, 53, 56, 59, 62, across |y| ≤ 1.55 (cells −16 ..= 15).
        for ix in [50, 53, 56, 59, 62] {
            assert!(stairs.iter().any(|c| c.ix == ix && c.iy == 0), "{ix}");
        }
        assert!(!stairs.iter().any(|c| c.ix == 51 && c.iy == 0));
        assert!(stairs.iter().any(|c| c.ix == 80 && c.iy == 15));
        let gate = Scene::scenario(Scenario::Gate).obstacle_cells(&spec);
        assert!(gate.iter().all(|c| c.kind == FeatureKind::Post));
        assert!(gate.iter().any(|c| c.ix == 50 && c.iy == 7));
        let tall = GroundTruthSpec {
            robot_height_m: 2.5,
            ..spec
        };
        let gate = Scene::scenario(Scenario::Gate).obstacle_cells(&tall);
        assert!(gate.iter().any(|c| c.kind == FeatureKind::Bar));
        assert!(Scene::scenario(Scenario::Branch)
            .obstacle_cells(&spec)
            .is_empty());
        let ditch = Scene::scenario(Scenario::Ditch).obstacle_cells(&spec);
        assert_eq!(ditch.iter().filter(|c| c.iy == 0).count(), 7); // 4.0 .. 4.7
        assert!(Scene::scenario(Scenario::Slope)
            .obstacle_cells(&spec)
            .is_empty());
    }
}
