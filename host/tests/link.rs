//! The host link end to end: frames round-trip through the library's encoder and decoder for
//! any field values; corrupted, truncated, oversized and old frames are refused and counted and
//! the next frame still decodes; and after lossy streams and snapshot recovery the host's
//! mirror equals the device's pyramid cell for cell.
#[path = "support/device.rs"]
mod support;

use proptest::prelude::*;
use support::{hello_message, scatter, wander, Channel, Rng};
use terrain_pyramid::design::{Schedule, SensorModel};
use terrain_pyramid::link::{Command, Link, LinkConfig, SensorCounters};
use terrain_pyramid::wire::link::{
    encode, ClampRequest, Configure, Decayed, DecayedRows, DecodeError, Decoded, FirmwareVersion,
    FrameAccumulator, GateRequest, Header, Hello, HelloReason, LaserSetup, LayerInfo, LayerPatch,
    Message, PanAngle, PatchArea, PatchCells, PoseReport, Reply, ReplyCode, RuleSetup, Setup,
    SnapshotScope, Stats, Undecoded, WindowMoved, MAX_ENCODED_FRAME, MAX_FRAME, STATS_COUNTERS,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Config, Decay, DecayMode, DefaultDesign, DefaultPyramid, Meters, TimeConstant,
    DEFAULT_CELLS_PER_SIDE,
};
use terrain_pyramid_host::link::{HostLink, LinkEvent};

// ------------------------------------------------------------------ messages

/// A message with owned cells, so that strategies can build it.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
enum Owned {
    Msg(Message<'static>),
    Patch(PatchArea, Vec<u8>),
}

impl Owned {
    fn message(&self) -> Message<'_> {
        match self {
            Self::Msg(m) => m.clone(),
            Self::Patch(area, bytes) => Message::LayerPatch(LayerPatch {
                area: *area,
                cells: PatchCells::from_le_bytes(bytes).unwrap(),
            }),
        }
    }
}

fn float() -> impl Strategy<Value = f32> {
    any::<f32>().prop_filter("NaN never equals itself", |v| !v.is_nan())
}

fn hello() -> impl Strategy<Value = Owned> {
    let layer = (any::<i32>(), float(), float(), any::<i32>(), any::<i32>()).prop_map(
        |(resolution_q16, band_inner_m, band_outer_m, origin_x, origin_y)| LayerInfo {
            resolution_q16,
            band_inner_m,
            band_outer_m,
            origin_x,
            origin_y,
        },
    );
    (
        any::<[u8; 4]>(),
        0_u8..4,
        any::<u16>(),
        any::<u32>(),
        prop::collection::vec(layer, 0..=32),
    )
        .prop_map(|(v, reason, cells_per_side, resend, layers)| {
            let reason = [
                HelloReason::Boot,
                HelloReason::Configured,
                HelloReason::Reset,
                HelloReason::Snapshot,
            ][usize::from(reason)];
            Owned::Msg(Message::Hello(Hello {
                protocol: v[0],
                firmware: FirmwareVersion {
                    major: v[1],
                    minor: v[2],
                    patch: v[3],
                },
                reason,
                cells_per_side,
                resend,
                clock: Default::default(),
                layers: layers.iter().copied().fold(Default::default(), |mut v, l| {
                    v.push(l).unwrap();
                    v
                }),
            }))
        })
}

fn patch() -> impl Strategy<Value = Owned> {
    (
        0_u8..16,
        1_u8..=16,
        1_u8..=16,
        any::<(i32, i32)>(),
        i32::MIN..i32::MAX - 16,
        i32::MIN..i32::MAX - 16,
    )
        .prop_flat_map(|(layer, width, height, origin, x, y)| {
            let n = usize::from(width) * usize::from(height);
            prop::collection::vec(any::<i16>(), n).prop_map(move |cells| {
                let area = PatchArea {
                    layer,
                    origin_x: origin.0,
                    origin_y: origin.1,
                    x,
                    y,
                    width,
                    height,
                };
                let bytes = cells.iter().flat_map(|c| c.to_le_bytes()).collect();
                Owned::Patch(area, bytes)
            })
        })
}

fn moved() -> impl Strategy<Value = Owned> {
    (
        1_u32..=u32::MAX,
        any::<[(i32, i32); 16]>(),
        any::<[(i32, i32); 16]>(),
    )
        .prop_map(|(mask, low, high)| {
            let mut m = WindowMoved::new();
            for (k, o) in low.iter().chain(&high).enumerate() {
                if mask & (1 << k) != 0 {
                    m.set(k, *o);
                }
            }
            Owned::Msg(Message::WindowMoved(m))
        })
}

