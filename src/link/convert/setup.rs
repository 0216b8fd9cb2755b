//! Setup ⇄ [`FrontendConfig`]: the fields a Setup carries and their limits ([`SetupField`],
//! [`SetupError`]), the setup of a recording's event ([`setup_message`]), the navigability
//! rule's block ([`navigability_rule`], [`set_rule_of`]) and the servo profile.

use core::fmt;

use super::{setup_refusal, ReplyText};
use crate::actuator::{Actuator, ServoProfile};
use crate::angle::FineAngle;
use crate::classify::{ClassifierConfig, NavigabilityRule, PlaneRule, Ratio};
use crate::geometry::{ActuatorAxis, Mount, ScanPlane};
use crate::laser::{Sensor, SensorKind};
use crate::pipeline::FrontendConfig;
use crate::pipeline::{ReturnFilter, Sector, MAX_SECTORS};
use crate::units::{Meters, Point3};
use crate::wire::link::{Header, LaserSetup, RuleSetup, SetRule, Setup};
use crate::wire::recording::{MountKind, RigEvent, SensorEvent, SetupEvent};
use crate::wire::sick::{MeasuringMode, Variant};

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
    /// The general mount's actuator axis: 0 pan, 1 tilt, 2 none (version 5).
    MountAxis = 71,
    /// The actuator's sense: +1 or −1.
    MountSense = 72,
    /// The actuator's zero, degrees.
    MountZero = 73,
    /// The general mount's roll, degrees.
    MountRoll = 74,
    /// The general mount's pitch, degrees.
    MountPitch = 75,
    /// The general mount's yaw, degrees.
    MountYaw = 76,
    /// The minimum range, centimetres.
    MinRange = 77,
    /// The maximum range, centimetres.
    MaxRange = 78,
    /// The number of masked sectors.
    SectorCount = 79,
    /// A masked sector's start or end (the value the bad angle, `min` the sector's index).
    Sector = 80,
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
            71 => Self::MountAxis,
            72 => Self::MountSense,
            73 => Self::MountZero,
            74 => Self::MountRoll,
            75 => Self::MountPitch,
            76 => Self::MountYaw,
            77 => Self::MinRange,
            78 => Self::MaxRange,
            79 => Self::SectorCount,
            80 => Self::Sector,
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
            Self::MountAxis => "setup mount axis",
            Self::MountSense => "setup actuator sense",
            Self::MountZero => "setup actuator zero",
            Self::MountRoll => "setup mount roll",
            Self::MountPitch => "setup mount pitch",
            Self::MountYaw => "setup mount yaw",
            Self::MinRange => "setup minimum range",
            Self::MaxRange => "setup maximum range",
            Self::SectorCount => "setup masked sector count",
            Self::Sector => "setup masked sector",
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
        mount_block: crate::wire::link::MountSetup::PRESET,
        filter: crate::wire::link::FilterSetup::NONE,
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

