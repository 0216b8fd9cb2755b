//! Real, hand-labelled street scans through the library: SemanticKITTI revolutions (a Velodyne
//! HDL-64E on a car in town streets, 1.73 m up) scored by range ring the way `lab experiments
//! --far-obstacles-only` scores the simulated street.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example semantic_kitti -- SCAN.bin SCAN.label [SCAN.bin SCAN.label ...]
//! ```
//!
//! `SCAN.bin` holds the points as KITTI writes them (`x y z reflectance`, little-endian `f32`,
//! metres, the laser's frame: x forward, y left, z up); `SCAN.label` one little-endian `u32` a
//! point, the class in its low 16 bits (SemanticKITTI's raw ids). None is in this repository:
//! KITTI's scans are CC BY-NC-SA 3.0 and SemanticKITTI's labels CC BY-NC-SA 4.0
//! (non-commercial, share-alike). Public copies: sequence 08, scan 0 in the
//! `mit-han-lab/spvnas` repository (`assets/000000.bin`, `assets/000000.label`); scans 0–9 of
//! every labelled sequence (00–10) in `rancheng/mini_kitti_dataset`
//! (`dataset/sequences/SS/velodyne/NNNNNN.bin`, `…/labels/NNNNNN.label`); the whole set at
//! semantic-kitti.org. Each scan prints one line (its counts and each rule's figures in firing
//! order); the tables sum every scan given.
//!
//! Each scan goes as ONE observation (the sensor at the origin, the robot's ground plane
//! 1.73 m below it) into a fresh pyramid of the street design (`--max-range-m 20 --gamma 3
//! --height-m 1.73 --phi-deg 0.4 --psi-deg 0.09 --sigma-m 0.02 --cells 128`, the HDL-64E's
//! beam spacing and its azimuth step at 10 Hz), through the library's classifier under each
//! rule, the points in the file's order (KITTI holds them beam by beam) and in firing order
//! (by azimuth in steps of ψ, then by elevation from the lowest: as `pyramid replay --order
//! firing` sorts them).
//!
//! The score, by the point's horizontal distance from the laser (0-5 … 15-20 m), counting
//! obstacles only within the robot's height (1.0 m above its ground plane):
//! - **clear ground**: road, parking, sidewalk, lane marking and other ground with no
//!   obstacle, vegetation, unlabelled or curb point within 0.5 m; right when the fused map
//!   reads navigable there;
//! - **curb** (SemanticKITTI has no curb class; derived): a ground point with a ground or
//!   terrain point of another class within 0.3 m at least 8 cm below it (the kerb's face and
//!   edge between road and sidewalk, or above a verge; again by the distance from that drop,
//!   and those with a drop of 10 cm or more, a town kerb's usual 10–15 cm); marked when an
//!   obstacle cell of the fused map lies within 0.2 m. A terrain point above such a drop is a
//!   kerb too (a verge above the pavement): not scored, but a feature for clear ground;
//! - **post** (pole, traffic sign, trunk), **block** (vehicles, people, buildings, fences,
//!   other structures), **vegetation**, **other** (other objects): marked as curbs are.

use std::collections::HashMap;
use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule, PlaneRule};
use terrain_pyramid::{Design, Fused, Pyramid};
use terrain_pyramid_host_tests::navigability::rings::{ring_name, ring_of, RINGS};
use terrain_pyramid_host_tests::navigability::{self, integrate_library};
use terrain_pyramid_host_tests::scan3dtk::{fused_at, obstacle_near};
use terrain_pyramid_host_tests::sim::cloud::{firing_order, Observation};

/// Layer capacity of the design.
const L: usize = 16;
/// Cells per layer side.
const W: usize = 128;
/// Classifier slots: a whole revolution in one observation.
const SLOTS: usize = 65_536;
/// KITTI's laser above the ground, metres.
const HEIGHT_M: f64 = 1.73;
/// The design's and the score's range, metres.
const RANGE_M: f64 = 20.0;
/// The robot's height above its ground plane: obstacles are counted below it, metres.
const ROBOT_HEIGHT_M: f64 = 1.0;
/// The azimuth step of the HDL-64E at 10 Hz, degrees.
const PSI_DEG: f64 = 0.09;

