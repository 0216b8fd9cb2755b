//! The YDLIDAR X4 / X2 scan protocol: the `AA 55` point-cloud packet view, its 16-bit XOR
//! check, its returns with the second-level angle correction in fixed point, the response
//! descriptor, the start/stop commands, and a resynchronising accumulator.
//!
//! The authorities are the YDLIDAR "X4 Development Manual" (Doc# 01.13.000002): "System
//! Communication" (commands, the response message: start sign `A5 5A`, 30-bit length, 2-bit
//! mode, type code), "Data Protocol" / "Scan command [A5 60]" (the packet, its distance and
//! angle analysis and its check code), "Stop command [A5 65]", "Device information
//! [A5 90]", "Health status [A5 91]"; and the "X2 Development Manual" (Doc# 01.13.000101):
//! §2 "Sampling and ranging" (the X2 sends `A5 5A 05 00 00 40 81` at power-on and streams
//! unasked), §3 "Power-on information", §4 "Data protocol". YDLIDAR's `YDLidar-SDK`
//! (`src/YDlidarDriver.cpp`) is the independent implementation cross-checked in the tests.
//!
//! # Wire format, little-endian
//! ```text
//! PH 0x55AA (AA 55) | CT u8 | LSN u8 | FSA u16 | LSA u16 | CS u16 | LSN × Si u16
//! ```
//! - CT bit 0 set: the packet that starts a revolution (the "zero packet", LSN = 1); bits 7..1
//!   are reserved (the SDK reads a scan frequency from them on newer models).
//! - FSA and LSA carry the angle of the first and last sample in bits 15..1 as
//!   degrees·64 ("Rshiftbit(FSA, 1)/64"); bit 0 is a check bit fixed at 1.
//! - CS: the XOR of the packet's 16-bit words, CS itself excluded:
//!   `PH ⊕ (CT | LSN·256) ⊕ FSA ⊕ LSA ⊕ S1 ⊕ … ⊕ Sn`.
//! - Distance = Si / 4 mm (the manual's example: `E5 6F` → 0x6FE5/4 = 7 161.25 mm); 0 is no
//!   return. A [`LaserReturn`] carries it rounded to the nearest millimetre.
//!
//! # Angles
//! First-level analysis: sample i (0-based) lies at `FSA + i·diff/(LSN − 1)`, where `diff`
//! is the clockwise difference from FSA to LSA (LSA below FSA means the packet crossed 360°).
//! [`YdlidarPacket::angle`] evaluates it on the exact rational value, rounded once to the
//! [`FineAngle`] LSB. Second-level analysis (the triangulation geometry of the X4 and X2): for
//! a distance d = Si/4 mm ≠ 0, add `AngCorrect = atan(21.8·(155.3 − d)/(155.3·d))` degrees,
//! which runs from +89.4° (d → 0) through 0 (d = 155.3 mm) to −8.0° (d → ∞). It is computed
//! without floating point ([`ydlidar_angle_correction`]): the argument is the exact rational
//! `(677 108 − 1 090·Si)/(7 765·Si)`, one integer division brings it into [−1, 1] (with
//! `atan x = 90° − atan(1/x)` above 1), and a 257-entry table of `atan(k/256)` built at
//! compile time is interpolated linearly. The unit tests bound the error against `f64` over
//! every Si in 1..=65 535.
//!
//! Both manuals give the second-level correction. [`YdlidarAngleCorrection::Off`] is there
//! for firmware that reports corrected angles (YDLIDAR's SDK skips it for its Tmini and R3
//! models) and to look at the first-level angles alone. The angle grows clockwise seen from
//! above ([`crate::wire::laser`]).
//!
//! # Stream reassembly
//! [`YdlidarAccumulator`] hunts for `AA 55` (packets) and `A5 5A` (response descriptors: the
//! scan, device-information and health descriptors the manuals list, with the content of a
//! single response). A candidate packet is refused as soon as a field shows it wrong (LSN 0
//! or beyond the capacity, a check bit of FSA or LSA clear, then the XOR), and the hunt
//! restarts one byte after its header. Bit 0 of FSA and LSA and the 16-bit XOR let a false
//! `AA 55` in garbage pass about once in 2¹⁸ candidates.

use core::fmt;

mod accumulator;
mod command;
mod correction;
mod packet;

pub use accumulator::{YdlidarAccumulator, YdlidarCounters, YdlidarItem, YDLIDAR_DEFAULT_CAPACITY};
pub use command::{YdlidarCommand, YdlidarDescriptor, YdlidarDescriptorRepr};
pub use correction::{
    ydlidar_angle_correction, YdlidarAngleCorrection, YDLIDAR_CORRECTION_MAX_ERROR_DEG,
};
pub(crate) use packet::corrected;
pub use packet::{ydlidar_checksum, YdlidarPacket, YdlidarRepr};

