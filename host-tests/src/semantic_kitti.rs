//! SemanticKITTI's labelled scans (a Velodyne HDL-64E on a car, `velodyne/NNNNNN.bin` and
//! `labels/NNNNNN.label`): reading a pair and deriving what each return counts as in the
//! street score of `examples/semantic_kitti.rs` (`docs/core.md`, "Real, hand-labelled street
//! scans"). SemanticKITTI has no curb class: a kerb is a class boundary with a drop, derived
//! here ([`truth`]).

use std::collections::HashMap;

/// The row of clear ground in the score's table.
pub const GROUND_ROW: usize = 0;
/// The row of the curb.
pub const CURB_ROW: usize = 1;
/// The rows of the obstacle kinds: post, block, vegetation, other.
pub const POST_ROW: usize = 2;
/// See [`POST_ROW`].
pub const BLOCK_ROW: usize = 3;
/// See [`POST_ROW`].
pub const VEGETATION_ROW: usize = 4;
/// See [`POST_ROW`].
pub const OTHER_ROW: usize = 5;
/// The first of the curb's rows by distance from the drop (0–0.1, 0.1–0.2, 0.2–0.3 m).
pub const BAND_ROW: usize = 7;
/// The width of those bands, metres.
pub const BAND_M: f64 = 0.1;
/// The row of the curb's returns with a drop of at least [`TALL_M`] within 0.3 m.
pub const TALL_ROW: usize = 10;
/// A town kerb's usual height (10–15 cm) from below: a drop of at least this, metres.
pub const TALL_M: f64 = 0.10;
/// The smallest drop that makes a class boundary a kerb, metres.
pub const KERB_M: f64 = 0.08;
/// How far from the drop a kerb's returns reach, metres.
pub const KERB_REACH_M: f64 = 0.3;
/// How far clear ground stands from every feature, metres.
pub const CLEAR_M: f64 = 0.5;

/// A curb return's further rows: its band by the distance from the drop ([`BAND_ROW`] + 0..=2)
/// and, for a drop of at least [`TALL_M`], [`TALL_ROW`].
pub type CurbRows = [Option<usize>; 2];

/// What a labelled point is, for the score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Flat ground (road, parking, sidewalk, lane marking, other ground).
    Ground,
    /// Grass and soil: never counted; a feature only where it stands over a drop (a verge).
    Terrain,
    /// Pole, traffic sign, trunk.
    Post,
    /// Vehicles, people, buildings, fences, other structures.
    Block,
    /// Bushes and trees.
    Vegetation,
    /// Other objects.
    Other,
    /// Unlabelled or an outlier: a feature near ground, never counted.
    Unlabelled,
}

/// The kind of a SemanticKITTI raw class id.
#[must_use]
pub fn kind(class: u32) -> Kind {
    match class {
        40 | 44 | 48 | 49 | 60 => Kind::Ground,
        72 => Kind::Terrain,
        71 | 80 | 81 => Kind::Post,
        10 | 11 | 13 | 15 | 16 | 18 | 20 | 30 | 31 | 32 | 50 | 51 | 52 | 252..=259 => Kind::Block,
        70 => Kind::Vegetation,
        99 => Kind::Other,
        _ => Kind::Unlabelled,
    }
}

fn read(path: &str) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("{path}: {e}"))
}

/// The points (metres, the laser's frame) and their classes (the raw ids) of the scan
/// `bin` and its labels `label`.
///
/// # Errors
/// A file that cannot be read, or files of the wrong length or that disagree.
pub fn load(bin: &str, label: &str) -> Result<(Vec<[f64; 3]>, Vec<u32>), String> {
    parse(&read(bin)?, &read(label)?).map_err(|e| format!("{bin} and {label}: {e}"))
}

/// The points and classes of a scan's bytes `b` (`x y z reflectance`, little-endian `f32`)
/// and its labels' `l` (little-endian `u32`, the class in the low 16 bits).
///
/// # Errors
/// Bytes of the wrong length (16 a point, 4 a label) or that do not hold the same points.
pub fn parse(b: &[u8], l: &[u8]) -> Result<(Vec<[f64; 3]>, Vec<u32>), String> {
    if !b.len().is_multiple_of(16) || !l.len().is_multiple_of(4) || b.len() / 16 != l.len() / 4 {
        return Err(format!(
            "{} bytes (16 a point) and {} bytes (4 a label) do not hold the same points",
            b.len(),
            l.len()
        ));
    }
    let f = |c: &[u8]| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    let points = b
        .chunks_exact(16)
        .map(|c| [f(&c[0..4]), f(&c[4..8]), f(&c[8..12])])
        .collect();
    let classes = l
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) & 0xFFFF)
        .collect();
    Ok((points, classes))
}

