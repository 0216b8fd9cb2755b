//! `pyramid demo`: the main job end to end. Each scenario makes a recording, runs it through
//! the emulated co-processor (`--board qemu`, the default) or the in-process pipeline
//! (`--board host`), and writes the maps, the pictures and `summary.json` under `DIR/NAME/`.
//! Without QEMU the demo says how to install it and runs the host pipeline instead, labelled.
use crate::run::Board;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// The shared data directory beside the workspace.
pub const SHARED_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data");

/// The shared data directory: `PYRAMID_SHARED_DATA` if set, else [`SHARED_DATA`].
#[must_use]
pub fn shared_data() -> PathBuf {
    std::env::var_os("PYRAMID_SHARED_DATA")
        .map_or_else(|| PathBuf::from(SHARED_DATA), PathBuf::from)
}

/// Arguments of `pyramid demo`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Where the recordings and maps go (one folder per scenario).
    #[arg(long, value_name = "DIR", default_value = "demo-out")]
    pub out: PathBuf,
    /// Where the pipeline runs.
    #[arg(long, value_enum, default_value_t = Board::Qemu)]
    pub board: Board,
}

/// One scenario of the demo: how its recording is made, and the `pyramid run` flags.
pub struct Scenario {
    /// The folder name and title.
    pub name: &'static str,
    /// What it shows.
    pub about: &'static str,
    /// Writes the recording to the given path.
    pub record: fn(&Path, &Path) -> Result<(), String>,
    /// The design and classifier flags of `pyramid run`.
    pub flags: &'static [&'static str],
}

/// The scenarios, in order.
#[must_use]
pub fn scenarios() -> Vec<Scenario> {
    vec![
        Scenario {
            name: "3dtk-tilt-scan",
            about: "a real tilting SICK scan (3DTK scan000), converted to SICK telegrams",
            record: record_3dtk,
            flags: &["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"],
        },
        Scenario {
            name: "stairs",
            about: "the paper's robot (a vertical SICK plane panned at 1 m) simulated in front of \
                    stairs (5 steps of 17 cm from 5.05 m): 10 s standing, then driving at \
                    0.5 m/s to 1 m from the first step",
            record: record_stairs,
            flags: &[],
        },
    ]
}

/// The simulated stairs: the default pyramid (h = 1.0 m, 10 m, γ = 2), as the firmware has it.
fn record_stairs(_me: &Path, out: &Path) -> Result<(), String> {
    use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
    let sim = simulate(&SimConfig::paper_stairs(10.0, 0.5, 1.0)).map_err(|e| e.to_string())?;
    std::fs::write(out, &sim.bytes).map_err(|e| format!("cannot write {}: {e}", out.display()))
}

fn record_3dtk(me: &Path, out: &Path) -> Result<(), String> {
    let data = shared_data().join("3dtk-tilt-scan");
    let scan = data.join("scan000.3d");
    if !scan.is_file() {
        return Err(format!("the 3DTK scan is missing: {}", scan.display()));
    }
    let status = Command::new(me)
        .arg("record-3dtk")
        .arg(&scan)
        .arg("--pose")
        .arg(data.join("scan000.pose"))
        .arg("--out")
        .arg(out)
        .status()
        .map_err(|e| e.to_string())?;
    if status.success() {
        Ok(())
    } else {
        Err("pyramid record-3dtk failed".into())
    }
}

fn run_scenario(me: &Path, s: &Scenario, dir: &Path, board: Board) -> Result<String, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let rec = dir.join(format!("{}.rec", s.name));
    (s.record)(me, &rec)?;
    let maps = dir.join("maps");
    let out = Command::new(me)
        .args(["run", "--json", "--board", board.name(), "--recording"])
        .arg(&rec)
        .arg("--out")
        .arg(&maps)
        .args(s.flags)
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(format!("pyramid run --board {} failed", board.name()));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Runs `pyramid demo`.
pub fn run(args: &Args) -> ExitCode {
    let me = match std::env::current_exe() {
        Ok(me) => me,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut board = args.board;
    if board == Board::Qemu && !crate::qemu::qemu_available() {
        eprintln!("QEMU is missing: {}", crate::qemu::INSTALL_HINT);
        eprintln!(
            "*** FALLBACK: running the HOST pipeline instead of the emulated co-processor ***"
        );
        board = Board::Host;
    }
    let mut failed = false;
    for s in scenarios() {
        let dir = args.out.join(s.name);
        println!("== {} ({}) on board {}", s.name, s.about, board.name());
        match run_scenario(&me, &s, &dir, board) {
            Ok(summary) => {
                println!("maps: {}", dir.join("maps").display());
                println!(
                    "picture: {}",
                    dir.join("maps").join(crate::export::PICTURE_FILE).display()
                );
                println!("summary: {summary}");
            }
            Err(e) => {
                eprintln!("error: {}: {e}", s.name);
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
