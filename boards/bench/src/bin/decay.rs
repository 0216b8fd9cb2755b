//! The decay's sweep alone: every cell of the default pyramid observed (obstacle and free
//! evidence, clamped), then four steps of every layer (`Pyramid::decay` at 125 ms intervals,
//! τ = 1 s); the xtask divides the instructions by the cells decayed (rows × 64).
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid::{Evidence, EvidenceClass, Weight};

#[cortex_m_rt::entry]
fn main() -> ! {
    let config = b::shortest_decay_config();
    let pyramid = b::configured_default_pyramid(&config);
    for k in 0..8_u8 {
        for x in -32..32 {
            for y in -32..32 {
                let class = if (x + y) % 3 == 0 {
                    EvidenceClass::Obstacle
                } else {
                    EvidenceClass::Navigable
                };
                for _ in 0..6 {
                    pyramid.apply(&Evidence {
                        layer: k,
                        cell_x: x,
                        cell_y: y,
                        class,
                        weight: Weight::ONE,
                    });
                }
            }
        }
    }
    let times = core::hint::black_box([0_u32, 125, 250, 375, 500]);
    pyramid.decay(times[0]);
    let before = pyramid.stats().rows_decayed;
    let top = b::paint_stack();
    b::start();
    for &t in &times[1..] {
        pyramid.decay(t);
    }
    b::end();
    let stack = b::stack_used(top);
    let cells = (pyramid.stats().rows_decayed - before) * 64;
    b::report(0, 4, cells, stack)
}
