//! What the tasks that run the firmware need on a fresh machine, installed when missing: the
//! Cortex-M targets (rustup), QEMU (Debian's `qemu-system-arm`, through sudo when not root),
//! `defmt-print` (cargo install), and the Python readers the output tests use (pip).
//! `cargo xtask test` and `cargo xtask demo` share them. Installers log on stderr only: a
//! task's stdout is its result.
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The repository's root (the xtask crate sits one level below it).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// The target directory every board crate builds into (`boards/target`, their
/// `.cargo/config.toml`): the firmware's ELFs are under `TARGET/release/`.
pub fn boards_target_dir() -> PathBuf {
    root().join("boards").join("target")
}

/// Runs a command from the root, failing with its name when it fails; its output goes where
/// xtask's goes.
pub fn step(program: &str, args: &[&str]) -> Result<(), String> {
    run_step(program, args, Stdio::inherit())
}

/// [`step`] for an installer (apt-get, rustup, cargo install, pip): its stdout goes to stderr
/// too, so that a task's stdout holds only its result (one JSON object with `--json`) even on
/// a fresh machine where something is installed first.
pub fn install_step(program: &str, args: &[&str]) -> Result<(), String> {
    run_step(program, args, Stdio::from(std::io::stderr()))
}

fn run_step(program: &str, args: &[&str], stdout: Stdio) -> Result<(), String> {
    eprintln!("\n==> {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .current_dir(root())
        .stdout(stdout)
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

/// Whether a program answers `--version`.
pub fn present(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The Cortex-M targets the firmware and the on-target tests build for.
pub fn ensure_targets() -> Result<(), String> {
    install_step(
        "rustup",
        &[
            "target",
            "add",
            "thumbv7em-none-eabihf",
            "thumbv6m-none-eabi",
        ],
    )
}

/// QEMU for the emulated board, from Debian's packages, through sudo when not root.
pub fn ensure_qemu() -> Result<(), String> {
    if present("qemu-system-arm") {
        return Ok(());
    }
    let root_user = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0"));
    let (program, prefix): (&str, &[&str]) = if root_user {
        ("apt-get", &[])
    } else {
        ("sudo", &["apt-get"])
    };
    let with = |args: &[&str]| -> Vec<String> {
        prefix
            .iter()
            .chain(args)
            .map(|s| (*s).to_string())
            .collect()
    };
    for args in [
        with(&["update"]),
        with(&["install", "-y", "qemu-system-arm"]),
    ] {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        install_step(program, &refs)?;
    }
    Ok(())
}

/// `defmt-print`, which turns the firmware's raw defmt log into text. Built unoptimised
/// (`--debug`): it decodes logs of a few kilobytes, and the build takes about 40 s instead of
/// about two minutes.
pub fn ensure_defmt_print() -> Result<(), String> {
    if present("defmt-print") {
        return Ok(());
    }
    install_step("cargo", &["install", "--debug", "defmt-print", "--locked"])
}

/// The Python readers the tests of `pyramid listen`'s outputs check against (MCAP, the
/// Foxglove WebSocket protocol, Cyclone DDS): `host/tests/py/setup.sh` when one is missing.
pub fn ensure_python_readers() -> Result<(), String> {
    let present = Command::new("python3")
        .args([
            "-c",
            "import mcap, mcap_ros2, mcap_protobuf, websockets, cyclonedds",
        ])
        .output()
        .is_ok_and(|o| o.status.success());
    if present {
        return Ok(());
    }
    install_step("sh", &["host/tests/py/setup.sh"])
}
