//! How a map scores against the scene's truth: the tallies of a layer, of the fused map and
//! of step detection, the flat cells' spread, and the cells the sensor saw.

use super::*;

/// Counts of one comparison with the truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Tally {
    /// Truly navigable cells observed.
    pub navigable: usize,
    /// Of those, classed navigable.
    pub navigable_ok: usize,
    /// True obstacle cells observed.
    pub obstacle: usize,
    /// Of those, classed obstacle.
    pub obstacle_ok: usize,
}

impl Tally {
    /// Adds another tally.
    pub fn add(&mut self, other: &Self) {
        self.navigable += other.navigable;
        self.navigable_ok += other.navigable_ok;
        self.obstacle += other.obstacle;
        self.obstacle_ok += other.obstacle_ok;
    }

    /// The share of truly navigable cells classed navigable, percent (NaN with none).
    #[must_use]
    pub fn navigable_pct(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let v = 100.0 * self.navigable_ok as f64 / self.navigable as f64;
        v
    }

    /// The share of true obstacles classed obstacle, percent (NaN with none).
    #[must_use]
    pub fn obstacle_pct(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let v = 100.0 * self.obstacle_ok as f64 / self.obstacle as f64;
        v
    }
}

/// Every observed cell of layer `k` against the truth at the layer's resolution.
#[must_use]
pub fn layer_tally<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    k: usize,
    scene: &Scene,
    robot_height_m: f64,
) -> Tally {
    let mut t = Tally::default();
    each_classed_cell(pyramid, k, |c, i, j, obstacle| {
        match cell_truth(scene, c, i64::from(i), i64::from(j), robot_height_m).truth() {
            Truth::Navigable => {
                t.navigable += 1;
                t.navigable_ok += usize::from(!obstacle);
            }
            Truth::Obstacle => {
                t.obstacle += 1;
                t.obstacle_ok += usize::from(obstacle);
            }
            Truth::Between => {}
        }
    });
    t
}

/// Hands every cell of layer `k` classed obstacle or navigable to `classed`: the layer's cell
/// size (metres), the cell's world index `(i, j)` and whether it is an obstacle. Nothing when
/// there is no layer `k`.
fn each_classed_cell<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    k: usize,
    mut classed: impl FnMut(f64, i32, i32, bool),
) {
    let Some(layer) = pyramid.layer(k) else {
        return;
    };
    let c = f64::from(layer.resolution().to_bits()) / 65_536.0;
    let (ox, oy) = layer.origin();
    #[allow(clippy::cast_possible_wrap, clippy::cast_possible_truncation)]
    let w = W as i32;
    for i in ox..ox + w {
        for j in oy..oy + w {
            let Some(cell) = layer.get(i, j) else {
                continue;
            };
            let obstacle = match cell.class() {
                CellClass::Obstacle => true,
                CellClass::Navigable => false,
                _ => continue,
            };
            classed(c, i, j, obstacle);
        }
    }
}

/// Per layer, per step height of `heights`: (cells whose tallest feature is that height,
/// classed obstacle).
#[must_use]
pub fn step_detection<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    k: usize,
    scene: &Scene,
    heights: &[f64],
    robot_height_m: f64,
) -> Vec<(usize, usize)> {
    let mut out = vec![(0, 0); heights.len()];
    each_classed_cell(pyramid, k, |c, i, j, obstacle| {
        let truth = cell_truth(scene, c, i64::from(i), i64::from(j), robot_height_m);
        if let Some(h) = heights
            .iter()
            .position(|&h| (h - truth.step_m).abs() < 1e-9)
        {
            if let Some(entry) = out.get_mut(h) {
                entry.0 += 1;
                entry.1 += usize::from(obstacle);
            }
        }
    });
    out
}

/// The fused answer of `pyramid` at the centre of cell `(i, j)` of the grid of `cell_m`
/// metres.
fn fused_at_cell<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    cell_m: f64,
    i: i64,
    j: i64,
) -> Fused {
    #[allow(clippy::cast_precision_loss)]
    let (x, y) = ((i as f64 + 0.5) * cell_m, (j as f64 + 0.5) * cell_m);
    pyramid.fused(
        Meters::saturating_from_num(x),
        Meters::saturating_from_num(y),
    )
}

/// Whether no feature of `scene` lies within `grow` cells of cell `(i, j)` of the grid of
/// `cell_m` metres: the cell grown by the margin is clear.
fn clear_around(
    scene: &Scene,
    cell_m: f64,
    (i, j): (i64, i64),
    grow: i64,
    robot_height_m: f64,
) -> bool {
    #[allow(clippy::cast_precision_loss)]
    let grown = crate::sim::terrain::Rect::new(
        (i - grow) as f64 * cell_m,
        (i + 1 + grow) as f64 * cell_m,
        (j - grow) as f64 * cell_m,
        (j + 1 + grow) as f64 * cell_m,
    );
    crate::sim::terrain::clear_of_features(scene, &grown, robot_height_m)
}

/// Whether `fused_at` (the fused answer at a cell's world index) is an obstacle at `(i, j)`
/// or a cell up to two away.
fn obstacle_near(fused_at: &impl Fn(i64, i64) -> Fused, i: i64, j: i64) -> bool {
    (-2..=2).any(|di| (-2..=2).any(|dj| matches!(fused_at(i + di, j + dj), Fused::Obstacle { .. })))
}

