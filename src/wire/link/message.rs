//! The messages of `docs/protocol.md`, section 4: typed representations, body parsing and
//! encoding into whole frames.

use super::cobs;
use super::crc::Crc32;
use super::{DecodeError, EncodeError, Frame, Header, MessageType, MAX_LAYERS, MAX_PATCH_SIDE};
use crate::angle::Angle;
use crate::classify::ClassifierConfig;
use crate::design::{DesignError, GateShape, Param, Schedule, SensorModel};
use crate::geometry::{Mount, ScanPlane, Variant};
use crate::logodds::{Clamp, InverseSensorModel};
use crate::pipeline::FrontendConfig;
use crate::pyramid::Config;
use crate::units::Meters;
use crate::wire::sick::MeasuringMode;
use crate::Design;
use crate::Point3;
use core::fmt;

/// Bytes of a Hello before its layers.
pub(crate) const HELLO_FIXED: usize = 12;
/// Bytes of one layer in a Hello.
pub(crate) const HELLO_LAYER: usize = 20;
/// Bytes of a LayerPatch before its cells.
pub(crate) const PATCH_FIXED: usize = 19;
/// Bytes of a Stats body.
pub(crate) const STATS_LEN: usize = 4 * STATS_COUNTERS;
/// Bytes of a Reply body.
pub(crate) const REPLY_LEN: usize = 17;
/// Bytes of a Pose body.
pub(crate) const POSE_LEN: usize = 28;
/// Bytes of a PanAngle body.
pub(crate) const PAN_LEN: usize = 6;
/// Bytes of a Configure body.
pub(crate) const CONFIGURE_LEN: usize = 61;
/// Configure's `flags` bit 0: every layer at the base cell size ([`Schedule::uniform_resolution`]).
pub const CONFIGURE_UNIFORM_RESOLUTION: u8 = 1;
/// Configure's `flags` bits a receiver knows; any other bit set is refused.
pub(crate) const CONFIGURE_FLAGS_KNOWN: u8 = CONFIGURE_UNIFORM_RESOLUTION;
/// Bytes of a Setup body.
pub(crate) const SETUP_LEN: usize = 38;
/// The number of counters in a [`Stats`].
pub const STATS_COUNTERS: usize = 30;

/// A firmware version, `major.minor.patch`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Major.
    pub major: u8,
    /// Minor.
    pub minor: u8,
    /// Patch.
    pub patch: u8,
}

/// Why a Hello was sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum HelloReason {
    /// The device started: every cell unknown.
    Boot = 0,
    /// A configuration was adopted: every cell unknown.
    Configured = 1,
    /// The maps were reset: every cell unknown.
    Reset = 2,
    /// A snapshot was requested: maps kept, the layers in `resend` follow in full.
    Snapshot = 3,
}

impl HelloReason {
    /// Whether the device's maps were cleared: the host must clear its copy.
    #[must_use]
    pub const fn clears_maps(self) -> bool {
        !matches!(self, Self::Snapshot)
    }

    const fn from_u8(byte: u8) -> Option<Self> {
        Some(match byte {
            0 => Self::Boot,
            1 => Self::Configured,
            2 => Self::Reset,
            3 => Self::Snapshot,
            _ => return None,
        })
    }
}

/// One layer as a Hello describes it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerInfo {
    /// The cell size, raw Q16.16 metres.
    pub resolution_q16: i32,
    /// The band's inner edge d_k, metres (0 when the device does not know the design).
    pub band_inner_m: f32,
    /// The band's outer edge d_{k+1}, metres (0 when unknown).
    pub band_outer_m: f32,
    /// The window origin, world cell index x.
    pub origin_x: i32,
    /// The window origin, world cell index y.
    pub origin_y: i32,
}

/// Device to host: the pyramid in force.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hello {
    /// The protocol version the firmware implements.
    pub protocol: u8,
    /// The firmware's version.
    pub firmware: FirmwareVersion,
    /// Why this Hello was sent.
    pub reason: HelloReason,
    /// W, cells per side of every window.
    pub cells_per_side: u16,
    /// Bit k: every tile of layer k follows (reason [`HelloReason::Snapshot`]).
    pub resend: u32,
    /// The layers in force, finest first.
    pub layers: heapless::Vec<LayerInfo, MAX_LAYERS>,
}

/// Where a [`LayerPatch`] lies: its layer, the window it was made in, its rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PatchArea {
    /// The layer, 0 = finest.
    pub layer: u8,
    /// The layer's window origin when the patch was made, x.
    pub origin_x: i32,
    /// The layer's window origin when the patch was made, y.
    pub origin_y: i32,
    /// World cell index of the rectangle's lower-left cell, x.
    pub x: i32,
    /// World cell index of the rectangle's lower-left cell, y.
    pub y: i32,
    /// Cells along x, 1 ..= 16.
    pub width: u8,
    /// Cells along y, 1 ..= 16.
    pub height: u8,
}

impl PatchArea {
    /// Cells in the rectangle.
    #[must_use]
    pub const fn cells(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Checks the format's limits: sides 1 ..= 16, layer < 16, no overflow of x + width.
    fn check(&self) -> Result<(), &'static str> {
        let side = 1..=MAX_PATCH_SIDE;
        if usize::from(self.layer) >= MAX_LAYERS {
            return Err("LayerPatch.layer");
        }
        if !side.contains(&usize::from(self.width)) {
            return Err("LayerPatch.width");
        }
        if !side.contains(&usize::from(self.height)) {
            return Err("LayerPatch.height");
        }
        if self.x.checked_add(i32::from(self.width)).is_none() {
            return Err("LayerPatch.x");
        }
        if self.y.checked_add(i32::from(self.height)).is_none() {
            return Err("LayerPatch.y");
        }
        Ok(())
    }
}

/// The cells of a [`LayerPatch`]: raw Q8.8 `i16`, little-endian, row-major, row 0 = lowest y,
/// read in place from the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PatchCells<'a> {
    bytes: &'a [u8],
}

impl<'a> PatchCells<'a> {
    /// Cells from their little-endian bytes, or `None` for an odd length.
    #[must_use]
    pub const fn from_le_bytes(bytes: &'a [u8]) -> Option<Self> {
        if bytes.len().is_multiple_of(2) {
            Some(Self { bytes })
        } else {
            None
        }
    }

    /// The little-endian bytes.
    #[must_use]
    pub const fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The number of cells.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.bytes.len() / 2
    }

    /// Whether there are no cells.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.bytes.len() < 2
    }

    /// Cell `index` (row-major), raw.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<i16> {
        let at = index.checked_mul(2)?;
        let pair = self.bytes.get(at..at.checked_add(2)?)?;
        Some(i16::from_le_bytes([
            pair.first().copied()?,
            pair.get(1).copied()?,
        ]))
    }

    /// The cells in order, raw.
    pub fn iter(&self) -> impl Iterator<Item = i16> + 'a {
        self.bytes.chunks_exact(2).map(|p| {
            i16::from_le_bytes([
                p.first().copied().unwrap_or(0),
                p.get(1).copied().unwrap_or(0),
            ])
        })
    }
}

