//! `pyramid record-3dtk`: a structured 3DTK tilt scan turned into a recording of real SICK
//! LMS2xx telegrams and tilt angles (`docs/recording.md`).
//!
//! The scan's lines (226 of 360 beams at 0.5° in `scan000.3d`) become B0 telegrams of 361
//! values in millimetres (the 32 m measuring mode, mask 0x7FFF, whose no-echo value 32767 mm
//! is what the file records), one per line, each preceded by its tilt angle. The 361st beam,
//! which the file drops, is sent as no echo. For every point the beam angle θ and the tilt τ
//! are recovered from its coordinates: in the file's frame (x right, y up, z forward)
//! `x = r cos θ`, `y = −r sin θ sin τ`, `z = r sin θ cos τ`; a line's tilt is the median of
//! its points' τ, and the largest deviation of θ from `i · 0.5°` is reported as a check.

use crate::uos::{parse_pose, UosReader};
use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;
use std::process::ExitCode;
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{emit_header, Event, MountKind, Payload};
use terrain_pyramid::wire::sick::{MeasuredValues, Unit};

/// Values of a 180°/0.5° line.
const VALUES_PER_LINE: usize = 361;
/// The 32 m measuring mode's no-echo value, mm.
const NO_ECHO_MM: u16 = 0x7FFF;
/// The 0x77 mode number written in the setup: 0x05, the 32 m mode (mask 0x7FFF).
const MEASURING_MODE: u8 = 0x05;
/// A point this far from the sensor is the no-echo value (see `pyramid replay`).
const NO_ECHO_CM: f64 = 3270.0;
/// The scanner's line period at 0.5° (37.5 lines per second), microseconds.
const LINE_PERIOD_US: u64 = 26_667;

/// Arguments of `pyramid record-3dtk`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The structured tilt scan, 3DTK `uos` format (`x y z` in cm per line).
    #[arg(value_name = "FILE.3d")]
    pub points: PathBuf,
    /// The scan's pose file (translation in cm; the rotation must be zero).
    #[arg(long, value_name = "FILE.pose")]
    pub pose: Option<PathBuf>,
    /// The recording to write.
    #[arg(long, value_name = "FILE.rec")]
    pub out: PathBuf,
    /// Beams per line in the file.
    #[arg(long, default_value_t = 360)]
    pub beams_per_line: usize,
    /// The sensor's height above the floor, metres (the robot's ground plane lies this far
    /// below the scan's origin). The floor of `scan000.3d` is about 0.4 m below its sensor.
    #[arg(long, value_name = "M", default_value_t = 0.4)]
    pub sensor_height_m: f64,
    /// Print what was written as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// What the conversion produced.
#[derive(serde::Serialize, Debug)]
pub struct Report {
    /// Scan lines read.
    pub lines: usize,
    /// Telegrams written.
    pub telegrams: usize,
    /// Points read.
    pub points: usize,
    /// Points without echo.
    pub no_echo: usize,
    /// Bytes of the recording.
    pub bytes: usize,
    /// The smallest and largest tilt, degrees.
    pub tilt_deg: [f64; 2],
    /// The largest deviation of a beam's angle from `i · 0.5°`, degrees.
    pub max_beam_angle_error_deg: f64,
    /// The recording written.
    pub out: PathBuf,
}

