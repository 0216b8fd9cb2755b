//! The default co-processor as in `pyramid`, with decay on: all evidence, every layer at the
//! shortest time constant its sweep's budget allows (τ = 1 s, a step every 125 ms: 262 144
//! cells a second over the 8 layers), polled with the recording's clock. Against `pyramid`,
//! the decay's cost per laser return at its most expensive.
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::{Config, Decay, DecayMode, DefaultCoProcessor, TimeConstant};
use terrain_pyramid_bench::{boot_with, default_design, Core, Pipeline};

static CORE: ConstStaticCell<DefaultCoProcessor> = ConstStaticCell::new(DefaultCoProcessor::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let core = CORE.take();
    let Some(design) = default_design::<64, 8>() else {
        panic!("default design");
    };
    let config = Config {
        decay: Decay::uniform(DecayMode::All, TimeConstant::MIN, 8),
        ..Config::default()
    };
    if !boot_with(core, rec, &design, &config) {
        panic!("boot");
    }
    let mut p = Core {
        core,
        angle: HostSuppliedAngle::new(),
    };
    let stack = b::measure(rec, &mut p);
    let cells = p.core.pyramid().stats().rows_decayed * 64;
    b::report(p.returns(), p.lines(), cells, stack)
}
