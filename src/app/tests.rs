//! The application core as a board drives it: bytes in, frames out, counters.
extern crate std;
use super::*;
use crate::angle::AngleSource;
use crate::design::{GateShape, Param, Schedule, SensorModel};
use crate::link::convert;
use crate::link::convert::{configure_of_design, param_of_code, ReplyText};
use crate::link::tests::{command, decode_all, decode_taken, Out};
use crate::wire::link::Reply;
use crate::wire::link::{
    ClampRequest, Configure, DecodeError, HelloReason, Message, MessageType, PanAngle, PoseReport,
    ReplyCode, Setup, SnapshotScope, TimeRequest,
};
use crate::wire::sick::MeasuredValues;
use crate::wire::sick::{Unit, Variant};
use crate::DefaultDesign;
use std::boxed::Box;
use std::vec::Vec;

pub(super) type Core = CoProcessor<64, 8, 1024, 4096>;

fn design() -> DefaultDesign {
    DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap()
}

/// A SICK LMS 291 at 180°/0.5°, 0.5 m up on a tilt unit, one observation per line.
fn setup() -> FrontendConfig {
    crate::pipeline::tests::sick_on_a_tilt_unit(1)
}

/// A booted co-processor whose boot Hello has been drained, Stats off.
pub(super) fn booted() -> Box<Core> {
    let mut core = Box::new(Core::new());
    let link = LinkConfig {
        stats_interval_ms: 0,
        ..LinkConfig::DEFAULT
    };
    core.boot(link, &design(), &Config::default(), setup())
        .unwrap();
    core.poll(0);
    output(&mut core);
    core
}

/// Everything the co-processor queued, decoded.
pub(super) fn output(core: &mut Core) -> Vec<(u16, Out)> {
    decode_taken(|buf| core.take_output(buf))
}

fn replies(out: &[(u16, Out)]) -> Vec<Reply> {
    out.iter().filter_map(|(_, o)| o.reply()).collect()
}

/// Polls at 10 ms and takes the output and its replies, asserting that there are `n`.
fn poll_replies(core: &mut Core, n: usize) -> (Vec<(u16, Out)>, Vec<Reply>) {
    core.poll(10);
    let out = output(core);
    let r = replies(&out);
    assert_eq!(r.len(), n, "{out:?}");
    (out, r)
}

/// The reply to `configure`, sent as command `seq`.
fn configure_reply(core: &mut Core, seq: u16, configure: Configure) -> Reply {
    core.host(&command(seq, &Message::Configure(configure)));
    replies(&output(core))[0]
}

