//! The classifier's unit tests: the slot table, the overhang and spread rules, the gates, the
//! drop-off, ceiling and missing-ground options, and the 32-bit cell arithmetic.

use super::scratch::*;
use super::*;
use crate::design::{Design, GateShape, Schedule, SensorModel};
use crate::pyramid::Config;
use crate::test_rng::XorShift;
use crate::Fused;
extern crate std;
use std::vec::Vec;

fn design(gate: GateShape) -> Design<8> {
    let schedule = Schedule {
        gate,
        ..Schedule::default()
    };
    Design::<8>::new(SensorModel::default(), schedule, 64).unwrap()
}

fn pyramid(gate: GateShape) -> Pyramid<64, 8> {
    let mut p = Pyramid::new();
    p.configure(&design(gate), &Config::default()).unwrap();
    p
}

/// A classifier of `C` slots with the default thresholds and the gating of the default
/// design with `gate`.
fn classifier<const C: usize>(gate: GateShape) -> Classifier<C, 8> {
    let mut c = Classifier::new();
    adopt(&mut c, gate);
    c
}

fn adopt<const C: usize>(c: &mut Classifier<C, 8>, gate: GateShape) {
    let increments = Config::default().model.increments().unwrap();
    c.adopt_design(&design(gate), increments).unwrap();
}

fn pt(x: f32, y: f32, z: f32) -> Point3 {
    Point3 {
        x: Meters::from_num(x),
        y: Meters::from_num(y),
        z: Meters::from_num(z),
    }
}

/// Configures `c` with `config` and begins an observation at ground level 0 with `points`,
/// each at horizontal distance `d`.
fn observe(c: &mut Classifier<256, 8>, config: ClassifierConfig, points: &[Point3], d: Meters) {
    c.configure(config);
    c.begin(Meters::ZERO);
    for &q in points {
        c.add_point(q, d, Meters::ZERO);
    }
}

fn records(c: &mut Classifier<256, 8>) -> Vec<Evidence> {
    let mut out = Vec::new();
    c.finish(|r| out.push(r));
    out
}

#[test]
fn flat_ground_is_navigable_and_a_step_is_an_obstacle() {
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    // Cell (3, 0) of layer 0: flat within 2 cm.
    c.add_point(pt(0.31, 0.02, 0.00), d, Meters::ZERO);
    c.add_point(pt(0.35, 0.05, 0.02), d, Meters::ZERO);
    // Cell (2, 0): a 10 cm step.
    c.add_point(pt(0.21, 0.02, 0.00), d, Meters::ZERO);
    c.add_point(pt(0.25, 0.05, 0.10), d, Meters::ZERO);
    let mut r = records(&mut c);
    r.sort_by_key(|e| e.cell_x);
    assert_eq!(r.len(), 2);
    assert_eq!((r[0].cell_x, r[0].class), (2, EvidenceClass::Obstacle));
    assert_eq!((r[1].cell_x, r[1].class), (3, EvidenceClass::Navigable));
    let w = c.gates().weight_at(0, d);
    assert!(r.iter().all(|e| e.layer == 0 && e.weight == w));
    assert_eq!(c.cells_in_use(), 0);
}

#[test]
fn overhang_above_the_robot_is_ignored_in_any_order() {
    let d = Meters::from_num(0.2);
    for order in [[0.0, 1.5, 0.01], [1.5, 0.0, 0.01], [1.5, 0.01, 0.0]] {
        let mut c = classifier::<256>(GateShape::Hard);
        c.begin(Meters::ZERO);
        for z in order {
            c.add_point(pt(0.05, 0.05, z), d, Meters::ZERO);
        }
        let r = records(&mut c);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].class, EvidenceClass::Navigable, "{order:?}");
    }
}

#[test]
fn mm_i16_is_the_64_bit_floor() {
    let reference = |raw: i32| {
        let mm = (i64::from(raw) * 1000) >> 16;
        i16::try_from(mm).unwrap_or(if mm < 0 { i16::MIN } else { i16::MAX })
    };
    let mut state = 0x9E37_79B9_u32;
    for raw in (-300_000..300_000)
        .chain([i32::MIN, i32::MIN + 1, i32::MAX, i32::MAX - 1])
        .chain((0..200_000).map(|_| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as i32
        }))
    {
        assert_eq!(mm_i16(raw), reference(raw), "{raw}");
        // And the ARMv6-M form, whichever target runs the tests.
        let halves = mm_halves(raw);
        let want = (i64::from(raw) * 1000) >> 16;
        assert_eq!(i64::from(halves), want, "{raw}");
    }
    // Around the saturation points ±32 768 mm.
    for raw in 2_147_000_i32..2_148_000 {
        assert_eq!(mm_i16(raw), reference(raw));
        assert_eq!(mm_i16(-raw), reference(-raw));
    }
}

