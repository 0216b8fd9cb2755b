//! The pipeline's tests: SICK lines, lidar packets, sweeps and observations, and timed
//! placement against the untimed path.

use super::*;
use crate::design::{Design, Schedule, SensorModel};
use crate::geometry::PoseTrack;
use crate::geometry::ScanPlane;
use crate::laser::SensorKind;
use crate::pyramid::Config;
use crate::units::Point3;
use crate::wire::sick::MeasuredValues;
use crate::wire::sick::Unit;
use crate::wire::LaserReturn;
use crate::Fused;
extern crate std;
use std::vec::Vec;

#[test]
fn the_step_per_return_is_the_i64_quotient() {
    let mut x = 0x9E37_79B9_7F4A_7C15_u64;
    for steps in 2..=255_i64 {
        for _ in 0..500 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let turn = i64::from(x as i32);
            for t in [turn, -turn, 1, -1, i64::from(i32::MAX), i64::from(i32::MIN)] {
                assert_eq!(
                    super::packet::step_q16(t, steps),
                    (t << 16) / steps,
                    "{t} {steps}"
                );
            }
        }
    }
}

/// A SICK at 0.5 m on a tilt unit, looking at flat floor with a wall 2 m ahead.
fn ranges_mm(tilt_deg: f64) -> Vec<u8> {
    let tau = tilt_deg.to_radians();
    let mut bytes = Vec::new();
    for i in 0..361 {
        let theta = (i as f64 * 0.5).to_radians();
        // Beam direction after the tilt: (sin θ cos τ, −cos θ, −sin θ sin τ).
        let (dx, dz) = (theta.sin() * tau.cos(), -theta.sin() * tau.sin());
        let floor = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
        let wall = if dx > 1e-6 { 2.0 / dx } else { f64::INFINITY };
        let r = floor.min(wall);
        let raw: u16 = if r < 8.0 {
            (r * 1000.0).round() as u16
        } else {
            0x1FFF
        };
        bytes.extend_from_slice(&raw.to_le_bytes());
    }
    bytes
}

/// A boxed pipeline (its 4096-slot scratch is 192 KiB) and pyramid of the default design.
fn setup(
    lines: u32,
) -> (
    std::boxed::Box<Frontend<4096, 8>>,
    std::boxed::Box<Pyramid<64, 8>>,
) {
    let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
    let mut p = std::boxed::Box::new(Pyramid::new());
    p.configure(&design, &Config::default()).unwrap();
    let mut f = std::boxed::Box::new(Frontend::unconfigured());
    f.configure(sick_on_a_tilt_unit(lines));
    f.adopt_design(&design, &Config::default()).unwrap();
    (f, p)
}

/// A SICK LMS 291 at 180°/0.5° (mm, 8 m), 0.5 m up on a tilt unit, an observation every
/// `lines_per_observation` lines (0: per sweep).
pub(crate) fn sick_on_a_tilt_unit(lines_per_observation: u32) -> FrontendConfig {
    FrontendConfig {
        filter: crate::pipeline::ReturnFilter::NONE,
        mount: Mount::new(
            ScanPlane::TiltedHorizontal,
            Point3 {
                z: Meters::from_num(0.5),
                ..Point3::default()
            },
        ),
        sensor: Sensor::Sick,
        baud: 500_000,
        actuator: Actuator::External,
        variant: Variant::Fov180StepHalf,
        measuring_mode: MeasuringMode::Mm8Cm80,
        lines_per_observation,
        classifier: ClassifierConfig::default(),
        missing_ground_within: None,
    }
}

fn sweep(f: &mut Frontend<4096, 8>, p: &mut Pyramid<64, 8>, degrees: impl Iterator<Item = u32>) {
    for tilt in degrees {
        let values = ranges_mm(f64::from(tilt));
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        f.set_actuator(FineAngle::from_quarter_degrees(4 * tilt));
        f.line(p, &line).unwrap();
    }
}

#[test]
fn a_sweep_over_floor_and_wall_marks_both() {
    let (mut f, mut p) = setup(36);
    sweep(&mut f, &mut p, 5..41);
    assert_eq!(f.stats().observations, 1);
    assert_eq!(f.stats().lines_applied, 36);
    let at = |x: f32, y: f32| p.fused(Meters::from_num(x), Meters::from_num(y));
    assert!(
        matches!(at(1.0, 0.05), Fused::Navigable { .. }),
        "{:?}",
        at(1.0, 0.05)
    );
    assert!(
        matches!(at(2.02, 0.05), Fused::Obstacle { .. }),
        "{:?}",
        at(2.02, 0.05)
    );
}