/// What a labelled point is, for the score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Flat ground (road, parking, sidewalk, lane marking, other ground).
    Ground,
    /// Grass and soil: neither counted nor a feature.
    Terrain,
    Post,
    Block,
    Vegetation,
    Other,
    /// Unlabelled or an outlier: a feature near ground, never counted.
    Unlabelled,
}

/// The kind of a SemanticKITTI raw class id.
fn kind(class: u32) -> Kind {
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

/// The rows of the table, by index: the curb's points again by their distance from the drop
/// (rows 7–9) and the tall kerbs (row 10) after the kinds and every obstacle.
const ROWS: [&str; 11] = [
    "clear ground (navigable)",
    "curb",
    "post",
    "block",
    "vegetation",
    "other",
    "every obstacle (marked)",
    "curb, drop within 0.1 m",
    "curb, drop 0.1–0.2 m",
    "curb, drop 0.2–0.3 m",
    "curb of 10 cm or more",
];

/// The order the rows are printed in: each curb band under the curb.
const PRINT_ORDER: [usize; 11] = [0, 1, 7, 8, 9, 10, 2, 3, 4, 5, 6];

/// The first of the curb's bands by distance from the drop, and their width (metres).
const BAND_ROW: usize = 7;
const BAND_M: f64 = 0.1;
/// The row of the curb's returns with a drop of at least [`TALL_M`] within 0.3 m.
const TALL_ROW: usize = 10;
/// A town kerb's usual height (10–15 cm) from below: a drop of at least this, metres.
const TALL_M: f64 = 0.10;

/// Per row and ring: (points, right).
type Table = [[(usize, usize); RINGS]; 11];

/// A curb return's further rows: its band by the distance from the drop and, for a drop of at
/// least [`TALL_M`], [`TALL_ROW`].
type CurbRows = [Option<usize>; 2];

fn read(path: &str) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("{path}: {e}"))
}

