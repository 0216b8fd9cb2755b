//! `pyramid` with the recording's poses taken as stamped poses at their recording times: each
//! return placed with the pose interpolated at its own time (the timed path's cost).
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid_bench::{boot, default_design, TimedCore};

#[cortex_m_rt::entry]
fn main() -> ! {
    let core = b::booted_core(b::default_core(), default_design::<64, 8>(), boot);
    b::run(&mut TimedCore(core))
}