fn stats() -> impl Strategy<Value = Owned> {
    prop::collection::vec(any::<u32>(), STATS_COUNTERS)
        .prop_map(|v| Owned::Msg(Message::Stats(Stats::from_array(v.try_into().unwrap()))))
}

fn reply() -> impl Strategy<Value = Owned> {
    (any::<(u16, u8, u8)>(), 0_u8..12, float(), float(), float()).prop_map(
        |((to_seq, to_type, param), code, value, a, b)| {
            // Any valid code: build one through the decoder's own table.
            let codes = [
                ReplyCode::Ok,
                ReplyCode::NotFinite,
                ReplyCode::NotPositive,
                ReplyCode::OutOfRange,
                ReplyCode::GammaNotAboveOne,
                ReplyCode::BaseBelowBound,
                ReplyCode::TooManyLayers,
                ReplyCode::BadWindow,
                ReplyCode::WindowTooSmall,
                ReplyCode::BadLayer,
                ReplyCode::Unsupported,
                ReplyCode::Malformed,
            ];
            Owned::Msg(Message::Reply(Reply {
                to_seq,
                to_type,
                code: codes[usize::from(code)],
                param,
                value,
                a,
                b,
            }))
        },
    )
}

fn commands() -> impl Strategy<Value = Owned> {
    let pose = (prop::array::uniform6(float()), any::<u32>()).prop_map(|(f, stamp_us)| {
        Owned::Msg(Message::Pose(PoseReport {
            x_m: f[0],
            y_m: f[1],
            z_m: f[2],
            roll_rad: f[3],
            pitch_rad: f[4],
            yaw_rad: f[5],
            stamp_us,
            flags: 0,
        }))
    });
    let pan = any::<(u16, u32)>().prop_map(|(turns, timestamp_ms)| {
        Owned::Msg(Message::PanAngle(PanAngle {
            turns,
            timestamp_ms,
        }))
    });
    let configure = (
        prop::array::uniform7(float()),
        prop::option::of(float()),
        any::<u16>(),
        prop::array::uniform3(float()),
        prop::option::of((float(), float())),
        float(),
        (0_u8..4, any::<[u8; 32]>()),
    )
        .prop_map(|(f, gate, cells_per_side, p, clamp, fused_margin, decay)| {
            Owned::Msg(Message::Configure(Configure {
                phi_rad: f[0],
                psi_rad: f[1],
                sigma_m: f[2],
                height_m: f[3],
                max_range_m: f[4],
                base_m: f[5],
                gamma: f[6],
                gate: gate.map_or(GateRequest::Hard, |width_factor| GateRequest::Soft {
                    width_factor,
                }),
                cells_per_side,
                p_obstacle: p[0],
                p_free: p[1],
                prior: p[2],
                uniform_resolution: false,
                clamp: clamp.map_or(ClampRequest::Off, |(min, max)| ClampRequest::Bounds {
                    min,
                    max,
                }),
                fused_margin,
                decay_mode: decay.0,
                decay_tau: decay.1,
            }))
        });
    let setup = (
        any::<(u8, u8, u16, u16, u32)>(),
        prop::array::uniform3(float()),
        prop::array::uniform4(float()),
        any::<(u8, u8, u32)>(),
        prop::array::uniform4(float()),
        (any::<u8>(), prop::array::uniform5(float())),
    )
        .prop_map(
            |((mount, mode, field, res, lines), sensor_m, t, (s, a, baud), servo, (rule, r))| {
                Owned::Msg(Message::Setup(Setup {
                    mount_block: terrain_pyramid::wire::link::MountSetup::PRESET,
                    filter: terrain_pyramid::wire::link::FilterSetup::NONE,
                    mount,
                    measuring_mode: mode,
                    field_deg: field,
                    resolution_cdeg: res,
                    sensor_m,
                    lines_per_observation: lines,
                    robot_height_m: t[0],
                    step_threshold_m: t[1],
                    drop_threshold_m: t[2],
                    ceiling_m: t[3],
                    rule: RuleSetup {
                        rule,
                        max_grade: r[0],
                        residual_m: r[1],
                        range_sigma_m: r[2],
                        angle_sigma_rad: r[3],
                        noise_factor: r[4],
                    },
                    laser: LaserSetup {
                        sensor: s,
                        actuator: a,
                        baud,
                        servo_min_deg: servo[0],
                        servo_max_deg: servo[1],
                        servo_rate_deg_s: servo[2],
                        servo_latency_ms: servo[3],
                    },
                }))
            },
        );
    let snapshot = prop::option::of(0_u8..255).prop_map(|k| {
        Owned::Msg(Message::RequestSnapshot(
            k.map_or(SnapshotScope::All, SnapshotScope::Layer),
        ))
    });
    prop_oneof![
        pose,
        pan,
        configure,
        setup,
        snapshot,
        Just(Owned::Msg(Message::Reset)),
        Just(Owned::Msg(Message::Ping)),
    ]
}

