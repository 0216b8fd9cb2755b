//! Golden frames of every message type, as hex written from `docs/protocol.md` (section 10 and
//! an independent encoder of the spec, `docs/link_golden.py`: Python's `zlib.crc32` and a COBS
//! encoder written from section 3), and the accumulator's handling of bad input.
extern crate std;
use super::*;
use crate::wire::FeedResult;
use std::vec::Vec;

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// Encodes `message` as seq `seq`, checks it against `encoded`, decodes `encoded` back (via the
/// accumulator) and checks the message and header.
fn golden(seq: u16, message: &Message<'_>, encoded: &str) {
    let expected = hex(encoded);
    let mut out = [0_u8; MAX_ENCODED_FRAME];
    let n = encode(seq, message, &mut out).unwrap();
    assert_eq!(&out[..n], &expected[..], "{message:?}");
    assert!(n <= message.encoded_len_max());
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    match acc.feed(&expected) {
        FeedResult::Item {
            item: Decoded {
                header,
                message: decoded,
            },
            remaining,
            ..
        } => {
            assert_eq!(
                header,
                Header {
                    version: VERSION,
                    msg_type: message.msg_type().to_u8(),
                    seq
                }
            );
            assert_eq!(&decoded, message);
            assert!(remaining.is_empty());
        }
        other => panic!("{other:?}"),
    }
}

/// Asserts that a body of each length in `lens` (zeros) is refused for type `msg_type`.
fn assert_bad_bodies(msg_type: u8, lens: &[usize]) {
    for &len in lens {
        assert_eq!(
            Message::parse(msg_type, &[0; 256][..len]),
            Err(DecodeError::BadBody { msg_type, len })
        );
    }
}

fn ping_frame() -> Vec<u8> {
    hex("04 06 86 01 05 b3 d6 8c f8 00")
}

#[test]
fn ping_reset_snapshot_golden() {
    golden(1, &Message::Ping, "04 06 86 01 05 b3 d6 8c f8 00");
    golden(0x0203, &Message::Reset, "09 06 84 03 02 73 01 30 27 00");
    golden(
        7,
        &Message::RequestSnapshot(SnapshotScope::All),
        "04 06 85 07 06 ff bc bd a8 bb 00",
    );
    golden(
        8,
        &Message::RequestSnapshot(SnapshotScope::Layer(2)),
        "04 06 85 08 06 02 20 74 f8 73 00",
    );
}

#[test]
fn pan_and_pose_golden() {
    golden(
        9,
        &Message::PanAngle(PanAngle {
            turns: 0x4000,
            timestamp_ms: 123_456,
        }),
        "04 06 82 09 01 05 40 40 e2 01 05 28 1e e2 c9 00",
    );
    golden(
        10,
        &Message::Pose(PoseReport {
            x_m: 1.5,
            y_m: -2.25,
            z_m: 0.0,
            roll_rad: 0.0,
            pitch_rad: 0.0,
            yaw_rad: 3.140625,
            stamp_us: 1000,
            flags: 0,
        }),
        "04 06 81 0a 01 01 03 c0 3f 01 03 10 c0 01 01 01 01 01 01 01 01 01 01 01 01 01 05 49 40 \
         e8 03 01 01 05 30 06 41 79 00",
    );
}

