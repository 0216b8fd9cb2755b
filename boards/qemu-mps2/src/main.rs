//! The firmware on QEMU's MPS2 AN386: the terrain pyramid's co-processor, fed by real SICK
//! telegrams on UART0 and driven by the host link (`docs/protocol.md`) on UART1.
//!
//! At boot: the default pyramid in a `static` (all zero bits: `.bss`), configured with the
//! default design and self-checked, then announced to the host (Hello, reason boot). Each
//! step of the main loop:
//!
//! 1. UART0: every byte that has arrived goes through the SICK accumulator
//!    (`drivers::uart::SickUart`); each telegram is parsed (`MeasuredValues::parse`) and fed
//!    to the pipeline (`Frontend::line`) in the same step.
//! 2. UART1: the host's bytes go to `Link::receive`, one byte at a time so that every command
//!    is carried out in order with the pipeline's own events (Pose, PanAngle, Setup,
//!    Configure, Reset, EndObservation, Shutdown).
//! 3. `Link::poll` with the time and the SICK and classifier counters, then the queue drains
//!    into UART1.
//!
//! Time: SysTick at 1 kHz from the 25 MHz processor clock (QEMU runs it on its virtual clock,
//! which follows the host's wall clock without `-icount`; DWT's cycle counter reads 0 in QEMU).
//!
//! The run ends when the host sends Shutdown (0x89): the firmware answers it with Reply Ok
//! (the stack's high-water mark in `value`, its size in `a`, bytes), drains its queue, logs
//! its counters and the stack through defmt, and exits with success.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use embedded_io::{Read, ReadReady, Write};
use qemu_mps2::stack;
use qemu_mps2::uart::{Uart0, Uart1, UartError, Uarts};
use static_cell::ConstStaticCell;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::drivers::uart::{Event as SickEvent, SickUart, UartError as SickError};
use terrain_pyramid::geometry::{Mount, Pose, ScanPlane};
use terrain_pyramid::link::{Event, Link, SensorCounters};
use terrain_pyramid::pipeline::Frontend;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::pyramid::static_ram_bytes;
use terrain_pyramid::wire::link::{Header, Reply};
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::wire::sick::{MeasuredValues, MeasuringMode};
use terrain_pyramid::{
    Applied, Config, Design, DesignError, Evidence, EvidenceClass, Fused, Meters, Point3, Pyramid,
    Schedule, SensorModel,
};

/// The sizes this firmware is built with: the library's defaults (W = 64, 8 layers, 1 024
/// classifier slots: 72 KiB of pyramid in the 4 MiB of SSRAM2/3).
#[cfg(not(feature = "paper-stairs"))]
mod sizes {
    use terrain_pyramid::link::LinkConfig;
    /// W, cells per side of every window.
    pub const CELLS: usize = terrain_pyramid::DEFAULT_CELLS_PER_SIDE;
    /// The pyramid's layer capacity.
    pub const LAYERS: usize = terrain_pyramid::DEFAULT_LAYERS;
    /// Classifier slots.
    pub const SLOTS: usize = terrain_pyramid::DEFAULT_CLASSIFIER_SLOTS;
    /// The link's queue: 2 KiB, 22 ms of the UART at 921 600 Bd, ahead of a patch budget of
    /// half the link; it keeps the firmware's static RAM within 96 KiB.
    pub const QUEUE: usize = 2048;
    /// The link's settings.
    pub const LINK: LinkConfig = LinkConfig::DEFAULT;
}

/// The sizes of the paper's stairs experiment (`--features paper-stairs`): every layer at
/// 0.1 m to 24 m needs 32 layers of 488 × 488 cells (15.3 MB, in the board's 16 MiB of PSRAM,
/// see `memory-paper-stairs.x`) and 16 384 classifier slots (a soft-gated point feeds several
/// layers). QEMU's UARTs have no baud rate, so the link's budget is 16 MB/s: a snapshot of
/// all layers takes seconds, not minutes.
#[cfg(feature = "paper-stairs")]
mod sizes {
    use terrain_pyramid::link::LinkConfig;
    /// W, cells per side of every window: a 24 m band at 0.1 m needs 2 · 24 / 0.1 + 2.
    pub const CELLS: usize = 488;
    /// The pyramid's layer capacity: the stairs design to 24 m has 32.
    pub const LAYERS: usize = 32;
    /// Classifier slots.
    pub const SLOTS: usize = 16_384;
    /// The link's queue.
    pub const QUEUE: usize = 16_384;
    /// The link's settings.
    pub const LINK: LinkConfig = LinkConfig {
        budget_bytes_per_s: 16_000_000,
        burst_bytes: 65_536,
        ..LinkConfig::DEFAULT
    };
}

