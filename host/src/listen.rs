//! `pyramid listen`: receives the device's map stream (`docs/protocol.md`) from a serial port
//! or a TCP socket (the emulated board), keeps the host's mirror of its pyramid, and writes
//! the maps when the session ends, in the same files as `pyramid replay` (see
//! [`crate::export`]) and a `summary.json`.
//!
//! # The session
//! - On connecting it sends one `0x00` (to end whatever the device's receiver holds) and a
//!   `RequestSnapshot(all)`, so that a device that was already running sends its whole maps.
//! - It asks again whenever the mirror may be wrong: a frame was lost or refused
//!   ([`LinkEvent::SnapshotNeeded`], [`Mirror::needs_snapshot`]). While a request is
//!   outstanding (no Hello has answered it) it does not ask again for [`SNAPSHOT_RETRY`], so
//!   a lossy line does not restart the resend on every gap.
//! - A status line on stderr, refreshed every [`STATUS_INTERVAL`]: rewritten in place with `\r`
//!   when stderr is a terminal, one plain line each time otherwise.
//! - It ends on Ctrl-C (or SIGTERM), when the device closes the stream, or after
//!   `--duration-s`; it then writes the last maps. A second Ctrl-C exits at once (status 130).
//!
//! - Live outputs (`--ros2`, `--foxglove`, `--mcap`, [`crate::publish`], `docs/ros2.md`): the
//!   mirror is offered to them after every read; they never hold up the reader.
//! - With a rig (`--rig FILE` or any rig flag, [`crate::rigfile`], `docs/rig.md`), it first
//!   sends the device its Setup: the sensor, mount, actuator, observation policy and the
//!   classifier's thresholds (the rig file's `[classifier]` with the rule flags over it). The
//!   device's answer is reported on stderr; a refusal names the field and its rule. Without a
//!   rig no Setup is sent and the device keeps the setup it has.
//! - With `--rule` or any of its parameters (`crate::rule`), it then sends a SetRule
//!   command: the device's classifier takes that step threshold and navigability rule (the
//!   rest of its setup stays); the device's answer is reported on stderr (an older firmware
//!   answers Unsupported and keeps its rule).
//! - The clocks (`docs/poses.md`): a TimeRequest every [`TIME_REQUEST_FAST`] for
//!   [`TIME_REQUEST_FAST_FOR`] after connecting (and after a device's boot Hello), then every
//!   [`TIME_REQUEST_SLOW`]; each TimeReply feeds the [`ClockSync`] filter. The maps published
//!   live are stamped with the device's latest `Observed.last_us` mapped to the host's wall
//!   clock (the time of the data, not of its receipt).
//! - The robot's poses (`--ros2 --odom-topic TOPIC`, `--pose-udp ADDR`, [`crate::pose_input`]):
//!   read by threads of their own into a channel the loop drains without waiting; each checked,
//!   at most 100 a second forwarded as a stamped Pose in the device's clock. While the clock
//!   mapping is not known (after connecting, after a device's boot) none is forwarded.
//! - When the stream ends on a serial port (or on TCP with `--reconnect`) the session goes on:
//!   the device is looked for every [`RECONNECT_INTERVAL`], the maps are kept, and a snapshot
//!   is requested once it is back.
//!
//! # summary.json
//! The maps' part is `pyramid replay`'s (`layers`, `fused`); the points are not known to the
//! host, so instead come the link's counters (`frames`, `crc_errors`, `patches`, `gaps`,
//! `snapshots_requested`, …), whether the mirror was `synced` with the device at the end,
//! and a hash of each layer's raw cells (`layer_cells_fnv1a64`, FNV-1a 64 of the W × W cells
//! as `i16` little-endian, row-major from the lowest row), to compare with the device's;
//! `reconnects`, and `outputs` (hand-offs, coalesced, messages per output and topic) when an
//! output was on; `time_sync` (the clock mapping and its counters), `poses` (the pose inputs'
//! counters, when one was on) and `device_pose_track` (the device's Stats 30 ..= 35).
use crate::clock_sync::{ClockCounters, ClockSync, Exchange, Outcome, ResetReason};
use crate::export::{self, MapSnapshot, MapSummary};
use crate::link::{HostLink, LinkEvent, Mirror};
use crate::pose_input::{self, PoseCounters, PoseForwarder, Source, SourceEvent, WallAnchor};
use crate::publish::ros_msgs;
use crate::publish::RobotPose;
use crate::publish::{OutputArgs, Outputs, OutputsReport};
use serde::Serialize;
use std::collections::VecDeque;
use std::io::{IsTerminal, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::{set_rule_message, ReplyText};
use terrain_pyramid::wire::link::{
    ClockSource, HelloReason, Message, MessageType, PoseReport, Reply, ReplyCode, RxCounters,
    SetRule, Setup, SnapshotScope, Stats, TimeRequest, POSE_STAMPED,
};
use terrain_pyramid::LogOddsFixed;

/// How often the status line is refreshed.
pub const STATUS_INTERVAL: Duration = Duration::from_millis(250);

/// The window the rates of the status line are measured over.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);

/// How long an unanswered snapshot request stands before the host asks again.
pub const SNAPSHOT_RETRY: Duration = Duration::from_secs(2);

/// The protocol's line speed, baud.
pub const DEFAULT_BAUD: u32 = 921_600;

/// How long one read waits for bytes, so that Ctrl-C and the deadline are seen promptly.
const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// How long one read waits for bytes while poses come in: a pose waits at most this long
/// (plus a pass of the loop) for the loop to forward it.
const POSE_READ_TIMEOUT: Duration = Duration::from_millis(2);

/// The TimeRequests' period after connecting or a device's boot (10 Hz).
pub const TIME_REQUEST_FAST: Duration = Duration::from_millis(100);

/// How long after connecting or a device's boot the TimeRequests go at [`TIME_REQUEST_FAST`].
pub const TIME_REQUEST_FAST_FOR: Duration = Duration::from_secs(2);

/// The TimeRequests' period otherwise (2 Hz).
pub const TIME_REQUEST_SLOW: Duration = Duration::from_millis(500);

/// The host's monotonic µs count (the clock the time exchanges are timed on) starts this long
/// before the session, so that a pose stamped shortly before it still has a time on it.
const MONOTONIC_LEAD: Duration = Duration::from_secs(10);

/// Pose-input events taken per pass of the loop, at most (the rest wait for the next pass).
const INPUTS_PER_PASS: usize = 1_000;

/// The channel between the pose inputs and the loop, events.
const INPUT_CHANNEL: usize = 1_024;

/// How long connecting to a TCP address may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// Arguments of `pyramid listen`.
#[derive(clap::Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["port", "tcp"])))]
#[command(
    after_help = "The rig: with --rig FILE or any rig flag (--sensor, --mount-xyz-m, \
--actuator, --servo-sweep-deg, --lines-per-observation, ...), the device is sent its Setup on \
connecting and on every reconnection, before the SetRule of the rule flags. Without them no \
Setup is sent: the device keeps the setup it booted with (or was last given)."
)]
pub struct Args {
    /// The device's serial port (8N1).
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,
    /// The serial port's speed, baud [default: 921600, the protocol's].
    #[arg(long, value_name = "BD", conflicts_with = "tcp")]
    pub baud: Option<u32>,
    /// A TCP address serving the device's stream instead (the emulated board).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// The directory the maps, the picture and `summary.json` are written into (created if
    /// missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print the summary as one JSON object on stdout (it is always written to
    /// `DIR/summary.json`).
    #[arg(long)]
    pub json: bool,
    /// Stop after this many seconds (otherwise at Ctrl-C or the end of the stream).
    #[arg(long, value_name = "N", value_parser = positive_seconds)]
    pub duration_s: Option<f64>,
    /// When the stream ends, try to reconnect every second (keeping the maps) until the session
    /// ends, instead of ending it. Always so for a serial port (a USB adapter unplugged).
    #[arg(long)]
    pub reconnect: bool,
    /// Subscribe to the robot's odometry (nav_msgs/msg/Odometry) on TOPIC, with --ros2's
    /// domain, and send each pose to the device stamped in its clock (header.stamp, pose.pose;
    /// the maps take header.frame_id unless --frame-id is given). QoS best effort, volatile:
    /// it takes reliable and best-effort publishers alike. See docs/poses.md.
    #[arg(long, value_name = "TOPIC", requires = "ros2")]
    pub odom_topic: Option<String>,
    /// Read the robot's poses as newline-delimited JSON datagrams on this UDP address [default:
    /// 127.0.0.1:7420] (for robots without ROS 2; the format is in docs/poses.md).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = pose_input::DEFAULT_POSE_UDP_ADDR)]
    pub pose_udp: Option<String>,
    /// The live outputs.
    #[command(flatten)]
    pub outputs: OutputArgs,
    /// The navigability rule and its parameters: when any of these flags is given, the
    /// device is told on connecting (and on every reconnection) with a SetRule command; the
    /// parameters not given take the library's defaults. Without them the device keeps its
    /// rule.
    #[command(flatten)]
    pub rule: crate::rule::RuleArgs,
    /// The rig the device is set up with (its Setup) on connecting; see below.
    #[command(flatten)]
    pub rig: crate::rigfile::RigArgs,
    /// The laser UART's baud rate sent in the Setup [default: the rig file's, else the
    /// sensor's].
    #[arg(long, value_name = "BD")]
    pub sensor_baud: Option<u32>,
}