#[test]
fn add_point_squared_is_add_point_with_the_floored_root() {
    let mut a = classifier::<256>(GateShape::default());
    let mut b = classifier::<256>(GateShape::default());
    a.begin(Meters::ZERO);
    b.begin(Meters::ZERO);
    for i in 0..2000_u64 {
        let sq = (i * 7_919_u64).pow(2) * 37 + i;
        let d = Meters::from_bits(i32::try_from(sq.isqrt()).unwrap());
        let q = pt(0.01 * i as f32 - 10.0, 0.3, 0.001 * (i % 97) as f32);
        a.add_point(q, d, Meters::ZERO);
        b.add_point_squared(q, sq, Meters::ZERO);
    }
    let (ra, rb) = (records(&mut a), records(&mut b));
    assert!(!ra.is_empty());
    assert_eq!(ra, rb);
    assert_eq!(a.stats(), b.stats());
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_slot_is_72_bytes() {
    assert_eq!(core::mem::size_of::<PlaneState>(), 52);
    assert_eq!(core::mem::size_of::<Slot>(), 72);
}

#[test]
#[cfg(not(feature = "plane-rule"))]
fn without_the_plane_rule_a_slot_is_16_bytes_and_the_paper_rule_applies() {
    assert_eq!(core::mem::size_of::<PlaneState>(), 0);
    assert_eq!(core::mem::size_of::<Slot>(), 16);
    assert_eq!(ClassifierConfig::default().rule, NavigabilityRule::Spread);
    assert!(!NavigabilityRule::Plane(PlaneRule::DEFAULT).is_built_in());
    // A plane rising 6 cm across the cell, which the plane rule would call navigable: asked
    // for, the plane rule becomes the spread rule, which calls the cell an obstacle.
    let d = Meters::from_num(0.3);
    let mut c = classifier::<256>(GateShape::Hard);
    c.configure(ClassifierConfig {
        rule: NavigabilityRule::Plane(PlaneRule::DEFAULT),
        ..ClassifierConfig::default()
    });
    assert_eq!(c.config().rule, NavigabilityRule::Spread);
    assert_eq!(c.plane, None);
    c.begin(Meters::ZERO);
    for q in [pt(0.301, 0.01, 0.00), pt(0.399, 0.09, 0.06)] {
        c.add_point(q, d, Meters::ZERO);
    }
    assert_eq!(records(&mut c)[0].class, EvidenceClass::Obstacle);
}

#[test]
#[cfg(feature = "plane-rule")]
fn the_paper_rule_stays_available() {
    let d = Meters::from_num(0.3);
    // Flat ground in a 4 × 4 grid over the cell's 0.1 m, one return 6 cm up (a tuft, a stone).
    let mut cell = [pt(0.0, 0.0, 0.0); 16];
    for (i, q) in cell.iter_mut().enumerate() {
        let (u, v) = ((i % 4) as f32, (i / 4) as f32);
        *q = pt(
            0.31 + 0.025 * u,
            0.01 + 0.025 * v,
            if i == 5 { 0.06 } else { 0.0 },
        );
    }
    let mut c = classifier::<256>(GateShape::Hard);
    // The sensor 1 m above the ground: the noise allowances at 0.3 m hold its range noise.
    let classify = |c: &mut Classifier<256, 8>| {
        c.begin(Meters::ONE);
        for q in cell {
            c.add_point(q, d, Meters::ZERO);
        }
        records(c)[0].class
    };
    // The plane rule: the stray return is within the texture and noise allowances, the plane
    // is not steeper than 20° and the lone 6 cm is within the extremes' allowance: navigable.
    assert_eq!(classify(&mut c), EvidenceClass::Navigable);
    // The paper's rule: a spread of 6 cm, over the 5 cm step threshold.
    c.configure(ClassifierConfig {
        rule: NavigabilityRule::Spread,
        ..ClassifierConfig::default()
    });
    assert_eq!(classify(&mut c), EvidenceClass::Obstacle);
}

#[test]
fn new_is_the_default_configuration() {
    let fresh = Classifier::<8, 8>::new();
    let mut configured = Classifier::<8, 8>::unconfigured();
    configured.configure(ClassifierConfig::default());
    assert_eq!(fresh.config(), configured.config());
    assert_eq!(
        (fresh.robot_height_mm, fresh.step_mm, fresh.plane),
        (
            configured.robot_height_mm,
            configured.step_mm,
            configured.plane
        )
    );
}

#[test]
fn a_single_point_always_looks_navigable() {
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    c.add_point(pt(0.05, 0.05, 0.4), Meters::from_num(0.2), Meters::ZERO);
    assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
}

#[test]
fn record_weight_is_the_gate_at_the_closest_look() {
    let mut c = classifier::<256>(GateShape::default());
    c.begin(Meters::ZERO);
    c.add_point(pt(0.05, 0.05, 0.0), Meters::from_num(0.4), Meters::ZERO);
    c.add_point(pt(0.06, 0.05, 0.0), Meters::from_num(0.2), Meters::ZERO);
    c.add_point(pt(0.07, 0.05, 0.0), Meters::from_num(0.3), Meters::ZERO);
    // The closest look, 0.2 m, is kept as its gate bin: 0.2 · 32 = 6.4 → bin 6, whose
    // lower edge is 6/32 = 0.1875 m; the record carries layer 0's weight there.
    let r = records(&mut c);
    let layer0 = r.iter().find(|e| e.layer == 0).unwrap();
    let gates = c.gates();
    assert_eq!(layer0.weight, gates.weight_at(0, Meters::from_num(0.1875)));
    assert_ne!(layer0.weight, gates.weight_at(0, Meters::from_num(0.4)));
}

#[test]
fn hard_gate_sends_each_point_to_one_layer_soft_to_several() {
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    c.add_point(pt(2.0, 0.0, 0.0), Meters::from_num(2.0), Meters::ZERO);
    assert_eq!(records(&mut c).len(), 1);
    adopt(&mut c, GateShape::default());
    c.add_point(pt(2.0, 0.0, 0.0), Meters::from_num(2.0), Meters::ZERO);
    assert!(records(&mut c).len() >= 2);
}

#[test]
fn drop_offs_and_missing_ground_are_obstacles_when_enabled() {
    let d = Meters::from_num(0.3);
    for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
        let mut c = classifier::<256>(GateShape::Hard);
        // A flat patch of ground 0.5 m below the robot's ground plane, and no return where
        // the ground should have been next to it.
        let patch = [
            pt(0.31, 0.01, -0.5),
            pt(0.39, 0.01, -0.5),
            pt(0.31, 0.09, -0.5),
            pt(0.39, 0.09, -0.5),
        ];
        let config = ClassifierConfig {
            rule,
            ..ClassifierConfig::default()
        };
        observe(&mut c, config, &patch, d);
        assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
        let drop_off = ClassifierConfig {
            drop_threshold: Some(Meters::from_num(0.3)),
            ..config
        };
        observe(&mut c, drop_off, &patch, d);
        c.add_missing_ground(pt(0.15, 0.05, 0.0), d);
        let r = records(&mut c);
        assert!(
            r.iter().all(|e| e.class == EvidenceClass::Obstacle),
            "{rule:?}"
        );
        assert_eq!(r.len(), 2);
        assert_eq!(c.stats().drop_points, 4);
    }
}

