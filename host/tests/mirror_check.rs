//! `summary.json`'s mirror check compares only what the device sent: a recording ends with
//! tiles the link's budget still holds back, and `pyramid run` has them sent before its final
//! snapshot, so that a cell that was merely not sent yet is never counted in
//! `mirror.resent_cells_differing`. In process (`--board host`), without decay: no QEMU.
use std::path::Path;
use std::process::Command;

mod common;
use common::{record_3dtk, succeeded, synthetic_recording, tmp, PYRAMID};

/// `pyramid run --board host --json` on `recording`; its summary.
fn run(recording: &Path, out: &Path) -> serde_json::Value {
    let output = succeeded(
        Command::new(PYRAMID)
            .args(["run", "--board", "host", "--json", "--recording"])
            .arg(recording)
            .arg("--out")
            .arg(out),
        "pyramid run failed: ",
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// Every resent cell equals the mirror's: nothing was pending when the snapshot came, and the
/// snapshot did compare cells (a mirror in step before it).
fn no_cell_differs(summary: &serde_json::Value) {
    let m = &summary["mirror"];
    assert!(
        m["resent_cells_compared"].as_u64().unwrap() > 0,
        "the snapshot compared nothing: {summary}"
    );
    assert_eq!(
        m["resent_cells_differing"], 0,
        "a cell not yet sent was counted as differing: {summary}"
    );
}

#[test]
fn a_run_without_decay_counts_no_pending_cell_as_differing() {
    let dir = tmp("mirror-check");
    let recording = dir.join("synthetic.rec");
    synthetic_recording(&recording);
    no_cell_differs(&run(&recording, &dir.join("synthetic")));
    // The real scan (226 lines, many tiles changed by its last observation), when present.
    if let Some(recording) = record_3dtk(&dir) {
        no_cell_differs(&run(&recording, &dir.join("3dtk")));
    }
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}
