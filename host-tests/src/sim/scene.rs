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

/// A flight of stairs rising away from the robot (+x), as a ground term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StairsSpec {
    /// x of the first riser, metres.
    pub first_riser_x: f64,
    /// Number of steps, ≥ 1. Default 5.
    pub steps: u32,
    /// Height of each step, metres, > 0 (stairs are 0.15-0.18 m). Default 0.17 m.
    pub rise_m: f64,
    /// Depth of each tread, metres, > 0. Default 0.30 m.
    pub run_m: f64,
    /// Width across y, metres, > 0, centred on y = 0. Default 3.1 m (its sides at ±1.55 m,
    /// off the lines of the 0.1 m grid).
    pub width_m: f64,
}

impl Default for StairsSpec {
    fn default() -> Self {
        Self {
            first_riser_x: 5.05,
            steps: 5,
            rise_m: 0.17,
            run_m: 0.30,
            width_m: 3.1,
        }
    }
}

impl StairsSpec {
    /// x of riser `i` (0-based, `i < steps`), metres.
    #[must_use]
    pub fn riser_x(&self, i: u32) -> f64 {
        self.first_riser_x + f64::from(i) * self.run_m
    }

    /// Height of the top landing, metres: `steps · rise`.
    #[must_use]
    pub fn top_m(&self) -> f64 {
        f64::from(self.steps) * self.rise_m
    }
}

/// One additive term of the ground height, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GroundTerm {
    /// The ground rises (or falls, for a negative angle) linearly in x from `x0` on:
    /// `(x − x0)·tan(angle)` for x > x0, 0 before. Any y.
    Slope {
        /// Where the slope starts, metres.
        x0: f64,
        /// The slope angle, radians, in (−π/2, π/2).
        angle_rad: f64,
    },
    /// A flight of stairs: `rise · min(steps, ⌊(x − x0)/run⌋ + 1)` for x ≥ x0 and
    /// |y| ≤ width/2, 0 elsewhere.
    Stairs(StairsSpec),
    /// A step of `height` (negative for a drop) for x ≥ `x0` and y in `[y_min, y_max]`: a curb.
    Step {
        /// Where the step is, metres.
        x0: f64,
        /// Its height, metres.
        height_m: f64,
        /// The lowest y it spans, metres (−∞ for all).
        y_min: f64,
        /// The highest y it spans, metres (+∞ for all).
        y_max: f64,
    },
    /// A trench of `depth` below the surrounding ground for x in `[x0, x0 + width)` and y in
    /// `[y_min, y_max]`, with vertical walls: a negative obstacle.
    Trench {
        /// The near wall, metres.
        x0: f64,
        /// Its width along x, metres, > 0.
        width_m: f64,
        /// Its depth, metres, > 0.
        depth_m: f64,
        /// The lowest y it spans, metres (−∞ for all).
        y_min: f64,
        /// The highest y it spans, metres (+∞ for all).
        y_max: f64,
    },
    /// Terrain beyond the paper's scenes: camber, side slopes, platforms, ramps, roughness
    /// ([`super::terrain`]).
    Terrain(super::terrain::TerrainTerm),
}

impl GroundTerm {
    /// The term's height at `(x, y)`, metres.
    #[must_use]
    pub fn height(&self, x: f64, y: f64) -> f64 {
        match *self {
            Self::Slope { x0, angle_rad } => {
                if x > x0 {
                    (x - x0) * angle_rad.tan()
                } else {
                    0.0
                }
            }
            Self::Stairs(s) => {
                if x < s.first_riser_x || y.abs() > 0.5 * s.width_m {
                    0.0
                } else {
                    let k = ((x - s.first_riser_x) / s.run_m).floor() + 1.0;
                    k.min(f64::from(s.steps)) * s.rise_m
                }
            }
            Self::Step {
                x0,
                height_m,
                y_min,
                y_max,
            } => {
                if x >= x0 && (y_min..=y_max).contains(&y) {
                    height_m
                } else {
                    0.0
                }
            }
            Self::Trench {
                x0,
                width_m,
                depth_m,
                y_min,
                y_max,
            } => {
                if (x0..x0 + width_m).contains(&x) && (y_min..=y_max).contains(&y) {
                    -depth_m
                } else {
                    0.0
                }
            }
            Self::Terrain(t) => t.height(x, y),
        }
    }

