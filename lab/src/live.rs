//! `lab live`: a recording played as a robot lives, through the emulated board and the host
//! tool a robot user runs.
//!
//! # What runs
//! - The recording: the LD19 nodding on its servo on a robot driving up the stairs at 1 m/s
//!   ([`crate::experiments::timing::ld19_setup`], quick: 2 s standing 6 m away).
//! - The emulated board (`boards/qemu-mps2` on QEMU's mps2-an386), its UARTs on sockets of
//!   its own. Over the host link's UART the lab sends the recording's Setup (the sensor and
//!   the servo: the board's servo model gives the angles) and waits for its Reply; then the
//!   link is relayed, byte for byte, to a TCP address on 127.0.0.1 for `pyramid listen --tcp`.
//! - The laser's bytes: each chunk written to the laser UART at its recorded time on the wall
//!   clock, from a start a few seconds ahead.
//! - The poses, not from the recording: `py/odom_pub.py`, a separate process, publishes the
//!   trajectory at 50 Hz as `nav_msgs/msg/Odometry` on `/odom` with Cyclone DDS, each stamped
//!   with the wall-clock time the robot was there and published 30 ± 10 ms after it.
//! - `pyramid listen --tcp ADDR --ros2 --odom-topic /odom` forwards them to the board as
//!   stamped Poses, and writes the maps and `summary.json` when the recording has played.
//!
//! # What is reported
//! Each layer of listen's maps against the lock-step run of the same recording (the library's
//! co-processor in this process with the firmware's design, each chunk's pose from the
//! recording before its bytes, the device's clock the recording's time: firmware = host bit
//! for bit, as every other harness relies on): its raw cells' FNV-1a 64 and its counts of
//! observed, obstacle and navigable cells, equal or not; and what listen's summary says of
//! the poses and the clock (passed on as it is).
//!
//! `--ros2` starts DDS participants: run it only inside a network namespace of its own
//! (`cargo xtask live` does; the command refuses elsewhere).

use crate::experiments::timing::{self, Input, LatePose, PoseRule};
use serde::Serialize;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::setup_message_with_sensor;
use terrain_pyramid::wire::link::Message;
use terrain_pyramid::{
    Config, DefaultDesign, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS,
    DEFAULT_LAYERS,
};
use terrain_pyramid_host::emulator::Machine;
use terrain_pyramid_host::link::{HostLink, LinkEvent};
use terrain_pyramid_host::listen::cells_fnv1a64;
use terrain_pyramid_host::play::{steps, Step, Steps};
use terrain_pyramid_host_tests::sim::lidar::simulate_lidar;

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
    /// Poses the publisher was given.
    pub poses: usize,
    /// Per layer.
    pub layers: Vec<LayerCompare>,
    /// Layers whose cells equal the lock-step run's exactly.
    pub layers_equal: usize,
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

fn only_loopback() -> bool {
    std::fs::read_dir("/sys/class/net").is_ok_and(|d| {
        d.filter_map(Result::ok)
            .all(|e| e.file_name().to_string_lossy() == "lo")
    })
}

