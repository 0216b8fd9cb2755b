//! From rays to the sensor's bytes: the ray-caster (each sample's direction from the
//! sensor, mount, sweep and pose, its true range in the scene, the range the sensor reports)
//! and the samples packed into the packets (and descriptors) each sensor sends, appended to
//! a recording as events.
use super::mount::{mat3, rot, Sweep};
use super::{LidarKind, LidarSimConfig, TrueHit};
use crate::sim::record::SimError;
use crate::sim::rng::Rng;
use crate::sim::scene::Ray;
use crate::sim::trajectory::Pose;
use core::fmt;
use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
use terrain_pyramid::wire::recording::MountKind;
use terrain_pyramid::wire::rplidar::{RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarNodeRepr};
use terrain_pyramid::wire::ydlidar::{YdlidarDescriptorRepr, YdlidarError, YdlidarRepr};

/// One measured sample.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    t: f64,
    /// The clockwise angle on the wire (first-level for the X4, uncompensated for a capsule),
    /// degrees in [0, 360).
    wire_deg: f64,
    /// The range in the sensor's units (mm; mm·4 for RPLIDAR nodes and the X4), 0 = none.
    units: u32,
    /// The capsule's dθ, degrees·8 (express only).
    dtheta_q3: u8,
}

/// The ray-caster: sensor geometry, sweep, noise.
pub(super) struct Caster<'a> {
    pub(super) config: &'a LidarSimConfig,
    pub(super) sweep: Sweep,
    pub(super) rng: Rng,
    pub(super) pose: Pose,
    /// The point the last cast met, world metres.
    pub(super) last_point: Option<[f64; 3]>,
    /// The returns kept for the configuration's hit box.
    pub(super) hits: Vec<TrueHit>,
}

impl Caster<'_> {
    /// The true range along clockwise angle `phi_deg` at time `t`, metres (`None`: no echo).
    fn true_range(&mut self, t: f64, phi_deg: f64) -> Option<f64> {
        let a = self.sweep.angle_deg(t).to_radians();
        let theta = (90.0 - phi_deg).to_radians();
        let (s, c) = theta.sin_cos();
        let (sa, ca) = a.sin_cos();
        let d = match (self.config.rig, self.config.actuator.mount_kind()) {
            (None, MountKind::PannedVertical) => [s * ca, s * sa, -c],
            (None, MountKind::TiltedHorizontal) => [s * ca, -c, -s * sa],
            (Some(rig), kind) => {
                let axis = match kind {
                    MountKind::PannedVertical => 2,
                    MountKind::TiltedHorizontal => 1,
                };
                let m = mat3(&rot(axis, a), &rig.rotation());
                let v = [s, -c, 0.0];
                core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
            }
        };
        let pose = if self.config.sample_poses {
            self.config.trajectory.pose_at(t, &self.config.scene)
        } else {
            self.pose
        };
        let r = pose.rotation();
        let dir = core::array::from_fn(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]);
        let origin = pose.to_world(self.config.position_m);
        let (_, max) = self.config.kind.range_m();
        let hit = self.config.scene.cast(&Ray { origin, dir }, max);
        self.last_point = hit.map(|h| core::array::from_fn(|i| origin[i] + h.t * dir[i]));
        hit.map(|h| h.t)
    }

    /// Keeps the last cast's point when the configuration's hit box holds it.
    fn keep_hit(&mut self, t: f64, truth: Option<f64>) {
        if let (Some(hit_box), Some(_), Some(p)) = (self.config.hit_box, truth, self.last_point) {
            if hit_box.contains(p) {
                self.hits.push(TrueHit { t_s: t, point_m: p });
            }
        }
    }

    /// A measured range in `per_m` units per metre, 0 for none or below the minimum.
    fn measure(&mut self, truth: Option<f64>, per_m: f64, max_units: u32) -> u32 {
        let Some(t) = truth else {
            return 0;
        };
        let (min, _) = self.config.kind.range_m();
        let m = t + self.config.sigma_m * self.rng.gaussian();
        if m < min {
            return 0;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let u = (m * per_m).round() as u32;
        u.min(max_units)
    }

    /// Measures sample `n`.
    fn sample(&mut self, n: u64) -> Sample {
        let kind = self.config.kind;
        #[allow(clippy::cast_precision_loss)]
        let t = n as f64 / kind.sample_hz();
        let wire_deg = (360.0 * kind.rotation_hz() * t).rem_euclid(360.0);
        match kind {
            LidarKind::Ld06 | LidarKind::Ld19 => {
                let truth = self.true_range(t, wire_deg);
                self.keep_hit(t, truth);
                let units = self.measure(truth, 1000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3: 0,
                }
            }
            LidarKind::RplidarStandard => {
                // The node's angle is quantised to 1/64°: cast along what a reader sees.
                let q6 = (wire_deg * 64.0).round().rem_euclid(23_040.0);
                let truth = self.true_range(t, q6 / 64.0);
                self.keep_hit(t, truth);
                let units = self.measure(truth, 4000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg: q6 / 64.0,
                    units,
                    dtheta_q3: 0,
                }
            }
            LidarKind::RplidarExpress => {
                #[allow(clippy::cast_possible_truncation)]
                let dtheta_q3 = (n % 4) as u8;
                let phi = (wire_deg - f64::from(dtheta_q3) / 8.0).rem_euclid(360.0);
                let truth = self.true_range(t, phi);
                self.keep_hit(t, truth);
                let units = self.measure(truth, 1000.0, 0x3FFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3,
                }
            }
            LidarKind::YdlidarX4 => {
                // The true direction is the first-level angle plus the correction of the
                // distance it gives: iterate from the first-level angle.
                let mut truth = self.true_range(t, wire_deg);
                for _ in 0..3 {
                    let Some(d) = truth else { break };
                    let corr = ydlidar_correction_deg(d * 1000.0);
                    truth = self.true_range(t, wire_deg + corr);
                }
                self.keep_hit(t, truth);
                let units = self.measure(truth, 4000.0, 0xFFFF);
                Sample {
                    t,
                    wire_deg,
                    units,
                    dtheta_q3: 0,
                }
            }
        }
    }
}