/// How often a lost device is looked for again.
pub const RECONNECT_INTERVAL: Duration = Duration::from_secs(1);

fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 && v < 1e9 {
        Ok(v)
    } else {
        Err(format!("{s:?} is not a positive number of seconds"))
    }
}

// ------------------------------------------------------------------ the byte stream

/// Where the device's bytes come from.
enum Transport {
    Serial(Box<dyn serialport::SerialPort>),
    Tcp(TcpStream),
    /// Released while the device is looked for again (a serial port must be closed, and its
    /// lock released, before it can be opened again).
    Closed,
}

/// What one read gave.
enum Received {
    Bytes(usize),
    Nothing,
    /// The stream ended; the reason, when it was an error.
    Ended(Option<String>),
}

impl Transport {
    fn open(args: &Args) -> Result<(Self, String), String> {
        let read_timeout = if args.odom_topic.is_some() || args.pose_udp.is_some() {
            POSE_READ_TIMEOUT
        } else {
            READ_TIMEOUT
        };
        if let Some(path) = &args.port {
            let baud = args.baud.unwrap_or(DEFAULT_BAUD);
            let port = serialport::new(path.as_str(), baud)
                .data_bits(serialport::DataBits::Eight)
                .parity(serialport::Parity::None)
                .stop_bits(serialport::StopBits::One)
                .flow_control(serialport::FlowControl::None)
                .timeout(read_timeout)
                .open()
                .map_err(|e| serial_open_error(path, &e))?;
            return Ok((Self::Serial(port), format!("{path} at {baud} Bd")));
        }
        let address = args.tcp.as_deref().unwrap_or_default();
        let addrs: Vec<_> = address
            .to_socket_addrs()
            .map_err(|e| format!("cannot connect to {address}: {e}"))?
            .collect();
        let mut last = format!("cannot connect to {address}: no address");
        for addr in addrs {
            match TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT) {
                Ok(stream) => {
                    stream
                        .set_read_timeout(Some(read_timeout))
                        .and_then(|()| stream.set_nodelay(true))
                        .map_err(|e| format!("cannot set up the connection to {address}: {e}"))?;
                    return Ok((Self::Tcp(stream), format!("tcp {address}")));
                }
                Err(e) => last = format!("cannot connect to {address}: {e}"),
            }
        }
        Err(last)
    }

    fn read(&mut self, buf: &mut [u8]) -> Received {
        let (result, is_tcp) = match self {
            Self::Serial(port) => (port.read(buf), false),
            Self::Tcp(stream) => (stream.read(buf), true),
            Self::Closed => return Received::Ended(None),
        };
        match result {
            Ok(0) if is_tcp => Received::Ended(None),
            Ok(0) => Received::Nothing,
            Ok(n) => Received::Bytes(n),
            Err(e) => match e.kind() {
                std::io::ErrorKind::WouldBlock
                | std::io::ErrorKind::TimedOut
                | std::io::ErrorKind::Interrupted => Received::Nothing,
                _ => Received::Ended(Some(e.to_string())),
            },
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Self::Serial(port) => port.write_all(bytes).and_then(|()| port.flush()),
            Self::Tcp(stream) => stream.write_all(bytes),
            Self::Closed => Err(std::io::ErrorKind::NotConnected.into()),
        }
    }
}

/// Why a serial port cannot be opened, in words: the port is exclusive (TIOCEXCL and an
/// exclusive `flock`, serialport's default), so another process holding it is named as such.
fn serial_open_error(path: &str, e: &serialport::Error) -> String {
    let busy = e.description.contains("exclusive lock")
        || e.description.contains("busy")
        || e.description.contains("EBUSY");
    if busy {
        format!("cannot open the serial port {path}: it is already open in another process ({e})")
    } else {
        format!("cannot open the serial port {path}: {e}")
    }
}

// ------------------------------------------------------------------ status line

/// The counters the status line shows, at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Good frames applied.
    pub frames: u64,
    /// Bad frames dropped (every kind).
    pub errors: u64,
    /// Patches applied.
    pub patches: u64,
    /// Sequence gaps.
    pub gaps: u64,
    /// Snapshots requested.
    pub snapshots: u64,
}

/// Rates per second of frames, errors and patches.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rates {
    /// Frames per second.
    pub frames: f64,
    /// Errors per second.
    pub errors: f64,
    /// Patches per second.
    pub patches: f64,
}

/// Rates over the last [`RATE_WINDOW`], from samples of the counters.
#[derive(Debug, Default)]
pub struct RateMeter {
    samples: VecDeque<(Instant, Counts)>,
}

