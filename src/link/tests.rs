//! The device's side against the wire decoder: what goes out, when, and in what order.
extern crate std;
use super::*;
use crate::pyramid::{Evidence, EvidenceClass};
use crate::units::Meters;
use crate::wire::link::{ClampRequest, MessageType, MAX_FRAME};
use crate::{DefaultDesign, DefaultPyramid, Param, Schedule, SensorModel};
use std::vec::Vec;

/// What came out of the queue, owned.
#[derive(Debug, Clone, PartialEq)]
enum Out {
    Hello(std::boxed::Box<Hello>),
    Patch(PatchArea, Vec<i16>),
    Moved(WindowMoved),
    Stats(Stats),
    Reply(Reply),
}

fn drain<const Q: usize>(link: &mut Link<Q>) -> Vec<(u16, Out)> {
    let mut bytes = Vec::new();
    let mut buf = [0_u8; 100];
    loop {
        let n = link.pop_bytes(&mut buf);
        if n == 0 {
            break;
        }
        bytes.extend_from_slice(&buf[..n]);
    }
    decode_all(&bytes)
}

fn decode_all(mut input: &[u8]) -> Vec<(u16, Out)> {
    let mut acc = Accumulator::<MAX_FRAME>::new();
    let mut out = Vec::new();
    loop {
        match acc.feed(input) {
            FeedResult::Consumed => return out,
            FeedResult::Frame {
                header,
                message,
                remaining,
            } => {
                input = remaining;
                let item = match message {
                    Message::Hello(h) => Out::Hello(std::boxed::Box::new(h)),
                    Message::LayerPatch(p) => Out::Patch(p.area, p.cells.iter().collect()),
                    Message::WindowMoved(m) => Out::Moved(m),
                    Message::Stats(s) => Out::Stats(s),
                    Message::Reply(r) => Out::Reply(r),
                    other => panic!("device sent {other:?}"),
                };
                out.push((header.seq, item));
            }
            FeedResult::Error { error, .. } => panic!("{error}"),
        }
    }
}

fn configured() -> (DefaultPyramid, Link) {
    let mut pyramid = DefaultPyramid::new();
    let mut link = Link::new(LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    let design = DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap();
    link.configure(&mut pyramid, &design, &Config::default())
        .unwrap();
    (pyramid, link)
}

/// An obstacle seen by `layer` at 0.2 m, weighted by the default design's gate.
fn obstacle(layer: u8, x: i32, y: i32) -> Evidence {
    let design = DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap();
    let mut gates = crate::gate::Gates::<8>::new();
    gates
        .configure(&design, Config::default().model.increments().unwrap())
        .unwrap();
    Evidence {
        layer,
        cell_x: x,
        cell_y: y,
        class: EvidenceClass::Obstacle,
        weight: gates.weight_at(usize::from(layer), Meters::from_num(0.2)),
    }
}

fn command(seq: u16, message: &Message<'_>) -> Vec<u8> {
    let mut out = [0_u8; 128];
    let n = encode(seq, message, &mut out).unwrap();
    out[..n].to_vec()
}

#[test]
fn first_poll_says_hello_then_patches_follow_changes() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    let out = drain(&mut link);
    assert_eq!(out.len(), 1);
    let Out::Hello(hello) = &out[0].1 else {
        panic!("{out:?}")
    };
    // Hello(boot) is pending at construction and stays a boot through `configure`.
    assert_eq!(hello.reason, HelloReason::Boot);
    assert_eq!(hello.layers.len(), pyramid.layer_count());
    assert_eq!(hello.cells_per_side, 64);
    assert_eq!(hello.layers[0].resolution_q16, 6554);
    assert_eq!(
        (hello.layers[0].origin_x, hello.layers[0].origin_y),
        (-32, -32)
    );
    assert!(hello.layers[0].band_outer_m > 0.5);

    assert_eq!(pyramid.apply(&obstacle(0, 3, -4)), crate::Applied::Updated);
    let report = link.poll(13, &mut pyramid, &SensorCounters::default());
    assert_eq!(report.patches, 1);
    let out = drain(&mut link);
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].0, 1, "sequence numbers count frames");
    let Out::Patch(area, cells) = &out[0].1 else {
        panic!("{out:?}")
    };
    assert_eq!((area.width, area.height, area.layer), (8, 8, 0));
    let (cx, cy) = (3 - area.x, -4 - area.y);
    assert!((0..8).contains(&cx) && (0..8).contains(&cy));
    for (i, &v) in cells.iter().enumerate() {
        let (c, r) = (i as i32 % 8, i as i32 / 8);
        let want = pyramid
            .layer(0)
            .unwrap()
            .get(area.x + c, area.y + r)
            .unwrap();
        assert_eq!(v, want.to_raw());
    }
    let raw = pyramid.layer(0).unwrap().get(3, -4).unwrap().to_raw();
    assert!(raw > 0);
    assert_eq!(cells[(cy * 8 + cx) as usize], raw);
    // Nothing changed: nothing goes out.
    link.poll(26, &mut pyramid, &SensorCounters::default());
    assert!(drain(&mut link).is_empty());
}

