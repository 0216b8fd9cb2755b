//! The crate's register module: the only place with `unsafe`.
//!
//! - Unmasking the two USART interrupts in the NVIC (`unsafe` in `cortex-m` because unmasking
//!   can break a critical section built on masking; this firmware's critical sections disable
//!   interrupts globally, so it cannot).
//! - The interrupt handlers' entry points (`#[interrupt]`), which hand over to [`crate::rx`].
//! - Volatile access to the five clock-tree registers [`crate::rcc`] drives itself ([`Reg`]).
//! - Under `log-semihosting`, the HardFault handler that ends an emulated run.
//! - Setting USART1's baud rate at run time (the laser the host's Setup names), while its
//!   receive half belongs to the interrupt.

use core::ptr::read_volatile;

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

/// The stack's high-water mark: `(used, size)` in bytes, the deepest the stack has been since
/// reset and the size of the stack region (RAM above the statics). Call it from the main loop.
pub fn stack_high_water() -> (u32, u32) {
    let usage = board_support::stack::usage();
    (usage.used, usage.size)
}

/// The clock-tree registers the start-up sequence ([`crate::rcc`]) drives itself, with their
/// addresses (RM0390 for the STM32F446, RM0090 for the STM32F405: the same offsets and bits
/// for everything used here; the over-drive bits exist on the F446 only).
///
/// | register | address | bits used |
/// | --- | --- | --- |
/// | `RCC_CR` | 0x4002_3800 | 0 HSION, 1 HSIRDY, 16 HSEON, 17 HSERDY, 18 HSEBYP, 24 PLLON, 25 PLLRDY |
/// | `RCC_PLLCFGR` | 0x4002_3804 | 5..0 PLLM, 14..6 PLLN, 17..16 PLLP, 22 PLLSRC, 27..24 PLLQ (F446: 30..28 PLLR) |
/// | `RCC_APB1ENR` | 0x4002_3840 | 28 PWREN |
/// | `PWR_CR` | 0x4000_7000 | 16 ODEN, 17 ODSWEN (F446) |
/// | `PWR_CSR` | 0x4000_7004 | 16 ODRDY, 17 ODSWRDY (F446) |
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "chip-f405", allow(dead_code))] // The F405 has no over-drive.
pub enum Reg {
    /// `RCC_CR`: oscillator and PLL enables and ready flags.
    RccCr,
    /// `RCC_PLLCFGR`: the main PLL's source and dividers.
    RccPllcfgr,
    /// `RCC_APB1ENR`: the APB1 clock enables (the PWR block's).
    RccApb1enr,
    /// `PWR_CR`: the regulator's over-drive enables.
    PwrCr,
    /// `PWR_CSR`: the regulator's over-drive ready flags.
    PwrCsr,
}

impl Reg {
    const fn address(self) -> usize {
        match self {
            Self::RccCr => 0x4002_3800,
            Self::RccPllcfgr => 0x4002_3804,
            Self::RccApb1enr => 0x4002_3840,
            Self::PwrCr => 0x4000_7000,
            Self::PwrCsr => 0x4000_7004,
        }
    }
}

/// Reads a clock-tree register.
pub fn read(reg: Reg) -> u32 {
    // SAFETY: one of the five aligned 32-bit registers of `Reg`, always mapped on the
    // STM32F4 (in QEMU's netduinoplus2 they are "unimplemented" regions that read 0); reading
    // has no side effect.
    unsafe { read_volatile(reg.address() as *const u32) }
}

/// Writes a clock-tree register. Only [`crate::rcc::start`] calls it, while it owns the RCC
/// (before the HAL gets it), so nothing else writes these registers meanwhile.
pub fn write(reg: Reg, value: u32) {
    // SAFETY: as in `read`; a write changes clocks, not memory Rust owns. The caller holds
    // the `RCC` peripheral by value, so no other code drives these registers concurrently.
    unsafe { core::ptr::write_volatile(reg.address() as *mut u32, value) }
}

/// Read-modify-write: clears the bits of `clear`, then sets those of `set`.
pub fn modify(reg: Reg, clear: u32, set: u32) {
    write(reg, (read(reg) & !clear) | set);
}

/// A HardFault ends an emulated run with exit code 102 (the stacked program counter logged:
/// [`board_support::runtime::hard_fault`]).
#[cfg(feature = "log-semihosting")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board_support::runtime::hard_fault(frame)
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
