//! The fixed-point classifier against the f64 reference, on random scenes, under both rules.
//!
//! Both see the same points (coordinates quantised to Q16.16 first, so cell assignment is
//! not what is tested here) and the same gate decision (whether a layer takes a point at a
//! distance: the library's gate table, itself checked against the reference elsewhere).
//! The library keeps z in millimetres and updates each cell incrementally; the reference keeps
//! every point.
//!
//! - The paper's spread rule: cells whose true spread lies within 2 mm of the step threshold,
//!   or with a point within 2 mm of the overhang cut, are left out of the comparison (the
//!   millimetre quantisation decides them).
//! - The plane rule: the library also quantises each point's position in its cell to 1/64 of
//!   the cell, judges σ_z at the lower edge of the closest look's gate bin and samples a cell's
//!   points past 62 of them, and restarts its sums from the best bound still known when a new
//!   lowest point moves the overhang cut below summed points; cells whose reference test
//!   ratios lie within 15 % of a threshold, whose pair test would cross its threshold were a
//!   pair's run 3/64 of the cell longer or shorter (the place's quantisation), with a pair
//!   across an edge whose run or rise lies that close to its bound, or with a point within
//!   2 mm of the overhang cut, are left out.

use proptest::prelude::*;
use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule, PlaneRule};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, EvidenceClass, GateShape, Meters, Schedule, SensorModel,
};
use terrain_pyramid_host_tests::classify::{
    classify, classify_after, RefClassifierConfig, RefPoint, RefRule,
};
use terrain_pyramid_host_tests::harness::{
    add_ref_points, evidence_by_cell, gate_feeds, layer_resolutions_m,
};

fn design(gate: GateShape) -> DefaultDesign {
    let schedule = Schedule {
        gate,
        ..Schedule::default()
    };
    DefaultDesign::new(SensorModel::default(), schedule, 64).unwrap()
}

fn pyramid(design: &DefaultDesign) -> Box<DefaultPyramid> {
    let mut p = Box::new(DefaultPyramid::new());
    p.configure(design, &Config::default()).unwrap();
    p
}

/// Whether the pair test's ratio, were every run 3/64 of a cell longer or shorter
/// (`RefRecord::pair_ratio_span`), may lie on either side of 1.
fn spans_one((lowest, highest): (f64, f64)) -> bool {
    lowest <= 1.0 && highest >= 1.0
}

fn q(v: f64) -> f64 {
    Meters::from_num(v).to_num::<f64>()
}

/// Which rule both sides run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rule {
    Spread,
    Plane,
    /// The plane rule with each point paired with the three before it in its cell (a
    /// spinning multi-beam laser's firing order).
    PlaneThreeBack,
}

/// Runs both classifiers; returns (compared cells, disagreements).
fn compare(points: &[(f64, f64, f64)], gate: GateShape, rule: Rule) -> (usize, usize) {
    compare_with(points, &design(gate), rule, rule)
}

/// [`compare`] in `design`, the library under `rule` and the reference under
/// `reference_rule`.
fn compare_with(
    points: &[(f64, f64, f64)],
    design: &DefaultDesign,
    rule: Rule,
    reference_rule: Rule,
) -> (usize, usize) {
    let (points, design) = (points.to_vec(), design.clone());
    on_a_large_stack(move || compare_with_on(&points, &design, rule, reference_rule))
}

/// Runs `f` on a thread of 64 MiB of stack: a classifier of 16 384 slots (1.2 MB) is built
/// before it is boxed, and may be moved once on the way.
fn on_a_large_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap()
}

