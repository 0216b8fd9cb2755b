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

fn case() -> impl Strategy<Value = (usize, Case)> {
    (
        0..5_usize,
        any::<prop::sample::Index>(),
        0..=81_910_u32,
        any::<bool>(),
        // Mount: x, y within ±2 m, z from 0 to 3 m (raw Q16.16).
        (
            -131_072..=131_072_i32,
            -131_072..=131_072_i32,
            0..=196_608_i32,
        ),
        any::<u32>(),
        (
            -29_999.0_f32..29_999.0,
            -29_999.0_f32..29_999.0,
            -999.0_f32..999.0,
            -THIRTY_DEG..=THIRTY_DEG,
            -THIRTY_DEG..=THIRTY_DEG,
            -20.0_f32..20.0,
        ),
    )
        .prop_map(|(v, beam, range_mm, tilted, m, actuator_bits, p)| {
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
                    mount_bits: [m.0, m.1, m.2],
                    actuator_bits,
                    pose: [p.0, p.1, p.2, p.3, p.4, p.5],
                },
            )
        })
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
