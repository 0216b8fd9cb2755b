//! The device's side against the wire decoder: what goes out, when, and in what order. (What
//! the application does with the commands it receives is tested in `crate::app`.)
extern crate std;
use super::*;
use crate::geometry::Pose;
use crate::pyramid::Config;
use crate::pyramid::{Evidence, EvidenceClass};
use crate::test_rng::XorShift;
use crate::units::Meters;
use crate::wire::link::{
    encode, Decoded, FrameAccumulator, Header, Hello, HelloReason, Message, Observed, PatchArea,
    Reply, ReplyCode, Stats, TimeReply, WindowMoved, MAX_ENCODED_FRAME, VERSION,
};
use crate::wire::link::{PoseReport, TimeRequest, MAX_FRAME, POSE_STAMPED};
use crate::wire::FeedResult;
use crate::{DefaultDesign, DefaultPyramid, Schedule, SensorModel};
use std::vec::Vec;

/// What came out of the queue, owned.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Out {
    Hello(std::boxed::Box<Hello>),
    Patch(PatchArea, Vec<i16>),
    Moved(WindowMoved),
    Stats(Stats),
    Reply(Reply),
    TimeReply(TimeReply),
    Observed(Observed),
}

impl Out {
    /// The Stats, if the frame is one.
    pub(crate) fn stats(&self) -> Option<Stats> {
        match self {
            Out::Stats(s) => Some(*s),
            _ => None,
        }
    }

    /// The Reply, if the frame is one.
    pub(crate) fn reply(&self) -> Option<Reply> {
        match self {
            Out::Reply(r) => Some(*r),
            _ => None,
        }
    }

    /// The Observed report, if the frame is one.
    pub(crate) fn observed(&self) -> Option<Observed> {
        match self {
            Out::Observed(o) => Some(*o),
            _ => None,
        }
    }
}

fn drain<const Q: usize>(link: &mut Link<Q>) -> Vec<(u16, Out)> {
    decode_taken(|buf| link.pop_bytes(buf))
}

/// Every frame of a device's output, taken 100 bytes at a time through `take` (which fills
/// the buffer it is given and returns the bytes it wrote, 0 when nothing is left), decoded.
pub(crate) fn decode_taken(mut take: impl FnMut(&mut [u8]) -> usize) -> Vec<(u16, Out)> {
    let mut bytes = Vec::new();
    let mut buf = [0_u8; 100];
    loop {
        let n = take(&mut buf);
        if n == 0 {
            break;
        }
        bytes.extend_from_slice(&buf[..n]);
    }
    decode_all(&bytes)
}

