//! `pyramid run`: a recording through the co-processor, and the maps it builds.
//!
//! `--board host` runs the library's application core ([`terrain_pyramid::app::CoProcessor`])
//! in this process; `--board qemu` runs the firmware on QEMU's emulated Cortex-M4F,
//! `netduinoplus2` the STM32F4 firmware on QEMU's STM32F405, `microbit` the micro:bit firmware
//! (16-cell windows, at most 4 layers: `--cells 16`) on QEMU's nRF51822. All are driven the
//! same way ([`crate::play`]): boot, Hello, Configure with the flags' design,
//! Setup from the recording, the recording's frames and telegrams lock-step, EndObservation,
//! the device's pending changes sent (`sync`), a snapshot, and the maps written from the
//! host's mirror of the device's layers.
//!
//! The final snapshot checks the mirror: before it the device sends every changed tile that
//! its link's budget held back (`sync`), so the mirror holds everything the device has; the
//! snapshot then compares every resent cell with the mirror's own
//! (`mirror.resent_cells_differing`: 0 when the mirror equals the device cell for cell).
//! Without the `sync`, the tiles still waiting at the end of the recording would be counted
//! as differing although nothing was wrong: they had not been sent yet.
//!
//! With `--decay`, the device decays by its own clock (QEMU's follows the wall clock, the
//! in-process device's moves 10 ms a poll), so the maps of the two boards differ by when the
//! decay ran; what must hold on both is that the mirror, which applies every decay step the
//! device announces with the host's build of the library, equals the device cell for cell:
//! the same check, where cells that changed only by decay since they were sent are compared
//! with the mirror's own decay of them.

use crate::decay::{DecayArgs, DecaySummary};
use crate::device::{Device, InProcess};
use crate::emulator::{qemu_available, Emulator, Machine, INSTALL_HINT};
use crate::export::{write_maps, MapSnapshot};
use crate::play::{mirror_snapshot, play, steps, RunCounts, Step, Steps};
use crate::publish::{OutputArgs, Outputs, OutputsReport, Publishing};
use crate::pyramid_args::PyramidArgs;
use crate::rigfile::{
    merged_rule, mount_rig, read_rig_file, recording_setup, SensorName, SensorSpec,
};
use crate::summary_args::SummaryArgs;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::{
    Config, DefaultDesign, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS,
};

/// Where the pipeline runs.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Board {
    /// In this process, with the library compiled for the host.
    Host,
    /// The firmware on QEMU's MPS2 AN386 (`boards/qemu-mps2`), telegrams on UART0, the host
    /// link on UART1.
    Qemu,
    /// The STM32F4 firmware (`boards/stm32f4`) on QEMU's `netduinoplus2` (STM32F405),
    /// telegrams on USART1, the host link on USART2.
    Netduinoplus2,
    /// The micro:bit firmware (`boards/microbit`) on QEMU's `microbit` (nRF51822, Cortex-M0,
    /// 16 KiB of RAM): 16-cell windows, at most 4 layers; telegrams and the host link on its
    /// one UART.
    Microbit,
}

impl Board {
    /// The board's name in summaries.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Host => "host",
            Self::Qemu => "qemu",
            Self::Netduinoplus2 => "netduinoplus2",
            Self::Microbit => "microbit",
        }
    }

    /// The emulated machine, or `None` for the host.
    #[must_use]
    pub const fn machine(self) -> Option<Machine> {
        match self {
            Self::Host => None,
            Self::Qemu => Some(Machine::Mps2An386),
            Self::Netduinoplus2 => Some(Machine::Netduinoplus2),
            Self::Microbit => Some(Machine::Microbit),
        }
    }

    /// The cells per side of the board's pyramid (the design's `--cells` must match).
    #[must_use]
    pub const fn cells_per_side(self) -> usize {
        match self {
            Self::Microbit => 16,
            _ => DEFAULT_CELLS_PER_SIDE,
        }
    }
}

