//! The library's pyramid against two reference pyramids driven in lock step by random
//! workloads (evidence for random layers and cells near — and outside — the window, random
//! classes and distances, interleaved with random recentres: small moves, moves onto exact
//! cell boundaries, and far jumps):
//! - the *quantised* reference (the rules of `docs/core.md` computed exactly): every cell of
//!   every layer must agree exactly — observed-ness, class, log-odds (0 ULP) — and so must
//!   every record's outcome, every window origin, the per-layer counts, the fused query and
//!   the region export. (The only slack: a gate-table entry whose `w·2¹⁵` lies within `f32`
//!   error of a rounding tie may legitimately differ by one; the reference tracks the
//!   consequences per cell.)
//! - the *ideal* `f64` reference (eq. 6 with exact increments and weights): every cell within
//!   its tracked error budget, classes equal wherever |L| exceeds it, the fused query equal
//!   wherever no cell on its path is within its budget.
//!
//! With decay on (a random mode and random time constants per layer), the workload also
//! advances a clock that wraps, and pays the decay owed (`Pyramid::decay`): the quantised
//! reference's sweep and step (`reference::decay`) must give the same cells, bit for bit, and
//! the ideal reference's exponential stays within its budget.
//!
//! Designs: the default (`Design::<8>`, W = 64) with the soft and the hard gate, and a coarse
//! one (φ = 2°, ψ = 4°, σ = 0.3 m, h = 0.5 m, R = 5 m, Δd = 0.2 m, γ = 3: 6 layers) in a
//! window of W = 10 cells (not a power of two), where recentres keep crossing the window.

use proptest::prelude::*;
use terrain_pyramid as tp;
use terrain_pyramid_host_tests::harness;
use terrain_pyramid_host_tests::reference::decay;
use terrain_pyramid_host_tests::reference::fused::Fused;
use terrain_pyramid_host_tests::reference::logodds::{Arithmetic, Model};
use terrain_pyramid_host_tests::reference::window::{resolution_raw, Pyramid};
use terrain_pyramid_host_tests::workload::{self, Step};
use tp::units::Meters;

const L: usize = 8;

#[derive(Debug, Clone, Copy)]
enum Which {
    DefaultSoft,
    DefaultHard,
    CoarseSoft,
    CoarseHard,
}

fn design_inputs(which: Which) -> (tp::SensorModel, tp::Schedule, usize) {
    let soft = tp::GateShape::default();
    match which {
        Which::DefaultSoft => (tp::SensorModel::default(), tp::Schedule::default(), 64),
        Which::DefaultHard => (
            tp::SensorModel::default(),
            tp::Schedule {
                gate: tp::GateShape::Hard,
                ..tp::Schedule::default()
            },
            64,
        ),
        Which::CoarseSoft | Which::CoarseHard => (
            tp::SensorModel {
                phi_rad: 2.0_f32.to_radians(),
                psi_rad: 4.0_f32.to_radians(),
                sigma_m: 0.3,
                height_m: 0.5,
                max_range_m: 5.0,
            },
            tp::Schedule {
                base_m: 0.2,
                gamma: 3.0,
                gate: if matches!(which, Which::CoarseSoft) {
                    soft
                } else {
                    tp::GateShape::Hard
                },
                uniform_resolution: false,
            },
            10,
        ),
    }
}

/// One random action, relative to the robot (the test turns it into absolute steps).
#[derive(Debug, Clone, Copy)]
enum Action {
    /// Evidence for layer `layer % (layers + 1)` (one past the last: a bad layer), at the
    /// robot's cell plus (dx, dy), with a distance in 0 ..= R (`distance` in 0 ..= 1 of R,
    /// or slightly negative / beyond R).
    Update {
        layer: u8,
        dx: i32,
        dy: i32,
        obstacle: bool,
        distance: f64,
    },
    /// Move the robot by (dx, dy) raw Q16.16.
    Move { dx: i32, dy: i32 },
    /// Put the robot exactly on a cell corner of layer `layer`, `n` cells away in x and y.
    Corner { layer: u8, nx: i32, ny: i32 },
    /// Jump far away (kilometres, possibly to negative coordinates).
    Jump { x_m: i32, y_m: i32 },
    /// Advance the clock by `dt_ms` and pay the decay owed.
    Decay { dt_ms: u32 },
}

