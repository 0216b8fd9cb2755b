//! The commands that bring a scanner up, and their replies.
//!
//! Requests (host to scanner, ADR 0x00):
//! ```text
//! 0x20 mode                      operating mode (continuous output, on request, baud rate)
//! 0x20 0x00 "SICK_LMS"           installation mode (needed before 0x77)
//! 0x3B angle(u16 LE) res(u16 LE) variant: 100/180 degrees, 25/50/100 hundredths of a degree
//! 0x30 0x01                      send the measured values once
//! ```
//! Replies (scanner to host, ADR 0x80), each after an ACK byte:
//! ```text
//! 0xA0 result status             result 0x00: mode changed
//! 0xBB result angle res status   result 0x01: variant accepted; angle and resolution as 0x3B
//! 0xB0 ...                       measured values, see MeasuredValues
//! ```
//! Reading of the replies (from the public drivers the protocol notes cite): 0xA0 carries a
//! result byte, 0x00 when the mode changed (0x01 refused, e.g. a wrong password, 0x02 refused
//! on a fault), then the status byte; 0xBB carries a result byte, 0x01 when the variant was
//! accepted, then the scan angle (degrees) and resolution (hundredths of a degree) now in
//! force as u16 LE, then the status byte.

use super::measured::MeasuredValues;
use super::telegram::{emit_with, Telegram, ADDRESS_HOST, ADDRESS_REPLY, CRC_LEN, HEADER_LEN};
use super::variant::Variant;
use super::{read_u16_le, Error};

/// The scanner's positive acknowledgement, one byte sent before a reply.
pub const ACK: u8 = 0x06;
/// The scanner's negative acknowledgement, one byte sent instead of a reply.
pub const NAK: u8 = 0x15;
/// SickRequest: select the operating mode.
pub const OPERATING_MODE: u8 = 0x20;
/// SickRequest: send measured values.
pub const REQUEST_MEASURED_VALUES: u8 = 0x30;
/// SickRequest: select the variant (scan angle and resolution).
pub const VARIANT: u8 = 0x3B;
/// SickReply to [`OPERATING_MODE`].
pub const OPERATING_MODE_REPLY: u8 = 0xA0;
/// SickReply to [`VARIANT`].
pub const VARIANT_REPLY: u8 = 0xBB;
/// The password of installation mode, 8 ASCII bytes.
pub const INSTALLATION_PASSWORD: [u8; 8] = *b"SICK_LMS";

/// The reply's command byte for a request's: `request + 0x80` (0x20 -> 0xA0), wrapping.
#[must_use]
pub const fn reply_command(request: u8) -> u8 {
    request.wrapping_add(0x80)
}

/// A serial speed the scanner can be switched to with command 0x20. It powers up at 9600 Bd,
/// 8N1; 500 kBd needs RS-422 (unverified for all models).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Baud {
    /// 9600 Bd, code 0x42 (the power-up speed).
    B9600,
    /// 19 200 Bd, code 0x41.
    B19200,
    /// 38 400 Bd, code 0x40.
    B38400,
    /// 500 000 Bd, code 0x48.
    B500k,
}

impl Baud {
    /// The mode byte of command 0x20 that selects this speed.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::B9600 => 0x42,
            Self::B19200 => 0x41,
            Self::B38400 => 0x40,
            Self::B500k => 0x48,
        }
    }

    /// The speed a mode byte selects, if it selects one.
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0x42 => Some(Self::B9600),
            0x41 => Some(Self::B19200),
            0x40 => Some(Self::B38400),
            0x48 => Some(Self::B500k),
            _ => None,
        }
    }

    /// The speed, bits per second.
    #[must_use]
    pub const fn bits_per_second(self) -> u32 {
        match self {
            Self::B9600 => 9_600,
            Self::B19200 => 19_200,
            Self::B38400 => 38_400,
            Self::B500k => 500_000,
        }
    }
}

/// An operating mode of command 0x20.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OperatingMode {
    /// Code 0x24: continuous output of all measured values (replies 0xB0, ~75 per second at 1°).
    ContinuousAll,
    /// Code 0x25: measured values only on request (0x30); stops continuous output.
    OnRequest,
    /// Codes 0x40-0x48: switch the serial speed.
    Baud(Baud),
    /// Code 0x00 followed by an 8-byte password ([`INSTALLATION_PASSWORD`]): installation mode,
    /// needed before configuration commands such as 0x77.
    Installation {
        /// The password, 8 bytes.
        password: [u8; 8],
    },
}

impl OperatingMode {
    /// Installation mode with the default password `SICK_LMS`.
    pub const INSTALLATION: Self = Self::Installation {
        password: INSTALLATION_PASSWORD,
    };