/// Every frame of a device's output, owned, with its sequence number.
pub(crate) fn decode_all(mut input: &[u8]) -> Vec<(u16, Out)> {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut out = Vec::new();
    loop {
        match acc.feed(input) {
            FeedResult::Consumed => return out,
            FeedResult::Item {
                item: Decoded { header, message },
                remaining,
                ..
            } => {
                input = remaining;
                let item = match message {
                    Message::Hello(h) => Out::Hello(std::boxed::Box::new(h)),
                    Message::LayerPatch(p) => Out::Patch(p.area, p.cells.iter().collect()),
                    Message::WindowMoved(m) => Out::Moved(m),
                    Message::Stats(s) => Out::Stats(s),
                    Message::Reply(r) => Out::Reply(r),
                    Message::TimeReply(t) => Out::TimeReply(t),
                    Message::Observed(o) => Out::Observed(o),
                    other => panic!("device sent {other:?}"),
                };
                out.push((header.seq, item));
            }
            FeedResult::Rejected { error, .. } => panic!("{error:?}"),
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
    pyramid.configure(&design, &Config::default()).unwrap();
    link.adopt(&design);
    (pyramid, link)
}

/// A [`configured`] pyramid and link, its first poll's output (the Hello) taken.
fn greeted() -> (DefaultPyramid, Link) {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    drain(&mut link);
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

/// One host frame, encoded.
pub(crate) fn command(seq: u16, message: &Message<'_>) -> Vec<u8> {
    let mut out = [0_u8; crate::wire::link::MAX_ENCODED_COMMAND];
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
    let (mut pyramid, mut link) = greeted();
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
    let (mut pyramid, mut link) = greeted();
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

/// A link of 512 bytes (room for one 157-byte patch beside the reserve), stats off, polled
/// once on `pyramid` and drained: its Hello and first patches gone.
fn small_link(pyramid: &mut DefaultPyramid) -> Link<512> {
    let mut link = Link::new(LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    });
    link.poll(0, pyramid, &SensorCounters::default());
    drain(&mut link);
    link
}

#[test]
fn a_full_queue_puts_tiles_back_and_drops_no_patch() {
    let (mut pyramid, _) = configured();
    let mut link = small_link(&mut pyramid);
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
    let mut link = small_link(&mut pyramid);
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
    let mut link = small_link(&mut pyramid);
    // Fill the queue with pings' replies (27 bytes each) without draining it.
    let mut bytes = Vec::new();
    for seq in 0..30 {
        bytes.extend(command(seq, &Message::Ping));
    }
    let mut pings = 0;
    let mut input = &bytes[..];
    while let FeedResult::Item {
        item, remaining, ..
    } = link.receive(input)
    {
        assert_eq!(item.command, Command::Ping);
        link.answer(Reply::ok(item.header));
        pings += 1;
        input = remaining;
    }
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
    // Queue 4 096, encode scratch 668, receive buffer 69, tile ages 512 (8 layers of 64
    // tiles), the rest small.
    let bytes = core::mem::size_of::<Link>();
    assert!(bytes < 6400, "{bytes}");
    // The per-layer state grows with the layers it is sized for.
    let per_layer = (core::mem::size_of::<Link<4096, 32>>() - bytes) / 24;
    assert!((64..128).contains(&per_layer), "{per_layer}");
}

/// The tile scheduler as it was before it visited only the waiting tiles (every age of every
/// layer at every poll): the reference the new one must equal, order and counters included.
/// Taking the dirty tiles and putting back those left waiting are the scheduler's own.
mod reference {
    use super::super::*;
    const N: usize = crate::DEFAULT_LAYERS;
    fn waiting<'a, const Q: usize>(
        link: &'a Link<Q>,
        dirty: &'a [u64; N],
        count: usize,
    ) -> impl Iterator<Item = (usize, usize, u8)> + 'a {
        dirty
            .iter()
            .zip(link.ages.iter())
            .take(count)
            .enumerate()
            .flat_map(|(k, (bits, ages))| {
                ages.iter()
                    .enumerate()
                    .filter(move |(tile, _)| bits & (1 << tile) != 0)
                    .map(move |(tile, &age)| (k, tile, age))
            })
    }

    pub(super) fn send_patches<const Q: usize, const W: usize, const L: usize>(
        link: &mut Link<Q>,
        pyramid: &mut Pyramid<W, L>,
        report: &mut PollReport,
    ) {
        let Some((count, total, mut dirty)) = poll::take_dirty::<N, W, L>(pyramid) else {
            return;
        };
        // Each waiting tile ages by one poll; the oldest go first, round-robin within an age.
        for (bits, ages) in dirty.iter().zip(link.ages.iter_mut()).take(count) {
            for (tile, age) in ages.iter_mut().enumerate() {
                *age = if bits & (1 << tile) != 0 {
                    age.saturating_add(1)
                } else {
                    0
                };
            }
        }
        let start = link.cursor % total;
        let mut level = u8::MAX;
        'ages: loop {
            let top = waiting(link, &dirty, count)
                .map(|(_, _, age)| age)
                .filter(|&age| age <= level)
                .max()
                .unwrap_or(0);
            if top == 0 {
                break;
            }
            for step in 0..total {
                let g = (start + step) % total;
                let (k, tile) = (g / TILES, g % TILES);
                let age = link.ages.get(k).and_then(|a| a.get(tile)).copied();
                let waiting = dirty.get(k).is_some_and(|b| b & (1 << tile) != 0);
                if !waiting || age != Some(top) {
                    continue;
                }
                if !link.send_tile(pyramid, k, tile, report) {
                    link.cursor = g;
                    break 'ages;
                }
                if let Some(bits) = dirty.get_mut(k) {
                    *bits &= !(1 << tile);
                }
                if let Some(age) = link.ages.get_mut(k).and_then(|a| a.get_mut(tile)) {
                    *age = 0;
                }
            }
            level = top - 1;
        }
        let (deferred, newly_deferred) = poll::put_back(pyramid, &dirty, &link.ages, count);
        report.deferred_tiles = deferred;
        link.counters.patches_deferred = link
            .counters
            .patches_deferred
            .saturating_add(newly_deferred);
    }
}

