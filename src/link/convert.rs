//! Between the link's messages ([`crate::wire::link`], pure wire values) and the core's types:
//! every host command is validated here, once, by the rule that converts it, and every refusal
//! is turned into the Reply that names the parameter and the rule.
//!
//! - A [`Configure`] becomes a [`Design`] by [`Design::new`]'s rules and a [`Config`] by the
//!   inverse sensor model's and [`Clamp::bounds`]' ([`design_of`], [`config_of`]); the host
//!   builds one from the same types ([`configure_message`]).
//! - A [`PoseReport`] becomes a [`Pose`] by [`Pose::from_f32`] ([`pose_of`]).
//! - A [`Setup`] becomes a [`FrontendConfig`] ([`frontend_config`]); a recording's setup event
//!   goes through the same rule ([`setup_message`], then [`frontend_config`]).
//! - A refusal becomes a [`Reply`] ([`design_refusal`], [`pose_refusal`], [`setup_refusal`],
//!   [`layer_refusal`]) whose `param` codes ([`param_code`], [`pose_field_code`],
//!   [`SetupField`], [`PARAM_LAYER`]) `docs/protocol.md` lists, and a Reply reads back as a
//!   sentence with [`ReplyText`].

use core::fmt;

use crate::actuator::{Actuator, ServoProfile};
use crate::angle::FineAngle;
use crate::classify::{ClassifierConfig, NavigabilityRule, PlaneRule, Ratio};
use crate::decay::{Decay, DecayMode, TimeConstant, DECAY_LAYERS};
use crate::design::{Design, DesignError, GateShape, Param, Schedule, SensorModel};
use crate::geometry::{Mount, Pose, PoseError, PoseField, ScanPlane};
use crate::laser::{Sensor, SensorKind};
use crate::logodds::{Clamp, InverseSensorModel};
use crate::pipeline::FrontendConfig;
use crate::pyramid::Config;
use crate::units::{Meters, Point3};
use crate::wire::link::{
    ClampRequest, Configure, GateRequest, Header, LaserSetup, PoseReport, Reply, ReplyCode,
    RuleSetup, SetRule, Setup, SnapshotScope, PARAM_LAYER, POSE_FLAGS_KNOWN, POSE_STAMPED,
};
use crate::wire::recording::{MountKind, SensorEvent, SetupEvent};
use crate::wire::sick::{MeasuringMode, Variant};

// ---------------------------------------------------------------- Configure

/// The Configure that asks for `sensor`, `schedule`, a window of `cells_per_side` and
/// `config` (clamping bounds as nats, exactly: Q8.8 values are exact in `f32`).
#[must_use]
pub fn configure_message(
    sensor: &SensorModel,
    schedule: &Schedule,
    cells_per_side: u16,
    config: &Config,
) -> Configure {
    Configure {
        phi_rad: sensor.phi_rad,
        psi_rad: sensor.psi_rad,
        sigma_m: sensor.sigma_m,
        height_m: sensor.height_m,
        max_range_m: sensor.max_range_m,
        base_m: schedule.base_m,
        gamma: schedule.gamma,
        gate: match schedule.gate {
            GateShape::Hard => GateRequest::Hard,
            GateShape::Soft { width_factor } => GateRequest::Soft { width_factor },
        },
        cells_per_side,
        p_obstacle: config.model.p_obstacle,
        p_free: config.model.p_free,
        prior: config.model.prior,
        clamp: match config.clamp {
            Clamp::Off => ClampRequest::Off,
            Clamp::Bounds { min, max } => ClampRequest::Bounds {
                min: min.to_num(),
                max: max.to_num(),
            },
        },
        fused_margin: config.fused_margin,
        uniform_resolution: schedule.uniform_resolution,
        decay_mode: config.decay.mode.to_u8(),
        decay_tau: config.decay.tau.map(TimeConstant::code),
    }
}

/// The Configure of a design and a configuration ([`configure_message`]).
#[must_use]
pub fn configure_of_design<const L: usize>(design: &Design<L>, config: &Config) -> Configure {
    configure_message(
        design.sensor(),
        design.schedule(),
        u16::try_from(design.cells_per_side()).unwrap_or(u16::MAX),
        config,
    )
}

/// The design a Configure asks for, by [`Design::new`]'s rules.
///
/// # Errors
/// The first rule broken.
pub fn design_of<const L: usize>(c: &Configure) -> Result<Design<L>, DesignError> {
    let sensor = SensorModel {
        phi_rad: c.phi_rad,
        psi_rad: c.psi_rad,
        sigma_m: c.sigma_m,
        height_m: c.height_m,
        max_range_m: c.max_range_m,
    };
    let schedule = Schedule {
        base_m: c.base_m,
        gamma: c.gamma,
        gate: match c.gate {
            GateRequest::Hard => GateShape::Hard,
            GateRequest::Soft { width_factor } => GateShape::Soft { width_factor },
        },
        uniform_resolution: c.uniform_resolution,
    };
    Design::new(sensor, schedule, usize::from(c.cells_per_side))
}

/// The configuration a Configure asks for, by [`InverseSensorModel::increments`]' and
/// [`Clamp::bounds`]' rules (the fused margin is checked by [`crate::Pyramid::configure`]).
///
/// # Errors
/// The first rule broken.
pub fn config_of(c: &Configure) -> Result<Config, DesignError> {
    let model = InverseSensorModel {
        p_obstacle: c.p_obstacle,
        p_free: c.p_free,
        prior: c.prior,
    };
    model.increments()?;
    let clamp = match c.clamp {
        ClampRequest::Off => Clamp::Off,
        ClampRequest::Bounds { min, max } => Clamp::bounds(min, max)?,
    };
    Ok(Config {
        model,
        clamp,
        fused_margin: c.fused_margin,
        decay: decay_of(c)?,
    })
}

