//! Real, hand-labelled street scans through the library: SemanticKITTI revolutions (a Velodyne
//! HDL-64E on a car in town streets, 1.73 m up) scored by range ring the way `lab experiments
//! --far-obstacles-only` scores the simulated street.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example semantic_kitti -- [--height-m H] [--psi-deg P] SCAN.bin SCAN.label [SCAN.bin SCAN.label ...]
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
//! beam spacing and its azimuth step at 10 Hz; `--height-m` and `--psi-deg` describe the laser
//! otherwise, as `pyramid replay` takes them: the design's height and the classifier's ground
//! plane, the design's ψ and the firing order's step, while the truth keeps KITTI's ground
//! plane), through the library's classifier under each
//! rule, the points in the file's order (KITTI holds them beam by beam) and in firing order
//! (by azimuth in steps of ψ, then by elevation from the lowest: as `pyramid replay --order
//! firing` sorts them). In firing order the plane rule pairs each return with the last three
//! of its cell (`PlaneRule::pair_depth` 3, as `pyramid replay` sets it for a spinning laser's
//! file); in the file's order with the last.
//!
//! The score, by the point's horizontal distance from the laser (0-5 … 15-20 m), counting
//! obstacles only within the robot's height (1.0 m above its ground plane):
//! - **clear ground**: road, parking, sidewalk, lane marking and other ground with no
//!   obstacle, vegetation, unlabelled or curb point within 0.5 m; right when the fused map
//!   reads navigable there. Again, those whose cell in their own band's layer holds no return
//!   but ground below the robot's height (**ground-only cells**,
//!   `semantic_kitti::in_ground_only_cells`): a far cell of 1.2–2.4 m that holds a kerb is an
//!   obstacle cell, and the road beside the kerb within it ground the map cannot resolve;
//! - **curb** (SemanticKITTI has no curb class; derived): a ground point with a ground or
//!   terrain point of another class within 0.3 m at least 8 cm below it (the kerb's face and
//!   edge between road and sidewalk, or above a verge; again by the distance from that drop,
//!   and those with a drop of 10 cm or more, a town kerb's usual 10–15 cm); marked when an
//!   obstacle cell of the fused map lies within 0.2 m. A terrain point above such a drop is a
//!   kerb too (a verge above the pavement): not scored, but a feature for clear ground;
//! - **post** (pole, traffic sign, trunk), **block** (vehicles, people, buildings, fences,
//!   other structures), **vegetation**, **other** (other objects): marked as curbs are.
//!
//! Under each table, the same points by how flat the surface around them is, whatever their
//! label: the height span of every return within 0.3 m (`semantic_kitti::local_spans`), for the
//! obstacles left unmarked, every obstacle, the clear ground read otherwise and all of it. An
//! obstacle whose surroundings span less than a kerb is one a geometric rule marks only by
//! marking ground as flat.
//!
//! Last, the same scoring of a map that marks the **witness pairs** of the scan's returns
//! (`navigability::witness`: two returns within 1 m rising more steeply than 20° and by more
//! than 5 cm; obstacle in the 0.1 m cell of the upper one, navigable elsewhere): the most a
//! rule that keeps every surface no steeper than 20° with steps of at most 5 cm navigable can
//! mark on these returns, whatever the design (here the returns as measured, their noise
//! included).
//!
//! The truth is derived by `terrain_pyramid_host_tests::semantic_kitti::truth` (tested there).

use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule, PlaneRule};
use terrain_pyramid::{Design, Fused, Meters, Pyramid, Resolution};
use terrain_pyramid_host_tests::navigability::rings::{ring_name, ring_of, RINGS};
use terrain_pyramid_host_tests::navigability::witness::{witnesses, Witness};
use terrain_pyramid_host_tests::navigability::{self, integrate_library};
use terrain_pyramid_host_tests::scan3dtk::{fused_at, obstacle_near_with};
use terrain_pyramid_host_tests::semantic_kitti::{
    in_ground_only_cells, load, local_spans, truth, CurbRows, BLOCK_ROW, CURB_ROW, GROUND_ROW,
    OTHER_ROW, POST_ROW, SPAN_RADIUS_M, VEGETATION_ROW,
};
use terrain_pyramid_host_tests::sim::cloud::{firing_order, Observation};