/// Device to host: the current values of a rectangle of one layer's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerPatch<'a> {
    /// Where the cells lie.
    pub area: PatchArea,
    /// `width · height` cells.
    pub cells: PatchCells<'a>,
}

/// Device to host: new window origins for the layers in `mask`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WindowMoved {
    mask: u32,
    origins: [(i32, i32); MAX_LAYERS],
}

impl WindowMoved {
    /// No layer moved yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            mask: 0,
            origins: [(0, 0); MAX_LAYERS],
        }
    }

    /// Records layer `layer`'s new origin; `false` for a layer ≥ [`MAX_LAYERS`].
    pub fn set(&mut self, layer: usize, origin: (i32, i32)) -> bool {
        match self.origins.get_mut(layer) {
            Some(slot) => {
                *slot = origin;
                self.mask |= 1 << layer;
                true
            }
            None => false,
        }
    }

    /// Bit k set: layer k moved.
    #[must_use]
    pub const fn mask(&self) -> u32 {
        self.mask
    }

    /// Layer `layer`'s new origin, or `None` when it did not move.
    #[must_use]
    pub fn origin(&self, layer: usize) -> Option<(i32, i32)> {
        if layer < MAX_LAYERS && self.mask & (1 << layer) != 0 {
            self.origins.get(layer).copied()
        } else {
            None
        }
    }

    /// The moved layers and their new origins, ascending.
    pub fn iter(&self) -> impl Iterator<Item = (usize, (i32, i32))> + '_ {
        (0..MAX_LAYERS).filter_map(|k| self.origin(k).map(|o| (k, o)))
    }

    /// The number of layers that moved.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.mask.count_ones() as usize
    }

    /// Whether no layer moved.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.mask == 0
    }
}

