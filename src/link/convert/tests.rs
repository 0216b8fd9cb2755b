//! The conversions' tests: every message to the core's types and back, every refusal's Reply.

extern crate std;
use super::*;
use crate::actuator::Actuator;
use crate::angle::FineAngle;
use crate::classify::{ClassifierConfig, NavigabilityRule, PlaneRule};
use crate::design::{Design, GateShape, Param, Schedule, SensorModel};
use crate::geometry::{PoseError, PoseField};
use crate::laser::Sensor;
use crate::logodds::Clamp;
use crate::pyramid::Config;
use crate::wire::link::{encode, Message};
use crate::wire::link::{
    Header, LaserSetup, PoseReport, ReplyCode, RuleSetup, SetRule, Setup, PARAM_LAYER,
};
use crate::wire::recording::{MountKind, SetupEvent};
use crate::wire::sick::Variant;
use std::vec::Vec;

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

#[test]
fn a_design_refusal_names_the_parameter() {
    let error = crate::DesignError::OutOfRange {
        param: crate::Param::Gamma,
        value: 200.0,
        min: 0.0,
        max: 100.0,
    };
    let configure = Header {
        version: 1,
        msg_type: 0x83,
        seq: 12,
    };
    let reply = design_refusal(configure, &error);
    assert_eq!(reply.code, ReplyCode::OutOfRange);
    assert_eq!(reply.param, 7);
    // The spec's worked example of a refusal (section 10; `docs/link_golden.py`).
    let mut out = [0_u8; 64];
    let n = encode(0x0106, &Message::Reply(reply), &mut out).unwrap();
    assert_eq!(
        &out[..n],
        &hex("06 06 05 06 01 0c 04 83 03 07 01 03 48 43 01 01 01 01 01 07 c8 42 dc 79 4e d4 00")[..]
    );
    assert_eq!(
        std::format!("{}", ReplyText(&reply)),
        "reply to #12 (0x83): --gamma: must lie within [0, 100] (got 200)"
    );
}

#[test]
fn pose_validation_names_the_field() {
    let ok = PoseReport {
        x_m: 29_999.0,
        y_m: -29_999.0,
        z_m: 999.0,
        roll_rad: 10.0,
        pitch_rad: -10.0,
        yaw_rad: 100.0,
        stamp_us: 0,
        flags: 0,
    };
    assert!(pose_of(&ok).is_ok());
    let far = PoseReport {
        y_m: 30_000.0,
        ..ok
    };
    assert_eq!(
        pose_of(&far).map(|_| ()),
        Err(PoseError::OutOfRange {
            field: PoseField::Y,
            value: 30_000.0,
            limit: 30_000.0
        })
    );
    let nan = PoseReport {
        pitch_rad: f32::NAN,
        ..ok
    };
    assert_eq!(
        pose_of(&nan).map(|_| ()),
        Err(PoseError::NotFinite {
            field: PoseField::Pitch
        })
    );
    let high = PoseReport { z_m: -1000.0, ..ok };
    assert!(matches!(
        pose_of(&high).map(|_| ()),
        Err(PoseError::OutOfRange {
            field: PoseField::Z,
            ..
        })
    ));
    let header = Header {
        version: 1,
        msg_type: 0x81,
        seq: 3,
    };
    let reply = pose_refusal(header, &pose_of(&far).unwrap_err());
    assert_eq!(
        (reply.code, reply.param, reply.b),
        (ReplyCode::OutOfRange, 33, 30_000.0)
    );
}

