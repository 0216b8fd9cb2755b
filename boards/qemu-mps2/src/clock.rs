//! The board's microsecond clock: the MPS2 FPGA system control block's prescaled counter
//! (`COUNTER`, AN385/AN386 application notes; QEMU's `mps2-fpgaio` at `0x4002_8000`), counting
//! the 25 MHz reference clock divided by 25.
//!
//! QEMU computes the counter from its virtual clock when it is read, and its virtual clock
//! follows the host's wall clock (no `-icount`): no interrupt is involved, so a busy host that
//! delays the emulator's timers loses no time. A clock counted by SysTick's interrupt does:
//! QEMU raises a late tick's exception once however many periods were missed, and on a
//! loaded machine the count fell behind the wall clock by up to a sixth.
//!
//! This module (with [`crate::uart`] and [`crate::stack`]) holds `unsafe`: volatile accesses
//! to the block's two registers.
use core::ptr::{read_volatile, write_volatile};

/// The FPGA system control block's base address.
const FPGAIO: usize = 0x4002_8000;
/// `COUNTER`: incremented each time the prescaler wraps.
const COUNTER: usize = FPGAIO + 0x18;
/// `PRESCALE`: the prescaler's reload value (it counts the reference clock).
const PRESCALE: usize = FPGAIO + 0x1c;
/// The reference clock the prescaler counts, Hz.
const REFERENCE_HZ: u32 = 25_000_000;

/// Starts the clock at 0: the prescaler wraps every microsecond.
pub fn start() {
    // SAFETY: PRESCALE and COUNTER are the FPGA block's registers on every MPS2 image; 32-bit
    // aligned, no other code touches them.
    unsafe {
        write_volatile(PRESCALE as *mut u32, REFERENCE_HZ / 1_000_000 - 1);
        write_volatile(COUNTER as *mut u32, 0);
    }
}

/// Microseconds since [`start`], wrapping every 2³² µs (71.6 minutes).
#[must_use]
pub fn micros() -> u32 {
    // SAFETY: as in `start`; reading COUNTER has no side effect on the hardware.
    unsafe { read_volatile(COUNTER as *const u32) }
}
