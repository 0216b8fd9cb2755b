//! The navigability rules measured: every table of the rule's choice.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example terrain_rules [-- PART]
//! ```
//! PART is one of `spread`, `car`, `gallery`, `pan`, `3dtk`, `agreement` (default: all, about
//! three minutes). Run from the workspace root: the 3DTK scan is read from
//! `../shared/data/3dtk-tilt-scan/scan000.3d`, and the labelling's top view is written to
//! `out/terrain-rules/scan000-labels.png`.
//!
//! - `spread`: the share of flat-ground cells whose spread exceeds 5 cm, by cell size, for the
//!   simulated car laser (the figure that calibrates the simulator's noise against the street
//!   scan's 7 / 30 / 68 %).
//! - `car`: the car laser (h 1.3 m, φ 0.4°, ψ 0.2°, σ 2 cm, 0.1° per-beam elevation and 2 cm
//!   per-beam range errors, 20 m) on the simulated street, one revolution from each of three
//!   places, through the street design (γ 3, 20 m) with σ 0.15 m (the default) and 0.02 m:
//!   per layer and fused, the share of truly navigable cells classed navigable and of true
//!   obstacles (features ≥ 8 cm) classed obstacle; the fused map also at the returns (clear
//!   ground within 0.5 m of no feature; obstacle returns with an obstacle cell within 0.2 m).
//! - `gallery`: the car laser before square platforms 3 … 20 cm high at 3 to 16.5 m: per layer,
//!   the smallest step found in at least half of the cells on its edges.
//! - `pan`: the paper's robot (a vertical SICK plane at 1.0 m panned ±45°, 0.5°, σ 2 cm),
//!   standing 2 s then driving at 1 m/s to 1 m before x = 5.05 m, over slopes of 5-20°, grass
//!   and gravel, a cambered road with 12 cm curbs and a kerb cut, a 10 cm curb, stairs, a
//!   ditch and the step gallery; the default design (10 m, γ 2).
//! - `3dtk`: the real scan against its hand labelling (`host-tests/data/scan000-labels.txt`),
//!   replayed as the README does (h 0.4 m, 8 m, γ 3, ceiling 1.2 m).
//! - `agreement`: the fixed-point plane rule against the f64 reference on the 3DTK scan and the
//!   simulated street, cell by cell.

mod agreement;

use agreement::part_agreement;

use std::collections::{BTreeMap, BTreeSet};
use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule};
use terrain_pyramid::{Design, EvidenceClass, Meters, Pyramid, Schedule, SensorModel};
use terrain_pyramid_host_tests::classify::{classify, RefClassifierConfig, RefPoint, RefRule};
use terrain_pyramid_host_tests::navigability::{
    self, flat_spread, fused_points, fused_tally, gates, integrate, integrate_library, layer_tally,
    mark_seen, observation_cells, pyramid, step_detection, CellPoints, Rule, Tally,
};
use terrain_pyramid_host_tests::scan3dtk::{
    self, labelled, read_uos, readme_design, render, Label, Labels, LABELS, SCAN_PATH,
};
use terrain_pyramid_host_tests::sim::cloud::{
    firing_order, pan_observations, Observation, RingLaser,
};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::terrain::GALLERY_STEPS_M;
use terrain_pyramid_host_tests::sim::trajectory::{Pose, Trajectory};

const L: usize = 16;
/// The library classifier's slots: a whole revolution of the car laser in one observation.
const SLOTS: usize = 65_536;
const ROBOT_HEIGHT: f64 = 1.0;

/// A rule as the tables run it: a candidate in f64, or the library's classifier.
#[derive(Debug, Clone, Copy)]
enum Judge {
    F64(Rule),
    Library(NavigabilityRule),
}

impl Judge {
    fn name(&self) -> String {
        match self {
            Self::F64(rule) => rule.name(),
            Self::Library(NavigabilityRule::Spread) => {
                "library, spread (paper), fixed point".into()
            }
            Self::Library(NavigabilityRule::Plane(_)) => {
                "library, plane (default), fixed point".into()
            }
        }
    }
}

/// Prints a Markdown table's head: the `columns`, then a column per layer of `design` (its
/// index and resolution).
fn print_head(columns: &[&str], design: &Design<L>) {
    let mut head = String::from("|");
    let mut rule = String::from("|");
    for column in columns {
        head += &format!(" {column} |");
        rule += " --- |";
    }
    for (k, l) in design.layers().iter().enumerate() {
        head += &format!(" L{k} {:.1} m |", l.resolution_m);
        rule += " --- |";
    }
    println!("{head}\n{rule}");
}

