//! The firmware on QEMU's `microbit` (nRF51822: Cortex-M0 at 16 MHz, 16 KiB of RAM): the
//! terrain pyramid's co-processor ([`terrain_pyramid::app::CoProcessor`]) in a small
//! configuration ([`Board`]), on the part's one UART.
//!
//! **One UART, two streams** (`README.md`, "One UART"): the robot's main computer writes the
//! laser's SICK telegrams onto the line whole, between its own host-link frames; the firmware
//! splits the line at frame boundaries ([`terrain_pyramid::wire::shared_line`]: an STX starts
//! a telegram, anything else is a link frame up to its `0x00`) and hands each piece to the
//! core's laser or host side. The UART's transmit side carries the link's frames alone.
//!
//! At boot the co-processor (in a `static`, all zero bits: `.bss`) adopts a design of four
//! 16-cell layers ([`boot_design`]) and a tilt-unit setup and checks its pyramid; Hello
//! (reason boot) goes out at the first poll. Each step of the main loop takes what the UART
//! holds, polls the core with TIMER0's milliseconds ([`microbit_board::timer`]) and drains its
//! queue into the UART. This board has no angle source: the host's PanAngle is the actuator
//! angle. Shutdown (0x89) is answered with the stack's high-water mark, the counters are
//! logged (defmt over semihosting) and the emulator exits with 0.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use embedded_io::{Read, ReadReady};
use microbit_board::stack;
use microbit_board::timer::Clock;
use microbit_board::uart::{Baud, Uart};
use static_cell::ConstStaticCell;
use terrain_pyramid::app::{BootError, CoProcessor, NoAngleSource, StackUsage};
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::ClockSource;
use terrain_pyramid::wire::shared_line::{Route, SharedLine};
use terrain_pyramid::{Config, Design, Schedule, SensorModel};

/// W, cells per side of every layer's window.
pub const CELLS: usize = 16;
/// The pyramid's layers, at most.
pub const LAYERS: usize = 4;
/// Classifier slots: distinct cells one observation can touch before the classifier counts
/// overflows. 32 (512 B): the library is built without the plane rule (`plane-rule` off), so
/// a slot is 16 bytes; with the plane rule's 48-byte slots only 16 fitted beside the stack.
/// 64 (1 KiB, the value before the plane rule) leave the statics 12 636 B and the stack
/// 3 748 B, under the ~3.8 KiB the deepest path (a host command that queues Hello) takes:
/// the firmware locked up on the first frames. 16 (256 B) since protocol 4 and the pose
/// track: its deepest stack measured 4 120 B, and 32 slots left 188 B less than the 256 B
/// margin `boards/check.sh` keeps of the 16 KiB.
pub const SLOTS: usize = 16;
/// The link's outgoing queue, bytes (at least `min_queue_bytes(16, 4)` = 384; a Stats frame
/// of 154 bytes goes out beside the 246 bytes left of it, `Link::STATS_RESERVE`). 400, not 512 as before the track of stamped
/// poses: the 112 bytes pay for the track and its counters (+120 B of statics with
/// `POSES = 2`) and a stack high-water 32 B above the last recorded (3 944 B against
/// 3 912 B), the statics and stack having had 44 B to spare.
pub const QUEUE: usize = 400;
/// The track of stamped poses, poses (28 bytes each): 2, the last two (40 ms at 50 Hz), not
/// the library's 16, which would not fit.
pub const POSES: usize = 2;

/// The co-processor of this board.
pub type Board = CoProcessor<CELLS, LAYERS, SLOTS, QUEUE, POSES>;

/// The co-processor, `const`-built: never on the stack, all zero bits, in `.bss`.
static CORE: ConstStaticCell<Board> = ConstStaticCell::new(Board::new());

/// Bytes taken from the UART per step, at most.
const CHUNK: usize = 64;

/// The boot design: four layers of 16 cells, 4 m of range, γ = 3, the rest the defaults
/// (the host sends Configure with its own before any line).
fn boot_design() -> Result<Design<LAYERS>, terrain_pyramid::DesignError> {
    let sensor = SensorModel {
        max_range_m: 4.0,
        height_m: 0.4,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gamma: 3.0,
        ..Schedule::default()
    };
    Design::new(sensor, schedule, CELLS)
}

