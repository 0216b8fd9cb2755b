//! `cargo xtask test [--lint]`: the whole test suite, from a fresh machine.
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root (the xtask crate sits one level below it).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Runs a command from the root, failing with its name when it fails.
fn step(program: &str, args: &[&str]) -> Result<(), String> {
    eprintln!("\n==> {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .current_dir(root())
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

/// Whether a program answers `--version`.
fn present(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// QEMU for the emulated board, from Debian's packages, through sudo when not root.
fn ensure_qemu() -> Result<(), String> {
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
        step(program, &refs)?;
    }
    Ok(())
}

/// Runs the whole suite.
fn run_all(lint: bool) -> Result<(), String> {
    step(
        "rustup",
        &[
            "target",
            "add",
            "thumbv7em-none-eabihf",
            "thumbv6m-none-eabi",
        ],
    )?;
    ensure_qemu()?;
    // Every host test: the library's unit and doc tests, the f64 references and property
    // tests, the simulator, the tools, and the firmware in QEMU against the host, bit for bit.
    step("cargo", &["test", "--workspace"])?;
    // The boards: builds, the firmware on the emulated board, the on-target tests (thumbv7em
    // and thumbv6m code), flash, RAM and stack. It installs defmt-print when missing.
    if lint {
        step("bash", &["boards/check.sh"])
    } else {
        step("bash", &["boards/check.sh", "--no-lint"])
    }
}

/// `cargo xtask test [--lint]`.
pub fn run(args: &[String]) -> Result<(), String> {
    let mut lint = false;
    for arg in args {
        match arg.as_str() {
            "--lint" => lint = true,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask test [--lint]"
                ))
            }
        }
    }
    run_all(lint)
}
