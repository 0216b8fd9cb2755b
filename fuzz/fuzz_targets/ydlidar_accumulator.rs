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
use terrain_pyramid::wire::FeedResult;

#[derive(Debug, Clone, PartialEq, Eq)]
enum Ev {
    P(u64, Vec<u8>),
    D(u64, Vec<u8>),
    R(u64, YdlidarError),
}

fn record(r: FeedResult<'_, YdlidarItem<'_>, YdlidarError>, out: &mut Vec<Ev>) -> bool {
    match r {
        FeedResult::Consumed => return false,
        FeedResult::Item {
            item: YdlidarItem::Packet(p),
            offset,
            ..
        } => {
            let bytes = p.into_inner();
            let checked = YdlidarPacket::new_checked(bytes).expect("a delivered packet is valid");
            assert_eq!(checked.total_len(), bytes.len());
            let n = usize::from(checked.sample_count());
            assert_eq!(checked.returns().count(), n);
            assert_eq!(checked.returns_with(YdlidarAngleCorrection::Off).count(), n);
            out.push(Ev::P(offset, bytes.to_vec()));
        }
        FeedResult::Item {
            item: YdlidarItem::Descriptor(d),
            offset,
            ..
        } => {
            let bytes = d.into_inner();
            let checked = YdlidarDescriptor::new_checked(bytes).expect("a known descriptor");
            assert_eq!(checked.as_bytes().len(), bytes.len());
            out.push(Ev::D(offset, bytes.to_vec()));
        }
        FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(offset, error)),
    }
    true
}

fn run<const N: usize>(chunks: &[&[u8]]) -> (Vec<Ev>, YdlidarCounters, u64) {
    common::run_accumulator!(
        YdlidarAccumulator::<N>::new(),
        chunks,
        |len| 2 * (len + N) + 2,
        record,
        counters
    )
}

fn check(stream: &[u8], events: &[Ev], c: YdlidarCounters, position: u64) {
    assert_eq!(position, stream.len() as u64);
    let mut seen = YdlidarCounters::default();
    let mut items = 0u64;
    let mut last_end = 0u64;
    for ev in events {
        match ev {
            Ev::P(offset, bytes) | Ev::D(offset, bytes) => {
                if matches!(ev, Ev::P(..)) {
                    seen.packets += 1;
                } else {
                    seen.descriptors += 1;
                }
                common::assert_next_unit(stream, *offset, bytes, &mut last_end, "items");
                items += bytes.len() as u64;
            }
            Ev::R(offset, e) => {
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
    let (small, c3, position3) = run::<32>(&chunked);
    check(stream, &small, c3, position3);
});
