//! The nRF51's UART (the one at 0x4000_2000), polled, behind `embedded-io` 0.6.
//!
//! This is the crate's register module: the only place (with [`crate::stack`]'s read of the
//! painted stack) that holds `unsafe`, and only for volatile accesses to the registers below
//! (nRF51 Series Reference Manual v3.0, chapter 29; the same offsets in QEMU's
//! `include/hw/char/nrf51_uart.h`).
//!
//! | offset | register | use here |
//! | --- | --- | --- |
//! | 0x000 | TASKS_STARTRX | write 1: start the receiver |
//! | 0x008 | TASKS_STARTTX | write 1: start the transmitter |
//! | 0x108 | EVENTS_RXDRDY | 1: a byte is in RXD; write 0 to clear (before reading RXD) |
//! | 0x11C | EVENTS_TXDRDY | 1: the byte written to TXD has gone; write 0 to clear |
//! | 0x124 | EVENTS_ERROR | 1: see ERRORSRC; write 0 to clear |
//! | 0x308 | INTENCLR | write 1s: interrupts off (they are not used: the UART is polled) |
//! | 0x480 | ERRORSRC | 0 overrun, 1 parity, 2 framing, 3 break; write 1s to clear |
//! | 0x500 | ENABLE | 4: enabled |
//! | 0x50C / 0x514 | PSELTXD / PSELRXD | the pins: P0.24 (TX) and P0.25 (RX) on the micro:bit |
//! | 0x518 | RXD | the received byte (reading takes it from the six-byte FIFO) |
//! | 0x51C | TXD | the byte to send |
//! | 0x524 | BAUDRATE | 0x01D7_E000: 115 200 Bd |
//! | 0x56C | CONFIG | 0: no flow control, no parity |
//!
//! What QEMU 7.2 models (`hw/char/nrf51_uart.c`): the tasks, the RXDRDY, TXDRDY, ERROR and RXTO
//! events, INTEN/INTENSET/INTENCLR and the level interrupt (IRQ 2, from the base address), a
//! six-byte receive FIFO that the backend fills only while it has room (so nothing is lost
//! however slowly the firmware reads), and a transmitter that takes one byte at a time (a byte
//! written to TXD while the previous one is pending is dropped, hence the wait for TXDRDY).
//! It ignores BAUDRATE, CONFIG and the pin selection, and never raises an overrun; on the part
//! a polled receiver that falls more than six bytes behind (520 µs at 115 200 Bd) loses bytes
//! and counts them here as [`UartError::Overrun`].

pub use board_support::uart::UartError;
use board_support::uart::{claim_once, PolledRx};
use core::marker::PhantomData;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::AtomicBool;

/// Base address of the UART.
pub const BASE: usize = 0x4000_2000;

const TASKS_STARTRX: usize = 0x000;
const TASKS_STARTTX: usize = 0x008;
const EVENTS_RXDRDY: usize = 0x108;
const EVENTS_TXDRDY: usize = 0x11C;
const EVENTS_ERROR: usize = 0x124;
const INTENCLR: usize = 0x308;
const ERRORSRC: usize = 0x480;
const ENABLE: usize = 0x500;
const PSELTXD: usize = 0x50C;
const PSELRXD: usize = 0x514;
const RXD: usize = 0x518;
const TXD: usize = 0x51C;
const BAUDRATE: usize = 0x524;
const CONFIG: usize = 0x56C;

const ENABLE_ON: u32 = 4;
const ERRORSRC_OVERRUN: u32 = 1 << 0;
/// The micro:bit v1's UART pins (to the interface chip's virtual COM port).
const PIN_TX: u32 = 24;
const PIN_RX: u32 = 25;

/// BAUDRATE register values (nRF51 RM, table "Baud rate").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Baud {
    /// 115 200 Bd (`0x01D7_E000`).
    B115200,
    /// 921 600 Bd (`0x0F00_0000`): the host link's rate.
    B921600,
}

impl Baud {
    const fn register(self) -> u32 {
        match self {
            Self::B115200 => 0x01D7_E000,
            Self::B921600 => 0x0F00_0000,
        }
    }
}

/// The UART. Only [`Uart::take`] makes one, once, so that its registers have a single owner.
#[derive(Debug)]
pub struct Uart {
    /// Not `Sync`, not constructible outside this module.
    _owned: PhantomData<*const ()>,
}

static TAKEN: AtomicBool = AtomicBool::new(false);

fn read_reg(offset: usize) -> u32 {
    // SAFETY: `offset` is one of the register offsets above: an aligned 32-bit register of the
    // UART block, always mapped on the nRF51; reading RXD takes a byte from the FIFO, which only
    // the owner of the `Uart` does.
    unsafe { read_volatile((BASE + offset) as *const u32) }
}

fn write_reg(offset: usize, value: u32) {
    // SAFETY: as in `read_reg`; the owner of the `Uart` is the only writer.
    unsafe { write_volatile((BASE + offset) as *mut u32, value) }
}

impl Uart {
    /// Enables the UART at `baud` (8N1, no flow control, polled), once: `None` on a second
    /// call.
    pub fn take(baud: Baud) -> Option<Self> {
        if !claim_once(&TAKEN) {
            return None;
        }
        write_reg(INTENCLR, u32::MAX);
        write_reg(PSELTXD, PIN_TX);
        write_reg(PSELRXD, PIN_RX);
        write_reg(BAUDRATE, baud.register());
        write_reg(CONFIG, 0);
        write_reg(ENABLE, ENABLE_ON);
        write_reg(EVENTS_RXDRDY, 0);
        write_reg(EVENTS_TXDRDY, 0);
        write_reg(EVENTS_ERROR, 0);
        write_reg(ERRORSRC, 0xF);
        write_reg(TASKS_STARTRX, 1);
        write_reg(TASKS_STARTTX, 1);
        Some(Self {
            _owned: PhantomData,
        })
    }

    /// Sends one byte and waits until the transmitter has taken it.
    fn write_byte(&mut self, byte: u8) {
        write_reg(EVENTS_TXDRDY, 0);
        write_reg(TXD, u32::from(byte));
        while read_reg(EVENTS_TXDRDY) == 0 {}
    }
}

impl PolledRx for Uart {
    /// Checks and clears an overrun.
    fn take_overrun(&mut self) -> bool {
        if read_reg(EVENTS_ERROR) == 0 {
            return false;
        }
        write_reg(EVENTS_ERROR, 0);
        let source = read_reg(ERRORSRC);
        write_reg(ERRORSRC, source);
        source & ERRORSRC_OVERRUN != 0
    }

    /// Takes the received byte if there is one: the event is cleared before RXD is read, so
    /// that a byte arriving meanwhile raises it again.
    fn try_read_byte(&mut self) -> Option<u8> {
        if read_reg(EVENTS_RXDRDY) == 0 {
            return None;
        }
        write_reg(EVENTS_RXDRDY, 0);
        // The byte is in bits 7..0; the truncation keeps exactly them.
        #[allow(clippy::cast_possible_truncation)]
        Some(read_reg(RXD) as u8)
    }

    fn rx_ready(&mut self) -> bool {
        read_reg(EVENTS_RXDRDY) != 0
    }
}

board_support::impl_polled_read!([] Uart);

impl embedded_io::Write for Uart {
    /// Sends every byte, each once the previous one has gone (the UART holds one).
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        for &byte in buf {
            self.write_byte(byte);
        }
        Ok(buf.len())
    }

    /// Every byte has gone when `write` returns.
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}
