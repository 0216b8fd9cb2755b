//! The firmware on QEMU's `microbit` (nRF51822: Cortex-M0 at 16 MHz, 16 KiB of RAM), its one
//! UART for everything:
//!
//! 1. **Echo**: every byte received is sent back until EOT (0x04), which ends the echo and is
//!    not echoed: the UART's I/O both ways.
//! 2. **Pipeline**: then the UART carries SICK LMS2xx measured-values telegrams (a LMS 291 at
//!    180°/0.5° in the 8 m mode, [`LINES`] of them). Each goes through the library's real
//!    per-line pipeline (`drivers::uart::SickUart` → `MeasuredValues::parse` →
//!    `Frontend::line`: geometry, classifier, pyramid), the scan plane vertical and panned by
//!    [`PAN_STEP`] per line (line i at `(i − LINES/2) · PAN_STEP`), the scanner 1 m up; after
//!    the last line the observation ends (`Frontend::end_observation`). The sizes are chosen
//!    to fit 16 KiB with a stack margin: a [`Pyramid<16, 4>`] and [`SLOTS`] classifier slots.
//! 3. **Summary**: one text line on the UART, `PIPELINE lines=… points=… applied=…
//!    obstacle=… free=… observed=… stack=… digest=0x…` (the digest: FNV-1a over every layer's window
//!    origin and raw Q8.8 cells, for a bit-exact comparison with the host pipeline), the same
//!    and the stack's high-water mark through defmt, then semihosting exit 0.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use embedded_io::{Read, Write};
use microbit_board::stack;
use microbit_board::uart::{Baud, Uart};
use static_cell::ConstStaticCell;
use terrain_pyramid::angle::{Angle, FineAngle};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::drivers::uart::SickUart;
use terrain_pyramid::geometry::{Mount, ScanPlane, Variant};
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::pyramid::static_ram_bytes;
use terrain_pyramid::wire::sick::{MeasuredValues, MeasuringMode};
use terrain_pyramid::{
    Config, Design, DesignError, GateShape, Meters, Point3, Pyramid, Schedule, SensorModel,
};

/// W, cells per side of every layer's window.
const CELLS: usize = 16;
/// The pyramid's layers.
const LAYERS: usize = 4;
/// Classifier slots (a power of two): distinct cells one observation can touch before the
/// classifier counts overflows.
const SLOTS: usize = 256;
/// Telegrams (lines) of the observation.
pub const LINES: u32 = 30;
/// The pan step between lines: 364 / 65 536 turn (1.9995°, ψ of the design: 2°), exact in
/// the encoder's unit.
pub const PAN_STEP: u16 = 364;
/// End of the echo.
const EOT: u8 = 0x04;

type SmallPyramid = Pyramid<CELLS, LAYERS>;

/// The pyramid in a `static` (all zero bits: `.bss`), configured in place.
static PYRAMID: ConstStaticCell<SmallPyramid> = ConstStaticCell::new(SmallPyramid::new());
/// The per-line pipeline, likewise.
static FRONTEND: ConstStaticCell<Frontend<SLOTS>> = ConstStaticCell::new(Frontend::unconfigured());

