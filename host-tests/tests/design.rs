//! The library's `f32` design (bound, bands, layer count, resolutions, gate centres and
//! widths, refusals) against the `f64` reference.
//!
//! Tolerances (measured by the `agreement` example over 2·10⁴ random configurations, then
//! widened about fivefold):
//! - δ(d) and its terms: relative 2·10⁻⁶ (measured 2.5·10⁻⁷);
//! - r_k: two `f32` ULPs (measured relative 1.2·10⁻⁷);
//! - a band edge d_{k+1}: `δ(d_lib)` within 2·10⁻⁶·r_k of r_k (measured 3.7·10⁻⁷), i.e.
//!   |d_lib − d_ref| ≤ 2·10⁻⁶·δ/δ' + 2 `f32` ULPs of d ([`bands::edge_tolerance`]). A plain
//!   relative tolerance does not work: where δ is nearly flat in relative terms (a tiny band
//!   0) the relative edge error reaches 9·10⁻⁴ while the edge still solves δ(d) = r_k to
//!   `f32` precision;
//! - c_k: the mean of its two edges' tolerances plus two ULPs; σ_g,k: f times their sum plus
//!   two ULPs (a narrow last band, 1 mm wide at 20 m, has a relative width error of 1 %).

use crate::common;

use common::{config, next_up, CAPACITY};
use proptest::prelude::*;
use terrain_pyramid as tp;
use terrain_pyramid_host_tests::harness;
use terrain_pyramid_host_tests::reference::bands::{self, edge_tolerance, ulp_f32, Violation};
use terrain_pyramid_host_tests::reference::gate;
use terrain_pyramid_host_tests::reference::window::resolution_raw;

/// Relative tolerance on δ(d) and its terms.
const DELTA_REL: f64 = 2e-6;

