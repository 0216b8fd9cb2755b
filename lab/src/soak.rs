//! `lab soak`: a long simulated drive through the co-processor's pipeline, watching for
//! what only shows over time: counters that wrap or go back, drift, memory growth,
//! maps leaving their bounds, throughput that falls.
//!
//! - **Host** (`--board host`): an hour of driving (270 000 telegrams at 75 lines/s, the
//!   simulator's [`Drive`], generated one line at a time) through the library's co-processor
//!   in this process ([`InProcess`], the application core the firmware runs): the host's
//!   PanAngle and Pose frames on its link, the telegram's bytes on its laser stream, its poll
//!   at the drive's clock after every telegram (token bucket, queue, rate-limited patches)
//!   drained into a host [`HostLink`] mirror. Every simulated minute: throughput, the process's RSS, every Stats
//!   counter (monotonic, not saturated), every cell (unknown or within the clamping bounds), the
//!   mirror's counters (no gap, nothing refused). At the end: the link flushed, the mirror equal
//!   to the device's pyramid cell for cell, each counter's projected saturation time.
//! - **Board** (`--board qemu`): ten simulated minutes (45 000 telegrams) through the firmware
//!   on QEMU (`boards/qemu-mps2`), in bursts of `--hold-lines` telegrams that share one angle
//!   and pose (the drive holds them, so the data is what the board is told): PanAngle, Pose
//!   and RequestStats, wait for the Stats that counts those frames, write the burst to UART0,
//!   RequestStats until the device counts the burst. The same frames and lines go through an
//!   in-process co-processor, the reference. Every 15 simulated seconds: the device's counters (monotonic, equal to the
//!   reference's for telegrams, points, evidence and observations). At the end: the mirror
//!   built from the patches equal to the reference, then after a snapshot too, and the
//!   firmware's stack high-water mark from its Shutdown Reply.

use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::convert::{frontend_config_of_event, setup_message};
use terrain_pyramid::link::{LinkConfig, DEFAULT_QUEUE_BYTES};
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{Message, PanAngle, PoseReport, Stats, STATS_COUNTERS};
use terrain_pyramid::{
    Clamp, Config, DefaultDesign, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS,
};
use terrain_pyramid_host::design::firmware_design;
use terrain_pyramid_host::device::Device;
use terrain_pyramid_host::device::InProcess;
use terrain_pyramid_host::emulator::{
    build_firmware, qemu_available, Emulator, Machine, BOARD_DIR, INSTALL_HINT,
};
use terrain_pyramid_host::link::{HostLink, UNKNOWN};
use terrain_pyramid_host_tests::sim::drive::{Drive, DriveConfig, DriveLine};

mod board;

use board::board_soak;

/// Where the soak runs.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SoakBoard {
    /// The host pipeline only.
    Host,
    /// The emulated board only.
    Qemu,
    /// Both, host first.
    Both,
}

/// Arguments of `lab soak`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Which soak to run.
    #[arg(long, value_enum, default_value_t = SoakBoard::Both)]
    pub board: SoakBoard,
    /// The CI form: 5 simulated minutes on the host, half a minute through QEMU.
    #[arg(long)]
    pub quick: bool,
    /// Print the report as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Simulated minutes through the host pipeline (default 60, `--quick` 5).
    #[arg(long, value_name = "MIN")]
    pub host_minutes: Option<f64>,
    /// Simulated minutes through the emulated board (default 10, `--quick` 0.5).
    #[arg(long, value_name = "MIN")]
    pub board_minutes: Option<f64>,
    /// Telegrams per burst on the emulated board (they share one angle and pose).
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub hold_lines: u32,
    /// Where the firmware's defmt log goes.
    #[arg(long, value_name = "DIR", default_value = "soak-out")]
    pub out: PathBuf,
}

/// One interval's measurements.
#[derive(Serialize, Debug, Clone)]
pub struct Sample {
    /// Simulated time at the end of the interval, s.
    pub sim_s: f64,
    /// Wall time since the start, s.
    pub wall_s: f64,
    /// Telegrams per wall-clock second over the interval.
    pub telegrams_per_s: f64,
    /// The process's resident set, KiB (host soak).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rss_kib: Option<u64>,
    /// The device's counters at the end of the interval, by name.
    pub stats: Vec<(String, u32)>,
}