/// Layer capacity of the design.
const L: usize = 16;
/// Cells per layer side.
const W: usize = 128;
/// Classifier slots: a whole revolution in one observation.
const SLOTS: usize = 65_536;
/// KITTI's laser above the ground, metres: the truth's ground plane, and the design's height
/// unless `--height-m` gives another.
const HEIGHT_M: f64 = 1.73;
/// The design's and the score's range, metres.
const RANGE_M: f64 = 20.0;
/// The robot's height above its ground plane: obstacles are counted below it, metres.
const ROBOT_HEIGHT_M: f64 = 1.0;
/// The azimuth step of the HDL-64E at 10 Hz, degrees: the design's ψ unless `--psi-deg`
/// gives another.
const PSI_DEG: f64 = 0.09;

/// The laser as the design describes it: the sensor's height above the robot's ground plane
/// (metres; the classifier's ground plane lies this far below the laser, as in `pyramid
/// replay`) and the azimuth step (degrees; the design's ψ and the firing order's step). The
/// truth keeps KITTI's own ground plane, [`HEIGHT_M`] below the laser, whatever the design
/// says.
#[derive(Clone, Copy)]
struct Described {
    height_m: f64,
    psi_deg: f64,
}

impl Described {
    /// The HDL-64E as KITTI mounts it.
    const KITTI: Self = Self {
        height_m: HEIGHT_M,
        psi_deg: PSI_DEG,
    };
}

/// The row of every obstacle, after the kinds' rows (`GROUND_ROW` … `OTHER_ROW`).
const EVERY_OBSTACLE_ROW: usize = 6;

/// The row of the clear ground in ground-only cells ([`in_ground_only_cells`]).
const GROUND_ONLY_ROW: usize = 11;

/// The rows of the table, by index: the curb's points again by their distance from the drop
/// (rows 7–9), the tall kerbs (row 10) and the clear ground in ground-only cells (row 11) after
/// the kinds and every obstacle.
const ROWS: [&str; 12] = [
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
    "clear ground in ground-only cells",
];

/// The order the rows are printed in: the ground-only cells' under the clear ground, each curb
/// band under the curb.
const PRINT_ORDER: [usize; 12] = [0, 11, 1, 7, 8, 9, 10, 2, 3, 4, 5, 6];

/// Per row and ring: (points, right).
type Table = [[(usize, usize); RINGS]; ROWS.len()];

/// The upper bounds of the flatness table's columns: the height span of every return within
/// [`SPAN_RADIUS_M`] of a point, metres (the last column is open).
const SPAN_BOUNDS_M: [f64; 4] = [0.05, 0.08, 0.10, 0.15];
/// The flatness table's columns.
const SPANS: usize = SPAN_BOUNDS_M.len() + 1;
/// The flatness table's rows, by index.
const FLAT_ROWS: [&str; 4] = [
    "every obstacle, unmarked",
    "every obstacle",
    "clear ground, not navigable",
    "clear ground",
];
/// Points by the flatness around them ([`local_spans`]): one row of [`FLAT_ROWS`] each.
type Flatness = [[usize; SPANS]; 4];

/// One run's score: the table by ring and the points by the flatness around them.
struct Scored {
    table: Table,
    flat: Flatness,
}

/// The range ring of a point, by its horizontal distance from the laser.
fn ring(p: &[f64; 3]) -> Option<usize> {
    ring_of(p[0].hypot(p[1]))
}

