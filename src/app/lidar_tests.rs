//! The application core with a spinning lidar: the Setup that chooses it, its packets timed
//! and placed at the actuator's angle of each return, its counters in Stats, and the servo.
extern crate std;
use super::tests::{booted, output, pan, Core};
use super::*;
use crate::actuator::SERVO_SETTLE_US;
use crate::angle::AngleSource;
use crate::angle::FineAngle;
use crate::link::tests::{command, Out};
use crate::wire::ld06::{Ld06Point, Ld06Repr};
use crate::wire::link::{LaserSetup, Message, Setup, Stats};
use crate::Fused;
use std::vec::Vec;

/// LD06 at 10 Hz: 3 600 °/s, 0.8° between returns, 9.6° between packets.
const SPEED: u16 = 3_600;
/// The transmission time of one LD06 packet at 230 400 Bd, µs (47 bytes of 10 bits).
const TX_US: f64 = 47.0 * 10.0 / 230_400.0 * 1e6;

fn setup(actuator: u8, latency_ms: f32) -> Setup {
    Setup {
        field_deg: 0,
        resolution_cdeg: 0,
        sensor_m: [0.0, 0.0, 0.5],
        ceiling_m: 0.0,
        laser: LaserSetup {
            actuator,
            servo_min_deg: 5.0,
            servo_max_deg: 35.0,
            servo_latency_ms: latency_ms,
            ..crate::wire::link::examples::LD06_ON_A_SERVO
        },
        ..crate::wire::link::examples::sick_setup(crate::link::convert::rule_setup(
            &crate::classify::NavigabilityRule::DEFAULT,
        ))
    }
}

/// One LD06 packet of a lidar 0.5 m above flat floor: packet `n` of the stream (from 0° at
/// t = 0), each return at the tilt `tilt_deg(t)` of its own time (seconds).
fn packet(n: u32, tilt_deg: impl Fn(f64) -> f64) -> Vec<u8> {
    let start = f64::from(n) * 9.6;
    let mut points = [Ld06Point::default(); 12];
    for (j, p) in points.iter_mut().enumerate() {
        let phi = start + 0.8 * j as f64;
        let t = phi / f64::from(SPEED);
        let tau = tilt_deg(t).to_radians();
        let theta = (90.0 - phi).to_radians();
        let dz = -theta.sin() * tau.sin();
        let r = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
        p.distance_mm = if r < 8.0 {
            (r * 1000.0).round() as u16
        } else {
            0
        };
        p.intensity = 200;
    }
    let repr = Ld06Repr {
        speed_deg_per_s: SPEED,
        start_angle_centideg: ((start * 100.0).round() as u32 % 36_000) as u16,
        end_angle_centideg: (((start + 8.8) * 100.0).round() as u32 % 36_000) as u16,
        timestamp_ms: 0,
        points,
    };
    let mut buf = std::vec![0; 47];
    repr.emit(&mut buf).unwrap();
    buf
}

/// When packet `n`'s last byte arrives, µs: its last return plus its transmission.
fn arrival_us(n: u32) -> u32 {
    let last = (f64::from(n) * 9.6 + 8.8) / f64::from(SPEED);
    (last * 1e6 + TX_US).round() as u32
}

fn stats(core: &mut Core, seq: u16) -> Stats {
    core.host(&command(seq, &Message::RequestStats));
    core.poll(1_000);
    output(core).iter().find_map(|(_, o)| o.stats()).unwrap()
}

/// Obstacles the fused map holds within 4 m ahead and to the sides.
fn obstacles(core: &Core) -> usize {
    let mut n = 0;
    for i in -40..40 {
        for j in -40..40 {
            let at = core.pyramid().fused(
                Meters::from_num(f64::from(i) * 0.1),
                Meters::from_num(f64::from(j) * 0.1),
            );
            n += usize::from(matches!(at, Fused::Obstacle { .. }));
        }
    }
    n
}

