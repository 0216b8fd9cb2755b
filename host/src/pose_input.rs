//! The robot's poses for `pyramid listen`: where they come from (ROS 2 Odometry, or
//! newline-delimited JSON over UDP), how their stamps reach the device's clock, and which are
//! forwarded. `docs/poses.md` is the user's description.
//!
//! # The path of one pose
//! 1. A source thread ([`spawn_udp`], [`spawn_odometry`]) reads it and sends a [`PoseInput`]
//!    (or the reason a line was bad) down a channel: the sources never hold up the reader of
//!    the device's link.
//! 2. Its stamp is the host's wall clock (ROS time: seconds since the Unix epoch). The
//!    [`WallAnchor`] maps it to the host's monotonic clock (the clock the time exchanges are
//!    timed with), tracking `wall − monotonic`; a change of that by more than
//!    [`MAX_WALL_STEP_US`] is a jump of the host's clock (counted; the anchor moves to it).
//! 3. The [`PoseForwarder`] checks it (finite and in the device's ranges; not older than the
//!    newest; not older than [`MAX_POSE_AGE_US`]; not ahead by more than [`MAX_POSE_LEAD_US`];
//!    the clock mapping known) and keeps the newest per [`FORWARD_PERIOD_US`]; each forwarded
//!    pose carries its stamp in the device's µs ([`crate::clock_sync::ClockSync::to_device`]).
//!    Every pose dropped is counted by its reason ([`PoseCounters`]), none is applied.
use crate::clock_sync::ClockSync;
use serde::{Deserialize, Serialize};

/// At most one pose is forwarded per this period, host µs (100 Hz): the newest within it.
pub const FORWARD_PERIOD_US: u64 = 10_000;

/// A pose older than this when it arrives is stale and dropped, µs (2 s).
pub const MAX_POSE_AGE_US: u64 = 2_000_000;

/// A pose stamped more than this ahead of the host's clock is dropped, µs (1 s, the device's
/// own bound on a pose's lead).
pub const MAX_POSE_LEAD_US: u64 = 1_000_000;

/// Consecutive forwarded poses further apart than this are counted as a gap, µs (500 ms: the
/// device restarts its pose track there).
pub const POSE_GAP_US: u64 = 500_000;

/// A change of `wall − monotonic` by more than this is a jump of the host's clock, µs (100 ms).
pub const MAX_WALL_STEP_US: i64 = 100_000;

/// The UDP input's port when `--pose-udp` is given without an address.
pub const DEFAULT_POSE_UDP_ADDR: &str = "127.0.0.1:7420";

// ------------------------------------------------------------------ the input

/// One pose as a source gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseInput {
    /// When the robot was there: the host's wall clock (ROS time), ns since the Unix epoch.
    pub stamp_ns: i128,
    /// The frame the pose is in (`odom`, …); empty when the source did not say.
    pub frame: String,
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z, metres.
    pub z: f64,
    /// Roll about x, radians.
    pub roll: f64,
    /// Pitch about y, radians.
    pub pitch: f64,
    /// Yaw about z, radians, counter-clockwise from +x.
    pub yaw: f64,
}

/// Why an input line or message was refused before it became a pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BadInput {
    /// Not a JSON object (or not UTF-8).
    NotJson,
    /// A field missing or of the wrong type (`t`, `x`, `y`, …), or both or neither of the
    /// angles and the quaternion.
    Fields,
    /// A number not finite (an Odometry's NaN; in JSON, which has no such numbers, a value
    /// out of f64's range such as `1e999` is not JSON), or a `t` beyond ±10¹² s.
    NotFinite,
    /// A quaternion whose norm is not within 10 % of 1 (a zero or garbage orientation).
    Quaternion,
}

/// What a source sends down the channel.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceEvent {
    /// A pose.
    Pose(PoseInput),
    /// An input refused, and why.
    Bad(BadInput),
}