    /// An upper bound of the term's height over the rectangle `[x_lo, x_hi] × [y_lo, y_hi]`.
    fn max_over(&self, x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64) -> f64 {
        match *self {
            // Monotone in x: the larger of the two ends.
            Self::Slope { .. } => self.height(x_lo, 0.0).max(self.height(x_hi, 0.0)),
            Self::Stairs(s) => {
                let half = 0.5 * s.width_m;
                if y_hi < -half || y_lo > half {
                    0.0
                } else {
                    self.height(x_hi, 0.0)
                }
            }
            Self::Step {
                x0,
                height_m,
                y_min,
                y_max,
            } => {
                if x_hi >= x0 && y_hi >= y_min && y_lo <= y_max {
                    height_m.max(0.0)
                } else {
                    0.0
                }
            }
            Self::Trench { .. } => 0.0,
            Self::Terrain(t) => t.max_over(x_lo, x_hi, y_lo, y_hi),
        }
    }
}

/// A solid primitive the laser sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// An axis-aligned box between two corners, metres.
    Box {
        /// The corner with the smallest coordinates.
        min: Vec3,
        /// The corner with the largest coordinates.
        max: Vec3,
    },
    /// A vertical cylinder (a post), metres.
    Cylinder {
        /// Its axis, (x, y).
        centre: [f64; 2],
        /// Its radius, > 0.
        radius_m: f64,
        /// Its bottom.
        z_min: f64,
        /// Its top.
        z_max: f64,
    },
}

/// Smallest distance along a ray that counts as a hit (not the ray's own origin), metres.
const T_EPSILON: f64 = 1e-9;

impl Solid {
    /// The distance along `ray` to the first hit with this solid in `(0, t_max]`, metres.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<f64> {
        match *self {
            Self::Box { min, max } => {
                let (mut t0, mut t1) = (T_EPSILON, t_max);
                for axis in 0..3 {
                    let (o, d) = (ray.origin[axis], ray.dir[axis]);
                    if d.abs() < 1e-15 {
                        if o < min[axis] || o > max[axis] {
                            return None;
                        }
                    } else {
                        let (a, b) = ((min[axis] - o) / d, (max[axis] - o) / d);
                        let (near, far) = if a < b { (a, b) } else { (b, a) };
                        t0 = t0.max(near);
                        t1 = t1.min(far);
                        if t0 > t1 {
                            return None;
                        }
                    }
                }
                Some(t0)
            }
            Self::Cylinder {
                centre,
                radius_m,
                z_min,
                z_max,
            } => {
                let r2 = radius_m * radius_m;
                let (ox, oy) = (ray.origin[0] - centre[0], ray.origin[1] - centre[1]);
                let (dx, dy) = (ray.dir[0], ray.dir[1]);
                let mut best: Option<f64> = None;
                let mut take = |t: f64| {
                    if t > T_EPSILON && t <= t_max && best.is_none_or(|b| t < b) {
                        best = Some(t);
                    }
                };
                // The side: |o + t·d − c|² = r² in the plane, with z within the post.
                let a = dx * dx + dy * dy;
                if a > 1e-15 {
                    let b = ox * dx + oy * dy;
                    let c = ox * ox + oy * oy - r2;
                    let disc = b * b - a * c;
                    if disc >= 0.0 {
                        let t = (-b - disc.sqrt()) / a;
                        let z = ray.origin[2] + t * ray.dir[2];
                        if (z_min..=z_max).contains(&z) {
                            take(t);
                        }
                    }
                }
                // The caps.
                if ray.dir[2].abs() > 1e-15 {
                    for z_cap in [z_min, z_max] {
                        let t = (z_cap - ray.origin[2]) / ray.dir[2];
                        let (px, py) = (ox + t * dx, oy + t * dy);
                        if px * px + py * py <= r2 {
                            take(t);
                        }
                    }
                }
                best
            }
        }
    }
}

/// What kind of obstacle a [`Feature`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FeatureKind {
    /// The edge of a stair step (a riser, or the side of the flight).
    StepEdge,
    /// A curb's edge.
    Curb,
    /// A post.
    Post,
    /// A bar overhead (a gate's).
    Bar,
    /// A ditch or trench (a negative obstacle).
    Ditch,
    /// An overhanging branch.
    Branch,
    /// A solid block standing on the ground: a wall, a parked car.
    Block,
}

