//! Setup → [`FrontendConfig`]: a Setup validated field by field and turned into the
//! pipeline's configuration ([`frontend_config`]), with its mount block, filter block and
//! servo sweep, and the angle conversions they use ([`fine_of_degrees`],
//! [`fine_of_centidegrees`]).

use super::{
    navigability_rule, SetupError, SetupField, SERVO_LIMIT_DEG, SERVO_MAX_LATENCY_MS,
    SERVO_MAX_RATE_DEG_S, SETUP_BAUD, SETUP_LIMIT_M,
};
use crate::actuator::{Actuator, ServoProfile};
use crate::angle::FineAngle;
use crate::classify::ClassifierConfig;
use crate::geometry::{ActuatorAxis, Mount, ScanPlane};
use crate::laser::{Sensor, SensorKind};
use crate::pipeline::FrontendConfig;
use crate::pipeline::{ReturnFilter, Sector, MAX_SECTORS};
use crate::units::{Meters, Point3};
use crate::wire::link::{LaserSetup, Setup};
use crate::wire::sick::{MeasuringMode, Variant};

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
        super::rule::non_negative_length(field, v).map(Meters::saturating_from_num)
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
