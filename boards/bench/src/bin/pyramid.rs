//! The default co-processor (8 × 64², soft gate, the default pipeline and the host link), as
//! the firmware runs it: the application core.
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::DefaultCoProcessor;
use terrain_pyramid_bench::{boot, default_design, Core, Pipeline};

static CORE: ConstStaticCell<DefaultCoProcessor> = ConstStaticCell::new(DefaultCoProcessor::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let core = CORE.take();
    let Some(design) = default_design::<64, 8>() else {
        panic!("default design");
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