/// Where a feature lies on the ground plane, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Footprint {
    /// The closed rectangle `[x_min, x_max] × [y_min, y_max]`; a zero width makes it a line
    /// (an edge). Infinite bounds are allowed.
    Rect {
        /// Smallest x.
        x_min: f64,
        /// Largest x.
        x_max: f64,
        /// Smallest y.
        y_min: f64,
        /// Largest y.
        y_max: f64,
    },
    /// A closed disc.
    Disc {
        /// Its centre, (x, y).
        centre: [f64; 2],
        /// Its radius, > 0.
        radius_m: f64,
    },
}

/// The truth about one obstacle: its footprint and vertical extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feature {
    /// What it is.
    pub kind: FeatureKind,
    /// Where it lies.
    pub footprint: Footprint,
    /// Height of its lowest part above the ground beside it, metres (0 for steps and posts,
    /// 2.0 for the gate's bar, negative for a ditch's floor).
    pub bottom_m: f64,
    /// Its vertical extent, metres (a step's rise, a ditch's depth, a post's height).
    pub height_m: f64,
}

/// The cells a map should mark as obstacles: the grid and the rule ([`Scene::obstacle_cells`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundTruthSpec {
    /// The cell size, metres, > 0; cell (i, j) is `[i·c, (i+1)·c) × [j·c, (j+1)·c)`, the
    /// pyramid's world indexing (`floor(x / c)`). Default 0.1 m (the default layer 0).
    pub cell_m: f64,
    /// The region of interest, metres: cells overlapping `[x_min, x_max] × [y_min, y_max]`.
    /// Default x ∈ [−1, 12], y ∈ [−4, 4].
    pub x_min: f64,
    /// See [`x_min`](Self::x_min).
    pub x_max: f64,
    /// See [`x_min`](Self::x_min).
    pub y_min: f64,
    /// See [`x_min`](Self::x_min).
    pub y_max: f64,
    /// Features whose lowest part is at or above this height over the ground are overhang
    /// the robot passes under, metres. Default 1.0 m (the classifier's default).
    pub robot_height_m: f64,
    /// Features whose vertical extent is at or below this are not obstacles, metres.
    /// Default 0.05 m (the classifier's step threshold).
    pub step_threshold_m: f64,
}

impl Default for GroundTruthSpec {
    fn default() -> Self {
        Self {
            cell_m: 0.1,
            x_min: -1.0,
            x_max: 12.0,
            y_min: -4.0,
            y_max: 4.0,
            robot_height_m: 1.0,
            step_threshold_m: 0.05,
        }
    }
}

/// One cell of the ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObstacleCell {
    /// World cell index along x: `floor(x / cell)`.
    pub ix: i32,
    /// World cell index along y: `floor(y / cell)`.
    pub iy: i32,
    /// The first feature (in the scene's order) that puts it here.
    pub kind: FeatureKind,
}

impl ObstacleCell {
    /// The cell's centre, metres, for a grid of `cell_m`.
    #[must_use]
    pub fn centre(&self, cell_m: f64) -> (f64, f64) {
        (
            (f64::from(self.ix) + 0.5) * cell_m,
            (f64::from(self.iy) + 0.5) * cell_m,
        )
    }
}

/// The scenarios, each with a default layout (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scenario {
    /// Flat ground.
    Flat,
    /// Stairs rising away from the robot (the paper's Figs 5-7).
    Stairs,
    /// A 10 cm curb.
    Curb,
    /// A gate: two posts and a bar overhead (the paper's Figs 8-9).
    Gate,
    /// A ditch: a negative obstacle.
    Ditch,
    /// An overhanging branch.
    Branch,
    /// Ground rising at 10°.
    Slope,
}

impl Scenario {
    /// Every scenario.
    pub const ALL: [Self; 7] = [
        Self::Flat,
        Self::Stairs,
        Self::Curb,
        Self::Gate,
        Self::Ditch,
        Self::Branch,
        Self::Slope,
    ];
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

const ALL_Y: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

impl Scene {
    /// Flat ground at z = 0, nothing else.
    #[must_use]
    pub fn flat() -> Self {
        Self {
            name: "flat",
            ground: Vec::new(),
            solids: Vec::new(),
            features: Vec::new(),
            target_x: None,
        }
    }