fn decayed() -> impl Strategy<Value = Owned> {
    (
        1_u8..4,
        prop::collection::vec(
            (0_usize..32, any::<u16>(), 1_u16..=1024, any::<u32>()),
            1..6,
        ),
    )
        .prop_map(|(mode, layers)| {
            let mut d = Decayed::new(mode);
            for (k, first, rows, faded) in layers {
                d.set(k, DecayedRows { first, rows, faded });
            }
            Owned::Msg(Message::Decayed(d))
        })
}

fn any_message() -> impl Strategy<Value = Owned> {
    prop_oneof![
        hello(),
        patch(),
        moved(),
        stats(),
        reply(),
        decayed(),
        commands()
    ]
}

fn encoded(seq: u16, m: &Owned) -> Vec<u8> {
    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
    let n = encode(seq, &m.message(), &mut out).unwrap();
    assert!(n <= m.message().encoded_len_max());
    out.truncate(n);
    out
}

/// Feeds `chunks` and returns (seq, re-encoded message) of every frame, and the errors.
fn decode_stream<'c>(
    acc: &mut FrameAccumulator<MAX_FRAME>,
    chunks: impl IntoIterator<Item = &'c [u8]>,
) -> (Vec<(u16, Vec<u8>)>, Vec<DecodeError>) {
    let (mut ok, mut bad) = (Vec::new(), Vec::new());
    for chunk in chunks {
        let mut input = chunk;
        loop {
            match acc.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Item {
                    item: Decoded { header, message },
                    remaining,
                    ..
                } => {
                    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
                    let n = encode(header.seq, &message, &mut out).unwrap();
                    out.truncate(n);
                    ok.push((header.seq, out));
                    input = remaining;
                }
                FeedResult::Rejected {
                    error: Undecoded { error, .. },
                    remaining,
                    ..
                } => {
                    bad.push(error);
                    input = remaining;
                }
            }
        }
    }
    (ok, bad)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn every_message_round_trips(m in any_message(), seq in any::<u16>()) {
        let bytes = encoded(seq, &m);
        prop_assert_eq!(bytes.iter().filter(|&&b| b == 0).count(), 1);
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        match acc.feed(&bytes) {
            FeedResult::Item { item: Decoded { header, message }, remaining, .. } => {
                prop_assert_eq!(header, Header { version: terrain_pyramid::wire::link::VERSION, msg_type: m.message().msg_type().to_u8(), seq });
                prop_assert_eq!(message, m.message());
                prop_assert!(remaining.is_empty());
            }
            other => prop_assert!(false, "{:?}", other),
        }
    }

    #[test]
    fn floats_survive_bit_for_bit(bits in prop::array::uniform6(any::<u32>())) {
        // NaN payloads included: decode(encode(x)) re-encodes to the same bytes.
        let f = bits.map(f32::from_bits);
        let pose = Owned::Msg(Message::Pose(PoseReport {
            x_m: f[0], y_m: f[1], z_m: f[2], roll_rad: f[3], pitch_rad: f[4], yaw_rad: f[5],
            stamp_us: 0,
            flags: 0,
        }));
        let bytes = encoded(3, &pose);
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        let (ok, bad) = decode_stream(&mut acc, [&bytes[..]]);
        prop_assert!(bad.is_empty());
        prop_assert_eq!(&ok[0].1, &bytes);
    }

    #[test]
    fn streams_reassemble_from_any_chunking(
        messages in prop::collection::vec(any_message(), 1..12),
        cuts in prop::collection::vec(1_usize..200, 1..40),
    ) {
        let frames: Vec<Vec<u8>> = messages.iter().enumerate()
            .map(|(i, m)| encoded(i as u16, m)).collect();
        let stream = frames.concat();
        let mut chunks = Vec::new();
        let (mut at, mut i) = (0, 0);
        while at < stream.len() {
            let n = cuts[i % cuts.len()].min(stream.len() - at);
            chunks.push(&stream[at..at + n]);
            at += n;
            i += 1;
        }
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        let (ok, bad) = decode_stream(&mut acc, chunks);
        prop_assert!(bad.is_empty());
        prop_assert_eq!(ok.len(), frames.len());
        for (i, (seq, bytes)) in ok.iter().enumerate() {
            prop_assert_eq!(*seq as usize, i);
            prop_assert_eq!(bytes, &frames[i]);
        }
    }

    /// Flipped bytes, deleted runs and oversized garbage: every frame left untouched (with the
    /// delimiter before it) still decodes, nothing else does, every bad frame is counted.
    #[test]
    fn corruption_is_refused_and_the_next_frame_decodes(
        messages in prop::collection::vec(any_message(), 2..10),
        flips in prop::collection::vec((any::<prop::sample::Index>(), 1_u8..=255), 0..4),
        cut in prop::option::of((any::<prop::sample::Index>(), 1_usize..40)),
        garbage in prop::option::of((any::<prop::sample::Index>(), (MAX_FRAME + 40)..(MAX_FRAME + 340))),
    ) {
        let frames: Vec<Vec<u8>> = messages.iter().enumerate()
            .map(|(i, m)| encoded(i as u16, m)).collect();
        // Mark each byte with the frame it belongs to, then damage the stream.
        let mut stream: Vec<(u8, Option<usize>)> = frames.iter().enumerate()
            .flat_map(|(i, f)| f.iter().map(move |&b| (b, Some(i)))).collect();
        let mut damaged = vec![false; frames.len()];
        let damage = |stream: &Vec<(u8, Option<usize>)>, at: usize, damaged: &mut Vec<bool>| {
            if let Some((_, Some(i))) = stream.get(at) {
                damaged[*i] = true;
                // A frame whose leading delimiter is hit merges with the one before.
                if stream[at].0 == 0 && *i + 1 < damaged.len() {
                    damaged[*i + 1] = true;
                }
            }
        };
        for (index, mask) in &flips {
            let at = index.index(stream.len());
            damage(&stream, at, &mut damaged);
            stream[at].0 ^= mask;
        }
        if let Some((index, len)) = cut {
            let at = index.index(stream.len());
            let end = (at + len).min(stream.len());
            for i in at..end {
                damage(&stream, i, &mut damaged);
            }
            stream.drain(at..end);
        }
        let mut garbage_ends = false;
        if let Some((index, len)) = garbage {
            // Oversized: a run of non-zero bytes inside some frame, longer than any frame.
            let at = index.index(stream.len());
            let owner = stream[at].1;
            if let Some(i) = owner {
                damaged[i] = true;
            }
            stream.splice(at..at, std::iter::repeat_n((0x5A, owner), len));
            // It is refused as too long when a delimiter still ends it.
            garbage_ends = stream[at + len..].iter().any(|(b, _)| *b == 0);
        }
        let bytes: Vec<u8> = stream.iter().map(|(b, _)| *b).collect();
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        let (ok, bad) = decode_stream(&mut acc, bytes.chunks(37));
        // A frame is intact exactly when its encoded bytes (ending in their delimiter) stand
        // whole in the damaged stream, at its start or right after a delimiter: a cut that
        // takes a frame's delimiter and everything up to a later one leaves it intact.
        let intact = |f: &Vec<u8>| {
            bytes
                .windows(f.len())
                .enumerate()
                .any(|(p, w)| w == &f[..] && (p == 0 || bytes[p - 1] == 0))
        };
        for (i, f) in frames.iter().enumerate() {
            damaged[i] = !intact(f);
        }
        let clean: Vec<usize> = (0..frames.len()).filter(|&i| !damaged[i]).collect();
        let got: Vec<usize> = ok.iter().map(|(s, _)| *s as usize).collect();
        prop_assert_eq!(&got, &clean, "errors {:?}", bad);
        for (seq, b) in &ok {
            prop_assert_eq!(b, &frames[*seq as usize]);
        }
        let c = acc.counters();
        prop_assert_eq!(c.errors() as usize, bad.len());
        prop_assert_eq!(c.frames_ok as usize, ok.len());
        if damaged.iter().any(|&d| d) && !bytes.is_empty() {
            prop_assert!(!bad.is_empty() || got.len() < frames.len());
        }
        if garbage_ends {
            let too_long = bad.iter().any(|e| matches!(e, DecodeError::TooLong { .. }));
            prop_assert!(too_long, "no TooLong in {:?}", bad);
        }
    }
}

