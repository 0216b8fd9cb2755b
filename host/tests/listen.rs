//! `pyramid listen` end to end: an in-process device (the library's `Link` and
//! `DefaultPyramid`, random evidence and recentres) serves its stream on a TCP socket on
//! 127.0.0.1; the `pyramid` binary connects, keeps its mirror, and writes the maps when the
//! stream ends, `--duration-s` elapses or it is interrupted. The maps written must equal the
//! device's pyramid cell for cell, also when the device's frames are lost or corrupted on the
//! way and the host recovers through snapshots.
#[path = "support/device.rs"]
mod support;

use serde_json::Value;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use support::serve_commands;
use terrain_pyramid::design::{Schedule, SensorModel};
use terrain_pyramid::link::{Link, LinkConfig, SensorCounters};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Evidence, EvidenceClass, Fused, Meters,
    DEFAULT_CELLS_PER_SIDE,
};

const W: usize = DEFAULT_CELLS_PER_SIDE;

/// The longest any one test waits for the device or the binary.
const PATIENCE: Duration = Duration::from_secs(120);

// ------------------------------------------------------------------ the device

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1_u64 << 53) as f64
    }
    fn chance(&mut self, per_mille: u32) -> bool {
        self.below(1000) < u64::from(per_mille)
    }
}

/// How the device's session goes.
#[derive(Clone, Copy)]
struct Plan {
    seed: u64,
    /// Steps of driving and evidence (13 ms of device time each).
    steps: usize,
    /// Steps at the start whose output nobody hears (the host joins mid-stream).
    deaf_steps: usize,
    /// Frames deleted on the way, per mille (during the driving steps only).
    drop_per_mille: u32,
    /// Frames with one bit flipped on the way, per mille (driving steps only).
    flip_per_mille: u32,
    /// The device is settled when its queue and tiles are empty and the host has sent no
    /// command for this long (longer than the host's snapshot retry on a lossy line).
    quiet_after: Duration,
    /// Once settled: close the socket (end of stream), or go on (sending Stats) until the
    /// host goes away.
    close_when_settled: bool,
}

/// What the device ended with.
struct Served {
    pyramid: Box<DefaultPyramid>,
    dropped: u32,
    flipped: u32,
    snapshots: u32,
}

/// Sends all of `bytes`; `false` when the host is gone.
fn send(stream: &mut TcpStream, mut bytes: &[u8]) -> bool {
    let start = Instant::now();
    while !bytes.is_empty() {
        match stream.write(bytes) {
            Ok(0) => return false,
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::Interrupted => {
                assert!(start.elapsed() < PATIENCE, "the host stopped reading");
                std::thread::sleep(Duration::from_millis(1));
            }
            Err(_) => return false,
        }
    }
    true
}

/// Deletes whole frames and flips bits in others.
struct Channel {
    pending: Vec<u8>,
    dropped: u32,
    flipped: u32,
}

impl Channel {
    fn pass(&mut self, rng: &mut Rng, plan: &Plan, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for &b in bytes {
            self.pending.push(b);
            if b == 0 {
                let mut frame = std::mem::take(&mut self.pending);
                if rng.chance(plan.drop_per_mille) {
                    self.dropped += 1;
                    continue;
                }
                if rng.chance(plan.flip_per_mille) && frame.len() > 1 {
                    let at = rng.below(frame.len() as u64 - 1) as usize;
                    frame[at] ^= 1 << rng.below(8);
                    self.flipped += 1;
                }
                out.extend(frame);
            }
        }
        out
    }
}

fn design() -> DefaultDesign {
    DefaultDesign::new(SensorModel::default(), Schedule::default(), W).unwrap()
}

