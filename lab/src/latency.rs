//! `lab latency`: how long after a laser telegram enters the emulated board its effect reaches
//! each live output, with every output on, at the SICK's full rate.
//!
//! # What runs
//! The simulated stairs approach (the lab's stairs scene, a robot standing, then driving at
//! walking pace; the LMS291 at its full rate for 0.5° scans, 37.5 telegrams of 361 ranges a
//! second, 27.5 kB/s of its 500 kBd line) is played through the QEMU co-processor
//! (`boards/qemu-mps2`, Cortex-M4F) at the recording's own times (`--rate-hz` scales them), as
//! a robot's laser sends them: each telegram's pan angle and pose, the
//! telegram, then a RequestStats that is not waited for (nothing waits for the device; what
//! it sends is read as it comes). The host's mirror is offered to the outputs at every read,
//! as `pyramid run --foxglove --mcap [--ros2]` does, at the default 10 Hz per topic.
//!
//! # The clocks
//! - *entered*: the host clock right after a telegram's last byte was written to the board's
//!   laser UART.
//! - *reflects*: a hand-off (the copy of the maps the outputs publish from) reflects telegram
//!   `k` when, before it, a Stats arrived that counted `k` telegrams with no changed tile left
//!   on the device (`tiles_dirty = 0`): every change up to `k` was then on the wire ahead of it.
//!   A Stats with tiles still waiting moves nothing (an upper bound on the latency).
//! - *left*: when the message was out of the host, seen by independent readers: a Foxglove
//!   WebSocket client (`py/latency_ws.py`, its receive time), an Eclipse Cyclone DDS reader
//!   (`py/latency_dds.py`, inside the namespace, its receive time), and for the MCAP file the
//!   moment the file had grown past the end of the chunk holding the message (sampled every
//!   millisecond; chunk offsets from the `mcap` package, `py/latency_mcap.py`). Each message
//!   carries its hand-off's stamp (ROS header, Foxglove log time, MCAP log time).
//!
//! Two figures per output, median and 99th percentile:
//! - `telegram_to_message_ms`: for each telegram, from *entered* to the first message of the
//!   output (any map topic: the fused map or a layer) whose hand-off reflects it. It includes
//!   the wait for the next hand-off (the 10 Hz bound), and, for MCAP, for the chunk to fill.
//! - `message_age_ms`: for each map message, from *entered* of the newest telegram it
//!   reflects to *left*.
//!
//! `--ros2` starts a DDS participant: run it only inside a network namespace of its own
//! (`cargo xtask latency` does; the command refuses elsewhere).
use crate::experiments::stairs::{self, Setup};
use clap::Parser;
use serde::Serialize;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use terrain_pyramid::link::convert::setup_message_with_sensor;
use terrain_pyramid::wire::link::{Message, PanAngle, PoseReport, Stats};
use terrain_pyramid_host::device::Device;
use terrain_pyramid_host::emulator::{Emulator, Machine};
use terrain_pyramid_host::link::{HostLink, LinkEvent};
use terrain_pyramid_host::play::{steps, Step};
use terrain_pyramid_host::publish::{only_loopback, Outputs, RobotPose};
use terrain_pyramid_host::run::{boot_emulator, run_config};

/// Arguments of `lab latency`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// A short approach (2 s standing, 2 m/s: about 430 telegrams) instead of the full one
    /// (5 s standing, 1 m/s: about 1 800).
    #[arg(long)]
    pub quick: bool,
    /// Also publish over ROS 2 (DDS) and read it back with Cyclone DDS. Only inside a network
    /// namespace of its own: `cargo xtask latency` runs it there.
    #[arg(long)]
    pub ros2: bool,
    /// Telegrams a second written to the board; the recording's times are scaled to it.
    /// Default: the recording's own rate, the SICK's full rate for its mode (37.5 telegrams of
    /// 361 ranges a second at 0.5°, 27.5 kB/s at 500 kBd).
    #[arg(long)]
    pub rate_hz: Option<f64>,
    /// Updates per second per topic, at most (`--publish-hz` of `pyramid run`).
    #[arg(long, default_value_t = 10.0)]
    pub publish_hz: f64,
    /// Where the recording, the MCAP file, the firmware's log and `latency.json` go.
    #[arg(long, default_value = "target/lab/latency")]
    pub out: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Median and 99th percentile of a set of latencies, ms.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Spread {
    /// How many values.
    pub n: usize,
    /// Median, ms.
    pub median_ms: f64,
    /// 99th percentile (nearest rank), ms.
    pub p99_ms: f64,
    /// Largest, ms.
    pub max_ms: f64,
}

