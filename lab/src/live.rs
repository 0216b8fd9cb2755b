//! `lab live`: a recording played as a robot lives, through the emulated board and the host
//! tool a robot user runs.
//!
//! # What runs
//! - The recording: the LD19 nodding on its servo on a robot driving up the stairs at 1 m/s
//!   ([`crate::experiments::timing::ld19_setup`], quick: 2 s standing 6 m away).
//! - The emulated board (`boards/qemu-mps2` on QEMU's mps2-an386), its UARTs on sockets of
//!   its own. Over the host link's UART the lab sends the recording's Setup (the sensor; an
//!   external actuator) and waits for its Reply; then the
//!   link is relayed, byte for byte, to a TCP address on 127.0.0.1 for `pyramid listen --tcp`.
//! - The laser's bytes: each chunk written to the laser UART at its recorded time on the wall
//!   clock, from a start a few seconds ahead, the recording's actuator angle as a PanAngle
//!   before it (the Setup names an external actuator: the board's servo model does not run).
//! - The poses, not from the recording: `py/odom_pub.py`, a separate process, publishes the
//!   trajectory at 50 Hz as `nav_msgs/msg/Odometry` on `/odom` with Cyclone DDS, each stamped
//!   with the wall-clock time the robot was there and published 30 ± 10 ms after it.
//! - `pyramid listen --tcp ADDR --ros2 --odom-topic /odom` forwards them to the board as
//!   stamped Poses, and writes the maps and `summary.json` when the recording has played.
//!
//! # What is reported
//! - The maps: the relay between listen and the board decodes the device's stream as listen
//!   does and keeps a mirror of its maps (checked equal to listen's, layer by layer, by the
//!   hashes in listen's `summary.json`). They are held, cell by cell ([`timing::agreement`]:
//!   the known cells of every layer, equal or not), against the same recording run in this
//!   process through the library's co-processor with the firmware's design, the device's clock
//!   the recording's time: **on time** (the trajectory at 250 Hz, each pose stamped and
//!   delivered at its stamp: what the device does with perfect poses) and **lock-step** (the
//!   recording's pose before each chunk), and **board-timed** (`timeline`: every chunk,
//!   PanAngle and on-time pose at the time the emulated board took it, from the Stats the lab
//!   asks for every [`STATS_PERIOD`]): what the device does with perfect poses and the
//!   emulator's backlog, the reference [`bounds::MAP_EQUAL`] holds the maps to. Beside them
//!   each layer's raw hash against the lock-step run's.
//! - The clock: listen's own estimate (`time_sync` in its summary) and a truth. The emulated
//!   board's µs clock follows the host's wall clock; the relay times each time exchange as it
//!   passes (the request from listen, the board's reply), which brackets the device's clock
//!   against the wall clock within the exchange's round trip at the relay (about 1 ms here). Each
//!   stamped Pose listen forwards is held against it: its `stamp_us` minus the device's clock
//!   at the wall-clock time of its Odometry stamp ([`ClockTruth`]).
//! - The poses' latency: from a pose's stamp, and from the publisher's write, to its Pose frame
//!   leaving listen (read by the relay once the board's UART has taken its earlier bytes)
//!   ([`PoseLatency`]).
//! - The pacing: chunks written more than 5 ms after their time.
//! - listen's `summary.json` and the publisher's report, as they are.
//!
//! `--check` holds the run to [`bounds`] (`cargo xtask test` runs `cargo xtask live --check`);
//! `--no-forward` (listen without `--odom-topic`) is the broken chain they must fail.
//!
//! `--ros2` starts DDS participants: run it only inside a network namespace of its own
//! (`cargo xtask live` does; the command refuses elsewhere).

mod board;
mod clock;
mod relay;
mod timeline;

pub use clock::{ClockTruth, PoseLatency, Spread};
pub use timeline::{BoardLag, STATS_PERIOD};