/// The device: accepts one connection and serves it by `plan`; `settled` is told when the
/// device has settled.
fn serve(listener: TcpListener, plan: Plan, settled: mpsc::Sender<()>) -> Served {
    listener.set_nonblocking(true).unwrap();
    let start = Instant::now();
    let mut stream = loop {
        match listener.accept() {
            Ok((stream, _)) => break stream,
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                assert!(start.elapsed() < PATIENCE, "the host never connected");
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => panic!("accept: {e}"),
        }
    };
    stream.set_nonblocking(true).unwrap();
    let mut rng = Rng(plan.seed | 1);
    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut link: Box<Link> = Box::new(Link::new(LinkConfig {
        stats_interval_ms: 200,
        ..LinkConfig::DEFAULT
    }));
    pyramid.configure(&design(), &Config::default()).unwrap();
    link.adopt(&design());
    let mut channel = Channel {
        pending: Vec::new(),
        dropped: 0,
        flipped: 0,
    };
    let mut uart = vec![0_u8; 92_160 * 13 / 1000];
    let mut rx = vec![0_u8; 1024];
    let (mut x, mut y) = (0.0_f64, 0.0_f64);
    let mut now_ms = 0_u32;
    let mut last_command = Instant::now();
    let mut settle_start: Option<Instant> = None;
    let mut told = false;
    let mut step = 0_usize;
    loop {
        assert!(start.elapsed() < PATIENCE, "the device never settled");
        let driving = step < plan.steps;
        if driving {
            if rng.chance(20) {
                x += (rng.unit() - 0.5) * 12.0;
                y += (rng.unit() - 0.5) * 12.0;
            } else {
                x += (rng.unit() - 0.5) * 0.3;
                y += (rng.unit() - 0.5) * 0.3;
            }
            let (mx, my) = (Meters::from_num(x), Meters::from_num(y));
            pyramid.recentre(mx, my);
            for _ in 0..60 {
                let k = rng.below(pyramid.layer_count() as u64) as usize;
                let r = pyramid.layer(k).unwrap().resolution();
                pyramid.apply(&Evidence {
                    layer: k as u8,
                    cell_x: r.cell_of(mx) + rng.below(70) as i32 - 35,
                    cell_y: r.cell_of(my) + rng.below(70) as i32 - 35,
                    class: if rng.chance(300) {
                        EvidenceClass::Obstacle
                    } else {
                        EvidenceClass::Navigable
                    },
                    weight: terrain_pyramid::Weight::from_num(rng.unit()),
                });
            }
        }
        now_ms += 13;
        link.poll(now_ms, &mut *pyramid, &SensorCounters::default());
        let n = link.pop_bytes(&mut uart);
        let out = if step < plan.deaf_steps {
            Vec::new()
        } else if driving {
            channel.pass(&mut rng, &plan, &uart[..n])
        } else {
            uart[..n].to_vec()
        };
        if !send(&mut stream, &out) {
            break;
        }
        // The host's commands.
        let mut host_gone = false;
        loop {
            match stream.read(&mut rx) {
                Ok(0) => {
                    host_gone = true;
                    break;
                }
                Ok(n) => {
                    if serve_commands(&mut link, &mut pyramid, &rx[..n]) {
                        last_command = Instant::now();
                    }
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => {
                    host_gone = true;
                    break;
                }
            }
        }
        if host_gone {
            break;
        }
        if !driving {
            let settling = *settle_start.get_or_insert_with(Instant::now);
            let quiet = link.queue().is_empty()
                && (0..pyramid.layer_count()).all(|k| pyramid.layer(k).unwrap().dirty() == 0)
                && last_command.elapsed() >= plan.quiet_after
                && settling.elapsed() >= plan.quiet_after;
            if quiet && !told {
                told = true;
                let _ = settled.send(());
                if plan.close_when_settled {
                    break;
                }
            }
        }
        step += 1;
        std::thread::sleep(Duration::from_millis(2));
    }
    let c = link.counters();
    Served {
        pyramid,
        dropped: channel.dropped,
        flipped: channel.flipped,
        snapshots: c.snapshots,
    }
}

/// A device listening on 127.0.0.1 (a free port): its port, its thread, and the channel it
/// says "settled" on.
fn device(plan: Plan) -> (u16, JoinHandle<Served>, mpsc::Receiver<()>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::spawn(move || serve(listener, plan, tx));
    (port, handle, rx)
}

// ------------------------------------------------------------------ the host

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("listen-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn listen(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .arg("listen")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the pyramid binary runs")
}

