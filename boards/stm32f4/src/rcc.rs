//! Clock start-up that cannot hang: the oscillators and the PLL are tried with time-outs
//! counted in loop iterations (no clock is trusted yet), the first ready flag that never comes
//! selects a fallback, and the result says which clock the core runs on.
//!
//! The order, on the NUCLEO-F446RE (the ST-LINK feeds 8 MHz from its MCO into OSC_IN):
//!
//! 1. **HSE bypass** (HSEBYP, HSEON; wait HSERDY). A missing MCO (solder bridges, an ST-LINK
//!    without MCO firmware) times out: HSE off, the PLL takes the HSI instead.
//! 2. **The PLL** from the chosen source, probed: configured to the target, PLLON, wait
//!    PLLRDY. A PLL that does not lock from the HSE is tried once more from the HSI.
//! 3. **Over-drive** (F446 only, needed above 168 MHz): PWREN, ODEN, wait ODRDY, ODSWEN, wait
//!    ODSWRDY. Without it the target drops to 168 MHz.
//! 4. The probe's PLL is stopped again (PLLON cleared, wait until PLLRDY clears), and
//!    `stm32f4xx-hal`'s `Rcc::freeze` builds the real configuration: it programs the flash
//!    wait states, the PLL and the bus prescalers and waits for the same flags, which the
//!    probe has just seen come, and its `Clocks` hold the frequencies every HAL driver
//!    (USART baud-rate divisors, SPI prescaler) computes from.
//! 5. If no PLL locks, the core stays on the HSI at 16 MHz, the reset state, and the HAL gets
//!    `constrain()`'s 16 MHz clocks, which are then the truth.
//!
//! **Why the HAL's `freeze` stays on the happy path, behind the probe.** `freeze` waits for
//! HSERDY, PLLRDY and the over-drive flags in unbounded loops, so it cannot be the one to
//! find out whether they come; but its `Clocks` cannot be built any other way (their fields
//! are private to the HAL), and every HAL driver derives its dividers from them. Programming
//! the whole tree here and handing the HAL `constrain()`'s 16 MHz would leave each USART's
//! BRR and the SPI prescaler wrong by the ratio of the real clock. So the probe decides, with
//! time-outs, and `freeze` is only called for a configuration whose every flag has been seen.
//!
//! **An RCC that reads all zeros** (QEMU's `netduinoplus2`, whose RCC is an unimplemented
//! region) shows no ready flag at all, not even HSIRDY, which silicon sets from reset on
//! (the core runs on the HSI then). The start-up reports [`Source::UnmodelledRcc`] and takes
//! the core clock as [`UNMODELLED_RCC_CORE_HZ`], the fixed clock QEMU runs that machine's
//! core and SysTick at; the HAL keeps `constrain()`'s clocks (QEMU's USARTs ignore BRR).
//!
//! The loop bounds: each iteration is a volatile load from the RCC or PWR (over AHB/APB),
//! a test, a branch and an increment, at least 5 core cycles on a Cortex-M4, at 16 MHz
//! (the HSI, the clock during start-up) at least 312 ns. So [`HSE_SPINS`] waits at least
//! 100 ms, ST's own HSE start-up time-out; [`PLL_SPINS`] and [`OVERDRIVE_SPINS`] at least
//! 10 ms, far beyond the datasheets' lock and switch times (well under 1 ms).

use stm32f4xx_hal::pac::RCC;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Rcc, RccExt};
use terrain_pyramid::wire::link::ClockSource;

use crate::hw::{self, Reg};

/// The HSE frequency: the ST-LINK's MCO on the NUCLEO-F446RE, hertz.
pub const HSE_HZ: u32 = 8_000_000;
/// The HSI's frequency, hertz.
pub const HSI_HZ: u32 = 16_000_000;
/// The core clock of an STM32F4 whose RCC reads all zeros: QEMU's `netduinoplus2` clocks its
/// core (and SysTick) at a fixed 168 MHz whatever the RCC is told (`SYSCLK_FRQ` in QEMU's
/// `hw/arm/netduinoplus2.c`), hertz.
pub const UNMODELLED_RCC_CORE_HZ: u32 = 168_000_000;

