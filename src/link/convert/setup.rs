//! The Setup's fields and their limits ([`SetupField`], [`SetupError`]) and the Setup of a
//! recording's events ([`setup_message`], [`setup_message_with_sensor`], [`setup_with_rig`]).
//! The navigability rule's block is in `rule.rs`, a Setup's validation into a
//! [`FrontendConfig`] in `frontend.rs`.

use core::fmt;

use super::{frontend_config, rule_setup, setup_refusal, ReplyText};
use crate::classify::ClassifierConfig;
use crate::laser::SensorKind;
use crate::pipeline::FrontendConfig;
use crate::units::Meters;
use crate::wire::link::{Header, LaserSetup, Setup};
use crate::wire::recording::{MountKind, RigEvent, SensorEvent, SetupEvent};

byte_enum! {
/// A field of a [`Setup`], as a Reply names it (`param` 48 ..= 57, and 58 ..= 64 for the
/// laser block of protocol version 3).
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
    /// The plane rule's pair depth (version 6).
    PairDepth = 81,
}
/// The field a Reply `param` names, if it names one.
pub fn from_param;
}

impl SetupField {
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
            Self::PairDepth => "setup pair depth",
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