impl Sample {
    /// The sample at simulated time `sim_s` (seconds): `lines_in` telegrams played in the
    /// last `interval_s` wall seconds, the wall time since `started`, the process's resident
    /// set (KiB) when measured, and the device's counters `stats`.
    #[allow(clippy::cast_precision_loss)]
    fn new(
        sim_s: f64,
        started: Instant,
        (lines_in, interval_s): (u64, f64),
        rss_kib: Option<u64>,
        stats: &Stats,
    ) -> Self {
        Self {
            sim_s,
            wall_s: started.elapsed().as_secs_f64(),
            telegrams_per_s: lines_in as f64 / interval_s.max(1e-9),
            rss_kib,
            stats: named(stats),
        }
    }
}

/// A counter's growth and when it would saturate.
#[derive(Serialize, Debug, Clone)]
pub struct Projection {
    /// The counter.
    pub counter: String,
    /// Its value at the end.
    pub value: u32,
    /// Per simulated second over the run.
    pub per_s: f64,
    /// Days of operation at this rate from boot until it reaches 2³² − 1 (`None`: it did not
    /// grow).
    pub saturates_after_days: Option<f64>,
}

/// What the host soak found.
#[derive(Serialize, Debug, Clone, Default)]
pub struct HostReport {
    /// Telegrams through the pipeline.
    pub telegrams: u64,
    /// Simulated seconds.
    pub sim_s: f64,
    /// Wall seconds.
    pub wall_s: f64,
    /// Telegrams per wall second over the whole run.
    pub telegrams_per_s: f64,
    /// Per-interval throughput: the lowest, the highest.
    pub interval_rate_min: f64,
    /// See `interval_rate_min`.
    pub interval_rate_max: f64,
    /// Median throughput of the first and the last third of the intervals.
    pub rate_first_third: f64,
    /// See `rate_first_third`.
    pub rate_last_third: f64,
    /// RSS after the first interval and the most seen afterwards, KiB.
    pub rss_first_kib: u64,
    /// See `rss_first_kib`.
    pub rss_max_kib: u64,
    /// Cells checked against the clamping bounds (all layers, every interval).
    pub cells_checked: u64,
    /// The largest and smallest known raw cell seen.
    pub cell_raw_min: i16,
    /// See `cell_raw_min`.
    pub cell_raw_max: i16,
    /// The mirror equals the pyramid at the end.
    pub mirror_equal: bool,
    /// Simulated seconds of polling the link needed after the drive to flush every tile.
    pub flush_s: f64,
    /// Observations applied.
    pub observations: u32,
    /// Waiting tiles summed over every poll (one poll per telegram here): what
    /// `patches_deferred` counted before protocol version 2, for comparison with the new count.
    pub deferred_tile_polls: u64,
    /// The device's final counters, by name.
    pub final_stats: Vec<(String, u32)>,
    /// Counters of the pyramid and the frontend that Stats does not carry, by name.
    pub internal_counters: Vec<(String, u32)>,
    /// Each counter's projected saturation, soonest first.
    pub projections: Vec<Projection>,
    /// The samples.
    pub samples: Vec<Sample>,
}

/// What the board soak found.
#[derive(Serialize, Debug, Clone, Default)]
pub struct BoardReport {
    /// Telegrams sent to the firmware.
    pub telegrams: u64,
    /// Simulated seconds.
    pub sim_s: f64,
    /// Wall seconds, boot to exit.
    pub wall_s: f64,
    /// Telegrams per wall second.
    pub telegrams_per_s: f64,
    /// Telegrams per burst.
    pub hold_lines: u32,
    /// Round trips (RequestStats answered) over the run.
    pub round_trips: u64,
    /// The mirror built from the patches equals the reference (before any snapshot).
    pub incremental_mirror_equal: bool,
    /// The mirror after RequestSnapshot(All) equals the reference.
    pub snapshot_mirror_equal: bool,
    /// The device's telegram, point, evidence and observation counters equal the
    /// reference's at every interval.
    pub counters_match_reference: bool,
    /// The firmware's stack high-water mark, bytes.
    pub stack_bytes: u32,
    /// The device's final counters, by name.
    pub final_stats: Vec<(String, u32)>,
    /// Each counter's projected saturation at the board's simulated rate, soonest first.
    pub projections: Vec<Projection>,
    /// The samples.
    pub samples: Vec<Sample>,
}

