//! How closely the fixed-point library follows the `f64` reference.
//!
//! ```text
//! cargo run --release -p terrain-pyramid-host-tests --example agreement [-- UPDATES [CONFIGS]]
//! ```
//!
//! UPDATES defaults to 100 000 (per pyramid scenario), CONFIGS (random design
//! configurations) to 2 000; `-- 100000 20000` gives the tails quoted in `tests/design.rs`.
//! The pyramid workloads are seeded, so a run is reproducible.
//!
//! Prints Markdown tables:
//! 1. the device-side `f32` design (δ, band edges, gate centres and widths) against `f64`,
//!    over the default design and random valid configurations;
//! 2. the Q1.15 gate tables against the reference's binned gate (rounded as specified, and
//!    unrounded), and the soft gate's binning error against the continuous gate;
//! 3. the default pyramid (`Design::<8>` defaults, W = 64, soft gate) after 10⁵ random
//!    updates with random recentres, clamping on and off, against the ideal `f64` recursion
//!    (the truth) and against the spec's quantised arithmetic (which it must match exactly).

use terrain_pyramid as tp;
use terrain_pyramid_host_tests::harness;
use terrain_pyramid_host_tests::reference::bands;
use terrain_pyramid_host_tests::reference::gate;
use terrain_pyramid_host_tests::reference::logodds::{Arithmetic, Model};
use terrain_pyramid_host_tests::reference::window::{resolution_raw, Pyramid};
use terrain_pyramid_host_tests::workload::{self, Rng, Shape};
use tp::gate::{DistanceBins, GateTable};

const CAPACITY: usize = 32;

/// A random configuration from the ranges of the design property test.
fn random_config(rng: &mut Rng) -> (tp::SensorModel, tp::Schedule, usize) {
    let phi = (0.1 + 1.9 * rng.unit()).to_radians() as f32;
    let psi = (0.25 + 3.75 * rng.unit()).to_radians() as f32;
    let sigma = (0.01 + 0.29 * rng.unit()) as f32;
    let h = (0.3 + 1.7 * rng.unit()) as f32;
    let range = (3.0 + 77.0 * rng.unit()) as f32;
    let phi_h = f64::from(phi) * f64::from(h);
    let gamma = (1.2 + 2.8 * rng.unit()) as f32;
    // Δd just above its floor (φ·h, 1 cm), or sized for a target number of layers.
    let rs = harness::sensor(&tp::SensorModel {
        phi_rad: phi,
        psi_rad: psi,
        sigma_m: sigma,
        height_m: h,
        max_range_m: range,
    });
    let floor = phi_h.max(0.01);
    let base = if rng.unit() < 0.2 {
        floor * (1.0 + 0.5 * rng.unit())
    } else {
        let layers = rng.range_i64(1, CAPACITY as i64 - 1) as f64;
        let sized = rs.delta(rs.max_range) / (f64::from(gamma) * layers);
        sized.max(floor) * (1.0 + 0.3 * rng.unit())
    }
    .min(100.0) as f32;
    let gate = if rng.unit() < 0.3 {
        tp::GateShape::Hard
    } else {
        tp::GateShape::Soft {
            width_factor: (0.1 + 1.9 * rng.unit()) as f32,
        }
    };
    let sensor = tp::SensorModel {
        phi_rad: phi,
        psi_rad: psi,
        sigma_m: sigma,
        height_m: h,
        max_range_m: range,
    };
    let schedule = tp::Schedule {
        base_m: base,
        gamma,
        gate,
        uniform_resolution: false,
    };
    // The smallest window that holds every band (if any), so that most configurations pass.
    let o = harness::reference_design(&sensor, &schedule, 1024, 1 << 20);
    let cells = o.result.map_or(1024, |d| {
        d.layers
            .iter()
            .map(|l| l.cells_needed)
            .max()
            .unwrap_or(4)
            .clamp(4, 1024)
    });
    (sensor, schedule, cells)
}

