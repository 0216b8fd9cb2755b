//! Classifier agreement on the real scan: the fixed-point classifier against the f64
//! reference on `../shared/data/3dtk-tilt-scan/scan000.3d`, as one observation, under the
//! paper's spread rule (the plane rule's agreement: `--example terrain_rules -- agreement`).
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example classify_agreement [-- PATH]
//! ```
//!
//! Points are read in the 3DTK frame (cm, left-handed x right, y up, z forward) and
//! converted to the project's frame as `x = z/100, y = −x/100, z = y/100`; the sensor is at
//! the origin, 1.0 m above the robot's ground plane (the floor is about 0.4 m below this
//! sensor, so the robot's ground plane is only used for the optional drop-off check, which is
//! off). The "no echo" value (3276.7 cm) is not a point.

use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, EvidenceClass, GateShape, Meters, Schedule, SensorModel,
};
use terrain_pyramid_host_tests::classify::{classify, RefClassifierConfig, RefPoint, RefRule};
use terrain_pyramid_host_tests::harness::{
    add_ref_points, evidence_by_cell, gate_feeds, layer_resolutions_m,
};

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "../shared/data/3dtk-tilt-scan/scan000.3d".into());
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("cannot read {path}: {e} (the real data lives in ../shared/data)");
            std::process::exit(1);
        }
    };
    let mut points = Vec::new();
    let mut no_echo = 0;
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line
            .split_whitespace()
            .filter_map(|t| t.parse().ok())
            .collect();
        let [xf, yf, zf] = v[..] else { continue };
        if (xf * xf + yf * yf + zf * zf).sqrt() >= 3276.6 {
            no_echo += 1;
            continue;
        }
        let q = |m: f64| Meters::from_num(m).to_num::<f64>();
        let (x, y, z) = (q(zf / 100.0), q(-xf / 100.0), q(yf / 100.0));
        points.push(RefPoint {
            x,
            y,
            z,
            distance: q((x * x + y * y).sqrt()),
        });
    }
    println!("{path}: {} points, {no_echo} without echo", points.len());
    println!();
    println!("| gate | cells | agreement, all cells | near a mm boundary | agreement, the rest |");
    println!("| --- | --- | --- | --- | --- |");
    for (name, gate) in [("hard", GateShape::Hard), ("soft", GateShape::default())] {
        let schedule = Schedule {
            gate,
            ..Schedule::default()
        };
        let design = DefaultDesign::new(SensorModel::default(), schedule, 64).unwrap();
        let mut p = Box::new(DefaultPyramid::new());
        p.configure(&design, &Config::default()).unwrap();
        let mut c = Box::new(Classifier::<65536, 8>::new());
        c.configure(ClassifierConfig {
            rule: NavigabilityRule::Spread,
            ..ClassifierConfig::default()
        });
        c.adopt_design(&design, p.increments()).unwrap();
        c.begin(Meters::ZERO);
        add_ref_points(&mut c, &points);
        let lib = evidence_by_cell(&mut c, |e| e.class == EvidenceClass::Obstacle);
        let resolutions = layer_resolutions_m(&p);
        let feeds = gate_feeds(c.gates(), p.increments());
        let reference = classify(
            &points,
            &resolutions,
            feeds,
            -1.0,
            0.0,
            &RefClassifierConfig {
                rule: RefRule::Spread,
                ..RefClassifierConfig::default()
            },
        );
        let (mut compared, mut agree, mut near, mut all_agree) = (0, 0, 0, 0);
        for (key, r) in &reference {
            let Some(&obstacle) = lib.get(key) else {
                continue;
            };
            all_agree += usize::from(obstacle == r.obstacle);
            if (r.spread - 0.05).abs() < 0.002 || r.cut_margin < 0.002 || r.edge_margin < 1.0 {
                near += 1;
                continue;
            }
            compared += 1;
            agree += usize::from(obstacle == r.obstacle);
        }
        let pct = |a: usize, n: usize| 100.0 * a as f64 / n.max(1) as f64;
        println!(
            "| {name} | {} | {:.2} % ({all_agree}) | {near} | {:.2} % ({agree} of {compared}) |",
            reference.len(),
            pct(all_agree, reference.len()),
            pct(agree, compared),
        );
        assert_eq!(c.stats().overflow_points, 0, "scratch overflowed");
    }
}