#[test]
fn the_tile_scheduler_sends_what_and_when_the_exhaustive_one_did() {
    // Twin links and pyramids, one scheduled by the reference; random updates over every
    // layer and budgets tight enough that tiles wait, age and go round-robin.
    let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
    let mut next = move |n: u64| rng.below(n);
    for case in 0..12 {
        let (mut pa, _) = configured();
        let (mut pb, _) = configured();
        let config = LinkConfig {
            stats_interval_ms: 0,
            budget_bytes_per_s: 500 + 500 * (case % 4),
            burst_bytes: 300 + 100 * (case % 3),
            ..LinkConfig::DEFAULT
        };
        let design = DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let mut a: Link<1024> = Link::new(config);
        let mut b: Link<1024> = Link::new(config);
        a.adopt(&design);
        b.adopt(&design);
        for poll in 0..300_u32 {
            for _ in 0..next(6) {
                let layer = next(8) as u8;
                let (x, y) = (next(64) as i32 - 32, next(64) as i32 - 32);
                pa.apply(&obstacle(layer, x, y));
                pb.apply(&obstacle(layer, x, y));
            }
            let now = poll * 20;
            a.bucket.refill(now);
            b.bucket.refill(now);
            let mut ra = PollReport::default();
            let mut rb = PollReport::default();
            a.send_patches(&mut pa, &mut ra);
            reference::send_patches(&mut b, &mut pb, &mut rb);
            assert_eq!(ra, rb, "case {case} poll {poll}");
            assert_eq!(a.ages, b.ages, "case {case} poll {poll}");
            assert_eq!(a.cursor, b.cursor, "case {case} poll {poll}");
            assert_eq!(a.counters, b.counters, "case {case} poll {poll}");
            for k in 0..8 {
                assert_eq!(pa.layer(k).unwrap().dirty(), pb.layer(k).unwrap().dirty());
            }
            // Drain only sometimes, so that the queue fills too.
            if next(3) == 0 {
                assert_eq!(drain(&mut a), drain(&mut b), "case {case} poll {poll}");
            }
        }
    }
}

/// Feeds `bytes`, taken at `now_us`, and serves every request they complete; the requests the
/// application would carry out and the rejections.
fn receive_all(
    link: &mut Link,
    pyramid: &mut DefaultPyramid,
    mut bytes: &[u8],
    now_us: u32,
) -> (Vec<Request<8>>, Vec<Rejection>) {
    let (mut requests, mut rejections) = (Vec::new(), Vec::new());
    let mut first = true;
    loop {
        let result = if first {
            link.receive_at(bytes, now_us)
        } else {
            link.receive(bytes)
        };
        first = false;
        match result {
            FeedResult::Consumed => return (requests, rejections),
            FeedResult::Item {
                item, remaining, ..
            } => {
                requests.extend(link.serve(pyramid, item));
                bytes = remaining;
            }
            FeedResult::Rejected {
                error, remaining, ..
            } => {
                rejections.push(error);
                bytes = remaining;
            }
        }
    }
}