/// Waits for the binary (killing it after [`PATIENCE`]) and collects its output.
fn finish(mut child: Child) -> Output {
    let start = Instant::now();
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
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > PATIENCE {
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(20));
    };
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

fn raw_cells(p: &DefaultPyramid, k: usize) -> Vec<i16> {
    let layer = p.layer(k).unwrap();
    (0..W * W)
        .map(|n| layer.at_offset(n % W, n / W).unwrap().to_raw())
        .collect()
}

fn fnv1a64(cells: &[i16]) -> String {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for byte in cells.iter().flat_map(|c| c.to_le_bytes()) {
        h ^= u64::from(byte);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    format!("{h:016x}")
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
    let fine = p.layer(0).unwrap().resolution();
    let coarse = p.layer(p.layer_count() - 1).unwrap();
    let (ox, oy) = coarse.origin();
    let (x0, y0) = (
        coarse.resolution().cell_edge(ox),
        coarse.resolution().cell_edge(oy),
    );
    let extent = W as i64 * i64::from(coarse.resolution().to_bits());
    let n = ((extent + i64::from(fine.to_bits()) - 1) / i64::from(fine.to_bits())) as usize;
    let mut fused = vec![Fused::Unknown; n * n];
    p.fused_region(x0, y0, fine.meters(), n, n, &mut fused)
        .unwrap();
    let pixels: Vec<u8> = fused
        .iter()
        .map(|f| match f {
            Fused::Obstacle { .. } => 0,
            Fused::Navigable { .. } => 254,
            Fused::Unknown => 205,
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

fn clean(seed: u64) -> Plan {
    Plan {
        seed,
        steps: 200,
        deaf_steps: 0,
        drop_per_mille: 0,
        flip_per_mille: 0,
        quiet_after: Duration::from_millis(700),
        close_when_settled: true,
    }
}

// ------------------------------------------------------------------ tests

#[test]
fn a_clean_stream_is_written_cell_for_cell_when_the_device_closes() {
    let (port, device, _) = device(clean(7));
    let dir = scratch("clean");
    let addr = format!("127.0.0.1:{port}");
    let child = listen(&["--tcp", &addr, "--out", dir.to_str().unwrap(), "--json"]);
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
        drop_per_mille: 30,
        flip_per_mille: 30,
        // Longer than the host's retry of an unanswered request (2 s).
        quiet_after: Duration::from_millis(2600),
        ..clean(42)
    };
    let (port, device, _) = device(plan);
    let dir = scratch("lossy");
    let addr = format!("127.0.0.1:{port}");
    let child = listen(&["--tcp", &addr, "--out", dir.to_str().unwrap(), "--json"]);
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
    let dir = scratch("duration");
    let addr = format!("127.0.0.1:{port}");
    let start = Instant::now();
    let child = listen(&[
        "--tcp",
        &addr,
        "--out",
        dir.to_str().unwrap(),
        "--json",
        "--duration-s",
        "6",
    ]);
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
    let dir = scratch("interrupt");
    let addr = format!("127.0.0.1:{port}");
    let child = listen(&["--tcp", &addr, "--out", dir.to_str().unwrap(), "--json"]);
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
    let dir = scratch("unreachable");
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
    let dir = scratch("silent");
    let addr = format!("127.0.0.1:{port}");
    let out = finish(listen(&["--tcp", &addr, "--out", dir.to_str().unwrap()]));
    server.join().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("error: no maps to write"), "{stderr}");
    assert!(!dir.join("summary.json").exists());
}
