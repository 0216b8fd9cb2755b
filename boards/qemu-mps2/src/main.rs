//! The firmware on QEMU's MPS2 AN386: the terrain pyramid's co-processor
//! ([`terrain_pyramid::app::CoProcessor`]), fed by the laser the host's Setup names (SICK
//! telegrams, or an LD06's, RPLIDAR's or YDLIDAR's packets) on UART0 and driven by the host
//! link (`docs/protocol.md`) on UART1.
//!
//! At boot the co-processor (in a `static`, all zero bits: `.bss`) adopts the default design
//! and a tilt-unit setup (a SICK) and checks its pyramid; Hello (reason boot) goes out at the
//! first poll. Each step of the main loop hands the core what UART0 and UART1 received, with
//! the microsecond clock of the laser bytes' arrival, polls it with SysTick's milliseconds and
//! drains its queue into UART1. When a Setup changes the sensor or its baud rate, UART0 is set
//! to that rate (which QEMU ignores). This board has no encoder and no servo: the host's
//! PanAngle, or a nodding servo's model run open loop (the Setup's actuator), is the angle.
//!
//! Time: microseconds from the FPGA block's prescaled counter ([`qemu_mps2::clock`]: QEMU
//! computes it from its virtual clock, which follows the host's wall clock without `-icount`,
//! so a loaded host loses it no time; DWT's cycle counter reads 0 in QEMU); the poll's
//! milliseconds from SysTick at 1 kHz.
//!
//! The run ends when the host sends Shutdown (0x89): the core answers it with Reply Ok (the
//! stack's high-water mark in `value`, its size in `a`, bytes), the queue is drained, the
//! counters and the stack are logged through defmt, and the emulator exits with success.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use embedded_io::{Read, ReadReady, Write};
use qemu_mps2::sizes;
use qemu_mps2::stack;
use qemu_mps2::uart::Uarts;
use static_cell::ConstStaticCell;
use terrain_pyramid::app::{BootError, CoProcessor, NoAngleSource, StackUsage};
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::{Config, Design, Schedule, SensorModel};

/// The co-processor of this build ([`sizes`]).
type Board = CoProcessor<{ sizes::CELLS }, { sizes::LAYERS }, { sizes::SLOTS }, { sizes::QUEUE }>;

/// The UARTs' baud rate at boot (the SICK LMS's fast mode is 500 kBd on real hardware; QEMU's
/// UARTs ignore the rate); UART0 follows the Setup's.
const BAUD: u32 = 500_000;

/// The processor clock of the MPS2 AN386, Hz: SysTick counts it.
const CPU_HZ: u32 = 25_000_000;

/// How long the main loop keeps polling after the last byte in or out before it sleeps, µs.
/// Within a stream the next byte comes in tens of microseconds (QEMU hands over the next one
/// when the last is read): waking from `wfi` for each one halves what the emulated board
/// takes in (`cargo xtask soak --quick`: 53 telegrams/s never sleeping, 28 sleeping between
/// any two bytes, 46 with 100 µs, 50 with 1 ms), while a board that spins between the bytes
/// of a slow stream contends with QEMU's I/O for the host's cores.
const AWAKE_AFTER_BYTES_US: u32 = 100;

/// The co-processor, `const`-built: never constructed on the stack, no `static mut`, no lock
/// (unlike a `Mutex<RefCell<…>>`), no run-time check but the one `take`; all zero bits, so it
/// lives in `.bss` and costs no flash.
static CORE: ConstStaticCell<Board> = ConstStaticCell::new(Board::new());

/// Milliseconds since SysTick started, wrapping.
static MILLIS: AtomicU32 = AtomicU32::new(0);

/// Microseconds since boot, wrapping every 2³² µs (71.6 minutes): [`qemu_mps2::clock`].
fn micros() -> u32 {
    qemu_mps2::clock::micros()
}

#[cortex_m_rt::exception]
fn SysTick() {
    // The handler is the only writer: a load and a store (ARMv6-M has no atomic add).
    MILLIS.store(
        MILLIS.load(Ordering::Relaxed).wrapping_add(1),
        Ordering::Relaxed,
    );
}

