//! The Reply (`docs/protocol.md`, "Reply"): the device's answer to one host frame, its codes
//! and its body length.

use super::Header;

/// Bytes of a Reply body.
pub(crate) const REPLY_LEN: usize = 17;

byte_enum! {
/// A Reply's code (`docs/protocol.md`, "Reply").
pub enum ReplyCode {
    /// Done.
    Ok = 0,
    /// A value is NaN or infinite.
    NotFinite = 1,
    /// A value must be positive.
    NotPositive = 2,
    /// A value lies outside `[a, b]`.
    OutOfRange = 3,
    /// γ ≤ 1.
    GammaNotAboveOne = 4,
    /// Δd ≤ φ·h.
    BaseBelowBound = 5,
    /// The design needs more layers than compiled in.
    TooManyLayers = 6,
    /// The window size is odd or out of range.
    BadWindow = 7,
    /// A layer's window cannot hold its band.
    WindowTooSmall = 8,
    /// The layer asked for does not exist.
    BadLayer = 9,
    /// The device does not take this type.
    Unsupported = 10,
    /// The frame's body was bad.
    Malformed = 11,
}
/// The code of a Reply's code byte, or `None`.
pub(super) fn from_u8;
}

/// The Reply `param` of the snapshot's layer.
pub const PARAM_LAYER: u8 = 40;

/// Device to host: the answer to one host frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reply {
    /// The host frame's sequence number.
    pub to_seq: u16,
    /// The host frame's type byte.
    pub to_type: u8,
    /// What happened.
    pub code: ReplyCode,
    /// The parameter or field concerned (0 = none).
    pub param: u8,
    /// The offending value (by code).
    pub value: f32,
    /// The first limit (by code).
    pub a: f32,
    /// The second limit (by code).
    pub b: f32,
}

impl Reply {
    /// Reply Ok to a frame.
    #[must_use]
    pub const fn ok(to: Header) -> Self {
        Self::code(to, ReplyCode::Ok)
    }

    /// A reply with a code and nothing else.
    #[must_use]
    pub const fn code(to: Header, code: ReplyCode) -> Self {
        Self {
            to_seq: to.seq,
            to_type: to.msg_type,
            code,
            param: 0,
            value: 0.0,
            a: 0.0,
            b: 0.0,
        }
    }

    /// Whether the command was done.
    #[must_use]
    pub fn is_ok(&self) -> bool {
        self.code == ReplyCode::Ok
    }
}
