//! The fixed-point scan geometry against the f64 reference: random mounts, actuator angles,
//! poses (roll and pitch within ±30°, any yaw), beams and ranges up to 81.91 m. Every world
//! point and horizontal distance must lie within `error_bound_m(range)` of the reference.

use proptest::prelude::*;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::geometry::{BeamTable, LineTransform, Mount, Pose, ScanPlane};
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::{Meters, Point3};
use terrain_pyramid_host_tests::geometry::{error_bound_m, evaluate, Case};

/// The five beam tables, built once.
fn tables() -> &'static [BeamTable; 5] {
    use std::sync::OnceLock;
    static TABLES: OnceLock<[BeamTable; 5]> = OnceLock::new();
    TABLES.get_or_init(|| Variant::ALL.map(BeamTable::new))
}

/// 30° in radians, as f32.
const THIRTY_DEG: f32 = std::f32::consts::FRAC_PI_6;

/// A mount position as raw Q16.16 bits: x, y within ±2 m, z from 0 to 3 m.
fn mount_bits() -> impl Strategy<Value = [i32; 3]> {
    (
        -131_072..=131_072_i32,
        -131_072..=131_072_i32,
        0..=196_608_i32,
    )
        .prop_map(|(x, y, z)| [x, y, z])
}

/// A pose as the host sends it (x, y, z in m, roll, pitch, yaw in rad): x and y within
/// ±`xy_m`, z within ±`z_m`, roll and pitch within ±30°, yaw within ±`yaw_rad`.
fn pose_within(xy_m: f32, z_m: f32, yaw_rad: f32) -> impl Strategy<Value = [f32; 6]> {
    (
        -xy_m..xy_m,
        -xy_m..xy_m,
        -z_m..z_m,
        -THIRTY_DEG..=THIRTY_DEG,
        -THIRTY_DEG..=THIRTY_DEG,
        -yaw_rad..yaw_rad,
    )
        .prop_map(|(x, y, z, roll, pitch, yaw)| [x, y, z, roll, pitch, yaw])
}

