//! Arbitrary bytes, arbitrarily chunked, into the YDLIDAR accumulator (default capacity and a
//! 32-byte one).
//!
//! Invariants: no panic; the events do not depend on the chunking; every packet handed out
//! passes `YdlidarPacket::new_checked`, is the stream's own bytes at its offset, does not
//! overlap the previous item, and yields LSN returns with either correction; every
//! descriptor is a known one with its content; the counters match the events; every byte is
//! accounted for exactly.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::ydlidar::{
    YdlidarAccumulator, YdlidarAngleCorrection, YdlidarCounters, YdlidarDescriptor, YdlidarError,
    YdlidarItem, YdlidarPacket,
};

/// Events, the units named "packet" or "descriptor".
type Ev = common::Event<&'static str, YdlidarError>;

/// Checks an item handed out: a valid packet yielding LSN returns with either correction, or
/// a known descriptor with its content; its kind and bytes.
fn item(item: YdlidarItem<'_>) -> (&'static str, Vec<u8>) {
    match item {
        YdlidarItem::Packet(p) => {
            let bytes = p.into_inner();
            let checked = YdlidarPacket::new_checked(bytes).expect("a delivered packet is valid");
            assert_eq!(checked.total_len(), bytes.len());
            let n = usize::from(checked.sample_count());
            assert_eq!(checked.returns().count(), n);
            assert_eq!(checked.returns_with(YdlidarAngleCorrection::Off).count(), n);
            ("packet", bytes.to_vec())
        }
        YdlidarItem::Descriptor(d) => {
            let bytes = d.into_inner();
            let checked = YdlidarDescriptor::new_checked(bytes).expect("a known descriptor");
            assert_eq!(checked.as_bytes().len(), bytes.len());
            ("descriptor", bytes.to_vec())
        }
    }
}

fn run<const N: usize>(chunks: &[&[u8]]) -> (Vec<Ev>, YdlidarCounters) {
    common::run_accumulator!(
        YdlidarAccumulator::<N>::new(),
        chunks,
        |len| 2 * (len + N) + 2,
        item,
        counters
    )
}

fn check(stream: &[u8], events: &[Ev], c: YdlidarCounters) {
    let mut seen = YdlidarCounters::default();
    let mut items = 0u64;
    let mut last_end = 0u64;
    for ev in events {
        match ev {
            Ev::Unit(offset, kind, bytes) => {
                match *kind {
                    "packet" => seen.packets += 1,
                    "descriptor" => seen.descriptors += 1,
                    other => panic!("unexpected unit {other}"),
                }
                common::assert_next_unit(stream, *offset, bytes, &mut last_end, "items");
                items += bytes.len() as u64;
            }
            Ev::Refused(offset, e) => {
                assert!(matches!(common::byte_at(stream, *offset), 0xAA | 0xA5));
                match e {
                    YdlidarError::BadChecksum { .. } => seen.checksum += 1,
                    YdlidarError::BadCheckBit { .. } => seen.check_bits += 1,
                    YdlidarError::NoSamples | YdlidarError::TooLong { .. } => seen.bad_length += 1,
                    YdlidarError::Truncated => seen.truncated += 1,
                    other => panic!("unexpected rejection {other:?}"),
                }
            }
        }
    }
    seen.garbage_bytes = c.garbage_bytes;
    assert_eq!(seen, c);
    let accounted = items
        + u64::from(c.checksum)
        + u64::from(c.check_bits)
        + u64::from(c.bad_length)
        + u64::from(c.truncated)
        + u64::from(c.garbage_bytes);
    assert_eq!(accounted, stream.len() as u64, "bytes not accounted for");
}

fuzz_target!(|data: &[u8]| {
    let (sizes, stream) = common::split_sizes(data);
    let chunked = common::check_chunking(stream, sizes, run::<520>, check);
    let (small, c3) = run::<32>(&chunked);
    check(stream, &small, c3);
});
