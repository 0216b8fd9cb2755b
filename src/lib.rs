//! # terrain-pyramid
//!
//! A `no_std`, allocation-free implementation of the multi-resolution terrain pyramid of
//! Montemerlo & Thrun, *"A Multi-Resolution Pyramid for Outdoor Robot Terrain Perception"*,
//! for a microcontroller that sits next to a scanning laser.
//!
//! The path of one observation:
//!
//! ```text
//! UART bytes --> [laser] the setup's sensor: SICK telegram (ranges + beam table), or a lidar
//!                packet (returns, each with its own angle, timed)
//! encoder / servo model / host --> actuator angle at each return's time ([actuator])
//! host link --> pose ----> [geometry] points --> [classify] evidence
//!                                         --> [pyramid] gated log-odds updates, window moves
//! ```
//!
//! The core rooms, each with one job:
//! - [`angle`]: angles as fractions of a turn ([`angle::Angle`], [`angle::FineAngle`]) and
//!   their integer sine and cosine.
//! - [`units`]: the fixed-point number types and their ranges.
//! - [`design`]: the sensor model, the cell-size bound δ(d) (eq. 17), the resolution schedule
//!   and the range bands (eq. 20), and the validation of a configuration.
//! - [`gate`]: the precomputed hard or soft gating tables `w_k(d)`.
//! - [`geometry`]: beam tables, mounts, poses and the per-line transform from a range
//!   reading to a world point, in fixed point; the per-return transform of a spinning lidar.
//! - [`actuator`]: the nodding servo's sweep model and the interpolation of an angle
//!   source's readings.
//! - [`logodds`]: the fixed-point log-odds cell, the inverse sensor model as increments, clamping.
//! - [`grid`]: one robot-centric layer as a circular buffer, and its index maths.
//! - [`pyramid`]: the layers together: gated integration, recentring, the fused query.
//! - [`classify`]: one observation's points → per-layer cell evidence (the navigability rule).
//!
//! At the edges:
//! - [`wire`]: pure, zero-copy wire formats: [`wire::sick`], the SICK LMS2xx telegrams and
//!   their reassembly from UART chunks; [`wire::ld06`], [`wire::rplidar`], [`wire::ydlidar`],
//!   the spinning UART lidars; [`wire::recording`], the recording file format.
//! - [`laser`]: the laser the host's Setup names: its decoder, its packets' times.
//! - [`link`]: the device side of the serial link to the main computer (`docs/protocol.md`):
//!   rate-limited patches of changed tiles, commands in, replies out.
//! - [`drivers`]: thin adapters from embedded-io / embedded-hal to the pure code:
//!   [`drivers::angle`], [`drivers::as5047`] and [`drivers::pot`] (sources of the actuator
//!   angle), [`drivers::servo`] (a nodding servo's PWM), [`drivers::lidar`] (requests to a
//!   lidar).
//!
//! # Panic contract
//! No function in this crate panics on any input, as smoltcp's `wire` promises: parsers and
//! bounded containers return errors, numeric conversions saturate and are counted. Clippy
//! denies `unwrap`, `expect`, `panic!` and unchecked indexing outside tests.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[macro_use]
mod macros;

pub mod actuator;
pub mod angle;
pub mod fmath;
#[macro_use]
mod fmt;

pub mod app;
pub mod classify;
pub mod decay;
pub mod design;
pub mod drivers;
pub mod gate;
pub mod geometry;
pub mod grid;
pub mod laser;
pub mod link;
pub mod logodds;
pub mod pipeline;
pub mod pyramid;
#[cfg(any(feature = "plane-rule", test))]
mod saturate;
#[cfg(test)]
mod test_rng;
pub mod units;
mod wide;
pub mod wire;

pub use decay::{Decay, DecayMode, TimeConstant};
pub use design::{Design, DesignError, GateShape, Param, Schedule, SensorModel};

pub use grid::{Layer, LayerCounts, Resolution};
pub use logodds::{Cell, CellClass, Clamp, GatedIncrement, Increments, InverseSensorModel};
pub use pyramid::{
    fused_answer, Applied, Config, Evidence, EvidenceClass, Fused, Pyramid, PyramidStats,
    DEFAULT_FUSED_MARGIN,
};
pub use units::{LogOddsFixed, Meters, Point3, Weight};

/// Window size of the default pyramid, cells per side: 6.4 m across at 0.1 m.
pub const DEFAULT_CELLS_PER_SIDE: usize = 64;
/// Layer capacity of the default pyramid: the default design (10 m, Δd = 0.1 m, γ = 2) needs 8.
pub const DEFAULT_LAYERS: usize = 8;
/// The default pyramid: 8 layers of 64 × 64 cells, about 73 KiB.
pub type DefaultPyramid = Pyramid<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS>;
/// The design type of the default pyramid.
pub type DefaultDesign = Design<DEFAULT_LAYERS>;
/// Classifier slots of the default pipeline: 1024 cells of one observation (22 KiB), enough
/// for a whole 226-line sweep of the real 3DTK scan (about 860 cells with the soft gate).
pub const DEFAULT_CLASSIFIER_SLOTS: usize = 1024;
/// The default pipeline, as the firmware runs it.
pub type DefaultFrontend = pipeline::Frontend<DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS>;

/// The default co-processor: the default pyramid and pipeline, and a link with a 2 KiB queue
/// (22 ms of the link at 921 600 Bd ahead of a budget of half of it), about 94 KiB.
pub type DefaultCoProcessor =
    app::CoProcessor<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, DEFAULT_CLASSIFIER_SLOTS, 2048>;

// The README's example is compiled and run as a doctest, so it stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
