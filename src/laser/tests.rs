//! The decoder over the four accumulators, packets as the pipeline takes them, and their
//! times.
extern crate std;
use super::*;
use crate::test_rng::XorShift;
use crate::wire::ld06::{Ld06Point, Ld06Repr};
use crate::wire::rplidar::{RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarNodeRepr};
use crate::wire::sick::{MeasuredValues, Unit};
use crate::wire::ydlidar::YdlidarRepr;
use std::vec::Vec;

fn ld06(start: u16, end: u16, speed: u16) -> Vec<u8> {
    let mut points = [Ld06Point::default(); 12];
    for (k, p) in points.iter_mut().enumerate() {
        p.distance_mm = 1000 + k as u16;
        p.intensity = 200;
    }
    let repr = Ld06Repr {
        speed_deg_per_s: speed,
        start_angle_centideg: start,
        end_angle_centideg: end,
        timestamp_ms: 0,
        points,
    };
    let mut buf = std::vec![0; 47];
    repr.emit(&mut buf).unwrap();
    buf
}

fn node(angle_q6: u16, start: bool) -> Vec<u8> {
    let mut buf = std::vec![0; 5];
    RplidarNodeRepr {
        quality: 30,
        start,
        angle_q6,
        distance_q2: 4 * 2_000,
    }
    .emit(&mut buf)
    .unwrap();
    buf
}

fn capsule(start_angle_q6: u16) -> Vec<u8> {
    let mut buf = std::vec![0; 84];
    RplidarCapsuleRepr {
        start_angle_q6,
        distances_mm: [1_500; 32],
        ..RplidarCapsuleRepr::default()
    }
    .emit(&mut buf)
    .unwrap();
    buf
}

fn ydlidar(first_q6: u16, last_q6: u16, samples: &[u16], start: bool) -> Vec<u8> {
    let repr = YdlidarRepr {
        packet_type: u8::from(start),
        first_angle_q6: first_q6,
        last_angle_q6: last_q6,
        samples,
    };
    let mut buf = std::vec![0; repr.buffer_len()];
    repr.emit(&mut buf).unwrap();
    buf
}

