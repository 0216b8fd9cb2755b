//! Writes the seed corpus of the cargo-fuzz targets (`fuzz/README.md`) from the library's own
//! encoders: SICK telegrams (the CRC test vectors, a 0xB0 scan, replies), link frames of every
//! message type (commands, and a real device's Hello, patches and Stats), configurations, a
//! small recording, and spinning-lidar streams (the LD06 manual's example packet, RPLIDAR
//! descriptors, responses, nodes and capsules, YDLIDAR X4 packets). Each file is in its
//! target's input format (see the target's doc comment).
//!
//! `cargo run -p terrain-pyramid-host-tests --example fuzz_seeds -- fuzz/corpus`
use std::fs;
use std::path::Path;

use terrain_pyramid::link::convert::configure_of_design;
use terrain_pyramid::link::{Link, SensorCounters};
use terrain_pyramid::wire::link::{
    cobs, encode, ClampRequest, Configure, GateRequest, Message, PanAngle, PoseReport,
    SnapshotScope, MAX_ENCODED_FRAME,
};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{emit_header, Event, MountKind, Payload};
use terrain_pyramid::wire::sick::{emit_telegram, ADDRESS_REPLY};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Evidence, EvidenceClass, Meters, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};

/// The SICK CRC test vectors (requests, address 0x00) of `src/wire/sick/crc.rs`, CRC appended.
const SICK_VECTORS: &[&[u8]] = &[
    &[0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08],
    &[0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08],
    &[0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08],
    &[0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12],
    &[
        0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F,
    ],
];

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    fs::create_dir_all(dir).unwrap();
    fs::write(dir.join(name), bytes).unwrap();
}

/// A damaged stream: `garbage`, then `good` with bit mask `flip` XORed into its byte `at`,
/// then `good` intact, then its first `cut` bytes.
fn damaged_stream(garbage: &[u8], good: &[u8], (at, flip): (usize, u8), cut: usize) -> Vec<u8> {
    let mut flipped = good.to_vec();
    flipped[at] ^= flip;
    [garbage, &flipped, good, &good[..cut]].concat()
}