/// Arguments of `pyramid run`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Where the pipeline runs.
    #[arg(long, value_enum, default_value_t = Board::Host)]
    pub board: Board,
    /// The recording to play (`docs/recording.md`).
    #[arg(long, value_name = "FILE.rec")]
    pub recording: PathBuf,
    /// The output directory, and whether the summary is also printed.
    #[command(flatten)]
    pub summary: SummaryArgs,
    /// The pyramid's design (the window is the board's: `--cells` must match), the clamping
    /// and the classifier (its rule is sent to the device in the Setup).
    #[command(flatten)]
    pub pyramid: PyramidArgs,
    /// The live outputs, as `pyramid listen`'s: the maps as the device sends them while the
    /// recording plays.
    #[command(flatten)]
    pub outputs: OutputArgs,
    /// Decay of stale evidence (off by default).
    #[command(flatten)]
    pub decay: DecayArgs,
    /// The lidar's mount and the returns refused before geometry, over the recording's (and
    /// over the rig file's).
    #[command(flatten)]
    pub mount: crate::rig::RigArgs,
    /// A rig file (docs/rig.md): its mount, sensor position, observation policy and
    /// classifier thresholds replace the recording's setup (its sensor must be the
    /// recording's); the classifier flags above override the file's.
    #[arg(long, value_name = "FILE.toml")]
    pub rig: Option<PathBuf>,
}

/// What the mirror made of the device's frames: its decay and the comparison at the final
/// snapshot.
#[derive(Serialize, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MirrorCheck {
    /// Decayed frames the mirror applied.
    pub decay_frames: u64,
    /// Storage rows the mirror decayed.
    pub rows_decayed: u64,
    /// Cells the mirror's decay made unknown.
    pub cells_faded: u64,
    /// Cells the device said its decay made unknown.
    pub cells_faded_device: u64,
    /// Cells a snapshot resent into a mirror in step, compared with the mirror's own.
    pub resent_cells_compared: u64,
    /// Of those, the cells that differed (0: device and mirror equal cell for cell). Every
    /// change is sent before the snapshot ([`drive`] syncs first), so a cell that was merely
    /// not sent yet is never counted here.
    pub resent_cells_differing: u64,
}

impl MirrorCheck {
    /// The check of a mirror's counters.
    #[must_use]
    pub fn of(c: &crate::link::MirrorCounters) -> Self {
        Self {
            decay_frames: c.decay_frames,
            rows_decayed: c.rows_decayed,
            cells_faded: c.cells_faded,
            cells_faded_device: c.cells_faded_device,
            resent_cells_compared: c.resent_cells_compared,
            resent_cells_differing: c.resent_cells_differing,
        }
    }
}

/// What `summary.json` holds.
#[derive(Serialize)]
pub struct Summary<'a> {
    /// The maps' numbers.
    #[serde(flatten)]
    pub maps: &'a crate::export::MapSummary,
    /// The run's counters.
    #[serde(flatten)]
    pub counts: &'a RunCounts,
    /// Where the pipeline ran.
    pub board: &'static str,
    /// FNV-1a (64 bits, hex) of every layer's index, origin, resolution and raw cells: equal
    /// hashes mean bit-identical maps.
    pub layers_hash: String,
    /// The firmware's stack high-water mark, bytes (emulated boards only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stack_bytes: Option<u32>,
    /// The decay configured on the device.
    pub decay: &'a DecaySummary,
    /// The mirror's decay and its comparison with the device at the final snapshot.
    pub mirror: MirrorCheck,
    /// What the live outputs published (when any was on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outputs: Option<&'a OutputsReport>,
}

/// The hash of [`Summary::layers_hash`].
#[must_use]
pub fn layers_hash(snapshot: &MapSnapshot) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for l in &snapshot.layers {
        eat(&(l.index as u64).to_le_bytes());
        eat(&l.origin_cells.0.to_le_bytes());
        eat(&l.origin_cells.1.to_le_bytes());
        eat(&l.resolution.to_bits().to_le_bytes());
        for c in &l.cells {
            eat(&c.to_le_bytes());
        }
    }
    format!("{h:016x}")
}