/// A TimeRequest is answered by the link itself with a TimeReply: the host's time echoed,
/// the device time the board passed with the bytes that completed it, and the bytes queued
/// ahead of the reply; it is counted, in the link's counters and in Stats.
#[test]
fn a_time_request_gets_a_time_reply_with_the_device_time() {
    let (mut pyramid, mut link) = configured();
    link.poll(0, &mut pyramid, &SensorCounters::default());
    let ahead = link.queue().len();
    assert!(ahead > 0, "the Hello waits in the queue");
    let host_us = 0x0123_4567_89AB_CDEF;
    let frame = command(5, &Message::TimeRequest(TimeRequest { host_us }));
    // Split: the chunk that completes the request gives its time.
    let (head, tail) = frame.split_at(frame.len() / 2);
    let (requests, rejections) = receive_all(&mut link, &mut pyramid, head, 1_000);
    assert!(requests.is_empty() && rejections.is_empty());
    let (requests, rejections) = receive_all(&mut link, &mut pyramid, tail, 4_000_123);
    assert!(requests.is_empty() && rejections.is_empty());
    let out = drain(&mut link);
    let replies: Vec<_> = out
        .iter()
        .filter_map(|(_, o)| match o {
            Out::TimeReply(t) => Some(*t),
            _ => None,
        })
        .collect();
    assert_eq!(
        replies,
        [TimeReply {
            host_us,
            device_us: 4_000_123,
            queued_ahead: u16::try_from(ahead).unwrap(),
        }]
    );
    // No Reply: the TimeReply is the answer.
    assert!(!out.iter().any(|(_, o)| matches!(o, Out::Reply(_))));
    assert_eq!(link.counters().time_requests, 1);
    // Taken with no time: the last one known; the queue empty now.
    let frame = command(6, &Message::TimeRequest(TimeRequest { host_us: 7 }));
    let mut input = &frame[..];
    while let FeedResult::Item {
        item, remaining, ..
    } = link.receive(input)
    {
        assert!(link.serve(&mut pyramid, item).is_none());
        input = remaining;
    }
    assert_eq!(
        drain(&mut link),
        [(
            link.next_seq() - 1,
            Out::TimeReply(TimeReply {
                host_us: 7,
                device_us: 4_000_123,
                queued_ahead: 0,
            })
        )]
    );
    let stats = link.stats(0, &pyramid, &SensorCounters::default());
    assert_eq!(stats.time_requests, 2);
}

/// The bytes queued ahead of a TimeReply saturate at 65 535 (a queue that large is possible).
#[test]
fn queued_ahead_saturates() {
    let mut link: Link<70_000> = Link::new(LinkConfig::DEFAULT);
    let filler = Reply::code(
        Header {
            version: VERSION,
            msg_type: 0x86,
            seq: 0,
        },
        ReplyCode::Ok,
    );
    while link.queue().len() <= 65_600 {
        link.answer(filler);
    }
    link.time_reply(1, 2);
    let mut bytes = Vec::new();
    let mut buf = [0_u8; 4096];
    loop {
        let n = link.pop_bytes(&mut buf);
        if n == 0 {
            break;
        }
        bytes.extend_from_slice(&buf[..n]);
    }
    let last = decode_all(&bytes).pop().unwrap().1;
    assert!(matches!(last, Out::TimeReply(t) if t.queued_ahead == u16::MAX && t.device_us == 2));
}

fn pose_report(flags: u8, stamp_us: u32) -> PoseReport {
    PoseReport {
        x_m: 1.0,
        y_m: -2.0,
        z_m: 0.5,
        roll_rad: 0.0,
        pitch_rad: 0.1,
        yaw_rad: 3.0,
        stamp_us,
        flags,
    }
}