/// The whole report.
#[derive(Serialize, Debug, Clone, Default)]
pub struct Report {
    /// The host soak, if run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host: Option<HostReport>,
    /// The board soak, if run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub board: Option<BoardReport>,
    /// Every check that failed.
    pub failures: Vec<String>,
    /// Whether every check passed.
    pub passed: bool,
}

/// Stats counters that are levels or the clock, not counters.
const NOT_COUNTERS: [&str; 5] = [
    "uptime_ms",
    "queue_used",
    "queue_high_water",
    "queue_capacity",
    "tiles_dirty",
];

/// Lines per sample of the host soak: one simulated minute at 75 lines/s.
const LINES_PER_MINUTE: u64 = 4500;

/// Lines per sample of the board soak: 15 simulated seconds.
const BOARD_SAMPLE_LINES: u64 = 1125;

/// The design and configuration the firmware boots with (the link's Configure repeats them).
fn design_and_config() -> Result<(DefaultDesign, Config), String> {
    Ok((firmware_design()?, Config::default()))
}

/// The soak's in-process co-processor: the firmware's pyramid and classifier, and the link's
/// default 4 KiB queue (the host soak's, as before the core existed; the QEMU board's is 2 KiB).
type HostDevice = InProcess<
    DEFAULT_CELLS_PER_SIDE,
    DEFAULT_LAYERS,
    DEFAULT_CLASSIFIER_SLOTS,
    DEFAULT_QUEUE_BYTES,
>;

/// The in-process co-processor booted as the firmware boots, then configured over its link
/// as the harness configures the board: Configure with the firmware's design, Setup from the
/// drive.
fn in_process(
    design: &DefaultDesign,
    config: &Config,
    setup: &terrain_pyramid::wire::recording::SetupEvent,
) -> Result<HostDevice, String> {
    let classifier = ClassifierConfig::default();
    frontend_config_of_event(setup, &classifier).map_err(|e| format!("the drive's setup: {e}"))?;
    let mut device = HostDevice::boot(
        LinkConfig::DEFAULT,
        design,
        config,
        FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal),
    )?;
    device.configure_after_hello(design, config)?;
    device.command("Setup", &Message::Setup(setup_message(setup, &classifier)))?;
    Ok(device)
}

/// Whether any layer of the co-processor's pyramid has a changed tile not yet sent.
fn dirty(device: &HostDevice) -> bool {
    let pyramid = device.core().pyramid();
    (0..pyramid.layer_count()).any(|k| pyramid.layer(k).is_some_and(|l| l.dirty() != 0))
}

/// Every layer's origin and raw cells, row-major from the lowest row (the mirror's order).
fn layers(device: &HostDevice) -> Vec<((i32, i32), Vec<i16>)> {
    let pyramid = device.core().pyramid();
    let w = DEFAULT_CELLS_PER_SIDE;
    (0..pyramid.layer_count())
        .filter_map(|k| {
            let layer = pyramid.layer(k)?;
            let cells = (0..w * w)
                .map(|n| {
                    layer
                        .at_offset(n % w, n / w)
                        .map_or(UNKNOWN, |c| c.to_raw())
                })
                .collect();
            Some((layer.origin(), cells))
        })
        .collect()
}

/// Whether the mirror holds exactly `layers`.
fn mirror_equals(host: &HostLink, layers: &[((i32, i32), Vec<i16>)]) -> bool {
    let mirror = host.mirror();
    mirror.layer_count() == layers.len()
        && layers.iter().enumerate().all(|(k, (origin, cells))| {
            mirror
                .layer(k)
                .is_some_and(|l| l.origin == *origin && l.cells() == cells.as_slice())
        })
}

/// The process's resident set, KiB.
fn rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

fn named(stats: &Stats) -> Vec<(String, u32)> {
    Stats::NAMES
        .iter()
        .zip(stats.to_array())
        .map(|(n, v)| ((*n).to_string(), v))
        .collect()
}

/// Checks that every counter of `now` is at least its value in `before` and below 2³² − 1.
fn check_counters(what: &str, before: &Stats, now: &Stats, failures: &mut Vec<String>) {
    let (a, b) = (before.to_array(), now.to_array());
    for i in 0..STATS_COUNTERS {
        let name = Stats::NAMES[i];
        if NOT_COUNTERS.contains(&name) {
            continue;
        }
        if b[i] < a[i] {
            failures.push(format!(
                "{what}: {name} went back from {} to {}",
                a[i], b[i]
            ));
        }
        if b[i] == u32::MAX {
            failures.push(format!("{what}: {name} saturated"));
        }
    }
}

