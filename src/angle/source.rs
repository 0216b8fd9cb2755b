//! [`AngleSource`]: what supplies the actuator's current angle. The drivers implement it
//! (`drivers::angle`, `drivers::as5047`, `drivers::pot`); the co-processor (`app`) takes any
//! source, so the trait sits here, below both.

use core::fmt;

use super::Angle;

/// Something that supplies the current pan angle: an encoder driver, the host link, a test.
///
/// A reading is the angle at the time of the call; the source never blocks longer than one
/// bus transaction and never panics. Errors are the source's own (bus, protocol, staleness).
pub trait AngleSource {
    /// Why a reading failed.
    type Error: fmt::Debug;

    /// Reads the current angle, with any mounting already applied.
    ///
    /// # Errors
    /// The source's error when no trustworthy angle is available; the caller should drop
    /// or hold the scan line rather than use a stale or corrupt angle.
    fn read_angle(&mut self) -> Result<Angle, Self::Error>;
}

impl<T: AngleSource + ?Sized> AngleSource for &mut T {
    type Error = T::Error;

    fn read_angle(&mut self) -> Result<Angle, Self::Error> {
        T::read_angle(self)
    }
}