/// The decay a Configure asks for: its mode and time constants (checked against the design
/// and the window by [`Decay::validate`], when the pyramid adopts it).
///
/// # Errors
/// A mode byte above 3 ([`Param::DecayMode`]; the wire's parser already refuses it).
pub fn decay_of(c: &Configure) -> Result<Decay, DesignError> {
    let mode = DecayMode::from_u8(c.decay_mode).ok_or(DesignError::OutOfRange {
        param: Param::DecayMode,
        value: f32::from(c.decay_mode),
        min: 0.0,
        max: 3.0,
    })?;
    let mut tau = [TimeConstant::NONE; DECAY_LAYERS];
    for (t, &code) in tau.iter_mut().zip(&c.decay_tau) {
        *t = TimeConstant::from_code(code);
    }
    Ok(Decay { mode, tau })
}

// ---------------------------------------------------------------- Pose

/// The pose a report gives, by the geometry's own rule ([`Pose::from_f32`]): every field
/// finite, |x|, |y| < 30 000 m, |z| < 1 000 m, |roll|, |pitch|, |yaw| < 32 768 rad.
///
/// # Errors
/// The first bad field, in the order x, y, z, roll, pitch, yaw.
pub fn pose_of(report: &PoseReport) -> Result<Pose, PoseError> {
    Pose::from_f32(
        report.x_m,
        report.y_m,
        report.z_m,
        report.roll_rad,
        report.pitch_rad,
        report.yaw_rad,
    )
}

/// The Reply `param` of a Pose's `flags` (protocol version 4): a bit other than
/// [`POSE_STAMPED`] set is refused with OutOfRange, the flags as the value, limits 0 and 1.
pub const PARAM_POSE_FLAGS: u8 = 38;

/// A Pose's stamp: `Some(stamp_us)` (the device's µs clock) when the pose is stamped,
/// `None` for an unstamped pose (the latest-pose rule).
///
/// # Errors
/// A flag bit other than [`POSE_STAMPED`] set: the flags byte.
pub const fn stamp_of(report: &PoseReport) -> Result<Option<u32>, u8> {
    if report.flags & !POSE_FLAGS_KNOWN != 0 {
        Err(report.flags)
    } else if report.flags & POSE_STAMPED != 0 {
        Ok(Some(report.stamp_us))
    } else {
        Ok(None)
    }
}

/// The refusal of a Pose's `flags` (a bit other than [`POSE_STAMPED`]): OutOfRange,
/// [`PARAM_POSE_FLAGS`], the flags byte, limits 0 and 1.
#[must_use]
pub fn pose_flags_refusal(to: Header, flags: u8) -> Reply {
    refusal(
        to,
        ReplyCode::OutOfRange,
        PARAM_POSE_FLAGS,
        f32::from(flags),
        0.0,
        1.0,
    )
}

/// The Reply `param` code of a pose field: 32 ..= 37 for x, y, z, roll, pitch, yaw.
#[must_use]
pub const fn pose_field_code(field: PoseField) -> u8 {
    match field {
        PoseField::X => 32,
        PoseField::Y => 33,
        PoseField::Z => 34,
        PoseField::Roll => 35,
        PoseField::Pitch => 36,
        PoseField::Yaw => 37,
    }
}

// ---------------------------------------------------------------- Setup

/// A field of a [`Setup`], as a Reply names it (`param` 48 ..= 57, and 58 ..= 64 for the
/// laser block of protocol version 3).
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
    /// The sensor: 0 SICK, 1 LD06, 2 RPLIDAR, 3 YDLIDAR.
    Sensor = 58,
    /// The laser UART's baud rate (0 = the sensor's default).
    Baud = 59,
    /// The actuator: 0 external, 1 nodding servo.
    Actuator = 60,
    /// The servo sweep's lower end.
    ServoMin = 61,
    /// The servo sweep's upper end.
    ServoMax = 62,
    /// The servo sweep's rate.
    ServoRate = 63,
    /// The servo's latency.
    ServoLatency = 64,
    /// The navigability rule: 0 the paper's spread rule, 1 the plane rule.
    Rule = 65,
    /// The plane rule's largest slope, as a grade.
    MaxGrade = 66,
    /// The plane rule's residual allowance.
    Residual = 67,
    /// The plane rule's range noise σ.
    RangeSigma = 68,
    /// The plane rule's elevation error σ_a.
    AngleSigma = 69,
    /// The plane rule's noise factor.
    NoiseFactor = 70,
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
            58 => Self::Sensor,
            59 => Self::Baud,
            60 => Self::Actuator,
            61 => Self::ServoMin,
            62 => Self::ServoMax,
            63 => Self::ServoRate,
            64 => Self::ServoLatency,
            65 => Self::Rule,
            66 => Self::MaxGrade,
            67 => Self::Residual,
            68 => Self::RangeSigma,
            69 => Self::AngleSigma,
            70 => Self::NoiseFactor,
            _ => return None,
        })
    }

    /// The field's name for messages.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Mount => "setup mount",
            Self::MeasuringMode => "setup sensor mode",
            Self::Variant => "setup scanner variant",
            Self::SensorX => "setup sensor x",
            Self::SensorY => "setup sensor y",
            Self::SensorZ => "setup sensor z",
            Self::RobotHeight => "setup robot height",
            Self::StepThreshold => "setup step threshold",
            Self::DropThreshold => "setup drop threshold",
            Self::Ceiling => "setup ceiling",
            Self::Sensor => "setup sensor",
            Self::Baud => "setup baud rate",
            Self::Actuator => "setup actuator",
            Self::ServoMin => "setup servo min",
            Self::ServoMax => "setup servo max",
            Self::ServoRate => "setup servo rate",
            Self::ServoLatency => "setup servo latency",
            Self::Rule => "setup navigability rule",
            Self::MaxGrade => "setup largest slope",
            Self::Residual => "setup residual allowance",
            Self::RangeSigma => "setup range noise",
            Self::AngleSigma => "setup elevation error",
            Self::NoiseFactor => "setup noise factor",
        }
    }
}

