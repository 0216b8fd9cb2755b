//! `pyramid record`: a laser's raw bytes and an angles CSV become a recording that plays to
//! the same maps as the recording the bytes came from (a user can replay their own robot's
//! data), and a serial port (a pseudo-terminal pair, no hardware) is recorded byte for byte.
mod common;

use common::{tmp, PYRAMID};
use serialport::{SerialPort, TTYPort};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use terrain_pyramid::wire::recording::{Payload, Reader, HEADER_LEN};

/// The laser bytes of a recording, concatenated, and each angle with the number of laser
/// bytes before it.
fn split(recording: &[u8]) -> (Vec<u8>, Vec<(usize, u16)>) {
    let mut bytes = Vec::new();
    let mut angles = Vec::new();
    for event in Reader::new(recording).unwrap() {
        match event.unwrap().payload {
            Payload::Laser(b) => bytes.extend_from_slice(b),
            Payload::Angle(a) => angles.push((bytes.len(), a)),
            Payload::Pose(_) => panic!("the source recording has a pose"),
            _ => {}
        }
    }
    (bytes, angles)
}

fn run_host(recording: &Path, out: &Path) -> serde_json::Value {
    let o = Command::new(PYRAMID)
        .args(["run", "--board", "host", "--json", "--recording"])
        .arg(recording)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The shared 3DTK scan (`scan000.3d`), or `None`, said on stderr, when it is absent (the
/// comparison is then skipped).
fn shared_scan() -> Option<PathBuf> {
    let scan = common::shared("scan000.3d");
    if scan.is_file() {
        Some(scan)
    } else {
        eprintln!(
            "note: {} is absent: the comparison is skipped",
            scan.display()
        );
        None
    }
}

/// A pseudo-terminal pair, no hardware: the side the test writes to, and the name of the
/// other side (closed here) that `pyramid record --port` opens.
fn pseudo_terminal() -> (TTYPort, String) {
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let name = slave.name().expect("the pair's name");
    drop(slave);
    (master, name)
}

/// Runs `pyramid record ARGS` on the raw capture `dir/capture.bin` with the angles CSV and
/// the recording written, `(angles, out)`, both in `dir`; what it printed and its status.
fn record_capture(args: &[&str], dir: &Path, (angles, out): (&str, &str)) -> Output {
    Command::new(PYRAMID)
        .arg("record")
        .args(args)
        .arg("--from")
        .arg(dir.join("capture.bin"))
        .arg("--angles")
        .arg(dir.join(angles))
        .arg("--out")
        .arg(dir.join(out))
        .output()
        .unwrap()
}

/// `pyramid record` of a serial port, running: the port's other side, the process (its stdout,
/// the JSON report, piped), and the recording it writes.
struct PortRecording {
    /// The side of the pseudo-terminal the test writes to; open until the test ends.
    _master: TTYPort,
    child: Child,
    dir: PathBuf,
    out: PathBuf,
}

/// Starts `pyramid record --json ARGS --port PTY --out NAME/port.rec` on a fresh
/// pseudo-terminal and, once it has had time to open the port (0.7 s), writes `sent` to it in
/// parts of `part_len` bytes, each flushed, `pause_ms` ms apart.
fn record_port(
    name: &str,
    args: &[&str],
    sent: &[u8],
    (part_len, pause_ms): (usize, u64),
) -> PortRecording {
    let (mut master, port) = pseudo_terminal();
    let dir = tmp(name);
    let out = dir.join("port.rec");
    let child = Command::new(PYRAMID)
        .args(["record", "--json"])
        .args(args)
        .args(["--port", &port])
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    for part in sent.chunks(part_len) {
        master.write_all(part).unwrap();
        master.flush().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(pause_ms));
    }
    PortRecording {
        _master: master,
        child,
        dir,
        out,
    }
}

#[test]
fn a_raw_capture_and_its_angles_replay_to_the_original_maps() {
    let Some(scan) = shared_scan() else {
        return;
    };
    let dir = tmp("record-from");
    // The 3DTK tilt scan as a recording of real SICK telegrams, from the shared data.
    let status = Command::new(PYRAMID)
        .arg("record-3dtk")
        .arg(&scan)
        .arg("--out")
        .arg(dir.join("original.rec"))
        .status()
        .unwrap();
    assert!(status.success());
    // Without its pose event (`record` writes no poses): the same telegrams and angles.
    let with_pose = std::fs::read(dir.join("original.rec")).unwrap();
    let mut original = with_pose[..HEADER_LEN].to_vec();
    let mut buf = vec![0_u8; 8192];
    for event in Reader::new(&with_pose).unwrap() {
        let event = event.unwrap();
        if !matches!(event.payload, Payload::Pose(_)) {
            let n = event.emit(&mut buf).unwrap();
            original.extend_from_slice(&buf[..n]);
        }
    }
    std::fs::write(dir.join("original.rec"), &original).unwrap();
    let setup = Reader::new(&original)
        .unwrap()
        .find_map(|e| match e.unwrap().payload {
            Payload::Setup(s) => Some(s),
            _ => None,
        })
        .unwrap();
    let (bytes, angles) = split(&original);
    assert!(angles.len() > 200, "{} angles", angles.len());
    std::fs::write(dir.join("capture.bin"), &bytes).unwrap();
    // The CSV a user's actuator log would be: each angle at the time its line's first byte
    // starts on a 500 kBd line (20 µs a byte), in degrees.
    let mut csv = String::from("time_s,angle_deg\n");
    for (offset, turns) in &angles {
        let t_us = *offset as u64 * 20;
        let deg = f64::from(*turns) * 360.0 / 65_536.0;
        csv.push_str(&format!("{:.6},{deg:.9}\n", t_us as f64 / 1e6));
    }
    std::fs::write(dir.join("angles.csv"), csv).unwrap();
    let [x, y, z] = setup.sensor_m;
    let o = record_capture(
        &[
            "--json",
            "--sensor",
            "sick",
            "--baud",
            "500000",
            "--sensor-mode",
            &setup.measuring_mode.to_string(),
            "--actuator",
            "tilt",
            "--mount-xyz-m",
            &format!("{x},{y},{z}"),
            "--lines-per-observation",
            &setup.lines_per_observation.to_string(),
        ],
        &dir,
        ("angles.csv", "mine.rec"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["laser_bytes"], bytes.len());
    assert_eq!(report["angle_events"], angles.len());
    assert_eq!(report["angles_after_end"], 0);
    // The new recording's bytes are the capture, its angles fall where the original's did.
    let mine = std::fs::read(dir.join("mine.rec")).unwrap();
    assert_eq!(split(&mine), (bytes.clone(), angles.clone()));
    // Its laser events are timed at the baud rate: the last byte complete at 20 µs · n.
    let last = Reader::new(&mine).unwrap().last().unwrap().unwrap();
    assert_eq!(last.time_us, 20 * bytes.len() as u64);
    let a = run_host(&dir.join("original.rec"), &dir.join("maps-original"));
    let b = run_host(&dir.join("mine.rec"), &dir.join("maps-mine"));
    assert!(a["telegrams_applied"].as_u64().unwrap() > 200, "{a}");
    assert_eq!(a["telegrams_applied"], b["telegrams_applied"]);
    assert_eq!(a["layers_hash"], b["layers_hash"]);
    let layers = a["layers"].as_array().unwrap().len();
    assert!(layers > 0);
    for k in 0..layers {
        let name = format!("cells-{k}.bin");
        let (ca, cb) = (
            std::fs::read(dir.join("maps-original").join(&name)).unwrap(),
            std::fs::read(dir.join("maps-mine").join(&name)).unwrap(),
        );
        assert_eq!(ca, cb, "layer {k}'s cells differ");
        assert!(ca.chunks(2).any(|c| c != [0, 0]), "layer {k} is empty");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_serial_port_is_recorded_byte_for_byte_with_host_times() {
    // Bytes that are not all a lidar's packets: the recording keeps them as they came.
    let sent: Vec<u8> = (0..3000_u32).map(|i| (i * 7 + i / 256) as u8).collect();
    let PortRecording {
        _master,
        child,
        dir,
        out,
    } = record_port(
        "record-port",
        &[
            "--sensor",
            "rplidar",
            "--actuator",
            "pan",
            "--duration-s",
            "2.5",
        ],
        &sent,
        (500, 100),
    );
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["ended"], "duration");
    assert_eq!(report["baud"], 115_200);
    let data = std::fs::read(&out).unwrap();
    let (bytes, angles) = split(&data);
    assert_eq!(bytes, sent);
    assert!(angles.is_empty());
    // Several reads, each stamped with its own host time, non-decreasing (the reader checks)
    // and spread over the writes' 0.5 s.
    let times: Vec<u64> = Reader::new(&data)
        .unwrap()
        .filter_map(|e| match e.unwrap() {
            e if matches!(e.payload, Payload::Laser(_)) => Some(e.time_us),
            _ => None,
        })
        .collect();
    assert!(times.len() >= 6, "{times:?}");
    assert!(
        times.last().unwrap() - times.first().unwrap() >= 400_000,
        "{times:?}"
    );
    let sensor = Reader::new(&data)
        .unwrap()
        .find_map(|e| match e.unwrap().payload {
            Payload::Sensor(s) => Some(s),
            _ => None,
        })
        .unwrap();
    assert_eq!(sensor.sensor, 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_angles_csv_is_named_by_its_line() {
    let dir = tmp("record-bad-csv");
    std::fs::write(dir.join("capture.bin"), [0_u8; 10]).unwrap();
    std::fs::write(dir.join("a.csv"), "time_s,angle_deg\n0.0,1\n0.5,2\n0.4,3\n").unwrap();
    let o = record_capture(&["--sensor", "ld19"], &dir, ("a.csv", "x.rec"));
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("a.csv:4") && stderr.contains("backwards"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_with_a_rig_file_takes_its_setup_over_the_recording_s() {
    if shared_scan().is_none() {
        return;
    }
    let dir = tmp("run-rig");
    let rec = common::record_3dtk(&dir).unwrap();
    let rig = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/rigs/sick-tilt.toml");
    let with = |rig: &Path, out: &str| {
        Command::new(PYRAMID)
            .args(["run", "--board", "host", "--json", "--recording"])
            .arg(&rec)
            .arg("--out")
            .arg(dir.join(out))
            .arg("--rig")
            .arg(rig)
            .output()
            .unwrap()
    };
    let plain = run_host(&rec, &dir.join("plain"));
    // The example describes the rig the recording was made with: the same maps.
    let o = with(&rig, "same");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let same: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(plain["layers_hash"], same["layers_hash"]);
    // The sensor 0.2 m higher: other maps.
    let higher = dir.join("higher.toml");
    let text = std::fs::read_to_string(&rig)
        .unwrap()
        .replace("xyz_m = [0.0, 0.0, 0.4]", "xyz_m = [0.0, 0.0, 0.6]");
    std::fs::write(&higher, text).unwrap();
    let o = with(&higher, "higher");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let moved: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_ne!(plain["layers_hash"], moved["layers_hash"]);
    // Another sensor than the recording's is refused.
    let other = dir.join("other.toml");
    std::fs::write(&other, "[sensor]\nkind = \"ld19\"\n").unwrap();
    let o = with(&other, "other");
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("not the recording's (sick)"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_ends_a_port_recording_with_a_complete_file() {
    let sent: Vec<u8> = (0..2000_u32).map(|i| (i % 251) as u8).collect();
    let PortRecording {
        _master,
        child,
        dir,
        out,
    } = record_port("record-ctrl-c", &["--sensor", "ld19"], &sent, (400, 50));
    std::thread::sleep(std::time::Duration::from_millis(300));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{:?}", o.status);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["ended"], "interrupted");
    assert_eq!(report["baud"], 230_400);
    // The file reads to its end without error and holds every byte.
    let data = std::fs::read(&out).unwrap();
    assert_eq!(report["bytes"], data.len());
    assert_eq!(split(&data).0, sent);
    let _ = std::fs::remove_dir_all(&dir);
}
