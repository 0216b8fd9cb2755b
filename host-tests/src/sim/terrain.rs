//! Terrain for the navigability rules: slopes, road camber, grass-like roughness, gravel,
//! curbs of several heights with kerb cuts, ramps, stairs across y, and the ground truth of
//! every cell of any grid (navigable, obstacle, the step height, the slope).
//!
//! # The terms ([`TerrainTerm`], a [`GroundTerm::Terrain`] of a scene's ground)
//! | term | height |
//! | --- | --- |
//! | [`TerrainTerm::Camber`] | a crowned road: `−grade·min(\|y − y_c\|, half_width)` |
//! | [`TerrainTerm::SideSlope`] | `grade·max(0, dir·(y − y0))`: ground rising (or falling) away from a line along x |
//! | [`TerrainTerm::Platform`] | `height` on a closed rectangle, 0 elsewhere: a sidewalk, a curb, a stair tread, a step |
//! | [`TerrainTerm::Ramp`] | on a rectangle, rising linearly from 0 on one side to `height` on the opposite side: a kerb cut, a driveway, a hill |
//! | [`TerrainTerm::Rough`] | smooth value noise of amplitude `a` and wavelength λ on a rectangle, tapered to 0 over λ at its border: grass (±2.5 cm, λ 0.12 m), gravel (±1.2 cm, λ 0.04 m) |
//! | [`TerrainTerm::Swell`] | smooth value noise everywhere, long wavelength: the unevenness of a street (±5 cm over 3 m) |
//!
//! Every term but the platform (and a ramp's sides) is continuous; the ray cast handles both
//! (it marches 1 cm and bisects, [`super::scene`]).
//!
//! # Ground truth ([`cell_truth`])
//! Per cell of side c: the **step** is the tallest [`Feature`] whose footprint meets the cell
//! (and whose bottom is below the robot's height): curbs, risers, kerb-cut sides, trench walls,
//! posts, blocks; the **slope** is the steepest *macro* slope of the ground within the cell
//! (the existing forward [`GroundTerm::Slope`], camber, side slopes and ramps; roughness is
//! texture, not slope), sampled on a 5 × 5 lattice over the cell. [`Truth`] says what a cell
//! is for a robot that climbs steps lower than 5 cm and slopes up to
//! [`TRUTH_MAX_SLOPE_DEG`]: navigable (no feature at all, slope within the limit), obstacle
//! (a feature of at least [`TRUTH_OBSTACLE_STEP_M`], or a slope beyond the limit), or neither
//! (a feature between 0 and 8 cm: the band where the step threshold is a choice).

use super::scene::{Feature, FeatureKind, Footprint, GroundTerm, Scene, Solid};

/// The steepest slope the truth calls navigable, degrees.
pub const TRUTH_MAX_SLOPE_DEG: f64 = 20.0;

/// Features at least this tall are obstacles in the truth, metres (steps of 8 cm and more:
/// curbs, stairs, drop-offs).
pub const TRUTH_OBSTACLE_STEP_M: f64 = 0.08;

/// Which way a ramp rises across its rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rise {
    /// From 0 at `x_min` to the height at `x_max`.
    PlusX,
    /// From 0 at `x_max` to the height at `x_min`.
    MinusX,
    /// From 0 at `y_min` to the height at `y_max`.
    PlusY,
    /// From 0 at `y_max` to the height at `y_min`.
    MinusY,
}

/// A closed rectangle on the ground plane, metres (infinite bounds allowed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Smallest x.
    pub x_min: f64,
    /// Largest x.
    pub x_max: f64,
    /// Smallest y.
    pub y_min: f64,
    /// Largest y.
    pub y_max: f64,
}

impl Rect {
    /// The rectangle `[x_min, x_max] × [y_min, y_max]`.
    #[must_use]
    pub const fn new(x_min: f64, x_max: f64, y_min: f64, y_max: f64) -> Self {
        Self {
            x_min,
            x_max,
            y_min,
            y_max,
        }
    }

    /// Whether `(x, y)` lies in it (closed).
    #[must_use]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        (self.x_min..=self.x_max).contains(&x) && (self.y_min..=self.y_max).contains(&y)
    }

    /// Whether it meets the rectangle `[x_lo, x_hi] × [y_lo, y_hi]`.
    #[must_use]
    pub fn meets(&self, x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64) -> bool {
        x_hi >= self.x_min && x_lo <= self.x_max && y_hi >= self.y_min && y_lo <= self.y_max
    }

    /// The distance from `(x, y)` inside it to its nearest side, metres (0 outside).
    fn inset(&self, x: f64, y: f64) -> f64 {
        if !self.contains(x, y) {
            return 0.0;
        }
        (x - self.x_min)
            .min(self.x_max - x)
            .min(y - self.y_min)
            .min(self.y_max - y)
    }
}