// ------------------------------------------------------------------ sequence numbers

fn device_frame(seq: u16, message: &Message<'_>) -> Vec<u8> {
    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
    let n = encode(seq, message, &mut out).unwrap();
    out.truncate(n);
    out
}

fn small_hello() -> Message<'static> {
    hello_message(8, 1, -4)
}

#[test]
fn old_frames_are_refused_gaps_ask_for_a_snapshot_and_the_next_frame_applies() {
    let mut host = HostLink::new();
    let cells = [7_i16.to_le_bytes(); 4].concat();
    let patch = |x| {
        Message::LayerPatch(LayerPatch {
            area: PatchArea {
                layer: 0,
                origin_x: -4,
                origin_y: -4,
                x,
                y: 0,
                width: 2,
                height: 2,
            },
            cells: PatchCells::from_le_bytes(&cells).unwrap(),
        })
    };
    let mut stream = device_frame(10, &small_hello());
    stream.extend(device_frame(11, &patch(-4)));
    let events = host.feed(&stream);
    assert!(matches!(events[..], [LinkEvent::Hello(_)]));
    assert!(host.mirror().is_synced());
    // An old frame: refused, counted, snapshot advised; the mirror keeps its cells.
    let events = host.feed(&device_frame(5, &patch(0)));
    assert_eq!(events, [LinkEvent::SnapshotNeeded]);
    assert_eq!(host.mirror().counters().out_of_order, 1);
    let (_, _, cells_now) = host.mirror().layer_cells(0).unwrap();
    assert_eq!(
        cells_now[4 * 8 + 4],
        i16::MIN,
        "the old patch at x = 0 was not applied"
    );
    // The next frame in order applies.
    host.feed(&device_frame(12, &patch(2)));
    let (origin, res, cells_now) = host.mirror().layer_cells(0).unwrap();
    assert_eq!((origin, res), ((-4, -4), 6554));
    assert_eq!(cells_now[4 * 8 + 6], 7);
    assert_eq!(cells_now[4 * 8], 7);
    // A gap: applied, counted, snapshot advised, the layer stale until resent.
    let events = host.feed(&device_frame(15, &patch(0)));
    assert_eq!(events, [LinkEvent::SnapshotNeeded]);
    assert_eq!(host.mirror().counters().missing, 2);
    assert!(host.mirror().needs_snapshot());
    assert_eq!(host.mirror().layer_cells(0).unwrap().2[4 * 8 + 4], 7);
    // A corrupted frame in between: counted, and the next one decodes.
    let mut bad = device_frame(16, &patch(-2));
    bad[5] ^= 0x10;
    bad.extend(device_frame(
        16,
        &Message::Reply(Reply::ok(Header {
            version: 1,
            msg_type: 0x86,
            seq: 0,
        })),
    ));
    let events = host.feed(&bad);
    assert!(matches!(
        events[0],
        LinkEvent::BadFrame(DecodeError::Crc { .. })
    ));
    assert!(matches!(events[1], LinkEvent::Reply(r) if r.is_ok()));
    assert_eq!(host.rx_counters().crc, 1);
    // A device that restarts: its Hello is taken whatever its number.
    let events = host.feed(&device_frame(0, &small_hello()));
    assert!(matches!(events[..], [LinkEvent::Hello(_)]));
    assert!(host.mirror().is_synced());
    assert_eq!(host.mirror().layer_cells(0).unwrap().2, vec![i16::MIN; 64]);
}