fn check_design(
    sensor: tp::SensorModel,
    schedule: tp::Schedule,
    cells: usize,
) -> Result<(), TestCaseError> {
    let rs = harness::sensor(&sensor);
    let rsch = harness::schedule(&schedule);
    let outcome = bands::design(&rs, &rsch, cells, CAPACITY);
    let lib = tp::Design::<CAPACITY>::new(sensor, schedule, cells);
    if !outcome.fragile.is_empty() {
        // A decision within rounding of its threshold: either verdict is right.
        return Ok(());
    }
    let rd = match (&outcome.result, &lib) {
        (Err(v), Err(e)) => {
            prop_assert!(
                harness::refusal_matches(e, v),
                "library refuses with {e:?}, reference breaks {v:?}"
            );
            return Ok(());
        }
        (Ok(rd), Ok(_)) => rd,
        (r, l) => {
            return Err(TestCaseError::fail(format!(
                "verdicts differ: reference {:?}, library {:?}",
                r.as_ref().err(),
                l.as_ref().err()
            )))
        }
    };
    let ld = lib.expect("both accepted");
    prop_assert_eq!(ld.cells_per_side(), cells);
    let n = rd.layers.len();
    prop_assert_eq!(ld.layers().len(), n, "layer count");
    let f = match rsch.gate {
        bands::GateKind::Hard => 0.0,
        bands::GateKind::Soft { width_factor } => width_factor,
    };
    for (k, (l, r)) in ld.layers().iter().zip(&rd.layers).enumerate() {
        let last = k + 1 == n;
        let res = f64::from(l.resolution_m);
        prop_assert!(
            (res - r.resolution).abs() <= 2.0 * ulp_f32(r.resolution),
            "layer {k}: r = {res} vs {}",
            r.resolution
        );
        // Resolution in Q16.16: round(r·2¹⁶), ties away from zero.
        // (Unless r·2¹⁶ lies within the f32 rounding of r of a tie.)
        let rq = tp::Resolution::from_m(l.resolution_m).map(tp::Resolution::to_bits);
        let scaled = r.resolution * 65_536.0;
        if ((scaled - scaled.floor()) - 0.5).abs() > 2.0 * ulp_f32(r.resolution) * 65_536.0 {
            prop_assert_eq!(rq.map(i64::from), Some(resolution_raw(r.resolution)));
        }
        let e_in = if k == 0 {
            prop_assert_eq!(l.band_inner_m, 0.0);
            0.0
        } else {
            prop_assert_eq!(
                l.band_inner_m,
                ld.layers()[k - 1].band_outer_m,
                "contiguous"
            );
            edge_tolerance(&rs, r.inner)
        };
        let e_out = if last {
            prop_assert_eq!(l.band_outer_m, sensor.max_range_m, "last band closed at R");
            prop_assert!(res >= rs.delta(rs.max_range) * (1.0 - 1e-6));
            0.0
        } else {
            let d = f64::from(l.band_outer_m);
            let defect = (rs.delta(d) - r.resolution).abs() / r.resolution;
            prop_assert!(
                defect <= bands::EDGE_DEFECT_REL,
                "layer {k}: δ(d_lib = {d}) = {} vs r = {}",
                rs.delta(d),
                r.resolution
            );
            let tol = edge_tolerance(&rs, r.outer);
            prop_assert!(
                (d - r.outer).abs() <= tol,
                "layer {k}: edge {d} vs {} (tol {tol:e})",
                r.outer
            );
            tol
        };
        let c = f64::from(l.gate_center_m);
        let c_tol = 0.5 * (e_in + e_out) + 2.0 * ulp_f32(r.centre);
        prop_assert!(
            (c - r.centre).abs() <= c_tol,
            "layer {k}: centre {c} vs {}",
            r.centre
        );
        let s = f64::from(l.gate_sigma_m);
        let s_tol = f * (e_in + e_out) + 2.0 * ulp_f32(r.sigma_g);
        prop_assert!(
            (s - r.sigma_g).abs() <= s_tol,
            "layer {k}: σ_g {s} vs {} (tol {s_tol:e})",
            r.sigma_g
        );
        // The soft gate's binning-error bound e^{−½}·b/(2σ_g) (the library adds the 2⁻¹⁶ of
        // rounding and says so).
        if r.sigma_g > 0.0 {
            let bins = tp::gate::DistanceBins::for_range(sensor.max_range_m);
            let (_, bound) = gate::binning_error(rd, k);
            let got = f64::from(tp::gate::binning_error_bound(l, bins));
            let want = bound + 1.0 / 65_536.0;
            let rel = 1e-5 + s_tol / r.sigma_g;
            prop_assert!(
                (got - want).abs() <= rel * want,
                "layer {k}: binning bound {got} vs {want}"
            );
        }
    }
    Ok(())
}

