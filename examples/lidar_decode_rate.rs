//! The spinning-lidar accumulators' decode rate on the host.
//!
//! For each format, builds about 20 MB of a realistic stream (a smooth wall with noise and a
//! few no-returns, the angle advancing as on a 10 Hz sensor, a burst of garbage between about
//! one unit in 50), feeds it in 64-byte chunks as a UART driver would, and prints MB/s and
//! returns/s: once for reassembly alone (synchronisation and checks), once with every return
//! decoded (angles interpolated, the YDLIDAR correction, the RPLIDAR capsule compensation).
//!
//! Run with `cargo run --release --example lidar_decode_rate`.
mod common;

use common::XorShift;
use std::error::Error;
use std::hint::black_box;
use std::time::{Duration, Instant};
use terrain_pyramid::wire::ld06::{Ld06Accumulator, Ld06Point, Ld06Repr};
use terrain_pyramid::wire::rplidar::{
    RplidarAccumulator, RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarItem, RplidarNodeRepr,
};
use terrain_pyramid::wire::ydlidar::{YdlidarAccumulator, YdlidarItem, YdlidarRepr};
use terrain_pyramid::wire::{FeedResult, LaserReturn};

/// Bytes of stream to build per format.
const TARGET_BYTES: usize = 20_000_000;
/// Bytes per feed call.
const CHUNK: usize = 64;

/// A wall distance in millimetres for sample `i`, with noise; 0 (no return) one time in 16.
fn wall_mm(rng: &mut XorShift, i: u64) -> u16 {
    if rng.next().is_multiple_of(16) {
        return 0;
    }
    (500 + (i * 7) % 6000 + rng.next() % 16) as u16
}

fn garbage(rng: &mut XorShift, stream: &mut Vec<u8>) {
    if rng.next().is_multiple_of(50) {
        let len = 1 + rng.next() % 32;
        stream.extend((0..len).map(|_| rng.next() as u8));
    }
}

/// Appends the unit of `N` bytes `emit` writes, then, after one unit in `garbage_one_in`
/// (every unit for 1), the chance of garbage [`garbage`] gives.
fn push_unit<const N: usize, E: Error + 'static>(
    rng: &mut XorShift,
    stream: &mut Vec<u8>,
    garbage_one_in: u64,
    emit: impl FnOnce(&mut [u8]) -> Result<usize, E>,
) -> Result<(), Box<dyn Error>> {
    let mut unit = [0; N];
    emit(&mut unit)?;
    stream.extend_from_slice(&unit);
    if garbage_one_in == 1 || rng.next().is_multiple_of(garbage_one_in) {
        garbage(rng, stream);
    }
    Ok(())
}

fn ld06_stream(rng: &mut XorShift) -> Result<Vec<u8>, Box<dyn Error>> {
    let mut stream = Vec::with_capacity(TARGET_BYTES + 1024);
    let mut angle = 0_u32;
    let mut i = 0_u64;
    while stream.len() < TARGET_BYTES {
        let mut points = [Ld06Point::default(); 12];
        for p in &mut points {
            p.distance_mm = wall_mm(rng, i);
            p.intensity = (rng.next() % 256) as u8;
            i += 1;
        }
        // 4 500 points/s at 10 Hz: 0.8° per point, 8.8° per packet.
        let repr = Ld06Repr {
            speed_deg_per_s: 3600,
            start_angle_centideg: (angle % 36_000) as u16,
            end_angle_centideg: ((angle + 880) % 36_000) as u16,
            timestamp_ms: (i % 30_000) as u16,
            points,
        };
        angle += 960;
        push_unit::<47, _>(rng, &mut stream, 1, |b| repr.emit(b))?;
    }
    Ok(stream)
}