fn projections(counters: &[(String, u32)], sim_s: f64) -> Vec<Projection> {
    let mut out: Vec<Projection> = counters
        .iter()
        .filter(|(n, _)| !NOT_COUNTERS.contains(&n.as_str()))
        .map(|(n, v)| {
            let per_s = f64::from(*v) / sim_s.max(1e-9);
            Projection {
                counter: n.clone(),
                value: *v,
                per_s,
                saturates_after_days: (*v > 0).then(|| f64::from(u32::MAX) / per_s / 86_400.0),
            }
        })
        .collect();
    out.sort_by(|a, b| {
        a.saturates_after_days
            .unwrap_or(f64::INFINITY)
            .total_cmp(&b.saturates_after_days.unwrap_or(f64::INFINITY))
    });
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The time of a line, ms, as the device's clock (wrapping).
#[allow(clippy::cast_possible_truncation)]
const fn line_ms(line: &DriveLine) -> u32 {
    (line.time_us / 1000) as u32
}

/// The host's frames for a new angle and pose.
fn hold_frames(line: &DriveLine, last_pose: &mut Option<[f32; 6]>) -> Vec<Message<'static>> {
    let mut frames = vec![Message::PanAngle(PanAngle {
        turns: line.angle,
        timestamp_ms: line_ms(line),
    })];
    if *last_pose != Some(line.pose) {
        frames.push(Message::Pose(PoseReport::unstamped(line.pose)));
        *last_pose = Some(line.pose);
    }
    frames
}

/// A pseudo-random cut for every 10th telegram (the reassembly over chunks), as the
/// recorder's `split_every`.
#[allow(clippy::cast_possible_truncation)]
fn cut(line: &DriveLine) -> usize {
    let len = line.telegram.len();
    if line.index % 10 != 9 || len < 2 {
        return len;
    }
    let h = line.index.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
    1 + (h as usize) % (len - 1)
}