/// [`compare_with`] on the calling thread.
fn compare_with_on(
    points: &[(f64, f64, f64)],
    design: &DefaultDesign,
    rule: Rule,
    reference_rule: Rule,
) -> (usize, usize) {
    let design = design.clone();
    let p = pyramid(&design);
    let pts: Vec<RefPoint> = points
        .iter()
        .map(|&(x, y, z)| {
            let (x, y, z) = (q(x), q(y), q(z));
            RefPoint {
                x,
                y,
                z,
                distance: q((x * x + y * y).sqrt()),
            }
        })
        .collect();
    let mut c = Box::new(Classifier::<16_384, 8>::new());
    c.configure(ClassifierConfig {
        rule: match rule {
            Rule::Spread => NavigabilityRule::Spread,
            Rule::Plane => NavigabilityRule::DEFAULT,
            Rule::PlaneThreeBack => NavigabilityRule::Plane(PlaneRule::DEFAULT.with_pair_depth(3)),
        },
        ..ClassifierConfig::default()
    });
    c.adopt_design(&design, p.increments()).unwrap();
    c.begin(Meters::ZERO);
    add_ref_points(&mut c, &pts);
    let lib = evidence_by_cell(&mut c, |e| (e.class, e.weight));
    assert_eq!(c.stats().overflow_points, 0);
    let resolutions = layer_resolutions_m(&p);
    let gates = c.gates();
    let feeds = gate_feeds(gates, p.increments());
    let config = RefClassifierConfig {
        rule: match reference_rule {
            Rule::Spread => RefRule::Spread,
            Rule::Plane => RefRule::plane(),
            Rule::PlaneThreeBack => RefRule::plane_paired(3),
        },
        ..RefClassifierConfig::default()
    };
    let reference = classify(&pts, &resolutions, feeds, -1.0, 0.0, &config);
    assert_eq!(
        lib.keys().collect::<Vec<_>>(),
        reference.keys().collect::<Vec<_>>(),
        "the same cells are touched"
    );
    let mut compared = 0;
    let mut differ = 0;
    for (key, r) in &reference {
        let (class, weight) = lib[key];
        // The library weighs the record at the closest look.
        assert_eq!(
            weight,
            gates.weight_at(key.0, Meters::from_num(r.distance)),
            "closest look"
        );
        let near = match reference_rule {
            Rule::Spread => (r.spread - 0.05).abs() < 0.002,
            Rule::Plane | Rule::PlaneThreeBack => {
                let close = |ratio: f64| ratio > 0.85 && ratio < 1.15;
                close(r.residual_ratio)
                    || close(r.rise_ratio)
                    || close(r.pair_ratio)
                    || spans_one(r.pair_ratio_span)
            }
        };
        if near || r.cut_margin < 0.002 || r.edge_margin < 1.0 || r.across_margin < 1.0 {
            continue;
        }
        compared += 1;
        if (class == EvidenceClass::Obstacle) != r.obstacle {
            differ += 1;
        }
    }
    (compared, differ)
}

/// Quantised reference points of `points` (x, y, z in m; the distance from the origin).
fn ref_points(points: &[(f64, f64, f64)]) -> Vec<RefPoint> {
    points
        .iter()
        .map(|&(x, y, z)| {
            let (x, y, z) = (q(x), q(y), q(z));
            RefPoint {
                x,
                y,
                z,
                distance: q((x * x + y * y).sqrt()),
            }
        })
        .collect()
}

/// Two observations in a row under the plane rule, the first with reference height `first_z`
/// (m) and the second with 0 (the library stores heights relative to them): the second's
/// verdicts of the library against the reference's, which makes every pair of a cell's first
/// point with the first observation's lowest ([`classify_after`]) where the library makes
/// those its slots still hold. So the library marks no cell the reference does not
/// (`invented`), and every cell the reference marks by the second observation alone
/// (`lost`). Returns (compared cells, invented, lost, cells the library marks only through the
/// first observation).
fn compare_after(
    first: &[(f64, f64, f64)],
    second: &[(f64, f64, f64)],
    first_z: f64,
) -> (usize, usize, usize, usize) {
    let (first, second) = (first.to_vec(), second.to_vec());
    on_a_large_stack(move || compare_after_on(&first, &second, first_z))
}

