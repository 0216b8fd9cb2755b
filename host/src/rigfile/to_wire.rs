//! Where a [`Rig`] becomes what the device's link (its Setup) and a recording (its setup,
//! sensor and rig events) carry: the only place the rig meets the wire formats.
use super::{Axis, Rig, SensorName, SensorSpec, DEFAULT_LINES_PER_OBSERVATION};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::rule_setup;
use terrain_pyramid::wire::link::{FilterSetup, LaserSetup, MountSetup, Setup};
use terrain_pyramid::wire::recording::{MountKind, RigEvent, SensorEvent, SetupEvent};
use terrain_pyramid::Meters;

// THE PLACE WHERE A RIG BECOMES WHAT THE DEVICE AND A RECORDING CARRY. The link's Setup
// (protocol version 5) and a recording (version 3) carry the general mount (Setup's mount
// byte 2 and its mount block, the recording's rig event) and the filter block: the rig's
// mount, actuator and filters go through [`crate::rig::Rig::apply`], the one check of them
// that `pyramid run`'s flags use too.

/// The preset a rig's axis starts from: a pan unit the panned-vertical preset, a tilt unit
/// or none the tilted-horizontal one. The rig's own orientation, zero and sense are then
/// written over it ([`mount_rig`]).
const fn preset_of(axis: Axis) -> MountKind {
    match axis {
        Axis::Pan => MountKind::PannedVertical,
        Axis::Tilt | Axis::None => MountKind::TiltedHorizontal,
    }
}

/// The rig's mount, actuator and filters as the flags' [`crate::rig::Rig`] (the rig file's
/// key names in its errors are the flags' names).
#[must_use]
pub fn mount_rig(rig: &Rig) -> crate::rig::Rig {
    let f = &rig.filters;
    let axis = rig.actuator.axis;
    let rpy = rig.mount.rpy_or_preset(axis);
    // A preset's own orientation on its own axis goes as the preset (Setup's mount byte 0
    // or 1); anything else as the general mount.
    let preset = match axis {
        Axis::Pan => rpy == [90.0, 0.0, 0.0],
        Axis::Tilt => rpy == [0.0; 3],
        Axis::None => false,
    };
    crate::rig::Rig {
        xyz_m: Some(rig.mount.xyz_m),
        rpy_deg: (!preset).then_some(rpy),
        axis: (!preset).then_some(axis),
        zero_deg: (rig.actuator.zero_deg != 0.0).then_some(rig.actuator.zero_deg),
        reversed: rig.actuator.reversed,
        masks: f
            .masks_deg
            .iter()
            .map(|&[start_deg, end_deg]| crate::rig::Mask { start_deg, end_deg })
            .collect(),
        min_range_m: f.min_range_m,
        max_range_m: f.max_range_m,
        min_quality: f.min_quality,
    }
}

/// The rig's mount and filters written over `setup` (its preset mount byte already set),
/// checked as the device checks them.
fn with_mount(rig: &Rig, setup: &mut Setup) -> Result<(), String> {
    mount_rig(rig).apply(setup).map_err(|e| e.to_string())
}

/// The sensor a rig must name.
fn sensor_of(rig: &Rig) -> Result<SensorSpec, String> {
    rig.sensor.ok_or_else(|| {
        "the rig names no sensor (--sensor, or [sensor] kind in the rig file)".into()
    })
}

/// The rig as the device's Setup (link protocol version 4), with `classifier`'s thresholds.
///
/// # Errors
/// No sensor, or a value this version's Setup cannot carry (named).
pub fn device_setup(rig: &Rig, classifier: &ClassifierConfig) -> Result<Setup, String> {
    let sensor = sensor_of(rig)?;
    let mount = preset_of(rig.actuator.axis);
    let m = |v: Meters| v.to_num::<f32>();
    let off = |v: Option<Meters>| v.map_or(0.0, m);
    #[allow(clippy::cast_possible_truncation)]
    let f = |v: f64| v as f32;
    let servo = rig.actuator.servo;
    let mut setup = Setup {
        mount: match mount {
            MountKind::PannedVertical => 0,
            MountKind::TiltedHorizontal => 1,
        },
        measuring_mode: sensor.mode,
        field_deg: sensor.field_deg,
        resolution_cdeg: sensor.resolution_cdeg,
        sensor_m: rig.mount.xyz_m.map(f),
        lines_per_observation: rig
            .lines_per_observation
            .unwrap_or(DEFAULT_LINES_PER_OBSERVATION),
        robot_height_m: m(classifier.robot_height),
        step_threshold_m: m(classifier.step_threshold),
        drop_threshold_m: off(classifier.drop_threshold),
        ceiling_m: off(classifier.ceiling),
        rule: rule_setup(&classifier.rule),
        laser: LaserSetup {
            sensor: sensor.name.kind().code(),
            actuator: u8::from(servo.is_some()),
            baud: sensor.baud,
            servo_min_deg: servo.map_or(0.0, |s| f(s.min_deg)),
            servo_max_deg: servo.map_or(0.0, |s| f(s.max_deg)),
            servo_rate_deg_s: servo.map_or(0.0, |s| f(s.rate_deg_s)),
            servo_latency_ms: servo.map_or(0.0, |s| f(s.latency_ms)),
        },
        mount_block: MountSetup::PRESET,
        filter: FilterSetup::NONE,
    };
    with_mount(rig, &mut setup)?;
    Ok(setup)
}

/// The rig's mount and filters as a recording's rig event (version 3), or `None` when the
/// setup event's preset says it all (a preset orientation, zero 0, sense +1, no filter).
///
/// # Errors
/// No sensor, or a value the device would refuse, named.
pub fn rig_event(rig: &Rig) -> Result<Option<RigEvent>, String> {
    let setup = device_setup(rig, &ClassifierConfig::DEFAULT)?;
    let plain = setup.mount != 2
        && setup.mount_block == MountSetup::PRESET
        && setup.filter == FilterSetup::NONE;
    Ok((!plain).then_some(RigEvent {
        mount: setup.mount,
        mount_block: setup.mount_block,
        filter: setup.filter,
    }))
}

/// The rig as a recording's setup and sensor events (the preset its axis starts from; the
/// rest of the mount and the filters go in the rig event, [`rig_event`]).
///
/// # Errors
/// No sensor, or a value the device would refuse (named).
pub fn recording_setup(rig: &Rig) -> Result<(SetupEvent, SensorEvent), String> {
    let sensor = sensor_of(rig)?;
    let mount = preset_of(rig.actuator.axis);
    rig_event(rig)?;
    let sick = sensor.name == SensorName::Sick;
    #[allow(clippy::cast_possible_truncation)]
    let setup = SetupEvent {
        mount,
        measuring_mode: if sick { sensor.mode } else { 0 },
        field_deg: if sick { sensor.field_deg } else { 180 },
        resolution_cdeg: if sick { sensor.resolution_cdeg } else { 50 },
        sensor_m: rig.mount.xyz_m.map(|v| v as f32),
        lines_per_observation: rig
            .lines_per_observation
            .unwrap_or(DEFAULT_LINES_PER_OBSERVATION),
    };
    let event = SensorEvent {
        sensor: sensor.name.kind().code(),
        mode: if sick { 0 } else { sensor.mode },
    };
    Ok((setup, event))
}
