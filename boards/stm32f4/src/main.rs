//! The firmware on a NUCLEO-F446RE: the terrain pyramid's co-processor. The laser on USART1
//! (500 kBd, RS-422), the host link (`docs/protocol.md`) on USART2 (the ST-LINK virtual COM
//! port, 921 600 Bd), the AS5047P pan encoder on SPI1, both USARTs received by interrupt into
//! bounded queues, the independent watchdog fed from the main loop, defmt over RTT. Wiring and
//! bring-up: `README.md`.
//!
//! At boot: the default pyramid configured with the default design, the pipeline
//! (`DefaultFrontend`) configured in place for a panned vertical LMS, the link told the design
//! (Hello, reason boot, at the first poll), SysTick started at 1 kHz, the scanner brought up.
//! The pyramid, the pipeline and the link live in `ConstStaticCell`s (all zero bits: `.bss`,
//! never on the stack). Each step of the main loop, as on the QEMU board:
//!
//! 1. Laser: the bytes the USART1 interrupt queued go through the SICK accumulator
//!    (`drivers::uart::SickUart` over [`LaserQueue`]); each measured-values telegram is parsed
//!    (`MeasuredValues::parse`), the pan angle read from the AS5047P (falling back to the
//!    host's last PanAngle when the encoder errs; a line with neither is dropped) and the line
//!    fed to the pipeline (`Frontend::line`).
//! 2. Host: the bytes the USART2 interrupt queued go to `Link::receive` one at a time, so
//!    every command is carried out in order (Pose, PanAngle, Setup, Configure, Reset,
//!    EndObservation, Shutdown).
//! 3. `Link::poll` with SysTick's milliseconds and the SICK and classifier counters; the
//!    link's queue drains into USART2 ([`BlockingTx`]).
//!
//! The watchdog is fed every step; once a second the counters and the stack's high-water mark
//! are logged. Shutdown (0x89) is answered with Reply Ok (the stack's high-water mark in
//! `value`, its size in `a`), the queue drained and the counters logged; the firmware then
//! parks (feeding the watchdog) until reset.
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

use core::convert::Infallible;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
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
use terrain_pyramid::angle::Angle;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::drivers::angle::{AngleSource, EncoderMount, HostSuppliedAngle};
use terrain_pyramid::drivers::as5047::{self, As5047};
use terrain_pyramid::drivers::uart::{Event as SickEvent, SickUart};
use terrain_pyramid::geometry::{Mount, Pose, ScanPlane};
use terrain_pyramid::link::{Event, Link, LinkConfig, SensorCounters};
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::pyramid::static_ram_bytes;
use terrain_pyramid::wire::link::{Header, Reply};
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::wire::sick::{MeasuredValues, MeasuringMode};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultFrontend, DefaultPyramid, Meters, Point3, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS,
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
/// SICK accumulator polls per main-loop step before the host link gets its turn.
const LASER_POLLS_PER_STEP: u32 = 4096;
/// Host bytes handed to the link per main-loop step.
const HOST_BYTES_PER_STEP: usize = 64;
/// Link bytes sent per main-loop step, at most: USART2 transmits blocking (5.6 ms for 512
/// bytes at 921 600 Bd), the laser queue must not fill meanwhile (1023 bytes: 20 ms).
const TX_BYTES_PER_STEP: usize = 512;

/// The pyramid in a `static`, built at compile time (see the QEMU board's `main.rs`: never
/// on the stack, which a 73 KiB value would overflow on this 128 KiB part).
static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());

/// The host link (queue, bucket, tile ages), `const`-built like the pyramid.
static LINK: ConstStaticCell<BoardLink> = ConstStaticCell::new(Link::new(LinkConfig::DEFAULT));

/// The link with a 1 KiB frame queue (11 ms of USART2 at 921 600 Bd; at least
/// `min_queue_bytes(64, 8)` = 504 bytes: the largest tile beside the control reserve). Half the
/// QEMU board's: with the laser's and the host's receive queues and the RTT buffer, 2 KiB
/// would take the static RAM past 96 KiB. Tiles that do not fit wait, dirty, for a later poll.
type BoardLink = Link<1024>;

