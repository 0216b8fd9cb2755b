//! The crate's register module: the only place with `unsafe`.
//!
//! - Unmasking the two USART interrupts in the NVIC (`unsafe` in `cortex-m` because unmasking
//!   can break a critical section built on masking; this firmware's critical sections disable
//!   interrupts globally, so it cannot).
//! - The interrupt handlers' entry points (`#[interrupt]`), which hand over to [`crate::rx`].
//! - Reading the painted stack for its high-water mark (`cortex-m-rt`'s `paint-stack` fills
//!   the stack with a pattern in the reset handler, before any Rust runs).

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
