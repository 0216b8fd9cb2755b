//! The AS5047P-kind 14-bit absolute magnetic encoder over an `embedded-hal` 1.0
//! [`SpiDevice`], as the pan/tilt angle [`AngleSource`].
//!
//! # Bus
//! SPI mode 1 ([`MODE`]: CPOL = 0, CPHA = 1), up to 10 MHz, 16-bit frames sent as two bytes,
//! most significant first. Each frame is one [`SpiDevice`] transaction, so chip select rises
//! between frames as the device requires (its minimum CSn high time, 350 ns, is the bus
//! implementation's to honour).
//!
//! # Protocol (AS5047P datasheet, SPI interface)
//! - Command frame: bit 15 even parity over bits 14..0, bit 14 = 1 for a read, bits 13..0 the
//!   register address.
//! - Read data frame: bit 15 even parity over bits 14..0, bit 14 EF (the error flag: a
//!   previous command frame was bad), bits 13..0 the data.
//! - Replies are pipelined: the data of a read command arrives during the *next* frame. A
//!   read therefore sends the command and then a NOP (a read of address 0), whose reply
//!   carries the data.
//! - On EF the cause is in ERRFL (framing, invalid command, parity), and reading ERRFL
//!   clears it.
//!
//! The parity of every reply is checked, and EF in any reply triggers an ERRFL read whose
//! contents are returned in [`As5047Error::ErrorFlag`]. With [`As5047::with_diagnostics_check`]
//! every angle reading also fetches DIAAGC in the same pipeline (three frames instead of two)
//! and refuses the angle when the magnet or the CORDIC is in trouble or the offset loop has not
//! finished.
//!
//! Writes (the non-volatile zero position, settings) are deliberately not supported: the zero
//! and direction are applied in software by the [`EncoderMount`].

use core::fmt;

use embedded_hal::spi::{Mode, SpiDevice, MODE_1};

use super::angle::{AngleSource, EncoderMount};
use crate::angle::Angle;

/// The SPI mode of the device: mode 1 (clock idle low, data sampled on the falling edge).
pub const MODE: Mode = MODE_1;

/// The largest SPI clock the device supports, hertz (10 MHz).
pub const MAX_CLOCK_HZ: u32 = 10_000_000;

/// Bit 14 of a command frame: 1 for a read.
const READ_BIT: u16 = 1 << 14;
/// Bit 14 of a reply: the error flag EF.
const EF_BIT: u16 = 1 << 14;
/// Bits 13..0 of a frame: the address of a command or the data of a reply.
const DATA_MASK: u16 = 0x3FFF;

/// A register of the device, by its 14-bit address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Register {
    /// NOP (0x0000): no operation; reads as 0. Sent to clock out the reply to a command.
    Nop,
    /// ERRFL (0x0001): the error flags of the SPI interface; cleared by reading.
    Errfl,
    /// PROG (0x0003): the OTP programming register.
    Prog,
    /// ZPOSM (0x0016): the zero position, most significant 8 bits (non-volatile).
    Zposm,
    /// ZPOSL (0x0017): the zero position, least significant 6 bits, and comparator settings.
    Zposl,
    /// SETTINGS1 (0x0018): non-volatile settings.
    Settings1,
    /// SETTINGS2 (0x0019): non-volatile settings.
    Settings2,
    /// DIAAGC (0x3FFC): diagnostics and the automatic gain control value.
    Diaagc,
    /// MAG (0x3FFD): the CORDIC magnitude, 14 bits.
    Mag,
    /// ANGLEUNC (0x3FFE): the angle without dynamic angle error compensation, 14 bits.
    Angleunc,
    /// ANGLECOM (0x3FFF): the angle with dynamic angle error compensation, 14 bits.
    Anglecom,
}

