//! The spinning lidars: an LDROBOT LD06/LD19, a Slamtec RPLIDAR (standard scan or express
//! scan) or a YDLIDAR X4 on a nodding servo or on the paper's panned mount, ray-cast into a
//! [`Scene`] in `f64` and written as the byte streams the sensors send, in a recording of
//! version 2 with its sensor event (`docs/recording.md`, `docs/lidars.md`).
//!
//! # Timing
//! The sensor measures at a constant rate ([`LidarKind::sample_hz`]) while its head turns at
//! a constant rotation rate ([`LidarKind::rotation_hz`]): sample n is measured at
//! `t_n = n / sample_hz`, clockwise angle `φ_n = 360° · rotation_hz · t_n` (mod 360°). The
//! samples are grouped into the sensor's packets as the makers' manuals describe them:
//! - **LD06/LD19**: 12 consecutive samples per 47-byte packet (start and end angle of the
//!   first and last, 0.01°; speed in °/s; a millisecond time stamp wrapping at 30 000); about
//!   37.5 packets per revolution at 10 Hz; a packet crosses 360° where the head does.
//! - **RPLIDAR standard scan**: the response descriptor first, then one 5-byte node per
//!   sample, the S flag on the first node of each revolution, quality 47 for an echo.
//! - **RPLIDAR express scan**: the express descriptor, then 84-byte capsules of 32 samples;
//!   a capsule's angles are its start angle ωᵢ plus k/32 of the way to the next capsule's,
//!   less each cabin's dθ (the simulator sets dθ = (k mod 4)/8°, the sample's true angle
//!   being that compensated one); S on the stream's first capsule only (a revolution starts
//!   where the capsules' angles pass 360°).
//! - **YDLIDAR X4**: the scan descriptor first, then `AA 55` packets of up to 40 samples;
//!   every revolution begins with its start packet (CT bit 0 set, one sample). The angles on
//!   the wire (FSA, LSA) are first-level angles; the manual's second-level correction
//!   `atan(21.8·(155.3 − d)/(155.3·d))` is added by a reader, so the simulator casts each
//!   sample at its first-level angle plus that correction (found by iterating: the correction
//!   depends on the distance it gives).
//!
//! A packet leaves the sensor when its last sample is measured and arrives after its
//! transmission time at the sensor's baud rate (10 bits a byte). The recording's laser events
//! are **chunks** of bytes: one per packet, or for the RPLIDAR's standard scan the nodes of
//! [`LidarSimConfig::chunk_us`] together, stamped with the arrival of their last byte.
//!
//! # The actuator
//! - [`LidarActuator::Servo`]: a nodding servo driven along the library's sweep model
//!   ([`ServoSweep`]: triangle wave from min to max and back, after a 500 ms hold at min, the
//!   servo `latency` behind its command). The sweep begins at t = 0; during the hold the
//!   servo is taken to be at min. Tilted horizontal mount (`docs/lidars.md`).
//! - [`LidarActuator::Pan`]: the paper's panned vertical mount, a triangle wave ±half width.
//!
//! Each sample is cast at the actuator's angle at its own time (the servo moves during a
//! packet). A recording carries one actuator angle per chunk (an angle event before the
//! chunk's bytes, 2⁻¹⁶ turn): the angle at the mean time of the samples the chunk completes.
//! A co-processor that takes the recording's angles (the host's PanAngle) thus places a
//! chunk's samples at its mean angle, off by at most `rate × chunk span / 2` (0.07° for an
//! LD19 packet at 60 °/s; `docs/lidars.md`, "Error budget").
//!
//! # Ranges
//! The true range gets Gaussian noise of σ ([`LidarSimConfig::sigma_m`]) and is rounded to the
//! sensor's unit (1 mm; ¼ mm for the RPLIDAR node and the YDLIDAR); no echo within the
//! maximum range, or a measured range below the minimum, is sent as 0 (no return).
//!
//! # Pose
//! The robot's pose (trajectory, `f32`-rounded) is taken at each chunk's time; a pose event is
//! written before a chunk when it changed. The samples of a chunk are cast from that pose, or
//! with [`LidarSimConfig::sample_poses`] each from the true pose at its own time.
//!
//! [`ServoSweep`]: terrain_pyramid::actuator::ServoSweep

