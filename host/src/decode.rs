//! `pyramid sick-decode`: decodes a captured SICK LMS2xx byte stream.
//!
//! The file is fed through the library's [`SickAccumulator`] exactly as the firmware feeds UART
//! chunks, then flushed. Every measured-values telegram (0xB0) that passes every check is
//! listed with its ranges in millimetres; framing errors are counted. A damaged stream is not
//! a failure: the command exits 0 and reports the counts, and 1 only when the file cannot be
//! read. A well-framed 0xB0 telegram whose fields do not parse (a unit code 10/11, a count
//! that does not match LEN) is left out of the list and reported on stderr.
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;
use terrain_pyramid::wire::sick::{
    MeasuredValues, MeasuringMode, SickAccumulator, SickCounters, SickItem, Telegram,
    MEASURED_VALUES_REPLY,
};
use terrain_pyramid::wire::FeedResult;

/// Arguments of `pyramid sick-decode`.
#[derive(clap::Args)]
pub struct Args {
    /// The captured byte stream (raw bytes as read from the scanner's serial port).
    pub file: PathBuf,
    /// The measuring mode set with command 0x77 (decimal or 0x-hex): it decides the distance
    /// mask (0x00-0x02: 0x1FFF; 0x03, 0x04: 0x3FFF; 0x05, 0x06: 0x7FFF; 0x0F: 0xFFFF).
    #[arg(long, value_name = "N", default_value = "0", value_parser = parse_measuring_mode)]
    pub measuring_mode: MeasuringMode,
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

/// Runs `pyramid sick-decode`.
pub fn run(args: &Args) -> ExitCode {
    let bytes = match std::fs::read(&args.file) {
        Ok(bytes) => bytes,
        Err(e) => {
            eprintln!(
                "pyramid sick-decode: cannot read {}: {e}",
                args.file.display()
            );
            return ExitCode::FAILURE;
        }
    };
    let (telegrams, refused, stats) = decode(&bytes, args.measuring_mode);
    for r in &refused {
        eprintln!(
            "pyramid sick-decode: offset {}: measured-values telegram refused: {}",
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
        match serde_json::to_string(&out) {
            Ok(json) => println!("{json}"),
            Err(e) => {
                eprintln!("pyramid sick-decode: cannot write JSON: {e}");
                return ExitCode::FAILURE;
            }
        }
    } else {
        print_summary(&telegrams, refused.len(), &stats);
    }
    ExitCode::SUCCESS
}

/// Feeds the whole stream through the accumulator and keeps the measured-values telegrams.
fn decode(bytes: &[u8], mode: MeasuringMode) -> (Vec<TelegramOut>, Vec<Refused>, SickCounters) {
    let mut acc: SickAccumulator = SickAccumulator::new();
    let mut telegrams = Vec::new();
    let mut refused = Vec::new();
    let mut window = bytes;
    loop {
        let result = acc.feed(window);
        window = result.remaining();
        match result {
            FeedResult::Consumed => break,
            FeedResult::Item {
                item: SickItem::Telegram(telegram),
                offset,
                ..
            } => keep(&telegram, offset, mode, &mut telegrams, &mut refused),
            _ => {}
        }
    }
    loop {
        match acc.flush() {
            FeedResult::Consumed => break,
            FeedResult::Item {
                item: SickItem::Telegram(telegram),
                offset,
                ..
            } => keep(&telegram, offset, mode, &mut telegrams, &mut refused),
            _ => {}
        }
    }
    (telegrams, refused, acc.stats())
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
        println!(
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
    println!(
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