macro_rules! stats_struct {
    ($($(#[$doc:meta])* $name:ident),* $(,)?) => {
        /// Device to host: counters (`docs/protocol.md`, "Stats"). Each saturates.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct Stats {
            $($(#[$doc])* pub $name: u32,)*
        }

        impl Stats {
            /// The counters in wire order.
            #[must_use]
            pub const fn to_array(&self) -> [u32; STATS_COUNTERS] {
                [$(self.$name),*]
            }

            /// Counters from wire order.
            #[must_use]
            pub const fn from_array(values: [u32; STATS_COUNTERS]) -> Self {
                let [$($name),*] = values;
                Self { $($name),* }
            }

            /// The counters' names in wire order.
            pub const NAMES: [&'static str; STATS_COUNTERS] = [$(stringify!($name)),*];
        }
    };
}

stats_struct! {
    /// The device's time when the Stats was queued, ms.
    uptime_ms,
    /// SICK telegrams decoded.
    telegrams_ok,
    /// SICK telegrams with a bad checksum.
    telegrams_bad_checksum,
    /// SICK telegrams with bad framing (sync, length, header).
    telegrams_bad_framing,
    /// SICK telegrams refused for another reason.
    telegrams_bad_other,
    /// Points offered to the classifier.
    points,
    /// Points dropped by a full classifier scratch table.
    classifier_overflows,
    /// Evidence records that changed a cell.
    evidence_applied,
    /// Evidence records gated out (increment zero).
    evidence_gated_out,
    /// Evidence records outside their layer's window.
    evidence_outside_window,
    /// Frames queued (all types).
    frames_sent,
    /// Encoded bytes queued.
    bytes_sent,
    /// LayerPatch frames queued.
    patches_sent,
    /// Tiles whose send was put back for lack of budget or queue room, once per dirty period
    /// (not once per poll while they wait).
    patches_deferred,
    /// Control frames dropped for lack of queue room (each used a sequence number).
    frames_dropped,
    /// Bytes in the queue now.
    queue_used,
    /// The most bytes the queue has held.
    queue_high_water,
    /// The queue's capacity, bytes.
    queue_capacity,
    /// Host frames received good.
    rx_frames_ok,
    /// Host frames with bad COBS.
    rx_bad_cobs,
    /// Host frames with a bad CRC.
    rx_bad_crc,
    /// Host frames too short or too long.
    rx_bad_length,
    /// Host frames with an unknown version or type, a bad body or an out-of-range field.
    rx_bad_other,
    /// Host frames missing by their sequence numbers.
    rx_seq_gaps,
    /// Commands refused with an error Reply.
    commands_refused,
    /// Snapshots served.
    snapshots,
    /// Full resends after window moves the link did not see one by one.
    resyncs,
    /// Observations finished and applied to the pyramid.
    observations,
    /// Bytes the laser's UART delivered to the SICK decoder (wraps at 2³²; a test harness
    /// uses it to know the device has taken every byte it wrote, whatever became of them).
    laser_bytes,
    /// Tiles changed and not yet queued, over every layer, at the time of the Stats (a level,
    /// 0 ..= 64 · layers): with `queue_used` 0 too, every change made before this Stats is
    /// already on the wire ahead of it, so the host's copy is current once it has read it.
    tiles_dirty,
}

/// A Reply's code (`docs/protocol.md`, "Reply").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
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

impl ReplyCode {
    const fn from_u8(byte: u8) -> Option<Self> {
        Some(match byte {
            0 => Self::Ok,
            1 => Self::NotFinite,
            2 => Self::NotPositive,
            3 => Self::OutOfRange,
            4 => Self::GammaNotAboveOne,
            5 => Self::BaseBelowBound,
            6 => Self::TooManyLayers,
            7 => Self::BadWindow,
            8 => Self::WindowTooSmall,
            9 => Self::BadLayer,
            10 => Self::Unsupported,
            11 => Self::Malformed,
            _ => return None,
        })
    }
}

/// A Pose field, as a Reply names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum PoseField {
    /// x.
    X = 32,
    /// y.
    Y = 33,
    /// z.
    Z = 34,
    /// Roll.
    Roll = 35,
    /// Pitch.
    Pitch = 36,
    /// Yaw.
    Yaw = 37,
}

/// The Reply `param` of the snapshot's layer.
pub(crate) const PARAM_LAYER: u8 = 40;

/// The Reply `param` code of a design parameter.
#[must_use]
pub const fn param_code(param: Param) -> u8 {
    match param {
        Param::Phi => 1,
        Param::Psi => 2,
        Param::Sigma => 3,
        Param::Height => 4,
        Param::MaxRange => 5,
        Param::Base => 6,
        Param::Gamma => 7,
        Param::GateWidth => 8,
        Param::Cells => 9,
        Param::PObstacle => 10,
        Param::PFree => 11,
        Param::Prior => 12,
        Param::ClampMin => 13,
        Param::ClampMax => 14,
    }
}

/// The design parameter of a Reply `param` code, if it names one.
#[must_use]
pub const fn param_of_code(code: u8) -> Option<Param> {
    Some(match code {
        1 => Param::Phi,
        2 => Param::Psi,
        3 => Param::Sigma,
        4 => Param::Height,
        5 => Param::MaxRange,
        6 => Param::Base,
        7 => Param::Gamma,
        8 => Param::GateWidth,
        9 => Param::Cells,
        10 => Param::PObstacle,
        11 => Param::PFree,
        12 => Param::Prior,
        13 => Param::ClampMin,
        14 => Param::ClampMax,
        _ => return None,
    })
}

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

/// A small count as `f32` (exact below 2²⁴; larger counts saturate there).
fn count_f32(n: usize) -> f32 {
    let n = u32::try_from(n).unwrap_or(u32::MAX).min(1 << 24);
    #[allow(clippy::cast_precision_loss)]
    let f = n as f32;
    f
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

    /// The refusal of a configuration, one code per [`DesignError`] variant.
    #[must_use]
    pub fn design_error(to: Header, error: &DesignError) -> Self {
        let mut reply = Self::code(to, ReplyCode::Ok);
        reply.param = param_code(error.param());
        let (code, value, a, b) = match *error {
            DesignError::NotFinite { .. } => (ReplyCode::NotFinite, 0.0, 0.0, 0.0),
            DesignError::NotPositive { value, .. } => (ReplyCode::NotPositive, value, 0.0, 0.0),
            DesignError::OutOfRange {
                value, min, max, ..
            } => (ReplyCode::OutOfRange, value, min, max),
            DesignError::GammaNotAboveOne { gamma } => {
                (ReplyCode::GammaNotAboveOne, gamma, 0.0, 0.0)
            }
            DesignError::BaseBelowBound { base_m, bound_m } => {
                (ReplyCode::BaseBelowBound, base_m, bound_m, 0.0)
            }
            DesignError::TooManyLayers { needed, capacity } => (
                ReplyCode::TooManyLayers,
                0.0,
                count_f32(needed),
                count_f32(capacity),
            ),
            DesignError::BadWindow { cells } => (ReplyCode::BadWindow, count_f32(cells), 0.0, 0.0),
            DesignError::WindowTooSmall {
                layer,
                cells,
                needed,
            } => (
                ReplyCode::WindowTooSmall,
                count_f32(layer),
                count_f32(cells),
                count_f32(needed),
            ),
        };
        reply.code = code;
        reply.value = value;
        reply.a = a;
        reply.b = b;
        reply
    }

    /// The refusal of a pose.
    #[must_use]
    pub fn pose_error(to: Header, error: PoseError) -> Self {
        let mut reply = Self::code(to, ReplyCode::Ok);
        reply.param = error.field() as u8;
        match error {
            PoseError::NotFinite { .. } => reply.code = ReplyCode::NotFinite,
            PoseError::OutOfRange { value, limit, .. } => {
                reply.code = ReplyCode::OutOfRange;
                reply.value = value;
                reply.a = -limit;
                reply.b = limit;
            }
        }
        reply
    }

    /// The refusal of a setup.
    #[must_use]
    pub fn setup_error(to: Header, error: SetupError) -> Self {
        let mut reply = Self::code(to, ReplyCode::Ok);
        reply.param = error.field() as u8;
        match error {
            SetupError::NotFinite { .. } => reply.code = ReplyCode::NotFinite,
            SetupError::NotPositive { value, .. } => {
                reply.code = ReplyCode::NotPositive;
                reply.value = value;
            }
            SetupError::OutOfRange {
                value, min, max, ..
            } => {
                reply.code = ReplyCode::OutOfRange;
                reply.value = value;
                reply.a = min;
                reply.b = max;
            }
        }
        reply
    }

    /// The design parameter named by `param`, if any.
    #[must_use]
    pub const fn design_param(&self) -> Option<Param> {
        param_of_code(self.param)
    }

    /// Whether the command was done.
    #[must_use]
    pub fn is_ok(&self) -> bool {
        self.code == ReplyCode::Ok
    }
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "reply to #{} ({:#04x}): ", self.to_seq, self.to_type)?;
        let name: &str = match (self.design_param(), self.param) {
            (Some(p), _) => p.flag(),
            (None, 32) => "pose x",
            (None, 33) => "pose y",
            (None, 34) => "pose z",
            (None, 35) => "pose roll",
            (None, 36) => "pose pitch",
            (None, 37) => "pose yaw",
            (None, PARAM_LAYER) => "layer",
            (None, p) => SetupField::from_param(p).map_or("-", SetupField::name),
        };
        let (v, a, b) = (self.value, self.a, self.b);
        match self.code {
            ReplyCode::Ok => f.write_str("ok"),
            ReplyCode::NotFinite => write!(f, "{name}: must be a finite number"),
            ReplyCode::NotPositive => write!(f, "{name}: must be greater than 0 (got {v})"),
            ReplyCode::OutOfRange if self.param == SetupField::Variant as u8 => write!(
                f,
                "{name}: {a} degrees at {v} centidegrees is not a SICK LMS2xx variant \
                 (180 at 50 or 100; 100 at 25, 50 or 100)"
            ),
            ReplyCode::OutOfRange => write!(f, "{name}: must lie within [{a}, {b}] (got {v})"),
            ReplyCode::GammaNotAboveOne => write!(f, "{name}: must be greater than 1 (got {v})"),
            ReplyCode::BaseBelowBound => {
                write!(f, "{name}: must exceed phi*h = {a} m (got {v} m)")
            }
            ReplyCode::TooManyLayers => {
                write!(f, "{name}: needs {a} layers, the device holds {b}")
            }
            ReplyCode::BadWindow => {
                write!(f, "{name}: must be an even number from 4 to 1024 (got {v})")
            }
            ReplyCode::WindowTooSmall => {
                write!(
                    f,
                    "{name}: layer {v} needs at least {b} cells per side (got {a})"
                )
            }
            ReplyCode::BadLayer => write!(f, "layer {v} does not exist ({a} layers)"),
            ReplyCode::Unsupported => f.write_str("the device does not take this message"),
            ReplyCode::Malformed => f.write_str("the device could not parse the message body"),
        }
    }
}

/// Why a pose was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PoseError {
    /// The field is NaN or infinite.
    NotFinite {
        /// The field.
        field: PoseField,
    },
    /// |value| ≥ limit.
    OutOfRange {
        /// The field.
        field: PoseField,
        /// Its value.
        value: f32,
        /// The bound on its magnitude (exclusive).
        limit: f32,
    },
}

impl PoseError {
    /// The field concerned.
    #[must_use]
    pub const fn field(&self) -> PoseField {
        match *self {
            Self::NotFinite { field } | Self::OutOfRange { field, .. } => field,
        }
    }
}

