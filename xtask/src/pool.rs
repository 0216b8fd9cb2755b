//! The workspace's test binaries, run side by side on a pool of workers.
//!
//! `cargo test --workspace` runs its test binaries one after another. Each binary runs its
//! tests on as many threads as it has tests to run, but several binaries hold one long test
//! (a QEMU run, an experiment) that keeps one core busy while the other waits. Here cargo
//! builds every binary once (`cargo test --workspace --no-run`, the same build and features),
//! and the binaries run `jobs` at a time, the longest first, each from its package's directory
//! as cargo runs it, its output kept in `target/xtask-test/logs/` and shown when it fails.
//! A binary whose test holds a wall-clock bound (a clock's drift, a pose's stamp error) runs
//! alone after the others ([`SOLO`]).
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Test binaries (by target name) that run alone, after the pool: their tests bound wall-clock
/// figures that a loaded machine would move.
pub const SOLO: &[&str] = &["listen_poses"];

/// Test binaries by their wall time on a two-core machine (seconds, measured with
/// `cargo xtask test`): the pool starts the longest first, so that no long binary starts last.
/// The rest follow in cargo's order.
const LONGEST_FIRST: &[&str] = &[
    "experiments",
    "run_qemu",
    "outputs",
    "suite",
    "run_microbit",
    "rule_hash",
    "listen",
    "record",
    "replay_cli",
    "listen_setup",
];

/// One test binary as cargo built it.
#[derive(Debug, Clone)]
pub struct TestBinary {
    /// The test target's name (`run_qemu`, or the package's library name for unit tests).
    pub name: String,
    /// The target's kind as cargo names it (`lib`, `bin`, `test`).
    pub kind: String,
    /// The package's directory: cargo runs a test binary from there.
    pub package_dir: PathBuf,
    /// The package's name (`terrain-pyramid-host`).
    pub package: String,
    /// The executable.
    pub executable: PathBuf,
}

impl TestBinary {
    /// A short label: `package/name`, or `package (kind)` for unit tests.
    pub fn label(&self) -> String {
        if self.kind == "test" {
            format!("{}/{}", self.package, self.name)
        } else {
            format!("{} ({} {})", self.package, self.kind, self.name)
        }
    }
}

/// Builds every test binary of the workspace (`cargo test --workspace --no-run`) and lists
/// them, in cargo's order. Compiler messages go to stderr as cargo renders them.
pub fn build(root: &Path) -> Result<Vec<TestBinary>, String> {
    eprintln!("\n==> cargo test --workspace --no-run");
    let out = Command::new("cargo")
        .current_dir(root)
        .args([
            "test",
            "--workspace",
            "--no-run",
            "--message-format=json-render-diagnostics",
        ])
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`cargo test --workspace --no-run` failed ({})",
            out.status
        ));
    }
    let mut binaries = Vec::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(message) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if message["reason"] != "compiler-artifact" || message["profile"]["test"] != true {
            continue;
        }
        let (Some(executable), Some(manifest)) = (
            message["executable"].as_str(),
            message["manifest_path"].as_str(),
        ) else {
            continue;
        };
        let package_dir = Path::new(manifest)
            .parent()
            .map_or_else(|| root.to_path_buf(), Path::to_path_buf);
        let package = message["package_id"]
            .as_str()
            .and_then(package_name)
            .unwrap_or_default();
        binaries.push(TestBinary {
            name: message["target"]["name"]
                .as_str()
                .unwrap_or_default()
                .to_string(),
            kind: message["target"]["kind"][0]
                .as_str()
                .unwrap_or_default()
                .to_string(),
            package_dir,
            package,
            executable: PathBuf::from(executable),
        });
    }
    if binaries.is_empty() {
        return Err("cargo built no test binary".to_string());
    }
    Ok(binaries)
}

/// The package's name from a cargo package id: `path+file:///…/host#terrain-pyramid-host@0.1.0`
/// (named) or `path+file:///…/terrain-pyramid#0.1.0` (the directory's name).
fn package_name(id: &str) -> Option<String> {
    let (path, fragment) = id.rsplit_once('#')?;
    match fragment.split_once('@') {
        Some((name, _)) => Some(name.to_string()),
        None => path.rsplit('/').next().map(str::to_string),
    }
}

/// The order the pool takes them in: [`LONGEST_FIRST`], then cargo's order.
pub fn longest_first(mut binaries: Vec<TestBinary>) -> Vec<TestBinary> {
    let rank = |b: &TestBinary| {
        if b.kind != "test" {
            return LONGEST_FIRST.len();
        }
        LONGEST_FIRST
            .iter()
            .position(|n| *n == b.name)
            .unwrap_or(LONGEST_FIRST.len())
    };
    binaries.sort_by_key(rank); // stable: cargo's order among the rest
    binaries
}

