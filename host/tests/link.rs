//! The host link's frames: they round-trip through the library's encoder and decoder for any
//! field values and any chunking; corrupted, truncated and oversized frames are refused and
//! counted and the next frame still decodes. The mirror behind the link: `link_mirror.rs`.
use proptest::prelude::*;
use terrain_pyramid::wire::link::{
    encode, ClampRequest, Configure, Decayed, DecayedRows, DecodeError, Decoded, FirmwareVersion,
    FrameAccumulator, GateRequest, Header, Hello, HelloReason, LaserSetup, LayerInfo, LayerPatch,
    Message, PanAngle, PatchArea, PatchCells, PoseReport, Reply, ReplyCode, RuleSetup, Setup,
    SnapshotScope, Stats, Undecoded, WindowMoved, MAX_ENCODED_FRAME, MAX_FRAME, STATS_COUNTERS,
};
use terrain_pyramid::wire::FeedResult;

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
        (any::<(u8, u8)>(), prop::array::uniform5(float())),
    )
        .prop_map(
            |(
                (mount, mode, field, res, lines),
                sensor_m,
                t,
                (s, a, baud),
                servo,
                ((rule, depth), r),
            )| {
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
                        pair_depth: depth,
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
            // Oversized: a run of non-zero bytes inside some frame, longer than any frame. A
            // cut may have taken the whole stream: the garbage is then all there is.
            let at = if stream.is_empty() { 0 } else { index.index(stream.len()) };
            let owner = stream.get(at).and_then(|(_, owner)| *owner);
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