/// Points bucketed by 0.5 m cells, for the neighbourhood searches.
struct Buckets(HashMap<(i64, i64), Vec<usize>>);

impl Buckets {
    const SIZE: f64 = 0.5;

    #[allow(clippy::cast_possible_truncation)]
    fn key(p: &[f64; 3]) -> (i64, i64) {
        (
            (p[0] / Self::SIZE).floor() as i64,
            (p[1] / Self::SIZE).floor() as i64,
        )
    }

    fn new(points: &[[f64; 3]]) -> Self {
        let mut m: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            m.entry(Self::key(p)).or_default().push(i);
        }
        Self(m)
    }

    /// The horizontal distance from `p` to the nearest point within `radius` (≤ 0.5 m) that
    /// satisfies `f`, if any.
    fn nearest(
        &self,
        points: &[[f64; 3]],
        p: &[f64; 3],
        radius: f64,
        f: impl Fn(usize) -> bool,
    ) -> Option<f64> {
        let (i, j) = Self::key(p);
        let mut best: Option<f64> = None;
        for di in -1..=1 {
            for dj in -1..=1 {
                for &k in self.0.get(&(i + di, j + dj)).into_iter().flatten() {
                    let q = &points[k];
                    let d = (q[0] - p[0]).hypot(q[1] - p[1]);
                    if d <= radius && best.is_none_or(|b| d < b) && f(k) {
                        best = Some(d);
                    }
                }
            }
        }
        best
    }

    /// The height span (highest less lowest, metres) of the points within `radius` (≤ 0.5 m)
    /// of `p`, horizontally, `p` itself among them.
    fn span(&self, points: &[[f64; 3]], p: &[f64; 3], radius: f64) -> f64 {
        let (i, j) = Self::key(p);
        let (mut low, mut high) = (p[2], p[2]);
        for di in -1..=1 {
            for dj in -1..=1 {
                for &k in self.0.get(&(i + di, j + dj)).into_iter().flatten() {
                    let q = &points[k];
                    if (q[0] - p[0]).hypot(q[1] - p[1]) <= radius {
                        low = low.min(q[2]);
                        high = high.max(q[2]);
                    }
                }
            }
        }
        high - low
    }
}

/// The radius of the neighbourhood [`local_spans`] measures, metres: a kerb's reach.
pub const SPAN_RADIUS_M: f64 = KERB_REACH_M;

/// How flat the surface around each point is, whatever its label: the height span (highest
/// less lowest, metres, ≥ 0) of every point of the scan within [`SPAN_RADIUS_M`] of it
/// horizontally. A geometric rule that marks a point whose neighbourhood spans less than a
/// kerb marks ground that spans as little.
#[must_use]
pub fn local_spans(points: &[[f64; 3]]) -> Vec<f64> {
    let buckets = Buckets::new(points);
    points
        .iter()
        .map(|p| buckets.span(points, p, SPAN_RADIUS_M))
        .collect()
}

