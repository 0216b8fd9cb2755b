//! Measures the error of a spinning lidar's per-return path against the f64 reference: LD06
//! packets (the manual's angle formula) decoded by the library, each return placed from its
//! own angle (`geometry::sweep`), against the manual's formula and the geometry in f64. The
//! maximum and the 99.9th percentile of the world-point and horizontal-distance errors, for
//! ranges up to 12 m (an LD06's or an X4's reach) and up to 40 m (an RPLIDAR S1's).
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example lidar_geometry_error [packets]
//! ```
//!
//! Inputs are drawn uniformly: packet start angle (0 ..< 360°) and span (0 ..= 12°, across
//! 360° too), ranges 0 ..= 40 000 mm, scan plane, mount position (x, y within ±2 m, z
//! 0 ..= 3 m), actuator angle (any), pose x, y within ±29 999 m, z within ±999 m, roll and
//! pitch within ±30°, yaw within ±20 rad. The seed is fixed, so runs repeat.

use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
use terrain_pyramid_host_tests::geometry::{
    draw_mount_bits, draw_pose, evaluate_ld06, lidar_error_bound_m, ErrorsByRange,
};
use terrain_pyramid_host_tests::workload::Rng;

fn main() {
    let packets: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200_000);
    let mut table = ErrorsByRange::new(&[12.0, 40.0]);
    let mut over_bound = 0_usize;
    let mut rng = Rng::new(0x11D0_6E0A_5EED);
    for _ in 0..packets {
        let start = rng.below(36_000) as u16;
        let span = rng.below(1_201) as u16;
        let mut points = [Ld06Point::default(); 12];
        for p in &mut points {
            p.distance_mm = rng.below(40_001) as u16;
        }
        let repr = Ld06Repr {
            speed_deg_per_s: 3_600,
            start_angle_centideg: start,
            end_angle_centideg: (start + span) % 36_000,
            timestamp_ms: 0,
            points,
        };
        let mut bytes = [0_u8; 47];
        repr.emit(&mut bytes).expect("47 bytes");
        let plane = if rng.below(2) == 0 {
            ScanPlane::PannedVertical
        } else {
            ScanPlane::TiltedHorizontal
        };
        let mount_bits = draw_mount_bits(&mut rng);
        let pose = draw_pose(&mut rng);
        let Some(errors) = evaluate_ld06(&bytes, plane, mount_bits, rng.next_u64() as u32, pose)
        else {
            eprintln!("refused: start {start} span {span} pose {pose:?}");
            continue;
        };
        for e in errors {
            if e.point_m > lidar_error_bound_m(e.range_m)
                || e.horizontal_m > lidar_error_bound_m(e.range_m)
            {
                over_bound += 1;
            }
            table.add(&e);
        }
    }
    println!(
        "spinning-lidar returns (LD06 packets, own angles) vs f64 reference, {packets} packets"
    );
    println!("bound: 0.03 mm + 1e-8 x range; returns over it: {over_bound}");
    table.print(lidar_error_bound_m);
}
