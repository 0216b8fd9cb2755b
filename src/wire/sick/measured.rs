//! SickReply 0xB0: the measured values of one scan.
//!
//! ```text
//! B0 | count word (u16 LE) | N x value (u16 LE) | [real-time scan index (u8)] | status (u8)
//! ```
//! - Count word: N = bits 0-9; bits 11-12 the partial-scan index of interlaced 0.25°/0.5°
//!   modes; bits 14-15 the unit, 00 cm, 01 mm (10 and 11 are refused). Bits 10 and 13 are
//!   ignored.
//! - The scan-index byte is present only when the scanner's "availability" configuration asks
//!   for it; LEN tells: `4 + 2N` without it, `5 + 2N` with it. Anything else is refused.
//! - Each value carries flag bits above its distance bits; how many distance bits depends on
//!   the measuring mode set with command 0x77 ([`MeasuringMode`]). The all-ones distance of
//!   the mode means "no echo" and yields no range.

use super::telegram::{emit_with, Telegram, ADDRESS_REPLY, CRC_LEN, HEADER_LEN, MAX_PAYLOAD_LEN};
use super::variant::Variant;
use super::Error;
use core::iter::FusedIterator;

/// The command byte of the measured-values reply.
pub const MEASURED_VALUES_REPLY: u8 = 0xB0;

/// The most values one telegram holds: `(812 − 4) / 2 = 404` (403 with the scan-index byte).
pub const MAX_VALUES: usize = (MAX_PAYLOAD_LEN - 4) / 2;

/// The unit of the distances in a measured-values reply (count word bits 14-15).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Unit {
    /// Code 00: centimetres (the "80 m" modes).
    Centimetre,
    /// Code 01: millimetres (the "8 m" modes).
    Millimetre,
}

impl Unit {
    /// The 2-bit code of the count word.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Centimetre => 0,
            Self::Millimetre => 1,
        }
    }

    /// The unit of a 2-bit code.
    ///
    /// # Errors
    /// [`Error::UnknownUnit`] for codes 10 and 11 (and anything above 3).
    pub const fn from_code(code: u8) -> Result<Self, Error> {
        match code {
            0 => Ok(Self::Centimetre),
            1 => Ok(Self::Millimetre),
            _ => Err(Error::UnknownUnit { code }),
        }
    }

    /// Millimetres per unit: 10 or 1.
    #[must_use]
    pub const fn millimetres(self) -> u32 {
        match self {
            Self::Centimetre => 10,
            Self::Millimetre => 1,
        }
    }

    /// `"cm"` or `"mm"`.
    #[must_use]
    pub const fn symbol(self) -> &'static str {
        match self {
            Self::Centimetre => "cm",
            Self::Millimetre => "mm",
        }
    }
}

/// The measuring mode configured with command 0x77, as far as it decides how many low bits of
/// a value are distance. The upper bits are flags (field A/B/C, dazzle or reflector levels,
/// depending on the mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MeasuringMode {
    /// Modes 0x00-0x02: 8 m in mm / 80 m in cm; distance mask 0x1FFF, 3 flag bits (13-15).
    /// Real captures have bit 13 set on ordinary returns. The default.
    #[default]
    Mm8Cm80,
    /// Modes 0x03 and 0x04: 16 m; distance mask 0x3FFF, 2 flag bits.
    Range16m,
    /// Modes 0x05 and 0x06: 32 m; distance mask 0x7FFF, 1 flag bit.
    Range32m,
    /// Mode 0x0F: 32 m; distance mask 0xFFFF, no flag bits.
    Range32mNoFlags,
}

impl MeasuringMode {
    /// The class of a 0x77 mode code.
    ///
    /// # Errors
    /// [`Error::UnknownMeasuringMode`] for 0x07-0x0E and above 0x0F.
    pub const fn from_code(code: u8) -> Result<Self, Error> {
        match code {
            0x00..=0x02 => Ok(Self::Mm8Cm80),
            0x03 | 0x04 => Ok(Self::Range16m),
            0x05 | 0x06 => Ok(Self::Range32m),
            0x0F => Ok(Self::Range32mNoFlags),
            _ => Err(Error::UnknownMeasuringMode { code }),
        }
    }

