//! The Slamtec RPLIDAR serial protocol (A1, A2, A3, C1, S series): requests, response
//! descriptors, the GET_HEALTH and GET_INFO responses, standard-scan nodes, legacy
//! express-scan capsules with their angle compensation, and an accumulator that follows a
//! stream through all of them.
//!
//! The authority is Slamtec's "RPLIDAR Interface Protocol and Application Notes" (the
//! A1/A2/A3 communication protocol, rev. 2019; figure numbers below are that revision's unless
//! marked): ch. 2 "Protocol Basics" (request packets, response descriptors, Figure 2-8 the
//! send modes) and ch. 4, the requests: SCAN (the measurement node, Figures 4-4/4-5 of the
//! 2016 A2 manual), EXPRESS_SCAN in its legacy capsule form (Figures 4-11 to 4-14 and the
//! angle formula by Figure 4-23), GET_INFO (Figure 4-25) and GET_HEALTH (Figures 4-28/4-29).
//! Slamtec's `rplidar_sdk` (`sdk/src/sl_lidar_driver.cpp`: `_sendCommand`, `_waitNode`,
//! `_waitCapsuledNode`, `_capsuleToNormal`) is the independent implementation the tests
//! transcribe and compare against.
//!
//! # Requests ([`RplidarRequest`])
//! `A5 cmd`, and for a request with a payload `A5 cmd size payload checksum`, the checksum
//! being the XOR of every byte before it. STOP `A5 25` and RESET `A5 40` get no answer;
//! EXPRESS_SCAN is `A5 82 05 00 00 00 00 00 22` in its legacy form.
//!
//! # Responses
//! Every response starts with a 7-byte descriptor ([`RplidarDescriptor`]): `A5 5A`, a 32-bit
//! little-endian word holding the data-response length (bits 29..0) and the send mode (bits
//! 31..30: 0 single, 1 multiple), and a data-type byte. Then:
//! - GET_HEALTH (`A5 5A 03 00 00 00 06`): 3 bytes, [`RplidarHealth`];
//! - GET_INFO (`A5 5A 14 00 00 00 04`): 20 bytes, [`RplidarInfo`];
//! - SCAN (`A5 5A 05 00 00 40 81`): 5-byte [`RplidarNode`]s until the next request;
//! - EXPRESS_SCAN (`A5 5A 54 00 00 40 82`): 84-byte [`RplidarCapsule`]s until the next
//!   request.
//!
//! # Angles
//! The heading grows clockwise seen from above ([`crate::wire::laser`]), degrees·64
//! ("angle_q6"). A node carries its own angle. A capsule carries only its start angle ωᵢ; its
//! 32 points lie at `θₖ = ωᵢ + AngleDiff(ωᵢ, ωᵢ₊₁)/32 · k − dθₖ`, where ωᵢ₊₁ is the **next**
//! capsule's start angle and AngleDiff adds 360° when ωᵢ₊₁ < ωᵢ. A capsule's points can
//! therefore be placed only once the next capsule has arrived: [`RplidarExpressScan`] pairs a
//! capsule with its successor's start angle, and the accumulator keeps the latest capsule and
//! hands out its returns when the next one arrives (and drops it, counted, when the next one
//! does not follow it directly or starts a new scan, as the SDK does).
//!
//! dθ is a 6-bit value in degrees·8. The protocol document calls its top bit a sign bit;
//! Slamtec's SDK reads the six bits as an unsigned number (0 to 7.875°) and subtracts it, which
//! is what the sensors' optics produce (the offset shrinks towards 8° with distance). This
//! module follows the SDK, bit for bit: the angle is the SDK's intermediate value
//! `(ωᵢ·2¹⁸ + k·AngleDiff·2¹³ − dθₖ·2¹³)/2¹⁶` degrees, before its truncation to degrees·64,
//! rounded once to the [`FineAngle`](crate::angle::FineAngle) LSB.
//!
//! # Synchronisation
//! The standard-scan node's checks are weak: S ≠ !S and C = 1 pass a random byte pair one
//! time in four, and the angle range (below 360°) 70 % of random angles. The accumulator
//! therefore locks on to a node stream either right after its descriptor (the alignment is
//! known) or, after an error, on a run of [`RPLIDAR_NODE_RUN`] (16) consecutive valid nodes.
//! Random bytes fake such a run with probability 0.176¹⁶ ≈ 10⁻¹²; a real node stream read at
//! the wrong alignment keeps passing for 16 nodes only with probability near 2⁻¹⁶, because
//! the bits the checks then read are distance bits (random from node to node) or angle bits
//! 7 and 8 (2° and 4°), which do not stay right over the several degrees 16 nodes span at
//! the sensors' sample spacing. Why not fewer: a misaligned read passes about half its nodes;
//! over a realistic stream of 40 000 nodes at 0.22° per node the unit test
//! (`misaligned_runs_reach_8_but_not_16`) finds 37 of the 160 000 misaligned positions
//! passing 8 nodes or more (a false lock about once in a thousand resynchronisations, each
//! trying 4 misaligned positions first) and none passing more than 11. Why not more: the
//! nodes of a run wait in the window (5 bytes each) until it completes, and nodes after the
//! last error that never complete a run are lost at the end of a stream. While locked, a
//! node whose check bits a bit flip hits (or whose angle it pushes past 360°) is rejected;
//! one whose checks survive the flip (most of its 40 bit positions) is delivered with the
//! wrong value: that is the format's limit.
//!
//! A capsule is recognised by its sync nibbles (0xA, 0x5) and its 8-bit XOR checksum over
//! bytes 2..84, which every single bit flip changes: a false capsule in random bytes passes
//! about once in 2¹⁶ positions. Known descriptors are recognised at any unit boundary by
//! their seven bytes; only the descriptors listed above (and the dense and ultra capsule
//! descriptors, reported as unsupported) are.

