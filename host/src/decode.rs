//! `pyramid decode --sensor sick|ld06|rplidar|ydlidar FILE [--json]` (alias `sick-decode`,
//! SICK by default): decodes a captured laser byte stream.
//!
//! The file is fed through the library's decoder of that sensor exactly as the firmware feeds
//! UART chunks, then flushed. A damaged stream is not a failure: the command exits 0 and
//! reports the counts, and 1 only when the file cannot be read.
//!
//! - **SICK** (`--sensor sick`): every measured-values telegram (0xB0) that passes every check
//!   is listed with its ranges in millimetres; framing errors are counted. A well-framed 0xB0
//!   telegram whose fields do not parse (a unit code 10/11, a count that does not match LEN)
//!   is left out of the list and reported on stderr. Its JSON is
//!   `{"telegrams":[...],"errors":{"crc","length","truncated","garbage_bytes"}}`.
//! - **Spinning lidars**: one entry per packet whose check holds, in stream order (an RPLIDAR
//!   standard-scan node is a packet of one return; an express capsule is listed once the next
//!   capsule has placed its points), with its returns as the manual defines them: the angle
//!   in the sensor's own clockwise convention, degrees (LD06 `start + k·(end − start)/11`;
//!   RPLIDAR `angle_q6/64`, capsules by the SDK's formula; YDLIDAR `FSA + i·diff/(LSN − 1)`
//!   plus the X4/X2 second-level correction), printed to 6 decimals (the library's angle
//!   resolution is 8.4·10⁻⁸°); the range in millimetres, rounded, 0 where the sensor
//!   reports no return; the quality or intensity where the sensor has one, else null; and
//!   whether a revolution starts in it (an LD06 packet whose angles cross 0° or whose start
//!   lies below the previous packet's end, an RPLIDAR node's S flag or a capsule passing
//!   360°, the YDLIDAR zero packet). Every kind of framing error is counted under the
//!   accumulator's own name. Its JSON is
//!   `{"sensor":"ld06","packets":[{"returns":[{"angle_deg","range_mm","quality"}],"start_of_revolution"}],"errors":{...}}`.
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;
use terrain_pyramid::laser::{
    LaserCounters, LaserDecoder, LaserItem, Packet, RevolutionTracker, Sensor,
};
use terrain_pyramid::wire::rplidar::RplidarScanMode;
use terrain_pyramid::wire::sick::{
    MeasuredValues, MeasuringMode, SickCounters, Telegram, MEASURED_VALUES_REPLY,
};
use terrain_pyramid::wire::ydlidar::YdlidarAngleCorrection;
use terrain_pyramid::wire::FeedResult;

/// The laser whose stream a file holds.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorArg {
    /// SICK LMS2xx telegrams.
    Sick,
    /// LDROBOT LD06 / LD19 / STL-19P packets.
    Ld06,
    /// Slamtec RPLIDAR: nodes or express capsules, with or without the response descriptor.
    Rplidar,
    /// YDLIDAR X4 / X2 packets.
    Ydlidar,
}

/// What an RPLIDAR capture holds when it does not start with a response descriptor.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum RplidarModeArg {
    /// Standard-scan nodes (after SCAN).
    Standard,
    /// Legacy express-scan capsules (after EXPRESS_SCAN).
    Express,
}

/// Which YDLIDAR, for its angle correction.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum YdlidarModelArg {
    /// X4: the second-level correction of the X4 manual.
    X4,
    /// X2: the same second-level correction (the X2 manual gives the same formula).
    X2,
    /// Firmware that corrects its angles itself: the first-level angles alone.
    Uncorrected,
}

