//! `lab faults`: fault injection through the emulated board.
//!
//! One run of the firmware in QEMU (`boards/qemu-mps2`, as `pyramid run --board qemu`) per
//! fault kind, on the simulated stairs drive (the paper's robot, a vertical SICK plane panned
//! at 1 m, driving towards stairs; real LMS2xx telegrams, a pose and a pan angle per line),
//! cut to its first lines. The harness drives the board lock-step, as `run --board qemu`
//! does, but damages what it sends:
//!
//! - laser faults (`bit_flips_*`, `dropped_bytes`, `garbage_bursts`, `truncated`,
//!   `lone_ack_nak`): each telegram's bytes are damaged (or not) before they go to UART0.
//!   The harness feeds the very same damaged bytes, chunk for chunk, to the library's SICK
//!   `SickAccumulator` on the host: it knows exactly which telegrams the firmware will decode, and
//!   when. A decoded telegram equal byte for byte to an original telegram at that
//!   telegram's own position in the damaged stream is **intact**; anything else decoded is
//!   **corrupt** (it passed the 16-bit CRC by chance). The reference map is the library's
//!   co-processor in this process (`InProcess`, as `run --board host` runs it), sent the same
//!   PanAngle and Pose frames as the board and fed exactly the intact telegrams, each when the
//!   firmware decodes it, so with the pan angle and pose the firmware had then. After each chunk the harness waits until the firmware's `laser_bytes`
//!   counter (Stats) says it has taken every byte written, so nothing is in flight.
//! - pose faults (`pose_gaps_jumps`, `bad_pose`): poses left out for runs of lines, jumps of
//!   tens to thousands of metres and back; NaN, infinite and out-of-range poses, each of
//!   which must be refused with the Reply the library's own rule gives (code and field:
//!   `link::convert::pose_refusal`).
//! - `bad_config`: invalid Configure and Setup commands mid-run, each refused with the
//!   library's Reply (`design_refusal`, `setup_refusal`) and no Hello (the maps are not
//!   cleared).
//! - `link_disconnect`: the host stops listening (the mirror gets nothing) for a stretch of
//!   lines, then the UART1 connection is closed while lines keep coming on UART0, then the
//!   host reconnects with a fresh link and mirror and asks for a snapshot.
//!
//! At the end of each run: EndObservation, RequestSnapshot(all), the mirror compared with the
//! reference cell for cell on every layer, the firmware's SICK counters compared with the
//! host accumulator's, Shutdown and QEMU's exit status (0; 101 panic, 102 HardFault).

use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::{
    config_of, configure_of_design, design_of, design_refusal, frontend_config, pose_of,
    pose_refusal, setup_message, setup_refusal, ReplyText,
};
use terrain_pyramid::wire::link::{
    ClampRequest, Configure, Header, Message, PanAngle, PoseReport, Reply, Setup, Stats,
};
use terrain_pyramid::wire::recording::SetupEvent;
use terrain_pyramid::wire::sick::{SickAccumulator, SickItem};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, DesignError, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS,
};
use terrain_pyramid_host::device::Device;
use terrain_pyramid_host::emulator::{
    build_firmware, qemu_available, Emulator, Machine, BOARD_DIR, INSTALL_HINT,
};
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::link::LinkEvent;
use terrain_pyramid_host::play::{steps, Step as PlayStep};
use terrain_pyramid_host::run::{boot_host_device, HostDevice};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};

/// Arguments of `lab faults`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Print `{"faults":[...]}` on stdout.
    #[arg(long)]
    pub json: bool,
    /// Fewer lines per run (CI).
    #[arg(long)]
    pub quick: bool,
    /// Run only these kinds (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Lines of the recording per run (default 240, 90 with --quick).
    #[arg(long)]
    pub lines: Option<usize>,
    /// Where the firmware's defmt logs go (one per kind).
    #[arg(long, value_name = "DIR", default_value = "target/faults")]
    pub out: PathBuf,
    /// Kinds run at once, each its own emulated board (default: the machine's cores). The
    /// harness drives each board lock-step, so a run keeps about one core busy.
    #[arg(long)]
    pub jobs: Option<usize>,
}