impl Spread {
    fn of(mut ns: Vec<i128>) -> Option<Self> {
        if ns.is_empty() {
            return None;
        }
        ns.sort_unstable();
        let rank = |q: f64| {
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                clippy::cast_precision_loss
            )]
            let i = ((q * ns.len() as f64).ceil() as usize).clamp(1, ns.len()) - 1;
            ms(ns[i])
        };
        Some(Self {
            n: ns.len(),
            median_ms: rank(0.5),
            p99_ms: rank(0.99),
            max_ms: ms(ns[ns.len() - 1]),
        })
    }
}

#[allow(clippy::cast_precision_loss)]
fn ms(ns: i128) -> f64 {
    (ns as f64 / 1e4).round() / 100.0
}

/// One output's figures.
#[derive(Debug, Clone, Serialize)]
pub struct OutputLatency {
    /// Map messages the reader logged.
    pub messages: usize,
    /// Of them, messages whose stamp is no recorded hand-off (the final state published when
    /// the outputs end) or that reflect no telegram yet.
    pub unmatched: usize,
    /// Telegram entered → first message reflecting it.
    pub telegram_to_message_ms: Option<Spread>,
    /// Newest telegram reflected entered → message out.
    pub message_age_ms: Option<Spread>,
}

/// `lab latency`'s report (`latency.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Telegrams played.
    pub telegrams: usize,
    /// Telegrams a second achieved (first to last entered).
    pub rate_hz: f64,
    /// The recording's own rate, telegrams a second.
    pub recording_rate_hz: f64,
    /// The rate asked for (`--rate-hz`, the recording's by default), telegrams a second.
    pub asked_rate_hz: f64,
    /// Telegrams written more than one period after their time.
    pub late: usize,
    /// Hand-offs to the outputs.
    pub handoffs: usize,
    /// Stats that arrived with changed tiles still on the device.
    pub stats_with_tiles_waiting: u64,
    /// `--publish-hz`.
    pub publish_hz: f64,
    /// Per output: `foxglove` (WebSocket), `mcap`, `ros2` (when on).
    pub outputs: std::collections::BTreeMap<String, OutputLatency>,
    /// The machine's load average (1 min) when the run ended.
    pub load_average: Option<f64>,
}

/// `pyramid run`'s flags, parsed as `pyramid` parses them (design, classifier, outputs).
#[derive(Parser)]
struct RunFlags {
    #[command(flatten)]
    args: terrain_pyramid_host::run::Args,
}

fn now_ns() -> i128 {
    stamp_ns(SystemTime::now())
}

fn stamp_ns(t: SystemTime) -> i128 {
    t.duration_since(UNIX_EPOCH)
        .map_or(0, |d| i128::try_from(d.as_nanos()).unwrap_or(i128::MAX))
}

/// The emulator with the outputs offered after every exchange (as `Publishing` does), and the
/// clocks of the measurement.
struct Timed<'a> {
    emu: &'a mut Emulator,
    outputs: &'a mut Outputs,
    pose: Option<RobotPose>,
    /// Host clock after each telegram's last byte was written, ns since the epoch.
    entered: Vec<i128>,
    /// Telegrams every change of which is in the mirror.
    reflected: u64,
    /// The last Stats looked at.
    last_stats: Option<Stats>,
    /// (hand-off stamp ns, telegrams it reflects).
    handoffs: Vec<(i128, u64)>,
    stats_with_tiles_waiting: u64,
}

impl Timed<'_> {
    /// Reads what the device sent by now, then looks at the mirror and offers it.
    fn poll(&mut self) {
        self.emu.poll_received();
        self.look();
    }

    /// Notes a new Stats (what the mirror now reflects) and offers the mirror to the outputs.
    fn look(&mut self) {
        let mirror = self.emu.link().mirror();
        if let Some(s) = mirror.last_stats() {
            if self.last_stats != Some(s) {
                self.last_stats = Some(s);
                if s.tiles_dirty == 0 {
                    self.reflected = self.reflected.max(u64::from(s.telegrams_ok));
                } else {
                    self.stats_with_tiles_waiting += 1;
                }
            }
        }
        if self.outputs.offer(mirror, self.pose) {
            if let Some(stamp) = self.outputs.last_handoff_stamp() {
                self.handoffs.push((stamp_ns(stamp), self.reflected));
            }
        }
    }
}