/// Host to device: the robot's pose in the world frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pose {
    /// x, metres; |x| < 30 000.
    pub x_m: f32,
    /// y, metres; |y| < 30 000.
    pub y_m: f32,
    /// z, metres; |z| < 1 000.
    pub z_m: f32,
    /// Roll about x, radians; finite, |v| < 32 768.
    pub roll_rad: f32,
    /// Pitch about y, radians; finite, |v| < 32 768.
    pub pitch_rad: f32,
    /// Yaw about z, radians, counter-clockwise from +x; finite, |v| < 32 768.
    pub yaw_rad: f32,
    /// The host's clock when the pose was valid, ms.
    pub timestamp_ms: u32,
}

impl Pose {
    /// The largest |x| and |y| accepted (exclusive), metres.
    pub const XY_LIMIT_M: f32 = crate::geometry::pose::MAX_HORIZONTAL_M;
    /// The largest |z| accepted (exclusive), metres.
    pub const Z_LIMIT_M: f32 = crate::geometry::pose::MAX_VERTICAL_M;
    /// The largest |roll|, |pitch| and |yaw| accepted (exclusive), radians: the geometry's
    /// limit ([`crate::geometry::Pose::from_f32`]).
    pub const ANGLE_LIMIT_RAD: f32 = crate::geometry::pose::MAX_ANGLE_RAD;

    /// Checks the pose with exactly the rule of [`crate::geometry::Pose::from_f32`]: every
    /// field finite, |x|, |y| < 30 000 m, |z| < 1 000 m, |roll|, |pitch|, |yaw| < 32 768 rad.
    /// Fields are checked in order x, y, z, roll, pitch, yaw; the first bad one is reported.
    /// A pose that passes converts with [`to_geometry`](Self::to_geometry).
    ///
    /// # Errors
    /// The first bad field.
    pub fn validate(&self) -> Result<(), PoseError> {
        self.to_geometry().map(|_| ())
    }

    /// The pose as the geometry takes it (positions rounded to 2⁻¹⁶ m, angles reduced modulo
    /// a turn), after [`validate`](Self::validate)'s checks.
    ///
    /// # Errors
    /// The first bad field.
    pub fn to_geometry(&self) -> Result<crate::geometry::Pose, PoseError> {
        let limited = [
            (PoseField::X, self.x_m, Self::XY_LIMIT_M),
            (PoseField::Y, self.y_m, Self::XY_LIMIT_M),
            (PoseField::Z, self.z_m, Self::Z_LIMIT_M),
            (PoseField::Roll, self.roll_rad, Self::ANGLE_LIMIT_RAD),
            (PoseField::Pitch, self.pitch_rad, Self::ANGLE_LIMIT_RAD),
            (PoseField::Yaw, self.yaw_rad, Self::ANGLE_LIMIT_RAD),
        ];
        for (field, value, limit) in limited {
            if !value.is_finite() {
                return Err(PoseError::NotFinite { field });
            }
            if value.abs() >= limit {
                return Err(PoseError::OutOfRange {
                    field,
                    value,
                    limit,
                });
            }
        }
        // The geometry's own conversion, so that the two rules cannot drift apart: a pose
        // the checks above pass and the geometry refused would be refused here, by field.
        crate::geometry::Pose::from_f32(
            self.x_m,
            self.y_m,
            self.z_m,
            self.roll_rad,
            self.pitch_rad,
            self.yaw_rad,
        )
        .map_err(|e| {
            let field = match e.field() {
                crate::geometry::PoseField::X => PoseField::X,
                crate::geometry::PoseField::Y => PoseField::Y,
                crate::geometry::PoseField::Z => PoseField::Z,
                crate::geometry::PoseField::Roll => PoseField::Roll,
                crate::geometry::PoseField::Pitch => PoseField::Pitch,
                _ => PoseField::Yaw,
            };
            match e {
                crate::geometry::PoseError::OutOfRange { value, limit, .. } => {
                    PoseError::OutOfRange {
                        field,
                        value,
                        limit,
                    }
                }
                _ => PoseError::NotFinite { field },
            }
        })
    }

    /// The position as [`crate::Point3`] (exact to 2⁻¹⁶ m after rounding; a validated pose
    /// always fits).
    #[must_use]
    pub fn position(&self) -> crate::Point3 {
        crate::Point3 {
            x: crate::units::meters_from_f32(self.x_m),
            y: crate::units::meters_from_f32(self.y_m),
            z: crate::units::meters_from_f32(self.z_m),
        }
    }
}

/// Host to device: the pan angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PanAngle {
    /// The angle, `turns / 65 536` of a turn.
    pub turns: u16,
    /// The host's clock, ms.
    pub timestamp_ms: u32,
}

impl PanAngle {
    /// The angle as the drivers' [`Angle`].
    #[must_use]
    pub const fn angle(&self) -> Angle {
        Angle::from_bits(self.turns)
    }
}

/// Clamping as a Configure asks for it, nats (validated by [`Clamp::bounds`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ClampRequest {
    /// No clamping.
    Off,
    /// Bounds, nats.
    Bounds {
        /// The lower bound, < 0.
        min: f32,
        /// The upper bound, > 0.
        max: f32,
    },
}

/// Host to device: a new design and configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Configure {
    /// The sensor model.
    pub sensor: SensorModel,
    /// The resolution schedule and gate.
    pub schedule: Schedule,
    /// W, cells per side.
    pub cells_per_side: u16,
    /// The inverse sensor model.
    pub model: InverseSensorModel,
    /// Clamping.
    pub clamp: ClampRequest,
    /// The fused query's margin, nats.
    pub fused_margin: f32,
}

impl Default for Configure {
    fn default() -> Self {
        Self {
            sensor: SensorModel::default(),
            schedule: Schedule::default(),
            cells_per_side: 64,
            model: InverseSensorModel::default(),
            clamp: ClampRequest::Bounds {
                min: -2.0,
                max: 3.5,
            },
            fused_margin: 0.0,
        }
    }
}

impl Configure {
    /// The design, by [`Design::new`]'s rules.
    ///
    /// # Errors
    /// The first rule broken.
    pub fn design<const L: usize>(&self) -> Result<Design<L>, DesignError> {
        Design::new(self.sensor, self.schedule, usize::from(self.cells_per_side))
    }

    /// The configuration, by [`InverseSensorModel::increments`] and [`Clamp::bounds`] rules.
    ///
    /// # Errors
    /// The first rule broken.
    pub fn config(&self) -> Result<Config, DesignError> {
        self.model.increments()?;
        let clamp = match self.clamp {
            ClampRequest::Off => Clamp::Off,
            ClampRequest::Bounds { min, max } => Clamp::bounds(min, max)?,
        };
        Ok(Config {
            model: self.model,
            clamp,
            fused_margin: self.fused_margin,
        })
    }
}