use crate::experiments::timing::{self, Input, LatePose, PoseRule};
use board::{setup_device, start_qemu};
use clock::clock_figures;
use relay::relay;
use serde::Serialize;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::setup_message_with_sensor;
use terrain_pyramid::wire::link::Message;
use terrain_pyramid::{Config, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS};
use terrain_pyramid_host::design::firmware_design;
use terrain_pyramid_host::emulator::Machine;
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::link::HostLink;
use terrain_pyramid_host::listen::cells_fnv1a64;
use terrain_pyramid_host::play::{steps, Step};
use terrain_pyramid_host_tests::sim::lidar::{simulate_lidar, LidarSimConfig};
use timeline::board_timed;

/// Arguments of `lab live`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Where the recording, the poses, listen's maps, the firmware's log and `live.json` go.
    #[arg(long, default_value = "target/lab/live")]
    pub out: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// The poses over ROS 2 (Cyclone DDS publisher, `listen --ros2 --odom-topic /odom`).
    /// Only inside a network namespace of its own: `cargo xtask live` runs it there.
    #[arg(long)]
    pub ros2: bool,
    /// The `pyramid` binary (default: beside this one).
    #[arg(long, value_name = "FILE")]
    pub pyramid: Option<PathBuf>,
    /// Check the run against the bounds of [`check`] (`cargo xtask test` runs it): exit
    /// non-zero, saying which failed, when one does not hold.
    #[arg(long)]
    pub check: bool,
    /// Listen without `--odom-topic`: the poses are published but not forwarded, so the
    /// device places every return at the origin. The broken chain [`bounds::MAP_EQUAL`] must
    /// catch (`--check` fails).
    #[arg(long)]
    pub no_forward: bool,
    /// Seconds between starting the publisher and listen and the recording's t = 0.
    #[arg(long, default_value_t = 4.0)]
    pub lead_s: f64,
}

/// One layer of listen's maps against the lock-step run's.
#[derive(Debug, Clone, Serialize)]
pub struct LayerCompare {
    /// The layer.
    pub layer: usize,
    /// FNV-1a 64 of listen's raw cells, hex.
    pub listen_fnv1a64: String,
    /// FNV-1a 64 of the lock-step run's.
    pub lock_step_fnv1a64: String,
    /// Whether they are equal.
    pub equal: bool,
    /// listen's observed, obstacle, navigable cells.
    pub listen_counts: [u64; 3],
    /// The lock-step run's.
    pub lock_step_counts: [u64; 3],
}

/// `lab live`'s report (`live.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Seconds of recording played.
    pub duration_s: f64,
    /// Laser chunks written.
    pub chunks: usize,
    /// Chunks written more than 5 ms after their time.
    pub late_chunks: usize,
    /// The latest a chunk was written after its time, ms.
    pub max_late_ms: f64,
    /// The recording's actuator angles written to the board as PanAngles (between listen's
    /// frames on the host link).
    pub angles: usize,
    /// Poses the publisher was given.
    pub poses: usize,
    /// Per layer.
    pub layers: Vec<LayerCompare>,
    /// Layers whose cells equal the lock-step run's exactly.
    pub layers_equal: usize,
    /// Whether the relay's mirror of the device's maps (built from the bytes listen received)
    /// hashes as listen's maps do, layer by layer: the agreements below are listen's maps'.
    pub mirror_is_listens: bool,
    /// listen's maps against the in-process run with every pose stamped on time (250 Hz, each
    /// delivered at its stamp): known cells of every layer equal.
    pub against_on_time: timing::Agreement,
    /// listen's maps against the in-process run with every pose on time and every chunk and
    /// PanAngle at the time the board took it (`timeline`): what the device does with
    /// perfect poses and the emulator's timing, the figure [`bounds::MAP_EQUAL`] holds.
    pub against_board_timed: timing::Agreement,
    /// That board-timed run against the on-time run: what the emulator's backlog alone moves.
    pub board_timed_against_on_time: timing::Agreement,
    /// How far behind its time the board took the laser's bytes.
    pub board_lag: BoardLag,
    /// … against the lock-step run (the recording's pose before each chunk).
    pub against_lock_step: timing::Agreement,
    /// The on-time run against the lock-step run, for scale.
    pub on_time_against_lock_step: timing::Agreement,
    /// The device's clock against the wall clock, and the pose stamps' error.
    pub clock: ClockTruth,
    /// How late the poses reach the board.
    pub latency: PoseLatency,
    /// The device's last Stats (every counter), as the relay's mirror last saw them.
    pub device_stats: Option<String>,
    /// listen's `summary.json`, as it is.
    pub listen: serde_json::Value,
    /// The publisher's own report, when it ran.
    pub publisher: Option<serde_json::Value>,
}

