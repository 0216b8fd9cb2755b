//! Measures the host link's traffic for the default pyramid at the laser's full rate.
//!
//! A robot drives along +x at 1 m/s over flat ground with box-shaped obstacles. A SICK LMS
//! scans a vertical plane (−90° ..= +90° elevation, the paper's mounting) from 1 m above the
//! ground, panned about the vertical axis by ψ = 2° per line. Each line's returns are ray-cast
//! in f64, fed to the library's classifier (one observation per line), and its evidence is
//! integrated; the pyramid recentres on the robot, and the link is polled once per line. The
//! UART drains the queue at 92 160 bytes/s (921 600 Bd); the link's budget is half of that.
//!
//! Reported: bytes per second on the link (all frames, and patches alone), and the delay from
//! a line's evidence arriving to the patch that carries its change leaving the queue (the
//! worst over every changed tile, measured to the end of the poll's last byte).
//!
//! ```sh
//! cargo run --release --example link_rate            # both laser modes, 60 s each
//! cargo run --release --example link_rate -- 120     # 120 s each
//! ```
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::cast_possible_truncation,
    clippy::cast_precision_loss
)]

use std::collections::VecDeque;
use terrain_pyramid::classify::Classifier;
use terrain_pyramid::link::{Link, LinkConfig, SensorCounters};
use terrain_pyramid::wire::link::{Decoded, FrameAccumulator, Message, MAX_FRAME};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Meters, Point3, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};

/// The UART's byte rate at 921 600 Bd, 8N1.
const UART_BYTES_PER_S: f64 = 92_160.0;
/// Sensor height above the ground, metres.
const SENSOR_HEIGHT_M: f64 = 1.0;
/// The design's maximum range: returns beyond it are dropped.
const MAX_RANGE_M: f64 = 10.0;
/// Robot speed, m/s.
const SPEED_M_S: f64 = 1.0;
/// Pan step per line, degrees (the design's ψ).
const PAN_STEP_DEG: f64 = 2.0;

/// An axis-aligned box on the ground.
struct Obstacle {
    min: [f64; 3],
    max: [f64; 3],
}

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1_u64 << 53) as f64
    }
    /// A roughly normal sample (sum of uniforms), standard deviation 1.
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.unit()).sum::<f64>() - 6.0
    }
}

/// Boxes 0.2–0.6 m tall, 0.3–1 m wide, scattered within ±6 m of the path, about one per
/// 2 m of travel.
fn obstacles(length_m: f64, rng: &mut Rng) -> Vec<Obstacle> {
    let mut out = Vec::new();
    let mut x = 3.0;
    while x < length_m + 10.0 {
        let y = (rng.unit() - 0.5) * 12.0;
        if y.abs() > 0.8 {
            let w = 0.3 + 0.7 * rng.unit();
            let d = 0.3 + 0.7 * rng.unit();
            let h = 0.2 + 0.4 * rng.unit();
            out.push(Obstacle {
                min: [x, y, 0.0],
                max: [x + d, y + w, h],
            });
        }
        x += 1.0 + 2.0 * rng.unit();
    }
    out
}

/// The distance along a ray to the nearest surface (ground or box), or `None` within range.
fn cast(origin: [f64; 3], dir: [f64; 3], boxes: &[Obstacle]) -> Option<f64> {
    let mut best = if dir[2] < -1e-9 {
        -origin[2] / dir[2]
    } else {
        f64::INFINITY
    };
    for b in boxes {
        // Slab test.
        let (mut t0, mut t1) = (0.0_f64, best);
        let mut hit = true;
        for a in 0..3 {
            if dir[a].abs() < 1e-12 {
                if origin[a] < b.min[a] || origin[a] > b.max[a] {
                    hit = false;
                    break;
                }
            } else {
                let (mut ta, mut tb) = (
                    (b.min[a] - origin[a]) / dir[a],
                    (b.max[a] - origin[a]) / dir[a],
                );
                if ta > tb {
                    std::mem::swap(&mut ta, &mut tb);
                }
                t0 = t0.max(ta);
                t1 = t1.min(tb);
                if t0 > t1 {
                    hit = false;
                    break;
                }
            }
        }
        if hit && t0 < best {
            best = t0;
        }
    }
    (best.is_finite()).then_some(best)
}