#[test]
fn window_moves_go_out_before_patches_at_the_new_origin() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    pyramid.recentre(Meters::from_num(0.25), Meters::ZERO);
    pyramid.apply(&obstacle(0, 5, 0));
    link.poll(10, &mut pyramid, &SensorCounters::default());
    let out = drain(&mut link);
    let Out::Moved(moved) = &out[0].1 else {
        panic!("{out:?}")
    };
    assert_eq!(moved.origin(0), Some((-30, -32)));
    assert_eq!(moved.origin(1), Some((-31, -32)));
    assert_eq!(moved.origin(2), None, "0.25 m is still cell 0 of 0.4 m");
    assert!(matches!(out[1].1, Out::Patch(a, _) if a.origin_x == -30));
    assert_eq!(link.counters().resyncs, 0);
}

#[test]
fn moves_that_collapse_between_polls_force_a_full_resend() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    // Out and back between two polls: no net move, but a column was reset.
    pyramid.recentre(Meters::from_num(0.15), Meters::ZERO);
    pyramid.recentre(Meters::from_num(0.05), Meters::ZERO);
    link.poll(10, &mut pyramid, &SensorCounters::default());
    assert_eq!(link.counters().resyncs, 1);
    assert!(pyramid.layer(0).unwrap().dirty() != 0 || !link.queue().is_empty());
    // A move the link sees one by one is no resync.
    pyramid.recentre(Meters::from_num(0.35), Meters::ZERO);
    link.poll(20, &mut pyramid, &SensorCounters::default());
    assert_eq!(link.counters().resyncs, 1);
}

