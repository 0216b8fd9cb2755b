//! `pyramid record`: a laser's bytes, as its UART delivers them, into a recording
//! (`docs/recording.md`) with the rig's sensor and mount, so that a user can play their own
//! robot's data through `pyramid run`.
//!
//! - `--port DEV`: the serial port the laser is wired to (8N1, raw, at the sensor's baud
//!   rate). Each read's bytes become one laser event stamped with the host's time of the
//!   read, microseconds since the first byte arrived.
//! - `--from FILE`: a raw byte capture instead, timed as the UART would have delivered it:
//!   byte k (from 0) is complete at `(k + 1) · 10 / baud` seconds (8N1: 10 bits a byte).
//! - `--angles FILE.csv`: the actuator's angle over time, `time_s,angle_deg` a line (seconds
//!   since the recording's start, on the recording's clock; degrees as the actuator reads
//!   them). Each becomes an actuator-angle event placed among the laser bytes by time: the
//!   bytes complete at or before the angle's time come before it, the rest after it.
//! - Ends at the end of `--from`'s file, after `--duration-s`, or on Ctrl-C (SIGTERM): the
//!   file is complete either way, every event written whole.

use crate::rigfile::{recording_setup, rig_event, RigArgs};
use serde::Serialize;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use terrain_pyramid::wire::recording::{emit_header, Event, Payload, HEADER_LEN, MAX_PAYLOAD};

/// Bytes a laser event of `--from` holds at most (events are split at angle times too).
const FROM_CHUNK: usize = 512;

/// How long one read of the serial port waits for bytes.
const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Arguments of `pyramid record`.
#[derive(clap::Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["port", "from"])))]
pub struct Args {
    /// The serial port the laser is wired to (8N1, raw).
    #[arg(long, value_name = "DEV")]
    pub port: Option<String>,
    /// A raw byte capture of the laser's UART instead of a port, timed at the baud rate.
    #[arg(long, value_name = "FILE")]
    pub from: Option<PathBuf>,
    /// The laser's baud rate [default: the rig's, else the sensor's: SICK 500000, LD06/LD19
    /// 230400, RPLIDAR 115200, YDLIDAR 128000].
    #[arg(long, value_name = "BD")]
    pub baud: Option<u32>,
    /// The actuator's angles: a CSV of `time_s,angle_deg` (seconds since the recording's
    /// start, degrees); an optional header line, `#` comments.
    #[arg(long, value_name = "FILE.csv")]
    pub angles: Option<PathBuf>,
    /// The recording to write.
    #[arg(long, value_name = "FILE.rec")]
    pub out: PathBuf,
    /// Stop after this many seconds of the recording's time.
    #[arg(long, value_name = "S")]
    pub duration_s: Option<f64>,
    /// Print what was written as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// The rig (sensor, mount, actuator, observation policy): `--rig FILE` and its flags.
    #[command(flatten)]
    pub rig: RigArgs,
}

/// What was recorded.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Report {
    /// The sensor's name.
    pub sensor: &'static str,
    /// The baud rate the bytes were read (or timed) at.
    pub baud: u32,
    /// Laser bytes recorded.
    pub laser_bytes: u64,
    /// Laser events written.
    pub laser_events: u64,
    /// Actuator-angle events written.
    pub angle_events: u64,
    /// Angles of the CSV after the last byte, not written (they would apply to nothing).
    pub angles_after_end: u64,
    /// The recording's time of its last event, seconds.
    pub duration_s: f64,
    /// Why it ended: `end of file`, `duration`, `interrupted`, `port closed`.
    pub ended: &'static str,
    /// Bytes of the recording.
    pub bytes: u64,
    /// The recording written.
    pub out: PathBuf,
}

/// One actuator angle of the CSV: the recording's time (µs) and the angle (2⁻¹⁶ turn).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AngleAt {
    /// Microseconds since the recording's start.
    pub time_us: u64,
    /// The angle, a fraction of a turn (value / 65 536 turns).
    pub turns: u16,
}

