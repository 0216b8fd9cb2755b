//! Decay against its reference (`reference::decay`, written from `docs/core.md`):
//! - the step, for every stored value and every mode: the library's fixed point equals the
//!   quantised rule exactly;
//! - the quantised step against the ideal exponential `L·e^{−n/8}`: within the drift bound
//!   after any number of steps, and a cell reads unknown no later than one step after the ideal
//!   one would (|L| under half a Q8.8 step), no earlier than the bound allows;
//! - the time constants of every code, and the validation rule;
//! - the sweep: for random clocks (steps, long gaps, a clock that goes back, wrapping), the
//!   library decays exactly the rows the reference's sweep owes, layer by layer;
//! - clamping holds, the modes touch only their kind, fresh evidence dominates aged evidence.
//!
//! (The whole pyramid with decay against both references, cell for cell, with evidence,
//! recentres and the fused query: `tests/pyramid.rs`.)

use proptest::prelude::*;
use terrain_pyramid as tp;
use terrain_pyramid_host_tests::reference::decay::{self as rd, Mode};
use tp::decay::{decayed, Decay, DecayMode, TimeConstant};

const MODES: [(DecayMode, Mode); 4] = [
    (DecayMode::Off, Mode::Off),
    (DecayMode::All, Mode::All),
    (DecayMode::Obstacle, Mode::Obstacle),
    (DecayMode::Free, Mode::Free),
];

fn lib_step(raw: Option<i64>, mode: DecayMode) -> Option<i64> {
    let cell = raw.map_or(tp::Cell::UNKNOWN, |r| {
        tp::Cell::from_raw(i16::try_from(r).unwrap())
    });
    decayed(cell, mode)
        .log_odds()
        .map(|v| i64::from(v.to_bits()))
}

#[test]
fn the_step_is_the_spec_for_every_value_and_mode() {
    for (lib_mode, ref_mode) in MODES {
        assert_eq!(lib_step(None, lib_mode), None);
        for raw in -32_767..=32_767_i64 {
            assert_eq!(
                lib_step(Some(raw), lib_mode),
                rd::step_quantised(Some(raw), ref_mode),
                "{raw} in {lib_mode:?}"
            );
        }
    }
}

#[test]
fn the_quantised_step_follows_the_exponential() {
    let bound = rd::error_bound_ulp();
    assert!(bound < rd::ERROR_BOUND_ULP + 1e-9);
    let mut worst = 0.0_f64;
    for raw in (-32_767..=32_767_i64).filter(|&r| r != 0) {
        let mut q = Some(raw);
        let mut n = 0_i32;
        let l = raw as f64;
        while let Some(v) = q {
            let ideal = l * rd::factor().powi(n);
            let drift = (v as f64 - ideal).abs();
            worst = worst.max(drift);
            assert!(drift <= bound, "{raw} after {n} steps: {v} against {ideal}");
            q = rd::step_quantised(q, Mode::All);
            n += 1;
        }
        // The ideal cell reads unknown once |L|·e^{−n/8} < ½ raw unit: after
        // ⌈8·ln(2|L|)⌉ steps (at least 1). The quantised one fades no later than one step after
        // that, and not before its value could have drifted to 0.
        let ideal_steps = (8.0 * (2.0 * l.abs()).ln()).ceil().max(1.0) as i32;
        assert!(
            n <= ideal_steps + 1,
            "{raw}: {n} steps, ideal {ideal_steps}"
        );
        let earliest = (8.0 * (l.abs() / bound).ln()).floor().max(0.0) as i32;
        assert!(n >= earliest, "{raw}: {n} steps, earliest {earliest}");
    }
    // The bound is nearly reached (it is not loose by an order of magnitude).
    assert!(worst > bound / 4.0, "worst drift {worst}");
}

