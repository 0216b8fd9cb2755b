//! Bounded random-stream smoke tests for CI (stable, no fuzzer): hostile input to every
//! decoder the firmware exposes to the outside world, with an oracle that knows what arrived
//! intact.
//!
//! - SICK: valid reply telegrams interleaved with garbage, bit-flipped and truncated
//!   telegrams, lone ACK/NAK and false `02 80` headers, fed in random chunks. Every telegram
//!   that arrived intact is delivered exactly once, at its offset; nothing else is delivered;
//!   the counters add up.
//! - Link: valid frames interleaved with garbage segments, bit-flipped and truncated frames.
//!   Every frame that arrived intact (its bytes unchanged, a delimiter before it) decodes
//!   exactly once; every other non-empty segment between delimiters is one counted error.
//! - Configurations: random fields (sane and arbitrary bit patterns) through `Design::new`,
//!   `increments`, `Clamp::bounds` and `Pyramid::configure`; accepted designs keep their
//!   documented invariants.
//! - Recordings: random valid recordings read back exactly; damaged ones never panic and read
//!   back every event that lies wholly before the damage.
//! - Spinning lidars: `hostile_lidars.rs`.
//!
//! The seeds are fixed (`RngSeed::Fixed`) so the run is reproducible: a false `02 80` passes
//! the SICK CRC-16 by chance about once in 65 536 candidates, and a fixed seed keeps that
//! from making CI flaky. Debug build (`cargo xtask test`), 2-core machine: about 10 s with
//! the default test threads (the lidars' part, in its own file, 2 s); the case counts below
//! set it.

use crate::common;

use common::{chunks, seeded, Piece, Units};
use proptest::prelude::*;
use terrain_pyramid::design::cells_to_hold;
use terrain_pyramid::wire::link::{
    encode, Decoded, FrameAccumulator, Message, PanAngle, PoseReport, SnapshotScope, Stats,
    MAX_ENCODED_FRAME, MAX_FRAME, STATS_COUNTERS,
};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{emit_header, Event, MountKind, Payload, Reader};
use terrain_pyramid::wire::sick::{
    emit_telegram, SickAccumulator, SickFeed, SickItem, Telegram, ADDRESS_REPLY, DEFAULT_CAPACITY,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Clamp, Config, Design, GateShape, InverseSensorModel, Pyramid, Schedule, SensorModel,
};

// ------------------------------------------------------------------------------------- SICK

/// One piece of a SICK stream: `Intact` holds a valid reply telegram's payload, as do
/// `Flipped` and `Truncated` (a telegram cut with at least 1 byte gone); `Garbage` holds no
/// STX, ACK or NAK.
type SickPiece = Piece<SickOwn>;

/// The SICK stream's own pieces.
#[derive(Debug, Clone)]
enum SickOwn {
    /// A lone ACK.
    Ack,
    /// A lone NAK.
    Nak,
    /// `02 80` and a LEN, with nothing of a telegram after it.
    FalseHeader(u16),
}

fn sick_payload() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        // A measured-values reply of up to 401 values.
        (0_u16..=401, any::<u8>(), any::<u8>()).prop_flat_map(|(n, hi, status)| {
            proptest::collection::vec(any::<u8>(), 2 * usize::from(n)).prop_map(move |values| {
                let mut p = vec![0xB0];
                p.extend_from_slice(&(n | u16::from(hi & 0xC0) << 8).to_le_bytes());
                p.extend_from_slice(&values);
                p.push(status);
                p
            })
        }),
        Just(vec![0xA0, 0x00, 0x10]),
        Just(vec![0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10]),
        proptest::collection::vec(any::<u8>(), 1..64),
    ]
}

