//! The real 3-D scan in `../shared/data/3dtk-tilt-scan/` and its hand labelling
//! (`host-tests/data/scan000-labels.txt`), for measuring the navigability rules.
//!
//! # The scan
//! 3DTK `uos` format (a `W x H` header, then `x y z` in cm per line, left-handed: x right, y
//! up, z forward), read into the project's frame (metres, x forward, y left, z up) as
//! `pyramid replay` does: `x = z/100, y = −x/100, z = y/100`. Returns at least 3270 cm from the
//! scanner are its "no echo" value and are not points. The scanner is at the origin, about
//! 0.4 m above the walkway's floor; the pose file is all zero.
//!
//! # The labelling ([`Labels`])
//! Made by hand from top views of the points coloured by height and side views (z against x
//! and y in strips), in the project's frame, and checked by rendering the labels over the top
//! view ([`render`], `cargo run --release -p terrain-pyramid-host-tests --example
//! terrain_rules -- 3dtk` writes it). Each line of the file is a region: a class, a height band
//! `z_min ..= z_max` (metres) and a polygon in x, y (metres); a point takes the class of the
//! first region that holds it. The classes:
//! - `ground`: the walkway's floor, inside rectangles drawn over the floor from the top view
//!   (five of them), below z = −0.30 m (the floor lies between −0.37 and −0.62 m there: the
//!   scan's floor falls about 4° away from the scanner);
//! - `step`: the 4-6 cm step up along y ≈ 1.4 m (x 0.15 … 2.1 m), from 2.5 cm above the
//!   floor beside it up to −0.28 m;
//! - `obstacle`: every point between −0.28 m (12 cm above the highest floor of the scan) and
//!   0.80 m (the ceiling cut of docs/guide.md's replay, 1.2 m above the floor) — walls, pillars,
//!   the ledge and the objects; above that lie the walkway's roof and overhang;
//! - `ignore`: the scanner's own housing and mount (returns within 0.25 m of it, and the frame
//!   beside it at x < 0.2 m), taken out before anything else.
//!
//! Clear ground ([`Evaluation`]) is ground at least 0.5 m (horizontally) from every `step` and
//! `obstacle` point.

use crate::classify::RefPoint;
use crate::navigability::{gates, integrate, observation_cells, pyramid, Rule};
use crate::png::Image;
use crate::sim::cloud::Observation;
use std::collections::HashMap;
use terrain_pyramid::{Design, Fused, GateShape, Meters, Schedule, SensorModel};

/// The scanner's "no echo" range, cm: returns this far or farther are not points.
pub const NO_ECHO_CM: f64 = 3270.0;

/// The labelling, as kept in the repository.
pub const LABELS: &str = include_str!("../data/scan000-labels.txt");

/// The scan's path relative to the workspace root.
pub const SCAN_PATH: &str = "../shared/data/3dtk-tilt-scan/scan000.3d";

/// Reads a 3DTK point file into the project's frame, in file order, without "no echo".
///
/// # Errors
/// The file cannot be read.
pub fn read_uos(path: &std::path::Path) -> std::io::Result<Vec<[f64; 3]>> {
    let text = std::fs::read_to_string(path)?;
    let mut out = Vec::new();
    for line in text.lines() {
        let v: Vec<f64> = line
            .split_whitespace()
            .filter_map(|t| t.parse().ok())
            .collect();
        let [xf, yf, zf] = v[..] else { continue };
        if (xf * xf + yf * yf + zf * zf).sqrt() >= NO_ECHO_CM {
            continue;
        }
        out.push([zf / 100.0, -xf / 100.0, yf / 100.0]);
    }
    Ok(out)
}

/// A label.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Label {
    /// The walkway's floor.
    Ground,
    /// The 4-6 cm step.
    Step,
    /// Walls, pillars, the ledge, objects.
    Obstacle,
    /// Not labelled: the scanner's own housing and its mount.
    Ignore,
}

/// One region of the labelling.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Its class.
    pub label: Label,
    /// The lowest z, metres.
    pub z_min: f64,
    /// The highest z, metres.
    pub z_max: f64,
    /// The polygon's corners (x, y), metres.
    pub polygon: Vec<(f64, f64)>,
}

impl Region {
    /// Whether the region holds `p`.
    #[must_use]
    pub fn holds(&self, p: [f64; 3]) -> bool {
        if !(self.z_min..=self.z_max).contains(&p[2]) {
            return false;
        }
        // Even-odd rule.
        let mut inside = false;
        let n = self.polygon.len();
        for i in 0..n {
            let (xi, yi) = self.polygon[i];
            let (xj, yj) = self.polygon[(i + n - 1) % n];
            if (yi > p[1]) != (yj > p[1]) && p[0] < (xj - xi) * (p[1] - yi) / (yj - yi) + xi {
                inside = !inside;
            }
        }
        inside
    }
}

