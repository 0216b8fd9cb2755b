//! The stack's high-water mark.
//!
//! `cortex-m-rt`'s `paint-stack` feature fills the stack region `_stack_end .. _stack_start`
//! with [`cortex_m_rt::STACK_PAINT_VALUE`] in the reset handler's assembly, before any Rust
//! runs (so no Rust code touches memory it does not own). Later, [`usage`] counts the painted
//! words that are still intact, from the bottom of the region up to the current stack
//! pointer: the words above the first overwritten one have been used at some time.
//!
//! The only module of this crate with `unsafe`: volatile reads of stack words strictly below
//! the current stack pointer, which no live Rust object occupies. An interrupt may push a frame
//! there meanwhile; the volatile read only sees a word.

use core::ptr::{addr_of, read_volatile};

extern "C" {
    /// The top of the stack (the initial stack pointer), from the linker script.
    static _stack_start: u32;
    /// The bottom of the stack region (the end of the statics), from the linker script.
    static _stack_end: u32;
}

/// The stack as measured now, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct StackUsage {
    /// The size of the stack region: everything from the end of the statics to the top of RAM.
    pub size: u32,
    /// The deepest the stack has ever reached (the high-water mark).
    pub used: u32,
    /// Painted words never touched, from the bottom of the region: the margin left.
    pub untouched: u32,
}

/// Measures the stack: call it from a shallow frame (the end of `main`).
#[must_use]
pub fn usage() -> StackUsage {
    let top = addr_of!(_stack_start) as usize;
    let bottom = addr_of!(_stack_end) as usize;
    // Only words below the current stack pointer (minus a word of slack) are read.
    let sp = cortex_m::register::msp::read() as usize;
    // `max`/`min` rather than `clamp`: the linker script puts `_stack_end` below
    // `_stack_start`, and `clamp` would carry a panic (and this file's path) for the case
    // where it did not.
    let limit = sp.saturating_sub(4).max(bottom).min(top);
    let mut address = bottom;
    while address + 4 <= limit {
        // SAFETY: `address` is word-aligned (the linker script aligns `_stack_end` to 4) and
        // lies in RAM between the end of the statics and the current stack pointer: memory
        // that belongs to no Rust object, read without creating a reference.
        let word = unsafe { read_volatile(address as *const u32) };
        if word != cortex_m_rt::STACK_PAINT_VALUE {
            break;
        }
        address += 4;
    }
    let size = top.saturating_sub(bottom);
    let untouched = address - bottom;
    let as_u32 = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    StackUsage {
        size: as_u32(size),
        used: as_u32(size - untouched),
        untouched: as_u32(untouched),
    }
}