fn telegram(payload: &[u8]) -> Vec<u8> {
    let mut buf = vec![0_u8; DEFAULT_CAPACITY];
    let n = emit_telegram(ADDRESS_REPLY, payload, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

fn sick_piece() -> impl Strategy<Value = SickPiece> {
    prop_oneof![
        4 => sick_payload().prop_map(SickPiece::Intact),
        2 => proptest::collection::vec(any::<u8>(), 1..40).prop_map(|mut g| {
            for b in &mut g {
                if matches!(*b, 0x02 | 0x06 | 0x15) {
                    *b = 0xEE;
                }
            }
            SickPiece::Garbage(g)
        }),
        1 => (sick_payload(), any::<usize>()).prop_map(|(p, bit)| SickPiece::Flipped(p, bit)),
        1 => (sick_payload(), any::<usize>()).prop_map(|(p, at)| SickPiece::Truncated(p, at)),
        1 => Just(SickPiece::Own(SickOwn::Ack)),
        1 => Just(SickPiece::Own(SickOwn::Nak)),
        1 => any::<u16>().prop_map(|len| SickPiece::Own(SickOwn::FalseHeader(len))),
    ]
}

proptest! {
    #![proptest_config(seeded(3000, 0x5eed_0001))]

    #[test]
    fn sick_stream_delivers_exactly_the_intact_telegrams(
        pieces in proptest::collection::vec(sick_piece(), 1..24),
        sizes in proptest::collection::vec(1_usize..300, 1..6),
    ) {
        let mut stream = Vec::new();
        let mut intact = Vec::new();
        let (mut acks, mut naks, mut damaged) = (0_u32, 0_u32, 0_usize);
        for piece in &pieces {
            match piece {
                SickPiece::Intact(p) => {
                    let t = telegram(p);
                    intact.push((stream.len() as u64, t.clone()));
                    stream.extend_from_slice(&t);
                }
                SickPiece::Garbage(g) => stream.extend_from_slice(g),
                SickPiece::Flipped(p, bit) => {
                    let mut t = telegram(p);
                    let bit = bit % (8 * t.len());
                    t[bit / 8] ^= 1 << (bit % 8);
                    stream.extend_from_slice(&t);
                    damaged += 1;
                }
                SickPiece::Truncated(p, at) => {
                    let t = telegram(p);
                    stream.extend_from_slice(&t[..at % t.len()]);
                    damaged += 1;
                }
                SickPiece::Own(SickOwn::Ack) => {
                    stream.push(0x06);
                    acks += 1;
                }
                SickPiece::Own(SickOwn::Nak) => {
                    stream.push(0x15);
                    naks += 1;
                }
                SickPiece::Own(SickOwn::FalseHeader(len)) => {
                    stream.extend_from_slice(&[0x02, 0x80]);
                    stream.extend_from_slice(&len.to_le_bytes());
                    damaged += 1;
                }
            }
        }

        let mut acc: Box<SickAccumulator> = Box::default();
        let mut delivered = Vec::new();
        let (mut ack_events, mut nak_events, mut rejected) = (0_u32, 0_u32, 0_u32);
        let mut handle = |r: &SickFeed<'_, '_>,
                          delivered: &mut Units|
         -> Result<bool, TestCaseError> {
            match r {
                FeedResult::Consumed => return Ok(false),
                FeedResult::Item {
 item: SickItem::Telegram(telegram),
 offset, .. } => {
                    prop_assert!(Telegram::new_checked(telegram.as_bytes()).is_ok());
                    delivered.push((*offset, telegram.as_bytes().to_vec()));
                }
                FeedResult::Item {
 item: SickItem::Ack,
 .. } => ack_events += 1,
                FeedResult::Item {
 item: SickItem::Nak,
 .. } => nak_events += 1,
                FeedResult::Rejected { .. } => rejected += 1,
            }
            Ok(true)
        };
        for chunk in chunks(&stream, &sizes) {
            let mut window = chunk;
            loop {
                let r = acc.feed(window);
                window = r.remaining();
                if !handle(&r, &mut delivered)? {
                    break;
                }
            }
        }
        loop {
            let r = acc.flush();
            if !handle(&r, &mut delivered)? {
                break;
            }
        }

        // Exactly the intact telegrams, once each, in order, at their offsets.
        prop_assert_eq!(&delivered, &intact);
        let stats = acc.stats();
        prop_assert_eq!(stats.telegrams_ok as usize, intact.len());
        prop_assert_eq!((stats.ack, stats.nak), (ack_events, nak_events));
        prop_assert_eq!(
            stats.crc_errors + stats.length_errors + stats.truncated,
            rejected
        );
        // At most every 0x06/0x15 outside the intact telegrams is reported (those in a
        // damaged telegram may be, once its header is gone).
        let outside = |byte: u8| {
            let all = stream.iter().filter(|&&b| b == byte).count();
            let inside: usize = intact
                .iter()
                .map(|(_, t)| t.iter().filter(|&&b| b == byte).count())
                .sum();
            u32::try_from(all - inside).unwrap()
        };
        prop_assert!(ack_events <= outside(0x06));
        prop_assert!(nak_events <= outside(0x15));
        if damaged == 0 {
            prop_assert_eq!((ack_events, nak_events, rejected), (acks, naks, 0));
            let telegram_bytes: usize = intact.iter().map(|(_, t)| t.len()).sum();
            prop_assert_eq!(
                stats.garbage_bytes as usize + telegram_bytes + (acks + naks) as usize,
                stream.len()
            );
        }
        prop_assert_eq!(acc.position(), stream.len() as u64);
        prop_assert_eq!(acc.buffered(), 0);
    }
}

// ------------------------------------------------------------------------------------- link

/// One piece of a link stream: `Intact` holds a valid frame; `Garbage` bytes ending with a
/// delimiter; `Flipped` a frame with one bit of a non-delimiter byte flipped; `Truncated` a
/// frame cut short, its delimiter gone (it runs into the next piece); `Own` a spare delimiter.
type LinkPiece = Piece<Delimiter>;

/// A spare delimiter in a link stream.
#[derive(Debug, Clone)]
struct Delimiter;

fn link_message() -> impl Strategy<Value = Message<'static>> {
    prop_oneof![
        Just(Message::Ping),
        Just(Message::Reset),
        Just(Message::RequestSnapshot(SnapshotScope::All)),
        (0_u8..255).prop_map(|k| Message::RequestSnapshot(SnapshotScope::Layer(k))),
        (
            -1000.0_f32..1000.0,
            -1000.0_f32..1000.0,
            -3.0_f32..3.0,
            any::<u32>()
        )
            .prop_map(|(x, y, yaw, t)| Message::Pose(PoseReport {
                x_m: x,
                y_m: y,
                z_m: 0.0,
                roll_rad: 0.0,
                pitch_rad: 0.0,
                yaw_rad: yaw,
                stamp_us: t,
                flags: 0,
            })),
        (any::<u16>(), any::<u32>()).prop_map(|(turns, t)| Message::PanAngle(PanAngle {
            turns,
            timestamp_ms: t
        })),
        proptest::collection::vec(any::<u32>(), STATS_COUNTERS).prop_map(|v| {
            let mut a = [0_u32; STATS_COUNTERS];
            a.copy_from_slice(&v);
            Message::Stats(Stats::from_array(a))
        }),
    ]
}

fn link_frame(seq: u16, message: &Message<'_>) -> Vec<u8> {
    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
    let n = encode(seq, message, &mut out).unwrap();
    out.truncate(n);
    out
}

fn link_piece() -> impl Strategy<Value = LinkPiece> {
    let frame = || (any::<u16>(), link_message()).prop_map(|(seq, m)| link_frame(seq, &m));
    prop_oneof![
        4 => frame().prop_map(LinkPiece::Intact),
        1 => proptest::collection::vec(any::<u8>(), 1..700).prop_map(|mut g| {
            g.push(0);
            LinkPiece::Garbage(g)
        }),
        1 => (frame(), any::<usize>()).prop_map(|(f, bit)| LinkPiece::Flipped(f, bit)),
        1 => (frame(), any::<usize>()).prop_map(|(f, at)| LinkPiece::Truncated(f, at)),
        1 => Just(LinkPiece::Own(Delimiter)),
    ]
}

proptest! {
    #![proptest_config(seeded(3000, 0x5eed_0002))]

    #[test]
    fn link_stream_decodes_exactly_the_intact_frames(
        pieces in proptest::collection::vec(link_piece(), 1..24),
        sizes in proptest::collection::vec(1_usize..200, 1..6),
    ) {
        let mut stream: Vec<u8> = Vec::new();
        let mut intact = Vec::new();
        for piece in &pieces {
            // A frame is whole only if a delimiter (or the start) comes right before it.
            let clean_start = stream.last().is_none_or(|&b| b == 0);
            match piece {
                LinkPiece::Intact(f) => {
                    if clean_start {
                        intact.push(f.clone());
                    }
                    stream.extend_from_slice(f);
                }
                LinkPiece::Garbage(g) => stream.extend_from_slice(g),
                LinkPiece::Flipped(f, bit) => {
                    let mut f = f.clone();
                    let bit = bit % (8 * (f.len() - 1));
                    f[bit / 8] ^= 1 << (bit % 8);
                    stream.extend_from_slice(&f);
                }
                LinkPiece::Truncated(f, at) => stream.extend_from_slice(&f[..at % (f.len() - 1)]),
                LinkPiece::Own(Delimiter) => stream.push(0),
            }
        }
        // Every non-empty run between delimiters ends as one event, if its delimiter came.
        let complete = stream.split(|&b| b == 0).count() - 1;
        let segments = stream
            .split(|&b| b == 0)
            .take(complete)
            .filter(|s| !s.is_empty())
            .count();

        let mut acc = Box::new(FrameAccumulator::<MAX_FRAME>::new());
        let mut decoded = Vec::new();
        let mut errors = 0_usize;
        for chunk in chunks(&stream, &sizes) {
            let mut window = chunk;
            loop {
                match acc.feed(window) {
                    FeedResult::Consumed => break,
                    FeedResult::Item { item: Decoded { header, message }, remaining, .. } => {
                        decoded.push(link_frame(header.seq, &message));
                        window = remaining;
                    }
                    FeedResult::Rejected { remaining, .. } => {
                        errors += 1;
                        window = remaining;
                    }
                }
            }
        }
        prop_assert_eq!(&decoded, &intact);
        prop_assert_eq!(decoded.len() + errors, segments);
        let counters = acc.counters();
        prop_assert_eq!(counters.frames_ok as usize, intact.len());
        prop_assert_eq!(counters.errors() as usize, errors);
    }
}

// ---------------------------------------------------------------------------- configuration

/// A field: mostly a plausible value, sometimes any bit pattern (NaN, ∞, subnormal, huge).
fn field(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => lo..hi,
        1 => any::<u32>().prop_map(f32::from_bits),
        1 => prop_oneof![
            Just(0.0_f32),
            Just(-0.0),
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::MIN_POSITIVE),
            Just(f32::MAX),
            Just(hi),
            Just(lo)
        ],
    ]
}

