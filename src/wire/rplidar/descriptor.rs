//! Response descriptors and the single responses (GET_HEALTH, GET_INFO).

use super::{
    read_u16_le, write_all, RplidarError, RPLIDAR_CAPSULE_LEN, RPLIDAR_DESCRIPTOR_LEN,
    RPLIDAR_DESCRIPTOR_SYNC, RPLIDAR_NODE_LEN, RPLIDAR_TYPE_CAPSULED, RPLIDAR_TYPE_HEALTH,
    RPLIDAR_TYPE_INFO, RPLIDAR_TYPE_MEASUREMENT, RPLIDAR_TYPE_SAMPLE_RATE,
};
use crate::wire::{check, descriptor, view};

view::fixed_view! {
    /// A zero-copy view over a 7-byte response descriptor: `A5 5A`, a little-endian word with
    /// the data-response length in bits 29..0 and the send mode in bits 31..30, the data type.
    ///
    /// Made with [`RplidarDescriptor::new_checked`], the buffer holds 7 bytes starting `A5 5A`;
    /// made with [`RplidarDescriptor::new_unchecked`], absent bytes read as 0.
    pub struct RplidarDescriptor: RPLIDAR_DESCRIPTOR_LEN bytes, a "descriptor",
        refused with RplidarError;

    /// Wraps a buffer after [`check_len`](Self::check_len) and the sync check.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] or [`RplidarError::BadSync`].
    fn new_checked: check_sync;
}

impl<T: AsRef<[u8]>> RplidarDescriptor<T> {
    /// Checks the sync bytes `A5 5A`.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] for fewer than 2 bytes, [`RplidarError::BadSync`].
    pub fn check_sync(&self) -> Result<(), RplidarError> {
        match self.buffer.as_ref().first_chunk::<2>() {
            Some(&pair) if pair == RPLIDAR_DESCRIPTOR_SYNC => Ok(()),
            Some(&found) => Err(RplidarError::BadSync { found }),
            None => Err(RplidarError::Truncated),
        }
    }

    /// The length of one data response, bytes (30 bits).
    pub fn response_len(&self) -> u32 {
        descriptor::len_and_mode(self.buffer.as_ref()).0
    }

    /// The send mode: 0 single response, 1 multiple responses (2 and 3 reserved).
    pub fn send_mode(&self) -> u8 {
        descriptor::len_and_mode(self.buffer.as_ref()).1
    }

    /// The data type (0x81 nodes, 0x82 capsules, 0x06 health, 0x04 info, 0x15 sample rate).
    pub fn data_type(&self) -> u8 {
        self.byte(6)
    }
}

/// The fields of a descriptor, to [`emit`](RplidarDescriptorRepr::emit) or as parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarDescriptorRepr {
    /// Length of one data response, bytes (below 2³⁰).
    pub response_len: u32,
    /// Send mode: 0 single, 1 multiple.
    pub send_mode: u8,
    /// Data type.
    pub data_type: u8,
}

impl RplidarDescriptorRepr {
    /// SCAN and FORCE_SCAN: `A5 5A 05 00 00 40 81`.
    pub const SCAN: Self = Self::new(RPLIDAR_NODE_LEN as u32, 1, RPLIDAR_TYPE_MEASUREMENT);
    /// Legacy EXPRESS_SCAN: `A5 5A 54 00 00 40 82`.
    pub const EXPRESS_SCAN: Self = Self::new(RPLIDAR_CAPSULE_LEN as u32, 1, RPLIDAR_TYPE_CAPSULED);
    /// GET_HEALTH: `A5 5A 03 00 00 00 06`.
    pub const HEALTH: Self = Self::new(3, 0, RPLIDAR_TYPE_HEALTH);
    /// GET_INFO: `A5 5A 14 00 00 00 04`.
    pub const INFO: Self = Self::new(20, 0, RPLIDAR_TYPE_INFO);
    /// GET_SAMPLERATE: `A5 5A 04 00 00 00 15`.
    pub const SAMPLE_RATE: Self = Self::new(4, 0, RPLIDAR_TYPE_SAMPLE_RATE);

