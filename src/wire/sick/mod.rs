//! The SICK LMS2xx (LMS200/LMS291 family) serial protocol: framing, CRC, the measured-values
//! reply, the commands that bring a scanner up, and the reassembly of telegrams from UART
//! chunks.
//!
//! # Wire format
//! ```text
//! STX 0x02 | ADR (u8) | LEN (u16 LE) | payload (LEN bytes) | CRC (u16 LE)
//! ```
//! - ADR is [`ADDRESS_HOST`] (0x00) from the host to the scanner and [`ADDRESS_REPLY`] (0x80)
//!   in replies; a receiver synchronises on the byte pair `02 80`.
//! - LEN counts the payload: the command byte, its data and, in replies, a trailing status
//!   byte. It lies in `1..=`[`MAX_PAYLOAD_LEN`] (812), so a telegram is at most
//!   [`MAX_TELEGRAM_LEN`] (818) bytes.
//! - The CRC ([`crc16`]) runs over every byte from STX to the end of the payload.
//! - A reply's command byte is the request's plus 0x80 ([`reply_command`]). Before a reply
//!   the scanner sends one [`ACK`] (0x06) or [`NAK`] (0x15) byte.
//!
//! # Layers
//! - [`Telegram`]: a zero-copy view over one framed telegram, with checked construction.
//! - [`MeasuredValues`] (reply 0xB0), [`SickRequest`] (0x20, 0x3B, 0x30), [`OperatingModeReply`]
//!   (0xA0), [`VariantReply`] (0xBB), and [`SickReply`] over all of them: validated
//!   representations with `parse`, `emit` and `buffer_len`.
//! - [`SickAccumulator`]: synchronisation and reassembly over arbitrary chunks of a byte
//!   stream, with the counters of everything it rejects ([`SickCounters`]).
//!
//! Facts marked *unverified* in the project's protocol notes are marked so where they are
//! used (the 100° start angle, the interlacing offsets).

use core::fmt;

mod accumulator;
mod command;
mod crc;
mod measured;
mod telegram;
#[cfg(test)]
mod test_support;
mod variant;

pub use accumulator::{
    SickAccumulator, SickCounters, SickFeed, SickFrameError, SickItem, DEFAULT_CAPACITY,
};
pub use command::{
    reply_command, Baud, OperatingMode, OperatingModeReply, SickReply, SickRequest, VariantReply,
    ACK, INSTALLATION_PASSWORD, NAK, OPERATING_MODE, OPERATING_MODE_REPLY, REQUEST_MEASURED_VALUES,
    VARIANT, VARIANT_REPLY,
};
pub use crc::{crc16, Crc};
pub use measured::{
    range_mm, Flags, MeasuredValues, MeasuringMode, RangesMm, RawValues, Unit, MAX_VALUES,
    MEASURED_VALUES_REPLY,
};
pub use telegram::{
    emit_telegram, Telegram, ADDRESS_HOST, ADDRESS_REPLY, CRC_LEN, HEADER_LEN, MAX_PAYLOAD_LEN,
    MAX_TELEGRAM_LEN, STX,
};
pub use variant::{Variant, MAX_BEAMS};