    /// The mode byte.
    #[must_use]
    pub const fn code(&self) -> u8 {
        match self {
            Self::ContinuousAll => 0x24,
            Self::OnRequest => 0x25,
            Self::Baud(baud) => baud.code(),
            Self::Installation { .. } => 0x00,
        }
    }

    /// Bytes after the mode byte: 8 for installation mode, 0 otherwise.
    const fn data_len(&self) -> usize {
        match self {
            Self::Installation { .. } => 8,
            _ => 0,
        }
    }
}

/// A request from the host to the scanner: a validated representation of the telegrams this
/// module can send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SickRequest {
    /// 0x20: select an operating mode (payload `20 mode [password]`).
    SetOperatingMode(OperatingMode),
    /// 0x3B: select a variant (payload `3B angle(u16 LE) resolution(u16 LE)`).
    SetVariant(Variant),
    /// 0x30 0x01: send the measured values once (the scanner answers with 0xB0).
    MeasuredValues,
}

impl SickRequest {
    /// Reads a request from a telegram's payload (ADR and CRC are the caller's: construct the
    /// telegram with [`Telegram::new_checked`]).
    ///
    /// # Errors
    /// [`Error::Truncated`]/[`Error::BadLength`] from the framing, [`Error::UnexpectedCommand`]
    /// for another command, [`Error::BadPayloadLength`] for a wrong LEN,
    /// [`Error::UnknownOperatingMode`] and the variant errors for values out of the model.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&T>) -> Result<Self, Error> {
        telegram.check_len()?;
        let payload = telegram.payload();
        let command = telegram.command();
        let bad_len = Error::BadPayloadLength {
            command,
            len: payload.len(),
        };
        match command {
            OPERATING_MODE => {
                let code = payload.get(1).copied().ok_or(bad_len)?;
                let mode = match code {
                    0x24 => OperatingMode::ContinuousAll,
                    0x25 => OperatingMode::OnRequest,
                    0x00 => {
                        let password = payload
                            .get(2..)
                            .and_then(|p| p.first_chunk::<8>())
                            .copied()
                            .ok_or(bad_len)?;
                        OperatingMode::Installation { password }
                    }
                    _ => OperatingMode::Baud(
                        Baud::from_code(code).ok_or(Error::UnknownOperatingMode { code })?,
                    ),
                };
                if payload.len() != 2 + mode.data_len() {
                    return Err(bad_len);
                }
                Ok(Self::SetOperatingMode(mode))
            }
            VARIANT => {
                if payload.len() != 5 {
                    return Err(bad_len);
                }
                let degrees = read_u16_le(payload, 1).ok_or(bad_len)?;
                let centideg = read_u16_le(payload, 3).ok_or(bad_len)?;
                Ok(Self::SetVariant(Variant::from_fields(degrees, centideg)?))
            }
            REQUEST_MEASURED_VALUES => {
                if payload != [REQUEST_MEASURED_VALUES, 0x01] {
                    return Err(bad_len);
                }
                Ok(Self::MeasuredValues)
            }
            found => Err(Error::UnexpectedCommand { found }),
        }
    }

    /// The payload length, bytes.
    #[must_use]
    pub const fn payload_len(&self) -> usize {
        match self {
            Self::SetOperatingMode(mode) => 2 + mode.data_len(),
            Self::SetVariant(_) => 5,
            Self::MeasuredValues => 2,
        }
    }

    /// The telegram's length, bytes: `6 + payload_len()`.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        self.payload_len() + HEADER_LEN + CRC_LEN
    }

    /// Writes the whole telegram (ADR 0x00, CRC filled) to the start of `buf`; returns its
    /// length, [`buffer_len`](Self::buffer_len) bytes. For example
    /// `SetOperatingMode(ContinuousAll)` is `02 00 02 00 20 24 34 08`.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when `buf` is shorter (nothing is written).
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let mut payload = [0u8; 10];
        match self {
            Self::SetOperatingMode(mode) => {
                payload[0] = OPERATING_MODE;
                payload[1] = mode.code();
                if let OperatingMode::Installation { password } = mode {
                    payload[2..].copy_from_slice(password);
                }
            }
            Self::SetVariant(variant) => {
                let [a0, a1] = variant.scan_angle_deg().to_le_bytes();
                let [r0, r1] = variant.resolution_centideg().to_le_bytes();
                payload[..5].copy_from_slice(&[VARIANT, a0, a1, r0, r1]);
            }
            Self::MeasuredValues => {
                payload[..2].copy_from_slice(&[REQUEST_MEASURED_VALUES, 0x01]);
            }
        }
        let len = self.payload_len();
        let bytes = payload.get(..len).unwrap_or(&payload);
        emit_with(buf, ADDRESS_HOST, len, |dst| dst.copy_from_slice(bytes))
    }
}