/// A field of a [`Setup`], as a Reply names it (`param` 48 ..= 57).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum SetupField {
    /// The mount: 0 panned vertical, 1 tilted horizontal.
    Mount = 48,
    /// The SICK measuring mode (the 0x77 mode number).
    MeasuringMode = 49,
    /// The scanner variant: field of view and resolution together.
    Variant = 50,
    /// The sensor's x in the robot frame.
    SensorX = 51,
    /// The sensor's y in the robot frame.
    SensorY = 52,
    /// The sensor's z in the robot frame.
    SensorZ = 53,
    /// The robot's height (overhang above the cell's ground).
    RobotHeight = 54,
    /// The step threshold.
    StepThreshold = 55,
    /// The drop threshold (0 = off).
    DropThreshold = 56,
    /// The ceiling (0 = off).
    Ceiling = 57,
}

impl SetupField {
    /// The field a Reply `param` names, if it names one.
    #[must_use]
    pub const fn from_param(param: u8) -> Option<Self> {
        Some(match param {
            48 => Self::Mount,
            49 => Self::MeasuringMode,
            50 => Self::Variant,
            51 => Self::SensorX,
            52 => Self::SensorY,
            53 => Self::SensorZ,
            54 => Self::RobotHeight,
            55 => Self::StepThreshold,
            56 => Self::DropThreshold,
            57 => Self::Ceiling,
            _ => return None,
        })
    }

    /// The field's name for messages.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Mount => "setup mount",
            Self::MeasuringMode => "setup measuring mode",
            Self::Variant => "setup scanner variant",
            Self::SensorX => "setup sensor x",
            Self::SensorY => "setup sensor y",
            Self::SensorZ => "setup sensor z",
            Self::RobotHeight => "setup robot height",
            Self::StepThreshold => "setup step threshold",
            Self::DropThreshold => "setup drop threshold",
            Self::Ceiling => "setup ceiling",
        }
    }
}

/// Why a [`Setup`] was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SetupError {
    /// The field is NaN or infinite.
    NotFinite {
        /// The field.
        field: SetupField,
    },
    /// The field must be greater than 0.
    NotPositive {
        /// The field.
        field: SetupField,
        /// Its value.
        value: f32,
    },
    /// The field lies outside `[min, max]` (for [`SetupField::Variant`]: `value` is the
    /// resolution in centidegrees, `min` the field of view in degrees, `max` 0).
    OutOfRange {
        /// The field.
        field: SetupField,
        /// Its value.
        value: f32,
        /// The smallest value allowed.
        min: f32,
        /// The largest value allowed.
        max: f32,
    },
}

impl SetupError {
    /// The field concerned.
    #[must_use]
    pub const fn field(&self) -> SetupField {
        match *self {
            Self::NotFinite { field }
            | Self::NotPositive { field, .. }
            | Self::OutOfRange { field, .. } => field,
        }
    }
}

/// Host to device: how the laser is mounted and how its lines make observations, and the
/// classifier's thresholds. Exactly the fields of a recording's setup event
/// (`docs/recording.md`) plus the thresholds; validated by [`Setup::frontend_config`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Setup {
    /// 0 panned vertical, 1 tilted horizontal.
    pub mount: u8,
    /// The SICK measuring mode (the 0x77 mode number).
    pub measuring_mode: u8,
    /// Field of view, degrees: 100 or 180.
    pub field_deg: u16,
    /// Angular resolution, centidegrees: 25, 50 or 100.
    pub resolution_cdeg: u16,
    /// The sensor's position in the robot frame, metres: x, y, z.
    pub sensor_m: [f32; 3],
    /// Lines per observation; 0 = one observation per sweep.
    pub lines_per_observation: u32,
    /// Points higher than the cell's ground plus this are overhang, metres; > 0.
    pub robot_height_m: f32,
    /// A spread above this makes a cell not navigable, metres; ≥ 0.
    pub step_threshold_m: f32,
    /// A return this far below the robot's ground marks a drop-off, metres; 0 = off.
    pub drop_threshold_m: f32,
    /// Returns higher than this above the robot's ground are overhang, metres; 0 = off.
    pub ceiling_m: f32,
}

impl Setup {
    /// The largest |value| of a position or threshold accepted, metres.
    pub const LIMIT_M: f32 = 1_000.0;

    /// The setup of a recording's setup event and the classifier's thresholds (exact: every
    /// Q16.16 value below 256 m is exact in `f32`, so [`frontend_config`](Self::frontend_config)
    /// gives back the same thresholds).
    #[must_use]
    pub fn from_recording(
        setup: &crate::wire::recording::Setup,
        classifier: &ClassifierConfig,
    ) -> Self {
        let m = |v: Meters| v.to_num::<f32>();
        let off = |v: Option<Meters>| v.map_or(0.0, m);
        Self {
            mount: match setup.mount {
                crate::wire::recording::MountKind::PannedVertical => 0,
                crate::wire::recording::MountKind::TiltedHorizontal => 1,
            },
            measuring_mode: setup.measuring_mode,
            field_deg: setup.field_deg,
            resolution_cdeg: setup.resolution_cdeg,
            sensor_m: setup.sensor_m,
            lines_per_observation: setup.lines_per_observation,
            robot_height_m: m(classifier.robot_height),
            step_threshold_m: m(classifier.step_threshold),
            drop_threshold_m: off(classifier.drop_threshold),
            ceiling_m: off(classifier.ceiling),
        }
    }

