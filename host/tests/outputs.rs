//! `pyramid listen`'s live outputs against independent implementations, with a simulated
//! device on 127.0.0.1 (`support/device.rs`):
//! - the MCAP file read back by Python's `mcap` with `mcap-ros2-support` (CDR) and
//!   `mcap-protobuf-support` (foxglove.*): every message decodes, and the last grids equal the
//!   maps the same session writes (`fused.pgm`, the layers' cells);
//! - the Foxglove WebSocket server through a `foxglove.websocket.v1` client (Python
//!   `websockets`), while another client subscribes to everything and never reads: no frame
//!   of the link is lost and the maps stay in sync;
//! - the ROS 2 topics received by Eclipse Cyclone DDS (Python `cyclonedds`), publisher and
//!   subscriber inside a network namespace of their own (`unshare -n`);
//! - the bad situations: an address in use, a device that goes away and comes back.
//!
//! The Python readers are installed by `host/tests/py/setup.sh`.
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

mod common;
use common::succeeded;
#[path = "support/netns.rs"]
mod netns;
#[path = "support/device.rs"]
mod support;
use netns::{run_in_own_network_namespace, NETNS_MARK};
use support::{
    device, fnv1a64, fused_occupancy, listen, listen_json, raw_cells, scratch, Device, Plan,
    PATIENCE, W,
};
#[path = "support/outputs.rs"]
mod outputs_support;
use outputs_support::{
    assert_fused_matches_pgm, fused_grid, grey, ints, pgm_rows_bottom_up, py_dir, python,
    read_mcap, running, stderr_of, summary, Running,
};
use terrain_pyramid_host::publish::only_loopback;

// ------------------------------------------------------------------ MCAP