impl Device for Timed<'_> {
    fn laser(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.emu.laser(bytes)?;
        self.entered.push(now_ns());
        Ok(())
    }

    fn send(&mut self, message: &Message<'_>) -> Result<u16, String> {
        if let Some(pose) = RobotPose::sent_in(message) {
            self.pose = Some(pose);
        }
        self.emu.send(message)
    }

    fn wait_for(
        &mut self,
        what: &str,
        done: impl FnMut(&HostLink, Option<&LinkEvent>) -> bool,
    ) -> Result<(), String> {
        let result = self.emu.wait_for(what, done);
        self.look();
        result
    }

    fn link(&self) -> &HostLink {
        self.emu.link()
    }

    fn frames_sent(&self) -> u64 {
        self.emu.frames_sent()
    }

    fn idle(&mut self) {
        self.emu.idle();
    }

    fn back_off(&mut self, round: u32) {
        self.emu.back_off(round);
    }
}

/// A reader process that prints "ready", then one JSON object at its end (when the server
/// closes, or its standard input does).
struct Reader {
    child: Child,
    stdout: BufReader<ChildStdout>,
}

impl Reader {
    fn start(mut command: Command, name: &str) -> Result<Self, String> {
        let mut child = command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("{name}: cannot start python3: {e}"))?;
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| format!("{name}: no stdout"))?;
        let mut reader = Self {
            child,
            stdout: BufReader::new(stdout),
        };
        let mut line = String::new();
        reader
            .stdout
            .read_line(&mut line)
            .map_err(|e| format!("{name}: {e}"))?;
        if line.trim() != "ready" {
            let _ = reader.child.kill();
            return Err(format!(
                "{name}: expected \"ready\", got {line:?} (are the readers installed? \
                 host/tests/py/setup.sh)"
            ));
        }
        Ok(reader)
    }

    /// The logged messages: (topic, stamp ns, received ns).
    fn finish(mut self, name: &str) -> Result<Vec<(String, i128, i128)>, String> {
        // Its standard input closing tells a reader that the publisher has finished.
        drop(self.child.stdin.take());
        let mut text = String::new();
        self.stdout
            .read_to_string(&mut text)
            .map_err(|e| format!("{name}: {e}"))?;
        let status = self.child.wait().map_err(|e| format!("{name}: {e}"))?;
        if !status.success() {
            return Err(format!("{name} failed ({status})"));
        }
        let v: serde_json::Value = serde_json::from_str(text.trim())
            .map_err(|e| format!("{name}: not one JSON object: {e}: {text}"))?;
        let messages = v["messages"].as_array().cloned().unwrap_or_default();
        Ok(messages
            .iter()
            .filter_map(|m| {
                Some((
                    m.get(0)?.as_str()?.to_string(),
                    i128::from(m.get(1)?.as_u64()?),
                    i128::from(m.get(2)?.as_u64()?),
                ))
            })
            .collect())
    }
}

fn python(script: &str) -> Command {
    let mut c = Command::new("python3");
    c.arg(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("py")
            .join(script),
    );
    c
}