/// The plane rule in f64 (extent-based rise, no backstop, σ_a = 0.075° unless set otherwise).
fn plane(max_slope_deg: f64, residual_m: f64, sigma_m: f64, k: f64) -> Rule {
    Rule::Plane {
        step_m: 0.05,
        max_slope_deg,
        residual_m,
        sigma_m,
        k,
        rise_over_cell: false,
        backstop: false,
        angle_sigma_deg: 0.075,
        extremes: true,
    }
}

/// The plane rule with an angular noise term.
fn plane_angular(angle_sigma_deg: f64) -> Rule {
    let mut rule = plane(20.0, 0.015, 0.02, 2.0);
    if let Rule::Plane {
        angle_sigma_deg: angle,
        ..
    } = &mut rule
    {
        *angle = angle_sigma_deg;
    }
    rule
}

/// The candidates and the sensitivity of the chosen one, then the library's two rules.
fn judges(sensitivity: bool) -> Vec<Judge> {
    let mut v = vec![
        Judge::F64(Rule::Paper { step_m: 0.05 }),
        Judge::F64(plane(20.0, 0.015, 0.02, 2.0)),
        Judge::F64(Rule::Jump {
            step_m: 0.05,
            max_slope_deg: 20.0,
            radius_m: 0.15,
            sigma_m: 0.02,
            k: 3.0,
        }),
        Judge::F64(Rule::Tolerant {
            step_m: 0.05,
            max_slope_deg: 20.0,
            sigma_m: 0.02,
            k: 3.0,
        }),
        Judge::F64(Rule::JumpOrTolerant {
            step_m: 0.05,
            max_slope_deg: 20.0,
            radius_m: 0.15,
            sigma_m: 0.02,
            k: 3.0,
        }),
    ];
    if sensitivity {
        for (slope, res, sigma, k) in [
            (15.0, 0.015, 0.02, 2.0),
            (20.0, 0.010, 0.02, 2.0),
            (20.0, 0.020, 0.02, 2.0),
            (20.0, 0.015, 0.02, 1.0),
            (20.0, 0.015, 0.02, 3.0),
            (20.0, 0.015, 0.01, 2.0),
            (20.0, 0.015, 0.05, 2.0),
        ] {
            v.push(Judge::F64(plane(slope, res, sigma, k)));
        }
        v.push(Judge::F64(Rule::Plane {
            step_m: 0.05,
            max_slope_deg: 20.0,
            residual_m: 0.015,
            sigma_m: 0.02,
            k: 2.0,
            rise_over_cell: true,
            backstop: false,
            angle_sigma_deg: 0.075,
            extremes: true,
        }));
        for a in [0.0, 0.05, 0.09, 0.1] {
            v.push(Judge::F64(plane_angular(a)));
        }
    }
    v.push(Judge::Library(NavigabilityRule::Spread));
    v.push(Judge::Library(NavigabilityRule::DEFAULT));
    v
}

fn car_design(sigma: f32) -> Design<L> {
    terrain_pyramid_host_tests::sim::cloud::car_design(sigma, 128)
        .expect("the street design is valid")
}

fn car_laser() -> RingLaser {
    RingLaser {
        elevation_bias_deg: 0.1,
        range_bias_m: 0.02,
        ..RingLaser::car(0.02)
    }
}

/// A noisier car laser: σ 3 cm, 0.15° per-beam elevation and 2 cm range errors.
fn noisy_car_laser() -> RingLaser {
    RingLaser {
        elevation_bias_deg: 0.15,
        range_bias_m: 0.02,
        ..RingLaser::car(0.03)
    }
}

fn car_scans(scene: &Scene, xs: &[f64], seed: u64) -> Vec<Vec<Observation>> {
    car_scans_with(&car_laser(), scene, xs, seed)
}

fn car_scans_with(
    laser: &RingLaser,
    scene: &Scene,
    xs: &[f64],
    seed: u64,
) -> Vec<Vec<Observation>> {
    let mut rng = Rng::new(seed);
    xs.iter()
        .map(|&x| {
            let pose = Pose {
                x,
                z: scene.ground_height(x, 0.0),
                ..Pose::default()
            };
            vec![laser.scan(scene, &pose, &mut rng)]
        })
        .collect()
}

