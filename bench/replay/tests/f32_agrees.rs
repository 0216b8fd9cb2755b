//! The f32 counterpart does the fixed pipeline's work: on the paper's stairs, under either
//! navigability rule, the two pyramids call the same cells obstacle and navigable (up to the
//! cells where rounding decides), so that the instructions the bench compares buy the same map.

use terrain_pyramid::classify::NavigabilityRule;
use terrain_pyramid::wire::sick::SickAccumulator;
use terrain_pyramid::{Config, DefaultFrontend, DefaultPyramid};
use terrain_pyramid_bench::f32_pipeline;
use terrain_pyramid_bench::{default_design, frontend_config, replay, setup, Fixed, F32};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};

/// Cells known in both maps, and of those, the ones whose sign (obstacle, navigable) agrees;
/// obstacles in the fixed map, and those the f32 map also calls obstacles.
fn compare(rule: NavigabilityRule) -> (usize, usize, usize, usize) {
    let sim = simulate(&SimConfig::paper_stairs(1.0, 1.0, 1.0)).unwrap();
    let rec = &sim.bytes[..];
    let mut config = setup(rec).as_ref().and_then(frontend_config).unwrap();
    config.classifier.rule = rule;
    let design = default_design::<64, 8>().unwrap();

    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut frontend = Box::new(DefaultFrontend::unconfigured());
    frontend.configure(config);
    pyramid.configure(&design, &Config::default()).unwrap();
    frontend.adopt_design(&design, &Config::default()).unwrap();
    let mut accumulator = Box::new(SickAccumulator::new());
    replay(
        rec,
        &mut Fixed {
            accumulator: &mut accumulator,
            frontend: &mut frontend,
            pyramid: &mut pyramid,
        },
    );

    let mut f32_pyramid = Box::new(f32_pipeline::Pyramid::<64, 8>::new());
    f32_pyramid.configure(&design, &Config::default()).unwrap();
    let mut f32_frontend = Box::new(f32_pipeline::Frontend::<1024>::new(config));
    let mut accumulator = Box::new(SickAccumulator::new());
    replay(
        rec,
        &mut F32 {
            accumulator: &mut accumulator,
            frontend: &mut f32_frontend,
            pyramid: &mut f32_pyramid,
        },
    );

    let (mut both, mut agree, mut obstacles, mut obstacles_agree) = (0, 0, 0, 0);
    for k in 0..8 {
        let layer = pyramid.layer(k).unwrap();
        let (ox, oy) = layer.origin();
        for j in oy..oy + 64 {
            for i in ox..ox + 64 {
                let fixed = layer
                    .get(i, j)
                    .and_then(|c| c.log_odds())
                    .map(|l| l.to_num::<f32>());
                let (Some(fixed), Some(float)) = (fixed, f32_pyramid.get(k, i, j)) else {
                    continue;
                };
                if fixed == 0.0 || float == 0.0 {
                    continue;
                }
                both += 1;
                agree += usize::from((fixed > 0.0) == (float > 0.0));
                if fixed > 0.0 {
                    obstacles += 1;
                    obstacles_agree += usize::from(float > 0.0);
                }
            }
        }
    }
    (both, agree, obstacles, obstacles_agree)
}

fn check(rule: NavigabilityRule, name: &str) {
    let (both, agree, obstacles, obstacles_agree) = compare(rule);
    println!("{name}: {agree} of {both} cells agree, {obstacles_agree} of {obstacles} obstacles");
    assert!(both > 1_000, "{name}: only {both} cells known in both");
    assert!(obstacles > 20, "{name}: only {obstacles} obstacle cells");
    assert!(
        agree as f64 >= 0.98 * both as f64,
        "{name}: {agree} of {both} cells agree"
    );
    assert!(
        obstacles_agree as f64 >= 0.9 * obstacles as f64,
        "{name}: {obstacles_agree} of {obstacles} obstacles agree"
    );
}

#[test]
fn the_f32_pipeline_makes_the_fixed_pipelines_map_under_the_plane_rule() {
    check(NavigabilityRule::DEFAULT, "plane rule");
}

#[test]
fn the_f32_pipeline_makes_the_fixed_pipelines_map_under_the_paper_rule() {
    check(NavigabilityRule::Spread, "paper's rule");
}