fn sick_line() -> Vec<u8> {
    let values: Vec<u8> = (0..361_u16).flat_map(|_| 2_000_u16.to_le_bytes()).collect();
    let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
    let mut buf = std::vec![0; line.buffer_len()];
    let n = line.emit(&mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// What the decoder made of a stream: (returns, starts revolution) per packet, telegrams.
fn decode(decoder: &mut LaserDecoder, stream: &[u8]) -> (Vec<(Vec<LaserReturn>, bool)>, usize) {
    let (mut packets, mut telegrams) = (Vec::new(), 0);
    let mut rest = stream;
    loop {
        rest = match decoder.feed(rest) {
            FeedResult::Consumed => break,
            FeedResult::Item {
                item, remaining, ..
            } => {
                match item {
                    LaserItem::Packet(p) => {
                        assert_eq!(p.returns().len(), p.len());
                        packets.push((p.returns().collect(), p.starts_revolution()));
                    }
                    LaserItem::Telegram(_) => telegrams += 1,
                    LaserItem::Other => {}
                }
                remaining
            }
            FeedResult::Rejected { remaining, .. } => remaining,
        };
    }
    (packets, telegrams)
}

#[test]
fn each_sensor_decodes_its_own_stream() {
    let mut d = LaserDecoder::new(Sensor::Sick);
    assert_eq!(decode(&mut d, &sick_line()).1, 1);

    assert!(d.set_sensor(Sensor::Ld06));
    let mut stream = ld06(35_900, 820, 3_600);
    stream.extend(ld06(900, 1_800, 3_600));
    let (packets, _) = decode(&mut d, &stream);
    assert_eq!(packets.len(), 2);
    assert!(packets[0].1 && !packets[1].1);
    assert_eq!(packets[0].0.len(), 12);
    assert_eq!(packets[0].0[0].range_mm, 1000);
    assert_eq!(packets[0].0[0].quality, Some(200));

    assert!(d.set_sensor(Sensor::Rplidar(RplidarScanMode::Standard)));
    let mut stream = Vec::new();
    let mut descriptor = [0; 7];
    RplidarDescriptorRepr::SCAN.emit(&mut descriptor).unwrap();
    stream.extend(descriptor);
    for k in 0..20_u16 {
        stream.extend(node(k * 64, k == 0));
    }
    let (packets, _) = decode(&mut d, &stream);
    assert_eq!(packets.len(), 20);
    assert!(packets[0].1 && !packets[1].1);
    assert_eq!(packets[3].0[0].range_mm, 2_000);

    assert!(d.set_sensor(Sensor::Rplidar(RplidarScanMode::Express)));
    let mut stream = Vec::new();
    for k in 0..4_u16 {
        stream.extend(capsule(k * 640));
    }
    let (packets, _) = decode(&mut d, &stream);
    // Each capsule is placed by the next: three of four.
    assert_eq!(packets.len(), 3);
    assert_eq!(packets[0].0.len(), 32);

    assert!(d.set_sensor(Sensor::Ydlidar(YdlidarAngleCorrection::Off)));
    let mut stream = ydlidar(0, 0, &[4_000], true);
    stream.extend(ydlidar(64, 64 * 10, &[4_000; 10], false));
    let (packets, _) = decode(&mut d, &stream);
    assert_eq!(packets.len(), 2);
    assert!(packets[0].1);
    assert_eq!(packets[1].0.len(), 10);
    assert_eq!(packets[1].0[9].angle, turn_fraction(10 * 64, 23_040));
    assert_eq!(packets[1].0[0].range_mm, 1_000);
}

#[test]
fn switching_sensors_keeps_the_counts() {
    let mut d = LaserDecoder::default();
    assert_eq!(d.sensor(), Sensor::Sick);
    let line = sick_line();
    let mut bad = line.clone();
    *bad.last_mut().unwrap() ^= 1;
    decode(&mut d, &line);
    decode(&mut d, &bad);
    assert_eq!(
        d.counts(),
        LaserCounts {
            ok: 1,
            bad_checksum: 1,
            bad_framing: 0,
            implausible: 0
        }
    );
    assert!(d.counters().sick().is_some());
    // The same sensor keeps its accumulator and what it holds.
    decode(&mut d, &line[..100]);
    assert!(!d.set_sensor(Sensor::Sick));
    assert_eq!(decode(&mut d, &line[100..]).1, 1);
    let bytes = d.bytes();
    assert_eq!(bytes, 3 * line.len() as u64);
    // Another sensor: fresh accumulator, old counts kept, bytes go on.
    assert!(d.set_sensor(Sensor::Ld06));
    assert_eq!(d.counters(), LaserCounters::Ld06(Ld06Counters::default()));
    let mut packet = ld06(100, 1_000, 3_600);
    decode(&mut d, &packet);
    packet[10] ^= 0x40;
    decode(&mut d, &packet);
    assert_eq!(
        d.counts(),
        LaserCounts {
            ok: 3,
            bad_checksum: 2,
            bad_framing: 0,
            implausible: 0
        }
    );
    assert_eq!(d.bytes(), bytes + 2 * 47);
    // Half a packet at the end: truncated, framing.
    decode(&mut d, &packet[..20]);
    while !matches!(d.flush(), FeedResult::Consumed) {}
    assert_eq!(d.counts().bad_framing, 1);
}

/// The packet `decoder` hands out first on `bytes` (the test fails on anything else).
fn first_packet<'d>(decoder: &'d mut LaserDecoder, bytes: &[u8]) -> Packet<'d> {
    let FeedResult::Item {
        item: LaserItem::Packet(p),
        ..
    } = decoder.feed(bytes)
    else {
        panic!()
    };
    p
}

