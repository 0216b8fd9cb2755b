//! Navigability rules, measured: candidate rules in `f64` that tell a step from a slope and
//! from noise, and the bench that runs them on simulated terrain and on real scans through the
//! library's pyramid.
//!
//! # The candidates ([`Rule`])
//! Each judges one layer cell of one observation from the points below the overhang cut
//! (ground = the lowest z; points above ground + robot height dropped, exactly), and each is
//! computable in one pass over the points in arrival order from bounded state:
//! - **(a) paper** — the spread (highest − lowest) over the step threshold. State: lowest and
//!   highest z.
//! - **(b) plane** — a least-squares plane from running sums (n, Σx, Σy, Σz, Σxx, Σxy, Σyy,
//!   Σxz, Σyz, Σzz; x and y relative to the cell's corner), ridge-regularised so that points on a
//!   line or a vertical face give a bounded slope: obstacle when the residual's RMS exceeds
//!   `√(residual² + (k·σ_z(d))²)`, or when the plane rises across the points' extent by more
//!   than a navigable slope and the step allow: `g·D > step + D·tan(max_slope) + k·σ_z(d)·√(12/n)`
//!   with g the gradient, n the points and `D = √12·s` (s the points' standard deviation along
//!   the gradient: the width of a uniform spread; `σ_z·√(12/n)` is the noise of the fitted rise
//!   `g·D`). State: the ten sums.
//! - **(c) jump** — the largest height jump between consecutive points (in arrival order) of
//!   the cell that lie within `radius` of each other horizontally, less what the largest slope
//!   allows over their distance: `|Δz| − d_xy·tan(max_slope) > step + k·√2·σ_z(d)`. Computing
//!   it over *all* close pairs in one pass needs every point (or a sub-grid of the cell at
//!   `radius/√2` with a lowest and highest z per sub-cell: 4·(c√2/radius)² bytes a cell, 400 B for
//!   a 1 m cell and 0.14 m radius); over consecutive pairs the state is the previous point and the
//!   largest jump (8 bytes), and it depends on the order the sensor produces its returns in.
//! - **(d) tolerant spread** — the spread against a tolerance that grows with the cell by the
//!   largest slope and with the noise: `spread > step + c·√2·tan(max_slope) + k·σ_z(d)` (√2 c:
//!   the cell's diagonal, the longest run a slope rises over in the cell). State: as (a).
//!
//! σ_z(d) is the height noise of a return at horizontal distance d from a sensor h above the
//! robot's ground plane, from the design's sensor model (range noise σ along the beam):
//! `σ_z(d) = σ·h/√(h² + d²)`, with d the cell's closest look.

use crate::classify::RefPoint;
use crate::sim::cloud::Observation;
use crate::sim::scene::Scene;
use crate::sim::terrain::{cell_truth, Truth};
use std::collections::{BTreeMap, BTreeSet};
use terrain_pyramid::gate::Gates;
use terrain_pyramid::{CellClass, Config, Design, Evidence, EvidenceClass, Fused, Meters, Pyramid};

pub mod rings;
mod score;
pub mod witness;

pub use rings::{
    far_obstacles, far_obstacles_with, pyramid_cell, square_cell, ObstacleKind, RingTally,
};
pub use score::{flat_spread, fused_points, fused_tally, layer_tally, step_detection, Tally};

/// What a rule knows about the cell it judges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellView {
    /// The cell's side, metres.
    pub cell_m: f64,
    /// The cell's corner (smallest x and y), metres.
    pub corner: (f64, f64),
    /// The sensor's height above the robot's ground plane, metres.
    pub sensor_height_m: f64,
    /// The closest look: the smallest horizontal distance of the cell's points from the
    /// sensor, metres.
    pub distance_m: f64,
}

impl CellView {
    /// `σ_z(d)` with an angular noise `σ_a` (radians) on top of the range noise:
    /// `√((σ·h/r)² + (σ_a·r)²)`, `r = √(h² + d²)` (the height error of a beam whose elevation
    /// is off by σ_a).
    #[must_use]
    pub fn sigma_z_angular(&self, sigma_m: f64, angle_rad: f64) -> f64 {
        let r = self
            .sensor_height_m
            .max(0.0)
            .hypot(self.distance_m.max(0.0));
        self.sigma_z(sigma_m).hypot(angle_rad * r)
    }