/// A child process killed and reaped when dropped.
struct Reaped(Option<Child>);

impl Drop for Reaped {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Whether a read of the board's UART ended without bytes only because its timeout passed
/// (the socket's read timeout or non-blocking mode), not for an error.
fn read_timed_out(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}

/// The wall clock, µs since the Unix epoch.
fn wall_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

fn write_poses(path: &Path, poses: &[LatePose]) -> Result<(), String> {
    let mut s = String::new();
    for p in poses {
        #[allow(clippy::cast_precision_loss)]
        let line = serde_json::json!({ "t": p.stamp_us as f64 * 1e-6, "pose": p.pose });
        s.push_str(&line.to_string());
        s.push('\n');
    }
    terrain_pyramid_host::export::write_file(path, s.as_bytes())
}

/// When the publisher wrote each pose (its `--log`: one line a pose, in order, with
/// `published`, wall-clock seconds); `None` for each when there is no log.
fn published_times(path: &Path, n: usize) -> Vec<Option<u64>> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut out: Vec<Option<u64>> = text
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).ok()?;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            v["published"].as_f64().map(|s| (s * 1e6).round() as u64)
        })
        .collect();
    out.resize(n, None);
    out
}

fn counts(cells: &[i16]) -> [u64; 3] {
    let mut c = [0_u64; 3];
    for &v in cells {
        if v == i16::MIN {
            continue;
        }
        c[0] += 1;
        if v > 0 {
            c[1] += 1;
        } else if v < 0 {
            c[2] += 1;
        }
    }
    c
}

/// The recording run in this process through the co-processor with poses by `rule`, on a
/// thread whose stack holds it.
fn reference(
    input: &Input<'_, DEFAULT_LAYERS>,
    rule: PoseRule,
) -> Result<timing::RunOutcome, String> {
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(64 << 20)
            .spawn_scoped(s, || {
                timing::run::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, DEFAULT_CLASSIFIER_SLOTS>(
                    input, rule,
                )
            })
            .map_err(|e| e.to_string())?
            .join()
            .unwrap_or_else(|_| Err("a reference run panicked".into()))
    })
}

/// Asks the board for its Stats every [`STATS_PERIOD`] through the relay (between listen's
/// frames) until `stop`: the relay reads the laser bytes it had taken from each.
fn request_stats(
    inject: Arc<std::sync::Mutex<relay::Injector>>,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut link = HostLink::new();
        while !stop.load(Ordering::Relaxed) {
            if let Ok(frame) = link.command(&Message::RequestStats) {
                if let Ok(mut i) = inject.lock() {
                    i.send(&frame, false);
                }
            }
            std::thread::sleep(STATS_PERIOD);
        }
    })
}