    /// Distance bits of a value: 13, 14, 15 or 16.
    #[must_use]
    pub const fn distance_bits(self) -> u32 {
        match self {
            Self::Mm8Cm80 => 13,
            Self::Range16m => 14,
            Self::Range32m => 15,
            Self::Range32mNoFlags => 16,
        }
    }

    /// The mask of the distance bits: 0x1FFF, 0x3FFF, 0x7FFF or 0xFFFF.
    #[must_use]
    pub const fn distance_mask(self) -> u16 {
        match self {
            Self::Mm8Cm80 => 0x1FFF,
            Self::Range16m => 0x3FFF,
            Self::Range32m => 0x7FFF,
            Self::Range32mNoFlags => 0xFFFF,
        }
    }

    /// The masked distance that means "no echo" (out of range): all ones, equal to the mask.
    #[must_use]
    pub const fn no_echo(self) -> u16 {
        self.distance_mask()
    }
}

/// The range of one raw value, millimetres: the masked distance times 10 in cm mode (up to
/// 655 350 mm, exact in a u32), or `None` for the "no echo" value of the mode.
#[must_use]
pub fn range_mm(raw: u16, mode: MeasuringMode, unit: Unit) -> Option<u32> {
    let distance = raw & mode.distance_mask();
    if distance == mode.no_echo() {
        None
    } else {
        Some(u32::from(distance).saturating_mul(unit.millimetres()))
    }
}

/// A measured-values reply (0xB0): a validated, zero-copy representation whose values stay in
/// the telegram's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasuredValues<'a> {
    unit: Unit,
    partial_index: u8,
    values: &'a [u8],
    scan_index: Option<u8>,
    status: u8,
}

impl<'a> MeasuredValues<'a> {
    /// A reply to emit: `values` holds the raw values as u16 LE pairs (flag bits included).
    ///
    /// # Errors
    /// [`Error::BadPartialIndex`] above 3, [`Error::OddValueBytes`] for an odd `values`
    /// length, [`Error::BadCount`] when the payload would exceed 812 bytes (more than
    /// [`MAX_VALUES`] values, or 403 with a scan index).
    pub fn new(
        unit: Unit,
        partial_index: u8,
        values: &'a [u8],
        scan_index: Option<u8>,
        status: u8,
    ) -> Result<Self, Error> {
        if partial_index > 3 {
            return Err(Error::BadPartialIndex {
                index: partial_index,
            });
        }
        if !values.len().is_multiple_of(2) {
            return Err(Error::OddValueBytes { len: values.len() });
        }
        let len = payload_len_of(values.len(), scan_index.is_some());
        if len > MAX_PAYLOAD_LEN {
            return Err(Error::BadCount {
                count: u16::try_from(values.len() / 2).unwrap_or(u16::MAX),
                len,
            });
        }
        Ok(Self {
            unit,
            partial_index,
            values,
            scan_index,
            status,
        })
    }

    /// Reads the reply from a telegram (CRC is the caller's: [`Telegram::new_checked`] and
    /// the accumulator verify it).
    ///
    /// # Errors
    /// The framing errors of [`Telegram::check_len`], and those of
    /// [`parse_payload`](Self::parse_payload).
    pub fn parse<T: AsRef<[u8]> + ?Sized>(telegram: &Telegram<&'a T>) -> Result<Self, Error> {
        telegram.check_len()?;
        Self::parse_payload(telegram.payload())
    }

    /// Reads the reply from a payload (command byte through status byte).
    ///
    /// # Errors
    /// [`Error::UnexpectedCommand`] unless the command is 0xB0, [`Error::BadPayloadLength`]
    /// without a count word, [`Error::UnknownUnit`] for unit codes 10/11, [`Error::BadCount`]
    /// unless LEN is `4 + 2N` or `5 + 2N`.
    pub fn parse_payload(payload: &'a [u8]) -> Result<Self, Error> {
        let len = payload.len();
        let Some((&command, rest)) = payload.split_first() else {
            return Err(Error::UnexpectedCommand { found: 0 });
        };
        if command != MEASURED_VALUES_REPLY {
            return Err(Error::UnexpectedCommand { found: command });
        }
        let Some((&[lo, hi], rest)) = rest.split_first_chunk::<2>() else {
            return Err(Error::BadPayloadLength { command, len });
        };
        let count = u16::from_le_bytes([lo, hi & 0x03]);
        let partial_index = (hi & 0x18) >> 3;
        let unit = Unit::from_code(hi >> 6)?;
        let bad_count = Error::BadCount { count, len };
        let (values, tail) = rest
            .split_at_checked(usize::from(count) * 2)
            .ok_or(bad_count)?;
        let (scan_index, status) = match *tail {
            [status] => (None, status),
            [index, status] => (Some(index), status),
            _ => return Err(bad_count),
        };
        Ok(Self {
            unit,
            partial_index,
            values,
            scan_index,
            status,
        })
    }