/// Runs `pyramid record-3dtk`.
pub fn run(args: &Args) -> ExitCode {
    match convert(args) {
        Ok(report) => {
            if args.json {
                crate::outln!("{}", serde_json::to_string(&report).unwrap_or_default());
            } else {
                crate::outln!(
                    "{}: {} lines, {} telegrams, {} points ({} without echo), tilt {:.2}° .. {:.2}°, beam angles within {:.3}° of i·0.5°, {} bytes",
                    report.out.display(),
                    report.lines,
                    report.telegrams,
                    report.points,
                    report.no_echo,
                    report.tilt_deg[0],
                    report.tilt_deg[1],
                    report.max_beam_angle_error_deg,
                    report.bytes
                );
            }
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
    }
}

/// Converts the scan of `args` and writes the recording; prints nothing.
///
/// # Errors
/// Invalid flags, a file that cannot be read or parsed, or the recording not written.
pub fn convert(args: &Args) -> Result<Report, String> {
    if args.beams_per_line == 0 || args.beams_per_line > VALUES_PER_LINE {
        return Err(format!(
            "--beams-per-line: must be 1 ..= {VALUES_PER_LINE} (got {})",
            args.beams_per_line
        ));
    }
    if !args.sensor_height_m.is_finite() || args.sensor_height_m <= 0.0 {
        return Err("--sensor-height-m: must be a positive number".into());
    }
    let translation = match &args.pose {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| format!("cannot read the pose file {}: {e}", path.display()))?;
            let pose = parse_pose(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            if pose.rotation_deg.iter().any(|r| *r != 0.0) {
                return Err(format!(
                    "{}: a rotated pose is not supported (rotation {:?} degrees)",
                    path.display(),
                    pose.rotation_deg
                ));
            }
            let [x, y, z] = pose.translation_cm;
            [z / 100.0, -x / 100.0, y / 100.0]
        }
        None => [0.0; 3],
    };
    let file = File::open(&args.points).map_err(|e| {
        format!(
            "cannot read the point file {}: {e} (the real data lives in ../shared/data)",
            args.points.display()
        )
    })?;
    let mut points = Vec::new();
    for p in UosReader::new(BufReader::new(file)) {
        let p = p.map_err(|e| format!("{}: {e}", args.points.display()))?;
        points.push([p.x, p.y, p.z]);
    }
    if points.is_empty() || points.len() % args.beams_per_line != 0 {
        return Err(format!(
            "{}: {} points do not make whole lines of {} beams",
            args.points.display(),
            points.len(),
            args.beams_per_line
        ));
    }

    let mut out = vec![0_u8; 16];
    emit_header(&mut out).map_err(|e| e.to_string())?;
    let push = |out: &mut Vec<u8>, event: Event<'_>| -> Result<(), String> {
        let start = out.len();
        out.resize(start + event.buffer_len(), 0);
        event
            .emit(&mut out[start..])
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    #[allow(clippy::cast_possible_truncation)]
    let setup = Setup {
        mount: MountKind::TiltedHorizontal,
        measuring_mode: MEASURING_MODE,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.0, 0.0, args.sensor_height_m as f32],
        lines_per_observation: u32::try_from(points.len() / args.beams_per_line).unwrap_or(0),
    };
    push(
        &mut out,
        Event {
            time_us: 0,
            payload: Payload::Setup(setup),
        },
    )?;
    #[allow(clippy::cast_possible_truncation)]
    let pose = [
        translation[0] as f32,
        translation[1] as f32,
        (translation[2] - args.sensor_height_m) as f32,
        0.0,
        0.0,
        0.0,
    ];
    push(
        &mut out,
        Event {
            time_us: 0,
            payload: Payload::Pose(pose),
        },
    )?;

    let (mut no_echo, mut tilt_min, mut tilt_max, mut theta_error) =
        (0, f64::INFINITY, f64::NEG_INFINITY, 0.0_f64);
    let mut telegram = vec![0_u8; 6 + 4 + 2 * VALUES_PER_LINE];
    let lines = points.len() / args.beams_per_line;
    for (k, line) in points.chunks(args.beams_per_line).enumerate() {
        let mut values = Vec::with_capacity(2 * VALUES_PER_LINE);
        let mut taus = Vec::new();
        for (i, &[x, y, z]) in line.iter().enumerate() {
            let r_cm = (x * x + y * y + z * z).sqrt();
            if r_cm >= NO_ECHO_CM {
                no_echo += 1;
                values.extend_from_slice(&NO_ECHO_MM.to_le_bytes());
                continue;
            }
            let lateral = y.hypot(z);
            if r_cm > 1.0 && lateral > 0.3 * r_cm {
                taus.push((-y).atan2(z));
                #[allow(clippy::cast_precision_loss)]
                let expected = (i as f64 * 0.5).to_radians();
                theta_error = theta_error.max((lateral.atan2(x) - expected).abs().to_degrees());
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let mm = (r_cm * 10.0).round().clamp(0.0, f64::from(NO_ECHO_MM - 1)) as u16;
            values.extend_from_slice(&mm.to_le_bytes());
        }
        while values.len() < 2 * VALUES_PER_LINE {
            no_echo += 1;
            values.extend_from_slice(&NO_ECHO_MM.to_le_bytes());
        }
        taus.sort_by(f64::total_cmp);
        let tau = taus.get(taus.len() / 2).copied().unwrap_or(0.0);
        tilt_min = tilt_min.min(tau.to_degrees());
        tilt_max = tilt_max.max(tau.to_degrees());
        let time_us = LINE_PERIOD_US * u64::try_from(k).unwrap_or(0);
        // A fraction of a turn, wrapping (negative tilts look up).
        #[allow(clippy::cast_possible_truncation)]
        let turn = (tau / std::f64::consts::TAU * 65_536.0).round() as i64;
        #[allow(clippy::cast_sign_loss, clippy::cast_possible_truncation)]
        let angle = turn.rem_euclid(65_536) as u16;
        push(
            &mut out,
            Event {
                time_us,
                payload: Payload::Angle(angle),
            },
        )?;
        let measured = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10)
            .map_err(|e| e.to_string())?;
        let n = measured.emit(&mut telegram).map_err(|e| e.to_string())?;
        push(
            &mut out,
            Event {
                time_us,
                payload: Payload::Laser(&telegram[..n]),
            },
        )?;
    }
    std::fs::write(&args.out, &out)
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    Ok(Report {
        lines,
        telegrams: lines,
        points: points.len(),
        no_echo,
        bytes: out.len(),
        tilt_deg: [tilt_min, tilt_max],
        max_beam_angle_error_deg: theta_error,
        out: args.out.clone(),
    })
}
