//! The benchmark firmware's shared parts: the embedded recording, the two marker functions
//! between which `cargo xtask bench` counts executed instructions in QEMU's trace, the stack
//! high-water mark of the measured region, the report line and the panic handler.
//!
//! Each binary (`src/bin/`) configures its pipeline, paints the stack, calls
//! [`bench_start`], runs, calls [`bench_end`], and prints one line on the semihosting console:
//! `BENCH returns=… lines=… cells=… stack=…`, then exits with 0.
#![no_std]
#![deny(missing_docs)]

use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicU8, Ordering};

/// The recording `cargo xtask bench` generated (`BENCH_RECORDING`), in flash. A named
/// symbol, so that the xtask can subtract its size from the image's.
#[no_mangle]
#[used]
pub static BENCH_RECORDING: [u8; include_bytes!(env!("BENCH_RECORDING")).len()] =
    *include_bytes!(env!("BENCH_RECORDING"));

/// The recording as a slice (read through a volatile pointer so that nothing is folded at
/// compile time).
#[must_use]
pub fn recording() -> &'static [u8] {
    let p = core::hint::black_box(&BENCH_RECORDING);
    p.as_slice()
}

/// The start marker: the xtask counts the instructions executed from this function's first
/// instruction up to (not including) [`bench_end`]'s.
#[inline(never)]
#[no_mangle]
#[allow(unsafe_code)]
extern "C" fn bench_start() {
    PHASE.store(1, Ordering::SeqCst);
    // SAFETY: a no-op; it keeps the two markers' bodies distinct (no identical-code folding).
    unsafe { core::arch::asm!("nop", options(nomem, nostack, preserves_flags)) };
}

/// The end marker.
#[inline(never)]
#[no_mangle]
#[allow(unsafe_code)]
extern "C" fn bench_end() {
    PHASE.store(2, Ordering::SeqCst);
    // SAFETY: as in `bench_start`.
    unsafe { core::arch::asm!("nop", "nop", options(nomem, nostack, preserves_flags)) };
}

/// Calls [`bench_start`] through an opaque pointer, so that it is never inlined away.
pub fn start() {
    core::hint::black_box(bench_start as extern "C" fn())();
}

/// Calls [`bench_end`] through an opaque pointer.
pub fn end() {
    core::hint::black_box(bench_end as extern "C" fn())();
}

/// Where the run is: 1 between the markers, 2 after. Distinct bodies keep the two marker
/// functions from being merged into one address.
static PHASE: AtomicU8 = AtomicU8::new(0);

/// The paint of the measured stack region.
const PAINT: u32 = 0xDEAD_BEEF;
/// How far below the caller's frame the stack is painted and measured, bytes.
pub const PAINTED: usize = 64 * 1024;

fn sp() -> usize {
    cortex_m::register::msp::read() as usize
}

/// Paints `PAINTED` bytes below the current stack pointer (minus a little slack), and
/// returns the painted region's top.
#[inline(never)]
#[allow(unsafe_code)]
pub fn paint_stack() -> usize {
    let top = (sp() - 256) & !3;
    let mut a = top - PAINTED;
    while a < top {
        // SAFETY: word-aligned RAM below the current stack pointer (minus slack), which no
        // live object occupies; the stack region is megabytes deep in QEMU's map.
        unsafe { write_volatile(a as *mut u32, PAINT) };
        a += 4;
    }
    top
}

/// The bytes of the painted region used since [`paint_stack`] returned `top`.
#[inline(never)]
#[allow(unsafe_code)]
#[must_use]
pub fn stack_used(top: usize) -> usize {
    let mut a = top - PAINTED;
    while a < top {
        // SAFETY: as in `paint_stack`; the region lies below the current stack pointer.
        if unsafe { read_volatile(a as *const u32) } != PAINT {
            break;
        }
        a += 4;
    }
    top - a
}

/// Paints the stack, runs the whole of `recording` through `pipeline` between the two
/// markers, and returns the bytes of stack the run used: the measured part of every binary.
pub fn measure<P: terrain_pyramid_bench::Pipeline>(recording: &[u8], pipeline: &mut P) -> usize {
    let top = paint_stack();
    start();
    terrain_pyramid_bench::replay(recording, pipeline);
    end();
    stack_used(top)
}

/// Prints the report line and exits with 0.
pub fn report(returns: u32, lines: u32, cells: u32, stack: usize) -> ! {
    semihosting::println!(
        "BENCH returns={} lines={} cells={} stack={}",
        returns,
        lines,
        cells,
        stack
    );
    semihosting::process::exit(0)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    if let Some(l) = info.location() {
        semihosting::eprintln!("panicked at {}:{}", l.file(), l.line());
    }
    semihosting::process::exit(101)
}

/// The f32 counterpart (`terrain-pyramid-f32`) of the pipeline without the link, measured:
/// the default design's 8 layers of 64², f32 cells, f32 geometry and classifier, 1 024 slots,
/// under the recording's configuration with its rule replaced by `rule` when given. The
/// `f32` and `f32-paper` binaries.
pub fn run_f32(rule: Option<terrain_pyramid::classify::NavigabilityRule>) -> ! {
    use static_cell::{ConstStaticCell, StaticCell};
    use terrain_pyramid::wire::sick::SickAccumulator;
    use terrain_pyramid::Config;
    use terrain_pyramid_bench::f32_pipeline::{Frontend, Pyramid};
    use terrain_pyramid_bench::{default_design, frontend_config, setup, Pipeline, F32};

    static PYRAMID: ConstStaticCell<Pyramid<64, 8>> = ConstStaticCell::new(Pyramid::new());
    static ACC: ConstStaticCell<SickAccumulator> = ConstStaticCell::new(SickAccumulator::new());
    static FRONTEND: StaticCell<Frontend<1024>> = StaticCell::new();

    let rec = recording();
    let Some(mut config) = setup(rec).as_ref().and_then(frontend_config) else {
        panic!("the recording has no usable setup");
    };
    if let Some(rule) = rule {
        config.classifier.rule = rule;
    }
    let pyramid = PYRAMID.take();
    let Some(design) = default_design::<64, 8>() else {
        panic!("default design");
    };
    if pyramid.configure(&design, &Config::default()).is_err() {
        panic!("configure");
    }
    let frontend = FRONTEND.init(Frontend::new(config));
    let mut p = F32 {
        accumulator: ACC.take(),
        frontend,
        pyramid,
    };
    let stack = measure(rec, &mut p);
    report(p.returns(), p.lines(), 0, stack)
}