    /// The default scene of a scenario (layouts in the module documentation).
    #[must_use]
    pub fn scenario(scenario: Scenario) -> Self {
        match scenario {
            Scenario::Flat => Self::flat(),
            Scenario::Stairs => Self::stairs(StairsSpec::default()),
            Scenario::Curb => Self::curb(4.05, 0.10),
            Scenario::Gate => Self::gate(5.05, 1.5, 2.0),
            Scenario::Ditch => Self::ditch(4.05, 0.6, 0.5),
            Scenario::Branch => Self::branch(4.05, 1.0, 2.0, 1.6, 1.8),
            Scenario::Slope => Self::slope(3.05, 10.0),
        }
    }

    /// Stairs rising away from the robot; features: every riser across the flight's width and
    /// both sides of the flight (from the first riser on), as [`FeatureKind::StepEdge`] lines.
    #[must_use]
    pub fn stairs(spec: StairsSpec) -> Self {
        let half = 0.5 * spec.width_m;
        let mut features: Vec<Feature> = (0..spec.steps)
            .map(|i| Feature {
                kind: FeatureKind::StepEdge,
                footprint: Footprint::Rect {
                    x_min: spec.riser_x(i),
                    x_max: spec.riser_x(i),
                    y_min: -half,
                    y_max: half,
                },
                bottom_m: 0.0,
                height_m: spec.rise_m,
            })
            .collect();
        for y in [-half, half] {
            features.push(Feature {
                kind: FeatureKind::StepEdge,
                footprint: Footprint::Rect {
                    x_min: spec.first_riser_x,
                    x_max: f64::INFINITY,
                    y_min: y,
                    y_max: y,
                },
                bottom_m: 0.0,
                height_m: spec.rise_m,
            });
        }
        Self {
            name: "stairs",
            ground: vec![GroundTerm::Stairs(spec)],
            solids: Vec::new(),
            features,
            target_x: Some(spec.first_riser_x),
        }
    }

    /// A curb: the ground steps up by `height_m` at `x0`, across all y.
    #[must_use]
    pub fn curb(x0: f64, height_m: f64) -> Self {
        Self {
            name: "curb",
            ground: vec![GroundTerm::Step {
                x0,
                height_m,
                y_min: ALL_Y.0,
                y_max: ALL_Y.1,
            }],
            solids: Vec::new(),
            features: vec![Feature {
                kind: FeatureKind::Curb,
                footprint: Footprint::Rect {
                    x_min: x0,
                    x_max: x0,
                    y_min: ALL_Y.0,
                    y_max: ALL_Y.1,
                },
                bottom_m: 0.0,
                height_m: height_m.abs(),
            }],
            target_x: Some(x0),
        }
    }

    /// A gate at `x`: two posts (radius 0.06 m, from the ground up to the bar's top)
    /// `spacing_m` apart, centred on y = 0, and a 0.1 m × 0.1 m bar across them (to the posts'
    /// outer sides) whose underside is at `bar_m`. Features: the posts, and the bar (overhead:
    /// an obstacle only for a robot taller than `bar_m`).
    #[must_use]
    pub fn gate(x: f64, spacing_m: f64, bar_m: f64) -> Self {
        const RADIUS: f64 = 0.06;
        const BAR: f64 = 0.1;
        let half = 0.5 * spacing_m;
        let top = bar_m + BAR;
        let mut solids = Vec::new();
        let mut features = Vec::new();
        for y in [-half, half] {
            solids.push(Solid::Cylinder {
                centre: [x, y],
                radius_m: RADIUS,
                z_min: 0.0,
                z_max: top,
            });
            features.push(Feature {
                kind: FeatureKind::Post,
                footprint: Footprint::Disc {
                    centre: [x, y],
                    radius_m: RADIUS,
                },
                bottom_m: 0.0,
                height_m: top,
            });
        }
        let bar = (
            [x - 0.5 * BAR, -half - RADIUS, bar_m],
            [x + 0.5 * BAR, half + RADIUS, top],
        );
        solids.push(Solid::Box {
            min: bar.0,
            max: bar.1,
        });
        features.push(Feature {
            kind: FeatureKind::Bar,
            footprint: Footprint::Rect {
                x_min: bar.0[0],
                x_max: bar.1[0],
                y_min: bar.0[1],
                y_max: bar.1[1],
            },
            bottom_m: bar_m,
            height_m: BAR,
        });
        Self {
            name: "gate",
            ground: Vec::new(),
            solids,
            features,
            target_x: Some(x),
        }
    }