/// The labelling: regions, first match wins.
#[derive(Debug, Clone, PartialEq)]
pub struct Labels {
    /// The regions in the file's order.
    pub regions: Vec<Region>,
}

impl Labels {
    /// Parses the text format: per line `class z_min z_max x,y x,y x,y …`; `#` starts a
    /// comment.
    ///
    /// # Errors
    /// The first malformed line, with its number.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut regions = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let bad = || format!("line {}: {line:?}", i + 1);
            let mut words = line.split_whitespace();
            let label = match words.next() {
                Some("ground") => Label::Ground,
                Some("step") => Label::Step,
                Some("obstacle") => Label::Obstacle,
                Some("ignore") => Label::Ignore,
                _ => return Err(bad()),
            };
            let z_min: f64 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
            let z_max: f64 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
            let polygon = words
                .map(|w| {
                    let (x, y) = w.split_once(',')?;
                    Some((x.parse().ok()?, y.parse().ok()?))
                })
                .collect::<Option<Vec<(f64, f64)>>>()
                .ok_or_else(bad)?;
            if polygon.len() < 3 {
                return Err(bad());
            }
            regions.push(Region {
                label,
                z_min,
                z_max,
                polygon,
            });
        }
        Ok(Self { regions })
    }

    /// The label of `p`, if any region holds it (and it is not [`Label::Ignore`]).
    #[must_use]
    pub fn label(&self, p: [f64; 3]) -> Option<Label> {
        self.regions
            .iter()
            .find(|r| r.holds(p))
            .map(|r| r.label)
            .filter(|&l| l != Label::Ignore)
    }
}

/// The replay of the README: the scanner 0.4 m above the floor, 8 m, γ = 3, the other
/// settings the defaults (φ 0.5°, ψ 2°, σ 0.15 m, Δd 0.1 m, soft gate, 64 × 64 cells).
///
/// # Panics
/// Never for these constants (the design is valid).
#[must_use]
pub fn readme_design() -> Design<16> {
    Design::new(
        SensorModel {
            height_m: 0.4,
            max_range_m: 8.0,
            ..SensorModel::default()
        },
        Schedule {
            gamma: 3.0,
            gate: GateShape::default(),
            ..Schedule::default()
        },
        64,
    )
    .expect("the replay's design of docs/guide.md is valid")
}

/// The ceiling cut of docs/guide.md's replay, above the robot's ground plane, metres.
pub const CEILING_M: f64 = 1.2;

/// The scanner's height above the floor, metres.
pub const SENSOR_HEIGHT_M: f64 = 0.4;

/// The scan as one observation, the ceiling cut applied (returns higher than 1.2 m above the
/// robot's ground plane dropped, as the classifier's option does).
#[must_use]
pub fn observation(points: &[[f64; 3]]) -> Observation {
    let ground_z = -SENSOR_HEIGHT_M;
    Observation {
        sensor: [0.0, 0.0, 0.0],
        ground_z,
        points: points
            .iter()
            .copied()
            .filter(|p| p[2] <= ground_z + CEILING_M)
            .collect(),
    }
}

/// One rule's outcome on the labelled scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Evaluation {
    /// Clear ground points within range.
    pub ground: usize,
    /// Of those, on a navigable cell of the fused map.
    pub ground_navigable: usize,
    /// Obstacle points within range.
    pub obstacle: usize,
    /// Of those, with an obstacle cell of the fused map within 0.2 m.
    pub obstacle_found: usize,
    /// The 0.1 m cells of the fused map's grid that hold clear ground points.
    pub ground_cells: usize,
    /// Of those, navigable in the fused map.
    pub ground_cells_navigable: usize,
    /// Step points within range.
    pub step: usize,
    /// Of those, with an obstacle cell within 0.2 m.
    pub step_found: usize,
}

/// The fused answer at `(x, y)`, metres.
pub fn fused_at<const W: usize, const L: usize>(
    p: &terrain_pyramid::Pyramid<W, L>,
    x: f64,
    y: f64,
) -> Fused {
    p.fused(
        Meters::saturating_from_num(x),
        Meters::saturating_from_num(y),
    )
}

/// Whether an obstacle cell of the fused map lies within 0.2 m of `(x, y)` (metres; sampled
/// on a 5 cm lattice over the disc).
pub fn obstacle_near<const W: usize, const L: usize>(
    p: &terrain_pyramid::Pyramid<W, L>,
    x: f64,
    y: f64,
) -> bool {
    obstacle_near_with(|qx, qy| fused_at(p, qx, qy), x, y)
}

