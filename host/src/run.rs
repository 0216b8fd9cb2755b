//! `pyramid run`: a recording through the co-processor's pipeline, and the maps it builds.
//!
//! With `--board host` the library's pipeline runs in this process exactly as the firmware
//! runs it (the same `DefaultFrontend` and `DefaultPyramid`): the recording's laser bytes go
//! through the SICK accumulator, each valid measured-values telegram through
//! `Frontend::line`, and the actuator angles and poses are handed in as they come.

use crate::design::DesignArgs;
use crate::export::{write_maps, MapSnapshot};
use crate::replay::ClampArg;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{Payload, Reader};
use terrain_pyramid::wire::sick::{MeasuredValues, SickAccumulator, SickItem};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Clamp, Config, DefaultDesign, DefaultFrontend, DefaultPyramid, Meters, DEFAULT_CELLS_PER_SIDE,
};

/// Where the pipeline runs.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Board {
    /// In this process, with the library compiled for the host.
    Host,
    /// The firmware on QEMU's MPS2 AN386 (`boards/qemu-mps2`), telegrams on UART0, the host
    /// link on UART1.
    Qemu,
}

impl Board {
    /// The board's name in summaries.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Host => "host",
            Self::Qemu => "qemu",
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
    /// The directory the maps, the picture and `summary.json` are written into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// The pyramid's design, as for `pyramid design` (the window is the firmware's: 64).
    #[command(flatten)]
    pub design: DesignArgs,
    /// Clamping of the stored log-odds.
    #[arg(long, value_enum, default_value_t = ClampArg::Octomap)]
    pub clamp: ClampArg,
    /// Returns higher than this above the robot's ground plane are overhang, metres.
    #[arg(long, value_name = "M")]
    pub ceiling_m: Option<f64>,
    /// Returns this far below the robot's ground plane mark a drop-off, metres.
    #[arg(long, value_name = "M")]
    pub drop_m: Option<f64>,
}

/// What a run did, beyond the maps.
#[derive(Serialize, Debug, Default, Clone, PartialEq, Eq)]
pub struct RunCounts {
    /// Valid measured-values telegrams in the recording's laser bytes.
    pub telegrams_sent: u64,
    /// Telegrams the pipeline applied.
    pub telegrams_applied: u64,
    /// Link frames received from the board (0 in-process).
    pub frames_received: u64,
    /// Link frames with a bad checksum (0 in-process).
    pub link_crc_errors: u64,
    /// Telegrams the SICK accumulator rejected (CRC, length, truncation).
    pub telegrams_rejected: u64,
    /// Lines the pipeline refused (a count that does not fit the variant).
    pub lines_rejected: u64,
    /// Poses refused (not finite or out of range).
    pub poses_rejected: u64,
    /// Observations applied.
    pub observations: u64,
    /// Points the classifier could not hold (its scratch was full).
    pub overflow_points: u64,
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
    stack_bytes: Option<u32>,
) -> Result<String, String> {
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
        crate::design::sensor_model(&args.design),
        crate::design::schedule(&args.design),
        args.design.cells,
    )
    .map_err(|e| (2, format!("error: {e}")))?;
    if design.cells_per_side() != DEFAULT_CELLS_PER_SIDE {
        return Err((
            2,
            format!("error: --cells: the firmware's pyramid has {DEFAULT_CELLS_PER_SIDE} cells per side"),
        ));
    }
    let config = Config {
        clamp: match args.clamp {
            ClampArg::Off => Clamp::Off,
            ClampArg::Octomap => Clamp::OCTOMAP,
        },
        ..Config::default()
    };
    let classifier = ClassifierConfig {
        ceiling: args.ceiling_m.map(Meters::saturating_from_num),
        drop_threshold: args.drop_m.map(Meters::saturating_from_num),
        ..ClassifierConfig::default()
    };
    Ok((design, config, classifier))
}

/// The pipeline's configuration from a recording's setup (the library's own conversion).
///
/// # Errors
/// The setup names a variant, mode or position the library does not take.
pub fn frontend_config(
    setup: &Setup,
    classifier: ClassifierConfig,
) -> Result<FrontendConfig, String> {
    FrontendConfig::from_setup(setup, classifier).map_err(|e| format!("the recording's setup: {e}"))
}