/// A case the property once found: a 0.014 m base to 75 m needs about 6 900 layers, and the
/// library (f32) counts 6 900 where the reference (f64) counts 6 901. Both refuse.
#[test]
fn a_far_range_on_a_fine_base_is_refused_alike() {
    let sensor = tp::SensorModel {
        phi_rad: 0.021_462_977,
        psi_rad: 0.065_041_98,
        sigma_m: 0.232_513_46,
        height_m: 0.443_658_3,
        max_range_m: 74.599_24,
    };
    let schedule = tp::Schedule {
        base_m: 0.013_865_11,
        gamma: 2.867_733_2,
        gate: tp::GateShape::Hard,
        uniform_resolution: false,
    };
    assert!(matches!(
        tp::Design::<CAPACITY>::new(sensor, schedule, 10),
        Err(tp::DesignError::TooManyLayers { .. })
    ));
    check_design(sensor, schedule, 10).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Over random configurations in the ranges: the library accepts exactly when the
    /// reference does (refusing for a rule the reference names), and an accepted design agrees
    /// layer by layer.
    #[test]
    fn random_configurations_match_the_reference((sensor, schedule, cells) in config()) {
        check_design(sensor, schedule, cells)?;
    }

    /// δ(d) and its three terms, and `reach`, against the reference.
    #[test]
    fn bound_and_reach_match(sensor in common::sensor(), t in 0.0f64..=1.0, cell in 0.0f64..1.0) {
        let rs = harness::sensor(&sensor);
        let d = (t * f64::from(sensor.max_range_m)) as f32;
        let got = sensor.bound(d);
        let want = rs.terms(f64::from(d));
        for (g, w) in [
            (got.noise_m, want.noise),
            (got.horizontal_m, want.horizontal),
            (got.vertical_m, want.vertical),
            (got.total_m, want.total),
        ] {
            prop_assert!((f64::from(g) - w).abs() <= DELTA_REL * w.abs() + 1e-12, "{g} vs {w} at d = {d}");
        }
        // reach(r) for r between δ(0) and δ(R).
        let lo = rs.delta(0.0);
        let hi = rs.delta(rs.max_range);
        let r = (lo + cell * (hi - lo)) as f32;
        let want = bands::reach(&rs, f64::from(r));
        let got = f64::from(sensor.reach(r));
        prop_assert!((got - want).abs() <= edge_tolerance(&rs, want), "reach({r}) = {got} vs {want}");
    }

    /// Invalid values of one parameter are refused, naming a rule the reference says is broken.
    #[test]
    fn invalid_configurations_are_refused(
        (sensor, schedule, cells) in config(),
        which in 0usize..14,
        u in 0.0f64..1.0,
    ) {
        let (mut s, mut sch, mut w) = (sensor, schedule, cells);
        let bad = [f32::NAN, f32::INFINITY, -1.0, 0.0][(u * 4.0) as usize % 4];
        match which {
            0 => s.phi_rad = bad,
            1 => s.psi_rad = bad,
            2 => s.sigma_m = bad,
            3 => s.height_m = bad,
            4 => s.max_range_m = bad,
            5 => sch.base_m = bad,
            6 => sch.gamma = (u * 1.0) as f32, // γ ≤ 1 (includes 0 and values just below 1)
            7 => sch.base_m = (f64::from(s.phi_rad) * f64::from(s.height_m) * (0.05 + 0.95 * u)).max(0.01) as f32,
            8 => w = [3, 2, 0, 1026, 2048, 65][(u * 6.0) as usize % 6],
            9 => s.phi_rad = core::f32::consts::FRAC_PI_2 * (1.001 + u as f32),
            10 => s.max_range_m = next_up(81.92) + (u * 100.0) as f32,
            11 => sch.gamma = 100.5 + (u * 100.0) as f32,
            12 => sch.gate = tp::GateShape::Soft { width_factor: 4.01 + (u * 4.0) as f32 },
            _ => { s.sigma_m = 100.01 + (u * 10.0) as f32; }
        }
        if which == 7 && f64::from(sch.base_m) > f64::from(s.phi_rad) * f64::from(s.height_m) {
            // The 1 cm floor kept Δd above φ·h: not an invalid configuration after all.
            return Ok(());
        }
        let o = harness::reference_design(&s, &sch, w, CAPACITY);
        if !o.fragile.is_empty() {
            return Ok(());
        }
        let Err(v) = o.result else {
            return Err(TestCaseError::fail(format!("reference accepts ({which}) {s:?} {sch:?} {w}")));
        };
        match tp::Design::<CAPACITY>::new(s, sch, w) {
            Ok(_) => return Err(TestCaseError::fail(format!("library accepts: reference says {v:?}"))),
            Err(e) => prop_assert!(harness::refusal_matches(&e, &v), "{e:?} vs {v:?}"),
        }
    }

    /// The distance bins: width 2⁻ˢ for the largest s with R < 512·2⁻ˢ, `min(floor(D/b), 511)`,
    /// 0 for negative distances, centres `(i + ½)·b`.
    #[test]
    fn distance_bins_match(range in 0.01f32..=81.92, d in any::<i32>(), i in 0usize..512) {
        let bins = tp::gate::DistanceBins::for_range(range);
        let shift = gate::bin_shift(f64::from(range)).expect("a valid range has bins");
        prop_assert_eq!(f64::from(bins.width_m()), gate::bin_width(shift));
        prop_assert_eq!(bins.bin(harness::meters(d)), gate::bin_of_raw(d, shift));
        let near = d.rem_euclid(1 << 23); // 0 ..< 128 m
        prop_assert_eq!(bins.bin(harness::meters(near)), gate::bin_of_raw(near, shift));
        prop_assert_eq!(f64::from(bins.center_m(i)), gate::bin_centre(i, shift));
    }

    /// `Resolution::from_m`: round(r·2¹⁶), ties away from zero.
    #[test]
    fn resolution_rounds_to_nearest(r in 0.01f32..100.0, n in 656u32..60_000) {
        let got = tp::Resolution::from_m(r).map(|q| i64::from(q.to_bits()));
        prop_assert_eq!(got, Some(resolution_raw(f64::from(r))));
        // An exact tie: (2n + 1)/2¹⁷ is representable in f32 for these n.
        let tie = (2 * n + 1) as f32 / 131_072.0;
        prop_assert_eq!(f64::from(tie) * 65_536.0, f64::from(n) + 0.5);
        prop_assert_eq!(tp::Resolution::from_m(tie).map(tp::Resolution::to_bits), Some(n as i32 + 1));
    }
}