/// `setup` with a recording's rig event (version 3) written over it: the mount byte, the mount
/// block and the filter block.
#[must_use]
pub fn setup_with_rig(setup: Setup, rig: &RigEvent) -> Setup {
    Setup {
        mount: rig.mount,
        mount_block: rig.mount_block,
        filter: rig.filter,
        ..setup
    }
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
        0 => Some(ScanPlane::PannedVertical),
        1 => Some(ScanPlane::TiltedHorizontal),
        2 => None,
        other => {
            return Err(SetupError::OutOfRange {
                field: SetupField::Mount,
                value: f32::from(other),
                min: 0.0,
                max: 2.0,
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
    let mount = mount_of(plane, position, &setup.mount_block)?;
    let filter = filter_of(&setup.filter)?;
    Ok(FrontendConfig {
        filter,
        mount,
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

/// The largest |angle| of the mount block, degrees (inclusive).
pub const MOUNT_LIMIT_DEG: f32 = 360.0;

/// An angle in degrees (finite, |v| ≤ 360, as checked) as a [`FineAngle`]:
/// `round(v/360 · 2³²)` modulo a turn, in integers from the value rounded to 2⁻¹⁵ degree
/// (multiples of 90° are exact; the rounding, 1.5·10⁻⁵ degree at most, is below an `f32`'s
/// own step near 360°).
#[must_use]
pub fn fine_of_degrees(deg: f32) -> FineAngle {
    // |deg| ≤ 360: |deg·2¹⁵| < 2²⁴, exact in the f32 product up to its own rounding.
    #[allow(clippy::cast_possible_truncation)]
    let q15 = libm_round(deg * 32_768.0) as i64;
    // bits = q15 · 2³² / (360 · 2¹⁵) = q15 · 2¹⁷ / 360, rounded to nearest.
    let num = q15 * (1 << 17);
    let bits = if num >= 0 {
        (num + 180) / 360
    } else {
        (num - 180) / 360
    };
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    FineAngle::from_bits(bits as u32)
}

/// `round(v)` of a finite `f32` below 2²⁴ in magnitude, half away from zero, without `std`.
fn libm_round(v: f32) -> f32 {
    // Below 2²⁴ the truncation to i32 is exact; the half is added with the value's sign.
    #[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss)]
    let t = (v + if v < 0.0 { -0.5 } else { 0.5 }) as i32 as f32;
    t
}

/// The mount of a preset (`plane`) or of the general mount (`None`) with the mount block,
/// validated in wire order: axis (general only), sense, zero, roll, pitch, yaw (general only).
fn mount_of(
    plane: Option<ScanPlane>,
    position: Point3,
    block: &crate::wire::link::MountSetup,
) -> Result<Mount, SetupError> {
    let angle = |field, v: f32| {
        if !v.is_finite() {
            return Err(SetupError::NotFinite { field });
        }
        if v.abs() > MOUNT_LIMIT_DEG {
            return Err(SetupError::OutOfRange {
                field,
                value: v,
                min: -MOUNT_LIMIT_DEG,
                max: MOUNT_LIMIT_DEG,
            });
        }
        Ok(fine_of_degrees(v))
    };
    let axis = match plane {
        Some(p) => p.axis(),
        None => ActuatorAxis::from_code(block.axis).ok_or(SetupError::OutOfRange {
            field: SetupField::MountAxis,
            value: f32::from(block.axis),
            min: 0.0,
            max: 2.0,
        })?,
    };
    let reversed = match block.sense {
        1 => false,
        -1 => true,
        other => {
            return Err(SetupError::OutOfRange {
                field: SetupField::MountSense,
                value: f32::from(other),
                min: -1.0,
                max: 1.0,
            })
        }
    };
    let zero = angle(SetupField::MountZero, block.zero_deg)?;
    let rpy = match plane {
        Some(p) => p.rpy(),
        None => {
            let [r, p, y] = block.rpy_deg;
            [
                angle(SetupField::MountRoll, r)?,
                angle(SetupField::MountPitch, p)?,
                angle(SetupField::MountYaw, y)?,
            ]
        }
    };
    Ok(Mount::general(position, rpy, axis, zero, reversed))
}

/// A centidegree angle 0 ..= 35 999 as a [`FineAngle`]: `round(c · 2³² / 36 000)`, exact at
/// multiples of 90°.
#[must_use]
pub fn fine_of_centidegrees(c: u16) -> FineAngle {
    // c < 2¹⁶: c·2³² < 2⁴⁸, the quotient below 2³².
    #[allow(clippy::cast_possible_truncation)]
    FineAngle::from_bits((((u64::from(c) << 32) + 18_000) / 36_000) as u32)
}

/// The filter block as the pipeline's [`ReturnFilter`], validated in wire order: the
/// maximum range above the minimum (when both are on), the sector count at most 8, each
/// used sector's start and end below 36 000 centidegrees.
fn filter_of(block: &crate::wire::link::FilterSetup) -> Result<ReturnFilter, SetupError> {
    let (lo, hi) = (block.min_range_cm, block.max_range_cm);
    if hi != 0 && hi <= lo {
        return Err(SetupError::OutOfRange {
            field: SetupField::MaxRange,
            value: f32::from(hi),
            min: f32::from(lo),
            max: f32::from(u16::MAX),
        });
    }
    let count = usize::from(block.sector_count);
    let too_many = SetupError::OutOfRange {
        field: SetupField::SectorCount,
        value: f32::from(block.sector_count),
        min: 0.0,
        max: 8.0,
    };
    if count > MAX_SECTORS {
        return Err(too_many);
    }
    let mut sectors = [Sector::default(); MAX_SECTORS];
    for (k, (&(a, b), out)) in block
        .sectors
        .iter()
        .zip(&mut sectors)
        .take(count)
        .enumerate()
    {
        for v in [a, b] {
            if v >= 36_000 {
                return Err(SetupError::OutOfRange {
                    field: SetupField::Sector,
                    value: f32::from(v),
                    min: f32::from(u8::try_from(k).unwrap_or(u8::MAX)),
                    max: 35_999.0,
                });
            }
        }
        *out = Sector::between(fine_of_centidegrees(a), fine_of_centidegrees(b));
    }
    let used = sectors.get(..count).unwrap_or(&[]);
    ReturnFilter::new(
        used,
        u32::from(lo) * 10,
        u32::from(hi) * 10,
        block.min_quality,
    )
    .ok_or(too_many)
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