#[test]
fn a_ceiling_cut_drops_roof_points_before_any_cell_sees_them() {
    let d = Meters::from_num(0.3);
    // A cell that saw only an uneven roof, 2.0 to 2.2 m above the robot's ground.
    let roof = [pt(0.35, 0.05, 2.0), pt(0.36, 0.05, 2.2)];
    for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
        let mut c = classifier::<256>(GateShape::Hard);
        let config = ClassifierConfig {
            rule,
            ..ClassifierConfig::default()
        };
        observe(&mut c, config, &roof, d);
        assert_eq!(
            records(&mut c)[0].class,
            EvidenceClass::Obstacle,
            "{rule:?}"
        );
        let cut = ClassifierConfig {
            ceiling: Some(Meters::from_num(1.5)),
            ..config
        };
        observe(&mut c, cut, &roof, d);
        assert!(records(&mut c).is_empty());
        assert_eq!(c.stats().overhang_points, 2);
    }
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_new_lowest_point_keeps_the_best_bound_in_the_plane_sums() {
    let d = Meters::from_num(0.3);
    let mut c = classifier::<256>(GateShape::Hard);
    let ground = [
        pt(0.31, 0.01, 0.0),
        pt(0.39, 0.01, 0.0),
        pt(0.31, 0.09, 0.0),
        pt(0.39, 0.09, 0.0),
    ];
    // A branch over flat ground, in either order: navigable.
    let branch = [pt(0.33, 0.04, 1.6), pt(0.37, 0.06, 1.7)];
    for order in [[&ground[..], &branch[..]], [&branch[..], &ground[..]]] {
        c.begin(Meters::ZERO);
        for q in order.concat() {
            c.add_point(q, d, Meters::ZERO);
        }
        assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
    }
    // A 0.3 m block top seen before a lower point moves the cut below a roof point: the
    // sums restart with the lowest and the block's top (the best bound below the new cut).
    let cell = [
        pt(0.33, 0.04, 0.3),
        pt(0.35, 0.05, 1.25),
        pt(0.37, 0.06, 0.0),
    ];
    c.begin(Meters::ZERO);
    for q in cell {
        c.add_point(q, d, Meters::ZERO);
    }
    assert_eq!(records(&mut c)[0].class, EvidenceClass::Obstacle);
}

