//! Refusals as Replies: the `param` codes of a design's parameters ([`param_code`]), the
//! Reply for each refused command ([`design_refusal`], [`pose_refusal`], [`setup_refusal`],
//! [`layer_refusal`]), and a Reply read back as a sentence ([`ReplyText`], [`ReplyReason`]).

use core::fmt;

use super::{pose_field_code, SetupError, SetupField, PARAM_POSE_FLAGS};
use crate::design::{DesignError, Param};
use crate::geometry::PoseError;
use crate::wire::link::{Header, Reply, ReplyCode, SnapshotScope, PARAM_LAYER};

/// The Reply `param` code of a design parameter: 1 ..= 15, and 96 + k (96 ..= 127) for layer
/// k's decay time constant.
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
        Param::DecayMode => 15,
        Param::DecayTau { layer } => 96_u8.saturating_add(layer),
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
        15 => Param::DecayMode,
        96..=127 => Param::DecayTau { layer: code - 96 },
        _ => return None,
    })
}

/// A small count as `f32` (exact below 2²⁴; larger counts saturate there).
pub(super) fn count_f32(n: usize) -> f32 {
    let n = u32::try_from(n).unwrap_or(u32::MAX).min(1 << 24);
    #[allow(clippy::cast_precision_loss)]
    let f = n as f32;
    f
}

/// A Reply with a code, a `param` and up to three values.
pub(super) const fn refusal(
    to: Header,
    code: ReplyCode,
    param: u8,
    value: f32,
    a: f32,
    b: f32,
) -> Reply {
    let mut reply = Reply::code(to, code);
    reply.param = param;
    reply.value = value;
    reply.a = a;
    reply.b = b;
    reply
}

/// The refusal of a configuration, one code per [`DesignError`] variant.
#[must_use]
pub fn design_refusal(to: Header, error: &DesignError) -> Reply {
    let param = param_code(error.param());
    let (code, value, a, b) = match *error {
        DesignError::NotFinite { .. } => (ReplyCode::NotFinite, 0.0, 0.0, 0.0),
        DesignError::NotPositive { value, .. } => (ReplyCode::NotPositive, value, 0.0, 0.0),
        DesignError::OutOfRange {
            value, min, max, ..
        } => (ReplyCode::OutOfRange, value, min, max),
        DesignError::GammaNotAboveOne { gamma } => (ReplyCode::GammaNotAboveOne, gamma, 0.0, 0.0),
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
    refusal(to, code, param, value, a, b)
}

/// The refusal of a pose.
#[must_use]
pub fn pose_refusal(to: Header, error: &PoseError) -> Reply {
    let param = pose_field_code(error.field());
    match *error {
        PoseError::OutOfRange { value, limit, .. } => {
            refusal(to, ReplyCode::OutOfRange, param, value, -limit, limit)
        }
        PoseError::NotFinite { .. } => refusal(to, ReplyCode::NotFinite, param, 0.0, 0.0, 0.0),
    }
}

/// The refusal of a setup.
#[must_use]
pub fn setup_refusal(to: Header, error: &SetupError) -> Reply {
    let param = error.field() as u8;
    match *error {
        SetupError::NotFinite { .. } => refusal(to, ReplyCode::NotFinite, param, 0.0, 0.0, 0.0),
        SetupError::NotPositive { value, .. } => {
            refusal(to, ReplyCode::NotPositive, param, value, 0.0, 0.0)
        }
        SetupError::OutOfRange {
            value, min, max, ..
        } => refusal(to, ReplyCode::OutOfRange, param, value, min, max),
    }
}

/// The refusal of a snapshot of a layer the device does not have (`layers` in force).
#[must_use]
pub fn layer_refusal(to: Header, asked: SnapshotScope, layers: usize) -> Reply {
    let asked = match asked {
        SnapshotScope::Layer(k) => f32::from(k),
        SnapshotScope::All => 255.0,
    };
    refusal(
        to,
        ReplyCode::BadLayer,
        PARAM_LAYER,
        asked,
        count_f32(layers),
        0.0,
    )
}

/// A Reply as a sentence: `reply to #seq (type): reason`, the reason naming the parameter
/// (by its `pyramid design` flag, its pose field or its setup field) and the rule.
#[derive(Debug, Clone, Copy)]
pub struct ReplyText<'a>(pub &'a Reply);

impl ReplyText<'_> {
    /// The reason alone, without the `reply to …:` prefix.
    #[must_use]
    pub const fn reason(self) -> ReplyReason {
        ReplyReason(*self.0)
    }
}

/// The reason part of a [`ReplyText`]: what was refused and by which rule.
#[derive(Debug, Clone, Copy)]
pub struct ReplyReason(pub Reply);

impl fmt::Display for ReplyText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "reply to #{} ({:#04x}): {}",
            self.0.to_seq,
            self.0.to_type,
            self.reason()
        )
    }
}

impl fmt::Display for ReplyReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let reply = &self.0;
        let name: &str = match (param_of_code(reply.param), reply.param) {
            (Some(p), _) => p.flag(),
            (None, 32) => "pose x",
            (None, 33) => "pose y",
            (None, 34) => "pose z",
            (None, 35) => "pose roll",
            (None, 36) => "pose pitch",
            (None, 37) => "pose yaw",
            (None, PARAM_POSE_FLAGS) => "pose flags",
            (None, PARAM_LAYER) => "layer",
            (None, p) => SetupField::from_param(p).map_or("-", SetupField::name),
        };
        let (v, a, b) = (reply.value, reply.a, reply.b);
        match reply.code {
            ReplyCode::Ok => f.write_str("ok"),
            ReplyCode::NotFinite => write!(f, "{name}: must be a finite number"),
            ReplyCode::NotPositive => write!(f, "{name}: must be greater than 0 (got {v})"),
            ReplyCode::OutOfRange if reply.param == SetupField::Variant as u8 => write!(
                f,
                "{name}: {a} degrees at {v} centidegrees is not a SICK LMS2xx variant \
                 (180 at 50 or 100; 100 at 25, 50 or 100)"
            ),
            ReplyCode::OutOfRange if reply.param == SetupField::ServoMax as u8 => write!(
                f,
                "{name}: must be above the servo min ({a}) and at most {b} degrees (got {v})"
            ),
            ReplyCode::OutOfRange if reply.param == SetupField::Sensor as u8 => write!(
                f,
                "{name}: {v} is not a sensor (0 SICK, 1 LD06, 2 RPLIDAR, 3 YDLIDAR)"
            ),
            // A device built without the plane rule (`plane-rule` feature) asked for it.
            ReplyCode::OutOfRange
                if reply.param == SetupField::Rule as u8 && v == 1.0 && a == 0.0 && b == 0.0 =>
            {
                write!(
                    f,
                    "{name}: the plane rule (1) is not built into the device (built without \
                     the plane-rule feature); it takes the paper's spread rule (0) only"
                )
            }
            ReplyCode::OutOfRange if reply.param == PARAM_POSE_FLAGS => write!(
                f,
                "{name}: only bit 0 (stamped) is defined, the others must be 0 (got {v})"
            ),
            ReplyCode::OutOfRange => match param_of_code(reply.param) {
                // The library's own sentence, which names the layer.
                Some(param @ Param::DecayTau { .. }) => write!(
                    f,
                    "{}",
                    DesignError::OutOfRange {
                        param,
                        value: v,
                        min: a,
                        max: b
                    }
                ),
                _ => write!(f, "{name}: must lie within [{a}, {b}] (got {v})"),
            },
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