#[test]
fn configure_golden() {
    let c = Configure {
        phi_rad: 0.5,
        psi_rad: 0.25,
        sigma_m: 0.15,
        height_m: 1.0,
        max_range_m: 10.0,
        base_m: 0.1,
        gamma: 2.0,
        gate: GateRequest::Soft { width_factor: 0.5 },
        cells_per_side: 64,
        p_obstacle: 0.7,
        p_free: 0.4,
        prior: 0.5,
        clamp: ClampRequest::Bounds {
            min: -2.0,
            max: 3.5,
        },
        fused_margin: 0.0,
        uniform_resolution: false,
        decay_mode: 0,
        decay_tau: [0; 32],
    };
    golden(
        11,
        &Message::Configure(c),
        "04 06 83 0b 01 01 01 02 3f 01 07 80 3e 9a 99 19 3e 01 03 80 3f 01 07 20 41 cd cc cc 3d \
         01 01 03 40 01 01 01 03 3f 40 09 33 33 33 3f cd cc cc 3e 01 01 03 3f 01 01 01 02 c0 01 \
         03 60 40 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 01 01 01 01 01 05 e9 7f 5e 4d 00",
    );
    // Decay on (obstacle evidence only), codes 54, 54, 70, 70, 86, 86 for layers 0 ..= 5.
    let mut tau = [0_u8; 32];
    tau[..6].copy_from_slice(&[54, 54, 70, 70, 86, 86]);
    let decaying = Configure {
        decay_mode: 2,
        decay_tau: tau,
        ..c
    };
    golden(
        12,
        &Message::Configure(decaying),
        "04 06 83 0c 01 01 01 02 3f 01 07 80 3e 9a 99 19 3e 01 03 80 3f 01 07 20 41 cd cc cc 3d \
         01 01 03 40 01 01 01 03 3f 40 09 33 33 33 3f cd cc cc 3e 01 01 03 3f 01 01 01 02 c0 01 \
         03 60 40 01 01 01 01 08 02 36 36 46 46 56 56 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 01 01 01 01 01 05 7f 25 7e b4 00",
    );
    // A mode above 3 is out of range (the body is otherwise the one above).
    let mut body = [0_u8; 94];
    body[61] = 4;
    assert_eq!(
        Message::parse(0x83, &body),
        Err(DecodeError::OutOfRange {
            field: "Configure.decay"
        })
    );
    // A version-2 Configure (61 bytes) is a bad body.
    assert!(matches!(
        Message::parse(0x83, &body[..61]),
        Err(DecodeError::BadBody {
            msg_type: 0x83,
            len: 61
        })
    ));
}

/// Decayed (0x06): layer 0's storage rows 62, 63 and 0 (5 cells faded) and layer 3's row 10,
/// all evidence.
#[test]
fn decayed_golden() {
    let mut d = Decayed::new(1);
    assert!(d.set(
        0,
        DecayedRows {
            first: 62,
            rows: 3,
            faded: 5
        }
    ));
    assert!(d.set(
        3,
        DecayedRows {
            first: 10,
            rows: 1,
            faded: 0
        }
    ));
    assert!(!d.set(32, DecayedRows::default()));
    golden(
        0x0107,
        &Message::Decayed(d),
        "07 06 06 07 01 01 09 01 01 02 3e 02 03 02 05 01 01 02 0a 02 01 01 01 01 01 05 93 8c 1a \
         5b 00",
    );
    assert_eq!(d.len(), 2);
    assert_eq!(d.rows(3).map(|r| r.first), Some(10));
    assert_eq!(d.rows(1), None);
    // Refused: mode 0 or 4, an empty mask, a layer of no rows, a wrong length.
    let body = |mode: u8, mask: u32, rows: u16| {
        let mut b = std::vec![mode];
        b.extend_from_slice(&mask.to_le_bytes());
        for _ in 0..mask.count_ones() {
            b.extend_from_slice(&7_u16.to_le_bytes());
            b.extend_from_slice(&rows.to_le_bytes());
            b.extend_from_slice(&0_u32.to_le_bytes());
        }
        b
    };
    let range = |field| Err(DecodeError::OutOfRange { field });
    assert_eq!(Message::parse(0x06, &body(0, 1, 1)), range("Decayed.mode"));
    assert_eq!(Message::parse(0x06, &body(4, 1, 1)), range("Decayed.mode"));
    assert_eq!(Message::parse(0x06, &body(1, 0, 1)), range("Decayed.mask"));
    assert_eq!(Message::parse(0x06, &body(3, 6, 0)), range("Decayed.rows"));
    assert!(matches!(
        Message::parse(0x06, &body(1, 1, 1)[..12]),
        Err(DecodeError::BadBody { msg_type: 6, .. })
    ));
    assert!(Message::parse(0x06, &body(3, 0x8000_0001, 1024)).is_ok());
    let mut out = [0_u8; MAX_ENCODED_FRAME];
    assert!(encode(0, &Message::Decayed(Decayed::new(1)), &mut out).is_err());
    assert!(encode(0, &Message::Decayed(Decayed::new(0)), &mut out).is_err());
}