#[test]
fn default_design_matches_exactly_in_structure() {
    let s = tp::SensorModel::default();
    let sch = tp::Schedule::default();
    check_design(s, sch, 64).unwrap();
    let o = harness::reference_design(&s, &sch, 64, 8);
    assert!(o.fragile.is_empty());
    let rd = o.result.unwrap();
    let ld = tp::Design::<8>::new(s, sch, 64).unwrap();
    assert_eq!(rd.layers.len(), 8);
    assert_eq!(ld.layers().len(), 8);
    // The default does not fit a smaller capacity, and says how many it needs.
    let v = harness::reference_design(&s, &sch, 64, 7)
        .result
        .unwrap_err();
    assert_eq!(v, vec![Violation::TooManyLayers { needed: 8 }]);
    let e = tp::Design::<7>::new(s, sch, 64).unwrap_err();
    assert!(harness::refusal_matches(&e, &v), "{e:?}");
}

/// Boundary values of the refusal rules, where `≤` and `<` part ways.
#[test]
fn boundaries_of_the_refusal_rules() {
    let s = tp::SensorModel::default();
    let sch = tp::Schedule::default();
    let verdict = |s: tp::SensorModel, sch: tp::Schedule, w: usize| {
        let o = harness::reference_design(&s, &sch, w, 16);
        let l = tp::Design::<16>::new(s, sch, w);
        (o.result.map(|_| ()), l.map(|_| ()))
    };
    let check = |s: tp::SensorModel, sch: tp::Schedule, w: usize, label: &str| {
        let (r, l) = verdict(s, sch, w);
        match (&r, &l) {
            (Ok(()), Ok(())) => {}
            (Err(v), Err(e)) => assert!(harness::refusal_matches(e, v), "{label}: {e:?} vs {v:?}"),
            _ => panic!("{label}: reference {r:?}, library {l:?}"),
        }
    };
    // γ = 1 exactly is refused; Δd = φ·h exactly (φ = 1/16 rad, h = 1 m: exact) is refused,
    // one f32 step above is not refused for that rule.
    check(s, tp::Schedule { gamma: 1.0, ..sch }, 64, "γ = 1");
    let flat = tp::SensorModel {
        phi_rad: 0.0625,
        height_m: 1.0,
        ..s
    };
    check(
        flat,
        tp::Schedule {
            base_m: 0.0625,
            ..sch
        },
        64,
        "Δd = φh",
    );
    check(
        flat,
        tp::Schedule {
            base_m: next_up(0.0625),
            ..sch
        },
        1024,
        "Δd just above φh",
    );
    // R = 81.92 is accepted as far as the range goes; one f32 step above is refused.
    let far = tp::SensorModel {
        max_range_m: 81.92,
        ..s
    };
    let coarse = tp::Schedule {
        base_m: 2.0,
        gamma: 4.0,
        ..sch
    };
    check(far, coarse, 1024, "R = 81.92");
    check(
        tp::SensorModel {
            max_range_m: next_up(81.92),
            ..s
        },
        coarse,
        1024,
        "R > 81.92",
    );
    // Δd = 0.01 (as typed, 0.01_f32) and Δd = 100 are allowed; W = 4 and 1024 are allowed,
    // 1026 and odd ones are not.
    check(
        s,
        tp::Schedule {
            base_m: 0.01,
            ..sch
        },
        1024,
        "Δd = 0.01",
    );
    check(
        s,
        tp::Schedule {
            base_m: 100.0,
            ..sch
        },
        4,
        "Δd = 100, W = 4",
    );
    check(
        s,
        tp::Schedule {
            base_m: 100.0,
            ..sch
        },
        1024,
        "W = 1024",
    );
    check(
        s,
        tp::Schedule {
            base_m: 100.0,
            ..sch
        },
        1026,
        "W = 1026",
    );
    check(
        s,
        tp::Schedule {
            base_m: 100.0,
            ..sch
        },
        5,
        "W = 5",
    );
    // Soft gate factor 4 is allowed, just above is not.
    check(
        s,
        tp::Schedule {
            gate: tp::GateShape::Soft { width_factor: 4.0 },
            ..sch
        },
        64,
        "f = 4",
    );
    check(
        s,
        tp::Schedule {
            gate: tp::GateShape::Soft {
                width_factor: next_up(4.0),
            },
            ..sch
        },
        64,
        "f > 4",
    );
}