/// One judge's outcome over a set of runs.
struct Outcome {
    layers: Vec<Tally>,
    fused: Tally,
    points: Tally,
    steps: Vec<Vec<(usize, usize)>>,
}

/// Runs every judge over `runs` (each a fresh pyramid of `design`) and scores them.
fn run<const W: usize>(
    design: &Design<L>,
    scene: &Scene,
    runs: &[Vec<Observation>],
    judges: &[Judge],
    max_range: f64,
) -> Vec<Outcome> {
    let layers = design.layers().len();
    let mut out: Vec<Outcome> = judges
        .iter()
        .map(|_| Outcome {
            layers: vec![Tally::default(); layers],
            fused: Tally::default(),
            points: Tally::default(),
            steps: vec![vec![(0, 0); GALLERY_STEPS_M.len()]; layers],
        })
        .collect();
    let mut classifier: Box<Classifier<SLOTS, L>> = navigability::classifier(design);
    let g = gates(design);
    for observations in runs {
        let mut seen = BTreeSet::new();
        let mut pyramids: Vec<Box<Pyramid<W, L>>> =
            judges.iter().map(|_| pyramid::<W, L>(design)).collect();
        for obs in observations {
            mark_seen(obs, max_range, &mut seen);
            let cells = observation_cells(&pyramids[0], &g, obs, ROBOT_HEIGHT);
            for (p, judge) in pyramids.iter_mut().zip(judges) {
                match judge {
                    Judge::F64(rule) => integrate(p, &g, obs, &cells, rule),
                    Judge::Library(rule) => {
                        classifier.configure(ClassifierConfig {
                            rule: *rule,
                            ..ClassifierConfig::default()
                        });
                        integrate_library(p, obs, &mut classifier);
                        assert_eq!(classifier.stats().overflow_points, 0, "scratch overflow");
                    }
                }
            }
        }
        for (p, o) in pyramids.iter().zip(out.iter_mut()) {
            for k in 0..layers {
                o.layers[k].add(&layer_tally(p, k, scene, ROBOT_HEIGHT));
                let s = step_detection(p, k, scene, &GALLERY_STEPS_M, ROBOT_HEIGHT);
                for (acc, v) in o.steps[k].iter_mut().zip(s) {
                    acc.0 += v.0;
                    acc.1 += v.1;
                }
            }
            o.fused
                .add(&fused_tally(p, scene, &seen, 0.5, ROBOT_HEIGHT));
            o.points.add(&fused_points(
                p,
                scene,
                observations,
                max_range,
                0.5,
                ROBOT_HEIGHT,
            ));
        }
    }
    out
}

fn pct(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else {
        format!("{v:.1}")
    }
}

fn share(ok: usize, n: usize) -> String {
    #[allow(clippy::cast_precision_loss)]
    pct(100.0 * ok as f64 / n as f64)
}

/// The per-layer, fused and at-returns table of one run.
fn print_table(title: &str, design: &Design<L>, judges: &[Judge], outcomes: &[Outcome]) {
    println!("\n### {title}\n");
    println!(
        "navigable % / obstacle % (truly navigable cells classed navigable / true obstacles classed obstacle)\n"
    );
    print_head(&["rule", "fused cells", "fused at returns"], design);
    for (judge, o) in judges.iter().zip(outcomes) {
        let mut line = format!(
            "| {} | {} / {} | {} / {} |",
            judge.name(),
            pct(o.fused.navigable_pct()),
            pct(o.fused.obstacle_pct()),
            pct(o.points.navigable_pct()),
            pct(o.points.obstacle_pct())
        );
        for t in &o.layers {
            line += &format!(" {} / {} |", pct(t.navigable_pct()), pct(t.obstacle_pct()));
        }
        println!("{line}");
    }
}

