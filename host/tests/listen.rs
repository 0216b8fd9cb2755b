//! `pyramid listen` end to end: an in-process device (the library's `Link` and
//! `DefaultPyramid`, random evidence and recentres) serves its stream on a TCP socket on
//! 127.0.0.1; the `pyramid` binary connects, keeps its mirror, and writes the maps when the
//! stream ends, `--duration-s` elapses or it is interrupted. The maps written must equal the
//! device's pyramid cell for cell, also when the device's frames are lost or corrupted on the
//! way and the host recovers through snapshots.
#[path = "support/device.rs"]
mod support;

use serde_json::Value;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Output};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use support::{
    fnv1a64, fused_occupancy, listen, listen_json, raw_cells, scratch, wait_or_kill, Plan, Served,
    PATIENCE, W,
};
use terrain_pyramid::DefaultPyramid;

// ------------------------------------------------------------------ the host

/// Waits for the binary (killing it after [`PATIENCE`]) and collects its output.
fn finish(mut child: Child) -> Output {
    // Read the pipes on threads, so that a full pipe never blocks the binary.
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    let err = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = err.read_to_end(&mut v);
        v
    });
    let status = wait_or_kill(&mut child);
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// The summary from `--json` on stdout, checked against `summary.json`.
fn summary(out: &Output, dir: &Path) -> Value {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "pyramid listen failed: {stderr}");
    let stdout = String::from_utf8(out.stdout.clone()).unwrap();
    assert_eq!(stdout.trim().lines().count(), 1, "one line: {stdout}");
    let printed: Value = serde_json::from_str(stdout.trim()).unwrap();
    let file: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(printed, file);
    for key in [
        "layers",
        "fused",
        "frames",
        "crc_errors",
        "patches",
        "gaps",
        "snapshots_requested",
        "synced",
        "layer_cells_fnv1a64",
        "files",
    ] {
        assert!(printed.get(key).is_some(), "{key} in {printed}");
    }
    printed
}

// ------------------------------------------------------------------ expected maps

fn pgm(width: usize, height: usize, rows_bottom_up: &[u8]) -> Vec<u8> {
    let mut out = format!("P5\n{width} {height}\n255\n").into_bytes();
    for row in rows_bottom_up.chunks(width).rev() {
        out.extend_from_slice(row);
    }
    out
}

/// The map_server value of a raw cell: obstacle 0 (L > 0), navigable 254 (L < 0), unknown
/// or undecided 205.
fn grey(raw: i16) -> u8 {
    match raw {
        i16::MIN | 0 => 205,
        r if r > 0 => 0,
        _ => 254,
    }
}

/// Every map in `dir` equals the device's pyramid: each layer's PGM, the raw cells' hash and
/// counts in the summary, and the fused map against the library's own `fused_region`.
fn assert_maps_equal(dir: &Path, s: &Value, p: &DefaultPyramid) {
    let layers = s["layers"].as_array().unwrap();
    assert_eq!(layers.len(), p.layer_count());
    let hashes = s["layer_cells_fnv1a64"].as_array().unwrap();
    for k in 0..p.layer_count() {
        let cells = raw_cells(p, k);
        let expected: Vec<u8> = cells.iter().map(|&c| grey(c)).collect();
        let written = std::fs::read(dir.join(format!("layer-{k}.pgm"))).unwrap();
        assert!(written == pgm(W, W, &expected), "layer-{k}.pgm differs");
        assert_eq!(
            hashes[k].as_str().unwrap(),
            fnv1a64(&cells),
            "layer {k} cells"
        );
        let c = p.counts(k).unwrap();
        let l = &layers[k];
        assert_eq!(l["observed_cells"], c.observed, "layer {k}");
        assert_eq!(l["obstacle_cells"], c.obstacle, "layer {k}");
        assert_eq!(l["free_cells"], c.free, "layer {k}");
        assert_eq!(l["cells_per_side"], W);
        let yaml = std::fs::read_to_string(dir.join(format!("layer-{k}.yaml"))).unwrap();
        assert!(yaml.starts_with(&format!("image: layer-{k}.pgm\nmode: trinary\n")));
        // The bands came with the Hello.
        let band = l["band_m"].as_array().unwrap();
        assert!(band[1].as_f64().unwrap() > band[0].as_f64().unwrap(), "{l}");
    }
    // The fused map: the finest resolution over the coarsest window.
    let (occupancy, n) = fused_occupancy(p);
    let pixels: Vec<u8> = occupancy
        .iter()
        .map(|&v| match v {
            100 => 0,
            0 => 254,
            _ => 205,
        })
        .collect();
    let written = std::fs::read(dir.join("fused.pgm")).unwrap();
    assert!(written == pgm(n, n, &pixels), "fused.pgm differs");
    assert_eq!(s["fused"]["width"], n);
    let obstacle = pixels.iter().filter(|&&v| v == 0).count();
    assert_eq!(s["fused"]["obstacle_cells"], obstacle);
    assert!(obstacle > 0);
    for file in ["maps.png", "fused.yaml", "summary.json"] {
        assert!(dir.join(file).is_file(), "{file}");
    }
    assert!(s["files"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f == "maps.png"));
}

/// A device whose line deletes and flips nothing (the host hears it through a channel all
/// the same, as a lossy one).
fn clean(seed: u64) -> Plan {
    Plan {
        loss: Some((0, 0)),
        ..Plan::clean(seed)
    }
}

