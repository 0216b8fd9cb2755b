//! Requests from the host ("Protocol Basics": request packets' format).

use super::{write_all, RplidarError, RPLIDAR_SYNC};
use crate::wire::laser::{LidarCommand, LIDAR_COMMAND_MAX_LEN};

/// A request to an RPLIDAR.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RplidarRequest {
    /// STOP `A5 25`: leave the scanning state; no response (wait at least 1 ms before the
    /// next request).
    Stop,
    /// RESET `A5 40`: restart the core; no response (wait at least 2 ms).
    Reset,
    /// SCAN `A5 20`: start scanning; answered by `A5 5A 05 00 00 40 81` and nodes.
    Scan,
    /// FORCE_SCAN `A5 21`: scan whatever the motor speed; the same answer as SCAN.
    ForceScan,
    /// EXPRESS_SCAN `A5 82 05 <working_mode> 00 00 00 00 <checksum>`: answered by
    /// `A5 5A 54 00 00 40 82` and capsules for working mode 0 (the legacy capsule format
    /// this module decodes; other modes answer in formats it does not).
    ExpressScan {
        /// The working mode; 0 for the legacy capsules.
        working_mode: u8,
    },
    /// GET_INFO `A5 50`: answered by `A5 5A 14 00 00 00 04` and 20 bytes.
    GetInfo,
    /// GET_HEALTH `A5 52`: answered by `A5 5A 03 00 00 00 06` and 3 bytes.
    GetHealth,
    /// GET_SAMPLERATE `A5 59`: answered by `A5 5A 04 00 00 00 15` and 4 bytes.
    GetSampleRate,
}

impl RplidarRequest {
    /// The legacy EXPRESS_SCAN request (working mode 0).
    pub const EXPRESS_SCAN: Self = Self::ExpressScan { working_mode: 0 };

    /// The command byte after `A5`.
    #[must_use]
    pub const fn command(self) -> u8 {
        match self {
            Self::Stop => 0x25,
            Self::Reset => 0x40,
            Self::Scan => 0x20,
            Self::ForceScan => 0x21,
            Self::ExpressScan { .. } => 0x82,
            Self::GetInfo => 0x50,
            Self::GetHealth => 0x52,
            Self::GetSampleRate => 0x59,
        }
    }

    /// Bytes of the emitted request: 2, or 9 for EXPRESS_SCAN.
    #[must_use]
    pub const fn buffer_len(self) -> usize {
        match self {
            Self::ExpressScan { .. } => 9,
            _ => 2,
        }
    }

    /// Writes the request to the front of `out` and returns its length.
    ///
    /// A request with a payload is `A5 cmd size payload… checksum`, the checksum being the
    /// XOR of `A5`, `cmd`, `size` and the payload bytes.
    ///
    /// # Errors
    /// [`RplidarError::BufferTooSmall`] when `out` is shorter than
    /// [`buffer_len`](Self::buffer_len); nothing is written.
    pub fn emit(self, out: &mut [u8]) -> Result<usize, RplidarError> {
        match self {
            Self::ExpressScan { working_mode } => {
                let mut bytes = [RPLIDAR_SYNC, self.command(), 5, working_mode, 0, 0, 0, 0, 0];
                let checksum = bytes.iter().fold(0, |acc, b| acc ^ b);
                if let Some(last) = bytes.last_mut() {
                    *last = checksum;
                }
                write_all(out, &bytes)
            }
            _ => write_all(out, &[RPLIDAR_SYNC, self.command()]),
        }
    }
}

impl LidarCommand for RplidarRequest {
    fn encode(&self, out: &mut [u8; LIDAR_COMMAND_MAX_LEN]) -> usize {
        self.emit(out).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documents_request_bytes() {
        let mut out = [0; LIDAR_COMMAND_MAX_LEN];
        for (request, bytes) in [
            (RplidarRequest::Stop, &[0xA5, 0x25][..]),
            (RplidarRequest::Reset, &[0xA5, 0x40]),
            (RplidarRequest::Scan, &[0xA5, 0x20]),
            (RplidarRequest::ForceScan, &[0xA5, 0x21]),
            (RplidarRequest::GetInfo, &[0xA5, 0x50]),
            (RplidarRequest::GetHealth, &[0xA5, 0x52]),
            (RplidarRequest::GetSampleRate, &[0xA5, 0x59]),
            // Checksum: A5 ⊕ 82 = 27; ⊕ 05 = 22; ⊕ 00 … 00 = 22.
            (
                RplidarRequest::EXPRESS_SCAN,
                &[0xA5, 0x82, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x22],
            ),
            // Working mode 2: 22 ⊕ 02 = 20.
            (
                RplidarRequest::ExpressScan { working_mode: 2 },
                &[0xA5, 0x82, 0x05, 0x02, 0x00, 0x00, 0x00, 0x00, 0x20],
            ),
        ] {
            let n = request.encode(&mut out);
            assert_eq!(&out[..n], bytes, "{request:?}");
            assert_eq!(request.buffer_len(), n);
        }
        assert_eq!(
            RplidarRequest::EXPRESS_SCAN.emit(&mut out[..8]),
            Err(RplidarError::BufferTooSmall {
                needed: 9,
                available: 8
            })
        );
    }
}