fn action(half: i32) -> impl Strategy<Value = Action> {
    let reach = half + 3;
    prop_oneof![
        40 => (any::<u8>(), -reach..=reach, -reach..=reach, any::<bool>(), prop_oneof![
            20 => 0.0f64..=1.0,
            1 => -0.2f64..0.0,
            1 => 1.0f64..1.5,
        ]).prop_map(|(layer, dx, dy, obstacle, distance)| Action::Update { layer, dx, dy, obstacle, distance }),
        4 => (-200_000i32..200_000, -200_000i32..200_000).prop_map(|(dx, dy)| Action::Move { dx, dy }),
        1 => (any::<u8>(), -20i32..20, -20i32..20).prop_map(|(layer, nx, ny)| Action::Corner { layer, nx, ny }),
        1 => (-5_000i32..5_000, -5_000i32..5_000).prop_map(|(x_m, y_m)| Action::Jump { x_m, y_m }),
        6 => prop_oneof![
            8 => 0_u32..200,
            1 => 200_u32..5_000,
            1 => Just(u32::MAX - 40), // the clock went back: nothing accrues
        ].prop_map(|dt_ms| Action::Decay { dt_ms }),
    ]
}

/// Turns actions into steps, following the robot and the clock (which starts at `clock`).
fn steps(actions: &[Action], rq: &[i64], max_range: f64, clock: u32) -> Vec<Step> {
    let n = rq.len();
    let (mut x, mut y) = (0_i64, 0_i64);
    let mut now = clock;
    let mut out = vec![Step::Decay(now)];
    for a in actions {
        match *a {
            Action::Update {
                layer,
                dx,
                dy,
                obstacle,
                distance,
            } => {
                let k = usize::from(layer) % (n + 1);
                let r = rq[k.min(n - 1)];
                out.push(Step::Update(harness::Observation {
                    layer: k as u8,
                    cell_x: (x.div_euclid(r) + i64::from(dx)) as i32,
                    cell_y: (y.div_euclid(r) + i64::from(dy)) as i32,
                    class: if obstacle {
                        tp::EvidenceClass::Obstacle
                    } else {
                        tp::EvidenceClass::Navigable
                    },
                    distance: Meters::from_bits((distance * max_range * 65_536.0) as i32),
                }));
            }
            Action::Move { dx, dy } => {
                x += i64::from(dx);
                y += i64::from(dy);
                out.push(Step::Recentre(x as i32, y as i32));
            }
            Action::Corner { layer, nx, ny } => {
                let r = rq[usize::from(layer) % n];
                x = (x.div_euclid(r) + i64::from(nx)) * r;
                y = (y.div_euclid(r) + i64::from(ny)) * r;
                out.push(Step::Recentre(x as i32, y as i32));
            }
            Action::Jump { x_m, y_m } => {
                x = i64::from(x_m) * 65_536 + x.rem_euclid(65_536);
                y = i64::from(y_m) * 65_536 + y.rem_euclid(65_536);
                out.push(Step::Recentre(x as i32, y as i32));
            }
            Action::Decay { dt_ms } => {
                now = now.wrapping_add(dt_ms);
                out.push(Step::Decay(now));
            }
        }
    }
    out
}

#[derive(Debug, Clone, Copy)]
struct Settings {
    clamp: Option<(i16, i16)>,
    model: (f32, f32, f32),
    margin_raw: i16,
    /// Decay: the mode (1 all, 2 obstacle, 3 free), each layer's time-constant byte, and
    /// where the clock starts.
    decay: Option<(u8, [u8; 8], u32)>,
}

fn settings() -> impl Strategy<Value = Settings> {
    (
        prop_oneof![
            2 => Just(Some((-512i16, 896i16))), // the default, −2 ..= 3.5
            2 => Just(None),
            1 => (-1_024i16..=-160, 160i16..=1_536).prop_map(Some),
        ],
        prop_oneof![
            2 => Just((0.7f32, 0.4f32, 0.5f32)),
            1 => (0.55f32..0.95, 0.05f32..0.45, 0.42f32..0.58)
                .prop_filter("order", |(o, f, p)| f < p && p < o),
        ],
        prop_oneof![3 => Just(0i16), 1 => 0i16..=256],
        prop_oneof![
            1 => Just(None),
            2 => (
                1_u8..4,
                prop::array::uniform8(prop_oneof![1 => Just(0_u8), 4 => 1_u8..40]),
                prop_oneof![any::<u32>(), Just(u32::MAX - 1_000)],
            )
                .prop_map(Some),
        ],
    )
        .prop_map(|(clamp, model, margin_raw, decay)| Settings {
            clamp,
            model,
            margin_raw,
            decay,
        })
}