use sizes::{CELLS, LAYERS, SLOTS};

/// The pyramid of this build.
type BoardPyramid = Pyramid<CELLS, LAYERS>;
/// Its design.
type BoardDesign = Design<LAYERS>;
/// The per-line pipeline of this build.
type BoardFrontend = Frontend<SLOTS>;

/// The UARTs' baud rate (the SICK LMS's fast mode is 500 kBd on real hardware; QEMU's UARTs
/// ignore the rate).
const BAUD: u32 = 500_000;

/// The processor clock of the MPS2 AN386, Hz: SysTick counts it.
const CPU_HZ: u32 = 25_000_000;

/// SICK accumulator polls per main-loop step before the host link gets its turn.
const LASER_POLLS_PER_STEP: u32 = 4096;

/// The pyramid, about 72 KiB (15.3 MB with `paper-stairs`), in a `static`.
///
/// `ConstStaticCell` because `Pyramid::new` is `const`: the value is built at compile time, so
/// it is never constructed on the stack (which `StaticCell::init` may do, and a
/// `cortex_m::singleton!` would do, for a 72 KiB value), there is no `static mut`, no lock
/// (unlike a `Mutex<RefCell<…>>`) and no run-time check but the one `take`. A fresh pyramid
/// is all zero bits, so it lives in `.bss` and costs no flash.
static PYRAMID: ConstStaticCell<BoardPyramid> = ConstStaticCell::new(BoardPyramid::new());

/// The host link (queue, bucket, tile ages: about 4 KiB), `const`-built like the pyramid.
static LINK: ConstStaticCell<BoardLink> = ConstStaticCell::new(Link::new(sizes::LINK));

/// The link, its frame queue ([`sizes::QUEUE`]) and its per-layer state for [`LAYERS`] layers.
type BoardLink = Link<{ sizes::QUEUE }, LAYERS>;

/// The per-line pipeline (about 24 KiB: the classifier's 1 024 slots and the beam table),
/// `const`-built unconfigured (all zero bits: `.bss`) and configured in place at boot, so it
/// never sits on the stack.
static FRONTEND: ConstStaticCell<BoardFrontend> =
    ConstStaticCell::new(BoardFrontend::unconfigured());

/// Milliseconds since SysTick started, wrapping.
static MILLIS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    // The handler is the only writer: a load and a store (ARMv6-M has no atomic add).
    MILLIS.store(
        MILLIS.load(Ordering::Relaxed).wrapping_add(1),
        Ordering::Relaxed,
    );
}