#[test]
fn the_budget_holds_and_deferred_tiles_go_later() {
    let (mut pyramid, _) = configured();
    let mut link: Link = Link::new(LinkConfig {
        budget_bytes_per_s: 2000,
        burst_bytes: 400,
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    link.adopt(&DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap());
    // Touch every tile of layer 0.
    for i in -32..32 {
        for j in (-32..32).step_by(8) {
            pyramid.apply(&obstacle(0, i, j));
        }
    }
    let mut sent = 0_usize;
    let mut tiles = 0;
    let mut t = 0;
    while t <= 10_000 {
        let report = link.poll(t, &mut pyramid, &SensorCounters::default());
        drain(&mut link);
        sent += report.bytes as usize;
        tiles += report.patches;
        t += 50;
    }
    // 10 s at 2 000 B/s plus one burst.
    assert!(sent <= 2000 * 10 + 400 + 200, "{sent}");
    assert_eq!(
        tiles, 64,
        "every tile went out once, later rather than never"
    );
    assert_eq!(pyramid.layer(0).unwrap().dirty(), 0);
    // Each tile is counted once however many polls it waited (200 polls here).
    let deferred = link.counters().patches_deferred;
    assert!(deferred > 0 && deferred <= 64, "{deferred}");
}

#[test]
fn a_full_queue_puts_tiles_back_and_drops_no_patch() {
    let (mut pyramid, _) = configured();
    // Room for one 157-byte patch beside the reserve.
    let mut link: Link<512> = Link::new(LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    for i in (-32..32).step_by(8) {
        pyramid.apply(&obstacle(0, i, 0));
    }
    let first = link.poll(1, &mut pyramid, &SensorCounters::default());
    assert_eq!(first.patches, 1);
    assert_eq!(first.deferred_tiles, 7);
    assert_eq!(pyramid.layer(0).unwrap().dirty().count_ones(), 7);
    let mut all = drain(&mut link);
    for t in 2..20 {
        link.poll(t * 100, &mut pyramid, &SensorCounters::default());
        all.extend(drain(&mut link));
    }
    assert_eq!(all.len(), 8);
    let seqs: Vec<u16> = all.iter().map(|(s, _)| *s).collect();
    assert_eq!(seqs, (1..9).collect::<Vec<u16>>(), "no gap");
    assert_eq!(link.counters().frames_dropped, 0);
    // The 7 tiles put back waited over several polls: each counted once.
    assert_eq!(link.counters().patches_deferred, 7);
}

#[test]
fn a_tile_that_keeps_changing_while_it_waits_is_deferred_once_per_dirty_period() {
    let (mut pyramid, _) = configured();
    let mut link: Link<512> = Link::new(LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    // Two tiles; the queue takes one per poll while nothing drains it.
    pyramid.apply(&obstacle(0, -32, 0));
    pyramid.apply(&obstacle(0, 0, 0));
    for t in 1..100 {
        // The waiting tile keeps changing.
        pyramid.apply(&obstacle(0, 0, 0));
        pyramid.apply(&obstacle(0, -32, 0));
        link.poll(t, &mut pyramid, &SensorCounters::default());
    }
    // Polled 99 times with a full queue: the counter measures tiles, not polls.
    let deferred = link.counters().patches_deferred;
    assert!((1..=2).contains(&deferred), "{deferred}");
    drain(&mut link);
}

#[test]
fn a_reply_that_finds_no_room_is_dropped_and_leaves_a_gap() {
    let (mut pyramid, _) = configured();
    let mut link: Link<512> = Link::new(LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    // Fill the queue with pings' replies (27 bytes each) without draining it.
    let mut bytes = Vec::new();
    for seq in 0..30 {
        bytes.extend(command(seq, &Message::Ping));
    }
    let mut pings = 0;
    link.receive(&bytes, &mut pyramid, |e| {
        pings += u32::from(e == Event::Ping)
    });
    assert_eq!(pings, 30);
    let dropped = link.counters().frames_dropped;
    assert!(dropped > 0);
    assert_eq!(
        link.next_seq(),
        1 + 30,
        "dropped replies used their numbers"
    );
    let out = drain(&mut link);
    assert_eq!(out.len() as u32 + dropped, 30);
}

#[test]
fn configure_is_validated_by_the_librarys_rules() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    pyramid.apply(&obstacle(0, 0, 0));
    let before = pyramid.layer(0).unwrap().get(0, 0).unwrap().to_raw();
    // γ = 1: Design::new refuses it by name.
    let mut bad = Configure::default();
    bad.schedule.gamma = 1.0;
    let mut events = Vec::new();
    link.receive(&command(5, &Message::Configure(bad)), &mut pyramid, |e| {
        events.push(e)
    });
    let out = drain(&mut link);
    let Out::Reply(reply) = out[0].1 else {
        panic!("{out:?}")
    };
    assert_eq!(reply.to_seq, 5);
    assert_eq!(reply.to_type, MessageType::Configure.to_u8());
    assert_eq!(reply.code, ReplyCode::GammaNotAboveOne);
    assert_eq!(reply.design_param(), Some(Param::Gamma));
    assert!(matches!(events[..], [Event::Refused(_)]));
    assert_eq!(
        pyramid.layer(0).unwrap().get(0, 0).unwrap().to_raw(),
        before,
        "nothing changed"
    );
    // The clamp's bounds, by Clamp::bounds.
    let bad = Configure {
        clamp: ClampRequest::Bounds { min: 1.0, max: 3.5 },
        ..Configure::default()
    };
    link.receive(&command(6, &Message::Configure(bad)), &mut pyramid, |_| {});
    let Out::Reply(reply) = drain(&mut link)[0].1 else {
        panic!()
    };
    assert_eq!(
        (reply.code, reply.design_param()),
        (ReplyCode::OutOfRange, Some(Param::ClampMin))
    );
    // The probabilities' order, by InverseSensorModel::increments.
    let mut bad = Configure::default();
    bad.model.p_free = 0.6;
    link.receive(&command(7, &Message::Configure(bad)), &mut pyramid, |_| {});
    let Out::Reply(reply) = drain(&mut link)[0].1 else {
        panic!()
    };
    assert_eq!(reply.design_param(), Some(Param::PFree));
    // A window the pyramid was not compiled for.
    let bad = Configure {
        cells_per_side: 128,
        ..Configure::default()
    };
    link.receive(&command(8, &Message::Configure(bad)), &mut pyramid, |_| {});
    let Out::Reply(reply) = drain(&mut link)[0].1 else {
        panic!()
    };
    assert_eq!(reply.design_param(), Some(Param::Cells));
    // A good one: Reply Ok, then Hello(configured), maps cleared.
    let mut good = Configure::default();
    good.schedule.gate = crate::GateShape::Hard;
    let mut events = Vec::new();
    link.receive(&command(9, &Message::Configure(good)), &mut pyramid, |e| {
        events.push(e)
    });
    assert_eq!(events, [Event::Configured]);
    let out = drain(&mut link);
    assert!(matches!(out[0].1, Out::Reply(r) if r.is_ok() && r.to_seq == 9));
    assert!(matches!(&out[1].1, Out::Hello(h) if h.reason == HelloReason::Configured));
    assert!(!pyramid.layer(0).unwrap().get(0, 0).unwrap().is_observed());
    assert_eq!(link.counters().commands_refused, 4);
}

#[test]
fn poses_are_validated_and_handed_over() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    let good = Pose {
        x_m: 12.5,
        y_m: -3.0,
        z_m: 0.2,
        yaw_rad: 1.0,
        timestamp_ms: 77,
        ..Pose::default()
    };
    let bad = Pose {
        x_m: f32::INFINITY,
        ..good
    };
    let mut bytes = command(0, &Message::Pose(good));
    bytes.extend(command(1, &Message::Pose(bad)));
    bytes.extend(command(
        2,
        &Message::PanAngle(PanAngle {
            turns: 0x8000,
            timestamp_ms: 78,
        }),
    ));
    let mut events = Vec::new();
    link.receive(&bytes, &mut pyramid, |e| events.push(e));
    assert_eq!(events[0], Event::Pose(good));
    assert!(
        matches!(events[1], Event::Refused(r) if r.param == 32 && r.code == ReplyCode::NotFinite)
    );
    assert!(matches!(events[2], Event::PanAngle(p) if p.angle().to_bits() == 0x8000));
    let out = drain(&mut link);
    assert_eq!(out.len(), 1, "only the refusal is answered");
}

#[test]
fn snapshot_reset_ping_and_bad_frames() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    pyramid.apply(&obstacle(0, 0, 0));
    link.poll(1, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    // Snapshot of layer 2: Reply, Hello(snapshot, resend bit 2), then its 64 tiles.
    link.receive(
        &command(0, &Message::RequestSnapshot(SnapshotScope::Layer(2))),
        &mut pyramid,
        |_| {},
    );
    let mut out = drain(&mut link);
    for t in 0..40 {
        link.poll(100 + t * 100, &mut pyramid, &SensorCounters::default());
        out.extend(drain(&mut link));
    }
    assert!(matches!(out[0].1, Out::Reply(r) if r.is_ok()));
    assert!(
        matches!(&out[1].1, Out::Hello(h) if h.reason == HelloReason::Snapshot && h.resend == 4)
    );
    let patches = out
        .iter()
        .filter(|(_, o)| matches!(o, Out::Patch(a, _) if a.layer == 2))
        .count();
    assert_eq!(patches, 64);
    // A layer the pyramid does not have.
    link.receive(
        &command(1, &Message::RequestSnapshot(SnapshotScope::Layer(9))),
        &mut pyramid,
        |_| {},
    );
    let Out::Reply(r) = drain(&mut link)[0].1 else {
        panic!()
    };
    assert_eq!((r.code, r.param, r.value), (ReplyCode::BadLayer, 40, 9.0));
    // Reset: Reply, Hello(reset), maps cleared.
    link.receive(&command(2, &Message::Reset), &mut pyramid, |_| {});
    let out = drain(&mut link);
    assert!(matches!(&out[1].1, Out::Hello(h) if h.reason == HelloReason::Reset));
    assert_eq!(pyramid.counts(0).unwrap().observed, 0);
    // A corrupted frame: no answer, counted; a gap in the host's numbers is counted.
    let mut bytes = command(3, &Message::Ping);
    bytes[3] ^= 1;
    bytes.extend(command(5, &Message::Ping));
    // A device-bound type from the host: Unsupported.
    bytes.extend(command(
        6,
        &Message::Reply(Reply::ok(Header {
            version: 1,
            msg_type: 0x86,
            seq: 0,
        })),
    ));
    let mut events = Vec::new();
    link.receive(&bytes, &mut pyramid, |e| events.push(e));
    assert!(matches!(
        events[0],
        Event::BadFrame(DecodeError::Crc { .. })
    ));
    assert_eq!(events[1], Event::Ping);
    let out = drain(&mut link);
    assert!(matches!(out[0].1, Out::Reply(r) if r.is_ok() && r.to_seq == 5));
    assert!(matches!(out[1].1, Out::Reply(r) if r.code == ReplyCode::Unsupported));
    assert_eq!(link.rx_counters().crc, 1);
    assert_eq!(link.counters().rx_seq_gaps, 2, "3 and 4 missing");
}

#[test]
fn queue_minimum() {
    assert_eq!(max_tile_bytes(64), 248);
    assert_eq!(min_queue_bytes(64, 8), 504);
    assert_eq!(
        min_queue_bytes(64, 32),
        MAX_ENCODED_FRAME,
        "a 32-layer Hello"
    );
    assert!(min_queue_bytes(1024, 8) > MAX_ENCODED_FRAME);
}

#[test]
fn stats_go_out_on_their_interval() {
    let (mut pyramid, _) = configured();
    let mut link: Link = Link::new(LinkConfig::DEFAULT);
    let sensor = SensorCounters {
        telegrams_ok: 7,
        points: 1234,
        ..SensorCounters::default()
    };
    let mut stats = Vec::new();
    for t in (0..=3000).step_by(100) {
        link.poll(t, &mut pyramid, &sensor);
        for (_, o) in drain(&mut link) {
            if let Out::Stats(s) = o {
                stats.push(s);
            }
        }
    }
    assert_eq!(stats.len(), 4);
    assert_eq!(stats[1].uptime_ms, 1000);
    assert_eq!((stats[1].telegrams_ok, stats[1].points), (7, 1234));
    assert_eq!(stats[1].queue_capacity, 4096);
    assert!(stats[1].frames_sent >= 2);
}

#[test]
fn the_default_link_fits_its_budget() {
    // Queue 4 096, encode scratch 664, receive buffer 69, tile ages 512 (8 layers of 64
    // tiles), the rest small.
    let bytes = core::mem::size_of::<Link>();
    assert!(bytes < 6400, "{bytes}");
    // The per-layer state grows with the layers it is sized for.
    let per_layer = (core::mem::size_of::<Link<4096, 32>>() - bytes) / 24;
    assert!((64..128).contains(&per_layer), "{per_layer}");
}

#[test]
fn setup_request_stats_end_observation_and_shutdown() {
    use crate::wire::link::Setup;
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
    let setup = Setup {
        mount: 0,
        measuring_mode: 3,
        field_deg: 100,
        resolution_cdeg: 25,
        sensor_m: [0.1, 0.0, 0.6],
        lines_per_observation: 20,
        robot_height_m: 0.4,
        step_threshold_m: 0.05,
        drop_threshold_m: 0.3,
        ceiling_m: 0.0,
    };
    let mut bytes = command(0, &Message::Setup(setup));
    bytes.extend(command(
        1,
        &Message::Setup(Setup {
            measuring_mode: 9,
            ..setup
        }),
    ));
    bytes.extend(command(2, &Message::EndObservation));
    bytes.extend(command(3, &Message::RequestStats));
    bytes.extend(command(4, &Message::Shutdown));
    let mut events = Vec::new();
    link.receive(&bytes, &mut pyramid, |e| events.push(e));
    let Event::Setup(config) = events[0] else {
        panic!("{events:?}")
    };
    assert_eq!(config.lines_per_observation, 20);
    assert_eq!(
        config.classifier.drop_threshold,
        Some(Meters::saturating_from_num(0.3_f32))
    );
    assert_eq!(config.classifier.ceiling, None);
    assert!(
        matches!(events[1], Event::Refused(r) if r.param == 49 && r.code == ReplyCode::OutOfRange)
    );
    assert_eq!(events[2], Event::EndObservation);
    assert_eq!(events[3], Event::StatsRequested);
    let Event::Shutdown(header) = events[4] else {
        panic!("{events:?}")
    };
    let mut answer = Reply::ok(header);
    answer.value = 1234.0;
    link.answer(answer);
    // Stats goes out at the next poll although the interval is 0 (never).
    let sensor = SensorCounters {
        telegrams_ok: 5,
        ..SensorCounters::default()
    };
    link.poll(10, &mut pyramid, &sensor);
    let out = drain(&mut link);
    let replies: Vec<_> = out
        .iter()
        .filter_map(|(_, o)| match o {
            Out::Reply(r) => Some(*r),
            _ => None,
        })
        .collect();
    assert_eq!(replies.len(), 3, "{out:?}");
    assert!(replies[0].is_ok() && replies[0].to_type == 0x87);
    assert_eq!(replies[1].code, ReplyCode::OutOfRange);
    assert_eq!((replies[2].to_type, replies[2].value), (0x89, 1234.0));
    let stats: Vec<_> = out
        .iter()
        .filter_map(|(_, o)| match o {
            Out::Stats(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(stats.len(), 1);
    assert_eq!(stats[0].telegrams_ok, 5);
    // Only once.
    link.poll(20, &mut pyramid, &sensor);
    assert!(drain(&mut link).is_empty());
}