/// What `summary.json` reports beside the maps and the counts.
#[derive(Debug, Clone, Copy)]
pub struct Beside<'a> {
    /// The firmware's stack high-water mark, bytes (emulated boards only).
    pub stack_bytes: Option<u32>,
    /// The decay configured on the device.
    pub decay: &'a DecaySummary,
    /// The mirror's decay and its comparison with the device at the final snapshot.
    pub mirror: MirrorCheck,
    /// What the live outputs published (when any was on).
    pub outputs: Option<&'a OutputsReport>,
}

/// Writes the maps, `cells-K.bin` (each layer's raw cells, i16 little-endian, row-major, row
/// 0 = lowest y) and `summary.json`; returns the summary's JSON.
///
/// # Errors
/// A file that cannot be written.
pub fn write_outputs(
    out: &Path,
    snapshot: &MapSnapshot,
    title: &str,
    counts: &RunCounts,
    board: Board,
    beside: Beside<'_>,
) -> Result<String, String> {
    let Beside {
        stack_bytes,
        decay,
        mirror,
        outputs,
    } = beside;
    let written = write_maps(out, snapshot, title)?;
    for l in &snapshot.layers {
        let bytes: Vec<u8> = l.cells.iter().flat_map(|c| c.to_le_bytes()).collect();
        crate::export::write_file(&out.join(format!("cells-{}.bin", l.index)), &bytes)?;
    }
    let summary = Summary {
        maps: &written.summary,
        counts,
        board: board.name(),
        layers_hash: layers_hash(snapshot),
        stack_bytes,
        decay,
        mirror,
        outputs,
    };
    let json = serde_json::to_string(&summary).map_err(|e| e.to_string())?;
    crate::export::write_file(&out.join("summary.json"), json.as_bytes())?;
    Ok(json)
}

/// The design, the pyramid's configuration and the classifier's of `pyramid run`'s flags.
///
/// # Errors
/// An invalid design (exit status 2).
pub fn run_config(args: &Args) -> Result<(DefaultDesign, Config, ClassifierConfig), (u8, String)> {
    let design: DefaultDesign = DefaultDesign::new(
        crate::design::sensor_model(&args.pyramid.design),
        crate::design::schedule(&args.pyramid.design),
        args.pyramid.design.cells,
    )
    .map_err(|e| (2, format!("error: {e}")))?;
    let cells = args.board.cells_per_side();
    if design.cells_per_side() != cells {
        return Err((
            2,
            format!(
                "error: --cells: the {} pyramid has {cells} cells per side",
                args.board.name()
            ),
        ));
    }
    let config = Config {
        clamp: args.pyramid.clamp(),
        model: args
            .pyramid
            .model()
            .map_err(|e| (2, format!("error: {e}")))?,
        decay: args
            .decay
            .decay(design.layers().len(), design.cells_per_side())
            .map_err(|e| (2, format!("error: {e}")))?,
        ..Config::default()
    };
    let classifier = match &args.rig {
        None => args.pyramid.classifier(),
        Some(path) => read_rig_file(path).and_then(|rig| {
            let mut spec = rig.classifier;
            spec.rule = merged_rule(&spec.rule, &args.pyramid.rule);
            spec.ceiling_m = args.pyramid.ceiling_m.or(spec.ceiling_m);
            spec.drop_m = args.pyramid.drop_m.or(spec.drop_m);
            spec.apply(ClassifierConfig::default())
        }),
    }
    .map_err(|e| (2, format!("error: {e}")))?;
    Ok((design, config, classifier))
}

/// The co-processor `--board host` runs: the library's defaults, as the QEMU firmware.
pub type HostDevice =
    InProcess<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, DEFAULT_CLASSIFIER_SLOTS, 2048>;

/// Boots the in-process co-processor as the QEMU firmware boots: the default design, a
/// tilt-unit setup, the default link settings.
///
/// # Errors
/// The boot was refused.
pub fn boot_host_device() -> Result<HostDevice, String> {
    let design = crate::design::firmware_design()?;
    HostDevice::boot(
        LinkConfig::DEFAULT,
        &design,
        &Config::default(),
        FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal),
    )
}

