//! f64 reference of the navigability classifier, written from the paper's rule (Ferguson et
//! al. as the paper summarises it, read in paper-notes) and `docs/core.md`, not from
//! `src/classify.rs`.
//!
//! It keeps every point of an observation, so it applies the rule exactly: per layer cell,
//! ground = the lowest z; points above ground + robot height are dropped; the rest are judged
//! by the rule in force ([`RefRule`], `docs/core.md` "The navigability rule"):
//! - the paper's **spread** rule: not navigable when they spread over more than the step
//!   threshold;
//! - the **plane** rule: the least-squares plane of the points (x, y relative to the cell,
//!   ridge λ = (c/64)² on both horizontal variances); not navigable when the RMS of the points
//!   about it exceeds `√(residual² + a²)`, or when it is steeper than the largest slope and
//!   rises across the points' extent (`D = √12·s`, s their standard deviation along the
//!   gradient) by more than `D·tan(max_slope) + 1.5·a·√(12/n)` and by more than
//!   `step + a·√(12/n)` in all; `a = k·σ_z`, `σ_z = √((σ·h/r)² + (σ_a·r)²)`,
//!   `r = √(h² + d²)`, h the sensor's height above the ground plane, d the cell's closest look,
//!   n the points; or when the lowest and the highest point (the first of each in arrival
//!   order) stand apart by more than the plane explains,
//!   `spread − max(0, w·(p_high − p_low)) > step + 2·k·σ·h/r` (the extremes test); or when two
//!   consecutive points in arrival order lie on a surface steeper than the largest slope and
//!   rise more than a step, `|Δz| − tan(max_slope)·(|Δx| + |Δy|) > 2·k·σ·h/r` and
//!   `|Δz| > step + 2·k·σ·h/r` (the pair test: a kerb's face, where two beams' returns nearly
//!   coincide or one beam crosses it). The pairs are those consecutive within the cell and,
//!   for the first eight layers, each pair of consecutive points of the observation that the
//!   layer takes in two different cells less than a cell's side apart (|Δx| + |Δy| < c),
//!   rising more than the step and at most the robot's height: it counts in the cell of its
//!   upper point (the pair test across a cell's edge). In every layer, the lowest points of
//!   two cells that share an edge are a pair too, however far apart in their cells, when they
//!   rise more than the step and at most the robot's height ("The step between neighbouring
//!   cells' lowest returns").
//!
//! A record's distance is the smallest horizontal distance among the cell's points.

use std::collections::BTreeMap;

/// A point of an observation, metres, with its horizontal distance from the sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefPoint {
    /// World x, m.
    pub x: f64,
    /// World y, m.
    pub y: f64,
    /// World z, m.
    pub z: f64,
    /// Horizontal distance from the sensor at measurement, m.
    pub distance: f64,
}

/// The rule that judges a cell's points below the overhang cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RefRule {
    /// The paper's: the spread over the step threshold.
    Spread,
    /// The least-squares plane (see the module documentation).
    Plane {
        /// tan of the largest traversable slope.
        max_grade: f64,
        /// The residual RMS allowed on top of the noise, metres.
        residual: f64,
        /// The range noise σ, metres.
        range_sigma: f64,
        /// The beams' elevation error σ_a, radians.
        angle_sigma: f64,
        /// The noise factor k.
        noise_factor: f64,
        /// How many of a cell's previous points (below the cut, in arrival order) the pair
        /// test pairs each point with, ≥ 1.
        pair_depth: usize,
    },
}

impl RefRule {
    /// The plane rule with the defaults of `docs/core.md`: 20°, 1.5 cm, σ = 2 cm,
    /// σ_a = 0.075°, k = 2, each point paired with the one before it.
    #[must_use]
    pub fn plane() -> Self {
        Self::plane_paired(1)
    }

    /// The plane rule with its defaults, each point paired with the `depth` points before it
    /// (3 for a spinning multi-beam laser's points in firing order).
    #[must_use]
    pub fn plane_paired(depth: usize) -> Self {
        Self::Plane {
            max_grade: 20f64.to_radians().tan(),
            residual: 0.015,
            range_sigma: 0.02,
            angle_sigma: 0.075f64.to_radians(),
            noise_factor: 2.0,
            pair_depth: depth,
        }
    }
}