    /// Validates the setup and turns it into the pipeline's configuration: the mount exists
    /// (0 or 1), the measuring mode is one the SICK knows, the field of view and resolution
    /// make a variant, positions are finite with |v| < 1 000 m, the robot height is positive,
    /// the thresholds are ≥ 0 and finite (all below 1 000 m). Fields are checked in wire
    /// order; the first bad one is reported.
    ///
    /// # Errors
    /// The first bad field.
    pub fn frontend_config(&self) -> Result<FrontendConfig, SetupError> {
        let plane = match self.mount {
            0 => ScanPlane::PannedVertical,
            1 => ScanPlane::TiltedHorizontal,
            other => {
                return Err(SetupError::OutOfRange {
                    field: SetupField::Mount,
                    value: f32::from(other),
                    min: 0.0,
                    max: 1.0,
                })
            }
        };
        let measuring_mode =
            MeasuringMode::from_code(self.measuring_mode).map_err(|_| SetupError::OutOfRange {
                field: SetupField::MeasuringMode,
                value: f32::from(self.measuring_mode),
                min: 0.0,
                max: 15.0,
            })?;
        let variant = Variant::from_sick(self.field_deg, self.resolution_cdeg).ok_or(
            SetupError::OutOfRange {
                field: SetupField::Variant,
                value: f32::from(self.resolution_cdeg),
                min: f32::from(self.field_deg),
                max: 0.0,
            },
        )?;
        let [sx, sy, sz] = self.sensor_m;
        let position = |field, v: f32| -> Result<Meters, SetupError> {
            if !v.is_finite() {
                return Err(SetupError::NotFinite { field });
            }
            if v.abs() >= Self::LIMIT_M {
                return Err(SetupError::OutOfRange {
                    field,
                    value: v,
                    min: -Self::LIMIT_M,
                    max: Self::LIMIT_M,
                });
            }
            Ok(Meters::saturating_from_num(v))
        };
        let threshold = |field, v: f32| -> Result<Meters, SetupError> {
            if !v.is_finite() {
                return Err(SetupError::NotFinite { field });
            }
            if !(0.0..Self::LIMIT_M).contains(&v) {
                return Err(SetupError::OutOfRange {
                    field,
                    value: v,
                    min: 0.0,
                    max: Self::LIMIT_M,
                });
            }
            Ok(Meters::saturating_from_num(v))
        };
        let position = Point3 {
            x: position(SetupField::SensorX, sx)?,
            y: position(SetupField::SensorY, sy)?,
            z: position(SetupField::SensorZ, sz)?,
        };
        let robot_height = threshold(SetupField::RobotHeight, self.robot_height_m)?;
        if robot_height <= Meters::ZERO {
            return Err(SetupError::NotPositive {
                field: SetupField::RobotHeight,
                value: self.robot_height_m,
            });
        }
        let step_threshold = threshold(SetupField::StepThreshold, self.step_threshold_m)?;
        let drop = threshold(SetupField::DropThreshold, self.drop_threshold_m)?;
        let ceiling = threshold(SetupField::Ceiling, self.ceiling_m)?;
        let optional = |v: Meters| (v > Meters::ZERO).then_some(v);
        Ok(FrontendConfig {
            mount: Mount::new(plane, position),
            variant,
            measuring_mode,
            lines_per_observation: self.lines_per_observation,
            classifier: ClassifierConfig {
                robot_height,
                step_threshold,
                drop_threshold: optional(drop),
                ceiling: optional(ceiling),
                // The link does not carry the rule: the default.
                rule: crate::classify::NavigabilityRule::DEFAULT,
            },
            // Version 1's Setup does not carry the missing-ground option: off.
            missing_ground_within: None,
        })
    }
}

/// Which layers a snapshot covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SnapshotScope {
    /// Every layer (`0xFF` on the wire).
    All,
    /// One layer, 0 ..= 254.
    Layer(u8),
}

/// One message of the protocol.
///
/// Its size is that of a 16-layer [`Hello`], about 350 bytes: bounded, and boxed nowhere (the
/// library has no heap).
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message<'a> {
    /// Device to host: the pyramid in force.
    Hello(Hello),
    /// Device to host: cells.
    LayerPatch(LayerPatch<'a>),
    /// Device to host: new window origins.
    WindowMoved(WindowMoved),
    /// Device to host: counters.
    Stats(Stats),
    /// Device to host: the answer to a command.
    Reply(Reply),
    /// Host to device: the robot's pose.
    Pose(Pose),
    /// Host to device: the pan angle.
    PanAngle(PanAngle),
    /// Host to device: a new design and configuration.
    Configure(Configure),
    /// Host to device: forget every observation.
    Reset,
    /// Host to device: send the cells again.
    RequestSnapshot(SnapshotScope),
    /// Host to device: answer Ok.
    Ping,
    /// Host to device: the laser's mounting, its lines' grouping and the classifier.
    Setup(Setup),
    /// Host to device: send a Stats frame at once.
    RequestStats,
    /// Host to device: flush the queue and stop.
    Shutdown,
    /// Host to device: end the current observation now.
    EndObservation,
}

/// Reads fixed fields from a body.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0_u8; N];
        let (head, tail) = self.bytes.split_at(N.min(self.bytes.len()));
        for (o, b) in out.iter_mut().zip(head) {
            *o = *b;
        }
        self.bytes = tail;
        out
    }
    fn u8(&mut self) -> u8 {
        let [b] = self.take::<1>();
        b
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn rest(self) -> &'a [u8] {
        self.bytes
    }
}

impl<'a> Message<'a> {
    /// The message's type.
    #[must_use]
    pub const fn msg_type(&self) -> MessageType {
        match self {
            Self::Hello(_) => MessageType::Hello,
            Self::LayerPatch(_) => MessageType::LayerPatch,
            Self::WindowMoved(_) => MessageType::WindowMoved,
            Self::Stats(_) => MessageType::Stats,
            Self::Reply(_) => MessageType::Reply,
            Self::Pose(_) => MessageType::Pose,
            Self::PanAngle(_) => MessageType::PanAngle,
            Self::Configure(_) => MessageType::Configure,
            Self::Reset => MessageType::Reset,
            Self::RequestSnapshot(_) => MessageType::RequestSnapshot,
            Self::Ping => MessageType::Ping,
            Self::Setup(_) => MessageType::Setup,
            Self::RequestStats => MessageType::RequestStats,
            Self::Shutdown => MessageType::Shutdown,
            Self::EndObservation => MessageType::EndObservation,
        }
    }

    /// The body's length, bytes.
    #[must_use]
    pub fn body_len(&self) -> usize {
        match self {
            Self::Hello(h) => HELLO_FIXED + HELLO_LAYER * h.layers.len(),
            Self::LayerPatch(p) => PATCH_FIXED + 2 * p.area.cells(),
            Self::WindowMoved(w) => 4 + 8 * w.len(),
            Self::Stats(_) => STATS_LEN,
            Self::Reply(_) => REPLY_LEN,
            Self::Pose(_) => POSE_LEN,
            Self::PanAngle(_) => PAN_LEN,
            Self::Configure(_) => CONFIGURE_LEN,
            Self::Reset
            | Self::Ping
            | Self::RequestStats
            | Self::Shutdown
            | Self::EndObservation => 0,
            Self::RequestSnapshot(_) => 1,
            Self::Setup(_) => SETUP_LEN,
        }
    }

    /// The most bytes this message takes on the wire, delimiter included.
    #[must_use]
    pub fn encoded_len_max(&self) -> usize {
        super::encoded_len_max(super::MIN_FRAME + self.body_len())
    }

