//! A recording through a co-processor: the one place that turns a recording into what a
//! device receives, for every harness (`pyramid run` on either board, the lab's experiments,
//! faults and soak).
//!
//! [`steps`] decodes a recording once into [`Step`]s, in order: its setup, the actuator
//! angles and poses, and every telegram that passes the SICK accumulator's checks, whole; or,
//! for a spinning lidar (the recording's sensor event, version 2), its laser bytes chunk by
//! chunk as recorded, with the packets each completes. [`play`] hands them to a [`Device`]
//! lock-step, as `docs/protocol.md` lets a host do it over two independent streams:
//!
//! 1. the setup (and the sensor) as Setup (waiting for its Reply);
//! 2. before each telegram or chunk, the angle and pose in force as PanAngle and Pose, then
//!    RequestStats and the Stats that shows them applied; then the telegram or chunk on the
//!    laser stream, and RequestStats until the device has counted the telegram (a lidar
//!    chunk: until it has taken every byte, `laser_bytes`);
//! 3. at the end, EndObservation (the last observation is applied) and the Stats that counts
//!    everything.
//!
//! [`play_watched`] is the same loop with a look at the device before and after each
//! telegram (the lab's stairs experiment asks the device's maps what it asks its own).

use crate::device::Device;
use crate::export::{LayerSnapshot, MapSnapshot};
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::laser::{LaserDecoder, LaserItem, Packet, Sensor, SensorKind};
use terrain_pyramid::link::convert::{pose_of, setup_message_with_sensor, setup_with_rig};
use terrain_pyramid::logodds::round_to_log_odds;
use terrain_pyramid::wire::link::{Message, PanAngle, PoseReport};
use terrain_pyramid::wire::recording::{Payload, Reader, SensorEvent, SetupEvent};
use terrain_pyramid::wire::sick::MeasuredValues;
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{Config, Design, Resolution};

/// One thing a device receives, in the recording's order.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// The laser's setup.
    Setup(SetupEvent),
    /// The actuator angle from now on, 2⁻¹⁶ turn.
    Angle(u16),
    /// The robot's pose from now on: x, y, z (m), roll, pitch, yaw (rad).
    Pose([f32; 6]),
    /// One whole telegram that passed the accumulator's checks, with the recording's time of
    /// the bytes that completed it, µs.
    Telegram {
        /// The telegram's bytes.
        bytes: Vec<u8>,
        /// Whether its payload is a measured-values telegram the pipeline takes.
        measured: bool,
        /// The recording's time, µs.
        time_us: u64,
    },
    /// A chunk of a spinning lidar's bytes, as recorded.
    Laser {
        /// The bytes.
        bytes: Vec<u8>,
        /// Packets the chunk completes that pass their checks (the decoder carries partial
        /// packets from chunk to chunk, as the device's does).
        packets: u64,
        /// The recording's time, µs.
        time_us: u64,
    },
}

/// A decoded recording.
#[derive(Debug, Clone)]
pub struct Steps {
    /// The steps, in order.
    pub steps: Vec<Step>,
    /// Telegram candidates the accumulator refused (CRC, length, truncation).
    pub telegrams_rejected: u64,
    /// The laser the recording's bytes come from (SICK without a sensor event).
    pub sensor: SensorEvent,
    /// The recording's rig event (version 3), written over each Setup its setup events make.
    pub rig_event: Option<terrain_pyramid::wire::recording::RigEvent>,
    /// The rig written over each Setup after the recording's rig event (the user's flags:
    /// empty by default).
    pub rig: crate::rig::Rig,
}

impl Default for Steps {
    fn default() -> Self {
        Self {
            steps: Vec::new(),
            telegrams_rejected: 0,
            sensor: SensorEvent::SICK,
            rig_event: None,
            rig: crate::rig::Rig::default(),
        }
    }
}

impl Steps {
    /// The recording's setup (its first setup event).
    #[must_use]
    pub fn setup(&self) -> Option<SetupEvent> {
        self.steps.iter().find_map(|s| match s {
            Step::Setup(setup) => Some(*setup),
            _ => None,
        })
    }
}