impl RateMeter {
    /// Adds a sample and returns the rates since the oldest sample within the window (the one
    /// just before it, so that the span is at least the window once there is history).
    pub fn sample(&mut self, now: Instant, counts: Counts) -> Rates {
        self.samples.push_back((now, counts));
        while self.samples.len() > 2
            && self
                .samples
                .get(1)
                .is_some_and(|(t, _)| now.duration_since(*t) >= RATE_WINDOW)
        {
            self.samples.pop_front();
        }
        let Some(&(t0, c0)) = self.samples.front() else {
            return Rates::default();
        };
        let dt = now.duration_since(t0).as_secs_f64();
        if dt <= 0.0 {
            return Rates::default();
        }
        #[allow(clippy::cast_precision_loss)]
        let per_s = |a: u64, b: u64| b.saturating_sub(a) as f64 / dt;
        Rates {
            frames: per_s(c0.frames, counts.frames),
            errors: per_s(c0.errors, counts.errors),
            patches: per_s(c0.patches, counts.patches),
        }
    }
}

/// The mirror's state in a word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyncState {
    /// No Hello yet.
    Waiting,
    /// The copy may differ from the device's (frames lost, or a resend under way).
    Syncing,
    /// The copy equals the device's as of the last frame.
    Synced,
}

impl SyncState {
    fn of(mirror: &Mirror) -> Self {
        if mirror.firmware().is_none() {
            Self::Waiting
        } else if mirror.is_synced() {
            Self::Synced
        } else {
            Self::Syncing
        }
    }

    const fn word(self) -> &'static str {
        match self {
            Self::Waiting => "waiting for Hello",
            Self::Syncing => "syncing",
            Self::Synced => "synced",
        }
    }
}

/// The status line: elapsed time, frames, errors and patches (totals and per second), gaps,
/// snapshots requested, and the mirror's state.
#[must_use]
pub fn status_line(elapsed: Duration, counts: &Counts, rates: &Rates, state: SyncState) -> String {
    format!(
        "{:7.1} s  frames {} ({:.0}/s)  errors {} ({:.0}/s)  patches {} ({:.0}/s)  gaps {}  snapshots {}  {}",
        elapsed.as_secs_f64(),
        counts.frames,
        rates.frames,
        counts.errors,
        rates.errors,
        counts.patches,
        rates.patches,
        counts.gaps,
        counts.snapshots,
        state.word()
    )
}

/// Writes the status line and notices to stderr.
struct StatusOutput {
    terminal: bool,
    /// The length of the line now on the terminal (0 = none).
    shown: usize,
}

impl StatusOutput {
    fn new() -> Self {
        Self {
            terminal: std::io::stderr().is_terminal(),
            shown: 0,
        }
    }

    fn status(&mut self, line: &str) {
        let mut err = std::io::stderr().lock();
        if self.terminal {
            let pad = self.shown.saturating_sub(line.len());
            let _ = write!(err, "\r{line}{:pad$}", "");
            let _ = err.flush();
            self.shown = line.len();
        } else {
            let _ = writeln!(err, "{line}");
        }
    }

    /// A line of its own (the status line, if shown, is ended first).
    fn notice(&mut self, line: &str) {
        self.finish();
        eprintln!("{line}");
    }

    /// Ends the rewritten line.
    fn finish(&mut self) {
        if self.terminal && self.shown > 0 {
            eprintln!();
            self.shown = 0;
        }
    }
}

// ------------------------------------------------------------------ the session

/// Why a session ended.
#[derive(Serialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// Ctrl-C or SIGTERM.
    Interrupted,
    /// The device closed the stream (or the port failed).
    EndOfStream,
    /// `--duration-s` elapsed.
    Duration,
}

/// The summary of a session: what `summary.json` holds and `--json` prints.
#[derive(Serialize, Debug, Clone)]
pub struct Summary {
    /// Per layer: counts of the cells of its window (as `pyramid replay`).
    pub layers: Vec<export::LayerSummary>,
    /// The fused map's counts (as `pyramid replay`).
    pub fused: export::FusedSummary,
    /// Good frames applied.
    pub frames: u64,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u64,
    /// Patches applied.
    pub patches: u64,
    /// Sequence gaps (each one or more frames lost).
    pub gaps: u64,
    /// Snapshots requested (the first one at the start included).
    pub snapshots_requested: u64,
    /// Bad frames of every kind (COBS, length, CRC, version, type, body, range).
    pub bad_frames: u64,
    /// Frames missing by their sequence numbers.
    pub missing_frames: u64,
    /// Old or repeated frames refused.
    pub out_of_order: u64,
    /// Hello frames.
    pub hellos: u64,
    /// Patches the mirror could not place.
    pub patches_refused: u64,
    /// Whether the maps written equal the device's as of the last frame.
    pub synced: bool,
    /// The device's firmware version, from its last Hello.
    pub firmware: String,
    /// The clock the device's board runs on, from its last Hello (`docs/protocol.md`).
    pub clock: String,
    /// What ended the session.
    pub ended_by: Ending,
    /// The session's length, seconds.
    pub duration_s: f64,
    /// Per layer, FNV-1a 64 of its raw cells, hex.
    pub layer_cells_fnv1a64: Vec<String>,
    /// The files written.
    pub files: Vec<String>,
    /// Times the device was reconnected after its stream ended (`--reconnect`, serial ports).
    pub reconnects: u64,
    /// Setups sent to the device (the rig's, one per connection; 0 without a rig).
    pub setups_sent: u64,
    /// The live outputs (`--ros2`, `--foxglove`, `--mcap`), when any was on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outputs: Option<OutputsReport>,
    /// The clock mapping at the end and its counters.
    pub time_sync: TimeSyncReport,
    /// The pose inputs (`--odom-topic`, `--pose-udp`), when one was on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub poses: Option<PosesReport>,
    /// The device's pose track and time counters (its last Stats, i = 30 ..= 35).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_pose_track: Option<DevicePoseTrack>,
}

/// The clock mapping (host ↔ device, [`ClockSync`]) at the end of a session.
#[derive(Serialize, Debug, Clone)]
pub struct TimeSyncReport {
    /// Whether the mapping was known at the end.
    pub synced: bool,
    /// Device µs minus host µs (the host's count starts 10 s before the session) at the
    /// mapping's anchor; `None` when not synced.
    pub offset_us: Option<f64>,
    /// The device's clock rate minus the host's, ppm.
    pub drift_ppm: Option<f64>,
    /// The stated bound on the mapping's error at its anchor, µs.
    pub accuracy_us: Option<f64>,
    /// The anchor exchange's round trip, µs.
    pub round_trip_us: Option<u64>,
    /// TimeRequests sent.
    pub requests_sent: u64,
    /// The filter's counters (replies taken, discarded, resets by reason).
    #[serde(flatten)]
    pub counters: ClockCounters,
    /// Every reset, whatever its reason.
    pub resets: u64,
    /// Observed frames received.
    pub observed: u64,
    /// Observed frames whose time could not be mapped (no mapping yet): the maps were
    /// stamped with the hand-off's time meanwhile.
    pub observed_unmapped: u64,
}

/// The pose inputs of a session.
#[derive(Serialize, Debug, Clone)]
pub struct PosesReport {
    /// The inputs (`ros2 /odom`, `udp 127.0.0.1:7420`).
    pub sources: Vec<String>,
    /// The poses' frame (the first named).
    pub frame: Option<String>,
    /// What became of the poses, by reason.
    #[serde(flatten)]
    pub counters: PoseCounters,
}