/// The target system clock, hertz: the part's maximum.
#[cfg(feature = "chip-f446")]
pub const TARGET_HZ: u32 = 180_000_000;
/// The target system clock, hertz: the part's maximum.
#[cfg(feature = "chip-f405")]
pub const TARGET_HZ: u32 = 168_000_000;
/// The highest system clock without the regulator's over-drive, hertz.
pub const NO_OVERDRIVE_HZ: u32 = 168_000_000;

/// Iterations to wait for HSERDY (at least 100 ms at 16 MHz, see the module documentation).
pub const HSE_SPINS: u32 = 320_000;
/// Iterations to wait for PLLRDY to set or to clear (at least 10 ms).
pub const PLL_SPINS: u32 = 32_000;
/// Iterations to wait for ODRDY and for ODSWRDY (at least 10 ms each).
#[cfg(feature = "chip-f446")]
pub const OVERDRIVE_SPINS: u32 = 32_000;

const CR_HSION: u32 = 1 << 0;
const CR_HSIRDY: u32 = 1 << 1;
const CR_HSEON: u32 = 1 << 16;
const CR_HSERDY: u32 = 1 << 17;
const CR_HSEBYP: u32 = 1 << 18;
const CR_PLLON: u32 = 1 << 24;
const CR_PLLRDY: u32 = 1 << 25;
const PLLCFGR_SRC_HSE: u32 = 1 << 22;
#[cfg(feature = "chip-f446")]
const APB1ENR_PWREN: u32 = 1 << 28;
#[cfg(feature = "chip-f446")]
const PWR_CR_ODEN: u32 = 1 << 16;
#[cfg(feature = "chip-f446")]
const PWR_CR_ODSWEN: u32 = 1 << 17;
#[cfg(feature = "chip-f446")]
const PWR_CSR_ODRDY: u32 = 1 << 16;
#[cfg(feature = "chip-f446")]
const PWR_CSR_ODSWRDY: u32 = 1 << 17;

/// The clock the core runs on after [`start`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Source {
    /// The PLL from the HSE (bypass, the ST-LINK's 8 MHz): the intended configuration.
    HsePll,
    /// The PLL from the HSI (16 MHz RC, ±1 % at 25 °C): the HSE never became ready.
    HsiPll,
    /// The HSI itself, 16 MHz: no PLL locked.
    Hsi,
    /// The RCC reads all zeros (no ready flag, not even the HSI's): an emulator. The core
    /// clock is [`UNMODELLED_RCC_CORE_HZ`].
    UnmodelledRcc,
}

impl Source {
    /// The source as Hello reports it to the host.
    #[must_use]
    pub const fn reported(self) -> ClockSource {
        match self {
            Self::HsePll => ClockSource::External,
            Self::HsiPll => ClockSource::InternalPll,
            Self::Hsi => ClockSource::Internal,
            Self::UnmodelledRcc => ClockSource::Unmodelled,
        }
    }
}

/// Ready flags that never came during [`start`], as bits of [`Started::timeouts`].
pub mod timeout {
    /// HSERDY (the HSE in bypass).
    pub const HSE: u8 = 1 << 0;
    /// PLLRDY with the HSE as source.
    pub const PLL_FROM_HSE: u8 = 1 << 1;
    /// PLLRDY with the HSI as source.
    pub const PLL_FROM_HSI: u8 = 1 << 2;
    /// ODRDY or ODSWRDY (F446 over-drive).
    pub const OVERDRIVE: u8 = 1 << 3;
    /// PLLRDY did not clear after PLLON was cleared.
    pub const PLL_STOP: u8 = 1 << 4;
    /// HSIRDY is clear although the core runs: the RCC is not modelled.
    pub const HSI: u8 = 1 << 5;
}

