//! `cargo xtask faults [--json] [--quick] [--only KIND,..] [--lines N]`: fault injection through
//! the emulated board (RELIABILITY.md). Builds the host tool and the QEMU firmware
//! (release) and runs `pyramid faults`: one run of the firmware in QEMU per fault kind, each
//! compared with the host's reference map. The table goes to stderr; with `--json`, stdout
//! holds `{"faults":[...]}`. Fails when any kind's outcome is bad.
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// `cargo xtask faults`.
pub fn task(args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    let mut rest = args.iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--json" | "--quick" => pass.push(a.clone()),
            "--only" | "--lines" => {
                let value = rest.next().ok_or(format!("{a} needs a value"))?;
                pass.push(a.clone());
                pass.push(value.clone());
            }
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask faults [--json] [--quick] \
                     [--only KIND,..] [--lines N]"
                ))
            }
        }
    }
    let started = Instant::now();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args([
            "run",
            "--release",
            "--quiet",
            "-p",
            "terrain-pyramid-host",
            "--",
            "faults",
            "--out",
            "target/faults",
        ])
        .args(&pass)
        .current_dir(root())
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    eprintln!(
        "xtask faults: done in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    if status.success() {
        Ok(())
    } else {
        Err(format!("pyramid faults failed ({status})"))
    }
}