    /// N, the number of values (0..=404).
    #[must_use]
    pub fn count(&self) -> u16 {
        u16::try_from(self.values.len() / 2).unwrap_or(u16::MAX)
    }

    /// The unit of the distances.
    #[must_use]
    pub const fn unit(&self) -> Unit {
        self.unit
    }

    /// The partial-scan index (0..=3) of an interlaced 0.25°/0.5° mode; 0 in a full scan.
    #[must_use]
    pub const fn partial_index(&self) -> u8 {
        self.partial_index
    }

    /// The real-time scan index (modulo 256), when the scanner is configured to send it.
    #[must_use]
    pub const fn scan_index(&self) -> Option<u8> {
        self.scan_index
    }

    /// The scanner's status byte.
    #[must_use]
    pub const fn status(&self) -> u8 {
        self.status
    }

    /// The count word as emitted: N, the partial index in bits 11-12, the unit in bits 14-15.
    #[must_use]
    pub fn count_word(&self) -> u16 {
        (self.count() & 0x03FF)
            | (u16::from(self.partial_index & 0x03) << 11)
            | (u16::from(self.unit.code()) << 14)
    }

    /// The raw values as u16 LE pairs, as on the wire.
    #[must_use]
    pub const fn values_le(&self) -> &'a [u8] {
        self.values
    }

    /// The raw values, flag bits included.
    #[must_use]
    pub const fn raw_values(&self) -> RawValues<'a> {
        RawValues { bytes: self.values }
    }

    /// The ranges in millimetres, one per value: the distance under `mode`'s mask, times 10 in
    /// cm mode, or `None` for "no echo" (see [`range_mm`]).
    #[must_use]
    pub const fn ranges_mm(&self, mode: MeasuringMode) -> RangesMm<'a> {
        RangesMm {
            raw: self.raw_values(),
            mask: mode.distance_mask(),
            scale: self.unit.millimetres(),
        }
    }

    /// The flag bits of each value, shifted down: the bits above `mode`'s distance bits
    /// (0..=7 in the 8 m/80 m modes, always 0 in mode 0x0F).
    #[must_use]
    pub const fn flags(&self, mode: MeasuringMode) -> Flags<'a> {
        Flags {
            raw: self.raw_values(),
            shift: mode.distance_bits(),
        }
    }

    /// The beam angle of value `index`, hundredths of a degree, for a scanner in `variant`;
    /// see [`Variant::beam_angle_centideg`].
    #[must_use]
    pub fn beam_angle_centideg(&self, variant: Variant, index: u16) -> Option<u32> {
        variant.beam_angle_centideg(self.count(), self.partial_index, index)
    }

    /// The payload length, bytes: `4 + 2N`, plus 1 with the scan index.
    #[must_use]
    pub const fn payload_len(&self) -> usize {
        payload_len_of(self.values.len(), self.scan_index.is_some())
    }

    /// The telegram's length, bytes: `6 + payload_len()`.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        self.payload_len() + HEADER_LEN + CRC_LEN
    }

    /// Writes the reply telegram (ADR 0x80, CRC filled) to the start of `buf`; returns its
    /// length, [`buffer_len`](Self::buffer_len) bytes.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when `buf` is shorter (nothing is written).
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let [w0, w1] = self.count_word().to_le_bytes();
        let head = [MEASURED_VALUES_REPLY, w0, w1];
        let index = self.scan_index.map(|i| [i]);
        let index: &[u8] = match &index {
            Some(i) => i,
            None => &[],
        };
        let status = [self.status];
        emit_with(buf, ADDRESS_REPLY, self.payload_len(), |dst| {
            let mut rest = dst;
            for part in [&head[..], self.values, index, &status[..]] {
                let Some((to, tail)) = core::mem::take(&mut rest).split_at_mut_checked(part.len())
                else {
                    return;
                };
                to.copy_from_slice(part);
                rest = tail;
            }
        })
    }
}