/// Roll, pitch and yaw (radians; REP-103: fixed axes x, y, z, i.e. `R = Rz(yaw) Ry(pitch)
/// Rx(roll)`) of the unit quaternion `(x, y, z, w)`; `None` when a component is not finite or
/// the norm is not within 10 % of 1 (the quaternion is normalised first).
#[must_use]
pub fn quaternion_to_rpy(x: f64, y: f64, z: f64, w: f64) -> Option<(f64, f64, f64)> {
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    if !norm.is_finite() || (norm - 1.0).abs() > 0.1 {
        return None;
    }
    let (x, y, z, w) = (x / norm, y / norm, z / norm, w / norm);
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    Some((roll, pitch, yaw))
}

/// One line of the UDP input (`docs/poses.md`).
#[derive(Deserialize)]
struct Line {
    t: f64,
    #[serde(default)]
    frame: Option<String>,
    x: f64,
    y: f64,
    #[serde(default)]
    z: Option<f64>,
    roll: Option<f64>,
    pitch: Option<f64>,
    yaw: Option<f64>,
    qx: Option<f64>,
    qy: Option<f64>,
    qz: Option<f64>,
    qw: Option<f64>,
}

/// Parses one line of the UDP input: a JSON object with `t` (seconds since the Unix epoch),
/// optionally `frame`, `x`, `y`, optionally `z` (0), and either `yaw` (with optional `roll`,
/// `pitch`, 0) or all of `qx`, `qy`, `qz`, `qw`.
///
/// # Errors
/// Why the line is refused ([`BadInput`]).
pub fn parse_line(line: &str) -> Result<PoseInput, BadInput> {
    let value: serde_json::Value = serde_json::from_str(line).map_err(|_| BadInput::NotJson)?;
    if !value.is_object() {
        return Err(BadInput::NotJson);
    }
    let l: Line = serde_json::from_value(value).map_err(|_| BadInput::Fields)?;
    let angles = l.roll.is_some() || l.pitch.is_some() || l.yaw.is_some();
    let quaternion = [l.qx, l.qy, l.qz, l.qw];
    let any_q = quaternion.iter().any(Option::is_some);
    let (roll, pitch, yaw) = match (angles, any_q) {
        (true, false) => {
            let yaw = l.yaw.ok_or(BadInput::Fields)?;
            (l.roll.unwrap_or(0.0), l.pitch.unwrap_or(0.0), yaw)
        }
        (false, true) => {
            let [Some(qx), Some(qy), Some(qz), Some(qw)] = quaternion else {
                return Err(BadInput::Fields);
            };
            if ![qx, qy, qz, qw].iter().all(|v| v.is_finite()) {
                return Err(BadInput::NotFinite);
            }
            quaternion_to_rpy(qx, qy, qz, qw).ok_or(BadInput::Quaternion)?
        }
        _ => return Err(BadInput::Fields),
    };
    let z = l.z.unwrap_or(0.0);
    if ![l.t, l.x, l.y, z, roll, pitch, yaw]
        .iter()
        .all(|v| v.is_finite())
    {
        return Err(BadInput::NotFinite);
    }
    // Seconds to ns, whole seconds apart so that the fraction keeps f64's precision
    // (0.24 µs at today's epoch seconds); |t| ≤ 1e12 s keeps it far inside i128.
    if l.t.abs() > 1e12 {
        return Err(BadInput::NotFinite);
    }
    let whole = l.t.trunc();
    #[allow(clippy::cast_possible_truncation)]
    let stamp_ns = whole as i128 * 1_000_000_000 + ((l.t - whole) * 1e9).round() as i128;
    Ok(PoseInput {
        stamp_ns,
        frame: l.frame.unwrap_or_default(),
        x: l.x,
        y: l.y,
        z,
        roll,
        pitch,
        yaw,
    })
}