#[test]
fn the_mcap_recording_reads_back_with_another_reader_and_equals_the_maps_written() {
    let py = python();
    let dev = device(Plan::clean(3), true);
    let dir = scratch("outputs", "mcap");
    let mcap = dir.join("session.mcap");
    let child = listen_json(dev.port, &dir, &["--mcap", mcap.to_str().unwrap()]);
    let served = dev.handle.join().unwrap();
    let out = running(child).finish();
    let s = summary(&out);
    assert_eq!(s["synced"], true);
    let outputs = &s["outputs"];
    assert!(
        outputs["frames_published"].as_u64().unwrap() >= 1,
        "{outputs}"
    );
    let m = read_mcap(py, &mcap);
    // Indexed and chunked, compressed.
    assert!(
        m["summary"]["chunks"].as_u64().unwrap() >= 1,
        "{}",
        m["summary"]
    );
    assert_eq!(m["summary"]["compression"], serde_json::json!(["zstd"]));
    // Every message the session counts was read back and decoded.
    let counts = m["counts"].as_object().unwrap();
    let decoded: u64 = counts.values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(Some(decoded), m["summary"]["message_count"].as_u64());
    let written: u64 = outputs["messages"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, _)| k.starts_with("foxglove "))
        .map(|(_, v)| v.as_u64().unwrap())
        .sum();
    assert_eq!(
        decoded, written,
        "{counts:?} against {}",
        outputs["messages"]
    );
    for topic in [
        "/terrain/fused",
        "/terrain/grid/fused",
        "/terrain/pose",
        "/terrain/windows",
        "/diagnostics",
        "/terrain/layer_0",
        "/terrain/grid/layer_7",
    ] {
        assert!(counts.contains_key(topic), "{topic} in {counts:?}");
    }
    let schemas = &m["schemas"];
    assert_eq!(
        schemas["/terrain/fused"],
        serde_json::json!(["nav_msgs/msg/OccupancyGrid", "ros2msg", "cdr"])
    );
    assert_eq!(
        schemas["/terrain/grid/fused"],
        serde_json::json!(["foxglove.Grid", "protobuf", "protobuf"])
    );
    let last = &m["last"];
    // The last fused grid (ROS and Foxglove) against fused.pgm, cell for cell.
    let f = &last["/terrain/fused"];
    assert_eq!(f["frame_id"], "odom");
    let grid = fused_grid(f);
    // ±10 m at 0.1 m: 200 cells.
    assert_eq!(grid.width, 200);
    assert_eq!(grid.cells.len(), 200 * 200);
    let both = grid.assert_matches_pgm(&dir);
    assert!(both > 10_000, "{both} cells in common");
    assert!(grid.cells.contains(&100) && grid.cells.contains(&0));
    let g = &last["/terrain/grid/fused"];
    assert_eq!(ints(&g["occupancy"]), grid.cells);
    assert_eq!(g["origin"][0].as_f64().unwrap(), grid.origin.0);
    // And the device's own fused query agrees with fused.pgm (so with both grids).
    let (device_fused, n) = fused_occupancy(&served.pyramid);
    let (pw, _, pixels) = pgm_rows_bottom_up(&dir.join("fused.pgm"));
    assert_eq!(pw, n);
    assert!(device_fused
        .iter()
        .zip(&pixels)
        .all(|(&v, &p)| grey(i64::from(v)) == p));
    // Every layer's last grid: the device's cells (Foxglove's log-odds are the raw Q8.8 / 256).
    for k in 0..served.pyramid.layer_count() {
        let cells = raw_cells(&served.pyramid, k);
        let grid = &last[&format!("/terrain/grid/layer_{k}")];
        let raw: Vec<i16> = ints(&grid["raw"]).iter().map(|&v| v as i16).collect();
        assert_eq!(fnv1a64(&raw), fnv1a64(&cells), "layer {k}");
        assert_eq!(
            s["layer_cells_fnv1a64"][k].as_str().unwrap(),
            fnv1a64(&cells)
        );
        let ros = &last[&format!("/terrain/layer_{k}")];
        assert_eq!(ros["width"].as_u64().unwrap() as usize, W);
        let occ = ints(&ros["data"]);
        for (o, c) in occ.iter().zip(&cells) {
            match *c {
                i16::MIN => assert_eq!(*o, -1),
                c if c > 0 => assert!(*o >= 50 && *o <= 100),
                c if c < 0 => assert!(*o >= 0 && *o <= 50),
                _ => assert_eq!(*o, 50),
            }
        }
        assert_eq!(ints(&grid["occupancy"]), occ, "layer {k}");
    }
    // The pose: the finest window's centre (listen hears no pose), in the windows' middle.
    let pose = &last["/terrain/pose"]["xy"];
    let layer0 = served.pyramid.layer(0).unwrap();
    let r0 = f64::from(layer0.resolution().to_bits()) / 65_536.0;
    let cx = (f64::from(layer0.origin().0) + W as f64 / 2.0) * r0;
    assert!((pose[0].as_f64().unwrap() - cx).abs() < 1e-9, "{pose}");
    assert_eq!(outputs["pose_source"], "window_centre");
    let loops = last["/terrain/windows"]["loops"].as_array().unwrap();
    assert_eq!(loops.len(), served.pyramid.layer_count());
    // The diagnostics carry the device's counters.
    let d = &last["/diagnostics"]["terrain_pyramid: device"];
    assert!(
        d["frames_sent"].as_str().unwrap().parse::<u64>().unwrap() > 0,
        "{d}"
    );
}