/// Boots the core in a frame of its own: the configuration's tables are built on the stack,
/// which on 16 KiB must not hold the main loop's buffers at the same time.
#[inline(never)]
fn boot(core: &mut Board, crystal: bool) -> Result<(), BootError> {
    let design = boot_design()?;
    let setup = FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal);
    // Hello tells the host whether the 16 MHz crystal started or the RC oscillator stands in.
    let clock = if crystal {
        ClockSource::External
    } else {
        ClockSource::Internal
    };
    let link = LinkConfig {
        clock,
        ..LinkConfig::DEFAULT
    };
    core.boot(link, &design, &Config::default(), setup)
}

// The core's entry points, each in a frame of its own: inlined into the main loop together,
// their locals would add up to one frame of 2 KiB; apart, the deepest one counts.

/// Laser bytes (one piece of a telegram) to the core, received at `now_us` (µs, wrapping).
#[inline(never)]
fn laser(core: &mut Board, bytes: &[u8], now_us: u32) {
    core.laser(bytes, now_us, &mut NoAngleSource);
}

/// Host bytes (one piece of a link frame) to the core, received at `now_us` (µs, wrapping):
/// a TimeRequest they complete is answered with that time.
#[inline(never)]
fn host(core: &mut Board, bytes: &[u8], now_us: u32) {
    core.host_at(bytes, now_us);
}

/// Polls the core and drains its queue into the UART.
#[inline(never)]
fn poll(core: &mut Board, now_ms: u32, uart: &mut Uart) {
    core.poll(now_ms);
    // The UART's write never fails.
    let _ = core.drain(uart, usize::MAX);
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(mut uart) = Uart::take(Baud::B115200) else {
        defmt::panic!("UART taken twice");
    };
    let mut clock = Clock::start();
    let core = CORE.take();
    if let Err(e) = boot(core, clock.crystal) {
        defmt::error!("boot: {}", e);
        microbit_board::exit(microbit_board::EXIT_FAILURE);
    }
    let usage = stack::usage();
    defmt::info!(
        "co-processor <{=usize}, {=usize}, {=usize}, {=usize}>: {=usize} B (pyramid {=usize}, pipeline {=usize}, link {=usize}); boot stack {=u32} B of {=u32}; crystal {=bool}",
        CELLS,
        LAYERS,
        SLOTS,
        QUEUE,
        core::mem::size_of::<Board>(),
        core::mem::size_of_val(core.pyramid()),
        core::mem::size_of_val(core.frontend()),
        core::mem::size_of_val(core.link()),
        usage.used,
        usage.size,
        clock.crystal
    );
    let mut line = SharedLine::new();
    let mut buf = [0_u8; CHUNK];
    loop {
        // What the UART holds, split into telegram and frame pieces.
        if let Ok(true) = uart.read_ready() {
            match uart.read(&mut buf) {
                Ok(n) => {
                    // The low 32 bits: the wrapping microseconds the core expects.
                    #[allow(clippy::cast_possible_truncation)]
                    let now_us = clock.micros() as u32;
                    let mut rest = buf.get(..n).unwrap_or(&[]);
                    while let Some((route, piece, next)) = line.split(rest) {
                        match route {
                            Route::Laser => laser(core, piece, now_us),
                            Route::Host => host(core, piece, now_us),
                        }
                        rest = next;
                    }
                }
                Err(_) => core.laser_overrun(),
            }
        }
        poll(core, clock.millis(), &mut uart);
        if core.shutdown_requested() {
            let usage = stack::usage();
            core.answer_shutdown(StackUsage {
                used: usage.used,
                size: usage.size,
            });
            let _ = core.drain(&mut uart, usize::MAX);
            defmt::info!("shutdown: {}; line {}", core.counters(), line.counters());
            defmt::info!(
                "stack: high-water {=u32} bytes of {=u32} ({=u32} never touched)",
                usage.used,
                usage.size,
                usage.untouched
            );
            microbit_board::exit(microbit_board::EXIT_SUCCESS);
        }
    }
}