/// What each point of a scan (`points`, metres, the laser at the origin; `classes`, raw ids)
/// counts as in the score: `None` (not counted: beyond `range_m` horizontally, terrain,
/// unlabelled, or an obstacle above `robot_height_m` over the ground plane at `ground_z_m`) or
/// its table row ([`GROUND_ROW`] … [`OTHER_ROW`]); and for a curb return its further rows
/// ([`CurbRows`]).
///
/// - A **kerb** return is a ground or terrain return with a ground or terrain return of another
///   class within [`KERB_REACH_M`] at least [`KERB_M`] lower (the drop): between road and
///   pavement, or a pavement above or below a verge. Ground kerb returns are the curb; terrain
///   ones are features, not scored.
/// - **Clear ground** is a ground return with no kerb, vegetation, unlabelled return, or
///   obstacle below the robot's height within [`CLEAR_M`].
#[must_use]
pub fn truth(
    points: &[[f64; 3]],
    classes: &[u32],
    ground_z_m: f64,
    robot_height_m: f64,
    range_m: f64,
) -> (Vec<Option<usize>>, Vec<CurbRows>) {
    let kinds: Vec<Kind> = classes.iter().map(|&c| kind(c)).collect();
    let buckets = Buckets::new(points);
    let below_robot = |p: &[f64; 3]| p[2] <= ground_z_m + robot_height_m;
    // A kerb is a class boundary with a drop: between two ground classes, or between ground
    // and terrain (a verge below or above the pavement).
    let surface = |k: usize| matches!(kinds[k], Kind::Ground | Kind::Terrain);
    let drop: Vec<Option<f64>> = (0..points.len())
        .map(|i| {
            if !surface(i) {
                return None;
            }
            buckets.nearest(points, &points[i], KERB_REACH_M, |k| {
                surface(k) && classes[k] != classes[i] && points[i][2] - points[k][2] >= KERB_M
            })
        })
        .collect();
    let curb: Vec<bool> = drop.iter().map(Option::is_some).collect();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let bands = drop
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let tall = d.is_some()
                && buckets
                    .nearest(points, &points[i], KERB_REACH_M, |k| {
                        surface(k)
                            && classes[k] != classes[i]
                            && points[i][2] - points[k][2] >= TALL_M
                    })
                    .is_some();
            [
                d.map(|d| BAND_ROW + ((d / BAND_M).floor() as usize).min(2)),
                tall.then_some(TALL_ROW),
            ]
        })
        .collect();
    let rows = (0..points.len())
        .map(|i| {
            let p = &points[i];
            if p[0].hypot(p[1]) > range_m {
                return None;
            }
            match kinds[i] {
                Kind::Ground if curb[i] => Some(CURB_ROW),
                Kind::Ground => {
                    let feature = buckets.nearest(points, p, CLEAR_M, |k| {
                        curb[k]
                            || matches!(kinds[k], Kind::Unlabelled | Kind::Vegetation)
                            || (matches!(kinds[k], Kind::Post | Kind::Block | Kind::Other)
                                && below_robot(&points[k]))
                    });
                    feature.is_none().then_some(GROUND_ROW)
                }
                _ if !below_robot(p) => None,
                Kind::Post => Some(POST_ROW),
                Kind::Block => Some(BLOCK_ROW),
                Kind::Vegetation => Some(VEGETATION_ROW),
                Kind::Other => Some(OTHER_ROW),
                Kind::Terrain | Kind::Unlabelled => None,
            }
        })
        .collect();
    (rows, bands)
}

