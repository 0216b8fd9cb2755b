//! The link's Setup frame (protocol version 6: its body with the navigability rule, laser,
//! mount and filter blocks) against an independent encoder written from `docs/protocol.md` alone:
//! `host/tests/py/link_setup.py` (Python's `struct`, `zlib.crc32` and the COBS of
//! `docs/link_golden.py`). Every field is given to both in wire order; the frames must be equal
//! byte for byte, and the library must decode Python's frame back to the same Setup.
use std::process::Command;

mod common;
use common::succeeded;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::classify::{NavigabilityRule, PlaneRule, Ratio};
use terrain_pyramid::link::convert::{frontend_config, rule_setup, set_rule_message, set_rule_of};
use terrain_pyramid::wire::link::{
    encode, Decoded, FrameAccumulator, LaserSetup, Message, RuleSetup, SetRule, Setup,
    MAX_ENCODED_FRAME, MAX_FRAME, VERSION,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::Meters;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/py/link_setup.py");

/// The script's arguments for a navigability rule: its number, then its parameters (f32's
/// Display: the shortest decimal that reads back as the same f32).
fn rule_args(rule: &RuleSetup) -> [String; 7] {
    [
        rule.rule.to_string(),
        rule.max_grade.to_string(),
        rule.residual_m.to_string(),
        rule.range_sigma_m.to_string(),
        rule.angle_sigma_rad.to_string(),
        rule.noise_factor.to_string(),
        rule.pair_depth.to_string(),
    ]
}

/// The frame the script printed: its bytes in hex, separated by white space.
fn frame_of_hex(stdout: Vec<u8>) -> Vec<u8> {
    String::from_utf8(stdout)
        .unwrap()
        .split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// Python's frame of `setup` as sequence number `seq`.
fn python_frame(seq: u16, s: &Setup) -> Vec<u8> {
    // f32's Display is the shortest decimal that reads back as the same f32.
    let mut args: Vec<String> = vec![seq.to_string()];
    args.extend([
        s.mount.to_string(),
        s.measuring_mode.to_string(),
        s.field_deg.to_string(),
        s.resolution_cdeg.to_string(),
    ]);
    args.extend(s.sensor_m.iter().map(f32::to_string));
    args.push(s.lines_per_observation.to_string());
    args.extend(
        [
            s.robot_height_m,
            s.step_threshold_m,
            s.drop_threshold_m,
            s.ceiling_m,
        ]
        .iter()
        .map(f32::to_string),
    );
    args.extend(rule_args(&s.rule));
    let l = &s.laser;
    args.extend([
        l.sensor.to_string(),
        l.actuator.to_string(),
        l.baud.to_string(),
    ]);
    args.extend(
        [
            l.servo_min_deg,
            l.servo_max_deg,
            l.servo_rate_deg_s,
            l.servo_latency_ms,
        ]
        .iter()
        .map(f32::to_string),
    );
    let m = &s.mount_block;
    args.extend([
        m.axis.to_string(),
        m.sense.to_string(),
        m.zero_deg.to_string(),
    ]);
    args.extend(m.rpy_deg.iter().map(f32::to_string));
    let f = &s.filter;
    args.extend([
        f.min_range_cm.to_string(),
        f.max_range_cm.to_string(),
        f.min_quality.to_string(),
        f.sector_count.to_string(),
    ]);
    for (a, b) in f.sectors {
        args.extend([a.to_string(), b.to_string()]);
    }
    let out = Command::new("python3")
        .arg(SCRIPT)
        .args(&args)
        .output()
        .expect("python3 runs (the independent encoder needs only its standard library)");
    assert!(
        out.status.success(),
        "{SCRIPT} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    frame_of_hex(out.stdout)
}

/// Python's SetRule frame.
fn python_set_rule(seq: u16, s: &SetRule) -> Vec<u8> {
    let mut args = vec![
        "setrule".to_string(),
        seq.to_string(),
        s.step_threshold_m.to_string(),
    ];
    args.extend(rule_args(&s.rule));
    let out = succeeded(Command::new("python3").arg(SCRIPT).args(&args), "");
    frame_of_hex(out.stdout)
}

#[test]
fn set_rule_frames_equal_an_independent_encoder() {
    let custom = NavigabilityRule::Plane(PlaneRule {
        max_grade: Ratio::from_num(0.25),
        residual: Meters::from_num(0.02),
        range_sigma: Meters::from_num(0.04),
        angle_sigma: Ratio::from_num(0.001),
        noise_factor: Ratio::from_num(1.5),
        pair_depth: 3,
    });
    for (i, rule) in [NavigabilityRule::Spread, NavigabilityRule::DEFAULT, custom]
        .into_iter()
        .enumerate()
    {
        let classifier = ClassifierConfig {
            step_threshold: Meters::from_num(0.03 * (i as f64 + 1.0)),
            rule,
            ..ClassifierConfig::DEFAULT
        };
        let set = set_rule_message(&classifier);
        let seq = u16::try_from(i).unwrap() + 40;
        let mut ours = [0_u8; MAX_ENCODED_FRAME];
        let n = encode(seq, &Message::SetRule(set), &mut ours).unwrap();
        assert_eq!(&ours[..n], &python_set_rule(seq, &set)[..], "{set:?}");
        assert_eq!(
            set_rule_of(&set).unwrap(),
            (classifier.step_threshold, classifier.rule)
        );
    }
}

fn base(rule: NavigabilityRule, laser: LaserSetup) -> Setup {
    Setup {
        mount_block: terrain_pyramid::wire::link::MountSetup::PRESET,
        filter: terrain_pyramid::wire::link::FilterSetup::NONE,
        mount: 1,
        measuring_mode: 0,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.25, -0.5, 0.75],
        lines_per_observation: 8,
        robot_height_m: 1.0,
        step_threshold_m: 0.08,
        drop_threshold_m: 0.3,
        ceiling_m: 2.0,
        rule: rule_setup(&rule),
        laser,
    }
}

#[test]
fn setup_frames_equal_an_independent_encoder() {
    let custom = NavigabilityRule::Plane(PlaneRule {
        max_grade: Ratio::from_num(0.5),
        residual: Meters::from_num(0.025),
        range_sigma: Meters::from_num(0.03),
        angle_sigma: Ratio::from_num(0.0025),
        noise_factor: Ratio::from_num(2.5),
        pair_depth: 2,
    });
    let servo = LaserSetup {
        sensor: 1,
        actuator: 1,
        baud: 230_400,
        servo_min_deg: -10.0,
        servo_max_deg: 30.0,
        servo_rate_deg_s: 60.0,
        servo_latency_ms: 25.0,
    };
    let mut setups = Vec::new();
    for rule in [NavigabilityRule::Spread, NavigabilityRule::DEFAULT, custom] {
        for laser in [LaserSetup::SICK, servo] {
            setups.push(base(rule, laser));
        }
    }
    // Odd values in every rule field (the wire carries what it is given).
    setups.push(Setup {
        mount_block: terrain_pyramid::wire::link::MountSetup::PRESET,
        filter: terrain_pyramid::wire::link::FilterSetup::NONE,
        rule: RuleSetup {
            rule: 7,
            max_grade: -1.5,
            residual_m: 1e-7,
            range_sigma_m: 123.456,
            angle_sigma_rad: f32::MAX,
            noise_factor: -0.0,
            pair_depth: 255,
        },
        ..base(NavigabilityRule::Spread, servo)
    });
    // The general mount and the filters, odd values included.
    let mut sectors = [(0_u16, 0_u16); 8];
    for (k, s) in sectors.iter_mut().enumerate() {
        let k = u32::try_from(k).unwrap();
        let c = |v: u32| u16::try_from(v % 36_000).unwrap();
        *s = (c(4_500 * k + 7), c(4_500 * k + 35_990));
    }
    setups.push(Setup {
        mount: 2,
        mount_block: terrain_pyramid::wire::link::MountSetup {
            axis: 2,
            sense: -1,
            zero_deg: -12.345,
            rpy_deg: [180.0, -0.001, 359.5],
        },
        filter: terrain_pyramid::wire::link::FilterSetup {
            min_range_cm: 3,
            max_range_cm: 65_535,
            min_quality: 255,
            sector_count: 8,
            sectors,
        },
        ..base(NavigabilityRule::Spread, servo)
    });
    setups.push(Setup {
        mount_block: terrain_pyramid::wire::link::MountSetup {
            axis: 0xFF,
            sense: i8::MIN,
            zero_deg: f32::MIN_POSITIVE,
            rpy_deg: [1e30, -1e-30, 0.5],
        },
        ..base(NavigabilityRule::Spread, LaserSetup::SICK)
    });
    for (i, setup) in setups.iter().enumerate() {
        let seq = u16::try_from(i).unwrap() * 257;
        let mut ours = [0_u8; MAX_ENCODED_FRAME];
        let n = encode(seq, &Message::Setup(*setup), &mut ours).unwrap();
        let theirs = python_frame(seq, setup);
        assert_eq!(&ours[..n], &theirs[..], "{setup:?}");
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        match acc.feed(&theirs) {
            FeedResult::Item {
                item: Decoded { header, message },
                ..
            } => {
                assert_eq!((header.version, header.seq), (VERSION, seq));
                assert_eq!(message, Message::Setup(*setup));
            }
            other => panic!("Python's frame did not decode: {other:?}"),
        }
    }
    // The rules the library sends arrive as they were sent.
    for setup in &setups[..6] {
        let config = frontend_config(setup).unwrap();
        assert_eq!(rule_setup(&config.classifier.rule), setup.rule);
    }
}