/// Why the firmware stopped early.
#[derive(Debug, defmt::Format)]
enum Fault {
    /// The boot design was refused or the self-check failed.
    Boot(BootError),
    /// The UARTs or the core peripherals were taken twice.
    Taken,
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let code = match run() {
        Ok(()) => qemu_mps2::EXIT_SUCCESS,
        Err(fault) => {
            defmt::error!("firmware stopped: {}", fault);
            qemu_mps2::EXIT_FAILURE
        }
    };
    let usage = stack::usage();
    defmt::info!(
        "stack: high-water {=u32} bytes; {=u32} bytes never touched of {=u32}",
        usage.used,
        usage.untouched,
        usage.size
    );
    qemu_mps2::exit(code)
}

fn run() -> Result<(), Fault> {
    let core = CORE.take();
    let design = Design::new(SensorModel::default(), Schedule::default(), sizes::CELLS)
        .map_err(|e| Fault::Boot(BootError::Design(e)))?;
    let setup = FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal);
    core.boot(sizes::LINK, &design, &Config::default(), setup)
        .map_err(Fault::Boot)?;
    defmt::info!("self-check passed");

    let mut peripherals = cortex_m::Peripherals::take().ok_or(Fault::Taken)?;
    let syst = &mut peripherals.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(CPU_HZ / 1000 - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    qemu_mps2::clock::start();

    let mut uarts = Uarts::take(BAUD).ok_or(Fault::Taken)?;
    uarts.wake_on_receive();
    let Uarts {
        uart0: mut laser,
        uart1: mut host,
    } = uarts;
    defmt::info!("running: the laser on UART0, the host link on UART1");
    let mut buf = [0_u8; 256];
    let mut last_bytes_at = micros();
    loop {
        let mut moved = false;
        if let Some(port) = core.take_laser_change() {
            laser.set_baud(port.baud);
            defmt::info!("laser: {} at {=u32} Bd", port.sensor, port.baud);
        }
        // No servo on this board: the command keeps the model's clock (open loop).
        let _ = core.actuator_command(micros());
        // The laser: everything UART0 holds (its only error is an overrun: bytes were lost).
        match laser.read_ready() {
            Ok(true) => match laser.read(&mut buf) {
                Ok(n) => {
                    moved = true;
                    core.laser(buf.get(..n).unwrap_or(&[]), micros(), &mut NoAngleSource);
                }
                Err(_) => core.laser_overrun(),
            },
            Ok(false) => {}
            Err(_) => core.laser_overrun(),
        }
        // The host's commands, carried out in order; a TimeRequest is answered with the
        // microseconds at which its bytes were read.
        if let Ok(true) = host.read_ready() {
            let n = host.read(&mut buf).unwrap_or(0);
            moved = true;
            core.host_at(buf.get(..n).unwrap_or(&[]), micros());
        }
        core.poll(MILLIS.load(Ordering::Relaxed));
        // Writing to UART1 cannot fail (no error but RX overrun exists on this UART).
        if core.drain(&mut host, usize::MAX).unwrap_or(0) > 0 {
            moved = true;
        }
        if core.shutdown_requested() {
            let usage = stack::usage();
            core.answer_shutdown(StackUsage {
                used: usage.used,
                size: usage.size,
            });
            let _ = core.drain(&mut host, usize::MAX);
            let _ = host.flush();
            defmt::info!("shutdown: {}", core.counters());
            return Ok(());
        }
        // No byte in or out for a while and both UARTs empty: sleep until a byte arrives (its
        // UART's receive interrupt) or SysTick's next millisecond (the link's polls), rather
        // than spin on the UARTs' registers (under QEMU a spinning core takes a whole host
        // core). A byte that arrives between this check and `wfi` waits for that millisecond
        // at most.
        let now = micros();
        if moved {
            last_bytes_at = now;
        } else if now.wrapping_sub(last_bytes_at) > AWAKE_AFTER_BYTES_US
            && !matches!(laser.read_ready(), Ok(true))
            && !matches!(host.read_ready(), Ok(true))
        {
            cortex_m::asm::wfi();
        }
    }
}