/// Why a setup (the link's [`Setup`], or a recording's setup event) cannot configure the
/// pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
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

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let to = Header {
            version: crate::wire::link::VERSION,
            msg_type: 0,
            seq: 0,
        };
        let reply = setup_refusal(to, self);
        write!(f, "{}", ReplyText(&reply).reason())
    }
}

impl core::error::Error for SetupError {}

/// The largest |value| of a sensor position or a threshold a setup may carry, metres
/// (exclusive).
pub const SETUP_LIMIT_M: f32 = 1_000.0;

/// The baud rates a setup may ask for (0 asks for the sensor's default).
pub const SETUP_BAUD: core::ops::RangeInclusive<u32> = 9_600..=3_000_000;

/// The largest |angle| of a servo sweep's end, degrees.
pub const SERVO_LIMIT_DEG: f32 = 179.0;

/// The fastest servo sweep, degrees per second.
pub const SERVO_MAX_RATE_DEG_S: f32 = 1_000.0;

/// The longest servo latency, milliseconds (exclusive).
pub const SERVO_MAX_LATENCY_MS: f32 = 1_000.0;

/// The link's Setup of a recording's setup event and the classifier's thresholds (exact:
/// every Q16.16 value below 256 m is exact in `f32`, so [`frontend_config`] gives back the
/// same thresholds).
#[must_use]
pub fn setup_message(event: &SetupEvent, classifier: &ClassifierConfig) -> Setup {
    let m = |v: Meters| v.to_num::<f32>();
    let off = |v: Option<Meters>| v.map_or(0.0, m);
    Setup {
        mount: match event.mount {
            MountKind::PannedVertical => 0,
            MountKind::TiltedHorizontal => 1,
        },
        measuring_mode: event.measuring_mode,
        field_deg: event.field_deg,
        resolution_cdeg: event.resolution_cdeg,
        sensor_m: event.sensor_m,
        lines_per_observation: event.lines_per_observation,
        robot_height_m: m(classifier.robot_height),
        step_threshold_m: m(classifier.step_threshold),
        drop_threshold_m: off(classifier.drop_threshold),
        ceiling_m: off(classifier.ceiling),
        rule: rule_setup(&classifier.rule),
        laser: LaserSetup::SICK,
    }
}

/// The link's rule block of a navigability rule (exact: every Q16.16 value below 256 is exact
/// in `f32`, so [`frontend_config`] gives back the same parameters).
#[must_use]
pub fn rule_setup(rule: &NavigabilityRule) -> RuleSetup {
    match rule {
        NavigabilityRule::Spread => RuleSetup::SPREAD,
        NavigabilityRule::Plane(p) => RuleSetup {
            rule: 1,
            max_grade: p.max_grade.to_num::<f32>(),
            residual_m: p.residual.to_num::<f32>(),
            range_sigma_m: p.range_sigma.to_num::<f32>(),
            angle_sigma_rad: p.angle_sigma.to_num::<f32>(),
            noise_factor: p.noise_factor.to_num::<f32>(),
        },
    }
}

/// The step threshold and navigability rule of a SetRule command, validated in wire order:
/// the step as Setup's (finite, 0 ≤ v < 1 000 m; param 55), then the rule block
/// ([`navigability_rule`]).
///
/// # Errors
/// The first bad field.
pub fn set_rule_of(set: &SetRule) -> Result<(Meters, NavigabilityRule), SetupError> {
    let v = set.step_threshold_m;
    let field = SetupField::StepThreshold;
    if !v.is_finite() {
        return Err(SetupError::NotFinite { field });
    }
    if !(0.0..SETUP_LIMIT_M).contains(&v) {
        return Err(SetupError::OutOfRange {
            field,
            value: v,
            min: 0.0,
            max: SETUP_LIMIT_M,
        });
    }
    Ok((
        Meters::saturating_from_num(v),
        navigability_rule(&set.rule)?,
    ))
}

/// The SetRule command that sets a classifier's step threshold and navigability rule (exact,
/// as [`setup_message`]).
#[must_use]
pub fn set_rule_message(classifier: &ClassifierConfig) -> SetRule {
    SetRule {
        step_threshold_m: classifier.step_threshold.to_num::<f32>(),
        rule: rule_setup(&classifier.rule),
    }
}

/// The largest navigability rule number this build takes: 1 (the plane rule) with the
/// `plane-rule` feature, 0 (the paper's spread rule only) without it.
pub const RULE_MAX: u8 = if cfg!(feature = "plane-rule") { 1 } else { 0 };

/// The navigability rule of a Setup's rule block, validated in wire order: the rule exists (0
/// spread, 1 plane) and this build has it; under the plane rule every parameter is finite with
/// 0 ≤ v < 1 000 (the parameters are ignored under the spread rule).
///
/// # Errors
/// The first bad field. A rule beyond [`RULE_MAX`] is out of range `[0, RULE_MAX]`
/// ([`SetupField::Rule`]): a build without the `plane-rule` feature refuses rule 1 with
/// value 1 in `[0, 0]`, which [`ReplyText`] reads as "not built in".
pub fn navigability_rule(block: &RuleSetup) -> Result<NavigabilityRule, SetupError> {
    match block.rule {
        0 => Ok(NavigabilityRule::Spread),
        1 if cfg!(feature = "plane-rule") => {
            let value = |field, v: f32| -> Result<f32, SetupError> {
                if !v.is_finite() {
                    return Err(SetupError::NotFinite { field });
                }
                if !(0.0..SETUP_LIMIT_M).contains(&v) {
                    return Err(SetupError::OutOfRange {
                        field,
                        value: v,
                        min: 0.0,
                        max: SETUP_LIMIT_M,
                    });
                }
                Ok(v)
            };
            let max_grade = value(SetupField::MaxGrade, block.max_grade)?;
            let residual = value(SetupField::Residual, block.residual_m)?;
            let range_sigma = value(SetupField::RangeSigma, block.range_sigma_m)?;
            let angle_sigma = value(SetupField::AngleSigma, block.angle_sigma_rad)?;
            let noise_factor = value(SetupField::NoiseFactor, block.noise_factor)?;
            Ok(NavigabilityRule::Plane(PlaneRule {
                max_grade: Ratio::saturating_from_num(max_grade),
                residual: Meters::saturating_from_num(residual),
                range_sigma: Meters::saturating_from_num(range_sigma),
                angle_sigma: Ratio::saturating_from_num(angle_sigma),
                noise_factor: Ratio::saturating_from_num(noise_factor),
            }))
        }
        other => Err(SetupError::OutOfRange {
            field: SetupField::Rule,
            value: f32::from(other),
            min: 0.0,
            max: f32::from(RULE_MAX),
        }),
    }
}