#[test]
fn hello_golden() {
    let mut layers = heapless::Vec::new();
    layers
        .push(LayerInfo {
            resolution_q16: 6554,
            band_inner_m: 0.0,
            band_outer_m: 0.5,
            origin_x: -32,
            origin_y: -32,
        })
        .unwrap();
    layers
        .push(LayerInfo {
            resolution_q16: 13107,
            band_inner_m: 0.5,
            band_outer_m: 1.5,
            origin_x: -32,
            origin_y: -32,
        })
        .unwrap();
    let hello = Hello {
        protocol: 1,
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 2,
        },
        reason: HelloReason::Boot,
        cells_per_side: 64,
        resend: 0,
        clock: ClockSource::InternalPll,
        layers,
    };
    golden(
        0,
        &Message::Hello(hello),
        "03 06 01 01 02 01 03 01 02 03 02 40 01 01 01 01 02 02 01 01 03 9a 19 01 01 01 01 01 01 \
         01 01 0c 3f e0 ff ff ff e0 ff ff ff 33 33 01 01 01 01 02 3f 01 0f c0 3f e0 ff ff ff e0 \
         ff ff ff f5 08 21 7b 00",
    );
}

#[test]
fn layer_patch_golden_is_the_specs_worked_example() {
    let cells = hex("00 80 d9 00 00 fe 00 00");
    let patch = LayerPatch {
        area: PatchArea {
            layer: 1,
            origin_x: -32,
            origin_y: -32,
            x: 3,
            y: -4,
            width: 2,
            height: 2,
        },
        cells: PatchCells::from_le_bytes(&cells).unwrap(),
    };
    let encoded =
        "11 06 02 02 01 01 02 02 e0 ff ff ff e0 ff ff ff 03 01 01 05 fc ff ff ff 03 80 d9 01 02 \
         fe 01 05 60 79 b0 6f 00";
    golden(0x0102, &Message::LayerPatch(patch), encoded);
    let values: Vec<i16> = patch.cells.iter().collect();
    assert_eq!(values, [i16::MIN, 217, -512, 0]);
    assert_eq!(patch.cells.get(3), Some(0));
    assert_eq!(patch.cells.get(4), None);
    // The device's writer, fed cell by cell, gives the same bytes.
    let mut out = [0_u8; 64];
    let grid = [[i16::MIN, 217], [-512, 0]];
    let n = encode_patch(
        0x0102,
        &patch.area,
        |c, r| grid[usize::from(r)][usize::from(c)],
        &mut out,
    )
    .unwrap();
    assert_eq!(&out[..n], &hex(encoded)[..]);
}

#[test]
fn window_moved_stats_reply_golden() {
    let mut moved = WindowMoved::new();
    moved.set(0, (-31, -32));
    moved.set(2, (-16, -33));
    golden(
        0x0103,
        &Message::WindowMoved(moved),
        "06 06 03 03 01 05 01 01 15 e1 ff ff ff e0 ff ff ff f0 ff ff ff df ff ff ff e9 d5 02 fa \
         00",
    );
    let mut values = [0_u32; STATS_COUNTERS];
    for (i, v) in values.iter_mut().enumerate() {
        *v = i as u32 + 1;
    }
    let stats = Stats::from_array(values);
    assert_eq!(stats.uptime_ms, 1);
    assert_eq!(stats.resyncs, 27);
    assert_eq!(stats.observations, 28);
    assert_eq!(stats.laser_bytes, 29);
    assert_eq!(stats.tiles_dirty, 30);
    assert_eq!(stats.poses_stamped, 31);
    assert_eq!(stats.returns_without_pose, 35);
    assert_eq!(stats.time_requests, 36);
    assert_eq!(Stats::NAMES[30], "poses_stamped");
    assert_eq!(Stats::NAMES[35], "time_requests");
    assert_eq!(stats.returns_masked, 37);
    assert_eq!(stats.returns_low_quality, 40);
    assert_eq!(stats.observations_split, 41);
    assert_eq!(stats.returns_implausible, 42);
    assert_eq!(Stats::NAMES[41], "returns_implausible");
    golden(
        0x0104,
        &Message::Stats(stats),
        "06 06 04 04 01 01 01 01 02 02 01 01 02 03 01 01 02 04 01 01 02 05 01 01 02 06 01 01 02 \
         07 01 01 02 08 01 01 02 09 01 01 02 0a 01 01 02 0b 01 01 02 0c 01 01 02 0d 01 01 02 0e \
         01 01 02 0f 01 01 02 10 01 01 02 11 01 01 02 12 01 01 02 13 01 01 02 14 01 01 02 15 01 \
         01 02 16 01 01 02 17 01 01 02 18 01 01 02 19 01 01 02 1a 01 01 02 1b 01 01 02 1c 01 01 \
         02 1d 01 01 02 1e 01 01 02 1f 01 01 02 20 01 01 02 21 01 01 02 22 01 01 02 23 01 01 02 \
         24 01 01 02 25 01 01 02 26 01 01 02 27 01 01 02 28 01 01 02 29 01 01 02 2a 01 01 05 4f \
         ed ee 18 00",
    );
    let configure = Header {
        version: 1,
        msg_type: 0x83,
        seq: 11,
    };
    golden(
        0x0105,
        &Message::Reply(Reply::ok(configure)),
        "06 06 05 05 01 0b 02 83 01 01 01 01 01 01 01 01 01 01 01 01 01 05 d1 a5 1b a7 00",
    );
    // The refusal of layer 3's decay time constant: param 96 + 3, OutOfRange, 1 s against
    // [4, 60 097] s.
    let refusal = Reply {
        to_seq: 12,
        to_type: 0x83,
        code: ReplyCode::OutOfRange,
        param: 99,
        value: 1.0,
        a: 4.0,
        b: 60_097.0,
    };
    golden(
        0x0106,
        &Message::Reply(refusal),
        "06 06 05 06 01 0c 04 83 03 63 01 03 80 3f 01 03 80 40 08 c1 6a 47 82 2d 8e 5d 00",
    );
}