/// Boots a board's firmware on its emulated machine (building it if needed), its defmt log
/// into `defmt_log`.
///
/// # Errors
/// QEMU or the target missing, the build or the boot failing.
pub fn boot_emulator(machine: Machine, defmt_log: &Path) -> Result<Emulator, String> {
    if !qemu_available() {
        return Err(format!("qemu-system-arm is missing: {INSTALL_HINT}"));
    }
    let elf = machine.build()?;
    Emulator::start(machine, &elf, defmt_log)
}

/// A recording through a device: Hello, Configure, the recording, every pending change sent
/// (`sync`), a snapshot; returns the counts and the maps.
///
/// # Errors
/// The device refused something or stopped answering.
pub fn drive(
    device: &mut impl Device,
    steps: &Steps,
    design: &DefaultDesign,
    config: &Config,
    classifier: &ClassifierConfig,
) -> Result<(RunCounts, MapSnapshot), String> {
    device.configure_after_hello(design, config)?;
    let (mut counts, sensor_xy) = play(device, steps, classifier)?;
    // Every change on the wire before the snapshot, so that it compares only what was sent:
    // a tile the link's budget still held back would otherwise count as differing. (With
    // decay, what is left to differ are the cells that changed only by decay since they were
    // sent: the mirror's decay against the device's.)
    device.sync()?;
    device.snapshot()?;
    let snapshot = mirror_snapshot(device, design, config, sensor_xy)?;
    counts.frames_received = device.link().mirror().counters().frames;
    counts.link_crc_errors = u64::from(device.link().rx_counters().crc);
    Ok((counts, snapshot))
}

/// [`drive`] with the device's maps offered to `outputs` as they arrive, the outputs finished
/// with the final maps; their report when any was on.
///
/// # Errors
/// The device refused something or stopped answering, or an output failed.
pub fn drive_published(
    device: &mut impl Device,
    mut outputs: Outputs,
    steps: &Steps,
    design: &DefaultDesign,
    config: &Config,
    classifier: &ClassifierConfig,
) -> Result<(RunCounts, MapSnapshot, Option<OutputsReport>), String> {
    let mut published = Publishing::new(device, &mut outputs);
    let (counts, snapshot) = drive(&mut published, steps, design, config, classifier)?;
    let pose = published.pose();
    if !outputs.is_on() {
        return Ok((counts, snapshot, None));
    }
    let report = outputs.finish(device.link().mirror(), pose)?;
    Ok((counts, snapshot, Some(report)))
}

