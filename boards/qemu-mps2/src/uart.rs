//! The CMSDK APB UARTs of the MPS2 boards, behind `embedded-io` 0.6.
//!
//! This is the crate's register module: the only place (with [`crate::stack`]'s read of the
//! painted stack and [`crate::clock`]) that holds `unsafe`, and only for volatile accesses to
//! the five registers of a UART at a fixed, board-defined address and for unmasking the two
//! receive interrupts in the NVIC.
//!
//! | offset | register            | bits used                                              |
//! | ------ | ------------------- | ------------------------------------------------------ |
//! | 0x00   | DATA                | 7..0: read takes the received byte, write sends one    |
//! | 0x04   | STATE               | 0 TX full, 1 RX full, 2 TX overrun, 3 RX overrun (w1c) |
//! | 0x08   | CTRL                | 0 TX enable, 1 RX enable, 3 RX interrupt enable        |
//! | 0x0C   | INTSTATUS/INTCLEAR  | 1 RX interrupt (w1c)                                   |
//! | 0x10   | BAUDDIV             | PCLK / baud, at least 16                               |
//!
//! The UART has a one-byte buffer each way. [`embedded_io::Read::read`] returns what is
//! available now (often a single byte: the UART holds one) and blocks only until at least one
//! byte has arrived; [`embedded_io::ReadReady::read_ready`] says whether it would block. A
//! byte lost because the previous one was not read in time (RX overrun) is reported once as
//! [`UartError::Overrun`].
//!
//! Reading is polled; the receive interrupts only wake the core. After
//! [`Uarts::wake_on_receive`] a byte's arrival raises its UART's receive interrupt (IRQ 0 for
//! UART0, 2 for UART1 on the MPS2 images), whose handler ([`acknowledge_receive`], called by
//! the crate's `DefaultHandler`) only clears it: the main loop can sleep in `wfi` while both
//! UARTs are empty and read the byte when it wakes. Under QEMU a core that spins on the
//! status registers instead takes a whole host core while it waits.

pub use board_support::uart::UartError;
use board_support::uart::{claim_once, PolledRx};
use core::marker::PhantomData;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::AtomicBool;

/// The peripheral clock of the MPS2 FPGA images (AN385/AN386/AN500), hertz.
pub const PCLK_HZ: u32 = 25_000_000;

/// Base address of UART0 on the MPS2 boards.
pub const UART0_BASE: usize = 0x4000_4000;
/// Base address of UART1 on the MPS2 boards.
pub const UART1_BASE: usize = 0x4000_5000;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTCLEAR: usize = 0x0C;
const BAUDDIV: usize = 0x10;

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_RX_OVERRUN: u32 = 1 << 3;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
/// CTRL of an enabled UART: both directions on.
const ENABLED: u32 = CTRL_TX_EN | CTRL_RX_EN;
const INT_RX: u32 = 1 << 1;
/// UART0's receive interrupt on the MPS2 images (AN385/AN386/AN500).
const UART0_RX_IRQ: u16 = 0;
/// UART1's receive interrupt.
const UART1_RX_IRQ: u16 = 2;
/// The smallest divider the UART accepts.
const MIN_BAUDDIV: u32 = 16;

/// A CMSDK APB UART at base address `BASE`. Only [`Uarts::take`] makes one, once per UART,
/// so that each register block has a single owner.
#[derive(Debug)]
pub struct CmsdkUart<const BASE: usize> {
    /// Not `Sync`, not constructible outside this module.
    _owned: PhantomData<*const ()>,
}

/// UART0 (0x4000_4000): the laser's byte stream.
pub type Uart0 = CmsdkUart<UART0_BASE>;
/// UART1 (0x4000_5000): the link to the main computer.
pub type Uart1 = CmsdkUart<UART1_BASE>;

/// Both UARTs, enabled at the same baud rate.
#[derive(Debug)]
pub struct Uarts {
    /// UART0, the laser side.
    pub uart0: Uart0,
    /// UART1, the host side.
    pub uart1: Uart1,
}

static TAKEN: AtomicBool = AtomicBool::new(false);

impl Uarts {
    /// Enables both UARTs (TX and RX, polled, interrupts cleared) at `baud`, once: `None` on
    /// a second call. The divider is `PCLK_HZ / baud`, at least 16 (QEMU ignores the rate).
    pub fn take(baud: u32) -> Option<Self> {
        if !claim_once(&TAKEN) {
            return None;
        }
        let divider = (PCLK_HZ / baud.max(1)).max(MIN_BAUDDIV);
        let uart0 = Uart0::enable(divider);
        let uart1 = Uart1::enable(divider);
        Some(Self { uart0, uart1 })
    }