struct Result {
    seconds: f64,
    bytes: u64,
    patch_bytes: u64,
    patches: u64,
    records: u64,
    delays_ms: Vec<f64>,
    max_queue: usize,
    deferred: u32,
}

/// Runs `seconds` of driving with `returns` beams per line at `lines_per_s`.
fn run(lines_per_s: f64, returns: usize, seconds: f64, config: LinkConfig) -> Result {
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let boxes = obstacles(SPEED_M_S * seconds, &mut rng);
    let mut pyramid = Box::new(DefaultPyramid::new());
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap();
    let mut link: Box<Link> = Box::new(Link::new(config));
    pyramid.configure(&design, &Config::default()).unwrap();
    link.adopt(&design);
    let mut classifier: Box<Classifier<1024, 8>> = Box::new(Classifier::new());
    classifier
        .adopt_design(&design, Config::default().model.increments().unwrap())
        .unwrap();
    let layers = pyramid.layer_count();
    // The time each tile's oldest unsent change arrived, seconds.
    let mut pending: Vec<[Option<f64>; 64]> = vec![[None; 64]; layers];
    let mut delays_ms = Vec::new();
    let (mut records, mut patch_bytes, mut patches) = (0_u64, 0_u64, 0_u64);
    let mut max_queue = 0;
    let line_dt = 1.0 / lines_per_s;
    let n_lines = (seconds * lines_per_s) as usize;
    let mut last_t = 0.0;
    let mut uart = vec![0_u8; 4096];
    let fan_step = 180.0 / (returns - 1) as f64;
    // What the host decodes as the UART sends it.
    let mut host = Box::new(FrameAccumulator::<MAX_FRAME>::new());
    // Per tile, the arrival times of the changes carried by patches queued but not yet out.
    let mut in_flight: Vec<Vec<VecDeque<f64>>> = vec![vec![VecDeque::new(); 64]; layers];
    // The delivery whose further pieces update its delay: (layer, tile, index in delays).
    let mut delivering: Option<(usize, usize, usize, f64)> = None;
    let w = DEFAULT_CELLS_PER_SIDE as i32;
    for line in 0..n_lines {
        let t = line as f64 * line_dt;
        // The UART sent, back to back from the last poll on, what it could since.
        let can = ((t - last_t) * UART_BYTES_PER_S) as usize;
        let n = link.pop_bytes(&mut uart[..can.min(4096)]);
        let mut input = &uart[..n];
        loop {
            let start = n - input.len();
            match host.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Item {
                    item: Decoded { message, .. },
                    remaining,
                    ..
                } => {
                    let end = n - remaining.len();
                    let leaves = last_t + end as f64 / UART_BYTES_PER_S;
                    if let Message::LayerPatch(p) = message {
                        patch_bytes += (end - start) as u64;
                        let k = usize::from(p.area.layer);
                        let tx = (p.area.x.rem_euclid(w) * 8 / w) as usize;
                        let ty = (p.area.y.rem_euclid(w) * 8 / w) as usize;
                        let tile = ty * 8 + tx;
                        match delivering {
                            Some((dk, dt, i, t0)) if (dk, dt) == (k, tile) => {
                                // A further piece of the same tile.
                                delays_ms[i] = (leaves - t0) * 1000.0;
                            }
                            _ => {
                                delivering = in_flight[k][tile].pop_front().map(|t0| {
                                    delays_ms.push((leaves - t0) * 1000.0);
                                    (k, tile, delays_ms.len() - 1, t0)
                                });
                            }
                        }
                    } else {
                        delivering = None;
                    }
                    input = remaining;
                }
                FeedResult::Rejected { error, .. } => panic!("{error:?}"),
            }
        }
        last_t = t;
        // The robot and the line.
        let (rx, ry) = (SPEED_M_S * t, 0.0);
        let sensor = [rx, ry, SENSOR_HEIGHT_M];
        let pan = (line as f64 * PAN_STEP_DEG).to_radians();
        classifier.begin(Meters::from_num(SENSOR_HEIGHT_M));
        for i in 0..returns {
            let el = (-90.0 + i as f64 * fan_step).to_radians();
            let dir = [el.cos() * pan.cos(), el.cos() * pan.sin(), el.sin()];
            let Some(range) = cast(sensor, dir, &boxes) else {
                continue;
            };
            let range = range + 0.01 * rng.normal();
            if !(0.05..=MAX_RANGE_M).contains(&range) {
                continue;
            }
            let p = [
                sensor[0] + range * dir[0],
                sensor[1] + range * dir[1],
                sensor[2] + range * dir[2],
            ];
            let horizontal = (range * el.cos()).abs();
            classifier.add_point(
                Point3 {
                    x: Meters::from_num(p[0]),
                    y: Meters::from_num(p[1]),
                    z: Meters::from_num(p[2]),
                },
                Meters::from_num(horizontal),
                Meters::ZERO,
            );
        }
        let before: Vec<u64> = (0..layers)
            .map(|k| pyramid.layer(k).unwrap().dirty())
            .collect();
        let mut line_records = 0;
        classifier.finish(|r| {
            line_records += 1;
            pyramid.apply(&r);
        });
        records += line_records;
        // Tiles whose cells changed now start (or keep) their clock.
        for k in 0..layers {
            let now_dirty = pyramid.layer(k).unwrap().dirty();
            let newly = now_dirty & !before[k];
            for (tile, since) in pending[k].iter_mut().enumerate() {
                if newly & (1 << tile) != 0 && since.is_none() {
                    *since = Some(t);
                }
            }
        }
        pyramid.recentre(Meters::from_num(rx), Meters::from_num(ry));
        let dirty_before: Vec<u64> = (0..layers)
            .map(|k| pyramid.layer(k).unwrap().dirty())
            .collect();
        let report = link.poll(
            (t * 1000.0) as u32,
            &mut pyramid,
            &SensorCounters::default(),
        );
        patches += u64::from(report.patches);
        max_queue = max_queue.max(link.queue().len());
        for k in 0..layers {
            let sent = dirty_before[k] & !pyramid.layer(k).unwrap().dirty();
            for tile in 0..64 {
                if sent & (1 << tile) != 0 {
                    if let Some(t0) = pending[k][tile].take() {
                        in_flight[k][tile].push_back(t0);
                    }
                }
            }
        }
    }
    // Changes still waiting at the end count with their age so far.
    let end = n_lines as f64 * line_dt;
    for tiles in &pending {
        for t0 in tiles.iter().flatten() {
            delays_ms.push((end - t0) * 1000.0);
        }
    }
    for tiles in &in_flight {
        for t0 in tiles.iter().flatten() {
            delays_ms.push((end - t0) * 1000.0);
        }
    }
    Result {
        seconds: end,
        bytes: u64::from(link.counters().bytes_sent),
        patch_bytes,
        patches,
        records,
        delays_ms,
        max_queue,
        deferred: link.counters().patches_deferred,
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

fn main() {
    let seconds: f64 = std::env::args()
        .nth(1)
        .map_or(60.0, |s| s.parse().expect("seconds"));
    let mut config = LinkConfig::DEFAULT;
    if let Some(budget) = std::env::args().nth(2) {
        config.budget_bytes_per_s = budget.parse().expect("budget, bytes per second");
    }
    if let Some(burst) = std::env::args().nth(3) {
        config.burst_bytes = burst.parse().expect("burst, bytes");
    }
    println!(
        "link {} B/s (921600 Bd), budget {} B/s, burst {} B, queue {} B; robot {SPEED_M_S} m/s, \
         pan {PAN_STEP_DEG} deg/line, {seconds} s per mode",
        UART_BYTES_PER_S, config.budget_bytes_per_s, config.burst_bytes, 4096
    );
    for (lines_per_s, returns) in [(75.0, 181), (37.5, 361)] {
        let r = run(lines_per_s, returns, seconds, config);
        let mut d = r.delays_ms.clone();
        d.sort_by(f64::total_cmp);
        let rate = r.bytes as f64 / r.seconds;
        println!(
            "{lines_per_s:>5} lines/s x {returns} returns: {:.0} records/s; link {:.0} B/s \
             ({:.1} % of the line; patches {:.0} B/s, {:.0} patches/s); delay ms: \
             median {:.1}, p99 {:.1}, max {:.1} over {} tile changes; queue max {} B; \
             tiles put back {}",
            r.records as f64 / r.seconds,
            rate,
            100.0 * rate / UART_BYTES_PER_S,
            r.patch_bytes as f64 / r.seconds,
            r.patches as f64 / r.seconds,
            percentile(&d, 0.5),
            percentile(&d, 0.99),
            d.last().copied().unwrap_or(0.0),
            d.len(),
            r.max_queue,
            r.deferred,
        );
    }
}
