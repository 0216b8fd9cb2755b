//! The firmware on a NUCLEO-F446RE: the laser on USART1 (500 kBd, RS-422), the host link on
//! USART2 (the ST-LINK virtual COM port, 921 600 Bd), the AS5047P pan encoder on SPI1, both
//! USARTs received by interrupt into bounded queues, the independent watchdog fed from the main
//! loop, defmt over RTT. Wiring and bring-up: `README.md`.
//!
//! The main loop mirrors the QEMU board's: one [`App::pipeline`] call per step. For now the
//! step is a placeholder: it counts the laser's bytes, echoes the host's bytes back, and
//! reads the pan angle; once a second it logs the counters and the stack's high-water mark.
//! The real step (SICK telegrams → geometry → classifier → pyramid → link) replaces its body.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod clock;
mod encoder;
#[allow(unsafe_code)]
mod hw;
mod link;
mod rx;
mod scanner;

use defmt_rtt as _;
use panic_probe as _;

use embedded_hal_bus::spi::ExclusiveDevice;
use embedded_io::Write as _;
use heapless::spsc::Consumer;
use static_cell::ConstStaticCell;
use stm32f4xx_hal::dwt::MonoTimer;
use stm32f4xx_hal::gpio::{Output, Pin, PinState, Speed};
use stm32f4xx_hal::pac::{self, SPI1, USART2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::serial;
use stm32f4xx_hal::spi::Spi;
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use terrain_pyramid::drivers::angle::{Angle, AngleSource, EncoderMount};
use terrain_pyramid::drivers::as5047::{self, As5047};
use terrain_pyramid::pyramid::static_ram_bytes;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE,
    DEFAULT_LAYERS,
};

use crate::clock::Clock;
use crate::encoder::CsHighTime;
use crate::link::BlockingTx;
use crate::scanner::ScannerState;

/// The host link's baud rate (USART2, ST-LINK VCP). 45 MHz / 921 600 → divider 48.8 → −0.35 %.
const HOST_BAUD: u32 = 921_600;
/// The encoder's SPI clock: well below the AS5047P's 10 MHz, for jumper wires.
const ENCODER_SPI_HZ: u32 = 1_000_000;
/// The watchdog's timeout; the main loop feeds it every step.
const WATCHDOG_MS: u32 = 1_000;
/// How often the main loop logs its counters.
const REPORT_MS: u32 = 1_000;

/// The pyramid in a `static`, built at compile time (see the QEMU board's `main.rs`: never
/// on the stack, which a 73 KiB value would overflow on this 128 KiB part).
static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());

type EncoderSpi = CsHighTime<ExclusiveDevice<Spi<SPI1>, Pin<'B', 6, Output>, Clock>, Clock>;

/// Everything the main loop owns.
struct App {
    /// Not used by the placeholder step yet; the real pipeline integrates into it.
    #[allow(dead_code)]
    pyramid: &'static mut DefaultPyramid,
    laser_rx: Consumer<'static, u8>,
    host_rx: Consumer<'static, u8>,
    host_tx: BlockingTx<USART2>,
    encoder: As5047<EncoderSpi>,
    clock: Clock,
    scanner: ScannerState,
    last_report: stm32f4xx_hal::dwt::Instant,
    laser_bytes: u32,
    echoed: u32,
    angle: Option<Angle>,
    encoder_errors: u32,
}