/// The device's own counters of the stamped poses and the time exchange (Stats 30 ..= 35).
#[derive(Serialize, Debug, Clone, Copy)]
pub struct DevicePoseTrack {
    /// Stamped poses taken into the track.
    pub poses_stamped: u32,
    /// Stamped poses refused (not newer than the newest, or over 1 s ahead of its clock).
    pub poses_refused: u32,
    /// Stamped poses over 500 ms after the newest (the track restarted at them).
    pub pose_gaps: u32,
    /// Returns placed with a pose extrapolated past the newest.
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u32,
    /// TimeRequests answered.
    pub time_requests: u32,
}

impl DevicePoseTrack {
    fn of(s: &Stats) -> Self {
        Self {
            poses_stamped: s.poses_stamped,
            poses_refused: s.poses_refused,
            pose_gaps: s.pose_gaps,
            returns_extrapolated: s.returns_extrapolated,
            returns_without_pose: s.returns_without_pose,
            time_requests: s.time_requests,
        }
    }
}

/// FNV-1a 64 of raw cells as `i16` little-endian.
#[must_use]
pub fn cells_fnv1a64(cells: &[i16]) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for byte in cells.iter().flat_map(|c| c.to_le_bytes()) {
        h ^= u64::from(byte);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

fn total_errors(rx: &RxCounters) -> u64 {
    [
        rx.cobs,
        rx.crc,
        rx.too_short,
        rx.too_long,
        rx.unknown_version,
        rx.unknown_type,
        rx.bad_body,
        rx.out_of_range,
    ]
    .iter()
    .map(|&n| u64::from(n))
    .sum()
}

/// The session's clocks and poses: the time exchanges, the clock mapping, the pose inputs.
struct Timing {
    /// The origin of the host's µs count.
    origin: Instant,
    clock: ClockSync,
    wall: WallAnchor,
    forwarder: PoseForwarder,
    inputs: Option<mpsc::Receiver<SourceEvent>>,
    /// The pose inputs' threads (stopped when dropped).
    sources: Vec<Source>,
    fast_until: Instant,
    next_request: Instant,
    requests_sent: u64,
    observed: u64,
    observed_unmapped: u64,
    /// The robot's latest forwarded pose (for the live outputs).
    last_pose: Option<RobotPose>,
    /// Dropped poses when the diagnostics were last built (a rise is a warning).
    dropped_before: u64,
}

impl Timing {
    fn new(now: Instant) -> Self {
        Self {
            origin: now.checked_sub(MONOTONIC_LEAD).unwrap_or(now),
            clock: ClockSync::new(),
            wall: WallAnchor::new(),
            forwarder: PoseForwarder::new(),
            inputs: None,
            sources: Vec::new(),
            fast_until: now + TIME_REQUEST_FAST_FOR,
            next_request: now,
            requests_sent: 0,
            observed: 0,
            observed_unmapped: 0,
            last_pose: None,
            dropped_before: 0,
        }
    }

    /// The host's µs count at `t`.
    fn host_us(&self, t: Instant) -> u64 {
        u64::try_from(t.saturating_duration_since(self.origin).as_micros()).unwrap_or(u64::MAX)
    }

    /// Forgets the clock mapping (counted by `reason`), drops a pose pending for the old
    /// clock, and exchanges fast again.
    fn restart(&mut self, reason: ResetReason, now: Instant) {
        self.clock.reset(reason);
        self.forwarder.drop_pending();
        self.fast_until = now + TIME_REQUEST_FAST_FOR;
        self.next_request = now;
    }

    /// The TimeRequest due at `now`, if one is.
    fn request_due(&mut self, now: Instant) -> Option<TimeRequest> {
        if now < self.next_request {
            return None;
        }
        let period = if now < self.fast_until {
            TIME_REQUEST_FAST
        } else {
            TIME_REQUEST_SLOW
        };
        self.next_request = now + period;
        self.requests_sent += 1;
        Some(TimeRequest {
            host_us: self.host_us(Instant::now()),
        })
    }

    /// Reads both host clocks (a jump of the wall clock is counted).
    fn observe_wall(&mut self, now: Instant) {
        let wall_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i128::try_from(d.as_micros()).unwrap_or(i128::MAX));
        if self.wall.observe(wall_us, self.host_us(now)) {
            self.forwarder.count_clock_jump();
        }
    }

    /// Takes what the pose inputs sent since the last pass.
    fn drain_inputs(&mut self, now: Instant) {
        let Some(rx) = &self.inputs else {
            return;
        };
        let now_us = self.host_us(now);
        for _ in 0..INPUTS_PER_PASS {
            match rx.try_recv() {
                Ok(event) => self.forwarder.take(event, now_us, &self.wall, &self.clock),
                Err(_) => break,
            }
        }
    }

    /// The host wall time of the device's `device_us`, if the mapping is known.
    fn wall_time_of(&self, device_us: u32) -> Option<SystemTime> {
        let host_us = self.clock.to_host(device_us)?;
        let wall_us = u64::try_from(self.wall.to_wall(host_us)?).ok()?;
        UNIX_EPOCH.checked_add(Duration::from_micros(wall_us))
    }

    fn report(&self) -> TimeSyncReport {
        let e = self.clock.estimate();
        let counters = self.clock.counters();
        TimeSyncReport {
            synced: self.clock.is_synced(),
            offset_us: e.map(|e| e.offset_us),
            drift_ppm: e.map(|e| e.drift_ppm),
            accuracy_us: e.map(|e| e.accuracy_us),
            round_trip_us: e.map(|e| e.round_trip_us),
            requests_sent: self.requests_sent,
            counters,
            resets: counters.resets(),
            observed: self.observed,
            observed_unmapped: self.observed_unmapped,
        }
    }

    fn poses_report(&self) -> Option<PosesReport> {
        (!self.sources.is_empty()).then(|| PosesReport {
            sources: self.sources.iter().map(|s| s.name.clone()).collect(),
            frame: self.forwarder.frame().map(str::to_string),
            counters: self.forwarder.counters(),
        })
    }

    /// The `/diagnostics` statuses of the clock and (when on) the pose inputs.
    fn diagnostics(&mut self, hardware_id: &str) -> Vec<ros_msgs::DiagnosticStatus> {
        let kv = |key: &str, value: String| ros_msgs::KeyValue {
            key: key.to_string(),
            value,
        };
        let r = self.report();
        let fmt =
            |v: Option<f64>, digits: usize| v.map_or_else(String::new, |v| format!("{v:.digits$}"));
        let clock = ros_msgs::DiagnosticStatus {
            level: if r.synced {
                ros_msgs::LEVEL_OK
            } else {
                ros_msgs::LEVEL_WARN
            },
            name: "terrain_pyramid: clock".into(),
            message: match (r.drift_ppm, r.accuracy_us) {
                (Some(drift), Some(acc)) if r.synced => {
                    format!("synced: drift {drift:.1} ppm, accuracy {acc:.0} µs")
                }
                _ => "not synced: no pose is forwarded".into(),
            },
            hardware_id: hardware_id.to_string(),
            values: vec![
                kv("synced", r.synced.to_string()),
                kv("offset_us", fmt(r.offset_us, 1)),
                kv("drift_ppm", fmt(r.drift_ppm, 3)),
                kv("accuracy_us", fmt(r.accuracy_us, 1)),
                kv(
                    "round_trip_us",
                    r.round_trip_us.map_or_else(String::new, |v| v.to_string()),
                ),
                kv("requests_sent", r.requests_sent.to_string()),
                kv("exchanges", r.counters.exchanges.to_string()),
                kv("discarded", r.counters.discarded.to_string()),
                kv("queued_replies", r.counters.queued_replies.to_string()),
                kv("resets", r.resets.to_string()),
                kv("resets_boot", r.counters.resets_boot.to_string()),
                kv("resets_reconnect", r.counters.resets_reconnect.to_string()),
                kv(
                    "resets_inconsistent",
                    r.counters.resets_inconsistent.to_string(),
                ),
                kv("observed", r.observed.to_string()),
                kv("observed_unmapped", r.observed_unmapped.to_string()),
            ],
        };
        let mut out = vec![clock];
        if let Some(p) = self.poses_report() {
            let dropped = p.counters.dropped();
            let rising = dropped > self.dropped_before;
            self.dropped_before = dropped;
            out.push(ros_msgs::DiagnosticStatus {
                level: if rising || p.counters.forwarded == 0 {
                    ros_msgs::LEVEL_WARN
                } else {
                    ros_msgs::LEVEL_OK
                },
                name: "terrain_pyramid: poses".into(),
                message: format!(
                    "{} forwarded, {} dropped ({}){}",
                    p.counters.forwarded,
                    dropped,
                    p.sources.join(", "),
                    if rising {
                        ": poses dropped since the last report"
                    } else {
                        ""
                    }
                ),
                hardware_id: hardware_id.to_string(),
                values: p
                    .counters
                    .named()
                    .iter()
                    .map(|(n, v)| kv(n, v.to_string()))
                    .chain(std::iter::once(kv("frame", p.frame.unwrap_or_default())))
                    .collect(),
            });
        }
        out
    }
}