/// The X4's second-level correction of a distance in mm, degrees (the manual's formula).
#[must_use]
pub fn ydlidar_correction_deg(d_mm: f64) -> f64 {
    if d_mm <= 0.0 {
        return 0.0;
    }
    (21.8 * (155.3 - d_mm) / (155.3 * d_mm)).atan().to_degrees()
}

/// One unit of bytes the sensor sends: a packet (or a descriptor) and its samples.
pub(super) struct Sent {
    pub(super) bytes: Vec<u8>,
    /// The time its last byte left the sensor... plus the transmission: its arrival, s.
    pub(super) arrival_s: f64,
    /// The samples it carries (their measurement times).
    pub(super) sample_times: Vec<f64>,
    /// Its samples with an echo.
    pub(super) echoes: u64,
    pub(super) starts_revolution: bool,
}

/// Degrees to 0.01° on the wire, 0 ..= 35 999.
fn centideg(deg: f64) -> u16 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = ((deg * 100.0).round() as u32) % 36_000;
    #[allow(clippy::cast_possible_truncation)]
    let v = v as u16;
    v
}

/// Degrees to degrees·64 on the wire, 0 ..= 23 039.
fn q6(deg: f64) -> u16 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = ((deg * 64.0).round() as u32) % 23_040;
    #[allow(clippy::cast_possible_truncation)]
    let v = v as u16;
    v
}

fn u16_units(v: u32) -> u16 {
    u16::try_from(v).unwrap_or(u16::MAX)
}

/// The sensor's packets, one at a time.
pub(super) struct Packets<'a> {
    pub(super) caster: Caster<'a>,
    pub(super) next_sample: u64,
    /// The X4's or the capsule's sample held back (the next capsule's first).
    pub(super) pending: Vec<Sample>,
    pub(super) byte_s: f64,
    pub(super) header_sent: bool,
    pub(super) last_deg: f64,
}