/// The classifier's thresholds, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefClassifierConfig {
    /// Overhang cut above the cell's ground.
    pub robot_height: f64,
    /// Largest spread of a navigable cell (spread rule); the plane rule's step allowance.
    pub step_threshold: f64,
    /// A point this far below the ground plane marks a drop-off (`None`: off).
    pub drop_threshold: Option<f64>,
    /// The rule. Default: the plane rule with its defaults.
    pub rule: RefRule,
}

impl Default for RefClassifierConfig {
    fn default() -> Self {
        Self {
            robot_height: 1.0,
            step_threshold: 0.05,
            drop_threshold: None,
            rule: RefRule::plane(),
        }
    }
}

/// The reference's verdict on one layer cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefRecord {
    /// Layer index.
    pub layer: usize,
    /// World cell index along x.
    pub cell_x: i64,
    /// World cell index along y.
    pub cell_y: i64,
    /// Not navigable?
    pub obstacle: bool,
    /// The spread of the points below the overhang cut, m.
    pub spread: f64,
    /// The closest look, m.
    pub distance: f64,
    /// How close any point came to the overhang cut (ground + robot height), m.
    pub cut_margin: f64,
    /// How close a pair of lowest points across the cell's edges (its own and a neighbour's,
    /// rising more than the step: "The step between neighbouring cells' lowest returns") came
    /// to the bound the firmware reads in its own units (heights in mm): its rise's distance
    /// from the robot's height over 2 mm; below 1 the two may differ there
    /// (`f64::INFINITY`: no such pair).
    pub edge_margin: f64,
    /// How close a pair of consecutive points across the cell's edge (this cell's and a
    /// neighbour's, rising more than the step: "The pair test across a cell's edge") came to
    /// the bounds the firmware reads in its own units: its run's distance from a cell's side
    /// over [`PAIR_RUN_SLACK_UNITS`] units of c/64 and its
    /// rise's distance from the robot's height over 2 mm, the smaller; below 1 the two may
    /// differ there (`f64::INFINITY`: no such pair).
    pub across_margin: f64,
    /// The plane rule's residual test: the residual's mean square over the allowed one (> 1:
    /// obstacle); 0 under the spread rule.
    pub residual_ratio: f64,
    /// The plane rule's rise test: `R·(g − tan)` over `g·(step + a·√(12/n))` (> 1: obstacle;
    /// 0 when the plane is no steeper than the largest slope, or under the spread rule).
    pub rise_ratio: f64,
    /// The plane rule's pair test: over the pairs of a point and one of the `pair_depth`
    /// points before it, the largest of the
    /// smaller of their rise beyond the largest slope over `2·k·σ·h/r` and their whole rise
    /// over `step + 2·k·σ·h/r` (> 1: obstacle; 0 under the spread rule).
    pub pair_ratio: f64,
    /// The pair test's ratio were every pair's run [`PAIR_RUN_SLACK_UNITS`] units of c/64
    /// longer, and shorter: (lowest, highest). The firmware holds a return's place in its cell
    /// as the floor of its place in those units, so where the span reaches 1 the two may
    /// differ, however far the ratio itself lies from 1: on a slope's allowance nearly as large
    /// as the rise, a run a centimetre shorter moves the ratio by tenths. (0, 0) under the
    /// spread rule.
    pub pair_ratio_span: (f64, f64),
}

/// How many units of a cell's side / 64 a pair's run may differ between the firmware and the
/// reference ([`RefRecord::pair_ratio_span`]): one a return's place along each axis, floored,
/// and one for the fixed point's rounding of the place.
pub const PAIR_RUN_SLACK_UNITS: f64 = 3.0;

/// The pair test's ratio over the pairs of each point (in arrival order) and each of the
/// `depth` points before it: for each pair, the smaller of its rise beyond what the slope
/// `max_grade` explains over their L1 horizontal distance over `noise` and its whole rise over
/// `step + noise` (m, m); the largest (0 for one point). Above 1 exactly when some pair lies
/// on a surface steeper than the slope beyond the noise and rises more than a step beyond it.
/// Each run is taken `run_slack` longer (m, either sign; a run stays ≥ 0).
fn pair_ratio(
    xys: &[(f64, f64)],
    zs: &[f64],
    depth: usize,
    max_grade: f64,
    step: f64,
    noise: f64,
    run_slack: f64,
) -> f64 {
    let mut largest: f64 = 0.0;
    for i in 1..xys.len() {
        for j in i.saturating_sub(depth)..i {
            let run = (xys[i].0 - xys[j].0).abs() + (xys[i].1 - xys[j].1).abs();
            let ratio = one_pair_ratio(
                (zs[i] - zs[j]).abs(),
                run,
                run_slack,
                max_grade,
                step,
                noise,
            );
            largest = largest.max(ratio);
        }
    }
    largest
}