/// The link refuses exactly the poses the geometry refuses: angles of 32 768 rad or more in
/// magnitude (the geometry cannot reduce them) get a Reply naming the field, like NaN.
#[test]
fn pose_validation_is_the_geometry_rule() {
    let header = Header {
        version: 1,
        msg_type: 0x81,
        seq: 4,
    };
    let base = [1.0_f32, -2.0, 0.5, 0.1, -0.2, 3.0];
    let edge = [
        29_999.99,
        30_000.0,
        -1e30,
        999.9,
        1000.0,
        32_767.0,
        32_768.0,
        -32_768.0,
        -32_767.99,
        4.0e4,
        f32::MAX,
        f32::MIN_POSITIVE,
        -0.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    for field in 0..6 {
        for &value in &edge {
            let mut v = base;
            v[field] = value;
            let pose = PoseReport {
                x_m: v[0],
                y_m: v[1],
                z_m: v[2],
                roll_rad: v[3],
                pitch_rad: v[4],
                yaw_rad: v[5],
                stamp_us: 0,
                flags: 0,
            };
            let geometry = crate::geometry::Pose::from_f32(v[0], v[1], v[2], v[3], v[4], v[5]);
            let link = pose_of(&pose);
            match (&link, &geometry) {
                (Ok(a), Ok(b)) => assert_eq!(a, b, "{field} {value}"),
                (Err(e), _) => {
                    assert_eq!(
                        pose_field_code(e.field()),
                        32 + field as u8,
                        "{field} {value}"
                    );
                    let reply = pose_refusal(header, e);
                    assert!(!reply.is_ok());
                    assert_eq!(reply.param, 32 + field as u8);
                }
                (Ok(_), Err(e)) => panic!("the link took {field} = {value}, the geometry: {e}"),
            }
        }
    }
    let spin = PoseReport {
        yaw_rad: 40_000.0,
        ..PoseReport::default()
    };
    assert_eq!(
        pose_of(&spin).map(|_| ()),
        Err(PoseError::OutOfRange {
            field: PoseField::Yaw,
            value: 40_000.0,
            limit: 32_768.0
        })
    );
}

/// The worked Setup of `docs/protocol.md` (section 10), validated field by field.
#[test]
fn setup_validation_names_the_field() {
    let setup = crate::wire::link::examples::sick_setup(rule_setup(&NavigabilityRule::DEFAULT));

    // Validation: the variant, the mode, finiteness, thresholds.
    let config = frontend_config(&setup).unwrap();
    assert_eq!(config.variant.beam_count(), 361);
    assert_eq!(config.classifier.drop_threshold, None);
    assert_eq!(
        config.classifier.ceiling,
        Some(crate::units::Meters::from_num(2))
    );
    let refused = |s: Setup| frontend_config(&s).unwrap_err().field();
    assert_eq!(refused(Setup { mount: 3, ..setup }), SetupField::Mount);
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            measuring_mode: 7,
            ..setup
        }),
        SetupField::MeasuringMode
    );
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            field_deg: 180,
            resolution_cdeg: 25,
            ..setup
        }),
        SetupField::Variant
    );
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            sensor_m: [0.0, f32::NAN, 0.0],
            ..setup
        }),
        SetupField::SensorY
    );
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            step_threshold_m: -0.01,
            ..setup
        }),
        SetupField::StepThreshold
    );
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            robot_height_m: 0.0,
            ..setup
        }),
        SetupField::RobotHeight
    );
    let error = frontend_config(&Setup { mount: 3, ..setup }).unwrap_err();
    assert_eq!(
        std::format!("{error}"),
        "setup mount: must lie within [0, 2] (got 3)"
    );
    // A version-2 peer's meaning: a SICK at 500 kBd on an external actuator.
    assert_eq!(config.sensor, Sensor::Sick);
    assert_eq!(config.baud, 500_000);
    assert_eq!(config.actuator, Actuator::External);
}

/// The rule block: both rules and any plane parameters travel bit for bit through the
/// Setup; a bad rule or plane parameter is refused by name; the paper's rule ignores the
/// plane parameters.
#[test]
fn the_plane_rule_is_taken_only_where_built_in() {
    let plane = rule_setup(&NavigabilityRule::Plane(PlaneRule::DEFAULT));
    let to = Header {
        version: crate::wire::link::VERSION,
        msg_type: 0x8B,
        seq: 7,
    };
    let set = SetRule {
        step_threshold_m: 0.05,
        rule: plane,
    };
    if cfg!(feature = "plane-rule") {
        assert_eq!(RULE_MAX, 1);
        assert_eq!(
            navigability_rule(&plane),
            Ok(NavigabilityRule::Plane(PlaneRule::DEFAULT))
        );
        assert!(set_rule_of(&set).is_ok());
    } else {
        assert_eq!(RULE_MAX, 0);
        let error = SetupError::OutOfRange {
            field: SetupField::Rule,
            value: 1.0,
            min: 0.0,
            max: 0.0,
        };
        assert_eq!(navigability_rule(&plane), Err(error));
        assert_eq!(set_rule_of(&set), Err(error));
        assert_eq!(
            navigability_rule(&RuleSetup::SPREAD),
            Ok(NavigabilityRule::Spread)
        );
    }
    // The refusal a build without the plane rule sends, read by any build.
    let refusal = setup_refusal(
        to,
        &SetupError::OutOfRange {
            field: SetupField::Rule,
            value: 1.0,
            min: 0.0,
            max: 0.0,
        },
    );
    assert_eq!(
        (
            refusal.code,
            refusal.param,
            refusal.value,
            refusal.a,
            refusal.b
        ),
        (ReplyCode::OutOfRange, 65, 1.0, 0.0, 0.0)
    );
    assert_eq!(
        std::format!("{}", ReplyText(&refusal)),
        "reply to #7 (0x8b): setup navigability rule: the plane rule (1) is not built into \
         the device (built without the plane-rule feature); it takes the paper's spread rule \
         (0) only"
    );
}