#[test]
fn remembering_the_last_cell_changes_nothing() {
    // Runs of points in and around cells (their corners ± 1 raw), jumps between far cells,
    // coordinates near ±32 768 m; each classifier once as is and once forgetting the last
    // cells before every point (every point through the cell index, hash and probe).
    let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
    let mut next = || rng.next();
    let cell = Meters::from_num(0.1).to_bits();
    for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
        for gate in [GateShape::Hard, GateShape::default()] {
            let mut a = classifier::<256>(gate);
            let mut b = classifier::<256>(gate);
            for c in [&mut a, &mut b] {
                c.configure(ClassifierConfig {
                    rule,
                    ..ClassifierConfig::default()
                });
            }
            for _observation in 0..40 {
                a.begin(Meters::ZERO);
                b.begin(Meters::ZERO);
                let mut x = (next() as i32) >> (next() % 32);
                let mut y = (next() as i32) >> (next() % 32);
                for _ in 0..200 {
                    match next() % 8 {
                        0 => x = next() as i32,
                        1 => y = (next() as i32) >> (next() % 32),
                        // A cell corner of some layer (cells of 0.1 m · 2ᵏ), ± 1.
                        2 => {
                            let size = cell << (next() % 8);
                            x = x.div_euclid(size).wrapping_mul(size) + (next() % 3) as i32 - 1;
                        }
                        _ => {
                            x = x.saturating_add((next() % 2001) as i32 - 1000);
                            y = y.saturating_add((next() % 2001) as i32 - 1000);
                        }
                    }
                    let z = Meters::from_bits((next() % 200_000) as i32 - 100_000);
                    let q = Point3 {
                        x: Meters::from_bits(x),
                        y: Meters::from_bits(y),
                        z,
                    };
                    let d = Meters::from_bits((next() % (20 << 16)) as i32);
                    a.add_point(q, d, Meters::ZERO);
                    b.forget_recent();
                    b.add_point(q, d, Meters::ZERO);
                }
                let (ra, rb) = (records(&mut a), records(&mut b));
                assert!(!ra.is_empty());
                assert_eq!(ra, rb, "{rule:?} {gate:?}");
            }
            assert_eq!(a.stats(), b.stats());
        }
    }
}

