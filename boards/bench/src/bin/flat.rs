//! The same application core into a single flat map: one layer of 200 × 200 cells at 0.1 m
//! (±10 m), every point fed (hard gate, one layer), with the pipeline and the link.
#![no_std]
#![no_main]

use bench_firmware as b;
use static_cell::ConstStaticCell;
use terrain_pyramid::app::CoProcessor;
use terrain_pyramid::{Design, GateShape, Schedule, SensorModel, DEFAULT_CLASSIFIER_SLOTS};
use terrain_pyramid_bench::boot;

type Flat = CoProcessor<200, 1, DEFAULT_CLASSIFIER_SLOTS, 2048>;
static CORE: ConstStaticCell<Flat> = ConstStaticCell::new(Flat::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    // A design of exactly one layer at Δd = 0.1 m: a sensor model whose range (0.5 m) the
    // base layer already reaches. Hard gate; the only layer is the last, so its weight is 1 at
    // every distance (distances past 0.5 m fall in the last bin): every point feeds it.
    let sensor = SensorModel {
        max_range_m: 0.5,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    let design = Design::<1>::new(sensor, schedule, 200).ok();
    b::run(&mut b::booted_core(CORE.take(), design, boot))
}
