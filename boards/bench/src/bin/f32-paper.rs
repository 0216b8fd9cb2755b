//! `f32` under the paper's navigability rule (the spread of a cell's points against the step
//! threshold), the f32 counterpart of `pyramid-paper`.
#![no_std]
#![no_main]

use terrain_pyramid::classify::NavigabilityRule;

#[cortex_m_rt::entry]
fn main() -> ! {
    bench_firmware::run_f32(Some(NavigabilityRule::Spread))
}