/// The per-line pipeline (the classifier's slots and the beam table), `const`-built
/// unconfigured (all zero bits: `.bss`) and configured in place at boot.
static FRONTEND: ConstStaticCell<DefaultFrontend> =
    ConstStaticCell::new(DefaultFrontend::unconfigured());

/// Milliseconds since SysTick started, wrapping.
static MILLIS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    MILLIS.fetch_add(1, Ordering::Relaxed);
}

type EncoderSpi = CsHighTime<ExclusiveDevice<Spi<SPI1>, Pin<'B', 6, Output>, Clock>, Clock>;

/// The pipeline's configuration until the host sends Setup: a SICK LMS 291 at 180°/0.5° in
/// the 8 m mode, its scan plane vertical and panned (the AS5047P reads the pan), 0.5 m up,
/// one observation per sweep.
fn boot_frontend_config() -> FrontendConfig {
    FrontendConfig {
        mount: Mount::new(
            ScanPlane::PannedVertical,
            Point3 {
                x: Meters::ZERO,
                y: Meters::ZERO,
                z: Meters::from_num(0.5),
            },
        ),
        variant: Variant::Fov180StepHalf,
        measuring_mode: MeasuringMode::Mm8Cm80,
        lines_per_observation: 0,
        classifier: ClassifierConfig::default(),
        missing_ground_within: None,
    }
}

/// The laser's receive queue as a stream that never blocks: `read` returns 0 (for
/// `SickUart`: "nothing now") when the interrupt has queued nothing.
struct LaserQueue(Consumer<'static, u8>);

impl embedded_io::ErrorType for LaserQueue {
    type Error = Infallible;
}

impl embedded_io::Read for LaserQueue {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        for slot in buf.iter_mut() {
            match self.0.dequeue() {
                Some(byte) => {
                    *slot = byte;
                    n += 1;
                }
                None => break,
            }
        }
        Ok(n)
    }
}

/// The firmware's own counters.
#[derive(Debug, Default, Clone, Copy, defmt::Format)]
struct Counters {
    /// Telegrams whose payload was not a measured-values telegram (or did not parse).
    telegrams_unparsed: u32,
    /// Lines the pipeline refused (a count that does not fit the variant).
    lines_rejected: u32,
    /// Lines applied.
    lines_applied: u32,
    /// Lines dropped: the encoder erred and the host has sent no pan angle.
    lines_without_angle: u32,
    /// Encoder readings that failed (the host's pan angle stood in, if any).
    encoder_errors: u32,
    /// Poses the geometry refused.
    poses_refused: u32,
    /// Main-loop steps.
    steps: u32,
}

/// Everything the main loop owns.
struct App {
    pyramid: &'static mut DefaultPyramid,
    frontend: &'static mut DefaultFrontend,
    link: &'static mut BoardLink,
    laser: SickUart<LaserQueue>,
    host_rx: Consumer<'static, u8>,
    host_tx: BlockingTx<USART2>,
    encoder: As5047<EncoderSpi>,
    /// The host's last PanAngle: the fallback when the encoder errs.
    host_pan: HostSuppliedAngle,
    clock: Clock,
    scanner: ScannerState,
    last_report: stm32f4xx_hal::dwt::Instant,
    /// The last pan angle a line used.
    angle: Option<Angle>,
    counters: Counters,
}

impl App {
    /// One step of the main loop. Returns the Shutdown's header when the host asked the
    /// firmware to stop.
    fn pipeline(&mut self) -> Option<Header> {
        self.laser_step();
        let shutdown = self.host_step();
        self.link_step();
        self.report();
        shutdown
    }

