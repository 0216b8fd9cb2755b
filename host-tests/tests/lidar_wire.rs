//! Property tests of the spinning-lidar wire formats (`terrain_pyramid::wire::{ld06, rplidar,
//! ydlidar}`): emit → feed round trips through random chunking and garbage, the returns
//! against the manuals' formulas evaluated in `f64`, single-bit flips, truncation, and the
//! accumulators' byte accounting. The mixed hostile streams are in `hostile.rs`.
//!
//! Fixed seeds: a checksum can pass by chance (1 in 256 for the LD06 CRC-8 and the RPLIDAR
//! capsule XOR), and a fixed seed keeps that from making CI flaky.

use crate::common;

use common::feed::{checked_ld06, checked_ydlidar, feed_all, run_to_end};
use common::{chunks, seeded, Units};
use proptest::prelude::*;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::wire::ld06::{
    Ld06Accumulator, Ld06Counters, Ld06Packet, Ld06Point, Ld06Repr, LD06_PACKET_LEN,
};
use terrain_pyramid::wire::rplidar::{
    RplidarAccumulator, RplidarCapsule, RplidarCapsuleRepr, RplidarCounters, RplidarDescriptor,
    RplidarDescriptorRepr, RplidarError, RplidarItem, RplidarNode, RplidarNodeRepr,
};
use terrain_pyramid::wire::ydlidar::{
    YdlidarAccumulator, YdlidarAngleCorrection, YdlidarCounters, YdlidarPacket,
    YDLIDAR_CORRECTION_MAX_ERROR_DEG,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid_host_tests::sim::lidar::ydlidar_packet_bytes;

fn degrees(a: FineAngle) -> f64 {
    f64::from(a.to_bits()) * 360.0 / 4_294_967_296.0
}

/// `a − b` in degrees, reduced to (−180, 180].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// Garbage without the byte `sync`.
fn garbage_without(sync: &'static [u8]) -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(any::<u8>(), 0..30).prop_map(move |mut g| {
        for b in &mut g {
            if sync.contains(b) {
                *b = 0x11;
            }
        }
        g
    })
}

// -------------------------------------------------------------------------------------- LD06

fn ld06_repr() -> impl Strategy<Value = Ld06Repr> {
    (
        any::<u16>(),
        0_u16..36_000,
        0_u16..36_000,
        0_u16..30_000,
        proptest::array::uniform12((any::<u16>(), any::<u8>())),
    )
        .prop_map(|(speed, start, end, ts, points)| Ld06Repr {
            speed_deg_per_s: speed,
            start_angle_centideg: start,
            end_angle_centideg: end,
            timestamp_ms: ts,
            points: points.map(|(distance_mm, intensity)| Ld06Point {
                distance_mm,
                intensity,
            }),
        })
}

fn ld06_bytes(repr: &Ld06Repr) -> Vec<u8> {
    let mut b = vec![0; LD06_PACKET_LEN];
    repr.emit(&mut b).unwrap();
    b
}

/// A stream of `head` (a descriptor, or nothing), then each packet after its garbage: with the
/// (offset, bytes) an accumulator should deliver (`head` first, unless empty, then every
/// packet) and how many bytes of garbage it holds.
fn garbled_stream<'g>(
    head: &[u8],
    packets: impl Iterator<Item = (&'g Vec<u8>, Vec<u8>)>,
) -> (Vec<u8>, Units, usize) {
    let mut stream = head.to_vec();
    let mut want = Vec::new();
    if !head.is_empty() {
        want.push((0, stream.clone()));
    }
    let mut garbage = 0;
    for (g, packet) in packets {
        stream.extend_from_slice(g);
        garbage += g.len();
        want.push((stream.len() as u64, packet.clone()));
        stream.extend(packet);
    }
    (stream, want, garbage)
}

/// Feeds the chunks and flushes: (offset, packet) delivered, rejections, counters.
fn ld06_run(chunks: &[&[u8]]) -> (Vec<(u64, Vec<u8>)>, usize, Ld06Counters, u64) {
    run_to_end(Ld06Accumulator::new(), chunks, checked_ld06)
}