/// A recording's setup event of a SICK at 180° and `resolution_cdeg` (centidegrees), tilted
/// horizontal, 0.5 m up, mode 0, an observation per sweep.
fn sick_event(resolution_cdeg: u16) -> SetupEvent {
    SetupEvent {
        mount: MountKind::TiltedHorizontal,
        measuring_mode: 0,
        field_deg: 180,
        resolution_cdeg,
        sensor_m: [0.0, 0.0, 0.5],
        lines_per_observation: 0,
    }
}

#[test]
#[cfg(feature = "plane-rule")]
fn the_rule_block_travels_and_is_validated() {
    use crate::classify::Ratio;
    use crate::units::Meters;
    let event = sick_event(50);
    let custom = NavigabilityRule::Plane(PlaneRule {
        max_grade: Ratio::from_num(1),
        residual: Meters::from_num(0.03),
        range_sigma: Meters::from_num(0.05),
        angle_sigma: Ratio::from_num(0.002),
        noise_factor: Ratio::from_num(3),
        pair_depth: 3,
    });
    for rule in [NavigabilityRule::Spread, NavigabilityRule::DEFAULT, custom] {
        let classifier = ClassifierConfig {
            rule,
            ..ClassifierConfig::DEFAULT
        };
        let config = frontend_config_of_event(&event, &classifier).unwrap();
        assert_eq!(config.classifier, classifier);
    }
    let plane = setup_message(&event, &ClassifierConfig::DEFAULT);
    let refused = |rule: RuleSetup| frontend_config(&Setup { rule, ..plane }).unwrap_err();
    assert_eq!(
        refused(RuleSetup {
            rule: 2,
            ..plane.rule
        }),
        SetupError::OutOfRange {
            field: SetupField::Rule,
            value: 2.0,
            min: 0.0,
            max: 1.0
        }
    );
    assert_eq!(
        refused(RuleSetup {
            residual_m: -0.01,
            ..plane.rule
        })
        .field(),
        SetupField::Residual
    );
    assert_eq!(
        refused(RuleSetup {
            max_grade: f32::INFINITY,
            ..plane.rule
        }),
        SetupError::NotFinite {
            field: SetupField::MaxGrade
        }
    );
    // Wire order: the first bad parameter is named.
    assert_eq!(
        refused(RuleSetup {
            range_sigma_m: f32::NAN,
            noise_factor: 1e6,
            ..plane.rule
        })
        .field(),
        SetupField::RangeSigma
    );
    assert_eq!(
        refused(RuleSetup {
            noise_factor: 1_000.0,
            ..plane.rule
        })
        .field(),
        SetupField::NoiseFactor
    );
    // The pair depth (version 6): 1 ..= 3, after the parameters in wire order.
    for depth in [0, 4, 255] {
        assert_eq!(
            refused(RuleSetup {
                pair_depth: depth,
                ..plane.rule
            }),
            SetupError::OutOfRange {
                field: SetupField::PairDepth,
                value: f32::from(depth),
                min: 1.0,
                max: 3.0
            }
        );
    }
    assert_eq!(
        refused(RuleSetup {
            noise_factor: f32::NAN,
            pair_depth: 0,
            ..plane.rule
        })
        .field(),
        SetupField::NoiseFactor
    );
    let paper = RuleSetup {
        rule: 0,
        angle_sigma_rad: f32::NAN,
        ..plane.rule
    };
    assert_eq!(
        frontend_config(&Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            rule: paper,
            ..plane
        })
        .unwrap()
        .classifier
        .rule,
        NavigabilityRule::Spread
    );
    for code in 65..=70 {
        let field = SetupField::from_param(code).unwrap();
        assert_eq!(field as u8, code);
    }
    for code in 71..=81 {
        let field = SetupField::from_param(code).unwrap();
        assert_eq!(field as u8, code);
    }
    assert_eq!(SetupField::from_param(82), None);
}