    /// `σ_z(d) = σ·h/√(h² + d²)` for range noise σ (metres).
    #[must_use]
    pub fn sigma_z(&self, sigma_m: f64) -> f64 {
        let h = self.sensor_height_m.max(0.0);
        let d = self.distance_m.max(0.0);
        if h <= 0.0 {
            return 0.0;
        }
        sigma_m * h / (h * h + d * d).sqrt()
    }
}

/// A candidate rule and its parameters (metres, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rule {
    /// (a) The paper's: `spread > step`.
    Paper {
        /// The step threshold.
        step_m: f64,
    },
    /// (b) A least-squares plane per cell (see the module documentation).
    Plane {
        /// The step allowance of the plane's rise.
        step_m: f64,
        /// The largest traversable slope.
        max_slope_deg: f64,
        /// The residual RMS allowed on top of the noise.
        residual_m: f64,
        /// The range noise σ of the sensor model.
        sigma_m: f64,
        /// How many σ_z the noise allowance is.
        k: f64,
        /// Judge the plane's rise across the cell's side c (`g·c`) rather than across the
        /// points' extent along the gradient.
        rise_over_cell: bool,
        /// Also an obstacle when the tolerant spread (d) says so.
        backstop: bool,
        /// An angular noise σ_a (degrees) added to σ_z ([`CellView::sigma_z_angular`]).
        angle_sigma_deg: f64,
        /// Also the extremes test: an obstacle when the lowest and highest points stand
        /// apart by more than the plane explains, `spread − max(0, w·(p_high − p_low)) >
        /// step + 2·k·σ_z(σ)` (the range noise alone).
        extremes: bool,
    },
    /// (c) The largest jump between consecutive close points.
    Jump {
        /// The step threshold.
        step_m: f64,
        /// The largest traversable slope.
        max_slope_deg: f64,
        /// How close two points must be to count, horizontally.
        radius_m: f64,
        /// The range noise σ.
        sigma_m: f64,
        /// How many σ the allowance is.
        k: f64,
    },
    /// (d) The spread against a tolerance growing with the cell and the noise.
    Tolerant {
        /// The step threshold.
        step_m: f64,
        /// The largest traversable slope.
        max_slope_deg: f64,
        /// The range noise σ.
        sigma_m: f64,
        /// How many σ_z the allowance is.
        k: f64,
    },
    /// (c) or (d): an obstacle when either says so.
    JumpOrTolerant {
        /// The step threshold (both).
        step_m: f64,
        /// The largest traversable slope (both).
        max_slope_deg: f64,
        /// (c)'s radius.
        radius_m: f64,
        /// The range noise σ (both).
        sigma_m: f64,
        /// The noise multiplier (both).
        k: f64,
    },
}

/// The least-squares plane of a cell's points: what the decision of (b) reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFit {
    /// Points.
    pub n: usize,
    /// The gradient's magnitude (rise per metre).
    pub gradient: f64,
    /// The RMS of the residuals, metres.
    pub residual_rms_m: f64,
    /// The points' extent along the gradient, `√12·s`, metres.
    pub extent_m: f64,
    /// The gradient (rise per metre along x, along y).
    pub w: (f64, f64),
}

/// The ridge of the plane fit, as a fraction of the cell's side: `λ = (ridge·c)²` is added to
/// both horizontal variances, so a set of points with no horizontal spread in some direction
/// fits no slope in it.
pub const RIDGE_FRACTION: f64 = 1.0 / 64.0;

