//! The ground truth of every cell of any grid ([`cell_truth`]): the tallest feature meeting
//! the cell, the steepest macro slope of the ground within it, and what the cell is
//! ([`Truth`]) for a robot that climbs small steps and slopes up to
//! [`TRUTH_MAX_SLOPE_DEG`](super::TRUTH_MAX_SLOPE_DEG).
use super::{Rect, TRUTH_MAX_SLOPE_DEG, TRUTH_OBSTACLE_STEP_M};
use crate::sim::scene::{FeatureKind, Footprint, GroundTerm, Scene};

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
