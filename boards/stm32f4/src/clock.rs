//! Time from the DWT cycle counter: timeouts for the scanner bring-up, periods of the main
//! loop, and short busy-wait delays. The counter wraps every 2³² cycles (23.9 s at 180 MHz):
//! every interval measured here is shorter.
//!
//! And the board's clocks for the core: SysTick's milliseconds ([`MILLIS`], the link's) and
//! microseconds ([`micros`], the laser bytes' and the servo's), wrapping.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::SYST;
use embedded_hal::delay::DelayNs;
use stm32f4xx_hal::dwt::{Instant, MonoTimer};

/// Milliseconds since SysTick started, wrapping; the SysTick handler is its only writer.
pub static MILLIS: AtomicU32 = AtomicU32::new(0);

/// Core cycles per millisecond (SysTick's reload + 1), set once before SysTick starts.
static CYCLES_PER_MS: AtomicU32 = AtomicU32::new(180_000);

/// Records SysTick's period in core cycles per millisecond (before it starts).
pub fn set_cycles_per_ms(cycles: u32) {
    CYCLES_PER_MS.store(cycles.max(1_000), Ordering::Relaxed);
}

/// Microseconds since SysTick started, wrapping every 2³² µs (71.6 minutes): the
/// milliseconds and what SysTick has counted down of the current one, read again if a tick
/// intervened. Callable from interrupts (it only reads).
pub fn micros() -> u32 {
    let per_ms = CYCLES_PER_MS.load(Ordering::Relaxed);
    let per_us = (per_ms / 1_000).max(1);
    loop {
        let ms = MILLIS.load(Ordering::Relaxed);
        let down = SYST::get_current();
        if MILLIS.load(Ordering::Relaxed) == ms {
            let within = per_ms.saturating_sub(1).saturating_sub(down) / per_us;
            return ms.wrapping_mul(1_000).wrapping_add(within.min(999));
        }
    }
}

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