/// One additive term of the ground beyond the paper's scenes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TerrainTerm {
    /// A crowned road: `−grade·min(|y − y_centre|, half_width)` (a grade of 0.025 is a 2.5 %
    /// camber).
    Camber {
        /// The crown, metres.
        y_centre: f64,
        /// The half width of the road, metres; beyond it the term stays at its edge value.
        half_width: f64,
        /// The fall per metre across the road.
        grade: f64,
    },
    /// Ground rising away from the line `y = y0`: `grade·max(0, dir·(y − y0))` with
    /// `dir = ±1`; a negative grade falls.
    SideSlope {
        /// Where it starts, metres.
        y0: f64,
        /// Rise per metre.
        grade: f64,
        /// +1: for y > y0; −1: for y < y0.
        dir: f64,
    },
    /// `height` on a closed rectangle (negative for a pit).
    Platform {
        /// Where.
        rect: Rect,
        /// Metres.
        height: f64,
    },
    /// A ramp on a closed rectangle rising from 0 to `height` the way `rise` says; 0 outside.
    Ramp {
        /// Where.
        rect: Rect,
        /// The height at the high side, metres.
        height: f64,
        /// Which way it rises.
        rise: Rise,
    },
    /// Smooth value noise: values uniform in `[−amplitude, amplitude]` on a square lattice of
    /// `wavelength`, interpolated with smoothstep weights, on a rectangle, tapered linearly to 0
    /// within one wavelength of its border (so the term is continuous).
    Rough {
        /// Where.
        rect: Rect,
        /// The largest deviation, metres.
        amplitude: f64,
        /// The lattice spacing, metres, > 0.
        wavelength: f64,
        /// The lattice's seed.
        seed: u64,
    },
    /// A gentle swell of the whole ground (a street is not a plane): smooth value noise of
    /// `amplitude` on a lattice of `wavelength` (metres), everywhere. Counted as macro slope.
    Swell {
        /// The largest deviation, metres.
        amplitude: f64,
        /// The lattice spacing, metres, > 0.
        wavelength: f64,
        /// The lattice's seed.
        seed: u64,
    },
}

/// A value in `[−1, 1]` for lattice node `(i, j)` of generator `seed` (SplitMix64 of the
/// packed key).
fn lattice(seed: u64, i: i64, j: i64) -> f64 {
    #[allow(clippy::cast_sign_loss)]
    let key = seed
        ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    let mut z = key.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    #[allow(clippy::cast_precision_loss)]
    let u = (z >> 11) as f64 / 9_007_199_254_740_992.0;
    2.0 * u - 1.0
}

/// Smooth value noise in `[−1, 1]` at `(u, v)` lattice units.
fn value_noise(seed: u64, u: f64, v: f64) -> f64 {
    let (fu, fv) = (u.floor(), v.floor());
    #[allow(clippy::cast_possible_truncation)]
    let (i, j) = (fu as i64, fv as i64);
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (a, b) = (s(u - fu), s(v - fv));
    let n00 = lattice(seed, i, j);
    let n10 = lattice(seed, i + 1, j);
    let n01 = lattice(seed, i, j + 1);
    let n11 = lattice(seed, i + 1, j + 1);
    let top = n00 + a * (n10 - n00);
    let bottom = n01 + a * (n11 - n01);
    top + b * (bottom - top)
}

impl TerrainTerm {
    /// The term's height at `(x, y)`, metres.
    #[must_use]
    pub fn height(&self, x: f64, y: f64) -> f64 {
        match *self {
            Self::Camber {
                y_centre,
                half_width,
                grade,
            } => -grade * (y - y_centre).abs().min(half_width),
            Self::SideSlope { y0, grade, dir } => grade * (dir * (y - y0)).max(0.0),
            Self::Platform { rect, height } => {
                if rect.contains(x, y) {
                    height
                } else {
                    0.0
                }
            }
            Self::Ramp { rect, height, rise } => {
                if !rect.contains(x, y) {
                    return 0.0;
                }
                let t = match rise {
                    Rise::PlusX => (x - rect.x_min) / (rect.x_max - rect.x_min),
                    Rise::MinusX => (rect.x_max - x) / (rect.x_max - rect.x_min),
                    Rise::PlusY => (y - rect.y_min) / (rect.y_max - rect.y_min),
                    Rise::MinusY => (rect.y_max - y) / (rect.y_max - rect.y_min),
                };
                height * t.clamp(0.0, 1.0)
            }
            Self::Rough {
                rect,
                amplitude,
                wavelength,
                seed,
            } => {
                let taper = (rect.inset(x, y) / wavelength).min(1.0);
                if taper <= 0.0 {
                    return 0.0;
                }
                amplitude * taper * value_noise(seed, x / wavelength, y / wavelength)
            }
            Self::Swell {
                amplitude,
                wavelength,
                seed,
            } => amplitude * value_noise(seed, x / wavelength, y / wavelength),
        }
    }

