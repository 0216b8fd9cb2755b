//! The worked Setups of `docs/protocol.md` ("0x87 Setup"), for the tests of the wire format
//! (their golden frames) and of their conversion to a frontend configuration.
use super::{FilterSetup, LaserSetup, MountSetup, RuleSetup, Setup};

/// The first worked example (section 10): a SICK tilted horizontal, mode 0, 180° at 0.5°,
/// sensor (0.25, −0.5, 0.75) m, per sweep, robot height 1 m, step 0.05 m, drop off, ceiling
/// 2 m, under `rule`.
pub(crate) fn sick_setup(rule: RuleSetup) -> Setup {
    Setup {
        mount_block: MountSetup::PRESET,
        filter: FilterSetup::NONE,
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
        rule,
        laser: LaserSetup::SICK,
    }
}

/// The laser block of the second worked example: an LD06 at its default rate on a nodding
/// servo from −10° to 30° at 60 °/s with 25 ms of latency.
pub(crate) const LD06_ON_A_SERVO: LaserSetup = LaserSetup {
    sensor: 1,
    actuator: 1,
    baud: 0,
    servo_min_deg: -10.0,
    servo_max_deg: 30.0,
    servo_rate_deg_s: 60.0,
    servo_latency_ms: 25.0,
};

/// The second worked example: [`LD06_ON_A_SERVO`] tilted horizontal, 0.4 m up, two
/// revolutions per observation, robot height 0.5 m, step 0.08 m, drop and ceiling off, the
/// SICK fields zero (ignored), under `rule`.
pub(crate) fn lidar_on_a_servo_setup(rule: RuleSetup) -> Setup {
    Setup {
        field_deg: 0,
        resolution_cdeg: 0,
        sensor_m: [0.1, 0.0, 0.4],
        lines_per_observation: 2,
        robot_height_m: 0.5,
        step_threshold_m: 0.08,
        ceiling_m: 0.0,
        laser: LD06_ON_A_SERVO,
        ..sick_setup(rule)
    }
}

/// The mount block of the third worked example: an LD19 upside down with its 0° to the left
/// (roll 180°, yaw 90°) on a tilt servo (axis 1) that reports the other way (sense −1) with
/// its zero at 5°.
pub(crate) const GENERAL_MOUNT: MountSetup = MountSetup {
    axis: 1,
    sense: -1,
    zero_deg: 5.0,
    rpy_deg: [180.0, 0.0, 90.0],
};

/// The filter block of the third worked example: ranges 5 cm ..= 12 m, quality at least 10,
/// the first `sector_count` of `sectors` masked (centidegrees).
pub(crate) fn filter(sector_count: u8, sectors: [(u16, u16); super::SETUP_SECTORS]) -> FilterSetup {
    FilterSetup {
        min_range_cm: 5,
        max_range_cm: 1_200,
        min_quality: 10,
        sector_count,
        sectors,
    }
}