/// [`obstacle_near`] of any map: `fused(x, y)` answers the fused query at a point, metres.
pub fn obstacle_near_with(fused: impl Fn(f64, f64) -> Fused, x: f64, y: f64) -> bool {
    (-4..=4).any(|i| {
        (-4..=4).any(|j| {
            let (dx, dy) = (0.05 * f64::from(i), 0.05 * f64::from(j));
            dx.hypot(dy) <= 0.2 + 1e-9 && matches!(fused(x + dx, y + dy), Fused::Obstacle { .. })
        })
    })
}

/// The labelled points: (point, label), within `max_range_m` of the scanner, ground points
/// only when clear (0.5 m from every step or obstacle point).
#[must_use]
pub fn labelled(points: &[[f64; 3]], labels: &Labels, max_range_m: f64) -> Vec<([f64; 3], Label)> {
    const CLEAR_M: f64 = 0.5;
    let all: Vec<([f64; 3], Label)> = points
        .iter()
        .filter(|p| p[0].hypot(p[1]) <= max_range_m)
        .filter_map(|&p| labels.label(p).map(|l| (p, l)))
        .collect();
    // A hash of the step and obstacle points on a 0.5 m grid.
    let key = |p: [f64; 3]| {
        #[allow(clippy::cast_possible_truncation)]
        let k = (
            (p[0] / CLEAR_M).floor() as i64,
            (p[1] / CLEAR_M).floor() as i64,
        );
        k
    };
    let mut blocked: HashMap<(i64, i64), Vec<[f64; 3]>> = HashMap::new();
    for &(p, l) in &all {
        if l != Label::Ground {
            blocked.entry(key(p)).or_default().push(p);
        }
    }
    all.into_iter()
        .filter(|&(p, l)| {
            if l != Label::Ground {
                return true;
            }
            let (i, j) = key(p);
            (-1..=1).all(|di| {
                (-1..=1).all(|dj| {
                    blocked.get(&(i + di, j + dj)).is_none_or(|v| {
                        v.iter()
                            .all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= CLEAR_M)
                    })
                })
            })
        })
        .collect()
}

/// Runs `rule` over the scan as one observation through a pyramid of `design` and measures it
/// against the labelled points.
#[must_use]
pub fn evaluate(
    design: &Design<16>,
    points: &[[f64; 3]],
    labelled: &[([f64; 3], Label)],
    rule: &Rule,
) -> (Evaluation, Box<terrain_pyramid::Pyramid<64, 16>>) {
    let obs = observation(points);
    let mut p = pyramid::<64, 16>(design);
    let g = gates(design);
    let cells = observation_cells(&p, &g, &obs, 1.0);
    integrate(&mut p, &g, &obs, &cells, rule);
    (score(&p, labelled), p)
}

/// Measures a fused map against the labelled points: clear ground on navigable cells (per
/// return and per 0.1 m cell), obstacle and step returns with an obstacle cell within 0.2 m.
#[must_use]
pub fn score<const W: usize, const L: usize>(
    p: &terrain_pyramid::Pyramid<W, L>,
    labelled: &[([f64; 3], Label)],
) -> Evaluation {
    let mut e = Evaluation::default();
    let mut cells = std::collections::BTreeSet::new();
    for &(q, label) in labelled {
        match label {
            Label::Ground => {
                e.ground += 1;
                let navigable = matches!(fused_at(p, q[0], q[1]), Fused::Navigable { .. });
                e.ground_navigable += usize::from(navigable);
                #[allow(clippy::cast_possible_truncation)]
                let cell = ((q[0] / 0.1).floor() as i64, (q[1] / 0.1).floor() as i64);
                if cells.insert(cell) {
                    e.ground_cells += 1;
                    #[allow(clippy::cast_precision_loss)]
                    let centre = ((cell.0 as f64 + 0.5) * 0.1, (cell.1 as f64 + 0.5) * 0.1);
                    e.ground_cells_navigable += usize::from(matches!(
                        fused_at(p, centre.0, centre.1),
                        Fused::Navigable { .. }
                    ));
                }
            }
            Label::Obstacle => {
                e.obstacle += 1;
                e.obstacle_found += usize::from(obstacle_near(p, q[0], q[1]));
            }
            Label::Step => {
                e.step += 1;
                e.step_found += usize::from(obstacle_near(p, q[0], q[1]));
            }
            Label::Ignore => {}
        }
    }
    e
}