#[derive(Debug, Clone)]
struct RandomConfig {
    sensor: SensorModel,
    schedule: Schedule,
    cells: usize,
    model: InverseSensorModel,
    clamp: (f32, f32),
    margin: f32,
}

fn random_config() -> impl Strategy<Value = RandomConfig> {
    let sensor = (
        field(0.001, 0.05),
        field(0.005, 0.2),
        field(0.0, 0.5),
        field(0.1, 3.0),
        field(0.5, 82.0),
    )
        .prop_map(|(phi, psi, sigma, h, r)| SensorModel {
            phi_rad: phi,
            psi_rad: psi,
            sigma_m: sigma,
            height_m: h,
            max_range_m: r,
        });
    let schedule = (
        field(0.005, 1.0),
        field(0.9, 5.0),
        field(0.0, 4.5),
        any::<(bool, bool)>(),
    )
        .prop_map(|(base, gamma, width, (hard, uniform))| Schedule {
            base_m: base,
            gamma,
            gate: if hard {
                GateShape::Hard
            } else {
                GateShape::Soft {
                    width_factor: width,
                }
            },
            uniform_resolution: uniform,
        });
    let cells = prop_oneof![Just(64_usize), 0_usize..1100];
    let model = (field(0.0, 1.0), field(0.0, 1.0), field(0.0, 1.0)).prop_map(|(o, f, p)| {
        InverseSensorModel {
            p_obstacle: o,
            p_free: f,
            prior: p,
        }
    });
    (
        sensor,
        schedule,
        cells,
        model,
        (field(-130.0, 1.0), field(-1.0, 130.0)),
        field(-1.0, 10.0),
    )
        .prop_map(
            |(sensor, schedule, cells, model, clamp, margin)| RandomConfig {
                sensor,
                schedule,
                cells,
                model,
                clamp,
                margin,
            },
        )
}

