//! Milliseconds from TIMER0, polled: the link's time base.
//!
//! The nRF51's Cortex-M0 has no SysTick (QEMU's model adds one; code that used it would not
//! run on the part), so the time comes from TIMER0 (0x4000_8000) in timer mode, 32 bits wide,
//! prescaler 4: 16 MHz / 2⁴ = 1 MHz, one tick a microsecond. [`Clock::millis`] captures the
//! counter (TASKS_CAPTURE[0] → CC[0]) and counts its wraps (every 2³² µs, 71.6 minutes), so
//! the milliseconds wrap at 2³² ms as the link expects; it must be called at least once per
//! wrap period (the main loop calls it every step).
//!
//! Before the timer starts, the 16 MHz crystal (HFCLK from the XOSC) is requested (CLOCK
//! TASKS_HFCLKSTART, EVENTS_HFCLKSTARTED), with a bounded wait: on the RC oscillator alone the
//! timer would run up to ±5 % off. QEMU's CLOCK block is a stub whose registers read 1, so
//! the event is seen at once there.
//!
//! | register | address | use here |
//! | --- | --- | --- |
//! | CLOCK TASKS_HFCLKSTART | 0x4000_0000 | write 1: start the crystal |
//! | CLOCK EVENTS_HFCLKSTARTED | 0x4000_0100 | 1: the crystal runs |
//! | TIMER0 TASKS_START / TASKS_STOP / TASKS_CLEAR | 0x4000_8000 / 004 / 00C | write 1 |
//! | TIMER0 TASKS_CAPTURE[0] | 0x4000_8040 | write 1: copy the counter into CC[0] |
//! | TIMER0 INTENCLR | 0x4000_8308 | write 1s: no interrupts |
//! | TIMER0 MODE / BITMODE / PRESCALER | 0x4000_8504 / 508 / 510 | 0 timer / 3 32-bit / 4 |
//! | TIMER0 CC[0] | 0x4000_8540 | the captured counter, µs |
//!
//! QEMU 7.2 models TIMER0-2 (`hw/timer/nrf51_timer.c`: the tasks, CC, BITMODE, PRESCALER, the
//! counter from its virtual clock, which follows the host's wall clock).

use core::ptr::{read_volatile, write_volatile};

const CLOCK_TASKS_HFCLKSTART: usize = 0x4000_0000;
const CLOCK_EVENTS_HFCLKSTARTED: usize = 0x4000_0100;
const TIMER0: usize = 0x4000_8000;
const TASKS_START: usize = 0x000;
const TASKS_STOP: usize = 0x004;
const TASKS_CLEAR: usize = 0x00C;
const TASKS_CAPTURE0: usize = 0x040;
const INTENCLR: usize = 0x308;
const MODE: usize = 0x504;
const BITMODE: usize = 0x508;
const PRESCALER: usize = 0x510;
const CC0: usize = 0x540;

const MODE_TIMER: u32 = 0;
const BITMODE_32: u32 = 3;
/// 16 MHz / 2⁴: 1 MHz.
const PRESCALER_1MHZ: u32 = 4;
/// Loop iterations to wait for the crystal (each at least 4 cycles at 16 MHz: at least 5 ms;
/// the nRF51822's crystal starts in well under 1 ms).
const HFCLK_SPINS: u32 = 20_000;

fn read(address: usize) -> u32 {
    // SAFETY: an aligned 32-bit register of the CLOCK or TIMER0 block (addresses above),
    // always mapped on the nRF51 (and in QEMU's `microbit`); reading has no side effect.
    unsafe { read_volatile(address as *const u32) }
}

fn write(address: usize, value: u32) {
    // SAFETY: as in `read`; the `Clock` (made once, by `Clock::start`) is the only user of
    // these registers, and a write changes the timer, not memory Rust owns.
    unsafe { write_volatile(address as *mut u32, value) }
}

/// TIMER0 counting microseconds, and the wraps seen.
#[derive(Debug)]
pub struct Clock {
    last_us: u32,
    wraps: u32,
    /// Whether the crystal reported it runs.
    pub crystal: bool,
}

impl Clock {
    /// Starts the crystal (bounded wait) and TIMER0 at 1 MHz from 0. Call it once.
    #[must_use]
    pub fn start() -> Self {
        write(CLOCK_TASKS_HFCLKSTART, 1);
        let crystal = (0..HFCLK_SPINS).any(|_| read(CLOCK_EVENTS_HFCLKSTARTED) != 0);
        write(TIMER0 + TASKS_STOP, 1);
        write(TIMER0 + INTENCLR, u32::MAX);
        write(TIMER0 + MODE, MODE_TIMER);
        write(TIMER0 + BITMODE, BITMODE_32);
        write(TIMER0 + PRESCALER, PRESCALER_1MHZ);
        write(TIMER0 + TASKS_CLEAR, 1);
        write(TIMER0 + TASKS_START, 1);
        Self {
            last_us: 0,
            wraps: 0,
            crystal,
        }
    }

    /// Microseconds since [`Clock::start`] (64 bits: they do not wrap).
    pub fn micros(&mut self) -> u64 {
        write(TIMER0 + TASKS_CAPTURE0, 1);
        let now = read(TIMER0 + CC0);
        if now < self.last_us {
            self.wraps = self.wraps.wrapping_add(1);
        }
        self.last_us = now;
        (u64::from(self.wraps) << 32) | u64::from(now)
    }

    /// Milliseconds since [`Clock::start`], wrapping at 2³²: the link's time.
    pub fn millis(&mut self) -> u32 {
        // The low 32 bits: the wrap the link expects.
        #[allow(clippy::cast_possible_truncation)]
        let ms = (self.micros() / 1000) as u32;
        ms
    }
}