fn ydlidar_stream(rng: &mut XorShift) -> Result<Vec<u8>, Box<dyn Error>> {
    let mut stream = vec![0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
    let mut angle = 0_u32;
    let mut i = 0_u64;
    let mut samples = [0_u16; 40];
    while stream.len() < TARGET_BYTES {
        for s in &mut samples {
            *s = wall_mm(rng, i).saturating_mul(4);
            i += 1;
        }
        // 5 000 samples/s at 7 Hz: about 0.5° per sample.
        let repr = YdlidarRepr {
            packet_type: 0,
            first_angle_q6: (angle % 23_040) as u16,
            last_angle_q6: ((angle + 1248) % 23_040) as u16,
            samples: &samples,
        };
        angle += 1280;
        push_unit::<90, _>(rng, &mut stream, 1, |b| repr.emit(b))?;
    }
    Ok(stream)
}

fn rplidar_node_stream(rng: &mut XorShift) -> Result<Vec<u8>, Box<dyn Error>> {
    let mut stream = vec![0; 7];
    RplidarDescriptorRepr::SCAN.emit(&mut stream)?;
    let mut angle = 0_u32;
    let mut i = 0_u64;
    while stream.len() < TARGET_BYTES {
        // 8 000 samples/s at 10 Hz: 0.45° per node.
        let q6 = angle % 23_040;
        let repr = RplidarNodeRepr {
            quality: (rng.next() % 64) as u8,
            start: q6 < 29,
            angle_q6: q6 as u16,
            distance_q2: wall_mm(rng, i).saturating_mul(4),
        };
        angle += 29;
        i += 1;
        // Garbage in a node stream costs a resynchronisation on 16 nodes: keep it rare.
        push_unit::<5, _>(rng, &mut stream, 20, |b| repr.emit(b))?;
    }
    Ok(stream)
}

fn rplidar_capsule_stream(rng: &mut XorShift) -> Result<Vec<u8>, Box<dyn Error>> {
    let mut stream = vec![0; 7];
    RplidarDescriptorRepr::EXPRESS_SCAN.emit(&mut stream)?;
    let mut angle = 0_u32;
    let mut i = 0_u64;
    let mut first = true;
    while stream.len() < TARGET_BYTES {
        let mut repr = RplidarCapsuleRepr {
            start_angle_q6: (angle % 23_040) as u16,
            start_flag: first,
            ..RplidarCapsuleRepr::default()
        };
        first = false;
        for (d, o) in repr
            .distances_mm
            .iter_mut()
            .zip(repr.angle_offsets_q3.iter_mut())
        {
            *d = wall_mm(rng, i) & 0x3FFF;
            *o = (rng.next() % 64) as u8;
            i += 1;
        }
        // 4 000 samples/s at 10 Hz: 0.9° per point, 28.8° per capsule.
        angle += 1843;
        push_unit::<84, _>(rng, &mut stream, 20, |b| repr.emit(b))?;
    }
    Ok(stream)
}

/// Times `run` (which feeds the whole stream and returns the number of returns and a
/// checksum of them): the best of three runs after one warm-up.
fn measure(stream: &[u8], mut run: impl FnMut(&[u8]) -> (u64, u64)) -> (Duration, u64) {
    let _ = run(stream);
    let mut best = Duration::MAX;
    let mut returns = 0;
    for _ in 0..3 {
        let start = Instant::now();
        let (n, sum) = run(stream);
        best = best.min(start.elapsed());
        black_box(sum);
        returns = n;
    }
    (best, returns)
}

fn report(label: &str, stream: &[u8], (elapsed, returns): (Duration, u64)) {
    let secs = elapsed.as_secs_f64();
    println!(
        "{label}: {:.0} MB/s, {:.1} M returns/s ({returns} returns in {:.1} MB)",
        stream.len() as f64 / 1e6 / secs,
        returns as f64 / 1e6 / secs,
        stream.len() as f64 / 1e6
    );
}

/// Feeds `stream` in chunks of [`CHUNK`] bytes through `feed` (one `feed` call of an
/// accumulator on what is left of a chunk: the rest of it, or `None` once it took it all).
fn feed_chunks<'s>(stream: &'s [u8], mut feed: impl FnMut(&'s [u8]) -> Option<&'s [u8]>) {
    for chunk in stream.chunks(CHUNK) {
        let mut window = chunk;
        while let Some(rest) = feed(window) {
            window = rest;
        }
    }
}

/// Runs the accumulator `$acc` over `$stream` in chunks ([`feed_chunks`]), evaluating `$on_item`
/// with each item it hands out bound to `$item`, then flushes it. A macro: the accumulators
/// share `feed` and `flush` by name, not through a trait.
macro_rules! drain {
    ($acc:expr, $stream:expr, |$item:ident| $on_item:block) => {{
        let mut acc = $acc;
        feed_chunks($stream, |window| match acc.feed(window) {
            FeedResult::Consumed => None,
            FeedResult::Item {
                item: $item,
                remaining,
                ..
            } => {
                $on_item
                Some(remaining)
            }
            FeedResult::Rejected { remaining, .. } => Some(remaining),
        });
        while !matches!(acc.flush(), FeedResult::Consumed) {}
    }};
}

/// A return's part of the checksum: its angle's bits XOR its range.
fn return_key(r: &LaserReturn) -> u64 {
    u64::from(r.angle.to_bits()) ^ u64::from(r.range_mm)
}

/// `sum` with the keys of `returns` added, wrapping.
fn add_returns(sum: u64, returns: impl Iterator<Item = LaserReturn>) -> u64 {
    returns.fold(sum, |sum, r| sum.wrapping_add(return_key(&r)))
}

fn ld06(stream: &[u8], decode: bool) -> (u64, u64) {
    let (mut n, mut sum) = (0_u64, 0_u64);
    drain!(Ld06Accumulator::new(), stream, |item| {
        n += 12;
        sum = if decode {
            add_returns(sum, item.returns())
        } else {
            sum.wrapping_add(u64::from(item.start_angle_centideg()))
        };
    });
    (n, sum)
}

fn ydlidar(stream: &[u8], decode: bool) -> (u64, u64) {
    let (mut n, mut sum) = (0_u64, 0_u64);
    drain!(<YdlidarAccumulator>::new(), stream, |item| {
        if let YdlidarItem::Packet(p) = item {
            n += u64::from(p.sample_count());
            sum = if decode {
                add_returns(sum, p.returns())
            } else {
                sum.wrapping_add(u64::from(p.first_angle_q6()))
            };
        }
    });
    (n, sum)
}

fn rplidar(stream: &[u8], decode: bool) -> (u64, u64) {
    let (mut n, mut sum) = (0_u64, 0_u64);
    drain!(RplidarAccumulator::new(), stream, |item| {
        match item {
            RplidarItem::Node(node) => {
                n += 1;
                let r = if decode {
                    return_key(&node.to_return())
                } else {
                    u64::from(node.angle_q6())
                };
                sum = sum.wrapping_add(r);
            }
            RplidarItem::Express(e) => {
                n += 32;
                sum = if decode {
                    add_returns(sum, e.returns())
                } else {
                    sum.wrapping_add(u64::from(e.next_start_angle_q6()))
                };
            }
            _ => {}
        }
    });
    (n, sum)
}

/// A decoder under test: the returns it counted and a checksum of what it read.
type Decoder = fn(&[u8], bool) -> (u64, u64);

fn main() -> Result<(), Box<dyn Error>> {
    let mut rng = XorShift(0x1D06_5EED_0BAD_CAFE);
    println!("{CHUNK}-byte chunks; best of three runs after a warm-up");
    let ld06_s = ld06_stream(&mut rng)?;
    let ydlidar_s = ydlidar_stream(&mut rng)?;
    let nodes_s = rplidar_node_stream(&mut rng)?;
    let capsules_s = rplidar_capsule_stream(&mut rng)?;
    let runs: [(&str, &str, &[u8], Decoder); 4] = [
        (
            "LD06 reassembly (sync, CRC-8)",
            "LD06 reassembly + returns",
            &ld06_s,
            ld06,
        ),
        (
            "YDLIDAR reassembly (sync, check bits, XOR)",
            "YDLIDAR reassembly + returns (second-level correction)",
            &ydlidar_s,
            ydlidar,
        ),
        (
            "RPLIDAR nodes reassembly (checks, runs)",
            "RPLIDAR nodes reassembly + returns",
            &nodes_s,
            rplidar,
        ),
        (
            "RPLIDAR capsules reassembly (sync, XOR, pairing)",
            "RPLIDAR capsules reassembly + returns (compensation)",
            &capsules_s,
            rplidar,
        ),
    ];
    for (plain, with_returns, s, decoder) in runs {
        report(plain, s, measure(s, |s| decoder(s, false)));
        report(with_returns, s, measure(s, |s| decoder(s, true)));
    }
    Ok(())
}