/// Arguments of `pyramid decode`.
#[derive(clap::Args)]
pub struct Args {
    /// The captured byte stream (raw bytes as read from the laser's serial port).
    pub file: PathBuf,
    /// The laser that sent it.
    #[arg(long, value_enum, default_value_t = SensorArg::Sick)]
    pub sensor: SensorArg,
    /// SICK: the measuring mode set with command 0x77 (decimal or 0x-hex): it decides the
    /// distance mask (0x00-0x02: 0x1FFF; 0x03, 0x04: 0x3FFF; 0x05, 0x06: 0x7FFF; 0x0F: 0xFFFF).
    #[arg(long, value_name = "N", default_value = "0", value_parser = parse_measuring_mode)]
    pub measuring_mode: MeasuringMode,
    /// RPLIDAR: what the capture holds when no response descriptor starts it (a descriptor,
    /// where there is one, decides).
    #[arg(long, value_enum, default_value_t = RplidarModeArg::Standard)]
    pub rplidar_mode: RplidarModeArg,
    /// YDLIDAR: the model, for the angle correction.
    #[arg(long, value_enum, default_value_t = YdlidarModelArg::X4)]
    pub ydlidar_model: YdlidarModelArg,
    /// Print one JSON object on stdout instead of a human summary.
    #[arg(long)]
    pub json: bool,
}

/// Reads a 0x77 mode number, decimal or `0x`-hex.
fn parse_measuring_mode(text: &str) -> Result<MeasuringMode, String> {
    let code = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u8::from_str_radix(hex, 16),
        None => text.parse::<u8>(),
    }
    .map_err(|e| format!("{text:?} is not a mode number 0..=255 (decimal or 0x-hex): {e}"))?;
    MeasuringMode::from_code(code).map_err(|e| e.to_string())
}

/// One decoded measured-values telegram.
#[derive(Serialize)]
struct TelegramOut {
    /// Byte offset of its STX in the file.
    offset: u64,
    /// The command byte, two lower-case hex digits ("b0").
    command: String,
    count: u16,
    /// "mm" or "cm".
    unit: &'static str,
    partial_index: u8,
    status: u8,
    /// Masked distance in millimetres (cm x 10); `null` for no echo.
    ranges_mm: Vec<Option<u32>>,
}

#[derive(Serialize)]
struct ErrorsOut {
    crc: u32,
    length: u32,
    truncated: u32,
    garbage_bytes: u32,
}

#[derive(Serialize)]
struct Output {
    telegrams: Vec<TelegramOut>,
    errors: ErrorsOut,
}

/// A well-framed 0xB0 telegram whose fields were refused.
struct Refused {
    offset: u64,
    reason: String,
}

/// One return of a lidar packet.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct ReturnOut {
    /// The angle in the sensor's clockwise convention, degrees in [0, 360), to 6 decimals.
    pub angle_deg: f64,
    /// The range, millimetres; 0 = no return.
    pub range_mm: u32,
    /// The quality or intensity, where the sensor has one.
    pub quality: Option<u8>,
}

/// One lidar packet whose check held.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct PacketOut {
    /// Its returns, in the order measured.
    pub returns: Vec<ReturnOut>,
    /// Whether a revolution starts in it.
    pub start_of_revolution: bool,
}

#[derive(Serialize)]
struct LidarOutput {
    sensor: &'static str,
    packets: Vec<PacketOut>,
    errors: BTreeMap<&'static str, u32>,
}

/// Runs `pyramid decode`.
pub fn run(args: &Args) -> ExitCode {
    let bytes = match std::fs::read(&args.file) {
        Ok(bytes) => bytes,
        Err(e) => {
            eprintln!("pyramid decode: cannot read {}: {e}", args.file.display());
            return ExitCode::FAILURE;
        }
    };
    let sensor = match args.sensor {
        SensorArg::Sick => return run_sick(args, &bytes),
        SensorArg::Ld06 => Sensor::Ld06,
        SensorArg::Rplidar => Sensor::Rplidar(match args.rplidar_mode {
            RplidarModeArg::Standard => RplidarScanMode::Standard,
            RplidarModeArg::Express => RplidarScanMode::Express,
        }),
        SensorArg::Ydlidar => Sensor::Ydlidar(match args.ydlidar_model {
            YdlidarModelArg::X4 | YdlidarModelArg::X2 => YdlidarAngleCorrection::SecondLevel,
            YdlidarModelArg::Uncorrected => YdlidarAngleCorrection::Off,
        }),
    };
    let (packets, counters) = decode_lidar(&bytes, sensor);
    let errors = error_counts(&counters);
    if args.json {
        let out = LidarOutput {
            sensor: sensor.kind().name(),
            packets,
            errors,
        };
        if !crate::json_line::print(&out, "pyramid decode: cannot write JSON: ") {
            return ExitCode::FAILURE;
        }
    } else {
        print_lidar_summary(sensor, &packets, &errors);
    }
    ExitCode::SUCCESS
}