    /// Parses a body of type `msg_type`.
    ///
    /// # Errors
    /// [`DecodeError::UnknownType`], [`DecodeError::BadBody`] (wrong length) or
    /// [`DecodeError::OutOfRange`].
    pub fn parse(msg_type: u8, body: &'a [u8]) -> Result<Self, DecodeError> {
        let Some(kind) = MessageType::from_u8(msg_type) else {
            return Err(DecodeError::UnknownType(msg_type));
        };
        let len = body.len();
        let bad = DecodeError::BadBody { msg_type, len };
        let exact = |n: usize| if len == n { Ok(()) } else { Err(bad) };
        let range = |field| DecodeError::OutOfRange { field };
        let mut r = Reader { bytes: body };
        Ok(match kind {
            MessageType::Hello => {
                if len < HELLO_FIXED {
                    return Err(bad);
                }
                let protocol = r.u8();
                let firmware = FirmwareVersion {
                    major: r.u8(),
                    minor: r.u8(),
                    patch: r.u8(),
                };
                let reason = HelloReason::from_u8(r.u8()).ok_or(range("Hello.reason"))?;
                let count = usize::from(r.u8());
                if count > MAX_LAYERS {
                    return Err(range("Hello.layers"));
                }
                exact(HELLO_FIXED + HELLO_LAYER * count)?;
                let cells_per_side = r.u16();
                let resend = r.u32();
                let mut layers = heapless::Vec::new();
                for _ in 0..count {
                    let layer = LayerInfo {
                        resolution_q16: r.i32(),
                        band_inner_m: r.f32(),
                        band_outer_m: r.f32(),
                        origin_x: r.i32(),
                        origin_y: r.i32(),
                    };
                    layers.push(layer).map_err(|_| range("Hello.layers"))?;
                }
                Self::Hello(Hello {
                    protocol,
                    firmware,
                    reason,
                    cells_per_side,
                    resend,
                    layers,
                })
            }
            MessageType::LayerPatch => {
                if len < PATCH_FIXED {
                    return Err(bad);
                }
                let layer = r.u8();
                let width = r.u8();
                let height = r.u8();
                let area = PatchArea {
                    layer,
                    origin_x: r.i32(),
                    origin_y: r.i32(),
                    x: r.i32(),
                    y: r.i32(),
                    width,
                    height,
                };
                area.check().map_err(range)?;
                exact(PATCH_FIXED + 2 * area.cells())?;
                let cells = PatchCells { bytes: r.rest() };
                Self::LayerPatch(LayerPatch { area, cells })
            }
            MessageType::WindowMoved => {
                if len < 4 {
                    return Err(bad);
                }
                let mask = r.u32();
                if mask == 0 {
                    return Err(range("WindowMoved.mask"));
                }
                exact(4 + 8 * mask.count_ones() as usize)?;
                let mut moved = WindowMoved::new();
                for k in 0..MAX_LAYERS {
                    if mask & (1 << k) != 0 {
                        let origin = (r.i32(), r.i32());
                        moved.set(k, origin);
                    }
                }
                Self::WindowMoved(moved)
            }
            MessageType::Stats => {
                exact(STATS_LEN)?;
                let mut values = [0_u32; STATS_COUNTERS];
                for v in &mut values {
                    *v = r.u32();
                }
                Self::Stats(Stats::from_array(values))
            }
            MessageType::Reply => {
                exact(REPLY_LEN)?;
                let to_seq = r.u16();
                let to_type = r.u8();
                let code = ReplyCode::from_u8(r.u8()).ok_or(range("Reply.code"))?;
                Self::Reply(Reply {
                    to_seq,
                    to_type,
                    code,
                    param: r.u8(),
                    value: r.f32(),
                    a: r.f32(),
                    b: r.f32(),
                })
            }
            MessageType::Pose => {
                exact(POSE_LEN)?;
                Self::Pose(Pose {
                    x_m: r.f32(),
                    y_m: r.f32(),
                    z_m: r.f32(),
                    roll_rad: r.f32(),
                    pitch_rad: r.f32(),
                    yaw_rad: r.f32(),
                    timestamp_ms: r.u32(),
                })
            }
            MessageType::PanAngle => {
                exact(PAN_LEN)?;
                Self::PanAngle(PanAngle {
                    turns: r.u16(),
                    timestamp_ms: r.u32(),
                })
            }
            MessageType::Configure => {
                exact(CONFIGURE_LEN)?;
                let sensor = SensorModel {
                    phi_rad: r.f32(),
                    psi_rad: r.f32(),
                    sigma_m: r.f32(),
                    height_m: r.f32(),
                    max_range_m: r.f32(),
                };
                let base_m = r.f32();
                let gamma = r.f32();
                let gate_tag = r.u8();
                let width_factor = r.f32();
                let gate = match gate_tag {
                    0 => GateShape::Hard,
                    1 => GateShape::Soft { width_factor },
                    _ => return Err(range("Configure.gate")),
                };
                let cells_per_side = r.u16();
                let model = InverseSensorModel {
                    p_obstacle: r.f32(),
                    p_free: r.f32(),
                    prior: r.f32(),
                };
                let clamp_tag = r.u8();
                let (min, max) = (r.f32(), r.f32());
                let clamp = match clamp_tag {
                    0 => ClampRequest::Off,
                    1 => ClampRequest::Bounds { min, max },
                    _ => return Err(range("Configure.clamp")),
                };
                let fused_margin = r.f32();
                let flags = r.u8();
                if flags & !CONFIGURE_FLAGS_KNOWN != 0 {
                    return Err(range("Configure.flags"));
                }
                Self::Configure(Configure {
                    sensor,
                    schedule: Schedule {
                        base_m,
                        gamma,
                        gate,
                        uniform_resolution: flags & CONFIGURE_UNIFORM_RESOLUTION != 0,
                    },
                    cells_per_side,
                    model,
                    clamp,
                    fused_margin,
                })
            }
            MessageType::Reset => {
                exact(0)?;
                Self::Reset
            }
            MessageType::RequestSnapshot => {
                exact(1)?;
                match r.u8() {
                    0xFF => Self::RequestSnapshot(SnapshotScope::All),
                    k => Self::RequestSnapshot(SnapshotScope::Layer(k)),
                }
            }
            MessageType::Ping => {
                exact(0)?;
                Self::Ping
            }
            MessageType::Setup => {
                exact(SETUP_LEN)?;
                Self::Setup(Setup {
                    mount: r.u8(),
                    measuring_mode: r.u8(),
                    field_deg: r.u16(),
                    resolution_cdeg: r.u16(),
                    sensor_m: [r.f32(), r.f32(), r.f32()],
                    lines_per_observation: r.u32(),
                    robot_height_m: r.f32(),
                    step_threshold_m: r.f32(),
                    drop_threshold_m: r.f32(),
                    ceiling_m: r.f32(),
                })
            }
            MessageType::RequestStats => {
                exact(0)?;
                Self::RequestStats
            }
            MessageType::Shutdown => {
                exact(0)?;
                Self::Shutdown
            }
            MessageType::EndObservation => {
                exact(0)?;
                Self::EndObservation
            }
        })
    }

    /// Checks what the format cannot carry.
    fn check(&self) -> Result<(), EncodeError> {
        let invalid = |field| Err(EncodeError::Invalid { field });
        match self {
            Self::LayerPatch(p) => {
                p.area
                    .check()
                    .map_err(|field| EncodeError::Invalid { field })?;
                if p.cells.len() != p.area.cells() || !p.cells.as_bytes().len().is_multiple_of(2) {
                    return invalid("LayerPatch.cells");
                }
            }
            Self::WindowMoved(w) if w.is_empty() => return invalid("WindowMoved.mask"),
            Self::RequestSnapshot(SnapshotScope::Layer(0xFF)) => {
                return invalid("RequestSnapshot.layer")
            }
            _ => {}
        }
        Ok(())
    }