/// A design whose four layers fit 16-cell windows (as the on-target tests' `small_design`):
/// σ = 0.3 m, 3 m range, Δd = 0.1 m, γ = 2, hard gates; the sensor 1 m up (the default h).
fn design() -> Result<Design<LAYERS>, DesignError> {
    let sensor = SensorModel {
        sigma_m: 0.3,
        max_range_m: 3.0,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    Design::new(sensor, schedule, CELLS)
}

/// The pipeline: an LMS 291 at 180°/0.5°, 8 m mode, scan plane vertical and panned, 1 m up.
fn frontend_config() -> FrontendConfig {
    FrontendConfig {
        mount: Mount::new(
            ScanPlane::PannedVertical,
            Point3 {
                x: Meters::ZERO,
                y: Meters::ZERO,
                z: Meters::ONE,
            },
        ),
        variant: Variant::Fov180StepHalf,
        measuring_mode: MeasuringMode::Mm8Cm80,
        lines_per_observation: 0,
        classifier: ClassifierConfig::default(),
        missing_ground_within: None,
    }
}

/// Echoes until EOT; returns the bytes echoed. Reads one byte at a time: what follows EOT
/// (the telegrams) stays in the UART for the pipeline.
#[inline(never)]
fn echo(uart: &mut Uart) -> u32 {
    let mut echoed = 0_u32;
    let mut buf = [0_u8; 1];
    loop {
        let n = match uart.read(&mut buf) {
            Ok(n) => n,
            Err(e) => {
                defmt::warn!("UART: {}", e);
                continue;
            }
        };
        for &byte in buf.get(..n).unwrap_or(&[]) {
            if byte == EOT {
                return echoed;
            }
            // Infallible: the UART's write never fails.
            let _ = uart.write_all(&[byte]);
            echoed += 1;
        }
    }
}

/// FNV-1a, 32 bits.
struct Fnv(u32);

impl Fnv {
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
    }
}

/// FNV-1a over every layer: its window origin (two i32 LE), then its cells (raw Q8.8, i16 LE;
/// unknown is −32 768) row by row from the window's lower-left offset.
fn digest(pyramid: &SmallPyramid) -> u32 {
    let mut h = Fnv(0x811C_9DC5);
    for k in 0..pyramid.layer_count() {
        let Some(layer) = pyramid.layer(k) else {
            continue;
        };
        let (ox, oy) = layer.origin();
        h.bytes(&ox.to_le_bytes());
        h.bytes(&oy.to_le_bytes());
        for dy in 0..CELLS {
            for dx in 0..CELLS {
                let raw = layer.at_offset(dx, dy).map_or(i16::MIN, |c| c.to_raw());
                h.bytes(&raw.to_le_bytes());
            }
        }
    }
    h.0
}

/// Writes `n` in decimal.
fn write_u32(uart: &mut Uart, n: u32) {
    let mut digits = [0_u8; 10];
    let mut i = digits.len();
    let mut v = n;
    loop {
        i -= 1;
        if let Some(d) = digits.get_mut(i) {
            // `v % 10` < 10: the cast keeps it.
            #[allow(clippy::cast_possible_truncation)]
            {
                *d = b'0' + (v % 10) as u8;
            }
        }
        v /= 10;
        if v == 0 || i == 0 {
            break;
        }
    }
    let _ = uart.write_all(digits.get(i..).unwrap_or(&[]));
}

fn write_hex(uart: &mut Uart, n: u32) {
    let mut text = *b"0x00000000";
    for (i, slot) in text.iter_mut().skip(2).enumerate() {
        let nibble = (n >> (28 - 4 * i)) & 0xF;
        *slot = b"0123456789abcdef"
            .get(nibble as usize)
            .copied()
            .unwrap_or(b'?');
    }
    let _ = uart.write_all(&text);
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(mut uart) = Uart::take(Baud::B115200) else {
        defmt::panic!("UART taken twice");
    };
    defmt::info!("micro:bit (nRF51822, Cortex-M0): echo until EOT");
    let echoed = echo(&mut uart);
    defmt::info!("echoed {=u32} bytes", echoed);

    let pyramid = PYRAMID.take();
    let frontend = FRONTEND.take();
    configure(pyramid, frontend);
    run(uart, pyramid, frontend)
}

/// Configures the pyramid and the pipeline in place, each in a frame of its own (not inlined
/// into `main`, nor into each other): `Pyramid::configure` and `Frontend::configure` build
/// tables on the way (the beam table alone is 1.6 KiB), and on 16 KiB only one of them fits on
/// the stack at a time, never together with the telegram accumulator of [`run`].
#[inline(never)]
fn configure(pyramid: &mut SmallPyramid, frontend: &mut Frontend<SLOTS>) {
    let design = configure_pyramid(pyramid);
    configure_frontend(frontend);
    defmt::info!(
        "pipeline: {}, pyramid {=usize} B, frontend {=usize} B ({=usize} slots); {=u32} lines",
        design,
        static_ram_bytes::<CELLS, LAYERS>(),
        core::mem::size_of::<Frontend<SLOTS>>(),
        SLOTS,
        LINES
    );
}