/// A device on 127.0.0.1 driving at once: its port, its thread, and the channel it says
/// "settled" on.
fn device(plan: Plan) -> (u16, JoinHandle<Served>, mpsc::Receiver<()>) {
    let device = support::device(plan, true);
    (device.port, device.handle, device.settled)
}

// ------------------------------------------------------------------ tests

#[test]
fn a_clean_stream_is_written_cell_for_cell_when_the_device_closes() {
    let (port, device, _) = device(clean(7));
    let dir = scratch("listen", "clean");
    let child = listen_json(port, &dir, &[]);
    let served = device.join().unwrap();
    let out = finish(child);
    let s = summary(&out, &dir);
    assert_eq!(s["ended_by"], "end_of_stream");
    assert_eq!(s["synced"], true);
    assert_eq!(s["gaps"], 0);
    assert_eq!(s["crc_errors"], 0);
    // The one request at the start, answered.
    assert_eq!(s["snapshots_requested"], 1);
    assert_eq!(served.snapshots, 1);
    assert!(s["patches"].as_u64().unwrap() > 0);
    assert_maps_equal(&dir, &s, &served.pyramid);
}

#[test]
fn lost_and_corrupted_frames_are_recovered_through_snapshots() {
    let plan = Plan {
        steps: 400,
        // The host joins after the device's first Hello and its answer to the request.
        deaf_steps: 30,
        loss: Some((30, 30)),
        // Longer than the host's retry of an unanswered request (2 s).
        quiet_after: Duration::from_millis(2600),
        ..clean(42)
    };
    let (port, device, _) = device(plan);
    let dir = scratch("listen", "lossy");
    let child = listen_json(port, &dir, &[]);
    let served = device.join().unwrap();
    let out = finish(child);
    let s = summary(&out, &dir);
    assert!(served.dropped > 0 && served.flipped > 0);
    assert_eq!(
        s["synced"],
        true,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(s["gaps"].as_u64().unwrap() > 0, "{s}");
    assert!(s["crc_errors"].as_u64().unwrap() > 0, "{s}");
    assert!(s["snapshots_requested"].as_u64().unwrap() > 1, "{s}");
    assert!(served.snapshots > 1);
    assert_maps_equal(&dir, &s, &served.pyramid);
}

#[test]
fn the_session_ends_after_its_duration() {
    let plan = Plan {
        steps: 100,
        close_when_settled: false,
        ..clean(11)
    };
    let (port, device, settled) = device(plan);
    let dir = scratch("listen", "duration");
    let start = Instant::now();
    let child = listen_json(port, &dir, &["--duration-s", "6"]);
    let out = finish(child);
    assert!(start.elapsed() >= Duration::from_secs(6));
    // The device settled before the host stopped, and stops when the host goes away.
    settled.try_recv().expect("the device settled in time");
    let served = device.join().unwrap();
    let s = summary(&out, &dir);
    assert_eq!(s["ended_by"], "duration");
    assert_eq!(s["synced"], true);
    assert!(s["duration_s"].as_f64().unwrap() >= 6.0);
    assert_maps_equal(&dir, &s, &served.pyramid);
    // Without a terminal the status line comes as plain lines.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains('\r'));
    assert!(
        stderr.lines().filter(|l| l.contains(" frames ")).count() >= 10,
        "{stderr}"
    );
}

#[test]
fn ctrl_c_ends_the_session_and_writes_the_maps() {
    let plan = Plan {
        close_when_settled: false,
        ..clean(5)
    };
    let (port, device, settled) = device(plan);
    let dir = scratch("listen", "interrupt");
    let child = listen_json(port, &dir, &[]);
    settled.recv_timeout(PATIENCE).expect("the device settled");
    let pid = child.id().to_string();
    let kill = Command::new("kill").args(["-INT", &pid]).status().unwrap();
    assert!(kill.success());
    let out = finish(child);
    let served = device.join().unwrap();
    let s = summary(&out, &dir);
    assert_eq!(s["ended_by"], "interrupted");
    assert_eq!(s["synced"], true);
    assert_maps_equal(&dir, &s, &served.pyramid);
}

#[test]
fn an_unreachable_device_is_one_line_and_status_1() {
    // A port nobody listens on: bind one, then free it.
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let dir = scratch("listen", "unreachable");
    let addr = format!("127.0.0.1:{port}");
    let missing = dir.join("no-such-tty");
    for args in [
        vec!["--tcp", &addr, "--out", dir.to_str().unwrap()],
        vec![
            "--port",
            missing.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ],
    ] {
        let out = finish(listen(&args));
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("error: cannot "), "{stderr}");
        assert!(out.stdout.is_empty());
        assert!(!dir.join("summary.json").exists());
    }
}

#[test]
fn a_device_that_never_says_hello_writes_nothing() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let server = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        // Noise, then the end of the stream.
        stream.write_all(&[1, 2, 3, 0, 7, 7, 7, 0]).unwrap();
    });
    let dir = scratch("listen", "silent");
    let addr = format!("127.0.0.1:{port}");
    let out = finish(listen(&["--tcp", &addr, "--out", dir.to_str().unwrap()]));
    server.join().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("error: no maps to write"), "{stderr}");
    assert!(!dir.join("summary.json").exists());
}