/// `pyramid run --board qemu --mcap`: a recording through the emulated board reaches the same
/// channels, the pose the recording sends is the one published, and the last fused grid read
/// back by another reader equals the `fused.pgm` the same run writes.
#[test]
fn pyramid_run_through_the_emulated_board_records_mcap_equal_to_its_maps() {
    if !common::qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let py = python();
    let dir = scratch("outputs", "run-mcap");
    let recording = dir.join("synthetic.rec");
    common::synthetic_recording(&recording);
    let mcap = dir.join("run.mcap");
    let out = succeeded(
        Command::new(common::PYRAMID)
            .args(["run", "--board", "qemu", "--json", "--drop-m", "0.3"])
            .arg("--recording")
            .arg(&recording)
            .arg("--out")
            .arg(&dir)
            .arg("--mcap")
            .arg(&mcap),
        "pyramid run: ",
    );
    let s: Value = serde_json::from_slice(&out.stdout).unwrap();
    let outputs = &s["outputs"];
    assert!(outputs["frames_published"].as_u64().unwrap() >= 1, "{s}");
    assert_eq!(outputs["pose_source"], "given");
    let m = read_mcap(py, &mcap);
    let f = &m["last"]["/terrain/fused"];
    let grid = fused_grid(f);
    let both = grid.assert_matches_pgm(&dir);
    assert!(both > 1_000, "{both} cells in common");
    assert!(
        grid.cells.contains(&100) && grid.cells.contains(&0),
        "obstacles and ground"
    );
    // The recording's second pose (x 0.35, y 0.1): the last one sent.
    let pose = &m["last"]["/terrain/pose"]["xy"];
    assert!((pose[0].as_f64().unwrap() - 0.35).abs() < 1e-6, "{pose}");
    assert!((pose[1].as_f64().unwrap() - 0.1).abs() < 1e-6, "{pose}");
}

/// A stand-in device driving `steps` steps of the clean plan of `seed` and staying connected
/// once settled (driving at once, or when told to go), and `pyramid listen --json` connected
/// to it with `flags`, writing into the scratch directory `outputs-NAME`.
fn listening_to_device(
    name: &str,
    (seed, steps): (u64, usize),
    go_now: bool,
    flags: &[&str],
) -> (Device, PathBuf, Running) {
    let plan = Plan {
        steps,
        close_when_settled: false,
        ..Plan::clean(seed)
    };
    let dev = device(plan, go_now);
    let dir = scratch("outputs", name);
    let run = running(listen_json(dev.port, &dir, flags));
    (dev, dir, run)
}

// ------------------------------------------------------------------ Foxglove

/// The `ws://` address `pyramid listen` says it serves.
fn served_url(run: &Running) -> String {
    let line = run.wait_for("foxglove: serving ");
    line.rsplit(' ').next().unwrap().to_string()
}

