//! The f32 counterpart (`terrain-pyramid-f32`) of the pipeline without the link
//! (`pyramid-nolink`): the default design's 8 layers of 64², f32 cells, f32 geometry and
//! classifier, under the configuration's rule (the default plane rule).
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::{ConstStaticCell, StaticCell};
use terrain_pyramid::wire::sick::SickAccumulator;
use terrain_pyramid::{Config, DefaultDesign, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE};
use terrain_pyramid_bench::f32_pipeline::{Frontend, Pyramid};
use terrain_pyramid_bench::{frontend_config, replay, setup, Pipeline, F32};

static PYRAMID: ConstStaticCell<Pyramid<64, 8>> = ConstStaticCell::new(Pyramid::new());
static ACC: ConstStaticCell<SickAccumulator> = ConstStaticCell::new(SickAccumulator::new());
static FRONTEND: StaticCell<Frontend<1024>> = StaticCell::new();

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let Some(config) = setup(rec).as_ref().and_then(frontend_config) else {
        panic!("the recording has no usable setup");
    };
    let pyramid = PYRAMID.take();
    let Ok(design) = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    ) else {
        panic!("default design");
    };
    if pyramid.configure(&design, &Config::default()).is_err() {
        panic!("configure");
    }
    let frontend = FRONTEND.init(Frontend::new(config));
    let mut p = F32 {
        accumulator: ACC.take(),
        frontend,
        pyramid,
    };
    let top = b::paint_stack();
    b::start();
    replay(rec, &mut p);
    b::end();
    let stack = b::stack_used(top);
    b::report(p.returns(), p.lines(), 0, stack)
}