fn part_spread() {
    println!("\n## Flat ground: the share of cells whose spread exceeds 5 cm\n");
    println!("The car laser on the street's flat, clear, untextured ground (slope ≤ 3°, 0.5 m from any feature), two revolutions; cells of a fixed grid over every return within 20 m, the overhang cut applied.\n");
    println!("| laser | 0.1 m cells | 0.3 m cells | 0.6 m cells |");
    println!("| --- | --- | --- | --- |");
    let scene = Scene::street(0.05);
    let grids = [0.1, 0.3, 0.6];
    for (name, laser) in [
        ("σ 2 cm only", RingLaser::car(0.02)),
        (
            "σ 2 cm, 0.1° and 2 cm per-beam errors (the bench's)",
            car_laser(),
        ),
        (
            "σ 3 cm, 0.15° and 2 cm per-beam errors (the noisier)",
            noisy_car_laser(),
        ),
    ] {
        let mut rng = Rng::new(3);
        let mut tot = [(0, 0); 3];
        for x in [-4.0, 3.0] {
            let pose = Pose {
                x,
                z: scene.ground_height(x, 0.0),
                ..Pose::default()
            };
            let obs = laser.scan(&scene, &pose, &mut rng);
            for (g, &c) in grids.iter().enumerate() {
                let mut cells: BTreeMap<(usize, i64, i64), CellPoints> = BTreeMap::new();
                for q in &obs.points {
                    if (q[0] - obs.sensor[0]).hypot(q[1] - obs.sensor[1]) > 20.0 {
                        continue;
                    }
                    #[allow(clippy::cast_possible_truncation)]
                    let key = (0, (q[0] / c).floor() as i64, (q[1] / c).floor() as i64);
                    cells.entry(key).or_default().points.push(RefPoint {
                        x: q[0],
                        y: q[1],
                        z: q[2],
                        distance: 0.0,
                    });
                }
                for cell in cells.values_mut() {
                    cell.cut_overhang(ROBOT_HEIGHT);
                }
                let v = flat_spread(&cells, &[c], &scene, 0.05, 3.0, 0.5, ROBOT_HEIGHT);
                tot[g].0 += v[0].0;
                tot[g].1 += v[0].1;
            }
        }
        println!(
            "| {name} | {} % | {} % | {} % |",
            share(tot[0].1, tot[0].0),
            share(tot[1].1, tot[1].0),
            share(tot[2].1, tot[2].0)
        );
    }
    println!("| the street scan (held out, as measured by hand labelling) | 7 % | 30 % | 68 % |");
}

fn part_car(judges: &[Judge]) {
    println!("\n## The car laser on the simulated street");
    let street = Scene::street(0.05);
    for (name, laser) in [
        ("σ 2 cm, 0.1° / 2 cm per-beam errors", car_laser()),
        (
            "noisier: σ 3 cm, 0.15° / 2 cm per-beam errors",
            noisy_car_laser(),
        ),
    ] {
        let scans = car_scans_with(&laser, &street, &[-4.0, 3.0, 10.0], 42);
        for design_sigma in [0.15_f32, 0.02] {
            let design = car_design(design_sigma);
            let outcomes = run::<128>(&design, &street, &scans, judges, 20.0);
            print_table(
                &format!("{name}, design σ {design_sigma} m (three revolutions)"),
                &design,
                judges,
                &outcomes,
            );
        }
    }
}

fn print_steps(title: &str, design: &Design<L>, judges: &[Judge], outcomes: &[Outcome]) {
    println!("\n### {title}\n");
    println!("The smallest step (cm) found in at least half of the observed cells on its edges, per layer (– none up to 20 cm, or no such cell observed); fused: obstacle share over true obstacle cells.\n");
    print_head(&["rule", "fused obstacle %"], design);
    for (judge, o) in judges.iter().zip(outcomes) {
        let mut line = format!("| {} | {} |", judge.name(), pct(o.fused.obstacle_pct()));
        for per in &o.steps {
            let found = GALLERY_STEPS_M
                .iter()
                .zip(per)
                .find(|(_, &(n, ok))| n > 0 && ok * 2 >= n)
                .map_or("–".to_string(), |(h, _)| format!("{:.0}", h * 100.0));
            line += &format!(" {found} |");
        }
        println!("{line}");
    }
}

fn part_gallery(judges: &[Judge]) {
    println!("\n## The step gallery");
    let gallery = Scene::step_gallery(&[3.0, 7.0, 11.0, 15.0]);
    let scans = car_scans(&gallery, &[0.0], 7);
    let design = car_design(0.15);
    let outcomes = run::<128>(&design, &gallery, &scans, judges, 20.0);
    print_steps(
        "car laser, one revolution, platforms at 3-16.5 m, design σ 0.15 m",
        &design,
        judges,
        &outcomes,
    );
    let pan_design = Design::<L>::new(SensorModel::default(), Schedule::default(), 64)
        .expect("the default design is valid");
    let gallery = Scene::step_gallery(&[5.0]);
    let obs = pan_observations(&gallery, pan_laser(), &approach(), 8, 1);
    let outcomes = run::<64>(&pan_design, &gallery, &[obs], judges, 10.0);
    print_steps(
        "the paper's robot approaching platforms at 5 m, default design",
        &pan_design,
        judges,
        &outcomes,
    );
}