/// The sensor of a recording's sensor event, checked as the device checks a Setup's.
fn sensor_of(event: &SensorEvent) -> Result<Sensor, String> {
    SensorKind::from_code(event.sensor)
        .and_then(|kind| Sensor::from_kind_and_mode(kind, event.mode))
        .ok_or_else(|| {
            format!(
                "the recording's sensor {} has no mode {}",
                event.sensor, event.mode
            )
        })
}

/// Feeds `chunk` to `decoder` until it wants more bytes, handing every packet the chunk
/// completes to `packet` with its stream offset (bytes from the start of the stream); returns
/// how many candidates the decoder refused.
pub fn each_packet(
    decoder: &mut LaserDecoder,
    chunk: &[u8],
    mut packet: impl FnMut(Packet<'_>, u64),
) -> u64 {
    each_unit(decoder, chunk, |item, offset| {
        if let LaserItem::Packet(p) = item {
            packet(p, offset);
        }
    })
}

/// Feeds `chunk` to `decoder` until it wants more bytes, handing every unit the chunk
/// completes (a telegram, a packet or another valid unit) to `unit` with its stream offset
/// (bytes from the start of the stream); returns how many candidates the decoder refused.
pub fn each_unit(
    decoder: &mut LaserDecoder,
    chunk: &[u8],
    mut unit: impl FnMut(LaserItem<'_>, u64),
) -> u64 {
    let mut refused = 0;
    let mut rest = chunk;
    loop {
        let result = decoder.feed(rest);
        rest = result.remaining();
        match result {
            FeedResult::Consumed => return refused,
            FeedResult::Rejected { .. } => refused += 1,
            FeedResult::Item { item, offset, .. } => unit(item, offset),
        }
    }
}

/// Decodes a whole recording into [`Steps`].
///
/// # Errors
/// A recording that cannot be read, laser bytes before the setup, or a sensor event after
/// them.
pub fn steps(data: &[u8]) -> Result<Steps, String> {
    let reader = Reader::new(data).map_err(|e| format!("the recording: {e}"))?;
    let mut sick = Box::new(LaserDecoder::new(Sensor::Sick));
    let mut lidar: Option<Box<LaserDecoder>> = None;
    let mut out = Steps::default();
    let mut have_setup = false;
    let mut have_laser = false;
    for event in reader {
        let event = event.map_err(|e| format!("the recording: {e}"))?;
        match event.payload {
            Payload::Setup(setup) => {
                have_setup = true;
                out.steps.push(Step::Setup(setup));
            }
            Payload::Sensor(sensor) => {
                if have_laser {
                    return Err("the recording names its sensor after laser bytes".into());
                }
                let s = sensor_of(&sensor)?;
                out.sensor = sensor;
                lidar = s.is_lidar().then(|| Box::new(LaserDecoder::new(s)));
            }
            Payload::Rig(rig) => {
                if have_laser {
                    return Err("the recording names its rig after laser bytes".into());
                }
                out.rig_event = Some(rig);
            }
            Payload::Angle(turns) => out.steps.push(Step::Angle(turns)),
            Payload::Pose(pose) => out.steps.push(Step::Pose(pose)),
            Payload::Laser(bytes) => {
                if !have_setup {
                    return Err("the recording has laser bytes before its setup event".into());
                }
                have_laser = true;
                if let Some(decoder) = lidar.as_mut() {
                    let mut packets = 0;
                    out.telegrams_rejected += each_packet(decoder, bytes, |_, _| packets += 1);
                    out.steps.push(Step::Laser {
                        bytes: bytes.to_vec(),
                        packets,
                        time_us: event.time_us,
                    });
                    continue;
                }
                out.telegrams_rejected += each_unit(&mut sick, bytes, |item, _| {
                    if let LaserItem::Telegram(telegram) = item {
                        out.steps.push(Step::Telegram {
                            bytes: telegram.as_bytes().to_vec(),
                            measured: MeasuredValues::parse(&telegram).is_ok(),
                            time_us: event.time_us,
                        });
                    }
                });
            }
            Payload::Marker(_) | Payload::Unknown { .. } => {}
        }
    }
    Ok(out)
}

/// What a play did, beyond the maps.
#[derive(Serialize, Debug, Default, Clone, PartialEq, Eq)]
pub struct RunCounts {
    /// Valid measured-values telegrams (or lidar packets) in the recording's laser bytes.
    pub telegrams_sent: u64,
    /// Telegrams (or lidar packets) the pipeline applied.
    pub telegrams_applied: u64,
    /// Link frames received from the device.
    pub frames_received: u64,
    /// Link frames with a bad checksum.
    pub link_crc_errors: u64,
    /// Telegrams the SICK accumulator rejected (CRC, length, truncation).
    pub telegrams_rejected: u64,
    /// Lines the pipeline refused (a count that does not fit the variant, or no angle).
    pub lines_rejected: u64,
    /// Poses refused (not finite or out of range).
    pub poses_rejected: u64,
    /// Observations applied.
    pub observations: u64,
    /// Points the classifier could not hold (its scratch was full).
    pub overflow_points: u64,
    /// Observations the device applied early because its classifier's scratch could not be
    /// sure to hold the next return (none dropped; counted in `observations` too).
    pub observations_split: u64,
    /// Returns the device's laser decoder refused as implausible (an RPLIDAR standard-scan
    /// node whose angle cannot follow its neighbours).
    pub returns_implausible: u64,
}

/// The angle and pose to send before the next telegram.
#[derive(Default)]
struct Pending {
    angle: Option<u16>,
    pose: Option<[f32; 6]>,
}

/// Brings the device's angle and pose up to date (and waits until they are applied).
fn send_pending(device: &mut impl Device, pending: &mut Pending) -> Result<(), String> {
    let mut sent = false;
    if let Some(turns) = pending.angle.take() {
        device.send(&Message::PanAngle(PanAngle {
            turns,
            timestamp_ms: 0,
        }))?;
        sent = true;
    }
    if let Some(pose) = pending.pose.take() {
        device.send(&Message::Pose(PoseReport::unstamped(pose)))?;
        sent = true;
    }
    if sent {
        device.stats()?;
    }
    Ok(())
}

/// The robot's position of the last valid pose, metres (the maps' picture centres on it).
pub type SensorXy = (f64, f64);

/// A moment of [`play_watched`] at which the harness looks at the device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Moment {
    /// Before a telegram (and the angle and pose in force for it) is sent.
    Before {
        /// The recording's time of the telegram, µs.
        time_us: u64,
        /// The robot's position in force for it (the last valid pose), metres.
        robot_xy: SensorXy,
    },
    /// After the device counted the telegram.
    After {
        /// Telegrams sent so far, this one included.
        telegrams: u64,
        /// The robot's position in force for it (the last valid pose), metres.
        robot_xy: SensorXy,
    },
}

/// Plays decoded `steps` through `device` (already configured with the design) with the
/// classifier's thresholds; returns the counts and the last robot position.
///
/// # Errors
/// The device refused the setup or stopped answering; the recording's setup is invalid.
pub fn play<D: Device>(
    device: &mut D,
    steps: &Steps,
    classifier: &ClassifierConfig,
) -> Result<(RunCounts, SensorXy), String> {
    play_watched(device, steps, classifier, |_, _| Ok(()))
}

/// [`play`], handing the device to `watch` before and after each telegram (to look at its
/// maps at the moments an experiment looks at its own).
///
/// # Errors
/// The device refused the setup or stopped answering; the recording's setup is invalid;
/// `watch` failed.
pub fn play_watched<D: Device>(
    device: &mut D,
    steps: &Steps,
    classifier: &ClassifierConfig,
    mut watch: impl FnMut(&mut D, Moment) -> Result<(), String>,
) -> Result<(RunCounts, SensorXy), String> {
    let mut counts = RunCounts {
        telegrams_rejected: steps.telegrams_rejected,
        ..RunCounts::default()
    };
    let mut sensor_xy = (0.0, 0.0);
    let mut pending = Pending::default();
    let mut counted: u64 = 0;
    let mut laser_bytes: u64 = 0;
    let lidar = steps.sensor != SensorEvent::SICK;
    for step in &steps.steps {
        match step {
            Step::Setup(setup) => {
                let mut message = setup_message_with_sensor(setup, &steps.sensor, classifier);
                if let Some(rig) = &steps.rig_event {
                    message = setup_with_rig(message, rig);
                }
                steps.rig.apply(&mut message).map_err(|e| e.to_string())?;
                // The library's own check first, for a clear error before any frame.
                terrain_pyramid::link::convert::frontend_config(&message)
                    .map_err(|e| format!("the recording's setup: {e}"))?;
                device.command("Setup", &Message::Setup(message))?;
            }
            Step::Angle(turns) => pending.angle = Some(*turns),
            Step::Pose(p) => {
                let report = PoseReport::unstamped(*p);
                if pose_of(&report).is_ok() {
                    sensor_xy = (f64::from(report.x_m), f64::from(report.y_m));
                    pending.pose = Some(*p);
                } else {
                    counts.poses_rejected += 1;
                }
            }
            Step::Telegram {
                measured: false, ..
            } => continue,
            Step::Telegram { bytes, time_us, .. } => {
                let robot_xy = sensor_xy;
                watch(
                    device,
                    Moment::Before {
                        time_us: *time_us,
                        robot_xy,
                    },
                )?;
                send_pending(device, &mut pending)?;
                device.laser(bytes)?;
                counts.telegrams_sent += 1;
                counted = device.wait_for_telegrams(counts.telegrams_sent)?;
                watch(
                    device,
                    Moment::After {
                        telegrams: counts.telegrams_sent,
                        robot_xy,
                    },
                )?;
            }
            Step::Laser { bytes, packets, .. } => {
                send_pending(device, &mut pending)?;
                device.laser(bytes)?;
                counts.telegrams_sent += packets;
                laser_bytes += bytes.len() as u64;
                device.wait_for_laser_bytes(laser_bytes)?;
            }
        }
    }
    send_pending(device, &mut pending)?;
    device.send(&Message::EndObservation)?;
    let s = device.stats()?;
    counts.telegrams_applied = u64::from(s.telegrams_ok.saturating_sub(s.telegrams_bad_other));
    counts.lines_rejected = u64::from(s.telegrams_bad_other);
    counts.overflow_points = u64::from(s.classifier_overflows);
    counts.observations_split = u64::from(s.observations_split);
    counts.returns_implausible = u64::from(s.returns_implausible);
    counts.observations = u64::from(s.observations);
    if lidar {
        counted = u64::from(s.telegrams_ok);
    }
    if counted != counts.telegrams_sent {
        return Err(format!(
            "the device counted {counted} telegrams of {} sent",
            counts.telegrams_sent
        ));
    }
    Ok((counts, sensor_xy))
}

/// The maps of the device's mirror, with the design's resolutions and bands; the mirror must
/// be complete ([`Device::snapshot`]).
///
/// # Errors
/// The mirror lacks a layer of the design, or a layer's cell size differs from the design's.
pub fn mirror_snapshot<const L: usize>(
    device: &impl Device,
    design: &Design<L>,
    config: &Config,
    sensor_xy: SensorXy,
) -> Result<MapSnapshot, String> {
    let mirror = device.link().mirror();
    let w = mirror.cells_per_side();
    let mut layers = Vec::new();
    for (k, d) in design.layers().iter().enumerate() {
        let (origin, resolution_q16, cells) = mirror
            .layer_cells(k)
            .ok_or_else(|| format!("the device has no layer {k}"))?;
        let resolution = Resolution::from_m(d.resolution_m)
            .ok_or_else(|| format!("layer {k}: bad resolution"))?;
        if resolution.to_bits() != resolution_q16 {
            return Err(format!(
                "layer {k}: the device's resolution {resolution_q16} differs from the design's {}",
                resolution.to_bits()
            ));
        }
        layers.push(LayerSnapshot {
            index: k,
            resolution,
            band_m: [f64::from(d.band_inner_m), f64::from(d.band_outer_m)],
            origin_cells: origin,
            cells_per_side: w,
            cells,
        });
    }
    Ok(MapSnapshot {
        layers,
        sensor_xy,
        fused_margin: round_to_log_odds(config.fused_margin),
    })
}