#[test]
fn a_foxglove_client_decodes_grids_while_a_stuck_client_holds_nothing_up() {
    let py = python();
    let (dev, dir, run) = listening_to_device(
        "foxglove",
        (17, 2500),
        false,
        &["--foxglove", "127.0.0.1:0", "--publish-hz", "50"],
    );
    let url = served_url(&run);
    assert!(url.starts_with("ws://127.0.0.1:"), "{url}");
    // The device's first Hello and snapshot have been published once the status says synced.
    run.wait_for("synced");
    let mut client = Command::new(py)
        .arg(py_dir().join("foxglove_client.py"))
        .arg(&url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(client.stdout.take().unwrap()).lines();
    let first = lines.next().and_then(Result::ok);
    if first.as_deref() != Some("ready") {
        let err = stderr_of(&mut client);
        panic!("foxglove_client.py: {first:?}: {err}");
    }
    // Now the device drives: thousands of frames while one client never reads.
    let start = Instant::now();
    dev.go.store(true, Ordering::SeqCst);
    dev.settled
        .recv_timeout(PATIENCE)
        .expect("the device settled");
    let driving = start.elapsed();
    run.interrupt();
    let out = run.finish();
    let served = dev.handle.join().unwrap();
    let result = lines.next().unwrap().unwrap();
    let status = client.wait().unwrap();
    let err = stderr_of(&mut client);
    assert!(status.success(), "foxglove_client.py: {err}");
    let s = summary(&out);
    // No frame of the link was lost, the mirror is the device's.
    assert_eq!(s["synced"], true);
    assert_eq!(s["gaps"], 0);
    assert_eq!(s["missing_frames"], 0);
    assert_eq!(s["bad_frames"], 0);
    assert_eq!(s["snapshots_requested"], 1);
    assert!(s["frames"].as_u64().unwrap() > 1000, "{s}");
    for k in 0..served.pyramid.layer_count() {
        assert_eq!(
            s["layer_cells_fnv1a64"][k].as_str().unwrap(),
            fnv1a64(&raw_cells(&served.pyramid, k)),
            "layer {k}"
        );
    }
    // The outputs went on publishing while the stuck client sat there (a publisher blocked by
    // it would have published a frame or two; a debug build publishes some 10 a second).
    let outputs = &s["outputs"];
    let published = outputs["frames_published"].as_u64().unwrap();
    assert!(
        published as f64 >= driving.as_secs_f64() * 3.0,
        "{published} frames published in {driving:?}: {outputs}"
    );
    let c: Value = serde_json::from_str(&result).unwrap();
    assert_eq!(c["errors"], Value::Array(vec![]), "{}", c["errors"]);
    assert_eq!(c["server"], "terrain-pyramid");
    // The protocol of foxglove/ws-protocol, under the name the Foxglove SDK gives it now.
    // Both names of the protocol: the reader offered only the old one, the stuck client only
    // the new one.
    assert_eq!(c["subprotocol"], "foxglove.websocket.v1");
    assert_eq!(c["stuck_subprotocol"], "foxglove.sdk.v1");
    let topics: Vec<&str> = c["topics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    for t in [
        "/terrain/grid/fused",
        "/terrain/grid/layer_0",
        "/terrain/grid/layer_7",
        "/terrain/pose",
        "/terrain/windows",
        "/terrain/fused",
        "/diagnostics",
    ] {
        assert!(topics.contains(&t), "{t} in {topics:?}");
    }
    assert_eq!(
        c["schemas"]["/terrain/grid/fused"],
        serde_json::json!(["foxglove.Grid", "protobuf"])
    );
    assert_eq!(
        c["schemas"]["/terrain/fused"],
        serde_json::json!(["nav_msgs/msg/OccupancyGrid", "cdr"])
    );
    let received = c["received"].as_u64().unwrap();
    let stuck = c["stuck_received"].as_u64().unwrap();
    assert!(received > 100, "{received}");
    // The server dropped for the stuck client what it could not take.
    assert!(stuck < received, "stuck {stuck}, reading {received}");
    // A Grid decoded: the fused map ±10 m around the robot, equal to fused.pgm where both lie.
    let g = &c["last"]["/terrain/grid/fused"];
    assert_eq!(g["frame_id"], "odom");
    assert_eq!(g["fields"], serde_json::json!(["occupancy"]));
    let width = g["column_count"].as_u64().unwrap() as usize;
    let cells = ints(&g["occupancy"]);
    assert_eq!((width, cells.len()), (200, 200 * 200));
    let both = assert_fused_matches_pgm(
        &dir,
        (
            g["origin"][0].as_f64().unwrap(),
            g["origin"][1].as_f64().unwrap(),
        ),
        g["cell_size"][0].as_f64().unwrap(),
        width,
        &cells,
    );
    assert!(both > 10_000, "{both}");
    let l = &c["last"]["/terrain/grid/layer_3"];
    assert_eq!(l["fields"], serde_json::json!(["log_odds", "occupancy"]));
    assert_eq!(l["column_count"].as_u64().unwrap() as usize, W);
}

// ------------------------------------------------------------------ ROS 2

#[test]
fn ros2_topics_reach_cyclone_dds_inside_a_network_namespace() {
    python();
    // This test binary again, inside a new network namespace with only loopback (multicast
    // on, routed to lo), running the inner test: device, publisher and subscriber all there.
    run_in_own_network_namespace("ros2_inner");
}

#[test]
#[ignore = "runs inside its own network namespace: ros2_topics_reach_cyclone_dds_inside_a_network_namespace"]
fn ros2_inner() {
    // DDS multicast must never leave the machine: refuse anywhere but an isolated namespace.
    assert!(
        std::env::var_os(NETNS_MARK).is_some() && only_loopback(),
        "ros2_inner runs only inside `unshare -n` (see the test that calls it)"
    );
    let py = python();
    let (dev, dir, run) =
        listening_to_device("ros2", (29, 300), true, &["--ros2", "--ros-domain-id", "7"]);
    dev.settled
        .recv_timeout(PATIENCE)
        .expect("the device settled");
    // Settled: the last maps have been published. A subscriber that joins now gets them
    // (transient local, as Nav2's static layer subscribes).
    let sub = Command::new(py)
        .arg(py_dir().join("dds_sub.py"))
        .args(["8", "30", "7"])
        .output()
        .unwrap();
    run.interrupt();
    let out = run.finish();
    let served = dev.handle.join().unwrap();
    assert!(
        sub.status.success(),
        "dds_sub.py: {}\n{}",
        String::from_utf8_lossy(&sub.stdout),
        String::from_utf8_lossy(&sub.stderr)
    );
    let s = summary(&out);
    assert_eq!(s["synced"], true);
    let r: Value = serde_json::from_slice(&sub.stdout).unwrap();
    eprintln!("late joiner: samples per topic {}", r["samples"]);
    let last = &r["last"];
    // The maps came at once, from the publisher's history (not from a later update).
    for k in 0..8 {
        let first = r["first_after_s"][format!("/terrain/layer_{k}")]
            .as_f64()
            .unwrap();
        assert!(first < 10.0, "layer {k} after {first} s");
    }
    // Each layer: the device's cells as occupancy percent.
    for k in 0..served.pyramid.layer_count() {
        let l = &last[&format!("/terrain/layer_{k}")];
        let raw = raw_cells(&served.pyramid, k);
        let expected: Vec<i64> = raw
            .iter()
            .map(|&c| {
                if c == i16::MIN {
                    -1
                } else {
                    (100.0 / (1.0 + (-f64::from(c) / 256.0).exp())).round() as i64
                }
            })
            .collect();
        let got = ints(&l["data"]);
        let differ = got.iter().zip(&expected).filter(|(a, b)| a != b).count();
        assert!(
            got.len() == expected.len() && differ == 0,
            "layer {k}: {differ} of {} cells differ; samples {}",
            expected.len(),
            r["samples"]
        );
        let layer = served.pyramid.layer(k).unwrap();
        let r = f64::from(layer.resolution().to_bits()) / 65_536.0;
        assert!((l["resolution"].as_f64().unwrap() - r).abs() < 1e-6);
        let ox = f64::from(layer.origin().0) * r;
        assert!(
            (l["origin"][0].as_f64().unwrap() - ox).abs() < 1e-6,
            "layer {k}"
        );
    }
    let f = &last["/terrain/fused"];
    assert_eq!(f["frame_id"], "odom");
    assert_eq!(
        (f["width"].as_u64(), f["height"].as_u64()),
        (Some(200), Some(200))
    );
    let cells = ints(&f["data"]);
    let both = assert_fused_matches_pgm(
        &dir,
        (
            f["origin"][0].as_f64().unwrap(),
            f["origin"][1].as_f64().unwrap(),
        ),
        f["resolution"].as_f64().unwrap(),
        200,
        &cells,
    );
    assert!(both > 10_000, "{both}");
    assert!(cells.contains(&100) && cells.contains(&0));
    let d = &last["/diagnostics"];
    assert!(
        d["terrain_pyramid: device"]["frames_sent"]
            .as_str()
            .is_some(),
        "{d}"
    );
    assert_eq!(d["terrain_pyramid: host link"]["gaps"], "0");
    let outputs = &s["outputs"]["messages"];
    assert!(
        outputs["ros2 /terrain/fused"].as_u64().unwrap() >= 1,
        "{outputs}"
    );
}

// ------------------------------------------------------------------ bad situations

#[test]
fn an_address_in_use_is_an_error_naming_the_flag() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let dir = scratch("outputs", "in-use");
    let out_dir = dir.to_str().unwrap();
    // `pyramid listen` with the outputs of `flags`, to a port nothing serves: it exits 1; its
    // stderr.
    let refusal = |flags: &[&str]| {
        let base = ["--tcp", "127.0.0.1:1", "--out", out_dir];
        let out = running(listen(&[&base, flags].concat())).finish();
        assert_eq!(out.status.code(), Some(1));
        String::from_utf8(out.stderr).unwrap()
    };
    // The outputs start before the device is opened: no device is needed to see the error.
    let stderr = refusal(&["--foxglove", &addr]);
    assert_eq!(
        stderr.trim(),
        format!("error: --foxglove: {addr} is already in use")
    );
    // An MCAP file that cannot be created names its flag too.
    let stderr = refusal(&["--mcap", dir.join("no/such/dir/x.mcap").to_str().unwrap()]);
    assert!(
        stderr.starts_with("error: --mcap: cannot create "),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_device_that_goes_away_and_comes_back_keeps_the_maps_and_resyncs() {
    // The TCP analogue of a USB adapter unplugged and plugged in again: the device drops the
    // connection mid-drive, drives on unheard (its maps change), then accepts again.
    let plan = Plan {
        steps: 400,
        unplug_at: Some(150),
        unplugged_steps: 150,
        close_when_settled: true,
        quiet_after: Duration::from_millis(1500),
        ..Plan::clean(23)
    };
    let dev = device(plan, true);
    let dir = scratch("outputs", "reconnect");
    let mcap = dir.join("s.mcap");
    let run = running(listen_json(
        dev.port,
        &dir,
        &["--reconnect", "--mcap", mcap.to_str().unwrap()],
    ));
    let gone = run.wait_for("stream ended");
    assert!(
        gone.contains("trying to reconnect every 1 s; the maps are kept"),
        "{gone}"
    );
    let back = run.wait_for("reconnected to tcp ");
    assert!(back.contains("snapshot requested"), "{back}");
    // The device closes at the end: the host keeps trying until its session ends.
    let served = dev.handle.join().unwrap();
    run.wait_for("stream ended");
    run.interrupt();
    let out = run.finish();
    let s = summary(&out);
    assert_eq!(served.connections, 2);
    assert_eq!(s["reconnects"], 1);
    assert_eq!(s["ended_by"], "interrupted");
    assert_eq!(
        s["synced"],
        true,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The request at the start and the one after the reconnection (at least).
    assert!(s["snapshots_requested"].as_u64().unwrap() >= 2, "{s}");
    assert!(served.snapshots >= 2);
    for k in 0..served.pyramid.layer_count() {
        assert_eq!(
            s["layer_cells_fnv1a64"][k].as_str().unwrap(),
            fnv1a64(&raw_cells(&served.pyramid, k)),
            "layer {k}"
        );
    }
    assert!(s["outputs"]["frames_published"].as_u64().unwrap() > 1);
}

#[test]
fn a_serial_port_open_elsewhere_is_refused_and_one_that_vanishes_is_waited_for() {
    // A pseudo-terminal stands for the USB adapter: Python holds its master side.
    let mut holder = Command::new("python3")
        .args([
            "-c",
            "import os, pty, sys, time\nm, s = pty.openpty()\nprint(os.ttyname(s), flush=True)\nsys.stdin.read()\n",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut path = String::new();
    BufReader::new(holder.stdout.take().unwrap())
        .read_line(&mut path)
        .unwrap();
    let path = path.trim().to_string();
    assert!(path.starts_with("/dev/pts/"), "{path}");
    let dir = scratch("outputs", "serial");
    let first = running(listen(&["--port", &path, "--out", dir.to_str().unwrap()]));
    first.wait_for("listening on ");
    // A second listener is refused: the port is exclusive (TIOCEXCL and flock).
    let second = running(listen(&["--port", &path, "--out", dir.to_str().unwrap()])).finish();
    assert_eq!(second.status.code(), Some(1));
    let stderr = String::from_utf8(second.stderr).unwrap();
    assert!(
        stderr.starts_with(&format!(
            "error: cannot open the serial port {path}: it is already open in another process"
        )),
        "{stderr}"
    );
    // The adapter goes away: a message, and the listener waits for it.
    drop(holder.stdin.take());
    holder.wait().unwrap();
    let gone = first.wait_for("stream ended");
    assert!(gone.contains("trying to reconnect every 1 s"), "{gone}");
    std::thread::sleep(Duration::from_millis(1500));
    assert!(first.child.id() > 0);
    first.interrupt();
    let out = first.finish();
    // No Hello ever came: nothing to write, said so; nothing panicked.
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("error: no maps to write"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}