proptest! {
    #![proptest_config(seeded(20_000, 0x5eed_0003))]

    #[test]
    fn random_configurations_are_refused_or_keep_the_invariants(c in random_config()) {
        let design = Design::<8>::new(c.sensor, c.schedule, c.cells);
        if let Ok(design) = &design {
            let layers = design.layers();
            prop_assert!(!layers.is_empty() && layers.len() <= 8);
            prop_assert_eq!(layers[0].band_inner_m, 0.0);
            for pair in layers.windows(2) {
                prop_assert_eq!(pair[0].band_outer_m, pair[1].band_inner_m);
            }
            for layer in layers {
                // Strictly increasing: an empty band is refused.
                prop_assert!(layer.band_outer_m > layer.band_inner_m, "{:?}", layer);
                prop_assert!(layer.resolution_m.is_finite() && layer.resolution_m > 0.0);
                prop_assert!(layer.gate_sigma_m.is_finite() && layer.gate_sigma_m >= 0.0);
                prop_assert!(cells_to_hold(layer.band_outer_m, layer.resolution_m) <= c.cells);
            }
            prop_assert_eq!(
                layers.last().map(|l| l.band_outer_m),
                Some(c.sensor.max_range_m)
            );
        }
        let _ = c.model.increments();
        let clamp = Clamp::bounds(c.clamp.0, c.clamp.1);
        if let (Ok(design), Ok(clamp)) = (design, clamp) {
            let mut pyramid = Box::new(Pyramid::<64, 8>::new());
            let config = Config { model: c.model, clamp, fused_margin: c.margin, decay: terrain_pyramid::Decay::OFF };
            match pyramid.configure(&design, &config) {
                Ok(()) => prop_assert_eq!(pyramid.layer_count(), design.layers().len()),
                Err(_) => prop_assert_eq!(pyramid.layer_count(), 0),
            }
        }
    }
}