impl Register {
    /// The register's 14-bit address, `0x0000 ..= 0x3FFF`.
    #[must_use]
    pub const fn address(self) -> u16 {
        match self {
            Self::Nop => 0x0000,
            Self::Errfl => 0x0001,
            Self::Prog => 0x0003,
            Self::Zposm => 0x0016,
            Self::Zposl => 0x0017,
            Self::Settings1 => 0x0018,
            Self::Settings2 => 0x0019,
            Self::Diaagc => 0x3FFC,
            Self::Mag => 0x3FFD,
            Self::Angleunc => 0x3FFE,
            Self::Anglecom => 0x3FFF,
        }
    }
}

/// Bit 15 that makes the parity of a whole frame even, given its bits 14..0 (bit 15 of the
/// argument is ignored): `0x8000` when bits 14..0 hold an odd number of ones, else 0.
#[must_use]
const fn parity_bit(frame: u16) -> u16 {
    // Fold the 15 low bits onto bit 0 by XOR.
    let mut x = frame & 0x7FFF;
    x ^= x >> 8;
    x ^= x >> 4;
    x ^= x >> 2;
    x ^= x >> 1;
    (x & 1) << 15
}

/// The 16-bit read command frame for a register: parity, the read bit and the address.
#[must_use]
pub const fn read_command(register: Register) -> u16 {
    let frame = READ_BIT | (register.address() & DATA_MASK);
    frame | parity_bit(frame)
}

/// A read data frame whose parity checked out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReadFrame {
    /// EF, bit 14: the device saw a bad command frame since ERRFL was last read.
    pub error_flag: bool,
    /// Bits 13..0: the data of the command sent one frame earlier, `0 ..= 0x3FFF`.
    pub data: u16,
}

impl ReadFrame {
    /// Checks the parity of a 16-bit read data frame and splits it.
    ///
    /// # Errors
    /// [`As5047Error::Parity`] with the frame when its sixteen bits hold an odd number of
    /// ones.
    pub fn parse<E>(frame: u16) -> Result<Self, As5047Error<E>> {
        if parity_bit(frame) != frame & 0x8000 {
            return Err(As5047Error::Parity { reply: frame });
        }
        Ok(Self {
            error_flag: frame & EF_BIT != 0,
            data: frame & DATA_MASK,
        })
    }
}

/// The contents of ERRFL: why the device set the error flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ErrorFlags {
    /// FRERR, bit 0: a framing error (a frame was not 16 clocks long).
    pub framing: bool,
    /// INVCOMM, bit 1: an invalid command (a read or write of a non-existent address).
    pub invalid_command: bool,
    /// PARERR, bit 2: a command frame with bad parity.
    pub parity: bool,
}

impl ErrorFlags {
    /// Decodes the 14-bit ERRFL data; bits other than 0..2 are ignored.
    #[must_use]
    pub const fn from_register(errfl: u16) -> Self {
        Self {
            framing: errfl & (1 << 0) != 0,
            invalid_command: errfl & (1 << 1) != 0,
            parity: errfl & (1 << 2) != 0,
        }
    }
}

/// The contents of DIAAGC: the health of the magnetic field and of the angle calculation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Diagnostics {
    /// AGC, bits 7..0: the automatic gain control value, `0 ..= 255`; low for a strong field,
    /// high for a weak one (it saturates at the ends when MAGH or MAGL is set).
    pub agc: u8,
    /// LF, bit 8: the internal offset compensation loop has finished; `false` shortly after
    /// power-up, while angles are not yet valid.
    pub offset_loop_ready: bool,
    /// COF, bit 9: the CORDIC overflowed; the angle and magnitude are invalid.
    pub cordic_overflow: bool,
    /// MAGH, bit 10: the magnetic field is too strong (the AGC is at its minimum).
    pub magnet_too_strong: bool,
    /// MAGL, bit 11: the magnetic field is too weak (the AGC is at its maximum), or absent.
    pub magnet_too_weak: bool,
}

