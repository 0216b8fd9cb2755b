//! The ground of a scene: a height field, the sum of [`GroundTerm`]s (a slope, a flight of
//! stairs ([`StairsSpec`]), a step, a trench, a terrain term).

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
    /// ([`crate::sim::terrain`]).
    Terrain(crate::sim::terrain::TerrainTerm),
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
    pub(super) fn max_over(&self, x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64) -> f64 {
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