#[derive(Default)]
struct DesignErrors {
    configs: usize,
    accepted: usize,
    refused_same: usize,
    refused_disagree: usize,
    fragile: usize,
    layers: usize,
    count_disagree: usize,
    delta_rel: f64,
    resolution_rel: f64,
    edge_abs: f64,
    edge_rel: f64,
    edge_defect: f64,
    centre_abs: f64,
    sigma_abs: f64,
    sigma_rel: f64,
    edge_over_tolerance: f64,
    table_own_max_ulp: u32,
    table_outside_range: usize,
    table_bins: usize,
    table_max_ulp: u32,
    table_mismatch_bins: usize,
    table_tie_distance: f64,
    table_abs: f64,
    hard_skipped_bins: usize,
    hard_max_ulp_all: u32,
}

fn design_and_tables(configs: usize, default_only: bool) -> DesignErrors {
    let mut rng = Rng::new(0x5eed_0001);
    let mut e = DesignErrors::default();
    for n in 0..configs {
        let (sensor, schedule, cells) = if default_only {
            let gate = if n == 0 {
                tp::GateShape::default()
            } else {
                tp::GateShape::Hard
            };
            (
                tp::SensorModel::default(),
                tp::Schedule {
                    gate,
                    ..tp::Schedule::default()
                },
                64,
            )
        } else {
            random_config(&mut rng)
        };
        e.configs += 1;
        let rs = harness::sensor(&sensor);
        let rsch = harness::schedule(&schedule);
        // δ itself, sampled over the range.
        for i in 0..=64 {
            let d = f64::from(sensor.max_range_m) * f64::from(i) / 64.0;
            let want = rs.delta(f64::from(d as f32));
            let got = f64::from(sensor.bound(d as f32).total_m);
            e.delta_rel = e.delta_rel.max(((got - want) / want).abs());
        }
        let outcome = bands::design(&rs, &rsch, cells, CAPACITY);
        let lib = tp::Design::<CAPACITY>::new(sensor, schedule, cells);
        if !outcome.fragile.is_empty() {
            e.fragile += 1;
            continue;
        }
        let rd = match (&outcome.result, &lib) {
            (Ok(rd), Ok(_)) => rd,
            (Err(v), Err(le)) => {
                if harness::refusal_matches(le, v) {
                    e.refused_same += 1;
                } else {
                    e.refused_disagree += 1;
                    println!("<!-- refusal disagrees: {le:?} vs {v:?} -->");
                }
                continue;
            }
            (r, l) => {
                e.refused_disagree += 1;
                println!(
                    "<!-- verdict disagrees: reference {:?}, library {:?} -->",
                    r.as_ref().err(),
                    l.as_ref().err()
                );
                continue;
            }
        };
        let Ok(ld) = lib else { continue };
        e.accepted += 1;
        if ld.layers().len() != rd.layers.len() {
            e.count_disagree += 1;
            continue;
        }
        let n_layers = rd.layers.len();
        for (k, (l, r)) in ld.layers().iter().zip(&rd.layers).enumerate() {
            e.layers += 1;
            let rel = |a: f32, b: f64| {
                if b == 0.0 {
                    f64::from(a).abs()
                } else {
                    ((f64::from(a) - b) / b).abs()
                }
            };
            e.resolution_rel = e.resolution_rel.max(rel(l.resolution_m, r.resolution));
            if k + 1 < n_layers {
                e.edge_abs = e.edge_abs.max((f64::from(l.band_outer_m) - r.outer).abs());
                e.edge_rel = e.edge_rel.max(rel(l.band_outer_m, r.outer));
                let defect =
                    (rs.delta(f64::from(l.band_outer_m)) - r.resolution).abs() / r.resolution;
                e.edge_defect = e.edge_defect.max(defect);
                let over = (f64::from(l.band_outer_m) - r.outer).abs()
                    / bands::edge_tolerance(&rs, r.outer);
                e.edge_over_tolerance = e.edge_over_tolerance.max(over);
            }
            e.centre_abs = e
                .centre_abs
                .max((f64::from(l.gate_center_m) - r.centre).abs());
            if r.sigma_g > 0.0 {
                e.sigma_rel = e.sigma_rel.max(rel(l.gate_sigma_m, r.sigma_g));
                e.sigma_abs = e
                    .sigma_abs
                    .max((f64::from(l.gate_sigma_m) - r.sigma_g).abs());
            }
        }
        // Gate tables: against the f64 design, and against the library's own f32 design.
        let bins = DistanceBins::for_range(sensor.max_range_m);
        let tables = gate::Tables::new(rd);
        let mut own = rd.clone();
        for (r, l) in own.layers.iter_mut().zip(ld.layers()) {
            r.inner = f64::from(l.band_inner_m);
            r.outer = f64::from(l.band_outer_m);
            r.centre = f64::from(l.gate_center_m);
            r.sigma_g = f64::from(l.gate_sigma_m);
        }
        let own_tables = gate::Tables::new(&own);
        for k in 0..n_layers {
            let t = GateTable::build(&ld, k, bins);
            for (i, w) in t.weights().iter().enumerate() {
                let got = u32::from(w.to_bits());
                e.table_own_max_ulp = e.table_own_max_ulp.max(got.abs_diff(own_tables.raw[k][i]));
                let (lo, hi) = tables.raw_range[k][i];
                if !(lo..=hi).contains(&got) {
                    e.table_outside_range += 1;
                }
                let want = tables.raw[k][i];
                let ulp = got.abs_diff(want);
                let x = gate::bin_centre(i, tables.shift);
                if matches!(rsch.gate, bands::GateKind::Hard) {
                    e.hard_max_ulp_all = e.hard_max_ulp_all.max(ulp);
                    if gate::hard_bin_is_fragile(rd, k, x) {
                        e.hard_skipped_bins += 1;
                        continue;
                    }
                }
                e.table_bins += 1;
                e.table_max_ulp = e.table_max_ulp.max(ulp);
                let exact = tables.exact[k][i];
                e.table_abs = e.table_abs.max((f64::from(got) / 32_768.0 - exact).abs());
                if ulp != 0 {
                    e.table_mismatch_bins += 1;
                    let scaled = exact * 32_768.0;
                    let tie = (scaled - scaled.floor() - 0.5).abs();
                    e.table_tie_distance = e.table_tie_distance.max(tie);
                }
            }
        }
    }
    e
}

