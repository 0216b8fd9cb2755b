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
//! - With a rig file's `[design]` ([`crate::rigfile::DesignSpec`]), it compares the pyramid
//!   each Hello describes with the rig's design built for the Hello's window, and sends a
//!   Configure only when they differ (a device that booted, or one configured by another
//!   host), once per connection or boot: a device already running the design keeps its maps.
//!   The device's answer is reported on stderr.
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
//!
//! [`LinkEvent::SnapshotNeeded`]: crate::link::LinkEvent::SnapshotNeeded
//! [`Mirror::needs_snapshot`]: crate::link::Mirror::needs_snapshot
//! [`ClockSync`]: crate::clock_sync::ClockSync

mod design;
mod session;
mod status;
mod summary;
mod timing;
mod transport;

pub use status::{status_line, Counts, RateMeter, Rates, SyncState};
pub use summary::{cells_fnv1a64, DevicePoseTrack, Ending, PosesReport, Summary, TimeSyncReport};

use crate::link::HostLink;
use crate::pose_input;
use crate::publish::{OutputArgs, Outputs};
use crate::summary_args::SummaryArgs;
use design::WantedDesign;
use session::{receive, Session};
use status::StatusOutput;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use summary::write_out;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::set_rule_message;
use terrain_pyramid::wire::link::{ClockSource, Setup};
use terrain_pyramid::DEFAULT_CELLS_PER_SIDE;
use timing::start_pose_inputs;
use transport::Transport;

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
connecting, on every reconnection and after the device boots, before the SetRule of the rule \
flags. Without them no Setup is sent: the device keeps the setup it booted with (or was last \
given). A rig file's [design] is sent as a Configure whenever the device's Hello shows another \
pyramid (docs/rig.md)."
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
    /// The output directory, and whether the summary is also printed.
    #[command(flatten)]
    pub summary: SummaryArgs,
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

/// Runs `pyramid listen`.
///
/// Exit status: 0 when the maps were written (a warning on stderr if the mirror was not in
/// sync at the end); 1 when the port cannot be opened or the address reached (one line), no
/// Hello came, or an output cannot be written.
pub fn run(args: &Args) -> ExitCode {
    // The rig and the rule first: a bad flag ends the command before anything is opened
    // (status 2).
    let (setup, design) = match rig_setup(args) {
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
    let outputs = match Outputs::start(&args.outputs.config(crate::export::default_fused_margin()))
    {
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
        design,
        configures_sent: 0,
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
            if args.summary.json {
                if !crate::json_line::print(&summary, "error: cannot encode the summary as JSON: ")
                {
                    return ExitCode::FAILURE;
                }
            } else {
                eprintln!(
                    "{} frames, {} patches, {} gaps, {} bad frames, {} snapshots requested; maps written to {}",
                    summary.frames,
                    summary.patches,
                    summary.gaps,
                    summary.bad_frames,
                    summary.snapshots_requested,
                    args.summary.out.display()
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
/// library's defaults with the rig file's `[classifier]` and the rule flags over it; and the
/// rig file's design (`[design]`), checked by the library at the boards' window
/// ([`DEFAULT_CELLS_PER_SIDE`]; the device's own, from its Hello, is the one sent).
///
/// # Errors
/// A bad rig file or flag, a value the Setup cannot carry, or a design the library refuses.
pub(crate) fn rig_setup(args: &Args) -> Result<(Option<Setup>, Option<WantedDesign>), String> {
    if !args.rig.given() && args.sensor_baud.is_none() {
        return Ok((None, None));
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
    let setup = crate::rigfile::device_setup(&rig, &classifier)?;
    let design = match rig.design {
        Some(spec) => {
            spec.design(DEFAULT_CELLS_PER_SIDE)
                .map_err(|e| format!("the rig's [design]: {e}"))?;
            Some(WantedDesign::new(spec))
        }
        None => None,
    };
    Ok((Some(setup), design))
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
    use crate::clock_sync::{Exchange, ResetReason};
    use std::time::{Instant, UNIX_EPOCH};
    use timing::Timing;

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