/// Plays `data` (a whole recording) through the pipeline into `pyramid`.
///
/// # Errors
/// A recording that cannot be read, or laser bytes before the setup.
pub fn play(
    data: &[u8],
    pyramid: &mut DefaultPyramid,
    classifier: ClassifierConfig,
) -> Result<(RunCounts, (f64, f64)), String> {
    let reader = Reader::new(data).map_err(|e| format!("the recording: {e}"))?;
    let mut frontend: Option<Box<DefaultFrontend>> = None;
    let mut accumulator: Box<SickAccumulator> = Box::new(SickAccumulator::new());
    let mut counts = RunCounts::default();
    let mut sensor_xy = (0.0, 0.0);
    for event in reader {
        let event = event.map_err(|e| format!("the recording: {e}"))?;
        match event.payload {
            Payload::Setup(setup) => {
                let config = FrontendConfig::from_setup(&setup, classifier)
                    .map_err(|e| format!("the recording's setup: {e}"))?;
                frontend = Some(Box::new(DefaultFrontend::new(config)));
            }
            Payload::Angle(turns) => {
                if let Some(f) = frontend.as_mut() {
                    f.set_actuator(FineAngle::from_bits(u32::from(turns) << 16));
                }
            }
            Payload::Pose([x, y, z, roll, pitch, yaw]) => {
                match Pose::from_f32(x, y, z, roll, pitch, yaw) {
                    Ok(pose) => {
                        sensor_xy = (f64::from(x), f64::from(y));
                        if let Some(f) = frontend.as_mut() {
                            f.set_pose(pose);
                        }
                    }
                    Err(_) => counts.poses_rejected += 1,
                }
            }
            Payload::Laser(bytes) => {
                let f = frontend
                    .as_mut()
                    .ok_or("the recording has laser bytes before its setup event")?;
                let mut rest = bytes;
                loop {
                    match accumulator.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: SickItem::Telegram(telegram),
                            remaining,
                            ..
                        } => {
                            if let Ok(values) = MeasuredValues::parse(&telegram) {
                                counts.telegrams_sent += 1;
                                if f.line(pyramid, &values).is_ok() {
                                    counts.telegrams_applied += 1;
                                } else {
                                    counts.lines_rejected += 1;
                                }
                            }
                            rest = remaining;
                        }
                        FeedResult::Rejected { remaining, .. } => {
                            counts.telegrams_rejected += 1;
                            rest = remaining;
                        }
                        other => rest = other.remaining(),
                    }
                }
            }
            Payload::Marker(_) | Payload::Unknown { .. } => {}
        }
    }
    if let Some(f) = frontend.as_mut() {
        f.end_observation(pyramid);
        counts.observations = u64::from(f.stats().observations);
        counts.overflow_points = u64::from(f.classifier_stats().overflow_points);
    }
    Ok((counts, sensor_xy))
}

fn run_host(args: &Args) -> Result<String, (u8, String)> {
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
    let mut pyramid = Box::new(DefaultPyramid::new());
    pyramid
        .configure(&design, &config)
        .map_err(|e| (2, format!("error: {e}")))?;
    let (counts, sensor_xy) =
        play(&data, &mut pyramid, classifier).map_err(|e| (1, format!("error: {e}")))?;
    let snapshot = MapSnapshot::from_pyramid(&pyramid, &design, &config, sensor_xy);
    let title = format!(
        "pyramid run --board host: {} ({} telegrams applied)",
        args.recording.display(),
        counts.telegrams_applied
    );
    write_outputs(&args.out, &snapshot, &title, &counts, Board::Host, None)
        .map_err(|e| (1, format!("error: {e}")))
}

/// Runs the pipeline on `args.board`; returns the summary's JSON.
///
/// # Errors
/// The exit status and the message.
pub fn execute(args: &Args) -> Result<String, (u8, String)> {
    match args.board {
        Board::Host => run_host(args),
        Board::Qemu => crate::qemu::run_qemu(args).map(|(json, _)| json),
    }
}

/// Runs `pyramid run`.
pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(json) => {
            if args.json {
                println!("{json}");
            } else {
                eprintln!("maps written to {}", args.out.display());
            }
            ExitCode::SUCCESS
        }
        Err((code, message)) => {
            eprintln!("{message}");
            ExitCode::from(code)
        }
    }
}