// ------------------------------------------------------------------ device and mirror

struct Outcome {
    decay_frames: u32,
    cells_faded: u64,
    dropped: u32,
    flipped: u32,
    snapshots: u32,
    resyncs: u32,
    frames_dropped_by_device: u32,
    patches_deferred: u32,
}

/// Hands host bytes to the device's link and carries out what concerns the link and the maps
/// ([`Link::serve`]), as the application core does; returns every command received.
fn deliver<const Q: usize>(
    link: &mut Link<Q>,
    pyramid: &mut DefaultPyramid,
    bytes: &[u8],
) -> Vec<Command<8>> {
    let mut commands = Vec::new();
    let mut input = bytes;
    loop {
        input = match link.receive(input) {
            FeedResult::Consumed => return commands,
            FeedResult::Item {
                item, remaining, ..
            } => {
                commands.push(item.command.clone());
                link.serve(pyramid, item);
                remaining
            }
            FeedResult::Rejected { remaining, .. } => remaining,
        };
    }
}

/// Drives a default pyramid with random evidence and moves, streams its link through a lossy
/// channel to a host mirror that asks for snapshots, then lets everything settle and compares
/// the mirror with the pyramid cell for cell. With `decay` on, the pyramid decays at the
/// link's polls and the mirror ages from the Decayed frames alone.
fn scenario<const Q: usize>(
    seed: u64,
    steps: usize,
    channel: Channel,
    pings: bool,
    collapse: bool,
) -> Outcome {
    scenario_with::<Q>(seed, steps, channel, pings, collapse, Decay::OFF)
}