/// The pose of a `nav_msgs/msg/Odometry`: its header's stamp and frame, `pose.pose`'s
/// position and orientation (as roll, pitch, yaw).
///
/// # Errors
/// A position not finite, or an orientation that is not a unit quaternion.
pub fn odometry_pose(odometry: &crate::publish::ros_msgs::Odometry) -> Result<PoseInput, BadInput> {
    let p = odometry.pose.pose.position;
    let q = odometry.pose.pose.orientation;
    if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w]
        .iter()
        .all(|v| v.is_finite())
    {
        return Err(BadInput::NotFinite);
    }
    let (roll, pitch, yaw) = quaternion_to_rpy(q.x, q.y, q.z, q.w).ok_or(BadInput::Quaternion)?;
    let stamp = odometry.header.stamp;
    Ok(PoseInput {
        stamp_ns: i128::from(stamp.sec) * 1_000_000_000 + i128::from(stamp.nanosec),
        frame: odometry.header.frame_id.clone(),
        x: p.x,
        y: p.y,
        z: p.z,
        roll,
        pitch,
        yaw,
    })
}

// ------------------------------------------------------------------ the host's two clocks

/// The host's wall clock against its monotonic clock: `wall − monotonic`, followed as it
/// slews (NTP), re-anchored when it jumps by more than [`MAX_WALL_STEP_US`] (counted).
#[derive(Debug, Clone, Copy, Default)]
pub struct WallAnchor {
    offset_us: Option<i128>,
    jumps: u64,
}

impl WallAnchor {
    /// No reading yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes one reading of both clocks: the wall clock (µs since the Unix epoch) and the
    /// monotonic one (µs, the session's origin). Returns whether it was a jump.
    pub fn observe(&mut self, wall_us: i128, monotonic_us: u64) -> bool {
        let offset = wall_us - i128::from(monotonic_us);
        let jumped = self
            .offset_us
            .is_some_and(|o| (offset - o).abs() > i128::from(MAX_WALL_STEP_US));
        if jumped {
            self.jumps = self.jumps.saturating_add(1);
        }
        self.offset_us = Some(offset);
        jumped
    }

    /// Jumps seen.
    #[must_use]
    pub fn jumps(&self) -> u64 {
        self.jumps
    }

    /// The monotonic time (µs) of wall time `wall_us` (µs since the Unix epoch); `None`
    /// before the first reading or before the monotonic origin.
    #[must_use]
    pub fn to_monotonic(&self, wall_us: i128) -> Option<u64> {
        u64::try_from(wall_us - self.offset_us?).ok()
    }

    /// The wall time (µs since the Unix epoch) of monotonic time `monotonic_us`; `None`
    /// before the first reading.
    #[must_use]
    pub fn to_wall(&self, monotonic_us: u64) -> Option<i128> {
        Some(i128::from(monotonic_us) + self.offset_us?)
    }
}

// ------------------------------------------------------------------ forwarding

/// A pose ready for the device: in its ranges, f32 as the wire carries it, stamped in the
/// device's µs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DevicePose {
    /// x, metres; |x| < 30 000.
    pub x: f32,
    /// y, metres; |y| < 30 000.
    pub y: f32,
    /// z, metres; |z| < 1 000.
    pub z: f32,
    /// Roll, radians; |v| < 32 768.
    pub roll: f32,
    /// Pitch, radians; |v| < 32 768.
    pub pitch: f32,
    /// Yaw, radians; |v| < 32 768.
    pub yaw: f32,
    /// The device's clock (wrapping µs) when the robot was there.
    pub stamp_us: u32,
    /// The same moment on the host's monotonic clock, µs.
    pub host_us: u64,
}