fn pan_laser() -> LaserConfig {
    LaserConfig {
        sigma_m: 0.02,
        ..LaserConfig::paper()
    }
}

fn approach() -> Trajectory {
    Trajectory::approach(2.0, 1.0, 5.05, 1.0)
}

fn part_pan(judges: &[Judge]) {
    println!("\n## The paper's robot on simulated terrain (default design: 10 m, γ 2)");
    let design = Design::<L>::new(SensorModel::default(), Schedule::default(), 64)
        .expect("the default design is valid");
    let mut scenes: Vec<(String, Scene)> = [5.0, 10.0, 15.0, 20.0]
        .iter()
        .map(|&a| (format!("slope {a}° from x = 3.05 m"), Scene::slope(3.05, a)))
        .collect();
    scenes.push((
        "grass ±2.5 cm (λ 0.12 m) from x = 2 m, gravel ±1.2 cm from 10 m".into(),
        Scene::rough(2.0, 0.025),
    ));
    scenes.push((
        "cambered road (2.5 %), 12 cm curbs at |y| = 3.5 m, a kerb cut".into(),
        Scene::cambered_road(0.025, 0.12, 5.0),
    ));
    scenes.push(("10 cm curb at x = 4.05 m".into(), Scene::curb(4.05, 0.10)));
    scenes.push((
        "stairs (5 × 17 cm) from x = 5.05 m".into(),
        Scene::stairs(Default::default()),
    ));
    scenes.push((
        "ditch 0.5 m deep, 0.6 m wide, at x = 4.05 m".into(),
        Scene::ditch(4.05, 0.6, 0.5),
    ));
    for (name, scene) in &scenes {
        let obs = pan_observations(scene, pan_laser(), &approach(), 8, 1);
        let outcomes = run::<64>(&design, scene, &[obs], judges, 10.0);
        print_table(name, &design, judges, &outcomes);
    }
}

/// One row of the 3DTK table: the rule's name and its scores.
fn print_3dtk_row(name: &str, e: &scan3dtk::Evaluation) {
    println!(
        "| {name} | {} % ({} of {}) | {} % ({} of {}) | {} % ({} of {}) | {} % |",
        share(e.ground_navigable, e.ground),
        e.ground_navigable,
        e.ground,
        share(e.ground_cells_navigable, e.ground_cells),
        e.ground_cells_navigable,
        e.ground_cells,
        share(e.obstacle_found, e.obstacle),
        e.obstacle_found,
        e.obstacle,
        share(e.step_found, e.step)
    );
}