const fn payload_len_of(value_bytes: usize, scan_index: bool) -> usize {
    value_bytes.saturating_add(4 + scan_index as usize)
}

/// The raw values of a reply, u16 each (flag bits included), in order.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawValues<'a> {
    bytes: &'a [u8],
}

impl Iterator for RawValues<'_> {
    type Item = u16;

    fn next(&mut self) -> Option<u16> {
        let (pair, rest) = self.bytes.split_first_chunk::<2>()?;
        self.bytes = rest;
        Some(u16::from_le_bytes(*pair))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.bytes.len() / 2;
        (n, Some(n))
    }
}

impl DoubleEndedIterator for RawValues<'_> {
    fn next_back(&mut self) -> Option<u16> {
        let (rest, pair) = self.bytes.split_last_chunk::<2>()?;
        self.bytes = rest;
        Some(u16::from_le_bytes(*pair))
    }
}

impl ExactSizeIterator for RawValues<'_> {}
impl FusedIterator for RawValues<'_> {}

/// The ranges of a reply in millimetres (`None` for no echo), in order; see
/// [`MeasuredValues::ranges_mm`].
#[derive(Debug, Clone)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangesMm<'a> {
    raw: RawValues<'a>,
    /// The mode's distance mask, which is also its "no echo" value.
    mask: u16,
    /// Millimetres per unit of the reply: 1 or 10.
    scale: u32,
}

impl RangesMm<'_> {
    /// [`range_mm`] with the mode's mask and the unit's scale looked up once per reply.
    #[inline]
    fn range(&self, raw: u16) -> Option<u32> {
        let distance = raw & self.mask;
        // The mask is the mode's "no echo" value; 65 535 · 10 fits a u32.
        (distance != self.mask).then(|| u32::from(distance) * self.scale)
    }
}

impl Iterator for RangesMm<'_> {
    type Item = Option<u32>;

    fn next(&mut self) -> Option<Option<u32>> {
        let raw = self.raw.next()?;
        Some(self.range(raw))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.raw.size_hint()
    }
}

impl DoubleEndedIterator for RangesMm<'_> {
    fn next_back(&mut self) -> Option<Option<u32>> {
        let raw = self.raw.next_back()?;
        Some(self.range(raw))
    }
}

impl ExactSizeIterator for RangesMm<'_> {}
impl FusedIterator for RangesMm<'_> {}

/// The flag bits of each value of a reply, shifted down, in order; see
/// [`MeasuredValues::flags`].
#[derive(Debug, Clone)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags<'a> {
    raw: RawValues<'a>,
    shift: u32,
}

impl Iterator for Flags<'_> {
    type Item = u8;

    fn next(&mut self) -> Option<u8> {
        let raw = self.raw.next()?;
        let flags = raw.checked_shr(self.shift).unwrap_or(0);
        Some(u8::try_from(flags).unwrap_or(u8::MAX))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.raw.size_hint()
    }
}

