//! The single flat map: one layer of 200 × 200 cells at 0.1 m (±10 m, the whole range), fed
//! every point (hard gate, one layer), with the default pipeline and the host link.
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::{ConstStaticCell, StaticCell};
use terrain_pyramid::link::{Link, LinkConfig};
use terrain_pyramid::wire::sick::Accumulator;
use terrain_pyramid::{Config, DefaultFrontend, Design, GateShape, Pyramid, Schedule, SensorModel};
use terrain_pyramid_bench::{frontend_config, replay, setup, Fixed, Pipeline};

/// One layer of 200 × 200 cells: 0.1 m cells over ±10 m.
type Flat = Pyramid<200, 1>;
static PYRAMID: ConstStaticCell<Flat> = ConstStaticCell::new(Flat::new());
static LINK: ConstStaticCell<Link> = ConstStaticCell::new(Link::new(LinkConfig::DEFAULT));
static ACC: ConstStaticCell<Accumulator> = ConstStaticCell::new(Accumulator::new());
static FRONTEND: StaticCell<DefaultFrontend> = StaticCell::new();

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let Some(config) = setup(rec).as_ref().and_then(frontend_config) else {
        panic!("the recording has no usable setup");
    };
    let pyramid = PYRAMID.take();
    let link = LINK.take();
    // A design of exactly one layer at Δd = 0.1 m: a sensor model whose range (0.5 m) the
    // base layer already reaches. Hard gate; the only layer is the last, so its weight is 1 at
    // every distance (distances past 0.5 m fall in the last bin): every point feeds it.
    let sensor = SensorModel {
        max_range_m: 0.5,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    let Ok(design) = Design::<1>::new(sensor, schedule, 200) else {
        panic!("default design");
    };
    if link
        .configure(pyramid, &design, &Config::default())
        .is_err()
    {
        panic!("configure");
    }
    let frontend = FRONTEND.init(DefaultFrontend::new(config));
    let acc = ACC.take();
    let mut p = Fixed {
        frontend,
        pyramid,
        link: Some(link),
    };
    let top = b::paint_stack();
    b::start();
    let counts = replay(rec, acc, &mut p);
    b::end();
    let stack = b::stack_used(top);
    b::report(p.returns(), counts.lines, 0, stack)
}