/// SickReply 0xA0 to an operating-mode request: `A0 result status`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OperatingModeReply {
    /// The result byte: 0x00 the mode changed, 0x01 refused (e.g. a wrong password), 0x02
    /// refused on a fault.
    pub result: u8,
    /// The scanner's status byte.
    pub status: u8,
}

/// Why `telegram` is not the reply `command` with its payload's length: a wrong length when
/// its payload starts with `command`, another command otherwise.
fn not_the_reply<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&T>, command: u8) -> Error {
    let payload = telegram.payload();
    if payload.first() == Some(&command) {
        Error::BadPayloadLength {
            command,
            len: payload.len(),
        }
    } else {
        Error::UnexpectedCommand {
            found: telegram.command(),
        }
    }
}

impl OperatingModeReply {
    /// Whether the mode changed (result 0x00).
    #[must_use]
    pub const fn accepted(&self) -> bool {
        self.result == 0x00
    }

    /// Reads the reply from a telegram's payload (CRC is the caller's, as for [`SickRequest::parse`]).
    ///
    /// # Errors
    /// [`Error::UnexpectedCommand`] for another command, [`Error::BadPayloadLength`] unless
    /// LEN is 3, and the framing errors of [`Telegram::check_len`].
    pub fn parse<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&T>) -> Result<Self, Error> {
        telegram.check_len()?;
        match *telegram.payload() {
            [OPERATING_MODE_REPLY, result, status] => Ok(Self { result, status }),
            _ => Err(not_the_reply(telegram, OPERATING_MODE_REPLY)),
        }
    }

    /// The telegram's length, bytes (9).
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        3 + HEADER_LEN + CRC_LEN
    }

    /// Writes the reply telegram (ADR 0x80) to `buf`; returns its length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when `buf` is shorter than [`buffer_len`](Self::buffer_len).
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let payload = [OPERATING_MODE_REPLY, self.result, self.status];
        emit_with(buf, ADDRESS_REPLY, payload.len(), |dst| {
            dst.copy_from_slice(&payload);
        })
    }
}

/// SickReply 0xBB to a variant request: `BB result angle(u16 LE) resolution(u16 LE) status`.
///
/// The angle and resolution are kept raw: they report the configuration in force, which a
/// refused request leaves as it was; [`VariantReply::variant`] validates them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VariantReply {
    /// The result byte: 0x01 the variant was accepted, 0x00 refused.
    pub result: u8,
    /// The scan angle in force, degrees (100 or 180).
    pub angle_deg: u16,
    /// The resolution in force, hundredths of a degree (25, 50 or 100).
    pub resolution_centideg: u16,
    /// The scanner's status byte.
    pub status: u8,
}

impl VariantReply {
    /// Whether the variant was accepted (result 0x01).
    #[must_use]
    pub const fn accepted(&self) -> bool {
        self.result == 0x01
    }

    /// The variant in force.
    ///
    /// # Errors
    /// As [`Variant::from_fields`].
    pub const fn variant(&self) -> Result<Variant, Error> {
        Variant::from_fields(self.angle_deg, self.resolution_centideg)
    }

    /// Reads the reply from a telegram's payload (CRC is the caller's).
    ///
    /// # Errors
    /// [`Error::UnexpectedCommand`] for another command, [`Error::BadPayloadLength`] unless
    /// LEN is 7, and the framing errors of [`Telegram::check_len`].
    pub fn parse<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&T>) -> Result<Self, Error> {
        telegram.check_len()?;
        match *telegram.payload() {
            [VARIANT_REPLY, result, a0, a1, r0, r1, status] => Ok(Self {
                result,
                angle_deg: u16::from_le_bytes([a0, a1]),
                resolution_centideg: u16::from_le_bytes([r0, r1]),
                status,
            }),
            _ => Err(not_the_reply(telegram, VARIANT_REPLY)),
        }
    }

    /// The telegram's length, bytes (13).
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        7 + HEADER_LEN + CRC_LEN
    }

    /// Writes the reply telegram (ADR 0x80) to `buf`; returns its length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when `buf` is shorter than [`buffer_len`](Self::buffer_len).
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let [a0, a1] = self.angle_deg.to_le_bytes();
        let [r0, r1] = self.resolution_centideg.to_le_bytes();
        let payload = [VARIANT_REPLY, self.result, a0, a1, r0, r1, self.status];
        emit_with(buf, ADDRESS_REPLY, payload.len(), |dst| {
            dst.copy_from_slice(&payload);
        })
    }
}