/// The host's end of one session: the link, and when it last asked for a snapshot.
struct Session {
    transport: Transport,
    host: HostLink,
    /// The live outputs, when any is on.
    outputs: Option<Outputs>,
    reconnects: u64,
    /// When the outstanding snapshot request was sent (`None`: none outstanding).
    requested: Option<Instant>,
    snapshots_requested: u64,
    /// The rule to set on the device on connecting (`--rule` and its parameters).
    set_rule: Option<SetRule>,
    /// The rig's Setup, sent on connecting before the rule (`--rig` and the rig flags).
    setup: Option<Setup>,
    /// Setups sent (one per connection).
    setups_sent: u64,
    /// The clocks and the poses.
    timing: Timing,
}

impl Session {
    /// Sends the rig's Setup (if given), the SetRule of `--rule` (if given) and then
    /// `RequestSnapshot(all)`; `Err` when the stream is gone.
    fn greet(&mut self, now: Instant) -> Result<(), String> {
        if let Some(setup) = self.setup {
            self.send(&Message::Setup(setup))?;
            self.setups_sent += 1;
        }
        if let Some(set) = self.set_rule {
            let bytes = self
                .host
                .command(&Message::SetRule(set))
                .map_err(|e| format!("cannot encode SetRule: {e:?}"))?;
            self.transport
                .write_all(&bytes)
                .map_err(|e| format!("cannot send to the device: {e}"))?;
        }
        self.request_snapshot(now)
    }

    /// Sends `RequestSnapshot(all)`; `Err` when the stream is gone.
    fn request_snapshot(&mut self, now: Instant) -> Result<(), String> {
        let bytes = self
            .host
            .command(&Message::RequestSnapshot(SnapshotScope::All))
            .map_err(|e| format!("cannot encode RequestSnapshot: {e:?}"))?;
        self.transport
            .write_all(&bytes)
            .map_err(|e| format!("cannot send to the device: {e}"))?;
        self.requested = Some(now);
        self.snapshots_requested += 1;
        Ok(())
    }

    /// Sends `message`; `Err` when the stream is gone.
    fn send(&mut self, message: &Message<'_>) -> Result<(), String> {
        let bytes = self
            .host
            .command(message)
            .map_err(|e| format!("cannot encode a command: {e:?}"))?;
        self.transport
            .write_all(&bytes)
            .map_err(|e| format!("cannot send to the device: {e}"))
    }

    /// The clocks' and the poses' part of a pass at `now`: the wall clock read, the inputs
    /// taken, a pose forwarded and a TimeRequest sent when due.
    fn tend(&mut self, now: Instant) -> Result<(), String> {
        self.timing.observe_wall(now);
        self.timing.drain_inputs(now);
        let now_us = self.timing.host_us(now);
        if let Some(p) = self.timing.forwarder.poll(now_us, &self.timing.clock) {
            self.send(&Message::Pose(PoseReport {
                x_m: p.x,
                y_m: p.y,
                z_m: p.z,
                roll_rad: p.roll,
                pitch_rad: p.pitch,
                yaw_rad: p.yaw,
                stamp_us: p.stamp_us,
                flags: POSE_STAMPED,
            }))?;
            self.timing.last_pose = Some(RobotPose {
                x: f64::from(p.x),
                y: f64::from(p.y),
                yaw: f64::from(p.yaw),
            });
        }
        if let Some(request) = self.timing.request_due(now) {
            self.send(&Message::TimeRequest(request))?;
        }
        Ok(())
    }

    fn counts(&self) -> Counts {
        let c = self.host.mirror().counters();
        Counts {
            frames: c.frames,
            errors: total_errors(&self.host.rx_counters()),
            patches: c.patches,
            gaps: c.gaps,
            snapshots: self.snapshots_requested,
        }
    }
}

/// The sensor's mark on the picture: the host does not know it, so the finest layer's
/// window centre (the device recentres the windows on the robot).
fn window_centre(mirror: &Mirror) -> (f64, f64) {
    mirror.layer(0).map_or((0.0, 0.0), |l| {
        #[allow(clippy::cast_precision_loss)]
        let half = mirror.cells_per_side() as f64 / 2.0;
        let r = f64::from(l.resolution_q16) / 65_536.0;
        (
            (f64::from(l.origin.0) + half) * r,
            (f64::from(l.origin.1) + half) * r,
        )
    })
}

/// Looks for the device again every [`RECONNECT_INTERVAL`], keeping the mirror; once it is
/// back, asks for a snapshot (whatever happened meanwhile, the mirror may be behind). `Some`
/// when the session ends first.
fn reconnect(
    session: &mut Session,
    args: &Args,
    stop: &AtomicBool,
    deadline: Option<Instant>,
    out: &mut StatusOutput,
) -> Option<Ending> {
    // Close the old connection (and a serial port's lock) first.
    session.transport = Transport::Closed;
    session.requested = None;
    let mut next_try = Instant::now() + RECONNECT_INTERVAL;
    let mut attempts = 0_u64;
    loop {
        if stop.load(Ordering::SeqCst) {
            return Some(Ending::Interrupted);
        }
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            return Some(Ending::Duration);
        }
        if now >= next_try {
            attempts += 1;
            match Transport::open(args) {
                Ok((transport, source)) => {
                    session.transport = transport;
                    session.reconnects += 1;
                    session
                        .timing
                        .restart(ResetReason::Reconnect, Instant::now());
                    let resumed = session
                        .transport
                        .write_all(&[0])
                        .map_err(|e| format!("cannot send to the device: {e}"))
                        .and_then(|()| session.greet(Instant::now()));
                    match resumed {
                        Ok(()) => out.notice(&format!(
                            "reconnected to {source} after {attempts} attempts; snapshot requested"
                        )),
                        Err(e) => out.notice(&format!("warning: {e}")),
                    }
                    return None;
                }
                Err(_) => next_try = Instant::now() + RECONNECT_INTERVAL,
            }
        }
        std::thread::sleep(READ_TIMEOUT);
    }
}