/// The laser block: each field refused with its own code and sentence; a lidar's mode is
/// its own, its variant fields ignored; the servo's sweep converted exactly enough.
#[test]
fn the_laser_block_is_validated_field_by_field() {
    let servo = crate::wire::link::examples::LD06_ON_A_SERVO;
    let setup =
        crate::wire::link::examples::lidar_on_a_servo_setup(rule_setup(&NavigabilityRule::DEFAULT));
    let config = frontend_config(&setup).unwrap();
    assert_eq!(config.sensor, Sensor::Ld06);
    assert_eq!(config.baud, 230_400);
    let Actuator::Servo(profile) = config.actuator else {
        panic!("{:?}", config.actuator)
    };
    let deg = |a: FineAngle| f64::from(a.to_bits() as i32) * 360.0 / 4_294_967_296.0;
    assert!((deg(profile.min) + 10.0).abs() < 1e-5);
    assert!((deg(profile.max) - 30.0).abs() < 1e-5);
    assert_eq!(
        (profile.rate_mdeg_per_s, profile.latency_us),
        (60_000, 25_000)
    );
    let with = |laser: LaserSetup| Setup { laser, ..setup };
    let refused = |s: Setup| {
        let e = frontend_config(&s).unwrap_err();
        let reply = setup_refusal(
            Header {
                version: 3,
                msg_type: 0x87,
                seq: 1,
            },
            &e,
        );
        assert_eq!(reply.param, e.field() as u8);
        assert_eq!(SetupField::from_param(reply.param), Some(e.field()));
        (e.field(), std::format!("{e}"))
    };
    assert_eq!(
        refused(with(LaserSetup { sensor: 4, ..servo })),
        (
            SetupField::Sensor,
            "setup sensor: 4 is not a sensor (0 SICK, 1 LD06, 2 RPLIDAR, 3 YDLIDAR)".into()
        )
    );
    // The mode is the sensor's: LD06 has only 0, RPLIDAR and YDLIDAR 0 and 1.
    assert_eq!(
        refused(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            measuring_mode: 1,
            ..setup
        }),
        (
            SetupField::MeasuringMode,
            "setup sensor mode: must lie within [0, 0] (got 1)".into()
        )
    );
    for (sensor, mode, want) in [
        (
            2,
            1,
            Sensor::Rplidar(crate::wire::rplidar::RplidarScanMode::Express),
        ),
        (
            3,
            1,
            Sensor::Ydlidar(crate::wire::ydlidar::YdlidarAngleCorrection::Off),
        ),
    ] {
        let s = Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            measuring_mode: mode,
            laser: LaserSetup { sensor, ..servo },
            ..setup
        };
        assert_eq!(frontend_config(&s).unwrap().sensor, want);
        let s = Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            measuring_mode: 2,
            ..s
        };
        assert_eq!(refused(s).0, SetupField::MeasuringMode);
    }
    assert_eq!(
        refused(with(LaserSetup { baud: 300, ..servo })),
        (
            SetupField::Baud,
            "setup baud rate: must lie within [9600, 3000000] (got 300)".into()
        )
    );
    let ok = frontend_config(&with(LaserSetup {
        baud: 460_800,
        ..servo
    }))
    .unwrap();
    assert_eq!(ok.baud, 460_800);
    assert_eq!(
        refused(with(LaserSetup {
            actuator: 2,
            ..servo
        }))
        .0,
        SetupField::Actuator
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_min_deg: f32::NAN,
            ..servo
        })),
        (
            SetupField::ServoMin,
            "setup servo min: must be a finite number".into()
        )
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_min_deg: -200.0,
            ..servo
        }))
        .0,
        SetupField::ServoMin
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_max_deg: -10.0,
            ..servo
        })),
        (
            SetupField::ServoMax,
            "setup servo max: must be above the servo min (-10) and at most 179 degrees \
             (got -10)"
                .into()
        )
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_rate_deg_s: 0.0,
            ..servo
        })),
        (
            SetupField::ServoRate,
            "setup servo rate: must be greater than 0 (got 0)".into()
        )
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_rate_deg_s: 1_000.5,
            ..servo
        }))
        .0,
        SetupField::ServoRate
    );
    assert_eq!(
        refused(with(LaserSetup {
            servo_latency_ms: 1_000.0,
            ..servo
        }))
        .0,
        SetupField::ServoLatency
    );
    // An external actuator ignores the servo fields; a SICK checks its own.
    let external = with(LaserSetup {
        actuator: 0,
        servo_min_deg: f32::NAN,
        ..servo
    });
    assert_eq!(
        frontend_config(&external).unwrap().actuator,
        Actuator::External
    );
    assert_eq!(
        refused(with(LaserSetup { sensor: 0, ..servo })).0,
        SetupField::Variant
    );
}