proptest! {
    #![proptest_config(seeded(600, 0x11d0_6001))]

    /// Packets with garbage (no 0x54) between them, fed in random chunks, come back exactly,
    /// at their offsets, and parse back to their fields; every byte is accounted for.
    #[test]
    fn ld06_round_trip(
        pieces in proptest::collection::vec((ld06_repr(), garbage_without(&[0x54])), 1..12),
        sizes in proptest::collection::vec(1_usize..120, 1..5),
    ) {
        let (stream, want, garbage) =
            garbled_stream(&[], pieces.iter().map(|(repr, g)| (g, ld06_bytes(repr))));
        let (delivered, rejected, c, position) = ld06_run(&chunks(&stream, &sizes));
        prop_assert_eq!(&delivered, &want);
        prop_assert_eq!(rejected, 0);
        prop_assert_eq!(position, stream.len() as u64);
        prop_assert_eq!(c, Ld06Counters { packets: pieces.len() as u32, garbage_bytes: garbage as u32, ..Ld06Counters::default() });
        for ((_, bytes), (repr, _)) in delivered.iter().zip(&pieces) {
            prop_assert_eq!(&Ld06Repr::parse(&Ld06Packet::new_unchecked(&bytes[..])), repr);
        }
    }

    /// The returns are the manual's interpolation across the wrap (§3.2), within the
    /// FineAngle LSB, with the distances and intensities as sent.
    #[test]
    fn ld06_returns_follow_the_manual(repr in ld06_repr()) {
        let bytes = ld06_bytes(&repr);
        let p = Ld06Packet::new_checked(&bytes[..]).unwrap();
        let start = f64::from(repr.start_angle_centideg) / 100.0;
        let mut end = f64::from(repr.end_angle_centideg) / 100.0;
        if end < start {
            end += 360.0;
        }
        for (k, r) in p.returns().enumerate() {
            let want = (start + k as f64 * (end - start) / 11.0).rem_euclid(360.0);
            prop_assert!(angle_diff(degrees(r.angle), want).abs() < 1e-7, "{k}: {} vs {want}", degrees(r.angle));
            prop_assert_eq!(r.range_mm, u32::from(repr.points[k].distance_mm));
            prop_assert_eq!(r.quality, Some(repr.points[k].intensity));
        }
        // The span crosses 0° exactly when the end angle is below the start angle.
        prop_assert_eq!(p.starts_revolution(), repr.end_angle_centideg < repr.start_angle_centideg);
    }

    /// Every single-bit flip of a packet is refused (the CRC-8 with x⁰ term catches them
    /// all), by the view and by the accumulator, and the packet after it still arrives.
    #[test]
    fn ld06_bit_flips_are_refused(repr in ld06_repr(), next in ld06_repr(), bit in 0_usize..(8 * 47)) {
        let mut flipped = ld06_bytes(&repr);
        flipped[bit / 8] ^= 1 << (bit % 8);
        prop_assert!(Ld06Packet::new_checked(&flipped[..]).is_err());
        let good = ld06_bytes(&next);
        let stream = [flipped.clone(), good.clone()].concat();
        let (delivered, _, c, _) = ld06_run(&[&stream]);
        // The good packet arrives, unless a false candidate inside the flipped one passed
        // the CRC by chance and overlaps it.
        let got_good = delivered.contains(&(47, good.clone()));
        let false_overlap = delivered.iter().any(|(o, _)| *o > 0 && *o < 47);
        prop_assert!(got_good || false_overlap);
        prop_assert!(!delivered.iter().any(|(o, _)| *o == 0));
        prop_assert_eq!(47 * u64::from(c.packets) + u64::from(c.checksum + c.truncated + c.garbage_bytes), 94);
    }

    /// A packet cut anywhere is reported as truncated at the end of the stream, never
    /// delivered; the bytes add up.
    #[test]
    fn ld06_truncation(repr in ld06_repr(), cut in 2_usize..47) {
        let bytes = ld06_bytes(&repr);
        let (delivered, rejected, c, _) = ld06_run(&[&bytes[..cut]]);
        prop_assert!(delivered.is_empty());
        // At least the cut packet; its data may hold another `54 2C`, cut as well.
        prop_assert!(rejected >= 1 && c.truncated as usize == rejected);
        prop_assert_eq!(u64::from(c.truncated + c.garbage_bytes), cut as u64);
    }
}

