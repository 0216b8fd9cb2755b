//! The 3DTK scan through `pyramid run --board host` (docs/guide.md's replay flags: `--height-m 0.4
//! --max-range-m 8 --gamma 3`) under each navigability rule, pinned by the maps' hash.
//!
//! - `--rule paper`: `de7d71d3e1d71392`, the hash every board gave before the plane rule
//!   existed (docs/measurements.md, BENCHMARKS.md): the paper's rule, carried to the co-processor in the
//!   link's Setup, still gives those maps bit for bit.
//! - the default (`--rule plane`): `e8d966e726a80cc7`, measured when neighbouring cells'
//!   lowest returns began to pair at any run within their two cells (`docs/core.md`, "The
//!   step between neighbouring cells' lowest returns"; `4f235b861aa69c73` before it, when
//!   they paired less than a cell's side apart; `2df1bca4cb673a0c` before that, from the pair
//!   test across a cell's edge,
//!   which took the tilt lines' consecutive returns that straddle an edge;
//!   `eaa2ac2a9f922126` before that, from the
//!   rise test that stopped adding the step to the largest slope on; `cc5fae74d9e79b55` before
//!   that, from the extremes test on, which the pair test within a cell left unchanged;
//!   `7f72fd2277f75e1e` before the extremes test); a change to the plane rule's arithmetic
//!   changes it, and then this pin is renewed with the reason.
//! - the default rule with `--p-obstacle 0.9` (the inverse sensor model travels in the
//!   link's Configure): `745cdaffa1984616`.
mod common;

use common::{record_3dtk, succeeded, tmp, PYRAMID};
use std::path::Path;
use std::process::Command;

fn hash(recording: &Path, out: &Path, rule: &[&str]) -> String {
    let output = succeeded(
        Command::new(PYRAMID)
            .args(["run", "--board", "host", "--json", "--recording"])
            .arg(recording)
            .arg("--out")
            .arg(out)
            .args(["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"])
            .args(rule),
        "",
    );
    let v: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    v["layers_hash"].as_str().unwrap().to_string()
}

#[test]
fn the_3dtk_maps_under_each_rule() {
    let dir = tmp("rule-hash");
    let Some(recording) = record_3dtk(&dir) else {
        return;
    };
    let paper = hash(&recording, &dir.join("paper"), &["--rule", "paper"]);
    let default = hash(&recording, &dir.join("default"), &[]);
    let plane = hash(&recording, &dir.join("plane"), &["--rule", "plane"]);
    assert_eq!(paper, "de7d71d3e1d71392", "the paper's rule");
    assert_eq!(default, "e8d966e726a80cc7", "the default rule");
    assert_eq!(plane, default);
    // A parameter of the plane rule travels too: a 2 cm step allowance changes the maps.
    let strict = hash(
        &recording,
        &dir.join("strict"),
        &["--rule", "plane", "--step-m", "0.02"],
    );
    assert_ne!(strict, default);
    // So does the inverse sensor model (`--p-obstacle`): an obstacle verdict adds logit(0.9).
    let strong = hash(&recording, &dir.join("strong"), &["--p-obstacle", "0.9"]);
    assert_eq!(
        strong, "745cdaffa1984616",
        "the default rule, p_obstacle 0.9"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plane_parameters_under_the_papers_rule_are_refused() {
    let output = Command::new(PYRAMID)
        .args(["run", "--board", "host", "--recording", "/nonexistent.rec"])
        .args([
            "--out",
            "/nonexistent-dir",
            "--rule",
            "paper",
            "--residual-m",
            "0.02",
        ])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("--residual-m is a parameter of --rule plane"),
        "{stderr}"
    );
}

/// `pyramid replay` takes the same flags: its summary names the rule, and the paper's rule
/// leaves fewer of the scan's cells navigable than the plane rule (the floor falls about 4°).
#[test]
fn replay_names_and_applies_the_rule() {
    let scan = common::shared("scan000.3d");
    if !scan.is_file() {
        eprintln!("note: {} is absent: skipped", scan.display());
        return;
    }
    let dir = tmp("rule-replay");
    let run = |rule: &str| -> serde_json::Value {
        let output = succeeded(
            Command::new(PYRAMID)
                .args(["replay", "--json", "--points"])
                .arg(&scan)
                .arg("--out")
                .arg(dir.join(rule))
                .args(["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"])
                .args(["--ceiling-m", "1.2", "--rule", rule]),
            "",
        );
        serde_json::from_slice(&output.stdout).unwrap()
    };
    let (paper, plane) = (run("paper"), run("plane"));
    assert_eq!(paper["rule"], "paper (step 0.05 m)");
    assert!(plane["rule"]
        .as_str()
        .unwrap()
        .starts_with("plane (step 0.05 m, slope 20.0°"));
    let free = |v: &serde_json::Value| v["fused"]["free_cells"].as_u64().unwrap();
    assert!(
        free(&plane) > free(&paper),
        "{} vs {}",
        free(&plane),
        free(&paper)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
