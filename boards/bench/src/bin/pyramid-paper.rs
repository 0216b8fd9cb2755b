//! `pyramid-nolink` under the paper's navigability rule (the spread of a cell's points against the
//! step threshold) instead of the default plane rule: the two rules' cost per return.
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::classify::NavigabilityRule;
use terrain_pyramid::wire::sick::SickAccumulator;
use terrain_pyramid::{Config, DefaultFrontend, DefaultPyramid};
use terrain_pyramid_bench::{default_design, frontend_config, setup, Fixed, Pipeline};

static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());
static ACC: ConstStaticCell<SickAccumulator> = ConstStaticCell::new(SickAccumulator::new());
static FRONTEND: ConstStaticCell<DefaultFrontend> =
    ConstStaticCell::new(DefaultFrontend::unconfigured());

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let Some(mut config) = setup(rec).as_ref().and_then(frontend_config) else {
        panic!("the recording has no usable setup");
    };
    config.classifier.rule = NavigabilityRule::Spread;
    let pyramid = PYRAMID.take();
    let Some(design) = default_design::<64, 8>() else {
        panic!("default design");
    };
    let frontend = FRONTEND.take();
    frontend.configure(config);
    if pyramid.configure(&design, &Config::default()).is_err()
        || frontend.adopt_design(&design, &Config::default()).is_err()
    {
        panic!("configure");
    }
    let mut p = Fixed {
        accumulator: ACC.take(),
        frontend,
        pyramid,
    };
    let stack = b::measure(rec, &mut p);
    b::report(p.returns(), p.lines(), 0, stack)
}
