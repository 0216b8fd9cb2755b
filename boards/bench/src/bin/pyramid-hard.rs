//! The default co-processor (8 × 64², the default pipeline and the host link) with the hard
//! gate instead of the soft one: each point feeds the one layer whose band holds it. It
//! measures what the soft gate's extra fed layers cost (`pyramid` against this).
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::{DefaultCoProcessor, Design, GateShape, Schedule, SensorModel};
use terrain_pyramid_bench::{boot, Core, Pipeline};

static CORE: ConstStaticCell<DefaultCoProcessor> = ConstStaticCell::new(DefaultCoProcessor::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let core = CORE.take();
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    let Ok(design) = Design::<8>::new(SensorModel::default(), schedule, 64) else {
        panic!("hard-gate design");
    };
    if !boot(core, rec, &design) {
        panic!("boot");
    }
    let mut p = Core {
        core,
        angle: HostSuppliedAngle::new(),
    };
    let stack = b::measure(rec, &mut p);
    b::report(p.returns(), p.lines(), 0, stack)
}
