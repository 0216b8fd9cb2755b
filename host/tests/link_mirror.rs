//! The host link's mirror end to end: old frames are refused and gaps ask for a snapshot;
//! after lossy streams (with and without decay) and snapshot recovery the host's mirror equals
//! the device's pyramid cell for cell; devices of another protocol version are refused and
//! named; time replies and observed frames become events. The frames themselves: `link.rs`.
#[path = "support/device.rs"]
mod support;

use proptest::prelude::*;
use support::{each_request, hello_message, scatter, wander, Channel, Rng};
use terrain_pyramid::design::{Schedule, SensorModel};
use terrain_pyramid::link::{Command, Link, LinkConfig, SensorCounters};
use terrain_pyramid::wire::link::{
    encode, DecodeError, Header, LayerPatch, Message, PatchArea, PatchCells, Reply, SnapshotScope,
    MAX_ENCODED_FRAME,
};
use terrain_pyramid::{
    Config, Decay, DecayMode, DefaultDesign, DefaultPyramid, Meters, TimeConstant,
    DEFAULT_CELLS_PER_SIDE,
};
use terrain_pyramid_host::link::{HostLink, LinkEvent};

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
    each_request(link, bytes, |link, request| {
        commands.push(request.command.clone());
        link.serve(pyramid, request);
    });
    commands
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

    // One 13 ms step of the line: the device's link polled, its bytes carried to the host
    // (through the channel when `lossy`).
    let mut step = |pyramid: &mut DefaultPyramid,
                    link: &mut Link<Q>,
                    host: &mut HostLink,
                    rng: &mut Rng,
                    lossy: bool| {
        now_ms += 13;
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
        step(&mut pyramid, &mut link, &mut host, &mut rng, true);
    }
    // Settle over a clean line.
    let mut settled = false;
    for _ in 0..5000 {
        step(&mut pyramid, &mut link, &mut host, &mut rng, false);
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
    assert!(hint.contains("version 6"), "{hint}");
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

/// A version-5 device (the release before the pair depth): its frames are refused whole and
/// the host names both versions. The Reply Ok to Configure of the version-5 worked examples
/// (`docs/link_golden.py` with version 5), whose CRC is good.
#[test]
fn a_version_5_device_is_refused_and_named() {
    let mut host = HostLink::new();
    // Reply Ok to configure 11, seq 0x0105, version 5.
    let v5 = [
        0x06, 0x05, 0x05, 0x05, 0x01, 0x0b, 0x02, 0x83, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
        0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x05, 0x32, 0x27, 0x05, 0xdc, 0x00,
    ];
    let events = host.feed(&v5);
    assert!(events
        .iter()
        .all(|e| matches!(e, LinkEvent::BadFrame(DecodeError::UnknownVersion(5)))));
    let rx = host.rx_counters();
    assert_eq!((rx.unknown_version, rx.frames_ok), (1, 0));
    let hint = terrain_pyramid_host::link::version_hint(&rx);
    assert!(hint.contains("do not match"), "{hint}");
    assert!(
        hint.contains("version 6") && hint.contains("version 5"),
        "{hint}"
    );
}

/// The frames of version 4 that carry the device's clock become events and leave the mirror
/// as it is.
#[test]
fn time_replies_and_observed_frames_become_events() {
    use terrain_pyramid::wire::link::{Observed, TimeReply};
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
    let mut host = HostLink::new();
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
