//! The host link's frames: COBS framing, CRC-32, a 4-byte header and fixed little-endian
//! bodies. `docs/protocol.md` is the specification; this module is its pure, zero-copy
//! implementation (no I/O, no clock, no allocation), after smoltcp's `wire`: a checked view
//! over a decoded frame ([`Frame`]), a typed [`Message`] with `parse`/`encode`, and a
//! [`FrameAccumulator`] that reassembles frames from byte chunks, after postcard's.
//!
//! # Panic contract
//! Nothing here panics on any input: lengths are checked before every read, encoders report a
//! too-small buffer as an error, counters saturate.
//!
//! # Example
//! ```
//! use terrain_pyramid::wire::link::{encode, Decoded, FrameAccumulator, Message, MAX_FRAME};
//! use terrain_pyramid::wire::FeedResult;
//! let mut out = [0_u8; 16];
//! let n = encode(1, &Message::Ping, &mut out).unwrap();
//! assert_eq!(&out[..n], &[0x04, 0x06, 0x86, 0x01, 0x05, 0xB3, 0xD6, 0x8C, 0xF8, 0x00]);
//! let mut acc = FrameAccumulator::<MAX_FRAME>::new();
//! match acc.feed(&out[..n]) {
//!     FeedResult::Item { item: Decoded { header, message }, remaining, .. } => {
//!         assert_eq!((header.seq, message, remaining.len()), (1, Message::Ping, 0));
//!     }
//!     other => panic!("{other:?}"),
//! }
//! ```

mod accumulator;
pub mod cobs;
mod command;
mod crc;
mod encoding;
mod map;
mod message;
mod reply;
mod setup;
mod stats;
mod time;

pub use accumulator::{Decoded, FrameAccumulator, FrameFeed, RxCounters, Undecoded};
pub use crc::{crc32, Crc32};
pub use encoding::{encode, encode_patch};
pub use message::{
    decode, ClampRequest, ClockSource, Configure, Decayed, DecayedRows, FilterSetup,
    FirmwareVersion, GateRequest, Hello, HelloReason, LaserSetup, LayerInfo, LayerPatch, Message,
    MountSetup, PanAngle, PatchArea, PatchCells, PoseReport, Reply, ReplyCode, RuleSetup, SetRule,
    Setup, SnapshotScope, Stats, WindowMoved, PARAM_LAYER, POSE_FLAGS_KNOWN, POSE_STAMPED,
    SETUP_FILTER_LEN, SETUP_LASER_LEN, SETUP_MOUNT_LEN, SETUP_RULE_LEN, SETUP_SECTORS,
    STATS_COUNTERS,
};
pub use time::{Observed, TimeReply, TimeRequest};

use core::fmt;

/// The protocol version this module speaks (`docs/protocol.md`, section 6).
pub const VERSION: u8 = 6;
/// Bytes of the header: version, type, sequence number.
pub const HEADER_LEN: usize = 4;
/// Bytes of the CRC-32 after the body.
pub const CRC_LEN: usize = 4;
/// The shortest decoded frame: a header and a CRC around an empty body.
pub const MIN_FRAME: usize = HEADER_LEN + CRC_LEN;
/// The most layers a frame describes (the masks of Hello and WindowMoved are 32 bits).
pub const MAX_LAYERS: usize = 32;
/// The longest side of a [`LayerPatch`], cells.
pub const MAX_PATCH_SIDE: usize = 16;
/// The largest LayerPatch body: 16 × 16 cells.
const MAX_PATCH_BODY: usize = map::PATCH_FIXED + 2 * MAX_PATCH_SIDE * MAX_PATCH_SIDE;
/// The largest Hello body: 32 layers.
const MAX_HELLO_BODY: usize = map::HELLO_FIXED + map::HELLO_LAYER * MAX_LAYERS;
/// The largest body device to host: a Hello of 32 layers (652 bytes; a 16 × 16
/// [`LayerPatch`] is 531).
pub const MAX_BODY: usize = if MAX_HELLO_BODY > MAX_PATCH_BODY {
    MAX_HELLO_BODY
} else {
    MAX_PATCH_BODY
};
/// The largest decoded frame (header, body, CRC), device to host: 664 bytes.
pub const MAX_FRAME: usize = MIN_FRAME + MAX_BODY;
/// The largest command body: a Configure (94 bytes) or a Setup (140), whichever is longer.
const MAX_COMMAND_BODY: usize = if message::CONFIGURE_LEN > message::SETUP_LEN {
    message::CONFIGURE_LEN
} else {
    message::SETUP_LEN
};
/// The largest decoded frame host to device (a [`Setup`]): 148 bytes.
pub const MAX_COMMAND_FRAME: usize = MIN_FRAME + MAX_COMMAND_BODY;
/// The largest encoded frame device to host, delimiter included: 668 bytes.
pub const MAX_ENCODED_FRAME: usize = encoded_len_max(MAX_FRAME);
/// The largest encoded frame host to device, delimiter included: 150 bytes.
pub const MAX_ENCODED_COMMAND: usize = encoded_len_max(MAX_COMMAND_FRAME);