fn reply(payload: &[u8]) -> Vec<u8> {
    let mut buf = vec![0_u8; 818];
    let n = emit_telegram(ADDRESS_REPLY, payload, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// A 0xB0 payload of 361 values (a 180°/0.5° scan): floor and a wall, flag bit 13 set.
fn b0_payload() -> Vec<u8> {
    let mut p = vec![0xB0];
    p.extend_from_slice(&361_u16.to_le_bytes());
    for i in 0..361_u32 {
        let mm = 800 + (i * 37) % 3000;
        p.extend_from_slice(&((mm as u16) | 0x2000).to_le_bytes());
    }
    p.push(0x10);
    p
}

/// The decoded frame (version, type, seq, body, CRC) of one encoded frame.
fn unstuff(encoded: &[u8]) -> Vec<u8> {
    let mut d = cobs::Decoder::new();
    let mut out = Vec::new();
    for &b in encoded {
        match d.step(b) {
            cobs::Step::Byte(x) => out.push(x),
            cobs::Step::End | cobs::Step::Error => break,
            cobs::Step::None => {}
        }
    }
    out
}

/// Every frame of an encoded stream, decoded.
fn frames(stream: &[u8]) -> Vec<Vec<u8>> {
    stream
        .split_inclusive(|&b| b == 0)
        .map(unstuff)
        .filter(|f| f.len() >= 8)
        .collect()
}

/// One segment of `common::link_stream`: a valid frame of `raw`'s type and body.
fn segment(raw: &[u8]) -> Vec<u8> {
    let body = &raw[4..raw.len() - 4];
    let len = u8::try_from(body.len()).unwrap_or(255);
    let mut out = vec![0, raw[1], len];
    out.extend_from_slice(&body[..usize::from(len)]);
    out
}

fn encoded(message: &Message<'_>) -> Vec<u8> {
    let mut out = vec![0_u8; MAX_ENCODED_FRAME];
    let n = encode(1, message, &mut out).unwrap();
    out.truncate(n);
    out
}

fn device_output() -> Vec<u8> {
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap();
    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut link: Box<Link> = Box::default();
    pyramid.configure(&design, &Config::default()).unwrap();
    link.adopt(&design);
    for i in 0..8 {
        pyramid.apply(&Evidence {
            layer: 0,
            cell_x: i,
            cell_y: -i,
            class: EvidenceClass::Obstacle,
            weight: terrain_pyramid::Weight::ONE,
        });
    }
    let mut out = Vec::new();
    let mut buf = [0_u8; 512];
    for t in 0..3 {
        pyramid.recentre(Meters::from_num(t), Meters::ZERO);
        link.poll(1000 * t, &mut pyramid, &SensorCounters::default());
        loop {
            let n = link.pop_bytes(&mut buf);
            if n == 0 {
                break;
            }
            out.extend_from_slice(&buf[..n]);
        }
    }
    out
}

fn main() {
    let root = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "fuzz/corpus".into());
    let root = Path::new(&root);

    // sick_accumulator: [n % 9 chunk sizes][sizes][stream].
    let dir = root.join("sick_accumulator");
    let b0 = reply(&b0_payload());
    let a0 = reply(&[0xA0, 0x00, 0x10]);
    let bb = reply(&[0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10]);
    write(&dir, "b0_whole", &[&[0][..], &b0].concat());
    write(&dir, "b0_chunked", &[&[3, 1, 7, 64][..], &b0].concat());
    write(
        &dir,
        "ack_a0_nak",
        &[&[0, 0x06][..], &a0, &[0x15], &bb].concat(),
    );
    let mut vectors = vec![2, 5, 2];
    for v in SICK_VECTORS {
        vectors.extend_from_slice(v);
    }
    write(&dir, "crc_vectors", &vectors);
    let mut damaged = vec![1, 9, 0xAA, 0x02, 0x80, 0x10, 0x00, 0xBB, 0x06];
    damaged.extend_from_slice(&a0);
    let mut cut = b0.clone();
    cut.truncate(100);
    damaged.extend_from_slice(&cut);
    damaged.extend_from_slice(&b0);
    let mut flipped = b0.clone();
    flipped[200] ^= 0x10;
    damaged.extend_from_slice(&flipped);
    damaged.extend_from_slice(&[0x02, 0x80, 0xFF, 0xFF, 0x02]);
    damaged.extend_from_slice(&a0);
    write(&dir, "damaged", &damaged);

    // link_device_rx: [n][sizes][segments]; link_host_rx: [n][sizes][mode][segments or raw].
    let default_design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap();
    let configure = configure_of_design(&default_design, &Config::default());
    let hard = Configure {
        gate: GateRequest::Hard,
        gamma: 3.0,
        clamp: ClampRequest::Off,
        ..configure
    };
    let bad = Configure {
        cells_per_side: 63,
        ..configure
    };
    let commands = [
        Message::Ping,
        Message::Reset,
        Message::RequestSnapshot(SnapshotScope::All),
        Message::RequestSnapshot(SnapshotScope::Layer(2)),
        Message::Pose(PoseReport {
            x_m: 1.5,
            y_m: -2.0,
            z_m: 0.0,
            roll_rad: 0.0,
            pitch_rad: 0.01,
            yaw_rad: 0.5,
            stamp_us: 1234,
            flags: 0,
        }),
        Message::PanAngle(PanAngle {
            turns: 0x4000,
            timestamp_ms: 99,
        }),
        Message::Configure(configure),
        Message::Configure(hard),
        Message::Configure(bad),
    ];
    let dir = root.join("link_device_rx");
    let mut all = vec![0];
    for (i, message) in commands.iter().enumerate() {
        let raw = unstuff(&encoded(message));
        let seg = segment(&raw);
        write(&dir, &format!("command_{i}"), &[&[0][..], &seg].concat());
        all.extend_from_slice(&seg);
    }
    write(&dir, "all_commands", &all);
    let mut raw_ping = vec![0, 1, 1, 10];
    raw_ping.extend_from_slice(&encoded(&Message::Ping));
    write(&dir, "raw_ping", &raw_ping);

    let dir = root.join("link_host_rx");
    let output = device_output();
    write(&dir, "device_raw", &[&[0, 1][..], &output].concat());
    write(
        &dir,
        "device_raw_chunked",
        &[&[2, 5, 61, 1][..], &output].concat(),
    );
    let mut segments = vec![0, 0];
    for raw in frames(&output) {
        if raw.len() - 8 <= 255 {
            segments.extend_from_slice(&segment(&raw));
        }
    }
    write(&dir, "device_segments", &segments);

    // config_validator: 15 f32, u16 cells, flags, nice.
    let dir = root.join("config_validator");
    let fields = [
        0.5_f32.to_radians(),
        2.0_f32.to_radians(),
        0.15,
        1.0,
        10.0,
        0.1,
        2.0,
        0.5,
        0.7,
        0.4,
        0.5,
        -2.0,
        3.5,
        0.0,
        0.0,
    ];
    let config = |fields: &[f32; 15], cells: u16, flags: u8, nice: u8| {
        let mut out: Vec<u8> = fields.iter().flat_map(|f| f.to_le_bytes()).collect();
        out.extend_from_slice(&cells.to_le_bytes());
        out.extend_from_slice(&[flags, nice]);
        out
    };
    write(&dir, "default", &config(&fields, 64, 0, 0));
    write(&dir, "default_nice", &config(&fields, 64, 0, 0xFF));
    write(&dir, "hard_uniform", &config(&fields, 256, 3, 0));
    let mut far = fields;
    far[4] = 80.0;
    far[6] = 1.5;
    write(&dir, "far", &config(&far, 1024, 0, 0));

    // recording_reader: [mode][file]; mode odd puts a header in front.
    let dir = root.join("recording_reader");
    let mut file = vec![0_u8; 16];
    emit_header(&mut file).unwrap();
    let setup = Setup {
        mount: MountKind::TiltedHorizontal,
        measuring_mode: 0,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.0, 0.0, 0.5],
        lines_per_observation: 4,
    };
    let events = [
        Event {
            time_us: 0,
            payload: Payload::Setup(setup),
        },
        Event {
            time_us: 10,
            payload: Payload::Pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.3]),
        },
        Event {
            time_us: 20,
            payload: Payload::Angle(0x1000),
        },
        Event {
            time_us: 30,
            payload: Payload::Laser(&b0),
        },
        Event {
            time_us: 40,
            payload: Payload::Marker(7),
        },
        Event {
            time_us: 50,
            payload: Payload::Unknown {
                kind: 0x42,
                data: &[1, 2, 3],
            },
        },
    ];
    for event in &events {
        let mut buf = vec![0_u8; event.buffer_len()];
        event.emit(&mut buf).unwrap();
        file.extend_from_slice(&buf);
    }
    write(&dir, "small", &[&[0][..], &file].concat());
    write(&dir, "small_no_header", &[&[1][..], &file[16..]].concat());

    // pipeline_line: 32-byte header, then lines [flags, actuator u32, len u16, bytes].
    let dir = root.join("pipeline_line");
    let mut header = [0_u8; 32];
    header[0] = 1; // tilted horizontal
    header[3] = 2; // two lines per observation
    header[4..6].copy_from_slice(&100_i16.to_le_bytes()); // robot height 1 m
    header[6..8].copy_from_slice(&5_i16.to_le_bytes()); // step 5 cm
    header[16..18].copy_from_slice(&50_i16.to_le_bytes()); // sensor 0.5 m up
    let payload = b0_payload();
    let mut seed = header.to_vec();
    for t in 0..4_u32 {
        seed.push(0);
        seed.extend_from_slice(&(t * 0x0100_0000).to_le_bytes());
        seed.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        seed.extend_from_slice(&payload);
    }
    write(&dir, "raw_b0", &seed);
    let mut seed = header.to_vec();
    for t in 0..4_u32 {
        seed.push(1 | (t as u8 & 3) << 1);
        seed.extend_from_slice(&(t * 0x0080_0000).to_le_bytes());
        seed.extend_from_slice(&4_u16.to_le_bytes());
        seed.extend_from_slice(&[0x20, 0x23, 0xE8, 0x03]);
    }
    write(&dir, "synth", &seed);

    lidar_seeds(root);
}