mod mount;
mod stream;

pub use mount::{LidarActuator, SimRig};
pub use stream::{ydlidar_correction_deg, ydlidar_packet_bytes};

use super::laser::{angle_to_u16, u16_to_angle_deg};
use super::record::{push, push_laser, push_pose_change, start_recording, SimError};
use super::rng::Rng;
use super::scene::{GroundTruthSpec, ObstacleCell, Scene};
use super::trajectory::Trajectory;
use mount::Sweep;
use stream::{Caster, Packets};
use terrain_pyramid::laser::{LaserDecoder, LaserItem, Packet, Sensor, SensorKind};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{Event, MountKind, Payload, SensorEvent};
use terrain_pyramid::wire::rplidar::RplidarScanMode;
use terrain_pyramid::wire::ydlidar::YdlidarAngleCorrection;
use terrain_pyramid::wire::FeedResult;

/// Which lidar, and how it scans.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LidarKind {
    /// LDROBOT LD06: 4 500 samples/s at 10 Hz, 0.02–12 m, 230 400 Bd.
    Ld06,
    /// LDROBOT LD19 (the LD06's protocol): 4 500 samples/s at 10 Hz, 0.02–12 m, 230 400 Bd.
    Ld19,
    /// Slamtec RPLIDAR A1 in standard scan: 2 000 samples/s at 5.5 Hz, 0.15–12 m, 115 200 Bd.
    RplidarStandard,
    /// Slamtec RPLIDAR A2 in express scan: 4 000 samples/s at 10 Hz, 0.15–12 m, 115 200 Bd.
    RplidarExpress,
    /// YDLIDAR X4: 5 000 samples/s at 7 Hz, 0.12–10 m, 128 000 Bd, second-level correction.
    YdlidarX4,
}

impl LidarKind {
    /// Every kind, in order.
    pub const ALL: [Self; 5] = [
        Self::Ld06,
        Self::Ld19,
        Self::RplidarStandard,
        Self::RplidarExpress,
        Self::YdlidarX4,
    ];

