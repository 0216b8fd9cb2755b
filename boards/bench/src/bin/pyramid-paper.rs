//! `pyramid-nolink` under the paper's navigability rule (the spread of a cell's points against the
//! step threshold) instead of the default plane rule: the two rules' cost per return.
#![no_std]
#![no_main]

use terrain_pyramid::classify::NavigabilityRule;

#[cortex_m_rt::entry]
fn main() -> ! {
    bench_firmware::run_fixed(Some(NavigabilityRule::Spread))
}