/// Runs the chain; returns the report.
///
/// # Errors
/// A part of the chain failed to start or to finish.
#[allow(clippy::too_many_lines)]
pub fn execute(args: &Args) -> Result<Report, String> {
    if args.ros2 && !terrain_pyramid_host::publish::only_loopback() {
        return Err(
            "--ros2 runs DDS: only inside a network namespace with nothing but loopback \
             (`cargo xtask live`)"
                .into(),
        );
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let out = std::fs::canonicalize(&args.out).map_err(|e| e.to_string())?;
    // The recording, its poses and the lock-step reference.
    let setup = timing::ld19_setup(true);
    let scene = setup.scene_config();
    let sim_config = LidarSimConfig {
        sample_poses: true,
        ..crate::experiments::lidar::ld19_sim(scene.scene.clone(), scene.trajectory, setup.seed)
    };
    let sim = simulate_lidar(&sim_config).map_err(|e| e.to_string())?;
    terrain_pyramid_host::export::write_file(&out.join("live.rec"), &sim.bytes)?;
    let steps = steps(&sim.bytes)?;
    let feed = timing::PoseFeed::ROBOT;
    let poses = timing::late_poses(
        &sim_config.trajectory,
        &sim_config.scene,
        sim.duration_us,
        &feed,
    );
    let mut in_order = poses.clone();
    in_order.sort_by_key(|p| p.stamp_us);
    write_poses(&out.join("poses.ndjson"), &in_order)?;
    let design = firmware_design()?;
    let config = Config::default();
    let frontend = terrain_pyramid::link::convert::frontend_config(&setup_message_with_sensor(
        &steps.setup().ok_or("no setup")?,
        &steps.sensor,
        &ClassifierConfig::DEFAULT,
    ))
    .map_err(|e| e.to_string())?;
    let on_time = timing::on_time_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let truth = timing::true_poses(&sim_config.trajectory, &sim_config.scene, sim.duration_us);
    let input = Input {
        steps: &steps,
        late: &[],
        on_time: &on_time,
        truth: &truth,
        design: &design,
        config: &config,
        frontend,
        first_riser: None,
        end_observation: false,
    };
    let lock_step = reference(&input, PoseRule::LockStep)?;
    let on_time_run = reference(&input, PoseRule::OnTime)?;
    // The board.
    let elf = Machine::Mps2An386.build()?;
    let sockets = std::env::temp_dir().join(format!("pyramid-live-{}", std::process::id()));
    std::fs::create_dir_all(&sockets).map_err(|e| e.to_string())?;
    let (qemu, mut uart0, mut uart1) = start_qemu(&elf, &sockets)?;
    // A board that stops taking the laser's bytes ends the run instead of holding it.
    uart0
        .set_write_timeout(Some(Duration::from_secs(20)))
        .map_err(|e| e.to_string())?;
    setup_device(&mut uart1, &steps)?;
    let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    let address = listener.local_addr().map_err(|e| e.to_string())?;
    let relay = relay(listener, uart1);
    // The clocks: t = 0 of the recording is `lead_s` from now on both.
    let start_wall = SystemTime::now() + Duration::from_secs_f64(args.lead_s);
    let start = Instant::now() + Duration::from_secs_f64(args.lead_s);
    let start_epoch = start_wall
        .duration_since(UNIX_EPOCH)
        .map_err(|e| e.to_string())?
        .as_secs_f64();
    #[allow(clippy::cast_precision_loss)]
    let duration_s = sim.duration_us as f64 * 1e-6;
    let pyramid = match &args.pyramid {
        Some(p) => p.clone(),
        None => std::env::current_exe()
            .map_err(|e| e.to_string())?
            .with_file_name("pyramid"),
    };
    let listen_dir = out.join("listen");
    let mut listen = Command::new(&pyramid);
    listen
        .arg("listen")
        .arg("--tcp")
        .arg(address.to_string())
        .arg("--out")
        .arg(&listen_dir)
        .arg("--duration-s")
        .arg(format!("{:.1}", args.lead_s + duration_s + 3.0));
    if args.ros2 {
        listen.arg("--ros2");
        if !args.no_forward {
            listen.args(["--odom-topic", "/odom"]);
        }
    }
    let listen = Reaped(Some(
        listen
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(out.join("listen.log")).map_err(|e| e.to_string())?)
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", pyramid.display()))?,
    ));
    let publisher = if args.ros2 {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("py/odom_pub.py");
        Some(Reaped(Some(
            Command::new("python3")
                .arg(script)
                .arg(out.join("poses.ndjson"))
                .arg(format!("{start_epoch:.6}"))
                .arg("--log")
                .arg(out.join("published.ndjson"))
                .stdout(Stdio::piped())
                .stderr(Stdio::inherit())
                .spawn()
                .map_err(|e| format!("cannot start python3: {e}"))?,
        )))
    } else {
        None
    };
    // The board's Stats, for the time it took each chunk.
    let stats_stop = Arc::new(AtomicBool::new(false));
    let stats = request_stats(Arc::clone(&relay.inject), Arc::clone(&stats_stop));
    // The laser, paced.
    let mut written_us = Vec::new();
    let mut chunks = 0;
    let mut late_chunks = 0;
    let mut max_late = Duration::ZERO;
    let mut angles = HostLink::new();
    let mut angle: Option<u16> = None;
    for step in &steps.steps {
        if let Step::Angle(turns) = step {
            angle = Some(*turns);
        }
        if let Step::Laser { bytes, time_us, .. } = step {
            let due = start + Duration::from_micros(*time_us);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            } else {
                max_late = max_late.max(now - due);
                if now - due > Duration::from_millis(5) {
                    late_chunks += 1;
                }
            }
            // The actuator's angle before the chunk it precedes, as `pyramid run` sends it
            // (this board has no encoder and the setup no servo).
            if let Some(turns) = angle.take() {
                let frame = timing::pan_angle_frame(&mut angles, turns)?;
                if let Ok(mut i) = relay.inject.lock() {
                    i.send(&frame, true);
                }
            }
            written_us.push(wall_us());
            uart0
                .write_all(bytes)
                .map_err(|e| format!("the laser UART: {e}"))?;
            chunks += 1;
        }
    }
    let publisher = match publisher {
        Some(mut p) => {
            let mut child = p.0.take().ok_or("no publisher")?;
            let mut text = String::new();
            if let Some(mut o) = child.stdout.take() {
                let _ = o.read_to_string(&mut text);
            }
            let _ = child.wait();
            serde_json::from_str(text.trim()).ok()
        }
        None => None,
    };
    let mut listen = listen;
    let status = listen
        .0
        .take()
        .ok_or("no listen")?
        .wait()
        .map_err(|e| e.to_string())?;
    stats_stop.store(true, Ordering::Relaxed);
    let _ = stats.join();
    relay.stop.store(true, Ordering::Relaxed);
    let mirror = relay
        .mirror
        .join()
        .map_err(|_| "the relay panicked".to_string())?;
    drop(qemu);
    let _ = std::fs::remove_dir_all(&sockets);
    let tap = std::mem::take(&mut *relay.tap.lock().map_err(|e| e.to_string())?);
    let published = published_times(&out.join("published.ndjson"), in_order.len());
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let start_us = (start_epoch * 1e6).round() as u64;
    let (clock, latency) = clock_figures(&tap, &in_order, start_us, &published);
    let angles_at = relay
        .inject
        .lock()
        .map(|i| i.angles_at.clone())
        .unwrap_or_default();
    let frames_at = relay
        .inject
        .lock()
        .map(|i| i.frames_at.clone())
        .unwrap_or_default();
    let (retimed, timed_poses, board_lag) = board_timed(
        &steps,
        &on_time,
        &timeline::Timed {
            start_us,
            stats: &tap.stats,
            written_us: &written_us,
            angles_at: &angles_at,
            frames_at: &frames_at,
        },
    );
    let board_timed_run = reference(
        &Input {
            steps: &retimed,
            on_time: &timed_poses,
            ..input
        },
        PoseRule::OnTime,
    )?;
    let board = MapSnapshot::from_mirror(
        mirror.mirror(),
        terrain_pyramid_host::export::default_fused_margin(),
        (0.0, 0.0),
    )
    .ok_or("the relay's mirror holds no maps")?;
    let text = std::fs::read_to_string(listen_dir.join("summary.json")).map_err(|e| {
        format!(
            "pyramid listen ({status}) wrote no summary: {e}; see {}",
            out.join("listen.log").display()
        )
    })?;
    let summary: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    let listen_hashes: Vec<String> = summary["layer_cells_fnv1a64"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    let mut layers = Vec::new();
    for (k, l) in lock_step.snapshot.layers.iter().enumerate() {
        let listen_counts = summary["layers"].get(k).map_or([0; 3], |s| {
            [
                s["observed_cells"].as_u64().unwrap_or(0),
                s["obstacle_cells"].as_u64().unwrap_or(0),
                s["free_cells"].as_u64().unwrap_or(0),
            ]
        });
        let lock = format!("{:016x}", cells_fnv1a64(&l.cells));
        let mine = listen_hashes.get(k).cloned().unwrap_or_default();
        layers.push(LayerCompare {
            layer: k,
            equal: lock == mine,
            listen_fnv1a64: mine,
            lock_step_fnv1a64: lock,
            listen_counts,
            lock_step_counts: counts(&l.cells),
        });
    }
    let report = Report {
        duration_s,
        chunks,
        late_chunks,
        max_late_ms: (max_late.as_secs_f64() * 1e5).round() / 100.0,
        poses: poses.len(),
        angles: relay.inject.lock().map_or(0, |i| i.written),
        layers_equal: layers.iter().filter(|l| l.equal).count(),
        mirror_is_listens: board
            .layers
            .iter()
            .zip(&listen_hashes)
            .all(|(l, h)| format!("{:016x}", cells_fnv1a64(&l.cells)) == *h)
            && board.layers.len() == listen_hashes.len(),
        against_board_timed: timing::agreement(&board, &board_timed_run.snapshot),
        board_timed_against_on_time: timing::agreement(
            &board_timed_run.snapshot,
            &on_time_run.snapshot,
        ),
        board_lag,
        against_on_time: timing::agreement(&board, &on_time_run.snapshot),
        against_lock_step: timing::agreement(&board, &lock_step.snapshot),
        on_time_against_lock_step: timing::agreement(&on_time_run.snapshot, &lock_step.snapshot),
        clock,
        latency,
        device_stats: mirror.mirror().last_stats().map(|s| format!("{s:?}")),
        layers,
        listen: summary,
        publisher,
    };
    let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    terrain_pyramid_host::export::write_file(&out.join("live.json"), json.as_bytes())?;
    Ok(report)
}

