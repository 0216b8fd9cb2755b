//! Arbitrary telegram payloads into `MeasuredValues::parse` and `Frontend::line`, with a
//! configured `DefaultPyramid`.
//!
//! Input: a 32-byte header (scan plane, variant, measuring mode, lines per observation,
//! classifier thresholds and rule, sensor position, pose), then lines `[flags, actuator u32 LE,
//! len u16 LE, bytes...]`. With flags bit 0 the harness builds a 0xB0 payload around `bytes`
//! (the variant's full or interlaced count, partial index from bits 1-2, unit from bits 3-4,
//! values cycled from `bytes`), so lines reach the geometry and the classifier; otherwise
//! `bytes` is the payload as is.
//!
//! Invariants: no panic; every payload of 1..=812 bytes frames as a telegram that passes
//! `Telegram::new_checked`; the frontend's counters add up (lines applied + rejected = lines
//! offered; returns + no-return = values of applied lines; dropped ≤ returns).
#![no_main]

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::{ClassifierConfig, NavigabilityRule, PlaneRule};
use terrain_pyramid::geometry::{Mount, Pose, ScanPlane};
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::wire::sick::{
    emit_telegram, MeasuredValues, MeasuringMode, Telegram, ADDRESS_REPLY,
};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Meters, Point3, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};

const VARIANTS: [(u16, u16); 5] = [(180, 50), (180, 100), (100, 100), (100, 50), (100, 25)];

fn i16_at(h: &[u8; 32], at: usize) -> i16 {
    i16::from_le_bytes([h[at], h[at + 1]])
}

fn f32_at(h: &[u8; 32], at: usize) -> f32 {
    f32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]])
}

/// Metres from a signed count of centimetres.
fn cm(v: i16) -> Meters {
    Meters::from_num(v) / 100
}

fuzz_target!(|data: &[u8]| {
    let mut header = [0_u8; 32];
    let n = data.len().min(32);
    header[..n].copy_from_slice(&data[..n]);
    let mut rest = &data[n..];

    let (deg, cdeg) = VARIANTS[usize::from(header[1]) % VARIANTS.len()];
    let variant = Variant::from_sick(deg, cdeg).expect("a listed variant");
    let measuring_mode = MeasuringMode::from_code(header[2] & 0x0F).unwrap_or_default();
    let classifier = ClassifierConfig {
        robot_height: cm(i16_at(&header, 4)),
        step_threshold: cm(i16_at(&header, 6)),
        drop_threshold: (header[0] & 2 != 0).then(|| cm(i16_at(&header, 8))),
        ceiling: (header[0] & 4 != 0).then(|| cm(i16_at(&header, 10))),
        // Flag bit 4: the paper's spread rule; otherwise the plane rule with the residual and
        // range noise from the header (any sign and size) and the default slope and factors.
        rule: if header[0] & 16 != 0 {
            NavigabilityRule::Spread
        } else {
            NavigabilityRule::Plane(PlaneRule {
                residual: cm(i16_at(&header, 10)),
                range_sigma: cm(i16_at(&header, 6)),
                ..PlaneRule::DEFAULT
            })
        },
    };
    let config = FrontendConfig {
        filter: terrain_pyramid::pipeline::ReturnFilter::NONE,
        mount: Mount::new(
            if header[0] & 1 == 0 {
                ScanPlane::PannedVertical
            } else {
                ScanPlane::TiltedHorizontal
            },
            Point3 {
                x: cm(i16_at(&header, 12)),
                y: cm(i16_at(&header, 14)),
                z: cm(i16_at(&header, 16)),
            },
        ),
        sensor: terrain_pyramid::laser::Sensor::Sick,
        baud: 500_000,
        actuator: terrain_pyramid::actuator::Actuator::External,
        variant,
        measuring_mode,
        lines_per_observation: u32::from(header[3] % 5),
        classifier,
        // The header has no room left: the drop threshold's bytes double as the distance.
        missing_ground_within: (header[0] & 8 != 0).then(|| cm(i16_at(&header, 8))),
    };
    // A pose from the header when valid (x, y, yaw as f32; z from cm), else the origin.
    let pose = Pose::from_f32(
        f32_at(&header, 18),
        f32_at(&header, 22),
        f32::from(i16_at(&header, 30)) / 100.0,
        0.0,
        0.0,
        f32_at(&header, 26),
    )
    .unwrap_or_default();

    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .expect("the default design");
    let mut pyramid = Box::new(DefaultPyramid::new());
    pyramid
        .configure(&design, &Config::default())
        .expect("the default config");
    let mut frontend = Box::new(Frontend::<1024, 8>::new(config));
    frontend
        .adopt_design(&design, &Config::default())
        .expect("the default design's gating");
    frontend.set_pose(pose);

    let mut offered = 0_u32;
    let mut values_applied = 0_u64;
    let mut telegram = vec![0_u8; 818];
    while let [flags, a0, a1, a2, a3, l0, l1, tail @ ..] = rest {
        let len = usize::from(u16::from_le_bytes([*l0, *l1])).min(tail.len());
        let (bytes, tail) = tail.split_at(len);
        rest = tail;
        let payload = if flags & 1 != 0 {
            let count = if flags & 0x20 != 0 {
                variant.sweep_count()
            } else {
                variant.beam_count()
            };
            let partial = (flags >> 1) & 3;
            let unit = (flags >> 3) & 3;
            let mut p = vec![0xB0];
            let word = count as u16 | u16::from(partial) << 11 | u16::from(unit) << 14;
            p.extend_from_slice(&word.to_le_bytes());
            for i in 0..2 * count {
                p.push(if bytes.is_empty() {
                    0
                } else {
                    bytes[i % bytes.len()]
                });
            }
            p.push(0x10);
            p
        } else {
            bytes.to_vec()
        };
        frontend.set_actuator(FineAngle::from_bits(u32::from_le_bytes([
            *a0, *a1, *a2, *a3,
        ])));

        // Framing, then the checked parse: what the accumulator would hand over.
        let framed = match emit_telegram(ADDRESS_REPLY, &payload, &mut telegram) {
            Ok(n) => {
                assert!((1..=812).contains(&payload.len()));
                &telegram[..n]
            }
            Err(_) => {
                assert!(payload.is_empty() || payload.len() > 812);
                // Still exercise the payload parser on what cannot be framed.
                let _ = MeasuredValues::parse_payload(&payload);
                continue;
            }
        };
        let checked = Telegram::new_checked(framed).expect("an emitted telegram checks");
        let Ok(values) = MeasuredValues::parse(&checked) else {
            continue;
        };
        offered += 1;
        let before = frontend.stats();
        if frontend.line(&mut pyramid, &values).is_ok() {
            values_applied += u64::from(values.count());
            assert_eq!(frontend.stats().lines_applied, before.lines_applied + 1);
        } else {
            assert_eq!(frontend.stats(), {
                let mut s = before;
                s.lines_rejected += 1;
                s
            });
        }
    }
    frontend.end_observation(&mut pyramid);
    let s = frontend.stats();
    assert_eq!(s.lines_applied + s.lines_rejected, offered);
    assert_eq!(
        u64::from(s.returns) + u64::from(s.no_return),
        values_applied
    );
    assert!(s.returns_dropped <= s.returns);
});