/// The LD06 manual's example packet (§3.3).
const LD06_EXAMPLE: [u8; 47] = [
    0x54, 0x2C, 0x68, 0x08, 0xAB, 0x7E, 0xE0, 0x00, 0xE4, 0xDC, 0x00, 0xE2, 0xD9, 0x00, 0xE5, 0xD5,
    0x00, 0xE3, 0xD3, 0x00, 0xE4, 0xD0, 0x00, 0xE9, 0xCD, 0x00, 0xE4, 0xCA, 0x00, 0xE2, 0xC7, 0x00,
    0xE9, 0xC5, 0x00, 0xE5, 0xC2, 0x00, 0xE5, 0xC0, 0x00, 0xE5, 0xBE, 0x82, 0x3A, 0x1A, 0x50,
];

/// Seeds of `ld06_accumulator`, `rplidar_accumulator` and `ydlidar_accumulator`:
/// `[n % 9][n chunk sizes][stream]`, and for the RPLIDAR target a mode byte before the stream
/// (0 expects a descriptor, 1 joins a node stream, 2 a capsule stream).
fn lidar_seeds(root: &Path) {
    use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
    use terrain_pyramid::wire::rplidar::{
        RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarHealthRepr, RplidarInfoRepr,
        RplidarNodeRepr,
    };
    use terrain_pyramid_host_tests::sim::lidar::ydlidar_packet_bytes;

    // ld06_accumulator.
    let dir = root.join("ld06_accumulator");
    write(&dir, "manual_example", &[&[0][..], &LD06_EXAMPLE].concat());
    let mut revolution = vec![3, 1, 46, 5];
    for k in 0..8_u16 {
        let start = (35_000 + 500 * k) % 36_000;
        let repr = Ld06Repr {
            speed_deg_per_s: 3600,
            start_angle_centideg: start,
            end_angle_centideg: (start + 480) % 36_000,
            timestamp_ms: 100 * k,
            points: [Ld06Point {
                distance_mm: 1000 + k,
                intensity: 200,
            }; 12],
        };
        let mut b = [0; 47];
        repr.emit(&mut b).unwrap();
        revolution.extend_from_slice(&b);
    }
    write(&dir, "across_360", &revolution);
    let garbage = [&[2, 7, 13, 0x54, 0x2C, 0x54, 0x00][..], &LD06_EXAMPLE[..30]].concat();
    let damaged = damaged_stream(&garbage, &LD06_EXAMPLE, (20, 0x04), 12);
    write(&dir, "damaged", &damaged);

    // ydlidar_accumulator: the scan descriptor, a zero packet, the X4 manual's example
    // header (LSN 0x28, FSA 0x6FE5, LSA 0x79BD) with 40 samples, device information.
    let dir = root.join("ydlidar_accumulator");
    let packet = |ct: u8, first: u16, last: u16, samples: &[u16]| {
        ydlidar_packet_bytes(ct, first, last, samples).unwrap()
    };
    let samples: Vec<u16> = (0..40).map(|i| 4000 + 37 * i).collect();
    let mut scan = vec![0, 0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
    scan.extend(packet(1, 0x37F2, 0x37F2, &[800]));
    scan.extend(packet(0, 0x6FE5 >> 1, 0x79BD >> 1, &samples));
    scan.extend(packet(0, 22_900, 200, &samples[..20]));
    write(&dir, "scan", &scan);
    let mut info = vec![1, 5, 0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x04, 0x04];
    info.extend((0..19).map(|i| i as u8));
    info.extend_from_slice(&[0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x06, 0, 0, 0]);
    write(&dir, "info_health", &info);
    let garbage = [3, 1, 9, 90, 0xAA, 0x55, 0x00, 0x00, 0xAA];
    let damaged = damaged_stream(&garbage, &packet(0, 100, 740, &samples), (33, 0x80), 50);
    write(&dir, "damaged", &damaged);

    // rplidar_accumulator.
    let dir = root.join("rplidar_accumulator");
    let descriptor = |d: RplidarDescriptorRepr| {
        let mut b = vec![0; 7];
        d.emit(&mut b).unwrap();
        b
    };
    let node = |i: u16| {
        let mut b = [0; 5];
        RplidarNodeRepr {
            quality: (i % 64) as u8,
            start: i == 0,
            angle_q6: (i * 53) % 23_040,
            distance_q2: 2000 + 7 * i,
        }
        .emit(&mut b)
        .unwrap();
        b
    };
    let capsule = |start: u16, flag: bool| {
        let mut repr = RplidarCapsuleRepr {
            start_angle_q6: start,
            start_flag: flag,
            ..RplidarCapsuleRepr::default()
        };
        for k in 0..32 {
            repr.distances_mm[k] = 1500 + 3 * k as u16;
            repr.angle_offsets_q3[k] = (k as u8 * 5) % 64;
        }
        let mut b = [0; 84];
        repr.emit(&mut b).unwrap();
        b
    };
    let mut session = vec![0, 0];
    session.extend(descriptor(RplidarDescriptorRepr::HEALTH));
    let mut h = [0; 3];
    RplidarHealthRepr::default().emit(&mut h).unwrap();
    session.extend_from_slice(&h);
    session.extend(descriptor(RplidarDescriptorRepr::INFO));
    let mut info = [0; 20];
    RplidarInfoRepr {
        model: 0x18,
        firmware_minor: 29,
        firmware_major: 1,
        hardware: 7,
        serial_number: [0xAB; 16],
    }
    .emit(&mut info)
    .unwrap();
    session.extend_from_slice(&info);
    session.extend(descriptor(RplidarDescriptorRepr::SCAN));
    for i in 0..40 {
        session.extend_from_slice(&node(i));
    }
    write(&dir, "health_info_scan", &session);
    let mut express = vec![2, 84, 3, 0];
    express.extend(descriptor(RplidarDescriptorRepr::EXPRESS_SCAN));
    for (i, s) in [23_000_u16, 22, 300, 620, 940].into_iter().enumerate() {
        express.extend_from_slice(&capsule(s, i == 0));
    }
    write(&dir, "express", &express);
    let mut nodes = vec![1, 3, 1, 0x00, 0x13];
    for i in 0..60 {
        let mut n = node(i);
        if i == 20 {
            n[1] ^= 1;
        }
        nodes.extend_from_slice(&n);
    }
    write(&dir, "joined_nodes", &nodes);
    let mut caps = vec![0, 2];
    caps.extend_from_slice(&capsule(100, false)[40..]);
    for s in [200_u16, 520, 840] {
        caps.extend_from_slice(&capsule(s, false));
    }
    let mut flipped = capsule(1160, false);
    flipped[50] ^= 0x20;
    caps.extend_from_slice(&flipped);
    caps.extend_from_slice(&capsule(1480, false));
    write(&dir, "joined_capsules", &caps);
}