/// Any reply this module reads, by command byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SickReply<'a> {
    /// 0xA0.
    OperatingMode(OperatingModeReply),
    /// 0xBB.
    Variant(VariantReply),
    /// 0xB0, borrowing the telegram's buffer.
    MeasuredValues(MeasuredValues<'a>),
    /// A well-framed reply with another command byte, left to the caller.
    Other {
        /// Its command byte.
        command: u8,
    },
}

impl<'a> SickReply<'a> {
    /// Reads a reply by its command byte (CRC is the caller's: the accumulator and
    /// [`Telegram::new_checked`] verify it).
    ///
    /// # Errors
    /// The errors of the reply's own `parse`; an unknown command is not an error but
    /// [`SickReply::Other`].
    pub fn parse<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&'a T>) -> Result<Self, Error> {
        telegram.check_len()?;
        match telegram.command() {
            OPERATING_MODE_REPLY => OperatingModeReply::parse(telegram).map(Self::OperatingMode),
            VARIANT_REPLY => VariantReply::parse(telegram).map(Self::Variant),
            super::MEASURED_VALUES_REPLY => {
                MeasuredValues::parse(telegram).map(Self::MeasuredValues)
            }
            command => Ok(Self::Other { command }),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::wire::sick::test_support::emitted;
    use std::vec::Vec;

    fn emit(request: SickRequest) -> Vec<u8> {
        emitted(request.buffer_len(), |buf| request.emit(buf))
    }

    #[test]
    fn operating_mode_bytes_match_the_documented_vectors() {
        use OperatingMode::*;
        let cases: [(OperatingMode, [u8; 8]); 5] = [
            (
                ContinuousAll,
                [0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08],
            ),
            (OnRequest, [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08]),
            (
                Baud(super::Baud::B500k),
                [0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08],
            ),
            (
                Baud(super::Baud::B9600),
                [0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08],
            ),
            (
                Baud(super::Baud::B38400),
                [0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08],
            ),
        ];
        for (mode, wire) in cases {
            let bytes = emit(SickRequest::SetOperatingMode(mode));
            assert_eq!(bytes, wire, "{mode:?}");
            let t = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(
                SickRequest::parse(&t),
                Ok(SickRequest::SetOperatingMode(mode))
            );
        }
    }

    #[test]
    fn variant_bytes_match_the_documented_vector() {
        let bytes = emit(SickRequest::SetVariant(Variant::Fov180StepHalf));
        assert_eq!(
            bytes,
            [0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F]
        );
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(
            SickRequest::parse(&t),
            Ok(SickRequest::SetVariant(Variant::Fov180StepHalf))
        );
    }

    #[test]
    fn installation_and_measured_values_round_trip() {
        let install = SickRequest::SetOperatingMode(OperatingMode::INSTALLATION);
        let bytes = emit(install);
        assert_eq!(&bytes[..6], &[0x02, 0x00, 0x0A, 0x00, 0x20, 0x00]);
        assert_eq!(&bytes[6..14], b"SICK_LMS");
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(SickRequest::parse(&t), Ok(install));

        let bytes = emit(SickRequest::MeasuredValues);
        assert_eq!(&bytes[..6], &[0x02, 0x00, 0x02, 0x00, 0x30, 0x01]);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(SickRequest::parse(&t), Ok(SickRequest::MeasuredValues));
    }

    #[test]
    fn request_parse_refuses_what_it_cannot_represent() {
        let mut buf = [0u8; 32];
        let cases: [(&[u8], Error); 6] = [
            (&[0x20, 0x99], Error::UnknownOperatingMode { code: 0x99 }),
            (
                &[0x20, 0x24, 0x00],
                Error::BadPayloadLength {
                    command: 0x20,
                    len: 3,
                },
            ),
            (
                &[0x20, 0x00, b'S'],
                Error::BadPayloadLength {
                    command: 0x20,
                    len: 3,
                },
            ),
            (
                &[0x3B, 0xB4, 0x00, 0x19, 0x00],
                Error::UnsupportedVariant {
                    degrees: 180,
                    centideg: 25,
                },
            ),
            (
                &[0x3B, 0x5A, 0x00, 0x32, 0x00],
                Error::UnknownScanAngle { degrees: 90 },
            ),
            (&[0x31], Error::UnexpectedCommand { found: 0x31 }),
        ];
        for (payload, error) in cases {
            let n = emit_with(&mut buf, ADDRESS_HOST, payload.len(), |d| {
                d.copy_from_slice(payload)
            })
            .unwrap();
            let t = Telegram::new_checked(&buf[..n]).unwrap();
            assert_eq!(SickRequest::parse(&t), Err(error), "{payload:02x?}");
        }
    }

    #[test]
    fn emit_into_a_short_buffer_writes_nothing() {
        let mut buf = [0xEE_u8; 7];
        assert_eq!(
            SickRequest::SetOperatingMode(OperatingMode::ContinuousAll).emit(&mut buf),
            Err(Error::BufferTooSmall {
                needed: 8,
                available: 7
            })
        );
        assert_eq!(buf, [0xEE; 7]);
    }

    #[test]
    fn replies_round_trip() {
        let mut buf = [0u8; 16];
        let a0 = OperatingModeReply {
            result: 0x00,
            status: 0x10,
        };
        let n = a0.emit(&mut buf).unwrap();
        assert_eq!(n, a0.buffer_len());
        assert_eq!(&buf[..7], &[0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10]);
        let t = Telegram::new_checked(&buf[..n]).unwrap();
        assert_eq!(SickReply::parse(&t), Ok(SickReply::OperatingMode(a0)));
        assert!(a0.accepted());

        let bb = VariantReply {
            result: 0x01,
            angle_deg: 180,
            resolution_centideg: 50,
            status: 0x10,
        };
        let n = bb.emit(&mut buf).unwrap();
        assert_eq!(n, bb.buffer_len());
        let t = Telegram::new_checked(&buf[..n]).unwrap();
        assert_eq!(SickReply::parse(&t), Ok(SickReply::Variant(bb)));
        assert!(bb.accepted());
        assert_eq!(bb.variant(), Ok(Variant::Fov180StepHalf));

        let n = emit_with(&mut buf, ADDRESS_REPLY, 2, |d| {
            d.copy_from_slice(&[0xB1, 0])
        })
        .unwrap();
        let t = Telegram::new_checked(&buf[..n]).unwrap();
        assert_eq!(SickReply::parse(&t), Ok(SickReply::Other { command: 0xB1 }));

        let n = emit_with(&mut buf, ADDRESS_REPLY, 2, |d| {
            d.copy_from_slice(&[0xA0, 0])
        })
        .unwrap();
        let t = Telegram::new_checked(&buf[..n]).unwrap();
        assert_eq!(
            SickReply::parse(&t),
            Err(Error::BadPayloadLength {
                command: 0xA0,
                len: 2
            })
        );
    }

    #[test]
    fn beam_angles() {
        for (variant, beams) in [
            (Variant::Fov180StepHalf, 361),
            (Variant::Fov100StepQuarter, 401),
            (Variant::Fov180Step1, 181),
        ] {
            assert_eq!(variant.beam_count(), beams);
        }
        // (variant, beams in the scan, partial-scan phase, beam index, angle in centidegrees)
        for (variant, beams, phase, index, angle) in [
            (Variant::Fov180StepHalf, 361, 0, 0, Some(0)),
            (Variant::Fov180StepHalf, 361, 0, 1, Some(50)),
            (Variant::Fov180StepHalf, 361, 0, 180, Some(9_000)),
            (Variant::Fov180StepHalf, 361, 0, 360, Some(18_000)),
            (Variant::Fov180StepHalf, 361, 0, 361, None),
            // A 1° partial scan of the interlaced 0.5° mode, second phase.
            (Variant::Fov180StepHalf, 181, 2, 0, Some(50)),
            (Variant::Fov180StepHalf, 181, 2, 1, Some(150)),
            (Variant::Fov180StepHalf, 181, 4, 1, None),
            (Variant::Fov180StepHalf, 1, 0, 0, None),
            (Variant::Fov100StepQuarter, 401, 0, 0, Some(4_000)),
            (Variant::Fov100StepQuarter, 401, 0, 1, Some(4_025)),
            (Variant::Fov100StepQuarter, 401, 0, 400, Some(14_000)),
            (Variant::Fov100StepQuarter, 101, 3, 0, Some(4_075)),
            (Variant::Fov180Step1, 181, 0, 90, Some(9_000)),
        ] {
            assert_eq!(
                variant.beam_angle_centideg(beams, phase, index),
                angle,
                "{variant:?} {beams} {phase} {index}"
            );
        }
        assert!(Variant::from_fields(180, 25).is_err());
        assert_eq!(reply_command(VARIANT), VARIANT_REPLY);
        assert_eq!(reply_command(OPERATING_MODE), OPERATING_MODE_REPLY);
    }
}
