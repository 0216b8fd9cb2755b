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
//!
//! [`GroundTerm::Terrain`]: super::scene::GroundTerm::Terrain
//! [`GroundTerm::Slope`]: super::scene::GroundTerm::Slope
//! [`Feature`]: super::scene::Feature

mod scenes;
mod truth;

pub use scenes::GALLERY_STEPS_M;
pub use truth::{cell_truth, clear_of_features, macro_gradient, CellTruth, Truth};

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
            Self::Platform { rect, height } | Self::Ramp { rect, height, .. } => {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scene::{Ray, Scene};

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