use core::fmt;

mod accumulator;
mod capsule;
mod descriptor;
mod node;
mod plausible;
mod request;
pub use plausible::{RPLIDAR_NODE_BACK_Q6, RPLIDAR_NODE_STEP_MAX_Q6};

pub use accumulator::{RplidarAccumulator, RplidarCounters, RplidarItem, RplidarScanMode};
pub use capsule::{RplidarCapsule, RplidarCapsuleRepr, RplidarExpressScan};
pub use descriptor::{
    RplidarDescriptor, RplidarDescriptorRepr, RplidarHealth, RplidarHealthRepr, RplidarInfo,
    RplidarInfoRepr, RplidarResponse,
};
pub use node::{RplidarNode, RplidarNodeRepr};
pub use request::RplidarRequest;

/// The first byte of every request and of every response descriptor.
pub const RPLIDAR_SYNC: u8 = 0xA5;
/// The first two bytes of every response descriptor.
pub const RPLIDAR_DESCRIPTOR_SYNC: [u8; 2] = super::descriptor::SYNC;
/// Bytes of a response descriptor.
pub const RPLIDAR_DESCRIPTOR_LEN: usize = 7;
/// Bytes of a standard-scan node.
pub const RPLIDAR_NODE_LEN: usize = 5;
/// Bytes of a legacy express-scan capsule.
pub const RPLIDAR_CAPSULE_LEN: usize = 84;
/// Cabins per capsule.
pub const RPLIDAR_CABINS: usize = 16;
/// Points per capsule (two per cabin).
pub const RPLIDAR_CAPSULE_POINTS: usize = 32;
/// Angle units per turn: angles count degrees·64.
pub const RPLIDAR_Q6_PER_TURN: u32 = 360 * 64;
/// Consecutive valid nodes the accumulator requires to lock on to a node stream after an
/// error (see the [module documentation](self)).
pub const RPLIDAR_NODE_RUN: usize = 16;

