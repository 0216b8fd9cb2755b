//! Time from the DWT cycle counter: timeouts for the scanner bring-up, periods of the main
//! loop, and short busy-wait delays. The counter wraps every 2³² cycles (23.9 s at 180 MHz):
//! every interval measured here is shorter.

use embedded_hal::delay::DelayNs;
use stm32f4xx_hal::dwt::{Instant, MonoTimer};

/// The cycle counter and its frequency.
#[derive(Clone, Copy)]
pub struct Clock {
    timer: MonoTimer,
}

impl Clock {
    /// Wraps a started `MonoTimer` (which enabled the DWT cycle counter).
    pub fn new(timer: MonoTimer) -> Self {
        Self { timer }
    }

    /// Now, for [`Clock::elapsed_ms`].
    pub fn now(&self) -> Instant {
        self.timer.now()
    }

    /// Milliseconds since `since` (intervals below 23 s).
    pub fn elapsed_ms(&self, since: Instant) -> u32 {
        let per_ms = (self.timer.frequency().raw() / 1000).max(1);
        since.elapsed() / per_ms
    }
}

impl DelayNs for Clock {
    fn delay_ns(&mut self, ns: u32) {
        let start = self.timer.now();
        let hz = u64::from(self.timer.frequency().raw());
        let ticks = (u64::from(ns) * hz).div_ceil(1_000_000_000);
        let ticks = u32::try_from(ticks)
            .unwrap_or(u32::MAX / 2)
            .min(u32::MAX / 2);
        while start.elapsed() < ticks {}
    }
}