/// The soft gate's binning error, default design: per layer, measured and bound.
fn binning() -> Vec<(usize, f64, f64, f32, f64)> {
    let sensor = tp::SensorModel::default();
    let schedule = tp::Schedule::default();
    let rd = harness::reference_design(&sensor, &schedule, 64, 8)
        .result
        .expect("the default design is valid");
    let ld = tp::Design::<8>::new(sensor, schedule, 64).expect("the default design is valid");
    let bins = DistanceBins::for_range(sensor.max_range_m);
    let mut rows = Vec::new();
    for k in 0..rd.layers.len() {
        let (measured, bound) = gate::binning_error(&rd, k);
        let lib_bound = tp::gate::binning_error_bound(&ld.layers()[k], bins);
        // The whole error of the library's table against the continuous gate.
        let t = GateTable::build(&ld, k, bins);
        let shift = gate::bin_shift(rd.sensor.max_range).expect("valid range");
        let mut total = 0.0_f64;
        let steps = 20_000;
        for s in 0..=steps {
            let d = rd.sensor.max_range * f64::from(s) / f64::from(steps);
            let raw = (d * 65_536.0) as i32;
            let w = f64::from(t.weight(gate::bin_of_raw(raw, shift)).to_bits()) / 32_768.0;
            total = total.max((w - gate::continuous(&rd, k, f64::from(raw) / 65_536.0)).abs());
        }
        rows.push((k, measured, bound, lib_bound, total));
    }
    rows
}

struct PyramidRow {
    label: String,
    versus: &'static str,
    cmp: harness::Comparison,
    outcome_mismatches: usize,
    fused_agree: f64,
}

