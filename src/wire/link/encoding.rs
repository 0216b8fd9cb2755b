//! Encoding into whole frames: each message's body written through the CRC and COBS
//! ([`encode`], [`encode_patch`] straight from a layer), after a check of what the format
//! cannot carry.

use super::cobs;
use super::crc::Crc32;
use super::map::PatchArea;
use super::message::{
    ClampRequest, GateRequest, Message, SnapshotScope, CONFIGURE_UNIFORM_RESOLUTION,
};
use super::setup::{LaserSetup, RuleSetup};
use super::{EncodeError, MessageType};

impl Message<'_> {
    /// Checks what the format cannot carry.
    fn check(&self) -> Result<(), EncodeError> {
        let invalid = |field| Err(EncodeError::Invalid { field });
        match self {
            Self::LayerPatch(p) => {
                p.area
                    .check()
                    .map_err(|field| EncodeError::Invalid { field })?;
                if p.cells.len() != p.area.cells() || !p.cells.as_bytes().len().is_multiple_of(2) {
                    return invalid("LayerPatch.cells");
                }
            }
            Self::WindowMoved(w) if w.is_empty() => return invalid("WindowMoved.mask"),
            Self::Decayed(d) if d.is_empty() => return invalid("Decayed.mask"),
            Self::Decayed(d) if !(1..=3).contains(&d.mode) => return invalid("Decayed.mode"),
            Self::Decayed(d) if d.iter().any(|(_, r)| r.rows == 0) => {
                return invalid("Decayed.rows")
            }
            Self::Configure(c) if c.decay_mode > 3 => return invalid("Configure.decay"),
            Self::RequestSnapshot(SnapshotScope::Layer(0xFF)) => {
                return invalid("RequestSnapshot.layer")
            }
            _ => {}
        }
        Ok(())
    }

    fn write_body(&self, w: &mut Writer<'_>) {
        match self {
            Self::Hello(h) => {
                w.u8(h.protocol);
                w.u8(h.firmware.major);
                w.u8(h.firmware.minor);
                w.u8(h.firmware.patch);
                w.u8(h.reason as u8);
                w.u8(u8::try_from(h.layers.len()).unwrap_or(u8::MAX));
                w.u16(h.cells_per_side);
                w.u32(h.resend);
                w.u8(h.clock.code());
                w.u8(0);
                w.u8(0);
                w.u8(0);
                for l in &h.layers {
                    w.i32(l.resolution_q16);
                    w.f32(l.band_inner_m);
                    w.f32(l.band_outer_m);
                    w.i32(l.origin_x);
                    w.i32(l.origin_y);
                }
            }
            Self::LayerPatch(p) => {
                w.patch_area(&p.area);
                w.bytes(p.cells.as_bytes());
            }
            Self::WindowMoved(m) => {
                w.u32(m.mask());
                for (_, (x, y)) in m.iter() {
                    w.i32(x);
                    w.i32(y);
                }
            }
            Self::Stats(s) => {
                for v in s.to_array() {
                    w.u32(v);
                }
            }
            Self::Reply(r) => {
                w.u16(r.to_seq);
                w.u8(r.to_type);
                w.u8(r.code as u8);
                w.u8(r.param);
                w.f32(r.value);
                w.f32(r.a);
                w.f32(r.b);
            }
            Self::Decayed(d) => {
                w.u8(d.mode);
                w.u32(d.mask());
                for (_, rows) in d.iter() {
                    w.u16(rows.first);
                    w.u16(rows.rows);
                    w.u32(rows.faded);
                }
            }
            Self::Pose(p) => {
                for v in [p.x_m, p.y_m, p.z_m, p.roll_rad, p.pitch_rad, p.yaw_rad] {
                    w.f32(v);
                }
                w.u32(p.stamp_us);
                w.u8(p.flags);
            }
            Self::PanAngle(p) => {
                w.u16(p.turns);
                w.u32(p.timestamp_ms);
            }
            Self::Configure(c) => {
                for v in [c.phi_rad, c.psi_rad, c.sigma_m, c.height_m, c.max_range_m] {
                    w.f32(v);
                }
                w.f32(c.base_m);
                w.f32(c.gamma);
                match c.gate {
                    GateRequest::Hard => {
                        w.u8(0);
                        w.f32(0.0);
                    }
                    GateRequest::Soft { width_factor } => {
                        w.u8(1);
                        w.f32(width_factor);
                    }
                }
                w.u16(c.cells_per_side);
                w.f32(c.p_obstacle);
                w.f32(c.p_free);
                w.f32(c.prior);
                match c.clamp {
                    ClampRequest::Off => {
                        w.u8(0);
                        w.f32(0.0);
                        w.f32(0.0);
                    }
                    ClampRequest::Bounds { min, max } => {
                        w.u8(1);
                        w.f32(min);
                        w.f32(max);
                    }
                }
                w.f32(c.fused_margin);
                w.u8(if c.uniform_resolution {
                    CONFIGURE_UNIFORM_RESOLUTION
                } else {
                    0
                });
                w.u8(c.decay_mode);
                w.bytes(&c.decay_tau);
            }
            Self::Reset
            | Self::Ping
            | Self::RequestStats
            | Self::Shutdown
            | Self::EndObservation => {}
            Self::Setup(s) => {
                w.u8(s.mount);
                w.u8(s.measuring_mode);
                w.u16(s.field_deg);
                w.u16(s.resolution_cdeg);
                for v in s.sensor_m {
                    w.f32(v);
                }
                w.u32(s.lines_per_observation);
                for v in [
                    s.robot_height_m,
                    s.step_threshold_m,
                    s.drop_threshold_m,
                    s.ceiling_m,
                ] {
                    w.f32(v);
                }
                w.rule_setup(&s.rule);
                w.laser_setup(&s.laser);
                let m = &s.mount_block;
                w.u8(m.axis);
                w.bytes(&m.sense.to_le_bytes());
                w.u16(0);
                w.f32(m.zero_deg);
                for v in m.rpy_deg {
                    w.f32(v);
                }
                let f = &s.filter;
                w.u16(f.min_range_cm);
                w.u16(f.max_range_cm);
                w.u8(f.min_quality);
                w.u8(f.sector_count);
                for (a, b) in f.sectors {
                    w.u16(a);
                    w.u16(b);
                }
            }
            Self::SetRule(s) => {
                w.f32(s.step_threshold_m);
                w.rule_setup(&s.rule);
            }
            Self::TimeRequest(t) => w.bytes(&t.to_le_bytes()),
            Self::TimeReply(t) => w.bytes(&t.to_le_bytes()),
            Self::Observed(o) => w.bytes(&o.to_le_bytes()),
            Self::RequestSnapshot(scope) => w.u8(match *scope {
                SnapshotScope::All => 0xFF,
                SnapshotScope::Layer(k) => k,
            }),
        }
    }
}