#[test]
fn no_return_beams_mark_missing_ground_only_when_asked() {
    // The floor returns nothing between 1.2 and 1.6 m ahead (a hole), seen at 20° tilt.
    let holed = |tilt: f64| {
        let mut v = ranges_mm(tilt);
        for pair in v.chunks_mut(2) {
            let r = u16::from_le_bytes([pair[0], pair[1]]);
            let ahead = f64::from(r) / 1000.0 * tilt.to_radians().cos();
            if (1.2..1.6).contains(&ahead) {
                pair.copy_from_slice(&0x1FFF_u16.to_le_bytes());
            }
        }
        v
    };
    for within in [None, Some(Meters::from_num(8))] {
        let (mut f, mut p) = setup(1);
        let mut config = *f.config();
        config.missing_ground_within = within;
        f.configure(config);
        let values = holed(20.0);
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        f.set_actuator(FineAngle::from_quarter_degrees(80));
        f.line(&mut p, &line).unwrap();
        let at_hole = p.fused(Meters::from_num(1.4), Meters::from_num(0.02));
        if within.is_some() {
            assert!(f.stats().missing_ground > 0);
            assert!(matches!(at_hole, Fused::Obstacle { .. }), "{at_hole:?}");
        } else {
            assert_eq!(f.stats().missing_ground, 0);
            assert_eq!(at_hole, Fused::Unknown);
        }
    }
}

#[test]
fn an_unconfigured_pipeline_refuses_lines() {
    let (_, mut p) = setup(1);
    let mut f = Frontend::<64, 8>::unconfigured();
    let values = ranges_mm(20.0);
    let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
    assert_eq!(f.line(&mut p, &line), Err(LineError::NotConfigured));
    assert_eq!(f.stats().lines_rejected, 1);
}

#[test]
fn a_line_that_does_not_fit_the_variant_is_refused_whole() {
    let (mut f, mut p) = setup(1);
    let values = ranges_mm(20.0);
    let short = MeasuredValues::new(Unit::Millimetre, 0, &values[..360], None, 0).unwrap();
    assert_eq!(
        f.line(&mut p, &short),
        Err(LineError::CountMismatch {
            count: 180,
            expected: 361
        })
    );
    assert_eq!(f.stats().lines_rejected, 1);
    assert_eq!(f.classifier_stats().points, 0);
    assert_eq!(p.stats().applied, 0);
}

/// The same frontend set up for an LD06 on the tilt unit, 0.5 m up.
fn lidar(
    revolutions: u32,
) -> (
    std::boxed::Box<Frontend<4096, 8>>,
    std::boxed::Box<Pyramid<64, 8>>,
) {
    let (mut f, p) = setup(revolutions);
    let mut config = *f.config();
    config.sensor = Sensor::Ld06;
    config.baud = 230_400;
    f.configure(config);
    (f, p)
}

/// Twelve returns from `start_deg` clockwise 0.8° apart, as a lidar 0.5 m up tilted by
/// `tilt_deg` sees flat floor (no return where the beam does not meet it within 8 m).
fn floor_returns(start_deg: f64, tilt_deg: f64) -> Vec<LaserReturn> {
    let tau = tilt_deg.to_radians();
    (0..12)
        .map(|k| {
            let phi = start_deg + 0.8 * f64::from(k);
            let theta = (90.0 - phi).to_radians();
            let dz = -theta.sin() * tau.sin();
            let r = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
            LaserReturn {
                angle: FineAngle::from_bits(
                    (phi.rem_euclid(360.0) / 360.0 * 4_294_967_296.0) as u32,
                ),
                range_mm: if r < 8.0 {
                    (r * 1000.0).round() as u32
                } else {
                    0
                },
                quality: Some(100),
            }
        })
        .collect()
}

fn all_cells(p: &Pyramid<64, 8>) -> Vec<Option<crate::Cell>> {
    let mut cells = Vec::new();
    for k in 0..p.layer_count() {
        let layer = p.layer(k).unwrap();
        let (ox, oy) = layer.origin();
        for j in 0..64 {
            for i in 0..64 {
                cells.push(layer.get(ox + i, oy + j));
            }
        }
    }
    cells
}