#[allow(unused_imports)] // Referenced by the documentation above.
use crate::angle::FineAngle;
use crate::wire::LaserReturn;

/// The packet header on the wire: `AA 55` (0x55AA little-endian).
pub const YDLIDAR_PACKET_HEADER: [u8; 2] = [0xAA, 0x55];
/// The packet header as the 16-bit word the check code includes.
pub const YDLIDAR_PACKET_HEADER_WORD: u16 = 0x55AA;
/// Bytes before the samples: PH, CT, LSN, FSA, LSA, CS.
pub const YDLIDAR_PACKET_HEADER_LEN: usize = 10;
/// The most samples a packet carries (LSN is one byte).
pub const YDLIDAR_MAX_SAMPLES: usize = 255;
/// The longest packet, bytes: 10 + 2·255 = 520.
pub const YDLIDAR_MAX_PACKET_LEN: usize = YDLIDAR_PACKET_HEADER_LEN + 2 * YDLIDAR_MAX_SAMPLES;
/// Angle units per turn: the angle fields count degrees·64.
pub const YDLIDAR_Q6_PER_TURN: u32 = 360 * 64;
/// The start sign of every response message (descriptor): `A5 5A`.
pub const YDLIDAR_DESCRIPTOR_SYNC: [u8; 2] = super::descriptor::SYNC;
/// Bytes of a response descriptor.
pub const YDLIDAR_DESCRIPTOR_LEN: usize = 7;

/// Why a YDLIDAR packet, descriptor or candidate was refused, or why an emit could not
/// proceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum YdlidarError {
    /// The buffer is shorter than the header or than the packet its LSN announces, or the
    /// stream ended inside a candidate ([`YdlidarCounters::truncated`]).
    Truncated,
    /// The first two bytes are not the expected sync pair (`AA 55` for a packet, `A5 5A` for
    /// a descriptor).
    BadHeader {
        /// The two bytes found.
        found: [u8; 2],
    },
    /// LSN is 0: a packet carries at least one sample ([`YdlidarCounters::bad_length`]).
    NoSamples,
    /// The packet LSN announces is longer than the accumulator's capacity
    /// ([`YdlidarCounters::bad_length`]).
    TooLong {
        /// The packet's length as LSN announces it, bytes.
        len: usize,
        /// The accumulator's capacity, bytes.
        capacity: usize,
    },
    /// Bit 0 (the check bit, always 1) of FSA or LSA is clear
    /// ([`YdlidarCounters::check_bits`]).
    BadCheckBit {
        /// The angle field with the clear bit, as read.
        field: u16,
    },
    /// The check code differs from the XOR computed over the packet
    /// ([`YdlidarCounters::checksum`]).
    BadChecksum {
        /// The check code carried by the packet.
        stored: u16,
        /// The XOR computed over it.
        computed: u16,
    },
    /// A descriptor this module does not know (only the scan, device-information and health
    /// descriptors are parsed).
    UnknownDescriptor,
    /// A value that the field cannot hold was given to an emitter.
    OutOfRange,
    /// The output buffer is shorter than what is to be emitted; nothing was written.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
        /// Bytes the buffer holds.
        available: usize,
    },
}

impl fmt::Display for YdlidarError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Truncated => f.write_str("YDLIDAR packet truncated"),
            Self::BadHeader { found: [a, b] } => {
                write!(f, "YDLIDAR sync bytes expected, found {a:02x} {b:02x}")
            }
            Self::NoSamples => f.write_str("YDLIDAR packet with LSN 0"),
            Self::TooLong { len, capacity } => write!(
                f,
                "YDLIDAR packet of {len} bytes exceeds the accumulator's capacity of {capacity}"
            ),
            Self::BadCheckBit { field } => {
                write!(
                    f,
                    "YDLIDAR angle field 0x{field:04x} has its check bit clear"
                )
            }
            Self::BadChecksum { stored, computed } => write!(
                f,
                "YDLIDAR check code mismatch: stored 0x{stored:04x}, computed 0x{computed:04x}"
            ),
            Self::UnknownDescriptor => f.write_str("unknown YDLIDAR response descriptor"),
            Self::OutOfRange => f.write_str("value out of range for a YDLIDAR field"),
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "output buffer too small: {needed} bytes needed, {available} available"
            ),
        }
    }
}

impl core::error::Error for YdlidarError {}

/// Reads a u16 LE at `at`, or `None` when the two bytes are not there.
fn read_u16_le(bytes: &[u8], at: usize) -> Option<u16> {
    let &pair = bytes.get(at..)?.first_chunk::<2>()?;
    Some(u16::from_le_bytes(pair))
}

/// A return of a packet: the sample's distance rounded to the millimetre, no quality.
fn laser_return(angle: FineAngle, sample: u16) -> LaserReturn {
    LaserReturn {
        angle,
        range_mm: (u32::from(sample) + 2) >> 2,
        quality: None,
    }
}