    /// An upper bound of the term over `[x_lo, x_hi] × [y_lo, y_hi]`.
    #[must_use]
    pub fn max_over(&self, x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64) -> f64 {
        match *self {
            Self::Camber {
                y_centre,
                half_width,
                grade,
            } => {
                // The least distance from the crown over [y_lo, y_hi].
                let nearest = if (y_lo..=y_hi).contains(&y_centre) {
                    0.0
                } else {
                    (y_lo - y_centre).abs().min((y_hi - y_centre).abs())
                };
                if grade >= 0.0 {
                    -grade * nearest.min(half_width)
                } else {
                    -grade * half_width
                }
            }
            Self::SideSlope { .. } => self.height(0.0, y_lo).max(self.height(0.0, y_hi)),
            Self::Platform { rect, height } => {
                if rect.meets(x_lo, x_hi, y_lo, y_hi) {
                    height.max(0.0)
                } else {
                    0.0
                }
            }
            Self::Ramp { rect, height, .. } => {
                if rect.meets(x_lo, x_hi, y_lo, y_hi) {
                    height.max(0.0)
                } else {
                    0.0
                }
            }
            Self::Rough {
                rect, amplitude, ..
            } => {
                if rect.meets(x_lo, x_hi, y_lo, y_hi) {
                    amplitude.abs()
                } else {
                    0.0
                }
            }
            Self::Swell { amplitude, .. } => amplitude.abs(),
        }
    }

    /// The term's macro gradient `(∂z/∂x, ∂z/∂y)` at `(x, y)` (0 for roughness: texture, not
    /// slope; 0 on a platform).
    #[must_use]
    pub fn gradient(&self, x: f64, y: f64) -> (f64, f64) {
        match *self {
            Self::Camber {
                y_centre,
                half_width,
                grade,
            } => {
                let dy = y - y_centre;
                if dy.abs() < half_width {
                    (0.0, -grade * dy.signum())
                } else {
                    (0.0, 0.0)
                }
            }
            Self::SideSlope { y0, grade, dir } => {
                if dir * (y - y0) > 0.0 {
                    (0.0, grade * dir)
                } else {
                    (0.0, 0.0)
                }
            }
            Self::Platform { .. } | Self::Rough { .. } => (0.0, 0.0),
            Self::Swell { .. } => {
                const H: f64 = 1e-4;
                (
                    (self.height(x + H, y) - self.height(x - H, y)) / (2.0 * H),
                    (self.height(x, y + H) - self.height(x, y - H)) / (2.0 * H),
                )
            }
            Self::Ramp { rect, height, rise } => {
                if !rect.contains(x, y) {
                    return (0.0, 0.0);
                }
                let (w, d) = (rect.x_max - rect.x_min, rect.y_max - rect.y_min);
                match rise {
                    Rise::PlusX => (height / w, 0.0),
                    Rise::MinusX => (-height / w, 0.0),
                    Rise::PlusY => (0.0, height / d),
                    Rise::MinusY => (0.0, -height / d),
                }
            }
        }
    }
}

/// The macro gradient of a scene's ground at `(x, y)`: the forward slopes and the terrain
/// terms (stairs, steps and trenches are flat between their edges; roughness is texture).
#[must_use]
pub fn macro_gradient(scene: &Scene, x: f64, y: f64) -> (f64, f64) {
    scene.ground.iter().fold((0.0, 0.0), |(gx, gy), term| {
        let (dx, dy) = match *term {
            GroundTerm::Slope { x0, angle_rad } if x > x0 => (angle_rad.tan(), 0.0),
            GroundTerm::Terrain(t) => t.gradient(x, y),
            _ => (0.0, 0.0),
        };
        (gx + dx, gy + dy)
    })
}

/// What a cell of a grid is, for the rules' evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellTruth {
    /// The tallest obstacle feature meeting the cell (below the robot's height), metres; 0
    /// when none.
    pub step_m: f64,
    /// The kind of that feature.
    pub kind: Option<FeatureKind>,
    /// The steepest macro slope in the cell, degrees.
    pub slope_deg: f64,
}

/// The truth's verdict on a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Truth {
    /// No feature, slope within [`TRUTH_MAX_SLOPE_DEG`].
    Navigable,
    /// A feature of at least [`TRUTH_OBSTACLE_STEP_M`], or a slope beyond the limit.
    Obstacle,
    /// A feature lower than [`TRUTH_OBSTACLE_STEP_M`]: neither counted as navigable nor as
    /// an obstacle.
    Between,
}

