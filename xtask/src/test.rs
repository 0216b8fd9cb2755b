//! `cargo xtask test [--lint] [--jobs N]`: the whole test suite, from a fresh machine.
use crate::install::{ensure_python_readers, ensure_qemu, ensure_targets, root, step};
use crate::{pool, prebuild};

/// Runs the whole suite.
fn run_all(lint: bool, jobs: usize) -> Result<(), String> {
    ensure_targets()?;
    ensure_qemu()?;
    ensure_python_readers()?;
    let root = root();
    // Every host test: the library's unit tests, the f64 references and property tests, the
    // simulator, the tools, and the firmware in QEMU against the host, bit for bit. The same
    // binaries `cargo test --workspace` builds and runs, here side by side (module `pool`).
    // The emulated boards' runs keep their outputs in `runs`, where boards/check.sh reads the
    // firmware's logs instead of running them again.
    let work = root.join("target").join("xtask-test");
    let runs = work.join("runs");
    let _ = std::fs::remove_dir_all(&runs);
    std::fs::create_dir_all(&runs).map_err(|e| format!("{}: {e}", runs.display()))?;
    let logs = work.join("logs");
    std::fs::create_dir_all(&logs).map_err(|e| format!("{}: {e}", logs.display()))?;
    let firmware_log = logs.join("firmware-prebuild.log");
    let _ = std::fs::remove_file(&firmware_log);
    let lint_log = logs.join("boards-lint.log");
    eprintln!(
        "\n==> the firmware builds{}, beside the host's (log in {})",
        if lint {
            " and the board crates' lints"
        } else {
            ""
        },
        firmware_log.display()
    );
    let firmware = prebuild::start(&root, firmware_log, lint.then(|| lint_log.clone()));
    let binaries = pool::build(&root)?;
    let (solo, shared): (Vec<_>, Vec<_>) = binaries
        .into_iter()
        .partition(|b| b.kind == "test" && pool::SOLO.contains(&b.name.as_str()));
    let env = [("PYRAMID_QEMU_OUT", runs.as_path())];
    let pooled = pool::run(pool::longest_first(shared), jobs, &env, &logs);
    // The wall-clock bounds, on a machine that runs nothing else of ours.
    let alone = pool::run(solo, 1, &env, &logs);
    let prebuilt = firmware
        .join()
        .map_err(|_| "the firmware builds' thread failed".to_string())?;
    for build in &prebuilt.failed_builds {
        eprintln!("note: the firmware build for {build} failed beside the host's build");
    }
    pooled.and(alone)?;
    step("cargo", &["test", "--workspace", "--doc"])?;
    // The code's shape: imports point down the library's layers, no cycle, one definition
    // per public type name.
    step("cargo", &["xtask", "layers"])?;
    // The live chain: a short recording paced into the emulated board, Odometry from a
    // Cyclone DDS publisher through `pyramid listen --ros2 --odom-topic /odom`, inside a
    // network namespace of its own; held to `lab live`'s bounds. It needs root and unshare.
    // It runs the lab and `pyramid` the test build above made (the dev profile), not a
    // second build of them and their dependencies in the tools profile (about 3.5 minutes on
    // two cores).
    match crate::lab::live_can_run() {
        Ok(()) => {
            eprintln!("\n==> cargo xtask live --check (the lab of the test build)");
            crate::lab::live_in(crate::lab::LabProfile::Dev, &["--check".to_string()])?;
        }
        Err(why) => eprintln!("\n==> skipped: cargo xtask live --check ({why})"),
    }
    // The board crates' format and lints ran beside the host's build (module `prebuild`)
    // with --lint.
    if let Some(lints) = prebuilt.lints {
        eprintln!("\n==> boards/check.sh --lint-only (beside the host's test build)");
        if let Err(why) = lints {
            eprintln!("{}", std::fs::read_to_string(&lint_log).unwrap_or_default());
            return Err(why);
        }
        eprintln!("the board crates' format and lints passed");
    }
    // The boards: builds (made above), the firmware on the emulated board (its runs' logs
    // from above), the on-target tests (thumbv7em and thumbv6m code), flash, RAM and stack.
    // It installs defmt-print when missing.
    let runs = runs.to_string_lossy();
    step(
        "bash",
        &["boards/check.sh", "--runs-from", &runs, "--no-lint"],
    )
}

/// `cargo xtask test [--lint] [--jobs N]`; `--jobs` defaults to the machine's cores.
pub fn run(args: &[String]) -> Result<(), String> {
    const USAGE: &str = "usage: cargo xtask test [--lint] [--jobs N]";
    let mut lint = false;
    let mut jobs = std::thread::available_parallelism().map_or(2, usize::from);
    let mut args = args.iter();
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--lint" => lint = true,
            "--jobs" => {
                jobs = args
                    .next()
                    .and_then(|n| n.parse().ok())
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("--jobs needs a number above 0; {USAGE}"))?;
            }
            other => return Err(format!("unknown option {other}; {USAGE}")),
        }
    }
    run_all(lint, jobs)
}