/// The most bytes a decoded frame of `decoded` bytes takes on the wire, delimiter included.
#[must_use]
pub const fn encoded_len_max(decoded: usize) -> usize {
    cobs::max_encoded_len(decoded) + 1
}

byte_enum! {
/// The message types (`docs/protocol.md`, section 4). Bit 7 set: host to device.
pub enum MessageType {
    /// Device to host: the pyramid in force.
    Hello = 0x01,
    /// Device to host: a rectangle of one layer's cells.
    LayerPatch = 0x02,
    /// Device to host: new window origins.
    WindowMoved = 0x03,
    /// Device to host: counters.
    Stats = 0x04,
    /// Device to host: the answer to a command.
    Reply = 0x05,
    /// Device to host: rows that took a decay step.
    Decayed = 0x06,
    /// Device to host: the answer to a TimeRequest (version 4).
    TimeReply = 0x07,
    /// Device to host: an observation was applied, and when its returns were measured
    /// (version 4).
    Observed = 0x08,
    /// Host to device: the robot's pose.
    Pose = 0x81,
    /// Host to device: the pan angle.
    PanAngle = 0x82,
    /// Host to device: a new design and configuration.
    Configure = 0x83,
    /// Host to device: forget every observation.
    Reset = 0x84,
    /// Host to device: send every cell of one layer or all layers again.
    RequestSnapshot = 0x85,
    /// Host to device: answer with Reply Ok.
    Ping = 0x86,
    /// Host to device: how the laser is mounted and how its lines make observations.
    Setup = 0x87,
    /// Host to device: send a Stats frame at once.
    RequestStats = 0x88,
    /// Host to device: flush the queue and stop (emulated boards and tests).
    Shutdown = 0x89,
    /// Host to device: end the current observation now (apply its evidence).
    EndObservation = 0x8A,
    /// Host to device: the classifier's step threshold and navigability rule, the rest of the
    /// setup unchanged.
    SetRule = 0x8B,
    /// Host to device: the host's clock, answered with a TimeReply (version 4).
    TimeRequest = 0x8C,
}
/// The type of a type byte, or `None` when unknown.
pub fn from_u8;
/// The type byte.
pub fn to_u8;
}

impl MessageType {
    /// Whether the host sends this type (bit 7 set).
    #[must_use]
    pub const fn is_command(self) -> bool {
        self.to_u8() & 0x80 != 0
    }
}

/// A frame's header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// The protocol version, [`VERSION`].
    pub version: u8,
    /// The type byte (see [`MessageType`]; unknown types are kept as they came).
    pub msg_type: u8,
    /// The sender's sequence number.
    pub seq: u16,
}

/// Why a frame was refused. One kind per check of `docs/protocol.md`, section 8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DecodeError {
    /// A COBS block ran into the delimiter.
    Cobs,
    /// The CRC-32 does not match the frame.
    Crc {
        /// The CRC carried by the frame.
        received: u32,
        /// The CRC computed over the frame.
        computed: u32,
    },
    /// The decoded frame is shorter than a header and a CRC.
    TooShort {
        /// Its length, bytes.
        len: usize,
    },
    /// The frame is longer than the receiver's buffer.
    TooLong {
        /// The receiver's limit, bytes.
        max: usize,
    },
    /// The version byte is not [`VERSION`].
    UnknownVersion(u8),
    /// The type byte names no message.
    UnknownType(u8),
    /// The body's length does not fit its type.
    BadBody {
        /// The type byte.
        msg_type: u8,
        /// The body's length, bytes.
        len: usize,
    },
    /// A field holds a value the format does not allow.
    OutOfRange {
        /// The field, `message.field`.
        field: &'static str,
    },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Cobs => f.write_str("bad COBS: a block runs into the delimiter"),
            Self::Crc { received, computed } => write!(
                f,
                "bad CRC: frame says {received:#010x}, bytes give {computed:#010x}"
            ),
            Self::TooShort { len } => write!(f, "frame too short: {len} bytes, at least 8"),
            Self::TooLong { max } => write!(f, "frame too long: over {max} bytes"),
            Self::UnknownVersion(v) => {
                write!(
                    f,
                    "unknown protocol version {v} (this side speaks {VERSION})"
                )
            }
            Self::UnknownType(t) => write!(f, "unknown message type {t:#04x}"),
            Self::BadBody { msg_type, len } => {
                write!(f, "bad body: {len} bytes for message type {msg_type:#04x}")
            }
            Self::OutOfRange { field } => write!(f, "field {field} out of range"),
        }
    }
}