/// What [`start`] did: the clock the core runs on and its frequencies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct Started {
    /// The clock source.
    pub source: Source,
    /// The core clock (SysTick's, the cycle counter's), hertz: the HAL's SYSCLK, or
    /// [`UNMODELLED_RCC_CORE_HZ`] with [`Source::UnmodelledRcc`].
    pub core_hz: u32,
    /// APB1's clock (USART2's), hertz, as the HAL uses it for divisors.
    pub pclk1_hz: u32,
    /// APB2's clock (USART1's, SPI1's), hertz, as the HAL uses it for divisors.
    pub pclk2_hz: u32,
    /// The ready flags that never came ([`timeout`] bits).
    pub timeouts: u8,
    /// Iterations HSERDY took (0 if it never came).
    pub hse_spins: u32,
}

/// Waits until `ready()` holds, at most `spins` iterations; returns the iterations taken.
fn wait(spins: u32, ready: impl Fn() -> bool) -> Option<u32> {
    (0..spins).find(|_| ready())
}

fn cr_has(bits: u32) -> bool {
    hw::read(Reg::RccCr) & bits == bits
}

/// HSE in bypass: HSEBYP (only while HSEON is clear), HSEON, wait HSERDY. Turned off again
/// when it does not come.
fn start_hse() -> Option<u32> {
    hw::modify(Reg::RccCr, CR_HSEON, 0);
    hw::modify(Reg::RccCr, 0, CR_HSEBYP);
    hw::modify(Reg::RccCr, 0, CR_HSEON);
    let spins = wait(HSE_SPINS, || cr_has(CR_HSERDY));
    if spins.is_none() {
        hw::modify(Reg::RccCr, CR_HSEON, 0);
        hw::modify(Reg::RccCr, CR_HSEBYP, 0);
    }
    spins
}

/// PLLCFGR for `target_hz` from a source of `source_hz`: a 2 MHz VCO input (M), the VCO at
/// twice the target (N), P = 2, Q = 7, R = 2 (the F446's reset value; the F405 ignores it).
fn pllcfgr(source_hz: u32, hse: bool, target_hz: u32) -> u32 {
    let m = source_hz / 2_000_000;
    let n = target_hz / 1_000_000;
    let (p_bits, q, r) = (0b00, 7, 2);
    let src = if hse { PLLCFGR_SRC_HSE } else { 0 };
    (r << 28) | (q << 24) | src | (p_bits << 16) | (n << 6) | m
}

/// Configures the PLL (which must be off) and waits for it to lock; stops it again when it
/// does not.
fn probe_pll(hse: bool, target_hz: u32) -> bool {
    let source_hz = if hse { HSE_HZ } else { HSI_HZ };
    hw::modify(Reg::RccCr, CR_PLLON, 0);
    hw::write(Reg::RccPllcfgr, pllcfgr(source_hz, hse, target_hz));
    hw::modify(Reg::RccCr, 0, CR_PLLON);
    if wait(PLL_SPINS, || cr_has(CR_PLLRDY)).is_some() {
        return true;
    }
    hw::modify(Reg::RccCr, CR_PLLON, 0);
    false
}

/// The regulator's over-drive (F446, above 168 MHz), with the PLL on: whether it is ready.
#[cfg(feature = "chip-f446")]
fn start_overdrive() -> bool {
    hw::modify(Reg::RccApb1enr, 0, APB1ENR_PWREN);
    // The enable takes effect after a bus cycle (erratum 2.1.13 of ES0298): read it back.
    let _ = hw::read(Reg::RccApb1enr);
    hw::modify(Reg::PwrCr, 0, PWR_CR_ODEN);
    let csr_has = |bits: u32| hw::read(Reg::PwrCsr) & bits == bits;
    if wait(OVERDRIVE_SPINS, || csr_has(PWR_CSR_ODRDY)).is_none() {
        hw::modify(Reg::PwrCr, PWR_CR_ODEN, 0);
        return false;
    }
    hw::modify(Reg::PwrCr, 0, PWR_CR_ODSWEN);
    if wait(OVERDRIVE_SPINS, || csr_has(PWR_CSR_ODSWRDY)).is_none() {
        hw::modify(Reg::PwrCr, PWR_CR_ODEN | PWR_CR_ODSWEN, 0);
        return false;
    }
    true
}

