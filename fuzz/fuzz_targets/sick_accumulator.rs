//! Arbitrary bytes, arbitrarily chunked, into the SICK feed accumulator.
//!
//! Invariants: no panic; the events do not depend on the chunking (the same stream fed whole
//! gives the same events); every telegram handed out passes `Telegram::new_checked`, is the
//! stream's own bytes at its offset, and parses (or is refused) by `SickReply::parse` without
//! panicking; the counters match the events; every byte is accounted for.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::sick::{
    MeasuredValues, SickAccumulator, SickCounters, SickFrameError, SickItem, SickReply, Telegram,
    ADDRESS_REPLY,
};

/// Events, the units named "telegram", "ACK" or "NAK".
type Ev = common::Event<&'static str, SickFrameError>;

/// Checks an item handed out: a valid reply telegram that parses (or is refused) without
/// panicking, or a lone ACK or NAK byte (no bytes kept); its kind and bytes.
fn item(item: SickItem<'_>) -> (&'static str, Vec<u8>) {
    match item {
        SickItem::Telegram(telegram) => {
            let bytes = telegram.as_bytes();
            let checked = Telegram::new_checked(bytes).expect("a delivered telegram is valid");
            assert_eq!(checked.address(), ADDRESS_REPLY);
            assert_eq!(checked.total_len(), bytes.len());
            let _ = SickReply::parse(&checked);
            if let Ok(mv) = MeasuredValues::parse(&checked) {
                let _ = mv.ranges_mm(Default::default()).count();
                let _ = mv.flags(Default::default()).count();
                assert_eq!(usize::from(mv.count()) * 2, mv.values_le().len());
            }
            ("telegram", bytes.to_vec())
        }
        SickItem::Ack => ("ACK", Vec::new()),
        SickItem::Nak => ("NAK", Vec::new()),
    }
}

fn run<const N: usize>(chunks: &[&[u8]]) -> (Vec<Ev>, SickCounters) {
    // Each event consumes a byte or resolves a buffered one: bounded by the bytes.
    common::run_accumulator!(
        SickAccumulator::<N>::new(),
        chunks,
        |len| 2 * (len + N) + 2,
        item,
        stats
    )
}

fn check(stream: &[u8], events: &[Ev], stats: SickCounters) {
    let mut ok = 0u32;
    let (mut ack, mut nak, mut crc, mut length, mut truncated) = (0u32, 0u32, 0u32, 0u32, 0u32);
    let mut accounted = 0u64;
    let mut last_end = 0u64;
    for ev in events {
        match ev {
            Ev::Unit(offset, "telegram", bytes) => {
                ok += 1;
                common::assert_next_unit(stream, *offset, bytes, &mut last_end, "telegrams");
                accounted += bytes.len() as u64;
            }
            Ev::Unit(offset, "ACK", _) => {
                ack += 1;
                assert_eq!(common::byte_at(stream, *offset), 0x06);
                accounted += 1;
            }
            Ev::Unit(offset, "NAK", _) => {
                nak += 1;
                assert_eq!(common::byte_at(stream, *offset), 0x15);
                accounted += 1;
            }
            Ev::Unit(_, other, _) => panic!("unexpected unit {other}"),
            Ev::Refused(offset, e) => {
                assert_eq!(common::byte_at(stream, *offset), 0x02);
                match e {
                    SickFrameError::BadLength { .. } | SickFrameError::TooLong { .. } => {
                        length += 1
                    }
                    SickFrameError::BadCrc { .. } => crc += 1,
                    SickFrameError::Truncated => truncated += 1,
                    _ => unreachable!(),
                }
            }
        }
    }
    assert_eq!(stats.telegrams_ok, ok);
    assert_eq!(stats.ack, ack);
    assert_eq!(stats.nak, nak);
    assert_eq!(stats.crc_errors, crc);
    assert_eq!(stats.length_errors, length);
    assert_eq!(stats.truncated, truncated);
    // Telegrams, ACK/NAK and garbage are disjoint parts of the stream; rejected candidates
    // hold the rest.
    accounted += u64::from(stats.garbage_bytes);
    assert!(
        accounted <= stream.len() as u64,
        "{accounted} bytes accounted for in a stream of {}",
        stream.len()
    );
    if crc + length + truncated == 0 {
        assert_eq!(
            accounted,
            stream.len() as u64,
            "bytes lost without a rejection"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    let (sizes, stream) = common::split_sizes(data);
    let chunked = common::check_chunking(stream, sizes, run::<818>, check);
    // A small accumulator: same invariants, longer telegrams refused as TooLong.
    let (small, stats3) = run::<64>(&chunked);
    check(stream, &small, stats3);
});