    /// A short name: `ld06`, `ld19`, `rplidar`, `rplidar-express`, `ydlidar`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Ld06 => "ld06",
            Self::Ld19 => "ld19",
            Self::RplidarStandard => "rplidar",
            Self::RplidarExpress => "rplidar-express",
            Self::YdlidarX4 => "ydlidar",
        }
    }

    /// The library's sensor (kind and mode) this stream is read with.
    #[must_use]
    pub const fn sensor(self) -> Sensor {
        match self {
            Self::Ld06 | Self::Ld19 => Sensor::Ld06,
            Self::RplidarStandard => Sensor::Rplidar(RplidarScanMode::Standard),
            Self::RplidarExpress => Sensor::Rplidar(RplidarScanMode::Express),
            Self::YdlidarX4 => Sensor::Ydlidar(YdlidarAngleCorrection::SecondLevel),
        }
    }

    /// The recording's sensor event.
    #[must_use]
    pub const fn sensor_event(self) -> SensorEvent {
        let sensor = self.sensor();
        SensorEvent {
            sensor: sensor.kind().code(),
            mode: sensor.mode(),
        }
    }

    /// Samples per second.
    #[must_use]
    pub const fn sample_hz(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 => 4_500.0,
            Self::RplidarStandard => 2_000.0,
            Self::RplidarExpress => 4_000.0,
            Self::YdlidarX4 => 5_000.0,
        }
    }

    /// Revolutions per second.
    #[must_use]
    pub const fn rotation_hz(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 | Self::RplidarExpress => 10.0,
            Self::RplidarStandard => 5.5,
            Self::YdlidarX4 => 7.0,
        }
    }

    /// The UART's baud rate.
    #[must_use]
    pub const fn baud(self) -> u32 {
        match self {
            Self::Ld06 | Self::Ld19 => 230_400,
            Self::RplidarStandard | Self::RplidarExpress => 115_200,
            Self::YdlidarX4 => 128_000,
        }
    }

    /// The shortest and longest range, metres.
    #[must_use]
    pub const fn range_m(self) -> (f64, f64) {
        match self {
            Self::Ld06 | Self::Ld19 => (0.02, 12.0),
            Self::RplidarStandard | Self::RplidarExpress => (0.15, 12.0),
            Self::YdlidarX4 => (0.12, 10.0),
        }
    }

    /// The range noise the makers state, metres (σ): LD19 10 mm (its datasheet's standard
    /// deviation, 0.3–12 m); RPLIDAR and X4 about 1 % of 1–3 m, taken as 15 mm.
    #[must_use]
    pub const fn sigma_m(self) -> f64 {
        match self {
            Self::Ld06 | Self::Ld19 => 0.010,
            Self::RplidarStandard | Self::RplidarExpress | Self::YdlidarX4 => 0.015,
        }
    }

    /// Samples per packet (the largest for the X4; one node for the RPLIDAR standard scan).
    #[must_use]
    pub const fn samples_per_packet(self) -> usize {
        match self {
            Self::Ld06 | Self::Ld19 => 12,
            Self::RplidarStandard => 1,
            Self::RplidarExpress => 32,
            Self::YdlidarX4 => 40,
        }
    }
}

/// A simulated lidar run.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarSimConfig {
    /// The world.
    pub scene: Scene,
    /// The sensor.
    pub kind: LidarKind,
    /// Its actuator.
    pub actuator: LidarActuator,
    /// The spin centre in the robot frame, metres.
    pub position_m: [f64; 3],
    /// The range noise, metres (default: the kind's).
    pub sigma_m: f64,
    /// The robot's motion.
    pub trajectory: Trajectory,
    /// Revolutions per observation (the setup's lines per observation); 0 = one per sweep.
    /// Default: 0 on a servo, 2 on the pan.
    pub revolutions_per_observation: u32,
    /// RPLIDAR standard scan: nodes sent within this many µs make one chunk. Default 5 000.
    pub chunk_us: u32,
    /// Every `split_every`-th chunk is cut in two at a random byte; 0 = never. Default 10.
    pub split_every: u32,
    /// The seed of every random draw.
    pub seed: u64,
    /// The ground truth's grid and rule.
    pub truth: GroundTruthSpec,
    /// Seconds the servo's sweep had run before t = 0 (0, the default: it begins at t = 0
    /// with its 500 ms hold at min; 0.5 or more: it is already sweeping).
    pub servo_lead_s: f64,
    /// The lidar mounted otherwise than the actuator's preset (`None`, the default: the
    /// preset).
    pub rig: Option<SimRig>,
    /// Each sample cast from the robot's true pose at its own time (default `false`: every
    /// sample of a chunk from the pose at the chunk's first sample, the one its pose event
    /// gives).
    pub sample_poses: bool,
    /// Where the run keeps each return's true point (before the range noise), for diagnostics:
    /// the returns whose point lies in this box; `None` (the default): none are kept.
    pub hit_box: Option<HitBox>,
}

/// An axis-aligned box of the world, metres: `min[i] ≤ p[i] ≤ max[i]` for x, y, z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HitBox {
    /// The lowest corner, metres.
    pub min: [f64; 3],
    /// The highest corner, metres.
    pub max: [f64; 3],
}

impl HitBox {
    /// Whether `p` lies in the box (its faces included).
    #[must_use]
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|i| self.min[i] <= p[i] && p[i] <= self.max[i])
    }
}