impl Diagnostics {
    /// Decodes the 14-bit DIAAGC data; bits 13..12 are ignored.
    #[must_use]
    pub const fn from_register(diaagc: u16) -> Self {
        Self {
            agc: (diaagc & 0xFF) as u8,
            offset_loop_ready: diaagc & (1 << 8) != 0,
            cordic_overflow: diaagc & (1 << 9) != 0,
            magnet_too_strong: diaagc & (1 << 10) != 0,
            magnet_too_weak: diaagc & (1 << 11) != 0,
        }
    }

    /// The first problem that makes an angle untrustworthy, in the order: magnet too weak,
    /// too strong, CORDIC overflow, offset loop not finished; `Ok` when there is none.
    ///
    /// # Errors
    /// [`As5047Error::Magnet`], [`As5047Error::CordicOverflow`] or [`As5047Error::NotReady`].
    pub const fn check<E>(&self) -> Result<(), As5047Error<E>> {
        if self.magnet_too_weak {
            Err(As5047Error::Magnet(MagnetFault::TooWeak))
        } else if self.magnet_too_strong {
            Err(As5047Error::Magnet(MagnetFault::TooStrong))
        } else if self.cordic_overflow {
            Err(As5047Error::CordicOverflow)
        } else if !self.offset_loop_ready {
            Err(As5047Error::NotReady)
        } else {
            Ok(())
        }
    }
}

/// What is wrong with the magnetic field, from DIAAGC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MagnetFault {
    /// MAGL: the field is too weak or the magnet is missing (too far from the chip).
    TooWeak,
    /// MAGH: the field is too strong (the magnet is too close).
    TooStrong,
}

impl fmt::Display for MagnetFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooWeak => f.write_str("magnetic field too weak (MAGL)"),
            Self::TooStrong => f.write_str("magnetic field too strong (MAGH)"),
        }
    }
}

/// Why a transaction with the encoder failed. `E` is the SPI device's error type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum As5047Error<E> {
    /// The SPI device failed.
    Spi(E),
    /// A reply frame had odd parity: it was corrupted on the wire and its data is not used.
    Parity {
        /// The whole 16-bit reply as received.
        reply: u16,
    },
    /// The device set EF: it received a bad command frame. ERRFL was read (which clears it);
    /// the reading it belonged to is discarded.
    ErrorFlag {
        /// The 14-bit ERRFL data; decode with [`ErrorFlags::from_register`].
        errfl: u16,
    },
    /// The magnetic field is out of range (DIAAGC MAGL or MAGH).
    Magnet(MagnetFault),
    /// The CORDIC overflowed (DIAAGC COF): the angle is invalid.
    CordicOverflow,
    /// The offset compensation loop has not finished (DIAAGC LF = 0): the device is still
    /// starting up.
    NotReady,
}

impl<E> As5047Error<E> {
    /// The decoded ERRFL flags of an [`As5047Error::ErrorFlag`], `None` for other errors.
    #[must_use]
    pub const fn error_flags(&self) -> Option<ErrorFlags> {
        match self {
            Self::ErrorFlag { errfl } => Some(ErrorFlags::from_register(*errfl)),
            _ => None,
        }
    }
}

impl<E: fmt::Debug> fmt::Display for As5047Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Spi(e) => write!(f, "encoder SPI bus error: {e:?}"),
            Self::Parity { reply } => {
                write!(f, "encoder reply {reply:#06x} failed its parity check")
            }
            Self::ErrorFlag { errfl } => {
                let flags = ErrorFlags::from_register(*errfl);
                write!(
                    f,
                    "encoder flagged a bad command frame (ERRFL {errfl:#06x}: framing {}, invalid command {}, parity {})",
                    flags.framing, flags.invalid_command, flags.parity
                )
            }
            Self::Magnet(fault) => write!(f, "encoder {fault}"),
            Self::CordicOverflow => f.write_str("encoder CORDIC overflow (COF): angle invalid"),
            Self::NotReady => {
                f.write_str("encoder offset loop not finished (LF = 0): still starting up")
            }
        }
    }
}