    /// A room to turn in: four walls 2 m high and 0.2 m thick, their inner faces
    /// `half_x_m` and `half_y_m` from the origin, and two pillars (0.6 m boxes, 1.5 m high) at
    /// (0.5 · `half_x_m`, 0.4 · `half_y_m`) and (−0.4 · `half_x_m`, −0.5 · `half_y_m`), so that
    /// no two headings see the same thing. Features: every solid, as [`FeatureKind::Block`].
    #[must_use]
    pub fn room(half_x_m: f64, half_y_m: f64) -> Self {
        const THICK: f64 = 0.2;
        const WALL: f64 = 2.0;
        const PILLAR: f64 = 0.6;
        const PILLAR_H: f64 = 1.5;
        let (ox, oy) = (half_x_m + THICK, half_y_m + THICK);
        let mut boxes = vec![
            ([half_x_m, -oy, 0.0], [ox, oy, WALL]),
            ([-ox, -oy, 0.0], [-half_x_m, oy, WALL]),
            ([-half_x_m, half_y_m, 0.0], [half_x_m, oy, WALL]),
            ([-half_x_m, -oy, 0.0], [half_x_m, -half_y_m, WALL]),
        ];
        for (cx, cy) in [
            (0.5 * half_x_m, 0.4 * half_y_m),
            (-0.4 * half_x_m, -0.5 * half_y_m),
        ] {
            let h = 0.5 * PILLAR;
            boxes.push(([cx - h, cy - h, 0.0], [cx + h, cy + h, PILLAR_H]));
        }
        let solids = boxes
            .iter()
            .map(|&(min, max)| Solid::Box { min, max })
            .collect();
        let features = boxes
            .iter()
            .map(|&(min, max)| Feature {
                kind: FeatureKind::Block,
                footprint: Footprint::Rect {
                    x_min: min[0],
                    x_max: max[0],
                    y_min: min[1],
                    y_max: max[1],
                },
                bottom_m: 0.0,
                height_m: max[2],
            })
            .collect();
        Self {
            name: "room",
            ground: Vec::new(),
            solids,
            features,
            target_x: None,
        }
    }

    /// A ditch: a trench `depth_m` deep from `x0` to `x0 + width_m`, across all y.
    #[must_use]
    pub fn ditch(x0: f64, width_m: f64, depth_m: f64) -> Self {
        Self {
            name: "ditch",
            ground: vec![GroundTerm::Trench {
                x0,
                width_m,
                depth_m,
                y_min: ALL_Y.0,
                y_max: ALL_Y.1,
            }],
            solids: Vec::new(),
            features: vec![Feature {
                kind: FeatureKind::Ditch,
                footprint: Footprint::Rect {
                    x_min: x0,
                    x_max: x0 + width_m,
                    y_min: ALL_Y.0,
                    y_max: ALL_Y.1,
                },
                bottom_m: -depth_m,
                height_m: depth_m,
            }],
            target_x: Some(x0),
        }
    }

    /// An overhanging branch: a box from `x0` to `x0 + length_m`, `width_m` wide centred on
    /// y = 0, between heights `z_min` and `z_max` (no trunk).
    #[must_use]
    pub fn branch(x0: f64, length_m: f64, width_m: f64, z_min: f64, z_max: f64) -> Self {
        let (min, max) = (
            [x0, -0.5 * width_m, z_min],
            [x0 + length_m, 0.5 * width_m, z_max],
        );
        Self {
            name: "branch",
            ground: Vec::new(),
            solids: vec![Solid::Box { min, max }],
            features: vec![Feature {
                kind: FeatureKind::Branch,
                footprint: Footprint::Rect {
                    x_min: min[0],
                    x_max: max[0],
                    y_min: min[1],
                    y_max: max[1],
                },
                bottom_m: z_min,
                height_m: z_max - z_min,
            }],
            target_x: Some(x0),
        }
    }

    /// Ground rising at `angle_deg` from `x0` on (no obstacle features: a 10° slope is
    /// navigable).
    #[must_use]
    pub fn slope(x0: f64, angle_deg: f64) -> Self {
        Self {
            name: "slope",
            ground: vec![GroundTerm::Slope {
                x0,
                angle_rad: angle_deg.to_radians(),
            }],
            solids: Vec::new(),
            features: Vec::new(),
            target_x: Some(x0),
        }
    }

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

