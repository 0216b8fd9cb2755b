//! The library's Q1.15 gate tables against the reference's binned `f64` gate, rounded as
//! `docs/core.md` specifies (`round(w·2¹⁵)`, ties away from zero, at the bin centres).
//!
//! Two comparisons:
//! - against the reference gate *of the library's own `f32` design* (its centres, widths and
//!   edges, widened): this isolates the table construction. At most 1 ULP apart, and apart at
//!   all only where `w·2¹⁵` lies within the `f32` evaluation error of a rounding tie; the hard
//!   gate is exact;
//! - against the reference gate *of the reference's own `f64` design*: within the rounding of
//!   `w ± t`, t being what the design's tolerated `f32` error moves the gate by
//!   ([`gate::design_tolerance`]) — at most 1 ULP from the reference's rounding except in
//!   narrow bands (1 mm wide at 20 m: tens of ULPs); a hard-gate bin whose centre lies within
//!   an edge's tolerance may hold 0 or 1.

use crate::common;

use common::{config, CAPACITY};
use proptest::prelude::*;
use terrain_pyramid as tp;
use terrain_pyramid_host_tests::harness;
use terrain_pyramid_host_tests::reference::bands::{self, GateKind};
use terrain_pyramid_host_tests::reference::gate::{self, Tables, BINS};
use tp::gate::{DistanceBins, GateTable};

/// The reference design with the library's `f32` layers (widened) in place of its own.
fn reference_of_library_design(ld: &tp::Design<CAPACITY>, rd: &bands::Design) -> bands::Design {
    let mut d = rd.clone();
    for (r, l) in d.layers.iter_mut().zip(ld.layers()) {
        r.resolution = f64::from(l.resolution_m);
        r.inner = f64::from(l.band_inner_m);
        r.outer = f64::from(l.band_outer_m);
        r.centre = f64::from(l.gate_center_m);
        r.sigma_g = f64::from(l.gate_sigma_m);
    }
    d
}

fn library_table(ld: &tp::Design<CAPACITY>, k: usize) -> Vec<u32> {
    let bins = DistanceBins::for_range(ld.sensor().max_range_m);
    GateTable::build(ld, k, bins)
        .weights()
        .iter()
        .map(|w| u32::from(w.to_bits()))
        .collect()
}

/// Distance of `x` from the nearest half-integer.
fn tie_distance(x: f64) -> f64 {
    ((x - x.floor()) - 0.5).abs()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 192, ..ProptestConfig::default() })]

    #[test]
    fn tables_are_the_rounded_gate_of_the_design((sensor, schedule, cells) in config()) {
        let rs = harness::sensor(&sensor);
        let rsch = harness::schedule(&schedule);
        let outcome = bands::design(&rs, &rsch, cells, CAPACITY);
        let (Ok(rd), Ok(ld)) = (outcome.result, tp::Design::<CAPACITY>::new(sensor, schedule, cells)) else {
            return Ok(()); // refusals are the design tests' business
        };
        prop_assume!(rd.layers.len() == ld.layers().len());
        let own = reference_of_library_design(&ld, &rd);
        let own_tables = Tables::new(&own);
        let ref_tables = Tables::new(&rd);
        for k in 0..rd.layers.len() {
            let got = library_table(&ld, k);
            prop_assert_eq!(got.len(), BINS);
            for (i, &g) in got.iter().enumerate() {
                let x = gate::bin_centre(i, own_tables.shift);
                // (a) the library's own design: the table construction alone.
                let w = own_tables.exact[k][i];
                let want = own_tables.raw[k][i];
                match rsch.gate {
                    GateKind::Hard => prop_assert_eq!(g, want, "hard, layer {}, bin {}", k, i),
                    GateKind::Soft { .. } => {
                        let l = &own.layers[k];
                        let z = (x - l.centre) / l.sigma_g;
                        let t = 32_768.0 * gate::f32_evaluation_tolerance(w, z) + 1e-3;
                        prop_assert!(g.abs_diff(want) <= 1, "layer {k}, bin {i}: {g} vs {want}");
                        prop_assert!(
                            g == want || tie_distance(w * 32_768.0) <= t,
                            "layer {k}, bin {i}: {g} vs {want} although w·2¹⁵ = {} is {} from a tie (allowed {t})",
                            w * 32_768.0, tie_distance(w * 32_768.0)
                        );
                    }
                }
                // (b) the reference's own f64 design: the entry lies in the range that the
                // design's tolerated f32 error allows (one exact entry for the hard gate away
                // from the edges).
                let (lo, hi) = ref_tables.raw_range[k][i];
                prop_assert!(
                    (lo..=hi).contains(&g),
                    "vs f64 design, layer {k}, bin {i}: {g} outside {lo} ..= {hi} (rounded {})",
                    ref_tables.raw[k][i]
                );
            }
        }
    }
}

