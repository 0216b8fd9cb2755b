//! The default co-processor (8 × 64², soft gate, the default pipeline and the host link) on a
//! spinning lidar's recording: the laser the recording's sensor event names, its packets
//! decoded, timed and placed return by return (`cargo xtask bench`, the lidar rows).
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid_bench::{boot_with_sensor, default_design};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut p = b::booted_core(
        b::default_core(),
        default_design::<64, 8>(),
        boot_with_sensor,
    );
    let stack = b::measure(b::recording(), &mut p);
    // The report's "cells" slot carries the samples without a distance (no window moves
    // are counted here): the xtask reads returns + no_return as the samples decoded.
    let stats = p.core.frontend().stats();
    b::report(stats.returns, stats.packets_applied, stats.no_return, stack)
}