fn pyramid(
    updates: usize,
    clamp: tp::Clamp,
    shape: Shape,
    label: &str,
    seed: u64,
) -> Vec<PyramidRow> {
    let sensor = tp::SensorModel::default();
    let schedule = tp::Schedule::default();
    let design = tp::Design::<8>::new(sensor, schedule, 64).expect("the default design is valid");
    let config = tp::Config {
        clamp,
        ..tp::Config::default()
    };
    let mut lib: Box<tp::Pyramid<64, 8>> = Box::default();
    lib.configure(&design, &config).expect("configures");
    let rd = harness::reference_design(&sensor, &schedule, 64, 8)
        .result
        .expect("valid");
    let model = |arithmetic| Model {
        arithmetic,
        inverse: harness::inverse(&config.model),
        clamp: harness::clamp(&config.clamp),
    };
    let margin = f64::from(config.fused_margin);
    let mut quantised = Pyramid::new(&rd, model(Arithmetic::Quantised), margin);
    let mut ideal = Pyramid::new(&rd, model(Arithmetic::Ideal), margin);
    let rq: Vec<i64> = rd
        .layers
        .iter()
        .map(|l| resolution_raw(l.resolution))
        .collect();
    let mut rng = Rng::new(seed);
    let steps = workload::random(&mut rng, updates, &rq, rd.sensor.max_range, shape);
    let gates = harness::gates(&design, &config);
    let mismatches = workload::run(&steps, &mut lib, &gates, &mut [&mut quantised, &mut ideal]);
    let mut rows = Vec::new();
    for (reference, versus) in [(&quantised, "quantised spec"), (&ideal, "ideal f64")] {
        let cmp = harness::compare(&lib, reference);
        // The fused query at random points around the robot.
        let (mut agree, mut total, mut fused_violations) = (0u64, 0u64, 0usize);
        let robot = steps.iter().rev().find_map(|s| match s {
            workload::Step::Recentre(x, y) => Some((*x, *y)),
            workload::Step::Update(_) | workload::Step::Decay(_) => None,
        });
        let (rx, ry) = robot.unwrap_or((0, 0));
        for _ in 0..20_000 {
            let x = rx + rng.range_i64(-12 * 65_536, 12 * 65_536) as i32;
            let y = ry + rng.range_i64(-12 * 65_536, 12 * 65_536) as i32;
            total += 1;
            let got = harness::fused(lib.fused(harness::meters(x), harness::meters(y)));
            if got == reference.fused(x, y) {
                agree += 1;
            }
            if reference.fused_robust(x, y).is_some_and(|want| want != got) {
                fused_violations += 1;
            }
        }
        rows.push(PyramidRow {
            label: label.to_string(),
            versus,
            cmp,
            outcome_mismatches: fused_violations
                + if versus == "quantised spec" {
                    mismatches.len()
                } else {
                    0
                },
            fused_agree: agree as f64 / total as f64,
        });
    }
    rows
}