#[test]
fn a_setup_chooses_the_laser_and_its_baud_rate() {
    let mut core = booted();
    // Boot: the board sets up the boot sensor once.
    assert_eq!(
        core.take_laser_change(),
        Some(LaserPort {
            sensor: Sensor::Sick,
            baud: 500_000
        })
    );
    assert_eq!(core.take_laser_change(), None);
    core.host(&command(0, &Message::Setup(setup(0, 0.0))));
    let replies: Vec<_> = output(&mut core)
        .into_iter()
        .filter_map(|(_, o)| o.reply())
        .collect();
    assert!(replies[0].is_ok(), "{replies:?}");
    assert_eq!(
        core.take_laser_change(),
        Some(LaserPort {
            sensor: Sensor::Ld06,
            baud: 230_400
        })
    );
    assert_eq!(core.laser_baud(), 230_400);
    // The same Setup again changes nothing the board must redo.
    core.host(&command(1, &Message::Setup(setup(0, 0.0))));
    assert_eq!(core.take_laser_change(), None);
    // Another rate does.
    let mut faster = setup(0, 0.0);
    faster.laser.baud = 460_800;
    core.host(&command(2, &Message::Setup(faster)));
    assert_eq!(core.take_laser_change().map(|p| p.baud), Some(460_800));
    // No servo: nothing to command.
    assert_eq!(core.actuator_command(0), None);
}

#[test]
fn packets_take_the_hosts_angle_and_fill_stats() {
    let mut core = booted();
    core.host(&command(0, &Message::Setup(setup(0, 0.0))));
    output(&mut core);
    let bytes_before = u64::from(stats(&mut core, 1).laser_bytes);
    // No angle at all: packets are dropped and counted.
    core.laser(&packet(0, |_| 20.0), arrival_us(0), &mut NoAngleSource);
    assert_eq!(core.counters().app.lines_without_angle, 1);
    // The host's PanAngle (20° down) stands in for every return.
    core.host(&pan(2, 0x0E39));
    let mut fed = 47;
    let mut stream = Vec::new();
    for n in 1..=80 {
        stream.extend(packet(n, |_| 20.0));
    }
    // In uneven chunks, as a UART delivers them.
    for chunk in stream.chunks(100) {
        core.laser(chunk, 0, &mut NoAngleSource);
    }
    fed += stream.len();
    let c = core.counters();
    assert_eq!(c.frontend.packets_applied, 80);
    // Two revolutions start: within packet 37 (355.2° → 364°) and between 74 and 75
    // (715.2° → 724°, then 720°).
    assert_eq!(c.frontend.revolutions, 2);
    let LaserCounters::Ld06(ld06) = c.laser else {
        panic!("{:?}", c.laser)
    };
    assert_eq!(ld06.packets, 81);
    // A corrupted packet is a checksum error in Stats.
    let mut bad = packet(81, |_| 20.0);
    bad[20] ^= 0x10;
    core.laser(&bad, 0, &mut NoAngleSource);
    fed += 47;
    core.end_observation();
    let s = stats(&mut core, 3);
    assert_eq!(s.telegrams_ok, 81);
    assert_eq!(s.telegrams_bad_checksum, 1);
    assert_eq!(s.telegrams_bad_other, 1);
    assert_eq!(u64::from(s.laser_bytes) - bytes_before, fed as u64);
    assert!(s.points > 0);
    // Flat floor: navigable ahead, nothing an obstacle.
    let ahead = core
        .pyramid()
        .fused(Meters::from_num(1.37), Meters::from_num(0.0));
    assert!(matches!(ahead, Fused::Navigable { .. }), "{ahead:?}");
    assert_eq!(obstacles(&core), 0);
}