/// The host soak.
#[allow(clippy::too_many_lines, clippy::cast_precision_loss)]
fn host_soak(minutes: f64, failures: &mut Vec<String>) -> Result<HostReport, String> {
    let (design, config) = design_and_config()?;
    let drive_config = DriveConfig::new(minutes * 60.0);
    let setup = drive_config.setup();
    let mut device = in_process(&design, &config, &setup)?;
    let mut report = HostReport {
        cell_raw_min: i16::MAX,
        cell_raw_max: i16::MIN,
        ..HostReport::default()
    };
    let (clamp_min, clamp_max) = match config.clamp {
        Clamp::Bounds { min, max } => (min.to_bits(), max.to_bits()),
        Clamp::Off => (i16::MIN + 1, i16::MAX),
    };

    let drive = Drive::new(drive_config);
    let total = drive.lines();
    eprintln!("soak (host): {total} telegrams, {minutes} simulated minutes, samples every minute");
    let started = Instant::now();
    let mut interval_start = Instant::now();
    let mut last_pose = None;
    let mut previous = device.stats()?;
    let mut now_ms = 0;
    let mut sim_s = 0.0;
    for line in drive {
        now_ms = line_ms(&line);
        device.set_time(now_ms);
        if line.new_hold {
            for frame in hold_frames(&line, &mut last_pose) {
                device.send(&frame)?;
            }
        }
        let at = cut(&line);
        device.laser(&line.telegram[..at])?;
        device.laser(&line.telegram[at..])?;
        // The link's poll after every telegram, drained into the mirror.
        device.poll();
        report.deferred_tile_polls += u64::from(device.last_poll().deferred_tiles);
        report.telegrams += 1;
        sim_s = line.time_us as f64 / 1e6;
        if report.telegrams.is_multiple_of(LINES_PER_MINUTE) || report.telegrams == total {
            let wall = interval_start.elapsed().as_secs_f64();
            interval_start = Instant::now();
            let lines_in = match report.telegrams % LINES_PER_MINUTE {
                0 => LINES_PER_MINUTE,
                n => n,
            };
            let stats = device.stats()?;
            check_counters("host", &previous, &stats, failures);
            previous = stats;
            // Every cell: unknown, or within the clamping bounds.
            for (_, cells) in layers(&device) {
                for &c in &cells {
                    report.cells_checked += 1;
                    if c == UNKNOWN {
                        continue;
                    }
                    report.cell_raw_min = report.cell_raw_min.min(c);
                    report.cell_raw_max = report.cell_raw_max.max(c);
                    if c < clamp_min || c > clamp_max {
                        failures.push(format!("host: a cell holds {c}, outside the clamp"));
                    }
                }
            }
            let m = device.link().mirror().counters();
            if m.gaps + m.missing + m.patches_refused + m.snapshots_advised > 0 {
                failures.push(format!("host: the mirror lost frames: {m:?}"));
            }
            let rss = rss_kib();
            let sample = Sample::new(sim_s, started, (lines_in, wall), rss, &stats);
            if !report.samples.is_empty() || rss.is_some() {
                eprintln!(
                    "  {:6.0} s simulated, {:6.1} s wall: {:7.0} telegrams/s, RSS {} KiB, points {}, patches {}, deferred {}",
                    sample.sim_s,
                    sample.wall_s,
                    sample.telegrams_per_s,
                    rss.unwrap_or(0),
                    stats.points,
                    stats.patches_sent,
                    stats.patches_deferred
                );
            }
            report.samples.push(sample);
        }
    }
    report.sim_s = sim_s;
    report.wall_s = started.elapsed().as_secs_f64();
    report.telegrams_per_s = report.telegrams as f64 / report.wall_s.max(1e-9);
    // The last observation, then the link until every changed tile is out.
    device.send(&Message::EndObservation)?;
    let flush_from = now_ms;
    let mut waited = 0;
    loop {
        now_ms = now_ms.wrapping_add(10);
        device.set_time(now_ms);
        device.poll();
        waited += 10;
        if !dirty(&device) && device.core().link().queue().is_empty() {
            break;
        }
        if waited > 120_000 {
            failures.push("host: the link did not flush within 120 simulated s".into());
            break;
        }
    }
    report.flush_s = f64::from(now_ms.wrapping_sub(flush_from)) / 1000.0;
    report.mirror_equal = mirror_equals(device.link(), &layers(&device));
    if !report.mirror_equal {
        failures.push("host: the mirror differs from the device's pyramid".into());
    }
    if !device.link().mirror().is_synced() {
        failures.push("host: the mirror is not synced".into());
    }
    let stats = device.stats()?;
    check_counters("host (end)", &previous, &stats, failures);
    if u64::from(stats.telegrams_ok) != report.telegrams {
        failures.push(format!(
            "host: {} telegrams sent, {} decoded",
            report.telegrams, stats.telegrams_ok
        ));
    }
    let counters = device.core().counters();
    let refused = u64::from(counters.app.telegrams_unparsed)
        + u64::from(counters.app.lines_without_angle)
        + u64::from(counters.frontend.lines_rejected)
        + u64::from(stats.commands_refused)
        + u64::from(stats.rx_bad_cobs)
        + u64::from(stats.rx_bad_crc)
        + u64::from(stats.rx_bad_length)
        + u64::from(stats.rx_bad_other);
    if refused > 0 {
        failures.push("host: the device refused a pose, a frame or a line".into());
    }
    report.observations = stats.observations;
    report.final_stats = named(&stats);
    let p = counters.pyramid;
    let f = counters.frontend;
    report.internal_counters = vec![
        ("pyramid.cells_reset".into(), p.cells_reset),
        ("pyramid.bad_layer".into(), p.bad_layer),
        ("frontend.returns".into(), f.returns),
        ("frontend.no_return".into(), f.no_return),
        ("frontend.missing_ground".into(), f.missing_ground),
        ("frontend.lines_applied".into(), f.lines_applied),
    ];
    let mut all = report.final_stats.clone();
    all.extend(report.internal_counters.iter().cloned());
    report.projections = projections(&all, report.sim_s);
    // Throughput and memory over the run.
    let rates: Vec<f64> = report.samples.iter().map(|s| s.telegrams_per_s).collect();
    // The last sample may be a short interval: leave it out of the medians.
    let full = &rates[..rates.len().saturating_sub(1).max(1).min(rates.len())];
    let third = (full.len() / 3).max(1);
    report.rate_first_third = median(full[..third.min(full.len())].to_vec());
    report.rate_last_third = median(full[full.len().saturating_sub(third)..].to_vec());
    report.interval_rate_min = full.iter().copied().fold(f64::INFINITY, f64::min);
    report.interval_rate_max = full.iter().copied().fold(0.0, f64::max);
    if report.rate_last_third < 0.5 * report.rate_first_third {
        failures.push(format!(
            "host: throughput fell from {:.0} to {:.0} telegrams/s",
            report.rate_first_third, report.rate_last_third
        ));
    }
    let rss: Vec<u64> = report.samples.iter().filter_map(|s| s.rss_kib).collect();
    report.rss_first_kib = rss.first().copied().unwrap_or(0);
    report.rss_max_kib = rss.iter().copied().max().unwrap_or(0);
    // Constant memory: at most 1 MiB above the first minute's (allocator noise).
    if report.rss_max_kib > report.rss_first_kib + 1024 {
        failures.push(format!(
            "host: RSS grew from {} to {} KiB",
            report.rss_first_kib, report.rss_max_kib
        ));
    }
    Ok(report)
}

