//! The system commands a host sends, and the response descriptor the device answers with.

use super::{YdlidarError, YDLIDAR_DESCRIPTOR_LEN, YDLIDAR_DESCRIPTOR_SYNC};
use crate::wire::descriptor;
use crate::wire::laser::{LidarCommand, LIDAR_COMMAND_MAX_LEN};

/// The first byte of every command.
const COMMAND_SYNC: u8 = 0xA5;

/// A system command: two bytes, `A5` and the command byte; none carries a payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YdlidarCommand {
    /// `A5 60`: start scanning; the device answers `A5 5A 05 00 00 40 81`, then streams
    /// point-cloud packets. (The X2 starts by itself at power-on.)
    Scan,
    /// `A5 65`: stop scanning; no answer.
    Stop,
    /// `A5 90`: device information; answered by `A5 5A 14 00 00 00 04` and 20 bytes (model,
    /// firmware, hardware, serial number).
    DeviceInfo,
    /// `A5 91`: health status; answered by `A5 5A 03 00 00 00 06` and 3 bytes (status, error
    /// code).
    Health,
}

impl YdlidarCommand {
    /// The command byte after `A5`.
    #[must_use]
    pub const fn command_byte(self) -> u8 {
        match self {
            Self::Scan => 0x60,
            Self::Stop => 0x65,
            Self::DeviceInfo => 0x90,
            Self::Health => 0x91,
        }
    }

    /// Bytes of the emitted command: 2.
    #[must_use]
    pub const fn buffer_len(self) -> usize {
        2
    }

    /// Writes the command to the front of `out` and returns its length (2).
    ///
    /// # Errors
    /// [`YdlidarError::BufferTooSmall`] for fewer than 2 bytes; nothing is written.
    pub fn emit(self, out: &mut [u8]) -> Result<usize, YdlidarError> {
        let available = out.len();
        let Some(dst) = out.first_chunk_mut::<2>() else {
            return Err(YdlidarError::BufferTooSmall {
                needed: 2,
                available,
            });
        };
        *dst = [COMMAND_SYNC, self.command_byte()];
        Ok(2)
    }
}

impl LidarCommand for YdlidarCommand {
    fn encode(&self, out: &mut [u8; LIDAR_COMMAND_MAX_LEN]) -> usize {
        self.emit(out).unwrap_or(0)
    }
}

/// The descriptors the accumulator recognises: bytes 2..7 (length, mode, type) and the
/// length of the single response that follows (0 for the continuous scan response).
const KNOWN: [([u8; 5], usize); 3] = [
    ([0x05, 0x00, 0x00, 0x40, 0x81], 0),
    ([0x14, 0x00, 0x00, 0x00, 0x04], 20),
    ([0x03, 0x00, 0x00, 0x00, 0x06], 3),
];

/// The response bytes following a known descriptor: `Some(0)` for the scan descriptor,
/// `Some(20)` for device information, `Some(3)` for health, `None` for anything else.
pub(super) fn known_content_len(descriptor: &[u8; YDLIDAR_DESCRIPTOR_LEN]) -> Option<usize> {
    descriptor::lookup(descriptor, &KNOWN)
}

/// A zero-copy view over a response descriptor (`A5 5A`, 30-bit response length, 2-bit
/// response mode, type code), followed, for a single response, by its content.
///
/// Made with [`YdlidarDescriptor::new_checked`], the buffer starts `A5 5A` and holds the 7
/// descriptor bytes; [`content`](YdlidarDescriptor::content) is whatever of the announced
/// single response the buffer holds (the accumulator hands out descriptors with their whole
/// content). Accessors never panic; absent bytes read as 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YdlidarDescriptor<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> YdlidarDescriptor<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after checking its length (≥ 7) and its start sign `A5 5A`.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`] or [`YdlidarError::BadHeader`].
    pub fn new_checked(buffer: T) -> Result<Self, YdlidarError> {
        let d = Self::new_unchecked(buffer);
        match d.buffer.as_ref().first_chunk::<YDLIDAR_DESCRIPTOR_LEN>() {
            None => Err(YdlidarError::Truncated),
            Some(&[a, b, ..]) if [a, b] != YDLIDAR_DESCRIPTOR_SYNC => {
                Err(YdlidarError::BadHeader { found: [a, b] })
            }
            Some(_) => Ok(d),
        }
    }

    /// Unwraps the buffer.
    #[must_use]
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The response length, bytes (30 bits); meaningless for a continuous response.
    pub fn response_len(&self) -> u32 {
        descriptor::len_and_mode(self.buffer.as_ref()).0
    }

    /// The response mode: 0 single, 1 continuous, 2 and 3 undefined.
    pub fn mode(&self) -> u8 {
        descriptor::len_and_mode(self.buffer.as_ref()).1
    }

    /// The type code (0x81 scan data, 0x04 device information, 0x06 health).
    pub fn data_type(&self) -> u8 {
        self.buffer.as_ref().get(6).copied().unwrap_or(0)
    }

    /// The descriptor and its content as the buffer holds them: 7 bytes, plus the single
    /// response for mode 0.
    pub fn as_bytes(&self) -> &[u8] {
        let data = self.buffer.as_ref();
        let len = if self.mode() == 0 {
            usize::try_from(self.response_len())
                .unwrap_or(usize::MAX)
                .saturating_add(YDLIDAR_DESCRIPTOR_LEN)
        } else {
            YDLIDAR_DESCRIPTOR_LEN
        };
        data.get(..len).unwrap_or(data)
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> YdlidarDescriptor<&'a T> {
    /// The single response after the descriptor (mode 0: device information, health), as far
    /// as the buffer holds it; empty for a continuous response.
    pub fn content(&self) -> &'a [u8] {
        let data: &'a [u8] = self.buffer.as_ref();
        if self.mode() != 0 {
            return &[];
        }
        let len = usize::try_from(self.response_len()).unwrap_or(usize::MAX);
        let rest = data.get(YDLIDAR_DESCRIPTOR_LEN..).unwrap_or(&[]);
        rest.get(..len).unwrap_or(rest)
    }
}

