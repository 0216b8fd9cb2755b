//! Time from SysTick: the link's milliseconds, timeouts for the scanner bring-up, periods of
//! the main loop, and short busy-wait delays.
//!
//! SysTick interrupts at 1 kHz from the core clock that [`crate::rcc::start`] reported, and
//! its handler counts milliseconds ([`millis`], wrapping after 49.7 days; every interval
//! measured here is shorter). Not DWT's cycle counter: QEMU does not model the DWT (its
//! registers read 0, so a timeout on it would never expire), and SysTick is the one timer
//! the firmware needs on both the board and the emulator. Busy-wait delays count
//! instructions (`cortex_m::asm::delay`, at least the cycles asked for). [`micros`] adds what
//! SysTick has counted down of the current millisecond: the laser bytes' and the servo's time.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use embedded_hal::delay::DelayNs;

/// Milliseconds since SysTick started, wrapping.
static MILLIS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    MILLIS.fetch_add(1, Ordering::Relaxed);
}

/// Core cycles per millisecond (SysTick's reload + 1), set by [`start`].
static CYCLES_PER_MS: AtomicU32 = AtomicU32::new(180_000);

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

/// Milliseconds since [`start`], wrapping: the link's time base.
pub fn millis() -> u32 {
    MILLIS.load(Ordering::Relaxed)
}

/// A point in time, in [`millis`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Instant(u32);

/// The time source: SysTick's milliseconds and the core clock for delays.
#[derive(Debug, Clone, Copy)]
pub struct Clock {
    core_hz: u32,
}

/// Starts SysTick at 1 kHz from the core clock (`core_hz`, hertz, at most 2²⁴ kHz) and
/// returns the clock.
pub fn start(mut syst: SYST, core_hz: u32) -> Clock {
    let reload = (core_hz / 1000).clamp(2, 1 << 24) - 1;
    CYCLES_PER_MS.store((reload + 1).max(1_000), Ordering::Relaxed);
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    Clock { core_hz }
}

impl Clock {
    /// Now, for [`Clock::elapsed_ms`].
    pub fn now(&self) -> Instant {
        Instant(millis())
    }

    /// Milliseconds since `since` (intervals below 49 days).
    pub fn elapsed_ms(&self, since: Instant) -> u32 {
        millis().wrapping_sub(since.0)
    }
}

impl DelayNs for Clock {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = (u64::from(ns) * u64::from(self.core_hz)).div_ceil(1_000_000_000);
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX));
    }
}