fn connect(path: &Path, child: &mut Child) -> Result<UnixStream, String> {
    let start = Instant::now();
    loop {
        match UnixStream::connect(path) {
            Ok(s) => return Ok(s),
            Err(e) => {
                if let Ok(Some(status)) = child.try_wait() {
                    return Err(format!("QEMU exited before its UARTs opened ({status})"));
                }
                if start.elapsed() > Duration::from_secs(20) {
                    return Err(format!("cannot connect to {}: {e}", path.display()));
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    }
}

/// QEMU with the firmware, its UARTs on sockets in `dir`.
fn start_qemu(elf: &Path, dir: &Path) -> Result<(Reaped, UnixStream, UnixStream), String> {
    let machine = Machine::Mps2An386;
    let (s0, s1) = (dir.join("uart0.sock"), dir.join("uart1.sock"));
    let log = std::fs::File::create(dir.join("firmware.defmt"))
        .map_err(|e| format!("cannot create the firmware's log: {e}"))?;
    let mut child = Command::new("qemu-system-arm")
        .args([
            "-machine",
            machine.qemu_machine(),
            "-nographic",
            "-cpu",
            "cortex-m4",
        ])
        .args([
            "-monitor",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
        ])
        .arg("-serial")
        .arg(format!("unix:{},server=on,wait=on", s0.display()))
        .arg("-serial")
        .arg(format!("unix:{},server=on,wait=on", s1.display()))
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let uart0 = connect(&s0, &mut child);
    let uart1 = connect(&s1, &mut child);
    let child = Reaped(Some(child));
    Ok((child, uart0?, uart1?))
}

/// Sends the recording's Setup over the link and waits for its Reply (and the Hello before).
fn setup_device(uart1: &mut UnixStream, steps: &Steps) -> Result<(), String> {
    let setup = steps.setup().ok_or("the recording has no setup")?;
    let message = setup_message_with_sensor(&setup, &steps.sensor, &ClassifierConfig::DEFAULT);
    let mut host = HostLink::new();
    let seq = host.next_seq();
    let frame = host
        .command(&Message::Setup(message))
        .map_err(|e| e.to_string())?;
    uart1
        .set_read_timeout(Some(Duration::from_millis(50)))
        .map_err(|e| e.to_string())?;
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut sent = false;
    let mut buf = [0_u8; 4096];
    while Instant::now() < deadline {
        if !sent && host.mirror().firmware().is_some() {
            uart1.write_all(&frame).map_err(|e| e.to_string())?;
            sent = true;
        }
        let n = match uart1.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                0
            }
            Err(e) => return Err(format!("the link: {e}")),
        };
        for event in host.feed(buf.get(..n).unwrap_or_default()) {
            if let LinkEvent::Reply(r) = event {
                if sent && r.to_seq == seq {
                    return if r.is_ok() {
                        Ok(())
                    } else {
                        Err(format!("the device refused the Setup: {r:?}"))
                    };
                }
            }
        }
    }
    Err("no Reply to the Setup in 20 s".into())
}

/// Relays the link between the board's UART and the first TCP client of `listener`, until
/// either side closes.
fn relay(listener: TcpListener, uart1: UnixStream) {
    std::thread::spawn(move || {
        let Ok((tcp, _)) = listener.accept() else {
            return;
        };
        let _ = tcp.set_nodelay(true);
        let _ = uart1.set_read_timeout(None);
        let (Ok(mut tcp_r), Ok(mut uart_w)) = (tcp.try_clone(), uart1.try_clone()) else {
            return;
        };
        std::thread::spawn(move || {
            let _ = std::io::copy(&mut tcp_r, &mut uart_w);
        });
        let (mut uart_r, mut tcp_w) = (uart1, tcp);
        let _ = std::io::copy(&mut uart_r, &mut tcp_w);
    });
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

/// Runs the chain; returns the report.
///
/// # Errors
/// A part of the chain failed to start or to finish.
#[allow(clippy::too_many_lines)]
pub fn execute(args: &Args) -> Result<Report, String> {
    if args.ros2 && !only_loopback() {
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
    let sim_config =
        crate::experiments::lidar::ld19_sim(scene.scene.clone(), scene.trajectory, setup.seed);
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
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .map_err(|e| e.to_string())?;
    let config = Config::default();
    let frontend = terrain_pyramid::link::convert::frontend_config(&setup_message_with_sensor(
        &steps.setup().ok_or("no setup")?,
        &steps.sensor,
        &ClassifierConfig::DEFAULT,
    ))
    .map_err(|e| e.to_string())?;
    let input = Input {
        steps: &steps,
        late: &[],
        on_time: &[],
        design: &design,
        config: &config,
        frontend,
        first_riser: None,
        end_observation: false,
    };
    let reference = std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(64 << 20)
            .spawn_scoped(s, || {
                timing::run::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, DEFAULT_CLASSIFIER_SLOTS>(
                    &input,
                    PoseRule::LockStep,
                )
            })
            .map_err(|e| e.to_string())?
            .join()
            .unwrap_or_else(|_| Err("the reference run panicked".into()))
    })?;
    // The board.
    let elf = Machine::Mps2An386.build()?;
    let sockets = std::env::temp_dir().join(format!("pyramid-live-{}", std::process::id()));
    std::fs::create_dir_all(&sockets).map_err(|e| e.to_string())?;
    let (qemu, mut uart0, mut uart1) = start_qemu(&elf, &sockets)?;
    setup_device(&mut uart1, &steps)?;
    let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    let address = listener.local_addr().map_err(|e| e.to_string())?;
    relay(listener, uart1);
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
        listen.args(["--ros2", "--odom-topic", "/odom"]);
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
                .stdout(Stdio::piped())
                .stderr(Stdio::inherit())
                .spawn()
                .map_err(|e| format!("cannot start python3: {e}"))?,
        )))
    } else {
        None
    };
    // The laser, paced.
    let mut chunks = 0;
    let mut late_chunks = 0;
    let mut max_late = Duration::ZERO;
    for step in &steps.steps {
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
    drop(qemu);
    let _ = std::fs::remove_dir_all(&sockets);
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
    for (k, l) in reference.snapshot.layers.iter().enumerate() {
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
        layers_equal: layers.iter().filter(|l| l.equal).count(),
        layers,
        listen: summary,
        publisher,
    };
    let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    terrain_pyramid_host::export::write_file(&out.join("live.json"), json.as_bytes())?;
    Ok(report)
}

/// Runs `lab live`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(r) => {
            if args.json {
                println!("{}", serde_json::to_string(&r).unwrap_or_default());
            } else {
                eprintln!(
                    "lab live: {} chunks ({} late), {} of {} layers equal to the lock-step run's; \
                     {}",
                    r.chunks,
                    r.late_chunks,
                    r.layers_equal,
                    r.layers.len(),
                    args.out.join("live.json").display()
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Whether the live chain can run here: root (for `unshare -n`) and `unshare` present.
pub fn can_run() -> Result<(), String> {
    let root = std::fs::read_to_string("/proc/self/status").is_ok_and(|s| {
        s.lines()
            .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"))
    });
    if !root {
        return Err("not root: `unshare -n` needs it".into());
    }
    if Command::new("unshare").arg("--version").output().is_err() {
        return Err("no `unshare` (util-linux)".into());
    }
    Ok(())
}