#[test]
fn spans_and_lags() {
    let mut d = LaserDecoder::new(Sensor::Ld06);
    let bytes = ld06(35_900, 820, 3_600);
    let p = first_packet(&mut d, &bytes);
    assert_eq!(p.span(), turn_fraction(920, 36_000));
    assert_eq!(p.lag(), None);
    assert_eq!(p.reported_rate_deg_per_s(), Some(3_600));
    assert_eq!(p.wire_len(), 47);

    let mut d = LaserDecoder::new(Sensor::Rplidar(RplidarScanMode::Express));
    let mut stream = capsule(23_040 - 320);
    stream.extend(capsule(320));
    let mut rest = &stream[..];
    let mut seen = 0;
    loop {
        rest = match d.feed(rest) {
            FeedResult::Consumed => break,
            FeedResult::Item {
                item: LaserItem::Packet(p),
                remaining,
                ..
            } => {
                // 10° from one capsule to the next, across 360°: 31/32 of it between the
                // first and the last point.
                assert_eq!(p.lag(), Some(turn_fraction(640, 23_040)));
                assert_eq!(p.span(), turn_fraction(640 * 31, 23_040 * 32));
                assert!(p.starts_revolution());
                seen += 1;
                remaining
            }
            other => other.remaining(),
        };
    }
    assert_eq!(seen, 1);
}

#[test]
fn packet_times_follow_the_rate_and_the_wire() {
    let mut d = LaserDecoder::new(Sensor::Ld06);
    // 9.6° at 3 600 °/s: 2 667 µs from the first return to the last.
    let bytes = ld06(1_000, 1_960, 3_600);
    let p = first_packet(&mut d, &bytes);
    let mut timer = PacketTimer::new(230_400);
    // 47 bytes at 230 400 Bd: 2 040 µs.
    assert_eq!(timer.bytes_us(47), 2_039);
    let (first, last) = timer.times(&p, 1_000_000, false);
    assert_eq!(last, 1_000_000 - 2_039);
    assert_eq!(last - first, 2_666);

    // The YDLIDAR's rate comes from its revolution starts.
    let mut d = LaserDecoder::new(Sensor::Ydlidar(YdlidarAngleCorrection::SecondLevel));
    let mut timer = PacketTimer::new(128_000);
    assert_eq!(timer.revolution_us(), (DEFAULT_REVOLUTION_US, false));
    let zero = ydlidar(0, 0, &[4_000], true);
    let mut times = Vec::new();
    for t in [0_u32, 140_000, 282_000] {
        let p = first_packet(&mut d, &zero);
        times.push(timer.times(&p, t, p.starts_revolution()));
    }
    // 140 ms, then the mean of 140 and 142.
    assert_eq!(timer.revolution_us(), (141_000, true));
    // A packet of 36° (a tenth of the turn) takes a tenth of the period.
    let bytes = ydlidar(0, 36 * 64, &[4_000; 40], false);
    let p = first_packet(&mut d, &bytes);
    let (first, last) = timer.times(&p, 500_000, false);
    assert_eq!(last, 500_000 - timer.bytes_us(90));
    assert_eq!(last - first, 14_100);
    // A period outside 20 ms ..= 1 s is ignored.
    let p = first_packet(&mut d, &zero);
    timer.times(&p, 282_000 + 5_000_000, true);
    assert_eq!(timer.revolution_us(), (141_000, true));
    timer.reset(115_200);
    assert_eq!(timer.revolution_us(), (DEFAULT_REVOLUTION_US, false));
}

#[test]
fn sensors_kinds_and_modes() {
    for kind in [
        SensorKind::Sick,
        SensorKind::Ld06,
        SensorKind::Rplidar,
        SensorKind::Ydlidar,
    ] {
        assert_eq!(SensorKind::from_code(kind.code()), Some(kind));
        for mode in 0..=Sensor::max_mode(kind).unwrap_or(0) {
            let s = Sensor::from_kind_and_mode(kind, mode).unwrap();
            assert_eq!((s.kind(), s.mode()), (kind, mode));
            assert_eq!(s.is_lidar(), kind != SensorKind::Sick);
        }
        if let Some(max) = Sensor::max_mode(kind) {
            assert_eq!(Sensor::from_kind_and_mode(kind, max + 1), None);
        }
    }
    assert_eq!(SensorKind::from_code(4), None);
    assert_eq!(SensorKind::Rplidar.default_baud(), 115_200);
    assert_eq!(std::format!("{}", SensorKind::Ydlidar), "ydlidar");
}