// ------------------------------------------------------------------------------------ YDLIDAR

fn ydlidar_parts() -> impl Strategy<Value = (u8, u16, u16, Vec<u16>)> {
    (
        prop_oneof![3 => Just(0_u8), 1 => Just(1_u8), 1 => any::<u8>()],
        0_u16..23_040,
        0_u16..23_040,
        proptest::collection::vec(any::<u16>(), 1..60),
    )
}

fn ydlidar_run(chunks: &[&[u8]]) -> (Vec<(u64, Vec<u8>)>, usize, YdlidarCounters, u64) {
    run_to_end(YdlidarAccumulator::new(), chunks, checked_ydlidar)
}

proptest! {
    #![proptest_config(seeded(600, 0x11d0_6002))]

    /// The scan descriptor and packets with garbage (no 0xAA, 0xA5) between them, fed in
    /// random chunks, come back exactly, at their offsets.
    #[test]
    fn ydlidar_round_trip(
        pieces in proptest::collection::vec((ydlidar_parts(), garbage_without(&[0xAA, 0xA5])), 1..10),
        sizes in proptest::collection::vec(1_usize..200, 1..5),
    ) {
        let (stream, want, garbage) = garbled_stream(
            &[0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81],
            pieces.iter().map(|((ct, first, last, samples), g)| {
                (g, ydlidar_packet_bytes(*ct, *first, *last, samples).unwrap())
            }),
        );
        let (delivered, rejected, c, position) = ydlidar_run(&chunks(&stream, &sizes));
        prop_assert_eq!(&delivered, &want);
        prop_assert_eq!(rejected, 0);
        prop_assert_eq!(position, stream.len() as u64);
        prop_assert_eq!(c, YdlidarCounters { packets: pieces.len() as u32, descriptors: 1, garbage_bytes: garbage as u32, ..YdlidarCounters::default() });
    }

    /// The returns are the manual's first-level interpolation plus the second-level
    /// correction, against `f64`, within the correction's documented bound; with the
    /// correction off, within the FineAngle LSB.
    #[test]
    fn ydlidar_returns_follow_the_manual((ct, first, last, samples) in ydlidar_parts()) {
        let bytes = ydlidar_packet_bytes(ct, first, last, &samples).unwrap();
        let p = YdlidarPacket::new_checked(&bytes[..]).unwrap();
        prop_assert_eq!(p.starts_revolution(), ct & 1 == 1);
        let fsa = f64::from(first) / 64.0;
        let mut lsa = f64::from(last) / 64.0;
        if lsa < fsa {
            lsa += 360.0;
        }
        let n = samples.len();
        let corrected: Vec<_> = p.returns().collect();
        let raw: Vec<_> = p.returns_with(YdlidarAngleCorrection::Off).collect();
        prop_assert_eq!(corrected.len(), n);
        for i in 0..n {
            let base = if n > 1 { fsa + i as f64 * (lsa - fsa) / (n - 1) as f64 } else { fsa };
            let d = f64::from(samples[i]) / 4.0;
            let corr = if samples[i] == 0 { 0.0 } else { (21.8 * (155.3 - d) / (155.3 * d)).atan().to_degrees() };
            prop_assert!(angle_diff(degrees(raw[i].angle), base).abs() < 1e-7);
            prop_assert!(angle_diff(degrees(corrected[i].angle), base + corr).abs() <= YDLIDAR_CORRECTION_MAX_ERROR_DEG + 1e-7);
            prop_assert_eq!(corrected[i].range_mm, (u32::from(samples[i]) + 2) / 4);
            prop_assert_eq!(corrected[i].quality, None);
        }
    }

    /// Every single-bit flip is refused by the view (header, check bits or the XOR), except
    /// a flip of LSN towards fewer samples, which reads a shorter packet whose XOR matches
    /// only by chance (1 in 65 536).
    #[test]
    fn ydlidar_bit_flips_are_refused((ct, first, last, samples) in ydlidar_parts(), bit in any::<usize>()) {
        let mut flipped = ydlidar_packet_bytes(ct, first, last, &samples).unwrap();
        let bit = bit % (8 * flipped.len());
        flipped[bit / 8] ^= 1 << (bit % 8);
        let lsn_shrunk = bit / 8 == 3 && usize::from(flipped[3]) < samples.len();
        prop_assert!(YdlidarPacket::new_checked(&flipped[..]).is_err() || lsn_shrunk);
    }

    /// A packet cut anywhere is reported at the end of the stream, never delivered; the
    /// bytes add up.
    #[test]
    fn ydlidar_truncation((ct, first, last, samples) in ydlidar_parts(), cut in any::<usize>()) {
        let bytes = ydlidar_packet_bytes(ct, first, last, &samples).unwrap();
        let cut = 2 + cut % (bytes.len() - 2);
        let (delivered, rejected, c, _) = ydlidar_run(&[&bytes[..cut]]);
        prop_assert!(delivered.is_empty());
        prop_assert!(rejected >= 1);
        prop_assert_eq!(
            u64::from(c.checksum + c.check_bits + c.bad_length + c.truncated + c.garbage_bytes),
            cut as u64
        );
    }
}