#[test]
fn sizes_match_the_spec() {
    // Section 9 of the spec: the largest frame device to host is a 32-layer Hello.
    assert_eq!(MAX_FRAME, 664);
    assert_eq!(MAX_ENCODED_FRAME, 668);
    // The largest command is a Setup (140 bytes of body; a Configure has 94).
    assert_eq!(MAX_COMMAND_FRAME, 148);
    assert_eq!(MAX_ENCODED_COMMAND, 150);
    assert_eq!(encoded_len_max(MIN_FRAME + 19 + 2 * 16 * 16), 543);
    assert_eq!(encoded_len_max(MIN_FRAME + 19 + 128), 157);
    assert_eq!(encoded_len_max(MIN_FRAME + 16 + 8 * 20), 186);
}

/// A frame with a given header and body, framed by this crate's CRC and COBS (whose own
/// vectors are checked above).
fn raw_frame(version: u8, msg_type: u8, seq: u16, body: &[u8]) -> Vec<u8> {
    let mut raw = std::vec![version, msg_type];
    raw.extend_from_slice(&seq.to_le_bytes());
    raw.extend_from_slice(body);
    let crc = crc32(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut out = std::vec![0_u8; raw.len() + 8];
    let mut enc = cobs::Encoder::new(&mut out);
    enc.push_all(&raw);
    let n = enc.finish().unwrap();
    out.truncate(n);
    out
}

/// Feeds `input` in one go and collects what came out.
fn feed_all<const N: usize>(
    acc: &mut FrameAccumulator<N>,
    mut input: &[u8],
) -> Vec<Result<u16, DecodeError>> {
    let mut out = Vec::new();
    loop {
        match acc.feed(input) {
            FeedResult::Consumed => return out,
            FeedResult::Item {
                item: Decoded { header, .. },
                remaining,
                ..
            } => {
                out.push(Ok(header.seq));
                input = remaining;
            }
            FeedResult::Rejected {
                error: Undecoded { error, .. },
                remaining,
                ..
            } => {
                out.push(Err(error));
                input = remaining;
            }
        }
    }
}

#[test]
fn bad_frames_are_refused_counted_and_the_next_frame_decodes() {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut stream = Vec::new();
    // 1. A corrupted byte: CRC.
    let mut bad = ping_frame();
    bad[6] ^= 0x40;
    stream.extend_from_slice(&bad);
    // 2. Truncated: a COBS block cut by the delimiter.
    stream.extend_from_slice(&hex("04 01 86 00"));
    // 3. Too short: a 3-byte frame.
    stream.extend_from_slice(&hex("04 01 86 01 00"));
    // 4. Unknown version, unknown type, bad body length, out-of-range field.
    // A version-2 frame (an older peer): refused whole.
    stream.extend_from_slice(&raw_frame(2, 0x86, 3, &[]));
    stream.extend_from_slice(&raw_frame(VERSION, 0x7E, 4, &[]));
    stream.extend_from_slice(&raw_frame(VERSION, 0x86, 5, &[0]));
    stream.extend_from_slice(&raw_frame(
        VERSION,
        0x01,
        6,
        &[2, 0, 0, 0, 9, 0, 64, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    ));
    // 5. Oversized: more than the buffer holds.
    stream.extend_from_slice(&[0x55; 700]);
    stream.push(0);
    // 6. Spare delimiters are not errors; then a good frame.
    stream.extend_from_slice(&[0, 0]);
    stream.extend_from_slice(&ping_frame());
    let got = feed_all(&mut acc, &stream);
    assert!(matches!(got[0], Err(DecodeError::Crc { .. })));
    assert_eq!(got[1], Err(DecodeError::Cobs));
    assert_eq!(got[2], Err(DecodeError::TooShort { len: 3 }));
    assert_eq!(got[3], Err(DecodeError::UnknownVersion(2)));
    assert_eq!(got[4], Err(DecodeError::UnknownType(0x7E)));
    assert_eq!(
        got[5],
        Err(DecodeError::BadBody {
            msg_type: 0x86,
            len: 1
        })
    );
    assert_eq!(
        got[6],
        Err(DecodeError::OutOfRange {
            field: "Hello.reason"
        })
    );
    assert_eq!(got[7], Err(DecodeError::TooLong { max: MAX_FRAME }));
    assert_eq!(got[8], Ok(1));
    assert_eq!(got.len(), 9);
    let c = acc.counters();
    assert_eq!(
        (
            c.crc,
            c.cobs,
            c.too_short,
            c.unknown_version,
            c.unknown_type
        ),
        (1, 1, 1, 1, 1)
    );
    assert_eq!((c.bad_body, c.out_of_range, c.too_long), (1, 1, 1));
    assert_eq!((c.frames_ok, c.errors()), (1, 8));
}

#[test]
fn frames_split_anywhere_reassemble() {
    let mut stream = Vec::new();
    for seq in 0..5_u16 {
        let mut out = [0_u8; 32];
        let n = encode(
            seq,
            &Message::RequestSnapshot(SnapshotScope::Layer(3)),
            &mut out,
        )
        .unwrap();
        stream.extend_from_slice(&out[..n]);
    }
    for chunk in 1..stream.len() {
        let mut acc = FrameAccumulator::<MAX_COMMAND_FRAME>::new();
        let mut seqs = Vec::new();
        for piece in stream.chunks(chunk) {
            seqs.extend(feed_all(&mut acc, piece));
        }
        assert_eq!(seqs, [Ok(0), Ok(1), Ok(2), Ok(3), Ok(4)], "chunk {chunk}");
    }
}

#[test]
fn a_garbage_prefix_costs_one_frame() {
    // Opening the port mid-frame: the tail of some frame, then good frames.
    let mut stream = hex("13 77 02 41");
    stream.extend_from_slice(&ping_frame());
    stream.extend_from_slice(&ping_frame());
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let got = feed_all(&mut acc, &stream);
    assert_eq!(got.len(), 2);
    assert!(got[0].is_err());
    assert_eq!(got[1], Ok(1));
}

#[test]
fn encoders_refuse_what_the_format_cannot_carry() {
    let mut out = [0_u8; MAX_ENCODED_FRAME];
    let cells = [0_u8; 2 * 17];
    let wide = LayerPatch {
        area: PatchArea {
            layer: 0,
            origin_x: 0,
            origin_y: 0,
            x: 0,
            y: 0,
            width: 17,
            height: 1,
        },
        cells: PatchCells::from_le_bytes(&cells).unwrap(),
    };
    assert_eq!(
        encode(0, &Message::LayerPatch(wide), &mut out),
        Err(EncodeError::Invalid {
            field: "LayerPatch.width"
        })
    );
    let short = LayerPatch {
        area: PatchArea {
            width: 2,
            ..wide.area
        },
        cells: PatchCells::from_le_bytes(&cells[..2]).unwrap(),
    };
    assert!(encode(0, &Message::LayerPatch(short), &mut out).is_err());
    assert!(encode(0, &Message::WindowMoved(WindowMoved::new()), &mut out).is_err());
    assert!(encode(
        0,
        &Message::RequestSnapshot(SnapshotScope::Layer(255)),
        &mut out
    )
    .is_err());
    assert_eq!(
        encode(1, &Message::Ping, &mut out[..9]),
        Err(EncodeError::BufferTooSmall { needed: 10, got: 9 })
    );
}

/// Setup (`docs/protocol.md`, "0x87 Setup" and the worked example of section 10): tilted
/// horizontal, mode 0, 180° at 0.5°, sensor (0.25, −0.5, 0.75) m, per sweep, robot height
/// 1 m, step 0.05 m, drop off, ceiling 2 m; then the empty commands 0x88 ..= 0x8A.
#[test]
fn setup_and_the_empty_commands_golden() {
    let setup = examples::sick_setup(RuleSetup::SPREAD);
    golden(
        7,
        &Message::Setup(setup),
        "04 06 87 07 02 01 02 b4 02 32 01 01 03 80 3e 01 01 02 bf 01 03 40 3f 01 01 01 01 01 07 \
         80 3f cd cc 4c 3d 01 01 01 01 01 01 02 40 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         02 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 05 \
         d5 dc 62 26 00",
    );
    golden(2, &Message::RequestStats, "04 06 88 02 05 7a a8 3f d9 00");
    golden(2, &Message::Shutdown, "04 06 89 02 05 4d c2 fd d8 00");
    golden(2, &Message::EndObservation, "04 06 8a 02 05 14 7c bb da 00");
    // A Setup body one byte short is a bad body; so is a version-2 Setup (38 bytes), a
    // Setup of version 3 before its rule block (60 bytes), one of version 4 (81 bytes) and
    // one of version 5 (139 bytes).
    assert_bad_bodies(0x87, &[139, 81, 60, 38]);
}

/// SetRule (0x8B, `docs/protocol.md`, "0x8B SetRule"): the paper's rule with a 0.08 m step,
/// then the default plane rule with the default step, 3 277 / 2¹⁶ m (frames from
/// `host/tests/py/link_setup.py`).
#[test]
fn set_rule_golden() {
    golden(
        9,
        &Message::SetRule(SetRule {
            step_threshold_m: 0.08,
            rule: RuleSetup::SPREAD,
        }),
        "04 06 8b 09 05 0a d7 a3 3d 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 05 c2 85 b9 d0 00",
    );
    // The plane rule with its defaults (what a build with the plane-rule feature defaults to).
    let default = crate::link::convert::set_rule_message(&crate::classify::ClassifierConfig {
        rule: crate::classify::NavigabilityRule::Plane(crate::classify::PlaneRule::DEFAULT),
        ..crate::classify::ClassifierConfig::DEFAULT
    });
    golden(
        10,
        &Message::SetRule(default),
        "04 06 8b 0a 01 05 d0 4c 3d 01 04 5a ba 3e 04 c0 75 3c 04 e0 a3 3c 01 03 ac 3a 01 01 07 \
         40 01 41 a0 d1 31 00",
    );
    // The same for a spinning multi-beam laser in firing order: pair depth 3 (version 6).
    let firing = crate::link::convert::set_rule_message(&crate::classify::ClassifierConfig {
        rule: crate::classify::NavigabilityRule::Plane(
            crate::classify::PlaneRule::DEFAULT
                .with_pair_depth(crate::classify::FIRING_ORDER_PAIR_DEPTH),
        ),
        ..crate::classify::ClassifierConfig::DEFAULT
    });
    golden(
        14,
        &Message::SetRule(firing),
        "04 06 8b 0e 01 05 d0 4c 3d 01 04 5a ba 3e 04 c0 75 3c 04 e0 a3 3c 01 03 ac 3a 01 01 07 \
         40 03 19 35 08 d9 00",
    );
    // A version-5 SetRule (25 bytes: no pair depth) is a bad body, as is one byte more.
    assert_bad_bodies(0x8B, &[25, 27]);
}

/// The laser block of version 3 (`docs/protocol.md`, "0x87 Setup", the second worked
/// example): an LD06 at its default rate on a nodding servo from −10° to 30° at 60 °/s with
/// 25 ms of latency, tilted horizontal, 0.4 m up, two revolutions per observation, robot
/// height 0.5 m, step 0.08 m, drop and ceiling off; the SICK fields zero (ignored).
#[test]
fn setup_with_a_lidar_on_a_servo_golden() {
    let setup = examples::lidar_on_a_servo_setup(RuleSetup {
        rule: 1,
        // The Q16.16 defaults, exact in f32.
        max_grade: 23_853.0 / 65_536.0,
        residual_m: 983.0 / 65_536.0,
        range_sigma_m: 1_311.0 / 65_536.0,
        angle_sigma_rad: 86.0 / 65_536.0,
        noise_factor: 2.0,
        pair_depth: 1,
    });
    golden(
        8,
        &Message::Setup(setup),
        "04 06 87 08 02 01 01 01 01 01 05 cd cc cc 3d 01 01 01 06 cd cc cc 3e 02 01 01 01 01 01 \
         06 3f 0a d7 a3 3d 01 01 01 01 01 01 01 02 01 04 5a ba 3e 04 c0 75 3c 04 e0 a3 3c 01 03 \
         ac 3a 01 01 05 40 01 01 01 01 01 01 01 01 03 20 c1 01 03 f0 41 01 03 70 42 01 03 c8 41 \
         02 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 05 \
         40 f1 b8 be 00",
    );
    // The rule block is the library's default plane rule, bit for bit.
    assert_eq!(
        setup.rule,
        crate::link::convert::rule_setup(&crate::classify::NavigabilityRule::Plane(
            crate::classify::PlaneRule::DEFAULT
        ))
    );
    assert_eq!((SETUP_RULE_LEN, SETUP_LASER_LEN), (22, 22));
}

/// A version-2 frame (the Ping of version 2's worked example, whose CRC is good) is refused
/// whole as an unknown version.
#[test]
fn a_version_2_frame_is_refused() {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let got = feed_all(&mut acc, &hex("04 02 86 01 05 e4 41 ee 77 00"));
    assert_eq!(got, [Err(DecodeError::UnknownVersion(2))]);
    assert_eq!(acc.counters().unknown_version, 1);
}

/// A version-3 frame (the Ping of version 3's worked example, whose CRC is good) is refused
/// whole as an unknown version: a version-3 peer gets no silent garbage.
#[test]
fn a_version_3_frame_is_refused() {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let got = feed_all(&mut acc, &hex("04 03 86 01 05 81 26 52 cf 00"));
    assert_eq!(got, [Err(DecodeError::UnknownVersion(3))]);
    assert_eq!(acc.counters().unknown_version, 1);
    // The same Ping of this version decodes.
    assert_eq!(feed_all(&mut acc, &ping_frame()), [Ok(1)]);
}

/// A version-4 frame (a Ping under the version-4 header, its CRC good) is refused whole as
/// an unknown version: a version-4 peer, whose Setup has no mount or filter block, gets no
/// silent garbage.
#[test]
fn a_version_4_frame_is_refused() {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let got = feed_all(&mut acc, &hex("04 04 86 01 05 38 1e 85 52 00"));
    assert_eq!(got, [Err(DecodeError::UnknownVersion(4))]);
    assert_eq!(
        std::format!("{}", DecodeError::UnknownVersion(4)),
        "unknown protocol version 4 (this side speaks 6)"
    );
}

/// A version-5 frame (the Ping of version 5's worked example, its CRC good) is refused whole
/// as an unknown version: a version-5 peer, whose rule block has no pair depth, gets no
/// silent garbage.
#[test]
fn a_version_5_frame_is_refused() {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let got = feed_all(&mut acc, &hex("04 05 86 01 05 5d 79 39 ea 00"));
    assert_eq!(got, [Err(DecodeError::UnknownVersion(5))]);
    assert_eq!(acc.counters().unknown_version, 1);
    assert_eq!(feed_all(&mut acc, &ping_frame()), [Ok(1)]);
}

/// The mount and filter blocks of version 5 (`docs/protocol.md`, "0x87 Setup", the third
/// worked example): the general mount (2), an LD19 upside down with its 0° to the left (roll
/// 180°, yaw 90°) on a tilt servo (axis 1) that reports the other way (sense −1) with its zero
/// at 5°; masked 135° ..< 225° and 350° ..< 10°, ranges 5 cm ..= 12 m, quality at least 10.
/// The frame from `docs/link_golden.py`.
#[test]
fn setup_with_a_general_mount_and_filters_golden() {
    let mut sectors = [(0, 0); crate::wire::link::SETUP_SECTORS];
    sectors[0] = (13_500, 22_500);
    sectors[1] = (35_000, 1_000);
    let setup = Setup {
        mount: 2,
        mount_block: examples::GENERAL_MOUNT,
        filter: examples::filter(2, sectors),
        ..examples::lidar_on_a_servo_setup(RuleSetup::SPREAD)
    };
    golden(
        13,
        &Message::Setup(setup),
        "04 06 87 0d 02 02 01 01 01 01 05 cd cc cc 3d 01 01 01 06 cd cc cc 3e 02 01 01 01 01 01 \
         06 3f 0a d7 a3 3d 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 \
         01 01 01 01 01 01 03 01 01 01 01 01 01 01 03 20 c1 01 03 f0 41 01 03 70 42 01 05 c8 41 \
         01 ff 01 01 01 03 a0 40 01 03 34 43 01 01 01 01 01 04 b4 42 05 0d b0 04 0a 02 bc 34 e4 \
         57 b8 88 e8 03 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 05 \
         2e 4b 45 a1 00",
    );
    assert_eq!(
        (
            crate::wire::link::SETUP_MOUNT_LEN,
            crate::wire::link::SETUP_FILTER_LEN
        ),
        (20, 38)
    );
}

/// A stamped Pose (flags bit 0, `docs/protocol.md`, "0x81 Pose"): the robot at (1.5, −2.25,
/// 0.125) m, pitch 0.25, yaw −1.5 rad, at 4 000 000 µs of the device's clock. Frames from
/// `docs/link_golden.py`.
#[test]
fn stamped_pose_golden() {
    let pose = PoseReport {
        x_m: 1.5,
        y_m: -2.25,
        z_m: 0.125,
        roll_rad: 0.0,
        pitch_rad: 0.25,
        yaw_rad: -1.5,
        stamp_us: 4_000_000,
        flags: POSE_STAMPED,
    };
    assert!(pose.is_stamped());
    golden(
        11,
        &Message::Pose(pose),
        "04 06 81 0b 01 01 03 c0 3f 01 03 10 c0 01 01 02 3e 01 01 01 01 01 03 80 3e 01 03 c0 bf \
         03 09 3d 06 01 96 b1 52 c9 00",
    );
    // Flags are carried as they are (the device validates them), a version-3 body (28 bytes)
    // and a byte too many are bad bodies.
    let mut body = [0_u8; 29];
    body[28] = 0x82;
    match Message::parse(0x81, &body) {
        Ok(Message::Pose(p)) => assert_eq!((p.flags, p.is_stamped()), (0x82, false)),
        other => panic!("{other:?}"),
    }
    assert_bad_bodies(0x81, &[28, 30]);
}

/// TimeRequest (0x8C), TimeReply (0x07) and Observed (0x08): frames from
/// `docs/link_golden.py`; any other body length is refused.
#[test]
fn time_messages_golden() {
    let host_us = 1_234_567_890_123;
    golden(
        12,
        &Message::TimeRequest(TimeRequest { host_us }),
        "04 06 8c 0c 07 cb 04 fb 71 1f 01 01 05 70 56 f3 92 00",
    );
    golden(
        0x0108,
        &Message::TimeReply(TimeReply {
            host_us,
            device_us: 4_000_123,
            queued_ahead: 300,
        }),
        "0b 06 07 08 01 cb 04 fb 71 1f 01 01 04 7b 09 3d 07 2c 01 74 ef b9 25 00",
    );
    golden(
        0x0109,
        &Message::Observed(Observed {
            observation: 42,
            first_us: 3_990_000,
            last_us: 4_090_000,
        }),
        "06 06 08 09 01 2a 01 01 04 f0 e1 3c 04 90 68 3e 05 14 e5 20 62 00",
    );
    for (msg_type, len) in [(0x8C, 8), (0x07, 14), (0x08, 12)] {
        assert_bad_bodies(msg_type, &[len - 1, len + 1, 0]);
    }
    assert!(MessageType::TimeRequest.is_command());
    assert!(!MessageType::TimeReply.is_command() && !MessageType::Observed.is_command());
}