/// The library's decay of a settings' decay, for a design of `layers` layers.
fn decay_of(settings: &Settings, layers: usize) -> tp::Decay {
    let Some((mode, codes, _)) = settings.decay else {
        return tp::Decay::OFF;
    };
    let mut decay = tp::Decay::OFF;
    decay.mode = tp::DecayMode::from_u8(mode).expect("1 ..= 3");
    for (t, &c) in decay.tau.iter_mut().zip(&codes).take(layers) {
        *t = tp::TimeConstant::from_code(c);
    }
    decay
}

/// Runs one case: configures everything, runs the workload, compares.
fn check<const W: usize>(
    which: Which,
    settings: Settings,
    actions: &[Action],
    probes: &[(i32, i32)],
) -> Result<(), TestCaseError> {
    let (sensor, schedule, cells) = design_inputs(which);
    assert_eq!(cells, W);
    let design = tp::Design::<L>::new(sensor, schedule, W).expect("a valid design");
    let (p_obstacle, p_free, prior) = settings.model;
    let config = tp::Config {
        model: tp::InverseSensorModel {
            p_obstacle,
            p_free,
            prior,
        },
        clamp: settings
            .clamp
            .map_or(tp::Clamp::Off, |(lo, hi)| tp::Clamp::Bounds {
                min: tp::LogOddsFixed::from_bits(lo),
                max: tp::LogOddsFixed::from_bits(hi),
            }),
        fused_margin: f32::from(settings.margin_raw) / 256.0,
        decay: decay_of(&settings, design.layers().len()),
    };
    let inverse = harness::inverse(&config.model);
    // The increments themselves are tested in tests/logodds.rs; a model whose logits sit on a
    // rounding tie is not this test's business.
    let (q_obs, q_free, q_l0) = inverse.quantised();
    // A model whose increment rounds to zero (p_obstacle a hair above the prior) is refused by
    // the library, by design (tests/logodds.rs): not this test's business either.
    let inc = config.model.increments();
    prop_assume!(inc.is_ok());
    let inc = inc.expect("checked above");
    prop_assume!(
        (
            i32::from(inc.obstacle.to_bits()),
            i32::from(inc.free.to_bits()),
            i32::from(inc.initial.to_bits())
        ) == (q_obs, q_free, q_l0)
    );
    let mut lib: Box<tp::Pyramid<W, L>> = Box::default();
    lib.configure(&design, &config).expect("configures");

    let rd = harness::reference_design(&sensor, &schedule, W, L)
        .result
        .expect("the reference accepts it too");
    prop_assert_eq!(lib.layer_count(), rd.layers.len());
    let rq: Vec<i64> = rd
        .layers
        .iter()
        .map(|l| resolution_raw(l.resolution))
        .collect();
    for (k, &q) in rq.iter().enumerate() {
        let layer = lib.layer(k).expect("layer");
        prop_assert_eq!(
            i64::from(layer.resolution().to_bits()),
            q,
            "rq of layer {}",
            k
        );
    }
    let model = |arithmetic| Model {
        arithmetic,
        inverse,
        clamp: harness::clamp(&config.clamp),
    };
    let margin = f64::from(settings.margin_raw) / 256.0;
    let mut quantised = Pyramid::new(&rd, model(Arithmetic::Quantised), margin);
    let mut ideal = Pyramid::new(&rd, model(Arithmetic::Ideal), margin);
    let clock = settings.decay.map_or(0, |(_, _, c)| c);
    if let Some((mode, codes, _)) = settings.decay {
        let mode = match mode {
            1 => decay::Mode::All,
            2 => decay::Mode::Obstacle,
            _ => decay::Mode::Free,
        };
        let codes = &codes[..rd.layers.len().min(8)];
        quantised.set_decay(mode, codes);
        ideal.set_decay(mode, codes);
    }

    let steps = steps(actions, &rq, rd.sensor.max_range, clock);
    let gates = harness::gates(&design, &config);
    let mismatches = workload::run(&steps, &mut lib, &gates, &mut [&mut quantised, &mut ideal]);
    prop_assert!(
        mismatches.is_empty(),
        "record outcomes differ: {:?}",
        &mismatches[..mismatches.len().min(5)]
    );

    // The counters: records outside the window are counted (those whose g = 0 may count as
    // gated out instead: the spec's step 3 comes first), bad layers are counted.
    let stats = lib.stats();
    prop_assert!(
        (quantised.dropped..=quantised.outside).contains(&u64::from(stats.outside_window)),
        "outside_window = {} not in {} ..= {}",
        stats.outside_window,
        quantised.dropped,
        quantised.outside
    );
    prop_assert_eq!(u64::from(stats.bad_layer), quantised.bad_layer);

    for (reference, label) in [(&quantised, "quantised"), (&ideal, "ideal")] {
        let cmp = harness::compare(&lib, reference);
        prop_assert!(
            cmp.violations.is_empty(),
            "{label}: {} violations, first {:?}",
            cmp.violations.len(),
            &cmp.violations[..cmp.violations.len().min(5)]
        );
    }

    // The fused query at random points around the robot, and a region export.
    let (rx, ry) = steps
        .iter()
        .rev()
        .find_map(|s| match s {
            Step::Recentre(x, y) => Some((*x, *y)),
            Step::Update(_) | Step::Decay(_) => None,
        })
        .unwrap_or((0, 0));
    let span = (W as i64 / 2 + 2) * rq[rq.len() - 1];
    for &(px, py) in probes {
        let x = (i64::from(rx) + i64::from(px) * span / 1_000_000) as i32;
        let y = (i64::from(ry) + i64::from(py) * span / 1_000_000) as i32;
        let got = harness::fused(lib.fused(Meters::from_bits(x), Meters::from_bits(y)));
        for (reference, label) in [(&quantised, "quantised"), (&ideal, "ideal")] {
            if let Some(want) = reference.fused_robust(x, y) {
                prop_assert_eq!(got, want, "{} fused at ({}, {})", label, x, y);
            }
        }
    }
    let step = 2 * (rq[0] / 2 + 7);
    let (w, h) = (W + 3, W / 2 + 1);
    let x0 = rx - (w as i32 / 2) * step as i32;
    let y0 = ry - (h as i32 / 2) * step as i32;
    let mut out = vec![tp::Fused::Unknown; w * h];
    lib.fused_region(
        Meters::from_bits(x0),
        Meters::from_bits(y0),
        Meters::from_bits(step as i32),
        w,
        h,
        &mut out,
    )
    .expect("a valid region");
    let want = quantised.fused_region(x0, y0, step as i32, w, h);
    for (n, (g, wv)) in out.iter().zip(&want).enumerate() {
        let (i, j) = (n % w, n / w);
        let x = x0 + (2 * i as i32 + 1) * step as i32 / 2;
        let y = y0 + (2 * j as i32 + 1) * step as i32 / 2;
        if quantised.fused_robust(x, y).is_some() {
            prop_assert_eq!(harness::fused(*g), *wv, "region cell ({}, {})", i, j);
        }
    }
    Ok(())
}