/// Runs the session until it ends; returns the link and why it ended.
fn receive(
    mut session: Session,
    args: &Args,
    stop: &AtomicBool,
    out: &mut StatusOutput,
) -> (Session, Ending, Duration) {
    let start = Instant::now();
    let deadline = args.duration_s.map(|s| start + Duration::from_secs_f64(s));
    let mut meter = RateMeter::default();
    let mut next_status = start;
    let mut next_diagnostics = start;
    let mut buf = vec![0_u8; 4096];
    // One delimiter ends whatever the device's receiver holds, then the first request.
    let opened = session
        .transport
        .write_all(&[0])
        .map_err(|e| format!("cannot send to the device: {e}"))
        .and_then(|()| session.greet(start));
    if let Err(e) = opened {
        out.notice(&format!("warning: {e}"));
    }
    session.timing.fast_until = start + TIME_REQUEST_FAST_FOR;
    session.timing.next_request = start;
    let mut announced_sync = false;
    let ending = loop {
        if stop.load(Ordering::SeqCst) {
            break Ending::Interrupted;
        }
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            break Ending::Duration;
        }
        if now >= next_status {
            let counts = session.counts();
            let rates = meter.sample(now, counts);
            let state = SyncState::of(session.host.mirror());
            out.status(&status_line(now - start, &counts, &rates, state));
            next_status += STATUS_INTERVAL;
            if next_status < now {
                next_status = now + STATUS_INTERVAL;
            }
        }
        let read = session.transport.read(&mut buf);
        let read_at = session.timing.host_us(Instant::now());
        let n = match read {
            Received::Bytes(n) => n,
            Received::Nothing => 0,
            Received::Ended(error) => {
                if !(args.reconnect || args.port.is_some()) {
                    if let Some(e) = error {
                        out.notice(&format!("warning: the stream ended: {e}"));
                    }
                    break Ending::EndOfStream;
                }
                out.notice(&format!(
                    "warning: the device's stream ended ({}): trying to reconnect every {} s; the maps are kept",
                    error.as_deref().unwrap_or("closed by the device"),
                    RECONNECT_INTERVAL.as_secs()
                ));
                match reconnect(&mut session, args, stop, deadline, out) {
                    Some(ending) => break ending,
                    None => continue,
                }
            }
        };
        let mut wants = false;
        for event in session.host.feed(buf.get(..n).unwrap_or_default()) {
            match event {
                LinkEvent::Hello(hello) => {
                    // Any Hello answers (or supersedes) an outstanding request.
                    session.requested = None;
                    if hello.reason == HelloReason::Boot {
                        // A new clock: the old mapping is void, poses wait for the new one.
                        session
                            .timing
                            .restart(ResetReason::DeviceBoot, Instant::now());
                    }
                    if hello.reason != HelloReason::Snapshot {
                        out.notice(&format!(
                            "device: Hello ({}), firmware {}.{}.{}, {} layers of {} cells, clock: {}",
                            match hello.reason {
                                HelloReason::Boot => "boot",
                                HelloReason::Configured => "configured",
                                HelloReason::Reset => "reset",
                                HelloReason::Snapshot => "snapshot",
                            },
                            hello.firmware.major,
                            hello.firmware.minor,
                            hello.firmware.patch,
                            hello.layers.len(),
                            hello.cells_per_side,
                            clock_name(hello.clock)
                        ));
                    }
                }
                LinkEvent::SnapshotNeeded => wants = true,
                LinkEvent::Reply(reply) if reply.to_type == MessageType::SetRule.to_u8() => {
                    out.notice(&set_rule_answer(&reply));
                }
                LinkEvent::Reply(reply) if reply.to_type == MessageType::Setup.to_u8() => {
                    out.notice(&setup_answer(&reply));
                }
                LinkEvent::TimeReply(reply) => {
                    let outcome = session.timing.clock.add(Exchange {
                        host_sent_us: reply.host_us,
                        device_us: reply.device_us,
                        host_received_us: read_at,
                        queued_ahead: reply.queued_ahead,
                    });
                    if outcome == Outcome::Reset {
                        out.notice(
                            "warning: the device's clock jumped (a reboot whose Hello was lost?): \
                             time sync restarted, poses wait for it",
                        );
                        session.timing.forwarder.drop_pending();
                        session.timing.fast_until = Instant::now() + TIME_REQUEST_FAST_FOR;
                    }
                }
                LinkEvent::Observed(observed) => {
                    session.timing.observed += 1;
                    match session.timing.wall_time_of(observed.last_us) {
                        Some(stamp) => {
                            if let Some(outputs) = &mut session.outputs {
                                outputs.set_data_stamp(stamp);
                            }
                        }
                        None => session.timing.observed_unmapped += 1,
                    }
                }
                LinkEvent::Reply(_)
                | LinkEvent::Stats(_)
                | LinkEvent::BadFrame(_)
                | LinkEvent::Faded(_) => {}
            }
        }
        let now = Instant::now();
        // A write that fails means the stream is gone: the next read says so and ends or
        // reconnects the session.
        let _ = session.tend(now);
        match (session.timing.clock.estimate(), announced_sync) {
            (Some(e), false) => {
                out.notice(&format!(
                    "clock: synced with the device (drift {:.1} ppm, accuracy {:.0} µs, round trip {} µs)",
                    e.drift_ppm, e.accuracy_us, e.round_trip_us
                ));
                announced_sync = true;
            }
            (None, true) => announced_sync = false,
            _ => {}
        }
        if let Some(outputs) = &mut session.outputs {
            if let Some(frame) = session.timing.forwarder.frame() {
                outputs.set_pose_frame(frame);
            }
            if now >= next_diagnostics {
                let hardware_id = session.host.mirror().firmware().map_or_else(
                    || "terrain-pyramid".to_string(),
                    |f| {
                        format!(
                            "terrain-pyramid firmware {}.{}.{}",
                            f.major, f.minor, f.patch
                        )
                    },
                );
                outputs.set_diagnostics(session.timing.diagnostics(&hardware_id));
                next_diagnostics = now + STATUS_INTERVAL;
            }
            outputs.offer(session.host.mirror(), session.timing.last_pose);
        }
        let overdue = session
            .requested
            .is_none_or(|t| now.duration_since(t) >= SNAPSHOT_RETRY);
        let needed = wants || session.host.mirror().needs_snapshot();
        if needed && overdue {
            if let Err(e) = session.request_snapshot(now) {
                out.notice(&format!("warning: the stream ended: {e}"));
                break Ending::EndOfStream;
            }
        }
    };
    let elapsed = start.elapsed();
    let counts = session.counts();
    let rates = meter.sample(Instant::now(), counts);
    out.status(&status_line(
        elapsed,
        &counts,
        &rates,
        SyncState::of(session.host.mirror()),
    ));
    out.finish();
    (session, ending, elapsed)
}