fn default_design(gate: tp::GateShape) -> (bands::Design, tp::Design<CAPACITY>) {
    let s = tp::SensorModel::default();
    let sch = tp::Schedule {
        gate,
        ..tp::Schedule::default()
    };
    let rd = harness::reference_design(&s, &sch, 64, CAPACITY)
        .result
        .unwrap();
    let ld = tp::Design::<CAPACITY>::new(s, sch, 64).unwrap();
    (rd, ld)
}

/// The default design's tables (soft and hard): every entry equals the reference's rounding
/// except where `w·2¹⁵` lies within `f32` error of a tie (one bin of the soft gate: layer 2,
/// bin 53, w·2¹⁵ = 23 979.498), and every entry lies in the range the pyramid tests allow.
#[test]
fn default_tables_match() {
    let mut differing = Vec::new();
    for g in [tp::GateShape::default(), tp::GateShape::Hard] {
        let (rd, ld) = default_design(g);
        let t = Tables::new(&rd);
        for k in 0..rd.layers.len() {
            for (i, &got) in library_table(&ld, k).iter().enumerate() {
                let (lo, hi) = t.raw_range[k][i];
                assert!((lo..=hi).contains(&got), "{g:?}, layer {k}, bin {i}");
                if got != t.raw[k][i] {
                    assert!(
                        tie_distance(t.exact[k][i] * 32_768.0) < 0.01,
                        "{g:?} {k} {i}"
                    );
                    differing.push((k, i));
                }
            }
        }
    }
    assert!(differing.len() <= 2, "{differing:?}");
}

/// The soft gate's binning error: the reference's measured error stays within the spec's
/// bound `e^{−½}·b/(2σ_g)` and comes close to it; the library's table (binning + rounding)
/// stays within that bound plus 2⁻¹⁶ (rounding) plus 2⁻¹⁵ (one ULP).
#[test]
fn soft_gate_binning_error_is_bounded() {
    let (rd, ld) = default_design(tp::GateShape::default());
    let shift = gate::bin_shift(rd.sensor.max_range).unwrap();
    for k in 0..rd.layers.len() {
        let (measured, bound) = gate::binning_error(&rd, k);
        assert!(
            measured <= bound * (1.0 + 1e-9),
            "layer {k}: {measured} > {bound}"
        );
        assert!(measured >= 0.9 * bound, "layer {k}: {measured} ≪ {bound}");
        let table = library_table(&ld, k);
        let mut worst = 0.0_f64;
        for s in 0..=20_000 {
            let d = rd.sensor.max_range * f64::from(s) / 20_000.0;
            let raw = (d * 65_536.0) as i32;
            let w = f64::from(table[gate::bin_of_raw(raw, shift)]) / 32_768.0;
            worst = worst.max((w - gate::continuous(&rd, k, f64::from(raw) / 65_536.0)).abs());
        }
        let allowed = bound + 1.0 / 65_536.0 + 1.0 / 32_768.0;
        assert!(
            worst <= allowed,
            "layer {k}: table vs continuous {worst} > {allowed}"
        );
    }
}