/// The fields of a descriptor to [`emit`](YdlidarDescriptorRepr::emit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YdlidarDescriptorRepr {
    /// Response length, bytes (below 2³⁰).
    pub response_len: u32,
    /// Response mode: 0 single, 1 continuous.
    pub mode: u8,
    /// Type code.
    pub data_type: u8,
}

impl YdlidarDescriptorRepr {
    /// The scan descriptor, `A5 5A 05 00 00 40 81`.
    pub const SCAN: Self = Self {
        response_len: 5,
        mode: 1,
        data_type: 0x81,
    };

    /// The fields of a descriptor view.
    pub fn parse<T: AsRef<[u8]>>(descriptor: &YdlidarDescriptor<T>) -> Self {
        Self {
            response_len: descriptor.response_len(),
            mode: descriptor.mode(),
            data_type: descriptor.data_type(),
        }
    }

    /// Writes the 7 descriptor bytes to the front of `out`.
    ///
    /// # Errors
    /// [`YdlidarError::OutOfRange`] for a length of 2³⁰ or more or a mode above 3,
    /// [`YdlidarError::BufferTooSmall`]; nothing is written then.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, YdlidarError> {
        let bytes = descriptor::encode(self.response_len, self.mode, self.data_type)
            .ok_or(YdlidarError::OutOfRange)?;
        let available = out.len();
        let Some(dst) = out.first_chunk_mut::<YDLIDAR_DESCRIPTOR_LEN>() else {
            return Err(YdlidarError::BufferTooSmall {
                needed: YDLIDAR_DESCRIPTOR_LEN,
                available,
            });
        };
        *dst = bytes;
        Ok(YDLIDAR_DESCRIPTOR_LEN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_the_manuals_bytes() {
        let mut out = [0; LIDAR_COMMAND_MAX_LEN];
        for (cmd, bytes) in [
            (YdlidarCommand::Scan, [0xA5, 0x60]),
            (YdlidarCommand::Stop, [0xA5, 0x65]),
            (YdlidarCommand::DeviceInfo, [0xA5, 0x90]),
            (YdlidarCommand::Health, [0xA5, 0x91]),
        ] {
            assert_eq!(cmd.encode(&mut out), 2);
            assert_eq!(&out[..2], &bytes);
            assert_eq!(cmd.buffer_len(), 2);
        }
        assert_eq!(
            YdlidarCommand::Scan.emit(&mut [0]),
            Err(YdlidarError::BufferTooSmall {
                needed: 2,
                available: 1
            })
        );
    }

    #[test]
    fn the_manuals_descriptors() {
        // Scan: A5 5A 05 00 00 40 81 → length 5, mode 1 (0x40 >> 6), type 0x81.
        let scan = [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
        let d = YdlidarDescriptor::new_checked(&scan[..]).unwrap();
        assert_eq!((d.response_len(), d.mode(), d.data_type()), (5, 1, 0x81));
        assert_eq!(d.content(), &[] as &[u8]);
        assert_eq!(known_content_len(&scan), Some(0));
        let mut out = [0; 7];
        YdlidarDescriptorRepr::SCAN.emit(&mut out).unwrap();
        assert_eq!(out, scan);
        assert_eq!(
            YdlidarDescriptorRepr::parse(&d),
            YdlidarDescriptorRepr::SCAN
        );
        // Device information: A5 5A 14 00 00 00 04 → 20 bytes, single, type 4; the X2's
        // model code is 04.
        let mut info = [0_u8; 27];
        info[..7].copy_from_slice(&[0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x04]);
        info[7] = 0x04;
        let d = YdlidarDescriptor::new_checked(&info[..]).unwrap();
        assert_eq!((d.response_len(), d.mode(), d.data_type()), (20, 0, 0x04));
        assert_eq!(d.content().len(), 20);
        assert_eq!(d.content()[0], 0x04);
        assert_eq!(d.as_bytes().len(), 27);
        assert_eq!(known_content_len(info.first_chunk().unwrap()), Some(20));
        // Health: A5 5A 03 00 00 00 06.
        assert_eq!(
            known_content_len(&[0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x06]),
            Some(3)
        );
        assert_eq!(
            known_content_len(&[0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x07]),
            None
        );
        assert_eq!(
            YdlidarDescriptor::new_checked(&scan[..6]),
            Err(YdlidarError::Truncated)
        );
        assert_eq!(
            YdlidarDescriptor::new_checked(&[0xA5, 0x5B, 0, 0, 0, 0, 0][..]),
            Err(YdlidarError::BadHeader {
                found: [0xA5, 0x5B]
            })
        );
        let bad = YdlidarDescriptorRepr {
            response_len: 1 << 30,
            mode: 0,
            data_type: 0,
        };
        assert_eq!(bad.emit(&mut out), Err(YdlidarError::OutOfRange));
    }
}
