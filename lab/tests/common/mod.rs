//! What the `lab` command's tests share: running it for its JSON, and reading numbers out.
#![allow(dead_code)]

use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// Runs `lab` with `args` and then `out` (the output directory, the last argument); asserts
/// that it succeeded (its stderr in the message). Returns its stdout as one JSON object and
/// its stderr.
pub fn run_lab(args: &[&str], out: &Path) -> (Value, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(args)
        .arg(out)
        .output()
        .expect("lab runs");
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(
        output.status.success(),
        "lab {} failed: {stderr}",
        args.first().copied().unwrap_or_default()
    );
    let json: Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    (json, stderr)
}

/// The number at `path` (object keys) in `v`; panics when it is not one.
pub fn f(v: &Value, path: &[&str]) -> f64 {
    let mut v = v;
    for p in path {
        v = &v[*p];
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {v}"))
}
