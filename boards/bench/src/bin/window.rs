//! Window moves of the default pyramid: the robot moves in 0.1 m steps (64 along +x, 64 along
//! +y, 32 diagonally back), each step a `recentre`; the xtask divides the instructions by the
//! cells reset (the pyramid's own count).
#![no_std]
#![no_main]

use bench_firmware as b;
use terrain_pyramid::{Config, Meters};

#[cortex_m_rt::entry]
fn main() -> ! {
    let pyramid = b::configured_default_pyramid(&Config::default());
    let step = Meters::from_bits(6554); // 0.1 m
    let mut path = [(Meters::ZERO, Meters::ZERO); 160];
    let (mut x, mut y) = (Meters::ZERO, Meters::ZERO);
    for (i, p) in path.iter_mut().enumerate() {
        match i {
            0..64 => x += step,
            64..128 => y += step,
            _ => {
                x -= step;
                y -= step;
            }
        }
        *p = (x, y);
    }
    let path = core::hint::black_box(path);
    pyramid.recentre(Meters::ZERO, Meters::ZERO);
    let before = pyramid.stats().cells_reset;
    let top = b::paint_stack();
    b::start();
    for &(x, y) in &path {
        pyramid.recentre(x, y);
    }
    b::end();
    let stack = b::stack_used(top);
    let cells = pyramid.stats().cells_reset - before;
    b::report(0, 160, cells, stack)
}