/// Samples the MCAP file's length every millisecond: (host clock ns, bytes), on change.
fn sample_sizes(path: PathBuf, stop: Arc<AtomicBool>) -> Vec<(i128, u64)> {
    let mut samples: Vec<(i128, u64)> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let len = std::fs::metadata(&path).map_or(0, |m| m.len());
        if samples.last().is_none_or(|&(_, l)| l != len) {
            samples.push((now_ns(), len));
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    samples
}

fn is_map_topic(topic: &str) -> bool {
    topic.contains("fused") || topic.contains("layer")
}

/// Both figures of one output from its messages `(topic, stamp, left)`.
fn figures(
    messages: &[(String, i128, i128)],
    handoffs: &[(i128, u64)],
    entered: &[i128],
) -> OutputLatency {
    let reflects: std::collections::HashMap<i128, u64> = handoffs.iter().copied().collect();
    let mut matched: Vec<(u64, i128)> = Vec::new();
    let mut total = 0;
    for (topic, stamp, left) in messages {
        if !is_map_topic(topic) {
            continue;
        }
        total += 1;
        if let Some(&r) = reflects.get(stamp) {
            if r > 0 {
                matched.push((r, *left));
            }
        }
    }
    let age: Vec<i128> = matched
        .iter()
        .filter_map(|&(r, left)| {
            let i = usize::try_from(r).ok()?.checked_sub(1)?;
            Some(left - entered.get(i)?)
        })
        .collect();
    // For each telegram k, the earliest message reflecting k or more.
    matched.sort_unstable_by_key(|m| std::cmp::Reverse(m.0));
    let mut first = vec![None::<i128>; entered.len()];
    let mut best: Option<i128> = None;
    let mut next = 0;
    for k in (1..=entered.len()).rev() {
        while let Some(&(r, left)) = matched.get(next) {
            if usize::try_from(r).unwrap_or(usize::MAX) < k {
                break;
            }
            best = Some(best.map_or(left, |b| b.min(left)));
            next += 1;
        }
        if let Some(slot) = first.get_mut(k - 1) {
            *slot = best;
        }
    }
    let to_message: Vec<i128> = first
        .iter()
        .zip(entered)
        .filter_map(|(f, e)| f.map(|f| f - e))
        .collect();
    OutputLatency {
        messages: total,
        unmatched: total - matched.len(),
        telegram_to_message_ms: Spread::of(to_message),
        message_age_ms: Spread::of(age),
    }
}

/// The MCAP messages as `(topic, stamp, left)`: left is when the file first held the chunk.
fn mcap_messages(path: &Path, sizes: &[(i128, u64)]) -> Result<Vec<(String, i128, i128)>, String> {
    let out = python("latency_mcap.py")
        .arg(path)
        .output()
        .map_err(|e| format!("latency_mcap.py: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "latency_mcap.py failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("latency_mcap.py: {e}"))?;
    let chunks: Vec<(i128, i128, u64)> = v["chunks"]
        .as_array()
        .cloned()
        .unwrap_or_default()
        .iter()
        .filter_map(|c| {
            Some((
                i128::from(c.get(0)?.as_u64()?),
                i128::from(c.get(1)?.as_u64()?),
                c.get(2)?.as_u64()?,
            ))
        })
        .collect();
    let listed = v["messages"].as_array().cloned().unwrap_or_default();
    let mut messages = Vec::new();
    for m in &listed {
        let (Some(topic), Some(stamp)) = (m.get(0).and_then(|t| t.as_str()), m.get(1)) else {
            continue;
        };
        let Some(stamp) = stamp.as_u64().map(i128::from) else {
            continue;
        };
        // The first chunk whose log-time range holds the message's (chunks in file order).
        let Some(&(_, _, end)) = chunks.iter().find(|&&(a, b, _)| a <= stamp && stamp <= b) else {
            continue;
        };
        if let Some(&(t, _)) = sizes.iter().find(|&&(_, len)| len >= end) {
            messages.push((topic.to_string(), stamp, t));
        }
    }
    Ok(messages)
}

/// Runs the measurement.
///
/// # Errors
/// The firmware, QEMU, an output or a reader failed.
pub fn execute(args: &Args) -> Result<Report, String> {
    if args.ros2 && !only_loopback() {
        return Err(
            "--ros2 starts a DDS participant, which discovers by multicast: run it \
                    only inside a network namespace of its own (`cargo xtask latency`)"
                .into(),
        );
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let setup = if args.quick {
        Setup {
            stand_s: 2.0,
            speed_mps: 2.0,
            ..Setup::QUICK
        }
    } else {
        Setup {
            stand_s: 5.0,
            speed_mps: 1.0,
            ..Setup::QUICK
        }
    };
    let recording = args.out.join("latency.rec");
    stairs::write_recording(&setup, &recording)?;
    let data = std::fs::read(&recording).map_err(|e| format!("{}: {e}", recording.display()))?;
    let steps = steps(&data)?;
    // The recording's own rate; its times are scaled to `--rate-hz`.
    let times: Vec<u64> = steps
        .steps
        .iter()
        .filter_map(|s| match s {
            Step::Telegram {
                measured: true,
                time_us,
                ..
            } => Some(*time_us),
            _ => None,
        })
        .collect();
    let recording_rate_hz = match (times.first(), times.last()) {
        #[allow(clippy::cast_precision_loss)]
        (Some(&a), Some(&b)) if b > a => (times.len() - 1) as f64 * 1e6 / (b - a) as f64,
        _ => return Err("the recording has fewer than two telegrams".into()),
    };
    let rate_hz = args.rate_hz.unwrap_or(recording_rate_hz);
    if !(rate_hz > 0.0 && rate_hz <= 1000.0) {
        return Err("--rate-hz: a rate in (0, 1000] telegrams a second".into());
    }
    let scale = recording_rate_hz / rate_hz;
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let mcap = args.out.join("latency.mcap");
    let _ = std::fs::remove_file(&mcap);
    let hz = args.publish_hz.to_string();
    let mut flags: Vec<std::ffi::OsString> = vec![
        "run".into(),
        "--board".into(),
        "qemu".into(),
        "--recording".into(),
        recording.clone().into(),
        "--out".into(),
        args.out.clone().into(),
        "--foxglove".into(),
        "127.0.0.1:0".into(),
        "--mcap".into(),
        mcap.clone().into(),
        "--publish-hz".into(),
        hz.into(),
    ];
    if args.ros2 {
        flags.extend(["--ros2".into(), "--ros-domain-id".into(), "9".into()]);
    }
    let run = RunFlags::try_parse_from(flags)
        .map_err(|e| e.to_string())?
        .args;
    let (design, config, classifier) = run_config(&run).map_err(|(_, e)| e)?;
    let mut outputs = Outputs::start(
        &run.outputs
            .config(terrain_pyramid_host::export::default_fused_margin()),
    )
    .map_err(|e| e.to_string())?;
    let addr = outputs
        .foxglove_addr()
        .ok_or("the Foxglove server did not start")?
        .to_string();
    let ws = Reader::start(
        {
            let mut c = python("latency_ws.py");
            c.arg(format!("ws://{addr}"));
            c
        },
        "latency_ws.py",
    )?;
    let dds = if args.ros2 {
        let mut c = python("latency_dds.py");
        c.args([&design.layers().len().to_string(), "3", "9"]);
        Some(Reader::start(c, "latency_dds.py")?)
    } else {
        None
    };
    let stop = Arc::new(AtomicBool::new(false));
    let sampler = {
        let (path, stop) = (mcap.clone(), Arc::clone(&stop));
        std::thread::spawn(move || sample_sizes(path, stop))
    };
    let mut emu = boot_emulator(Machine::Mps2An386, &args.out.join("firmware.defmt"))?;
    emu.configure_after_hello(&design, &config)?;
    eprintln!("latency: the stairs approach through the emulated board at {rate_hz:.1} Hz ...");
    let mut timed = Timed {
        emu: &mut emu,
        outputs: &mut outputs,
        pose: None,
        entered: Vec::new(),
        reflected: 0,
        last_stats: None,
        handoffs: Vec::new(),
        stats_with_tiles_waiting: 0,
    };
    let mut late = 0;
    let mut clock: Option<(Instant, u64)> = None;
    for step in &steps.steps {
        match step {
            Step::Setup(setup) => {
                let message = setup_message_with_sensor(setup, &steps.sensor, &classifier);
                timed.command("Setup", &Message::Setup(message))?;
            }
            Step::Angle(turns) => {
                timed.send(&Message::PanAngle(PanAngle {
                    turns: *turns,
                    timestamp_ms: 0,
                }))?;
            }
            Step::Pose(pose) => {
                timed.send(&Message::Pose(PoseReport::unstamped(*pose)))?;
            }
            Step::Telegram {
                measured: false, ..
            } => continue,
            Step::Telegram { bytes, time_us, .. } => {
                // Paced at the recording's times; what the device sent meanwhile is read as
                // it comes, and offered to the outputs.
                let (start, first) = *clock.get_or_insert((Instant::now(), *time_us));
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let due = start
                    + Duration::from_micros(
                        (time_us.saturating_sub(first) as f64 * scale).round() as u64
                    );
                loop {
                    timed.poll();
                    let now = Instant::now();
                    match due.checked_duration_since(now) {
                        Some(wait) => std::thread::sleep(wait.min(Duration::from_millis(1))),
                        None => {
                            if now.duration_since(due) > period {
                                late += 1;
                            }
                            break;
                        }
                    }
                }
                timed.laser(bytes)?;
                timed.send(&Message::RequestStats)?;
            }
            Step::Laser { .. } => return Err("lab latency plays SICK telegrams only".into()),
        }
    }
    timed.send(&Message::EndObservation)?;
    // The last changes on the wire, so the last hand-off reflects every telegram.
    timed.sync()?;
    let (entered, handoffs, waiting, pose) = (
        std::mem::take(&mut timed.entered),
        std::mem::take(&mut timed.handoffs),
        timed.stats_with_tiles_waiting,
        timed.pose,
    );
    outputs.finish(emu.link().mirror(), pose)?;
    emu.shutdown()?;
    std::thread::sleep(Duration::from_millis(50));
    stop.store(true, Ordering::Relaxed);
    let sizes = sampler.join().map_err(|_| "the MCAP sampler failed")?;
    let mut per_output = std::collections::BTreeMap::new();
    per_output.insert(
        "foxglove".to_string(),
        figures(&ws.finish("latency_ws.py")?, &handoffs, &entered),
    );
    per_output.insert(
        "mcap".to_string(),
        figures(&mcap_messages(&mcap, &sizes)?, &handoffs, &entered),
    );
    if let Some(dds) = dds {
        per_output.insert(
            "ros2".to_string(),
            figures(&dds.finish("latency_dds.py")?, &handoffs, &entered),
        );
    }
    let span_s = match (entered.first(), entered.last()) {
        #[allow(clippy::cast_precision_loss)]
        (Some(a), Some(b)) if b > a => (b - a) as f64 / 1e9,
        _ => 0.0,
    };
    #[allow(clippy::cast_precision_loss)]
    let achieved_hz = if span_s > 0.0 {
        (entered.len().saturating_sub(1)) as f64 / span_s
    } else {
        0.0
    };
    Ok(Report {
        telegrams: entered.len(),
        rate_hz: (achieved_hz * 10.0).round() / 10.0,
        recording_rate_hz: (recording_rate_hz * 10.0).round() / 10.0,
        asked_rate_hz: (rate_hz * 10.0).round() / 10.0,
        late,
        handoffs: handoffs.len(),
        stats_with_tiles_waiting: waiting,
        publish_hz: args.publish_hz,
        outputs: per_output,
        load_average: std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|t| t.split_whitespace().next()?.parse().ok()),
    })
}

/// `lab latency`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(report) => {
            let json = serde_json::to_string_pretty(&report).unwrap_or_default();
            let _ = std::fs::write(args.out.join("latency.json"), &json);
            if args.json {
                println!("{json}");
            } else {
                eprintln!("{json}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => crate::command_failed(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i128 = 1_000_000;

    #[test]
    fn each_telegram_is_timed_to_the_first_message_that_reflects_it() {
        // Hand-off at 100 ms reflects telegrams 1-2, the one at 200 ms telegrams 1-3.
        let handoffs = [(100 * MS, 2), (200 * MS, 3), (300 * MS, 0)];
        let entered = [10 * MS, 20 * MS, 30 * MS];
        let messages = [
            ("/terrain/fused".to_string(), 100 * MS, 150 * MS),
            ("/terrain/layer_0".to_string(), 200 * MS, 260 * MS),
            // Not a map topic: not counted.
            ("/diagnostics".to_string(), 200 * MS, 210 * MS),
            // A hand-off that reflects nothing yet, and a stamp no hand-off has.
            ("/terrain/fused".to_string(), 300 * MS, 310 * MS),
            ("/terrain/fused".to_string(), 400 * MS, 410 * MS),
        ];
        let f = figures(&messages, &handoffs, &entered);
        assert_eq!(f.messages, 4);
        assert_eq!(f.unmatched, 2);
        let t = f.telegram_to_message_ms.unwrap();
        // Telegram 1: 150 - 10; telegram 2: 150 - 20; telegram 3: 260 - 30.
        assert_eq!((t.n, t.median_ms, t.max_ms), (3, 140.0, 230.0));
        let age = f.message_age_ms.unwrap();
        // 150 - 20 (newest reflected: 2) and 260 - 30 (newest: 3).
        assert_eq!((age.n, age.median_ms, age.max_ms), (2, 130.0, 230.0));
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let s = Spread::of((1..=200).map(|v| v * MS).collect()).unwrap();
        assert_eq!((s.median_ms, s.p99_ms, s.max_ms), (100.0, 198.0, 200.0));
        assert!(Spread::of(Vec::new()).is_none());
    }
}