#[test]
fn time_constants_are_the_spec() {
    assert_eq!(
        u64::from(tp::decay::STEP_FACTOR_Q16),
        rd::factor_q16(),
        "the step factor"
    );
    for code in 0..=255_u8 {
        let t = TimeConstant::from_code(code);
        assert_eq!(
            t.step_ms().map(u64::from),
            rd::step_period_ms(code),
            "{code}"
        );
        if code > 0 {
            let s = rd::tau_s(code).unwrap();
            assert_eq!(f64::from(t.seconds().unwrap()), s as f32 as f64);
            // Each code is within 2.3 % (half a sixteenth octave, and the rounding of the
            // period) of 2^((c − 1)/16) s.
            let nominal = 2.0_f64.powf(f64::from(code - 1) / 16.0);
            assert!((s / nominal - 1.0).abs() < 0.023, "{code}: {s} s");
            assert_eq!(TimeConstant::from_seconds(s as f32), Some(t));
        }
    }
    // The sweep's budget: at most 32 768 cells a second per layer.
    for w in [4_usize, 10, 64, 128, 488, 1024] {
        let min_step = Decay::min_step_ms(w);
        assert_eq!(min_step, (1000 * (w * w) as u64).div_ceil(32_768));
        for code in 1..=255_u8 {
            let decay = Decay::uniform(DecayMode::All, TimeConstant::from_code(code), 3);
            let ok = rd::step_period_ms(code).unwrap() >= min_step;
            assert_eq!(decay.validate(w, 3).is_ok(), ok, "W = {w}, code {code}");
        }
    }
    // A time constant for a layer the design lacks; ignored when the mode is off.
    let mut decay = Decay::uniform(DecayMode::Free, TimeConstant::MIN, 3);
    decay.tau[5] = TimeConstant::MIN;
    let error = decay.validate(64, 3).unwrap_err();
    assert_eq!(error.param(), tp::Param::DecayTau { layer: 5 });
    assert!(error.to_string().contains("no layer 5"), "{error}");
    decay.mode = DecayMode::Off;
    assert!(decay.validate(64, 3).is_ok());
}

/// The coarse test design: 6 layers in a window of 10 cells.
fn coarse() -> tp::Design<6> {
    let sensor = tp::SensorModel {
        phi_rad: 2.0_f32.to_radians(),
        psi_rad: 4.0_f32.to_radians(),
        sigma_m: 0.3,
        height_m: 0.5,
        max_range_m: 5.0,
    };
    let schedule = tp::Schedule {
        base_m: 0.2,
        gamma: 3.0,
        ..tp::Schedule::default()
    };
    tp::Design::new(sensor, schedule, 10).unwrap()
}