#[test]
fn lidar_packets_mark_the_floor_ahead() {
    let (mut f, mut p) = lidar(1);
    // A revolution: 0° ahead, packets of 9.6° all the way round, tilted 25° down.
    for n in 0..38 {
        let start = f64::from(n) * 9.6 - 4.8;
        let returns = floor_returns(start, 25.0);
        let wraps = n == 0 || n == 37;
        f.packet(
            &mut p,
            returns,
            wraps,
            PacketActuator::still(FineAngle::from_quarter_degrees(100)),
        )
        .unwrap();
    }
    assert_eq!(f.stats().packets_applied, 38);
    assert_eq!(f.stats().revolutions, 2);
    // The second start closed the first observation.
    assert_eq!(f.stats().observations, 1);
    assert!(f.stats().returns > 100 && f.stats().no_return > 100);
    let at = |x: f32, y: f32| p.fused(Meters::from_num(x), Meters::from_num(y));
    // 0.5 m up at 25°: the floor ahead at 1.07 m, behind the beams go up (no return).
    assert!(
        matches!(at(1.07, 0.0), Fused::Navigable { .. }),
        "{:?}",
        at(1.07, 0.0)
    );
    assert_eq!(at(-1.07, 0.0), Fused::Unknown);
    // A SICK line is refused while a lidar is set up, and a packet while a SICK is.
    let values = ranges_mm(20.0);
    let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
    assert_eq!(
        f.line(&mut p, &line),
        Err(LineError::WrongSensor {
            configured: SensorKind::Ld06
        })
    );
    let (mut sick, mut q) = setup(1);
    assert_eq!(
        sick.packet(
            &mut q,
            floor_returns(0.0, 20.0),
            false,
            PacketActuator::default()
        ),
        Err(LineError::WrongSensor {
            configured: SensorKind::Sick
        })
    );
    assert_eq!(sick.stats().lines_rejected, 1);
}

#[test]
fn each_return_gets_its_own_actuator_angle() {
    // One packet while the actuator turns from 10° to 21°, against twelve packets of one
    // return each at the interpolated angle (1° apart): the same points, the same cells.
    let first = FineAngle::from_quarter_degrees(40);
    let step = FineAngle::from_quarter_degrees(4).to_bits();
    let last = FineAngle::from_bits(first.to_bits() + 11 * step);
    let returns = floor_returns(-4.8, 15.0);
    let (mut whole, mut p) = lidar(0);
    whole
        .packet(
            &mut p,
            returns.clone(),
            false,
            PacketActuator { first, last },
        )
        .unwrap();
    whole.end_observation(&mut p);
    let (mut single, mut q) = lidar(0);
    for (k, r) in returns.iter().enumerate() {
        let a = FineAngle::from_bits(first.to_bits() + k as u32 * step);
        single
            .packet(&mut q, [*r], false, PacketActuator::still(a))
            .unwrap();
    }
    single.end_observation(&mut q);
    assert_eq!(whole.classifier_stats(), single.classifier_stats());
    assert_eq!(all_cells(&p), all_cells(&q));
    // And not the cells of a packet at one angle throughout.
    let (mut still, mut r) = lidar(0);
    still
        .packet(&mut r, returns, false, PacketActuator::still(first))
        .unwrap();
    still.end_observation(&mut r);
    assert_ne!(all_cells(&p), all_cells(&r));
}

#[test]
fn a_lidar_sweep_ends_when_the_actuator_turns_back() {
    let (mut f, mut p) = lidar(0);
    let packet = |f: &mut Frontend<4096, 8>, p: &mut Pyramid<64, 8>, a: u32, b: u32| {
        let act = PacketActuator {
            first: FineAngle::from_quarter_degrees(a),
            last: FineAngle::from_quarter_degrees(b),
        };
        f.packet(p, floor_returns(0.0, 20.0), false, act).unwrap();
    };
    for a in 40..60 {
        packet(&mut f, &mut p, 4 * a, 4 * a + 2);
    }
    assert_eq!(f.stats().observations, 0);
    packet(&mut f, &mut p, 240, 236);
    assert_eq!(f.stats().observations, 1);
    assert_eq!(f.lines_in_observation(), 1);
}

#[test]
fn a_sweep_ends_when_the_actuator_turns_back() {
    let (mut f, mut p) = setup(0);
    sweep(&mut f, &mut p, 5..41);
    assert_eq!(f.stats().observations, 0);
    sweep(&mut f, &mut p, (5..40).rev());
    assert_eq!(f.stats().observations, 1);
    f.end_observation(&mut p);
    assert_eq!(f.stats().observations, 2);
}

