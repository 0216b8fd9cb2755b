//! The relay of `lab live` between listen's TCP connection and the board's host-link UART:
//! the bytes passed both ways, the time exchanges and stamped Poses timed on the wall clock
//! as they pass, the lab's own frames injected between listen's, and a mirror of the maps.
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};
use terrain_pyramid::wire::link::{FrameAccumulator, Message, PoseReport};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid_host::link::{HostLink, LinkEvent};

/// The wall clock, µs since the Unix epoch.
fn wall_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

/// What the relay saw pass between listen and the board, timed on the wall clock (µs since
/// the epoch) as it read it.
#[derive(Debug, Default)]
pub(super) struct Tap {
    /// TimeRequests from listen: its `host_us` → when the relay read it (just before
    /// handing it to the board).
    requests: HashMap<u64, u64>,
    /// Time exchanges seen whole: (request read, reply read, the device's µs in the reply).
    pub(super) exchanges: Vec<(u64, u64, u32)>,
    /// Stamped Poses from listen: (when read, the pose).
    pub(super) poses: Vec<(u64, PoseReport)>,
    /// The device's Stats as read: (when read, the laser bytes it had taken by then, the
    /// host-link frames it had taken whole).
    pub(super) stats: Vec<(u64, u32, u32)>,
}

/// Frames of the lab's own for the board (the recording's PanAngles, the RequestStats that
/// time the board's laser bytes), written into the host link between listen's frames: at once
/// when listen's stream is between frames, else as soon as its frame in progress has ended.
pub(super) struct Injector {
    /// The board's side of the link, once the relay has a client.
    uart: Option<UnixStream>,
    /// Whether listen's last bytes ended a frame.
    idle: bool,
    /// Frames waiting for listen's frame to end, each with whether it is a PanAngle.
    pending: Vec<(Vec<u8>, bool)>,
    /// PanAngles written.
    pub(super) written: usize,
    /// When each PanAngle was written to the board's UART, wall-clock µs since the epoch (in
    /// the order sent; a frame lost with the link has none).
    pub(super) angles_at: Vec<u64>,
    /// When each frame the relay wrote to the board (listen's and the lab's, in the order of
    /// the stream) was written, wall-clock µs since the epoch.
    pub(super) frames_at: Vec<u64>,
}

impl Injector {
    /// Writes `frame` now, or queues it until listen's frame in progress has ended;
    /// `angle`: it is a PanAngle (its time is kept).
    pub(super) fn send(&mut self, frame: &[u8], angle: bool) {
        self.pending.push((frame.to_vec(), angle));
        self.flush();
    }

    fn flush(&mut self) {
        if !self.idle || self.pending.is_empty() {
            return;
        }
        if let Some(u) = self.uart.as_mut() {
            for (frame, angle) in self.pending.drain(..) {
                if u.write_all(&frame).is_ok() {
                    let at = wall_us();
                    self.frames_at.push(at);
                    if angle {
                        self.written += 1;
                        self.angles_at.push(at);
                    }
                }
            }
        }
    }
}

/// The relay's threads: the tap, and the device's stream mirrored as listen mirrors it.
pub(super) struct Relay {
    pub(super) tap: Arc<Mutex<Tap>>,
    pub(super) inject: Arc<Mutex<Injector>>,
    pub(super) stop: Arc<AtomicBool>,
    pub(super) mirror: std::thread::JoinHandle<HostLink>,
}

/// Relays the link between the board's UART and the first TCP client of `listener`, until
/// either side closes; decodes both directions on the way ([`Tap`]) and keeps a host's mirror
/// of the device's maps from the same bytes listen receives.
pub(super) fn relay(listener: TcpListener, uart1: UnixStream) -> Relay {
    let tap = Arc::new(Mutex::new(Tap::default()));
    let inject = Arc::new(Mutex::new(Injector {
        uart: None,
        idle: true,
        pending: Vec::new(),
        written: 0,
        angles_at: Vec::new(),
        frames_at: Vec::new(),
    }));
    let inject2 = Arc::clone(&inject);
    let stop = Arc::new(AtomicBool::new(false));
    let (tap2, stop2) = (Arc::clone(&tap), Arc::clone(&stop));
    let mirror = std::thread::spawn(move || {
        let mut host = HostLink::new();
        let Ok((tcp, _)) = listener.accept() else {
            return host;
        };
        let _ = tcp.set_nodelay(true);
        let _ = uart1.set_read_timeout(Some(Duration::from_millis(100)));
        // A board that stops taking the host link's bytes fails the writes, never holds them.
        let _ = uart1.set_write_timeout(Some(Duration::from_secs(5)));
        let (Ok(mut tcp_r), Ok(uart_w)) = (tcp.try_clone(), uart1.try_clone()) else {
            return host;
        };
        if let Ok(mut i) = inject2.lock() {
            i.uart = Some(uart_w);
        }
        let tap_in = Arc::clone(&tap2);
        std::thread::spawn(move || {
            let mut frames: Box<FrameAccumulator<4096>> = Box::new(FrameAccumulator::new());
            let mut buf = [0_u8; 4096];
            while let Ok(n) = tcp_r.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let at = wall_us();
                let mut rest = buf.get(..n).unwrap_or_default();
                let mut ended = false;
                let mut completed = 0;
                loop {
                    match frames.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item, remaining, ..
                        } => {
                            if let Ok(mut t) = tap_in.lock() {
                                match item.message {
                                    Message::TimeRequest(r) => {
                                        t.requests.insert(r.host_us, at);
                                    }
                                    Message::Pose(p) if p.is_stamped() => t.poses.push((at, p)),
                                    _ => {}
                                }
                            }
                            ended = remaining.is_empty();
                            rest = remaining;
                            completed += 1;
                        }
                        FeedResult::Rejected { remaining, .. } => {
                            ended = remaining.is_empty();
                            rest = remaining;
                        }
                    }
                }
                let Ok(mut i) = inject2.lock() else {
                    break;
                };
                let Some(u) = i.uart.as_mut() else {
                    break;
                };
                if u.write_all(buf.get(..n).unwrap_or_default()).is_err() {
                    break;
                }
                let written = wall_us();
                i.frames_at.extend(std::iter::repeat_n(written, completed));
                i.idle = ended;
                i.flush();
            }
        });
        let (mut uart_r, mut tcp_w) = (uart1, tcp);
        let mut listening = true;
        let mut buf = [0_u8; 4096];
        while !stop2.load(Ordering::Relaxed) {
            let n = match uart_r.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if super::read_timed_out(&e) => continue,
                Err(_) => break,
            };
            let at = wall_us();
            let bytes = buf.get(..n).unwrap_or_default();
            for event in host.feed(bytes) {
                match event {
                    LinkEvent::TimeReply(r) => {
                        if let Ok(mut t) = tap2.lock() {
                            if let Some(sent) = t.requests.get(&r.host_us).copied() {
                                t.exchanges.push((sent, at, r.device_us));
                            }
                        }
                    }
                    LinkEvent::Stats(s) => {
                        if let Ok(mut t) = tap2.lock() {
                            t.stats.push((at, s.laser_bytes, s.rx_frames_ok));
                        }
                    }
                    _ => {}
                }
            }
            // Once listen has gone, the board's output is still read (and dropped): a board
            // whose output stalls stops reading its input, and the lab's writes would hang.
            if listening && tcp_w.write_all(bytes).is_err() {
                listening = false;
            }
        }
        host
    });
    Relay {
        tap,
        inject,
        stop,
        mirror,
    }
}