/// `docs/core.md` refuses φ ≥ π/2 and ψ ≥ π: the closed end is refused too.
#[test]
fn angles_at_their_limit_are_refused() {
    let s = tp::SensorModel::default();
    let sch = tp::Schedule {
        base_m: 100.0,
        ..tp::Schedule::default()
    };
    let mut failures = Vec::new();
    for (label, sensor) in [
        (
            "φ = π/2",
            tp::SensorModel {
                phi_rad: core::f32::consts::FRAC_PI_2,
                height_m: 0.01,
                max_range_m: 0.5,
                ..s
            },
        ),
        (
            "ψ = π",
            tp::SensorModel {
                psi_rad: core::f32::consts::PI,
                ..s
            },
        ),
    ] {
        let v = harness::reference_design(&sensor, &sch, 1024, 16)
            .result
            .expect_err("the reference refuses");
        match tp::Design::<16>::new(sensor, sch, 1024) {
            Err(e) => assert!(harness::refusal_matches(&e, &v), "{label}: {e:?} vs {v:?}"),
            Ok(d) => failures.push(format!(
                "{label}: the library accepts ({} layers); the spec refuses it: {v:?}",
                d.layers().len()
            )),
        }
        // Just below the limit, both accept.
        let below = tp::SensorModel {
            phi_rad: if label.starts_with('φ') {
                f32::from_bits(sensor.phi_rad.to_bits() - 1)
            } else {
                sensor.phi_rad
            },
            psi_rad: if label.starts_with('ψ') {
                f32::from_bits(sensor.psi_rad.to_bits() - 1)
            } else {
                sensor.psi_rad
            },
            ..sensor
        };
        assert!(harness::reference_design(&below, &sch, 1024, 16)
            .result
            .is_ok());
        assert!(
            tp::Design::<16>::new(below, sch, 1024).is_ok(),
            "{label}, one step below"
        );
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
