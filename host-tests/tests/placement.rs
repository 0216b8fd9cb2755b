//! Each return at the pose of its own moment: the library's timed placement
//! (`Frontend::packet_timed` with a `PoseTrack`) against the rule written independently in
//! f64 (`reference::placement`) and the f64 geometry (`geometry::world_point`).
//!
//! The robot drives a circle: 1 m/s forward while turning at 1 rad/s, with a slow roll and
//! pitch and a rising z. Its poses are stamped at 50 Hz and reach the device 30 ± 10 ms late;
//! a lidar on the tilt unit returns 4 500 times a second, each return handed to the device
//! 3 ms after it was measured with the poses delivered by then (so most are extrapolated).
//! The clock starts 1 s before its wrap.
//!
//! Bound: the geometry's own (`lidar_error_bound_m`) plus the pose's interpolation: a
//! component of the fixed-point pose lies within one LSB of the exact interpolation of its
//! rounded inputs, extrapolated within (1 + ratio) LSB, and the inputs themselves are rounded
//! to half an LSB, which the interpolation carries with a factor up to 1 + 2·ratio (ratio =
//! (t − a)/(b − a) ≤ 7 here): per component (2 + 2·ratio) LSB, of 2⁻¹⁶ m for x, y, z and of
//! 2⁻³² turn for the angles (times the range).

use terrain_pyramid::geometry::{
    beam_angle_of_clockwise, Mount, Pose, PoseTrack, ScanPlane, SweepTransform,
};
use terrain_pyramid::pipeline::{Frontend, FrontendConfig, PacketActuator, PacketTimes};
use terrain_pyramid::{
    angle::FineAngle, Config, Design, Meters, Point3, Pyramid, Schedule, SensorModel,
};
use terrain_pyramid_host_tests::geometry::{self as g, lidar_error_bound_m, lidar_theta_rad};
use terrain_pyramid_host_tests::reference::placement::{later, Found, InForce, RefTrack};

/// The true pose at `t` seconds after the start.
fn truth(t: f64) -> g::Pose {
    let w = 1.0;
    g::Pose {
        x: 2.0 + (w * t).sin() / w,
        y: -1.0 + (1.0 - (w * t).cos()) / w,
        z: 0.05 * t,
        roll: 0.05 * (2.0 * t).sin(),
        pitch: -0.03 * (1.5 * t).cos(),
        // Wrapped into (−π, π], as a robot's stack reports it.
        yaw: {
            let y = (w * t + 2.8).rem_euclid(std::f64::consts::TAU);
            if y > std::f64::consts::PI {
                y - std::f64::consts::TAU
            } else {
                y
            }
        },
    }
}

/// The f32 values a host would send, and the f64 of those f32 (what both sides start from).
fn sent(p: &g::Pose) -> (Pose, g::Pose) {
    let f = |v: f64| v as f32;
    let lib = Pose::from_f32(f(p.x), f(p.y), f(p.z), f(p.roll), f(p.pitch), f(p.yaw)).unwrap();
    let r = |v: f64| f64::from(v as f32);
    let reference = g::Pose {
        x: r(p.x),
        y: r(p.y),
        z: r(p.z),
        roll: r(p.roll),
        pitch: r(p.pitch),
        yaw: r(p.yaw),
    };
    (lib, reference)
}

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1_u64 << 53) as f64
    }
}

fn frontend() -> (Box<Frontend<4096, 8>>, Box<Pyramid<64, 8>>, Mount) {
    let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
    let mut p = Box::new(Pyramid::new());
    p.configure(&design, &Config::default()).unwrap();
    let mount = Mount::new(
        ScanPlane::TiltedHorizontal,
        Point3 {
            x: Meters::from_num(0.1),
            y: Meters::ZERO,
            z: Meters::from_num(0.5),
        },
    );
    let mut config = FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal);
    config.mount = mount;
    config.sensor = terrain_pyramid::laser::Sensor::Ld06;
    config.baud = 230_400;
    config.lines_per_observation = 0;
    let mut f = Box::new(Frontend::unconfigured());
    f.configure(config);
    f.adopt_design(&design, &Config::default()).unwrap();
    (f, p, mount)
}