/// One pair's ratio for [`pair_ratio`]: a rise `rise` over an L1 run `run` taken `run_slack`
/// longer (m; either sign, the run stays ≥ 0).
fn one_pair_ratio(
    rise: f64,
    run: f64,
    run_slack: f64,
    max_grade: f64,
    step: f64,
    noise: f64,
) -> f64 {
    let run = (run + run_slack).max(0.0);
    let steep = (rise - max_grade * run) / noise.max(1e-300);
    steep.min(rise / (step + noise).max(1e-300))
}

/// The layers whose cells take pairs across their edges: the first eight.
const ACROSS_LAYERS: usize = 8;

/// The plane rule's three test ratios (residual, rise, extremes) for `zs` at `xys`, see
/// [`RefRecord`]; `extremes_allowance` is `step + 2·k·σ·h/r`.
#[allow(clippy::too_many_arguments, clippy::many_single_char_names)]
fn plane_ratios(
    xys: &[(f64, f64)],
    zs: &[f64],
    cell: f64,
    step: f64,
    max_grade: f64,
    residual: f64,
    noise: f64,
    extremes_allowance: f64,
) -> (f64, f64, f64) {
    #[allow(clippy::cast_precision_loss)]
    let n = zs.len() as f64;
    if zs.len() < 2 {
        return (0.0, 0.0, 0.0);
    }
    let mean = |f: &dyn Fn(usize) -> f64| (0..zs.len()).map(f).sum::<f64>() / n;
    let (mx, my, mz) = (mean(&|i| xys[i].0), mean(&|i| xys[i].1), mean(&|i| zs[i]));
    let cov = |f: &dyn Fn(usize) -> f64, g: &dyn Fn(usize) -> f64| {
        (0..zs.len()).map(|i| f(i) * g(i)).sum::<f64>() / n
    };
    let dx = |i: usize| xys[i].0 - mx;
    let dy = |i: usize| xys[i].1 - my;
    let dz = |i: usize| zs[i] - mz;
    let (cxx, cyy, cxy) = (cov(&dx, &dx), cov(&dy, &dy), cov(&dx, &dy));
    let (cxz, cyz, czz) = (cov(&dx, &dz), cov(&dy, &dz), cov(&dz, &dz));
    let lambda = (cell / 64.0).powi(2);
    let (a, b) = (cxx + lambda, cyy + lambda);
    let det = a * b - cxy * cxy;
    let (wx, wy) = ((b * cxz - cxy * cyz) / det, (a * cyz - cxy * cxz) / det);
    let explained = wx * wx * cxx + 2.0 * wx * wy * cxy + wy * wy * cyy;
    let r2 = czz - 2.0 * (wx * cxz + wy * cyz) + explained;
    let residual_ratio = r2 / (residual * residual + noise * noise).max(1e-300);
    let g = wx.hypot(wy);
    let rise = (12.0 * explained).max(0.0).sqrt();
    // The rise test: steeper than the largest slope, rising beyond it over the points'
    // extent D = R/g by more than 1.5 times the rise's noise, and rising more than a step
    // and that noise in all; the ratio is the smaller of the two margins.
    let rise_noise = noise * (12.0 / n).sqrt();
    let rise_ratio = if g > max_grade {
        let beyond_slope = rise * (g - max_grade) / (g * 1.5 * rise_noise).max(1e-300);
        let beyond_step = rise / (step + rise_noise).max(1e-300);
        beyond_slope.min(beyond_step)
    } else {
        0.0
    };
    // The extremes: the first lowest and the first highest point in arrival order.
    let (low, high) = (first_by(zs, |a, b| a < b), first_by(zs, |a, b| a > b));
    let spread = zs[high] - zs[low];
    let explained_rise =
        (wx * (xys[high].0 - xys[low].0) + wy * (xys[high].1 - xys[low].1)).max(0.0);
    let extremes_ratio = if spread > step {
        (spread - explained_rise) / extremes_allowance.max(1e-300)
    } else {
        0.0
    };
    (residual_ratio, rise_ratio, extremes_ratio)
}

