//! The messages of `docs/protocol.md`, section 4: [`Message`], each body's length, and body
//! parsing ([`decode`]). The bodies live beside it (`command`, `reply`, `map`, `setup`,
//! `stats`, `time`), the encoding into whole frames in `encoding`; every path is re-exported
//! here.

pub use super::command::{
    ClampRequest, Configure, GateRequest, PanAngle, PoseReport, SnapshotScope,
    CONFIGURE_UNIFORM_RESOLUTION, POSE_FLAGS_KNOWN, POSE_STAMPED,
};
pub(crate) use super::command::{CONFIGURE_FLAGS_KNOWN, CONFIGURE_LEN, PAN_LEN, POSE_LEN};
pub use super::map::{
    ClockSource, Decayed, DecayedRows, FirmwareVersion, Hello, HelloReason, LayerInfo, LayerPatch,
    PatchArea, PatchCells, WindowMoved,
};
use super::map::{DECAYED_FIXED, DECAYED_LAYER, HELLO_FIXED, HELLO_LAYER, PATCH_FIXED};
pub(crate) use super::reply::REPLY_LEN;
pub use super::reply::{Reply, ReplyCode, PARAM_LAYER};
pub use super::setup::{
    FilterSetup, LaserSetup, MountSetup, RuleSetup, SetRule, Setup, SETUP_FILTER_LEN,
    SETUP_LASER_LEN, SETUP_MOUNT_LEN, SETUP_RULE_LEN, SETUP_SECTORS,
};
pub(crate) use super::setup::{SETUP_LEN, SET_RULE_LEN};
use super::stats::STATS_LEN;
pub use super::stats::{Stats, STATS_COUNTERS};
use super::time::{
    Observed, TimeReply, TimeRequest, OBSERVED_LEN, TIME_REPLY_LEN, TIME_REQUEST_LEN,
};
use super::{DecodeError, Frame, Header, MessageType, MAX_LAYERS};

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
            pair_depth: self.u8(),
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
                    mount_block: {
                        let axis = r.u8();
                        let [sense] = r.take::<1>().map(|b| i8::from_le_bytes([b]));
                        let _reserved = r.u16();
                        MountSetup {
                            axis,
                            sense,
                            zero_deg: r.f32(),
                            rpy_deg: [r.f32(), r.f32(), r.f32()],
                        }
                    },
                    filter: {
                        let (min_range_cm, max_range_cm) = (r.u16(), r.u16());
                        let (min_quality, sector_count) = (r.u8(), r.u8());
                        let mut sectors = [(0, 0); SETUP_SECTORS];
                        for s in &mut sectors {
                            *s = (r.u16(), r.u16());
                        }
                        FilterSetup {
                            min_range_cm,
                            max_range_cm,
                            min_quality,
                            sector_count,
                            sectors,
                        }
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
