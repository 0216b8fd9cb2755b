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

/// The kind of a unit handed out, with what it says beyond its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Descriptor,
    /// A single response, of this data type.
    Response(u8),
    Node,
    /// A capsule, with the next one's start angle and where a revolution starts.
    Express(u16, Option<usize>),
}

type Ev = common::Event<Kind, RplidarError>;

/// Checks an item handed out (descriptors known, nodes and capsules valid, a capsule with 32
/// returns); its kind and bytes.
fn item(item: RplidarItem<'_>) -> (Kind, Vec<u8>) {
    match item {
        RplidarItem::Descriptor(d) => {
            let bytes = d.into_inner();
            RplidarDescriptor::new_checked(bytes).expect("a known descriptor");
            (Kind::Descriptor, bytes.to_vec())
        }
        RplidarItem::Response(r) => {
            let _ = (r.health(), r.info());
            (Kind::Response(r.data_type), r.data.to_vec())
        }
        RplidarItem::Node(n) => {
            let bytes = n.into_inner();
            let n = RplidarNode::new_checked(bytes).expect("a delivered node is valid");
            let _ = n.to_return();
            (Kind::Node, bytes.to_vec())
        }
        RplidarItem::Express(e) => {
            let bytes = e.capsule().into_inner();
            RplidarCapsule::new_checked(bytes).expect("a delivered capsule is valid");
            assert_eq!(e.returns().count(), 32);
            let kind = Kind::Express(e.next_start_angle_q6(), e.revolution_start());
            (kind, bytes.to_vec())
        }
    }
}

fn accumulator(mode: u8) -> RplidarAccumulator {
    match mode % 3 {
        0 => RplidarAccumulator::new(),
        1 => RplidarAccumulator::with_mode(RplidarScanMode::Standard),
        _ => RplidarAccumulator::with_mode(RplidarScanMode::Express),
    }
}

fn run(mode: u8, chunks: &[&[u8]]) -> (Vec<Ev>, RplidarCounters) {
    common::run_accumulator!(
        accumulator(mode),
        chunks,
        |len| 3 * (len + 96) + 4,
        item,
        counters
    )
}

fn check(stream: &[u8], events: &[Ev], c: RplidarCounters) {
    let mut seen = RplidarCounters::default();
    let mut response_bytes = 0u64;
    let mut last_end = 0u64;
    for ev in events {
        match ev {
            Ev::Unit(offset, kind, bytes) => {
                match kind {
                    Kind::Descriptor => seen.descriptors += 1,
                    Kind::Response(_) => {
                        seen.responses += 1;
                        response_bytes += bytes.len() as u64;
                    }
                    Kind::Node => seen.nodes += 1,
                    Kind::Express(..) => seen.capsules += 1,
                }
                // Express items come one capsule behind, so check order only among the rest.
                if matches!(kind, Kind::Express(..)) {
                    common::assert_in_stream(stream, *offset, bytes);
                } else {
                    common::assert_next_unit(stream, *offset, bytes, &mut last_end, "units");
                }
            }
            Ev::Refused(_, e) => match e {
                RplidarError::BadNode => seen.node_check += 1,
                RplidarError::Implausible => seen.implausible += 1,
                RplidarError::BadChecksum { .. } => seen.checksum += 1,
                RplidarError::CapsuleUnpaired => seen.capsules_unpaired += 1,
                RplidarError::Truncated => seen.truncated += 1,
                other => panic!("unexpected rejection {other:?}"),
            },
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
