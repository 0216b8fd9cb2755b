//! The firmware on a NUCLEO-F446RE: the terrain pyramid's co-processor
//! ([`terrain_pyramid::app::CoProcessor`]). The laser on USART1 (the one the host's Setup
//! names: a SICK LMS2xx at 500 kBd over RS-422, or an LD06, RPLIDAR or YDLIDAR at its own rate,
//! [`laser`]), the host link (`docs/protocol.md`) on USART2 (the ST-LINK virtual COM port,
//! 921 600 Bd), the AS5047P encoder on SPI1, a nodding servo's PWM on TIM2 channel 1 (PA0),
//! both USARTs received by interrupt into bounded queues ([`rx`]), the independent watchdog
//! fed from the main loop, defmt over RTT (over semihosting on QEMU's `netduinoplus2`:
//! [`logging`]). Wiring, bring-up and the emulated run: `README.md`.
//!
//! At boot the clocks start with bounded waits and fallbacks ([`rcc`]; the source is logged
//! and reported in Hello), SysTick counts milliseconds ([`clock`]), and the
//! co-processor (in a `static`, all zero bits: `.bss`) adopts the default design
//! and a panned-vertical setup and checks its pyramid; the scanner is brought up
//! ([`scanner`]); Hello (reason boot) goes out at the first poll. Each step of the main loop
//! feeds the watchdog, sets USART1 up when the core asks ([`laser::switch`]), commands the
//! servo when the setup has one, hands the core the bytes the two interrupts queued (the
//! laser's with the microsecond time its interrupt queued their last byte; the encoder is
//! read as a telegram or packet completes, and when it errs the servo's model or the host's
//! PanAngle stands in), polls it with SysTick's milliseconds and sends at most
//! [`TX_BYTES_PER_STEP`] of its queue. Once a second
//! the counters and the stack's high-water mark are logged. Shutdown (0x89) is answered with
//! the stack's figures, the queue drained, and the firmware parks (feeding the watchdog).
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod clock;
mod encoder;
#[allow(unsafe_code)]
mod hw;
mod laser;
mod link;
mod logging;
mod rcc;
mod rx;
mod scanner;

use embedded_io::Write as _;
use static_cell::ConstStaticCell;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::serial;
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use terrain_pyramid::app::{BootError, CoProcessor, StackUsage};
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::{
    Config, DefaultDesign, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS,
    DEFAULT_LAYERS,
};

use crate::link::BlockingTx;

/// The host link's baud rate (USART2, ST-LINK VCP). 45 MHz / 921 600 → divider 48.8 → −0.35 %.
const HOST_BAUD: u32 = 921_600;
/// The watchdog's timeout; the main loop feeds it every step.
const WATCHDOG_MS: u32 = 1_000;
/// How often the main loop logs its counters.
const REPORT_MS: u32 = 1_000;
/// Link bytes sent per main-loop step, at most: USART2 transmits blocking (5.6 ms for 512
/// bytes at 921 600 Bd), and the laser queue (1023 bytes: 20 ms) must not fill meanwhile.
const TX_BYTES_PER_STEP: usize = 512;

/// The classifier's observation scratch: half the default. A slot is 60 bytes with the plane
/// rule (the default 1024 would take 60 KiB, and the part's 128 KiB could not hold it beside
/// the pyramid); 512 slots hold an observation of a few SICK lines (a line touches 2-4 cells
/// per return at most, mostly far fewer), and a point that finds the scratch full is counted
/// (`overflow_points`), never misplaced. 256 would bring the statics under the 96 KiB goal
/// (94 448 B) but more than double the dropped additions of the 3DTK sweep (104 674 against
/// 43 933; README.md, "Memory").
const CLASSIFIER_SLOTS: usize = DEFAULT_CLASSIFIER_SLOTS / 2;

/// The co-processor: the default pyramid, the pipeline with [`CLASSIFIER_SLOTS`] and a link with
/// a 1 KiB queue (11 ms of USART2; at least `min_queue_bytes(64, 8)` = 504 bytes).
type Board = CoProcessor<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, CLASSIFIER_SLOTS, 1024>;