/// Runs the soak; the report.
///
/// # Errors
/// A soak that could not run at all.
pub fn execute(args: &Args) -> Result<Report, String> {
    let mut report = Report::default();
    let mut failures = Vec::new();
    let host_minutes = args
        .host_minutes
        .unwrap_or(if args.quick { 5.0 } else { 60.0 });
    let board_minutes = args
        .board_minutes
        .unwrap_or(if args.quick { 0.5 } else { 10.0 });
    if matches!(args.board, SoakBoard::Host | SoakBoard::Both) {
        report.host = Some(host_soak(host_minutes, &mut failures)?);
    }
    if matches!(args.board, SoakBoard::Qemu | SoakBoard::Both) {
        report.board = Some(board_soak(
            board_minutes,
            args.hold_lines,
            &args.out,
            &mut failures,
        )?);
    }
    failures.dedup();
    report.passed = failures.is_empty();
    report.failures = failures;
    Ok(report)
}

fn print_summary(report: &Report) {
    if let Some(h) = &report.host {
        eprintln!(
            "host: {} telegrams ({:.0} simulated s) in {:.1} s wall, {:.0} telegrams/s \
             (intervals {:.0} .. {:.0}; first third {:.0}, last third {:.0}); RSS {} -> max {} KiB; \
             {} observations; cells in [{}, {}] raw; flush {:.2} s; mirror equal: {}; \
             patches_deferred {} (waiting tiles summed over polls: {})",
            h.telegrams,
            h.sim_s,
            h.wall_s,
            h.telegrams_per_s,
            h.interval_rate_min,
            h.interval_rate_max,
            h.rate_first_third,
            h.rate_last_third,
            h.rss_first_kib,
            h.rss_max_kib,
            h.observations,
            h.cell_raw_min,
            h.cell_raw_max,
            h.flush_s,
            h.mirror_equal,
            h.final_stats
                .iter()
                .find(|(n, _)| n == "patches_deferred")
                .map_or(0, |x| x.1),
            h.deferred_tile_polls
        );
        eprintln!("host: the soonest counters to saturate at this drive's rates:");
        for p in h.projections.iter().take(6) {
            eprintln!(
                "  {:28} {:>12} ({:>10.1}/s): {}",
                p.counter,
                p.value,
                p.per_s,
                p.saturates_after_days
                    .map_or("never".to_string(), |d| format!("{d:.1} days"))
            );
        }
    }
    if let Some(b) = &report.board {
        eprintln!(
            "qemu: {} telegrams ({:.0} simulated s) in {:.1} s wall, {:.0} telegrams/s, {} round trips; \
             counters match the reference: {}; mirror from patches equal: {}, after snapshot: {}; \
             stack high-water {} bytes",
            b.telegrams,
            b.sim_s,
            b.wall_s,
            b.telegrams_per_s,
            b.round_trips,
            b.counters_match_reference,
            b.incremental_mirror_equal,
            b.snapshot_mirror_equal,
            b.stack_bytes
        );
    }
    for f in &report.failures {
        eprintln!("FAILED: {f}");
    }
    eprintln!("soak: {}", if report.passed { "passed" } else { "FAILED" });
}

/// Runs `lab soak`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(report) => {
            print_summary(&report);
            if args.json && !terrain_pyramid_host::json_line::print(&report, "error: ") {
                return ExitCode::FAILURE;
            }
            if report.passed {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => crate::command_failed(e),
    }
}