    const fn new(response_len: u32, send_mode: u8, data_type: u8) -> Self {
        Self {
            response_len,
            send_mode,
            data_type,
        }
    }

    /// The fields of a descriptor view.
    pub fn parse<T: AsRef<[u8]>>(descriptor: &RplidarDescriptor<T>) -> Self {
        Self::new(
            descriptor.response_len(),
            descriptor.send_mode(),
            descriptor.data_type(),
        )
    }

    /// Bytes of the emitted descriptor: 7.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        RPLIDAR_DESCRIPTOR_LEN
    }

    /// Writes the 7 descriptor bytes to the front of `out`.
    ///
    /// # Errors
    /// [`RplidarError::OutOfRange`] for a length of 2³⁰ or more or a send mode above 3,
    /// [`RplidarError::BufferTooSmall`]; nothing is written then.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RplidarError> {
        let bytes = descriptor::encode(self.response_len, self.send_mode, self.data_type)
            .ok_or(RplidarError::OutOfRange)?;
        write_all(out, &bytes)
    }
}

/// What the data after a known descriptor is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Follow {
    /// Standard-scan nodes.
    Nodes,
    /// Legacy capsules.
    Capsules,
    /// A single response of this data type and length.
    Response(u8, usize),
    /// A multiple response in a format this module does not decode (dense or ultra capsules).
    Unsupported,
}

/// The descriptors the accumulator recognises, bytes 2..7, and what follows them.
const KNOWN: [([u8; 5], Follow); 7] = [
    ([0x05, 0x00, 0x00, 0x40, 0x81], Follow::Nodes),
    ([0x54, 0x00, 0x00, 0x40, 0x82], Follow::Capsules),
    (
        [0x03, 0x00, 0x00, 0x00, 0x06],
        Follow::Response(RPLIDAR_TYPE_HEALTH, 3),
    ),
    (
        [0x14, 0x00, 0x00, 0x00, 0x04],
        Follow::Response(RPLIDAR_TYPE_INFO, 20),
    ),
    (
        [0x04, 0x00, 0x00, 0x00, 0x15],
        Follow::Response(RPLIDAR_TYPE_SAMPLE_RATE, 4),
    ),
    // Dense capsules (84 bytes, type 0x85) and ultra capsules (132 bytes, type 0x84).
    ([0x54, 0x00, 0x00, 0x40, 0x85], Follow::Unsupported),
    ([0x84, 0x00, 0x00, 0x40, 0x84], Follow::Unsupported),
];

/// What follows `descriptor` when it is one the accumulator knows.
pub(super) fn known(descriptor: &[u8; RPLIDAR_DESCRIPTOR_LEN]) -> Option<Follow> {
    descriptor::lookup(descriptor, &KNOWN)
}

/// A single response as the accumulator hands it out: its data type (from the descriptor)
/// and its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarResponse<'a> {
    /// The data type its descriptor announced.
    pub data_type: u8,
    /// The response bytes (as long as the descriptor announced).
    pub data: &'a [u8],
}

impl<'a> RplidarResponse<'a> {
    /// The GET_HEALTH view of the response.
    ///
    /// # Errors
    /// [`RplidarError::UnexpectedType`] for another data type, [`RplidarError::Truncated`]
    /// for fewer than 3 bytes.
    pub fn health(&self) -> Result<RplidarHealth<&'a [u8]>, RplidarError> {
        if self.data_type != RPLIDAR_TYPE_HEALTH {
            return Err(RplidarError::UnexpectedType {
                data_type: self.data_type,
            });
        }
        RplidarHealth::new_checked(self.data)
    }

    /// The GET_INFO view of the response.
    ///
    /// # Errors
    /// [`RplidarError::UnexpectedType`] for another data type, [`RplidarError::Truncated`]
    /// for fewer than 20 bytes.
    pub fn info(&self) -> Result<RplidarInfo<&'a [u8]>, RplidarError> {
        if self.data_type != RPLIDAR_TYPE_INFO {
            return Err(RplidarError::UnexpectedType {
                data_type: self.data_type,
            });
        }
        RplidarInfo::new_checked(self.data)
    }
}

