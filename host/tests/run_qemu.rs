//! The emulated co-processor against the in-process pipeline: `pyramid run --board qemu` (and
//! `--board netduinoplus2`, the STM32F4 firmware) and `--board host` on the same recording and
//! flags must give bit-identical layers (every raw cell of every layer, the windows' origins
//! and resolutions). The micro:bit, whose pyramid is smaller, has its own: `run_microbit.rs`.
//!
//! With decay on, each board decays by its own clock (QEMU's is the wall clock), so their maps
//! differ by when the decay ran; what must hold is that the host's mirror, which applies every
//! decay step the firmware announces with the x86 build of the library, equals the Cortex-M4F
//! firmware's cells bit for bit (the final snapshot compares every resent cell).
//!
//! QEMU (`qemu-system-arm`) and the `thumbv7em-none-eabihf` target are required: without them
//! the test FAILS, unless `PYRAMID_SKIP_QEMU=1` is set. The 3DTK scan (`../shared/data`) is
//! used when present; a small synthetic recording written here always runs.
use std::path::Path;
use std::process::Command;

mod common;
use common::{qemu_ready, record_3dtk, synthetic_recording, tmp, PYRAMID};

fn run(board: &str, recording: &Path, out: &Path, flags: &[&str]) -> serde_json::Value {
    let output = Command::new(PYRAMID)
        .args(["run", "--board", board, "--json", "--recording"])
        .arg(recording)
        .arg("--out")
        .arg(out)
        .args(flags)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "pyramid run --board {board} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// Runs `--board host` and `--board board` and compares every raw cell; returns the number of
/// cells compared.
fn compare(board: &str, recording: &Path, dir: &Path, flags: &[&str]) -> usize {
    let (host_dir, qemu_dir) = (dir.join("host"), dir.join(board));
    let host = run("host", recording, &host_dir, flags);
    let qemu = run(board, recording, &qemu_dir, flags);
    assert_eq!(host["telegrams_sent"], qemu["telegrams_sent"]);
    assert_eq!(host["telegrams_applied"], qemu["telegrams_applied"]);
    assert_eq!(qemu["telegrams_applied"], qemu["telegrams_sent"]);
    // Stats carries the observations (protocol version 2).
    assert_eq!(host["observations"], qemu["observations"]);
    assert_eq!(qemu["link_crc_errors"], 0);
    assert_eq!(
        host["layers"], qemu["layers"],
        "per-layer counts and origins"
    );
    assert_eq!(host["fused"], qemu["fused"]);
    assert_eq!(host["layers_hash"], qemu["layers_hash"]);
    let layers = host["layers"].as_array().unwrap().len();
    assert!(layers > 0);
    let mut cells = 0;
    for k in 0..layers {
        let name = format!("cells-{k}.bin");
        let a = std::fs::read(host_dir.join(&name)).unwrap();
        let b = std::fs::read(qemu_dir.join(&name)).unwrap();
        assert_eq!(a.len(), 64 * 64 * 2);
        assert!(a == b, "layer {k}: the raw cells differ");
        cells += a.len() / 2;
    }
    let observed: u64 = host["layers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["observed_cells"].as_u64().unwrap())
        .sum();
    assert!(
        observed > 0,
        "nothing was observed: the comparison is empty"
    );
    let stack = qemu["stack_bytes"].as_u64().unwrap_or(0);
    assert!(
        stack > 0,
        "{board}: no stack high-water mark in the Reply to Shutdown"
    );
    eprintln!(
        "{board}: {cells} cells compared ({observed} observed): identical, layers_hash {}, \
         stack high-water {stack} bytes",
        host["layers_hash"]
    );
    cells
}

/// The synthetic recording through `board` and the host, compared cell for cell.
fn synthetic(board: &str) {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp(&format!("synthetic-{board}"));
    let recording = dir.join("synthetic.rec");
    synthetic_recording(&recording);
    // A drop-off threshold and an inverse sensor model of the user's (both travel in the
    // link's Configure; the 3DTK scan below runs the defaults).
    let flags = ["--drop-m", "0.3", "--p-obstacle", "0.9", "--p-free", "0.35"];
    let cells = compare(board, &recording, &dir, &flags);
    assert_eq!(cells, 8 * 64 * 64);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The 3DTK scan (when present) through `board` and the host, compared cell for cell.
fn scan_3dtk(board: &str) {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp(&format!("3dtk-{board}"));
    let Some(recording) = record_3dtk(&dir) else {
        return;
    };
    let flags = ["--height-m", "0.4", "--max-range-m", "8", "--gamma", "3"];
    compare(board, &recording, &dir, &flags);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn qemu_matches_host_on_a_synthetic_recording() {
    synthetic("qemu");
}

#[test]
fn qemu_matches_host_on_the_3dtk_scan() {
    scan_3dtk("qemu");
}

/// The STM32F4 firmware on QEMU's STM32F405 (a stand-in scanner answers its bring-up).
#[test]
fn netduinoplus2_matches_host_on_a_synthetic_recording() {
    synthetic("netduinoplus2");
}

#[test]
fn netduinoplus2_matches_host_on_the_3dtk_scan() {
    scan_3dtk("netduinoplus2");
}

/// An LD06 (10 Hz, 12 returns a packet) 0.5 m up on a nodding tilt unit over flat floor
/// with a wall 2.5 m ahead and a box to the left, written with the library's LD06 emitter and
/// recording writer (version 2, its sensor event): the tilt nods 8° → 30° → 8° in 2° steps,
/// one step per packet, an angle event before each packet's bytes; the bytes in uneven chunks
/// with a corrupted packet and some noise; two revolutions per observation; two poses.
fn synthetic_ld06_recording(path: &Path) {
    use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
    use terrain_pyramid::wire::recording::SensorEvent;
    use terrain_pyramid::wire::recording::SetupEvent as Setup;
    use terrain_pyramid::wire::recording::{emit_header, Event, MountKind, Payload};
    let mut file = vec![0_u8; 16];
    emit_header(&mut file).unwrap();
    let mut clock = 0_u64;
    let mut push = |payload: Payload<'_>| {
        clock += 700;
        let event = Event {
            time_us: clock,
            payload,
        };
        let mut buf = vec![0_u8; event.buffer_len()];
        let n = event.emit(&mut buf).unwrap();
        file.extend_from_slice(&buf[..n]);
    };
    push(Payload::Setup(Setup {
        mount: MountKind::TiltedHorizontal,
        measuring_mode: 0,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.1, 0.0, 0.5],
        lines_per_observation: 2,
    }));
    push(Payload::Sensor(SensorEvent { sensor: 1, mode: 0 }));
    push(Payload::Pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
    // The scene, in the sensor's frame before the tilt: the range along a direction.
    let range = |dir: [f64; 3]| -> f64 {
        let mut r = f64::INFINITY;
        if dir[2] < -1e-6 {
            r = r.min(0.5 / -dir[2]);
        }
        if dir[0] > 1e-6 {
            r = r.min(2.4 / dir[0]);
        }
        // A box 0.3 m high between x 1.0 .. 1.4, y 0.6 .. 1.0: its near face at y = 0.6.
        if dir[1] > 1e-6 {
            let t = 0.6 / dir[1];
            let (x, z) = (0.1 + t * dir[0], 0.5 + t * dir[2]);
            if (1.0..1.4).contains(&x) && z < 0.3 {
                r = r.min(t);
            }
        }
        r
    };
    let tilts: Vec<f64> = (0..12)
        .chain((1..11).rev())
        .map(|k| 8.0 + 2.0 * f64::from(k))
        .collect();
    let mut stream_packets = 0_u32;
    for n in 0..180_u32 {
        if n == 90 {
            push(Payload::Pose([0.3, 0.05, 0.0, 0.0, 0.0, 0.1]));
        }
        let tilt = tilts[n as usize % tilts.len()];
        let turns = (tilt / 360.0 * 65_536.0).round() as u16;
        push(Payload::Angle(turns));
        let start = f64::from(n) * 9.6;
        let tau = tilt.to_radians();
        let mut points = [Ld06Point::default(); 12];
        for (j, p) in points.iter_mut().enumerate() {
            let phi = (start + 0.8 * j as f64).to_radians();
            // Clockwise from ahead, then tilted about y (positive looks down).
            let (s, c) = (phi.sin(), phi.cos());
            let dir = [c * tau.cos(), -s, -c * tau.sin()];
            let r = range(dir);
            p.distance_mm = if r < 12.0 {
                (r * 1000.0).round() as u16
            } else {
                0
            };
            p.intensity = 100 + (j as u8);
        }
        let repr = Ld06Repr {
            speed_deg_per_s: 3_600,
            start_angle_centideg: ((start * 100.0).round() as u32 % 36_000) as u16,
            end_angle_centideg: (((start + 8.8) * 100.0).round() as u32 % 36_000) as u16,
            timestamp_ms: (n * 3 % 30_000) as u16,
            points,
        };
        let mut packet = [0_u8; 47];
        repr.emit(&mut packet).unwrap();
        if n == 50 {
            packet[30] ^= 0x20;
        } else {
            stream_packets += 1;
        }
        if n == 70 {
            push(Payload::Laser(&[0x54, 0x00, 0xFF]));
        }
        let (a, b) = packet.split_at(5 + (n as usize * 7) % 40);
        push(Payload::Laser(a));
        push(Payload::Laser(b));
    }
    assert_eq!(stream_packets, 179);
    std::fs::write(path, file).unwrap();
}

#[test]
fn qemu_matches_host_on_an_ld06_recording() {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp("ld06");
    let recording = dir.join("ld06.rec");
    synthetic_ld06_recording(&recording);
    let cells = compare("qemu", &recording, &dir, &[]);
    assert_eq!(cells, 8 * 64 * 64);
    let host = std::fs::read_to_string(dir.join("host").join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&host).unwrap();
    assert_eq!(summary["telegrams_sent"], 179);
    // 180 packets over 4.8 turns: revolutions start in packets 37, 75, 112 and 150; an
    // observation ends where the third revolution since its start begins (the first one also
    // holds the partial revolution before 37): at 112, then EndObservation.
    assert_eq!(summary["observations"], 2);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Runs `pyramid run` with decay on a board; checks that the mirror's decay equals the
/// device's at the final snapshot, and that the decay did something.
fn decays_alike(board: &str, recording: &Path, dir: &Path) -> serde_json::Value {
    let flags = ["--drop-m", "0.3", "--decay", "all", "--decay-tau-s", "1"];
    let summary = run(board, recording, &dir.join(board), &flags);
    let m = &summary["mirror"];
    eprintln!("{board}: {m}");
    assert_eq!(summary["decay"]["mode"], "all");
    assert_eq!(summary["decay"]["tau_s"][0], 1.0);
    assert!(m["decay_frames"].as_u64().unwrap() > 0, "{summary}");
    assert!(m["rows_decayed"].as_u64().unwrap() > 0, "{summary}");
    assert_eq!(
        m["resent_cells_compared"].as_u64().unwrap(),
        8 * 64 * 64,
        "{summary}"
    );
    assert_eq!(m["resent_cells_differing"], 0, "{summary}");
    summary
}

#[test]
fn the_mirror_decays_as_the_firmware_does() {
    let dir = tmp("decay");
    let recording = dir.join("synthetic.rec");
    synthetic_recording(&recording);
    let host = decays_alike("host", &recording, &dir);
    assert!(
        host["mirror"]["cells_faded"].as_u64().unwrap() > 0,
        "{host}"
    );
    if qemu_ready() {
        decays_alike("qemu", &recording, &dir);
    } else {
        eprintln!("PYRAMID_SKIP_QEMU=1: the QEMU half is skipped");
    }
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}