/// Runs the drive for `seconds`, each return handed to the device `handed_after_us` after it
/// was measured; returns (returns compared, largest error over its bound,
/// returns extrapolated, returns refused) — and with `latest` the latest-pose rule instead
/// (for contrast: its error over the bound).
fn drive(seconds: f64, latest: bool, handed_after_us: u32) -> (usize, f64, u32, u32) {
    let (mut f, mut p, mount) = frontend();
    let ref_mount = g::Mount {
        plane: g::Plane::TiltedHorizontal,
        position: [0.1, 0.0, 0.5],
    };
    let mut track = PoseTrack::<16>::new();
    let mut reference = RefTrack::new(16);
    let mut in_force = InForce::default();
    let start_us = 0_u32.wrapping_sub(1_000_000);
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    // The poses: stamped every 20 ms, delivered 30 ± 10 ms later.
    let poses: Vec<(u32, u32, g::Pose)> = (0..)
        .map(|k| f64::from(k) * 0.02)
        .take_while(|&t| t < seconds + 0.1)
        .map(|t| {
            let stamp = start_us.wrapping_add((t * 1e6).round() as u32);
            let late = 20_000 + (rng.unit() * 20_000.0) as u32;
            (stamp, stamp.wrapping_add(late), truth(t))
        })
        .collect();
    let mut delivered = 0;
    let tilt = FineAngle::from_quarter_degrees(60);
    let tilt_rad = 15_f64.to_radians();
    let (mut compared, mut worst) = (0, 0_f64);
    let n = (seconds * 4_500.0) as u32;
    for k in 0..n {
        let t_rel = f64::from(k) / 4_500.0;
        let t = start_us.wrapping_add((t_rel * 1e6).round() as u32);
        let handed = t.wrapping_add(handed_after_us);
        // The poses that reached the device by the time the return is handed to it.
        while delivered < poses.len() && later(handed, poses[delivered].1) >= 0 {
            let (stamp, arrival, pose) = poses[delivered];
            let (lib_pose, ref_pose) = sent(&pose);
            if latest {
                f.set_pose(lib_pose);
            } else {
                let taken = track.push(stamp, lib_pose, arrival);
                let ref_taken = reference.push(stamp, ref_pose, arrival);
                assert_eq!(taken.is_ok(), ref_taken.is_some());
                f.forget_timed_pose();
                in_force.forget();
            }
            delivered += 1;
        }
        // A return at the lidar's own angle, 0.6 .. 12 m.
        let phi_deg = (t_rel * 3_600.0).rem_euclid(360.0);
        let range_mm = 600 + (rng.unit() * 11_400.0) as u32;
        let angle = FineAngle::from_bits((phi_deg / 360.0 * 4_294_967_296.0) as u32);
        let ret = terrain_pyramid::wire::LaserReturn {
            angle,
            range_mm,
            quality: Some(200),
        };
        let without = f.stats().returns_without_pose;
        let times = PacketTimes {
            first_us: t,
            last_us: t,
        };
        if latest {
            f.packet(&mut p, [ret], false, PacketActuator::still(tilt))
                .unwrap();
        } else {
            f.packet_timed(
                &mut p,
                [ret],
                false,
                PacketActuator::still(tilt),
                times,
                &track,
            )
            .unwrap();
        }
        let refused = f.stats().returns_without_pose != without;
        // The reference: the true pose of the moment, by the rule in f64.
        let wanted = if latest {
            // Contrast: the latest pose against the true pose of the moment.
            Some((sent(&truth(t_rel)).1, Found::Between, 1.0))
        } else {
            in_force.pose(&reference, t).map(|(pose, found)| {
                // The interpolation's ratio, for the bound.
                let ratio = match found {
                    Found::Between => 1.0,
                    Found::After => 7.0,
                };
                (pose, found, ratio)
            })
        };
        assert_eq!(refused, wanted.is_none(), "return {k}: refusal differs");
        let Some((ref_pose, _, ratio)) = wanted else {
            continue;
        };
        // The library's point: the pose it put in force, through its geometry.
        let pose = *f.pose();
        let plane = SweepTransform::new(&mount, &pose.frame()).at(tilt);
        let Some(located) = plane.locate(beam_angle_of_clockwise(angle), range_mm) else {
            continue;
        };
        let got = g::vec_of(located.point);
        let range_m = f64::from(range_mm) / 1000.0;
        let want = g::world_point(
            &ref_mount,
            &ref_pose,
            tilt_rad,
            lidar_theta_rad(phi_deg.to_radians()),
            range_m,
        );
        let lsb = 2.0 + 2.0 * ratio;
        let bound = lidar_error_bound_m(range_m)
            + lsb
                * (3_f64.sqrt() * 2_f64.powi(-16)
                    + std::f64::consts::TAU * 2_f64.powi(-32) * (range_m + 1.0) * 3.0);
        worst = worst.max(g::distance(got, want) / bound);
        compared += 1;
    }
    let s = f.stats();
    (
        compared,
        worst,
        s.returns_extrapolated,
        s.returns_without_pose,
    )
}

#[test]
fn timed_placement_agrees_with_the_f64_rule() {
    let (compared, worst, extrapolated, refused) = drive(4.0, false, 3_000);
    eprintln!("timed: {compared} returns, worst {worst:.3} × the bound, {extrapolated} extrapolated, {refused} refused");
    assert!(compared > 17_000, "{compared}");
    assert!(worst <= 1.0, "worst error {worst} × the bound");
    // 30 ± 10 ms late poses against returns handed in 3 ms after measurement: most returns
    // lie past the newest pose; none beyond the bound (the latest pose is < 50 ms old).
    assert!(extrapolated > 10_000, "{extrapolated}");
    // Only the returns before the first pose arrived.
    assert!(refused < 200, "{refused}");
}

#[test]
fn the_latest_pose_rule_misses_the_bound_by_far() {
    let (_, worst, _, _) = drive(2.0, true, 3_000);
    eprintln!("latest pose: worst {worst:.1} × the bound");
    assert!(
        worst > 100.0,
        "the latest pose came within {worst} × the bound"
    );
}

#[test]
fn returns_handed_in_after_their_poses_are_interpolated() {
    // 60 ms after measurement every return has a pose stamped after it: interpolated.
    let (compared, worst, extrapolated, refused) = drive(3.0, false, 60_000);
    eprintln!("interpolated: {compared} returns, worst {worst:.3} × the bound, {refused} refused");
    assert!(compared > 13_000, "{compared}");
    assert!(worst <= 1.0, "worst error {worst} × the bound");
    assert_eq!(extrapolated, 0);
    assert!(refused < 200, "{refused}");
}