/// The link's Setup of a recording's setup event, its sensor event (version 2; use
/// [`SensorEvent::SICK`] for a version-1 recording) and the classifier's thresholds: the
/// laser block names the sensor at its default baud rate on an external actuator (the
/// recording's angle events are the angle), and byte 1 is the sensor's mode for a lidar.
#[must_use]
pub fn setup_message_with_sensor(
    event: &SetupEvent,
    sensor: &SensorEvent,
    classifier: &ClassifierConfig,
) -> Setup {
    let mut setup = setup_message(event, classifier);
    setup.laser.sensor = sensor.sensor;
    if sensor.sensor != SensorKind::Sick.code() {
        setup.measuring_mode = sensor.mode;
    }
    setup
}

/// The pipeline's configuration of a recording's setup event and the classifier's
/// thresholds, by the link's rule ([`setup_message`], then [`frontend_config`]).
///
/// # Errors
/// The first bad field.
pub fn frontend_config_of_event(
    event: &SetupEvent,
    classifier: &ClassifierConfig,
) -> Result<FrontendConfig, SetupError> {
    frontend_config(&setup_message(event, classifier))
}

/// Validates a setup and turns it into the pipeline's configuration. The sensor is checked
/// first (the mode's and the variant's meaning depend on it), then the fields in wire order:
/// the mount exists (0 or 1); for a SICK the measuring mode is one it knows and the field of
/// view and resolution make a variant, for a spinning lidar the mode is one of its modes
/// (LD06 0; RPLIDAR and YDLIDAR 0 or 1) and the variant fields are ignored; positions are
/// finite with |v| < 1 000 m, the robot height is positive, the thresholds are ≥ 0 and finite
/// (all below 1 000 m); the navigability rule exists and, under the plane rule, its parameters
/// are finite with 0 ≤ v < 1 000 ([`navigability_rule`]); the baud rate is 0 (the sensor's default) or 9 600 ..= 3 000 000;
/// the actuator exists (0 external, 1 servo), and for a servo its sweep is finite with
/// −179° ≤ min < max ≤ 179°, a rate in (0, 1 000] °/s and a latency in [0, 1 000) ms (the
/// servo fields are ignored for an external actuator). The first bad field is reported.
/// Missing ground is off (the Setup does not carry it).
///
/// # Errors
/// The first bad field.
pub fn frontend_config(setup: &Setup) -> Result<FrontendConfig, SetupError> {
    let laser = &setup.laser;
    let kind = SensorKind::from_code(laser.sensor).ok_or(SetupError::OutOfRange {
        field: SetupField::Sensor,
        value: f32::from(laser.sensor),
        min: 0.0,
        max: 3.0,
    })?;
    let plane = match setup.mount {
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
    let (sensor, measuring_mode, variant) = match Sensor::max_mode(kind) {
        None => {
            let measuring_mode = MeasuringMode::from_code(setup.measuring_mode).map_err(|_| {
                SetupError::OutOfRange {
                    field: SetupField::MeasuringMode,
                    value: f32::from(setup.measuring_mode),
                    min: 0.0,
                    max: 15.0,
                }
            })?;
            let variant = Variant::from_sick(setup.field_deg, setup.resolution_cdeg).ok_or(
                SetupError::OutOfRange {
                    field: SetupField::Variant,
                    value: f32::from(setup.resolution_cdeg),
                    min: f32::from(setup.field_deg),
                    max: 0.0,
                },
            )?;
            (Sensor::Sick, measuring_mode, variant)
        }
        Some(max) => {
            let sensor = Sensor::from_kind_and_mode(kind, setup.measuring_mode).ok_or(
                SetupError::OutOfRange {
                    field: SetupField::MeasuringMode,
                    value: f32::from(setup.measuring_mode),
                    min: 0.0,
                    max: f32::from(max),
                },
            )?;
            // Unused by a lidar; the pipeline keeps a placeholder.
            (sensor, MeasuringMode::Mm8Cm80, Variant::Fov180Step1)
        }
    };
    let [sx, sy, sz] = setup.sensor_m;
    let position = |field, v: f32| -> Result<Meters, SetupError> {
        if !v.is_finite() {
            return Err(SetupError::NotFinite { field });
        }
        if v.abs() >= SETUP_LIMIT_M {
            return Err(SetupError::OutOfRange {
                field,
                value: v,
                min: -SETUP_LIMIT_M,
                max: SETUP_LIMIT_M,
            });
        }
        Ok(Meters::saturating_from_num(v))
    };
    let threshold = |field, v: f32| -> Result<Meters, SetupError> {
        if !v.is_finite() {
            return Err(SetupError::NotFinite { field });
        }
        if !(0.0..SETUP_LIMIT_M).contains(&v) {
            return Err(SetupError::OutOfRange {
                field,
                value: v,
                min: 0.0,
                max: SETUP_LIMIT_M,
            });
        }
        Ok(Meters::saturating_from_num(v))
    };
    let position = Point3 {
        x: position(SetupField::SensorX, sx)?,
        y: position(SetupField::SensorY, sy)?,
        z: position(SetupField::SensorZ, sz)?,
    };
    let robot_height = threshold(SetupField::RobotHeight, setup.robot_height_m)?;
    if robot_height <= Meters::ZERO {
        return Err(SetupError::NotPositive {
            field: SetupField::RobotHeight,
            value: setup.robot_height_m,
        });
    }
    let step_threshold = threshold(SetupField::StepThreshold, setup.step_threshold_m)?;
    let drop = threshold(SetupField::DropThreshold, setup.drop_threshold_m)?;
    let ceiling = threshold(SetupField::Ceiling, setup.ceiling_m)?;
    let optional = |v: Meters| (v > Meters::ZERO).then_some(v);
    let rule = navigability_rule(&setup.rule)?;
    let baud = match laser.baud {
        0 => kind.default_baud(),
        b if SETUP_BAUD.contains(&b) => b,
        b => {
            #[allow(clippy::cast_precision_loss)]
            let (value, min, max) = (
                b as f32,
                *SETUP_BAUD.start() as f32,
                *SETUP_BAUD.end() as f32,
            );
            return Err(SetupError::OutOfRange {
                field: SetupField::Baud,
                value,
                min,
                max,
            });
        }
    };
    let actuator = match laser.actuator {
        0 => Actuator::External,
        1 => Actuator::Servo(servo_profile(laser)?),
        other => {
            return Err(SetupError::OutOfRange {
                field: SetupField::Actuator,
                value: f32::from(other),
                min: 0.0,
                max: 1.0,
            })
        }
    };
    Ok(FrontendConfig {
        mount: Mount::new(plane, position),
        sensor,
        baud,
        actuator,
        variant,
        measuring_mode,
        lines_per_observation: setup.lines_per_observation,
        classifier: ClassifierConfig {
            robot_height,
            step_threshold,
            drop_threshold: optional(drop),
            ceiling: optional(ceiling),
            rule,
        },
        missing_ground_within: None,
    })
}

/// The servo sweep of a laser block, validated in wire order (min, max, rate, latency).
fn servo_profile(laser: &LaserSetup) -> Result<ServoProfile, SetupError> {
    let finite = |field, v: f32| {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(SetupError::NotFinite { field })
        }
    };
    let min = finite(SetupField::ServoMin, laser.servo_min_deg)?;
    if !(-SERVO_LIMIT_DEG..=SERVO_LIMIT_DEG).contains(&min) {
        return Err(SetupError::OutOfRange {
            field: SetupField::ServoMin,
            value: min,
            min: -SERVO_LIMIT_DEG,
            max: SERVO_LIMIT_DEG,
        });
    }
    let max = finite(SetupField::ServoMax, laser.servo_max_deg)?;
    if max <= min || max > SERVO_LIMIT_DEG {
        return Err(SetupError::OutOfRange {
            field: SetupField::ServoMax,
            value: max,
            min,
            max: SERVO_LIMIT_DEG,
        });
    }
    let rate = finite(SetupField::ServoRate, laser.servo_rate_deg_s)?;
    if rate <= 0.0 {
        return Err(SetupError::NotPositive {
            field: SetupField::ServoRate,
            value: rate,
        });
    }
    if rate > SERVO_MAX_RATE_DEG_S {
        return Err(SetupError::OutOfRange {
            field: SetupField::ServoRate,
            value: rate,
            min: 0.0,
            max: SERVO_MAX_RATE_DEG_S,
        });
    }
    let latency = finite(SetupField::ServoLatency, laser.servo_latency_ms)?;
    if !(0.0..SERVO_MAX_LATENCY_MS).contains(&latency) {
        return Err(SetupError::OutOfRange {
            field: SetupField::ServoLatency,
            value: latency,
            min: 0.0,
            max: SERVO_MAX_LATENCY_MS,
        });
    }
    let angle = |deg: f32| FineAngle::from_radians_f32(deg.to_radians()).unwrap_or(FineAngle::ZERO);
    // Configuration-time conversions of values checked above: the rate (≤ 1 000 °/s) in
    // millidegrees and the latency (< 1 s) in µs fit a u32; `as` rounds down after + 0.5.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (rate_mdeg_per_s, latency_us) = (
        ((rate * 1_000.0 + 0.5) as u32).max(1),
        (latency * 1_000.0 + 0.5) as u32,
    );
    Ok(ServoProfile {
        min: angle(min),
        max: angle(max),
        rate_mdeg_per_s,
        latency_us,
    })
}