    fn write_body(&self, w: &mut Writer<'_>) {
        match self {
            Self::Hello(h) => {
                w.u8(h.protocol);
                w.u8(h.firmware.major);
                w.u8(h.firmware.minor);
                w.u8(h.firmware.patch);
                w.u8(h.reason as u8);
                w.u8(u8::try_from(h.layers.len()).unwrap_or(u8::MAX));
                w.u16(h.cells_per_side);
                w.u32(h.resend);
                for l in &h.layers {
                    w.i32(l.resolution_q16);
                    w.f32(l.band_inner_m);
                    w.f32(l.band_outer_m);
                    w.i32(l.origin_x);
                    w.i32(l.origin_y);
                }
            }
            Self::LayerPatch(p) => {
                w.patch_area(&p.area);
                w.bytes(p.cells.as_bytes());
            }
            Self::WindowMoved(m) => {
                w.u32(m.mask());
                for (_, (x, y)) in m.iter() {
                    w.i32(x);
                    w.i32(y);
                }
            }
            Self::Stats(s) => {
                for v in s.to_array() {
                    w.u32(v);
                }
            }
            Self::Reply(r) => {
                w.u16(r.to_seq);
                w.u8(r.to_type);
                w.u8(r.code as u8);
                w.u8(r.param);
                w.f32(r.value);
                w.f32(r.a);
                w.f32(r.b);
            }
            Self::Pose(p) => {
                for v in [p.x_m, p.y_m, p.z_m, p.roll_rad, p.pitch_rad, p.yaw_rad] {
                    w.f32(v);
                }
                w.u32(p.timestamp_ms);
            }
            Self::PanAngle(p) => {
                w.u16(p.turns);
                w.u32(p.timestamp_ms);
            }
            Self::Configure(c) => {
                let s = &c.sensor;
                for v in [s.phi_rad, s.psi_rad, s.sigma_m, s.height_m, s.max_range_m] {
                    w.f32(v);
                }
                w.f32(c.schedule.base_m);
                w.f32(c.schedule.gamma);
                match c.schedule.gate {
                    GateShape::Hard => {
                        w.u8(0);
                        w.f32(0.0);
                    }
                    GateShape::Soft { width_factor } => {
                        w.u8(1);
                        w.f32(width_factor);
                    }
                }
                w.u16(c.cells_per_side);
                w.f32(c.model.p_obstacle);
                w.f32(c.model.p_free);
                w.f32(c.model.prior);
                match c.clamp {
                    ClampRequest::Off => {
                        w.u8(0);
                        w.f32(0.0);
                        w.f32(0.0);
                    }
                    ClampRequest::Bounds { min, max } => {
                        w.u8(1);
                        w.f32(min);
                        w.f32(max);
                    }
                }
                w.f32(c.fused_margin);
                w.u8(if c.schedule.uniform_resolution {
                    CONFIGURE_UNIFORM_RESOLUTION
                } else {
                    0
                });
            }
            Self::Reset
            | Self::Ping
            | Self::RequestStats
            | Self::Shutdown
            | Self::EndObservation => {}
            Self::Setup(s) => {
                w.u8(s.mount);
                w.u8(s.measuring_mode);
                w.u16(s.field_deg);
                w.u16(s.resolution_cdeg);
                for v in s.sensor_m {
                    w.f32(v);
                }
                w.u32(s.lines_per_observation);
                for v in [
                    s.robot_height_m,
                    s.step_threshold_m,
                    s.drop_threshold_m,
                    s.ceiling_m,
                ] {
                    w.f32(v);
                }
            }
            Self::RequestSnapshot(scope) => w.u8(match *scope {
                SnapshotScope::All => 0xFF,
                SnapshotScope::Layer(k) => k,
            }),
        }
    }
}

/// Writes a frame: header and body through the CRC and COBS, then the CRC, then the delimiter.
struct Writer<'a> {
    cobs: cobs::Encoder<'a>,
    crc: Crc32,
}

impl<'a> Writer<'a> {
    fn new(out: &'a mut [u8], msg_type: MessageType, seq: u16) -> Self {
        let mut w = Self {
            cobs: cobs::Encoder::new(out),
            crc: Crc32::new(),
        };
        w.u8(super::VERSION);
        w.u8(msg_type.to_u8());
        w.u16(seq);
        w
    }
    fn bytes(&mut self, bytes: &[u8]) {
        self.crc.update(bytes);
        self.cobs.push_all(bytes);
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }
    fn patch_area(&mut self, a: &PatchArea) {
        self.u8(a.layer);
        self.u8(a.width);
        self.u8(a.height);
        self.i32(a.origin_x);
        self.i32(a.origin_y);
        self.i32(a.x);
        self.i32(a.y);
    }
    fn finish(mut self, got: usize) -> Result<usize, EncodeError> {
        let crc = self.crc.finish();
        self.cobs.push_all(&crc.to_le_bytes());
        self.cobs
            .finish()
            .map_err(|needed| EncodeError::BufferTooSmall { needed, got })
    }
}

/// Encodes `message` with sequence number `seq` into `out` as one complete frame: COBS, CRC,
/// trailing `0x00`. Returns the bytes written.
///
/// # Errors
/// A field the format cannot carry, or `out` too small (nothing usable is written then).
pub fn encode(seq: u16, message: &Message<'_>, out: &mut [u8]) -> Result<usize, EncodeError> {
    message.check()?;
    let got = out.len();
    let mut w = Writer::new(out, message.msg_type(), seq);
    message.write_body(&mut w);
    w.finish(got)
}

/// Encodes a LayerPatch whose cells come from `cell(column, row)` (raw Q8.8, row 0 = lowest
/// y), without an intermediate buffer: the device writes straight from its layer.
///
/// # Errors
/// A field the format cannot carry, or `out` too small.
pub fn encode_patch(
    seq: u16,
    area: &PatchArea,
    mut cell: impl FnMut(u8, u8) -> i16,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    area.check()
        .map_err(|field| EncodeError::Invalid { field })?;
    let got = out.len();
    let mut w = Writer::new(out, MessageType::LayerPatch, seq);
    w.patch_area(area);
    for row in 0..area.height {
        for col in 0..area.width {
            w.bytes(&cell(col, row).to_le_bytes());
        }
    }
    w.finish(got)
}

/// Decodes one frame (COBS already removed): length, CRC, version, type, body.
///
/// # Errors
/// The first check that fails, with the header when the frame got far enough to have one.
pub fn decode(frame: &[u8]) -> Result<(Header, Message<'_>), (DecodeError, Option<Header>)> {
    let frame = Frame::new_checked(frame).map_err(|e| (e, None))?;
    let header = frame.header();
    let message =
        Message::parse(header.msg_type, frame.body_ref()).map_err(|e| (e, Some(header)))?;
    Ok((header, message))
}
