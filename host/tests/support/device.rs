//! A simulated device for the tests of `pyramid listen`'s outputs: the library's `Link` and
//! `DefaultPyramid` with random evidence and recentres, serving its stream on 127.0.0.1 (the
//! approach of `host/tests/listen.rs`). It can wait for a go before it drives, and drop its
//! connection once and accept a new one (the TCP analogue of a USB adapter unplugged).
#![allow(dead_code)]
#[path = "accept.rs"]
mod accept;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use terrain_pyramid::design::{Schedule, SensorModel};
use terrain_pyramid::link::{Link, LinkConfig, Request, SensorCounters};
use terrain_pyramid::wire::link::{FirmwareVersion, Hello, HelloReason, LayerInfo, Message, Reply};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Evidence, EvidenceClass, Fused, Meters,
    DEFAULT_CELLS_PER_SIDE,
};

/// Cells per side.
pub const W: usize = DEFAULT_CELLS_PER_SIDE;

/// The longest any one wait lasts.
pub const PATIENCE: Duration = Duration::from_secs(120);

/// xorshift64*.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1_u64 << 53) as f64
    }
    pub fn chance(&mut self, per_mille: u32) -> bool {
        self.below(1000) < u64::from(per_mille)
    }
}

/// A serial line that forwards whole frames (ending at a 0 byte), deleting some and flipping
/// a bit in others.
pub struct Channel {
    /// Bytes of the frame still open.
    pub pending: Vec<u8>,
    /// Frames deleted, per mille.
    pub drop_per_mille: u32,
    /// Frames with one bit flipped, per mille.
    pub flip_per_mille: u32,
    /// Frames deleted so far.
    pub dropped: u32,
    /// Frames flipped so far.
    pub flipped: u32,
}

impl Channel {
    /// A line that deletes and flips frames at these rates (per mille).
    pub fn new(drop_per_mille: u32, flip_per_mille: u32) -> Self {
        Self {
            pending: Vec::new(),
            drop_per_mille,
            flip_per_mille,
            dropped: 0,
            flipped: 0,
        }
    }