/// The servo's model, open loop: each return placed at the tilt of its own time. Flat floor
/// stays flat; a model whose latency is 100 ms off puts the floor at wrong heights, which the
/// classifier sees as steps.
#[test]
fn a_nodding_servo_places_each_return_at_its_own_tilt() {
    let run = |model_latency_ms: f32| {
        let mut core = booted();
        core.host(&command(0, &Message::Setup(setup(1, model_latency_ms))));
        output(&mut core);
        // The sweep begins at the first command: hold at 5° for the settling time, then
        // 5° → 35° → 5° at 60 °/s, 20 ms behind the command (the true servo).
        let hold = core.actuator_command(0).unwrap();
        let five = FineAngle::from_quarter_degrees(20);
        assert!(
            hold.wrapping_sub(five).to_bits().wrapping_add(8) < 16,
            "{hold:?}"
        );
        let start = f64::from(SERVO_SETTLE_US) / 1e6 + 0.020;
        let tilt = |t: f64| {
            let travelled = ((t - start).max(0.0) * 60.0).rem_euclid(60.0);
            if travelled < 30.0 {
                5.0 + travelled
            } else {
                35.0 - (travelled - 30.0)
            }
        };
        // 3 s of packets, each handed in when its last byte arrives.
        for n in 0..1_125 {
            let now = arrival_us(n);
            let _ = core.actuator_command(now);
            core.laser(&packet(n, tilt), now, &mut NoAngleSource);
        }
        core.end_observation();
        (core.counters(), obstacles(&core))
    };
    let (counters, right) = run(20.0);
    // Nothing before the settling hold ends is placed.
    assert!(counters.app.lines_without_angle > 150, "{counters:?}");
    assert!(counters.frontend.packets_applied > 800);
    // Five turns of the sweep: five observations (the last one ended by hand).
    assert!(counters.frontend.observations >= 5, "{counters:?}");
    assert_eq!(right, 0);
    let (_, wrong) = run(120.0);
    assert!(wrong > 0, "a 100 ms error of the model went unseen");
}

/// An encoder on the axis: read once per call, its readings interpolated; the board's
/// readings win over the model.
#[test]
fn an_encoders_readings_are_interpolated_per_return() {
    struct Moving {
        now_s: f64,
    }
    impl AngleSource for Moving {
        type Error = ();
        fn read_angle(&mut self) -> Result<Angle, ()> {
            // 10° + 40 °/s, in the encoder's Q0.16 turn.
            let deg = 10.0 + 40.0 * self.now_s;
            Ok(Angle::from_bits((deg / 360.0 * 65_536.0).round() as u16))
        }
    }
    let tilt = |t: f64| 10.0 + 40.0 * t;
    let mut core = booted();
    core.host(&command(0, &Message::Setup(setup(0, 0.0))));
    output(&mut core);
    for n in 0..280 {
        let now = arrival_us(n);
        let mut encoder = Moving {
            now_s: f64::from(now) / 1e6,
        };
        core.laser(&packet(n, tilt), now, &mut encoder);
    }
    core.end_observation();
    let c = core.counters();
    assert_eq!(c.app.angle_source_errors, 0);
    assert_eq!(c.frontend.packets_applied, 280);
    assert_eq!(obstacles(&core), 0);
}

