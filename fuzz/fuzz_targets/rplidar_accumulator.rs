//! Arbitrary bytes, arbitrarily chunked, into the RPLIDAR accumulator, started expecting a
//! descriptor, or joining a standard or express stream (the first data byte chooses).
//!
//! Invariants: no panic; the events do not depend on the chunking; every unit handed out is
//! the stream's own bytes at its offset (descriptors known, nodes passing
//! `RplidarNode::new_checked`, capsules passing `RplidarCapsule::new_checked` and yielding 32
//! returns, responses as long as announced); units do not overlap; the counters match the
//! events; every byte is accounted for exactly.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::wire::rplidar::{
    RplidarAccumulator, RplidarCapsule, RplidarCounters, RplidarDescriptor, RplidarError,
    RplidarItem, RplidarNode, RplidarScanMode,
};
use terrain_pyramid::wire::FeedResult;

#[derive(Debug, Clone, PartialEq, Eq)]
enum Ev {
    D(u64, Vec<u8>),
    Resp(u64, u8, Vec<u8>),
    N(u64, Vec<u8>),
    X(u64, Vec<u8>, u16, Option<usize>),
    R(u64, RplidarError),
}

fn record(r: FeedResult<'_, RplidarItem<'_>, RplidarError>, out: &mut Vec<Ev>) -> bool {
    match r {
        FeedResult::Consumed => return false,
        FeedResult::Item { item, offset, .. } => out.push(match item {
            RplidarItem::Descriptor(d) => {
                let bytes = d.into_inner();
                RplidarDescriptor::new_checked(bytes).expect("a known descriptor");
                Ev::D(offset, bytes.to_vec())
            }
            RplidarItem::Response(r) => {
                let _ = (r.health(), r.info());
                Ev::Resp(offset, r.data_type, r.data.to_vec())
            }
            RplidarItem::Node(n) => {
                let bytes = n.into_inner();
                let n = RplidarNode::new_checked(bytes).expect("a delivered node is valid");
                let _ = n.to_return();
                Ev::N(offset, bytes.to_vec())
            }
            RplidarItem::Express(e) => {
                let bytes = e.capsule().into_inner();
                RplidarCapsule::new_checked(bytes).expect("a delivered capsule is valid");
                assert_eq!(e.returns().count(), 32);
                Ev::X(
                    offset,
                    bytes.to_vec(),
                    e.next_start_angle_q6(),
                    e.revolution_start(),
                )
            }
        }),
        FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(offset, error)),
    }
    true
}

fn accumulator(mode: u8) -> RplidarAccumulator {
    match mode % 3 {
        0 => RplidarAccumulator::new(),
        1 => RplidarAccumulator::with_mode(RplidarScanMode::Standard),
        _ => RplidarAccumulator::with_mode(RplidarScanMode::Express),
    }
}

fn run(mode: u8, chunks: &[&[u8]]) -> (Vec<Ev>, RplidarCounters, u64) {
    common::run_accumulator!(
        accumulator(mode),
        chunks,
        |len| 3 * (len + 96) + 4,
        record,
        counters
    )
}

fn check(stream: &[u8], events: &[Ev], c: RplidarCounters, position: u64) {
    assert_eq!(position, stream.len() as u64);
    let mut seen = RplidarCounters::default();
    let mut response_bytes = 0u64;
    let mut last_end = 0u64;
    for ev in events {
        let unit = match ev {
            Ev::D(o, b) => {
                seen.descriptors += 1;
                Some((o, b))
            }
            Ev::Resp(o, _, b) => {
                seen.responses += 1;
                response_bytes += b.len() as u64;
                Some((o, b))
            }
            Ev::N(o, b) => {
                seen.nodes += 1;
                Some((o, b))
            }
            Ev::X(o, b, ..) => {
                seen.capsules += 1;
                Some((o, b))
            }
            Ev::R(_, e) => {
                match e {
                    RplidarError::BadNode => seen.node_check += 1,
                    RplidarError::Implausible => seen.implausible += 1,
                    RplidarError::BadChecksum { .. } => seen.checksum += 1,
                    RplidarError::CapsuleUnpaired => seen.capsules_unpaired += 1,
                    RplidarError::Truncated => seen.truncated += 1,
                    other => panic!("unexpected rejection {other:?}"),
                }
                None
            }
        };
        if let Some((offset, bytes)) = unit {
            // Express items come one capsule behind, so check order only among the rest.
            if matches!(ev, Ev::X(..)) {
                common::assert_in_stream(stream, *offset, bytes);
            } else {
                common::assert_next_unit(stream, *offset, bytes, &mut last_end, "units");
            }
        }
    }
    seen.unsupported = c.unsupported;
    seen.garbage_bytes = c.garbage_bytes;
    assert_eq!(seen, c);
    let accounted = 7 * u64::from(c.descriptors)
        + response_bytes
        + 5 * u64::from(c.nodes)
        + 84 * u64::from(c.capsules + c.capsules_unpaired)
        + u64::from(c.node_check)
        + u64::from(c.checksum)
        + u64::from(c.truncated)
        + u64::from(c.garbage_bytes)
        + 5 * u64::from(c.implausible);
    assert_eq!(accounted, stream.len() as u64, "bytes not accounted for");
}

fuzz_target!(|data: &[u8]| {
    let (sizes, rest) = common::split_sizes(data);
    let Some((&mode, stream)) = rest.split_first() else {
        return;
    };
    common::check_chunking(stream, sizes, |chunks| run(mode, chunks), check);
});
