//! `lab demo`: the main job end to end. Each scenario makes a recording, runs it through the
//! co-processor as `pyramid run` does ([`terrain_pyramid_host::run`]) and writes the maps, the
//! pictures and `summary.json` under `DIR/NAME/maps/`.
//!
//! The co-processor is the firmware on the emulated board (`--board qemu`, the default); the
//! in-process co-processor runs only when asked for (`--board host`). Without QEMU the demo
//! fails and says how to install it: it never changes the board on its own.
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use terrain_pyramid_host::emulator::{qemu_available, INSTALL_HINT};
use terrain_pyramid_host::export::PICTURE_FILE;
use terrain_pyramid_host::record3dtk;
use terrain_pyramid_host::run::{self, Board};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};

/// The shared data directory beside the workspace.
pub const SHARED_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data");

/// The shared data directory: `PYRAMID_SHARED_DATA` if set, else [`SHARED_DATA`].
#[must_use]
pub fn shared_data() -> PathBuf {
    std::env::var_os("PYRAMID_SHARED_DATA")
        .map_or_else(|| PathBuf::from(SHARED_DATA), PathBuf::from)
}

/// Arguments of `lab demo`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Where the recordings and maps go (one folder per scenario).
    #[arg(long, value_name = "DIR", default_value = "demo-out")]
    pub out: PathBuf,
    /// Where the pipeline runs: the firmware on the emulated board, or (only when asked for)
    /// the library's co-processor in this process.
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
    pub record: fn(&Path) -> Result<(), String>,
    /// The design and classifier flags of `pyramid run`.
    pub flags: &'static [&'static str],
}

/// The 3DTK scenario's `pyramid run` flags: the scan's sensor at 0.4 m, 8 m, γ = 3.
pub const FLAGS_3DTK: &[&str] = &["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"];

/// The scenarios, in order.
#[must_use]
pub fn scenarios() -> Vec<Scenario> {
    vec![
        Scenario {
            name: "3dtk-tilt-scan",
            about: "a real tilting SICK scan (3DTK scan000), converted to SICK telegrams",
            record: record_3dtk,
            flags: FLAGS_3DTK,
        },
        Scenario {
            name: "stairs",
            about: "the paper's robot (a vertical SICK plane panned at 1 m) simulated in front of \
                    stairs (5 steps of 17 cm from 5.05 m): 10 s standing, then driving at \
                    0.5 m/s to 1 m from the first step",
            record: record_stairs,
            flags: &[],
        },
        Scenario {
            name: "ld19-nodding-stairs",
            about: "an LDROBOT LD19 (47-byte packets, 4 500 returns/s at 10 Hz) lying on a servo \
                    that nods it 2°..35° at 15 °/s, 1 m up, simulated in front of the same \
                    stairs: 1 s standing, then driving at 1 m/s to 1 m from the first step; \
                    the design from its datasheet and nod (φ = 1.5°, ψ = 0.8°, σ = 0.045 m; \
                    γ = 3, 8 m: 8 layers)",
            record: record_ld19_stairs,
            flags: FLAGS_LD19,
        },
    ]
}

/// The LD19 scenario's `pyramid run` flags: the design of its datasheet and nod
/// (`lab/src/experiments/lidar.rs`): φ = 1.5° (the tilt between revolutions), ψ = 0.8°,
/// σ = 0.045 m, h = 1.0 m; γ = 3 and 8 m so that it fits the firmware's 8 layers (at γ = 2
/// and 10 m it needs 16), as `examples/rigs/ld19-nodding.toml`'s design.
pub const FLAGS_LD19: &[&str] = &[
    "--phi-deg",
    "1.5",
    "--psi-deg",
    "0.8",
    "--sigma-m",
    "0.045",
    "--gamma",
    "3",
    "--max-range-m",
    "8",
];