/// [`compare_after`] on the calling thread.
fn compare_after_on(
    first: &[(f64, f64, f64)],
    second: &[(f64, f64, f64)],
    first_z: f64,
) -> (usize, usize, usize, usize) {
    let design = design(GateShape::default());
    let p = pyramid(&design);
    let (first, second) = (ref_points(first), ref_points(second));
    let mut c = Box::new(Classifier::<16_384, 8>::new());
    c.adopt_design(&design, p.increments()).unwrap();
    c.begin(Meters::from_num(first_z));
    add_ref_points(&mut c, &first);
    let _ = evidence_by_cell(&mut c, |e| (e.class, e.weight));
    c.begin(Meters::ZERO);
    add_ref_points(&mut c, &second);
    let lib = evidence_by_cell(&mut c, |e| (e.class, e.weight));
    assert_eq!(c.stats().overflow_points, 0);
    let resolutions = layer_resolutions_m(&p);
    let config = RefClassifierConfig::default();
    let feeds = gate_feeds(c.gates(), p.increments());
    let (_, lowest) = classify_after(&first, &resolutions, feeds, -1.0, 0.0, &config, None);
    let feeds = gate_feeds(c.gates(), p.increments());
    let (after, _) = classify_after(
        &second,
        &resolutions,
        feeds,
        -1.0,
        0.0,
        &config,
        Some(&lowest),
    );
    let feeds = gate_feeds(c.gates(), p.increments());
    let alone = classify(&second, &resolutions, feeds, -1.0, 0.0, &config);
    let (mut compared, mut invented, mut lost, mut through_last) = (0, 0, 0, 0);
    for (key, r) in &after {
        let a = &alone[key];
        let close = |ratio: f64| ratio > 0.85 && ratio < 1.15;
        let near = |r: &terrain_pyramid_host_tests::classify::RefRecord| {
            close(r.residual_ratio)
                || close(r.rise_ratio)
                || close(r.pair_ratio)
                || spans_one(r.pair_ratio_span)
                || r.cut_margin < 0.002
                || r.edge_margin < 1.0
                || r.across_margin < 1.0
        };
        if near(r) || near(a) {
            continue;
        }
        compared += 1;
        let marked = lib[key].0 == EvidenceClass::Obstacle;
        invented += usize::from(marked && !r.obstacle);
        lost += usize::from(!marked && a.obstacle);
        through_last += usize::from(marked && !a.obstacle);
    }
    (compared, invented, lost, through_last)
}

/// A riser between two observations: the first saw the ground before it, the second only the
/// tread behind it (a nodding lidar's lines of the up and the down sweep). Neither marks the
/// riser by its own points; the second does, as the reference does, through the first's lowest
/// returns. The first observation's reference height differs from the second's, so the
/// library's heights must be brought to one reference.
#[test]
fn a_riser_between_two_observations_is_marked() {
    // Lines across the x axis at 2.0 and 2.1 m (ground, z = −1) and at 2.3 m (tread, 0.17 m
    // up): 0.17 m over 0.2–0.3 m, steeper than 20°.
    let line = |x: f64, z: f64| (0..40).map(move |i| (x, -1.0 + 0.05 * f64::from(i), z));
    let ground: Vec<_> = line(2.0, -1.0).chain(line(2.1, -1.0)).collect();
    let tread: Vec<_> = line(2.3, -0.83).chain(line(2.4, -0.83)).collect();
    let (compared, invented, lost, through_last) = compare_after(&ground, &tread, 0.25);
    assert!(compared > 0);
    assert_eq!((invented, lost), (0, 0), "of {compared}");
    assert!(
        through_last > 0,
        "the riser is marked through the last observation"
    );
    // The other way round (the tread first, then the ground) marks nothing new: the last
    // observation's cells are never marked again, and the ground below is no step up.
    let (_, invented, lost, through_last) = compare_after(&tread, &ground, 0.0);
    assert_eq!((invented, lost, through_last), (0, 0, 0));
}

fn scene() -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
    prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, -0.3..2.2f64), 1..400)
}