/// The F405 has no over-drive: its target is 168 MHz already.
#[cfg(feature = "chip-f405")]
fn start_overdrive() -> bool {
    true
}

/// Stops the probe's PLL, so that the HAL can program it (PLLCFGR may only be written while
/// the PLL is off).
fn stop_pll() -> bool {
    hw::modify(Reg::RccCr, CR_PLLON, 0);
    wait(PLL_SPINS, || !cr_has(CR_PLLRDY)).is_some()
}

/// The HAL's configuration for a PLL at `sysclk_hz` from the HSE (bypass) or the HSI, with
/// APB1 at a quarter and APB2 at half the system clock (45 and 90 MHz at 180 MHz: USART1 at
/// 500 kBd divides exactly).
fn hal_config(hse: bool, sysclk_hz: u32) -> Config {
    let base = if hse {
        Config::hse(HSE_HZ.Hz()).bypass_hse_oscillator()
    } else {
        Config::hsi()
    };
    base.sysclk(sysclk_hz.Hz())
        .pclk1((sysclk_hz / 4).Hz())
        .pclk2((sysclk_hz / 2).Hz())
}

/// Starts the clocks (see the module documentation) and hands the RCC to the HAL: the HAL's
/// `Rcc` (its `clocks` are the frequencies in force) and what happened. Never hangs: every
/// wait is bounded.
pub fn start(rcc: RCC) -> (Rcc, Started) {
    let mut timeouts = 0;
    let hse_spins = start_hse();
    if hse_spins.is_none() {
        timeouts |= timeout::HSE;
    }
    let mut hse = hse_spins.is_some();
    let mut locked = probe_pll(hse, TARGET_HZ);
    if !locked && hse {
        timeouts |= timeout::PLL_FROM_HSE;
        hw::modify(Reg::RccCr, CR_HSEON, 0);
        hse = false;
        locked = probe_pll(false, TARGET_HZ);
    }
    if !locked {
        timeouts |= timeout::PLL_FROM_HSI;
    }
    let mut target = TARGET_HZ;
    if locked && TARGET_HZ > NO_OVERDRIVE_HZ && !start_overdrive() {
        timeouts |= timeout::OVERDRIVE;
        target = NO_OVERDRIVE_HZ;
    }
    if locked && !stop_pll() {
        timeouts |= timeout::PLL_STOP;
        locked = false;
    }
    let (rcc, source) = if locked {
        let source = if hse { Source::HsePll } else { Source::HsiPll };
        (rcc.freeze(hal_config(hse, target)), source)
    } else {
        // The reset state: the HSI at 16 MHz, no prescaler.
        hw::modify(Reg::RccCr, CR_HSEON, 0);
        let source = if cr_has(CR_HSION | CR_HSIRDY) {
            Source::Hsi
        } else {
            timeouts |= timeout::HSI;
            Source::UnmodelledRcc
        };
        (rcc.constrain(), source)
    };
    let clocks = rcc.clocks;
    let core_hz = match source {
        Source::UnmodelledRcc => UNMODELLED_RCC_CORE_HZ,
        _ => clocks.sysclk().raw(),
    };
    let started = Started {
        source,
        core_hz,
        pclk1_hz: clocks.pclk1().raw(),
        pclk2_hz: clocks.pclk2().raw(),
        timeouts,
        hse_spins: hse_spins.unwrap_or(0),
    };
    (rcc, started)
}