/// The fused map against the truth on the 0.1 m grid, over the cells that hold at least one
/// return (`seen`): a truly navigable cell counts when no feature lies within `clear_m` of it
/// (clear flat ground) and is right when the fused answer there is navigable; a true obstacle
/// cell is right when an obstacle cell of the fused map lies within 0.2 m (its centre's
/// neighbours up to two cells away).
#[must_use]
pub fn fused_tally<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    scene: &Scene,
    seen: &BTreeSet<(i64, i64)>,
    clear_m: f64,
    robot_height_m: f64,
) -> Tally {
    const C: f64 = 0.1;
    let fused_at = |i: i64, j: i64| fused_at_cell(pyramid, C, i, j);
    let mut t = Tally::default();
    // Cells within `clear_m` of a feature: the truth of a cell grown by the margin.
    #[allow(clippy::cast_possible_truncation)]
    let grow = (clear_m / C).ceil() as i64;
    for &(i, j) in seen {
        match cell_truth(scene, C, i, j, robot_height_m).truth() {
            Truth::Navigable => {
                if !clear_around(scene, C, (i, j), grow, robot_height_m) {
                    continue;
                }
                t.navigable += 1;
                t.navigable_ok += usize::from(matches!(fused_at(i, j), Fused::Navigable { .. }));
            }
            Truth::Obstacle => {
                t.obstacle += 1;
                t.obstacle_ok += usize::from(obstacle_near(&fused_at, i, j));
            }
            Truth::Between => {}
        }
    }
    t
}

/// Per layer: (cells of `cells` on clear, flat, untextured ground, of those whose spread
/// exceeds `spread_m`). Flat: the truth's slope at most `max_slope_deg`; clear: no feature
/// within `clear_m`; untextured: outside every roughness patch.
#[must_use]
pub fn flat_spread(
    cells: &BTreeMap<(usize, i64, i64), CellPoints>,
    resolutions: &[f64],
    scene: &Scene,
    spread_m: f64,
    max_slope_deg: f64,
    clear_m: f64,
    robot_height_m: f64,
) -> Vec<(usize, usize)> {
    use crate::sim::scene::GroundTerm;
    use crate::sim::terrain::TerrainTerm;
    let mut out = vec![(0, 0); resolutions.len()];
    for (&(k, ix, iy), cell) in cells {
        let (Some(&c), Some(entry)) = (resolutions.get(k), out.get_mut(k)) else {
            continue;
        };
        #[allow(clippy::cast_precision_loss)]
        let (x0, y0) = (ix as f64 * c, iy as f64 * c);
        let textured = scene.ground.iter().any(|g| {
            matches!(g, GroundTerm::Terrain(TerrainTerm::Rough { rect, .. })
                if rect.meets(x0, x0 + c, y0, y0 + c))
        });
        if textured {
            continue;
        }
        let truth = cell_truth(scene, c, ix, iy, robot_height_m);
        if truth.slope_deg > max_slope_deg || truth.truth() != Truth::Navigable {
            continue;
        }
        // Clear: the cell grown by the margin holds no feature.
        let grown = crate::sim::terrain::Rect::new(
            x0 - clear_m,
            x0 + c + clear_m,
            y0 - clear_m,
            y0 + c + clear_m,
        );
        if !crate::sim::terrain::clear_of_features(scene, &grown, robot_height_m) {
            continue;
        }
        entry.0 += 1;
        entry.1 += usize::from(spread(&cell.points) > spread_m);
    }
    out
}

/// The fused map at the returns of `observations` (within `max_range_m` of their sensor)
/// that lie on truly navigable ground clear of every feature by `clear_m` (counted in
/// `navigable`, right when the fused answer there is navigable) or on a true obstacle cell
/// (counted in `obstacle`, right when an obstacle cell of the fused map lies within 0.2 m).
#[must_use]
pub fn fused_points<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    scene: &Scene,
    observations: &[Observation],
    max_range_m: f64,
    clear_m: f64,
    robot_height_m: f64,
) -> Tally {
    const C: f64 = 0.1;
    let mut verdict: BTreeMap<(i64, i64), Option<bool>> = BTreeMap::new();
    let fused_at = |i: i64, j: i64| fused_at_cell(pyramid, C, i, j);
    #[allow(clippy::cast_possible_truncation)]
    let grow = (clear_m / C).ceil() as i64;
    let mut t = Tally::default();
    for obs in observations {
        for p in &obs.points {
            if (p[0] - obs.sensor[0]).hypot(p[1] - obs.sensor[1]) > max_range_m {
                continue;
            }
            #[allow(clippy::cast_possible_truncation)]
            let (i, j) = ((p[0] / C).floor() as i64, (p[1] / C).floor() as i64);
            // Per cell: None = not counted; Some(true) = an obstacle cell; Some(false) = clear
            // navigable ground.
            let kind = *verdict.entry((i, j)).or_insert_with(|| {
                match cell_truth(scene, C, i, j, robot_height_m).truth() {
                    Truth::Obstacle => Some(true),
                    Truth::Between => None,
                    Truth::Navigable => {
                        clear_around(scene, C, (i, j), grow, robot_height_m).then_some(false)
                    }
                }
            });
            match kind {
                Some(false) => {
                    t.navigable += 1;
                    t.navigable_ok +=
                        usize::from(matches!(fused_at(i, j), Fused::Navigable { .. }));
                }
                Some(true) => {
                    t.obstacle += 1;
                    t.obstacle_ok += usize::from(obstacle_near(&fused_at, i, j));
                }
                None => {}
            }
        }
    }
    t
}