impl<E: fmt::Debug> core::error::Error for As5047Error<E> {}

/// An AS5047P-kind encoder on an SPI device, with its mounting.
///
/// Readings of [`AngleSource::read_angle`] are the compensated angle (ANGLECOM) through the
/// [`EncoderMount`]. The driver keeps no state between calls but its configuration: every
/// register read is a complete command + NOP exchange.
#[derive(Debug)]
pub struct As5047<SPI> {
    spi: SPI,
    mount: EncoderMount,
    check_diagnostics: bool,
}

impl<SPI: SpiDevice> As5047<SPI> {
    /// A driver for the encoder on `spi` (configured for [`MODE`], ≤ [`MAX_CLOCK_HZ`]), with
    /// the given mounting and without the diagnostics check. Talks to nothing yet.
    #[must_use]
    pub const fn new(spi: SPI, mount: EncoderMount) -> Self {
        Self {
            spi,
            mount,
            check_diagnostics: false,
        }
    }

    /// Enables (`true`) or disables the DIAAGC check on every angle reading: the reading then
    /// costs three frames instead of two and fails with [`As5047Error::Magnet`],
    /// [`As5047Error::CordicOverflow`] or [`As5047Error::NotReady`] as
    /// [`Diagnostics::check`] decides.
    #[must_use]
    pub const fn with_diagnostics_check(mut self, enabled: bool) -> Self {
        self.check_diagnostics = enabled;
        self
    }

    /// The mounting applied to angle readings.
    #[must_use]
    pub const fn mount(&self) -> EncoderMount {
        self.mount
    }

    /// Replaces the mounting applied to angle readings (e.g. after a zeroing routine).
    pub fn set_mount(&mut self, mount: EncoderMount) {
        self.mount = mount;
    }

    /// Whether angle readings check DIAAGC.
    #[must_use]
    pub const fn checks_diagnostics(&self) -> bool {
        self.check_diagnostics
    }

    /// Gives the SPI device back.
    #[must_use]
    pub fn release(self) -> SPI {
        self.spi
    }

    /// Sends one 16-bit frame in its own transaction and returns the frame clocked in.
    fn exchange(&mut self, command: u16) -> Result<u16, As5047Error<SPI::Error>> {
        let mut buf = command.to_be_bytes();
        self.spi
            .transfer_in_place(&mut buf)
            .map_err(As5047Error::Spi)?;
        Ok(u16::from_be_bytes(buf))
    }

    /// Checks the parity of every reply, then EF in any of them (reading ERRFL if set), and
    /// returns the data of the last `N − 1` replies (the first is the reply to whatever came
    /// before and carries no data of ours).
    fn validate<const N: usize>(
        &mut self,
        replies: [u16; N],
    ) -> Result<[u16; N], As5047Error<SPI::Error>> {
        let mut data = [0_u16; N];
        let mut error_flag = false;
        for (frame, slot) in replies.iter().zip(data.iter_mut()) {
            let reply = ReadFrame::parse(*frame)?;
            error_flag |= reply.error_flag;
            *slot = reply.data;
        }
        if error_flag {
            let errfl = self.read_errfl_raw()?;
            warn!("AS5047: EF set, ERRFL {:#x}", errfl);
            return Err(As5047Error::ErrorFlag { errfl });
        }
        Ok(data)
    }

    /// Reads ERRFL, clearing it: command, then NOP. EF is expected in these replies and not
    /// acted on; parity is checked.
    fn read_errfl_raw(&mut self) -> Result<u16, As5047Error<SPI::Error>> {
        let first = self.exchange(read_command(Register::Errfl))?;
        let second = self.exchange(read_command(Register::Nop))?;
        ReadFrame::parse(first)?;
        Ok(ReadFrame::parse(second)?.data)
    }