// ------------------------------------------------------------------------------------ RPLIDAR

fn node_repr() -> impl Strategy<Value = RplidarNodeRepr> {
    (0_u8..64, any::<bool>(), 0_u16..23_040, any::<u16>()).prop_map(
        |(quality, start, angle_q6, distance_q2)| RplidarNodeRepr {
            quality,
            start,
            angle_q6,
            distance_q2,
        },
    )
}

fn node_bytes(n: &RplidarNodeRepr) -> Vec<u8> {
    let mut b = vec![0; 5];
    n.emit(&mut b).unwrap();
    b
}

fn capsule_repr() -> impl Strategy<Value = RplidarCapsuleRepr> {
    (
        0_u16..23_040,
        proptest::array::uniform32(0_u16..0x4000),
        proptest::array::uniform32(0_u8..64),
    )
        .prop_map(
            |(start, distances_mm, angle_offsets_q3)| RplidarCapsuleRepr {
                start_angle_q6: start,
                start_flag: false,
                distances_mm,
                angle_offsets_q3,
            },
        )
}

fn capsule_bytes(c: &RplidarCapsuleRepr) -> Vec<u8> {
    let mut b = vec![0; 84];
    c.emit(&mut b).unwrap();
    b
}

fn descriptor_bytes(d: RplidarDescriptorRepr) -> Vec<u8> {
    let mut b = vec![0; 7];
    d.emit(&mut b).unwrap();
    b
}

