//! What the emulated-board tests share: where the tool and the data are, whether QEMU can
//! run, scratch directories, and a small synthetic recording written with the library's
//! recording writer.
#![allow(dead_code)] // Each test crate uses its own part.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{emit_header, Event, MountKind, Payload};
use terrain_pyramid::wire::sick::{MeasuredValues, Unit};

pub const PYRAMID: &str = env!("CARGO_BIN_EXE_pyramid");
const SHARED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data");

/// The shared data directory: `PYRAMID_SHARED_DATA` if set, else `../shared/data` beside the
/// workspace.
pub fn shared(file: &str) -> PathBuf {
    let dir = std::env::var_os("PYRAMID_SHARED_DATA")
        .map_or_else(|| PathBuf::from(SHARED), PathBuf::from);
    dir.join("3dtk-tilt-scan").join(file)
}

pub fn skip_qemu() -> bool {
    std::env::var("PYRAMID_SKIP_QEMU").is_ok_and(|v| v == "1")
}

pub fn qemu_ready() -> bool {
    let qemu = Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        qemu || skip_qemu(),
        "qemu-system-arm is missing: `sudo apt-get install -y qemu-system-arm` and \
         `rustup target add thumbv7em-none-eabihf` (or set PYRAMID_SKIP_QEMU=1 to skip)"
    );
    qemu
}

/// A fresh directory; under `PYRAMID_QEMU_OUT` when set (and then kept).
pub fn tmp(name: &str) -> PathBuf {
    let dir = match std::env::var_os("PYRAMID_QEMU_OUT") {
        Some(base) => PathBuf::from(base).join(name),
        None => {
            std::env::temp_dir().join(format!("pyramid-run-qemu-{}-{name}", std::process::id()))
        }
    };
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The 3DTK scan of `../shared/data` as a recording in `dir` (`pyramid record-3dtk`), or
/// `None` (with a note) when the scan is absent.
pub fn record_3dtk(dir: &Path) -> Option<PathBuf> {
    let (scan, pose) = (shared("scan000.3d"), shared("scan000.pose"));
    if !scan.is_file() || !pose.is_file() {
        eprintln!(
            "note: {} is absent: the 3DTK comparison is skipped",
            scan.display()
        );
        return None;
    }
    let recording = dir.join("scan000.rec");
    let status = Command::new(PYRAMID)
        .arg("record-3dtk")
        .arg(&scan)
        .arg("--pose")
        .arg(&pose)
        .arg("--out")
        .arg(&recording)
        .status()
        .unwrap();
    assert!(status.success());
    Some(recording)
}

/// A SICK at 0.5 m on a tilt unit over flat floor with a wall 2 m ahead, 40 lines of one
/// sweep, two poses: written with the library's recording writer.
pub fn synthetic_recording(path: &Path) {
    let mut file = vec![0_u8; 16];
    emit_header(&mut file).unwrap();
    let mut clock = 0_u64;
    let mut push = |payload: Payload<'_>, _time_us: u64| {
        clock += 1000;
        let event = Event {
            time_us: clock,
            payload,
        };
        let mut buf = vec![0_u8; event.buffer_len()];
        let n = event.emit(&mut buf).unwrap();
        file.extend_from_slice(&buf[..n]);
    };
    push(
        Payload::Setup(Setup {
            mount: MountKind::TiltedHorizontal,
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: [0.1, 0.0, 0.5],
            lines_per_observation: 20,
        }),
        0,
    );
    push(Payload::Pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), 1);
    for line in 0..40_u32 {
        let tilt_deg = 5.0 + f64::from(line);
        if line == 20 {
            push(
                Payload::Pose([0.35, 0.1, 0.0, 0.0, 0.0, 0.2]),
                2 + u64::from(line),
            );
        }
        let turns = (tilt_deg / 360.0 * 65_536.0).round() as u16;
        push(Payload::Angle(turns), 10 + u64::from(line) * 1000);
        let tau = tilt_deg.to_radians();
        let mut values = Vec::new();
        for i in 0..361 {
            let theta = (f64::from(i) * 0.5).to_radians();
            let (dx, dz) = (theta.sin() * tau.cos(), -theta.sin() * tau.sin());
            let floor = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
            let wall = if dx > 1e-6 { 2.0 / dx } else { f64::INFINITY };
            let r = floor.min(wall);
            let raw: u16 = if r < 8.0 {
                (r * 1000.0).round() as u16
            } else {
                0x1FFF
            };
            values.extend_from_slice(&raw.to_le_bytes());
        }
        let measured = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10).unwrap();
        let mut telegram = vec![0_u8; measured.buffer_len()];
        let n = measured.emit(&mut telegram).unwrap();
        // Cut in two chunks, as a UART delivers them.
        let (a, b) = telegram[..n].split_at(n / 3);
        push(Payload::Laser(a), 20 + u64::from(line) * 1000);
        push(Payload::Laser(b), 21 + u64::from(line) * 1000);
    }
    std::fs::write(path, file).unwrap();
}

/// Runs the `pyramid` tool with `args`; what it printed and its status.
pub fn pyramid(args: &[&str]) -> Output {
    Command::new(PYRAMID).args(args).output().unwrap()
}

/// Runs `pyramid COMMAND --json ARGS`, checks that it succeeded and printed one JSON object;
/// the object, and stdout as printed.
pub fn json_object(command: &str, args: &[&str]) -> (serde_json::Value, String) {
    let mut all = vec![command, "--json"];
    all.extend_from_slice(args);
    let out = pyramid(&all);
    assert!(
        out.status.success(),
        "pyramid {all:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).expect("UTF-8 output");
    let value: serde_json::Value =
        serde_json::from_str(stdout.trim()).expect("stdout is one JSON value");
    assert!(value.is_object(), "the JSON is an object: {stdout}");
    (value, stdout)
}

/// Runs `command` to its end and returns what it printed; fails the test, with `what_failed`
/// followed by the command's stderr, when it does not exit successfully.
pub fn succeeded(command: &mut Command, what_failed: &str) -> Output {
    let output = command.output().unwrap();
    assert!(
        output.status.success(),
        "{what_failed}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// Writes `bytes` to a fresh file in the system's temporary directory
/// (`pyramid-WHAT-TAG-PID-NANOS.bin`); its path.
pub fn temp_file(what: &str, tag: &str, bytes: &[u8]) -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let path = std::env::temp_dir().join(format!(
        "pyramid-{what}-{tag}-{}-{nanos}.bin",
        std::process::id()
    ));
    std::fs::write(&path, bytes).unwrap();
    path
}
