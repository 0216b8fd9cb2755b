//! The emulated co-processor against the in-process pipeline: `pyramid run --board qemu` (and
//! `--board netduinoplus2`, the STM32F4 firmware) and `--board host` on the same recording and
//! flags must give bit-identical layers (every raw cell of every layer, the windows' origins
//! and resolutions). The micro:bit, whose pyramid is smaller, has its own: `run_microbit.rs`.
//!
//! QEMU (`qemu-system-arm`) and the `thumbv7em-none-eabihf` target are required: without them
//! the test FAILS, unless `PYRAMID_SKIP_QEMU=1` is set. The 3DTK scan (`../shared/data`) is
//! used when present; a small synthetic recording written here always runs.
use std::path::Path;
use std::process::Command;

mod common;
use common::{qemu_ready, record_3dtk, synthetic_recording, tmp, PYRAMID};

fn run(board: &str, recording: &Path, out: &Path, flags: &[&str]) -> serde_json::Value {
    let output = Command::new(PYRAMID)
        .args(["run", "--board", board, "--json", "--recording"])
        .arg(recording)
        .arg("--out")
        .arg(out)
        .args(flags)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "pyramid run --board {board} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// Runs `--board host` and `--board board` and compares every raw cell; returns the number of
/// cells compared.
fn compare(board: &str, recording: &Path, dir: &Path, flags: &[&str]) -> usize {
    let (host_dir, qemu_dir) = (dir.join("host"), dir.join(board));
    let host = run("host", recording, &host_dir, flags);
    let qemu = run(board, recording, &qemu_dir, flags);
    assert_eq!(host["telegrams_sent"], qemu["telegrams_sent"]);
    assert_eq!(host["telegrams_applied"], qemu["telegrams_applied"]);
    assert_eq!(qemu["telegrams_applied"], qemu["telegrams_sent"]);
    // Stats carries the observations (protocol version 2).
    assert_eq!(host["observations"], qemu["observations"]);
    assert_eq!(qemu["link_crc_errors"], 0);
    assert_eq!(
        host["layers"], qemu["layers"],
        "per-layer counts and origins"
    );
    assert_eq!(host["fused"], qemu["fused"]);
    assert_eq!(host["layers_hash"], qemu["layers_hash"]);
    let layers = host["layers"].as_array().unwrap().len();
    assert!(layers > 0);
    let mut cells = 0;
    for k in 0..layers {
        let name = format!("cells-{k}.bin");
        let a = std::fs::read(host_dir.join(&name)).unwrap();
        let b = std::fs::read(qemu_dir.join(&name)).unwrap();
        assert_eq!(a.len(), 64 * 64 * 2);
        assert!(a == b, "layer {k}: the raw cells differ");
        cells += a.len() / 2;
    }
    let observed: u64 = host["layers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["observed_cells"].as_u64().unwrap())
        .sum();
    assert!(
        observed > 0,
        "nothing was observed: the comparison is empty"
    );
    let stack = qemu["stack_bytes"].as_u64().unwrap_or(0);
    assert!(
        stack > 0,
        "{board}: no stack high-water mark in the Reply to Shutdown"
    );
    eprintln!(
        "{board}: {cells} cells compared ({observed} observed): identical, layers_hash {}, \
         stack high-water {stack} bytes",
        host["layers_hash"]
    );
    cells
}

/// The synthetic recording through `board` and the host, compared cell for cell.
fn synthetic(board: &str) {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp(&format!("synthetic-{board}"));
    let recording = dir.join("synthetic.rec");
    synthetic_recording(&recording);
    let cells = compare(board, &recording, &dir, &["--drop-m", "0.3"]);
    assert_eq!(cells, 8 * 64 * 64);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The 3DTK scan (when present) through `board` and the host, compared cell for cell.
fn scan_3dtk(board: &str) {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp(&format!("3dtk-{board}"));
    let Some(recording) = record_3dtk(&dir) else {
        return;
    };
    let flags = ["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"];
    compare(board, &recording, &dir, &flags);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn qemu_matches_host_on_a_synthetic_recording() {
    synthetic("qemu");
}

#[test]
fn qemu_matches_host_on_the_3dtk_scan() {
    scan_3dtk("qemu");
}

/// The STM32F4 firmware on QEMU's STM32F405 (a stand-in scanner answers its bring-up).
#[test]
fn netduinoplus2_matches_host_on_a_synthetic_recording() {
    synthetic("netduinoplus2");
}

#[test]
fn netduinoplus2_matches_host_on_the_3dtk_scan() {
    scan_3dtk("netduinoplus2");
}
