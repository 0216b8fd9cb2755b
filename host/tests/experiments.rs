//! `pyramid experiments --quick`: the paper's three claims, held on the simulator.
//!
//! - Stairs (Figs 5-7): after standing 20 m from the stairs for 2 minutes and driving up to
//!   1.0 m, the pyramid (all layers at 0.1 m) marks at least 90 % of the step cells, the
//!   unclamped flat grid at most 20 %.
//! - Coverage (Figs 8-9): the pyramid's holes are at most a third of the fixed grid's.
//! - Cost: asserted only on a deterministic proxy, the evidence records per line (the
//!   pyramid's coarse far layers write fewer records than the 0.1 m grid: 0.59×). The median
//!   wall-clock ratio is reported in `results.json` but NOT asserted: on the shared 2-core
//!   machine it measured between 1.1× and 3.5× (the pyramid steady at about 32 µs per line,
//!   the single grid 9-32 µs), and the classifier looks up every layer's gate for every
//!   point, which the records proxy does not see; the paper's "only marginally more
//!   expensive" (≤ 1.5×) is therefore not established for wall-clock time.
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

fn out_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pyramid-experiments-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run_quick() -> (Value, PathBuf) {
    let dir = out_dir();
    let output = Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args(["experiments", "--quick", "--json", "--out"])
        .arg(&dir)
        .output()
        .expect("pyramid runs");
    assert!(
        output.status.success(),
        "pyramid experiments failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json: Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    (json, dir)
}

fn f(v: &Value, path: &[&str]) -> f64 {
    let mut v = v;
    for p in path {
        v = &v[*p];
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {v}"))
}

#[test]
fn the_papers_claims_hold_on_the_simulator() {
    let (r, dir) = run_quick();

    // Stairs.
    let pyramid = f(&r, &["stairs", "pyramid", "detected_fraction"]);
    let soft = f(&r, &["stairs", "pyramid_soft", "detected_fraction"]);
    let flat = f(&r, &["stairs", "flat", "detected_fraction"]);
    assert!(
        pyramid >= 0.9,
        "pyramid (hard gate) marks only {pyramid} of the step cells"
    );
    assert!(
        soft >= 0.9,
        "pyramid (soft gate) marks only {soft} of the step cells"
    );
    assert!(flat <= 0.2, "the flat grid marks {flat} of the step cells");
    // Fig. 5: from far away every map calls the observed step cells free.
    for map in ["flat", "flat_clamped", "pyramid", "pyramid_soft"] {
        let obstacle = f(&r, &["stairs", map, "far", "obstacle"]);
        assert!(
            obstacle < 0.05,
            "{map} sees the stairs from far away: {obstacle}"
        );
    }
    // The pyramid sees the first step in time to stop; the flat grid never.
    assert!(r["stairs"]["flat"]["detect_distance_m"].is_null());
    assert!(f(&r, &["stairs", "pyramid", "detect_distance_m"]) >= 2.0);

    // Coverage.
    let fixed = f(&r, &["coverage", "fixed", "holes_fraction"]);
    let multi = f(&r, &["coverage", "pyramid", "holes_fraction"]);
    assert!(fixed > 0.0);
    assert!(
        multi <= fixed / 3.0,
        "pyramid holes {multi} vs fixed grid holes {fixed}"
    );

    // Cost: the deterministic proxy; the timed ratio must at least be there.
    let records = f(&r, &["cost", "records_ratio"]);
    assert!(
        records <= 1.5,
        "the pyramid produces {records}× the records"
    );
    assert!(f(&r, &["cost", "pyramid_over_flat"]) > 0.0);

    // The files.
    for name in [
        "fig2.png",
        "stairs.png",
        "stairs-detection.png",
        "coverage.png",
        "report.md",
        "results.json",
    ] {
        assert!(dir.join(name).is_file(), "{name} was not written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
