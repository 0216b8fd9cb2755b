//! Exploration: the share of flat-ground cells whose spread exceeds 5 cm, per layer.
use terrain_pyramid::{Design, GateShape, Schedule, SensorModel};
use terrain_pyramid_host_tests::navigability::{flat_spread, observation_cells, pyramid};
use terrain_pyramid_host_tests::sim::cloud::RingLaser;
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Pose;

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().unwrap())
        .collect();
    let (sigma, elev, rbias) = (a[0], a[1], a[2]);
    let design = Design::<16>::new(
        SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: 0.2_f32.to_radians(),
            sigma_m: 0.15,
            height_m: 1.3,
            max_range_m: 20.0,
        },
        Schedule {
            base_m: 0.1,
            gamma: 3.0,
            gate: GateShape::default(),
            ..Schedule::default()
        },
        128,
    )
    .unwrap();
    let p = pyramid::<128, 16>(&design);
    let res: Vec<f64> = design
        .layers()
        .iter()
        .map(|l| f64::from(l.resolution_m))
        .collect();
    let scene = Scene::street(a[3]);
    let laser = RingLaser {
        elevation_bias_deg: elev,
        range_bias_m: rbias,
        ..RingLaser::car(sigma)
    };
    let mut rng = Rng::new(3);
    let mut tot = vec![(0, 0); res.len()];
    let grids = [0.1, 0.3, 0.6];
    let mut gtot = vec![(0, 0); 3];
    for x in [-4.0, 3.0] {
        let pose = Pose {
            x,
            ..Pose::default()
        };
        let obs = laser.scan(&scene, &pose, &mut rng);
        let cells = observation_cells(&p, &obs, 1.0);
        for (g, &c) in grids.iter().enumerate() {
            let mut m: std::collections::BTreeMap<
                (usize, i64, i64),
                terrain_pyramid_host_tests::navigability::CellPoints,
            > = Default::default();
            for q in &obs.points {
                if (q[0] - obs.sensor[0]).hypot(q[1] - obs.sensor[1]) > 20.0 {
                    continue;
                }
                let e = m
                    .entry((0, (q[0] / c).floor() as i64, (q[1] / c).floor() as i64))
                    .or_default();
                e.points
                    .push(terrain_pyramid_host_tests::classify::RefPoint {
                        x: q[0],
                        y: q[1],
                        z: q[2],
                        distance: 0.0,
                    });
            }
            for e in m.values_mut() {
                let lo = e.points.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
                e.points.retain(|p| p.z <= lo + 1.0);
            }
            let v = flat_spread(&m, &[c], &scene, 0.05, 3.0, 0.5, 1.0);
            gtot[g].0 += v[0].0;
            gtot[g].1 += v[0].1;
        }
        for (t, v) in tot
            .iter_mut()
            .zip(flat_spread(&cells, &res, &scene, 0.05, 3.0, 0.5, 1.0))
        {
            t.0 += v.0;
            t.1 += v.1;
        }
    }
    for (g, (n, m)) in gtot.iter().enumerate() {
        println!(
            "grid {:.1} m: {m}/{n} = {:.1}%",
            grids[g],
            100.0 * *m as f64 / *n as f64
        );
    }
    for (k, (n, m)) in tot.iter().enumerate() {
        println!(
            "layer {k} ({:.1} m): {m}/{n} = {:.1}%",
            res[k],
            100.0 * *m as f64 / *n as f64
        );
    }
}