    /// Step 1: every telegram the laser queue holds, through the pipeline.
    fn laser_step(&mut self) {
        for _ in 0..LASER_POLLS_PER_STEP {
            match self.laser.poll() {
                Ok(Some(SickEvent::Telegram(telegram))) => {
                    let Ok(values) = MeasuredValues::parse(&telegram) else {
                        self.counters.telegrams_unparsed =
                            self.counters.telegrams_unparsed.saturating_add(1);
                        continue;
                    };
                    let Some(angle) = pan_angle(
                        &mut self.encoder,
                        &self.host_pan,
                        &mut self.counters.encoder_errors,
                    ) else {
                        self.counters.lines_without_angle =
                            self.counters.lines_without_angle.saturating_add(1);
                        continue;
                    };
                    self.angle = Some(angle);
                    self.frontend.set_actuator(FineAngle::from(angle));
                    match self.frontend.line(self.pyramid, &values) {
                        Ok(()) => {
                            self.counters.lines_applied =
                                self.counters.lines_applied.saturating_add(1);
                        }
                        Err(_) => {
                            self.counters.lines_rejected =
                                self.counters.lines_rejected.saturating_add(1);
                        }
                    }
                }
                Ok(_) => {}
                // The queue is empty (`LaserQueue` never fails).
                Err(_) => return,
            }
        }
    }

    /// Step 2: the host's queued bytes, one command at a time.
    fn host_step(&mut self) -> Option<Header> {
        let mut shutdown = None;
        for _ in 0..HOST_BYTES_PER_STEP {
            let Some(byte) = self.host_rx.dequeue() else {
                break;
            };
            let mut end_observation = false;
            let frontend = &mut *self.frontend;
            let counters = &mut self.counters;
            let host_pan = &mut self.host_pan;
            self.link
                .receive(&[byte], self.pyramid, |event| match event {
                    Event::Pose(p) => {
                        match Pose::from_f32(
                            p.x_m,
                            p.y_m,
                            p.z_m,
                            p.roll_rad,
                            p.pitch_rad,
                            p.yaw_rad,
                        ) {
                            Ok(pose) => frontend.set_pose(pose),
                            Err(_) => {
                                counters.poses_refused = counters.poses_refused.saturating_add(1);
                            }
                        }
                    }
                    // Used only when the encoder errs.
                    Event::PanAngle(a) => host_pan.set(Angle::from_bits(a.turns)),
                    Event::Setup(config) => {
                        defmt::info!("setup: {}", config);
                        frontend.configure(config);
                    }
                    // The maps were cleared: the observation under way is discarded.
                    Event::Configured | Event::Reset => frontend.configure(*frontend.config()),
                    Event::EndObservation => end_observation = true,
                    Event::Shutdown(header) => shutdown = Some(header),
                    Event::Refused(reply) => defmt::warn!("refused: {}", reply),
                    Event::BadFrame(error) => defmt::warn!("bad frame: {}", error),
                    Event::SnapshotRequested(_) | Event::StatsRequested | Event::Ping => {}
                });
            if end_observation {
                self.frontend.end_observation(self.pyramid);
            }
            if shutdown.is_some() {
                break;
            }
        }
        shutdown
    }

    /// The SICK accumulator's and the classifier's counters, for Stats.
    fn sensor_counters(&self) -> SensorCounters {
        let sick = self.laser.stats();
        let classifier = self.frontend.classifier_stats();
        SensorCounters {
            telegrams_ok: sick.telegrams_ok,
            telegrams_bad_checksum: sick.crc_errors,
            telegrams_bad_framing: sick.length_errors.saturating_add(sick.truncated),
            telegrams_bad_other: self
                .counters
                .telegrams_unparsed
                .saturating_add(self.counters.lines_rejected)
                .saturating_add(self.counters.lines_without_angle),
            points: classifier.points,
            classifier_overflows: classifier.overflow_points,
            // Stats carries the low 32 bits (it wraps).
            laser_bytes: u32::try_from(self.laser.position() & u64::from(u32::MAX))
                .unwrap_or(u32::MAX),
            observations: self.frontend.stats().observations,
        }
    }

    /// Step 3: poll the link and drain its queue into USART2.
    fn link_step(&mut self) {
        let sensor = self.sensor_counters();
        self.link
            .poll(MILLIS.load(Ordering::Relaxed), self.pyramid, &sensor);
        self.drain(TX_BYTES_PER_STEP);
    }