/// Terrain-like scenes for the plane rule: points on a tilted plane with noise over part of the
/// area, a step of a random height along a random line, and random clutter.
fn terrain() -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
    (
        -0.6..0.6f64,
        -0.6..0.6f64,
        0.0..0.08f64,
        -0.12..0.12f64,
        -1.0..1.0f64,
        prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, 0.0..1.0f64), 50..600),
        prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, -0.3..2.2f64), 0..30),
    )
        .prop_map(|(gx, gy, noise, step, at, ground, clutter)| {
            ground
                .into_iter()
                .map(|(x, y, u)| {
                    // A deterministic "noise" from the draw itself.
                    let e = noise * (2.0 * u - 1.0);
                    let z = -1.0 + gx * x + gy * y + e + if x > at { step } else { 0.0 };
                    (x, y, z)
                })
                .chain(clutter)
                .collect()
        })
}

/// The reach of the ring laser's street comparison, metres.
const RANGE_M: f64 = 14.0;

/// One revolution of the simulated car's ring laser (68 beams, 0.2° azimuth step, σ 2 cm) on
/// the simulated street (15 cm and 10 cm curbs, poles, a car, stairs, a ramp) in its firing
/// order, the returns ahead (within 45° of its heading) and within [`RANGE_M`], relative to the sensor less 1 m (the harness's ground
/// plane is 1 m below the sensor).
fn ring_laser_street() -> Vec<(f64, f64, f64)> {
    use terrain_pyramid_host_tests::sim::cloud::RingLaser;

    use terrain_pyramid_host_tests::sim::rng::Rng;
    use terrain_pyramid_host_tests::sim::scene::Scene;
    use terrain_pyramid_host_tests::sim::trajectory::Pose;
    let scene = Scene::street(0.05);
    let pose = Pose {
        x: 3.0,
        z: scene.ground_height(3.0, 0.0),
        ..Pose::default()
    };
    let obs = RingLaser::car(0.02).scan(&scene, &pose, &mut Rng::new(1));
    obs.points
        .iter()
        .map(|p| {
            (
                p[0] - obs.sensor[0],
                p[1] - obs.sensor[1],
                p[2] - obs.sensor[2],
            )
        })
        .filter(|&(x, y, _)| x.hypot(y) < RANGE_M && x > y.abs())
        .collect()
}

