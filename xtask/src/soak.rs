//! `cargo xtask soak [--json] [--quick] [-- PYRAMID-SOAK-ARGS]`: builds the host tool and runs
//! `pyramid soak` (an hour of simulated driving through the host pipeline, ten minutes through
//! the firmware on QEMU; `--quick`: five minutes and half a minute, for CI). Fails when any of
//! the soak's checks fails. RELIABILITY.md, "Soak".
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// `cargo xtask soak`.
pub fn task(args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    let mut rest = false;
    for a in args {
        match a.as_str() {
            _ if rest => pass.push(a.clone()),
            "--json" | "--quick" => pass.push(a.clone()),
            "--" => rest = true,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask soak [--json] [--quick] \
                     [-- options of `pyramid soak`]"
                ))
            }
        }
    }
    let root = root();
    let t = Instant::now();
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(&root)
        .args([
            "build",
            "--release",
            "--quiet",
            "-p",
            "terrain-pyramid-host",
        ])
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("building the host tool failed ({status})"));
    }
    let pyramid = root.join("target").join("release").join("pyramid");
    let status = Command::new(&pyramid)
        .current_dir(&root)
        .arg("soak")
        .args(["--out", "target/soak"])
        .args(&pass)
        .status()
        .map_err(|e| format!("cannot run {}: {e}", pyramid.display()))?;
    eprintln!("xtask soak: done in {:.1} s", t.elapsed().as_secs_f64());
    if status.success() {
        Ok(())
    } else {
        Err(format!("the soak failed ({status})"))
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}