/// What the device's answer to the rig's Setup tells the user: a refusal names the field and
/// its rule, as every refused command is rendered ([`ReplyText`]).
fn setup_answer(reply: &Reply) -> String {
    match reply.code {
        ReplyCode::Ok => "device: the rig's setup taken".to_string(),
        ReplyCode::Unsupported => {
            "warning: the device does not take Setup: it keeps its own setup".to_string()
        }
        _ => format!(
            "warning: the device refused the rig's setup: {} (it keeps its own setup)",
            ReplyText(reply).reason()
        ),
    }
}

/// What the device's answer to SetRule tells the user.
fn set_rule_answer(reply: &Reply) -> String {
    match reply.code {
        ReplyCode::Ok => "device: navigability rule set".to_string(),
        ReplyCode::Unsupported => "warning: the device does not take SetRule (its firmware is \
             older than this host): it keeps its own navigability rule"
            .to_string(),
        code => {
            let field = terrain_pyramid::link::convert::SetupField::from_param(reply.param)
                .map_or("a field", |f| f.name());
            format!(
                "warning: the device refused the navigability rule: {field} ({code:?}, value {})",
                reply.value
            )
        }
    }
}

/// Writes the maps and the summary of a finished session.
fn write_out(
    session: &Session,
    args: &Args,
    source: &str,
    ending: Ending,
    elapsed: Duration,
    outputs: Option<OutputsReport>,
) -> Result<Summary, String> {
    let mirror = session.host.mirror();
    let rx = session.host.rx_counters();
    let Some(snapshot) =
        MapSnapshot::from_mirror(mirror, LogOddsFixed::ZERO, window_centre(mirror))
    else {
        let hint = crate::link::version_hint(&rx);
        return Err(format!(
            "no maps to write: the device sent no usable Hello in {:.1} s ({} good frames, {} bad){hint}",
            elapsed.as_secs_f64(),
            rx.frames_ok,
            total_errors(&rx)
        ));
    };
    let title = format!(
        "pyramid listen: {source} ({:.0} s, {} patches{})",
        elapsed.as_secs_f64(),
        mirror.counters().patches,
        if mirror.is_synced() {
            ""
        } else {
            ", NOT synced"
        }
    );
    let written = export::write_maps(&args.out, &snapshot, &title)?;
    let MapSummary { layers, fused } = written.summary;
    let c = mirror.counters();
    let mut files: Vec<String> = written
        .files
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    files.push("summary.json".to_string());
    let summary = Summary {
        layers,
        fused,
        frames: c.frames,
        crc_errors: u64::from(rx.crc),
        patches: c.patches,
        gaps: c.gaps,
        snapshots_requested: session.snapshots_requested,
        bad_frames: total_errors(&rx),
        missing_frames: c.missing,
        out_of_order: c.out_of_order,
        hellos: c.hellos,
        patches_refused: c.patches_refused,
        synced: mirror.is_synced(),
        firmware: mirror.firmware().map_or_else(String::new, |f| {
            format!("{}.{}.{}", f.major, f.minor, f.patch)
        }),
        clock: clock_name(mirror.clock()).to_string(),
        ended_by: ending,
        duration_s: (elapsed.as_secs_f64() * 1000.0).round() / 1000.0,
        layer_cells_fnv1a64: snapshot
            .layers
            .iter()
            .map(|l| format!("{:016x}", cells_fnv1a64(&l.cells)))
            .collect(),
        files,
        reconnects: session.reconnects,
        setups_sent: session.setups_sent,
        outputs,
        time_sync: session.timing.report(),
        poses: session.timing.poses_report(),
        device_pose_track: mirror.last_stats().map(|s| DevicePoseTrack::of(&s)),
    };
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| format!("cannot encode the summary as JSON: {e}"))?;
    export::write_file(
        &args.out.join("summary.json"),
        format!("{json}\n").as_bytes(),
    )?;
    Ok(summary)
}

/// Starts the pose inputs `args` asks for, each on a thread of its own feeding one channel.
fn start_pose_inputs(args: &Args) -> Result<Timing, String> {
    let mut timing = Timing::new(Instant::now());
    if args.odom_topic.is_none() && args.pose_udp.is_none() {
        return Ok(timing);
    }
    let (tx, rx) = mpsc::sync_channel(INPUT_CHANNEL);
    if let Some(addr) = &args.pose_udp {
        let (source, _) = pose_input::spawn_udp(addr, tx.clone())?;
        timing.sources.push(source);
    }
    if let Some(topic) = &args.odom_topic {
        let domain = args
            .outputs
            .config(LogOddsFixed::ZERO)
            .ros2_domain
            .unwrap_or(0);
        timing
            .sources
            .push(pose_input::spawn_odometry(domain, topic, tx)?);
    }
    timing.inputs = Some(rx);
    Ok(timing)
}