/// Where one return's beam met the scene, before the range noise: the simulator's truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueHit {
    /// The sample's time, seconds since the run's start.
    pub t_s: f64,
    /// The point, world metres.
    pub point_m: [f64; 3],
}

impl LidarSimConfig {
    /// A run of `kind` on `actuator` at `position_m` over `scene` along `trajectory`, with the
    /// defaults.
    #[must_use]
    pub fn new(
        scene: Scene,
        kind: LidarKind,
        actuator: LidarActuator,
        position_m: [f64; 3],
        trajectory: Trajectory,
    ) -> Self {
        Self {
            scene,
            kind,
            actuator,
            position_m,
            sigma_m: kind.sigma_m(),
            trajectory,
            revolutions_per_observation: match actuator.mount_kind() {
                MountKind::TiltedHorizontal => 0,
                MountKind::PannedVertical => 2,
            },
            chunk_us: 5_000,
            split_every: 10,
            seed: 1,
            truth: GroundTruthSpec::default(),
            servo_lead_s: 0.0,
            rig: None,
            sample_poses: false,
            hit_box: None,
        }
    }

    /// The setup event (the variant fields, which a lidar ignores, say 180° at 0.5°).
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn setup(&self) -> Setup {
        Setup {
            mount: self.actuator.mount_kind(),
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: self.position_m.map(|v| v as f32),
            lines_per_observation: self.revolutions_per_observation,
        }
    }

    /// Checks the fields.
    ///
    /// # Errors
    /// The first one out of bounds.
    pub fn validate(&self) -> Result<(), SimError> {
        self.trajectory.validate().map_err(SimError)?;
        if !(self.sigma_m >= 0.0 && self.sigma_m.is_finite()) {
            return Err(SimError("lidar: σ must be ≥ 0".into()));
        }
        if !self.position_m.iter().all(|v| v.is_finite()) {
            return Err(SimError("lidar: the position must be finite".into()));
        }
        match self.actuator {
            LidarActuator::Servo(p) => {
                if p.span_bits() == 0 || p.rate_mdeg_per_s == 0 {
                    return Err(SimError("lidar: the servo's sweep is empty".into()));
                }
            }
            LidarActuator::Pan {
                half_width_cdeg,
                rate_cdeg_s,
            } => {
                if !(1..18_000).contains(&half_width_cdeg) || rate_cdeg_s == 0 {
                    return Err(SimError("lidar: the pan is out of bounds".into()));
                }
            }
        }
        Ok(())
    }
}

/// A simulated lidar run: the recording and what is known about it.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarSimulation {
    /// The recording (version 2), header included.
    pub bytes: Vec<u8>,
    /// Its setup event.
    pub setup: Setup,
    /// Its sensor event.
    pub sensor: SensorEvent,
    /// Packets sent (nodes and capsules for the RPLIDAR, start packets for the X4).
    pub packets: u64,
    /// Samples measured (returns in packets, echoes or not).
    pub samples: u64,
    /// Samples with an echo (a range other than 0).
    pub echoes: u64,
    /// Revolutions begun (the sensor's start flags; the LD06 has none and counts wraps).
    pub revolutions: u64,
    /// Laser-byte events.
    pub laser_events: u64,
    /// Laser bytes.
    pub laser_bytes: u64,
    /// The time of the last event, µs.
    pub duration_us: u64,
    /// The obstacle cells of the scene.
    pub ground_truth: Vec<ObstacleCell>,
    /// The returns whose true point lies in the configuration's `hit_box`, in time order.
    pub hits: Vec<TrueHit>,
}

/// Salt of the split-point generator's seed.
const SPLIT_SALT: u64 = 0x11DA_C0DE_11DA_C0DE;