/// The bounds `--check` holds a run to: the chain ran, the clocks agree, the poses reached the
/// device stamped, and the maps are the device's with those poses. Set from runs on a loaded
/// 2-core machine (`docs/poses.md`, "Playing a recording as a robot lives": accuracy
/// 0.6–1.4 ms, stamp error p95 0.1–5.6 ms, 333–344 of 353 poses taken) with a margin of about
/// two.
///
/// The maps are held against the reference run as the board took the recording
/// ([`Report::against_board_timed`]: every chunk, PanAngle and perfect pose at the time the
/// emulated board took it), not against the on-time run: QEMU's UART hands the firmware one
/// byte a pass and the board takes the LD19's bytes 0.1–3.5 s behind their time on a loaded
/// host, so against the on-time run the same correct chain measured 4 % to 51 % of known cells
/// equal. Against the board-timed run it measured 91.8 % to 98.2 % (lags up to 2.2 s);
/// with the poses not forwarded (`--no-forward`: every return at the origin) 1.7 %.
pub mod bounds {
    /// listen's stated accuracy of its clock mapping, at most, µs.
    pub const ACCURACY_US: f64 = 3_000.0;
    /// The pose stamps' error against the board's clock (95th percentile of |error|), at
    /// most, µs.
    pub const STAMP_ERROR_P95_US: f64 = 12_000.0;
    /// Share of the poses published that the device took into its track, at least.
    pub const POSES_TAKEN: f64 = 0.8;
    /// Share of the known cells (every layer, either map) of listen's maps equal to the
    /// board-timed reference's, at least: a correct chain measured 0.918–0.982 under load, a
    /// chain whose poses are not forwarded 0.017.
    pub const MAP_EQUAL: f64 = 0.8;
}

