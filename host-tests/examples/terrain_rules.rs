//! The navigability rules measured on simulated terrain (exploration build).

use std::collections::BTreeSet;
use terrain_pyramid::{Design, GateShape, Schedule, SensorModel};
use terrain_pyramid_host_tests::navigability::{
    fused_points, fused_tally, integrate, layer_tally, mark_seen, observation_cells, pyramid,
    step_detection, Rule, Tally,
};
use terrain_pyramid_host_tests::sim::cloud::{pan_observations, Observation, RingLaser};
use terrain_pyramid_host_tests::sim::laser::LaserConfig;
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::terrain::GALLERY_STEPS_M;
use terrain_pyramid_host_tests::sim::trajectory::{Pose, Trajectory};

const L: usize = 16;

fn car_design(sigma: f32) -> Design<L> {
    Design::new(
        SensorModel {
            phi_rad: 0.4_f32.to_radians(),
            psi_rad: 0.2_f32.to_radians(),
            sigma_m: sigma,
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
    .unwrap()
}

struct Run {
    layers: Vec<Tally>,
    fused: Tally,
    points: Tally,
    steps: Vec<Vec<(usize, usize)>>,
}

fn run<const W: usize>(
    design: &Design<L>,
    scene: &Scene,
    runs: &[Vec<Observation>],
    rules: &[Rule],
    max_range: f64,
) -> Vec<Run> {
    let robot_h = 1.0;
    let mut out: Vec<Run> = rules
        .iter()
        .map(|_| Run {
            layers: vec![Tally::default(); design.layers().len()],
            fused: Tally::default(),
            points: Tally::default(),
            steps: vec![vec![(0, 0); GALLERY_STEPS_M.len()]; design.layers().len()],
        })
        .collect();
    for observations in runs {
        let mut seen = BTreeSet::new();
        let mut pyramids: Vec<_> = rules.iter().map(|_| pyramid::<W, L>(design)).collect();
        for obs in observations {
            mark_seen(obs, max_range, &mut seen);
            let cells = observation_cells(&pyramids[0], obs, robot_h);
            for (p, rule) in pyramids.iter_mut().zip(rules) {
                integrate(p, obs, &cells, rule);
            }
        }
        for (p, o) in pyramids.iter().zip(out.iter_mut()) {
            for k in 0..design.layers().len() {
                o.layers[k].add(&layer_tally(p, k, scene, robot_h));
                let s = step_detection(p, k, scene, &GALLERY_STEPS_M, robot_h);
                for (acc, v) in o.steps[k].iter_mut().zip(s) {
                    acc.0 += v.0;
                    acc.1 += v.1;
                }
            }
            o.fused.add(&fused_tally(p, scene, &seen, 0.5, robot_h));
            o.points.add(&fused_points(
                p,
                scene,
                observations,
                max_range,
                0.5,
                robot_h,
            ));
        }
    }
    out
}

fn pct(v: f64) -> String {
    if v.is_nan() {
        "   -  ".into()
    } else {
        format!("{v:5.1}%")
    }
}

fn print(title: &str, rules: &[Rule], runs: &[Run], steps: bool) {
    println!("\n## {title}");
    for (rule, r) in rules.iter().zip(runs) {
        let mut line = format!("{:<70}", rule.name());
        line += &format!(
            " fused nav {} obs {} pts {} {} |",
            pct(r.fused.navigable_pct()),
            pct(r.fused.obstacle_pct()),
            pct(r.points.navigable_pct()),
            pct(r.points.obstacle_pct())
        );
        for t in &r.layers {
            line += &format!(" {}/{}", pct(t.navigable_pct()), pct(t.obstacle_pct()));
        }
        println!("{line}");
        if steps {
            let mut s = String::from("      smallest step ≥50% per layer:");
            for per in &r.steps {
                let found = GALLERY_STEPS_M
                    .iter()
                    .zip(per)
                    .find(|(_, &(n, ok))| n > 0 && ok * 2 >= n)
                    .map_or("-".to_string(), |(h, _)| format!("{:.0}", h * 100.0));
                s += &format!(" {found}");
            }
            println!("{s}");
        }
    }
}

fn rules(sigma: f64) -> Vec<Rule> {
    let mut v = vec![
        Rule::Paper { step_m: 0.05 },
        Rule::Tolerant {
            step_m: 0.05,
            max_slope_deg: 15.0,
            sigma_m: sigma,
            k: 3.0,
        },
        Rule::JumpOrTolerant {
            step_m: 0.05,
            max_slope_deg: 15.0,
            radius_m: 0.15,
            sigma_m: sigma,
            k: 3.0,
        },
    ];
    for (rise_over_cell, backstop) in [(false, false), (true, false), (true, true)] {
        for (slope, res) in [(15.0, 0.015), (20.0, 0.015), (15.0, 0.02)] {
            v.push(Rule::Plane {
                step_m: 0.05,
                max_slope_deg: slope,
                residual_m: res,
                sigma_m: sigma,
                k: 2.0,
                rise_over_cell,
                backstop,
            });
        }
    }
    v
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let only = args.get(1).cloned().unwrap_or_default();
    let sigma_sim = 0.02;
    let rules = rules(sigma_sim);
    if only.is_empty() || only == "car" {
        let street = Scene::street(0.05);
        let laser = RingLaser {
            elevation_bias_deg: 0.1,
            range_bias_m: 0.02,
            ..RingLaser::car(sigma_sim)
        };
        let mut rng = Rng::new(42);
        let scans: Vec<Vec<Observation>> = [-4.0, 3.0, 10.0]
            .iter()
            .map(|&x| {
                let pose = Pose {
                    x,
                    z: street.ground_height(x, 0.0),
                    ..Pose::default()
                };
                vec![laser.scan(&street, &pose, &mut rng)]
            })
            .collect();
        for design_sigma in [0.15_f32, 0.02] {
            let design = car_design(design_sigma);
            let r = run::<128>(&design, &street, &scans, &rules, 20.0);
            print(
                &format!("car laser (σ 2 cm) on the street, design σ {design_sigma} m"),
                &rules,
                &r,
                false,
            );
        }
        let gallery = Scene::step_gallery(&[3.0, 7.0, 11.0, 15.0]);
        let scans: Vec<Vec<Observation>> =
            vec![vec![laser.scan(&gallery, &Pose::default(), &mut rng)]];
        let design = car_design(0.15);
        let r = run::<128>(&design, &gallery, &scans, &rules, 20.0);
        print(
            "car laser on the step gallery, design σ 0.15",
            &rules,
            &r,
            true,
        );
    }
    if only.is_empty() || only == "3dtk" {
        use terrain_pyramid_host_tests::scan3dtk::{
            evaluate, labelled, read_uos, readme_design, render, Labels, LABELS, SCAN_PATH,
        };
        let points = read_uos(std::path::Path::new(SCAN_PATH)).unwrap();
        let labels = Labels::parse(LABELS).unwrap();
        let lab = labelled(&points, &labels, 8.0);
        std::fs::create_dir_all("out/terrain-rules").unwrap();
        let img = render(&points, &labels, &lab, (-0.5, 8.5, -2.0, 8.0), 0.01);
        std::fs::write("out/terrain-rules/scan000-labels.png", img.encode()).unwrap();
        let design = readme_design();
        println!("\n## 3DTK scan000 (README replay: h 0.4 m, 8 m, γ 3, ceiling 1.2 m)");
        for rule in &rules {
            let (e, _) = evaluate(&design, &points, &lab, rule);
            println!(
                "{:<70} clear ground navigable {}/{} = {:.1}%  obstacle {}/{} = {:.1}%  step {}/{} = {:.1}%",
                rule.name(),
                e.ground_navigable, e.ground, 100.0 * e.ground_navigable as f64 / e.ground as f64,
                e.obstacle_found, e.obstacle, 100.0 * e.obstacle_found as f64 / e.obstacle as f64,
                e.step_found, e.step, 100.0 * e.step_found as f64 / e.step as f64,
            );
        }
    }
    if only.is_empty() || only == "pan" {
        let design = Design::<L>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let laser = LaserConfig {
            sigma_m: sigma_sim,
            ..LaserConfig::paper()
        };
        let mut scenes: Vec<Scene> = [5.0, 10.0, 15.0, 20.0]
            .iter()
            .map(|&a| Scene::slope(3.05, a))
            .collect();
        scenes.push(Scene::rough(2.0, 0.025));
        scenes.push(Scene::cambered_road(0.025, 0.12, 5.0));
        scenes.push(Scene::curb(4.05, 0.10));
        scenes.push(Scene::stairs(Default::default()));
        scenes.push(Scene::ditch(4.05, 0.6, 0.5));
        scenes.push(Scene::step_gallery(&[5.0]));
        for scene in &scenes {
            let traj = Trajectory::approach(2.0, 1.0, 5.05, 1.0);
            let obs = pan_observations(scene, laser, &traj, 8, 1);
            let r = run::<64>(&design, scene, &[obs], &rules, 10.0);
            print(
                &format!("paper robot (σ 2 cm), {}", scene.name),
                &rules,
                &r,
                scene.name == "step gallery",
            );
        }
    }
}