/// Why a message could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        got: usize,
    },
    /// A field holds a value the format cannot carry.
    Invalid {
        /// The field, `message.field`.
        field: &'static str,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BufferTooSmall { needed, got } => {
                write!(f, "frame needs {needed} bytes, the buffer holds {got}")
            }
            Self::Invalid { field } => write!(f, "field {field} cannot be encoded"),
        }
    }
}

/// A checked view over one decoded frame (COBS removed): header, body and CRC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Frame<T> {
    /// Wraps a buffer without checking it; the accessors then return zeros or empty slices
    /// for what is missing.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after [`check`](Self::check).
    ///
    /// # Errors
    /// See [`check`](Self::check).
    pub fn new_checked(buffer: T) -> Result<Self, DecodeError> {
        let frame = Self::new_unchecked(buffer);
        frame.check()?;
        Ok(frame)
    }

    /// Checks the length, the CRC and the version, in that order.
    ///
    /// # Errors
    /// [`DecodeError::TooShort`], [`DecodeError::Crc`] or [`DecodeError::UnknownVersion`].
    pub fn check(&self) -> Result<(), DecodeError> {
        let bytes = self.buffer.as_ref();
        let len = bytes.len();
        let Some(split) = len.checked_sub(CRC_LEN).filter(|_| len >= MIN_FRAME) else {
            return Err(DecodeError::TooShort { len });
        };
        let (covered, tail) = bytes.split_at(split);
        let received = u32::from_le_bytes(le4(tail));
        let computed = crc32(covered);
        if received != computed {
            return Err(DecodeError::Crc { received, computed });
        }
        let version = self.version();
        if version != VERSION {
            return Err(DecodeError::UnknownVersion(version));
        }
        Ok(())
    }

    fn byte(&self, at: usize) -> u8 {
        self.buffer.as_ref().get(at).copied().unwrap_or(0)
    }

    /// The version byte.
    pub fn version(&self) -> u8 {
        self.byte(0)
    }

    /// The type byte.
    pub fn msg_type(&self) -> u8 {
        self.byte(1)
    }

    /// The sequence number.
    pub fn seq(&self) -> u16 {
        u16::from_le_bytes([self.byte(2), self.byte(3)])
    }

    /// The header.
    pub fn header(&self) -> Header {
        Header {
            version: self.version(),
            msg_type: self.msg_type(),
            seq: self.seq(),
        }
    }

    /// The body: the bytes between the header and the CRC.
    pub fn body(&self) -> &[u8] {
        let bytes = self.buffer.as_ref();
        let end = bytes.len().saturating_sub(CRC_LEN);
        bytes.get(HEADER_LEN..end).unwrap_or(&[])
    }

    /// The buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }
}

impl<'a> Frame<&'a [u8]> {
    /// The body, borrowed for as long as the buffer.
    #[must_use]
    pub fn body_ref(&self) -> &'a [u8] {
        let bytes: &'a [u8] = self.buffer;
        let end = bytes.len().saturating_sub(CRC_LEN);
        bytes.get(HEADER_LEN..end).unwrap_or(&[])
    }
}

/// The first four bytes of a slice (zeros for what is missing).
fn le4(bytes: &[u8]) -> [u8; 4] {
    let mut out = [0_u8; 4];
    for (o, b) in out.iter_mut().zip(bytes) {
        *o = *b;
    }
    out
}

#[cfg(test)]
pub(crate) mod examples;
#[cfg(test)]
mod tests;
