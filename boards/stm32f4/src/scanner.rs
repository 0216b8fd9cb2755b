//! Bring-up of the SICK LMS2xx on USART1 (polled, before its interrupt takes over).
//!
//! The scanner powers up at 9600 Bd. The firmware sends the 500 kBd command
//! ([`SET_500K`]), waits for the ACK (0x06) and the reply telegram, switches USART1 to
//! 500 kBd, and starts continuous output ([`START_CONTINUOUS`]). If the scanner does not answer
//! at 9600 Bd it may already run at 500 kBd (the microcontroller was reset, the scanner was
//! not), so each attempt also asks at 500 kBd. After [`ATTEMPTS`] silent attempts (about a
//! minute: an LMS takes tens of seconds to boot) it gives up and leaves USART1 at 500 kBd, so
//! that the rest of the firmware (the host link) runs without a scanner. The watchdog is fed
//! throughout.

use embedded_hal_nb::serial::{Read as _, Write as _};
use stm32f4xx_hal::pac::USART1;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::serial::{self, Serial};
use stm32f4xx_hal::watchdog::IndependentWatchdog;

use crate::clock::Clock;

/// USART1 with the laser on it.
pub type Laser = Serial<USART1>;

/// The scanner's baud rate at power-on.
pub const POWER_ON_BAUD: u32 = 9_600;
/// The baud rate the firmware runs the scanner at.
pub const FAST_BAUD: u32 = 500_000;

/// "Switch to 500 kBd": STX, address 0, length 2, command 0x20 (operating mode), mode 0x48,
/// CRC 0x0858 (little-endian).
pub const SET_500K: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08];
/// "Continuous output of all measured values": command 0x20, mode 0x24, CRC 0x0834.
pub const START_CONTINUOUS: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08];

const ACK: u8 = 0x06;
const NAK: u8 = 0x15;
const STX: u8 = 0x02;
/// The LMS acknowledges within 60 ms.
const ACK_TIMEOUT_MS: u32 = 100;
/// The reply telegram to a mode change: STX, 0x80, length 3, 0xA0, status, 0x10, CRC.
const REPLY_LEN: usize = 9;
const REPLY_TIMEOUT_MS: u32 = 500;
/// Silent attempts before giving up.
pub const ATTEMPTS: u32 = 30;
const RETRY_PERIOD_MS: u32 = 1_000;

/// How the bring-up ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ScannerState {
    /// At 500 kBd, streaming (continuous output acknowledged).
    Streaming,
    /// At 500 kBd, but continuous output was not acknowledged.
    Unconfirmed,
    /// No answer at either rate: no scanner, or a wiring fault.
    Absent,
}

/// Why the bring-up could not even run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum BringUpError {
    /// The USART refused a baud rate, or lost its pins (neither happens with the clocks set
    /// in `main`).
    Usart,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Answer {
    Ack,
    Nak,
    Silence,
}

/// What the bring-up needs besides the USART.
pub struct Context<'a> {
    /// To rebuild USART1 at another baud rate.
    pub rcc: &'a mut Rcc,
    /// For timeouts.
    pub clock: Clock,
    /// Fed while waiting.
    pub watchdog: &'a mut IndependentWatchdog,
}

/// Runs the bring-up; see the module documentation.
///
/// # Errors
/// [`BringUpError::Usart`] if USART1 cannot be reconfigured.
pub fn bring_up(
    mut laser: Laser,
    ctx: &mut Context<'_>,
) -> Result<(Laser, ScannerState), BringUpError> {
    let mut found = false;
    for attempt in 1..=ATTEMPTS {
        laser = set_baud(laser, POWER_ON_BAUD, ctx.rcc)?;
        match command(&mut laser, &SET_500K, ctx) {
            Answer::Ack => {
                let mut reply = [0_u8; REPLY_LEN];
                let n = read_reply(&mut laser, &mut reply, ctx);
                defmt::info!(
                    "LMS: 500 kBd acknowledged at 9600 Bd, reply {=[u8]:02x}",
                    reply.get(..n).unwrap_or(&[])
                );
                laser = set_baud(laser, FAST_BAUD, ctx.rcc)?;
                found = true;
                break;
            }
            Answer::Nak => defmt::warn!("LMS: 500 kBd command refused (NAK) at 9600 Bd"),
            Answer::Silence => {}
        }
        laser = set_baud(laser, FAST_BAUD, ctx.rcc)?;
        if command(&mut laser, &SET_500K, ctx) == Answer::Ack {
            defmt::info!("LMS: already at 500 kBd");
            found = true;
            break;
        }
        defmt::warn!(
            "LMS: no answer at 9600 or 500000 Bd (attempt {=u32} of {=u32})",
            attempt,
            ATTEMPTS
        );
        wait_ms(RETRY_PERIOD_MS, ctx);
    }
    if !found {
        defmt::error!("LMS: no scanner; USART1 left at 500 kBd");
        return Ok((laser, ScannerState::Absent));
    }
    for _ in 0..3 {
        if command(&mut laser, &START_CONTINUOUS, ctx) == Answer::Ack {
            defmt::info!("LMS: continuous output started");
            return Ok((laser, ScannerState::Streaming));
        }
    }
    defmt::warn!("LMS: continuous output not acknowledged");
    Ok((laser, ScannerState::Unconfirmed))
}

/// Rebuilds USART1 at `baud` (8N1), keeping its pins.
fn set_baud(laser: Laser, baud: u32, rcc: &mut Rcc) -> Result<Laser, BringUpError> {
    let (usart, (tx, rx)) = laser.release();
    let (Some(tx), Some(rx)) = (tx, rx) else {
        return Err(BringUpError::Usart);
    };
    let config = serial::Config::default().baudrate(baud.bps());
    usart
        .serial((tx, rx), config, rcc)
        .map_err(|_| BringUpError::Usart)
}

/// Drops stale input, sends a telegram, and waits for ACK or NAK (other bytes are skipped).
fn command(laser: &mut Laser, telegram: &[u8], ctx: &mut Context<'_>) -> Answer {
    while !matches!(laser.read(), Err(nb::Error::WouldBlock)) {}
    for &byte in telegram {
        if nb::block!(laser.write(byte)).is_err() {
            return Answer::Silence;
        }
    }
    let _ = nb::block!(laser.flush());
    let start = ctx.clock.now();
    while ctx.clock.elapsed_ms(start) < ACK_TIMEOUT_MS {
        match laser.read() {
            Ok(ACK) => return Answer::Ack,
            Ok(NAK) => return Answer::Nak,
            _ => {}
        }
    }
    ctx.watchdog.feed();
    Answer::Silence
}

/// Reads the reply telegram (from its STX) into `reply`; returns the bytes read.
fn read_reply(laser: &mut Laser, reply: &mut [u8; REPLY_LEN], ctx: &mut Context<'_>) -> usize {
    let start = ctx.clock.now();
    let mut n = 0;
    while n < REPLY_LEN && ctx.clock.elapsed_ms(start) < REPLY_TIMEOUT_MS {
        if let Ok(byte) = laser.read() {
            if n > 0 || byte == STX {
                if let Some(slot) = reply.get_mut(n) {
                    *slot = byte;
                }
                n += 1;
            }
        }
    }
    ctx.watchdog.feed();
    n
}

fn wait_ms(ms: u32, ctx: &mut Context<'_>) {
    let start = ctx.clock.now();
    while ctx.clock.elapsed_ms(start) < ms {
        ctx.watchdog.feed();
    }
}