/// A packet as [`PacketOut`].
fn packet_out(packet: &Packet<'_>, start_of_revolution: bool) -> PacketOut {
    PacketOut {
        returns: packet
            .returns()
            .map(|r| ReturnOut {
                angle_deg: degrees(r.angle.to_bits()),
                range_mm: r.range_mm,
                quality: r.quality,
            })
            .collect(),
        start_of_revolution,
    }
}

/// A Q0.32 fraction of a turn in degrees, rounded to 6 decimals (exact in f64: bits·360 <
/// 2⁴¹).
fn degrees(bits: u32) -> f64 {
    let exact = f64::from(bits) * 360.0 / 4_294_967_296.0;
    (exact * 1e6).round() / 1e6
}

/// Feeds all of `bytes` to a fresh decoder of `sensor` and flushes it, handing every unit
/// that passed its checks to `unit` with its stream offset (bytes from the start); returns
/// the decoder's counters.
fn decode_stream(
    bytes: &[u8],
    sensor: Sensor,
    mut unit: impl FnMut(LaserItem<'_>, u64),
) -> LaserCounters {
    let mut decoder = LaserDecoder::new(sensor);
    crate::play::each_unit(&mut decoder, bytes, &mut unit);
    loop {
        match decoder.flush() {
            FeedResult::Consumed => break,
            FeedResult::Item { item, offset, .. } => unit(item, offset),
            FeedResult::Rejected { .. } => {}
        }
    }
    decoder.counters()
}

/// Feeds the whole stream through the decoder of `sensor`, flushes it, and keeps every
/// packet whose check held.
#[must_use]
pub fn decode_lidar(bytes: &[u8], sensor: Sensor) -> (Vec<PacketOut>, LaserCounters) {
    let mut tracker = RevolutionTracker::new();
    let mut packets = Vec::new();
    let counters = decode_stream(bytes, sensor, |item, _| {
        if let LaserItem::Packet(p) = item {
            packets.push(packet_out(&p, tracker.starts(&p)));
        }
    });
    (packets, counters)
}

/// Every error counter of a lidar decoder, by the accumulator's own name.
fn error_counts(counters: &LaserCounters) -> BTreeMap<&'static str, u32> {
    // Every decoder counts the candidates cut off by the end of the stream and the bytes
    // between units; the rest are its own.
    let (own, truncated, garbage_bytes): (Vec<(&'static str, u32)>, u32, u32) = match *counters {
        LaserCounters::Sick(c) => (
            vec![("crc", c.crc_errors), ("length", c.length_errors)],
            c.truncated,
            c.garbage_bytes,
        ),
        LaserCounters::Ld06(c) => (vec![("checksum", c.checksum)], c.truncated, c.garbage_bytes),
        LaserCounters::Rplidar(c) => (
            vec![
                ("checksum", c.checksum),
                ("node_check", c.node_check),
                ("implausible", c.implausible),
                ("capsules_unpaired", c.capsules_unpaired),
                ("unsupported", c.unsupported),
            ],
            c.truncated,
            c.garbage_bytes,
        ),
        LaserCounters::Ydlidar(c) => (
            vec![
                ("checksum", c.checksum),
                ("check_bits", c.check_bits),
                ("bad_length", c.bad_length),
            ],
            c.truncated,
            c.garbage_bytes,
        ),
    };
    let pairs = own
        .into_iter()
        .chain([("truncated", truncated), ("garbage_bytes", garbage_bytes)]);
    pairs.into_iter().collect()
}

fn print_lidar_summary(sensor: Sensor, packets: &[PacketOut], errors: &BTreeMap<&str, u32>) {
    const SHOWN: usize = 3;
    for (i, p) in packets.iter().enumerate() {
        let first: Vec<String> = p
            .returns
            .iter()
            .take(SHOWN)
            .map(|r| format!("{:.4}° {} mm", r.angle_deg, r.range_mm))
            .collect();
        let more = if p.returns.len() > SHOWN { ", ..." } else { "" };
        crate::outln!(
            "packet {i:>6}: {:>3} returns{} [{}{}]",
            p.returns.len(),
            if p.start_of_revolution {
                ", revolution starts"
            } else {
                ""
            },
            first.join(", "),
            more
        );
    }
    let revolutions = packets.iter().filter(|p| p.start_of_revolution).count();
    let returns: usize = packets.iter().map(|p| p.returns.len()).sum();
    let errors: Vec<String> = errors.iter().map(|(k, v)| format!("{k} {v}")).collect();
    crate::outln!(
        "{} {} packets ({returns} returns, {revolutions} revolution starts); errors: {}",
        packets.len(),
        sensor.kind(),
        errors.join(", ")
    );
}

fn run_sick(args: &Args, bytes: &[u8]) -> ExitCode {
    let (telegrams, refused, stats) = decode(bytes, args.measuring_mode);
    for r in &refused {
        eprintln!(
            "pyramid decode: offset {}: measured-values telegram refused: {}",
            r.offset, r.reason
        );
    }
    if args.json {
        let out = Output {
            telegrams,
            errors: ErrorsOut {
                crc: stats.crc_errors,
                length: stats.length_errors,
                truncated: stats.truncated,
                garbage_bytes: stats.garbage_bytes,
            },
        };
        if !crate::json_line::print(&out, "pyramid decode: cannot write JSON: ") {
            return ExitCode::FAILURE;
        }
    } else {
        print_summary(&telegrams, refused.len(), &stats);
    }
    ExitCode::SUCCESS
}

/// Feeds the whole stream through the accumulator and keeps the measured-values telegrams.
fn decode(bytes: &[u8], mode: MeasuringMode) -> (Vec<TelegramOut>, Vec<Refused>, SickCounters) {
    let mut telegrams = Vec::new();
    let mut refused = Vec::new();
    let counters = decode_stream(bytes, Sensor::Sick, |item, offset| {
        if let LaserItem::Telegram(telegram) = item {
            keep(&telegram, offset, mode, &mut telegrams, &mut refused);
        }
    });
    (telegrams, refused, counters.sick().unwrap_or_default())
}

fn keep(
    telegram: &Telegram<&[u8]>,
    offset: u64,
    mode: MeasuringMode,
    telegrams: &mut Vec<TelegramOut>,
    refused: &mut Vec<Refused>,
) {
    if telegram.command() != MEASURED_VALUES_REPLY {
        return;
    }
    match MeasuredValues::parse(telegram) {
        Ok(m) => telegrams.push(TelegramOut {
            offset,
            command: format!("{:02x}", telegram.command()),
            count: m.count(),
            unit: m.unit().symbol(),
            partial_index: m.partial_index(),
            status: m.status(),
            ranges_mm: m.ranges_mm(mode).collect(),
        }),
        Err(e) => refused.push(Refused {
            offset,
            reason: e.to_string(),
        }),
    }
}

fn print_summary(telegrams: &[TelegramOut], refused: usize, stats: &SickCounters) {
    const SHOWN: usize = 5;
    for t in telegrams {
        let first: Vec<String> = t
            .ranges_mm
            .iter()
            .take(SHOWN)
            .map(|r| r.map_or_else(|| "-".to_owned(), |mm| mm.to_string()))
            .collect();
        let more = if t.ranges_mm.len() > SHOWN {
            ", ..."
        } else {
            ""
        };
        crate::outln!(
            "offset {:>8}: b0 count {:>3} unit {} partial {} status 0x{:02x} ranges_mm [{}{}]",
            t.offset,
            t.count,
            t.unit,
            t.partial_index,
            t.status,
            first.join(", "),
            more
        );
    }
    crate::outln!(
        "{} measured-values telegrams ({} telegrams ok in all, {} 0xB0 refused); \
         errors: crc {}, length {}, truncated {}, garbage bytes {}; ack {}, nak {}",
        telegrams.len(),
        stats.telegrams_ok,
        refused,
        stats.crc_errors,
        stats.length_errors,
        stats.truncated,
        stats.garbage_bytes,
        stats.ack,
        stats.nak
    );
}
