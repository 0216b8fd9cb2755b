//! `pyramid design` as scripts use it: the JSON report, the refusals, the plot.
use serde_json::Value;
use std::path::PathBuf;
use std::process::Output;

mod common;

/// Runs `pyramid design ARGS`.
fn pyramid(args: &[&str]) -> Output {
    common::pyramid(&[&["design"], args].concat())
}

/// Runs `pyramid design --json ARGS`, checks it succeeded, and parses its stdout as one object.
fn design_json(args: &[&str]) -> Value {
    common::json_object("design", args).0
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Checks that a refused configuration exits 2, prints nothing on stdout and exactly one line on
/// stderr that names `flag`.
fn assert_refused(args: &[&str], flag: &str) {
    for json in [false, true] {
        let mut all = args.to_vec();
        if json {
            all.push("--json");
        }
        let out = pyramid(&all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{all:?}: stderr {stderr}");
        assert!(out.stdout.is_empty(), "{all:?}: stdout not empty");
        assert_eq!(stderr.lines().count(), 1, "{all:?}: stderr {stderr:?}");
        assert!(stderr.ends_with('\n'), "{all:?}: stderr {stderr:?}");
        assert!(stderr.contains(flag), "{all:?}: {stderr} names {flag}");
    }
}

#[test]
fn default_layers_have_contiguous_increasing_bands_up_to_the_max_range() {
    let v = design_json(&[]);
    let layers = v["layers"].as_array().expect("layers is an array");
    assert!(layers.len() >= 2);
    let first = &layers[0];
    assert_eq!(first["index"], 0);
    assert!(close(num(&first["resolution_m"]), 0.1, 1e-9));
    assert_eq!(num(&first["band_m"][0]), 0.0);
    assert!(close(num(&first["band_m"][1]), 0.53, 0.01));
    for (k, l) in layers.iter().enumerate() {
        assert_eq!(l["index"], k);
        let (inner, outer) = (num(&l["band_m"][0]), num(&l["band_m"][1]));
        assert!(outer > inner, "layer {k}: band {inner}..{outer}");
        assert_eq!(l["cells_per_side"], 64);
        let r = num(&l["resolution_m"]);
        assert!(close(num(&l["extent_m"]), 64.0 * r, 1e-3));
        assert!(close(num(&l["gate_center_m"]), 0.5 * (inner + outer), 2e-4));
        // The default soft gate's width is half the band's.
        assert!(close(num(&l["gate_sigma_m"]), 0.5 * (outer - inner), 2e-4));
    }
    for w in layers.windows(2) {
        assert_eq!(num(&w[0]["band_m"][1]), num(&w[1]["band_m"][0]));
        assert!(num(&w[1]["resolution_m"]) > num(&w[0]["resolution_m"]));
        assert!(num(&w[1]["band_m"][1]) > num(&w[0]["band_m"][1]));
    }
    let last = layers.last().unwrap();
    assert_eq!(num(&last["band_m"][1]), 10.0);
}

#[test]
fn default_bound_lists_the_distances_and_matches_the_paper_notes() {
    let v = design_json(&[]);
    let bound = v["bound"].as_array().expect("bound is an array");
    let ds: Vec<f64> = bound.iter().map(|b| num(&b["d_m"])).collect();
    assert_eq!(ds, vec![0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0]);
    for b in bound {
        let sum = num(&b["noise_m"]) + num(&b["horizontal_m"]) + num(&b["vertical_m"]);
        // Each of the four is rounded to 0.1 mm.
        assert!(close(num(&b["total_m"]), sum, 3e-4), "{b}");
    }
    let total_at = |d: f64| {
        bound
            .iter()
            .find(|b| num(&b["d_m"]) == d)
            .map(|b| num(&b["total_m"]))
            .unwrap()
    };
    // paper-notes check values, h = 1 m.
    assert!(close(total_at(1.0), 0.158, 0.003));
    assert!(close(total_at(5.0), 0.548, 0.003));
    assert!(close(total_at(10.0), 1.380, 0.003));
}

#[test]
fn static_ram_counts_every_layer() {
    let v = design_json(&[]);
    let n = v["layers"].as_array().unwrap().len() as u64;
    // Each layer: 64 × 64 cells of 2 bytes in the pyramid and a 1 KiB gate table (512 bins
    // of 2 bytes) in the classifier, which owns the gating, plus small headers.
    let ram = v["static_ram_bytes"].as_u64().unwrap();
    let floor = n * (64 * 64 * 2 + 512 * 2);
    assert!(ram >= floor && ram < floor + n * 64 + 256, "{ram}");
}

#[test]
fn the_bound_stops_at_a_shorter_max_range_and_lists_it() {
    let v = design_json(&["--max-range-m", "4"]);
    let ds: Vec<f64> = v["bound"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| num(&b["d_m"]))
        .collect();
    assert_eq!(ds, vec![0.5, 1.0, 2.0, 3.0, 4.0]);
    let layers = v["layers"].as_array().unwrap();
    assert_eq!(num(&layers.last().unwrap()["band_m"][1]), 4.0);
}

#[test]
fn the_hard_gate_has_no_width_and_degrees_are_converted() {
    let v = design_json(&[
        "--gate",
        "hard",
        "--phi-deg",
        "1",
        "--height-m",
        "0.5",
        "--gamma",
        "4",
    ]);
    for l in v["layers"].as_array().unwrap() {
        assert_eq!(num(&l["gate_sigma_m"]), 0.0);
    }
    // δ(0.5) with φ = 1°, ψ = 2°, σ = 0.15 m, h = 0.5 m.
    let (phi, psi, sigma, h, d): (f64, f64, f64, f64, f64) =
        (1f64.to_radians(), 2f64.to_radians(), 0.15, 0.5, 0.5);
    let delta = sigma / (1.0 + (h / d) * (h / d)).sqrt()
        + 2.0 * d * (psi / 2.0).atan()
        + phi * (d * d + h * h) / h;
    let b = &v["bound"][0];
    assert_eq!(num(&b["d_m"]), 0.5);
    assert!(close(num(&b["total_m"]), delta, 2e-4), "{b} vs {delta}");
}

#[test]
fn the_table_is_printed_without_json() {
    let out = pyramid(&[]);
    assert!(out.status.success());
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("Layers (8)"), "{stdout}");
    assert!(stdout.contains("Static RAM"), "{stdout}");
    assert!(stdout.contains("1.3797"), "{stdout}");
}

/// Each refused configuration: what is wrong, its flags, the flag the refusal names.
const REFUSALS: &[(&str, &[&str], &str)] = &[
    ("gamma one", &["--gamma", "1"], "--gamma"),
    (
        "a base cell below a centimetre",
        &["--base-m", "0.001"],
        "--base-m",
    ),
    ("a NaN sigma", &["--sigma-m", "nan"], "--sigma-m"),
    // Negative and infinite values reach the library, which names them.
    ("a negative height", &["--height-m", "-1"], "--height-m"),
    ("an infinite psi", &["--psi-deg", "-inf"], "--psi-deg"),
    (
        "an infinite range",
        &["--max-range-m", "inf"],
        "--max-range-m",
    ),
    (
        "a window too small for its band",
        &["--cells", "8"],
        "--cells",
    ),
    (
        "a plot that is not a PNG",
        &["--plot", "figure.svg"],
        "--plot",
    ),
];

#[test]
fn every_refused_configuration_is_refused_by_name() {
    for (what, args, flag) in REFUSALS {
        eprintln!("{what}");
        assert_refused(args, flag);
    }
}

/// A file under the target directory, removed first.
fn scratch_file(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

#[test]
fn the_plot_is_a_png_and_json_stays_alone_on_stdout() {
    let path = scratch_file("design_cli_fig2.png");
    let v = design_json(&["--plot", path.to_str().unwrap()]);
    assert!(v["layers"].is_array());
    let bytes = std::fs::read(&path).expect("the plot was written");
    assert!(bytes.len() > 1000, "{} bytes", bytes.len());
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn a_refused_configuration_writes_no_plot() {
    let path = scratch_file("design_cli_refused.png");
    assert_refused(
        &["--gamma", "0.5", "--plot", path.to_str().unwrap()],
        "--gamma",
    );
    assert!(!path.exists());
}

#[test]
fn an_unwritable_plot_fails_with_one_line() {
    let dir = scratch_file("design_cli_not_a_dir");
    std::fs::write(&dir, b"a file, not a directory").unwrap();
    let path = dir.join("fig2.png");
    let out = pyramid(&["--json", "--plot", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr:?}");
    assert!(stderr.contains("--plot"), "{stderr}");
}

/// The LD19 of `examples/rigs/ld19-nodding.toml`, nodding at 15 °/s (φ 1.5°, ψ 0.8°,
/// σ 0.045 m, h 1 m) to 8 m: the design of γ = 2 needs more than a board's 8 layers.
const LD19_8M: [&str; 8] = [
    "--phi-deg",
    "1.5",
    "--psi-deg",
    "0.8",
    "--sigma-m",
    "0.045",
    "--max-range-m",
    "8",
];

#[test]
fn fit_layers_raises_gamma_to_the_smallest_that_fits_and_reports_it() {
    let layers = |v: &Value| v["layers"].as_array().expect("layers").len();
    let unfitted = design_json(&LD19_8M);
    assert_eq!(num(&unfitted["gamma"]), 2.0);
    assert!(
        layers(&unfitted) > 8,
        "γ = 2 already fits: {}",
        layers(&unfitted)
    );
    let fitted = design_json(&[&LD19_8M[..], &["--fit-layers", "8"]].concat());
    let gamma = num(&fitted["gamma"]);
    assert!(layers(&fitted) <= 8);
    // The same design as asked for by γ directly, and half a step less does not fit.
    let direct = design_json(&[&LD19_8M[..], &["--gamma", &gamma.to_string()]].concat());
    assert_eq!(fitted, direct);
    let less = design_json(&[&LD19_8M[..], &["--gamma", &(gamma - 0.5).to_string()]].concat());
    assert!(layers(&less) > 8, "γ {} fits too", gamma - 0.5);
    // A design that fits already keeps its γ.
    let kept = design_json(&["--fit-layers", "16"]);
    assert_eq!(kept, design_json(&[]));
    // The table says what was fitted.
    let out = pyramid(&[&LD19_8M[..], &["--fit-layers", "8"]].concat());
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table.contains(&format!(
            "Fitted to 8 layers: gamma {gamma} (from --gamma 2)"
        )),
        "{table}"
    );
}

#[test]
fn a_fit_no_gamma_can_make_or_a_bad_count_is_refused_by_name() {
    // One layer cannot reach 8 m at any γ (layer 0's band ends where δ(d) passes Δd).
    assert_refused(
        &[&LD19_8M[..], &["--fit-layers", "1"]].concat(),
        "--fit-layers",
    );
    // What γ cannot mend is refused as without the flag.
    assert_refused(&["--phi-deg", "-1", "--fit-layers", "8"], "--phi-deg");
    for bad in ["0", "17", "eight"] {
        let out = pyramid(&["--fit-layers", bad]);
        assert_eq!(out.status.code(), Some(2), "--fit-layers {bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--fit-layers"));
    }
}

#[test]
fn a_reader_that_goes_away_ends_the_command_quietly() {
    // `pyramid design --json | true`: the pipe's reader is gone before the answer is
    // written; a Unix tool ends quietly (print! panicked with status 101).
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args(["design", "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_rig_file_s_design_is_the_one_its_flags_give() {
    let rig = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/rigs/ld19-nodding.toml"
    );
    // The example's [design], written out as flags (the file's comment says the same).
    let flags = design_json(&[&LD19_8M[..], &["--height-m", "1", "--fit-layers", "8"]].concat());
    assert_eq!(design_json(&["--rig", rig]), flags);
    // Another window: the device's, as `listen` builds it.
    assert_eq!(
        design_json(&["--rig", rig, "--cells", "128"]),
        design_json(
            &[
                &LD19_8M[..],
                &["--height-m", "1", "--fit-layers", "8", "--cells", "128"]
            ]
            .concat()
        )
    );
    // The sensor and schedule flags may not be given with it; a rig without [design] is
    // refused by name.
    let out = pyramid(&["--rig", rig, "--gamma", "3"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--gamma"));
    let sick = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/rigs/sick-tilt.toml"
    );
    let out = pyramid(&["--rig", sick]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("has no [design]"));
}

/// The LD19 of docs/lidars.md nodding at 20 °/s (φ 2° at 10 Hz, h 1 m) for its stairs' 0.17 m
/// risers: a line every 0.593 m at 4 m (0.034907 · 17), every step sure within 3.52 m, and
/// from 4 m with φ ≤ 0.467 / 17 rad = 1.574°, a nod of 15.74 °/s (worked in `nod.rs`).
#[test]
fn a_nodding_lidar_s_plan_is_in_the_json_and_the_table() {
    // An LD19 nodding at 20 °/s (φ 2°, ψ 0.8°, σ 0.045 m), to 10 m with γ 3 (14 layers).
    let flags = [
        &["--phi-deg", "2", "--psi-deg", "0.8", "--sigma-m", "0.045"][..],
        &[
            "--max-range-m",
            "10",
            "--gamma",
            "3",
            "--revolution-hz",
            "10",
            "--step-m",
            "0.17",
            "--sure-from-m",
            "4",
        ],
    ]
    .concat();
    let v = design_json(&flags);
    let n = &v["nodding"];
    assert!(close(num(&n["nod_deg_s"]), 20.0, 1e-9), "{n}");
    assert!(close(num(&n["sure_within_m"]), 3.52, 0.005), "{n}");
    assert!(
        close(num(&n["sure_from"]["max_nod_deg_s"]), 15.74, 0.01),
        "{n}"
    );
    let at_4 = n["spacing"]
        .as_array()
        .and_then(|s| s.iter().find(|p| num(&p["d_m"]) == 4.0))
        .expect("the spacing at 4 m");
    assert!(close(num(&at_4["spacing_m"]), 0.5934, 1e-3), "{at_4}");
    // Without the rate there is no plan; the table carries it when asked.
    assert!(design_json(&[]).get("nodding").is_none());
    let out = pyramid(&flags);
    assert!(out.status.success());
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("phi is a nod of 20.00°/s"), "{table}");
    assert!(table.contains("a nod of at most 15.74°/s"), "{table}");
    // A bad rate or step is refused by name, before any plot is written.
    assert_refused(&["--revolution-hz", "0"], "--revolution-hz");
    assert_refused(&["--revolution-hz", "10", "--step-m", "-1"], "--step-m");
    let png = scratch_file("nod_refused.png");
    let _ = std::fs::remove_file(&png);
    let out = pyramid(&[
        "--revolution-hz",
        "nan",
        "--plot",
        png.to_str().expect("a UTF-8 path"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!png.exists());
}
