//! The messages of `docs/protocol.md`, section 4: typed representations, body parsing and
//! encoding into whole frames.

use super::cobs;
use super::crc::Crc32;
pub use super::map::{
    ClockSource, Decayed, DecayedRows, FirmwareVersion, Hello, HelloReason, LayerInfo, LayerPatch,
    PatchArea, PatchCells, WindowMoved,
};
use super::map::{DECAYED_FIXED, DECAYED_LAYER, HELLO_FIXED, HELLO_LAYER, PATCH_FIXED};
pub use super::setup::{LaserSetup, RuleSetup, SetRule, Setup, SETUP_LASER_LEN, SETUP_RULE_LEN};
pub(crate) use super::setup::{SETUP_LEN, SET_RULE_LEN};
use super::stats::STATS_LEN;
pub use super::stats::{Stats, STATS_COUNTERS};
use super::time::{
    Observed, TimeReply, TimeRequest, OBSERVED_LEN, TIME_REPLY_LEN, TIME_REQUEST_LEN,
};
use super::{DecodeError, EncodeError, Frame, Header, MessageType, MAX_LAYERS};
use crate::angle::Angle;

/// Bytes of a Reply body.
pub(crate) const REPLY_LEN: usize = 17;
/// Bytes of a Pose body: the six pose fields, the stamp and the flags.
pub(crate) const POSE_LEN: usize = 29;
/// Pose's `flags` bit 0: `stamp_us` is valid and the pose joins the device's pose track;
/// clear, the pose applies to every return from now on (version 3's latest-pose rule).
pub const POSE_STAMPED: u8 = 1;
/// Pose's `flags` bits a receiver knows; any other bit set is out of range.
pub const POSE_FLAGS_KNOWN: u8 = POSE_STAMPED;
/// Bytes of a PanAngle body.
pub(crate) const PAN_LEN: usize = 6;
/// Bytes of a Configure body: 61 of version 2, the decay mode and 32 time-constant codes.
pub(crate) const CONFIGURE_LEN: usize = 61 + 1 + MAX_LAYERS;
/// Configure's `flags` bit 0: every layer at the base cell size ([`Configure::uniform_resolution`]).
pub const CONFIGURE_UNIFORM_RESOLUTION: u8 = 1;
/// Configure's `flags` bits a receiver knows; any other bit set is refused.
pub(crate) const CONFIGURE_FLAGS_KNOWN: u8 = CONFIGURE_UNIFORM_RESOLUTION;

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

/// Host to device: the robot's pose in the world frame, as the host reports it (unvalidated
/// `f32`s: the device converts it with the geometry's own rule,
/// [`crate::geometry::Pose::from_f32`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseReport {
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
    /// The device's µs clock (wrapping) at which the robot was at this pose; read only when
    /// `flags` has [`POSE_STAMPED`].
    pub stamp_us: u32,
    /// Bit 0 [`POSE_STAMPED`]; every other bit must be 0 (the device refuses the pose).
    pub flags: u8,
}

impl PoseReport {
    /// Whether the pose is stamped ([`POSE_STAMPED`]): it joins the device's pose track.
    #[must_use]
    pub const fn is_stamped(&self) -> bool {
        self.flags & POSE_STAMPED != 0
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
    /// The angle as an [`Angle`].
    #[must_use]
    pub const fn angle(&self) -> Angle {
        Angle::from_bits(self.turns)
    }
}

/// Clamping as a Configure asks for it, nats (validated by [`crate::Clamp::bounds`]).
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

/// The gate as a Configure asks for it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GateRequest {
    /// The top-hat over each band (tag 0).
    Hard,
    /// The Gaussian around each band's centre (tag 1), its σ this factor of the band's width.
    Soft {
        /// σ_g / band width.
        width_factor: f32,
    },
}