/// Stamped poses: counted, refused, restarted after a gap; while the track holds one, each
/// packet's returns are placed at their own moments and the observation's span is known; an
/// unstamped pose or a Setup returns to the latest-pose rule.
#[test]
fn stamped_poses_place_returns_at_their_moments_and_are_counted() {
    use crate::geometry::Pose;
    let mut core = booted();
    core.host(&command(0, &Message::Setup(setup(0, 0.0))));
    output(&mut core);
    core.host(&pan(1, 0x0E39));
    let at = |x: f64| Pose {
        x: Meters::from_num(x),
        ..Pose::IDENTITY
    };
    // 1 m/s along x, stamped every 20 ms, 30 ms late: the pose for t arrives at t + 30 ms.
    let mut next_pose = 0_u32;
    let mut fed_to = 0_u32;
    for n in 0..200 {
        let now = arrival_us(n);
        while next_pose * 20_000 + 30_000 <= now {
            let t = next_pose * 20_000;
            core.stamped_pose(t, at(f64::from(t) / 1e6));
            next_pose += 1;
        }
        core.laser(&packet(n, |_| 20.0), now, &mut NoAngleSource);
        fed_to = now;
    }
    core.end_observation();
    let c = core.counters();
    assert_eq!(c.app.poses_stamped, next_pose);
    assert_eq!(c.app.poses_refused, 0);
    // Packets before the first pose went the latest-pose way; after it, the returns at most
    // 30 ms past the newest pose were extrapolated, none refused.
    assert!(c.frontend.returns_extrapolated > 0, "{c:?}");
    assert_eq!(c.frontend.returns_without_pose, 0);
    let span = core.take_observed().unwrap();
    assert_eq!(span.observation, c.frontend.observations);
    // The floor is seen ahead only: the last return placed lies within a revolution of the
    // end, the first after the first pose.
    assert!(
        span.last_us < fed_to && fed_to - span.last_us < 100_000,
        "{span:?}"
    );
    assert!(
        span.first_us > 0 && span.first_us < span.last_us,
        "{span:?}"
    );
    assert_eq!(core.take_observed(), None);
    // The robot moved: the window followed the pose in force at the observation's end.
    let newest = core.pose_track().newest().unwrap();
    assert!(
        core.frontend().pose().x > newest.1.x,
        "extrapolated past the newest"
    );
    // Out of order and far ahead: refused; a 600 ms gap: restarted.
    core.stamped_pose(0, at(0.0));
    core.stamped_pose(fed_to + 2_000_000, at(0.0));
    assert_eq!(core.counters().app.poses_refused, 2);
    core.stamped_pose(newest.0 + 600_000, at(9.0));
    assert_eq!(core.counters().app.pose_gaps, 1);
    assert_eq!(core.pose_track().len(), 1);
    // Returns long after the newest pose are refused and counted (a packet ahead, at 0°).
    core.laser(
        &packet(225, |_| 20.0),
        newest.0 + 800_000,
        &mut NoAngleSource,
    );
    assert!(core.counters().frontend.returns_without_pose > 0);
    // An unstamped pose clears the track, and so does a Setup.
    core.set_pose(at(1.0));
    assert!(core.pose_track().is_empty());
    core.stamped_pose(newest.0 + 900_000, at(9.0));
    assert_eq!(core.pose_track().len(), 1);
    core.host(&command(2, &Message::Setup(setup(0, 0.0))));
    assert!(core.pose_track().is_empty());
}

/// The device tells the host when its maps' data were measured: after an observation placed
/// with stamped poses, the next poll queues an Observed frame with its span ahead of the
/// patches it changed, and Stats carries the pose track's counters (i = 30 ..= 35).
#[test]
fn a_poll_sends_the_observed_span_ahead_of_its_patches_and_stats_count_the_poses() {
    use crate::geometry::Pose;
    let mut core = booted();
    core.host(&command(0, &Message::Setup(setup(0, 0.0))));
    core.host(&pan(1, 0x0E39));
    core.poll(0);
    output(&mut core);
    let mut next_pose = 0_u32;
    for n in 0..200 {
        let now = arrival_us(n);
        while next_pose * 20_000 + 30_000 <= now {
            let t = next_pose * 20_000;
            let pose = Pose {
                x: Meters::from_num(f64::from(t) / 1e6),
                ..Pose::IDENTITY
            };
            core.stamped_pose(t, pose);
            next_pose += 1;
        }
        core.laser(&packet(n, |_| 20.0), now, &mut NoAngleSource);
    }
    core.end_observation();
    let counted = core.counters();
    core.poll(2_000);
    let out = output(&mut core);
    let observed = out
        .iter()
        .position(|(_, o)| matches!(o, Out::Observed(_)))
        .expect("an Observed frame");
    let first_patch = out
        .iter()
        .position(|(_, o)| matches!(o, Out::Patch(..)))
        .expect("the observation's patches");
    assert!(observed < first_patch, "{out:?}");
    let o = out.iter().find_map(|(_, o)| o.observed()).unwrap();
    assert_eq!(o.observation, counted.frontend.observations);
    assert!(
        o.first_us < o.last_us && o.last_us <= arrival_us(199),
        "{o:?}"
    );
    // Once: the next poll has nothing new to say.
    core.poll(2_100);
    assert!(!output(&mut core)
        .iter()
        .any(|(_, o)| matches!(o, Out::Observed(_))));
    let s = stats(&mut core, 2);
    assert_eq!(s.poses_stamped, next_pose);
    assert_eq!(s.poses_refused, 0);
    assert_eq!(
        s.returns_extrapolated,
        counted.frontend.returns_extrapolated
    );
    assert!(s.returns_extrapolated > 0);
    assert_eq!(s.returns_without_pose, 0);
}