/// A recording's setup event takes the same path.
#[test]
fn a_recording_setup_goes_through_the_same_rule() {
    let event = sick_event(25);
    let error = frontend_config_of_event(&event, &ClassifierConfig::default()).unwrap_err();
    assert_eq!(error.field(), SetupField::Variant);
    let ok = SetupEvent {
        resolution_cdeg: 50,
        ..event
    };
    let config = frontend_config_of_event(&ok, &ClassifierConfig::default()).unwrap();
    assert_eq!(config.variant, Variant::Fov180StepHalf);
    assert_eq!(config.classifier, ClassifierConfig::default());
}

/// A Configure carries a design and a configuration exactly: the conversion there and back is
/// the identity on valid inputs.
#[test]
fn configure_round_trips_a_design() {
    let schedule = Schedule {
        gate: GateShape::Hard,
        uniform_resolution: true,
        ..Schedule::default()
    };
    let design = Design::<32>::new(SensorModel::default(), schedule, 256).unwrap();
    let config = Config {
        clamp: Clamp::Off,
        fused_margin: 0.25,
        ..Config::default()
    };
    let c = configure_of_design(&design, &config);
    assert_eq!(design_of::<32>(&c).unwrap(), design);
    assert_eq!(config_of(&c).unwrap(), config);
}

/// Every Reply param names one thing: the design's codes (the decay's time constants
/// included), the pose's, the layer's and Setup's never share a number.
#[test]
fn reply_param_codes_are_disjoint() {
    for code in 0..=u8::MAX {
        let design = param_of_code(code).is_some();
        let setup = SetupField::from_param(code).is_some();
        let other = (32..=37).contains(&code) || code == PARAM_LAYER;
        assert!(
            u8::from(design) + u8::from(setup) + u8::from(other) <= 1,
            "param {code}"
        );
        if let Some(p) = param_of_code(code) {
            assert_eq!(param_code(p), code);
        }
    }
    assert_eq!(
        param_code(Param::DecayTau { layer: 31 }),
        127,
        "layer 31's time constant"
    );
    assert_eq!(SetupField::from_param(64), Some(SetupField::ServoLatency));
}