/// A zero-copy view over the 3-byte GET_HEALTH response (Figures 4-28/4-29): status, error
/// code (u16 LE).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarHealth<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> RplidarHealth<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer of at least 3 bytes.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`].
    pub fn new_checked(buffer: T) -> Result<Self, RplidarError> {
        check::at_least(buffer.as_ref(), 3, RplidarError::Truncated)?;
        Ok(Self { buffer })
    }

    /// The status: 0 good, 1 warning, 2 error (the device is in its protection stop state);
    /// 0 if absent.
    pub fn status(&self) -> u8 {
        self.buffer.as_ref().first().copied().unwrap_or(0)
    }

    /// The error code when the status is a warning or an error; 0 if absent.
    pub fn error_code(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), 1).unwrap_or(0)
    }
}

/// The fields of a GET_HEALTH response, to [`emit`](RplidarHealthRepr::emit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarHealthRepr {
    /// 0 good, 1 warning, 2 error.
    pub status: u8,
    /// The error code.
    pub error_code: u16,
}

impl RplidarHealthRepr {
    /// Writes the 3 response bytes (without descriptor) to the front of `out`.
    ///
    /// # Errors
    /// [`RplidarError::BufferTooSmall`]; nothing is written.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RplidarError> {
        let [lo, hi] = self.error_code.to_le_bytes();
        write_all(out, &[self.status, lo, hi])
    }
}

/// A zero-copy view over the 20-byte GET_INFO response (Figure 4-25): model, firmware minor
/// and major version, hardware version, 16-byte serial number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarInfo<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> RplidarInfo<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer of at least 20 bytes.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`].
    pub fn new_checked(buffer: T) -> Result<Self, RplidarError> {
        check::at_least(buffer.as_ref(), 20, RplidarError::Truncated)?;
        Ok(Self { buffer })
    }

    fn byte(&self, at: usize) -> u8 {
        self.buffer.as_ref().get(at).copied().unwrap_or(0)
    }

    /// The model ID; 0 if absent.
    pub fn model(&self) -> u8 {
        self.byte(0)
    }

    /// The firmware version's minor part (the decimals); 0 if absent.
    pub fn firmware_minor(&self) -> u8 {
        self.byte(1)
    }

    /// The firmware version's major part; 0 if absent.
    pub fn firmware_major(&self) -> u8 {
        self.byte(2)
    }

    /// The hardware version; 0 if absent.
    pub fn hardware(&self) -> u8 {
        self.byte(3)
    }

    /// The 128-bit serial number, least significant byte first as sent; zeros where absent.
    pub fn serial_number(&self) -> [u8; 16] {
        let mut serial = [0; 16];
        for (i, slot) in serial.iter_mut().enumerate() {
            *slot = self.byte(4 + i);
        }
        serial
    }
}

/// The fields of a GET_INFO response, to [`emit`](RplidarInfoRepr::emit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarInfoRepr {
    /// Model ID.
    pub model: u8,
    /// Firmware minor version.
    pub firmware_minor: u8,
    /// Firmware major version.
    pub firmware_major: u8,
    /// Hardware version.
    pub hardware: u8,
    /// Serial number, as sent.
    pub serial_number: [u8; 16],
}

