//! Scenes that change: a static [`Scene`] plus [`Mover`]s, solids that move along a path and
//! may leave. The laser sees the scene of each line's time ([`super::record::simulate_with`]); the
//! truth says which cells each mover covers when, and which cells of the static obstacles the
//! laser hit when (so that an evaluation can tell the obstacles in view from those out of
//! view).
//!
//! | scenario | the robot | what changes |
//! | --- | --- | --- |
//! | [`ChangingScene::pedestrian`] | stands at the origin, facing +x | a pedestrian (a 0.25 m cylinder, 1.7 m) walks in from the right at 1.4 m/s, waits 5 s 3 m in front of the robot, walks on to the left and out of sight; a bollard (0.1 m, 1 m tall) stands at (5.05, −1.55) m |
//! | [`ChangingScene::door`] | stands at the origin | a wall 4 m ahead (x 4.0 – 4.1 m, \|y\| ≤ 4 m) with a 1 m doorway; the door (5 cm thick, 2 m tall) slides open behind the wall at t = 10 s, in 1 s |
//! | [`ChangingScene::car`] | stands 2 s at x = −10 m, drives to 0 at 1 m/s, then stands | three cars (4.5 × 1.8 × 1.5 m) parked beside the lane (\|y\| 1.65 – 3.45 m): one the robot drives past (right, x −9.05 – −4.55 m: out of the laser's view at the end), one across the lane ahead (left, x 2.55 – 7.05 m) and the one that leaves (right, the same x), pulling away along +x at t = 15 s (1.5 m/s²) |
//!
//! Every layout keeps its edges off the 0.1 m grid lines (x and y ending in .05 where they
//! matter) as [`super::scene`] does.

use std::collections::{BTreeMap, BTreeSet};

use super::laser::{Actuator, LaserConfig};
use super::record::{simulate_with, LineView, SimConfig, SimError, Simulation};
use super::scene::{
    Feature, FeatureKind, Footprint, GroundTruthSpec, ObstacleCell, Scene, Solid, Surface,
};
use super::trajectory::Trajectory;

/// A world cell index on the truth grid (0.1 m by default).
pub type CellIndex = (i32, i32);

/// A solid that moves: where it is (an offset of its solid, piecewise linear between key
/// frames, held before the first and after the last) and while it exists.
#[derive(Debug, Clone, PartialEq)]
pub struct Mover {
    /// A short name ("pedestrian", "door", "car").
    pub name: &'static str,
    /// The solid at offset (0, 0).
    pub solid: Solid,
    /// Key frames: (time s, (dx, dy) m), times ascending.
    pub keys: Vec<(f64, [f64; 2])>,
    /// It exists from `present.0` until before `present.1`, seconds.
    pub present: (f64, f64),
}

