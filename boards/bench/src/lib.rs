//! The benchmark firmware's shared parts: the embedded recording, the two marker functions
//! between which `cargo xtask bench` counts executed instructions in QEMU's trace, the stack
//! high-water mark of the measured region, the report line and the panic handler.
//!
//! Each binary (`src/bin/`) configures its pipeline, paints the stack, calls
//! [`bench_start`], runs, calls [`bench_end`], and prints one line on the semihosting console:
//! `BENCH returns=… lines=… cells=… stack=…`, then exits with 0.
//!
//! The helpers that set a pipeline up and run it ([`booted_core`], [`run`], [`run_fixed`],
//! …) are always inlined: each binary's `main` stays the one function that holds the setup
//! and the measured region, as when each binary spelt them out, so that the measured stack
//! and instruction counts do not depend on where the setup is written.
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

/// The recording's frontend configuration (from its setup event), with its navigability rule
/// replaced by `rule` when given: the configuration of the binaries without the link.
#[inline(always)]
fn recording_frontend_config(
    recording: &[u8],
    rule: Option<terrain_pyramid::classify::NavigabilityRule>,
) -> terrain_pyramid::pipeline::FrontendConfig {
    use terrain_pyramid_bench::{frontend_config, setup};
    let Some(mut config) = setup(recording).as_ref().and_then(frontend_config) else {
        panic!("the recording has no usable setup");
    };
    if let Some(rule) = rule {
        config.classifier.rule = rule;
    }
    config
}

/// The default pipeline without the link, measured: the default pyramid (8 layers of 64²,
/// soft gate) fed by the per-line frontend, under the recording's configuration with its rule
/// replaced by `rule` when given. The `pyramid-nolink` and `pyramid-paper` binaries.
#[inline(always)]
pub fn run_fixed(rule: Option<terrain_pyramid::classify::NavigabilityRule>) -> ! {
    use static_cell::ConstStaticCell;
    use terrain_pyramid::wire::sick::SickAccumulator;
    use terrain_pyramid::{Config, DefaultFrontend, DefaultPyramid};
    use terrain_pyramid_bench::{default_design, Fixed};

    static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());
    static ACC: ConstStaticCell<SickAccumulator> = ConstStaticCell::new(SickAccumulator::new());
    static FRONTEND: ConstStaticCell<DefaultFrontend> =
        ConstStaticCell::new(DefaultFrontend::unconfigured());

    let rec = recording();
    let config = recording_frontend_config(rec, rule);
    let pyramid = PYRAMID.take();
    let design = design_or_panic(default_design::<64, 8>());
    let frontend = FRONTEND.take();
    frontend.configure(config);
    if pyramid.configure(&design, &Config::default()).is_err()
        || frontend.adopt_design(&design, &Config::default()).is_err()
    {
        panic!("configure");
    }
    let mut p = Fixed {
        accumulator: ACC.take(),
        frontend,
        pyramid,
    };
    run(&mut p)
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
    use terrain_pyramid_bench::{default_design, F32};

    static PYRAMID: ConstStaticCell<Pyramid<64, 8>> = ConstStaticCell::new(Pyramid::new());
    static ACC: ConstStaticCell<SickAccumulator> = ConstStaticCell::new(SickAccumulator::new());
    static FRONTEND: StaticCell<Frontend<1024>> = StaticCell::new();

    let rec = recording();
    let config = recording_frontend_config(rec, rule);
    let pyramid = PYRAMID.take();
    let design = design_or_panic(default_design::<64, 8>());
    if pyramid.configure(&design, &Config::default()).is_err() {
        panic!("configure");
    }
    let frontend = FRONTEND.init(Frontend::new(config));
    let mut p = F32 {
        accumulator: ACC.take(),
        frontend,
        pyramid,
    };
    run(&mut p)
}

/// Boots `core` on the recording under `design` with `boot` (one of `terrain_pyramid_bench`'s
/// `boot` functions), and pairs it with the recording's actuator angle: the pipeline of the
/// binaries with the link. Panics when the design is `None` or the boot fails.
#[inline(always)]
pub fn booted_core<'a, const W: usize, const L: usize, const C: usize, const Q: usize>(
    core: &'a mut terrain_pyramid::app::CoProcessor<W, L, C, Q>,
    design: Option<terrain_pyramid::Design<L>>,
    boot: impl FnOnce(
        &mut terrain_pyramid::app::CoProcessor<W, L, C, Q>,
        &[u8],
        &terrain_pyramid::Design<L>,
    ) -> bool,
) -> terrain_pyramid_bench::Core<'a, W, L, C, Q> {
    let design = design_or_panic(design);
    if !boot(core, recording(), &design) {
        panic!("boot");
    }
    terrain_pyramid_bench::Core {
        core,
        angle: terrain_pyramid::drivers::angle::HostSuppliedAngle::new(),
    }
}

/// The default pyramid (8 layers of 64², the default design) configured under `config`, for
/// the binaries that measure one of its sweeps alone (`decay`, `window`). Call it once.
#[inline(always)]
pub fn configured_default_pyramid(
    config: &terrain_pyramid::Config,
) -> &'static mut terrain_pyramid::DefaultPyramid {
    use static_cell::ConstStaticCell;
    use terrain_pyramid::{DefaultDesign, DefaultPyramid, Schedule, SensorModel};

    static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());

    let pyramid = PYRAMID.take();
    let Ok(design) = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        terrain_pyramid::DEFAULT_CELLS_PER_SIDE,
    ) else {
        panic!("default design");
    };
    if pyramid.configure(&design, config).is_err() {
        panic!("configure");
    }
    pyramid
}

/// The design a binary built, or a panic when it could not build one.
#[inline(always)]
pub fn design_or_panic<const L: usize>(
    design: Option<terrain_pyramid::Design<L>>,
) -> terrain_pyramid::Design<L> {
    let Some(design) = design else {
        panic!("design");
    };
    design
}

/// The default co-processor (8 layers of 64², the default pipeline and the host link), in a
/// static. Call it once.
#[inline(always)]
pub fn default_core() -> &'static mut terrain_pyramid::DefaultCoProcessor {
    use static_cell::ConstStaticCell;
    use terrain_pyramid::DefaultCoProcessor;

    static CORE: ConstStaticCell<DefaultCoProcessor> =
        ConstStaticCell::new(DefaultCoProcessor::new());
    CORE.take()
}

/// Runs the whole recording through `pipeline` between the markers ([`measure`]) and reports
/// its returns and lines (no cells): the end of every binary that measures a pipeline.
#[inline(always)]
pub fn run<P: terrain_pyramid_bench::Pipeline>(pipeline: &mut P) -> ! {
    let stack = measure(recording(), pipeline);
    report(pipeline.returns(), pipeline.lines(), 0, stack)
}

/// The decay at its most expensive: all evidence, every layer at the shortest time constant
/// its sweep's budget allows (τ = 1 s, a step every 125 ms), the rest of the default
/// configuration. The `decay` and `pyramid-decay` binaries.
#[must_use]
#[inline(always)]
pub fn shortest_decay_config() -> terrain_pyramid::Config {
    use terrain_pyramid::{Config, Decay, DecayMode, TimeConstant};
    Config {
        decay: Decay::uniform(DecayMode::All, TimeConstant::MIN, 8),
        ..Config::default()
    }
}