/// A pose track of a robot driving along x at 1 m/s and turning at 1 rad/s, stamped
/// every 20 ms from `t0_us`.
fn moving_track(t0_us: u32, count: u32) -> PoseTrack<16> {
    let mut track = PoseTrack::new();
    for k in 0..count {
        let t = f64::from(k) * 0.02;
        let pose = Pose {
            x: Meters::from_num(t),
            y: Meters::from_num(0.1 * t),
            yaw: FineAngle::from_bits((t / core::f64::consts::TAU * 4_294_967_296.0) as u32),
            ..Pose::IDENTITY
        };
        track
            .push(t0_us.wrapping_add(k * 20_000), pose, t0_us)
            .unwrap();
    }
    track
}

#[test]
fn timed_returns_take_the_pose_of_their_moment_by_the_quantum_rule() {
    // The clock wraps during the packets.
    let t0 = u32::MAX - 30_000;
    let track = moving_track(t0, 16);
    let first = FineAngle::from_quarter_degrees(40);
    let (mut whole, mut p) = lidar(0);
    let (mut single, mut q) = lidar(0);
    let mut in_force: Option<u32> = None;
    let mut placed = 0;
    let mut span = (0_u32, 0_u32);
    for n in 0..40_u32 {
        // Packets of 12 returns over 2.2 ms, 2.67 ms apart, 10 ms after the first pose.
        let start = t0.wrapping_add(10_000 + n * 2_667);
        let times = PacketTimes {
            first_us: start,
            last_us: start.wrapping_add(2_200),
        };
        let returns = floor_returns(f64::from(n) * 9.6, 15.0);
        whole
            .packet_timed(
                &mut p,
                returns.clone(),
                false,
                PacketActuator::still(first),
                times,
                &track,
            )
            .unwrap();
        // The same rule, return by return: the pose at the return's own time (k·200 µs),
        // kept while within 1 ms of the time it was evaluated at.
        for (k, r) in returns.iter().enumerate() {
            let t = start.wrapping_add(k as u32 * 200);
            if r.range_mm == 0 {
                continue;
            }
            if in_force.is_none_or(|f| t.wrapping_sub(f) as i32 >= 1_000) {
                in_force = Some(t);
            }
            let pose = track.at(in_force.unwrap()).unwrap().0;
            single.set_pose(pose);
            single
                .packet(&mut q, [*r], false, PacketActuator::still(first))
                .unwrap();
            if placed == 0 {
                span.0 = t;
            }
            span.1 = t;
            placed += 1;
        }
    }
    assert!(placed > 100);
    whole.end_observation(&mut p);
    single.end_observation(&mut q);
    assert_eq!(whole.classifier_stats(), single.classifier_stats());
    assert_eq!(all_cells(&p), all_cells(&q));
    assert_eq!(whole.pose(), single.pose());
    assert_eq!(whole.stats().returns_extrapolated, 0);
    assert_eq!(whole.stats().returns_without_pose, 0);
    assert_eq!(
        whole.take_observed(),
        Some(ObservedSpan {
            observation: 1,
            first_us: span.0,
            last_us: span.1
        })
    );
    assert_eq!(whole.take_observed(), None);
    assert_eq!(single.take_observed(), None);
}

#[test]
fn timed_returns_past_the_track_are_extrapolated_then_refused() {
    let track = moving_track(0, 2);
    let (mut f, mut p) = lidar(0);
    let returns = floor_returns(0.0, 15.0);
    let placeable = returns.iter().filter(|r| r.range_mm != 0).count() as u32;
    assert!(placeable > 0);
    let packet = |f: &mut Frontend<4096, 8>, p: &mut Pyramid<64, 8>, first_us: u32| {
        let times = PacketTimes {
            first_us,
            last_us: first_us + 2_200,
        };
        let act = PacketActuator::still(FineAngle::from_quarter_degrees(60));
        f.packet_timed(p, returns.clone(), false, act, times, &track)
            .unwrap();
    };
    // Within 100 ms of the newest pose (20 ms): extrapolated.
    packet(&mut f, &mut p, 100_000);
    assert_eq!(f.stats().returns_extrapolated, placeable);
    assert_eq!(f.stats().returns_without_pose, 0);
    // Past it: refused, counted, and nothing more placed.
    let points = f.classifier_stats().points;
    packet(&mut f, &mut p, 130_000);
    assert_eq!(f.stats().returns_without_pose, placeable);
    assert_eq!(f.classifier_stats().points, points);
    // Before the oldest pose: refused too.
    packet(&mut f, &mut p, 0_u32.wrapping_sub(5_000));
    assert_eq!(f.stats().returns_without_pose, 2 * placeable);
}

