//! Thin adapters from embedded-hal / embedded-io traits to the pure code.
//!
//! Each driver owns a bus handle (an `embedded-hal` `SpiDevice`, an `embedded-io` reader or
//! writer), turns its bytes into the library's types and its failures into a per-driver error
//! enum, and does nothing else: the core modules never touch a peripheral, a clock or an
//! allocator, and are handed the data these adapters produce. Like the rest of the crate, no
//! driver panics on any input from its bus.
//!
//! - [`angle`]: the [`angle::AngleSource`] trait, encoder mounting, and the host-supplied
//!   angle for boards without an encoder.
//! - [`as5047`]: the AS5047P-kind 14-bit magnetic encoder over SPI.
//! - [`lidar`]: requests to the spinning UART lidars (RPLIDAR, YDLIDAR) through any
//!   `embedded_io::Write`.
//! - [`servo`]: a nodding servo on a PWM channel through embedded-hal's `SetDutyCycle`.
//! - [`pot`]: a potentiometer on the actuator's axis through an ADC channel ([`pot::AdcChannel`],
//!   embedded-hal having no ADC trait), as an [`angle::AngleSource`].
//!
//! (A laser's bytes need no driver: a board hands whatever its UART received to
//! [`crate::app::CoProcessor::laser`].)

pub mod angle;
pub mod as5047;
pub mod lidar;
pub mod pot;
pub mod servo;
