//! The framed telegram: a zero-copy view, as smoltcp's `Packet`.

use super::{crc16, read_u16_le, Error};
use crate::wire::check;

/// Start of text, the first byte of every telegram.
pub const STX: u8 = 0x02;
/// ADR of telegrams from the host to the scanner.
pub const ADDRESS_HOST: u8 = 0x00;
/// ADR of the scanner's replies; a receiver synchronises on `STX ADDRESS_REPLY` (`02 80`).
pub const ADDRESS_REPLY: u8 = 0x80;
/// Bytes before the payload: STX, ADR and LEN (u16 LE).
pub const HEADER_LEN: usize = 4;
/// Bytes after the payload: the CRC (u16 LE).
pub const CRC_LEN: usize = 2;
/// The largest payload (LEN) a telegram carries, bytes.
pub const MAX_PAYLOAD_LEN: usize = 812;
/// The largest telegram, bytes: header + [`MAX_PAYLOAD_LEN`] + CRC = 818.
pub const MAX_TELEGRAM_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;

mod field {
    pub const STX: usize = 0;
    pub const ADR: usize = 1;
    pub const LEN: usize = 2;
    pub const PAYLOAD: usize = 4;
}

/// A zero-copy view over one framed telegram held in `T` (a slice, an array, a `Vec`).
///
/// Made with [`Telegram::new_checked`], the view has passed every framing check: the buffer
/// holds the header, LEN lies in `1..=812`, the buffer holds the whole telegram, the first
/// byte is STX and the CRC matches. Bytes after the telegram's end are ignored.
///
/// Made with [`Telegram::new_unchecked`], its accessors still never panic: absent bytes read as
/// zero and absent slices as empty (see the [module's panic contract](crate::wire)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telegram<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Telegram<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after [`check_len`](Self::check_len), the STX check and the CRC check.
    ///
    /// # Errors
    /// [`Error::Truncated`], [`Error::BadLength`], [`Error::BadStx`] or [`Error::BadCrc`].
    pub fn new_checked(buffer: T) -> Result<Self, Error> {
        let telegram = Self::new_unchecked(buffer);
        telegram.check_len()?;
        telegram.check_stx()?;
        telegram.check_crc()?;
        Ok(telegram)
    }

    /// Checks that the buffer holds the header, that LEN lies in `1..=`[`MAX_PAYLOAD_LEN`],
    /// and that the buffer holds the whole telegram (`6 + LEN` bytes). After it passes, every
    /// accessor reads real bytes.
    ///
    /// # Errors
    /// [`Error::Truncated`] for a short buffer, [`Error::BadLength`] for an impossible LEN.
    pub fn check_len(&self) -> Result<(), Error> {
        let data = self.buffer.as_ref();
        if data.len() < HEADER_LEN {
            return Err(Error::Truncated);
        }
        let len = usize::from(self.payload_len());
        if len == 0 || len > MAX_PAYLOAD_LEN {
            return Err(Error::BadLength { len });
        }
        if data.len() < self.total_len() {
            return Err(Error::Truncated);
        }
        Ok(())
    }

    /// Checks that the first byte is STX.
    ///
    /// # Errors
    /// [`Error::Truncated`] for an empty buffer, [`Error::BadStx`] for another byte.
    pub fn check_stx(&self) -> Result<(), Error> {
        match self.buffer.as_ref().first() {
            None => Err(Error::Truncated),
            Some(&STX) => Ok(()),
            Some(&found) => Err(Error::BadStx { found }),
        }
    }

    /// Checks the CRC carried after the payload against the one computed over STX..payload.
    ///
    /// # Errors
    /// [`Error::Truncated`] when the buffer does not hold the whole telegram,
    /// [`Error::BadCrc`] on a mismatch.
    pub fn check_crc(&self) -> Result<(), Error> {
        let total = self.total_len();
        let Some(body) = self.buffer.as_ref().get(..total.saturating_sub(CRC_LEN)) else {
            return Err(Error::Truncated);
        };
        let Some(stored) = read_u16_le(self.buffer.as_ref(), body.len()) else {
            return Err(Error::Truncated);
        };
        let computed = crc16(body);
        check::stored_matches(stored, computed, |stored, computed| Error::BadCrc {
            stored,
            computed,
        })
    }

    /// Unwraps the buffer.
    #[must_use]
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The first byte (STX, 0x02, in a valid telegram); 0 if absent.
    pub fn stx(&self) -> u8 {
        self.byte(field::STX)
    }

    /// ADR: [`ADDRESS_HOST`] (0x00) in requests, [`ADDRESS_REPLY`] (0x80) in replies; 0 if absent.
    pub fn address(&self) -> u8 {
        self.byte(field::ADR)
    }

    /// LEN, the payload length in bytes (command, data, and a reply's status byte); 0 if
    /// absent. Only checked values (1..=812) are meaningful.
    pub fn payload_len(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), field::LEN).unwrap_or(0)
    }

    /// The telegram's length in bytes as LEN announces it: `6 + LEN` (6..=65 541).
    pub fn total_len(&self) -> usize {
        usize::from(self.payload_len()).saturating_add(HEADER_LEN + CRC_LEN)
    }

    /// The command byte (first payload byte); 0 if absent.
    pub fn command(&self) -> u8 {
        self.byte(field::PAYLOAD)
    }

    /// The CRC carried after the payload (as sent: little-endian on the wire); 0 if absent.
    pub fn crc(&self) -> u16 {
        let at = usize::from(self.payload_len()).saturating_add(HEADER_LEN);
        read_u16_le(self.buffer.as_ref(), at).unwrap_or(0)
    }

    /// The CRC computed over STX..payload, over the bytes present.
    pub fn computed_crc(&self) -> u16 {
        let end = usize::from(self.payload_len()).saturating_add(HEADER_LEN);
        let data = self.buffer.as_ref();
        crc16(data.get(..end).unwrap_or(data))
    }

    /// The telegram's bytes, STX through CRC, without anything the buffer holds after them;
    /// the whole buffer when it is shorter than LEN announces.
    pub fn as_bytes(&self) -> &[u8] {
        let data = self.buffer.as_ref();
        data.get(..self.total_len()).unwrap_or(data)
    }

    fn byte(&self, at: usize) -> u8 {
        self.buffer.as_ref().get(at).copied().unwrap_or(0)
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> Telegram<&'a T> {
    /// The payload (LEN bytes after the header: command, data, status), borrowed for the
    /// buffer's lifetime; the bytes present when the buffer is short.
    pub fn payload(&self) -> &'a [u8] {
        let data: &'a [u8] = self.buffer.as_ref();
        let end = usize::from(self.payload_len()).saturating_add(HEADER_LEN);
        let upto = data.get(..end).unwrap_or(data);
        upto.get(field::PAYLOAD..).unwrap_or(&[])
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Telegram<T> {
    /// Sets the first byte (STX); ignored if the buffer is empty.
    pub fn set_stx(&mut self, value: u8) {
        self.set_byte(field::STX, value);
    }

    /// Sets ADR; ignored if absent.
    pub fn set_address(&mut self, value: u8) {
        self.set_byte(field::ADR, value);
    }

    /// Sets LEN, the payload length in bytes; ignored if the buffer is shorter than the header.
    pub fn set_payload_len(&mut self, value: u16) {
        if let Some(len) = self
            .buffer
            .as_mut()
            .get_mut(field::LEN..)
            .and_then(<[u8]>::first_chunk_mut::<2>)
        {
            *len = value.to_le_bytes();
        }
    }

    /// The payload, mutable: the LEN bytes after the header that the buffer holds.
    pub fn payload_mut(&mut self) -> &mut [u8] {
        let end = usize::from(self.payload_len()).saturating_add(HEADER_LEN);
        let data = self.buffer.as_mut();
        let len = data.len();
        data.get_mut(field::PAYLOAD..end.min(len))
            .unwrap_or(&mut [])
    }

    /// Computes the CRC over STX..payload and writes it after the payload; ignored when the
    /// buffer does not hold the whole telegram.
    pub fn fill_crc(&mut self) {
        let at = usize::from(self.payload_len()).saturating_add(HEADER_LEN);
        let data = self.buffer.as_mut();
        let Some((body, rest)) = data.split_at_mut_checked(at) else {
            return;
        };
        let crc = crc16(body);
        if let Some(slot) = rest.first_chunk_mut::<2>() {
            *slot = crc.to_le_bytes();
        }
    }

    fn set_byte(&mut self, at: usize, value: u8) {
        if let Some(b) = self.buffer.as_mut().get_mut(at) {
            *b = value;
        }
    }
}

/// Frames `payload` into `buf` as one telegram (STX, `address`, LEN, payload, CRC) and
/// returns its length, `6 + payload.len()` bytes.
///
/// # Errors
/// [`Error::BadLength`] for an empty payload or one above [`MAX_PAYLOAD_LEN`],
/// [`Error::BufferTooSmall`] when `buf` cannot hold the telegram (nothing is written).
pub fn emit_telegram(address: u8, payload: &[u8], buf: &mut [u8]) -> Result<usize, Error> {
    emit_with(buf, address, payload.len(), |dst| {
        dst.copy_from_slice(payload);
    })
}

/// Frames a payload of `payload_len` bytes written by `fill` into `buf`; returns the
/// telegram's length. `fill` receives exactly `payload_len` bytes.
pub(super) fn emit_with(
    buf: &mut [u8],
    address: u8,
    payload_len: usize,
    fill: impl FnOnce(&mut [u8]),
) -> Result<usize, Error> {
    let len = match u16::try_from(payload_len) {
        Ok(len) if payload_len != 0 && payload_len <= MAX_PAYLOAD_LEN => len,
        _ => return Err(Error::BadLength { len: payload_len }),
    };
    let total = payload_len + HEADER_LEN + CRC_LEN;
    let available = buf.len();
    let Some(frame) = buf.get_mut(..total) else {
        return Err(Error::BufferTooSmall {
            needed: total,
            available,
        });
    };
    let [l0, l1] = len.to_le_bytes();
    if let Some(header) = frame.first_chunk_mut::<HEADER_LEN>() {
        *header = [STX, address, l0, l1];
    }
    if let Some(payload) = frame.get_mut(field::PAYLOAD..field::PAYLOAD + payload_len) {
        fill(payload);
    }
    let mut telegram = Telegram::new_unchecked(frame);
    telegram.fill_crc();
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    const START_CONTINUOUS: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08];

    #[test]
    fn view_reads_fields() {
        let t = Telegram::new_checked(&START_CONTINUOUS[..]).unwrap();
        assert_eq!(t.stx(), STX);
        assert_eq!(t.address(), ADDRESS_HOST);
        assert_eq!(t.payload_len(), 2);
        assert_eq!(t.total_len(), 8);
        assert_eq!(t.command(), 0x20);
        assert_eq!(t.payload(), &[0x20, 0x24]);
        assert_eq!(t.crc(), 0x0834);
        assert_eq!(t.computed_crc(), 0x0834);
        assert_eq!(t.as_bytes(), &START_CONTINUOUS);
    }

    #[test]
    fn trailing_bytes_are_ignored() {
        let mut buf = [0xEE_u8; 12];
        buf[..8].copy_from_slice(&START_CONTINUOUS);
        let t = Telegram::new_checked(&buf[..]).unwrap();
        assert_eq!(t.as_bytes(), &START_CONTINUOUS);
        assert_eq!(t.payload(), &[0x20, 0x24]);
    }

    #[test]
    fn checked_construction_refuses_damage() {
        for cut in 0..START_CONTINUOUS.len() {
            assert_eq!(
                Telegram::new_checked(&START_CONTINUOUS[..cut]),
                Err(Error::Truncated),
                "cut at {cut}"
            );
        }
        let mut bad = START_CONTINUOUS;
        bad[0] = 0x03;
        assert_eq!(
            Telegram::new_checked(&bad[..]),
            Err(Error::BadStx { found: 0x03 })
        );
        let mut bad = START_CONTINUOUS;
        bad[5] = 0x25;
        assert_eq!(
            Telegram::new_checked(&bad[..]),
            Err(Error::BadCrc {
                stored: 0x0834,
                computed: 0x0835
            })
        );
        let zero = [0x02, 0x80, 0x00, 0x00, 0x00, 0x00];
        assert_eq!(
            Telegram::new_checked(&zero[..]),
            Err(Error::BadLength { len: 0 })
        );
        let huge = [0x02, 0x80, 0x2D, 0x03, 0x00, 0x00]; // 813
        assert_eq!(
            Telegram::new_checked(&huge[..]),
            Err(Error::BadLength { len: 813 })
        );
    }

    #[test]
    fn unchecked_view_over_short_buffers_never_panics() {
        for cut in 0..START_CONTINUOUS.len() {
            let t = Telegram::new_unchecked(&START_CONTINUOUS[..cut]);
            let _ = (t.stx(), t.address(), t.payload_len(), t.command(), t.crc());
            let _ = (t.computed_crc(), t.as_bytes(), t.payload(), t.total_len());
            let mut owned = START_CONTINUOUS[..cut].to_vec();
            let mut m = Telegram::new_unchecked(&mut owned[..]);
            m.set_stx(1);
            m.set_address(2);
            m.set_payload_len(0xFFFF);
            let _ = m.payload_mut();
            m.fill_crc();
        }
    }

    #[test]
    fn emit_frames_and_fills_the_crc() {
        let mut buf = [0u8; 16];
        let n = emit_telegram(ADDRESS_HOST, &[0x20, 0x24], &mut buf).unwrap();
        assert_eq!(&buf[..n], &START_CONTINUOUS);
        assert_eq!(
            emit_telegram(ADDRESS_HOST, &[0x20, 0x24], &mut buf[..7]),
            Err(Error::BufferTooSmall {
                needed: 8,
                available: 7
            })
        );
        assert_eq!(
            emit_telegram(ADDRESS_HOST, &[], &mut buf),
            Err(Error::BadLength { len: 0 })
        );
        let big = [0u8; MAX_PAYLOAD_LEN + 1];
        let mut out = [0u8; MAX_TELEGRAM_LEN + 1];
        assert_eq!(
            emit_telegram(ADDRESS_REPLY, &big, &mut out),
            Err(Error::BadLength { len: 813 })
        );
        let n = emit_telegram(ADDRESS_REPLY, &big[..MAX_PAYLOAD_LEN], &mut out).unwrap();
        assert_eq!(n, MAX_TELEGRAM_LEN);
        assert!(Telegram::new_checked(&out[..n]).is_ok());
    }

    #[test]
    fn setters_build_a_telegram() {
        let mut buf = [0u8; 8];
        let mut t = Telegram::new_unchecked(&mut buf[..]);
        t.set_stx(STX);
        t.set_address(ADDRESS_HOST);
        t.set_payload_len(2);
        t.payload_mut().copy_from_slice(&[0x20, 0x24]);
        t.fill_crc();
        assert_eq!(buf, START_CONTINUOUS);
    }
}