impl CellTruth {
    /// The verdict.
    #[must_use]
    pub fn truth(&self) -> Truth {
        if self.step_m >= TRUTH_OBSTACLE_STEP_M || self.slope_deg > TRUTH_MAX_SLOPE_DEG + 1e-9 {
            Truth::Obstacle
        } else if self.step_m > 0.0 {
            Truth::Between
        } else {
            Truth::Navigable
        }
    }
}

/// Whether a feature's footprint meets the half-open cell `[x0, x0+c) × [y0, y0+c)`
/// (as [`Scene::obstacle_cells`] decides: a closed footprint against the half-open cell).
fn meets(footprint: &Footprint, x0: f64, y0: f64, c: f64) -> bool {
    match *footprint {
        Footprint::Rect {
            x_min,
            x_max,
            y_min,
            y_max,
        } => x_max >= x0 && x_min < x0 + c && y_max >= y0 && y_min < y0 + c,
        Footprint::Disc { centre, radius_m } => {
            let nx = centre[0].clamp(x0, x0 + c);
            let ny = centre[1].clamp(y0, y0 + c);
            (nx - centre[0]).hypot(ny - centre[1]) <= radius_m
        }
    }
}

/// Whether no obstacle feature (below the robot's height) meets the closed rectangle.
#[must_use]
pub fn clear_of_features(scene: &Scene, rect: &Rect, robot_height_m: f64) -> bool {
    scene.features.iter().all(|f| {
        if f.bottom_m >= robot_height_m || f.height_m <= 0.0 {
            return true;
        }
        match f.footprint {
            Footprint::Rect {
                x_min,
                x_max,
                y_min,
                y_max,
            } => !Rect::new(x_min, x_max, y_min, y_max)
                .meets(rect.x_min, rect.x_max, rect.y_min, rect.y_max),
            Footprint::Disc { centre, radius_m } => {
                let nx = centre[0].clamp(rect.x_min, rect.x_max);
                let ny = centre[1].clamp(rect.y_min, rect.y_max);
                (nx - centre[0]).hypot(ny - centre[1]) > radius_m
            }
        }
    })
}

/// The truth of cell `(ix, iy)` of a grid of `cell_m` for a robot of `robot_height_m`.
#[must_use]
pub fn cell_truth(scene: &Scene, cell_m: f64, ix: i64, iy: i64, robot_height_m: f64) -> CellTruth {
    #[allow(clippy::cast_precision_loss)]
    let (x0, y0) = (ix as f64 * cell_m, iy as f64 * cell_m);
    let mut step_m = 0.0;
    let mut kind = None;
    for f in &scene.features {
        if f.bottom_m >= robot_height_m || f.height_m <= 0.0 {
            continue;
        }
        if meets(&f.footprint, x0, y0, cell_m) && f.height_m > step_m {
            step_m = f.height_m;
            kind = Some(f.kind);
        }
    }
    let mut slope: f64 = 0.0;
    for a in 0..5 {
        for b in 0..5 {
            let x = x0 + cell_m * (0.1 + 0.2 * f64::from(a));
            let y = y0 + cell_m * (0.1 + 0.2 * f64::from(b));
            let (gx, gy) = macro_gradient(scene, x, y);
            slope = slope.max(gx.hypot(gy));
        }
    }
    CellTruth {
        step_m,
        kind,
        slope_deg: slope.atan().to_degrees(),
    }
}

/// A feature along the segment from `(x0, y0)` to `(x1, y1)` (an axis-parallel line).
fn edge(kind: FeatureKind, x0: f64, x1: f64, y0: f64, y1: f64, height_m: f64) -> Feature {
    Feature {
        kind,
        footprint: Footprint::Rect {
            x_min: x0.min(x1),
            x_max: x0.max(x1),
            y_min: y0.min(y1),
            y_max: y0.max(y1),
        },
        bottom_m: 0.0,
        height_m,
    }
}