/// Runs the simulation and writes the recording: header, setup and sensor events at t = 0,
/// then per chunk (pose when changed, angle, bytes) until the trajectory's end.
///
/// # Errors
/// A configuration [`LidarSimConfig::validate`] refuses, or an emitter's refusal.
pub fn simulate_lidar(config: &LidarSimConfig) -> Result<LidarSimulation, SimError> {
    config.validate()?;
    let setup = config.setup();
    let sensor = config.kind.sensor_event();
    // The lidar sits where the setup says (f32).
    let config = &LidarSimConfig {
        position_m: setup.sensor_m.map(f64::from),
        ..config.clone()
    };
    let duration = config.trajectory.duration_s();
    // A rig needs version 3 (its rig event); without one the file stays version 2.
    let mut head = vec![Payload::Setup(setup), Payload::Sensor(sensor)];
    let version = if let Some(rig) = config.rig {
        head.push(Payload::Rig(rig.event(&config.actuator)));
        terrain_pyramid::wire::recording::VERSION
    } else {
        terrain_pyramid::wire::recording::VERSION_WITHOUT_RIG
    };
    let mut bytes = start_recording(version, &head)?;
    let mut packets = Packets {
        caster: Caster {
            config,
            sweep: Sweep::new(config.actuator, config.servo_lead_s),
            rng: Rng::new(config.seed),
            pose: config.trajectory.pose_at(0.0, &config.scene).rounded_f32(),
            last_point: None,
            hits: Vec::new(),
        },
        next_sample: 0,
        pending: Vec::new(),
        byte_s: 10.0 / f64::from(config.kind.baud()),
        header_sent: false,
        last_deg: 0.0,
    };
    let mut angle_sweep = Sweep::new(config.actuator, config.servo_lead_s);
    let mut splits = Rng::new(config.seed ^ SPLIT_SALT);
    let mut sim = LidarSimulation {
        bytes: Vec::new(),
        setup,
        sensor,
        packets: 0,
        samples: 0,
        echoes: 0,
        revolutions: 0,
        laser_events: 0,
        laser_bytes: 0,
        duration_us: 0,
        ground_truth: config.scene.obstacle_cells(&config.truth),
        hits: Vec::new(),
    };
    let mut last_pose: Option<[f32; 6]> = None;
    let mut last_time_us = 0_u64;
    let mut chunks = 0_u64;
    let chunk_s = if config.kind == LidarKind::RplidarStandard {
        f64::from(config.chunk_us) * 1e-6
    } else {
        0.0
    };
    loop {
        // Gather one chunk: the packets that arrive within chunk_s of the first.
        let mut chunk: Vec<u8> = Vec::new();
        let mut times: Vec<f64> = Vec::new();
        let mut arrival = 0.0;
        let pose = config
            .trajectory
            .pose_at(packets.next_time(), &config.scene)
            .rounded_f32();
        packets.caster.pose = pose;
        loop {
            let sent = packets.next_packet()?;
            if chunk.is_empty() {
                arrival = sent.arrival_s;
            }
            let counted = !sent.sample_times.is_empty();
            sim.packets += u64::from(counted);
            sim.revolutions += u64::from(sent.starts_revolution);
            sim.samples += sent.sample_times.len() as u64;
            sim.echoes += sent.echoes;
            chunk.extend_from_slice(&sent.bytes);
            times.extend_from_slice(&sent.sample_times);
            let end = sent.arrival_s;
            arrival = arrival.max(end);
            if chunk_s <= 0.0 || end - times.first().copied().unwrap_or(end) >= chunk_s {
                break;
            }
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let now = ((arrival * 1e6).round() as u64).max(last_time_us);
        last_time_us = now;
        push_pose_change(&mut bytes, now, pose.to_f32(), &mut last_pose)?;
        if !times.is_empty() {
            #[allow(clippy::cast_precision_loss)]
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            push(
                &mut bytes,
                &Event {
                    time_us: now,
                    payload: Payload::Angle(angle_to_u16({
                        let a = angle_sweep.angle_deg(mean);
                        config.rig.map_or(a, |rig| rig.reported_deg(a))
                    })),
                },
            )?;
        }
        chunks += 1;
        let split = config.split_every != 0 && chunks.is_multiple_of(u64::from(config.split_every));
        sim.laser_events += u64::from(push_laser(&mut bytes, now, &chunk, split, &mut splits)?);
        sim.laser_bytes += chunk.len() as u64;
        if arrival >= duration {
            break;
        }
    }
    sim.duration_us = last_time_us;
    sim.bytes = bytes;
    sim.hits = core::mem::take(&mut packets.caster.hits);
    Ok(sim)
}

/// Feeds one laser chunk to `decoder`, handing each packet the chunk completes to `packet`, in
/// stream order; the decoder's other units and the candidates it refuses are passed over.
pub fn feed_packets(decoder: &mut LaserDecoder, chunk: &[u8], mut packet: impl FnMut(&Packet<'_>)) {
    let mut rest = chunk;
    loop {
        match decoder.feed(rest) {
            FeedResult::Consumed => return,
            result => {
                if let FeedResult::Item {
                    item: LaserItem::Packet(p),
                    ..
                } = &result
                {
                    packet(p);
                }
                rest = result.remaining();
            }
        }
    }
}

/// Echoes the decoder of the library finds in a simulated stream, with their decoded angle
/// (degrees, clockwise) and range (mm): the test's view of what a reader gets.
///
/// # Errors
/// A recording the reader refuses.
pub fn decoded_returns(bytes: &[u8]) -> Result<Vec<(f64, u32)>, String> {
    use terrain_pyramid::wire::recording::Reader;
    let reader = Reader::new(bytes).map_err(|e| e.to_string())?;
    let mut decoder: Option<Box<LaserDecoder>> = None;
    let mut out = Vec::new();
    for event in reader {
        match event.map_err(|e| e.to_string())?.payload {
            Payload::Sensor(s) => {
                let sensor = SensorKind::from_code(s.sensor)
                    .and_then(|k| Sensor::from_kind_and_mode(k, s.mode))
                    .ok_or("bad sensor")?;
                decoder = Some(Box::new(LaserDecoder::new(sensor)));
            }
            Payload::Laser(chunk) => {
                let d = decoder.as_mut().ok_or("laser bytes before the sensor")?;
                feed_packets(d, chunk, |p| {
                    for r in p.returns() {
                        out.push((
                            f64::from(r.angle.to_bits()) * 360.0 / 4_294_967_296.0,
                            r.range_mm,
                        ));
                    }
                });
            }
            _ => {}
        }
    }
    Ok(out)
}

/// The recording's angle events in degrees, in order (for tests).
///
/// # Errors
/// A recording the reader refuses.
pub fn angle_events_deg(bytes: &[u8]) -> Result<Vec<f64>, String> {
    let reader = terrain_pyramid::wire::recording::Reader::new(bytes).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for event in reader {
        if let Payload::Angle(a) = event.map_err(|e| e.to_string())?.payload {
            out.push(u16_to_angle_deg(a));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A servo that stays at `deg` (after its hold at min = `deg`): 1 milli-degree per second.
    fn still(deg: f64) -> LidarActuator {
        LidarActuator::servo(deg, deg + 1.0, 0.001, 0.0)
    }

    fn run(kind: LidarKind, actuator: LidarActuator, seconds: f64, sigma: f64) -> LidarSimulation {
        let mut config = LidarSimConfig::new(
            Scene::flat(),
            kind,
            actuator,
            [0.0, 0.0, 1.0],
            Trajectory::standing(seconds),
        );
        config.sigma_m = sigma;
        simulate_lidar(&config).unwrap()
    }

    #[test]
    fn a_hit_box_keeps_the_true_points_in_it_and_changes_nothing_else() {
        // Tilted 20° down from 1 m, every lidar's beams meet the flat ground ahead at
        // 1/tan 20° = 2.75 m; behind and beside it the scan meets it elsewhere.
        let hit_box = HitBox {
            min: [2.5, -0.5, -0.01],
            max: [3.0, 0.5, 0.01],
        };
        for kind in LidarKind::ALL {
            let mut config = LidarSimConfig::new(
                Scene::flat(),
                kind,
                still(20.0),
                [0.0, 0.0, 1.0],
                Trajectory::standing(1.0),
            );
            let plain = simulate_lidar(&config).unwrap();
            config.hit_box = Some(hit_box);
            let kept = simulate_lidar(&config).unwrap();
            assert_eq!(kept.bytes, plain.bytes, "{kind:?}");
            assert!(plain.hits.is_empty());
            assert!(!kept.hits.is_empty(), "{kind:?}");
            assert!(kept.hits.iter().all(|h| hit_box.contains(h.point_m)));
            assert!(kept.hits.windows(2).all(|w| w[0].t_s <= w[1].t_s));
            // A ±0.5 m chord at 2.9 m is about 20° of a revolution, well under its whole.
            #[allow(clippy::cast_precision_loss)]
            let share = kept.hits.len() as f64 / kept.echoes as f64;
            assert!(share > 0.02 && share < 0.15, "{kind:?}: {share}");
        }
    }

    #[test]
    fn every_packet_decodes_at_the_makers_rates() {
        for kind in LidarKind::ALL {
            let sim = run(kind, still(20.0), 2.0, kind.sigma_m());
            let returns = decoded_returns(&sim.bytes).unwrap();
            // Every sample comes out of the library's decoder (an express capsule waits for
            // the next one: the last capsule's 32 stay in the reader).
            let held = if kind == LidarKind::RplidarExpress {
                32
            } else {
                0
            };
            assert_eq!(returns.len() as u64 + held, sim.samples, "{kind:?}");
            let expected = 2.0 * kind.sample_hz();
            let per_packet = kind.samples_per_packet() as f64;
            assert!(
                (sim.samples as f64 - expected).abs() <= per_packet + 12.0,
                "{kind:?}: {} samples in 2 s",
                sim.samples
            );
            // Revolutions: one start per turn (none before the first wrap).
            let turns = 2.0 * kind.rotation_hz();
            assert!(
                (sim.revolutions as f64 - turns).abs() <= 1.0,
                "{kind:?}: {} revolutions",
                sim.revolutions
            );
            // Echoes: what the simulator sent is what the decoder reads (all but the held
            // capsule's, which lie ahead on the floor at 20° of tilt).
            let echoes = returns.iter().filter(|r| r.1 != 0).count() as u64;
            assert!(echoes > 0 && echoes <= sim.echoes && echoes + held >= sim.echoes);
        }
    }

    /// The RPLIDAR's plausibility rule (`docs/lidars.md`) refuses no intact node: over the
    /// stairs while driving, on a nodding servo, panned, and standing still, with the
    /// sensor's noise, every sample the simulator sent comes out of the library's decoder
    /// with its angle and range, and the decoder counts none implausible.
    #[test]
    fn no_intact_rplidar_node_is_refused_as_implausible() {
        use terrain_pyramid::wire::recording::Reader;
        let spec = super::super::scene::StairsSpec::default();
        let actuators = [
            LidarActuator::servo(2.0, 35.0, 20.0, 0.0),
            LidarActuator::Pan {
                half_width_cdeg: 4_500,
                rate_cdeg_s: 7_500,
            },
            still(20.0),
        ];
        for actuator in actuators {
            let config = LidarSimConfig::new(
                Scene::stairs(spec),
                LidarKind::RplidarStandard,
                actuator,
                [0.0, 0.0, 1.0],
                Trajectory::approach(1.0, 0.5, spec.first_riser_x, 3.0),
            );
            let sim = simulate_lidar(&config).unwrap();
            let returns = decoded_returns(&sim.bytes).unwrap();
            assert_eq!(returns.len() as u64, sim.samples, "{actuator:?}");
            assert_eq!(
                returns.iter().filter(|r| r.1 != 0).count() as u64,
                sim.echoes,
                "{actuator:?}"
            );
            let mut decoder = LaserDecoder::new(LidarKind::RplidarStandard.sensor());
            for event in Reader::new(&sim.bytes).unwrap() {
                if let Payload::Laser(chunk) = event.unwrap().payload {
                    feed_packets(&mut decoder, chunk, |_| {});
                }
            }
            let counts = decoder.counts();
            assert_eq!(counts.implausible, 0, "{actuator:?}");
            assert_eq!(u64::from(counts.ok), sim.samples, "{actuator:?}");
        }
    }

    #[test]
    fn ld06_packets_are_12_points_375_a_second() {
        let sim = run(LidarKind::Ld19, still(20.0), 1.0, 0.0);
        // 47-byte packets, one event each (some split in two).
        assert_eq!(sim.laser_bytes, 47 * sim.packets);
        assert!((374..=377).contains(&sim.packets), "{}", sim.packets);
    }

    /// With no noise, a still tilt of 20° and a flat floor 1 m down, every decoded return
    /// lies on the floor: the decoded angle (the library's reading of the stream, including
    /// the X4's correction and the capsules' dθ) and range place it at z = 0 in f64.
    #[test]
    fn decoded_returns_lie_on_the_floor() {
        let tau = 20.0_f64.to_radians();
        for kind in LidarKind::ALL {
            let sim = run(kind, still(20.0), 1.2, 0.0);
            let returns = decoded_returns(&sim.bytes).unwrap();
            let mut echoes = 0;
            let mut worst = 0.0_f64;
            for (phi, r) in returns {
                if r == 0 {
                    continue;
                }
                echoes += 1;
                let z = 1.0 - f64::from(r) / 1000.0 * phi.to_radians().cos() * tau.sin();
                worst = worst.max(z.abs());
            }
            assert!(echoes > 100, "{kind:?}: {echoes}");
            // Range rounding (≤ 0.5 mm) and angle quantisation (1/64° at 12 m: ≈ 2 mm of z).
            assert!(worst < 0.004, "{kind:?}: {worst} m off the floor");
        }
    }

    #[test]
    fn the_servo_nods_through_the_librarys_model() {
        let act = LidarActuator::servo(-5.0, 35.0, 40.0, 20.0);
        let sim = run(LidarKind::Ld19, act, 4.0, 0.01);
        let angles = angle_events_deg(&sim.bytes).unwrap();
        // The 500 ms hold at min, then up to 35° in 1 s, down in 1 s, ...
        let lo = angles.iter().copied().fold(f64::MAX, f64::min);
        let hi = angles.iter().copied().fold(f64::MIN, f64::max);
        assert!((lo + 5.0).abs() < 0.01, "{lo}");
        assert!((hi - 35.0).abs() < 0.2, "{hi}");
        // At 375 angle events a second and 40 °/s, consecutive angles differ by ≤ 0.11°.
        let step = angles
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(step < 0.12, "{step}");
    }

    #[test]
    fn the_pan_mount_looks_down_at_90_degrees() {
        let act = LidarActuator::Pan {
            half_width_cdeg: 4500,
            rate_cdeg_s: 2000,
        };
        let sim = run(LidarKind::Ld06, act, 0.5, 0.0);
        assert_eq!(sim.setup.mount, MountKind::PannedVertical);
        let returns = decoded_returns(&sim.bytes).unwrap();
        // Straight down (90° on the panned mount) is the floor, 1 m away.
        let down: Vec<u32> = returns
            .iter()
            .filter(|(phi, _)| (phi - 90.0).abs() < 0.5)
            .map(|&(_, r)| r)
            .collect();
        assert!(!down.is_empty());
        assert!(down.iter().all(|&r| (999..=1001).contains(&r)), "{down:?}");
    }

    #[test]
    fn deterministic() {
        let a = run(LidarKind::YdlidarX4, still(10.0), 0.5, 0.01);
        let b = run(LidarKind::YdlidarX4, still(10.0), 0.5, 0.01);
        assert_eq!(a, b);
    }
}