impl RplidarInfoRepr {
    /// Writes the 20 response bytes (without descriptor) to the front of `out`.
    ///
    /// # Errors
    /// [`RplidarError::BufferTooSmall`]; nothing is written.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RplidarError> {
        let mut bytes = [0_u8; 20];
        let (head, serial) = bytes.split_at_mut(4);
        head.copy_from_slice(&[
            self.model,
            self.firmware_minor,
            self.firmware_major,
            self.hardware,
        ]);
        serial.copy_from_slice(&self.serial_number);
        write_all(out, &bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documents_descriptors() {
        // (bytes, length, send mode, type) as the protocol document prints them.
        let cases = [
            (
                [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81],
                RplidarDescriptorRepr::SCAN,
                5,
                1,
                0x81,
            ),
            (
                [0xA5, 0x5A, 0x54, 0x00, 0x00, 0x40, 0x82],
                RplidarDescriptorRepr::EXPRESS_SCAN,
                84,
                1,
                0x82,
            ),
            (
                [0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x06],
                RplidarDescriptorRepr::HEALTH,
                3,
                0,
                6,
            ),
            (
                [0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x04],
                RplidarDescriptorRepr::INFO,
                20,
                0,
                4,
            ),
            (
                [0xA5, 0x5A, 0x04, 0x00, 0x00, 0x00, 0x15],
                RplidarDescriptorRepr::SAMPLE_RATE,
                4,
                0,
                0x15,
            ),
        ];
        for (bytes, repr, len, mode, ty) in cases {
            let d = RplidarDescriptor::new_checked(&bytes[..]).unwrap();
            // 0x40 in byte 5 is bit 30 of the word: send mode 1.
            assert_eq!(
                (d.response_len(), d.send_mode(), d.data_type()),
                (len, mode, ty)
            );
            assert_eq!(RplidarDescriptorRepr::parse(&d), repr);
            let mut out = [0; 7];
            assert_eq!(repr.emit(&mut out), Ok(7));
            assert_eq!(out, bytes);
            assert!(known(&bytes).is_some());
            assert_eq!(d.as_bytes(), &bytes);
        }
        assert_eq!(known(&[0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x80]), None);
        assert_eq!(known(&[0xA5, 0x5B, 0x05, 0x00, 0x00, 0x40, 0x81]), None);
        assert_eq!(
            RplidarDescriptor::new_checked(&[0xA5, 0x5A, 0, 0, 0, 0][..]),
            Err(RplidarError::Truncated)
        );
        assert_eq!(
            RplidarDescriptor::new_checked(&[0xA5, 0x55, 0, 0, 0, 0, 0][..]),
            Err(RplidarError::BadSync {
                found: [0xA5, 0x55]
            })
        );
        let bad = RplidarDescriptorRepr {
            response_len: 0,
            send_mode: 4,
            data_type: 0,
        };
        assert_eq!(bad.emit(&mut [0; 7]), Err(RplidarError::OutOfRange));
    }

    #[test]
    fn health_and_info() {
        // Status 2 (error), error code 0x1234 little-endian.
        let h = RplidarResponse {
            data_type: 0x06,
            data: &[0x02, 0x34, 0x12],
        };
        let v = h.health().unwrap();
        assert_eq!((v.status(), v.error_code()), (2, 0x1234));
        assert_eq!(h.info(), Err(RplidarError::UnexpectedType { data_type: 6 }));
        let mut out = [0; 3];
        RplidarHealthRepr {
            status: 2,
            error_code: 0x1234,
        }
        .emit(&mut out)
        .unwrap();
        assert_eq!(out, [0x02, 0x34, 0x12]);

        let repr = RplidarInfoRepr {
            model: 0x18,
            firmware_minor: 29,
            firmware_major: 1,
            hardware: 7,
            serial_number: core::array::from_fn(|i| i as u8),
        };
        let mut buf = [0; 20];
        repr.emit(&mut buf).unwrap();
        let r = RplidarResponse {
            data_type: 0x04,
            data: &buf,
        };
        let info = r.info().unwrap();
        assert_eq!(
            (
                info.model(),
                info.firmware_major(),
                info.firmware_minor(),
                info.hardware()
            ),
            (0x18, 1, 29, 7)
        );
        assert_eq!(info.serial_number(), repr.serial_number);
        assert_eq!(
            RplidarInfo::new_checked(&buf[..19]),
            Err(RplidarError::Truncated)
        );
        assert_eq!(RplidarInfo::new_unchecked(&[][..]).serial_number(), [0; 16]);
        assert_eq!(
            RplidarHealth::new_checked(&buf[..2]),
            Err(RplidarError::Truncated)
        );
    }
}