impl Mover {
    /// The offset at `t` seconds, or `None` while it does not exist.
    #[must_use]
    pub fn offset_at(&self, t: f64) -> Option<[f64; 2]> {
        if !(self.present.0..self.present.1).contains(&t) {
            return None;
        }
        let first = self.keys.first()?;
        if t <= first.0 {
            return Some(first.1);
        }
        for pair in self.keys.windows(2) {
            let ((t0, a), (t1, b)) = (pair[0], pair[1]);
            if t <= t1 {
                let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                return Some([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
            }
        }
        self.keys.last().map(|k| k.1)
    }

    /// The solid at `t`, or `None`.
    #[must_use]
    pub fn solid_at(&self, t: f64) -> Option<Solid> {
        let [dx, dy] = self.offset_at(t)?;
        Some(match self.solid {
            Solid::Box { min, max } => Solid::Box {
                min: [min[0] + dx, min[1] + dy, min[2]],
                max: [max[0] + dx, max[1] + dy, max[2]],
            },
            Solid::Cylinder {
                centre,
                radius_m,
                z_min,
                z_max,
            } => Solid::Cylinder {
                centre: [centre[0] + dx, centre[1] + dy],
                radius_m,
                z_min,
                z_max,
            },
        })
    }

    /// The mover at `t` as an obstacle feature (its footprint, on the ground), or `None`.
    #[must_use]
    pub fn feature_at(&self, t: f64) -> Option<Feature> {
        Some(feature_of(self.solid_at(t)?))
    }
}

/// A solid standing on the ground as an obstacle feature.
fn feature_of(solid: Solid) -> Feature {
    match solid {
        Solid::Box { min, max } => Feature {
            kind: FeatureKind::Post,
            footprint: Footprint::Rect {
                x_min: min[0],
                x_max: max[0],
                y_min: min[1],
                y_max: max[1],
            },
            bottom_m: min[2],
            height_m: max[2] - min[2],
        },
        Solid::Cylinder {
            centre,
            radius_m,
            z_min,
            z_max,
        } => Feature {
            kind: FeatureKind::Post,
            footprint: Footprint::Disc { centre, radius_m },
            bottom_m: z_min,
            height_m: z_max - z_min,
        },
    }
}

/// A scene that changes, the robot's motion and how long it lasts.
#[derive(Debug, Clone, PartialEq)]
pub struct ChangingScene {
    /// A short name ("pedestrian", "door", "car").
    pub name: &'static str,
    /// What never moves: its solids are the static obstacles (each with its feature).
    pub base: Scene,
    /// What moves.
    pub movers: Vec<Mover>,
    /// The robot.
    pub trajectory: Trajectory,
}

impl ChangingScene {
    /// The scene at `t`: the base and every mover that exists then (after the base's solids,
    /// in order).
    #[must_use]
    pub fn at(&self, t: f64) -> Scene {
        let mut scene = self.base.clone();
        scene
            .solids
            .extend(self.movers.iter().filter_map(|m| m.solid_at(t)));
        scene
    }

    /// A pedestrian crossing in front of a robot that stands (40 s).
    #[must_use]
    pub fn pedestrian() -> Self {
        let walk = 1.4;
        let (x, from, to) = (3.05, -6.0, 6.0);
        let t0 = 3.0;
        let arrive = t0 + (0.0 - from) / walk;
        let wait = 5.0;
        let gone = arrive + wait + (to - 0.0) / walk;
        let mut base = Scene::flat();
        base.name = "pedestrian";
        let bollard = Solid::Cylinder {
            centre: [5.05, -1.55],
            radius_m: 0.1,
            z_min: 0.0,
            z_max: 1.0,
        };
        base.solids.push(bollard);
        base.features.push(feature_of(bollard));
        Self {
            name: "pedestrian",
            base,
            movers: vec![Mover {
                name: "pedestrian",
                solid: Solid::Cylinder {
                    centre: [x, 0.0],
                    radius_m: 0.25,
                    z_min: 0.0,
                    z_max: 1.7,
                },
                keys: vec![
                    (t0, [0.0, from]),
                    (arrive, [0.0, 0.0]),
                    (arrive + wait, [0.0, 0.0]),
                    (gone, [0.0, to]),
                ],
                present: (0.0, gone),
            }],
            trajectory: Trajectory::standing(40.0),
        }
    }

    /// A door that opens in a wall ahead of a robot that stands (40 s).
    #[must_use]
    pub fn door() -> Self {
        let (x0, x1) = (4.05, 4.15);
        let gap = 0.55;
        let mut base = Scene::flat();
        base.name = "door";
        for (y_min, y_max) in [(-4.05, -gap), (gap, 4.05)] {
            let solid = Solid::Box {
                min: [x0, y_min, 0.0],
                max: [x1, y_max, 2.5],
            };
            base.solids.push(solid);
            base.features.push(feature_of(solid));
        }
        let open_at = 10.0;
        Self {
            name: "door",
            base,
            movers: vec![Mover {
                name: "door",
                solid: Solid::Box {
                    min: [x0, -gap, 0.0],
                    max: [x0 + 0.05, gap, 2.0],
                },
                // Behind the wall, out of the laser's sight, 1.1 m to the left.
                keys: vec![(open_at, [0.0, 0.0]), (open_at + 1.0, [0.15, 1.1])],
                present: (0.0, f64::INFINITY),
            }],
            trajectory: Trajectory::standing(40.0),
        }
    }

    /// A car that leaves its parking space ahead of a robot that drove past another (50 s).
    #[must_use]
    pub fn car() -> Self {
        let h = 1.5;
        let car = |x: f64, right: bool| {
            let (y0, y1) = if right { (-3.45, -1.65) } else { (1.65, 3.45) };
            Solid::Box {
                min: [x, y0, 0.0],
                max: [x + 4.5, y1, h],
            }
        };
        let mut base = Scene::flat();
        base.name = "car";
        // Passed by the robot (behind it at the end), and across the lane ahead.
        for (x, right) in [(-9.05, true), (2.55, false)] {
            base.solids.push(car(x, right));
            base.features.push(feature_of(car(x, right)));
        }
        let leave = 15.0;
        let accel: f64 = 1.5;
        // x offset = a·s²/2 for s seconds after leaving; key frames every 0.25 s for 6 s.
        let keys = (0..=24)
            .map(|i| {
                let s = f64::from(i) * 0.25;
                (leave + s, [0.5 * accel * s * s, 0.0])
            })
            .collect();
        Self {
            name: "car",
            base,
            movers: vec![Mover {
                name: "car",
                solid: car(2.55, true),
                keys,
                present: (0.0, leave + 6.0),
            }],
            trajectory: Trajectory {
                start_x: -10.0,
                y: 0.0,
                stand_s: 2.0,
                speed_mps: 1.0,
                stop_x: 0.0,
                dwell_s: 38.0,
                yaw_rate_rad_s: 0.0,
            },
        }
    }

    /// The three changing scenes.
    #[must_use]
    pub fn all() -> [Self; 3] {
        [Self::pedestrian(), Self::door(), Self::car()]
    }

    /// The simulator's configuration: the paper's panned laser, the truth on a 0.1 m grid
    /// around the robot's path (±12 m).
    #[must_use]
    pub fn sim(&self) -> SimConfig {
        let laser = LaserConfig {
            actuator: Actuator::Pan {
                half_width_deg: 45.0,
                rate_deg_s: 74.0,
            },
            ..LaserConfig::paper()
        };
        let mut sim = SimConfig::new(self.base.clone(), laser, self.trajectory);
        sim.truth = GroundTruthSpec {
            x_min: self.trajectory.start_x - 12.0,
            x_max: self.trajectory.stop_x + 12.0,
            y_min: -12.0,
            y_max: 12.0,
            ..GroundTruthSpec::default()
        };
        sim
    }
}

/// A changing scene simulated: the recording and the truth over time.
#[derive(Debug, Clone)]
pub struct ChangingSimulation {
    /// The recording (with its static truth, [`Simulation::ground_truth`]).
    pub simulation: Simulation,
    /// The truth grid.
    pub truth: GroundTruthSpec,
    /// The time of every line, seconds.
    pub line_times: Vec<f64>,
    /// Each mover's cells: for each cell it covered, the time it first and last covered it
    /// (sampled at the lines), seconds.
    pub mover_cells: Vec<BTreeMap<CellIndex, (f64, f64)>>,
    /// The static obstacles' cells (the base's features).
    pub static_cells: BTreeSet<CellIndex>,
    /// For each static obstacle cell the laser hit, the times of the lines that hit it.
    pub static_hits: BTreeMap<CellIndex, Vec<f64>>,
}

/// Simulates a changing scene: the recording, and the truth sampled at every line.
///
/// # Errors
/// The simulator refused the configuration.
pub fn simulate_changing(scene: &ChangingScene) -> Result<ChangingSimulation, SimError> {
    let config = scene.sim();
    let truth = config.truth;
    let statics = scene.base.solids.len();
    let cell_of = |v: f64| (v / truth.cell_m).floor() as i32;
    let mut line_times = Vec::new();
    let mut mover_cells = vec![BTreeMap::new(); scene.movers.len()];
    let mut static_hits: BTreeMap<CellIndex, Vec<f64>> = BTreeMap::new();
    let static_cells: BTreeSet<CellIndex> = scene
        .base
        .obstacle_cells(&truth)
        .iter()
        .map(|c| (c.ix, c.iy))
        .collect();
    let max_range = config.laser.max_range();
    let simulation = simulate_with(&config, &|t| Some(scene.at(t)), &mut |line: &LineView<
        '_,
    >| {
        let t = line.t_s;
        line_times.push(t);
        for (cells, mover) in mover_cells.iter_mut().zip(&scene.movers) {
            let Some(feature) = mover.feature_at(t) else {
                continue;
            };
            for c in footprint_cells(feature, &truth) {
                cells
                    .entry((c.ix, c.iy))
                    .and_modify(|span: &mut (f64, f64)| span.1 = t)
                    .or_insert((t, t));
            }
        }
        for ray in line.laser.rays(line.pose, line.angle) {
            let Some(hit) = line.scene.cast(&ray, max_range) else {
                continue;
            };
            if matches!(hit.surface, Surface::Solid(i) if i < statics) {
                let c = (cell_of(hit.point[0]), cell_of(hit.point[1]));
                if static_cells.contains(&c) {
                    let times = static_hits.entry(c).or_default();
                    if times.last() != Some(&t) {
                        times.push(t);
                    }
                }
            }
        }
    })?;
    Ok(ChangingSimulation {
        simulation,
        truth,
        line_times,
        mover_cells,
        static_cells,
        static_hits,
    })
}

/// The cells of the truth grid a feature covers.
fn footprint_cells(feature: Feature, truth: &GroundTruthSpec) -> Vec<ObstacleCell> {
    let mut scene = Scene::flat();
    scene.features.push(feature);
    scene.obstacle_cells(truth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn movers_follow_their_key_frames() {
        let p = ChangingScene::pedestrian();
        let m = &p.movers[0];
        assert_eq!(m.offset_at(0.0), Some([0.0, -6.0]));
        let arrive = 3.0 + 6.0 / 1.4;
        assert_eq!(m.offset_at(arrive + 2.0), Some([0.0, 0.0]));
        let [_, y] = m.offset_at(arrive + 5.0 + 0.7).unwrap();
        assert!((y - 0.98).abs() < 1e-9);
        assert_eq!(m.offset_at(40.0), None);
        let door = ChangingScene::door();
        assert_eq!(door.at(5.0).solids.len(), 3);
        assert_eq!(p.at(0.0).solids.len(), 2, "the bollard and the pedestrian");
        let Some(Solid::Box { min, .. }) = door.movers[0].solid_at(20.0) else {
            panic!("the door");
        };
        assert!((min[1] - 0.55).abs() < 1e-9, "{min:?}");
        let car = ChangingScene::car();
        assert!(car.at(30.0).solids.len() == 2, "the car has gone");
        let Some(Solid::Box { min, .. }) = car.movers[0].solid_at(17.0) else {
            panic!("the car");
        };
        assert!((min[0] - (2.55 + 3.0)).abs() < 1e-9); // 1.5·2²/2 = 3 m
    }

    #[test]
    fn the_door_scene_is_seen_changing() {
        let sim = simulate_changing(&ChangingScene::door()).unwrap();
        assert_eq!(sim.line_times.len() as u32, sim.simulation.lines);
        // The door covers x 4.05 – 4.10, |y| < 0.55: cells 40, −6 ..= 5, until it opens.
        let door = &sim.mover_cells[0];
        let (first, last) = door[&(40, 0)];
        assert_eq!(first, 0.0);
        assert!((10.0..10.5).contains(&last), "{last}");
        // The wall is hit on its face (x = 4.05 m: cells 40) while the door is shut and after.
        let face = sim.static_hits.get(&(40, 10)).expect("the wall is seen");
        assert!(face.iter().any(|&t| t < 10.0) && face.iter().any(|&t| t > 20.0));
        assert!(sim.static_cells.contains(&(41, -20)));
    }
}
