//! The default pyramid (8 × 64², soft gate) with the default pipeline, without the link (for the f32 comparison).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    bench_firmware::run_fixed(None)
}