fn main() {
    let mut args = std::env::args().skip(1);
    let updates: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(100_000);
    let configs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(2_000);

    let d = design_and_tables(2, true);
    let e = design_and_tables(configs, false);
    println!("## Design: device f32 vs f64 reference\n");
    println!(
        "| quantity | default design (soft + hard) | {} random configurations |",
        e.configs
    );
    println!("| --- | --- | --- |");
    let row = |name: &str, a: String, b: String| println!("| {name} | {a} | {b} |");
    row(
        "δ(d), max relative error",
        format!("{:.2e}", d.delta_rel),
        format!("{:.2e}", e.delta_rel),
    );
    row(
        "r_k, max relative error",
        format!("{:.2e}", d.resolution_rel),
        format!("{:.2e}", e.resolution_rel),
    );
    row(
        "band edge d_k+1 (k < N−1), max abs error",
        format!("{:.2e} m", d.edge_abs),
        format!("{:.2e} m", e.edge_abs),
    );
    row(
        "band edge, max relative error",
        format!("{:.2e}", d.edge_rel),
        format!("{:.2e}", e.edge_rel),
    );
    row(
        "band edge defect abs(δ(d_lib) − r_k)/r_k",
        format!("{:.2e}", d.edge_defect),
        format!("{:.2e}", e.edge_defect),
    );
    row(
        "band edge error / test tolerance",
        format!("{:.3}", d.edge_over_tolerance),
        format!("{:.3}", e.edge_over_tolerance),
    );
    row(
        "gate centre c_k, max abs error",
        format!("{:.2e} m", d.centre_abs),
        format!("{:.2e} m", e.centre_abs),
    );
    row(
        "gate width σ_g,k, max abs error",
        format!("{:.2e} m", d.sigma_abs),
        format!("{:.2e} m", e.sigma_abs),
    );
    row(
        "gate width σ_g,k, max relative error",
        format!("{:.2e}", d.sigma_rel),
        format!("{:.2e}", e.sigma_rel),
    );
    row(
        "layer count differs",
        format!("{}", d.count_disagree),
        format!("{}", e.count_disagree),
    );
    println!(
        "\nrandom configurations: {} accepted by both ({} layers), {} refused by both for the same rule, {} verdicts disagree, {} skipped as fragile (a decision within 1e-5 of its threshold)\n",
        e.accepted, e.layers, e.refused_same, e.refused_disagree, e.fragile
    );
    println!("## Gate tables: Q1.15 (device, built from its f32 design) vs f64 reference\n");
    println!("| quantity | default design (soft + hard) | random configurations |");
    println!("| --- | --- | --- |");
    row(
        "bins compared",
        format!("{}", d.table_bins),
        format!("{}", e.table_bins),
    );
    row(
        "max abs(lib − round(w·2¹⁵)), gate of the library's own f32 design",
        format!("{} ULP", d.table_own_max_ulp),
        format!("{} ULP", e.table_own_max_ulp),
    );
    row(
        "max abs(lib − round(w·2¹⁵)), gate of the f64 design",
        format!("{} ULP", d.table_max_ulp),
        format!("{} ULP", e.table_max_ulp),
    );
    row(
        "bins that differ from round(w·2¹⁵) of the f64 design",
        format!("{}", d.table_mismatch_bins),
        format!("{}", e.table_mismatch_bins),
    );
    row(
        "max abs(w_lib − w) vs the unrounded f64 gate",
        format!("{:.2e}", d.table_abs),
        format!("{:.2e}", e.table_abs),
    );
    row(
        "entries outside the tolerated range (must be 0)",
        format!("{}", d.table_outside_range),
        format!("{}", e.table_outside_range),
    );
    row(
        "hard-gate bins within f32 error of a band edge (skipped)",
        format!("{}", d.hard_skipped_bins),
        format!("{}", e.hard_skipped_bins),
    );
    println!("\n(1 ULP = 2⁻¹⁵ ≈ 3.05e-5; the rounding alone contributes up to 2⁻¹⁶ ≈ 1.53e-5.)");
    println!("\n## Soft gate binning error, default design (b = 1/32 m)\n");
    println!("| layer | measured max abs(w(d) − w(x_bin)) | bound e^−½·b/(2σ_g) | library's reported bound (incl. 2⁻¹⁶) | library table vs continuous gate |");
    println!("| --- | --- | --- | --- | --- |");
    for (k, m, b, lb, t) in binning() {
        println!("| {k} | {m:.2e} | {b:.2e} | {lb:.2e} | {t:.2e} |");
    }

    println!("\n## Pyramid: Design::<8> defaults, W = 64, soft gate, {updates} random updates\n");
    println!("| scenario | versus | max abs(ΔL) | mean abs(ΔL) | class agrees (obst./nav./unknown) | observed differs | fused agrees | spec violations |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    let spread = Shape {
        spread: 36,
        recentre_probability: 0.01,
        jump_probability: 0.02,
        step_m: 1.0,
    };
    let dense = Shape {
        spread: 6,
        recentre_probability: 0.002,
        jump_probability: 0.0,
        step_m: 0.2,
    };
    for (clamp, cname) in [
        (tp::Clamp::default(), "clamp on"),
        (tp::Clamp::Off, "clamp off"),
    ] {
        for (shape, sname) in [(spread, "whole window"), (dense, "13×13 cells")] {
            let label = format!("{cname}, {sname}");
            for row in pyramid(updates, clamp, shape, &label, 0xA11CE) {
                let c = &row.cmp;
                println!(
                    "| {} | {} | {:.2} ULP | {:.3} ULP | {:.4} % | {} | {:.4} % | {} |",
                    row.label,
                    row.versus,
                    c.max_ulps,
                    c.mean_ulps(),
                    100.0 * c.class_share(),
                    c.observed_differs,
                    100.0 * row.fused_agree,
                    c.violations.len() + row.outcome_mismatches
                );
                for v in c.violations.iter().take(3) {
                    println!("<!-- violation: {v:?} -->");
                }
            }
        }
    }
}