// ---------------------------------------------------------------- refusals

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
fn count_f32(n: usize) -> f32 {
    let n = u32::try_from(n).unwrap_or(u32::MAX).min(1 << 24);
    #[allow(clippy::cast_precision_loss)]
    let f = n as f32;
    f
}

/// A Reply with a code, a `param` and up to three values.
const fn refusal(to: Header, code: ReplyCode, param: u8, value: f32, a: f32, b: f32) -> Reply {
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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::link::{encode, Message};
    use std::vec::Vec;

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect()
    }

    #[test]
    fn a_design_refusal_names_the_parameter() {
        let error = crate::DesignError::OutOfRange {
            param: crate::Param::Gamma,
            value: 200.0,
            min: 0.0,
            max: 100.0,
        };
        let configure = Header {
            version: 1,
            msg_type: 0x83,
            seq: 12,
        };
        let reply = design_refusal(configure, &error);
        assert_eq!(reply.code, ReplyCode::OutOfRange);
        assert_eq!(reply.param, 7);
        // The spec's worked example of a refusal (section 10; `docs/link_golden.py`).
        let mut out = [0_u8; 64];
        let n = encode(0x0106, &Message::Reply(reply), &mut out).unwrap();
        assert_eq!(
            &out[..n],
            &hex(
                "06 04 05 06 01 0c 04 83 03 07 01 03 48 43 01 01 01 01 01 07 c8 42 a1 78 8a 30 00"
            )[..]
        );
        assert_eq!(
            std::format!("{}", ReplyText(&reply)),
            "reply to #12 (0x83): --gamma: must lie within [0, 100] (got 200)"
        );
    }

    #[test]
    fn pose_validation_names_the_field() {
        let ok = PoseReport {
            x_m: 29_999.0,
            y_m: -29_999.0,
            z_m: 999.0,
            roll_rad: 10.0,
            pitch_rad: -10.0,
            yaw_rad: 100.0,
            stamp_us: 0,
            flags: 0,
        };
        assert!(pose_of(&ok).is_ok());
        let far = PoseReport {
            y_m: 30_000.0,
            ..ok
        };
        assert_eq!(
            pose_of(&far).map(|_| ()),
            Err(PoseError::OutOfRange {
                field: PoseField::Y,
                value: 30_000.0,
                limit: 30_000.0
            })
        );
        let nan = PoseReport {
            pitch_rad: f32::NAN,
            ..ok
        };
        assert_eq!(
            pose_of(&nan).map(|_| ()),
            Err(PoseError::NotFinite {
                field: PoseField::Pitch
            })
        );
        let high = PoseReport { z_m: -1000.0, ..ok };
        assert!(matches!(
            pose_of(&high).map(|_| ()),
            Err(PoseError::OutOfRange {
                field: PoseField::Z,
                ..
            })
        ));
        let header = Header {
            version: 1,
            msg_type: 0x81,
            seq: 3,
        };
        let reply = pose_refusal(header, &pose_of(&far).unwrap_err());
        assert_eq!(
            (reply.code, reply.param, reply.b),
            (ReplyCode::OutOfRange, 33, 30_000.0)
        );
    }

    /// The link refuses exactly the poses the geometry refuses: angles of 32 768 rad or more in
    /// magnitude (the geometry cannot reduce them) get a Reply naming the field, like NaN.
    #[test]
    fn pose_validation_is_the_geometry_rule() {
        let header = Header {
            version: 1,
            msg_type: 0x81,
            seq: 4,
        };
        let base = [1.0_f32, -2.0, 0.5, 0.1, -0.2, 3.0];
        let edge = [
            29_999.99,
            30_000.0,
            -1e30,
            999.9,
            1000.0,
            32_767.0,
            32_768.0,
            -32_768.0,
            -32_767.99,
            4.0e4,
            f32::MAX,
            f32::MIN_POSITIVE,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for field in 0..6 {
            for &value in &edge {
                let mut v = base;
                v[field] = value;
                let pose = PoseReport {
                    x_m: v[0],
                    y_m: v[1],
                    z_m: v[2],
                    roll_rad: v[3],
                    pitch_rad: v[4],
                    yaw_rad: v[5],
                    stamp_us: 0,
                    flags: 0,
                };
                let geometry = crate::geometry::Pose::from_f32(v[0], v[1], v[2], v[3], v[4], v[5]);
                let link = pose_of(&pose);
                match (&link, &geometry) {
                    (Ok(a), Ok(b)) => assert_eq!(a, b, "{field} {value}"),
                    (Err(e), _) => {
                        assert_eq!(
                            pose_field_code(e.field()),
                            32 + field as u8,
                            "{field} {value}"
                        );
                        let reply = pose_refusal(header, e);
                        assert!(!reply.is_ok());
                        assert_eq!(reply.param, 32 + field as u8);
                    }
                    (Ok(_), Err(e)) => panic!("the link took {field} = {value}, the geometry: {e}"),
                }
            }
        }
        let spin = PoseReport {
            yaw_rad: 40_000.0,
            ..PoseReport::default()
        };
        assert_eq!(
            pose_of(&spin).map(|_| ()),
            Err(PoseError::OutOfRange {
                field: PoseField::Yaw,
                value: 40_000.0,
                limit: 32_768.0
            })
        );
    }

    /// The worked Setup of `docs/protocol.md` (section 10), validated field by field.
    #[test]
    fn setup_validation_names_the_field() {
        let setup = Setup {
            mount: 1,
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: [0.25, -0.5, 0.75],
            lines_per_observation: 0,
            robot_height_m: 1.0,
            step_threshold_m: 0.05,
            drop_threshold_m: 0.0,
            ceiling_m: 2.0,
            rule: rule_setup(&NavigabilityRule::DEFAULT),
            laser: LaserSetup::SICK,
        };
        // Validation: the variant, the mode, finiteness, thresholds.
        let config = frontend_config(&setup).unwrap();
        assert_eq!(config.variant.beam_count(), 361);
        assert_eq!(config.classifier.drop_threshold, None);
        assert_eq!(
            config.classifier.ceiling,
            Some(crate::units::Meters::from_num(2))
        );
        let refused = |s: Setup| frontend_config(&s).unwrap_err().field();
        assert_eq!(refused(Setup { mount: 2, ..setup }), SetupField::Mount);
        assert_eq!(
            refused(Setup {
                measuring_mode: 7,
                ..setup
            }),
            SetupField::MeasuringMode
        );
        assert_eq!(
            refused(Setup {
                field_deg: 180,
                resolution_cdeg: 25,
                ..setup
            }),
            SetupField::Variant
        );
        assert_eq!(
            refused(Setup {
                sensor_m: [0.0, f32::NAN, 0.0],
                ..setup
            }),
            SetupField::SensorY
        );
        assert_eq!(
            refused(Setup {
                step_threshold_m: -0.01,
                ..setup
            }),
            SetupField::StepThreshold
        );
        assert_eq!(
            refused(Setup {
                robot_height_m: 0.0,
                ..setup
            }),
            SetupField::RobotHeight
        );
        let error = frontend_config(&Setup { mount: 2, ..setup }).unwrap_err();
        assert_eq!(
            std::format!("{error}"),
            "setup mount: must lie within [0, 1] (got 2)"
        );
        // A version-2 peer's meaning: a SICK at 500 kBd on an external actuator.
        assert_eq!(config.sensor, Sensor::Sick);
        assert_eq!(config.baud, 500_000);
        assert_eq!(config.actuator, Actuator::External);
    }

    /// The rule block: both rules and any plane parameters travel bit for bit through the
    /// Setup; a bad rule or plane parameter is refused by name; the paper's rule ignores the
    /// plane parameters.
    #[test]
    fn the_plane_rule_is_taken_only_where_built_in() {
        let plane = rule_setup(&NavigabilityRule::Plane(PlaneRule::DEFAULT));
        let to = Header {
            version: crate::wire::link::VERSION,
            msg_type: 0x8B,
            seq: 7,
        };
        let set = SetRule {
            step_threshold_m: 0.05,
            rule: plane,
        };
        if cfg!(feature = "plane-rule") {
            assert_eq!(RULE_MAX, 1);
            assert_eq!(
                navigability_rule(&plane),
                Ok(NavigabilityRule::Plane(PlaneRule::DEFAULT))
            );
            assert!(set_rule_of(&set).is_ok());
        } else {
            assert_eq!(RULE_MAX, 0);
            let error = SetupError::OutOfRange {
                field: SetupField::Rule,
                value: 1.0,
                min: 0.0,
                max: 0.0,
            };
            assert_eq!(navigability_rule(&plane), Err(error));
            assert_eq!(set_rule_of(&set), Err(error));
            assert_eq!(
                navigability_rule(&RuleSetup::SPREAD),
                Ok(NavigabilityRule::Spread)
            );
        }
        // The refusal a build without the plane rule sends, read by any build.
        let refusal = setup_refusal(
            to,
            &SetupError::OutOfRange {
                field: SetupField::Rule,
                value: 1.0,
                min: 0.0,
                max: 0.0,
            },
        );
        assert_eq!(
            (
                refusal.code,
                refusal.param,
                refusal.value,
                refusal.a,
                refusal.b
            ),
            (ReplyCode::OutOfRange, 65, 1.0, 0.0, 0.0)
        );
        assert_eq!(
            std::format!("{}", ReplyText(&refusal)),
            "reply to #7 (0x8b): setup navigability rule: the plane rule (1) is not built into \
             the device (built without the plane-rule feature); it takes the paper's spread rule \
             (0) only"
        );
    }

    #[test]
    #[cfg(feature = "plane-rule")]
    fn the_rule_block_travels_and_is_validated() {
        let event = SetupEvent {
            mount: MountKind::TiltedHorizontal,
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: [0.0, 0.0, 0.5],
            lines_per_observation: 0,
        };
        let custom = NavigabilityRule::Plane(PlaneRule {
            max_grade: Ratio::from_num(1),
            residual: Meters::from_num(0.03),
            range_sigma: Meters::from_num(0.05),
            angle_sigma: Ratio::from_num(0.002),
            noise_factor: Ratio::from_num(3),
        });
        for rule in [NavigabilityRule::Spread, NavigabilityRule::DEFAULT, custom] {
            let classifier = ClassifierConfig {
                rule,
                ..ClassifierConfig::DEFAULT
            };
            let config = frontend_config_of_event(&event, &classifier).unwrap();
            assert_eq!(config.classifier, classifier);
        }
        let plane = setup_message(&event, &ClassifierConfig::DEFAULT);
        let refused = |rule: RuleSetup| frontend_config(&Setup { rule, ..plane }).unwrap_err();
        assert_eq!(
            refused(RuleSetup {
                rule: 2,
                ..plane.rule
            }),
            SetupError::OutOfRange {
                field: SetupField::Rule,
                value: 2.0,
                min: 0.0,
                max: 1.0
            }
        );
        assert_eq!(
            refused(RuleSetup {
                residual_m: -0.01,
                ..plane.rule
            })
            .field(),
            SetupField::Residual
        );
        assert_eq!(
            refused(RuleSetup {
                max_grade: f32::INFINITY,
                ..plane.rule
            }),
            SetupError::NotFinite {
                field: SetupField::MaxGrade
            }
        );
        // Wire order: the first bad parameter is named.
        assert_eq!(
            refused(RuleSetup {
                range_sigma_m: f32::NAN,
                noise_factor: 1e6,
                ..plane.rule
            })
            .field(),
            SetupField::RangeSigma
        );
        assert_eq!(
            refused(RuleSetup {
                noise_factor: 1_000.0,
                ..plane.rule
            })
            .field(),
            SetupField::NoiseFactor
        );
        let paper = RuleSetup {
            rule: 0,
            angle_sigma_rad: f32::NAN,
            ..plane.rule
        };
        assert_eq!(
            frontend_config(&Setup {
                rule: paper,
                ..plane
            })
            .unwrap()
            .classifier
            .rule,
            NavigabilityRule::Spread
        );
        for code in 65..=70 {
            let field = SetupField::from_param(code).unwrap();
            assert_eq!(field as u8, code);
        }
        assert_eq!(SetupField::from_param(71), None);
    }

    /// The laser block: each field refused with its own code and sentence; a lidar's mode is
    /// its own, its variant fields ignored; the servo's sweep converted exactly enough.
    #[test]
    fn the_laser_block_is_validated_field_by_field() {
        let servo = LaserSetup {
            sensor: 1,
            actuator: 1,
            baud: 0,
            servo_min_deg: -10.0,
            servo_max_deg: 30.0,
            servo_rate_deg_s: 60.0,
            servo_latency_ms: 25.0,
        };
        let setup = Setup {
            mount: 1,
            measuring_mode: 0,
            field_deg: 0,
            resolution_cdeg: 0,
            sensor_m: [0.1, 0.0, 0.4],
            lines_per_observation: 2,
            robot_height_m: 0.5,
            step_threshold_m: 0.08,
            drop_threshold_m: 0.0,
            ceiling_m: 0.0,
            rule: rule_setup(&NavigabilityRule::DEFAULT),
            laser: servo,
        };
        let config = frontend_config(&setup).unwrap();
        assert_eq!(config.sensor, Sensor::Ld06);
        assert_eq!(config.baud, 230_400);
        let Actuator::Servo(profile) = config.actuator else {
            panic!("{:?}", config.actuator)
        };
        let deg = |a: FineAngle| f64::from(a.to_bits() as i32) * 360.0 / 4_294_967_296.0;
        assert!((deg(profile.min) + 10.0).abs() < 1e-5);
        assert!((deg(profile.max) - 30.0).abs() < 1e-5);
        assert_eq!(
            (profile.rate_mdeg_per_s, profile.latency_us),
            (60_000, 25_000)
        );
        let with = |laser: LaserSetup| Setup { laser, ..setup };
        let refused = |s: Setup| {
            let e = frontend_config(&s).unwrap_err();
            let reply = setup_refusal(
                Header {
                    version: 3,
                    msg_type: 0x87,
                    seq: 1,
                },
                &e,
            );
            assert_eq!(reply.param, e.field() as u8);
            assert_eq!(SetupField::from_param(reply.param), Some(e.field()));
            (e.field(), std::format!("{e}"))
        };
        assert_eq!(
            refused(with(LaserSetup { sensor: 4, ..servo })),
            (
                SetupField::Sensor,
                "setup sensor: 4 is not a sensor (0 SICK, 1 LD06, 2 RPLIDAR, 3 YDLIDAR)".into()
            )
        );
        // The mode is the sensor's: LD06 has only 0, RPLIDAR and YDLIDAR 0 and 1.
        assert_eq!(
            refused(Setup {
                measuring_mode: 1,
                ..setup
            }),
            (
                SetupField::MeasuringMode,
                "setup sensor mode: must lie within [0, 0] (got 1)".into()
            )
        );
        for (sensor, mode, want) in [
            (
                2,
                1,
                Sensor::Rplidar(crate::wire::rplidar::RplidarScanMode::Express),
            ),
            (
                3,
                1,
                Sensor::Ydlidar(crate::wire::ydlidar::YdlidarAngleCorrection::Off),
            ),
        ] {
            let s = Setup {
                measuring_mode: mode,
                laser: LaserSetup { sensor, ..servo },
                ..setup
            };
            assert_eq!(frontend_config(&s).unwrap().sensor, want);
            let s = Setup {
                measuring_mode: 2,
                ..s
            };
            assert_eq!(refused(s).0, SetupField::MeasuringMode);
        }
        assert_eq!(
            refused(with(LaserSetup { baud: 300, ..servo })),
            (
                SetupField::Baud,
                "setup baud rate: must lie within [9600, 3000000] (got 300)".into()
            )
        );
        let ok = frontend_config(&with(LaserSetup {
            baud: 460_800,
            ..servo
        }))
        .unwrap();
        assert_eq!(ok.baud, 460_800);
        assert_eq!(
            refused(with(LaserSetup {
                actuator: 2,
                ..servo
            }))
            .0,
            SetupField::Actuator
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_min_deg: f32::NAN,
                ..servo
            })),
            (
                SetupField::ServoMin,
                "setup servo min: must be a finite number".into()
            )
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_min_deg: -200.0,
                ..servo
            }))
            .0,
            SetupField::ServoMin
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_max_deg: -10.0,
                ..servo
            })),
            (
                SetupField::ServoMax,
                "setup servo max: must be above the servo min (-10) and at most 179 degrees \
                 (got -10)"
                    .into()
            )
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_rate_deg_s: 0.0,
                ..servo
            })),
            (
                SetupField::ServoRate,
                "setup servo rate: must be greater than 0 (got 0)".into()
            )
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_rate_deg_s: 1_000.5,
                ..servo
            }))
            .0,
            SetupField::ServoRate
        );
        assert_eq!(
            refused(with(LaserSetup {
                servo_latency_ms: 1_000.0,
                ..servo
            }))
            .0,
            SetupField::ServoLatency
        );
        // An external actuator ignores the servo fields; a SICK checks its own.
        let external = with(LaserSetup {
            actuator: 0,
            servo_min_deg: f32::NAN,
            ..servo
        });
        assert_eq!(
            frontend_config(&external).unwrap().actuator,
            Actuator::External
        );
        assert_eq!(
            refused(with(LaserSetup { sensor: 0, ..servo })).0,
            SetupField::Variant
        );
    }

    /// A recording's setup event takes the same path.
    #[test]
    fn a_recording_setup_goes_through_the_same_rule() {
        let event = SetupEvent {
            mount: MountKind::TiltedHorizontal,
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 25,
            sensor_m: [0.0, 0.0, 0.5],
            lines_per_observation: 0,
        };
        let error = frontend_config_of_event(&event, &ClassifierConfig::default()).unwrap_err();
        assert_eq!(error.field(), SetupField::Variant);
        let ok = SetupEvent {
            resolution_cdeg: 50,
            ..event
        };
        let config = frontend_config_of_event(&ok, &ClassifierConfig::default()).unwrap();
        assert_eq!(config.variant, Variant::Fov180StepHalf);
        assert_eq!(config.classifier, ClassifierConfig::default());
    }

    /// A Configure carries a design and a configuration exactly: the conversion there and back is
    /// the identity on valid inputs.
    #[test]
    fn configure_round_trips_a_design() {
        let schedule = Schedule {
            gate: GateShape::Hard,
            uniform_resolution: true,
            ..Schedule::default()
        };
        let design = Design::<32>::new(SensorModel::default(), schedule, 256).unwrap();
        let config = Config {
            clamp: Clamp::Off,
            fused_margin: 0.25,
            ..Config::default()
        };
        let c = configure_of_design(&design, &config);
        assert_eq!(design_of::<32>(&c).unwrap(), design);
        assert_eq!(config_of(&c).unwrap(), config);
    }

    /// Every Reply param names one thing: the design's codes (the decay's time constants
    /// included), the pose's, the layer's and Setup's never share a number.
    #[test]
    fn reply_param_codes_are_disjoint() {
        for code in 0..=u8::MAX {
            let design = param_of_code(code).is_some();
            let setup = SetupField::from_param(code).is_some();
            let other = (32..=37).contains(&code) || code == PARAM_LAYER;
            assert!(
                u8::from(design) + u8::from(setup) + u8::from(other) <= 1,
                "param {code}"
            );
            if let Some(p) = param_of_code(code) {
                assert_eq!(param_code(p), code);
            }
        }
        assert_eq!(
            param_code(Param::DecayTau { layer: 31 }),
            127,
            "layer 31's time constant"
        );
        assert_eq!(SetupField::from_param(64), Some(SetupField::ServoLatency));
    }
}