/// The LD19 on its nodding servo in front of the stairs (a version-2 recording, one packet per
/// laser event, the servo's angle at each packet's mean sample time before it).
fn record_ld19_stairs(out: &Path) -> Result<(), String> {
    use terrain_pyramid_host_tests::sim::scene::{Scene, StairsSpec};
    use terrain_pyramid_host_tests::sim::trajectory::Trajectory;
    let spec = StairsSpec::default();
    let config = crate::experiments::lidar::ld19_sim(
        Scene::stairs(spec),
        Trajectory::approach(1.0, 1.0, spec.first_riser_x, 1.0),
        1,
    );
    let sim = terrain_pyramid_host_tests::sim::lidar::simulate_lidar(&config)
        .map_err(|e| e.to_string())?;
    std::fs::write(out, &sim.bytes).map_err(|e| format!("cannot write {}: {e}", out.display()))
}

/// The simulated stairs: the default pyramid (h = 1.0 m, 10 m, γ = 2), as the firmware has it.
fn record_stairs(out: &Path) -> Result<(), String> {
    let sim = simulate(&SimConfig::paper_stairs(10.0, 0.5, 1.0)).map_err(|e| e.to_string())?;
    std::fs::write(out, &sim.bytes).map_err(|e| format!("cannot write {}: {e}", out.display()))
}

/// The 3DTK scan as a recording (`pyramid record-3dtk`).
///
/// # Errors
/// The scan is missing, or the conversion failed.
pub fn record_3dtk(out: &Path) -> Result<(), String> {
    let data = shared_data().join("3dtk-tilt-scan");
    let scan = data.join("scan000.3d");
    if !scan.is_file() {
        return Err(format!("the 3DTK scan is missing: {}", scan.display()));
    }
    record3dtk::convert(&record3dtk::Args {
        points: scan,
        pose: Some(data.join("scan000.pose")),
        out: out.to_path_buf(),
        beams_per_line: 360,
        sensor_height_m: 0.4,
        json: false,
    })
    .map(|_| ())
}

/// `pyramid run`'s arguments from its command line.
#[derive(clap::Parser)]
struct RunCommandLine {
    #[command(flatten)]
    args: run::Args,
}

/// The arguments of `pyramid run --board B --recording R --out O FLAGS`.
///
/// # Errors
/// Flags `pyramid run` refuses.
pub fn run_args(
    board: Board,
    recording: &Path,
    out: &Path,
    flags: &[&str],
) -> Result<run::Args, String> {
    let mut line: Vec<String> = vec!["run".into(), "--board".into(), board.name().into()];
    line.push("--recording".into());
    line.push(recording.display().to_string());
    line.push("--out".into());
    line.push(out.display().to_string());
    line.extend(flags.iter().map(|f| (*f).to_string()));
    <RunCommandLine as clap::Parser>::try_parse_from(line)
        .map(|c| c.args)
        .map_err(|e| e.to_string())
}

/// One scenario: its recording, then `pyramid run`; returns the summary's JSON.
fn run_scenario(s: &Scenario, dir: &Path, board: Board) -> Result<String, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let rec = dir.join(format!("{}.rec", s.name));
    (s.record)(&rec)?;
    let args = run_args(board, &rec, &dir.join("maps"), s.flags)?;
    run::execute(&args).map_err(|(_, message)| message.trim_start_matches("error: ").to_string())
}

/// Runs `lab demo`.
pub fn run(args: &Args) -> ExitCode {
    let board = args.board;
    if board == Board::Qemu && !qemu_available() {
        eprintln!(
            "error: the demo runs on the emulated board and QEMU is missing: {INSTALL_HINT} \
             (`cargo xtask demo` installs both); `lab demo --board host` runs the in-process \
             co-processor instead"
        );
        return ExitCode::FAILURE;
    }
    let mut failed = false;
    for s in scenarios() {
        let dir = args.out.join(s.name);
        println!("== {} ({}) on board {}", s.name, s.about, board.name());
        match run_scenario(&s, &dir, board) {
            Ok(summary) => {
                println!("maps: {}", dir.join("maps").display());
                println!("picture: {}", dir.join("maps").join(PICTURE_FILE).display());
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