#[test]
fn an_ld06_revolution_between_two_packets_is_seen() {
    let mut d = LaserDecoder::new(Sensor::Ld06);
    let mut tracker = RevolutionTracker::new();
    let mut starts = Vec::new();
    // 350.4 → 359.2, then 0.0 → 8.8 (the turn between them), then 9.6 → 18.4, then one
    // crossing 0° inside.
    for (a, b) in [(35_040, 35_920), (0, 880), (960, 1_840), (35_500, 380)] {
        let bytes = ld06(a, b, 3_600);
        let p = first_packet(&mut d, &bytes);
        starts.push(tracker.starts(&p));
    }
    assert_eq!(starts, [false, true, false, true]);
}

#[test]
fn an_ld06_packets_returns_step_to_exactly_its_angles() {
    // The returns iterator steps the angles with two divisions a packet; each must be the
    // packet's own `get(k)`, across the wrap and at every start, span and the wire's
    // out-of-range angles (≥ 36 000 centidegrees).
    let mut rng = XorShift(0x0123_4567_89AB_CDEF_u64);
    let mut next = move |n: u64| rng.below(n) as u16;
    let mut cases = std::vec![(35_900, 120), (0, 0), (35_999, 35_999), (65_535, 0)];
    for _ in 0..2_000 {
        cases.push((next(65_536), next(65_536)));
        let start = next(36_000);
        cases.push((start, (start + next(400)) % 36_000));
    }
    for (start, end) in cases {
        let bytes = ld06(start, end, 3_600);
        let view = Ld06Packet::new_checked(&bytes[..]).unwrap();
        let packet = Packet::Ld06(view);
        let stepped: Vec<LaserReturn> = packet.returns().collect();
        let direct: Vec<LaserReturn> = (0..12).filter_map(|k| packet.get(k)).collect();
        assert_eq!(stepped, direct, "start {start}, end {end}");
        assert_eq!(stepped.len(), 12);
        let own: Vec<LaserReturn> = view.returns().collect();
        assert_eq!(own, direct, "start {start}, end {end}");
    }
}

#[test]
fn a_ydlidar_packets_returns_step_to_exactly_its_angles() {
    // As for the LD06: the stepped first-level angles (with and without the second-level
    // correction) equal the packet's own per-sample angles, for 1..=40 samples, across the
    // wrap and at out-of-range wire angles.
    let mut rng = XorShift(0x0F0E_0D0C_0B0A_0908_u64);
    let mut next = move |n: u64| rng.below(n);
    for case in 0..3_000 {
        let n = 1 + next(40) as usize;
        let samples: Vec<u16> = (0..n).map(|_| next(40_000) as u16).collect();
        let first = next(32_768) as u16;
        let last = if case % 2 == 0 {
            next(32_768) as u16
        } else {
            ((u64::from(first) + next(1_000)) % 23_040) as u16
        };
        let bytes = ydlidar(first, last, &samples, false);
        let view = YdlidarPacket::new_checked(&bytes[..]).unwrap();
        for correction in [
            YdlidarAngleCorrection::SecondLevel,
            YdlidarAngleCorrection::Off,
        ] {
            let packet = Packet::Ydlidar(view, correction);
            let stepped: Vec<LaserReturn> = packet.returns().collect();
            let direct: Vec<LaserReturn> = (0..n).filter_map(|k| packet.get(k)).collect();
            assert_eq!(stepped, direct, "case {case}");
            assert_eq!(stepped.len(), n);
            let own: Vec<LaserReturn> = view.returns_with(correction).collect();
            assert_eq!(own, direct, "case {case}");
        }
    }
}
