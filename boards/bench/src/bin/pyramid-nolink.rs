//! The default pyramid (8 × 64², soft gate) with the default pipeline, without the link (for the f32 comparison).
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::{ConstStaticCell, StaticCell};
use terrain_pyramid::link::Link;
use terrain_pyramid::wire::sick::Accumulator;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultFrontend, DefaultPyramid, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};
use terrain_pyramid_bench::{frontend_config, replay, setup, Fixed, Pipeline};

static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());
static ACC: ConstStaticCell<Accumulator> = ConstStaticCell::new(Accumulator::new());
static FRONTEND: StaticCell<DefaultFrontend> = StaticCell::new();

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
    let frontend = FRONTEND.init(DefaultFrontend::new(config));
    let acc = ACC.take();
    let mut p = Fixed {
        frontend,
        pyramid,
        link: None::<&mut Link>,
    };
    let top = b::paint_stack();
    b::start();
    let counts = replay(rec, acc, &mut p);
    b::end();
    let stack = b::stack_used(top);
    b::report(p.returns(), counts.lines, 0, stack)
}