/// Data type of the standard-scan response (nodes).
pub const RPLIDAR_TYPE_MEASUREMENT: u8 = 0x81;
/// Data type of the legacy express-scan response (capsules).
pub const RPLIDAR_TYPE_CAPSULED: u8 = 0x82;
/// Data type of the GET_HEALTH response.
pub const RPLIDAR_TYPE_HEALTH: u8 = 0x06;
/// Data type of the GET_INFO response.
pub const RPLIDAR_TYPE_INFO: u8 = 0x04;
/// Data type of the GET_SAMPLERATE response.
pub const RPLIDAR_TYPE_SAMPLE_RATE: u8 = 0x15;

/// Why an RPLIDAR unit or candidate was refused, or why an emit could not proceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RplidarError {
    /// The buffer is shorter than the unit, or the stream ended inside a candidate
    /// ([`RplidarCounters::truncated`]).
    Truncated,
    /// The sync bytes are wrong: not `A5 5A` for a descriptor, not the nibbles 0xA and 0x5
    /// for a capsule.
    BadSync {
        /// The first two bytes found.
        found: [u8; 2],
    },
    /// A node's check bits are wrong (S = !S, or C = 0) or its angle is 360° or more
    /// ([`RplidarCounters::node_check`]).
    BadNode,
    /// A capsule's checksum differs from the XOR of its bytes 2..84
    /// ([`RplidarCounters::checksum`]).
    BadChecksum {
        /// The checksum carried by the capsule (its two nibbles).
        stored: u8,
        /// The XOR computed over it.
        computed: u8,
    },
    /// A capsule that passed its checks was dropped because no capsule followed it directly,
    /// or the next one started a new scan: its points cannot be placed
    /// ([`RplidarCounters::capsules_unpaired`]).
    CapsuleUnpaired,
    /// A standard-scan node that passed its check bits but whose angle cannot follow its
    /// neighbours ([`RplidarCounters::implausible`], module `plausible`'s rule,
    /// `docs/lidars.md`): almost surely damaged.
    Implausible,
    /// A response view was made over data of another type.
    UnexpectedType {
        /// The data type found.
        data_type: u8,
    },
    /// A value that its field cannot hold was given to an emitter.
    OutOfRange,
    /// The output buffer is shorter than what is to be emitted; nothing was written.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
        /// Bytes the buffer holds.
        available: usize,
    },
}

impl fmt::Display for RplidarError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Truncated => f.write_str("RPLIDAR unit truncated"),
            Self::BadSync { found: [a, b] } => {
                write!(f, "RPLIDAR sync bytes expected, found {a:02x} {b:02x}")
            }
            Self::BadNode => f.write_str("RPLIDAR node fails its check bits or angle range"),
            Self::BadChecksum { stored, computed } => write!(
                f,
                "RPLIDAR capsule checksum mismatch: stored 0x{stored:02x}, computed 0x{computed:02x}"
            ),
            Self::Implausible => {
                f.write_str("RPLIDAR node refused: its angle cannot follow its neighbours")
            }
            Self::CapsuleUnpaired => {
                f.write_str("RPLIDAR capsule dropped: no directly following capsule")
            }
            Self::UnexpectedType { data_type } => {
                write!(f, "RPLIDAR response of unexpected type 0x{data_type:02x}")
            }
            Self::OutOfRange => f.write_str("value out of range for an RPLIDAR field"),
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "output buffer too small: {needed} bytes needed, {available} available"
            ),
        }
    }
}

impl core::error::Error for RplidarError {}

/// Reads a u16 LE at `at`, or `None` when the two bytes are not there.
fn read_u16_le(bytes: &[u8], at: usize) -> Option<u16> {
    let &pair = bytes.get(at..)?.first_chunk::<2>()?;
    Some(u16::from_le_bytes(pair))
}

/// Writes `bytes` to the front of `out`, or reports the buffer too small (writing nothing).
fn write_all(out: &mut [u8], bytes: &[u8]) -> Result<usize, RplidarError> {
    let available = out.len();
    match out.get_mut(..bytes.len()) {
        Some(dst) => {
            dst.copy_from_slice(bytes);
            Ok(bytes.len())
        }
        None => Err(RplidarError::BufferTooSmall {
            needed: bytes.len(),
            available,
        }),
    }
}