/// The co-processor, `const`-built (never on the stack of this 128 KiB part).
static CORE: ConstStaticCell<Board> = ConstStaticCell::new(Board::new());

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::panic!("peripherals taken twice");
    };
    // 8 MHz from the ST-LINK's MCO (HSE bypass) → 180 MHz; APB1 45 MHz, APB2 90 MHz
    // (USART1: 90 MHz / 500 kBd = 180, exact); falls back to the HSI (`rcc.rs`).
    let (mut rcc, clocks) = rcc::start(dp.RCC);
    defmt::info!("clocks: {}", clocks);
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());
    // SysTick: 1 kHz from the core clock, the link's milliseconds.
    let clock = clock::start(cp.SYST, clocks.core_hz);

    let core = CORE.take();
    let setup = FrontendConfig::lms291_boot(ScanPlane::PannedVertical);
    // Hello tells the host which clock the board runs on (a fallback costs ±1 %).
    let link = LinkConfig {
        clock: clocks.source.reported(),
        ..LinkConfig::DEFAULT
    };
    let booted = DefaultDesign::new(SensorModel::default(), Schedule::default(), 64)
        .map_err(BootError::Design)
        .and_then(|design| core.boot(link, &design, &Config::default(), setup));
    if let Err(e) = booted {
        defmt::panic!("boot: {}", e);
    }
    watchdog.feed();

    let pclk2_hz = rcc.clocks.pclk2().raw();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    // Host link: USART2 on PA2 (TX) / PA3 (RX), wired to the ST-LINK's virtual COM port.
    let Ok(host) = dp.USART2.serial(
        (gpioa.pa2, gpioa.pa3),
        serial::Config::default().baudrate(HOST_BAUD.bps()),
        &mut rcc,
    ) else {
        defmt::panic!("USART2 refused {=u32} Bd", HOST_BAUD);
    };
    let (host_tx, host_rx) = host.split();
    let mut host_tx = BlockingTx::new(host_tx);
    let pins = (gpioa.pa5, gpioa.pa6, gpioa.pa7, gpiob.pb6);
    let mut encoder = encoder::connect(dp.SPI1, pins, clock, &mut rcc);
    // Laser: USART1 on PA9 (TX) / PA10 (RX) through the RS-422 transceiver, 9600 Bd at
    // power-on, then 500 kBd.
    let Ok(laser) = dp.USART1.serial(
        (gpioa.pa9, gpioa.pa10),
        serial::Config::default().baudrate(scanner::POWER_ON_BAUD.bps()),
        &mut rcc,
    ) else {
        defmt::panic!("USART1 refused 9600 Bd");
    };
    let mut ctx = scanner::Context {
        rcc: &mut rcc,
        clock,
        watchdog: &mut watchdog,
    };
    let (laser, scanner_state) = match scanner::bring_up(laser, &mut ctx) {
        Ok(done) => done,
        Err(e) => defmt::panic!("scanner bring-up: {}", e),
    };
    let (laser_tx, laser_rx) = laser.split();
    let laser_rx = rx::install_laser(laser_rx);
    let mut laser_side = laser::LaserSide::new(BlockingTx::new(laser_tx), laser_rx, pclk2_hz);
    // The nodding servo's signal: TIM2 channel 1 on PA0, 50 Hz (idle until a Setup names one).
    let mut servo = laser::servo(dp.TIM2, gpioa.pa0, &mut rcc);
    let mut host_rx = rx::install_host(host_rx);
    hw::unmask_usart_interrupts();

    defmt::info!("main loop: the laser on USART1, the host link on USART2");
    let mut buf = [0_u8; 256];
    let mut last_report = clock.now();
    loop {
        watchdog.feed();
        if let Some(angle) = core.actuator_command(clock::micros()) {
            // TIM2's channel cannot fail (its error type is `Infallible`).
            let _ = servo.set_angle(angle);
        }
        laser_side.step(core, &mut buf, &mut encoder);
        let n = rx::take(&mut host_rx, buf.get_mut(..64).unwrap_or(&mut []));
        // Timed when the main loop takes them (a TimeRequest's device time): the interrupt
        // queued them at most one loop step earlier.
        core.host_at(buf.get(..n).unwrap_or(&[]), clock::micros());
        core.poll(clock::millis());
        if let Err(e) = core.drain(&mut host_tx, TX_BYTES_PER_STEP) {
            defmt::warn!("USART2: {}", defmt::Debug2Format(&e));
        }
        if clock.elapsed_ms(last_report) >= REPORT_MS {
            last_report = clock.now();
            let (used, size) = hw::stack_high_water();
            defmt::info!(
                "scanner {}: {}; laser rx {}, host rx {}; stack {=u32}/{=u32} bytes",
                scanner_state,
                core.counters(),
                rx::laser_stats(),
                rx::host_stats(),
                used,
                size
            );
        }
        if core.shutdown_requested() {
            let (used, size) = hw::stack_high_water();
            core.answer_shutdown(StackUsage { used, size });
            let _ = core.drain(&mut host_tx, usize::MAX);
            let _ = host_tx.flush();
            defmt::info!(
                "shutdown: {}; clock source {}",
                core.counters(),
                clocks.source
            );
            break;
        }
    }
    defmt::info!("stopped (Shutdown): parked until reset");
    logging::stopped();
    loop {
        watchdog.feed();
        cortex_m::asm::wfi();
    }
}