/// The outcome of one binary.
struct Outcome {
    label: String,
    passed: bool,
    seconds: f64,
    log: PathBuf,
    /// libtest's closing line (`test result: ok. 6 passed; …`).
    result: String,
}

/// Runs `binaries` `jobs` at a time with `env` added, each with its output in `logs`. Prints a
/// line per binary as it ends; every log of a failed binary is printed in full at the end.
///
/// # Errors
/// When any binary fails (all of them still run), naming those that failed.
pub fn run(
    binaries: Vec<TestBinary>,
    jobs: usize,
    env: &[(&str, &Path)],
    logs: &Path,
) -> Result<(), String> {
    std::fs::create_dir_all(logs).map_err(|e| format!("{}: {e}", logs.display()))?;
    let count = binaries.len();
    eprintln!(
        "\n==> {count} test binaries, {jobs} at a time (logs in {})",
        logs.display()
    );
    let queue = Arc::new(Mutex::new(VecDeque::from(binaries)));
    let outcomes = Arc::new(Mutex::new(Vec::new()));
    let start = Instant::now();
    let workers: Vec<_> = (0..jobs.max(1))
        .map(|_| {
            let queue = Arc::clone(&queue);
            let outcomes = Arc::clone(&outcomes);
            let env: Vec<(String, PathBuf)> = env
                .iter()
                .map(|(k, v)| ((*k).to_string(), v.to_path_buf()))
                .collect();
            let logs = logs.to_path_buf();
            std::thread::spawn(move || loop {
                let next = queue.lock().ok().and_then(|mut q| q.pop_front());
                let Some(binary) = next else { break };
                let outcome = run_one(&binary, &env, &logs);
                eprintln!(
                    "[{:>5.0} s] {} {:<48} {:>6.1} s  {}",
                    start.elapsed().as_secs_f64(),
                    if outcome.passed { "ok  " } else { "FAIL" },
                    outcome.label,
                    outcome.seconds,
                    outcome.result
                );
                if let Ok(mut o) = outcomes.lock() {
                    o.push(outcome);
                }
            })
        })
        .collect();
    for worker in workers {
        worker
            .join()
            .map_err(|_| "a test worker panicked".to_string())?;
    }
    let outcomes = outcomes
        .lock()
        .map_err(|_| "the outcomes' lock was poisoned".to_string())?;
    let failed: Vec<&Outcome> = outcomes.iter().filter(|o| !o.passed).collect();
    for o in &failed {
        eprintln!(
            "\n==> {} failed; its output ({}):",
            o.label,
            o.log.display()
        );
        eprintln!(
            "{}",
            std::fs::read_to_string(&o.log).unwrap_or_else(|e| format!("(unreadable: {e})"))
        );
    }
    if outcomes.len() != count {
        return Err(format!("{} of {count} test binaries ran", outcomes.len()));
    }
    if failed.is_empty() {
        eprintln!(
            "==> {count} test binaries passed in {:.0} s",
            start.elapsed().as_secs_f64()
        );
        Ok(())
    } else {
        let names: Vec<&str> = failed.iter().map(|o| o.label.as_str()).collect();
        Err(format!("test binaries failed: {}", names.join(", ")))
    }
}

/// Runs one binary from its package's directory, as `cargo test` would.
fn run_one(binary: &TestBinary, env: &[(String, PathBuf)], logs: &Path) -> Outcome {
    let label = binary.label();
    let file: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    let log = logs.join(format!("{file}.log"));
    let t = Instant::now();
    let passed = std::fs::File::create(&log)
        .and_then(|out| {
            let err = out.try_clone()?;
            Command::new(&binary.executable)
                .current_dir(&binary.package_dir)
                .env("CARGO_MANIFEST_DIR", &binary.package_dir)
                .env("CARGO_PKG_NAME", &binary.package)
                .envs(env.iter().map(|(k, v)| (k, v)))
                .stdin(Stdio::null())
                .stdout(out)
                .stderr(err)
                .status()
        })
        .is_ok_and(|s| s.success());
    let result = std::fs::read_to_string(&log)
        .ok()
        .and_then(|text| {
            text.lines()
                .rfind(|l| l.starts_with("test result:"))
                .map(|l| l.trim_start_matches("test result: ").to_string())
        })
        .unwrap_or_default();
    Outcome {
        label,
        passed,
        seconds: t.elapsed().as_secs_f64(),
        log,
        result,
    }
}