#[inline(never)]
fn configure_pyramid(pyramid: &mut SmallPyramid) -> Design<LAYERS> {
    let design = match design() {
        Ok(d) => d,
        Err(e) => defmt::panic!("design refused: {}", e),
    };
    if let Err(e) = pyramid.configure(&design, &Config::default()) {
        defmt::panic!("configuration refused: {}", e);
    }
    design
}

#[inline(never)]
fn configure_frontend(frontend: &mut Frontend<SLOTS>) {
    frontend.configure(frontend_config());
}

/// The telegrams through the pipeline, then the summary and the exit.
#[inline(never)]
fn run(uart: Uart, pyramid: &mut SmallPyramid, frontend: &mut Frontend<SLOTS>) -> ! {
    let mut laser: SickUart<Uart> = SickUart::new(uart);
    let mut unparsed = 0_u32;
    let mut rejected = 0_u32;
    let mut line = 0_u32;
    while line < LINES {
        let telegram = match laser.next_telegram() {
            Ok(t) => t,
            Err(e) => {
                defmt::warn!("laser: {}", e);
                continue;
            }
        };
        let Ok(values) = MeasuredValues::parse(&telegram) else {
            unparsed += 1;
            continue;
        };
        // Line i at (i − LINES/2) · PAN_STEP, wrapping like the angle.
        #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
        let steps = line as i32 - (LINES / 2) as i32;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let pan = Angle::from_bits((steps * i32::from(PAN_STEP)) as u16);
        frontend.set_actuator(FineAngle::from(pan));
        if frontend.line(pyramid, &values).is_err() {
            rejected += 1;
        }
        line += 1;
    }
    frontend.end_observation(pyramid);

    let sick = laser.stats();
    let classifier = frontend.classifier_stats();
    let stats = pyramid.stats();
    let (mut obstacle, mut free, mut observed) = (0_u32, 0_u32, 0_u32);
    for k in 0..pyramid.layer_count() {
        if let Some(c) = pyramid.counts(k) {
            obstacle += c.obstacle;
            free += c.free;
            observed += c.observed;
        }
    }
    let hash = digest(pyramid);
    let usage = stack::usage();
    defmt::info!("sick: {}", sick);
    defmt::info!("frontend: {}", frontend.stats());
    defmt::info!("classifier: {}", classifier);
    defmt::info!("pyramid: {}", stats);
    defmt::info!(
        "cells: {=u32} obstacle, {=u32} free, {=u32} observed; digest {=u32:#010x}; unparsed {=u32}, rejected {=u32}",
        obstacle,
        free,
        observed,
        hash,
        unparsed,
        rejected
    );
    defmt::info!(
        "stack: high-water {=u32} bytes of {=u32} ({=u32} never touched)",
        usage.used,
        usage.size,
        usage.untouched
    );

    let uart = laser.reader_mut();
    let fields: [(&[u8], u32); 8] = [
        (b"PIPELINE lines=", line),
        (b" points=", classifier.points),
        (b" overflows=", classifier.overflow_points),
        (b" applied=", stats.applied),
        (b" obstacle=", obstacle),
        (b" free=", free),
        (b" observed=", observed),
        (b" stack=", usage.used),
    ];
    for (name, value) in fields {
        let _ = uart.write_all(name);
        write_u32(uart, value);
    }
    let _ = uart.write_all(b" digest=");
    write_hex(uart, hash);
    let _ = uart.write_all(b"\n");
    microbit_board::exit(microbit_board::EXIT_SUCCESS)
}