/// The mount and filter blocks (version 5): the general mount's fields and the filters, each
/// refused with its own field; a preset with a zero and a reversed sense; the general mount of
/// a preset's values is the preset.
#[test]
fn the_mount_and_filter_blocks_are_validated_field_by_field() {
    use crate::geometry::{ActuatorAxis, Mount, ScanPlane};
    use crate::wire::link::{FilterSetup, MountSetup};
    let base = Setup {
        sensor_m: [0.0, 0.0, 0.5],
        ceiling_m: 0.0,
        ..crate::wire::link::examples::sick_setup(RuleSetup::SPREAD)
    };
    let preset = frontend_config(&base).unwrap().mount;
    assert_eq!(preset.preset(), Some(ScanPlane::TiltedHorizontal));
    // The general mount of the preset's values is the preset.
    let general = Setup {
        mount: 2,
        mount_block: MountSetup {
            axis: 1,
            ..MountSetup::PRESET
        },
        ..base
    };
    assert_eq!(frontend_config(&general).unwrap().mount, preset);
    let panned = Setup {
        mount: 2,
        mount_block: MountSetup {
            axis: 0,
            rpy_deg: [90.0, 0.0, 0.0],
            ..MountSetup::PRESET
        },
        ..base
    };
    assert_eq!(
        frontend_config(&panned).unwrap().mount.preset(),
        Some(ScanPlane::PannedVertical)
    );
    // A preset keeps its rotation and axis but takes the zero and the sense.
    let m = frontend_config(&Setup {
        mount_block: MountSetup {
            sense: -1,
            zero_deg: -90.0,
            axis: 7,
            rpy_deg: [1.0, 2.0, 3.0],
        },
        ..base
    })
    .unwrap()
    .mount;
    assert_eq!(m.axis(), ActuatorAxis::Tilt);
    assert_eq!(m.columns(), preset.columns());
    assert!(m.reversed());
    assert_eq!(m.zero(), FineAngle::from_bits(3 << 30));
    assert_eq!(
        m,
        Mount::general(
            m.position,
            ScanPlane::TiltedHorizontal.rpy(),
            ActuatorAxis::Tilt,
            FineAngle::from_bits(3 << 30),
            true
        )
    );
    let refused = |s: Setup| frontend_config(&s).unwrap_err().field();
    let with_mount = |b: MountSetup| Setup {
        mount: 2,
        mount_block: b,
        ..base
    };
    assert_eq!(
        refused(with_mount(MountSetup {
            axis: 3,
            ..MountSetup::PRESET
        })),
        SetupField::MountAxis
    );
    assert_eq!(
        refused(with_mount(MountSetup {
            sense: 0,
            ..MountSetup::PRESET
        })),
        SetupField::MountSense
    );
    assert_eq!(
        refused(with_mount(MountSetup {
            zero_deg: f32::NAN,
            ..MountSetup::PRESET
        })),
        SetupField::MountZero
    );
    for (k, field) in [
        SetupField::MountRoll,
        SetupField::MountPitch,
        SetupField::MountYaw,
    ]
    .into_iter()
    .enumerate()
    {
        let mut rpy_deg = [0.0; 3];
        rpy_deg[k] = 360.5;
        assert_eq!(
            refused(with_mount(MountSetup {
                rpy_deg,
                ..MountSetup::PRESET
            })),
            field
        );
    }
    let with_filter = |f: FilterSetup| Setup { filter: f, ..base };
    assert_eq!(
        refused(with_filter(FilterSetup {
            min_range_cm: 100,
            max_range_cm: 100,
            ..FilterSetup::NONE
        })),
        SetupField::MaxRange
    );
    assert_eq!(
        refused(with_filter(FilterSetup {
            sector_count: 9,
            ..FilterSetup::NONE
        })),
        SetupField::SectorCount
    );
    let mut sectors = [(0, 0); 8];
    sectors[1] = (100, 36_000);
    let e = frontend_config(&with_filter(FilterSetup {
        sector_count: 2,
        sectors,
        ..FilterSetup::NONE
    }))
    .unwrap_err();
    assert_eq!(
        e,
        SetupError::OutOfRange {
            field: SetupField::Sector,
            value: 36_000.0,
            min: 1.0,
            max: 35_999.0
        }
    );
    // A sector past the count is not looked at; the filter takes the ranges in mm.
    let f = frontend_config(&with_filter(FilterSetup {
        min_range_cm: 5,
        max_range_cm: 1_200,
        min_quality: 10,
        sector_count: 1,
        sectors: [(9_000, 18_000); 8],
    }))
    .unwrap()
    .filter;
    assert_eq!(
        (f.min_range_mm(), f.max_range_mm(), f.min_quality()),
        (50, 12_000, 10)
    );
    assert_eq!(f.sectors().len(), 1);
    assert!(f.masked(FineAngle::QUARTER));
    assert!(!f.masked(FineAngle::HALF));
}

/// Degrees and centidegrees become angles exactly at right angles and within a few 2⁻³² turns
/// elsewhere.
#[test]
fn degrees_convert_exactly_at_right_angles() {
    assert_eq!(fine_of_degrees(90.0), FineAngle::QUARTER);
    assert_eq!(fine_of_degrees(-90.0), FineAngle::from_bits(3 << 30));
    assert_eq!(fine_of_degrees(180.0), FineAngle::HALF);
    assert_eq!(fine_of_degrees(360.0), FineAngle::ZERO);
    assert_eq!(fine_of_centidegrees(9_000), FineAngle::QUARTER);
    assert_eq!(fine_of_centidegrees(27_000), FineAngle::from_bits(3 << 30));
    for d in [0.1_f32, 17.3, -123.45, 359.99] {
        let want = (f64::from(d) / 360.0).rem_euclid(1.0) * 4_294_967_296.0;
        let got = f64::from(fine_of_degrees(d).to_bits());
        let diff = (got - want).abs().min(4_294_967_296.0 - (got - want).abs());
        // The degrees rounded to 2⁻¹⁵ (at most 2⁻¹⁶ degree off, 182 LSB of 2⁻³² turn).
        assert!(diff < 200.0, "{d}: {diff}");
    }
}