/// Runs `pyramid listen`.
///
/// Exit status: 0 when the maps were written (a warning on stderr if the mirror was not in
/// sync at the end); 1 when the port cannot be opened or the address reached (one line), no
/// Hello came, or an output cannot be written.
pub fn run(args: &Args) -> ExitCode {
    // The rig and the rule first: a bad flag ends the command before anything is opened
    // (status 2).
    let setup = match rig_setup(args) {
        Ok(setup) => setup,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let set_rule = if args.rule.given() {
        match args.rule.apply(ClassifierConfig::DEFAULT) {
            Ok(config) => Some(set_rule_message(&config)),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        }
    } else {
        None
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let handler = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            // A second Ctrl-C: the user does not want to wait for the maps.
            std::process::exit(130);
        }
    });
    if let Err(e) = handler {
        eprintln!("warning: cannot catch Ctrl-C ({e}); use --duration-s to end the session");
    }
    // The outputs first: a port already in use ends the command before the device is opened.
    let outputs = match Outputs::start(&args.outputs.config(LogOddsFixed::ZERO)) {
        Ok(o) => o.is_on().then_some(o),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The pose inputs too: a port in use or a bad topic ends the command before the device is
    // opened.
    let timing = match start_pose_inputs(args) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let (transport, source) = match Transport::open(args) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut out = StatusOutput::new();
    for input in &timing.sources {
        out.notice(&format!("poses: reading {}", input.name));
    }
    out.notice(&format!(
        "listening on {source}; Ctrl-C ends and writes the maps"
    ));
    if let Some(addr) = outputs.as_ref().and_then(Outputs::foxglove_addr) {
        out.notice(&format!("foxglove: serving ws://{addr}"));
    }
    let session = Session {
        transport,
        host: HostLink::new(),
        outputs,
        reconnects: 0,
        requested: None,
        snapshots_requested: 0,
        set_rule,
        setup,
        setups_sent: 0,
        timing,
    };
    let (mut session, ending, elapsed) = receive(session, args, &stop, &mut out);
    let report = match session.outputs.take() {
        Some(outputs) => match outputs.finish(session.host.mirror(), None) {
            Ok(report) => Some(report),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        },
        None => None,
    };
    match write_out(&session, args, &source, ending, elapsed, report) {
        Ok(summary) => {
            if !summary.synced {
                eprintln!(
                    "warning: the maps may differ from the device's: frames were lost or a resend was incomplete when the session ended"
                );
            }
            if args.json {
                match serde_json::to_string(&summary) {
                    Ok(json) => println!("{json}"),
                    Err(e) => {
                        eprintln!("error: cannot encode the summary as JSON: {e}");
                        return ExitCode::FAILURE;
                    }
                }
            } else {
                eprintln!(
                    "{} frames, {} patches, {} gaps, {} bad frames, {} snapshots requested; maps written to {}",
                    summary.frames,
                    summary.patches,
                    summary.gaps,
                    summary.bad_frames,
                    summary.snapshots_requested,
                    args.out.display()
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

/// The Setup of the rig's flags and file (`None` without either): the classifier is the
/// library's defaults with the rig file's `[classifier]` and the rule flags over it.
///
/// # Errors
/// A bad rig file or flag, or a value the Setup cannot carry.
pub fn rig_setup(args: &Args) -> Result<Option<Setup>, String> {
    if !args.rig.given() && args.sensor_baud.is_none() {
        return Ok(None);
    }
    let mut rig = args.rig.rig()?;
    if let Some(b) = args.sensor_baud {
        if !(9_600..=3_000_000).contains(&b) {
            return Err(format!("--sensor-baud {b} is not in 9600 ..= 3000000"));
        }
        rig.sensor
            .as_mut()
            .ok_or("--sensor-baud needs a sensor (--sensor or the rig file's)")?
            .baud = b;
    }
    rig.classifier.rule = crate::rigfile::merged_rule(&rig.classifier.rule, &args.rule);
    let classifier = rig.classifier.apply(ClassifierConfig::DEFAULT)?;
    crate::rigfile::device_setup(&rig, &classifier).map(Some)
}

/// How the listener names the device's clock: a fallback says what it costs.
fn clock_name(clock: ClockSource) -> &'static str {
    match clock {
        ClockSource::NotReported => "not reported",
        ClockSource::External => "external",
        ClockSource::InternalPll => "internal oscillator + PLL (fallback: rates within ±1 %)",
        ClockSource::Internal => "internal oscillator (fallback: rates within ±1 %)",
        ClockSource::Unmodelled => "no clock tree (an emulator)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_status_line_shows_totals_rates_and_state() {
        let counts = Counts {
            frames: 1234,
            errors: 3,
            patches: 1100,
            gaps: 2,
            snapshots: 4,
        };
        let rates = Rates {
            frames: 310.4,
            errors: 0.0,
            patches: 289.6,
        };
        assert_eq!(
            status_line(Duration::from_millis(12_345), &counts, &rates, SyncState::Synced),
            "   12.3 s  frames 1234 (310/s)  errors 3 (0/s)  patches 1100 (290/s)  gaps 2  snapshots 4  synced"
        );
        let line = status_line(
            Duration::ZERO,
            &Counts::default(),
            &Rates::default(),
            SyncState::Waiting,
        );
        assert!(line.ends_with("snapshots 0  waiting for Hello"), "{line}");
        assert!(!line.contains('\n') && !line.contains('\r'));
    }

    #[test]
    fn rates_are_measured_over_the_last_second() {
        let mut meter = RateMeter::default();
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        let c = |frames: u64| Counts {
            frames,
            errors: frames / 10,
            patches: frames / 2,
            ..Counts::default()
        };
        assert_eq!(meter.sample(at(0), c(0)), Rates::default());
        let r = meter.sample(at(250), c(100));
        assert!((r.frames - 400.0).abs() < 1e-9, "{r:?}");
        meter.sample(at(500), c(200));
        meter.sample(at(750), c(300));
        meter.sample(at(1000), c(400));
        // From now on the rate spans the last second: 100 frames per 250 ms, then a stop.
        let r = meter.sample(at(1250), c(500));
        assert!((r.frames - 400.0).abs() < 1e-9, "{r:?}");
        assert!((r.patches - 200.0).abs() < 1e-9, "{r:?}");
        assert!((r.errors - 40.0).abs() < 1e-9, "{r:?}");
        let r = meter.sample(at(2250), c(500));
        assert!(r.frames.abs() < 1e-9, "{r:?}");
        assert!(meter.samples.len() <= 6);
    }

    #[test]
    fn fnv1a64_of_known_bytes() {
        // FNV-1a 64 of the empty input and of "a" (0x61): the published values.
        assert_eq!(cells_fnv1a64(&[]), 0xCBF2_9CE4_8422_2325);
        // Cells 0x6261 little-endian are the bytes "ab".
        assert_eq!(cells_fnv1a64(&[0x6261]), 0x089C_4407_B545_986A);
    }

    #[test]
    fn time_requests_go_fast_for_two_seconds_then_slow_and_fast_again_after_a_boot() {
        let t0 = Instant::now();
        let mut timing = Timing::new(t0);
        let mut sent = Vec::new();
        for ms in (0..4_000).step_by(10) {
            let now = t0 + Duration::from_millis(ms);
            if timing.request_due(now).is_some() {
                sent.push(ms);
            }
            if ms == 3_000 {
                timing.restart(ResetReason::DeviceBoot, now);
            }
        }
        let fast: Vec<u64> = (0..20).map(|k| k * 100).collect();
        assert_eq!(&sent[..20], fast.as_slice());
        assert_eq!(&sent[20..22], &[2_000, 2_500]);
        // The boot at 3 s: at once, then every 100 ms again.
        assert_eq!(&sent[22..25], &[3_000, 3_010, 3_110]);
        assert_eq!(timing.clock.counters().resets_boot, 1);
    }

    #[test]
    fn an_observed_device_time_maps_to_the_host_wall_clock() {
        let t0 = Instant::now();
        let mut timing = Timing::new(t0);
        assert_eq!(timing.wall_time_of(5), None);
        // Device = host µs + 1 000 000, exchanges with symmetric 300 µs delays.
        for k in 0..10_u64 {
            let t = 20_000_000 + k * 100_000;
            timing.clock.add(Exchange {
                host_sent_us: t,
                device_us: u32::try_from(t + 300 + 1_000_000).unwrap(),
                host_received_us: t + 600,
                queued_ahead: 0,
            });
        }
        // Wall = host µs + 1.7e15 µs.
        timing
            .wall
            .observe(1_700_000_000_000_000 + 21_000_000, 21_000_000);
        let stamp = timing.wall_time_of(22_500_000 + 1_000_000).unwrap();
        let us = stamp.duration_since(UNIX_EPOCH).unwrap().as_micros();
        assert_eq!(us, 1_700_000_000_000_000 + 22_500_000);
    }

    #[test]
    fn seconds_must_be_positive() {
        assert_eq!(positive_seconds("2.5"), Ok(2.5));
        assert!(positive_seconds("0").is_err());
        assert!(positive_seconds("-1").is_err());
        assert!(positive_seconds("nan").is_err());
        assert!(positive_seconds("x").is_err());
    }
}
