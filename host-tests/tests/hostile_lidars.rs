//! Bounded random-stream smoke tests for CI (stable, no fuzzer), the spinning lidars' part of
//! `hostile.rs`: hostile input to the LD06, YDLIDAR and RPLIDAR (nodes and capsules)
//! accumulators, with an oracle that knows what arrived intact.
//!
//! Valid packets interleaved with arbitrary garbage, bit-flipped and truncated packets and
//! false headers, fed in random chunks. Every unit handed out is valid and the stream's own
//! bytes at its offset; every intact packet is handed out exactly once unless a false
//! candidate that passed its checksum by chance overlaps it (LD06, YDLIDAR, capsules), or, for
//! the weakly checked RPLIDAR nodes, once it lies 24 nodes or more into an undamaged run; the
//! counters add up to the stream's length.
//!
//! The seeds are fixed (`RngSeed::Fixed`) so the run is reproducible. The four properties add
//! about 15 % to `hostile.rs`'s time (measured with `--test-threads=1` on a loaded machine:
//! 20.3 s without them, 23.5 s with them).

use crate::common;

use common::feed::{
    checked_ld06, checked_node, checked_ydlidar, feed_all, tally, Accumulate, Tally,
};
use common::{chunks, seeded, Piece, Units};
use proptest::prelude::*;
use std::convert::Infallible;

use terrain_pyramid::wire::ld06::{Ld06Accumulator, Ld06Point, Ld06Repr};
use terrain_pyramid::wire::rplidar::{
    RplidarAccumulator, RplidarCapsule, RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarError,
    RplidarItem, RplidarNode, RplidarNodeRepr,
};
use terrain_pyramid::wire::ydlidar::YdlidarAccumulator;
use terrain_pyramid::wire::FeedResult as WireFeed;
use terrain_pyramid_host_tests::sim::lidar::ydlidar_packet_bytes;

/// One piece of a lidar stream, whatever the packet: `Intact` holds a valid packet, `Garbage`
/// arbitrary bytes, `Flipped` and `Truncated` a packet (cut with at least 1 byte gone); a
/// lidar stream has no pieces of its own.
type LidarPiece = Piece<Infallible>;

/// Builds the stream; returns it with the offsets and bytes of the intact packets, and
/// whether any piece was damage (garbage included).
fn lidar_stream(pieces: &[LidarPiece], prefix: &[u8]) -> (Vec<u8>, Units, bool) {
    let mut stream = prefix.to_vec();
    let mut intact = Vec::new();
    let mut damaged = false;
    for piece in pieces {
        match piece {
            LidarPiece::Intact(p) => {
                intact.push((stream.len() as u64, p.clone()));
                stream.extend_from_slice(p);
            }
            LidarPiece::Garbage(g) => {
                damaged |= !g.is_empty();
                stream.extend_from_slice(g);
            }
            LidarPiece::Flipped(p, bit) => {
                let mut p = p.clone();
                let bit = bit % (8 * p.len());
                p[bit / 8] ^= 1 << (bit % 8);
                stream.extend_from_slice(&p);
                damaged = true;
            }
            LidarPiece::Truncated(p, at) => {
                stream.extend_from_slice(&p[..at % p.len()]);
                damaged = true;
            }
            LidarPiece::Own(never) => match *never {},
        }
    }
    (stream, intact, damaged)
}

fn lidar_piece(
    packet: impl Strategy<Value = Vec<u8>> + Clone,
) -> impl Strategy<Value = LidarPiece> {
    prop_oneof![
        6 => packet.clone().prop_map(LidarPiece::Intact),
        2 => proptest::collection::vec(any::<u8>(), 1..40).prop_map(LidarPiece::Garbage),
        1 => (packet.clone(), any::<usize>()).prop_map(|(p, b)| LidarPiece::Flipped(p, b)),
        1 => (packet, any::<usize>()).prop_map(|(p, at)| LidarPiece::Truncated(p, at)),
    ]
}