fn scenario_with<const Q: usize>(
    seed: u64,
    steps: usize,
    channel: Channel,
    pings: bool,
    collapse: bool,
    decay: Decay,
) -> Outcome {
    let mut rng = Rng(seed | 1);
    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut link: Box<Link<Q>> = Box::new(Link::new(LinkConfig {
        stats_interval_ms: 500,
        ..LinkConfig::DEFAULT
    }));
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap();
    let config = Config {
        decay,
        ..Config::default()
    };
    pyramid.configure(&design, &config).unwrap();
    link.adopt(&design);
    let mut host = HostLink::new();
    let mut channel = channel;
    let (mut x, mut y) = (0.0_f64, 0.0_f64);
    let mut now_ms = 0_u32;
    let uart_per_step = 92_160 * 13 / 1000;
    let mut last_request: Option<u32> = None;

    let mut step = |pyramid: &mut DefaultPyramid,
                    link: &mut Link<Q>,
                    host: &mut HostLink,
                    channel: &mut Channel,
                    rng: &mut Rng,
                    now_ms: u32,
                    lossy: bool| {
        link.poll(now_ms, pyramid, &SensorCounters::default());
        let mut uart = vec![0_u8; uart_per_step];
        let n = link.pop_bytes(&mut uart);
        let bytes = if lossy {
            channel.pass(rng, &uart[..n])
        } else {
            uart[..n].to_vec()
        };
        let mut wants_snapshot = false;
        for event in host.feed(&bytes) {
            wants_snapshot |= event == LinkEvent::SnapshotNeeded;
        }
        // A host that is still missing something asks again after a while.
        let overdue = last_request.is_none_or(|t| now_ms.wrapping_sub(t) > 2000);
        if wants_snapshot || (host.mirror().needs_snapshot() && overdue) {
            let cmd = host
                .command(&Message::RequestSnapshot(SnapshotScope::All))
                .unwrap();
            last_request = Some(now_ms);
            let commands = deliver(link, pyramid, &cmd);
            assert_eq!(commands, [Command::Snapshot(SnapshotScope::All)]);
        }
    };

    for _ in 0..steps {
        // Drive: mostly small steps, sometimes a jump of several metres.
        let (mx, my) = wander(&mut rng, &mut x, &mut y);
        pyramid.recentre(mx, my);
        if collapse && rng.chance(30) {
            // A second move before the link is polled: the link must resend everything.
            pyramid.recentre(mx + Meters::from_num(0.35), my);
            pyramid.recentre(mx, my);
        }
        scatter(&mut rng, &mut pyramid, mx, my, 60);
        if pings && rng.chance(300) {
            // Bursts of commands whose replies may find the small queue full.
            for _ in 0..20 {
                let cmd = host.command(&Message::Ping).unwrap();
                deliver(&mut link, &mut pyramid, &cmd);
            }
        }
        now_ms += 13;
        step(
            &mut pyramid,
            &mut link,
            &mut host,
            &mut channel,
            &mut rng,
            now_ms,
            true,
        );
    }
    // Settle over a clean line.
    let mut settled = false;
    for _ in 0..5000 {
        now_ms += 13;
        step(
            &mut pyramid,
            &mut link,
            &mut host,
            &mut channel,
            &mut rng,
            now_ms,
            false,
        );
        let quiet = link.queue().is_empty()
            && (0..pyramid.layer_count()).all(|k| pyramid.layer(k).unwrap().dirty() == 0);
        if quiet && host.mirror().is_synced() {
            settled = true;
            break;
        }
    }
    assert!(
        settled,
        "the mirror never settled: {:?} {:?} queue {} dirty {:?} stale {:?}",
        host.mirror().counters(),
        link.counters(),
        link.queue().len(),
        (0..pyramid.layer_count())
            .map(|k| pyramid.layer(k).unwrap().dirty())
            .collect::<Vec<_>>(),
        (0..pyramid.layer_count())
            .map(|k| host.mirror().layer(k).unwrap().is_stale())
            .collect::<Vec<_>>(),
    );
    assert_eq!(host.mirror().layer_count(), pyramid.layer_count());
    let w = DEFAULT_CELLS_PER_SIDE;
    for k in 0..pyramid.layer_count() {
        let layer = pyramid.layer(k).unwrap();
        let (origin, res, cells) = host.mirror().layer_cells(k).unwrap();
        assert_eq!(origin, layer.origin(), "layer {k}");
        assert_eq!(res, layer.resolution().to_bits(), "layer {k}");
        for dy in 0..w {
            for dx in 0..w {
                assert_eq!(
                    cells[dy * w + dx],
                    layer.at_offset(dx, dy).unwrap().to_raw(),
                    "layer {k} cell ({dx}, {dy})"
                );
            }
        }
    }
    let c = link.counters();
    // A snapshot now resends every cell into a mirror in step: each compared with the
    // mirror's own (for cells that only decayed since they were sent: the mirror's decay
    // against the device's), none different.
    let before = host.mirror().counters();
    let cmd = host
        .command(&Message::RequestSnapshot(SnapshotScope::All))
        .unwrap();
    deliver(&mut link, &mut pyramid, &cmd);
    for _ in 0..5000 {
        now_ms += 13;
        link.poll(now_ms, &mut pyramid, &SensorCounters::default());
        let mut uart = vec![0_u8; 92_160 * 13 / 1000];
        let n = link.pop_bytes(&mut uart);
        host.feed(&uart[..n]);
        if host.mirror().is_synced() && host.mirror().counters().hellos > before.hellos {
            break;
        }
    }
    let after = host.mirror().counters();
    assert_eq!(
        after.resent_cells_compared - before.resent_cells_compared,
        (w * w * pyramid.layer_count()) as u64,
        "{after:?}"
    );
    assert_eq!(after.resent_cells_differing, 0, "{after:?}");
    assert_eq!(
        host.mirror().counters().decay_frames > 0,
        decay.is_on(),
        "{:?}",
        host.mirror().counters()
    );
    Outcome {
        decay_frames: c.decay_frames,
        cells_faded: host.mirror().counters().cells_faded,
        dropped: channel.dropped,
        flipped: channel.flipped,
        snapshots: c.snapshots,
        resyncs: c.resyncs,
        frames_dropped_by_device: c.frames_dropped,
        patches_deferred: c.patches_deferred,
    }
}