impl Packets<'_> {
    /// The time of the next sample to be measured, s.
    pub(super) fn next_time(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let t = self.next_sample as f64 / self.caster.config.kind.sample_hz();
        t
    }

    fn take_sample(&mut self) -> Sample {
        let s = self.caster.sample(self.next_sample);
        self.next_sample += 1;
        s
    }

    fn sent(&self, bytes: Vec<u8>, samples: &[Sample], starts: bool) -> Sent {
        let last_t = samples.last().map_or(0.0, |s| s.t);
        #[allow(clippy::cast_precision_loss)]
        let tx = bytes.len() as f64 * self.byte_s;
        Sent {
            arrival_s: last_t + tx,
            sample_times: samples.iter().map(|s| s.t).collect(),
            echoes: samples.iter().filter(|s| s.units != 0).count() as u64,
            bytes,
            starts_revolution: starts,
        }
    }

    /// Whether the head passed 0° since the previous sample.
    fn wrapped(&mut self, deg: f64) -> bool {
        let w = deg < self.last_deg;
        self.last_deg = deg;
        w
    }

    pub(super) fn next_packet(&mut self) -> Result<Sent, SimError> {
        let kind = self.caster.config.kind;
        let err = |e: &dyn fmt::Debug| SimError(format!("emit: {e:?}"));
        if !self.header_sent {
            self.header_sent = true;
            let mut buf = vec![0_u8; 7];
            let n = match kind {
                LidarKind::Ld06 | LidarKind::Ld19 => 0,
                LidarKind::RplidarStandard => RplidarDescriptorRepr::SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
                LidarKind::RplidarExpress => RplidarDescriptorRepr::EXPRESS_SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
                LidarKind::YdlidarX4 => YdlidarDescriptorRepr::SCAN
                    .emit(&mut buf)
                    .map_err(|e| err(&e))?,
            };
            if n > 0 {
                buf.truncate(n);
                return Ok(self.sent(buf, &[], false));
            }
        }
        match kind {
            LidarKind::Ld06 | LidarKind::Ld19 => {
                let samples: Vec<Sample> = (0..12).map(|_| self.take_sample()).collect();
                let mut starts = false;
                let mut points = [Ld06Point::default(); 12];
                for (p, s) in points.iter_mut().zip(&samples) {
                    starts |= self.wrapped(s.wire_deg);
                    p.distance_mm = u16_units(s.units);
                    p.intensity = if s.units == 0 { 0 } else { 200 };
                }
                let first = samples.first().map_or(0.0, |s| s.wire_deg);
                let last = samples.last().map_or(0.0, |s| s.wire_deg);
                let t = samples.first().map_or(0.0, |s| s.t);
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let repr = Ld06Repr {
                    speed_deg_per_s: (360.0 * kind.rotation_hz()).round() as u16,
                    start_angle_centideg: centideg(first),
                    end_angle_centideg: centideg(last),
                    timestamp_ms: ((t * 1000.0).round() as u64 % 30_000) as u16,
                    points,
                };
                let mut buf = vec![0_u8; repr.buffer_len()];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &samples, starts))
            }
            LidarKind::RplidarStandard => {
                let s = self.take_sample();
                let start = self.wrapped(s.wire_deg);
                let repr = RplidarNodeRepr {
                    quality: if s.units == 0 { 0 } else { 47 },
                    start,
                    angle_q6: q6(s.wire_deg),
                    distance_q2: u16_units(s.units),
                };
                let mut buf = vec![0_u8; 5];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &[s], start))
            }
            LidarKind::RplidarExpress => {
                // A capsule is sent when its 32 samples are measured; its angles are read with
                // the next capsule's start angle (the reader waits for it).
                let samples: Vec<Sample> = (0..32).map(|_| self.take_sample()).collect();
                let mut starts = false;
                let mut repr = RplidarCapsuleRepr {
                    start_angle_q6: samples.first().map_or(0, |s| q6(s.wire_deg)),
                    ..RplidarCapsuleRepr::default()
                };
                for (k, s) in samples.iter().enumerate() {
                    starts |= self.wrapped(s.wire_deg);
                    if let (Some(d), Some(o)) = (
                        repr.distances_mm.get_mut(k),
                        repr.angle_offsets_q3.get_mut(k),
                    ) {
                        *d = u16_units(s.units);
                        *o = s.dtheta_q3;
                    }
                }
                // S marks the first capsule of the stream only (the SDK resets its pairing
                // there); a revolution starts where the angles pass 360°.
                repr.start_flag = self.next_sample == 32;
                let mut buf = vec![0_u8; repr.buffer_len()];
                repr.emit(&mut buf).map_err(|e| err(&e))?;
                Ok(self.sent(buf, &samples, starts))
            }
            LidarKind::YdlidarX4 => {
                // A revolution begins with its start packet (one sample); then up to 40
                // samples, cut where the head passes 0°.
                let mut samples = std::mem::take(&mut self.pending);
                if samples.is_empty() {
                    let s = self.take_sample();
                    samples.push(s);
                }
                let first_wraps = samples.first().is_some_and(|s| s.wire_deg < self.last_deg);
                if first_wraps {
                    if let Some(s) = samples.first() {
                        self.last_deg = s.wire_deg;
                    }
                    return self.x4_packet(&samples, true);
                }
                if let Some(s) = samples.first() {
                    self.last_deg = s.wire_deg;
                }
                while samples.len() < 40 {
                    let s = self.take_sample();
                    if s.wire_deg < self.last_deg {
                        self.pending.push(s);
                        break;
                    }
                    self.last_deg = s.wire_deg;
                    samples.push(s);
                }
                self.x4_packet(&samples, false)
            }
        }
    }

    fn x4_packet(&self, samples: &[Sample], start: bool) -> Result<Sent, SimError> {
        let raw: Vec<u16> = samples.iter().map(|s| u16_units(s.units)).collect();
        let buf = ydlidar_packet_bytes(
            u8::from(start),
            samples.first().map_or(0, |s| q6(s.wire_deg)),
            samples.last().map_or(0, |s| q6(s.wire_deg)),
            &raw,
        )
        .map_err(|e| SimError(format!("emit: {e:?}")))?;
        Ok(self.sent(buf, samples, start))
    }
}

/// One YDLIDAR X4 packet as the sensor sends it (`AA 55`, CT, LSN, FSA, LSA, checksum, the
/// samples): CT `packet_type` (bit 0: a revolution's start packet), the first and last
/// first-level angles in 1/64° (≤ 0x7FFF), and 1 to 255 samples in mm·4, as the wire carries
/// them.
///
/// # Errors
/// The library's emitter's: no samples, more than 255, or an angle over 0x7FFF.
pub fn ydlidar_packet_bytes(
    packet_type: u8,
    first_angle_q6: u16,
    last_angle_q6: u16,
    samples: &[u16],
) -> Result<Vec<u8>, YdlidarError> {
    let repr = YdlidarRepr {
        packet_type,
        first_angle_q6,
        last_angle_q6,
        samples,
    };
    let mut bytes = vec![0_u8; repr.buffer_len()];
    repr.emit(&mut bytes)?;
    Ok(bytes)
}