/// A stream of `descriptor` and then every unit's `bytes`, with the offset of each unit.
fn after_descriptor<T>(
    descriptor: RplidarDescriptorRepr,
    units: &[T],
    bytes: impl Fn(&T) -> Vec<u8>,
) -> (Vec<u8>, Vec<u64>) {
    let mut stream = descriptor_bytes(descriptor);
    let mut offsets = Vec::new();
    for unit in units {
        offsets.push(stream.len() as u64);
        stream.extend(bytes(unit));
    }
    (stream, offsets)
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Rp {
    D(u64),
    N(u64, Vec<u8>),
    X(u64, Vec<u8>, u16, Vec<(u32, u32)>),
    R(u64, RplidarError),
    Other,
}

fn rplidar_run(acc: RplidarAccumulator, chunks: &[&[u8]]) -> (Vec<Rp>, RplidarCounters, u64) {
    let mut acc = acc;
    let mut out = Vec::new();
    feed_all(&mut acc, chunks, |r| {
        match r {
            FeedResult::Consumed => return false,
            FeedResult::Item { item, offset, .. } => out.push(match item {
                RplidarItem::Descriptor(d) => {
                    assert!(RplidarDescriptor::new_checked(d.as_bytes()).is_ok());
                    Rp::D(offset)
                }
                RplidarItem::Node(n) => {
                    assert!(RplidarNode::new_checked(n.as_bytes()).is_ok());
                    Rp::N(offset, n.as_bytes().to_vec())
                }
                RplidarItem::Express(e) => {
                    assert!(RplidarCapsule::new_checked(e.capsule().as_bytes()).is_ok());
                    Rp::X(
                        offset,
                        e.capsule().as_bytes().to_vec(),
                        e.next_start_angle_q6(),
                        e.returns()
                            .map(|r| (r.angle.to_bits(), r.range_mm))
                            .collect(),
                    )
                }
                RplidarItem::Response(_) => Rp::Other,
            }),
            FeedResult::Rejected { error, offset, .. } => out.push(Rp::R(offset, error)),
        }
        true
    });
    assert_eq!(acc.buffered(), 0);
    let c = acc.counters();
    (out, c, acc.position())
}

proptest! {
    #![proptest_config(seeded(600, 0x11d0_6003))]

    /// SCAN descriptor and nodes, in random chunks: exactly the nodes, at their offsets. The
    /// nodes' angles advance by `step` (up to 3.6°, the fastest head at the slowest sampling)
    /// with the start flag where they pass 0°, as a sensor sends them: none is implausible.
    #[test]
    fn rplidar_node_round_trip(
        mut nodes in proptest::collection::vec(node_repr(), 1..80),
        sizes in proptest::collection::vec(1_usize..50, 1..5),
        first in 0_u32..23_040,
        step in 1_u32..=230,
    ) {
        for (i, n) in nodes.iter_mut().enumerate() {
            let at = first + step * i as u32;
            n.angle_q6 = (at % 23_040) as u16;
            n.start = i > 0 && at / 23_040 != (at - step) / 23_040;
        }
        let mut stream = descriptor_bytes(RplidarDescriptorRepr::SCAN);
        let mut want = vec![Rp::D(0)];
        for n in &nodes {
            want.push(Rp::N(stream.len() as u64, node_bytes(n)));
            stream.extend(node_bytes(n));
        }
        let (events, c, position) = rplidar_run(RplidarAccumulator::new(), &chunks(&stream, &sizes));
        prop_assert_eq!(&events, &want);
        prop_assert_eq!(position, stream.len() as u64);
        prop_assert_eq!((c.nodes as usize, c.descriptors, c.garbage_bytes), (nodes.len(), 1, 0));
        for (e, n) in events[1..].iter().zip(&nodes) {
            if let Rp::N(_, b) = e {
                prop_assert_eq!(&RplidarNodeRepr::parse(&RplidarNode::new_unchecked(&b[..])), n);
            }
        }
    }

    /// SCAN descriptor and nodes at random angles, in random chunks: each node comes out
    /// whole at its offset or is refused whole as implausible, never anything else, and every
    /// byte is accounted for (5 per node either way).
    #[test]
    fn rplidar_random_angles_are_delivered_or_refused_whole(
        nodes in proptest::collection::vec(node_repr(), 1..80),
        sizes in proptest::collection::vec(1_usize..50, 1..5),
    ) {
        let (stream, offsets) = after_descriptor(RplidarDescriptorRepr::SCAN, &nodes, node_bytes);
        let (events, c, position) = rplidar_run(RplidarAccumulator::new(), &chunks(&stream, &sizes));
        prop_assert_eq!(position, stream.len() as u64);
        prop_assert_eq!(events.len(), 1 + nodes.len());
        for (e, (&at, n)) in events[1..].iter().zip(offsets.iter().zip(&nodes)) {
            match e {
                Rp::N(offset, b) => {
                    prop_assert_eq!(*offset, at);
                    prop_assert_eq!(b, &node_bytes(n));
                }
                Rp::R(offset, RplidarError::Implausible) => {
                    prop_assert_eq!(*offset, at);
                    prop_assert!(n.distance_q2 != 0);
                }
                other => return Err(TestCaseError::fail(format!("{other:?}"))),
            }
        }
        prop_assert_eq!(c.nodes as usize + c.implausible as usize, nodes.len());
        prop_assert_eq!(c.garbage_bytes, 0);
    }

    /// EXPRESS_SCAN descriptor and capsules, in random chunks: every capsule but the last
    /// comes back placed with its successor's start angle, at the protocol document's
    /// angles (θₖ = ωᵢ + k·AngleDiff/32 − dθₖ, in `f64`) within the FineAngle LSB; the last
    /// one is reported unpaired at the end of the stream.
    #[test]
    fn rplidar_capsule_round_trip(
        caps in proptest::collection::vec(capsule_repr(), 1..8),
        sizes in proptest::collection::vec(1_usize..200, 1..5),
    ) {
        let (stream, offsets) = after_descriptor(RplidarDescriptorRepr::EXPRESS_SCAN, &caps, capsule_bytes);
        let (events, c, _) = rplidar_run(RplidarAccumulator::new(), &chunks(&stream, &sizes));
        prop_assert_eq!(events.len(), 1 + caps.len());
        prop_assert_eq!(&events[0], &Rp::D(0));
        for (i, e) in events[1..caps.len()].iter().enumerate() {
            let Rp::X(offset, bytes, next, returns) = e else {
                return Err(TestCaseError::fail(format!("{e:?}")));
            };
            prop_assert_eq!(*offset, offsets[i]);
            prop_assert_eq!(bytes, &capsule_bytes(&caps[i]));
            prop_assert_eq!(*next, caps[i + 1].start_angle_q6);
            let w = f64::from(caps[i].start_angle_q6) / 64.0;
            let mut w1 = f64::from(*next) / 64.0;
            if w1 < w {
                w1 += 360.0;
            }
            for (k, &(angle, range)) in returns.iter().enumerate() {
                let want = w + (w1 - w) / 32.0 * k as f64 - f64::from(caps[i].angle_offsets_q3[k]) / 8.0;
                let got = degrees(FineAngle::from_bits(angle));
                prop_assert!(angle_diff(got, want).abs() < 1e-7, "{k}: {got} vs {want}");
                prop_assert_eq!(range, u32::from(caps[i].distances_mm[k]));
            }
        }
        prop_assert_eq!(events.last(), Some(&Rp::R(*offsets.last().unwrap(), RplidarError::CapsuleUnpaired)));
        prop_assert_eq!((c.capsules as usize, c.capsules_unpaired), (caps.len() - 1, 1));
    }

    /// Every single-bit flip of a capsule is refused (sync nibble or XOR checksum).
    #[test]
    fn rplidar_capsule_flips_are_refused(cap in capsule_repr(), bit in 0_usize..(84 * 8)) {
        let mut b = capsule_bytes(&cap);
        b[bit / 8] ^= 1 << (bit % 8);
        prop_assert!(RplidarCapsule::new_checked(&b[..]).is_err());
    }

    /// A node flip is refused by its checks or changes the node's value (every one of the
    /// 40 bits means something): the weak check's documented limit, never a silent copy.
    #[test]
    fn rplidar_node_flips_are_refused_or_change_the_value(n in node_repr(), bit in 0_usize..40) {
        let mut b = node_bytes(&n);
        b[bit / 8] ^= 1 << (bit % 8);
        match RplidarNode::new_checked(&b[..]) {
            Err(e) => prop_assert_eq!(e, RplidarError::BadNode),
            Ok(v) => {
                prop_assert_ne!(RplidarNodeRepr::parse(&v), n);
                // The check bits survive only flips outside S, !S and C.
                prop_assert!(![0, 1, 8].contains(&bit));
            }
        }
    }
}

/// A single bit flip never turns one known descriptor into another (their Hamming distance
/// is at least 2), so a flipped descriptor is never followed in the wrong mode.
#[test]
fn rplidar_descriptor_flips_are_never_another_known_descriptor() {
    let known = [
        RplidarDescriptorRepr::SCAN,
        RplidarDescriptorRepr::EXPRESS_SCAN,
        RplidarDescriptorRepr::HEALTH,
        RplidarDescriptorRepr::INFO,
        RplidarDescriptorRepr::SAMPLE_RATE,
    ];
    for d in known {
        let good = descriptor_bytes(d);
        for bit in 0..56 {
            let mut b = good.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            let mut stream = b.clone();
            stream.extend_from_slice(&[0x3E; 30]);
            let (events, c, _) = rplidar_run(RplidarAccumulator::new(), &[&stream]);
            assert!(!events.contains(&Rp::D(0)), "{d:?} bit {bit}");
            assert_eq!(c.descriptors, 0);
        }
    }
}