    /// Lets a received byte wake the core from `wfi`: enables both UARTs' receive interrupts
    /// and unmasks them in the NVIC. Their handler is [`acknowledge_receive`]; the bytes are
    /// still read by polling.
    pub fn wake_on_receive(&mut self) {
        self.uart0.interrupt_on_receive();
        self.uart1.interrupt_on_receive();
        for irq in [UART0_RX_IRQ, UART1_RX_IRQ] {
            // SAFETY: the only handler these interrupts reach is `acknowledge_receive` (through
            // the crate's `DefaultHandler`), which touches no memory but INTCLEAR, so unmasking
            // breaks no critical section's assumptions.
            unsafe { cortex_m::peripheral::NVIC::unmask(Irq(irq)) };
        }
    }
}

/// An external interrupt's number, for the NVIC.
#[derive(Debug, Clone, Copy)]
struct Irq(u16);

// SAFETY: the numbers are the MPS2 images' UART receive interrupts, valid NVIC lines.
unsafe impl cortex_m::interrupt::InterruptNumber for Irq {
    fn number(self) -> u16 {
        self.0
    }
}

/// The handler of the receive interrupts that [`Uarts::wake_on_receive`] enables: clears the
/// interrupt of external interrupt `irqn` when it is a UART's receive interrupt (the byte
/// stays in the UART for the main loop to read) and says whether it was one.
pub fn acknowledge_receive(irqn: i16) -> bool {
    match u16::try_from(irqn) {
        Ok(UART0_RX_IRQ) => Uart0::write_reg(INTCLEAR, INT_RX),
        Ok(UART1_RX_IRQ) => Uart1::write_reg(INTCLEAR, INT_RX),
        _ => return false,
    }
    true
}

impl<const BASE: usize> CmsdkUart<BASE> {
    fn read_reg(offset: usize) -> u32 {
        // SAFETY: BASE is one of the two UART blocks of the board (the only instances are the
        // `Uart0`/`Uart1` aliases), `offset` one of the register offsets above: an aligned,
        // always-mapped 32-bit device register with no side effect on memory Rust owns.
        unsafe { read_volatile((BASE + offset) as *const u32) }
    }

    fn write_reg(offset: usize, value: u32) {
        // SAFETY: as in `read_reg`; the owner of the `CmsdkUart` is the only writer.
        unsafe { write_volatile((BASE + offset) as *mut u32, value) }
    }

    fn enable(divider: u32) -> Self {
        Self::write_reg(CTRL, 0);
        Self::write_reg(BAUDDIV, divider);
        // Clear any stale interrupt and overrun flags (write one to clear).
        Self::write_reg(INTCLEAR, 0xF);
        Self::write_reg(STATE, 0xC);
        Self::write_reg(CTRL, ENABLED);
        Self {
            _owned: PhantomData,
        }
    }

    /// Raises the receive interrupt when a byte arrives (a stale one cleared first).
    fn interrupt_on_receive(&mut self) {
        Self::write_reg(INTCLEAR, INT_RX);
        Self::write_reg(CTRL, ENABLED | CTRL_RX_INT_EN);
    }

    fn state(&self) -> u32 {
        Self::read_reg(STATE)
    }

    /// Sets the baud rate: the divider `PCLK_HZ / baud`, at least 16 (QEMU ignores it; on
    /// the FPGA board it is the rate).
    pub fn set_baud(&mut self, baud: u32) {
        Self::write_reg(BAUDDIV, (PCLK_HZ / baud.max(1)).max(MIN_BAUDDIV));
    }

    /// Whether the transmitter can take a byte now.
    fn tx_ready(&self) -> bool {
        self.state() & STATE_TX_FULL == 0
    }
}

impl<const BASE: usize> PolledRx for CmsdkUart<BASE> {
    /// Checks and clears the RX overrun flag.
    fn take_overrun(&mut self) -> bool {
        if self.state() & STATE_RX_OVERRUN != 0 {
            Self::write_reg(STATE, STATE_RX_OVERRUN);
            true
        } else {
            false
        }
    }

    /// Takes the received byte if there is one.
    fn try_read_byte(&mut self) -> Option<u8> {
        if self.state() & STATE_RX_FULL == 0 {
            return None;
        }
        // The byte is in bits 7..0; the truncation keeps exactly them.
        #[allow(clippy::cast_possible_truncation)]
        Some(Self::read_reg(DATA) as u8)
    }

    fn rx_ready(&mut self) -> bool {
        self.state() & STATE_RX_FULL != 0
    }
}

board_support::impl_polled_read!([const BASE: usize] CmsdkUart<BASE>);

impl<const BASE: usize> embedded_io::WriteReady for CmsdkUart<BASE> {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.tx_ready())
    }
}

impl<const BASE: usize> embedded_io::Write for CmsdkUart<BASE> {
    /// Blocks until the first byte is taken (unless `buf` is empty), then sends as many more
    /// as the transmitter takes without waiting.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        let mut n = 0;
        for &byte in buf {
            if n > 0 && !self.tx_ready() {
                break;
            }
            while !self.tx_ready() {}
            Self::write_reg(DATA, u32::from(byte));
            n += 1;
        }
        Ok(n)
    }

    /// Waits until the transmitter has taken the last byte.
    fn flush(&mut self) -> Result<(), Self::Error> {
        while !self.tx_ready() {}
        Ok(())
    }
}