/// What of `r` breaks the [`bounds`]; empty when it holds.
#[must_use]
pub fn check(r: &Report) -> Vec<String> {
    let mut failed = Vec::new();
    let mut need = |ok: bool, what: String| {
        if !ok {
            failed.push(what);
        }
    };
    let publisher = r.publisher.as_ref();
    let published = publisher.and_then(|p| p["published"].as_u64()).unwrap_or(0);
    need(
        publisher.and_then(|p| p["matched"].as_u64()).unwrap_or(0) > 0,
        "the publisher matched no subscriber".into(),
    );
    need(
        published == r.poses as u64,
        format!("the publisher wrote {published} of {} poses", r.poses),
    );
    let track = &r.listen["device_pose_track"];
    let stamped = track["poses_stamped"].as_u64().unwrap_or(0);
    #[allow(clippy::cast_precision_loss)]
    need(
        stamped as f64 >= bounds::POSES_TAKEN * r.poses as f64,
        format!(
            "the device took {stamped} stamped poses of {} (at least {:.0} %)",
            r.poses,
            bounds::POSES_TAKEN * 100.0
        ),
    );
    let sync = &r.listen["time_sync"];
    need(
        sync["synced"].as_bool() == Some(true),
        "listen's clock mapping not synced at the end".into(),
    );
    let accuracy = sync["accuracy_us"].as_f64().unwrap_or(f64::INFINITY);
    need(
        accuracy <= bounds::ACCURACY_US,
        format!(
            "listen's clock accuracy {accuracy} µs (at most {})",
            bounds::ACCURACY_US
        ),
    );
    need(
        r.clock.stamp_error_abs_us.n > 0
            && r.clock.stamp_error_abs_us.p95 <= bounds::STAMP_ERROR_P95_US,
        format!(
            "pose stamps' error p95 {} µs over {} poses (at most {})",
            r.clock.stamp_error_abs_us.p95,
            r.clock.stamp_error_abs_us.n,
            bounds::STAMP_ERROR_P95_US
        ),
    );
    need(
        r.mirror_is_listens,
        "the relay's mirror differs from listen's maps".into(),
    );
    need(
        r.against_board_timed.known > 0 && r.against_board_timed.equal_share >= bounds::MAP_EQUAL,
        format!(
            "listen's maps: {:.1} % of {} known cells equal to the board-timed reference's \
             (at least {:.0} %)",
            r.against_board_timed.equal_share * 100.0,
            r.against_board_timed.known,
            bounds::MAP_EQUAL * 100.0
        ),
    );
    failed
}