/// Pose flags: 0 is an unstamped pose (no stamp, whatever the field holds), bit 0 a stamped
/// one; any other bit is refused with OutOfRange, param 38 ("pose flags"), the flags as the
/// value, limits 0 and 1, and counted.
#[test]
fn pose_flags_are_validated() {
    let (mut pyramid, mut link) = configured();
    let pose = Pose::from_f32(1.0, -2.0, 0.5, 0.0, 0.1, 3.0).unwrap();
    let mut bytes = command(1, &Message::Pose(pose_report(0, 99)));
    bytes.extend(command(
        2,
        &Message::Pose(pose_report(POSE_STAMPED, 4_000_000)),
    ));
    for (seq, flags) in [(3, 2), (4, 0x81), (5, 0xFF)] {
        bytes.extend(command(seq, &Message::Pose(pose_report(flags, 5))));
    }
    let (requests, rejections) = receive_all(&mut link, &mut pyramid, &bytes, 0);
    let commands: Vec<_> = requests.into_iter().map(|r| r.command).collect();
    assert_eq!(
        commands,
        [
            Command::Pose(pose, None),
            Command::Pose(pose, Some(4_000_000))
        ]
    );
    let refused: Vec<_> = rejections
        .iter()
        .map(|r| match r {
            Rejection::Refused(reply) => (reply.to_seq, reply.code, reply.param, reply.value),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        refused,
        [
            (3, ReplyCode::OutOfRange, 38, 2.0),
            (4, ReplyCode::OutOfRange, 38, 129.0),
            (5, ReplyCode::OutOfRange, 38, 255.0),
        ]
    );
    assert_eq!(link.counters().commands_refused, 3);
    let Rejection::Refused(reply) = rejections[0] else {
        panic!("{:?}", rejections[0])
    };
    assert_eq!((reply.a, reply.b, reply.to_type), (0.0, 1.0, 0x81));
    assert_eq!(
        std::format!("{}", convert::ReplyText(&reply)),
        "reply to #3 (0x81): pose flags: only bit 0 (stamped) is defined, the others must be 0 \
         (got 2)"
    );
    // A bad field is named before the flags are looked at.
    let mut bad = pose_report(2, 0);
    bad.z_m = f32::NAN;
    let (_, rejections) = receive_all(&mut link, &mut pyramid, &command(6, &Message::Pose(bad)), 0);
    assert!(matches!(rejections[..], [Rejection::Refused(r)] if r.param == 34));
}

/// Observed goes out at once as a control frame, ahead of the patches of the next poll; Stats
/// carries the pose counters the application gives it.
#[test]
fn observed_goes_ahead_of_the_patches_and_stats_carry_the_pose_counters() {
    let (mut pyramid, mut link) = greeted();
    pyramid.apply(&obstacle(0, 3, 4));
    assert!(link.observed(1, 3_990_000, 4_090_000));
    link.poll(10, &mut pyramid, &SensorCounters::default());
    let out = drain(&mut link);
    assert_eq!(
        out[0].1,
        Out::Observed(Observed {
            observation: 1,
            first_us: 3_990_000,
            last_us: 4_090_000,
        })
    );
    assert!(out.len() > 1 && out[1..].iter().all(|(_, o)| matches!(o, Out::Patch(..))));
    assert_eq!(link.counters().observed_frames, 1);
    let sensor = SensorCounters {
        pose: PoseCounters {
            poses_stamped: 1,
            poses_refused: 2,
            pose_gaps: 3,
            returns_extrapolated: 4,
            returns_without_pose: 5,
        },
        filtered: crate::link::FilterCounters {
            returns_masked: 6,
            returns_too_near: 7,
            returns_too_far: 8,
            returns_low_quality: 9,
        },
        observations_split: 10,
        returns_implausible: 11,
        ..SensorCounters::default()
    };
    // Each counter in its own place; between the pose and the filter counters, the link's
    // own count of TimeRequests.
    let stats = link.stats(0, &pyramid, &sensor);
    assert_eq!(
        stats.to_array()[30..],
        [1, 2, 3, 4, 5, 0, 6, 7, 8, 9, 10, 11]
    );
}

/// A queue too small to hold a Stats beside the whole control reserve (the micro:bit's 400
/// bytes) keeps less beside it, so an empty queue always takes one; a larger queue keeps the
/// whole reserve. (The micro:bit's run, `host/tests/run_microbit.rs`, sends them.)
#[test]
fn a_small_queue_reserves_less_beside_a_stats() {
    let stats = crate::wire::link::encoded_len_max(
        crate::wire::link::MIN_FRAME + 4 * crate::wire::link::STATS_COUNTERS,
    );
    assert_eq!(stats, 178);
    assert_eq!(Link::<400>::STATS_RESERVE, 400 - 178);
    assert_eq!(Link::<434>::STATS_RESERVE, CONTROL_RESERVE);
    assert_eq!(Link::<433>::STATS_RESERVE, 433 - 178);
    assert_eq!(Link::<4096>::STATS_RESERVE, CONTROL_RESERVE);
}