/// A layer cell's points as [`classify`] gathers them.
struct Acc {
    zs: Vec<f64>,
    /// Positions in the cell, m from its lower corner.
    xys: Vec<(f64, f64)>,
    distance: f64,
    hole: bool,
    /// Pairs across the cell's edge whose upper point lies here (the pair across an edge, the
    /// step between neighbouring cells' lowest points): (rise, run), m.
    across: Vec<(f64, f64)>,
    /// [`RefRecord::across_margin`].
    across_margin: f64,
}

/// A cell's key: (layer, world cell index along x, along y).
type CellKey = (usize, i64, i64);

/// The index of the first point of `zs` that no later one beats (`better(later, best)`), in
/// arrival order: the first lowest or the first highest. 0 for no point.
fn first_by(zs: &[f64], better: impl Fn(f64, f64) -> bool) -> usize {
    (1..zs.len()).fold(0, |best, i| if better(zs[i], zs[best]) { i } else { best })
}

/// The step between neighbouring cells' lowest returns (`docs/core.md`, the section of that
/// name): each cell's lowest point (the first of the lowest, in arrival order) and that of
/// the cell beside it to the east and to the north in the same layer, however far apart in
/// their cells (the largest slope's allowance grows with their run), rising more than the step
/// and no more than the robot's height: a pair (rise, run) of the upper cell, judged as a
/// pair of consecutive points is, kept in the upper cell's `across`. Returns each cell's
/// [`RefRecord::edge_margin`] where it has one.
fn steps_between_cells(
    cells: &mut BTreeMap<CellKey, Acc>,
    resolutions: &[f64],
    config: &RefClassifierConfig,
) -> BTreeMap<CellKey, f64> {
    // Per cell: its lowest point's height and position in the cell (every cell holds one).
    let lowest = |acc: &Acc| {
        let i = first_by(&acc.zs, |a, b| a < b);
        (acc.zs[i], acc.xys[i])
    };
    let mut pairs = Vec::new();
    let mut margins: BTreeMap<CellKey, f64> = BTreeMap::new();
    for (&(k, x, y), a) in cells.iter() {
        let (za, (xa, ya)) = lowest(a);
        let r = resolutions[k];
        for (dx, dy) in [(1_i64, 0_i64), (0, 1)] {
            let beside = (k, x + dx, y + dy);
            let Some((zb, (xb, yb))) = cells.get(&beside).map(lowest) else {
                continue;
            };
            #[allow(clippy::cast_precision_loss)]
            let run = (xb + r * dx as f64 - xa).abs() + (yb + r * dy as f64 - ya).abs();
            let rise = zb - za;
            if rise.abs() > config.step_threshold {
                let margin = (rise.abs() - config.robot_height).abs() / 0.002;
                for key in [(k, x, y), beside] {
                    let m = margins.entry(key).or_insert(f64::INFINITY);
                    *m = m.min(margin);
                }
            }
            if rise.abs() > config.step_threshold && rise.abs() <= config.robot_height {
                let upper = if rise > 0.0 { beside } else { (k, x, y) };
                pairs.push((upper, (rise.abs(), run)));
            }
        }
    }
    for (upper, pair) in pairs {
        if let Some(acc) = cells.get_mut(&upper) {
            acc.across.push(pair);
        }
    }
    margins
}

/// Classifies one observation.
///
/// `resolutions[k]` is layer k's cell size (m); `feeds(k, d)` says whether a point at
/// horizontal distance d feeds layer k (its gated increment is non-zero); `ground_z` is the
/// robot's ground plane and `sensor_z` the sensor's height (the plane rule's noise model).
pub fn classify(
    points: &[RefPoint],
    resolutions: &[f64],
    feeds: impl FnMut(usize, f64) -> bool,
    ground_z: f64,
    sensor_z: f64,
    config: &RefClassifierConfig,
) -> BTreeMap<(usize, i64, i64), RefRecord> {
    classify_after(points, resolutions, feeds, ground_z, sensor_z, config, None).0
}

/// One observation's lowest returns, for the next one ([`classify_after`]): per cell its
/// lowest point (the first of the lowest, in arrival order), height in metres and position in
/// the cell in metres from its lower corner.
pub type Lowest = BTreeMap<(usize, i64, i64), (f64, (f64, f64))>;