/// Checks delivered units against the intact ones: each delivered unit is the stream's bytes
/// at its offset; offsets increase; every intact unit not overlapped by a false unit (one
/// delivered that is not intact, or in `accepted`, `(offset, length)` of units that passed
/// their checks but were not delivered) is delivered exactly once.
fn check_delivery(
    stream: &[u8],
    delivered: &[(u64, Vec<u8>)],
    intact: &[(u64, Vec<u8>)],
    accepted: &[(u64, u64)],
) -> Result<(), TestCaseError> {
    let mut last = None;
    for (o, b) in delivered {
        let at = usize::try_from(*o).unwrap();
        prop_assert_eq!(&stream[at..at + b.len()], &b[..]);
        prop_assert!(last.is_none_or(|l| *o > l), "offsets must increase");
        last = Some(*o);
    }
    let false_units: Vec<(u64, u64)> = delivered
        .iter()
        .filter(|d| !intact.contains(d))
        .map(|(o, b)| (*o, b.len() as u64))
        .chain(accepted.iter().copied())
        .collect();
    for (o, b) in intact {
        let end = o + b.len() as u64;
        let overlapped = false_units.iter().any(|(fo, fl)| *fo < end && fo + fl > *o);
        if !overlapped {
            prop_assert!(
                delivered.contains(&(*o, b.clone())),
                "intact unit at {} lost",
                o
            );
        }
    }
    Ok(())
}