/// A spinning multi-beam laser's street in firing order (the order the deeper pairs are
/// for): the library pairing each return with the last three of its cell agrees with the
/// reference doing the same on at least 98 % of the cells compared.
#[test]
fn three_back_on_a_ring_lasers_street_is_the_references() {
    let points = ring_laser_street();
    assert!(points.len() > 10_000, "{}", points.len());
    // The car laser's street design (`sim::cloud::car_design`) to 14 m from 0.2 m cells: the
    // default pyramid's eight layers of 64² cells.
    let street = DefaultDesign::new(
        SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: 0.2_f32.to_radians(),
            sigma_m: 0.02,
            height_m: 1.3,
            max_range_m: RANGE_M as f32,
        },
        Schedule {
            base_m: 0.2,
            gamma: 3.0,
            ..Schedule::default()
        },
        64,
    )
    .unwrap();
    let three = Rule::PlaneThreeBack;
    let (compared, differ) = compare_with(&points, &street, three, three);
    assert!(compared > 1_000, "{compared}");
    assert!(differ * 50 <= compared, "{differ} of {compared}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The spread rule, points arriving lowest first: the incremental rule is exact, so the
    /// two agree on every cell away from the threshold.
    #[test]
    fn spread_ascending_z_agrees_exactly(mut points in scene(), hard in any::<bool>()) {
        points.sort_by(|a, b| a.2.total_cmp(&b.2));
        let gate = if hard { GateShape::Hard } else { GateShape::default() };
        let (_, differ) = compare(&points, gate, Rule::Spread);
        prop_assert_eq!(differ, 0);
    }

    /// The spread rule, points in any order: the incremental rule may underestimate a spread
    /// when a lower point arrives after the cut moved; it never invents one. Agreement stays
    /// high.
    #[test]
    fn spread_any_order_agrees_closely(points in scene()) {
        let (compared, differ) = compare(&points, GateShape::default(), Rule::Spread);
        prop_assert!(differ * 20 <= compared.max(1), "{differ} of {compared}");
    }

    /// The plane rule, points lowest first (no restart of the sums by a new lowest point):
    /// away from its thresholds the fixed point agrees on at least 98 % of the cells.
    #[test]
    fn plane_ascending_z_agrees(mut points in terrain(), hard in any::<bool>()) {
        points.sort_by(|a, b| a.2.total_cmp(&b.2));
        let gate = if hard { GateShape::Hard } else { GateShape::default() };
        let (compared, differ) = compare(&points, gate, Rule::Plane);
        prop_assert!(differ * 50 <= compared.max(1), "{differ} of {compared}");
    }

    /// The plane rule, points in any order, clutter included: at least 95 %.
    #[test]
    fn plane_any_order_agrees_closely(points in terrain(), hard in any::<bool>()) {
        let gate = if hard { GateShape::Hard } else { GateShape::default() };
        let (compared, differ) = compare(&points, gate, Rule::Plane);
        prop_assert!(differ * 20 <= compared.max(1), "{differ} of {compared}");
    }

    /// The plane rule pairing each point with the three before it in its cell: lowest first
    /// at least 98 %, in any order at least 95 %, as with one.
    #[test]
    fn plane_three_back_agrees(mut points in terrain(), sorted in any::<bool>()) {
        if sorted {
            points.sort_by(|a, b| a.2.total_cmp(&b.2));
        }
        let (compared, differ) = compare(&points, GateShape::default(), Rule::PlaneThreeBack);
        let share = if sorted { 50 } else { 20 };
        prop_assert!(differ * share <= compared.max(1), "{differ} of {compared}");
    }

    /// Two observations of terrain in a row, split where the step lies or at random: the
    /// library marks at most 5 % of the cells compared that the reference, pairing with the
    /// first's lowest returns, does not, and leaves at most 5 % unmarked that the reference
    /// marks by the second alone (as one observation in any order agrees). A split near either
    /// end leaves the second a few cells; under 20 compared, 5 % is less than one cell, and
    /// one may differ (the order's approximations: a new lowest point restarting a cell's sums
    /// drops a pair the reference keeps).
    #[test]
    fn two_observations_agree(points in terrain(), split in 0.0..1.0f64, by_x in any::<bool>(), first_z in -0.5..0.5f64) {
        let (first, second): (Vec<_>, Vec<_>) = points.iter().enumerate().partition(|&(i, p)| {
            if by_x {
                p.0 < 6.0 * split - 3.0
            } else {
                #[allow(clippy::cast_precision_loss)]
                let f = i as f64 / points.len() as f64;
                f < split
            }
        });
        let first: Vec<_> = first.into_iter().map(|(_, &p)| p).collect();
        let second: Vec<_> = second.into_iter().map(|(_, &p)| p).collect();
        let (compared, invented, lost, _) = compare_after(&first, &second, first_z);
        prop_assert!(invented * 20 <= compared.max(20), "{invented} invented of {compared}");
        prop_assert!(lost * 20 <= compared.max(20), "{lost} lost of {compared}");
    }

    /// Random clutter under the plane rule (the same scenes as the spread tests): when a new
    /// lowest point moves the overhang cut below summed points, the library restarts its sums
    /// from the best bound still known (the lowest and the previous lowest) and the reference
    /// keeps every point; random clutter arriving in random order is the worst case of that
    /// approximation: within 10 %.
    #[test]
    fn plane_on_clutter_agrees(points in scene()) {
        let (compared, differ) = compare(&points, GateShape::default(), Rule::Plane);
        prop_assert!(differ * 10 <= compared.max(1), "{differ} of {compared}");
    }
}