/// [`classify`] after an observation whose lowest returns were `last` (the step from the last
/// observation's lowest return, `docs/core.md`; plane rule only), and this observation's
/// lowest returns for the next.
pub fn classify_after(
    points: &[RefPoint],
    resolutions: &[f64],
    mut feeds: impl FnMut(usize, f64) -> bool,
    ground_z: f64,
    sensor_z: f64,
    config: &RefClassifierConfig,
    last: Option<&Lowest>,
) -> (BTreeMap<(usize, i64, i64), RefRecord>, Lowest) {
    let mut cells: BTreeMap<CellKey, Acc> = BTreeMap::new();
    let mut previous: Option<&RefPoint> = None;
    for p in points {
        let hole = config
            .drop_threshold
            .is_some_and(|drop| p.z < ground_z - drop);
        for (k, &r) in resolutions.iter().enumerate() {
            if !feeds(k, p.distance) {
                continue;
            }
            let key = (k, (p.x / r).floor() as i64, (p.y / r).floor() as i64);
            let acc = cells.entry(key).or_insert(Acc {
                zs: Vec::new(),
                xys: Vec::new(),
                distance: f64::INFINITY,
                hole: false,
                across: Vec::new(),
                across_margin: f64::INFINITY,
            });
            #[allow(clippy::cast_precision_loss)]
            acc.xys
                .push((p.x - key.1 as f64 * r, p.y - key.2 as f64 * r));
            acc.zs.push(p.z);
            acc.distance = acc.distance.min(p.distance);
            acc.hole |= hole;
            // The pair with the previous point across the cell's edge.
            let Some(q) = previous.filter(|q| k < ACROSS_LAYERS && feeds(k, q.distance)) else {
                continue;
            };
            let q_key = (k, (q.x / r).floor() as i64, (q.y / r).floor() as i64);
            let (rise, run) = ((p.z - q.z).abs(), (p.x - q.x).abs() + (p.y - q.y).abs());
            if q_key == key || rise <= config.step_threshold {
                continue;
            }
            let margin = ((run - r).abs() * 64.0 / r / PAIR_RUN_SLACK_UNITS)
                .min((rise - config.robot_height).abs() / 0.002);
            for side in [key, q_key] {
                if let Some(cell) = cells.get_mut(&side) {
                    cell.across_margin = cell.across_margin.min(margin);
                }
            }
            if run < r && rise <= config.robot_height {
                let upper = if p.z > q.z { key } else { q_key };
                if let Some(cell) = cells.get_mut(&upper) {
                    cell.across.push((rise, run));
                }
            }
        }
        previous = Some(p);
    }
    let plane = matches!(config.rule, RefRule::Plane { .. });
    let mut edge_margins = if plane {
        steps_between_cells(&mut cells, resolutions, config)
    } else {
        BTreeMap::new()
    };
    if let (true, Some(last)) = (plane, last) {
        for (key, margin) in steps_from_last(&mut cells, config, last) {
            let m = edge_margins.entry(key).or_insert(f64::INFINITY);
            *m = m.min(margin);
        }
    }
    let lowest: Lowest = cells
        .iter()
        .map(|(&key, acc)| (key, lowest_of(acc)))
        .collect();
    let records = cells
        .into_iter()
        .map(|((layer, cell_x, cell_y), acc)| {
            let ground = acc.zs.iter().copied().fold(f64::INFINITY, f64::min);
            let top = acc
                .zs
                .iter()
                .copied()
                .filter(|&z| z <= ground + config.robot_height)
                .fold(f64::NEG_INFINITY, f64::max);
            let spread = top - ground;
            let cut = ground + config.robot_height;
            let cut_margin = acc
                .zs
                .iter()
                .map(|z| (z - cut).abs())
                .fold(f64::INFINITY, f64::min);
            let (residual_ratio, rise_ratio, pair_ratio, pair_span, judged) = match config.rule {
                RefRule::Spread => (0.0, 0.0, 0.0, (0.0, 0.0), spread > config.step_threshold),
                RefRule::Plane {
                    max_grade,
                    residual,
                    range_sigma,
                    angle_sigma,
                    noise_factor,
                    pair_depth,
                } => {
                    let (xys, zs): (Vec<(f64, f64)>, Vec<f64>) = acc
                        .xys
                        .iter()
                        .zip(&acc.zs)
                        .filter(|&(_, &z)| z <= ground + config.robot_height)
                        .map(|(&xy, &z)| (xy, z))
                        .unzip();
                    let h = (sensor_z - ground_z).max(0.0);
                    let d = acc.distance.max(0.0);
                    let r = h.hypot(d);
                    let from_range = if r > 0.0 {
                        range_sigma * h / r
                    } else {
                        range_sigma
                    };
                    let sigma_z = from_range.hypot(angle_sigma * r);
                    let extremes_allowance =
                        config.step_threshold + 2.0 * noise_factor * from_range;
                    let (rr, qr, er) = plane_ratios(
                        &xys,
                        &zs,
                        resolutions[layer],
                        config.step_threshold,
                        max_grade,
                        residual,
                        noise_factor * sigma_z,
                        extremes_allowance,
                    );
                    let pair_noise = 2.0 * noise_factor * from_range;
                    // The pair test with every run `slack` longer (m).
                    let pairs_at = |slack: f64| {
                        acc.across
                            .iter()
                            .map(|&(rise, run)| {
                                one_pair_ratio(
                                    rise,
                                    run,
                                    slack,
                                    max_grade,
                                    config.step_threshold,
                                    pair_noise,
                                )
                            })
                            .fold(
                                pair_ratio(
                                    &xys,
                                    &zs,
                                    pair_depth,
                                    max_grade,
                                    config.step_threshold,
                                    pair_noise,
                                    slack,
                                ),
                                f64::max,
                            )
                    };
                    let pr = pairs_at(0.0);
                    let slack = PAIR_RUN_SLACK_UNITS * resolutions[layer] / 64.0;
                    let span = (pairs_at(slack), pairs_at(-slack));
                    (
                        rr,
                        qr,
                        pr,
                        span,
                        rr > 1.0 || qr > 1.0 || er > 1.0 || pr > 1.0,
                    )
                }
            };
            let record = RefRecord {
                layer,
                cell_x,
                cell_y,
                obstacle: acc.hole || judged,
                spread,
                distance: acc.distance,
                cut_margin,
                edge_margin: edge_margins
                    .get(&(layer, cell_x, cell_y))
                    .copied()
                    .unwrap_or(f64::INFINITY),
                across_margin: acc.across_margin,
                residual_ratio,
                rise_ratio,
                pair_ratio,
                pair_ratio_span: pair_span,
            };
            ((layer, cell_x, cell_y), record)
        })
        .collect();
    (records, if plane { lowest } else { Lowest::new() })
}

