//! The default co-processor (8 × 64², the default pipeline and the host link) with the hard
//! gate instead of the soft one: each point feeds the one layer whose band holds it. It
//! measures what the soft gate's extra fed layers cost (`pyramid` against this).
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid::{Design, GateShape, Schedule, SensorModel};
use terrain_pyramid_bench::boot;

#[cortex_m_rt::entry]
fn main() -> ! {
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    let design = Design::<8>::new(SensorModel::default(), schedule, 64).ok();
    b::run(&mut b::booted_core(b::default_core(), design, boot))
}