/// Per layer `k` of a map, against the labelled points: (clear ground returns whose layer-k
/// cell is observed, of those on a navigable cell, obstacle and step returns whose layer-k
/// cell is observed, of those on an obstacle cell). Each return is judged by the one cell of
/// the layer that holds it.
#[must_use]
pub fn score_layer<const W: usize, const L: usize>(
    p: &terrain_pyramid::Pyramid<W, L>,
    k: usize,
    labelled: &[([f64; 3], Label)],
) -> crate::navigability::Tally {
    let mut t = crate::navigability::Tally::default();
    let Some(layer) = p.layer(k) else {
        return t;
    };
    let r = layer.resolution();
    for &(q, label) in labelled {
        let (i, j) = (
            r.cell_of(Meters::saturating_from_num(q[0])),
            r.cell_of(Meters::saturating_from_num(q[1])),
        );
        let obstacle = match layer.get(i, j).map(|c| c.class()) {
            Some(terrain_pyramid::CellClass::Obstacle) => true,
            Some(terrain_pyramid::CellClass::Navigable) => false,
            _ => continue,
        };
        match label {
            Label::Ground => {
                t.navigable += 1;
                t.navigable_ok += usize::from(!obstacle);
            }
            Label::Obstacle | Label::Step => {
                t.obstacle += 1;
                t.obstacle_ok += usize::from(obstacle);
            }
            Label::Ignore => {}
        }
    }
    t
}

/// A top view of the scan (x up, y to the left, one pixel per `pixel_m`) over
/// `[x0, x1] × [y0, y1]`: unlabelled points grey by height (darker is lower), ground pale green,
/// and the points of `labelled` over them (clear ground green, step orange, obstacle red), the
/// regions' outlines in black and a 1 m grid.
#[must_use]
pub fn render(
    points: &[[f64; 3]],
    labels: &Labels,
    labelled: &[([f64; 3], Label)],
    bounds: (f64, f64, f64, f64),
    pixel_m: f64,
) -> Image {
    let (x0, x1, y0, y1) = bounds;
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (w, h) = (
        ((y1 - y0) / pixel_m).ceil() as usize,
        ((x1 - x0) / pixel_m).ceil() as usize,
    );
    let mut img = Image::new(w, h, [255, 255, 255]);
    // Image column from y (left is +y), row from x (top is +x).
    let to_px = |x: f64, y: f64| ((y1 - y) / pixel_m, (x1 - x) / pixel_m);
    for gx in (x0.ceil() as i64)..=(x1.floor() as i64) {
        #[allow(clippy::cast_precision_loss)]
        let x = gx as f64;
        img.line(to_px(x, y0), to_px(x, y1), [220, 220, 220]);
    }
    for gy in (y0.ceil() as i64)..=(y1.floor() as i64) {
        #[allow(clippy::cast_precision_loss)]
        let y = gy as f64;
        img.line(to_px(x0, y), to_px(x1, y), [220, 220, 220]);
    }
    let plot = |img: &mut Image, p: [f64; 3], c: [u8; 3]| {
        let (u, v) = to_px(p[0], p[1]);
        #[allow(clippy::cast_possible_truncation)]
        img.set(u.floor() as i64, v.floor() as i64, c);
    };
    for &p in points {
        let c = match labels.label(p) {
            Some(Label::Ground) => [150, 220, 150],
            _ => {
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let shade = (((p[2] + 0.7) / 1.5).clamp(0.0, 1.0) * 160.0) as u8 + 60;
                [shade, shade, shade]
            }
        };
        plot(&mut img, p, c);
    }
    for &(p, l) in labelled {
        let c = match l {
            Label::Ground => [0, 150, 0],
            Label::Step => [255, 140, 0],
            Label::Obstacle => [210, 0, 0],
            Label::Ignore => continue,
        };
        plot(&mut img, p, c);
    }
    for r in &labels.regions {
        if r.polygon.len() > 8
            || r.polygon
                .iter()
                .any(|&(x, y)| x.abs() > 40.0 || y.abs() > 40.0)
        {
            continue;
        }
        for i in 0..r.polygon.len() {
            let (a, b) = (r.polygon[i], r.polygon[(i + 1) % r.polygon.len()]);
            img.line(to_px(a.0, a.1), to_px(b.0, b.1), [0, 0, 0]);
        }
    }
    img
}

/// The points of the scan as the f64 reference takes them.
#[must_use]
pub fn ref_points(points: &[[f64; 3]]) -> Vec<RefPoint> {
    points
        .iter()
        .map(|p| RefPoint {
            x: p[0],
            y: p[1],
            z: p[2],
            distance: p[0].hypot(p[1]),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_labels_parse_and_a_square_holds_its_inside() {
        let labels = Labels::parse(LABELS).unwrap();
        assert!(labels.regions.iter().any(|r| r.label == Label::Ground));
        let square = Region {
            label: Label::Ground,
            z_min: -1.0,
            z_max: 1.0,
            polygon: vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)],
        };
        assert!(square.holds([0.5, 0.5, 0.0]));
        assert!(!square.holds([1.5, 0.5, 0.0]));
        assert!(!square.holds([0.5, 0.5, 2.0]));
        assert!(Labels::parse("wall 0 1 0,0 1,0 1,1").is_err());
        assert!(Labels::parse("ground 0 1 0,0 1,0").is_err());
    }
}
