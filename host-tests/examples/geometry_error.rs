//! Measures the error of the fixed-point scan geometry against the f64 reference over a large
//! random sweep: the maximum and the 99.9th percentile of the world-point error and of the
//! horizontal-distance error, for ranges up to 8 m, 30 m and 81.91 m.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example geometry_error [samples]
//! ```
//!
//! Inputs are drawn uniformly: variant, beam, range 0 ..= 81 910 mm, scan plane, mount
//! position (x, y within ±2 m, z 0 ..= 3 m), actuator angle (any), pose x, y within
//! ±29 999 m, z within ±999 m, roll and pitch within ±30°, yaw within ±20 rad. The seed is
//! fixed, so runs repeat.

use terrain_pyramid::geometry::{BeamTable, ScanPlane};
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid_host_tests::geometry::{
    draw_mount_bits, draw_pose, error_bound_m, evaluate, Case, ErrorsByRange,
};
use terrain_pyramid_host_tests::workload::Rng;

fn main() {
    let samples: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2_000_000);
    let tables = Variant::ALL.map(BeamTable::new);
    let mut errors = ErrorsByRange::new(&[8.0, 30.0, 81.91]);
    let mut relative_max = 0.0_f64;
    let mut over_bound = 0_usize;
    let mut rng = Rng::new(0x5EED_0F6E_00E7);

    for _ in 0..samples {
        let v = rng.below(5) as usize;
        let table = &tables[v];
        let case = Case {
            beam: rng.below(table.len() as u64) as usize,
            range_mm: rng.below(81_911) as u32,
            plane: if rng.below(2) == 0 {
                ScanPlane::PannedVertical
            } else {
                ScanPlane::TiltedHorizontal
            },
            mount_bits: draw_mount_bits(&mut rng),
            actuator_bits: rng.next_u64() as u32,
            pose: draw_pose(&mut rng),
        };
        let Some(e) = evaluate(table, &case) else {
            eprintln!("refused: {case:?}");
            continue;
        };
        if e.point_m > error_bound_m(e.range_m) || e.horizontal_m > error_bound_m(e.range_m) {
            over_bound += 1;
        }
        if e.range_m >= 10.0 {
            relative_max = relative_max.max(e.point_m / e.range_m);
        }
        errors.add(&e);
    }

    println!("fixed-point scan geometry vs f64 reference, {samples} random returns");
    println!(
        "bound: 0.03 mm + 3.1e-5 x range; returns over it: {over_bound}; \
         max relative error (ranges >= 10 m): {relative_max:.2e}"
    );
    errors.print(error_bound_m);
}