    /// The ground truth: every cell of `spec`'s grid, within its region, that holds an
    /// obstacle feature lower than the robot (`bottom < robot_height`) and taller than the
    /// step threshold, sorted by (ix, iy), one entry per cell. A cell holds a feature when
    /// the half-open cell and the closed footprint share a point (an edge on a cell boundary
    /// belongs to the cell on its +x / +y side).
    #[must_use]
    pub fn obstacle_cells(&self, spec: &GroundTruthSpec) -> Vec<ObstacleCell> {
        let c = spec.cell_m;
        let index = |v: f64| -> i32 {
            // Saturating: the region bounds every feature below.
            #[allow(clippy::cast_possible_truncation)]
            let i = (v / c).floor() as i32;
            i
        };
        let (rx0, rx1, ry0, ry1) = (
            index(spec.x_min),
            index(spec.x_max),
            index(spec.y_min),
            index(spec.y_max),
        );
        let mut cells: Vec<ObstacleCell> = Vec::new();
        for f in &self.features {
            if f.bottom_m >= spec.robot_height_m || f.height_m <= spec.step_threshold_m {
                continue;
            }
            match f.footprint {
                Footprint::Rect {
                    x_min,
                    x_max,
                    y_min,
                    y_max,
                } => {
                    let (i0, i1) = (index(x_min.max(spec.x_min)), index(x_max.min(spec.x_max)));
                    let (j0, j1) = (index(y_min.max(spec.y_min)), index(y_max.min(spec.y_max)));
                    for ix in i0.max(rx0)..=i1.min(rx1) {
                        for iy in j0.max(ry0)..=j1.min(ry1) {
                            cells.push(ObstacleCell {
                                ix,
                                iy,
                                kind: f.kind,
                            });
                        }
                    }
                }
                Footprint::Disc { centre, radius_m } => {
                    let (i0, i1) = (index(centre[0] - radius_m), index(centre[0] + radius_m));
                    let (j0, j1) = (index(centre[1] - radius_m), index(centre[1] + radius_m));
                    for ix in i0.max(rx0)..=i1.min(rx1) {
                        for iy in j0.max(ry0)..=j1.min(ry1) {
                            // The point of the cell nearest the centre.
                            let nx = centre[0].clamp(f64::from(ix) * c, f64::from(ix + 1) * c);
                            let ny = centre[1].clamp(f64::from(iy) * c, f64::from(iy + 1) * c);
                            if (nx - centre[0]).hypot(ny - centre[1]) <= radius_m {
                                cells.push(ObstacleCell {
                                    ix,
                                    iy,
                                    kind: f.kind,
                                });
                            }
                        }
                    }
                }
            }
        }
        // One entry per cell, the first feature's kind (a stable sort keeps the scene's order).
        cells.sort_by_key(|cell| (cell.ix, cell.iy));
        cells.dedup_by_key(|cell| (cell.ix, cell.iy));
        cells
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let up = Ray {
            origin: [0.0, 0.0, 1.0],
            dir: [1.0, 0.0, 0.0],
        };
        assert_eq!(scene.cast(&up, 80.0), None);
    }

    #[test]
    fn a_riser_is_hit_on_its_face() {
        let scene = Scene::scenario(Scenario::Stairs);
        // Horizontal ray at 0.1 m: hits the first riser's face at x = 5.05.
        let ray = Ray {
            origin: [0.0, 0.0, 0.1],
            dir: [1.0, 0.0, 0.0],
        };
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[0] - 5.05).abs() < 1e-9, "{:?}", hit);
        // At 0.3 m: the second riser (steps at 0.17, 0.34).
        let ray = Ray {
            origin: [0.0, 0.0, 0.3],
            dir: [1.0, 0.0, 0.0],
        };
        let hit = scene.cast(&ray, 20.0).unwrap();
        assert!((hit.point[0] - 5.35).abs() < 1e-9, "{:?}", hit);
        // Beside the flight: nothing.
        let ray = Ray {
            origin: [0.0, 2.0, 0.3],
            dir: [1.0, 0.0, 0.0],
        };
        assert_eq!(scene.cast(&ray, 20.0), None);
    }

    #[test]
    fn posts_and_bars_are_hit() {
        let scene = Scene::scenario(Scenario::Gate);
        let ray = Ray {
            origin: [0.0, 0.75, 1.0],
            dir: [1.0, 0.0, 0.0],
        };
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
        let ray = Ray {
            origin: [0.0, 0.0, 1.0],
            dir: [1.0, 0.0, 0.0],
        };
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
