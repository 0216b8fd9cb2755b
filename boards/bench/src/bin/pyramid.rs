//! The default co-processor (8 × 64², soft gate, the default pipeline and the host link), as
//! the firmware runs it: the application core.
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid_bench::{boot, default_design};

#[cortex_m_rt::entry]
fn main() -> ! {
    b::run(&mut b::booted_core(
        b::default_core(),
        default_design::<64, 8>(),
        boot,
    ))
}