/// The points and their classes; an error for files of the wrong length or that disagree.
fn load(bin: &str, label: &str) -> Result<(Vec<[f64; 3]>, Vec<u32>), String> {
    let (b, l) = (read(bin)?, read(label)?);
    if b.len() % 16 != 0 || l.len() % 4 != 0 || b.len() / 16 != l.len() / 4 {
        return Err(format!(
            "{bin} ({} bytes, 16 a point) and {label} ({} bytes, 4 a point) do not hold the same points",
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

/// The range ring of a point, by its horizontal distance from the laser.
fn ring(p: &[f64; 3]) -> Option<usize> {
    ring_of(p[0].hypot(p[1]))
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

    /// Whether any point within `radius` (≤ 0.5 m) of `p` satisfies `f`.
    fn any_near(
        &self,
        points: &[[f64; 3]],
        p: &[f64; 3],
        radius: f64,
        f: impl Fn(usize) -> bool,
    ) -> bool {
        self.nearest(points, p, radius, f).is_some()
    }
}

/// What each point counts as: `None` (not counted) or the table row; and for a curb point,
/// its band row by the distance from the drop (the nearest lower point of the other class) and
/// whether it stands [`TALL_M`] or more over a point of the other class within 0.3 m.
fn truth(points: &[[f64; 3]], classes: &[u32]) -> (Vec<Option<usize>>, Vec<CurbRows>) {
    let kinds: Vec<Kind> = classes.iter().map(|&c| kind(c)).collect();
    let buckets = Buckets::new(points);
    let ground_z = -HEIGHT_M;
    let below_robot = |p: &[f64; 3]| p[2] <= ground_z + ROBOT_HEIGHT_M;
    // A kerb is a class boundary with a drop: between two ground classes, or between ground
    // and terrain (a verge below or above the pavement).
    let surface = |k: usize| matches!(kinds[k], Kind::Ground | Kind::Terrain);
    let drop: Vec<Option<f64>> = (0..points.len())
        .map(|i| {
            if !surface(i) {
                return None;
            }
            buckets.nearest(points, &points[i], 0.3, |k| {
                surface(k) && classes[k] != classes[i] && points[i][2] - points[k][2] >= 0.08
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
                && buckets.any_near(points, &points[i], 0.3, |k| {
                    surface(k) && classes[k] != classes[i] && points[i][2] - points[k][2] >= TALL_M
                });
            [
                d.map(|d| BAND_ROW + ((d / BAND_M).floor() as usize).min(2)),
                tall.then_some(TALL_ROW),
            ]
        })
        .collect();
    let rows = (0..points.len())
        .map(|i| {
            let p = &points[i];
            ring(p)?;
            match kinds[i] {
                Kind::Ground if curb[i] => Some(1),
                Kind::Ground => {
                    let feature = buckets.any_near(points, p, 0.5, |k| {
                        curb[k]
                            || matches!(kinds[k], Kind::Unlabelled | Kind::Vegetation)
                            || (matches!(kinds[k], Kind::Post | Kind::Block | Kind::Other)
                                && below_robot(&points[k]))
                    });
                    (!feature).then_some(0)
                }
                _ if !below_robot(p) => None,
                Kind::Post => Some(2),
                Kind::Block => Some(3),
                Kind::Vegetation => Some(4),
                Kind::Other => Some(5),
                Kind::Terrain | Kind::Unlabelled => None,
            }
        })
        .collect();
    (rows, bands)
}

fn design() -> Result<Design<L>, String> {
    #[allow(clippy::cast_possible_truncation)]
    Design::new(
        terrain_pyramid::SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: (PSI_DEG as f32).to_radians(),
            sigma_m: 0.02,
            height_m: HEIGHT_M as f32,
            max_range_m: RANGE_M as f32,
        },
        terrain_pyramid::Schedule {
            base_m: 0.1,
            gamma: 3.0,
            ..terrain_pyramid::Schedule::default()
        },
        W,
    )
    .map_err(|e| format!("the design: {e:?}"))
}

fn score(
    p: &Pyramid<W, L>,
    points: &[[f64; 3]],
    rows: &[Option<usize>],
    bands: &[CurbRows],
) -> Table {
    let mut t: Table = [[(0, 0); RINGS]; 11];
    for ((q, row), band) in points.iter().zip(rows).zip(bands) {
        let (Some(row), Some(r)) = (*row, ring(q)) else {
            continue;
        };
        let band = if row == 1 { *band } else { [None; 2] };
        let right = if row == 0 {
            matches!(fused_at(p, q[0], q[1]), Fused::Navigable { .. })
        } else {
            obstacle_near(p, q[0], q[1])
        };
        for k in [Some(row), (row != 0).then_some(6), band[0], band[1]]
            .into_iter()
            .flatten()
        {
            t[k][r].0 += 1;
            t[k][r].1 += usize::from(right);
        }
    }
    t
}

fn cell((n, ok): (usize, usize)) -> String {
    if n == 0 {
        return "–".into();
    }
    #[allow(clippy::cast_precision_loss)]
    let pct = 100.0 * ok as f64 / n as f64;
    format!("{pct:.1} % ({ok} / {n})")
}

fn print(title: &str, t: &Table) {
    println!("\n### {title}\n");
    let names: Vec<String> = (0..RINGS).map(ring_name).collect();
    println!("| points on | {} | all |", names.join(" | "));
    println!("|{}", " --- |".repeat(RINGS + 2));
    for (name, row) in PRINT_ORDER.iter().map(|&k| (ROWS[k], &t[k])) {
        let all = row.iter().fold((0, 0), |a, c| (a.0 + c.0, a.1 + c.1));
        let cells: Vec<String> = row.iter().map(|&c| cell(c)).collect();
        println!("| {name} | {} | {} |", cells.join(" | "), cell(all));
    }
}

/// The rules and the orders every scan runs under, in the order the tables are printed.
const RUNS: usize = 4;

/// One scan's tables, one per rule and order ([`RUNS`]), and its one-line summary.
fn score_scan(
    bin: &str,
    label: &str,
    design: &Design<L>,
    classifier: &mut Classifier<SLOTS, L>,
) -> Result<([(String, Table); RUNS], String), String> {
    let (points, classes) = load(bin, label)?;
    let (rows, bands) = truth(&points, &classes);
    let count = |row: usize| rows.iter().filter(|r| **r == Some(row)).count();
    let mut summary = format!(
        "{bin}: {} points; within {RANGE_M} m: {} clear ground, {} curb, {} post, {} block, {} vegetation, {} other (obstacles below {ROBOT_HEIGHT_M} m over the ground plane)",
        points.len(),
        count(0),
        count(1),
        count(2),
        count(3),
        count(4),
        count(5),
    );
    let orders = [
        ("file order", points.clone()),
        (
            "firing order",
            firing_order(&points, [0.0; 3], PSI_DEG.to_radians()),
        ),
    ];
    let rules = [
        (
            "plane (default)",
            NavigabilityRule::Plane(PlaneRule::DEFAULT),
        ),
        ("spread (paper)", NavigabilityRule::Spread),
    ];
    let mut tables: Vec<(String, Table)> = Vec::with_capacity(RUNS);
    for (rule_name, rule) in rules {
        for (order_name, ordered) in &orders {
            classifier.configure(ClassifierConfig {
                rule,
                ..ClassifierConfig::default()
            });
            let obs = Observation {
                sensor: [0.0, 0.0, 0.0],
                ground_z: -HEIGHT_M,
                points: ordered.clone(),
            };
            let mut p: Box<Pyramid<W, L>> = navigability::pyramid(design);
            integrate_library(&mut p, &obs, classifier);
            if classifier.stats().overflow_points != 0 {
                return Err(format!(
                    "{bin}: {rule_name}: the classifier's scratch overflowed"
                ));
            }
            tables.push((
                format!("{rule_name}, {order_name}"),
                score(&p, &points, &rows, &bands),
            ));
        }
    }
    // Each rule in firing order, the way a device receives a spinning laser.
    for (name, t) in tables.iter().skip(1).step_by(2) {
        let all = |row: usize| cell(t[row].iter().fold((0, 0), |a, c| (a.0 + c.0, a.1 + c.1)));
        summary.push_str(&format!(
            "\n  {name}: clear ground {}, curb {}, post {}, every obstacle {}",
            all(0),
            all(1),
            all(2),
            all(6)
        ));
    }
    let tables: [(String, Table); RUNS] = tables
        .try_into()
        .map_err(|_| "a rule or an order is missing".to_string())?;
    Ok((tables, summary))
}

/// Every scan of `pairs` (`SCAN.bin`, `SCAN.label`), each summed into the printed tables.
fn run(pairs: &[(String, String)]) -> Result<(), String> {
    let design = design()?;
    let mut classifier: Box<Classifier<SLOTS, L>> = navigability::classifier(&design);
    let mut sums: Option<[(String, Table); RUNS]> = None;
    for (bin, label) in pairs {
        let (tables, summary) = score_scan(bin, label, &design, &mut classifier)?;
        println!("{summary}");
        match &mut sums {
            None => sums = Some(tables),
            Some(sums) => {
                for ((_, sum), (_, t)) in sums.iter_mut().zip(&tables) {
                    for (sum_row, row) in sum.iter_mut().zip(t) {
                        for (a, c) in sum_row.iter_mut().zip(row) {
                            *a = (a.0 + c.0, a.1 + c.1);
                        }
                    }
                }
            }
        }
    }
    let scans = pairs.len();
    for (name, t) in sums.iter().flatten() {
        let title = if scans == 1 {
            name.clone()
        } else {
            format!("{name}, {scans} scans")
        };
        print(&title, t);
    }
    Ok(())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || !args.len().is_multiple_of(2) {
        eprintln!("usage: semantic_kitti SCAN.bin SCAN.label [SCAN.bin SCAN.label ...] (SemanticKITTI's velodyne/ and labels/ files)");
        std::process::exit(2);
    }
    let pairs: Vec<(String, String)> = args
        .chunks_exact(2)
        .map(|c| (c[0].clone(), c[1].clone()))
        .collect();
    // The classifier's scratch and the pyramid are built in place before they are boxed.
    let outcome = std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || run(&pairs))
        .map_err(|e| e.to_string())
        .and_then(|h| {
            h.join()
                .map_err(|_| "the scoring thread panicked".to_string())
        });
    match outcome {
        Ok(Ok(())) => {}
        Ok(Err(e)) | Err(e) => {
            eprintln!("semantic_kitti: {e}");
            std::process::exit(1);
        }
    }
}
