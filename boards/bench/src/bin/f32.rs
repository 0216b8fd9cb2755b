//! The f32 counterpart (`terrain-pyramid-f32`) of the pipeline without the link
//! (`pyramid-nolink`): the default design's 8 layers of 64², f32 cells, f32 geometry and
//! classifier, under the configuration's rule (the default plane rule).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    bench_firmware::run_f32(None)
}