    /// Reads one register: its read command, then a NOP whose reply carries the 14-bit data
    /// (`0 ..= 0x3FFF`). Reading [`Register::Errfl`] this way clears it, and EF is then
    /// reported as an error like on any other register; [`As5047::read_error_flags`] is the
    /// dedicated path.
    ///
    /// # Errors
    /// [`As5047Error::Spi`], [`As5047Error::Parity`] on any reply, [`As5047Error::ErrorFlag`]
    /// when EF was set in any reply (ERRFL has then been read and cleared).
    pub fn read_register(&mut self, register: Register) -> Result<u16, As5047Error<SPI::Error>> {
        let first = self.exchange(read_command(register))?;
        let second = self.exchange(read_command(Register::Nop))?;
        let [_, data] = self.validate([first, second])?;
        Ok(data)
    }

    /// Reads and clears ERRFL. EF in the replies is expected here and not an error.
    ///
    /// # Errors
    /// [`As5047Error::Spi`], [`As5047Error::Parity`] on any reply.
    pub fn read_error_flags(&mut self) -> Result<ErrorFlags, As5047Error<SPI::Error>> {
        self.read_errfl_raw().map(ErrorFlags::from_register)
    }

    /// Reads DIAAGC, the magnet and CORDIC diagnostics, without judging them (see
    /// [`Diagnostics::check`]).
    ///
    /// # Errors
    /// As [`As5047::read_register`].
    pub fn diagnostics(&mut self) -> Result<Diagnostics, As5047Error<SPI::Error>> {
        self.read_register(Register::Diaagc)
            .map(Diagnostics::from_register)
    }

    /// Reads the compensated angle ANGLECOM as a raw 14-bit count, `0 ..= 16 383`, before the
    /// mounting, with no diagnostics check (for zeroing routines).
    ///
    /// # Errors
    /// As [`As5047::read_register`].
    pub fn read_raw_count(&mut self) -> Result<u16, As5047Error<SPI::Error>> {
        self.read_register(Register::Anglecom)
    }

    /// Reads DIAAGC and ANGLECOM in one three-frame pipeline (DIAAGC command, ANGLECOM command
    /// whose reply is DIAAGC, NOP whose reply is the angle), checks the diagnostics and
    /// returns the raw 14-bit count.
    fn read_checked_raw_count(&mut self) -> Result<u16, As5047Error<SPI::Error>> {
        let first = self.exchange(read_command(Register::Diaagc))?;
        let second = self.exchange(read_command(Register::Anglecom))?;
        let third = self.exchange(read_command(Register::Nop))?;
        let [_, diaagc, count] = self.validate([first, second, third])?;
        let diagnostics = Diagnostics::from_register(diaagc);
        if let Err(e) = diagnostics.check() {
            debug!("AS5047: diagnostics refused the angle: {:?}", diagnostics);
            return Err(e);
        }
        Ok(count)
    }
}

impl<SPI: SpiDevice> AngleSource for As5047<SPI> {
    type Error = As5047Error<SPI::Error>;