#[test]
fn a_timed_sick_line_with_a_still_robot_is_the_untimed_line() {
    // A track that holds one pose for the whole line places it as set_pose does.
    let pose = Pose {
        x: Meters::from_num(0.25),
        yaw: FineAngle::from_quarter_degrees(40),
        ..Pose::IDENTITY
    };
    let mut track = PoseTrack::<4>::new();
    track.push(0, pose, 0).unwrap();
    track.push(40_000, pose, 0).unwrap();
    let (mut timed, mut p) = setup(1);
    let (mut untimed, mut q) = setup(1);
    untimed.set_pose(pose);
    let values = ranges_mm(20.0);
    let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
    for f in [&mut timed, &mut untimed] {
        f.set_actuator(FineAngle::from_quarter_degrees(80));
    }
    timed.line_timed(&mut p, &line, 30_000, &track).unwrap();
    untimed.line(&mut q, &line).unwrap();
    assert_eq!(timed.classifier_stats(), untimed.classifier_stats());
    assert_eq!(all_cells(&p), all_cells(&q));
    // The 0.5° line spans two mirror turns: its first beam 19.98 ms before its last.
    let span = timed.take_observed().unwrap();
    assert!(span.last_us <= 30_000 && span.last_us > 29_000, "{span:?}");
    assert!(
        span.first_us >= 30_000 - 19_982 && span.first_us < 11_000,
        "{span:?}"
    );
    assert_eq!(untimed.take_observed(), None, "an untimed line has no span");
    // A line whose beams all precede the track is refused beam by beam.
    let (mut early, mut r) = setup(1);
    early.set_actuator(FineAngle::from_quarter_degrees(80));
    early.line_timed(&mut r, &line, 10_000, &track).unwrap();
    let s = early.stats();
    assert!(
        s.returns_without_pose > 0 && s.returns_without_pose < s.returns,
        "{s:?}"
    );
}

/// [`setup`]'s pipeline with `C` classifier slots.
fn setup_slots<const C: usize>(lines: u32) -> std::boxed::Box<Frontend<C, 8>> {
    let (f, _) = setup(lines);
    let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
    let mut small = std::boxed::Box::new(Frontend::<C, 8>::unconfigured());
    small.configure(*f.config());
    small.adopt_design(&design, &Config::default()).unwrap();
    small
}

/// A scratch too small for a sweep: the observation is split where the scratch could not
/// be sure to hold the next return, and no return is dropped; a scratch that holds the sweep
/// never splits, and both feed the classifier the same points.
#[test]
fn a_full_scratch_splits_the_observation_and_drops_nothing() {
    let mut small = setup_slots::<16>(36);
    let mut large = setup_slots::<4096>(36);
    let (_, mut p) = setup(36);
    let (_, mut q) = setup(36);
    for tilt in 5..41 {
        let values = ranges_mm(f64::from(tilt));
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        let angle = FineAngle::from_quarter_degrees(4 * tilt);
        small.set_actuator(angle);
        large.set_actuator(angle);
        small.line(&mut p, &line).unwrap();
        large.line(&mut q, &line).unwrap();
    }
    let (s, c) = (small.stats(), small.classifier_stats());
    let (sl, cl) = (large.stats(), large.classifier_stats());
    assert_eq!(c.overflow_points, 0);
    assert_eq!(cl.overflow_points, 0);
    assert_eq!((sl.observations, sl.observations_split), (1, 0));
    assert!(s.observations_split > 10, "{s:?}");
    assert_eq!(s.observations, 1 + s.observations_split);
    // Every point the large scratch used, the small one used too.
    assert_eq!(c.points, cl.points);
    assert_eq!(c.points_used, cl.points_used);
    assert_eq!(c.points_gated_out, cl.points_gated_out);
    let at = |x: f32, y: f32| p.fused(Meters::from_num(x), Meters::from_num(y));
    assert!(
        matches!(at(1.0, 0.05), Fused::Navigable { .. }),
        "{:?}",
        at(1.0, 0.05)
    );
    // Without the split, the small scratch drops returns: the same sweep with the split
    // disabled (as before) is what `overflow_points` counted.
    let mut dropping = setup_slots::<16>(36);
    dropping.slots_per_return = 0;
    let (_, mut r) = setup(36);
    for tilt in 5..41 {
        let values = ranges_mm(f64::from(tilt));
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        dropping.set_actuator(FineAngle::from_quarter_degrees(4 * tilt));
        dropping.line(&mut r, &line).unwrap();
    }
    assert!(dropping.classifier_stats().overflow_points > 1000);
    assert_eq!(dropping.stats().observations_split, 0);
}