#[test]
fn a_corner_in_32_bits_is_the_checked_product_within_the_limit() {
    let within = |o: Option<i32>| o.filter(|o| (-ORIGIN_LIMIT..=ORIGIN_LIMIT).contains(o));
    let mut rng = XorShift(0xD1B5_4A32_D192_ED03_u64);
    let sizes = [
        1,
        2,
        655,
        6_553,
        65_536,
        1 << 20,
        (1 << 29) + 7,
        ORIGIN_LIMIT - 1,
    ];
    for bits in sizes {
        let mut xs = std::vec![
            i32::MIN,
            i32::MIN + 1,
            i32::MIN + bits - 1,
            i32::MIN + bits,
            -ORIGIN_LIMIT - 1,
            -ORIGIN_LIMIT,
            -1,
            0,
            ORIGIN_LIMIT,
            ORIGIN_LIMIT + bits,
            i32::MAX - bits,
            i32::MAX,
        ];
        xs.extend((0..20_000).map(|_| rng.next() as i32 >> (rng.next() % 32)));
        for x in xs {
            let c = x.div_euclid(bits);
            assert_eq!(corner(c, bits), within(c.checked_mul(bits)), "{x} {bits}");
        }
    }
}

#[test]
fn every_offered_point_is_counted_once() {
    // Overhang, drop-off, used, gated out (beyond the range) and dropped on a full table.
    let mut c = classifier::<8>(GateShape::Hard);
    c.configure(ClassifierConfig {
        ceiling: Some(Meters::from_num(1.5)),
        drop_threshold: Some(Meters::from_num(0.3)),
        ..ClassifierConfig::default()
    });
    c.begin(Meters::ZERO);
    let near = Meters::from_num(0.2);
    let mut offered = 0;
    for i in 0..30 {
        let x = 0.05 + 0.1 * i as f32;
        let (z, d) = match i % 5 {
            0 => (2.0, near),
            1 => (-1.0, near),
            2 => (0.0, Meters::from_num(1000.0)),
            _ => (0.0, near),
        };
        c.add_point(pt(x - 3.0, 0.05, z), d, Meters::ZERO);
        offered += 1;
    }
    let s = c.stats();
    assert!(s.overhang_points > 0 && s.points_gated_out > 0 && s.overflow_points > 0);
    assert!(s.drop_points > 0 && s.points_used > 0);
    assert_eq!(s.points, offered);
}

#[test]
fn a_full_table_drops_and_counts_instead_of_panicking() {
    let mut c = classifier::<8>(GateShape::Hard);
    c.begin(Meters::ZERO);
    for i in 0..20 {
        let x = 0.05 + 0.1 * i as f32;
        c.add_point(pt(x - 3.0, 0.05, 0.0), Meters::from_num(0.2), Meters::ZERO);
    }
    assert_eq!(c.cells_in_use(), 8);
    assert_eq!(c.stats().overflow_points, 12);
    // A point that lost its only cell fed no layer: it is counted with the gated-out
    // ones, as `points_gated_out` says.
    assert_eq!(c.stats().points, 20);
    assert_eq!(c.stats().points_used, 8);
    assert_eq!(c.stats().points_gated_out, 12);
    let mut n = 0;
    c.finish(|_| n += 1);
    assert_eq!(n, 8);
}

#[test]
fn a_point_refused_by_one_layer_and_taken_by_another_is_used() {
    // The soft gate feeds three layers at 2 m: 0.2, 0.4 and 0.6 m cells.
    let mut c = classifier::<4>(GateShape::default());
    c.begin(Meters::ZERO);
    let d = Meters::from_num(2.0);
    c.add_point(pt(2.001, 0.001, 0.0), d, Meters::ZERO);
    assert_eq!(c.cells_in_use(), 3);
    // Another 0.2 m cell, the same 0.4 and 0.6 m ones: the table is full.
    c.add_point(pt(2.201, 0.001, 0.0), d, Meters::ZERO);
    assert_eq!(c.cells_in_use(), 4);
    // Yet another 0.2 m cell (refused: no slot left), the same 0.4 and 0.6 m cells (taken):
    // the point is used, and its refusal counted.
    c.add_point(pt(2.201, 0.201, 0.0), d, Meters::ZERO);
    let stats = c.stats();
    assert_eq!(stats.overflow_points, 1);
    assert_eq!(stats.points, 3);
    assert_eq!(stats.points_used, 3);
    assert_eq!(stats.points_gated_out, 0);
    let mut layers = Vec::new();
    c.finish(|e| layers.push(e.layer));
    assert_eq!(layers, [1, 2, 3, 1]);
}