/// Feeds `stream` in chunks of `sizes` to `acc`, keeping the units `keep` gives bytes for;
/// checks them against `intact` ([`check_delivery`]) and, when the stream was not `damaged`,
/// that they are exactly the intact units. Returns the tally.
fn intact_delivered<A: Accumulate>(
    acc: &mut A,
    stream: &[u8],
    sizes: &[usize],
    (intact, damaged): (&[(u64, Vec<u8>)], bool),
    keep: impl FnMut(A::Unit<'_>) -> Option<Vec<u8>>,
) -> Result<Tally, TestCaseError> {
    let t = tally(acc, &chunks(stream, sizes), keep);
    check_delivery(stream, &t.delivered, intact, &[])?;
    if !damaged {
        prop_assert_eq!(&t.delivered, &intact);
    }
    Ok(t)
}

fn ld06_packet() -> impl Strategy<Value = Vec<u8>> + Clone {
    (
        any::<u16>(),
        0_u16..36_000,
        0_u16..36_000,
        proptest::array::uniform12((any::<u16>(), any::<u8>())),
    )
        .prop_map(|(speed, start, end, points)| {
            let repr = Ld06Repr {
                speed_deg_per_s: speed,
                start_angle_centideg: start,
                end_angle_centideg: end,
                timestamp_ms: start % 30_000,
                points: points.map(|(distance_mm, intensity)| Ld06Point {
                    distance_mm,
                    intensity,
                }),
            };
            let mut b = vec![0; 47];
            repr.emit(&mut b).unwrap();
            b
        })
}

fn ydlidar_packet() -> impl Strategy<Value = Vec<u8>> + Clone {
    (
        any::<u8>(),
        0_u16..23_040,
        0_u16..23_040,
        proptest::collection::vec(any::<u16>(), 1..50),
    )
        .prop_map(|(ct, first, last, samples)| {
            ydlidar_packet_bytes(ct, first, last, &samples).unwrap()
        })
}

fn capsule_packet() -> impl Strategy<Value = Vec<u8>> + Clone {
    (
        0_u16..23_040,
        proptest::array::uniform32(0_u16..0x4000),
        proptest::array::uniform32(0_u8..64),
    )
        .prop_map(|(start, distances_mm, angle_offsets_q3)| {
            let mut b = vec![0; 84];
            RplidarCapsuleRepr {
                start_angle_q6: start,
                start_flag: false,
                distances_mm,
                angle_offsets_q3,
            }
            .emit(&mut b)
            .unwrap();
            b
        })
}

fn node_packet() -> impl Strategy<Value = Vec<u8>> + Clone {
    (0_u8..64, any::<bool>(), 0_u16..23_040, any::<u16>()).prop_map(|(q, s, a, d)| {
        let mut b = vec![0; 5];
        RplidarNodeRepr {
            quality: q,
            start: s,
            angle_q6: a,
            distance_q2: d,
        }
        .emit(&mut b)
        .unwrap();
        b
    })
}

proptest! {
    #![proptest_config(seeded(1500, 0x5eed_1d06))]

    #[test]
    fn ld06_stream_delivers_the_intact_packets(
        pieces in proptest::collection::vec(lidar_piece(ld06_packet()), 1..20),
        sizes in proptest::collection::vec(1_usize..120, 1..6),
    ) {
        let (stream, intact, damaged) = lidar_stream(&pieces, &[]);
        let mut acc = Ld06Accumulator::new();
        let Tally { delivered, rejected } = intact_delivered(&mut acc, &stream, &sizes, (&intact, damaged), checked_ld06)?;
        let c = acc.counters();
        prop_assert_eq!(c.packets as usize, delivered.len());
        prop_assert_eq!(c.checksum + c.truncated, rejected);
        prop_assert_eq!(47 * u64::from(c.packets) + u64::from(c.checksum + c.truncated + c.garbage_bytes), stream.len() as u64);
        prop_assert_eq!(acc.position(), stream.len() as u64);
    }

    #[test]
    fn ydlidar_stream_delivers_the_intact_packets(
        pieces in proptest::collection::vec(lidar_piece(ydlidar_packet()), 1..16),
        sizes in proptest::collection::vec(1_usize..200, 1..6),
    ) {
        let scan = [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
        let (stream, mut intact, damaged) = lidar_stream(&pieces, &scan);
        intact.insert(0, (0, scan.to_vec()));
        let mut acc: Box<YdlidarAccumulator> = Box::default();
        let Tally { delivered, rejected } = intact_delivered(acc.as_mut(), &stream, &sizes, (&intact, damaged), checked_ydlidar)?;
        let c = acc.counters();
        prop_assert_eq!((c.packets + c.descriptors) as usize, delivered.len());
        prop_assert_eq!(c.checksum + c.check_bits + c.bad_length + c.truncated, rejected);
        let items: u64 = delivered.iter().map(|(_, b)| b.len() as u64).sum();
        prop_assert_eq!(items + u64::from(c.checksum + c.check_bits + c.bad_length + c.truncated + c.garbage_bytes), stream.len() as u64);
    }

    #[test]
    fn rplidar_capsule_stream_places_every_intact_pair(
        pieces in proptest::collection::vec(lidar_piece(capsule_packet()), 1..14),
        sizes in proptest::collection::vec(1_usize..200, 1..6),
    ) {
        let mut prefix = vec![0; 7];
        RplidarDescriptorRepr::EXPRESS_SCAN.emit(&mut prefix).unwrap();
        let (stream, intact, damaged) = lidar_stream(&pieces, &prefix);
        let mut acc = Box::new(RplidarAccumulator::new());
        let mut placed = Vec::new();
        let mut next_of = Vec::new();
        let mut rejected = 0_u32;
        // Capsules that passed their checks but were dropped unplaced.
        let mut unpaired = Vec::new();
        feed_all(acc.as_mut(), &chunks(&stream, &sizes), |r| match r {
            WireFeed::Consumed => false,
            WireFeed::Item { item: RplidarItem::Express(e), offset, .. } => {
                assert!(RplidarCapsule::new_checked(e.capsule().as_bytes()).is_ok());
                assert_eq!(e.returns().count(), 32);
                placed.push((offset, e.capsule().as_bytes().to_vec()));
                next_of.push(e.next_start_angle_q6());
                true
            }
            WireFeed::Item { .. } => true,
            WireFeed::Rejected { error, offset, .. } => {
                if error == RplidarError::CapsuleUnpaired {
                    unpaired.push((offset, 84));
                }
                rejected += 1;
                true
            }
        });
        // A placed capsule is directly followed in the stream by a valid capsule whose start
        // angle placed it.
        for ((o, _), next) in placed.iter().zip(&next_of) {
            let at = usize::try_from(*o).unwrap() + 84;
            let succ = RplidarCapsule::new_checked(&stream[at..at + 84]);
            prop_assert!(succ.is_ok());
            prop_assert_eq!(succ.unwrap().start_angle_q6(), *next);
        }
        // Every intact capsule directly followed by an intact one is placed.
        let pairs: Vec<_> = intact
            .windows(2)
            .filter(|w| w[0].0 + 84 == w[1].0)
            .map(|w| w[0].clone())
            .collect();
        // A capsule accepted but unpaired is false when no intact capsule starts there: it
        // passed its 8-bit checksum by chance, and its bytes may hide an intact one.
        let false_unpaired: Vec<_> = unpaired
            .iter()
            .filter(|(o, _)| !intact.iter().any(|(io, _)| io == o))
            .copied()
            .collect();
        check_delivery(&stream, &placed, &pairs, &false_unpaired)?;
        let c = acc.counters();
        prop_assert_eq!(c.capsules as usize, placed.len());
        prop_assert_eq!(c.checksum + c.truncated + c.capsules_unpaired + c.node_check, rejected);
        prop_assert_eq!(
            7 * u64::from(c.descriptors) + 84 * u64::from(c.capsules + c.capsules_unpaired)
                + u64::from(c.checksum + c.truncated + c.node_check + c.garbage_bytes),
            stream.len() as u64
        );
        if !damaged {
            prop_assert_eq!(&placed, &pairs);
        }
    }

    #[test]
    fn rplidar_node_stream_delivers_settled_intact_nodes(
        pieces in proptest::collection::vec(
            prop_oneof![
                3 => proptest::collection::vec(node_packet(), 1..60).prop_map(|ns| ns.into_iter().map(LidarPiece::Intact).collect::<Vec<_>>()),
                1 => lidar_piece(node_packet()).prop_map(|p| vec![p]),
            ],
            1..12,
        ),
        sizes in proptest::collection::vec(1_usize..100, 1..6),
        first in 0_u32..23_040,
        step in 1_u32..=230,
    ) {
        let mut pieces: Vec<LidarPiece> = pieces.into_iter().flatten().collect();
        // The intact nodes at a sensor's angles: advancing by `step` (up to 3.6°) from one
        // to the next, the start flag where they pass 0° (`docs/lidars.md`, "Plausibility").
        let mut k = 0_u32;
        for piece in &mut pieces {
            if let LidarPiece::Intact(b) = piece {
                let mut n = RplidarNodeRepr::parse(&RplidarNode::new_unchecked(&b[..]));
                let at = first + step * k;
                n.angle_q6 = (at % 23_040) as u16;
                n.start = k > 0 && at / 23_040 != (at - step) / 23_040;
                n.emit(b).unwrap();
                k += 1;
            }
        }
        let mut prefix = vec![0; 7];
        RplidarDescriptorRepr::SCAN.emit(&mut prefix).unwrap();
        let (stream, intact, damaged) = lidar_stream(&pieces, &prefix);
        let mut acc = Box::new(RplidarAccumulator::new());
        let Tally { delivered, rejected } = tally(acc.as_mut(), &chunks(&stream, &sizes), checked_node);
        // Delivered nodes: valid, the stream's bytes, in order, never overlapping.
        let mut end = 0;
        for (o, b) in &delivered {
            let at = usize::try_from(*o).unwrap();
            prop_assert_eq!(&stream[at..at + 5], &b[..]);
            prop_assert!(*o >= end);
            end = o + 5;
        }
        // Settled intact nodes (24 or more into a run of contiguous intact nodes) arrive.
        let mut run = 0;
        for (i, (o, b)) in intact.iter().enumerate() {
            run = if i > 0 && intact[i - 1].0 + 5 == *o { run + 1 } else { 0 };
            if run >= 24 {
                prop_assert!(delivered.contains(&(*o, b.clone())), "settled node at {} lost", o);
            }
        }
        let c = acc.counters();
        prop_assert_eq!(c.nodes as usize, delivered.len());
        prop_assert_eq!(c.node_check + c.truncated + c.implausible, rejected);
        prop_assert_eq!(
            7 * u64::from(c.descriptors) + 5 * u64::from(c.nodes + c.implausible)
                + u64::from(c.node_check + c.truncated + c.garbage_bytes),
            stream.len() as u64
        );
        if !damaged {
            prop_assert_eq!(c.implausible, 0);
        }
        if !damaged {
            prop_assert_eq!(&delivered, &intact);
        }
    }
}