/// What became of the poses, by reason. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct PoseCounters {
    /// Poses received from the sources (good or not).
    pub received: u64,
    /// Poses forwarded to the device.
    pub forwarded: u64,
    /// Replaced by a newer one within the same [`FORWARD_PERIOD_US`] (the rate limit).
    pub coalesced: u64,
    /// Input lines or messages refused before parsing into a pose: not JSON.
    pub bad_not_json: u64,
    /// … a field missing or of the wrong type.
    pub bad_fields: u64,
    /// … a number not finite.
    pub bad_not_finite: u64,
    /// … a quaternion not of unit norm.
    pub bad_quaternion: u64,
    /// A field outside the device's ranges (|x|, |y| < 30 km, |z| < 1 km, angles < 32 768).
    pub out_of_range: u64,
    /// Not newer than the newest pose taken.
    pub out_of_order: u64,
    /// Older than [`MAX_POSE_AGE_US`] on arrival.
    pub stale: u64,
    /// Stamped more than [`MAX_POSE_LEAD_US`] ahead of the host's clock.
    pub from_future: u64,
    /// Arrived while the clock mapping was not known (after connecting or a device boot).
    pub unsynced: u64,
    /// In another frame than the first pose's.
    pub other_frame: u64,
    /// Forwarded poses more than [`POSE_GAP_US`] after the previous one.
    pub gaps: u64,
    /// Jumps of the host's wall clock ([`WallAnchor`]).
    pub clock_jumps: u64,
}

impl PoseCounters {
    /// Every pose or line dropped, whatever the reason (coalesced ones are not dropped for a
    /// fault and not included).
    #[must_use]
    pub fn dropped(&self) -> u64 {
        [
            self.bad_not_json,
            self.bad_fields,
            self.bad_not_finite,
            self.bad_quaternion,
            self.out_of_range,
            self.out_of_order,
            self.stale,
            self.from_future,
            self.unsynced,
            self.other_frame,
        ]
        .iter()
        .fold(0_u64, |a, &b| a.saturating_add(b))
    }

    /// The counters as (name, value) pairs, in a fixed order, for reports.
    #[must_use]
    pub fn named(&self) -> [(&'static str, u64); 15] {
        [
            ("received", self.received),
            ("forwarded", self.forwarded),
            ("coalesced", self.coalesced),
            ("bad_not_json", self.bad_not_json),
            ("bad_fields", self.bad_fields),
            ("bad_not_finite", self.bad_not_finite),
            ("bad_quaternion", self.bad_quaternion),
            ("out_of_range", self.out_of_range),
            ("out_of_order", self.out_of_order),
            ("stale", self.stale),
            ("from_future", self.from_future),
            ("unsynced", self.unsynced),
            ("other_frame", self.other_frame),
            ("gaps", self.gaps),
            ("clock_jumps", self.clock_jumps),
        ]
    }
}

fn bump(n: &mut u64) {
    *n = n.saturating_add(1);
}

/// A pose taken, waiting for its period.
#[derive(Debug, Clone)]
struct Pending {
    host_us: u64,
    input: PoseInput,
}

/// Checks poses, keeps the newest per period, and stamps them in the device's clock. Pure
/// logic: the caller gives the clocks.
#[derive(Debug, Clone, Default)]
pub struct PoseForwarder {
    pending: Option<Pending>,
    /// The newest stamp taken (host monotonic µs).
    newest_us: Option<u64>,
    /// The last forwarded pose's stamp.
    last_forwarded_us: Option<u64>,
    /// When the last pose was forwarded (host monotonic µs, the caller's clock).
    last_sent_at: Option<u64>,
    frame: Option<String>,
    counters: PoseCounters,
}

impl PoseForwarder {
    /// Nothing taken yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The counters.
    #[must_use]
    pub fn counters(&self) -> PoseCounters {
        self.counters
    }

    /// The poses' frame: the first named one taken; `None` before.
    #[must_use]
    pub fn frame(&self) -> Option<&str> {
        self.frame.as_deref()
    }

    /// Counts a jump of the host's clock (the caller's [`WallAnchor`] saw it).
    pub fn count_clock_jump(&mut self) {
        bump(&mut self.counters.clock_jumps);
    }