fn case() -> impl Strategy<Value = (usize, Case)> {
    (
        0..5_usize,
        any::<prop::sample::Index>(),
        0..=81_910_u32,
        any::<bool>(),
        mount_bits(),
        any::<u32>(),
        pose_within(29_999.0, 999.0, 20.0),
    )
        .prop_map(
            |(v, beam, range_mm, tilted, mount_bits, actuator_bits, pose)| {
                let count = Variant::ALL[v].beam_count();
                (
                    v,
                    Case {
                        beam: beam.index(count),
                        range_mm,
                        plane: if tilted {
                            ScanPlane::TiltedHorizontal
                        } else {
                            ScanPlane::PannedVertical
                        },
                        mount_bits,
                        actuator_bits,
                        pose,
                    },
                )
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn world_points_are_within_the_bound((v, case) in case()) {
        let e = evaluate(&tables()[v], &case).expect("valid inputs");
        let bound = error_bound_m(e.range_m);
        prop_assert!(e.point_m <= bound, "point {:.4} mm > {:.4} mm", e.point_m * 1e3, bound * 1e3);
        prop_assert!(
            e.horizontal_m <= bound,
            "horizontal {:.4} mm > {:.4} mm", e.horizontal_m * 1e3, bound * 1e3
        );
        prop_assert!(e.origin_m <= error_bound_m(0.0));
    }

    #[test]
    fn the_per_point_path_is_locate((v, case) in case()) {
        // `locate_squared` (the pipeline's per-point path, in 32-bit words where no point of
        // the line can saturate) gives `locate`'s point and the square of its distance: the
        // bound above holds for it too.
        let [x, y, z, roll, pitch, yaw] = case.pose;
        let pose = Pose::from_f32(x, y, z, roll, pitch, yaw).expect("valid pose");
        let [mx, my, mz] = case.mount_bits.map(Meters::from_bits);
        let mount = Mount::new(case.plane, Point3 { x: mx, y: my, z: mz });
        let actuator = FineAngle::from_bits(case.actuator_bits);
        let line = LineTransform::from_pose(&tables()[v], &mount, actuator, &pose);
        let located = line.locate(case.beam, case.range_mm).expect("valid beam");
        let squared = line.locate_squared(case.beam, case.range_mm).expect("valid beam");
        prop_assert_eq!(squared.point, located.point);
        prop_assert_eq!(round_sqrt(squared.horizontal_squared), i64::from(located.horizontal.to_bits()));
    }

    #[test]
    fn near_points_are_within_two_millimetres((v, mut case) in case()) {
        case.range_mm %= 8_001;
        let e = evaluate(&tables()[v], &case).expect("valid inputs");
        prop_assert!(e.point_m <= 0.002 && e.horizontal_m <= 0.002);
    }
}

/// `round(√s)`, halves up, exactly.
fn round_sqrt(s: u64) -> i64 {
    let mut r = (s as f64).sqrt() as u64;
    while r * r > s {
        r -= 1;
    }
    while (r + 1) * (r + 1) <= s {
        r += 1;
    }
    // √s ≥ r + ½ exactly when s > r² + r.
    i64::try_from(r + u64::from(s - r * r > r)).expect("small")
}

/// Every beam of every variant, both mounts, at the longest range and a tilted, turned pose.
#[test]
fn every_beam_of_every_variant() {
    for (v, table) in tables().iter().enumerate() {
        for plane in [ScanPlane::PannedVertical, ScanPlane::TiltedHorizontal] {
            for beam in 0..table.len() {
                let case = Case {
                    beam,
                    range_mm: 81_910,
                    plane,
                    mount_bits: [32_768, -16_384, 65_536],
                    actuator_bits: 0x1555_5555 * (beam as u32 % 12),
                    pose: [12.5, -7.25, 0.5, 0.2, -0.3, 2.5],
                };
                let e = evaluate(table, &case).expect("valid inputs");
                assert!(e.point_m <= error_bound_m(e.range_m), "{v} {beam} {e:?}");
                assert!(
                    e.horizontal_m <= error_bound_m(e.range_m),
                    "{v} {beam} {e:?}"
                );
            }
        }
    }
}

/// The turn of raw Q0.32 bits, radians.
fn rad_of(bits: u32) -> f64 {
    f64::from(bits) / 4_294_967_296.0 * std::f64::consts::TAU
}

/// Any mount (random roll, pitch, yaw, axis, zero and sense) against the f64 reference's own
/// rotation matrices: a spinning lidar's return (`SweepTransform`, its own angle in Q2.30)
/// within 0.03 mm + 10⁻⁸·r (the bound documented for the preset mounts, which it keeps), a
/// SICK beam (`LineTransform`, the Q1.15 table) within the line's bound, `error_bound_m`.
/// The presets' bits are the fixed mounts' (the golden hashes of the library's tests).
mod general_mount {
    use super::*;
    use terrain_pyramid::geometry::{ActuatorAxis, SweepTransform};
    use terrain_pyramid_host_tests::geometry::{self as g, Axis, GeneralMount};

    /// The sweep path's bound, metres, at `range_m`.
    fn sweep_bound_m(range_m: f64) -> f64 {
        3.0e-5 + 1.0e-8 * range_m
    }

    fn mount_strategy() -> impl Strategy<Value = ([u32; 3], u8, u32, bool, [i32; 3])> {
        (
            any::<[u32; 3]>(),
            0..3_u8,
            any::<u32>(),
            any::<bool>(),
            mount_bits(),
        )
    }

    fn pose_strategy() -> impl Strategy<Value = [f32; 6]> {
        pose_within(999.0, 99.0, 3.2)
    }

    struct Built {
        lib: Mount,
        reference: GeneralMount,
        pose: Pose,
        ref_pose: g::Pose,
    }

    fn build(m: ([u32; 3], u8, u32, bool, [i32; 3]), p: [f32; 6]) -> Built {
        let (rpy, axis, zero, reversed, pos) = m;
        let lib_axis = ActuatorAxis::from_code(axis).unwrap();
        let position = Point3 {
            x: Meters::from_bits(pos[0]),
            y: Meters::from_bits(pos[1]),
            z: Meters::from_bits(pos[2]),
        };
        let lib = Mount::general(
            position,
            rpy.map(FineAngle::from_bits),
            lib_axis,
            FineAngle::from_bits(zero),
            reversed,
        );
        let reference = GeneralMount {
            rpy_rad: rpy.map(rad_of),
            axis: [Axis::Pan, Axis::Tilt, Axis::Fixed][usize::from(axis)],
            zero_rad: rad_of(zero),
            sense: if reversed { -1.0 } else { 1.0 },
            position: pos.map(|b| f64::from(b) / 65_536.0),
        };
        let pose = Pose::from_f32(p[0], p[1], p[2], p[3], p[4], p[5]).unwrap();
        let [x, y, z, roll, pitch, yaw] = p.map(f64::from);
        Built {
            lib,
            reference,
            pose,
            ref_pose: g::Pose {
                x,
                y,
                z,
                roll,
                pitch,
                yaw,
            },
        }
    }

    fn q16(m: Meters) -> f64 {
        f64::from(m.to_bits()) / 65_536.0
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        #[test]
        fn a_lidar_return_on_any_mount_is_within_the_bound(
            m in mount_strategy(),
            p in pose_strategy(),
            actuator in any::<u32>(),
            theta in any::<u32>(),
            range_mm in 0..=40_000_u32,
        ) {
            let b = build(m, p);
            let got = SweepTransform::new(&b.lib, &b.pose.frame())
                .at(FineAngle::from_bits(actuator))
                .point(FineAngle::from_bits(theta), range_mm)
                .unwrap();
            let r = f64::from(range_mm) / 1000.0;
            let want = g::general_world_point(
                &b.reference, &b.ref_pose, rad_of(actuator), rad_of(theta), r,
            );
            let e = g::distance([q16(got.x), q16(got.y), q16(got.z)], want);
            prop_assert!(e <= sweep_bound_m(r), "{e} m at {r} m");
        }

        #[test]
        fn a_sick_beam_on_any_mount_is_within_the_bound(
            m in mount_strategy(),
            p in pose_strategy(),
            actuator in any::<u32>(),
            beam in 0..361_usize,
            range_mm in 0..=81_910_u32,
        ) {
            let b = build(m, p);
            let table = &tables()[1];
            prop_assume!(table.len() == 361);
            let line = LineTransform::from_pose(
                table, &b.lib, FineAngle::from_bits(actuator), &b.pose,
            );
            let got = line.point(beam, range_mm).unwrap();
            let r = f64::from(range_mm) / 1000.0;
            let theta = Variant::ALL[1].beam_angle(beam).unwrap();
            let want = g::general_world_point(
                &b.reference, &b.ref_pose, rad_of(actuator), rad_of(theta.to_bits()), r,
            );
            let e = g::distance([q16(got.x), q16(got.y), q16(got.z)], want);
            prop_assert!(e <= error_bound_m(r), "{e} m at {r} m");
        }
    }

    /// The general mount's reference, of a preset's values, is the preset's (the reference's
    /// two models agree with each other).
    #[test]
    fn the_references_general_mount_of_a_preset_is_the_preset() {
        for (plane, rpy, axis) in [
            (
                g::Plane::PannedVertical,
                [std::f64::consts::FRAC_PI_2, 0.0, 0.0],
                Axis::Pan,
            ),
            (g::Plane::TiltedHorizontal, [0.0; 3], Axis::Tilt),
        ] {
            let general = GeneralMount {
                rpy_rad: rpy,
                axis,
                zero_rad: 0.0,
                sense: 1.0,
                position: [0.1, 0.2, 0.3],
            };
            for k in 0..100 {
                let (t, a) = (f64::from(k) * 0.37, f64::from(k) * -0.21);
                let d = g::general_direction_robot(&general, t, a);
                let e = g::beam_direction_robot(plane, t, a);
                assert!(g::distance(d, e) < 1e-15, "{plane:?} {k}");
            }
        }
    }
}