/// One 361-beam line of a SICK 0.5 m above flat floor, tilted 20° down: every beam below the
/// horizon meets the floor.
fn floor_telegram() -> Vec<u8> {
    let tau = 20_f64.to_radians();
    let mut values = Vec::new();
    for i in 0..361 {
        let theta = (f64::from(i) * 0.5).to_radians();
        let dz = -theta.sin() * tau.sin();
        let r = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
        let raw: u16 = if r < 8.0 {
            (r * 1000.0).round() as u16
        } else {
            0x1FFF
        };
        values.extend_from_slice(&raw.to_le_bytes());
    }
    let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
    let mut buf = std::vec![0_u8; line.buffer_len()];
    let n = line.emit(&mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// Observed cells over every layer.
fn observed(core: &Core) -> u32 {
    (0..core.pyramid().layer_count())
        .map(|k| core.pyramid().counts(k).unwrap().observed)
        .sum()
}

pub(super) fn pan(seq: u16, turns: u16) -> Vec<u8> {
    command(
        seq,
        &Message::PanAngle(PanAngle {
            turns,
            timestamp_ms: 0,
        }),
    )
}

/// An angle source that reads a fixed angle, or fails.
struct Encoder(Option<Angle>);

impl AngleSource for Encoder {
    type Error = ();
    fn read_angle(&mut self) -> Result<Angle, ()> {
        self.0.ok_or(())
    }
}

/// A flat grid is a design of one layer (the bench's `flat` firmware): the self-check has no
/// layer 1 to try and must not need one.
#[test]
fn a_one_layer_design_boots() {
    let sensor = SensorModel {
        max_range_m: 0.5,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    let design = crate::Design::<1>::new(sensor, schedule, 64).unwrap();
    let mut core = Box::new(CoProcessor::<64, 1, 256, 2048>::new());
    core.boot(LinkConfig::DEFAULT, &design, &Config::default(), setup())
        .unwrap();
    assert_eq!(core.pyramid().counts(0).unwrap().observed, 0);
    // The record for layer 1 and the one past the last layer: both refused.
    assert_eq!(core.pyramid().stats().bad_layer, 2);
}

#[test]
fn boot_checks_the_pyramid_and_says_hello() {
    let mut core = Box::new(Core::new());
    core.boot(LinkConfig::DEFAULT, &design(), &Config::default(), setup())
        .unwrap();
    // The self-check's records are forgotten.
    assert_eq!(core.pyramid().counts(0).unwrap().observed, 0);
    assert_eq!(core.pyramid().stats().bad_layer, 1);
    core.poll(0);
    let out = output(&mut core);
    let Out::Hello(hello) = &out[0].1 else {
        panic!("{out:?}")
    };
    assert_eq!(hello.reason, HelloReason::Boot);
    assert_eq!(hello.layers.len(), 8);
    let version = env!("CARGO_PKG_VERSION");
    let firmware = hello.firmware;
    assert_eq!(
        std::format!("{}.{}.{}", firmware.major, firmware.minor, firmware.patch),
        version
    );
    // A design the window does not fit is refused, and nothing is configured.
    let mut other = Box::new(Core::new());
    let wide = DefaultDesign::new(SensorModel::default(), Schedule::default(), 128).unwrap();
    assert!(matches!(
        other.boot(LinkConfig::DEFAULT, &wide, &Config::default(), setup()),
        Err(BootError::Design(DesignError::OutOfRange {
            param: Param::Cells,
            ..
        }))
    ));
    assert_eq!(other.pyramid().layer_count(), 0);
}

#[test]
fn a_line_needs_an_angle_from_the_board_or_the_host() {
    let mut core = booted();
    let telegram = floor_telegram();
    // No source, no PanAngle yet: the line is dropped and counted.
    core.laser(&telegram, 0, &mut NoAngleSource);
    let c = core.counters();
    assert_eq!(
        (c.app.lines_without_angle, c.frontend.lines_applied),
        (1, 0)
    );
    assert_eq!(c.app.angle_source_errors, 1);
    assert_eq!(c.laser.sick().unwrap().telegrams_ok, 1);
    // The host's angle stands in.
    core.host(&pan(0, 0x0E39)); // 20° down, as 2⁻¹⁶ turn
    core.laser(&telegram, 0, &mut NoAngleSource);
    assert_eq!(core.counters().frontend.lines_applied, 1);
    assert!(core.pyramid().stats().applied > 0);
    // An encoder is read first; when it fails, the host's angle stands in again.
    core.laser(&telegram, 0, &mut Encoder(Some(Angle::from_bits(0x0E39))));
    core.laser(&telegram, 0, &mut Encoder(None));
    let c = core.counters();
    assert_eq!(c.frontend.lines_applied, 3);
    assert_eq!(
        (c.app.angle_source_errors, c.app.lines_without_angle),
        (3, 1)
    );
    // Stats counts the dropped line as a bad telegram.
    core.host(&command(1, &Message::RequestStats));
    core.poll(5);
    let out = output(&mut core);
    let stats = out.iter().find_map(|(_, o)| o.stats()).unwrap();
    assert_eq!((stats.telegrams_ok, stats.telegrams_bad_other), (4, 1));
    assert_eq!(stats.observations, 3);
}

#[test]
fn a_telegram_split_anywhere_is_one_line() {
    let telegram = floor_telegram();
    let mut whole = booted();
    whole.host(&pan(0, 0x0E39));
    whole.laser(&telegram, 0, &mut NoAngleSource);
    for cut in [1, 7, 100, telegram.len() - 1] {
        let mut split = booted();
        split.host(&pan(0, 0x0E39));
        split.laser(&telegram[..cut], 0, &mut NoAngleSource);
        assert_eq!(split.counters().frontend.lines_applied, 0);
        split.laser(&telegram[cut..], 0, &mut NoAngleSource);
        assert_eq!(split.counters(), whole.counters(), "cut at {cut}");
    }
}

#[test]
fn configure_is_validated_by_the_librarys_rules() {
    let mut core = booted();
    core.host(&pan(0, 0x0E39));
    core.laser(&floor_telegram(), 0, &mut NoAngleSource);
    let before = observed(&core);
    assert!(before > 0);
    let default = configure_of_design(&design(), &Config::default());
    // γ = 1: Design::new refuses it by name.
    let bad = Configure {
        gamma: 1.0,
        ..default
    };
    let reply = configure_reply(&mut core, 5, bad);
    assert_eq!(reply.to_seq, 5);
    assert_eq!(reply.to_type, MessageType::Configure.to_u8());
    assert_eq!(reply.code, ReplyCode::GammaNotAboveOne);
    assert_eq!(param_of_code(reply.param), Some(Param::Gamma));
    assert_eq!(
        std::format!("{}", ReplyText(&reply).reason()),
        "--gamma: must be greater than 1 (got 1)"
    );
    assert_eq!(observed(&core), before, "nothing changed");
    // The clamp's bounds, by Clamp::bounds.
    let bad = Configure {
        clamp: ClampRequest::Bounds { min: 1.0, max: 3.5 },
        ..default
    };
    let reply = configure_reply(&mut core, 6, bad);
    assert_eq!(
        (reply.code, param_of_code(reply.param)),
        (ReplyCode::OutOfRange, Some(Param::ClampMin))
    );
    // The probabilities' order, by InverseSensorModel::increments.
    let bad = Configure {
        p_free: 0.6,
        ..default
    };
    let reply = configure_reply(&mut core, 7, bad);
    assert_eq!(param_of_code(reply.param), Some(Param::PFree));
    // A window the pyramid was not compiled for: refused when it is applied.
    let bad = Configure {
        cells_per_side: 128,
        ..default
    };
    let reply = configure_reply(&mut core, 8, bad);
    assert_eq!(param_of_code(reply.param), Some(Param::Cells));
    assert_eq!(observed(&core), before);
    // A good one: Reply Ok, then Hello(configured), maps cleared, the classifier's gating
    // follows (hard gate: a point feeds one layer).
    let good = Configure {
        gate: crate::wire::link::GateRequest::Hard,
        ..default
    };
    core.host(&command(9, &Message::Configure(good)));
    let out = output(&mut core);
    assert!(matches!(out[0].1, Out::Reply(r) if r.is_ok() && r.to_seq == 9));
    assert!(matches!(&out[1].1, Out::Hello(h) if h.reason == HelloReason::Configured));
    assert_eq!(observed(&core), 0);
    let hard = Design::<8>::new(
        SensorModel::default(),
        Schedule {
            gate: GateShape::Hard,
            ..Schedule::default()
        },
        64,
    )
    .unwrap();
    let mut expected = crate::gate::Gates::<8>::new();
    expected
        .configure(&hard, Config::default().model.increments().unwrap())
        .unwrap();
    for k in 0..8 {
        assert_eq!(
            core.frontend().gates().table(k),
            expected.table(k),
            "layer {k}"
        );
    }
    assert_eq!(core.counters().link.commands_refused, 4);
}

#[test]
fn poses_are_validated_and_pan_angles_kept() {
    let mut core = booted();
    let good = PoseReport {
        x_m: 12.5,
        y_m: -3.0,
        z_m: 0.2,
        yaw_rad: 1.0,
        stamp_us: 77,
        flags: 0,
        ..PoseReport::default()
    };
    let bad = PoseReport {
        x_m: f32::INFINITY,
        ..good
    };
    let mut bytes = command(0, &Message::Pose(good));
    bytes.extend(command(1, &Message::Pose(bad)));
    bytes.extend(pan(2, 0x8000));
    core.host(&bytes);
    let expected = convert::pose_of(&good).unwrap();
    assert_eq!(*core.frontend().pose(), expected);
    assert_eq!(core.host_angle(), Some(Angle::from_bits(0x8000)));
    let out = output(&mut core);
    let r = replies(&out);
    assert_eq!(r.len(), 1, "only the refusal is answered");
    assert_eq!((r[0].param, r[0].code), (32, ReplyCode::NotFinite));
    assert_eq!(
        std::format!("{}", ReplyText(&r[0]).reason()),
        "pose x: must be a finite number"
    );
}

#[test]
fn snapshot_reset_ping_and_bad_frames() {
    let mut core = booted();
    core.host(&pan(0, 0x0E39));
    core.laser(&floor_telegram(), 0, &mut NoAngleSource);
    assert!(observed(&core) > 0);
    core.poll(1);
    output(&mut core);
    // Snapshot of layer 2: Reply, Hello(snapshot, resend bit 2), then its 64 tiles.
    core.host(&command(
        1,
        &Message::RequestSnapshot(SnapshotScope::Layer(2)),
    ));
    let mut out = output(&mut core);
    for t in 0..40 {
        core.poll(100 + t * 100);
        out.extend(output(&mut core));
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
    core.host(&command(
        2,
        &Message::RequestSnapshot(SnapshotScope::Layer(9)),
    ));
    let r = replies(&output(&mut core))[0];
    assert_eq!((r.code, r.param, r.value), (ReplyCode::BadLayer, 40, 9.0));
    // Reset: Reply, Hello(reset), maps cleared.
    core.host(&command(3, &Message::Reset));
    let out = output(&mut core);
    assert!(matches!(&out[1].1, Out::Hello(h) if h.reason == HelloReason::Reset));
    assert_eq!(observed(&core), 0);
    // A corrupted frame: no answer, counted; a gap in the host's numbers is counted.
    let mut bytes = command(4, &Message::Ping);
    bytes[3] ^= 1;
    bytes.extend(command(6, &Message::Ping));
    // A device-bound type from the host: Unsupported.
    bytes.extend(command(
        7,
        &Message::Reply(Reply::ok(Header {
            version: 1,
            msg_type: 0x86,
            seq: 0,
        })),
    ));
    core.host(&bytes);
    let out = output(&mut core);
    assert!(matches!(out[0].1, Out::Reply(r) if r.is_ok() && r.to_seq == 6));
    assert!(matches!(out[1].1, Out::Reply(r) if r.code == ReplyCode::Unsupported));
    assert_eq!(core.link().rx_counters().crc, 1);
    assert_eq!(core.counters().link.rx_seq_gaps, 2, "4 and 5 missing");
    assert!(matches!(
        crate::wire::link::decode(&[]),
        Err((DecodeError::TooShort { .. }, None))
    ));
}

#[test]
fn setup_request_stats_end_observation_and_shutdown() {
    let mut core = booted();
    let setup = Setup {
        mount_block: crate::wire::link::MountSetup::PRESET,
        filter: crate::wire::link::FilterSetup::NONE,
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
        rule: crate::link::convert::rule_setup(&crate::classify::NavigabilityRule::DEFAULT),
        laser: crate::wire::link::LaserSetup::SICK,
    };
    let mut bytes = command(0, &Message::Setup(setup));
    bytes.extend(command(
        1,
        &Message::Setup(Setup {
            mount_block: crate::wire::link::MountSetup::PRESET,
            filter: crate::wire::link::FilterSetup::NONE,
            measuring_mode: 9,
            ..setup
        }),
    ));
    bytes.extend(command(2, &Message::EndObservation));
    bytes.extend(command(3, &Message::RequestStats));
    bytes.extend(command(4, &Message::Shutdown));
    bytes.extend(command(5, &Message::Ping));
    core.host(&bytes);
    let config = core.frontend().config();
    assert_eq!(config.lines_per_observation, 20);
    assert_eq!(config.variant, Variant::Fov100StepQuarter);
    assert_eq!(
        config.classifier.drop_threshold,
        Some(Meters::saturating_from_num(0.3_f32))
    );
    assert_eq!(config.classifier.ceiling, None);
    // The Ping after Shutdown is dropped; laser bytes are no longer taken.
    assert!(core.shutdown_requested());
    assert!(core.counters().app.bytes_after_shutdown > 0);
    core.laser(&floor_telegram(), 0, &mut NoAngleSource);
    assert_eq!(core.counters().laser.sick().unwrap().telegrams_ok, 0);
    core.answer_shutdown(StackUsage {
        used: 1234,
        size: 4096,
    });
    assert!(core.stopped() && !core.shutdown_requested());
    // A second answer adds nothing.
    core.answer_shutdown(StackUsage::default());
    // Stats goes out at the next poll although the interval is 0 (never).
    let (out, r) = poll_replies(&mut core, 3);
    assert!(r[0].is_ok() && r[0].to_type == 0x87);
    assert_eq!((r[1].code, r[1].param), (ReplyCode::OutOfRange, 49));
    assert_eq!((r[2].to_type, r[2].value, r[2].a), (0x89, 1234.0, 4096.0));
    assert!(out.iter().any(|(_, o)| matches!(o, Out::Stats(_))));
}

/// SetRule changes the classifier's step and rule and nothing else of the setup; a bad
/// rule is refused with its param and changes nothing.
#[test]
fn set_rule_changes_only_the_classifiers_rule() {
    use crate::classify::{NavigabilityRule, PlaneRule};
    use crate::wire::link::{RuleSetup, SetRule};
    let mut core = booted();
    let before = *core.frontend().config();
    assert_eq!(before.classifier.rule, NavigabilityRule::DEFAULT);
    let paper = SetRule {
        step_threshold_m: 0.08,
        rule: RuleSetup::SPREAD,
    };
    let mut bytes = command(0, &Message::SetRule(paper));
    bytes.extend(command(
        1,
        &Message::SetRule(SetRule {
            rule: RuleSetup {
                rule: 3,
                ..RuleSetup::SPREAD
            },
            ..paper
        }),
    ));
    core.host(&bytes);
    let after = *core.frontend().config();
    assert_eq!(after.classifier.rule, NavigabilityRule::Spread);
    assert_eq!(
        after.classifier.step_threshold,
        Meters::saturating_from_num(0.08_f32)
    );
    let unchanged = FrontendConfig {
        classifier: before.classifier,
        ..after
    };
    assert_eq!(unchanged, before);
    // Back to the default rule (the plane rule with its defaults, or without the plane-rule
    // feature the paper's), exactly.
    let default = crate::link::convert::set_rule_message(&before.classifier);
    core.host(&command(2, &Message::SetRule(default)));
    assert_eq!(*core.frontend().config(), before);
    assert_eq!(
        core.frontend().config().classifier.rule,
        if cfg!(feature = "plane-rule") {
            NavigabilityRule::Plane(PlaneRule::DEFAULT)
        } else {
            NavigabilityRule::Spread
        }
    );
    let (_, r) = poll_replies(&mut core, 3);
    assert!(r[0].is_ok() && r[0].to_type == 0x8B);
    assert_eq!((r[1].code, r[1].param), (ReplyCode::OutOfRange, 65));
    assert!(r[2].is_ok());
}

#[test]
fn drain_writes_what_the_writer_takes_within_the_limit() {
    /// Takes at most `chunk` bytes a call.
    struct Slow {
        taken: Vec<u8>,
        chunk: usize,
    }
    impl embedded_io::ErrorType for Slow {
        type Error = core::convert::Infallible;
    }
    impl embedded_io::Write for Slow {
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            let n = buf.len().min(self.chunk);
            self.taken.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }
    let mut core = Box::new(Core::new());
    core.boot(LinkConfig::DEFAULT, &design(), &Config::default(), setup())
        .unwrap();
    core.poll(0);
    let mut slow = Slow {
        taken: Vec::new(),
        chunk: 7,
    };
    let Ok(n) = core.drain(&mut slow, 50);
    assert_eq!(n, 50);
    let Ok(rest) = core.drain(&mut slow, usize::MAX);
    assert!(rest > 0);
    assert_eq!(slow.taken.len(), 50 + rest);
    let out = decode_all(&slow.taken);
    assert!(matches!(&out[0].1, Out::Hello(h) if h.reason == HelloReason::Boot));
}

/// The board passes the time of the host bytes (`host_at`): a TimeRequest they complete is
/// answered by a TimeReply with that device time; `host` (no time) answers with the last one
/// known. Counted in Stats `time_requests`.
#[test]
fn a_time_request_is_answered_with_the_time_of_its_bytes() {
    let mut core = booted();
    let request = |seq, host_us| command(seq, &Message::TimeRequest(TimeRequest { host_us }));
    core.host_at(&request(0, 11), 2_000_000);
    core.host(&request(1, 12));
    core.host_at(&request(2, 13), u32::MAX - 5);
    let times: Vec<_> = output(&mut core)
        .into_iter()
        .map(|(_, o)| match o {
            Out::TimeReply(t) => (t.host_us, t.device_us, t.queued_ahead),
            other => panic!("{other:?}"),
        })
        .collect();
    // Each reply waits behind those before it: a TimeReply is 24 bytes on the wire here
    // (22 decoded, two COBS code bytes; the delimiter is one of the 24).
    assert_eq!(
        times,
        [
            (11, 2_000_000, 0),
            (12, 2_000_000, 24),
            (13, u32::MAX - 5, 48)
        ]
    );
    assert_eq!(core.counters().link.time_requests, 3);
    core.host(&command(3, &Message::RequestStats));
    core.poll(5);
    let stats = output(&mut core)
        .into_iter()
        .find_map(|(_, o)| o.stats())
        .unwrap();
    assert_eq!(stats.time_requests, 3);
}

/// A stamped Pose (flags bit 0) is taken without a Reply, like an unstamped one; a Pose with
/// another flag bit is refused (param 38).
#[test]
fn stamped_poses_are_taken_and_unknown_flags_refused() {
    let mut core = booted();
    let stamped = PoseReport {
        x_m: 2.0,
        yaw_rad: 0.5,
        stamp_us: 1_000_000,
        flags: crate::wire::link::POSE_STAMPED,
        ..PoseReport::default()
    };
    let odd = PoseReport {
        flags: 0x04,
        ..stamped
    };
    let mut bytes = command(0, &Message::Pose(stamped));
    bytes.extend(command(1, &Message::Pose(odd)));
    core.host(&bytes);
    let r = replies(&output(&mut core));
    assert_eq!(r.len(), 1, "only the refusal is answered");
    assert_eq!(
        (
            r[0].to_seq,
            r[0].code,
            r[0].param,
            r[0].value,
            r[0].a,
            r[0].b
        ),
        (1, ReplyCode::OutOfRange, 38, 4.0, 0.0, 1.0)
    );
    assert_eq!(core.counters().app.commands, 1);
}