mod lidar;
mod plan;
mod reference;

use plan::{plan, recording, Cmd, Line, Phase, Rng, Step};
use reference::Reference;

/// Every fault kind, in order (the spinning lidars' kinds, `lidar::KINDS`, follow).
pub const KINDS: [&str; 10] = [
    "bit_flips_1e-4",
    "bit_flips_1e-3",
    "dropped_bytes",
    "garbage_bursts",
    "truncated",
    "lone_ack_nak",
    "link_disconnect",
    "pose_gaps_jumps",
    "bad_pose",
    "bad_config",
];

/// The outcome of one fault kind.
#[derive(Serialize, Debug, Clone, Default)]
pub struct Outcome {
    /// The kind.
    pub name: String,
    /// Telegrams the recording's lines carried.
    pub telegrams_total: u64,
    /// Telegrams the library's accumulator decodes, equal to the originals, from the damaged
    /// stream.
    pub telegrams_intact: u64,
    /// Telegrams the fault damaged or that were lost with a damaged neighbour.
    pub telegrams_damaged: u64,
    /// Telegrams the firmware applied (telegrams_ok − telegrams_bad_other).
    pub telegrams_applied: u64,
    /// Decoded telegrams that were not intact (passed the CRC by chance).
    pub corrupt_applied: u64,
    /// Intact telegrams decoded only when later bytes arrived (applied with a later angle and
    /// pose; the reference does the same).
    pub telegrams_delayed: u64,
    /// The most telegrams, after a damaged one, whose bytes the fault left untouched but that
    /// were not applied before an intact one was (0: every fault resynchronised by the next
    /// intact telegram).
    pub resync_max_telegrams: u64,
    /// Damage runs (consecutive damaged telegrams) the firmware's counters show no trace of.
    pub unaccounted_damage: u64,
    /// Bad commands sent / refused with the library's own Reply (code, field, value).
    pub commands_bad: u64,
    /// Bad commands refused as expected.
    pub commands_refused_as_expected: u64,
    /// Cells of all layers that differ between the mirror and the reference.
    pub cells_differing: u64,
    /// The mirror equals the reference cell for cell, on every layer.
    pub map_equal_to_reference: bool,
    /// QEMU stopped, hung (no answer within 20 s) or exited non-zero.
    pub crashed: bool,
    /// The firmware's Stats at the end.
    pub counters: Option<Counters>,
    /// Known (not unknown) cells of the reference at the end, over every layer: the
    /// comparison is not one of two empty maps.
    pub reference_known_cells: u64,
    /// Frames the device sent while the host was not listening (`link_disconnect`).
    pub frames_lost_while_deaf: u64,
    /// Frames the mirror counted missing when the host listened again (`link_disconnect`;
    /// at least `frames_lost_while_deaf`).
    pub mirror_missing_after_deaf: u64,
    /// Gaps the host mirror counted (by sequence number).
    pub mirror_gaps: u64,
    /// Frames the mirror counted missing.
    pub mirror_missing: u64,
    /// Every failed requirement, in words.
    pub failures: Vec<String>,
    /// All requirements hold.
    pub ok: bool,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// The firmware's counters that matter here.
#[derive(Serialize, Debug, Clone, Copy, Default)]
pub struct Counters {
    /// SICK telegrams decoded.
    pub telegrams_ok: u32,
    /// Bad checksum.
    pub telegrams_bad_checksum: u32,
    /// Bad framing (length, truncation).
    pub telegrams_bad_framing: u32,
    /// Not applied (not measured values, or refused by the pipeline).
    pub telegrams_bad_other: u32,
    /// Laser bytes taken.
    pub laser_bytes: u32,
    /// Host frames missing by sequence.
    pub rx_seq_gaps: u32,
    /// Commands refused.
    pub commands_refused: u32,
    /// Control frames dropped.
    pub frames_dropped: u32,
    /// Snapshots served.
    pub snapshots: u32,
}

impl From<&Stats> for Counters {
    fn from(s: &Stats) -> Self {
        Self {
            telegrams_ok: s.telegrams_ok,
            telegrams_bad_checksum: s.telegrams_bad_checksum,
            telegrams_bad_framing: s.telegrams_bad_framing,
            telegrams_bad_other: s.telegrams_bad_other,
            laser_bytes: s.laser_bytes,
            rx_seq_gaps: s.rx_seq_gaps,
            commands_refused: s.commands_refused,
            frames_dropped: s.frames_dropped,
            snapshots: s.snapshots,
        }
    }
}

/// The default design: the firmware's at boot, and the demo's stairs scenario.
fn default_design() -> DefaultDesign {
    DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap_or_else(|e| unreachable!("the default design is valid: {e}"))
}

/// Runs one kind; an error is a crash or a hang.
#[allow(clippy::too_many_lines)]
fn run_kind(
    kind: &str,
    elf: &Path,
    out: &Path,
    setup_rec: &SetupEvent,
    lines: &[Line],
    outcome: &mut Outcome,
) -> Result<(), String> {
    let classifier = ClassifierConfig::default();
    let design = default_design();
    let config = Config::default();
    let setup = setup_message(setup_rec, &classifier);
    let steps = plan(kind, lines, &setup);
    let mut reference = Reference::new(setup_rec, steps.len())?;
    outcome.telegrams_total = lines.len() as u64;

    let mut emu = Emulator::start(Machine::Mps2An386, elf, &out.join(format!("{kind}.defmt")))?;
    emu.configure_after_hello(&design, &config)?;
    emu.command("Setup", &Message::Setup(setup))?;

    let mut phase = Phase::Normal;
    // Trace of the accumulator at the last intact delivery, and the damaged lines since.
    let mut last_trace = 0_u64;
    let mut pending_damage = 0_u64;
    for (i, step) in steps.iter().enumerate() {
        // Phase changes.
        if step.phase != phase {
            match (phase, step.phase) {
                (_, Phase::Deaf) => emu.set_deaf(true),
                (Phase::Deaf, Phase::Normal) => {
                    emu.set_deaf(false);
                    let tapped = emu.tapped_frames();
                    outcome.frames_lost_while_deaf = tapped;
                    // The next Stats shows the mirror the gap; it asks for a snapshot.
                    barrier(&mut emu, reference.written)?;
                    let c = emu.link().mirror().counters();
                    outcome.mirror_missing_after_deaf = c.missing;
                    if c.missing < tapped {
                        outcome.failures.push(format!(
                            "the mirror counted {} missing frames of the {tapped} it did not get",
                            c.missing
                        ));
                    }
                    if emu.link().mirror().needs_snapshot() {
                        emu.snapshot()?;
                    } else {
                        outcome
                            .failures
                            .push("the mirror did not notice the frames it missed".into());
                    }
                }
                (_, Phase::Disconnected) => emu.disconnect_link(),
                (Phase::Disconnected, Phase::Normal) => {
                    emu.reconnect_link()?;
                    barrier(&mut emu, reference.written)?;
                    emu.snapshot()?;
                    // The mirror must be the reference again, now.
                    let diff = compare(&emu, reference.pyramid(), &design, &config)?;
                    if diff != 0 {
                        outcome.failures.push(format!(
                            "after reconnecting, {diff} cells differ from the reference"
                        ));
                    }
                }
                _ => {}
            }
            phase = step.phase;
        }
        // Commands (none while disconnected: the device keeps its angle and pose).
        if phase != Phase::Disconnected {
            let mut sent = false;
            for cmd in &step.cmds {
                match cmd {
                    Cmd::Angle(turns) => {
                        let message = Message::PanAngle(PanAngle {
                            turns: *turns,
                            timestamp_ms: 0,
                        });
                        emu.send(&message)?;
                        reference.send(&message)?;
                        sent = true;
                    }
                    Cmd::Pose(p) => {
                        let report = PoseReport::unstamped(*p);
                        let message = Message::Pose(report);
                        match pose_of(&report) {
                            Ok(_) => {
                                emu.send(&message)?;
                                sent = true;
                            }
                            Err(e) => {
                                let expected = pose_refusal(next_header(&emu, &message), &e);
                                refused(&mut emu, &message, expected, outcome)?;
                            }
                        }
                        // The reference gets the same frame (and refuses it the same way).
                        reference.send(&message)?;
                    }
                    Cmd::Configure(c) => {
                        let message = Message::Configure(**c);
                        let Some(e) = configure_error(c) else {
                            outcome
                                .failures
                                .push("the plan holds a valid Configure".into());
                            continue;
                        };
                        let expected = design_refusal(next_header(&emu, &message), &e);
                        refused(&mut emu, &message, expected, outcome)?;
                    }
                    Cmd::Setup(s) => {
                        let message = Message::Setup(*s);
                        let Err(e) = frontend_config(s) else {
                            outcome.failures.push("the plan holds a valid Setup".into());
                            continue;
                        };
                        let expected = setup_refusal(next_header(&emu, &message), &e);
                        refused(&mut emu, &message, expected, outcome)?;
                    }
                }
            }
            if sent {
                emu.stats()?;
            }
        }
        emu.laser(&step.chunk)?;
        reference.feed(i, step, lines)?;
        if phase != Phase::Disconnected {
            barrier(&mut emu, reference.written)?;
        }
        // Damage accounting: every run of damaged lines leaves a trace in the counters of the
        // accumulator the firmware runs (a rejected candidate or garbage bytes).
        if reference.intact[i] {
            if pending_damage > 0 && reference.trace() == last_trace {
                reference.unaccounted += 1;
            }
            pending_damage = 0;
            last_trace = reference.trace();
        } else if step.intact_at.is_none() {
            pending_damage += 1;
        }
    }
    reference.settle(&steps);

    emu.send(&Message::EndObservation)?;
    reference.send(&Message::EndObservation)?;
    let stats = barrier(&mut emu, reference.written)?;
    emu.snapshot()?;
    let diff = compare(&emu, reference.pyramid(), &design, &config)?;
    let mirror = emu.link().mirror().counters();
    outcome.mirror_gaps = mirror.gaps;
    outcome.mirror_missing = mirror.missing;
    outcome.counters = Some(Counters::from(&stats));
    outcome.telegrams_intact = reference.intact.iter().filter(|&&b| b).count() as u64;
    outcome.telegrams_damaged = outcome.telegrams_total - outcome.telegrams_intact;
    outcome.telegrams_applied =
        u64::from(stats.telegrams_ok.saturating_sub(stats.telegrams_bad_other));
    outcome.corrupt_applied = reference.corrupt;
    outcome.telegrams_delayed = reference.delayed;
    outcome.resync_max_telegrams = reference.resync_max;
    outcome.unaccounted_damage = reference.unaccounted;
    outcome.cells_differing = diff;
    outcome.reference_known_cells = known_cells(reference.pyramid());
    // Every intact telegram reached the reference at an angle (a line before any angle
    // would be dropped, by the reference and the firmware alike).
    let without_angle = reference.device.core().counters().app.lines_without_angle;
    if without_angle > 0 {
        outcome.failures.push(format!(
            "{without_angle} intact telegrams reached the reference before any pan angle"
        ));
    }
    outcome.map_equal_to_reference = diff == 0;

    // The firmware's counters against the accumulator's on the host, over the same bytes.
    let sim = reference.acc.stats();
    let want = (
        sim.telegrams_ok,
        sim.crc_errors,
        sim.length_errors + sim.truncated,
    );
    check_counters(outcome, &stats, want, ("SICK", "accumulator"));
    // Shutdown: QEMU must exit with 0 (a panic or HardFault is an error, hence `crashed`).
    emu.shutdown()?;
    Ok(())
}

/// Waits until the firmware has taken `written` laser bytes; returns its Stats.
fn barrier(emu: &mut Emulator, written: u64) -> Result<Stats, String> {
    #[allow(clippy::cast_possible_truncation)]
    let want = written as u32;
    for _ in 0..100_000 {
        let s = emu.stats()?;
        if s.laser_bytes == want {
            return Ok(s);
        }
    }
    Err(format!(
        "the firmware never took the {written} laser bytes written"
    ))
}

/// Sends a command that must be refused with `expected` (code, field, value) and must not
/// clear the maps (no Hello).
fn refused(
    emu: &mut Emulator,
    message: &Message<'_>,
    expected: Reply,
    outcome: &mut Outcome,
) -> Result<(), String> {
    outcome.commands_bad += 1;
    let hellos = emu.link().mirror().counters().hellos;
    let seq = emu.send(message)?;
    let to_type = message.msg_type().to_u8();
    let mut reply = None;
    let waited = emu.wait_for("a Reply to a bad command", |_, e| match e {
        Some(LinkEvent::Reply(r)) if r.to_seq == seq && r.to_type == to_type => {
            reply = Some(*r);
            true
        }
        _ => false,
    });
    // A Stats after the Reply: anything the command did is out by then. When no Reply came,
    // the Stats tells a silent refusal (the firmware answers) from a hang (it does not).
    emu.stats()?;
    let Some(reply) = reply else {
        let why = waited.err().unwrap_or_default();
        outcome.failures.push(format!(
            "{message:?}: no Reply, the command was dropped silently ({why})"
        ));
        return Ok(());
    };
    let same = reply.code == expected.code
        && reply.param == expected.param
        && reply.value.to_bits() == expected.value.to_bits()
        && reply.a.to_bits() == expected.a.to_bits()
        && reply.b.to_bits() == expected.b.to_bits();
    let hello = emu.link().mirror().counters().hellos != hellos;
    if same && !reply.is_ok() && !hello {
        outcome.commands_refused_as_expected += 1;
    } else {
        outcome.failures.push(format!(
            "{message:?}: answered {} (expected {}){}",
            ReplyText(&reply),
            ReplyText(&expected),
            if hello {
                ", and the maps were cleared"
            } else {
                ""
            }
        ));
    }
    Ok(())
}

/// The header of the next frame the harness sends on the emulator's link: what a Reply to
/// `message` answers.
fn next_header(emu: &Emulator, message: &Message<'_>) -> Header {
    Header {
        version: terrain_pyramid::wire::link::VERSION,
        msg_type: message.msg_type().to_u8(),
        seq: emu.link().next_seq(),
    }
}

/// Why the device refuses the Configure `c`, on the host: the link's conversion
/// ([`design_of`], [`config_of`]), then what the co-processor checks when it adopts it (the
/// increments, the window, the clamp, the margin); `None` when it would be accepted.
fn configure_error(c: &Configure) -> Option<DesignError> {
    let design = match design_of::<DEFAULT_LAYERS>(c) {
        Ok(d) => d,
        Err(e) => return Some(e),
    };
    let config = match config_of(c) {
        Ok(config) => config,
        Err(e) => return Some(e),
    };
    if let Err(e) = config.model.increments() {
        return Some(e);
    }
    let mut scratch = Box::new(DefaultPyramid::new());
    scratch.configure(&design, &config).err()
}

/// Cells that differ between the mirror and the reference, over every layer (a layer whose
/// origin or resolution differs counts all its cells).
fn compare(
    emu: &Emulator,
    pyramid: &DefaultPyramid,
    design: &DefaultDesign,
    config: &Config,
) -> Result<u64, String> {
    let snapshot = MapSnapshot::from_pyramid(pyramid, design, config, (0.0, 0.0));
    let mirror = emu.link().mirror();
    let mut diff = 0_u64;
    for layer in &snapshot.layers {
        let (origin, resolution, cells) = mirror
            .layer_cells(layer.index)
            .ok_or_else(|| format!("the mirror has no layer {}", layer.index))?;
        if origin != layer.origin_cells
            || resolution != layer.resolution.to_bits()
            || cells.len() != layer.cells.len()
        {
            diff += layer.cells.len() as u64;
            continue;
        }
        diff += cells
            .iter()
            .zip(&layer.cells)
            .filter(|(a, b)| a != b)
            .count() as u64;
    }
    if mirror.layer_count() != snapshot.layers.len() {
        return Err(format!(
            "the mirror has {} layers, the reference {}",
            mirror.layer_count(),
            snapshot.layers.len()
        ));
    }
    Ok(diff)
}

/// Adds a failure to `outcome` unless the firmware's telegram counters in `stats` (ok, bad
/// checksum, bad framing) equal `want`, the host's count over the same bytes; `(counters,
/// host)` name them in the failure (`SICK`, `accumulator`; `packet`, `decoder`).
fn check_counters(
    outcome: &mut Outcome,
    stats: &Stats,
    want: (u32, u32, u32),
    (counters, host): (&str, &str),
) {
    let got = (
        stats.telegrams_ok,
        stats.telegrams_bad_checksum,
        stats.telegrams_bad_framing,
    );
    if want != got {
        outcome.failures.push(format!(
            "the firmware's {counters} counters (ok, checksum, framing) {got:?} differ from the \
             host {host}'s {want:?} over the same bytes"
        ));
    }
}

/// Cells of every layer that are not unknown.
fn known_cells(pyramid: &DefaultPyramid) -> u64 {
    (0..pyramid.layer_count())
        .filter_map(|k| pyramid.layer(k))
        .map(|layer| {
            let w = DEFAULT_CELLS_PER_SIDE;
            (0..w * w)
                .filter(|n| {
                    layer
                        .at_offset(n % w, n / w)
                        .is_some_and(|c| c != terrain_pyramid::logodds::Cell::UNKNOWN)
                })
                .count() as u64
        })
        .sum()
}

/// What every fault run must show.
fn judge(o: &mut Outcome) {
    if o.crashed {
        o.failures.push("the firmware crashed or hung".into());
    }
    if o.corrupt_applied > 0 {
        o.failures.push(format!(
            "{} corrupt telegrams were decoded",
            o.corrupt_applied
        ));
    }
    if o.resync_max_telegrams > 0 {
        o.failures.push(format!(
            "{} untouched telegrams were lost after damage",
            o.resync_max_telegrams
        ));
    }
    if o.unaccounted_damage > 0 {
        o.failures.push(format!(
            "{} runs of damaged telegrams left no trace in the counters",
            o.unaccounted_damage
        ));
    }
    if !o.crashed {
        if o.telegrams_applied != o.telegrams_intact + o.corrupt_applied {
            o.failures.push(format!(
                "the firmware applied {} telegrams; {} arrived intact",
                o.telegrams_applied, o.telegrams_intact
            ));
        }
        if o.reference_known_cells == 0 {
            o.failures
                .push("the reference map is empty: the comparison shows nothing".into());
        }
        if !o.map_equal_to_reference {
            o.failures.push(format!(
                "{} cells differ from the reference",
                o.cells_differing
            ));
        }
        if o.commands_refused_as_expected != o.commands_bad {
            o.failures.push(format!(
                "{} of {} bad commands refused as expected",
                o.commands_refused_as_expected, o.commands_bad
            ));
        }
    }
    o.ok = o.failures.is_empty();
}

/// Runs every kind (or `only`); returns the outcomes.
///
/// # Errors
/// The firmware cannot be built or the recording made.
pub fn execute(args: &Args) -> Result<Vec<Outcome>, String> {
    if !qemu_available() {
        return Err(format!("qemu-system-arm is missing: {INSTALL_HINT}"));
    }
    for name in &args.only {
        if !KINDS.contains(&name.as_str()) && !lidar::KINDS.contains(&name.as_str()) {
            return Err(format!(
                "unknown fault kind {name}; the kinds: {}, {}",
                KINDS.join(", "),
                lidar::KINDS.join(", ")
            ));
        }
    }
    let elf = build_firmware(Path::new(BOARD_DIR), "qemu-mps2")?;
    let n = args.lines.unwrap_or(if args.quick { 90 } else { 240 });
    let (setup, lines) = recording(n)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let kinds: Vec<&str> = KINDS
        .iter()
        .chain(&lidar::KINDS)
        .copied()
        .filter(|kind| args.only.is_empty() || args.only.iter().any(|k| k == kind))
        .collect();
    // One kind per worker at a time; the outcomes keep the kinds' order.
    let run_one = |kind: &str| -> Outcome {
        let started = Instant::now();
        let mut o = Outcome {
            name: kind.to_string(),
            ..Outcome::default()
        };
        let is_lidar = lidar::KINDS.contains(&kind);
        let result = if is_lidar {
            lidar::run_kind(kind, &elf, &args.out, n, &mut o)
        } else {
            run_kind(kind, &elf, &args.out, &setup, &lines, &mut o)
        };
        if let Err(e) = result {
            o.crashed = true;
            o.failures.push(e);
        }
        o.seconds = started.elapsed().as_secs_f64();
        if is_lidar {
            lidar::judge(&mut o);
        } else {
            judge(&mut o);
        }
        report(kind, &o);
        o
    };
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from))
        .clamp(1, kinds.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done: std::sync::Mutex<Vec<Option<Outcome>>> =
        std::sync::Mutex::new(vec![None; kinds.len()]);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(kind) = kinds.get(i) else { break };
                let outcome = run_one(kind);
                if let Some(slot) = done.lock().as_mut().ok().and_then(|d| d.get_mut(i)) {
                    *slot = Some(outcome);
                }
            });
        }
    });
    let outcomes: Vec<Outcome> = done
        .into_inner()
        .map_err(|_| "a fault run's thread panicked".to_string())?
        .into_iter()
        .zip(&kinds)
        .map(|(o, kind)| {
            o.unwrap_or_else(|| Outcome {
                name: kind.to_string(),
                crashed: true,
                failures: vec!["its run did not finish".to_string()],
                ..Outcome::default()
            })
        })
        .collect();
    Ok(outcomes)
}

