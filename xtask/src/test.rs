//! `cargo xtask test [--lint]`: the whole test suite, from a fresh machine.
use crate::install::{ensure_python_readers, ensure_qemu, ensure_targets, step};

/// Runs the whole suite.
fn run_all(lint: bool) -> Result<(), String> {
    ensure_targets()?;
    ensure_qemu()?;
    ensure_python_readers()?;
    // Every host test: the library's unit and doc tests, the f64 references and property
    // tests, the simulator, the tools, and the firmware in QEMU against the host, bit for bit.
    step("cargo", &["test", "--workspace"])?;
    // The code's shape: imports point down the library's layers, no cycle, one definition
    // per public type name.
    step("cargo", &["xtask", "layers"])?;
    // The live chain: a short recording paced into the emulated board, Odometry from a
    // Cyclone DDS publisher through `pyramid listen --ros2 --odom-topic /odom`, inside a
    // network namespace of its own; held to `lab live`'s bounds. It needs root and unshare.
    match crate::lab::live_can_run() {
        Ok(()) => step("cargo", &["xtask", "live", "--check"])?,
        Err(why) => eprintln!("\n==> skipped: cargo xtask live --check ({why})"),
    }
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
