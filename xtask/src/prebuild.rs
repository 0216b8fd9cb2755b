//! The firmware the test suite runs, built beside the host's test build.
//!
//! The board crates build into a target directory of their own, `boards/target` (they are
//! not in the workspace), so cargo lets their builds run while `cargo test --workspace
//! --no-run` compiles the host side: the firmware's fat-LTO links and the board crates'
//! dependency chains are mostly serial, and fill the core the host build leaves idle in its
//! long tail. Without this, the emulator tests each build their firmware when they first need
//! it, in the middle of the pooled test runs, and `boards/check.sh` builds the rest at the end.
//!
//! Each build here is the exact command its consumer runs (the same arguments, hence the same
//! fingerprints): the consumer's own `cargo build` then finds it up to date. A command that
//! drifted from its consumer's costs one build more, never a wrong firmware: the consumer
//! always builds (and waits on cargo's lock while a build here runs). A build that fails here
//! is reported and left to its consumer, which fails with its own message.
//!
//! With `--lint`, the board crates' format and lints (`boards/check.sh --lint-only`) follow
//! the builds in the same thread; `boards/check.sh` then runs with `--no-lint` at the end.
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread::JoinHandle;

/// One firmware build: the board crate (a folder under `boards/`) and cargo's arguments.
/// Every build goes to `boards/target` (the board crates' `.cargo/config.toml`), or to the
/// `--target-dir` its arguments name (`../target/variants`: a build with other features whose
/// binary keeps the default build's name).
struct FirmwareBuild {
    /// The board crate's folder under `boards/`.
    board: &'static str,
    /// cargo's arguments as the consumer gives them, separated by spaces.
    args: &'static str,
    /// Who runs it, for the log.
    consumer: &'static str,
}

/// A build of `board` with `args`, for `consumer`.
const fn at(board: &'static str, args: &'static str, consumer: &'static str) -> FirmwareBuild {
    FirmwareBuild {
        board,
        args,
        consumer,
    }
}

/// The builds, in the order the suite first needs them: the pooled tests' firmware (the
/// longest tests start first), then what `boards/check.sh` builds after the pool. They share
/// one target directory (two with the netduinoplus2's variant): the host's proc macros and
/// build scripts and the Cortex-M dependencies the boards have in common are built once, and
/// the paper's stairs firmware (a binary of its own) reuses every dependency of the default
/// one. The microbit's builds of the on-target tests come before the mps2-an386's of the same tests, which then are the
/// ones left when `boards/check.sh` runs them first (each build of the other kind replaces
/// them, in a second or two).
#[rustfmt::skip]
const BUILDS: &[FirmwareBuild] = &[
    at("qemu-mps2", "build --release --quiet --target thumbv7em-none-eabihf",
        "host/src/emulator.rs: Machine::Mps2An386.build()"),
    at("qemu-mps2", "build --release --quiet --features paper-stairs --bin qemu-mps2-paper-stairs",
        "host/src/emulator.rs: build_firmware_variant(.., Some(\"paper-stairs\"))"),
    at("stm32f4", "build --release --quiet --target thumbv7em-none-eabihf --no-default-features \
        --features chip-f405,log-semihosting --target-dir ../target/variants",
        "host/src/emulator.rs: Machine::Netduinoplus2.build()"),
    at("microbit", "build --release --quiet --target thumbv6m-none-eabi",
        "host/src/emulator.rs: Machine::Microbit.build()"),
    at("stm32f4", "build --release", "boards/check.sh: the NUCLEO-F446RE build"),
    at("qemu-mps2", "test --release --target thumbv7em-none-eabihf --no-run",
        "boards/check.sh: on-target tests, thumbv7em-none-eabihf"),
    at("qemu-mps2", "rustc --release --target thumbv6m-none-eabi --test arith \
        -- -C link-arg=--defsym=_stack_start=0x20004000",
        "boards/microbit/run-mps2-tests.sh: arith"),
    at("qemu-mps2", "rustc --release --target thumbv6m-none-eabi --test pyramid \
        -- -C link-arg=--defsym=_stack_start=0x20004000",
        "boards/microbit/run-mps2-tests.sh: pyramid"),
    at("qemu-mps2", "test --release --target thumbv6m-none-eabi --no-run",
        "boards/check.sh: on-target tests, thumbv6m-none-eabi"),
];