/// Writes a frame: header and body through the CRC and COBS, then the CRC, then the delimiter.
struct Writer<'a> {
    cobs: cobs::Encoder<'a>,
    crc: Crc32,
}

impl<'a> Writer<'a> {
    fn new(out: &'a mut [u8], msg_type: MessageType, seq: u16) -> Self {
        let mut w = Self {
            cobs: cobs::Encoder::new(out),
            crc: Crc32::new(),
        };
        w.u8(super::VERSION);
        w.u8(msg_type.to_u8());
        w.u16(seq);
        w
    }
    fn bytes(&mut self, bytes: &[u8]) {
        self.crc.update(bytes);
        self.cobs.push_all(bytes);
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }
    fn rule_setup(&mut self, r: &RuleSetup) {
        self.u8(r.rule);
        for v in [
            r.max_grade,
            r.residual_m,
            r.range_sigma_m,
            r.angle_sigma_rad,
            r.noise_factor,
        ] {
            self.f32(v);
        }
        self.u8(r.pair_depth);
    }
    fn laser_setup(&mut self, l: &LaserSetup) {
        self.u8(l.sensor);
        self.u8(l.actuator);
        self.u32(l.baud);
        for v in [
            l.servo_min_deg,
            l.servo_max_deg,
            l.servo_rate_deg_s,
            l.servo_latency_ms,
        ] {
            self.f32(v);
        }
    }
    fn patch_area(&mut self, a: &PatchArea) {
        self.u8(a.layer);
        self.u8(a.width);
        self.u8(a.height);
        self.i32(a.origin_x);
        self.i32(a.origin_y);
        self.i32(a.x);
        self.i32(a.y);
    }
    fn finish(mut self, got: usize) -> Result<usize, EncodeError> {
        let crc = self.crc.finish();
        self.cobs.push_all(&crc.to_le_bytes());
        self.cobs
            .finish()
            .map_err(|needed| EncodeError::BufferTooSmall { needed, got })
    }
}

/// Encodes `message` with sequence number `seq` into `out` as one complete frame: COBS, CRC,
/// trailing `0x00`. Returns the bytes written.
///
/// # Errors
/// A field the format cannot carry, or `out` too small (nothing usable is written then).
pub fn encode(seq: u16, message: &Message<'_>, out: &mut [u8]) -> Result<usize, EncodeError> {
    message.check()?;
    let got = out.len();
    let mut w = Writer::new(out, message.msg_type(), seq);
    message.write_body(&mut w);
    w.finish(got)
}

/// Encodes a LayerPatch whose cells come from `cell(column, row)` (raw Q8.8, row 0 = lowest
/// y), without an intermediate buffer: the device writes straight from its layer.
///
/// # Errors
/// A field the format cannot carry, or `out` too small.
pub fn encode_patch(
    seq: u16,
    area: &PatchArea,
    mut cell: impl FnMut(u8, u8) -> i16,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    area.check()
        .map_err(|field| EncodeError::Invalid { field })?;
    let got = out.len();
    let mut w = Writer::new(out, MessageType::LayerPatch, seq);
    w.patch_area(area);
    for row in 0..area.height {
        for col in 0..area.width {
            w.bytes(&cell(col, row).to_le_bytes());
        }
    }
    w.finish(got)
}