    /// Takes one event of a source at monotonic time `now_us`, with the clocks as they stand:
    /// counted, and kept as the pending pose if it passes.
    pub fn take(&mut self, event: SourceEvent, now_us: u64, wall: &WallAnchor, clock: &ClockSync) {
        let c = &mut self.counters;
        bump(&mut c.received);
        let input = match event {
            SourceEvent::Pose(p) => p,
            SourceEvent::Bad(reason) => {
                bump(match reason {
                    BadInput::NotJson => &mut c.bad_not_json,
                    BadInput::Fields => &mut c.bad_fields,
                    BadInput::NotFinite => &mut c.bad_not_finite,
                    BadInput::Quaternion => &mut c.bad_quaternion,
                });
                return;
            }
        };
        if !in_device_ranges(&input) {
            bump(&mut c.out_of_range);
            return;
        }
        let Some(host_us) = wall.to_monotonic(input.stamp_ns.div_euclid(1_000)) else {
            bump(&mut c.stale);
            return;
        };
        if now_us.saturating_sub(host_us) > MAX_POSE_AGE_US {
            bump(&mut c.stale);
            return;
        }
        if host_us.saturating_sub(now_us) > MAX_POSE_LEAD_US {
            bump(&mut c.from_future);
            return;
        }
        if self.newest_us.is_some_and(|n| host_us <= n) {
            bump(&mut c.out_of_order);
            return;
        }
        if !input.frame.is_empty() {
            match &self.frame {
                Some(f) if *f != input.frame => {
                    bump(&mut c.other_frame);
                    return;
                }
                Some(_) => {}
                None => self.frame = Some(input.frame.clone()),
            }
        }
        if !clock.is_synced() {
            bump(&mut c.unsynced);
            return;
        }
        self.newest_us = Some(host_us);
        if self.pending.replace(Pending { host_us, input }).is_some() {
            bump(&mut c.coalesced);
        }
    }

    /// The pose to send now, if one is pending and the last was sent at least
    /// [`FORWARD_PERIOD_US`] before `now_us`; stamped through `clock` (a pose pending when the
    /// mapping was lost is dropped, counted `unsynced`).
    pub fn poll(&mut self, now_us: u64, clock: &ClockSync) -> Option<DevicePose> {
        if self
            .last_sent_at
            .is_some_and(|t| now_us.saturating_sub(t) < FORWARD_PERIOD_US)
        {
            return None;
        }
        let pending = self.pending.take()?;
        let Some(stamp_us) = clock.to_device(pending.host_us) else {
            bump(&mut self.counters.unsynced);
            return None;
        };
        if self
            .last_forwarded_us
            .is_some_and(|t| pending.host_us.saturating_sub(t) > POSE_GAP_US)
        {
            bump(&mut self.counters.gaps);
        }
        self.last_forwarded_us = Some(pending.host_us);
        self.last_sent_at = Some(now_us);
        bump(&mut self.counters.forwarded);
        let p = &pending.input;
        #[allow(clippy::cast_possible_truncation)]
        Some(DevicePose {
            x: p.x as f32,
            y: p.y as f32,
            z: p.z as f32,
            roll: p.roll as f32,
            pitch: p.pitch as f32,
            yaw: p.yaw as f32,
            stamp_us,
            host_us: pending.host_us,
        })
    }

    /// Forgets the pending pose (the device rebooted: it is for a clock that is gone).
    pub fn drop_pending(&mut self) {
        if self.pending.take().is_some() {
            bump(&mut self.counters.unsynced);
        }
    }
}

/// The device's rule for a pose (`terrain_pyramid::geometry::Pose::from_f32`), on the values
/// as f32 will carry them.
fn in_device_ranges(p: &PoseInput) -> bool {
    #[allow(clippy::cast_possible_truncation)]
    let f = |v: f64| v as f32;
    terrain_pyramid::geometry::Pose::from_f32(
        f(p.x),
        f(p.y),
        f(p.z),
        f(p.roll),
        f(p.pitch),
        f(p.yaw),
    )
    .is_ok()
}

mod sources;
#[cfg(test)]
use sources::topic_name;
pub use sources::{
    datagram_events, odometry_qos, spawn_odometry, spawn_udp, OdometryPublishers, Source,
};

#[cfg(test)]
mod tests;