/// The pipeline's configuration until the host sends Setup: a SICK LMS 291 at 180°/0.5° in
/// the 8 m mode, 0.5 m up on a tilt unit, one observation per sweep.
fn boot_frontend_config() -> FrontendConfig {
    FrontendConfig {
        mount: Mount::new(
            ScanPlane::TiltedHorizontal,
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

/// Why the firmware stopped early.
#[derive(Debug, defmt::Format)]
enum Fault {
    /// The default design or configuration was refused.
    Design(DesignError),
    /// The pyramid answered the self-check wrongly.
    SelfCheck(&'static str),
    /// The UARTs or a static were taken twice.
    Taken,
}

impl From<DesignError> for Fault {
    fn from(e: DesignError) -> Self {
        Self::Design(e)
    }
}

/// UART0 as a stream that never blocks: `read` returns 0 (end of stream, for `SickUart`:
/// "nothing now") when no byte has arrived.
struct Laser(Uart0);

impl embedded_io::ErrorType for Laser {
    type Error = UartError;
}

impl Read for Laser {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        if buf.is_empty() || !self.0.read_ready()? {
            return Ok(0);
        }
        self.0.read(buf)
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
    /// Poses the geometry refused.
    poses_refused: u32,
    /// UART0 overruns.
    overruns: u32,
    /// Main-loop steps.
    steps: u32,
}

/// Everything the main loop owns.
struct App {
    pyramid: &'static mut BoardPyramid,
    frontend: &'static mut BoardFrontend,
    link: &'static mut BoardLink,
    laser: SickUart<Laser>,
    host: Uart1,
    counters: Counters,
}

impl App {
    /// Step 1: every telegram UART0 holds, through the pipeline.
    fn laser_step(&mut self) {
        for _ in 0..LASER_POLLS_PER_STEP {
            match self.laser.poll() {
                Ok(Some(SickEvent::Telegram(telegram))) => match MeasuredValues::parse(&telegram) {
                    Ok(values) => match self.frontend.line(self.pyramid, &values) {
                        Ok(()) => {
                            self.counters.lines_applied =
                                self.counters.lines_applied.saturating_add(1);
                        }
                        Err(_) => {
                            self.counters.lines_rejected =
                                self.counters.lines_rejected.saturating_add(1);
                        }
                    },
                    Err(_) => {
                        self.counters.telegrams_unparsed =
                            self.counters.telegrams_unparsed.saturating_add(1);
                    }
                },
                Ok(_) => {}
                Err(SickError::EndOfStream) => return,
                Err(_) => {
                    self.counters.overruns = self.counters.overruns.saturating_add(1);
                    defmt::warn!("UART0 overrun");
                    return;
                }
            }
        }
    }

    /// Step 2: the host's bytes, one command at a time. Returns the Shutdown's header when
    /// the host asked the firmware to stop.
    fn host_step(&mut self) -> Option<Header> {
        let mut buf = [0_u8; 64];
        let n = match self.host.read_ready() {
            Ok(true) => self.host.read(&mut buf).unwrap_or(0),
            _ => 0,
        };
        let mut shutdown = None;
        for &byte in buf.get(..n).unwrap_or(&[]) {
            let mut end_observation = false;
            let frontend = &mut *self.frontend;
            let counters = &mut self.counters;
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
                    Event::PanAngle(a) => {
                        frontend.set_actuator(FineAngle::from_bits(u32::from(a.turns) << 16));
                    }
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
                .saturating_add(self.counters.lines_rejected),
            points: classifier.points,
            classifier_overflows: classifier.overflow_points,
            // Stats carries the low 32 bits (it wraps).
            laser_bytes: u32::try_from(self.laser.position() & u64::from(u32::MAX))
                .unwrap_or(u32::MAX),
            observations: self.frontend.stats().observations,
        }
    }

    /// Step 3: poll the link and drain its queue into UART1.
    fn link_step(&mut self) {
        let sensor = self.sensor_counters();
        self.link
            .poll(MILLIS.load(Ordering::Relaxed), self.pyramid, &sensor);
        self.drain();
    }

    fn drain(&mut self) {
        let mut out = [0_u8; 128];
        loop {
            let n = self.link.pop_bytes(&mut out);
            if n == 0 {
                break;
            }
            // Writing to UART1 cannot fail (no error but RX overrun exists on this UART).
            let _ = self.host.write_all(out.get(..n).unwrap_or(&[]));
        }
    }

    /// Answers Shutdown with the stack's high-water mark, drains the queue and logs.
    fn shutdown(&mut self, header: Header) {
        let usage = stack::usage();
        let mut reply = Reply::ok(header);
        #[allow(clippy::cast_precision_loss)]
        {
            reply.value = usage.used as f32;
            reply.a = usage.size as f32;
        }
        self.link.answer(reply);
        self.drain();
        let _ = self.host.flush();
        defmt::info!("shutdown: {}", self.counters);
        defmt::info!("sick: {}", self.laser.stats());
        defmt::info!("frontend: {}", self.frontend.stats());
        defmt::info!("classifier: {}", self.frontend.classifier_stats());
        defmt::info!("link: {}", self.link.counters());
        defmt::info!("pyramid: {}", self.pyramid.stats());
    }
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
    let pyramid = PYRAMID.take();
    let design = BoardDesign::new(SensorModel::default(), Schedule::default(), CELLS)?;
    pyramid.configure(&design, &Config::default())?;
    log_design(&design);
    self_check(pyramid)?;

    let link = LINK.take();
    // Hello (boot) announces the default design at the first poll.
    link.adopt(&design);
    let frontend = FRONTEND.take();
    frontend.configure(boot_frontend_config());

    let mut core = cortex_m::Peripherals::take().ok_or(Fault::Taken)?;
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(CPU_HZ / 1000 - 1);
    core.SYST.clear_current();
    core.SYST.enable_interrupt();
    core.SYST.enable_counter();

    let Uarts { uart0, uart1 } = Uarts::take(BAUD).ok_or(Fault::Taken)?;
    let mut app = App {
        pyramid,
        frontend,
        link,
        laser: SickUart::new(Laser(uart0)),
        host: uart1,
        counters: Counters::default(),
    };
    defmt::info!("running: SICK telegrams on UART0, the host link on UART1");
    loop {
        app.counters.steps = app.counters.steps.wrapping_add(1);
        app.laser_step();
        let shutdown = app.host_step();
        app.link_step();
        if let Some(header) = shutdown {
            app.shutdown(header);
            return Ok(());
        }
    }
}

fn log_design(design: &BoardDesign) {
    defmt::info!(
        "pyramid: {} ({=usize} layers max, {=usize} bytes of static RAM)",
        design,
        LAYERS,
        static_ram_bytes::<CELLS, LAYERS>()
    );
    defmt::info!("sensor: {}", design.sensor());
    defmt::info!("schedule: {}", design.schedule());
    for (k, layer) in design.layers().iter().enumerate() {
        defmt::info!(
            "layer {=usize}: cell {=f32} m, band [{=f32}, {=f32}) m, gate centre {=f32} m, sigma {=f32} m",
            k,
            layer.resolution_m,
            layer.band_inner_m,
            layer.band_outer_m,
            layer.gate_center_m,
            layer.gate_sigma_m
        );
    }
}

/// Applies a few records and checks what the pyramid makes of them, then forgets them.
fn self_check(pyramid: &mut BoardPyramid) -> Result<(), Fault> {
    let records = [
        // An obstacle seen by layer 0 at 0.35 m, in its cell (3, 0).
        (
            Evidence {
                layer: 0,
                cell_x: 3,
                cell_y: 0,
                class: EvidenceClass::Obstacle,
                distance: Meters::from_num(0.35),
            },
            Applied::Updated,
        ),
        // Free ground seen by layer 1 at 1 m, around the robot.
        (
            Evidence {
                layer: 1,
                cell_x: 0,
                cell_y: 0,
                class: EvidenceClass::Navigable,
                distance: Meters::from_num(1),
            },
            Applied::Updated,
        ),
        // A layer the design does not have.
        (
            Evidence {
                layer: u8::try_from(LAYERS).unwrap_or(u8::MAX),
                cell_x: 0,
                cell_y: 0,
                class: EvidenceClass::Obstacle,
                distance: Meters::from_num(1),
            },
            Applied::BadLayer,
        ),
    ];
    for (record, expected) in &records {
        let applied = pyramid.apply(record);
        defmt::debug!("{} -> {}", record, applied);
        if applied != *expected {
            return Err(Fault::SelfCheck("a record was applied unexpectedly"));
        }
    }
    let at = |x: f32, y: f32| pyramid.fused(Meters::from_num(x), Meters::from_num(y));
    if at(0.35, 0.05) != (Fused::Obstacle { layer: 0 }) {
        return Err(Fault::SelfCheck("layer 0 lost the obstacle"));
    }
    if at(0.15, 0.15) != (Fused::Navigable { layer: 1 }) {
        return Err(Fault::SelfCheck("layer 1 lost the free ground"));
    }
    if at(2.0, 2.0) != Fused::Unknown {
        return Err(Fault::SelfCheck("an unobserved place is known"));
    }
    let stats = pyramid.stats();
    defmt::info!("self-check passed: {}", stats);
    pyramid.clear();
    Ok(())
}