/// A cell's lowest point (the first of the lowest, in arrival order): height and position in
/// the cell, m.
fn lowest_of(acc: &Acc) -> (f64, (f64, f64)) {
    let i = first_by(&acc.zs, |a, b| a < b);
    (acc.zs[i], acc.xys[i])
}

/// The step from the last observation's lowest return (`docs/core.md`, the section of that
/// name): each cell's first point (in arrival order) and the lowest point `last` holds for the
/// same cell; where the first stands higher by more than the step and no more than the
/// robot's height, the pair (rise, run) is this cell's, judged as a pair of consecutive points
/// is. Every such pair is made here; the firmware makes it only where the cell's slot of the
/// last observation is free for it again (`src/classify/recall.rs`), so it may mark fewer
/// cells, never more. Returns the margins, as [`steps_between_cells`] does.
fn steps_from_last(
    cells: &mut BTreeMap<CellKey, Acc>,
    config: &RefClassifierConfig,
    last: &Lowest,
) -> BTreeMap<CellKey, f64> {
    let mut margins = BTreeMap::new();
    for (key, acc) in cells.iter_mut() {
        let (Some(&za), Some(&(xa, ya))) = (acc.zs.first(), acc.xys.first()) else {
            continue;
        };
        let Some(&(zb, (xb, yb))) = last.get(key) else {
            continue;
        };
        let run = (xb - xa).abs() + (yb - ya).abs();
        let rise = za - zb;
        if rise.abs() > config.step_threshold {
            // Heights in mm on the firmware's side: within 2 mm of a bound, either answer.
            let margin = ((rise.abs() - config.robot_height).abs())
                .min((rise.abs() - config.step_threshold).abs())
                / 0.002;
            let m = margins.entry(*key).or_insert(f64::INFINITY);
            *m = f64::min(*m, margin);
        }
        if rise > config.step_threshold && rise <= config.robot_height {
            acc.across.push((rise, run));
        }
    }
    margins
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> RefPoint {
        RefPoint {
            x,
            y,
            z,
            distance: 1.0,
        }
    }

    #[test]
    fn the_pair_test_pairs_as_deep_as_asked() {
        // A kerb return 0.11 m above a road return 0.01 m from it two points before, with a
        // road point 0.6 m away between them: tan 20° explains 0.22 m over that run.
        let xys = [(0.0, 0.0), (0.3, 0.3), (0.01, 0.0)];
        let zs = [0.0, 0.002, 0.11];
        let grade = 20f64.to_radians().tan();
        let ratio = |depth| pair_ratio(&xys, &zs, depth, grade, 0.05, 0.006, 0.0);
        assert!(ratio(1) < 1.0, "{}", ratio(1));
        // Two back: 0.11 − 0.0036 beyond the slope over 0.006, and 0.11 over 0.056: the
        // smaller, 1.96.
        let expected = (0.11 / 0.056_f64).min((0.11 - grade * 0.01) / 0.006);
        assert!((ratio(2) - expected).abs() < 1e-9, "{}", ratio(2));
        assert!((ratio(3) - expected).abs() < 1e-9, "{}", ratio(3));
        // Three back is out of reach of two.
        let xys = [(0.0, 0.0), (0.3, 0.3), (-0.3, 0.3), (0.01, 0.0)];
        let zs = [0.0, 0.002, 0.001, 0.11];
        assert!(pair_ratio(&xys, &zs, 2, grade, 0.05, 0.006, 0.0) < 1.0);
        assert!((pair_ratio(&xys, &zs, 3, grade, 0.05, 0.006, 0.0) - expected).abs() < 1e-9);
    }

    #[test]
    fn the_rule_by_hand() {
        let pts = [
            p(0.05, 0.05, 0.0),
            p(0.06, 0.05, 0.04),
            p(0.15, 0.05, 0.0),
            p(0.16, 0.05, 0.08),
            p(0.25, 0.05, 0.0),
            p(0.26, 0.05, 1.6),
        ];
        let spread = RefClassifierConfig {
            rule: RefRule::Spread,
            ..RefClassifierConfig::default()
        };
        let out = classify(&pts, &[0.1], |_, _| true, 0.0, 1.0, &spread);
        assert!(!out[&(0, 0, 0)].obstacle);
        assert!(out[&(0, 1, 0)].obstacle);
        assert!(!out[&(0, 2, 0)].obstacle, "overhang ignored");
    }

    #[test]
    fn the_plane_rule_by_hand() {
        // 1 m cells, a lattice of 10 × 10 points in each: a 15° slope, a 10 cm step across the
        // middle, 1 cm of texture; a roof 1.5 m over the slope.
        let mut pts = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                let (x, y) = (0.05 + 0.1 * f64::from(i), 0.05 + 0.1 * f64::from(j));
                pts.push(p(x, y, x * 15f64.to_radians().tan()));
                pts.push(p(x, y, 1.5));
                pts.push(p(x + 1.0, y, if x > 0.5 { 0.1 } else { 0.0 }));
                let texture = if (i + j) % 2 == 0 { 0.01 } else { -0.01 };
                pts.push(p(x + 2.0, y, texture));
            }
        }
        // The sensor at the ground plane's height: no height noise (σ_z = 0).
        let out = classify(
            &pts,
            &[1.0],
            |_, _| true,
            0.0,
            0.0,
            &RefClassifierConfig::default(),
        );
        assert!(!out[&(0, 0, 0)].obstacle, "a 15° slope, under a roof");
        assert!(out[&(0, 1, 0)].obstacle, "a 10 cm step");
        assert!(!out[&(0, 2, 0)].obstacle, "1 cm of texture");
        assert!(out[&(0, 1, 0)].residual_ratio > 1.0);
        let spread = RefClassifierConfig {
            rule: RefRule::Spread,
            ..RefClassifierConfig::default()
        };
        let out = classify(&pts, &[1.0], |_, _| true, 0.0, 0.0, &spread);
        assert!(out[&(0, 0, 0)].obstacle, "the paper's rule: a 24 cm spread");
    }

    #[test]
    fn a_pair_across_a_cells_edge_marks_the_upper_cell() {
        // A 10 cm kerb on the edge x = 0.3 m between 0.1 m cells 2 and 3, each flat.
        let kerb = |gap: f64, top: f64, down: bool| {
            // The road's first point is its lowest, at x = 0.2005 m.
            let mut pts: Vec<RefPoint> = [0.2005, 0.25, 0.28, 0.3 - gap]
                .iter()
                .map(|&x| p(x, 0.05, 0.0))
                .chain([0.305, 0.33, 0.36, 0.39].iter().map(|&x| p(x, 0.05, top)))
                .collect();
            if down {
                pts.reverse();
            }
            let out = classify(&pts, &[0.1], |_, _| true, 0.0, 0.0, &Default::default());
            (out[&(0, 2, 0)].obstacle, out[&(0, 3, 0)].obstacle)
        };
        assert_eq!(kerb(0.005, 0.1, false), (false, true));
        assert_eq!(kerb(0.005, 0.1, true), (false, true));
        assert_eq!(kerb(0.005, 0.04, false), (false, false), "within the step");
        // Two consecutive points a cell's side apart are no pair, but the cells' lowest
        // points, 0.1045 m apart, still show the kerb.
        assert_eq!(
            kerb(0.096, 0.1, false),
            (false, true),
            "a cell's side apart"
        );
        assert_eq!(
            kerb(0.005, 1.2, false),
            (false, false),
            "beyond the robot's height"
        );
        // Layers from the ninth on take no pairs across their edges. A 6 cm kerb whose
        // cells' lowest points lie 0.198 m apart, a rise the largest slope explains (no step
        // between the cells' lowest points): the first layer marks the pavement, the ninth
        // does not.
        let pts = [
            p(0.201, 0.05, 0.0),
            p(0.299, 0.05, 0.0),
            p(0.301, 0.05, 0.06),
            p(0.399, 0.05, 0.058),
        ];
        let resolutions = [0.1; 9];
        for (layer, marked) in [(0, true), (8, false)] {
            let out = classify(
                &pts,
                &resolutions,
                |k, _| k == layer,
                0.0,
                0.0,
                &Default::default(),
            );
            assert_eq!(out[&(layer, 3, 0)].obstacle, marked, "layer {layer}");
        }
    }

    #[test]
    fn a_step_between_neighbouring_cells_lowest_points_marks_the_upper_cell() {
        // Two lines parallel to the edge x = 0.3 m (or y = 0.3 m) between 0.1 m cells 2 and 3,
        // a far point between them: no two consecutive points cross the edge.
        let lines = |top: f64, road: f64, pavement: f64, north: bool, layers: usize| {
            let at = |across: f64, along: f64, z: f64| {
                if north {
                    p(along, across, z)
                } else {
                    p(across, along, z)
                }
            };
            let along = [0.01, 0.03, 0.05, 0.07, 0.09];
            let mut pts: Vec<RefPoint> = along.iter().map(|&v| at(road, v, 0.0)).collect();
            pts.push(p(-0.55, -0.55, 0.0));
            pts.extend(along.iter().map(|&v| at(pavement, v, top)));
            let resolutions = vec![0.1; layers];
            let out = classify(
                &pts,
                &resolutions,
                |k, _| k + 1 == layers,
                0.0,
                0.0,
                &Default::default(),
            );
            let (lower, upper) = if north {
                ((0, 2), (0, 3))
            } else {
                ((2, 0), (3, 0))
            };
            let k = layers - 1;
            (
                out[&(k, lower.0, lower.1)].obstacle,
                out[&(k, upper.0, upper.1)].obstacle,
            )
        };
        for north in [false, true] {
            // Every layer, the ninth too.
            for layers in [1, 9] {
                assert_eq!(lines(0.1, 0.295, 0.305, north, layers), (false, true));
            }
            assert_eq!(lines(-0.1, 0.295, 0.305, north, 1), (true, false), "down");
            assert_eq!(
                lines(0.04, 0.295, 0.305, north, 1),
                (false, false),
                "within the step"
            );
            assert_eq!(
                lines(0.15, 0.205, 0.395, north, 1),
                (false, true),
                "almost two cells' sides apart, beyond the slope"
            );
            assert_eq!(
                lines(0.06, 0.205, 0.395, north, 1),
                (false, false),
                "a rise the slope explains over the run"
            );
            assert_eq!(
                lines(1.2, 0.295, 0.305, north, 1),
                (false, false),
                "beyond the robot's height"
            );
        }
        // The paper's rule judges each cell by its own spread.
        let pts = [
            p(0.295, 0.05, 0.0),
            p(-0.55, -0.55, 0.0),
            p(0.305, 0.05, 0.1),
        ];
        let spread = RefClassifierConfig {
            rule: RefRule::Spread,
            ..RefClassifierConfig::default()
        };
        let out = classify(&pts, &[0.1], |_, _| true, 0.0, 0.0, &spread);
        assert!(!out[&(0, 3, 0)].obstacle);
    }
}