/// The sides of a ramp as features of 0.05 m segments along it, where the ramp has risen by
/// `t·height`: cut into a platform of `height` (a kerb cut, `into_platform`) the step beside
/// it is `height·(1 − t)`; standing on level ground (a hill) it is `height·t`. Each segment
/// carries its tallest value.
fn ramp_sides(
    rect: Rect,
    height: f64,
    rise: Rise,
    kind: FeatureKind,
    into_platform: bool,
) -> Vec<Feature> {
    let mut out = Vec::new();
    let (along, lo, hi) = match rise {
        Rise::PlusY | Rise::MinusY => (true, rect.y_min, rect.y_max),
        Rise::PlusX | Rise::MinusX => (false, rect.x_min, rect.x_max),
    };
    let n = ((hi - lo) / 0.05).ceil().max(1.0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let segments = n as usize;
    for s in 0..segments {
        #[allow(clippy::cast_precision_loss)]
        let (a, b) = (
            lo + (hi - lo) * s as f64 / n,
            lo + (hi - lo) * (s + 1) as f64 / n,
        );
        // The ramp's height fractions at the segment's ends.
        let (ta, tb) = match rise {
            Rise::PlusX | Rise::PlusY => ((a - lo) / (hi - lo), (b - lo) / (hi - lo)),
            Rise::MinusX | Rise::MinusY => ((hi - a) / (hi - lo), (hi - b) / (hi - lo)),
        };
        let side = if into_platform {
            height.abs() * (1.0 - ta.min(tb))
        } else {
            height.abs() * ta.max(tb)
        };
        if side <= 1e-9 {
            continue;
        }
        if along {
            out.push(edge(kind, rect.x_min, rect.x_min, a, b, side));
            out.push(edge(kind, rect.x_max, rect.x_max, a, b, side));
        } else {
            out.push(edge(kind, a, b, rect.y_min, rect.y_min, side));
            out.push(edge(kind, a, b, rect.y_max, rect.y_max, side));
        }
    }
    out
}

/// The four edges of a platform of `height` on `rect` (finite sides only).
fn platform_edges(rect: Rect, height: f64, kind: FeatureKind) -> Vec<Feature> {
    let h = height.abs();
    let mut out = Vec::new();
    if rect.x_min.is_finite() {
        out.push(edge(
            kind, rect.x_min, rect.x_min, rect.y_min, rect.y_max, h,
        ));
    }
    if rect.x_max.is_finite() {
        out.push(edge(
            kind, rect.x_max, rect.x_max, rect.y_min, rect.y_max, h,
        ));
    }
    if rect.y_min.is_finite() {
        out.push(edge(
            kind, rect.x_min, rect.x_max, rect.y_min, rect.y_min, h,
        ));
    }
    if rect.y_max.is_finite() {
        out.push(edge(
            kind, rect.x_min, rect.x_max, rect.y_max, rect.y_max, h,
        ));
    }
    out
}

/// A box standing on the ground (a wall, a parked car) as a solid and its feature.
fn block(min: [f64; 3], max: [f64; 3]) -> (Solid, Feature) {
    (
        Solid::Box { min, max },
        Feature {
            kind: FeatureKind::Block,
            footprint: Footprint::Rect {
                x_min: min[0],
                x_max: max[0],
                y_min: min[1],
                y_max: max[1],
            },
            bottom_m: 0.0,
            height_m: max[2] - min[2],
        },
    )
}

/// A pole of radius 0.05 m and 2.5 m standing at `(x, y)` on ground at `z0`.
fn pole(x: f64, y: f64, z0: f64) -> (Solid, Feature) {
    (
        Solid::Cylinder {
            centre: [x, y],
            radius_m: 0.05,
            z_min: z0 - 0.2,
            z_max: z0 + 2.5,
        },
        Feature {
            kind: FeatureKind::Post,
            footprint: Footprint::Disc {
                centre: [x, y],
                radius_m: 0.05,
            },
            bottom_m: 0.0,
            height_m: 2.5,
        },
    )
}

/// The heights of the step gallery ([`Scene::step_gallery`]), metres.
pub const GALLERY_STEPS_M: [f64; 8] = [0.03, 0.05, 0.06, 0.08, 0.10, 0.12, 0.15, 0.20];

impl Scene {
    /// A street for the car laser and the paper's robot, driven along +x at y = 0:
    /// - a road `|y| ≤ 3.5 m` crowned with a 2.5 % camber;
    /// - on the left (y > 3.5) a 15 cm curb and a sidewalk to y = 6 rising 2 % away from the
    ///   road, with a kerb cut at x ∈ [4, 5.5] (a 1.2 m ramp, 7°); beyond it gravel
    ///   (±1.2 cm, λ 0.04 m) for x < 3, stairs of four 16 cm risers every 0.3 m from y = 7
    ///   for x ∈ [6, 10], and a 15° ramp up 0.54 m from y = 6 to y = 8 for x ∈ [12, 18];
    /// - on the right (y < −3.5) a 10 cm curb and a sidewalk to y = −6, level; beyond it
    ///   grass (±2.5 cm, λ 0.12 m) for x < 5, a 10° slope away from the road (falling) for
    ///   x ∈ [5, 20], a 0.3 m deep ditch at y ∈ [−13, −12.4] for x < 5;
    /// - a parked car (a 4.5 × 1.8 × 1.4 m box) at x ∈ [8, 12.5], y ∈ [1.4, 3.2]; poles at
    ///   (2, 5.0) and (9, −5.0); a facade (a wall 3 m tall) at y ≥ 14;
    /// - everywhere, a swell of ±`swell_m` on a 3 m lattice (0 for none).
    #[must_use]
    #[allow(clippy::too_many_lines)]
    pub fn street(swell_m: f64) -> Self {
        const ROAD: f64 = 3.5;
        const LEFT_CURB: f64 = 0.15;
        const RIGHT_CURB: f64 = 0.10;
        const CAMBER: f64 = 0.025;
        let edge_z = -CAMBER * ROAD;
        let inf = f64::INFINITY;
        let cut = (4.0, 5.5);
        let mut ground = vec![GroundTerm::Terrain(TerrainTerm::Camber {
            y_centre: 0.0,
            half_width: ROAD,
            grade: CAMBER,
        })];
        if swell_m != 0.0 {
            ground.push(GroundTerm::Terrain(TerrainTerm::Swell {
                amplitude: swell_m,
                wavelength: 3.0,
                seed: 17,
            }));
        }
        let mut features = Vec::new();
        let mut solids = Vec::new();
        // Left sidewalk (and everything beyond it) at the curb's height, but for the kerb cut.
        for rect in [
            Rect::new(-inf, cut.0, ROAD, inf),
            Rect::new(cut.1, inf, ROAD, inf),
            Rect::new(cut.0, cut.1, ROAD + 1.2, inf),
        ] {
            ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                rect,
                height: LEFT_CURB,
            }));
        }
        let kerb_cut = Rect::new(cut.0, cut.1, ROAD, ROAD + 1.2);
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: kerb_cut,
            height: LEFT_CURB,
            rise: Rise::PlusY,
        }));
        features.push(edge(FeatureKind::Curb, -inf, cut.0, ROAD, ROAD, LEFT_CURB));
        features.push(edge(FeatureKind::Curb, cut.1, inf, ROAD, ROAD, LEFT_CURB));
        features.extend(ramp_sides(
            kerb_cut,
            LEFT_CURB,
            Rise::PlusY,
            FeatureKind::Curb,
            true,
        ));
        ground.push(GroundTerm::Terrain(TerrainTerm::SideSlope {
            y0: ROAD,
            grade: 0.02,
            dir: 1.0,
        }));
        // Gravel beyond the left sidewalk.
        ground.push(GroundTerm::Terrain(TerrainTerm::Rough {
            rect: Rect::new(-20.0, 3.0, 6.0, 13.0),
            amplitude: 0.012,
            wavelength: 0.04,
            seed: 11,
        }));
        // Stairs across y on the left.
        for i in 0..4 {
            let y = 7.0 + 0.3 * f64::from(i);
            let rect = Rect::new(6.0, 10.0, y, inf);
            ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                rect,
                height: 0.16,
            }));
            features.push(edge(FeatureKind::StepEdge, 6.0, 10.0, y, y, 0.16));
            features.push(edge(FeatureKind::StepEdge, 6.0, 6.0, y, inf, 0.16));
            features.push(edge(FeatureKind::StepEdge, 10.0, 10.0, y, inf, 0.16));
        }
        // A 15° ramp up from y = 6 to y = 8, then a plateau, for x ∈ [12, 18].
        let hill = Rect::new(12.0, 18.0, 6.0, 8.0);
        let hill_rise = 2.0 * 15f64.to_radians().tan();
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: hill,
            height: hill_rise,
            rise: Rise::PlusY,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(12.0, 18.0, 8.0 + 1e-9, inf),
            height: hill_rise,
        }));
        features.extend(ramp_sides(
            hill,
            hill_rise,
            Rise::PlusY,
            FeatureKind::Curb,
            false,
        ));
        features.push(edge(FeatureKind::Curb, 12.0, 12.0, 8.0, inf, hill_rise));
        features.push(edge(FeatureKind::Curb, 18.0, 18.0, 8.0, inf, hill_rise));
        // Right: a curb, a level sidewalk, then grass, a falling 10° slope and a ditch.
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(-inf, inf, -inf, -ROAD),
            height: RIGHT_CURB,
        }));
        features.push(edge(FeatureKind::Curb, -inf, inf, -ROAD, -ROAD, RIGHT_CURB));
        ground.push(GroundTerm::Terrain(TerrainTerm::Rough {
            rect: Rect::new(-20.0, 5.0, -20.0, -6.0),
            amplitude: 0.025,
            wavelength: 0.12,
            seed: 7,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: Rect::new(5.0, 20.0, -12.0, -6.0),
            height: -6.0 * 10f64.to_radians().tan(),
            rise: Rise::MinusY,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(5.0, 20.0, -inf, -12.0 - 1e-9),
            height: -6.0 * 10f64.to_radians().tan(),
        }));
        // The slope's sides against the level ground beside it (x = 5 and x = 20): drops.
        features.extend(ramp_sides(
            Rect::new(5.0, 20.0, -12.0, -6.0),
            6.0 * 10f64.to_radians().tan(),
            Rise::MinusY,
            FeatureKind::Curb,
            false,
        ));
        features.push(edge(
            FeatureKind::Curb,
            5.0,
            5.0,
            -inf,
            -12.0,
            6.0 * 10f64.to_radians().tan(),
        ));
        features.push(edge(
            FeatureKind::Curb,
            20.0,
            20.0,
            -inf,
            -12.0,
            6.0 * 10f64.to_radians().tan(),
        ));
        let ditch = Rect::new(-inf, 5.0, -13.0, -12.4);
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: ditch,
            height: -0.3,
        }));
        features.push(Feature {
            kind: FeatureKind::Ditch,
            footprint: Footprint::Rect {
                x_min: ditch.x_min,
                x_max: ditch.x_max,
                y_min: ditch.y_min,
                y_max: ditch.y_max,
            },
            bottom_m: -0.3,
            height_m: 0.3,
        });
        // Objects.
        let road_edge = edge_z;
        for (s, f) in [
            block([8.0, 1.4, road_edge - 0.2], [12.5, 3.2, 1.4 + road_edge]),
            block([-20.0, 14.0, 0.0], [30.0, 14.5, 3.0]),
            pole(2.0, 5.0, LEFT_CURB),
            pole(9.0, -5.0, RIGHT_CURB + edge_z),
        ] {
            solids.push(s);
            features.push(f);
        }
        Self {
            name: "street",
            ground,
            solids,
            features,
            target_x: None,
        }
    }

    /// Flat ground with square platforms (1.5 m × 1.5 m) of each height of
    /// [`GALLERY_STEPS_M`], in rows at x = `x0`, `x0` + 4, … (one row per entry of `rows`, a
    /// row's platforms 2.5 m apart across y, centred on y = 0): the smallest step each layer
    /// still finds. Features: every platform's four edges.
    #[must_use]
    pub fn step_gallery(rows: &[f64]) -> Self {
        let mut ground = Vec::new();
        let mut features = Vec::new();
        #[allow(clippy::cast_precision_loss)]
        let n = GALLERY_STEPS_M.len() as f64;
        for &x0 in rows {
            for (i, &h) in GALLERY_STEPS_M.iter().enumerate() {
                #[allow(clippy::cast_precision_loss)]
                let y = (i as f64 - 0.5 * (n - 1.0)) * 2.5 - 0.75 + 0.013;
                let rect = Rect::new(x0 + 0.013, x0 + 1.513, y, y + 1.5);
                ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                    rect,
                    height: h,
                }));
                features.extend(platform_edges(rect, h, FeatureKind::StepEdge));
            }
        }
        Self {
            name: "step gallery",
            ground,
            solids: Vec::new(),
            features,
            target_x: rows.first().copied(),
        }
    }

    /// Flat ground for x < `x0`, then grass (±`amplitude`, λ 0.12 m) for x ∈ [x0, x0 + 8]
    /// over |y| ≤ 4 m, then gravel (±1.2 cm, λ 0.04 m) from x0 + 8 to x0 + 14. No obstacle.
    #[must_use]
    pub fn rough(x0: f64, amplitude: f64) -> Self {
        Self {
            name: "rough",
            ground: vec![
                GroundTerm::Terrain(TerrainTerm::Rough {
                    rect: Rect::new(x0, x0 + 8.0, -4.0, 4.0),
                    amplitude,
                    wavelength: 0.12,
                    seed: 3,
                }),
                GroundTerm::Terrain(TerrainTerm::Rough {
                    rect: Rect::new(x0 + 8.0, x0 + 14.0, -4.0, 4.0),
                    amplitude: 0.012,
                    wavelength: 0.04,
                    seed: 5,
                }),
            ],
            solids: Vec::new(),
            features: Vec::new(),
            target_x: Some(x0),
        }
    }

    /// A crowned road (`grade` camber over |y| ≤ 3.5 m) with curbs of `curb_m` at |y| = 3.5
    /// and a kerb cut (1.2 m ramp) in the left curb at x ∈ [`cut_x`, `cut_x` + 1.5]; the
    /// sidewalks level beyond.
    #[must_use]
    pub fn cambered_road(grade: f64, curb_m: f64, cut_x: f64) -> Self {
        const ROAD: f64 = 3.5;
        let inf = f64::INFINITY;
        let cut = (cut_x, cut_x + 1.5);
        let mut ground = vec![GroundTerm::Terrain(TerrainTerm::Camber {
            y_centre: 0.0,
            half_width: ROAD,
            grade,
        })];
        let mut features = Vec::new();
        for rect in [
            Rect::new(-inf, cut.0, ROAD, inf),
            Rect::new(cut.1, inf, ROAD, inf),
            Rect::new(cut.0, cut.1, ROAD + 1.2, inf),
            Rect::new(-inf, inf, -inf, -ROAD),
        ] {
            ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                rect,
                height: curb_m,
            }));
        }
        let kerb_cut = Rect::new(cut.0, cut.1, ROAD, ROAD + 1.2);
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: kerb_cut,
            height: curb_m,
            rise: Rise::PlusY,
        }));
        features.push(edge(FeatureKind::Curb, -inf, cut.0, ROAD, ROAD, curb_m));
        features.push(edge(FeatureKind::Curb, cut.1, inf, ROAD, ROAD, curb_m));
        features.push(edge(FeatureKind::Curb, -inf, inf, -ROAD, -ROAD, curb_m));
        features.extend(ramp_sides(
            kerb_cut,
            curb_m,
            Rise::PlusY,
            FeatureKind::Curb,
            true,
        ));
        Self {
            name: "cambered road",
            ground,
            solids: Vec::new(),
            features,
            target_x: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scene::Ray;

    #[test]
    fn value_noise_stays_within_its_amplitude_and_is_continuous() {
        let t = TerrainTerm::Rough {
            rect: Rect::new(0.0, 10.0, 0.0, 10.0),
            amplitude: 0.025,
            wavelength: 0.12,
            seed: 3,
        };
        let mut max: f64 = 0.0;
        for i in 0..2000 {
            let x = 0.005 * f64::from(i);
            let a = t.height(x, 3.3);
            let b = t.height(x + 1e-6, 3.3);
            assert!((a - b).abs() < 1e-5, "{x}");
            max = max.max(a.abs());
        }
        assert!(max <= 0.025 && max > 0.012, "{max}");
        assert_eq!(t.height(-0.1, 3.0), 0.0);
        assert!(t.height(0.001, 3.0).abs() < 0.001, "tapered at the border");
    }

    #[test]
    fn street_heights_and_truth() {
        let s = Scene::street(0.0);
        // The crown, the road's edge, the curbs.
        assert!(s.ground_height(0.0, 0.0).abs() < 1e-12);
        assert!((s.ground_height(0.0, 3.4) + 0.085).abs() < 1e-9);
        assert!((s.ground_height(0.0, 3.6) - (0.15 - 0.0875 + 0.002)).abs() < 1e-9);
        assert!((s.ground_height(0.0, -3.6) - (0.10 - 0.0875)).abs() < 1e-9);
        // In the kerb cut, halfway up the ramp.
        assert!((s.ground_height(4.7, 4.1) - (0.075 - 0.0875 + 0.012)).abs() < 1e-9);
        // Truth: the curb's cells, the cut, the road, the 15° hill.
        let curb = cell_truth(&s, 0.1, 0, 35, 1.0);
        assert_eq!(curb.truth(), Truth::Obstacle);
        assert!((curb.step_m - 0.15).abs() < 1e-12);
        let cut_mid = cell_truth(&s, 0.1, 47, 35, 1.0);
        assert_eq!(cut_mid.truth(), Truth::Navigable, "{cut_mid:?}");
        let cut_side = cell_truth(&s, 0.1, 40, 36, 1.0);
        assert!(cut_side.step_m > 0.1, "{cut_side:?}");
        let road = cell_truth(&s, 0.1, 0, 10, 1.0);
        assert_eq!(road.truth(), Truth::Navigable);
        assert!((road.slope_deg - 0.025f64.atan().to_degrees()).abs() < 1e-9);
        let hill = cell_truth(&s, 0.3, 50, 23, 1.0);
        // 15° plus the sidewalk's 2 % rising the same way.
        let expected = (15f64.to_radians().tan() + 0.02).atan().to_degrees();
        assert!((hill.slope_deg - expected).abs() < 1e-9, "{hill:?}");
        assert_eq!(hill.truth(), Truth::Navigable);
        // A car is an obstacle, and the laser sees it.
        assert_eq!(cell_truth(&s, 0.1, 100, 20, 1.0).truth(), Truth::Obstacle);
        let ray = Ray {
            origin: [0.0, 2.0, 1.3],
            dir: [1.0, 0.0, 0.0],
        };
        let hit = s.cast(&ray, 20.0).unwrap();
        assert!((hit.point[0] - 8.0).abs() < 1e-9, "{hit:?}");
    }

    #[test]
    fn gallery_edges_carry_their_heights() {
        let s = Scene::step_gallery(&[5.0]);
        assert_eq!(s.features.len(), 4 * GALLERY_STEPS_M.len());
        let mut heights: Vec<f64> = s.features.iter().map(|f| f.height_m).collect();
        heights.dedup();
        assert_eq!(heights.len(), GALLERY_STEPS_M.len());
        // The 20 cm platform's near edge, at x = 5.013.
        let last = GALLERY_STEPS_M.len() - 1;
        #[allow(clippy::cast_precision_loss)]
        let y = (last as f64 - 3.5) * 2.5;
        assert!((s.ground_height(5.5, y) - 0.20).abs() < 1e-12);
        assert_eq!(s.ground_height(4.9, y), 0.0);
    }
}