// ------------------------------------------------------------------------------- recordings

fn recording_event() -> impl Strategy<Value = (u64, u8, Vec<u8>)> {
    // (time step, kind, payload bytes for laser/unknown).
    (
        0_u64..1000,
        prop_oneof![Just(1_u8), Just(2), Just(3), Just(4), Just(5), Just(0x40)],
        proptest::collection::vec(any::<u8>(), 1..300),
    )
}

fn emit_event(time_us: u64, kind: u8, bytes: &[u8]) -> Vec<u8> {
    let setup = Setup {
        mount: MountKind::PannedVertical,
        measuring_mode: 0,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.1, 0.0, 1.0],
        lines_per_observation: 0,
    };
    let payload = match kind {
        1 => Payload::Laser(bytes),
        2 => Payload::Angle(u16::from(bytes[0]) << 8),
        3 => Payload::Pose([0.5, -0.5, 0.0, 0.0, 0.0, f32::from(bytes[0]) / 100.0]),
        4 => Payload::Setup(setup),
        5 => Payload::Marker(u32::from(bytes[0])),
        kind => Payload::Unknown { kind, data: bytes },
    };
    let event = Event { time_us, payload };
    let mut out = vec![0_u8; event.buffer_len()];
    event.emit(&mut out).unwrap();
    out
}

proptest! {
    #![proptest_config(seeded(4000, 0x5eed_0004))]

    #[test]
    fn random_recordings_read_back_up_to_the_damage(
        events in proptest::collection::vec(recording_event(), 0..20),
        damage in prop_oneof![
            Just(None),
            (any::<usize>(), any::<u8>()).prop_map(|(at, x)| Some((at, x | 1, false))),
            any::<usize>().prop_map(|at| Some((at, 0, true))),
        ],
    ) {
        let mut file = vec![0_u8; 16];
        emit_header(&mut file).unwrap();
        let mut ends = Vec::new();
        let mut time = 0;
        for (step, kind, bytes) in &events {
            time += step;
            file.extend_from_slice(&emit_event(time, *kind, bytes));
            ends.push(file.len());
        }
        let clean = file.clone();
        // Damage: XOR a byte (never 0) or truncate, somewhere after the header.
        let mut damaged_at = usize::MAX;
        if let Some((at, x, truncate)) = damage {
            if file.len() > 16 {
                let at = 16 + at % (file.len() - 16);
                if truncate {
                    file.truncate(at);
                } else {
                    file[at] ^= x;
                }
                damaged_at = at;
            }
        }
        let read: Vec<_> = match Reader::new(&file) {
            Ok(r) => r.collect(),
            Err(e) => return Err(TestCaseError::fail(format!("header refused: {e}"))),
        };
        let expected: Vec<_> = Reader::new(&clean).unwrap().collect();
        prop_assert!(expected.iter().all(Result::is_ok));
        prop_assert_eq!(expected.len(), events.len());
        // Every event wholly before the damage reads back the same.
        let whole = ends.iter().take_while(|&&end| end <= damaged_at).count();
        prop_assert!(read.len() >= whole);
        prop_assert_eq!(&read[..whole], &expected[..whole]);
        // Nothing after the first error.
        if let Some(i) = read.iter().position(Result::is_err) {
            prop_assert_eq!(i + 1, read.len());
        }
    }
}