/// One kind's line on stderr (as each kind finishes; with `--jobs` above 1 not in order).
fn report(kind: &str, o: &Outcome) {
    eprintln!(
        "{kind:16} total {:4} intact {:4} damaged {:4} applied {:4} corrupt {} delayed {} \
         resync {} bad commands {}/{} map {} ({} known cells) crashed {} {:.1} s{}",
        o.telegrams_total,
        o.telegrams_intact,
        o.telegrams_damaged,
        o.telegrams_applied,
        o.corrupt_applied,
        o.telegrams_delayed,
        o.resync_max_telegrams,
        o.commands_refused_as_expected,
        o.commands_bad,
        if o.map_equal_to_reference {
            "equal"
        } else {
            "DIFFERS"
        },
        o.reference_known_cells,
        o.crashed,
        o.seconds,
        if o.ok {
            String::new()
        } else {
            format!("\n  FAILED: {}", o.failures.join("; "))
        }
    );
}

/// The JSON of `--json`.
#[derive(Serialize)]
struct Report<'a> {
    faults: &'a [Outcome],
}

/// Runs `lab faults`: exit 0 when every kind's outcome is good, 1 otherwise.
pub fn run(args: &Args) -> ExitCode {
    let started = Instant::now();
    match execute(args) {
        Ok(outcomes) => {
            if args.json
                && !terrain_pyramid_host::json_line::print(&Report { faults: &outcomes }, "error: ")
            {
                return ExitCode::FAILURE;
            }
            let bad: Vec<&str> = outcomes
                .iter()
                .filter(|o| !o.ok)
                .map(|o| o.name.as_str())
                .collect();
            eprintln!(
                "faults: {} kinds in {:.1} s; {}",
                outcomes.len(),
                started.elapsed().as_secs_f64(),
                if bad.is_empty() {
                    "every requirement holds".to_string()
                } else {
                    format!("FAILED: {}", bad.join(", "))
                }
            );
            if bad.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => crate::command_failed(e),
    }
}

#[cfg(test)]
mod tests;