/// Host to device: a new design and configuration, as the wire carries it (unvalidated: the
/// device checks it with the library's own rules, [`crate::link::convert`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Configure {
    /// φ, the vertical angular resolution, radians.
    pub phi_rad: f32,
    /// ψ, the horizontal angular resolution, radians.
    pub psi_rad: f32,
    /// σ, the range noise, metres.
    pub sigma_m: f32,
    /// h, the sensor's height above the ground, metres.
    pub height_m: f32,
    /// The sensor's maximum range, metres.
    pub max_range_m: f32,
    /// Δd, the base cell size, metres.
    pub base_m: f32,
    /// γ, the linear scaling of the resolution schedule.
    pub gamma: f32,
    /// The gate.
    pub gate: GateRequest,
    /// W, cells per side.
    pub cells_per_side: u16,
    /// p(x | obstacle seen).
    pub p_obstacle: f32,
    /// p(x | navigable seen).
    pub p_free: f32,
    /// The prior p(x).
    pub prior: f32,
    /// Clamping.
    pub clamp: ClampRequest,
    /// The fused query's margin, nats.
    pub fused_margin: f32,
    /// Every layer at the base cell size (`flags` bit 0).
    pub uniform_resolution: bool,
    /// The decay mode: 0 off, 1 all evidence, 2 obstacle evidence only, 3 free evidence only
    /// (*checked*; `crate::decay::DecayMode`).
    pub decay_mode: u8,
    /// Each layer's decay time constant as a code: 0 = none, c = τ of 8 · ⌊(125 · 2^q · T_r +
    /// 2¹⁵) / 2¹⁶⌋ ms with c − 1 = 16q + r (`crate::decay::TimeConstant`).
    pub decay_tau: [u8; MAX_LAYERS],
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
/// Its size is that of a 32-layer [`Hello`], about 664 bytes: bounded, and boxed nowhere (the
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
    /// Device to host: rows that took a decay step.
    Decayed(Decayed),
    /// Host to device: the robot's pose.
    Pose(PoseReport),
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
    /// Host to device: the classifier's step threshold and navigability rule.
    SetRule(SetRule),
    /// Host to device: the host's clock, to be answered with a TimeReply.
    TimeRequest(TimeRequest),
    /// Device to host: the answer to a TimeRequest.
    TimeReply(TimeReply),
    /// Device to host: an observation was applied, and when its returns were measured.
    Observed(Observed),
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
    fn rule_setup(&mut self) -> RuleSetup {
        RuleSetup {
            rule: self.u8(),
            max_grade: self.f32(),
            residual_m: self.f32(),
            range_sigma_m: self.f32(),
            angle_sigma_rad: self.f32(),
            noise_factor: self.f32(),
        }
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
            Self::Decayed(_) => MessageType::Decayed,
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
            Self::SetRule(_) => MessageType::SetRule,
            Self::TimeRequest(_) => MessageType::TimeRequest,
            Self::TimeReply(_) => MessageType::TimeReply,
            Self::Observed(_) => MessageType::Observed,
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
            Self::Decayed(d) => DECAYED_FIXED + DECAYED_LAYER * d.len(),
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
            Self::SetRule(_) => SET_RULE_LEN,
            Self::TimeRequest(_) => TIME_REQUEST_LEN,
            Self::TimeReply(_) => TIME_REPLY_LEN,
            Self::Observed(_) => OBSERVED_LEN,
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
                let clock = ClockSource::from_code(r.u8()).ok_or(range("Hello.clock"))?;
                // Three reserved bytes, sent as 0, ignored.
                let _ = (r.u8(), r.u8(), r.u8());
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
                    clock,
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
                let cells = PatchCells::of_body(r.rest());
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
            MessageType::Decayed => {
                if len < DECAYED_FIXED {
                    return Err(bad);
                }
                let mode = r.u8();
                if !(1..=3).contains(&mode) {
                    return Err(range("Decayed.mode"));
                }
                let mask = r.u32();
                if mask == 0 {
                    return Err(range("Decayed.mask"));
                }
                exact(DECAYED_FIXED + DECAYED_LAYER * mask.count_ones() as usize)?;
                let mut decayed = Decayed::new(mode);
                for k in 0..MAX_LAYERS {
                    if mask & (1 << k) != 0 {
                        let rows = DecayedRows {
                            first: r.u16(),
                            rows: r.u16(),
                            faded: r.u32(),
                        };
                        if rows.rows == 0 {
                            return Err(range("Decayed.rows"));
                        }
                        decayed.set(k, rows);
                    }
                }
                Self::Decayed(decayed)
            }
            MessageType::Pose => {
                exact(POSE_LEN)?;
                Self::Pose(PoseReport {
                    x_m: r.f32(),
                    y_m: r.f32(),
                    z_m: r.f32(),
                    roll_rad: r.f32(),
                    pitch_rad: r.f32(),
                    yaw_rad: r.f32(),
                    stamp_us: r.u32(),
                    flags: r.u8(),
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
                let (phi_rad, psi_rad, sigma_m) = (r.f32(), r.f32(), r.f32());
                let (height_m, max_range_m) = (r.f32(), r.f32());
                let base_m = r.f32();
                let gamma = r.f32();
                let gate_tag = r.u8();
                let width_factor = r.f32();
                let gate = match gate_tag {
                    0 => GateRequest::Hard,
                    1 => GateRequest::Soft { width_factor },
                    _ => return Err(range("Configure.gate")),
                };
                let cells_per_side = r.u16();
                let (p_obstacle, p_free, prior) = (r.f32(), r.f32(), r.f32());
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
                let decay_mode = r.u8();
                if decay_mode > 3 {
                    return Err(range("Configure.decay"));
                }
                let decay_tau = r.take::<MAX_LAYERS>();
                Self::Configure(Configure {
                    phi_rad,
                    psi_rad,
                    sigma_m,
                    height_m,
                    max_range_m,
                    base_m,
                    gamma,
                    gate,
                    cells_per_side,
                    p_obstacle,
                    p_free,
                    prior,
                    clamp,
                    fused_margin,
                    uniform_resolution: flags & CONFIGURE_UNIFORM_RESOLUTION != 0,
                    decay_mode,
                    decay_tau,
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
                    rule: r.rule_setup(),
                    laser: LaserSetup {
                        sensor: r.u8(),
                        actuator: r.u8(),
                        baud: r.u32(),
                        servo_min_deg: r.f32(),
                        servo_max_deg: r.f32(),
                        servo_rate_deg_s: r.f32(),
                        servo_latency_ms: r.f32(),
                    },
                })
            }
            MessageType::RequestStats => {
                exact(0)?;
                Self::RequestStats
            }
            MessageType::SetRule => {
                exact(SET_RULE_LEN)?;
                Self::SetRule(SetRule {
                    step_threshold_m: r.f32(),
                    rule: r.rule_setup(),
                })
            }
            MessageType::Shutdown => {
                exact(0)?;
                Self::Shutdown
            }
            MessageType::EndObservation => {
                exact(0)?;
                Self::EndObservation
            }
            MessageType::TimeRequest => {
                exact(TIME_REQUEST_LEN)?;
                Self::TimeRequest(TimeRequest::from_le_bytes(&r.take()))
            }
            MessageType::TimeReply => {
                exact(TIME_REPLY_LEN)?;
                Self::TimeReply(TimeReply::from_le_bytes(&r.take()))
            }
            MessageType::Observed => {
                exact(OBSERVED_LEN)?;
                Self::Observed(Observed::from_le_bytes(&r.take()))
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
            Self::Decayed(d) if d.is_empty() => return invalid("Decayed.mask"),
            Self::Decayed(d) if !(1..=3).contains(&d.mode) => return invalid("Decayed.mode"),
            Self::Decayed(d) if d.iter().any(|(_, r)| r.rows == 0) => {
                return invalid("Decayed.rows")
            }
            Self::Configure(c) if c.decay_mode > 3 => return invalid("Configure.decay"),
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
                w.u8(h.clock.code());
                w.u8(0);
                w.u8(0);
                w.u8(0);
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
            Self::Decayed(d) => {
                w.u8(d.mode);
                w.u32(d.mask());
                for (_, rows) in d.iter() {
                    w.u16(rows.first);
                    w.u16(rows.rows);
                    w.u32(rows.faded);
                }
            }
            Self::Pose(p) => {
                for v in [p.x_m, p.y_m, p.z_m, p.roll_rad, p.pitch_rad, p.yaw_rad] {
                    w.f32(v);
                }
                w.u32(p.stamp_us);
                w.u8(p.flags);
            }
            Self::PanAngle(p) => {
                w.u16(p.turns);
                w.u32(p.timestamp_ms);
            }
            Self::Configure(c) => {
                for v in [c.phi_rad, c.psi_rad, c.sigma_m, c.height_m, c.max_range_m] {
                    w.f32(v);
                }
                w.f32(c.base_m);
                w.f32(c.gamma);
                match c.gate {
                    GateRequest::Hard => {
                        w.u8(0);
                        w.f32(0.0);
                    }
                    GateRequest::Soft { width_factor } => {
                        w.u8(1);
                        w.f32(width_factor);
                    }
                }
                w.u16(c.cells_per_side);
                w.f32(c.p_obstacle);
                w.f32(c.p_free);
                w.f32(c.prior);
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
                w.u8(if c.uniform_resolution {
                    CONFIGURE_UNIFORM_RESOLUTION
                } else {
                    0
                });
                w.u8(c.decay_mode);
                w.bytes(&c.decay_tau);
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
                w.rule_setup(&s.rule);
                w.laser_setup(&s.laser);
            }
            Self::SetRule(s) => {
                w.f32(s.step_threshold_m);
                w.rule_setup(&s.rule);
            }
            Self::TimeRequest(t) => w.bytes(&t.to_le_bytes()),
            Self::TimeReply(t) => w.bytes(&t.to_le_bytes()),
            Self::Observed(o) => w.bytes(&o.to_le_bytes()),
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
    fn rule_setup(&mut self, r: &RuleSetup) {
        self.u8(r.rule);
        for v in [
            r.max_grade,
            r.residual_m,
            r.range_sigma_m,
            r.angle_sigma_rad,
            r.noise_factor,
        ] {
            self.f32(v);
        }
    }
    fn laser_setup(&mut self, l: &LaserSetup) {
        self.u8(l.sensor);
        self.u8(l.actuator);
        self.u32(l.baud);
        for v in [
            l.servo_min_deg,
            l.servo_max_deg,
            l.servo_rate_deg_s,
            l.servo_latency_ms,
        ] {
            self.f32(v);
        }
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