/// Fits the plane of (b) to `points` from the ten sums (x, y relative to the corner).
#[must_use]
pub fn fit_plane(points: &[RefPoint], view: &CellView) -> PlaneFit {
    let n = points.len();
    #[allow(clippy::cast_precision_loss)]
    let nf = n as f64;
    let (mut sx, mut sy, mut sz, mut sxx, mut sxy, mut syy, mut sxz, mut syz, mut szz) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let z0 = points.first().map_or(0.0, |p| p.z);
    for p in points {
        let (x, y, z) = (p.x - view.corner.0, p.y - view.corner.1, p.z - z0);
        sx += x;
        sy += y;
        sz += z;
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sxz += x * z;
        syz += y * z;
        szz += z * z;
    }
    if n == 0 {
        return PlaneFit {
            n,
            gradient: 0.0,
            residual_rms_m: 0.0,
            extent_m: 0.0,
            w: (0.0, 0.0),
        };
    }
    let (mx, my, mz) = (sx / nf, sy / nf, sz / nf);
    let cxx = (sxx / nf - mx * mx).max(0.0);
    let cyy = (syy / nf - my * my).max(0.0);
    let cxy = sxy / nf - mx * my;
    let cxz = sxz / nf - mx * mz;
    let cyz = syz / nf - my * mz;
    let czz = (szz / nf - mz * mz).max(0.0);
    let lambda = (RIDGE_FRACTION * view.cell_m).powi(2);
    let (axx, ayy) = (cxx + lambda, cyy + lambda);
    let det = axx * ayy - cxy * cxy;
    let (a, b) = if det > 0.0 {
        ((ayy * cxz - cxy * cyz) / det, (axx * cyz - cxy * cxz) / det)
    } else {
        (0.0, 0.0)
    };
    // The residual of the ridge solution against the unregularised covariance.
    let res = czz - 2.0 * (a * cxz + b * cyz) + a * a * cxx + 2.0 * a * b * cxy + b * b * cyy;
    let gradient = a.hypot(b);
    let extent = if gradient > 0.0 {
        let (ux, uy) = (a / gradient, b / gradient);
        (12.0 * (ux * ux * cxx + 2.0 * ux * uy * cxy + uy * uy * cyy))
            .max(0.0)
            .sqrt()
    } else {
        0.0
    };
    PlaneFit {
        n,
        gradient,
        residual_rms_m: res.max(0.0).sqrt(),
        extent_m: extent,
        w: (a, b),
    }
}

/// The extremes test's unexplained spread of `points` under the plane gradient `w`: the
/// first lowest and the first highest point in arrival order, `spread − max(0, w·(p_high −
/// p_low))`; 0 without points.
#[must_use]
pub fn unexplained_spread(points: &[RefPoint], w: (f64, f64)) -> f64 {
    let first_by = |better: &dyn Fn(f64, f64) -> bool| {
        points.iter().fold(None::<&RefPoint>, |best, p| match best {
            Some(b) if !better(p.z, b.z) => Some(b),
            _ => Some(p),
        })
    };
    match (first_by(&|a, b| a < b), first_by(&|a, b| a > b)) {
        (Some(low), Some(high)) => {
            let explained = (w.0 * (high.x - low.x) + w.1 * (high.y - low.y)).max(0.0);
            high.z - low.z - explained
        }
        _ => 0.0,
    }
}

fn spread(points: &[RefPoint]) -> f64 {
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.z), hi.max(p.z))
        });
    if points.is_empty() {
        0.0
    } else {
        hi - lo
    }
}