fn clean() -> Channel {
    Channel::new(0, 0)
}

#[test]
fn a_clean_line_needs_no_snapshot() {
    let out = scenario::<4096>(7, 300, clean(), false, false);
    assert_eq!(out.snapshots, 0);
    assert_eq!(out.resyncs, 0);
}

#[test]
fn deleted_and_corrupted_frames_are_recovered_by_snapshots() {
    let lossy = Channel {
        drop_per_mille: 20,
        flip_per_mille: 20,
        ..clean()
    };
    let out = scenario::<4096>(42, 400, lossy, false, false);
    assert!(out.dropped > 0 && out.flipped > 0);
    assert!(out.snapshots > 0);
}

#[test]
fn a_queue_too_small_drops_replies_and_still_converges() {
    let out = scenario::<512>(3, 300, clean(), true, false);
    assert!(out.frames_dropped_by_device > 0, "replies were dropped");
    assert!(out.patches_deferred > 0);
    assert!(out.snapshots > 0);
}

#[test]
fn moves_that_collapse_between_polls_are_resent() {
    let out = scenario::<4096>(11, 200, clean(), false, true);
    assert!(out.resyncs > 0);
}

/// Decay at τ = 1 s (a step every 125 ms) on every layer, all evidence.
fn fast_decay(mode: DecayMode) -> Decay {
    Decay::uniform(mode, TimeConstant::MIN, 8)
}

#[test]
fn the_mirror_ages_alike_with_no_patch_in_between() {
    let out = scenario_with::<4096>(7, 300, clean(), false, false, fast_decay(DecayMode::All));
    // Equal cell for cell (checked in the scenario) with no snapshot: the mirror aged from
    // the Decayed frames alone.
    assert_eq!(out.snapshots, 0);
    assert!(out.decay_frames > 20, "{}", out.decay_frames);
    assert!(out.cells_faded > 1000, "{}", out.cells_faded);
}

#[test]
fn decay_with_lost_frames_is_recovered_by_snapshots() {
    let lossy = Channel {
        drop_per_mille: 20,
        flip_per_mille: 20,
        ..clean()
    };
    let out = scenario_with::<4096>(42, 400, lossy, false, false, fast_decay(DecayMode::All));
    assert!(out.dropped > 0 && out.flipped > 0);
    assert!(out.snapshots > 0);
    assert!(out.cells_faded > 0);
}

