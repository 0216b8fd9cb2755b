//! The firmware on QEMU's MPS2 AN386: the default pyramid in a `static`, configured with the
//! default design and self-checked, then the main loop, one [`App::pipeline`] call per step.
//!
//! For now the pipeline is a placeholder that proves both UARTs: it echoes the bytes that
//! arrive on UART0 (the laser's side) to UART1 (the host link) until a byte 0x04 (EOT)
//! arrives, and the firmware then exits with success. The real step (SICK telegrams →
//! geometry → classifier → pyramid → link) replaces the body of [`App::pipeline`].
//!
//! At exit the stack's high-water mark is logged (see `qemu_mps2::stack`).
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use embedded_io::{Read, Write};
use qemu_mps2::stack;
use qemu_mps2::uart::{Uart0, Uart1, UartError, Uarts};
use static_cell::ConstStaticCell;
use terrain_pyramid::pyramid::static_ram_bytes;
use terrain_pyramid::{
    Applied, Config, DefaultDesign, DefaultPyramid, DesignError, Evidence, EvidenceClass, Fused,
    Meters, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS,
};

/// The UARTs' baud rate (the SICK LMS's fast mode is 500 kBd on real hardware; QEMU's UARTs
/// ignore the rate).
const BAUD: u32 = 500_000;

/// The byte that ends the echo placeholder: ASCII EOT.
const END_OF_ECHO: u8 = 0x04;

/// The pyramid, about 73 KiB, in a `static`.
///
/// `ConstStaticCell` because `Pyramid::new` is `const`: the value is built at compile time, so
/// it is never constructed on the stack (which `StaticCell::init` may do, and a
/// `cortex_m::singleton!` would do, for a 73 KiB value), there is no `static mut`, no lock
/// (unlike a `Mutex<RefCell<…>>`) and no run-time check but the one `take`. Its price: the
/// unknown cells are `0x8000`, not zero, so the initial image sits in `.data` and costs as
/// much flash as RAM.
static PYRAMID: ConstStaticCell<DefaultPyramid> = ConstStaticCell::new(DefaultPyramid::new());

/// Why the firmware stopped early.
#[derive(Debug, defmt::Format)]
enum Fault {
    /// The default design or configuration was refused.
    Design(DesignError),
    /// The pyramid answered the self-check wrongly.
    SelfCheck(&'static str),
    /// The UARTs were taken twice.
    UartsTaken,
}

impl From<DesignError> for Fault {
    fn from(e: DesignError) -> Self {
        Self::Design(e)
    }
}

/// What the main loop does after a pipeline step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flow {
    Continue,
    Stop,
}

/// Everything the main loop owns.
struct App {
    /// Not used by the placeholder step yet; the real pipeline integrates into it.
    #[allow(dead_code)]
    pyramid: &'static mut DefaultPyramid,
    /// UART0: the laser's telegrams come in here.
    laser: Uart0,
    /// UART1: the link to the main computer.
    link: Uart1,
    /// Bytes echoed so far.
    echoed: u32,
    /// UART0 overruns seen.
    overruns: u32,
}

impl App {
    /// One step of the main loop. Placeholder: echo what UART0 has to UART1; stop at EOT.
    fn pipeline(&mut self) -> Flow {
        let mut buf = [0_u8; 64];
        let n = match self.laser.read(&mut buf) {
            Ok(n) => n,
            Err(UartError::Overrun) => {
                self.overruns = self.overruns.saturating_add(1);
                defmt::warn!("UART0 overrun");
                return Flow::Continue;
            }
        };
        let received = buf.get(..n).unwrap_or(&[]);
        let (payload, flow) = match received.iter().position(|&b| b == END_OF_ECHO) {
            Some(end) => (received.get(..end).unwrap_or(&[]), Flow::Stop),
            None => (received, Flow::Continue),
        };
        // Writing to UART1 cannot fail (no error but RX overrun exists on this UART).
        let _ = self.link.write_all(payload);
        self.echoed = self
            .echoed
            .saturating_add(u32::try_from(payload.len()).unwrap_or(u32::MAX));
        if flow == Flow::Stop {
            let _ = self.link.flush();
        }
        flow
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
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )?;
    pyramid.configure(&design, &Config::default())?;
    log_design(&design);
    self_check(pyramid)?;

    let Uarts { uart0, uart1 } = Uarts::take(BAUD).ok_or(Fault::UartsTaken)?;
    let mut app = App {
        pyramid,
        laser: uart0,
        link: uart1,
        echoed: 0,
        overruns: 0,
    };
    defmt::info!("echoing UART0 -> UART1 until 0x04");
    while app.pipeline() == Flow::Continue {}
    defmt::info!(
        "echo done: {=u32} bytes, {=u32} overruns",
        app.echoed,
        app.overruns
    );
    Ok(())
}

fn log_design(design: &DefaultDesign) {
    defmt::info!(
        "pyramid: {} ({=usize} layers max, {=usize} bytes of static RAM)",
        design,
        DEFAULT_LAYERS,
        static_ram_bytes::<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS>()
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
fn self_check(pyramid: &mut DefaultPyramid) -> Result<(), Fault> {
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
                layer: DEFAULT_LAYERS as u8,
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
