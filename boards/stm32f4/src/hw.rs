//! The crate's register module: the only place with `unsafe`.
//!
//! - Unmasking the two USART interrupts in the NVIC (`unsafe` in `cortex-m` because unmasking
//!   can break a critical section built on masking; this firmware's critical sections disable
//!   interrupts globally, so it cannot).
//! - The interrupt handlers' entry points (`#[interrupt]`), which hand over to [`crate::rx`].
//! - Reading the painted stack for its high-water mark (`cortex-m-rt`'s `paint-stack` fills
//!   the stack with a pattern in the reset handler, before any Rust runs).
//! - Setting USART1's baud rate at run time (the laser the host's Setup names), while its
//!   receive half belongs to the interrupt.

use core::ptr::{addr_of, read_volatile};

use stm32f4xx_hal::pac::{self, interrupt};

/// Lets USART1 (laser) and USART2 (host) interrupts through the NVIC. Their sources (RXNE)
/// are enabled by the `Rx` handles handed to [`crate::rx`].
pub fn unmask_usart_interrupts() {
    // SAFETY: the handlers below only take `critical_section::with` (PRIMASK), never rely on
    // these interrupts staying masked, and the state they touch is installed before this.
    unsafe {
        pac::NVIC::unmask(pac::Interrupt::USART1);
        pac::NVIC::unmask(pac::Interrupt::USART2);
    }
}

#[interrupt]
fn USART1() {
    crate::rx::on_laser_interrupt();
}

#[interrupt]
fn USART2() {
    crate::rx::on_host_interrupt();
}

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The stack's high-water mark: `(used, size)` in bytes, the deepest the stack has been since
/// reset and the size of the stack region (RAM above the statics). Call it from the main loop.
pub fn stack_high_water() -> (u32, u32) {
    let top = addr_of!(_stack_start) as usize;
    let bottom = addr_of!(_stack_end) as usize;
    let limit = (cortex_m::register::msp::read() as usize)
        .saturating_sub(4)
        .clamp(bottom, top);
    let mut address = bottom;
    while address + 4 <= limit {
        // SAFETY: word-aligned (the linker script aligns `_stack_end`), in RAM between the end
        // of the statics and the current stack pointer: memory no Rust object occupies. An
        // interrupt may push a frame there meanwhile; the volatile read only sees a word.
        let word = unsafe { read_volatile(address as *const u32) };
        if word != cortex_m_rt::STACK_PAINT_VALUE {
            break;
        }
        address += 4;
    }
    let size = top.saturating_sub(bottom);
    let used = size - (address - bottom);
    let as_u32 = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    (as_u32(used), as_u32(size))
}

/// Sets USART1 to `baud` (8N1 unchanged) from its clock `pclk2_hz`: the USART is disabled,
/// oversampling by 16 chosen, the divider `round(pclk2 / baud)` written, the USART enabled
/// again. A byte in flight is lost (the laser's decoder resynchronises). At 90 MHz: 230 400 Bd
/// → 391 (+0.1 %), 115 200 → 781 (+0.03 %), 128 000 → 703 (+0.01 %), 500 000 → 180 (exact).
pub fn set_usart1_baud(pclk2_hz: u32, baud: u32) {
    let divider = (pclk2_hz + baud.max(1) / 2) / baud.max(1);
    // The divider's 16 bits (12 mantissa, 4 fraction); at least 16 (one mantissa unit).
    let divider = u16::try_from(divider.clamp(16, 0xFFFF)).unwrap_or(u16::MAX);
    // SAFETY: USART1's register block at its fixed address. The main loop is its only writer
    // of CR1 and BRR (the HAL's `Rx` in the interrupt reads SR and DR only, and clears RXNE by
    // reading); the writes below touch UE, OVER8 and the divider, nothing Rust owns.
    let usart = unsafe { &*pac::USART1::ptr() };
    usart
        .cr1()
        .modify(|_, w| w.ue().clear_bit().over8().clear_bit());
    // SAFETY: any 16-bit value is a valid divider (the reference manual's BRR); it was
    // clamped above.
    usart.brr().write(|w| unsafe { w.bits(divider) });
    usart.cr1().modify(|_, w| w.ue().set_bit());
}