    /// The compensated angle (ANGLECOM) through the mounting; with the diagnostics check
    /// enabled, only when DIAAGC reports a good field, no CORDIC overflow and a finished
    /// offset loop.
    fn read_angle(&mut self) -> Result<Angle, Self::Error> {
        let raw = if self.check_diagnostics {
            self.read_checked_raw_count()?
        } else {
            self.read_raw_count()?
        };
        Ok(self.mount.angle(raw))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use embedded_hal::spi::{ErrorKind, ErrorType, Operation};
    use embedded_hal_mock::eh1::spi::{Mock, Transaction};
    use std::{format, string::ToString, vec::Vec};

    /// A 16-bit frame with its parity bit set so that the whole frame has even parity,
    /// computed independently of the code under test.
    fn with_parity(low15: u16) -> u16 {
        let low15 = low15 & 0x7FFF;
        if low15.count_ones() % 2 == 1 {
            low15 | 0x8000
        } else {
            low15
        }
    }

    /// A good reply frame carrying `data`, with EF as given.
    fn reply(data: u16, ef: bool) -> u16 {
        with_parity(data & 0x3FFF | if ef { 0x4000 } else { 0 })
    }

    /// The expectations of one frame: the command sent and the reply clocked in, in their own
    /// chip-select transaction.
    fn frame(command: u16, response: u16) -> [Transaction<u8>; 3] {
        [
            Transaction::transaction_start(),
            Transaction::transfer_in_place(
                command.to_be_bytes().to_vec(),
                response.to_be_bytes().to_vec(),
            ),
            Transaction::transaction_end(),
        ]
    }

    /// Read commands, with parity computed here.
    const fn cmd(address: u16) -> u16 {
        0x4000 | address
    }

    fn expect(frames: &[(u16, u16)]) -> Vec<Transaction<u8>> {
        frames
            .iter()
            .flat_map(|&(c, r)| frame(with_parity(cmd(c)), r))
            .collect()
    }

    const ANGLECOM: u16 = 0x3FFF;
    const DIAAGC: u16 = 0x3FFC;
    const ERRFL: u16 = 0x0001;
    const NOP: u16 = 0x0000;

    #[test]
    fn command_frames_match_the_datasheet() {
        // The well-known frames: 0xFFFF reads ANGLECOM, 0xC000 is the NOP, 0x4001 reads
        // ERRFL, 0xFFFC reads DIAAGC.
        assert_eq!(read_command(Register::Anglecom), 0xFFFF);
        assert_eq!(read_command(Register::Nop), 0xC000);
        assert_eq!(read_command(Register::Errfl), 0x4001);
        assert_eq!(read_command(Register::Diaagc), 0xFFFC);
        for reg in [
            Register::Nop,
            Register::Errfl,
            Register::Prog,
            Register::Zposm,
            Register::Zposl,
            Register::Settings1,
            Register::Settings2,
            Register::Diaagc,
            Register::Mag,
            Register::Angleunc,
            Register::Anglecom,
        ] {
            let c = read_command(reg);
            assert_eq!(c.count_ones() % 2, 0, "{reg:?}");
            assert_eq!(c, with_parity(cmd(reg.address())));
        }
    }

    #[test]
    fn reply_parsing_agrees_with_count_ones_on_every_frame() {
        for f in 0..=u16::MAX {
            match ReadFrame::parse::<()>(f) {
                Ok(r) => {
                    assert_eq!(f.count_ones() % 2, 0);
                    assert_eq!(r.data, f & 0x3FFF);
                    assert_eq!(r.error_flag, f & 0x4000 != 0);
                }
                Err(e) => {
                    assert_eq!(f.count_ones() % 2, 1);
                    assert_eq!(e, As5047Error::Parity { reply: f });
                }
            }
        }
    }

    #[test]
    fn reads_a_good_angle() {
        let raw = 0x1ABC;
        let t = expect(&[(ANGLECOM, reply(0, false)), (NOP, reply(raw, false))]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        let a = enc.read_angle().unwrap();
        assert_eq!(a, Angle::from_counts14(raw));
        assert_eq!(a.to_counts14(), raw);
        spi.done();
    }

    #[test]
    fn applies_the_mount_with_wrapping() {
        // Zero at 16 000, reversed: raw 100 is (100 − 16 000) mod 2¹⁴ = 484 counts past the
        // zero, which reversed is 16 384 − 484 = 15 900.
        let t = expect(&[
            (ANGLECOM, reply(0, false)),
            (NOP, reply(100, false)),
            (ANGLECOM, reply(0, false)),
            (NOP, reply(16_000, false)),
            (ANGLECOM, reply(0, false)),
            (NOP, reply(15_999, false)),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::new(16_000, true));
        assert_eq!(enc.read_angle().unwrap().to_counts14(), 15_900);
        assert_eq!(enc.read_angle().unwrap(), Angle::ZERO);
        assert_eq!(enc.read_angle().unwrap().to_counts14(), 1);
        spi.done();

        // Not reversed: past the zero wraps up from 0, before it wraps down from 16 383.
        let t = expect(&[
            (ANGLECOM, reply(0, false)),
            (NOP, reply(5, false)),
            (ANGLECOM, reply(0, false)),
            (NOP, reply(15_999, false)),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::new(16_000, false));
        assert_eq!(enc.read_angle().unwrap().to_counts14(), 389);
        assert_eq!(enc.read_angle().unwrap().to_counts14(), 16_383);
        assert_eq!(enc.mount(), EncoderMount::new(16_000, false));
        enc.set_mount(EncoderMount::IDENTITY);
        assert_eq!(enc.mount(), EncoderMount::IDENTITY);
        spi.done();
    }

    #[test]
    fn refuses_a_reply_with_bad_parity() {
        let good = reply(0x0123, false);
        let bad = good ^ 0x0001; // one bit flipped on the wire
        assert_eq!(bad.count_ones() % 2, 1);
        let t = expect(&[(ANGLECOM, reply(0, false)), (NOP, bad)]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        assert_eq!(enc.read_angle(), Err(As5047Error::Parity { reply: bad }));
        spi.done();

        // A corrupt first reply (the one carrying no data of ours) is refused too.
        let bad_first = reply(0, false) ^ 0x2000;
        let t = expect(&[(ANGLECOM, bad_first), (NOP, reply(7, false))]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        assert_eq!(
            enc.read_angle(),
            Err(As5047Error::Parity { reply: bad_first })
        );
        spi.done();
    }

    #[test]
    fn error_flag_reads_back_errfl() {
        // The angle command was received with bad parity: the reply to the NOP carries EF.
        // The driver then reads ERRFL (command, NOP) and reports PARERR.
        let t = expect(&[
            (ANGLECOM, reply(0, false)),
            (NOP, reply(0, true)),
            (ERRFL, reply(0, true)),
            (NOP, reply(0b100, false)),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        let err = enc.read_angle().unwrap_err();
        assert_eq!(err, As5047Error::ErrorFlag { errfl: 0b100 });
        assert_eq!(
            err.error_flags(),
            Some(ErrorFlags {
                framing: false,
                invalid_command: false,
                parity: true,
            })
        );
        assert!(err.to_string().contains("parity true"));
        spi.done();
    }

    #[test]
    fn errfl_read_with_corrupt_reply_reports_parity() {
        let bad = reply(0b011, false) ^ 0x0100;
        let t = expect(&[
            (ANGLECOM, reply(0, true)),
            (NOP, reply(0x0042, true)),
            (ERRFL, reply(0, true)),
            (NOP, bad),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        assert_eq!(enc.read_angle(), Err(As5047Error::Parity { reply: bad }));
        spi.done();
    }

    #[test]
    fn read_error_flags_decodes_and_tolerates_ef() {
        let t = expect(&[(ERRFL, reply(0, true)), (NOP, reply(0b011, true))]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        assert_eq!(
            enc.read_error_flags().unwrap(),
            ErrorFlags {
                framing: true,
                invalid_command: true,
                parity: false,
            }
        );
        spi.done();
    }

    #[test]
    fn diagnostics_report_a_weak_magnet() {
        // MAGL set, LF set, AGC at its maximum.
        let diaagc = (1 << 11) | (1 << 8) | 0xFF;
        let t = expect(&[(DIAAGC, reply(0, false)), (NOP, reply(diaagc, false))]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY);
        let d = enc.diagnostics().unwrap();
        assert_eq!(
            d,
            Diagnostics {
                agc: 0xFF,
                offset_loop_ready: true,
                cordic_overflow: false,
                magnet_too_strong: false,
                magnet_too_weak: true,
            }
        );
        assert_eq!(
            d.check::<()>(),
            Err(As5047Error::Magnet(MagnetFault::TooWeak))
        );
        spi.done();
    }

    #[test]
    fn checked_reading_refuses_a_weak_magnet() {
        // Three frames: DIAAGC command, ANGLECOM command (reply: DIAAGC), NOP (reply: angle).
        let diaagc = (1 << 11) | (1 << 8) | 0xFF;
        let t = expect(&[
            (DIAAGC, reply(0, false)),
            (ANGLECOM, reply(diaagc, false)),
            (NOP, reply(1234, false)),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY).with_diagnostics_check(true);
        assert!(enc.checks_diagnostics());
        let err = enc.read_angle().unwrap_err();
        assert_eq!(err, As5047Error::Magnet(MagnetFault::TooWeak));
        assert_eq!(err.to_string(), "encoder magnetic field too weak (MAGL)");
        spi.done();
    }

    #[test]
    fn checked_reading_passes_a_healthy_encoder_and_refuses_the_others() {
        let lf = 1 << 8;
        let cases: [(u16, Result<Angle, As5047Error<ErrorKind>>); 5] = [
            (lf | 0x40, Ok(Angle::from_counts14(1234))),
            (0x40, Err(As5047Error::NotReady)),
            (lf | (1 << 9), Err(As5047Error::CordicOverflow)),
            (
                lf | (1 << 10),
                Err(As5047Error::Magnet(MagnetFault::TooStrong)),
            ),
            // Several at once: the magnet is named first.
            (
                (1 << 11) | (1 << 9),
                Err(As5047Error::Magnet(MagnetFault::TooWeak)),
            ),
        ];
        for (diaagc, want) in cases {
            let t = expect(&[
                (DIAAGC, reply(0, false)),
                (ANGLECOM, reply(diaagc, false)),
                (NOP, reply(1234, false)),
            ]);
            let mut spi = Mock::new(&t);
            let mut enc =
                As5047::new(spi.clone(), EncoderMount::IDENTITY).with_diagnostics_check(true);
            assert_eq!(enc.read_angle(), want, "DIAAGC {diaagc:#x}");
            spi.done();
        }
    }

    #[test]
    fn checked_reading_reports_the_error_flag_before_diagnostics() {
        let t = expect(&[
            (DIAAGC, reply(0, false)),
            (ANGLECOM, reply(0x0800, true)),
            (NOP, reply(1234, true)),
            (ERRFL, reply(0, true)),
            (NOP, reply(0b010, false)),
        ]);
        let mut spi = Mock::new(&t);
        let mut enc = As5047::new(spi.clone(), EncoderMount::IDENTITY).with_diagnostics_check(true);
        assert_eq!(
            enc.read_angle(),
            Err(As5047Error::ErrorFlag { errfl: 0b010 })
        );
        spi.done();
    }

    /// An SPI device whose every transaction fails.
    struct BrokenSpi;

    impl ErrorType for BrokenSpi {
        type Error = ErrorKind;
    }

    impl SpiDevice for BrokenSpi {
        fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
            Err(ErrorKind::ModeFault)
        }
    }

    #[test]
    fn spi_errors_propagate() {
        let mut enc = As5047::new(BrokenSpi, EncoderMount::IDENTITY);
        assert_eq!(
            enc.read_angle(),
            Err(As5047Error::Spi(ErrorKind::ModeFault))
        );
        assert_eq!(
            enc.diagnostics(),
            Err(As5047Error::Spi(ErrorKind::ModeFault))
        );
        let mut enc = enc.with_diagnostics_check(true);
        assert_eq!(
            enc.read_angle(),
            Err(As5047Error::Spi(ErrorKind::ModeFault))
        );
        let e = enc.read_angle().unwrap_err();
        assert!(format!("{e}").starts_with("encoder SPI bus error"));
        let _spi: BrokenSpi = enc.release();
    }
}