/// What the thread did: the builds that failed (left to their consumers), and the board
/// crates' lints' outcome when they ran (`Err` names their log).
pub struct Outcome {
    /// The consumers of the builds that failed, with why.
    pub failed_builds: Vec<String>,
    /// `boards/check.sh --lint-only`: `None` when not asked for.
    pub lints: Option<Result<(), String>>,
}

/// Starts the builds in a thread of their own, their output in `log`, and then, with `lint`,
/// the board crates' format and lints (`boards/check.sh --lint-only`, the same steps the
/// script runs without `--no-lint`), their output in `lint_log`.
pub fn start(root: &Path, log: PathBuf, lint: Option<PathBuf>) -> JoinHandle<Outcome> {
    let boards = root.join("boards");
    std::thread::spawn(move || {
        let mut failed_builds = Vec::new();
        for build in BUILDS {
            if let Err(why) = run(&boards, build, &log) {
                failed_builds.push(format!("{} ({why})", build.consumer));
            }
        }
        let lints = lint.map(|lint_log| lint_boards(&boards, &lint_log));
        Outcome {
            failed_builds,
            lints,
        }
    })
}

/// `boards/check.sh --lint-only`, its output in `log`. Nothing waits for the lints until the
/// suite's end, so they run at a lower priority (`nice -n 10`): they take the cores the host's
/// build and the tests leave idle, and do not slow the tests with wall-clock bounds.
fn lint_boards(boards: &Path, log: &Path) -> Result<(), String> {
    let mut lint = Command::new("nice");
    lint.args(["-n", "10", "bash"])
        .arg(boards.join("check.sh"))
        .arg("--lint-only");
    File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
    logged(&mut lint, log).map_err(|why| format!("boards/check.sh --lint-only: {why}"))
}

/// Runs one build, its output appended to `log`.
fn run(boards: &Path, build: &FirmwareBuild, log: &Path) -> Result<(), String> {
    let dir = boards.join(build.board);
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .args(build.args.split_whitespace())
        .current_dir(&dir)
        // As the consumers run it (host/src/emulator.rs: run_build).
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR");
    logged(&mut command, log)
}

/// Runs `command` with its output appended to `log`; an error says how it ended and where
/// its output is.
fn logged(command: &mut Command, log: &Path) -> Result<(), String> {
    let out = File::options()
        .create(true)
        .append(true)
        .open(log)
        .map_err(|e| format!("{}: {e}", log.display()))?;
    let err = out.try_clone().map_err(|e| e.to_string())?;
    let status = command
        .stdin(Stdio::null())
        .stdout(Stdio::from(out))
        .stderr(Stdio::from(err))
        .status()
        .map_err(|e| format!("cannot run {:?}: {e}", command.get_program()))?;
    status
        .success()
        .then_some(())
        .ok_or_else(|| format!("{status}; its output: {}", log.display()))
}

#[cfg(test)]
mod tests {
    use super::BUILDS;
    use std::path::Path;

    /// Each build names a board crate that exists, each binary it names is declared, and each
    /// on-target test it names has its source: a renamed crate, binary or test fails here, not
    /// as a silent second build.
    #[test]
    fn every_build_names_what_exists() {
        let boards = Path::new(env!("CARGO_MANIFEST_DIR")).join("../boards");
        for build in BUILDS {
            let crate_dir = boards.join(build.board);
            assert!(crate_dir.join("Cargo.toml").is_file(), "{}", build.board);
            let args: Vec<&str> = build.args.split_whitespace().collect();
            assert!(
                matches!(args.first(), Some(&("build" | "test" | "rustc"))),
                "{args:?}"
            );
            if let Some(i) = args.iter().position(|a| *a == "--bin") {
                let name = args.get(i + 1).expect("a binary's name after --bin");
                let manifest = std::fs::read_to_string(crate_dir.join("Cargo.toml")).unwrap();
                assert!(manifest.contains(&format!("name = \"{name}\"")), "{name}");
            }
            if let Some(i) = args.iter().position(|a| *a == "--test") {
                let name = args.get(i + 1).expect("a test name after --test");
                assert!(
                    crate_dir.join("tests").join(format!("{name}.rs")).is_file(),
                    "{name}"
                );
            }
        }
    }
}