fn part_3dtk(judges: &[Judge]) {
    println!("\n## The 3DTK scan against its hand labelling (README replay: h 0.4 m, 8 m, γ 3, ceiling 1.2 m)\n");
    let points = match read_uos(std::path::Path::new(SCAN_PATH)) {
        Ok(p) => p,
        Err(e) => {
            println!("cannot read {SCAN_PATH}: {e} (run from the workspace root)");
            return;
        }
    };
    let labels = Labels::parse(LABELS).expect("the labelling parses");
    let lab = labelled(&points, &labels, 8.0);
    std::fs::create_dir_all("out/terrain-rules").ok();
    let img = render(&points, &labels, &lab, (-0.5, 8.5, -2.0, 8.0), 0.01);
    if std::fs::write("out/terrain-rules/scan000-labels.png", img.encode()).is_ok() {
        println!("(the labelling over the top view: out/terrain-rules/scan000-labels.png)\n");
    }
    let count = |l: Label| lab.iter().filter(|(_, x)| *x == l).count();
    println!(
        "Labelled within 8 m: {} clear ground returns, {} obstacle returns, {} returns on the 4-6 cm step.\n",
        count(Label::Ground),
        count(Label::Obstacle),
        count(Label::Step)
    );
    println!("| rule | clear ground navigable (returns) | clear ground navigable (0.1 m cells) | obstacle returns with an obstacle cell within 0.2 m | step returns, same |");
    println!("| --- | --- | --- | --- | --- |");
    let design = readme_design();
    let obs = scan3dtk::observation(&points);
    let mut classifier: Box<Classifier<SLOTS, L>> = navigability::classifier(&design);
    let g = gates(&design);
    let mut per_layer: Vec<(String, Vec<Tally>)> = Vec::new();
    let mut layer_names: Vec<String> = Vec::new();
    for judge in judges {
        let mut p = pyramid::<64, L>(&design);
        match judge {
            Judge::F64(rule) => {
                let cells = observation_cells(&p, &g, &obs, ROBOT_HEIGHT);
                integrate(&mut p, &g, &obs, &cells, rule);
            }
            Judge::Library(rule) => {
                classifier.configure(ClassifierConfig {
                    rule: *rule,
                    ceiling: Some(Meters::from_num(scan3dtk::CEILING_M)),
                    ..ClassifierConfig::default()
                });
                // The whole scan (the ceiling is the classifier's option here).
                let all = Observation {
                    points: points.clone(),
                    ..obs.clone()
                };
                integrate_library(&mut p, &all, &mut classifier);
            }
        }
        print_3dtk_row(&judge.name(), &scan3dtk::score(&p, &lab));
        if let Judge::Library(_) = judge {
            layer_names = (0..p.layer_count())
                .filter_map(|k| p.layer(k))
                .enumerate()
                .map(|(k, l)| {
                    format!(
                        "L{k} {:.1} m",
                        f64::from(l.resolution().to_bits()) / 65_536.0
                    )
                })
                .collect();
            let tallies = (0..p.layer_count())
                .map(|k| scan3dtk::score_layer(&p, k, &lab))
                .collect();
            per_layer.push((judge.name(), tallies));
        }
    }
    // The default rule again, the points sorted into a spinning laser's firing order (by
    // azimuth in steps of the design's ψ, then by elevation from the bottom), as `pyramid
    // replay --order firing` gives them (the plane rule pairing each return with the last
    // three of its cell, as replay sets it in that order): what that order costs a tilting
    // 2-D laser's scan.
    let mut p = pyramid::<64, L>(&design);
    classifier.configure(ClassifierConfig {
        ceiling: Some(Meters::from_num(scan3dtk::CEILING_M)),
        rule: NavigabilityRule::DEFAULT.for_firing_order(),
        ..ClassifierConfig::default()
    });
    let psi = f64::from(design.sensor().psi_rad);
    let all = Observation {
        points: firing_order(&points, obs.sensor, psi),
        ..obs.clone()
    };
    integrate_library(&mut p, &all, &mut classifier);
    print_3dtk_row(
        "library, plane (default), fixed point, firing order (`pyramid replay --order firing`)",
        &scan3dtk::score(&p, &lab),
    );
    println!(
        "\nPer layer (the library's rules): of the clear ground returns whose cell in the layer is \
         observed, the share on a navigable cell / of the obstacle and step returns whose cell is \
         observed, the share on an obstacle cell (each return judged by the one cell that holds it).\n"
    );
    println!("| rule | {} |", layer_names.join(" | "));
    println!("| --- |{}", " --- |".repeat(layer_names.len()));
    for (name, tallies) in &per_layer {
        let cells: Vec<String> = tallies
            .iter()
            .map(|t| {
                let f = |a: usize, b: usize| {
                    if b == 0 {
                        "–".to_string()
                    } else {
                        format!("{:.1}", 100.0 * a as f64 / b as f64)
                    }
                };
                format!(
                    "{} / {}",
                    f(t.navigable_ok, t.navigable),
                    f(t.obstacle_ok, t.obstacle)
                )
            })
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}
fn main() {
    let part = std::env::args().nth(1).unwrap_or_default();
    // The library's scratch (3 MiB) is built in place on this thread's stack.
    let worker = std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(move || {
            let all = part.is_empty();
            if all || part == "spread" {
                part_spread();
            }
            if all || part == "car" {
                part_car(&judges(true));
            }
            if all || part == "gallery" {
                let mut j = judges(false);
                j.insert(2, Judge::F64(plane_angular(0.0)));
                part_gallery(&j);
            }
            if all || part == "pan" {
                part_pan(&judges(false));
            }
            if all || part == "3dtk" {
                part_3dtk(&judges(true));
            }
            if all || part == "agreement" {
                part_agreement();
            }
        })
        .expect("a thread");
    worker.join().expect("the tables");
}
