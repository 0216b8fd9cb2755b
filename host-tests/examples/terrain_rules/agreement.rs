//! `terrain_rules -- agreement`: the library's fixed-point plane rule against the f64
//! reference, cell by cell, on the 3DTK scan and the simulated street.

use super::*;
use terrain_pyramid_host_tests::harness::evidence_by_cell;

/// The library's plane rule against the f64 reference on one observation: (cells, agreeing,
/// cells away from the thresholds, agreeing among those).
fn agreement<const W: usize>(
    design: &Design<L>,
    obs: &Observation,
    ceiling: Option<f64>,
) -> (usize, usize, usize, usize) {
    let pyr = pyramid::<W, L>(design);
    let mut c: Box<Classifier<SLOTS, L>> = navigability::classifier(design);
    let g = gates(design);
    c.configure(ClassifierConfig {
        ceiling: ceiling.map(Meters::from_num),
        ..ClassifierConfig::default()
    });
    let q = |v: f64| Meters::saturating_from_num(v).to_num::<f64>();
    let kept: Vec<[f64; 3]> = obs
        .points
        .iter()
        .copied()
        .filter(|p| ceiling.is_none_or(|h| q(p[2]) <= q(obs.ground_z) + h))
        .collect();
    let sensor = terrain_pyramid::Point3 {
        x: Meters::saturating_from_num(obs.sensor[0]),
        y: Meters::saturating_from_num(obs.sensor[1]),
        z: Meters::saturating_from_num(obs.sensor[2]),
    };
    c.begin(sensor.z);
    let mut pts = Vec::new();
    for k in &kept {
        let point = terrain_pyramid::Point3 {
            x: Meters::saturating_from_num(k[0]),
            y: Meters::saturating_from_num(k[1]),
            z: Meters::saturating_from_num(k[2]),
        };
        let d = terrain_pyramid::geometry::horizontal_distance(sensor, point);
        c.add_point(point, d, Meters::saturating_from_num(obs.ground_z));
        pts.push(RefPoint {
            x: point.x.to_num(),
            y: point.y.to_num(),
            z: point.z.to_num(),
            distance: d.to_num(),
        });
    }
    let lib = evidence_by_cell(&mut c, |e| e.class == EvidenceClass::Obstacle);
    let resolutions: Vec<f64> = (0..g.layer_count())
        .filter_map(|k| g.resolution(k))
        .map(|r| f64::from(r.to_bits()) / 65_536.0)
        .collect();
    let bins = g.distance_bins();
    let inc = pyr.increments();
    let feeds = |k: usize, d: f64| {
        g.table(k).is_some_and(|g| {
            let w = g.weight(bins.bin(Meters::saturating_from_num(d)));
            terrain_pyramid::logodds::gated(inc.obstacle, w) != 0
                || terrain_pyramid::logodds::gated(inc.free, w) != 0
        })
    };
    let reference = classify(
        &pts,
        &resolutions,
        feeds,
        q(obs.ground_z),
        sensor.z.to_num(),
        &RefClassifierConfig {
            rule: RefRule::plane(),
            ..RefClassifierConfig::default()
        },
    );
    let (mut all, mut agree, mut away, mut away_agree) = (0, 0, 0, 0);
    for (key, r) in &reference {
        let Some(&obstacle) = lib.get(key) else {
            continue;
        };
        all += 1;
        agree += usize::from(obstacle == r.obstacle);
        let near = |x: f64| x > 0.85 && x < 1.15;
        if near(r.residual_ratio)
            || near(r.rise_ratio)
            || near(r.pair_ratio)
            || r.cut_margin < 0.002
            || r.edge_margin < 1.0
        {
            continue;
        }
        away += 1;
        away_agree += usize::from(obstacle == r.obstacle);
    }
    (all, agree, away, away_agree)
}

pub(super) fn part_agreement() {
    println!("\n## The fixed-point plane rule against its f64 reference\n");
    println!("| observation | cells | agree | cells away from the thresholds (ratios outside 0.85-1.15, 2 mm from the cut) | agree there |");
    println!("| --- | --- | --- | --- | --- |");
    let mut rows: Vec<(String, (usize, usize, usize, usize))> = Vec::new();
    if let Ok(points) = read_uos(std::path::Path::new(SCAN_PATH)) {
        let obs = Observation {
            sensor: [0.0, 0.0, 0.0],
            ground_z: -scan3dtk::SENSOR_HEIGHT_M,
            points,
        };
        rows.push((
            "3DTK scan000, README replay".into(),
            agreement::<64>(&readme_design(), &obs, Some(scan3dtk::CEILING_M)),
        ));
    }
    let street = Scene::street(0.05);
    for (i, run) in car_scans(&street, &[-4.0, 3.0, 10.0], 42)
        .iter()
        .enumerate()
    {
        for design_sigma in [0.15_f32, 0.02] {
            rows.push((
                format!(
                    "simulated street, revolution {}, design σ {design_sigma} m",
                    i + 1
                ),
                agreement::<128>(&car_design(design_sigma), &run[0], None),
            ));
        }
    }
    for (name, (all, agree, away, away_agree)) in rows {
        println!(
            "| {name} | {all} | {} % | {away} | {} % |",
            share(agree, all),
            share(away_agree, away)
        );
    }
}