/// Degrees as the recording's angle: a fraction of a turn, wrapped to 0 ..= 65 535.
#[must_use]
pub fn turns_of_deg(deg: f64) -> u16 {
    let t = (deg / 360.0 * 65_536.0).round().rem_euclid(65_536.0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = t as u32;
    u16::try_from(v).unwrap_or(0)
}

/// Parses an angles CSV: `time_s,angle_deg` a line, times non-decreasing and ≥ 0; an
/// optional first line that is not numbers (a header), blank lines and `#` comments.
///
/// # Errors
/// A line that is not two numbers, a negative or decreasing time: named by its line.
pub fn parse_angles(path: &Path, text: &str) -> Result<Vec<AngleAt>, String> {
    let mut out: Vec<AngleAt> = Vec::new();
    let mut seen_data = false;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let numbers: Option<Vec<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
        let where_ = || format!("{}:{}", path.display(), i + 1);
        let Some(numbers) = numbers else {
            if !seen_data {
                seen_data = true; // the header
                continue;
            }
            return Err(format!("{}: {line:?} is not time_s,angle_deg", where_()));
        };
        seen_data = true;
        let &[t, deg] = numbers.as_slice() else {
            return Err(format!(
                "{}: {} values: needs time_s,angle_deg",
                where_(),
                numbers.len()
            ));
        };
        if !((0.0..1e9).contains(&t) && deg.is_finite()) {
            return Err(format!(
                "{}: time {t} s or angle {deg}° is not a finite time ≥ 0 and angle",
                where_()
            ));
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let time_us = (t * 1e6).round() as u64;
        if out.last().is_some_and(|p| time_us < p.time_us) {
            return Err(format!("{}: time {t} s goes backwards", where_()));
        }
        out.push(AngleAt {
            time_us,
            turns: turns_of_deg(deg),
        });
    }
    Ok(out)
}

/// Writes a recording's events as they come: laser bytes with their times and the angles
/// placed among them by time.
pub struct Recorder<W: Write> {
    out: W,
    angles: std::vec::IntoIter<AngleAt>,
    next_angle: Option<AngleAt>,
    last_us: u64,
    buf: Vec<u8>,
    /// What has been written.
    pub report: Report,
}

impl<W: Write> Recorder<W> {
    /// Starts a recording on `out`: the header, the setup and sensor events at time 0.
    ///
    /// # Errors
    /// The writer failed.
    pub fn start(
        mut out: W,
        setup: &[Event<'_>],
        angles: Vec<AngleAt>,
        report: Report,
    ) -> Result<Self, String> {
        let mut buf = vec![0_u8; HEADER_LEN.max(MAX_PAYLOAD + 64)];
        let mut bytes = 0_u64;
        let n = emit_header(&mut buf).map_err(|e| format!("{e:?}"))?;
        out.write_all(buf.get(..n).unwrap_or_default())
            .map_err(|e| e.to_string())?;
        bytes += n as u64;
        for event in setup {
            let n = event.emit(&mut buf).map_err(|e| format!("{e:?}"))?;
            out.write_all(buf.get(..n).unwrap_or_default())
                .map_err(|e| e.to_string())?;
            bytes += n as u64;
        }
        let mut angles = angles.into_iter();
        let next_angle = angles.next();
        Ok(Self {
            out,
            angles,
            next_angle,
            last_us: 0,
            buf,
            report: Report { bytes, ..report },
        })
    }

    fn emit(&mut self, event: &Event<'_>) -> Result<(), String> {
        let n = event.emit(&mut self.buf).map_err(|e| format!("{e:?}"))?;
        self.out
            .write_all(self.buf.get(..n).unwrap_or_default())
            .map_err(|e| format!("cannot write the recording: {e}"))?;
        self.report.bytes += n as u64;
        self.last_us = self.last_us.max(event.time_us);
        Ok(())
    }

    /// Writes the angles due at or before `time_us`.
    fn angles_until(&mut self, time_us: u64) -> Result<(), String> {
        while let Some(a) = self.next_angle.filter(|a| a.time_us <= time_us) {
            let at = a.time_us.max(self.last_us);
            self.emit(&Event {
                time_us: at,
                payload: Payload::Angle(a.turns),
            })?;
            self.report.angle_events += 1;
            self.next_angle = self.angles.next();
        }
        Ok(())
    }

    /// Writes laser bytes: byte k of `bytes` complete at `time_of(k)` µs (non-decreasing);
    /// the bytes are split where an angle falls between two of them, and into events of at
    /// most `chunk` bytes.
    ///
    /// # Errors
    /// The writer failed.
    pub fn laser(
        &mut self,
        bytes: &[u8],
        chunk: usize,
        time_of: impl Fn(usize) -> u64,
    ) -> Result<(), String> {
        let chunk = chunk.clamp(1, MAX_PAYLOAD);
        let mut start = 0;
        while start < bytes.len() {
            self.angles_until(time_of(start).saturating_sub(1))?;
            // The bytes up to the next angle's time (at most `chunk`).
            let limit = (start + chunk).min(bytes.len());
            let mut end = start + 1;
            while end < limit && self.next_angle.is_none_or(|a| time_of(end) <= a.time_us) {
                end += 1;
            }
            let time_us = time_of(end - 1).max(self.last_us);
            if let Some(part) = bytes.get(start..end) {
                self.emit(&Event {
                    time_us,
                    payload: Payload::Laser(part),
                })?;
                self.report.laser_events += 1;
                self.report.laser_bytes += part.len() as u64;
            }
            start = end;
        }
        Ok(())
    }

    /// Ends the recording: flushes the writer; the angles after the last byte are counted,
    /// not written.
    ///
    /// # Errors
    /// The writer failed.
    pub fn finish(mut self, ended: &'static str) -> Result<Report, String> {
        self.report.angles_after_end =
            u64::from(self.next_angle.is_some()) + self.angles.len() as u64;
        self.out
            .flush()
            .map_err(|e| format!("cannot write the recording: {e}"))?;
        #[allow(clippy::cast_precision_loss)]
        let duration = self.last_us as f64 / 1e6;
        self.report.duration_s = duration;
        self.report.ended = ended;
        Ok(self.report)
    }
}

/// The time byte `k` of a capture is complete at `baud` (8N1: 10 bits a byte), µs.
#[must_use]
pub fn byte_time_us(k: u64, baud: u32) -> u64 {
    (k + 1) * 10_000_000 / u64::from(baud.max(1))
}

/// Records as `args` says; the report.
///
/// # Errors
/// The exit status and the message.
pub fn execute(args: &Args, stop: &AtomicBool) -> Result<Report, (u8, String)> {
    let usage = |e: String| (2, format!("error: {e}"));
    let fail = |e: String| (1, format!("error: {e}"));
    let mut rig = args.rig.rig().map_err(usage)?;
    let Some(sensor) = rig.sensor.as_mut() else {
        return Err(usage(
            "the sensor is not named: --sensor S, or [sensor] kind in the rig file".into(),
        ));
    };
    if let Some(b) = args.baud {
        if !(9_600..=3_000_000).contains(&b) {
            return Err(usage(format!("--baud {b} is not in 9600 ..= 3000000")));
        }
        sensor.baud = b;
    }
    let sensor = *sensor;
    let baud = sensor.effective_baud();
    let (setup, sensor_event) = recording_setup(&rig).map_err(usage)?;
    let rig_event = rig_event(&rig).map_err(usage)?;
    if rig.actuator.servo.is_some() {
        // A recording carries the actuator's angles, not the servo's commanded sweep.
        eprintln!(
            "note: the rig's servo sweep is not recorded (a recording carries angles): {}",
            if args.angles.is_some() {
                "the angles come from --angles"
            } else {
                "without --angles the recording has no angles"
            }
        );
    }
    let duration_us = match args.duration_s {
        Some(s) if s.is_finite() && s > 0.0 && s < 1e9 => {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let us = (s * 1e6) as u64;
            Some(us)
        }
        Some(s) => return Err(usage(format!("--duration-s {s} is not a positive time"))),
        None => None,
    };
    let angles = match &args.angles {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| fail(format!("cannot read {}: {e}", path.display())))?;
            parse_angles(path, &text).map_err(usage)?
        }
        None => Vec::new(),
    };
    let capture = match &args.from {
        Some(path) => Some(
            std::fs::read(path)
                .map_err(|e| fail(format!("cannot read {}: {e}", path.display())))?,
        ),
        None => None,
    };
    let port = match &args.port {
        Some(path) => Some(crate::serial::open(path, baud, READ_TIMEOUT).map_err(fail)?),
        None => None,
    };
    let file = std::fs::File::create(&args.out)
        .map_err(|e| fail(format!("cannot create {}: {e}", args.out.display())))?;
    let report = Report {
        sensor: sensor.name.name(),
        baud,
        laser_bytes: 0,
        laser_events: 0,
        angle_events: 0,
        angles_after_end: 0,
        duration_s: 0.0,
        ended: "",
        bytes: 0,
        out: args.out.clone(),
    };
    let mut recorder = Recorder::start(
        BufWriter::new(file),
        &[
            Some(Event {
                time_us: 0,
                payload: Payload::Setup(setup),
            }),
            Some(Event {
                time_us: 0,
                payload: Payload::Sensor(sensor_event),
            }),
            rig_event.map(|rig| Event {
                time_us: 0,
                payload: Payload::Rig(rig),
            }),
        ]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>(),
        angles,
        report,
    )
    .map_err(fail)?;
    let ended = if let Some(bytes) = capture {
        let mut n = bytes.len();
        if let Some(limit) = duration_us {
            n = bytes
                .iter()
                .enumerate()
                .position(|(k, _)| byte_time_us(k as u64, baud) > limit)
                .unwrap_or(n);
        }
        let ended = if n < bytes.len() {
            "duration"
        } else {
            "end of file"
        };
        recorder
            .laser(bytes.get(..n).unwrap_or_default(), FROM_CHUNK, |k| {
                byte_time_us(k as u64, baud)
            })
            .map_err(fail)?;
        ended
    } else if let Some(mut port) = port {
        let mut buf = vec![0_u8; MAX_PAYLOAD];
        let mut start: Option<Instant> = None;
        loop {
            if stop.load(Ordering::SeqCst) {
                break "interrupted";
            }
            if let (Some(s), Some(limit)) = (start, duration_us) {
                if s.elapsed() >= Duration::from_micros(limit) {
                    break "duration";
                }
            }
            match port.read(&mut buf) {
                Ok(0) => {}
                Ok(n) => {
                    let now = Instant::now();
                    let t0 = *start.get_or_insert(now);
                    #[allow(clippy::cast_possible_truncation)]
                    let t = now.duration_since(t0).as_micros() as u64;
                    recorder
                        .laser(buf.get(..n).unwrap_or_default(), MAX_PAYLOAD, |_| t)
                        .map_err(fail)?;
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(_) => break "port closed",
            }
        }
    } else {
        return Err(usage("give --port DEV or --from FILE".into()));
    };
    recorder.finish(ended).map_err(fail)
}

/// Runs `pyramid record`.
pub fn run(args: &Args) -> ExitCode {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    if let Err(e) = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    }) {
        eprintln!("warning: cannot catch Ctrl-C ({e}); use --duration-s to end the recording");
    }
    if args.port.is_some() {
        eprintln!("recording; Ctrl-C ends it (the file stays complete)");
    }
    match execute(args, &stop) {
        Ok(report) => {
            if args.json {
                if !crate::json_line::print(&report, "error: ") {
                    return ExitCode::FAILURE;
                }
            } else {
                eprintln!(
                    "{} bytes of {} at {} Bd in {} laser events, {} angles, {:.3} s ({}): {}",
                    report.laser_bytes,
                    report.sensor,
                    report.baud,
                    report.laser_events,
                    report.angle_events,
                    report.duration_s,
                    report.ended,
                    report.out.display()
                );
            }
            ExitCode::SUCCESS
        }
        Err((code, message)) => {
            eprintln!("{message}");
            ExitCode::from(code)
        }
    }
}