fn probes() -> impl Strategy<Value = Vec<(i32, i32)>> {
    prop::collection::vec((-1_000_000i32..=1_000_000, -1_000_000i32..=1_000_000), 64)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The default window with the soft and with the hard gate, each on every case.
    #[test]
    fn default_pyramid_soft_and_hard_gate(
        settings in settings(),
        actions in prop::collection::vec(action(32), 1..400),
        probes in probes(),
    ) {
        for which in [Which::DefaultSoft, Which::DefaultHard] {
            check::<64>(which, settings, &actions, &probes)?;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    #[test]
    fn coarse_pyramid_small_window(
        settings in settings(),
        hard in any::<bool>(),
        actions in prop::collection::vec(action(5), 1..300),
        probes in probes(),
    ) {
        let which = if hard { Which::CoarseHard } else { Which::CoarseSoft };
        check::<10>(which, settings, &actions, &probes)?;
    }
}

/// A fixed scenario, to make sure the comparison sees something: evidence piles up in one
/// cell, the window moves away and back (the cell is forgotten), an undecided cell defers to
/// a coarser layer in the fused query.
#[test]
fn scripted_scenario() {
    let settings = Settings {
        clamp: None,
        model: (0.7, 0.4, 0.5),
        margin_raw: 0,
        decay: None,
    };
    let near = tp::Meters::from_num(0.25).to_bits();
    let mut actions = Vec::new();
    for _ in 0..5 {
        actions.push(Action::Update {
            layer: 0,
            dx: 1,
            dy: 1,
            obstacle: true,
            distance: f64::from(near) / 65_536.0 / 10.0,
        });
    }
    actions.push(Action::Move {
        dx: 65_536 * 5,
        dy: 0,
    });
    actions.push(Action::Move {
        dx: -65_536 * 5,
        dy: 0,
    });
    actions.push(Action::Update {
        layer: 1,
        dx: 0,
        dy: 0,
        obstacle: false,
        distance: 0.1,
    });
    let probes: Vec<(i32, i32)> = (-5..5).map(|i| (i * 50_000, i * 30_000)).collect();
    check::<64>(Which::DefaultSoft, settings, &actions, &probes).unwrap();
    check::<64>(Which::DefaultHard, settings, &actions, &probes).unwrap();
}

/// The comparison can fail: a reference that forgets one update, or clamps at a different
/// bound, or computes the fused query with a different margin, is caught.
#[test]
fn the_comparison_catches_a_wrong_reference() {
    let (sensor, schedule, _) = design_inputs(Which::DefaultSoft);
    let design = tp::Design::<L>::new(sensor, schedule, 64).unwrap();
    let config = tp::Config::default();
    let mut lib: Box<tp::Pyramid<64, L>> = Box::default();
    lib.configure(&design, &config).unwrap();
    let rd = harness::reference_design(&sensor, &schedule, 64, L)
        .result
        .unwrap();
    let model = Model {
        arithmetic: Arithmetic::Quantised,
        inverse: harness::inverse(&config.model),
        clamp: harness::clamp(&config.clamp),
    };
    let gates = harness::gates(&design, &config);
    let e = harness::Observation {
        layer: 0,
        cell_x: 3,
        cell_y: -2,
        class: tp::EvidenceClass::Obstacle,
        distance: tp::Meters::from_num(0.25),
    };
    let mut good = Pyramid::new(&rd, model, 0.0);
    let mut skipped = Pyramid::new(&rd, model, 0.0);
    // Three obstacle updates: 3·217 raw, below the 3.5-nat clamp.
    for n in 0..3 {
        lib.apply(&e.evidence(&gates));
        good.apply(&harness::evidence(&e));
        if n != 1 {
            skipped.apply(&harness::evidence(&e));
        }
    }
    assert!(harness::compare(&lib, &good).violations.is_empty());
    let bad = harness::compare(&lib, &skipped);
    assert_eq!(bad.violations.len(), 1, "{:?}", bad.violations);
    // A wrong clamp bound (3.5 + 1 ULP) shows once the cell saturates.
    let mut wrong_clamp = Pyramid::new(
        &rd,
        Model {
            clamp: terrain_pyramid_host_tests::reference::logodds::Clamp::Bounds {
                min: -2.0,
                max: 3.5 + 1.0 / 256.0,
            },
            ..model
        },
        0.0,
    );
    for _ in 0..10 {
        lib.apply(&e.evidence(&gates));
        good.apply(&harness::evidence(&e));
    }
    for _ in 0..13 {
        wrong_clamp.apply(&harness::evidence(&e));
    }
    assert!(harness::compare(&lib, &good).violations.is_empty());
    assert_eq!(harness::compare(&lib, &wrong_clamp).violations.len(), 1);
    // The fused query: a free cell with L = −0.406 is navigable at margin 0, not at 0.5.
    let free = harness::Observation {
        class: tp::EvidenceClass::Navigable,
        cell_x: -7,
        ..e
    };
    lib.apply(&free.evidence(&gates));
    good.apply(&harness::evidence(&free));
    let (x, y) = (-7 * 6_554 + 100, -2 * 6_554 + 100);
    let got = harness::fused(lib.fused(Meters::from_bits(x), Meters::from_bits(y)));
    assert_eq!(got, Fused::Navigable { layer: 0 });
    assert_eq!(good.fused(x, y), got);
    good.margin = 0.5;
    assert_ne!(good.fused(x, y), got);
}

/// A fixed scenario with decay: evidence in a few cells, then a second of clock in small
/// steps at τ = 1 s (all layers), then fresh evidence; and the same with only obstacles
/// ageing.
#[test]
fn scripted_decay() {
    let near = f64::from(tp::Meters::from_num(0.25).to_bits()) / 65_536.0 / 10.0;
    let mut actions = Vec::new();
    for dx in 0..4 {
        for _ in 0..6 {
            actions.push(Action::Update {
                layer: 0,
                dx,
                dy: 1,
                obstacle: dx % 2 == 0,
                distance: near,
            });
        }
    }
    for _ in 0..150 {
        actions.push(Action::Decay { dt_ms: 13 });
    }
    actions.push(Action::Update {
        layer: 0,
        dx: 0,
        dy: 1,
        obstacle: false,
        distance: near,
    });
    let probes: Vec<(i32, i32)> = (-5..5).map(|i| (i * 50_000, i * 30_000)).collect();
    for mode in 1..=3 {
        let settings = Settings {
            clamp: Some((-512, 896)),
            model: (0.7, 0.4, 0.5),
            margin_raw: 0,
            decay: Some((mode, [1; 8], u32::MAX - 500)),
        };
        check::<64>(Which::DefaultSoft, settings, &actions, &probes).unwrap();
    }
}