fn clock() -> impl Strategy<Value = u32> {
    prop_oneof![
        20 => 0_u32..30,
        4 => 30_u32..400,
        1 => 400_u32..100_000,
        1 => Just(u32::MAX - 5), // the clock went back
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn the_sweep_decays_the_rows_the_reference_owes(
        codes in prop::array::uniform6(prop_oneof![1 => Just(0_u8), 5 => 1_u8..=255]),
        mode in 1_u8..4,
        start in any::<u32>(),
        deltas in prop::collection::vec(clock(), 1..300),
    ) {
        let design = coarse();
        let mut decay = Decay::OFF;
        decay.mode = DecayMode::from_u8(mode).unwrap();
        for (t, &c) in decay.tau.iter_mut().zip(&codes) {
            *t = TimeConstant::from_code(c);
        }
        let config = tp::Config { decay, ..tp::Config::default() };
        let mut lib: Box<tp::Pyramid<10, 6>> = Box::default();
        lib.configure(&design, &config).unwrap();
        let mut reference = rd::Sweep::new(10, &codes);
        let mut now = start;
        for (n, d) in std::iter::once(0).chain(deltas).enumerate() {
            now = now.wrapping_add(d);
            lib.accrue_decay(now);
            reference.accrue(now);
            for k in 0..6 {
                prop_assert_eq!(lib.decay_due(k) as u64, reference.due(k), "call {} layer {}", n, k);
                let got = lib.decay_layer(k).map(|r| (u64::from(r.first), u64::from(r.rows)));
                prop_assert_eq!(got, reference.take(k), "call {} layer {}", n, k);
            }
        }
    }
}

/// Fills layer 0 of the default pyramid with evidence of both kinds (clamped), then ages it.
fn aged(mode: DecayMode, clamp: tp::Clamp, seconds: u32) -> Box<tp::DefaultPyramid> {
    let design = tp::DefaultDesign::new(
        tp::SensorModel::default(),
        tp::Schedule::default(),
        tp::DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap();
    let config = tp::Config {
        clamp,
        decay: Decay::uniform(mode, TimeConstant::from_seconds(2.0).unwrap(), 8),
        ..tp::Config::default()
    };
    let mut p: Box<tp::DefaultPyramid> = Box::default();
    p.configure(&design, &config).unwrap();
    for x in -32..32_i32 {
        let class = if x % 2 == 0 {
            tp::EvidenceClass::Obstacle
        } else {
            tp::EvidenceClass::Navigable
        };
        for _ in 0..(40 + x.rem_euclid(7)) {
            p.apply(&tp::Evidence {
                layer: 0,
                cell_x: x,
                cell_y: 3,
                class,
                weight: tp::Weight::ONE,
            });
        }
    }
    p.decay(0);
    for t in 1..=seconds * 100 {
        p.decay(t * 10);
    }
    p
}

#[test]
fn clamping_holds_and_modes_touch_only_their_kind() {
    let clamp = tp::Clamp::OCTOMAP;
    let fresh = aged(DecayMode::Off, clamp, 0);
    for mode in [DecayMode::All, DecayMode::Obstacle, DecayMode::Free] {
        let p = aged(mode, clamp, 1);
        for x in -32..32 {
            let before = fresh.layer(0).unwrap().get(x, 3).unwrap().to_raw();
            let after = p.layer(0).unwrap().get(x, 3).unwrap();
            assert!((-512..=896).contains(&before));
            let ages = match mode {
                DecayMode::Obstacle => before > 0,
                DecayMode::Free => before < 0,
                _ => true,
            };
            let a = after.to_raw();
            if ages {
                // Half a time constant: 4 steps of e^{−1/8}, within the drift bound.
                let ideal = f64::from(before) * (-0.5_f64).exp();
                assert!(after.is_observed());
                assert!(
                    (f64::from(a) - ideal).abs() <= rd::ERROR_BOUND_ULP,
                    "{x}: {a}"
                );
                assert!(a.signum() == before.signum() && a.abs() < before.abs());
            } else {
                assert_eq!(a, before, "{mode:?} aged cell {x}");
            }
        }
    }
    // Unclamped evidence (saturated at 40·217 raw) decays too, within the format.
    let p = aged(DecayMode::All, tp::Clamp::Off, 20);
    assert_eq!(p.counts(0).unwrap().observed, 0, "10 τ fade everything");
}

#[test]
fn fresh_evidence_dominates_aged_evidence() {
    // An obstacle cell at the clamp (3.5 nats), then free observations: without decay it takes
    // ⌈896/104⌉ = 9 to turn it navigable; after 2 τ (3.5·e⁻² ≈ 0.47 nats = 121 raw) two.
    for (mode, seconds, needed) in [(DecayMode::Off, 4, 9), (DecayMode::All, 4, 2)] {
        let mut p = aged(mode, tp::Clamp::OCTOMAP, seconds);
        let mut n = 0;
        while p.layer(0).unwrap().get(0, 3).unwrap().class() != tp::CellClass::Navigable {
            p.apply(&tp::Evidence {
                layer: 0,
                cell_x: 0,
                cell_y: 3,
                class: tp::EvidenceClass::Navigable,
                weight: tp::Weight::ONE,
            });
            n += 1;
        }
        assert_eq!(n, needed, "{mode:?}");
    }
}