#[test]
fn decay_of_one_kind_with_a_small_queue_and_collapsed_moves() {
    for mode in [DecayMode::Obstacle, DecayMode::Free] {
        scenario_with::<512>(3, 200, clean(), true, false, fast_decay(mode));
        scenario_with::<4096>(11, 150, clean(), false, true, fast_decay(mode));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

    #[test]
    fn any_lossy_stream_converges(seed in any::<u64>(), drop in 0_u32..60, flip in 0_u32..60) {
        let lossy = Channel { drop_per_mille: drop, flip_per_mille: flip, ..clean() };
        scenario::<4096>(seed, 150, lossy, false, false);
    }

    #[test]
    fn any_lossy_stream_with_decay_converges(
        seed in any::<u64>(),
        drop in 0_u32..60,
        flip in 0_u32..60,
        mode in 1_u8..4,
        code in 1_u8..60,
    ) {
        let lossy = Channel { drop_per_mille: drop, flip_per_mille: flip, ..clean() };
        let decay = Decay::uniform(
            DecayMode::from_u8(mode).unwrap(),
            TimeConstant::from_code(code),
            8,
        );
        scenario_with::<4096>(seed, 150, lossy, false, false, decay);
    }
}

/// An older device (protocol version 2) is refused whole, frame by frame, and the host says
/// why: the firmware and the host do not match.
#[test]
fn a_version_2_device_is_refused_and_named() {
    // A version-2 Reply Ok (the v2 specification's encoding: version byte 2).
    let mut raw = vec![2_u8, 0x05, 0x00, 0x00];
    raw.extend_from_slice(&[0x01, 0x00, 0x86, 0x00, 0x00]);
    raw.extend_from_slice(&[0; 12]);
    let crc = terrain_pyramid::wire::link::crc32(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut framed = vec![0_u8; raw.len() + 4];
    let mut enc = terrain_pyramid::wire::link::cobs::Encoder::new(&mut framed);
    enc.push_all(&raw);
    let n = enc.finish().unwrap();
    framed.truncate(n);
    let mut host = HostLink::new();
    assert!(host
        .feed(&framed)
        .iter()
        .all(|e| !matches!(e, LinkEvent::Reply(_))));
    let rx = host.rx_counters();
    assert_eq!((rx.unknown_version, rx.frames_ok), (1, 0));
    let hint = terrain_pyramid_host::link::version_hint(&rx);
    assert!(hint.contains("do not match"), "{hint}");
    assert!(hint.contains("version 4"), "{hint}");
    // A frame of this version clears it.
    host.feed(&device_frame(
        0,
        &Message::Reply(terrain_pyramid::wire::link::Reply::code(
            terrain_pyramid::wire::link::Header {
                version: 3,
                msg_type: 0x86,
                seq: 1,
            },
            terrain_pyramid::wire::link::ReplyCode::Ok,
        )),
    ));
    assert_eq!(
        terrain_pyramid_host::link::version_hint(&host.rx_counters()),
        ""
    );
}

/// A version-4 device (the release before the mount and filter blocks): its frames are refused
/// whole and the host names both versions. The Reply Ok to Configure of the version-4 worked
/// examples (`docs/link_golden.py` with version 4), whose CRC is good.
#[test]
fn a_version_4_device_is_refused_and_named() {
    let mut host = HostLink::new();
    // Reply Ok to configure 11, seq 0x0105, version 4.
    let v4 = [
        0x06, 0x04, 0x05, 0x05, 0x01, 0x0b, 0x02, 0x83, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
        0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x05, 0xac, 0xa4, 0xdf, 0x43, 0x00,
    ];
    let events = host.feed(&v4);
    assert!(events
        .iter()
        .all(|e| matches!(e, LinkEvent::BadFrame(DecodeError::UnknownVersion(4)))));
    let rx = host.rx_counters();
    assert_eq!((rx.unknown_version, rx.frames_ok), (1, 0));
    let hint = terrain_pyramid_host::link::version_hint(&rx);
    assert!(hint.contains("do not match"), "{hint}");
    assert!(
        hint.contains("version 5") && hint.contains("version 4"),
        "{hint}"
    );
}

/// The frames of version 4 that carry the device's clock become events and leave the mirror
/// as it is.
#[test]
fn time_replies_and_observed_frames_become_events() {
    use terrain_pyramid::wire::link::{Observed, TimeReply};
    let mut host = HostLink::new();
    let reply = TimeReply {
        host_us: 1_234_567_890_123,
        device_us: 4_000_123,
        queued_ahead: 300,
    };
    let observed = Observed {
        observation: 42,
        first_us: 3_990_000,
        last_us: 4_090_000,
    };
    let mut bytes = device_frame(0, &Message::TimeReply(reply));
    bytes.extend(device_frame(1, &Message::Observed(observed)));
    let events = host.feed(&bytes);
    assert_eq!(
        events,
        [LinkEvent::TimeReply(reply), LinkEvent::Observed(observed)]
    );
    assert_eq!(host.mirror().counters().frames, 2);
    assert_eq!(host.mirror().layer_count(), 0);
}