impl ExactSizeIterator for Flags<'_> {}
impl FusedIterator for Flags<'_> {}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::wire::sick::test_support::emitted;
    use crate::wire::sick::{emit_telegram, SickReply};
    use std::vec::Vec;

    fn le(values: &[u16]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    fn emit(m: &MeasuredValues<'_>) -> Vec<u8> {
        emitted(m.buffer_len(), |buf| m.emit(buf))
    }

    #[test]
    fn round_trip_with_and_without_scan_index() {
        let values = le(&[0x21C2, 0x1FFF, 0x0000, 0xE123]);
        for scan_index in [None, Some(7)] {
            let m = MeasuredValues::new(Unit::Millimetre, 2, &values, scan_index, 0x10).unwrap();
            let bytes = emit(&m);
            assert_eq!(bytes[1], 0x80);
            assert_eq!(
                usize::from(bytes[2]),
                4 + 8 + usize::from(scan_index.is_some())
            );
            let t = Telegram::new_checked(&bytes[..]).unwrap();
            let p = MeasuredValues::parse(&t).unwrap();
            assert_eq!(p, m);
            assert_eq!(p.count(), 4);
            assert_eq!(p.partial_index(), 2);
            assert_eq!(p.scan_index(), scan_index);
            assert_eq!(p.status(), 0x10);
            assert_eq!(p.count_word(), 4 | (2 << 11) | (1 << 14));
            assert_eq!(SickReply::parse(&t), Ok(SickReply::MeasuredValues(m)));
        }
    }

    #[test]
    fn bit_13_is_a_flag_in_the_8m_mode() {
        // 450 mm with bit 13 set: a decoder without the mask reads 8.6 m.
        let values = le(&[0x2000 | 450, 0x1FFF, 0x3FFF, 0]);
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        let r: Vec<_> = m.ranges_mm(MeasuringMode::Mm8Cm80).collect();
        assert_eq!(r, [Some(450), None, None, Some(0)]);
        let f: Vec<_> = m.flags(MeasuringMode::Mm8Cm80).collect();
        assert_eq!(f, [1, 0, 1, 0]);
        let r: Vec<_> = m.ranges_mm(MeasuringMode::Range16m).collect();
        assert_eq!(r, [Some(0x2000 | 450), Some(0x1FFF), None, Some(0)]);
        let r: Vec<_> = m.ranges_mm(MeasuringMode::Range32mNoFlags).rev().collect();
        assert_eq!(r, [Some(0), Some(0x3FFF), Some(0x1FFF), Some(0x2000 | 450)]);
        assert!(m.flags(MeasuringMode::Range32mNoFlags).all(|f| f == 0));
    }

    #[test]
    fn ranges_are_range_mm_of_every_value_in_every_mode_and_unit() {
        // Every 16-bit value, forwards and backwards, in both units and all four modes.
        let all: Vec<u16> = (0..=u16::MAX).collect();
        let bytes = le(&all);
        for unit in [Unit::Millimetre, Unit::Centimetre] {
            for mode in [
                MeasuringMode::Mm8Cm80,
                MeasuringMode::Range16m,
                MeasuringMode::Range32m,
                MeasuringMode::Range32mNoFlags,
            ] {
                let ranges = RangesMm {
                    raw: RawValues { bytes: &bytes },
                    mask: mode.distance_mask(),
                    scale: unit.millimetres(),
                };
                let want: Vec<_> = all.iter().map(|&raw| range_mm(raw, mode, unit)).collect();
                assert_eq!(ranges.clone().collect::<Vec<_>>(), want);
                let mut back: Vec<_> = ranges.rev().collect();
                back.reverse();
                assert_eq!(back, want);
            }
        }
    }

    #[test]
    fn masks_and_no_echo_per_mode() {
        let cases = [
            (MeasuringMode::Mm8Cm80, 0x1FFF),
            (MeasuringMode::Range16m, 0x3FFF),
            (MeasuringMode::Range32m, 0x7FFF),
            (MeasuringMode::Range32mNoFlags, 0xFFFF),
        ];
        for (mode, mask) in cases {
            assert_eq!(mode.distance_mask(), mask);
            assert_eq!(range_mm(0xFFFF, mode, Unit::Millimetre), None);
            assert_eq!(range_mm(mask, mode, Unit::Centimetre), None);
            assert_eq!(
                range_mm(mask - 1, mode, Unit::Centimetre),
                Some(u32::from(mask - 1) * 10)
            );
            assert_eq!(range_mm(!mask, mode, Unit::Millimetre), Some(0));
        }
        for code in 0..=255u8 {
            let m = MeasuringMode::from_code(code);
            match code {
                0..=2 => assert_eq!(m, Ok(MeasuringMode::Mm8Cm80)),
                3 | 4 => assert_eq!(m, Ok(MeasuringMode::Range16m)),
                5 | 6 => assert_eq!(m, Ok(MeasuringMode::Range32m)),
                0x0F => assert_eq!(m, Ok(MeasuringMode::Range32mNoFlags)),
                _ => assert_eq!(m, Err(Error::UnknownMeasuringMode { code })),
            }
        }
        assert_eq!(MeasuringMode::default(), MeasuringMode::Mm8Cm80);
    }

    #[test]
    fn cm_values_are_scaled_to_mm() {
        let values = le(&[0x1FFE, 1, 0x1FFF]);
        let m = MeasuredValues::new(Unit::Centimetre, 0, &values, None, 0).unwrap();
        let r: Vec<_> = m.ranges_mm(MeasuringMode::Mm8Cm80).collect();
        assert_eq!(r, [Some(81_900), Some(10), None]);
    }

    fn frame(payload: &[u8]) -> Vec<u8> {
        let mut buf = [0u8; 818];
        let n = emit_telegram(0x80, payload, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn parse_refuses_bad_units_counts_and_commands() {
        // Unit code 10.
        let bytes = frame(&[0xB0, 0x01, 0x80, 0x34, 0x12, 0x00]);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(
            MeasuredValues::parse(&t),
            Err(Error::UnknownUnit { code: 2 })
        );
        // N = 2 but one value.
        let bytes = frame(&[0xB0, 0x02, 0x40, 0x34, 0x12, 0x00]);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(
            MeasuredValues::parse(&t),
            Err(Error::BadCount { count: 2, len: 6 })
        );
        // Two extra bytes after the values and status.
        let bytes = frame(&[0xB0, 0x01, 0x40, 0x34, 0x12, 0x00, 0x00, 0x00]);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(
            MeasuredValues::parse(&t),
            Err(Error::BadCount { count: 1, len: 8 })
        );
        // No status byte.
        assert_eq!(
            MeasuredValues::parse_payload(&[0xB0, 0x00, 0x40]),
            Err(Error::BadCount { count: 0, len: 3 })
        );
        assert_eq!(
            MeasuredValues::parse_payload(&[0xB0, 0x00]),
            Err(Error::BadPayloadLength {
                command: 0xB0,
                len: 2
            })
        );
        assert_eq!(
            MeasuredValues::parse_payload(&[0xA0, 0x00, 0x10]),
            Err(Error::UnexpectedCommand { found: 0xA0 })
        );
        assert_eq!(
            MeasuredValues::parse_payload(&[]),
            Err(Error::UnexpectedCommand { found: 0 })
        );
        // The count word's maximum (1023) cannot fit.
        let bytes = frame(&[0xB0, 0xFF, 0x43, 0x00]);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(
            MeasuredValues::parse(&t),
            Err(Error::BadCount {
                count: 1023,
                len: 4
            })
        );
    }

    #[test]
    fn parse_payload_never_panics_on_any_short_payload() {
        for len in 0..8 {
            for fill in [0x00, 0x40, 0xB0, 0xFF] {
                let mut p = [fill; 8];
                p[0] = 0xB0;
                let _ = MeasuredValues::parse_payload(&p[..len]);
            }
        }
    }

    #[test]
    fn constructor_limits() {
        let max = [0u8; 2 * MAX_VALUES];
        assert!(MeasuredValues::new(Unit::Millimetre, 0, &max, None, 0).is_ok());
        assert_eq!(
            MeasuredValues::new(Unit::Millimetre, 0, &max, Some(1), 0),
            Err(Error::BadCount {
                count: 404,
                len: 813
            })
        );
        assert_eq!(
            MeasuredValues::new(Unit::Millimetre, 4, &max[..2], None, 0),
            Err(Error::BadPartialIndex { index: 4 })
        );
        assert_eq!(
            MeasuredValues::new(Unit::Millimetre, 0, &max[..3], None, 0),
            Err(Error::OddValueBytes { len: 3 })
        );
        let m = MeasuredValues::new(Unit::Millimetre, 0, &max, None, 0).unwrap();
        assert_eq!(m.buffer_len(), 818);
        let mut short = [0u8; 817];
        assert_eq!(
            m.emit(&mut short),
            Err(Error::BufferTooSmall {
                needed: 818,
                available: 817
            })
        );
    }

    #[test]
    fn beam_angle_of_a_reply() {
        let values = [0u8; 2 * 361];
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        assert_eq!(m.beam_angle_centideg(Variant::Fov180StepHalf, 3), Some(150));
    }
}
