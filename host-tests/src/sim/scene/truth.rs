//! The ground truth of a scene: the obstacle [`Feature`]s (footprints, their bottom and
//! height; the laser does not see them) and the map cells they put an obstacle in
//! ([`Scene::obstacle_cells`]).
use super::Scene;

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

impl Feature {
    /// A block standing on the ground (a wall, a pillar, a parked car) over `min`..`max`
    /// (x, y, metres), `max[2] − min[2]` metres tall.
    #[must_use]
    pub fn block(min: [f64; 3], max: [f64; 3]) -> Self {
        Self {
            kind: FeatureKind::Block,
            footprint: Footprint::Rect {
                x_min: min[0],
                x_max: max[0],
                y_min: min[1],
                y_max: max[1],
            },
            bottom_m: 0.0,
            height_m: max[2] - min[2],
        }
    }
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

impl Scene {
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