    /// Sends up to `limit` bytes of the link's queue (in 128-byte pieces), blocking.
    fn drain(&mut self, limit: usize) {
        let mut out = [0_u8; 128];
        let mut sent = 0;
        while sent < limit {
            let n = self.link.pop_bytes(&mut out);
            if n == 0 {
                break;
            }
            sent += n;
            if let Err(e) = self.host_tx.write_all(out.get(..n).unwrap_or(&[])) {
                defmt::warn!("USART2: {}", defmt::Debug2Format(&e));
            }
        }
    }

    /// Once a second: the counters and the stack's high-water mark.
    fn report(&mut self) {
        if self.clock.elapsed_ms(self.last_report) < REPORT_MS {
            return;
        }
        self.last_report = self.clock.now();
        let (stack_used, stack_size) = hw::stack_high_water();
        defmt::info!(
            "scanner {}: {} ({}); host {}; pan {}; {}; stack {=u32}/{=u32} bytes",
            self.scanner,
            self.laser.stats(),
            rx::laser_stats(),
            rx::host_stats(),
            self.angle,
            self.counters,
            stack_used,
            stack_size
        );
    }

    /// Answers Shutdown with the stack's high-water mark, drains the queue and logs.
    fn shutdown(&mut self, header: Header) {
        let (stack_used, stack_size) = hw::stack_high_water();
        let mut reply = Reply::ok(header);
        #[allow(clippy::cast_precision_loss)]
        {
            reply.value = stack_used as f32;
            reply.a = stack_size as f32;
        }
        self.link.answer(reply);
        self.drain(usize::MAX);
        let _ = self.host_tx.flush();
        defmt::info!("shutdown: {}", self.counters);
        defmt::info!("sick: {}", self.laser.stats());
        defmt::info!("frontend: {}", self.frontend.stats());
        defmt::info!("classifier: {}", self.frontend.classifier_stats());
        defmt::info!("link: {}", self.link.counters());
        defmt::info!("pyramid: {}", self.pyramid.stats());
    }
}

/// The pan angle for a line: the encoder's, or the host's last PanAngle when the encoder errs
/// (the error counted); `None` when neither is available.
fn pan_angle(
    encoder: &mut As5047<EncoderSpi>,
    host: &HostSuppliedAngle,
    errors: &mut u32,
) -> Option<Angle> {
    match encoder.read_angle() {
        Ok(angle) => Some(angle),
        Err(e) => {
            *errors = errors.saturating_add(1);
            if *errors == 1 {
                defmt::warn!("encoder: {}; the host's pan angle stands in", e);
            }
            host.get()
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
    let design = configure(pyramid);
    let link = LINK.take();
    // Hello (boot) announces the default design at the first poll.
    link.adopt(&design);
    let frontend = FRONTEND.take();
    frontend.configure(boot_frontend_config());
    watchdog.feed();

    // SysTick: 1 kHz from the core clock, the link's milliseconds.
    let mut syst = cp.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(rcc.clocks.sysclk().raw() / 1000 - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();

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
        frontend,
        link,
        laser: SickUart::new(LaserQueue(laser_rx)),
        host_rx,
        host_tx: BlockingTx::new(host_tx),
        encoder,
        host_pan: HostSuppliedAngle::new(),
        clock,
        scanner: scanner_state,
        last_report: clock.now(),
        angle: None,
        counters: Counters::default(),
    };
    defmt::info!("main loop: SICK telegrams on USART1, the host link on USART2");
    loop {
        watchdog.feed();
        app.counters.steps = app.counters.steps.wrapping_add(1);
        if let Some(header) = app.pipeline() {
            app.shutdown(header);
            break;
        }
    }
    defmt::info!("stopped (Shutdown): parked until reset");
    loop {
        watchdog.feed();
        cortex_m::asm::wfi();
    }
}

/// Configures the pyramid with the default design and returns the design; a refused default is a build error in
/// all but name, so it panics (and the watchdog or probe-rs reports it).
fn configure(pyramid: &mut DefaultPyramid) -> DefaultDesign {
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
    design
}