#[test]
fn finish_into_updates_the_pyramid() {
    let mut p = pyramid(GateShape::Hard);
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    c.add_point(pt(0.21, 0.02, 0.00), d, Meters::ZERO);
    c.add_point(pt(0.25, 0.05, 0.12), d, Meters::ZERO);
    c.finish_into(&mut p);
    assert_eq!(
        p.fused(Meters::from_num(0.25), Meters::from_num(0.05)),
        Fused::Obstacle { layer: 0 }
    );
}

/// A 10 cm kerb on the edge x = 0.3 m between layer 0's cells 2 (road, z = 0) and 3
/// (pavement, z = `top`), each cell's own points flat; the road's last return `gap` m before
/// the edge and the pavement's first just after it, `down` walking from the pavement to the
/// road instead. The classes of cells 2 and 3.
#[cfg(feature = "plane-rule")]
fn kerb_on_an_edge(top: f32, gap: f32, down: bool) -> (EvidenceClass, EvidenceClass) {
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    // The road's lowest return is its first, at x = 0.2005 m.
    let road = [0.2005, 0.25, 0.28, 0.3 - gap];
    let pavement = [0.305, 0.33, 0.36, 0.39];
    let mut line: Vec<Point3> = road.iter().map(|&x| pt(x, 0.05, 0.0)).collect();
    line.extend(pavement.iter().map(|&x| pt(x, 0.05, top)));
    if down {
        line.reverse();
    }
    for q in line {
        c.add_point(q, d, Meters::ZERO);
    }
    let mut r = records(&mut c);
    r.sort_by_key(|e| e.cell_x);
    assert_eq!(r.iter().map(|e| e.cell_x).collect::<Vec<_>>(), [2, 3]);
    (r[0].class, r[1].class)
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_pair_across_a_cells_edge_marks_the_upper_cell() {
    use EvidenceClass::{Navigable, Obstacle};
    // Up the kerb and down it: the pavement's cell, never the road's.
    assert_eq!(kerb_on_an_edge(0.10, 0.005, false), (Navigable, Obstacle));
    assert_eq!(kerb_on_an_edge(0.10, 0.005, true), (Navigable, Obstacle));
    // Within the step (4 cm): nothing.
    assert_eq!(kerb_on_an_edge(0.04, 0.005, false), (Navigable, Navigable));
    // Two consecutive returns a cell's side apart or more (0.1 m) are no pair
    // (`across::tests`), but the cells' lowest returns, 0.1045 m apart, still show the kerb
    // (`edges`).
    assert_eq!(kerb_on_an_edge(0.10, 0.096, false), (Navigable, Obstacle));
    // A rise of more than the robot's height (1 m) is overhang to the lower cell: no pair.
    assert_eq!(kerb_on_an_edge(1.2, 0.005, false), (Navigable, Navigable));
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_pair_across_a_cells_edge_needs_a_steep_surface() {
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    // A 20° ramp (tan 20° = 0.364, within the largest slope) sampled every 5 cm: pairs
    // across each edge rise 1.8 cm, none beyond the slope.
    for i in 0..40_u8 {
        let x = 0.0025 + 0.05 * f32::from(i);
        c.add_point(pt(x, 0.05, 0.36 * x), d, Meters::ZERO);
    }
    let r = records(&mut c);
    assert!(
        r.iter().all(|e| e.class == EvidenceClass::Navigable),
        "{r:?}"
    );
    // A 45° face over the same edge: steeper than the robot climbs.
    c.begin(Meters::ZERO);
    c.add_point(pt(0.25, 0.05, 0.0), d, Meters::ZERO);
    c.add_point(pt(0.29, 0.05, 0.0), d, Meters::ZERO);
    c.add_point(pt(0.37, 0.05, 0.08), d, Meters::ZERO);
    c.add_point(pt(0.39, 0.05, 0.08), d, Meters::ZERO);
    let mut r = records(&mut c);
    r.sort_by_key(|e| e.cell_x);
    assert_eq!(
        r.iter().map(|e| (e.cell_x, e.class)).collect::<Vec<_>>(),
        [(2, EvidenceClass::Navigable), (3, EvidenceClass::Obstacle)]
    );
}

/// Two lines of returns parallel to the edge x = 0.3 m between layer 0's cells 2 (a road line
/// at `road_x`, z = 0) and 3 (a pavement line at `pavement_x`, z = `top`), with a return in a
/// far cell between them so that no two consecutive returns cross the edge (two sweeps of a
/// nodding lidar). `north`: the same turned by 90° (the edge y = 0.3 m). The classes of the
/// road's cell and the pavement's, under `rule`.
#[cfg(feature = "plane-rule")]
fn lines_beside_an_edge(
    top: f32,
    road_x: f32,
    pavement_x: f32,
    north: bool,
    rule: NavigabilityRule,
) -> (EvidenceClass, EvidenceClass) {
    let mut c = classifier::<256>(GateShape::Hard);
    c.configure(ClassifierConfig {
        rule,
        ..ClassifierConfig::default()
    });
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    let at = |across: f32, along: f32, z: f32| {
        if north {
            pt(along, across, z)
        } else {
            pt(across, along, z)
        }
    };
    let along = [0.01, 0.03, 0.05, 0.07, 0.09];
    for &v in &along {
        c.add_point(at(road_x, v, 0.0), d, Meters::ZERO);
    }
    c.add_point(pt(-0.55, -0.55, 0.0), d, Meters::ZERO);
    for &v in &along {
        c.add_point(at(pavement_x, v, top), d, Meters::ZERO);
    }
    let mut r = records(&mut c);
    r.retain(|e| e.cell_x >= 0 && e.cell_y >= 0);
    r.sort_by_key(|e| (e.cell_x, e.cell_y));
    let cells: Vec<(i32, i32)> = r.iter().map(|e| (e.cell_x, e.cell_y)).collect();
    assert_eq!(
        cells,
        if north {
            [(0, 2), (0, 3)]
        } else {
            [(2, 0), (3, 0)]
        }
    );
    (r[0].class, r[1].class)
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_step_between_neighbouring_cells_lowest_returns_marks_the_upper_cell() {
    use EvidenceClass::{Navigable, Obstacle};
    let plane = NavigabilityRule::Plane(PlaneRule::DEFAULT);
    for north in [false, true] {
        // A 10 cm kerb on the edge, each cell's returns flat, none consecutive across it.
        assert_eq!(
            lines_beside_an_edge(0.10, 0.295, 0.305, north, plane),
            (Navigable, Obstacle)
        );
        // Down rather than up: still the upper cell.
        assert_eq!(
            lines_beside_an_edge(-0.10, 0.295, 0.305, north, plane),
            (Obstacle, Navigable)
        );
        // Within the step (4 cm): nothing.
        assert_eq!(
            lines_beside_an_edge(0.04, 0.295, 0.305, north, plane),
            (Navigable, Navigable)
        );
        // The lowest returns almost two cells' sides apart (0.19 m): still a pair, its
        // rise beyond the largest slope (20°: 6.9 cm over the run).
        assert_eq!(
            lines_beside_an_edge(0.15, 0.205, 0.395, north, plane),
            (Navigable, Obstacle)
        );
        // A rise the largest slope explains over that run (6 cm): nothing.
        assert_eq!(
            lines_beside_an_edge(0.06, 0.205, 0.395, north, plane),
            (Navigable, Navigable)
        );
        // A rise of more than the robot's height (1 m) is overhang to the lower cell: no pair.
        assert_eq!(
            lines_beside_an_edge(1.2, 0.295, 0.305, north, plane),
            (Navigable, Navigable)
        );
        // The paper's rule judges each cell by its own spread only.
        assert_eq!(
            lines_beside_an_edge(0.10, 0.295, 0.305, north, NavigabilityRule::Spread),
            (Navigable, Navigable)
        );
    }
}

#[test]
#[cfg(feature = "plane-rule")]
fn a_single_return_above_a_neighbours_lowest_is_marked() {
    // One return fits no plane, but with the road's lowest return beside it, 10 cm lower and
    // 1 cm away across the edge x = 0.3 m, it is two returns on a kerb's face.
    let mut c = classifier::<256>(GateShape::Hard);
    c.begin(Meters::ZERO);
    let d = Meters::from_num(0.3);
    for v in [0.01, 0.03, 0.05] {
        c.add_point(pt(0.295, v, 0.0), d, Meters::ZERO);
    }
    c.add_point(pt(-0.55, -0.55, 0.0), d, Meters::ZERO);
    c.add_point(pt(0.305, 0.01, 0.1), d, Meters::ZERO);
    let mut r = records(&mut c);
    r.retain(|e| e.cell_x >= 0);
    r.sort_by_key(|e| e.cell_x);
    assert_eq!(
        r.iter().map(|e| (e.cell_x, e.class)).collect::<Vec<_>>(),
        [(2, EvidenceClass::Navigable), (3, EvidenceClass::Obstacle)]
    );
}

#[cfg(feature = "plane-rule")]
/// One observation of `points` at horizontal distance 0.3 m into `c` (reference height
/// `reference`, ground plane 0); its records.
fn observation(c: &mut Classifier<256, 8>, reference: f32, points: &[Point3]) -> Vec<Evidence> {
    c.begin(Meters::from_num(reference));
    for &q in points {
        c.add_point(q, Meters::from_num(0.3), Meters::ZERO);
    }
    records(c)
}

#[cfg(feature = "plane-rule")]
/// Cell (3, 0) of layer 0 (0.1 m): ground in its lower half, a tread 10 cm up in its upper.
fn ground_and_tread() -> ([Point3; 2], [Point3; 2]) {
    (
        [pt(0.31, 0.02, 0.0), pt(0.33, 0.05, 0.0)],
        [pt(0.37, 0.05, 0.10), pt(0.39, 0.02, 0.10)],
    )
}

#[cfg(feature = "plane-rule")]
#[test]
fn a_step_between_two_observations_marks_the_later_cell() {
    let (ground, tread) = ground_and_tread();
    // Each alone is flat.
    for points in [&ground, &tread] {
        let mut c = classifier::<256>(GateShape::Hard);
        let r = observation(&mut c, 0.0, points);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].class, EvidenceClass::Navigable);
    }
    // The ground, then the tread: 10 cm over 6–8 cm, steeper than 20°. The first observation's
    // heights are stored 0.5 m lower (its reference is 0.5 m up) and brought to one reference.
    let mut c = classifier::<256>(GateShape::Hard);
    observation(&mut c, 0.5, &ground);
    let r = observation(&mut c, 0.0, &tread);
    assert_eq!((r[0].cell_x, r[0].class), (3, EvidenceClass::Obstacle));
    // The tread, then the ground: the ground fell away from the last look; nothing marked.
    let mut c = classifier::<256>(GateShape::Hard);
    observation(&mut c, 0.0, &tread);
    let r = observation(&mut c, 0.0, &ground);
    assert_eq!(r[0].class, EvidenceClass::Navigable);
}

#[cfg(feature = "plane-rule")]
#[test]
fn only_the_last_observation_is_recalled() {
    let (ground, tread) = ground_and_tread();
    // An observation between them, elsewhere: the ground is no longer the last look.
    let mut c = classifier::<256>(GateShape::Hard);
    observation(&mut c, 0.0, &ground);
    observation(&mut c, 0.0, &[pt(0.05, 0.05, 0.0)]);
    assert_eq!(
        observation(&mut c, 0.0, &tread)[0].class,
        EvidenceClass::Navigable
    );
    // 256 observations between them bring the stamp round to the ground's: every slot's is
    // cleared on the way, so the ground is not taken for the last look.
    let mut c = classifier::<256>(GateShape::Hard);
    observation(&mut c, 0.0, &ground);
    for _ in 0..255 {
        observation(&mut c, 0.0, &[]);
    }
    assert_eq!(
        c.recall_state.last, 1,
        "the stamp came round to the ground's"
    );
    assert_eq!(
        observation(&mut c, 0.0, &tread)[0].class,
        EvidenceClass::Navigable
    );
    // A new configuration forgets the last observation.
    let mut c = classifier::<256>(GateShape::Hard);
    observation(&mut c, 0.0, &ground);
    c.configure(ClassifierConfig::default());
    assert_eq!(
        observation(&mut c, 0.0, &tread)[0].class,
        EvidenceClass::Navigable
    );
    // The paper's rule pairs nothing.
    let mut c = classifier::<256>(GateShape::Hard);
    c.configure(ClassifierConfig {
        rule: NavigabilityRule::Spread,
        ..ClassifierConfig::default()
    });
    observation(&mut c, 0.0, &ground);
    assert_eq!(
        observation(&mut c, 0.0, &tread)[0].class,
        EvidenceClass::Navigable
    );
}