    /// The frames of `bytes` that get through (each draws from `rng` whatever its rates).
    pub fn pass(&mut self, rng: &mut Rng, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for &b in bytes {
            self.pending.push(b);
            if b == 0 {
                let mut frame = std::mem::take(&mut self.pending);
                if rng.chance(self.drop_per_mille) {
                    self.dropped += 1;
                    continue;
                }
                if rng.chance(self.flip_per_mille) && frame.len() > 1 {
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

/// One step of the robot's random walk from (`x`, `y`), metres: mostly small steps, sometimes
/// a jump of several metres. Returns the new position.
pub fn wander(rng: &mut Rng, x: &mut f64, y: &mut f64) -> (Meters, Meters) {
    if rng.chance(20) {
        *x += (rng.unit() - 0.5) * 12.0;
        *y += (rng.unit() - 0.5) * 12.0;
    } else {
        *x += (rng.unit() - 0.5) * 0.3;
        *y += (rng.unit() - 0.5) * 0.3;
    }
    (Meters::from_num(*x), Meters::from_num(*y))
}

/// Applies `count` random evidence updates (30 % obstacle) to random layers within 35 cells
/// of (`mx`, `my`).
pub fn scatter(rng: &mut Rng, pyramid: &mut DefaultPyramid, mx: Meters, my: Meters, count: usize) {
    for _ in 0..count {
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

/// How the device's session goes.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub seed: u64,
    /// Steps of driving (13 ms of device time each, about 2 ms of real time).
    pub steps: usize,
    /// Real time per step (the device's clock advances 13 ms per step regardless).
    pub step_sleep: Duration,
    /// Settled = queue and tiles empty and no host command for this long.
    pub quiet_after: Duration,
    /// Once settled: close (end of stream) or go on until the host goes away.
    pub close_when_settled: bool,
    /// Drop the connection at this driving step, drive on unheard for `unplugged_steps`, then
    /// accept the host's next connection.
    pub unplug_at: Option<usize>,
    pub unplugged_steps: usize,
    /// Evidence updates per step (176 per 13 ms is the SICK LMS2xx's 13 575 points/s).
    pub evidence_per_step: usize,
    /// Steps at the start whose output nobody hears (the host joins mid-stream).
    pub deaf_steps: usize,
    /// The line between device and host during the driving steps: frames deleted and
    /// flipped, per mille (`None`: a clean line that draws nothing from the generator).
    pub loss: Option<(u32, u32)>,
}

impl Plan {
    pub fn clean(seed: u64) -> Self {
        Self {
            seed,
            steps: 200,
            step_sleep: Duration::from_millis(2),
            quiet_after: Duration::from_millis(700),
            close_when_settled: true,
            unplug_at: None,
            unplugged_steps: 0,
            evidence_per_step: 60,
            deaf_steps: 0,
            loss: None,
        }
    }
}

/// What the device ended with.
pub struct Served {
    pub pyramid: Box<DefaultPyramid>,
    pub snapshots: u32,
    pub connections: u32,
    pub bytes_sent: u64,
    /// Frames the line deleted and flipped.
    pub dropped: u32,
    pub flipped: u32,
}

/// A running device.
pub struct Device {
    pub port: u16,
    pub handle: JoinHandle<Served>,
    /// Told once the device has settled.
    pub settled: mpsc::Receiver<()>,
    /// The device drives only once this is set.
    pub go: Arc<AtomicBool>,
}

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

fn accept(listener: &TcpListener) -> TcpStream {
    accept::accept(listener, PATIENCE, true)
}

/// Carries out the commands `pyramid listen` sends a device (snapshots, Stats, pings, time
/// requests), as the application core does ([`Link::serve`]); the rest is answered Ok.
/// Returns whether any was other than a TimeRequest (the host's time exchange goes on all the
/// session: it does not keep a device from settling).
pub fn serve_commands(link: &mut Link, pyramid: &mut DefaultPyramid, bytes: &[u8]) -> bool {
    let mut commanded = false;
    each_request(link, bytes, |link, request| {
        commanded |= !matches!(
            request.command,
            terrain_pyramid::link::Command::TimeRequest { .. }
        );
        if let Some(other) = link.serve(pyramid, request) {
            link.answer(Reply::ok(other.header));
        }
    });
    commanded
}

/// Hands host bytes to the device's link and every request it decodes, in order, to
/// `request` with the link (the link counts and skips the frames it refuses).
pub fn each_request<const Q: usize, const N: usize>(
    link: &mut Link<Q, N>,
    bytes: &[u8],
    mut request: impl FnMut(&mut Link<Q, N>, Request<N>),
) {
    let mut input = bytes;
    loop {
        input = match link.receive(input) {
            FeedResult::Consumed => return,
            FeedResult::Item {
                item, remaining, ..
            } => {
                request(link, item);
                remaining
            }
            FeedResult::Rejected { remaining, .. } => remaining,
        };
    }
}

/// The default design.
pub fn design() -> DefaultDesign {
    DefaultDesign::new(SensorModel::default(), Schedule::default(), W).unwrap()
}

/// A device just booted: the default pyramid configured with the default design, and its
/// link (Stats every 200 ms) announcing that design.
pub fn booted() -> (Box<DefaultPyramid>, Box<Link>) {
    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut link: Box<Link> = Box::new(Link::new(LinkConfig {
        stats_interval_ms: 200,
        ..LinkConfig::DEFAULT
    }));
    pyramid.configure(&design(), &Config::default()).unwrap();
    link.adopt(&design());
    (pyramid, link)
}

fn serve(
    listener: TcpListener,
    plan: Plan,
    settled: mpsc::Sender<()>,
    go: Arc<AtomicBool>,
) -> Served {
    listener.set_nonblocking(true).unwrap();
    let start = Instant::now();
    let mut stream = Some(accept(&listener));
    let mut connections = 1;
    let mut rng = Rng(plan.seed | 1);
    let (mut pyramid, mut link) = booted();
    let mut channel = plan.loss.map(|(drop, flip)| Channel::new(drop, flip));
    let mut uart = vec![0_u8; 92_160 * 13 / 1000];
    let mut rx = vec![0_u8; 1024];
    let (mut x, mut y) = (0.0_f64, 0.0_f64);
    let mut now_ms = 0_u32;
    let mut last_command = Instant::now();
    let mut settle_start: Option<Instant> = None;
    let mut told = false;
    let mut step = 0_usize;
    let mut bytes_sent = 0_u64;
    let mut unplugged_until: Option<usize> = None;
    loop {
        assert!(start.elapsed() < PATIENCE * 2, "the device never settled");
        let going = go.load(Ordering::SeqCst);
        let driving = going && step < plan.steps;
        if driving {
            if plan.unplug_at == Some(step) && unplugged_until.is_none() {
                stream = None;
                unplugged_until = Some(step + plan.unplugged_steps);
            }
            let (mx, my) = wander(&mut rng, &mut x, &mut y);
            pyramid.recentre(mx, my);
            scatter(&mut rng, &mut pyramid, mx, my, plan.evidence_per_step);
        }
        now_ms += 13;
        link.poll(now_ms, &mut *pyramid, &SensorCounters::default());
        let n = link.pop_bytes(&mut uart);
        if stream.is_none() && unplugged_until.is_some_and(|u| step >= u) {
            // Back: the host's next connection.
            stream = Some(accept(&listener));
            connections += 1;
            unplugged_until = Some(usize::MAX);
        }
        let heard = match channel.as_mut() {
            _ if step < plan.deaf_steps => Vec::new(),
            Some(channel) if driving => channel.pass(&mut rng, &uart[..n]),
            _ => uart[..n].to_vec(),
        };
        if let Some(s) = stream.as_mut() {
            if !send(s, &heard) {
                break;
            }
            bytes_sent += heard.len() as u64;
            let mut host_gone = false;
            loop {
                match s.read(&mut rx) {
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
        }
        if going && !driving && stream.is_some() {
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
        if going {
            step += 1;
        }
        std::thread::sleep(plan.step_sleep);
    }
    Served {
        pyramid,
        snapshots: link.counters().snapshots,
        connections,
        bytes_sent,
        dropped: channel.as_ref().map_or(0, |c| c.dropped),
        flipped: channel.as_ref().map_or(0, |c| c.flipped),
    }
}

/// A device on 127.0.0.1 (a free port); it drives at once when `go_now`.
pub fn device(plan: Plan, go_now: bool) -> Device {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let (tx, rx) = mpsc::channel();
    let go = Arc::new(AtomicBool::new(go_now));
    let flag = Arc::clone(&go);
    let handle = std::thread::spawn(move || serve(listener, plan, tx, flag));
    Device {
        port,
        handle,
        settled: rx,
        go,
    }
}

/// Layer `k`'s raw cells, row-major from the lowest row.
pub fn raw_cells(p: &DefaultPyramid, k: usize) -> Vec<i16> {
    let layer = p.layer(k).unwrap();
    (0..W * W)
        .map(|n| layer.at_offset(n % W, n / W).unwrap().to_raw())
        .collect()
}

/// FNV-1a 64 of raw cells as i16 little-endian, hex (as `summary.json`).
pub fn fnv1a64(cells: &[i16]) -> String {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for byte in cells.iter().flat_map(|c| c.to_le_bytes()) {
        h ^= u64::from(byte);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    format!("{h:016x}")
}

/// The fused map over the coarsest window at the finest resolution (`fused.pgm`'s cells), as
/// OccupancyGrid values, rows from the lowest y; and its side.
pub fn fused_occupancy(p: &DefaultPyramid) -> (Vec<i8>, usize) {
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
    let values = fused
        .iter()
        .map(|f| match f {
            Fused::Obstacle { .. } => 100,
            Fused::Navigable { .. } => 0,
            Fused::Unknown => -1,
        })
        .collect();
    (values, n)
}

/// A fresh directory `<test>-<name>` for one test.
pub fn scratch(test: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{test}-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `pyramid listen` with these arguments, its output piped.
pub fn listen(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .arg("listen")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the pyramid binary runs")
}

/// `pyramid listen --tcp 127.0.0.1:<port> --out <dir> --json` and the `extra` arguments, its
/// output piped.
pub fn listen_json(port: u16, dir: &Path, extra: &[&str]) -> Child {
    let addr = format!("127.0.0.1:{port}");
    let out = dir.to_str().unwrap();
    let mut args = vec!["--tcp", &addr, "--out", out, "--json"];
    args.extend_from_slice(extra);
    listen(&args)
}

/// Waits for `child`, killing it after [`PATIENCE`].
pub fn wait_or_kill(child: &mut Child) -> ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > PATIENCE {
            let _ = child.kill();
            return child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The Hello of a booting device (protocol 1): windows of `cells_per_side` cells a side and
/// `layers` layers of 0.1 m cells (6554 in Q16.16) over the band 0 ..= 0.5 m, every window's
/// lower-left cell at (`origin`, `origin`).
pub fn hello_message(cells_per_side: u16, layers: usize, origin: i32) -> Message<'static> {
    let mut hello = Hello {
        protocol: 1,
        firmware: FirmwareVersion::default(),
        reason: HelloReason::Boot,
        cells_per_side,
        resend: 0,
        clock: Default::default(),
        layers: Default::default(),
    };
    for _ in 0..layers {
        hello
            .layers
            .push(LayerInfo {
                resolution_q16: 6554,
                band_inner_m: 0.0,
                band_outer_m: 0.5,
                origin_x: origin,
                origin_y: origin,
            })
            .unwrap();
    }
    Message::Hello(hello)
}
