//! The default co-processor (8 × 64², soft gate, the default pipeline and the host link) on a
//! spinning lidar's recording: the laser the recording's sensor event names, its packets
//! decoded, timed and placed return by return (`cargo xtask bench`, the lidar rows).
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::DefaultCoProcessor;
use terrain_pyramid_bench::{boot_with_sensor, default_design, Core};

static CORE: ConstStaticCell<DefaultCoProcessor> = ConstStaticCell::new(DefaultCoProcessor::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    let rec = b::recording();
    let core = CORE.take();
    let Some(design) = default_design::<64, 8>() else {
        panic!("default design");
    };
    if !boot_with_sensor(core, rec, &design) {
        panic!("boot");
    }
    let mut p = Core {
        core,
        angle: HostSuppliedAngle::new(),
    };
    let stack = b::measure(rec, &mut p);
    // The report's "cells" slot carries the samples without a distance (no window moves
    // are counted here): the xtask reads returns + no_return as the samples decoded.
    let stats = p.core.frontend().stats();
    b::report(stats.returns, stats.packets_applied, stats.no_return, stack)
}