/// Why a telegram or one of its fields was refused, or why an emit could not proceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The buffer is shorter than the 4-byte header, or than the telegram its LEN announces.
    Truncated,
    /// The first byte is not STX (0x02).
    BadStx {
        /// The byte found instead.
        found: u8,
    },
    /// LEN is 0 or above [`MAX_PAYLOAD_LEN`] (812).
    BadLength {
        /// The payload length read or requested, bytes.
        len: usize,
    },
    /// The CRC stored in the telegram differs from the one computed over it.
    BadCrc {
        /// The CRC carried by the telegram.
        stored: u16,
        /// The CRC computed over STX..payload.
        computed: u16,
    },
    /// The command byte is not the one the representation parses.
    UnexpectedCommand {
        /// The command byte found (0 when the payload is empty).
        found: u8,
    },
    /// The payload length does not fit the command's fields.
    BadPayloadLength {
        /// The command byte.
        command: u8,
        /// The payload length, bytes (LEN).
        len: usize,
    },
    /// A measured-values count N that the payload length does not match
    /// (LEN must be `4 + 2N`, or `5 + 2N` with the scan-index byte), or that is too large.
    BadCount {
        /// N, the number of values announced (low 10 bits of the count word).
        count: u16,
        /// The payload length, bytes (LEN).
        len: usize,
    },
    /// Units code of the count word (bits 14-15) other than 00 (cm) or 01 (mm).
    UnknownUnit {
        /// The 2-bit code.
        code: u8,
    },
    /// A partial-scan index above 3 (it has two bits).
    BadPartialIndex {
        /// The index given.
        index: u8,
    },
    /// A value-byte slice of odd length: values are u16 LE pairs.
    OddValueBytes {
        /// Its length, bytes.
        len: usize,
    },
    /// A measuring-mode (command 0x77) code with no known distance mask.
    UnknownMeasuringMode {
        /// The code.
        code: u8,
    },
    /// An operating-mode (command 0x20) code this module does not model.
    UnknownOperatingMode {
        /// The code.
        code: u8,
    },
    /// A scan angle other than 100° or 180°.
    UnknownScanAngle {
        /// The angle, degrees.
        degrees: u16,
    },
    /// An angular resolution other than 25, 50 or 100 hundredths of a degree.
    UnknownResolution {
        /// The resolution, hundredths of a degree.
        centideg: u16,
    },
    /// A scan angle and resolution that no LMS2xx offers together (0.25° needs the 100° field).
    UnsupportedVariant {
        /// The angle, degrees.
        degrees: u16,
        /// The resolution, hundredths of a degree.
        centideg: u16,
    },
    /// The output buffer is shorter than the telegram to emit; nothing was written.
    BufferTooSmall {
        /// Bytes the telegram needs.
        needed: usize,
        /// Bytes the buffer holds.
        available: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Truncated => f.write_str("telegram truncated: shorter than its header or LEN"),
            Self::BadStx { found } => {
                write!(f, "telegram does not start with STX 0x02 (0x{found:02x})")
            }
            Self::BadLength { len } => {
                write!(
                    f,
                    "telegram payload length {len} outside 1..={MAX_PAYLOAD_LEN}"
                )
            }
            Self::BadCrc { stored, computed } => write!(
                f,
                "telegram CRC mismatch: stored 0x{stored:04x}, computed 0x{computed:04x}"
            ),
            Self::UnexpectedCommand { found } => write!(f, "unexpected command byte 0x{found:02x}"),
            Self::BadPayloadLength { command, len } => {
                write!(
                    f,
                    "command 0x{command:02x}: payload length {len} does not fit its fields"
                )
            }
            Self::BadCount { count, len } => write!(
                f,
                "measured values: count {count} does not match payload length {len}"
            ),
            Self::UnknownUnit { code } => write!(f, "measured values: unknown unit code {code}"),
            Self::BadPartialIndex { index } => {
                write!(f, "measured values: partial-scan index {index} above 3")
            }
            Self::OddValueBytes { len } => {
                write!(
                    f,
                    "measured values: {len} value bytes, not a whole number of u16"
                )
            }
            Self::UnknownMeasuringMode { code } => {
                write!(f, "unknown measuring mode 0x{code:02x}")
            }
            Self::UnknownOperatingMode { code } => {
                write!(f, "unknown operating mode 0x{code:02x}")
            }
            Self::UnknownScanAngle { degrees } => {
                write!(f, "unknown scan angle {degrees} degrees (100 or 180)")
            }
            Self::UnknownResolution { centideg } => write!(
                f,
                "unknown angular resolution {centideg} hundredths of a degree (25, 50 or 100)"
            ),
            Self::UnsupportedVariant { degrees, centideg } => write!(
                f,
                "unsupported variant: {degrees} degrees at {centideg} hundredths of a degree"
            ),
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "output buffer too small: {needed} bytes needed, {available} available"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Reads a u16 LE at `offset` of `bytes`, or `None` when the two bytes are not there.
fn read_u16_le(bytes: &[u8], offset: usize) -> Option<u16> {
    let [lo, hi] = *bytes.get(offset..)?.first_chunk::<2>()?;
    Some(u16::from_le_bytes([lo, hi]))
}