/// Which returns are clear ground in a ground-only cell of the map: a clear-ground return
/// (`rows[i] == Some(GROUND_ROW)`, from [`truth`]) whose cell in its own band's layer holds no
/// return but ground below the robot's height (no kerb, terrain, vegetation, unlabelled return
/// or obstacle at or below `robot_height_m` over the ground plane at `ground_z_m`).
///
/// The map's cells coarsen with range: a far cell holding a kerb is an obstacle cell however
/// much road it holds besides, and its road is clear ground the map cannot resolve. `band`
/// names the layer whose band holds a point (`None` beyond the design), `cell` the index of a
/// point's cell in layer `k` of `layers`.
#[must_use]
pub fn in_ground_only_cells<C: Eq + std::hash::Hash>(
    points: &[[f64; 3]],
    classes: &[u32],
    rows: &[Option<usize>],
    (ground_z_m, robot_height_m): (f64, f64),
    layers: usize,
    band: impl Fn(&[f64; 3]) -> Option<usize>,
    cell: impl Fn(usize, &[f64; 3]) -> C,
) -> Vec<bool> {
    let feature = |i: usize| {
        points[i][2] <= ground_z_m + robot_height_m
            && (kind(classes[i]) != Kind::Ground || rows[i] == Some(CURB_ROW))
    };
    let featured: std::collections::HashSet<(usize, C)> = (0..points.len())
        .filter(|&i| feature(i))
        .flat_map(|i| (0..layers).map(move |k| (k, i)))
        .map(|(k, i)| (k, cell(k, &points[i])))
        .collect();
    points
        .iter()
        .zip(rows)
        .map(|(p, row)| {
            *row == Some(GROUND_ROW)
                && band(p).is_some_and(|k| !featured.contains(&(k, cell(k, p))))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(points: &[[f32; 3]], labels: &[u32]) -> (Vec<u8>, Vec<u8>) {
        let b = points
            .iter()
            .flat_map(|p| [p[0], p[1], p[2], 0.5])
            .flat_map(f32::to_le_bytes)
            .collect();
        let l = labels.iter().flat_map(|c| c.to_le_bytes()).collect();
        (b, l)
    }

    #[test]
    fn a_scan_and_its_labels_are_read_and_disagreeing_files_refused() {
        // The instance id in the high 16 bits is dropped.
        let (b, l) = bytes(
            &[[1.0, 2.0, -1.5], [3.0, -4.0, 0.25]],
            &[40, (7 << 16) | 80],
        );
        let (points, classes) = parse(&b, &l).unwrap();
        assert_eq!(points, vec![[1.0, 2.0, -1.5], [3.0, -4.0, 0.25]]);
        assert_eq!(classes, vec![40, 80]);
        assert!(parse(&b, &l[..4])
            .unwrap_err()
            .contains("do not hold the same points"));
        assert!(parse(&b[..20], &l).is_err());
        assert!(load("/nonexistent/000000.bin", "/nonexistent/000000.label").is_err());
    }

    #[test]
    fn a_local_span_holds_the_neighbours_within_the_radius_only() {
        // A flat patch, a 12 cm step 0.25 m away, and a post 0.4 m away (beyond the radius).
        let points = [
            [0.0, 0.0, -1.73],
            [0.1, 0.0, -1.72],
            [0.25, 0.0, -1.61],
            [0.0, 0.4, -1.0],
        ];
        let spans = local_spans(&points);
        assert!((spans[0] - 0.12).abs() < 1e-9, "{spans:?}");
        // The step sees the patch below it but not the post (0.47 m away).
        assert!((spans[2] - 0.12).abs() < 1e-9, "{spans:?}");
        // The post sees nothing within 0.3 m but itself.
        assert!(spans[3].abs() < 1e-12, "{spans:?}");
        // Across bucket boundaries (0.5 m cells): a point at 0.49 m sees one at 0.51 m.
        let spans = local_spans(&[[0.49, 0.0, 0.0], [0.51, 0.0, 0.05], [1.2, 0.0, 1.0]]);
        assert!((spans[0] - 0.05).abs() < 1e-9 && (spans[1] - 0.05).abs() < 1e-9);
        assert!(spans[2].abs() < 1e-12);
    }

    #[test]
    fn classes_map_to_the_score_s_kinds() {
        assert_eq!(kind(40), Kind::Ground);
        assert_eq!(kind(48), Kind::Ground);
        assert_eq!(kind(72), Kind::Terrain);
        assert_eq!(kind(80), Kind::Post);
        assert_eq!(kind(10), Kind::Block);
        assert_eq!(kind(254), Kind::Block);
        assert_eq!(kind(70), Kind::Vegetation);
        assert_eq!(kind(99), Kind::Other);
        assert_eq!(kind(0), Kind::Unlabelled);
        assert_eq!(kind(1), Kind::Unlabelled);
    }

    /// A street 1.73 m below the laser, returns every 5 cm over x 5..8 m: road (40) for
    /// y < 3 m, pavement (48) 12 cm higher up to y = 5.5 m, a verge (72) back at road level
    /// beyond; a pole (80) at (6.5, 1.5) up to 0.8 m and a fence (51) top 1.6 m up.
    fn street() -> (Vec<[f64; 3]>, Vec<u32>) {
        let (mut points, mut classes) = (Vec::new(), Vec::new());
        for i in 0..60 {
            for j in 0..140 {
                let (x, y) = (5.0 + 0.05 * f64::from(i), 0.025 + 0.05 * f64::from(j));
                let (z, class) = if y < 3.0 {
                    (-1.73, 40)
                } else if y < 5.5 {
                    (-1.61, 48)
                } else {
                    (-1.73, 72)
                };
                points.push([x, y, z]);
                classes.push(class);
            }
        }
        for k in 0..16 {
            points.push([6.5, 1.5, -1.73 + 0.05 * f64::from(k)]);
            classes.push(80);
        }
        points.push([7.0, 0.5, -0.1]);
        classes.push(51);
        points.push([30.0, 0.0, -1.73]);
        classes.push(40);
        (points, classes)
    }

    /// The index of the street's point at `(x, y)`.
    fn index_at(points: &[[f64; 3]], x: f64, y: f64) -> usize {
        points
            .iter()
            .position(|p| (p[0] - x).abs() < 1e-9 && (p[1] - y).abs() < 1e-9)
            .unwrap()
    }

    #[test]
    fn kerbs_are_class_boundaries_with_a_drop_and_clear_ground_keeps_away_from_features() {
        let (points, classes) = street();
        let (rows, bands) = truth(&points, &classes, -1.73, 1.0, 20.0);
        let at = |x: f64, y: f64| index_at(&points, x, y);
        // The pavement's edge over the road: curb, banded by the distance from the drop (the
        // nearest road return is 5 cm below the edge's first row), 12 cm: tall.
        let edge = at(6.0, 3.025);
        assert_eq!(rows[edge], Some(CURB_ROW));
        assert_eq!(bands[edge], [Some(BAND_ROW), Some(TALL_ROW)]);
        let behind = at(6.0, 3.225);
        assert_eq!(bands[behind], [Some(BAND_ROW + 2), Some(TALL_ROW)]);
        // 0.3 m and more behind the drop: pavement, clear ground 0.5 m on.
        assert_eq!(rows[at(6.0, 3.325)], None);
        assert_eq!(rows[at(6.0, 4.025)], Some(GROUND_ROW));
        // The pavement over the verge is a kerb too; the verge itself is never counted.
        assert_eq!(rows[at(6.0, 5.475)], Some(CURB_ROW));
        assert_eq!(rows[at(6.0, 5.525)], None);
        // The road below the kerb is no curb, and within 0.5 m of it no clear ground.
        assert_eq!(rows[at(6.0, 2.975)], None);
        assert_eq!(rows[at(6.0, 2.025)], Some(GROUND_ROW));
        // The pole below the robot's height, and the road within 0.5 m of it.
        assert_eq!(rows[points.len() - 18], Some(POST_ROW));
        assert_eq!(rows[at(6.5, 1.775)], None);
        assert_eq!(rows[at(6.5, 2.025)], Some(GROUND_ROW));
        // The fence's top above the robot's height, the road beyond the range: not counted.
        assert_eq!(rows[points.len() - 2], None);
        assert_eq!(rows[points.len() - 1], None);
    }

    #[test]
    fn clear_ground_in_a_cell_with_a_feature_is_not_in_a_ground_only_cell() {
        let (points, classes) = street();
        let (rows, _) = truth(&points, &classes, -1.73, 1.0, 20.0);
        let at = |x: f64, y: f64| index_at(&points, x, y);
        // Two layers: 1 m cells for x < 6.5 m, 2 m cells beyond (floored from the origin).
        let band = |p: &[f64; 3]| (p[0].hypot(p[1]) <= 20.0).then_some(usize::from(p[0] >= 6.5));
        #[allow(clippy::cast_possible_truncation)]
        let cell = |k: usize, p: &[f64; 3]| {
            let r = if k == 0 { 1.0 } else { 2.0 };
            ((p[0] / r).floor() as i64, (p[1] / r).floor() as i64)
        };
        let only = in_ground_only_cells(&points, &classes, &rows, (-1.73, 1.0), 2, band, cell);
        // Road 1 m from the kerb in a 1 m cell of road alone: ground-only.
        assert_eq!(rows[at(6.0, 2.025)], Some(GROUND_ROW));
        assert!(only[at(6.0, 2.025)]);
        // The same road in a 2 m cell (x 6–8, y 2–4) that holds the kerb: not.
        assert_eq!(rows[at(7.0, 2.025)], Some(GROUND_ROW));
        assert!(!only[at(7.0, 2.025)]);
        // Pavement in the 1 m cell x 5–6, y 4–5 (no kerb, no verge): ground-only; the same
        // pavement's 2 m cell y 4–6 holds the verge: not.
        assert!(only[at(5.5, 4.525)]);
        assert!(!only[at(7.0, 4.525)]);
        // The road in the 2 m cell x 6–8, y 0–2 holds the pole (below the robot's height).
        assert!(!only[at(7.0, 0.525)]);
        // Not clear ground, not counted: the kerb itself, the verge.
        assert!(!only[at(6.0, 3.025)] && !only[at(6.0, 5.775)]);
    }
}