impl App {
    /// One step of the main loop. Placeholder: count laser bytes, echo host bytes, read the
    /// pan angle; report once a second.
    fn pipeline(&mut self) {
        while self.laser_rx.dequeue().is_some() {
            self.laser_bytes = self.laser_bytes.wrapping_add(1);
        }
        let mut chunk = [0_u8; 32];
        let mut n = 0;
        while let Some(slot) = chunk.get_mut(n) {
            match self.host_rx.dequeue() {
                Some(byte) => {
                    *slot = byte;
                    n += 1;
                }
                None => break,
            }
        }
        if n > 0
            && self
                .host_tx
                .write_all(chunk.get(..n).unwrap_or(&[]))
                .is_ok()
        {
            self.echoed = self.echoed.wrapping_add(u32::try_from(n).unwrap_or(0));
        }
        match self.encoder.read_angle() {
            Ok(angle) => self.angle = Some(angle),
            Err(e) => {
                self.angle = None;
                self.encoder_errors = self.encoder_errors.saturating_add(1);
                if self.encoder_errors == 1 {
                    defmt::warn!("encoder: {}", e);
                }
            }
        }
        if self.clock.elapsed_ms(self.last_report) >= REPORT_MS {
            self.last_report = self.clock.now();
            let (stack_used, stack_size) = hw::stack_high_water();
            defmt::info!(
                "scanner {}: {=u32} bytes ({}); host: {=u32} echoed ({}); pan {}, {=u32} encoder errors; stack {=u32}/{=u32} bytes",
                self.scanner,
                self.laser_bytes,
                rx::laser_stats(),
                self.echoed,
                rx::host_stats(),
                self.angle,
                self.encoder_errors,
                stack_used,
                stack_size
            );
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::panic!("peripherals taken twice");
    };
    // 8 MHz from the ST-LINK's MCO (HSE bypass) → 180 MHz; APB1 45 MHz, APB2 90 MHz
    // (USART1: 90 MHz / 500 kBd = 180, exact).
    let mut rcc = dp.RCC.freeze(
        ClockConfig::hse(8.MHz())
            .bypass_hse_oscillator()
            .sysclk(180.MHz())
            .pclk1(45.MHz())
            .pclk2(90.MHz()),
    );
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());
    let clock = Clock::new(MonoTimer::new(cp.DWT, cp.DCB, &rcc.clocks));

    let pyramid = PYRAMID.take();
    configure(pyramid);
    watchdog.feed();

    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);

    // Host link: USART2 on PA2 (TX) / PA3 (RX), wired to the ST-LINK's virtual COM port.
    let host = match dp.USART2.serial(
        (gpioa.pa2, gpioa.pa3),
        serial::Config::default().baudrate(HOST_BAUD.bps()),
        &mut rcc,
    ) {
        Ok(s) => s,
        Err(_) => defmt::panic!("USART2 refused {=u32} Bd", HOST_BAUD),
    };
    let (host_tx, host_rx) = host.split();

    // Pan encoder: SPI1 on PA5 (SCK) / PA6 (MISO) / PA7 (MOSI), chip select PB6.
    let spi = Spi::new(
        dp.SPI1,
        (
            Some(gpioa.pa5.into_alternate().speed(Speed::VeryHigh)),
            Some(gpioa.pa6.into_alternate().speed(Speed::VeryHigh)),
            Some(gpioa.pa7.into_alternate().speed(Speed::VeryHigh)),
        ),
        as5047::MODE,
        ENCODER_SPI_HZ.Hz(),
        &mut rcc,
    );
    let cs = gpiob.pb6.into_push_pull_output_in_state(PinState::High);
    let Ok(device) = ExclusiveDevice::new(spi, cs, clock);
    let encoder = As5047::new(CsHighTime::new(device, clock), EncoderMount::IDENTITY)
        .with_diagnostics_check(true);

    // Laser: USART1 on PA9 (TX) / PA10 (RX) through the RS-422 transceiver, 9600 Bd at
    // power-on, then 500 kBd.
    let laser = match dp.USART1.serial(
        (gpioa.pa9, gpioa.pa10),
        serial::Config::default().baudrate(scanner::POWER_ON_BAUD.bps()),
        &mut rcc,
    ) {
        Ok(s) => s,
        Err(_) => defmt::panic!("USART1 refused 9600 Bd"),
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
    let (_laser_tx, laser_rx) = laser.split();

    let laser_rx = rx::install_laser(laser_rx);
    let host_rx = rx::install_host(host_rx);
    hw::unmask_usart_interrupts();

    let mut app = App {
        pyramid,
        laser_rx,
        host_rx,
        host_tx: BlockingTx::new(host_tx),
        encoder,
        clock,
        scanner: scanner_state,
        last_report: clock.now(),
        laser_bytes: 0,
        echoed: 0,
        angle: None,
        encoder_errors: 0,
    };
    defmt::info!("main loop");
    loop {
        watchdog.feed();
        app.pipeline();
    }
}

/// Configures the pyramid with the default design; a refused default is a build error in
/// all but name, so it panics (and the watchdog or probe-rs reports it).
fn configure(pyramid: &mut DefaultPyramid) {
    let design = match DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    ) {
        Ok(d) => d,
        Err(e) => defmt::panic!("default design refused: {}", e),
    };
    if let Err(e) = pyramid.configure(&design, &Config::default()) {
        defmt::panic!("default configuration refused: {}", e);
    }
    defmt::info!(
        "pyramid: {} ({=usize} bytes of static RAM)",
        design,
        static_ram_bytes::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS>()
    );
}
