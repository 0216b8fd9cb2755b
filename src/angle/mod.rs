//! Angles as fractions of a turn, in integer arithmetic, so the host and a Cortex-M0 produce
//! the same bits:
//! - [`Angle`]: unsigned Q0.16, the resolution of an actuator (an encoder, a servo, the host's
//!   PanAngle); a 14-bit encoder count converts exactly.
//! - [`FineAngle`]: unsigned Q0.32, the resolution of the geometry (beam and actuator angles,
//!   headings), with its sine and cosine ([`SinCos`], signed Q2.30) from a quarter-wave table.
//!
//! Both wrap: every value is a valid angle and arithmetic is modulo one turn. Nothing here
//! depends on any other room of the crate but [`crate::fmath`]'s constants, so every layer
//! (wire formats, geometry, drivers) can use them.

mod coarse;
mod fine;
mod source;

pub use coarse::{Angle, COUNTS_PER_TURN, COUNT_MASK};
pub use fine::{FineAngle, SinCos};
pub use source::AngleSource;