fn design(described: Described) -> Result<Design<L>, String> {
    #[allow(clippy::cast_possible_truncation)]
    Design::new(
        terrain_pyramid::SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: (described.psi_deg as f32).to_radians(),
            sigma_m: 0.02,
            height_m: described.height_m as f32,
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

/// The column of [`Flatness`] a span (metres) falls in.
fn span_column(span: f64) -> usize {
    SPAN_BOUNDS_M
        .iter()
        .position(|&b| span < b)
        .unwrap_or(SPANS - 1)
}

/// What the scan's returns count as: their rows and curb rows ([`truth`]), the height span
/// around them ([`local_spans`]) and whether they are clear ground in a ground-only cell
/// ([`in_ground_only_cells`]).
struct Truth {
    rows: Vec<Option<usize>>,
    bands: Vec<CurbRows>,
    spans: Vec<f64>,
    ground_only: Vec<bool>,
}

impl Truth {
    /// The truth of `points` (classes `classes`) for the design's cells, each return in its
    /// own band's layer (by its horizontal distance from the laser).
    fn new(points: &[[f64; 3]], classes: &[u32], design: &Design<L>) -> Self {
        let (rows, bands) = truth(points, classes, -HEIGHT_M, ROBOT_HEIGHT_M, RANGE_M);
        let layers = design.layers();
        // The bands run on from 0 m, the last one closed at the range.
        let band = |q: &[f64; 3]| {
            let d = q[0].hypot(q[1]);
            let last = layers.len().checked_sub(1)?;
            layers
                .iter()
                .position(|l| d < f64::from(l.band_outer_m))
                .or_else(|| (d <= RANGE_M).then_some(last))
        };
        // Each layer's cell size as the pyramid rounds it.
        let resolutions: Vec<Option<Resolution>> = layers
            .iter()
            .map(|l| Resolution::from_m(l.resolution_m))
            .collect();
        let cell = |k: usize, q: &[f64; 3]| {
            resolutions.get(k).copied().flatten().map(|r| {
                (
                    r.cell_of(Meters::saturating_from_num(q[0])),
                    r.cell_of(Meters::saturating_from_num(q[1])),
                )
            })
        };
        let ground_only = in_ground_only_cells(
            points,
            classes,
            &rows,
            (-HEIGHT_M, ROBOT_HEIGHT_M),
            layers.len(),
            band,
            cell,
        );
        Self {
            rows,
            bands,
            spans: local_spans(points),
            ground_only,
        }
    }
}

/// The table of a map, `fused(x, y)` its fused answer at a point (metres), at the returns
/// `points` with their truth.
fn score(fused: impl Fn(f64, f64) -> Fused, points: &[[f64; 3]], truth: &Truth) -> Scored {
    let mut t: Table = [[(0, 0); RINGS]; ROWS.len()];
    let mut flat: Flatness = [[0; SPANS]; 4];
    let each = points
        .iter()
        .zip(&truth.rows)
        .zip(&truth.bands)
        .zip(&truth.spans)
        .zip(&truth.ground_only);
    for ((((q, row), band), span), ground_only) in each {
        let (Some(row), Some(r)) = (*row, ring(q)) else {
            continue;
        };
        let band = if row == CURB_ROW { *band } else { [None; 2] };
        let right = if row == 0 {
            matches!(fused(q[0], q[1]), Fused::Navigable { .. })
        } else {
            obstacle_near_with(&fused, q[0], q[1])
        };
        let flat_row = if row == GROUND_ROW { 2 } else { 0 };
        let column = span_column(*span);
        flat[flat_row + 1][column] += 1;
        flat[flat_row][column] += usize::from(!right);
        for k in [
            Some(row),
            (row != GROUND_ROW).then_some(EVERY_OBSTACLE_ROW),
            ground_only.then_some(GROUND_ONLY_ROW),
            band[0],
            band[1],
        ]
        .into_iter()
        .flatten()
        {
            t[k][r].0 += 1;
            t[k][r].1 += usize::from(right);
        }
    }
    Scored { table: t, flat }
}

/// Adds `t`'s points and rights to `sum`'s, cell by cell.
fn add_into(sum: &mut Scored, t: &Scored) {
    for (a, c) in sum.table.iter_mut().flatten().zip(t.table.iter().flatten()) {
        *a = (a.0 + c.0, a.1 + c.1);
    }
    for (a, c) in sum.flat.iter_mut().flatten().zip(t.flat.iter().flatten()) {
        *a += c;
    }
}

/// A row's points and rights summed over the rings.
fn total(row: &[(usize, usize)]) -> (usize, usize) {
    row.iter().fold((0, 0), |a, c| (a.0 + c.0, a.1 + c.1))
}

fn cell((n, ok): (usize, usize)) -> String {
    if n == 0 {
        return "–".into();
    }
    #[allow(clippy::cast_precision_loss)]
    let pct = 100.0 * ok as f64 / n as f64;
    format!("{pct:.1} % ({ok} / {n})")
}

fn print(title: &str, scored: &Scored) {
    let t = &scored.table;
    println!("\n### {title}\n");
    let names: Vec<String> = (0..RINGS).map(ring_name).collect();
    println!("| points on | {} | all |", names.join(" | "));
    println!("|{}", " --- |".repeat(RINGS + 2));
    for (name, row) in PRINT_ORDER.iter().map(|&k| (ROWS[k], &t[k])) {
        let all = total(row);
        let cells: Vec<String> = row.iter().map(|&c| cell(c)).collect();
        println!("| {name} | {} | {} |", cells.join(" | "), cell(all));
    }
    print_flatness(&scored.flat);
}

/// The flatness table: the points by the height span of every return within
/// [`SPAN_RADIUS_M`] of them, and what share of each row's points each column holds.
fn print_flatness(flat: &Flatness) {
    println!(
        "\nThe same points by the height span of every return within {SPAN_RADIUS_M} m of them:\n"
    );
    let cm = |m: f64| format!("{:.0}", m * 100.0);
    let names: Vec<String> = SPAN_BOUNDS_M
        .first()
        .map(|&b| format!("< {} cm", cm(b)))
        .into_iter()
        .chain(
            SPAN_BOUNDS_M
                .windows(2)
                .map(|w| format!("{}–{} cm", cm(w[0]), cm(w[1]))),
        )
        .chain(SPAN_BOUNDS_M.last().map(|&b| format!("≥ {} cm", cm(b))))
        .collect();
    println!("| points | {} | all |", names.join(" | "));
    println!("|{}", " --- |".repeat(SPANS + 2));
    for (name, row) in FLAT_ROWS.iter().zip(flat) {
        let all: usize = row.iter().sum();
        let cells: Vec<String> = row.iter().map(|&n| cell((all, n))).collect();
        println!("| {name} | {} | {all} |", cells.join(" | "));
    }
}

/// The rules and the orders every scan runs under, in the order the tables are printed, and
/// the bound of the witness pairs ([`BOUND`]) last.
const RUNS: usize = 5;

/// The last table's name: the most a rule could mark on the scan's returns.
const BOUND: &str = "bound: the witness pairs of the scan's returns";

/// The map of the witness pairs (`navigability::witness`) among `points`: obstacle in the 0.1 m
/// cell of each pair's upper return, navigable elsewhere. The most a rule that keeps every
/// surface no steeper than 20° with steps of at most 5 cm navigable can mark on these returns,
/// as `lab experiments` bounds the simulated street (there at the true points; here the
/// returns as measured, their noise included).
fn witness_map(points: &[[f64; 3]]) -> impl Fn(f64, f64) -> Fused {
    #[allow(clippy::cast_possible_truncation)]
    let cell = |x: f64, y: f64| ((x / 0.1).floor() as i64, (y / 0.1).floor() as i64);
    let cells: std::collections::HashSet<(i64, i64)> = witnesses(points, &Witness::library())
        .iter()
        .map(|p| cell(p[0], p[1]))
        .collect();
    move |x, y| {
        if cells.contains(&cell(x, y)) {
            Fused::Obstacle { layer: 0 }
        } else {
            Fused::Navigable { layer: 0 }
        }
    }
}

/// One scan's tables, one per rule and order and the bound ([`RUNS`]), and its one-line
/// summary.
fn score_scan(
    bin: &str,
    label: &str,
    design: &Design<L>,
    described: Described,
    classifier: &mut Classifier<SLOTS, L>,
) -> Result<([(String, Scored); RUNS], String), String> {
    let (points, classes) = load(bin, label)?;
    let truth = Truth::new(&points, &classes, design);
    let count = |row: usize| truth.rows.iter().filter(|r| **r == Some(row)).count();
    let mut summary = format!(
        "{bin}: {} points; within {RANGE_M} m: {} clear ground, {} curb, {} post, {} block, {} vegetation, {} other (obstacles below {ROBOT_HEIGHT_M} m over the ground plane)",
        points.len(),
        count(GROUND_ROW),
        count(CURB_ROW),
        count(POST_ROW),
        count(BLOCK_ROW),
        count(VEGETATION_ROW),
        count(OTHER_ROW),
    );
    // Each order, and whether it is a spinning laser's firing order.
    let orders = [
        ("file order", points.clone(), false),
        (
            "firing order",
            firing_order(&points, [0.0; 3], described.psi_deg.to_radians()),
            true,
        ),
    ];
    let rules = [
        (
            "plane (default)",
            NavigabilityRule::Plane(PlaneRule::DEFAULT),
        ),
        ("spread (paper)", NavigabilityRule::Spread),
    ];
    let mut tables: Vec<(String, Scored)> = Vec::with_capacity(RUNS);
    for (rule_name, rule) in rules {
        for (order_name, ordered, firing) in &orders {
            // In firing order the plane rule pairs each return with the last three of its
            // cell, as `pyramid replay` sets it for a spinning laser's file.
            let rule = if *firing {
                rule.for_firing_order()
            } else {
                rule
            };
            classifier.configure(ClassifierConfig {
                rule,
                ..ClassifierConfig::default()
            });
            let obs = Observation {
                sensor: [0.0, 0.0, 0.0],
                ground_z: -described.height_m,
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
                score(|x, y| fused_at(&p, x, y), &points, &truth),
            ));
        }
    }
    tables.push((
        BOUND.to_string(),
        score(witness_map(&points), &points, &truth),
    ));
    // Each rule in firing order, the way a device receives a spinning laser, and the bound.
    for (name, t) in tables.iter().skip(1).step_by(2).chain(tables.last()) {
        let all = |row: usize| cell(total(&t.table[row]));
        summary.push_str(&format!(
            "\n  {name}: clear ground {} (in ground-only cells {}), curb {}, post {}, every obstacle {}",
            all(GROUND_ROW),
            all(GROUND_ONLY_ROW),
            all(CURB_ROW),
            all(POST_ROW),
            all(EVERY_OBSTACLE_ROW)
        ));
    }
    let tables: [(String, Scored); RUNS] = tables
        .try_into()
        .map_err(|_| "a rule or an order is missing".to_string())?;
    Ok((tables, summary))
}

/// Every scan of `pairs` (`SCAN.bin`, `SCAN.label`), each summed into the printed tables.
fn run(pairs: &[(String, String)], described: Described) -> Result<(), String> {
    let design = design(described)?;
    let mut classifier: Box<Classifier<SLOTS, L>> = navigability::classifier(&design);
    let mut sums: Option<[(String, Scored); RUNS]> = None;
    for (bin, label) in pairs {
        let (tables, summary) = score_scan(bin, label, &design, described, &mut classifier)?;
        println!("{summary}");
        match &mut sums {
            None => sums = Some(tables),
            Some(sums) => {
                for ((_, sum), (_, t)) in sums.iter_mut().zip(&tables) {
                    add_into(sum, t);
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

/// The usage line.
const USAGE: &str = "usage: semantic_kitti [--height-m H] [--psi-deg P] SCAN.bin SCAN.label [SCAN.bin SCAN.label ...] (SemanticKITTI's velodyne/ and labels/ files; H and P the design's laser height, metres, and azimuth step, degrees, as `pyramid replay` takes them: KITTI's 1.73 and 0.09 unless given)";

/// The design's flags and the scan pairs from the command line.
fn parse(args: &[String]) -> Result<(Described, Vec<(String, String)>), String> {
    let mut described = Described::KITTI;
    let mut rest = args;
    while let [flag, value, tail @ ..] = rest {
        let target = match flag.as_str() {
            "--height-m" => &mut described.height_m,
            "--psi-deg" => &mut described.psi_deg,
            _ => break,
        };
        *target = value
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
            .ok_or_else(|| format!("{flag}: {value:?} is not a positive number"))?;
        rest = tail;
    }
    if rest.is_empty() || !rest.len().is_multiple_of(2) || rest.iter().any(|a| a.starts_with("--"))
    {
        return Err(USAGE.to_string());
    }
    let pairs = rest
        .chunks_exact(2)
        .map(|c| (c[0].clone(), c[1].clone()))
        .collect();
    Ok((described, pairs))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (described, pairs) = match parse(&args) {
        Ok(parsed) => parsed,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    // The classifier's scratch and the pyramid are built in place before they are boxed.
    let outcome = std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || run(&pairs, described))
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