/// Runs the pipeline on `args.board`; returns the summary's JSON.
///
/// # Errors
/// The exit status and the message.
pub fn execute(args: &Args) -> Result<String, (u8, String)> {
    let (design, config, classifier) = run_config(args)?;
    let data = std::fs::read(&args.recording).map_err(|e| {
        (
            1,
            format!(
                "error: cannot read the recording {}: {e}",
                args.recording.display()
            ),
        )
    })?;
    std::fs::create_dir_all(&args.summary.out).map_err(|e| {
        (
            1,
            format!("error: cannot create {}: {e}", args.summary.out.display()),
        )
    })?;
    let fail = |e: String| (1, format!("error: {e}"));
    let mut steps = steps(&data).map_err(fail)?;
    let flags = args.mount.rig().map_err(|e| (2, format!("error: {e}")))?;
    steps.rig = match &args.rig {
        Some(path) => {
            rig_over_recording(path, &mut steps).map_err(|e| (2, format!("error: {e}")))?;
            let file = read_rig_file(path).map_err(|e| (2, format!("error: {e}")))?;
            if file.design.is_some() {
                eprintln!(
                    "note: the rig's [design] is what `pyramid listen` sends a device; `run` \
                     takes its design from its own flags (--phi-deg, --gamma, ...)"
                );
            }
            mount_rig(&file).then(flags)
        }
        None => flags,
    };
    // The outputs first: an address already in use ends the command before a board boots.
    let outputs = Outputs::start(&args.outputs.config(crate::export::default_fused_margin()))
        .map_err(|e| (1, format!("error: {e}")))?;
    if let Some(addr) = outputs.foxglove_addr() {
        eprintln!("foxglove: serving ws://{addr}");
    }
    let started = Instant::now();
    let (counts, snapshot, stack_bytes, published, mirror) = match args.board.machine() {
        None => {
            let mut device = boot_host_device().map_err(fail)?;
            let (counts, snapshot, published) =
                drive_published(&mut device, outputs, &steps, &design, &config, &classifier)
                    .map_err(fail)?;
            let mirror = MirrorCheck::of(&device.link().mirror().counters());
            (counts, snapshot, None, published, mirror)
        }
        Some(machine) => {
            let mut emu =
                boot_emulator(machine, &args.summary.out.join("firmware.defmt")).map_err(fail)?;
            let (counts, snapshot, published) =
                drive_published(&mut emu, outputs, &steps, &design, &config, &classifier)
                    .map_err(fail)?;
            let mirror = MirrorCheck::of(&emu.link().mirror().counters());
            let stack = emu.shutdown().map_err(fail)?;
            eprintln!(
                "{}: {} telegrams in {:.1} s, firmware stack high-water {stack} bytes",
                args.board.name(),
                counts.telegrams_sent,
                started.elapsed().as_secs_f64()
            );
            (counts, snapshot, Some(stack), published, mirror)
        }
    };
    let decay = DecaySummary::of(&config.decay, design.layers().len());
    let title = format!(
        "pyramid run --board {}: {} ({} telegrams applied)",
        args.board.name(),
        args.recording.display(),
        counts.telegrams_applied
    );
    write_outputs(
        &args.summary.out,
        &snapshot,
        &title,
        &counts,
        args.board,
        Beside {
            stack_bytes,
            decay: &decay,
            mirror,
            outputs: published.as_ref(),
        },
    )
    .map_err(fail)
}

/// Replaces a recording's setup with the rig file's (`--rig`): its mount, sensor position
/// and observation policy. The rig's sensor, when it names one, must be the recording's;
/// when it names none, the recording's is taken.
///
/// # Errors
/// The rig file's errors, a sensor other than the recording's, or a value the recording's
/// setup cannot carry.
pub fn rig_over_recording(path: &Path, steps: &mut Steps) -> Result<(), String> {
    let mut rig = read_rig_file(path)?;
    let recorded = steps.sensor;
    match rig.sensor {
        Some(s) if s.name.kind().code() != recorded.sensor => {
            return Err(format!(
                "{}: the rig's sensor {} is not the recording's ({})",
                path.display(),
                s.name.name(),
                terrain_pyramid::laser::SensorKind::from_code(recorded.sensor)
                    .map_or("unknown", terrain_pyramid::laser::SensorKind::name)
            ));
        }
        Some(_) => {}
        None => {
            let name = match recorded.sensor {
                0 => SensorName::Sick,
                1 => SensorName::Ld06,
                2 => SensorName::Rplidar,
                _ => SensorName::Ydlidar,
            };
            let mut spec = SensorSpec::of(name);
            spec.mode = recorded.mode;
            if let Some(setup) = steps.setup() {
                spec.field_deg = setup.field_deg;
                spec.resolution_cdeg = setup.resolution_cdeg;
                if name == SensorName::Sick {
                    spec.mode = setup.measuring_mode;
                }
            }
            rig.sensor = Some(spec);
        }
    }
    let (setup, sensor) = recording_setup(&rig).map_err(|e| format!("{}: {e}", path.display()))?;
    if sensor != recorded {
        return Err(format!(
            "{}: the rig's sensor mode {} is not the recording's ({})",
            path.display(),
            sensor.mode,
            recorded.mode
        ));
    }
    for step in &mut steps.steps {
        if let Step::Setup(s) = step {
            *s = setup;
        }
    }
    Ok(())
}

/// Runs `pyramid run`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(json) => {
            if args.summary.json {
                crate::outln!("{json}");
            } else {
                eprintln!("maps written to {}", args.summary.out.display());
            }
            ExitCode::SUCCESS
        }
        Err((code, message)) => {
            eprintln!("{message}");
            ExitCode::from(code)
        }
    }
}
