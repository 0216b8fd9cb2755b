//! The default co-processor as in `pyramid`, with decay on: all evidence, every layer at the
//! shortest time constant its sweep's budget allows (τ = 1 s, a step every 125 ms: 262 144
//! cells a second over the 8 layers), polled with the recording's clock. Against `pyramid`,
//! the decay's cost per laser return at its most expensive.
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid_bench::{boot_with, default_design, Pipeline};

#[cortex_m_rt::entry]
fn main() -> ! {
    let config = b::shortest_decay_config();
    let mut p = b::booted_core(
        b::default_core(),
        default_design::<64, 8>(),
        |core, rec, design| boot_with(core, rec, design, &config),
    );
    let stack = b::measure(b::recording(), &mut p);
    let cells = p.core.pyramid().stats().rows_decayed * 64;
    b::report(p.returns(), p.lines(), cells, stack)
}