/// Microseconds as signed milliseconds with an ASCII unit: the summary line's clock error
/// (printed as "µs" it read as seconds wherever the "µ" was lost: −501.71 µs became
/// "−501.71 s").
fn us_as_ms(us: f64) -> String {
    format!("{:+.3} ms", us / 1000.0)
}

/// Runs `lab live`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(r) => {
            if args.check {
                let failed = check(&r);
                if !failed.is_empty() {
                    for f in &failed {
                        eprintln!("lab live --check: {f}");
                    }
                    return ExitCode::FAILURE;
                }
                eprintln!("lab live --check: every bound holds");
            }
            if args.json {
                println!("{}", serde_json::to_string(&r).unwrap_or_default());
            } else {
                eprintln!(
                    "lab live: {} chunks ({} late), {} of {} layers equal to the lock-step run's; \
                     known cells equal to the board-timed run's {} (on-time run's {}, worst \
                     layer {}); pose stamps' clock error median {}; stamp to board median {} \
                     ms; {}",
                    r.chunks,
                    r.late_chunks,
                    r.layers_equal,
                    r.layers.len(),
                    r.against_board_timed.equal_share,
                    r.against_on_time.equal_share,
                    r.against_on_time.worst_layer_equal_share,
                    us_as_ms(r.clock.stamp_error_us.median),
                    r.latency.stamp_to_board_ms.median,
                    args.out.join("live.json").display()
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => crate::command_failed(e),
    }
}

#[cfg(test)]
mod tests {
    use super::us_as_ms;

    #[test]
    fn the_clock_error_is_printed_in_milliseconds() {
        assert_eq!(us_as_ms(-501.71), "-0.502 ms");
        assert_eq!(us_as_ms(390.0), "+0.390 ms");
    }
}