/// The largest `|Δz| − d_xy·tan` over consecutive pairs within `radius` (−∞ with none).
fn largest_jump(points: &[RefPoint], tan_slope: f64, radius: f64) -> f64 {
    points
        .windows(2)
        .filter_map(|w| {
            let d = (w[1].x - w[0].x).hypot(w[1].y - w[0].y);
            (d <= radius).then(|| (w[1].z - w[0].z).abs() - d * tan_slope)
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

impl Rule {
    /// A short name for tables.
    #[must_use]
    pub fn name(&self) -> String {
        match *self {
            Self::Paper { step_m } => format!("(a) paper, step {:.0} cm", step_m * 100.0),
            Self::Plane {
                step_m,
                max_slope_deg,
                residual_m,
                sigma_m,
                k,
                rise_over_cell,
                backstop,
                angle_sigma_deg,
                extremes,
            } => format!(
                "(b) plane{}{}{}, step {:.0} cm, {max_slope_deg:.0}°, res {:.1} cm, {k}·σ_z(σ {:.0} cm{})",
                if rise_over_cell { " c" } else { "" },
                if backstop { "|(d)" } else { "" },
                if extremes { "+extremes" } else { "" },
                step_m * 100.0,
                residual_m * 100.0,
                sigma_m * 100.0,
                if angle_sigma_deg > 0.0 {
                    format!(", σ_a {angle_sigma_deg}°")
                } else {
                    String::new()
                }
            ),
            Self::Jump {
                step_m,
                max_slope_deg,
                radius_m,
                sigma_m,
                k,
            } => format!(
                "(c) jump, step {:.0} cm, {max_slope_deg:.0}°, r {:.0} cm, {k}·σ_z(σ {:.0} cm)",
                step_m * 100.0,
                radius_m * 100.0,
                sigma_m * 100.0
            ),
            Self::Tolerant {
                step_m,
                max_slope_deg,
                sigma_m,
                k,
            } => format!(
                "(d) tolerant, step {:.0} cm, {max_slope_deg:.0}°, {k}·σ_z(σ {:.0} cm)",
                step_m * 100.0,
                sigma_m * 100.0
            ),
            Self::JumpOrTolerant {
                step_m,
                max_slope_deg,
                radius_m,
                sigma_m,
                k,
            } => format!(
                "(c)|(d), step {:.0} cm, {max_slope_deg:.0}°, r {:.0} cm, {k}·σ_z(σ {:.0} cm)",
                step_m * 100.0,
                radius_m * 100.0,
                sigma_m * 100.0
            ),
        }
    }

    /// Whether the cell whose points (below the overhang cut, in arrival order) are `points`
    /// is not navigable.
    #[must_use]
    pub fn obstacle(&self, points: &[RefPoint], view: &CellView) -> bool {
        match *self {
            Self::Paper { step_m } => spread(points) > step_m,
            Self::Tolerant {
                step_m,
                max_slope_deg,
                sigma_m,
                k,
            } => {
                let tol = step_m
                    + view.cell_m * std::f64::consts::SQRT_2 * max_slope_deg.to_radians().tan()
                    + k * view.sigma_z(sigma_m);
                spread(points) > tol
            }
            Self::Plane {
                step_m,
                max_slope_deg,
                residual_m,
                sigma_m,
                k,
                rise_over_cell,
                backstop,
                angle_sigma_deg,
                extremes,
            } => {
                let fit = fit_plane(points, view);
                if extremes
                    && unexplained_spread(points, fit.w) > step_m + 2.0 * k * view.sigma_z(sigma_m)
                {
                    return true;
                }
                let noise = k * view.sigma_z_angular(sigma_m, angle_sigma_deg.to_radians());
                let tan = max_slope_deg.to_radians().tan();
                #[allow(clippy::cast_precision_loss)]
                let n = fit.n.max(1) as f64;
                let extent = if rise_over_cell {
                    view.cell_m
                } else {
                    fit.extent_m
                };
                let plane = fit.residual_rms_m.powi(2) > residual_m.powi(2) + noise.powi(2)
                    || fit.gradient * extent > step_m + extent * tan + noise * (12.0 / n).sqrt();
                plane
                    || (backstop
                        && Self::Tolerant {
                            step_m,
                            max_slope_deg,
                            sigma_m,
                            k: 3.0,
                        }
                        .obstacle(points, view))
            }
            Self::Jump {
                step_m,
                max_slope_deg,
                radius_m,
                sigma_m,
                k,
            } => {
                let tan = max_slope_deg.to_radians().tan();
                largest_jump(points, tan, radius_m)
                    > step_m + k * std::f64::consts::SQRT_2 * view.sigma_z(sigma_m)
            }
            Self::JumpOrTolerant {
                step_m,
                max_slope_deg,
                radius_m,
                sigma_m,
                k,
            } => {
                Self::Jump {
                    step_m,
                    max_slope_deg,
                    radius_m,
                    sigma_m,
                    k,
                }
                .obstacle(points, view)
                    || Self::Tolerant {
                        step_m,
                        max_slope_deg,
                        sigma_m,
                        k,
                    }
                    .obstacle(points, view)
            }
        }
    }
}

/// The points of one layer cell of one observation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CellPoints {
    /// Below the overhang cut, in arrival order.
    pub points: Vec<RefPoint>,
    /// The closest look, metres.
    pub distance_m: f64,
}

impl CellPoints {
    /// The overhang cut: keeps the points at most `robot_height_m` (metres) above the cell's
    /// lowest, in their order.
    pub fn cut_overhang(&mut self, robot_height_m: f64) {
        let ground = self
            .points
            .iter()
            .map(|p| p.z)
            .fold(f64::INFINITY, f64::min);
        self.points.retain(|p| p.z <= ground + robot_height_m);
    }
}

/// The layer cells of one observation, as the library's gates feed them: a point joins the
/// cell of every layer whose gated increment at its distance is non-zero; per cell the points
/// above the lowest + `robot_height_m` are dropped (exactly, whatever their order).
#[must_use]
pub fn observation_cells<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    gates: &Gates<L>,
    obs: &Observation,
    robot_height_m: f64,
) -> BTreeMap<(usize, i64, i64), CellPoints> {
    let bins = gates.distance_bins();
    let inc = pyramid.increments();
    let resolutions: Vec<f64> = (0..gates.layer_count())
        .filter_map(|k| gates.resolution(k))
        .map(|r| f64::from(r.to_bits()) / 65_536.0)
        .collect();
    let q = |v: f64| Meters::saturating_from_num(v).to_num::<f64>();
    let mut cells: BTreeMap<(usize, i64, i64), CellPoints> = BTreeMap::new();
    for p in &obs.points {
        let (x, y, z) = (q(p[0]), q(p[1]), q(p[2]));
        let distance = (x - obs.sensor[0]).hypot(y - obs.sensor[1]);
        let bin = bins.bin(Meters::saturating_from_num(distance));
        for (k, &r) in resolutions.iter().enumerate() {
            let Some(gate) = gates.table(k) else {
                continue;
            };
            let w = gate.weight(bin);
            if terrain_pyramid::logodds::gated(inc.obstacle, w) == 0
                && terrain_pyramid::logodds::gated(inc.free, w) == 0
            {
                continue;
            }
            #[allow(clippy::cast_possible_truncation)]
            let key = (k, (x / r).floor() as i64, (y / r).floor() as i64);
            let cell = cells.entry(key).or_insert_with(|| CellPoints {
                points: Vec::new(),
                distance_m: f64::INFINITY,
            });
            cell.points.push(RefPoint { x, y, z, distance });
            cell.distance_m = cell.distance_m.min(distance);
        }
    }
    for cell in cells.values_mut() {
        cell.cut_overhang(robot_height_m);
    }
    cells
}

/// Integrates one observation judged by `rule` into `pyramid` (recentred on the sensor), each
/// record weighed by `gates` at its closest look as the library's classifier weighs it.
pub fn integrate<const W: usize, const L: usize>(
    pyramid: &mut Pyramid<W, L>,
    gates: &Gates<L>,
    obs: &Observation,
    cells: &BTreeMap<(usize, i64, i64), CellPoints>,
    rule: &Rule,
) {
    pyramid.recentre(
        Meters::saturating_from_num(obs.sensor[0]),
        Meters::saturating_from_num(obs.sensor[1]),
    );
    let resolutions: Vec<f64> = (0..gates.layer_count())
        .filter_map(|k| gates.resolution(k))
        .map(|r| f64::from(r.to_bits()) / 65_536.0)
        .collect();
    for (&(k, ix, iy), cell) in cells {
        let Some(&c) = resolutions.get(k) else {
            continue;
        };
        #[allow(clippy::cast_precision_loss)]
        let view = CellView {
            cell_m: c,
            corner: (ix as f64 * c, iy as f64 * c),
            sensor_height_m: obs.sensor[2] - obs.ground_z,
            distance_m: cell.distance_m,
        };
        let class = if rule.obstacle(&cell.points, &view) {
            EvidenceClass::Obstacle
        } else {
            EvidenceClass::Navigable
        };
        let (Ok(cx), Ok(cy), Ok(layer)) = (i32::try_from(ix), i32::try_from(iy), u8::try_from(k))
        else {
            continue;
        };
        pyramid.apply(&Evidence {
            layer,
            cell_x: cx,
            cell_y: cy,
            class,
            weight: gates.weight_at(k, Meters::saturating_from_num(cell.distance_m)),
        });
    }
}

/// Integrates one observation through the library's classifier (fixed point, the rule its
/// configuration names) into `pyramid`, as the firmware's pipeline does: recentre on the
/// sensor, every return with its horizontal distance from the sensor and the robot's ground
/// plane, then the observation's evidence. The classifier must have adopted the pyramid's
/// design ([`classifier`]).
pub fn integrate_library<const W: usize, const L: usize, const C: usize>(
    pyramid: &mut Pyramid<W, L>,
    obs: &Observation,
    classifier: &mut terrain_pyramid::classify::Classifier<C, L>,
) {
    let m = Meters::saturating_from_num;
    let sensor = terrain_pyramid::Point3 {
        x: m(obs.sensor[0]),
        y: m(obs.sensor[1]),
        z: m(obs.sensor[2]),
    };
    pyramid.recentre(sensor.x, sensor.y);
    classifier.begin(sensor.z);
    for p in &obs.points {
        let point = terrain_pyramid::Point3 {
            x: m(p[0]),
            y: m(p[1]),
            z: m(p[2]),
        };
        let distance = terrain_pyramid::geometry::horizontal_distance(sensor, point);
        classifier.add_point(point, distance, m(obs.ground_z));
    }
    classifier.finish_into(pyramid);
}

/// The 0.1 m cells that hold a return of `obs` within `max_range_m` of its sensor.
pub fn mark_seen(obs: &Observation, max_range_m: f64, seen: &mut BTreeSet<(i64, i64)>) {
    for p in &obs.points {
        if (p[0] - obs.sensor[0]).hypot(p[1] - obs.sensor[1]) <= max_range_m {
            #[allow(clippy::cast_possible_truncation)]
            seen.insert(((p[0] / 0.1).floor() as i64, (p[1] / 0.1).floor() as i64));
        }
    }
}

/// A configured pyramid of `design`, boxed.
///
/// # Panics
/// When the design does not fit `Pyramid<W, L>` (a bench set-up error).
#[must_use]
pub fn pyramid<const W: usize, const L: usize>(design: &Design<L>) -> Box<Pyramid<W, L>> {
    let mut p = Box::new(Pyramid::new());
    p.configure(design, &Config::default())
        .expect("the bench's design fits its pyramid");
    p
}

/// The gating of `design` with the default increments, boxed (as the library's classifier
/// adopts it).
///
/// # Panics
/// When the design's resolutions cannot be represented (a bench set-up error).
#[must_use]
pub fn gates<const L: usize>(design: &Design<L>) -> Box<Gates<L>> {
    let mut g = Box::new(Gates::new());
    let increments = Config::default()
        .model
        .increments()
        .expect("the default model's increments");
    g.configure(design, increments)
        .expect("the bench's design has representable resolutions");
    g
}

/// A library classifier of `C` slots with the default configuration, having adopted the
/// gating of `design` with the default increments, boxed.
///
/// # Panics
/// When the design's resolutions cannot be represented (a bench set-up error).
#[must_use]
pub fn classifier<const C: usize, const L: usize>(
    design: &Design<L>,
) -> Box<terrain_pyramid::classify::Classifier<C, L>> {
    let mut c = Box::new(terrain_pyramid::classify::Classifier::new());
    let increments = Config::default()
        .model
        .increments()
        .expect("the default model's increments");
    c.adopt_design(design, increments)
        .expect("the bench's design has representable resolutions");
    c
}

#[cfg(test)]
mod tests;
