//! The SICK accumulator's decode rate on the host.
//!
//! Builds about 50 MB of a realistic stream (361-value mm measured-values telegrams, bit 13
//! set on most returns, a few "no echo" values, a burst of garbage or an ACK between some
//! telegrams), feeds it in 64-byte chunks as a UART driver would, and prints MB/s and
//! telegrams/s: once for reassembly alone (synchronisation, LEN and CRC checks), once with the
//! measured values parsed and every range decoded.
//!
//! Run with `cargo run --release --example sick_decode_rate`.
mod common;

use common::XorShift;
use std::error::Error;
use std::hint::black_box;
use std::time::{Duration, Instant};
use terrain_pyramid::wire::sick::{
    MeasuredValues, MeasuringMode, SickAccumulator, SickCounters, SickItem, Unit,
};
use terrain_pyramid::wire::FeedResult;

/// Bytes of stream to build.
const TARGET_BYTES: usize = 50_000_000;
/// Bytes per feed call.
const CHUNK: usize = 64;
/// Values per scan: 180° at 0.5°.
const VALUES: usize = 361;

fn build(rng: &mut XorShift) -> Result<(Vec<u8>, u64), Box<dyn Error>> {
    let mut stream = Vec::with_capacity(TARGET_BYTES + 1024);
    let mut values = vec![0u8; 2 * VALUES];
    let mut telegram = [0u8; 818];
    let mut sent = 0u64;
    let mut phase = 0u64;
    while stream.len() < TARGET_BYTES {
        phase = phase.wrapping_add(1);
        for (i, pair) in values.chunks_exact_mut(2).enumerate() {
            let noise = rng.next() % 16;
            let raw = if noise == 0 {
                0x1FFF // no echo
            } else {
                // A smooth wall between 0.5 m and 7.5 m, with bit 13 set as real captures have.
                let mm = 500 + ((i as u64 * 37 + phase * 11) % 7000) + noise;
                0x2000 | (mm as u16 & 0x1FFF)
            };
            pair.copy_from_slice(&raw.to_le_bytes());
        }
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10)?;
        let n = m.emit(&mut telegram)?;
        stream.extend_from_slice(telegram.get(..n).ok_or("emit")?);
        sent += 1;
        match rng.next() % 20 {
            0 => stream.push(0x06),
            1 => {
                let len = 1 + rng.next() % 64;
                stream.extend((0..len).map(|_| rng.next() as u8));
            }
            _ => {}
        }
    }
    Ok((stream, sent))
}

/// Feeds the stream in chunks; `parse` also decodes every range.
fn run(stream: &[u8], parse: bool) -> (Duration, SickCounters, u64) {
    let mut acc: SickAccumulator = SickAccumulator::new();
    let mut sum = 0u64;
    let start = Instant::now();
    for chunk in stream.chunks(CHUNK) {
        let mut window = chunk;
        loop {
            let result = acc.feed(window);
            window = result.remaining();
            match result {
                FeedResult::Consumed => break,
                FeedResult::Item {
                    item: SickItem::Telegram(telegram),
                    ..
                } => {
                    if parse {
                        if let Ok(m) = MeasuredValues::parse(&telegram) {
                            sum += m
                                .ranges_mm(MeasuringMode::Mm8Cm80)
                                .map(|r| u64::from(r.unwrap_or(0)))
                                .sum::<u64>();
                        }
                    } else {
                        sum += u64::from(telegram.payload_len());
                    }
                }
                _ => {}
            }
        }
    }
    while !matches!(acc.flush(), FeedResult::Consumed) {}
    (start.elapsed(), acc.stats(), black_box(sum))
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut rng = XorShift(0x1234_5678_9ABC_DEF1);
    let (stream, sent) = build(&mut rng)?;
    println!(
        "stream: {:.1} MB, {} telegrams of {} values, fed in {}-byte chunks",
        stream.len() as f64 / 1e6,
        sent,
        VALUES,
        CHUNK
    );
    for (label, parse) in [
        ("reassembly (sync, LEN, CRC)", false),
        ("reassembly + parse + ranges", true),
    ] {
        // One warm-up pass, then the best of three.
        let _ = run(&stream, parse);
        let mut best = Duration::MAX;
        let mut stats = SickCounters::default();
        for _ in 0..3 {
            let (elapsed, s, _) = run(&stream, parse);
            best = best.min(elapsed);
            stats = s;
        }
        let secs = best.as_secs_f64();
        println!(
            "{label}: {:.0} MB/s, {:.0} telegrams/s ({} ok, {} crc, {} length, {} truncated, {} garbage bytes, {} ack)",
            stream.len() as f64 / 1e6 / secs,
            f64::from(stats.telegrams_ok) / secs,
            stats.telegrams_ok,
            stats.crc_errors,
            stats.length_errors,
            stats.truncated,
            stats.garbage_bytes,
            stats.ack
        );
    }
    Ok(())
}
