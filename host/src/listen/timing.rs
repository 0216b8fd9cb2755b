//! The clocks and poses of a `pyramid listen` session: the time exchanges with the device,
//! the clock mapping ([`ClockSync`]), the pose inputs and their `/diagnostics`.
use super::{
    Args, INPUTS_PER_PASS, INPUT_CHANNEL, MONOTONIC_LEAD, TIME_REQUEST_FAST, TIME_REQUEST_FAST_FOR,
    TIME_REQUEST_SLOW,
};
use crate::clock_sync::{ClockCounters, ClockSync, ResetReason};
use crate::pose_input::{self, PoseForwarder, Source, SourceEvent, WallAnchor};
use crate::pose_input::{OdometryPublishers, PoseCounters};
use crate::publish::ros_msgs;
use crate::publish::RobotPose;
use serde::Serialize;
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use terrain_pyramid::wire::link::TimeRequest;

/// The session's clocks and poses: the time exchanges, the clock mapping, the pose inputs.
pub(super) struct Timing {
    /// The origin of the host's µs count.
    origin: Instant,
    pub(super) clock: ClockSync,
    pub(super) wall: WallAnchor,
    pub(super) forwarder: PoseForwarder,
    inputs: Option<mpsc::Receiver<SourceEvent>>,
    /// The pose inputs' threads (stopped when dropped).
    pub(super) sources: Vec<Source>,
    pub(super) fast_until: Instant,
    pub(super) next_request: Instant,
    requests_sent: u64,
    pub(super) observed: u64,
    pub(super) observed_unmapped: u64,
    /// The robot's latest forwarded pose (for the live outputs).
    pub(super) last_pose: Option<RobotPose>,
    /// Dropped poses when the diagnostics were last built (a rise is a warning).
    dropped_before: u64,
}

impl Timing {
    pub(super) fn new(now: Instant) -> Self {
        Self {
            origin: now.checked_sub(MONOTONIC_LEAD).unwrap_or(now),
            clock: ClockSync::new(),
            wall: WallAnchor::new(),
            forwarder: PoseForwarder::new(),
            inputs: None,
            sources: Vec::new(),
            fast_until: now + TIME_REQUEST_FAST_FOR,
            next_request: now,
            requests_sent: 0,
            observed: 0,
            observed_unmapped: 0,
            last_pose: None,
            dropped_before: 0,
        }
    }

    /// The host's µs count at `t`.
    pub(super) fn host_us(&self, t: Instant) -> u64 {
        u64::try_from(t.saturating_duration_since(self.origin).as_micros()).unwrap_or(u64::MAX)
    }

    /// Forgets the clock mapping (counted by `reason`), drops a pose pending for the old
    /// clock, and exchanges fast again.
    pub(super) fn restart(&mut self, reason: ResetReason, now: Instant) {
        self.clock.reset(reason);
        self.forwarder.drop_pending();
        self.fast_until = now + TIME_REQUEST_FAST_FOR;
        self.next_request = now;
    }

    /// The TimeRequest due at `now`, if one is.
    pub(super) fn request_due(&mut self, now: Instant) -> Option<TimeRequest> {
        if now < self.next_request {
            return None;
        }
        let period = if now < self.fast_until {
            TIME_REQUEST_FAST
        } else {
            TIME_REQUEST_SLOW
        };
        self.next_request = now + period;
        self.requests_sent += 1;
        Some(TimeRequest {
            host_us: self.host_us(Instant::now()),
        })
    }

    /// Reads both host clocks (a jump of the wall clock is counted).
    pub(super) fn observe_wall(&mut self, now: Instant) {
        let wall_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i128::try_from(d.as_micros()).unwrap_or(i128::MAX));
        if self.wall.observe(wall_us, self.host_us(now)) {
            self.forwarder.count_clock_jump();
        }
    }

    /// Takes what the pose inputs sent since the last pass.
    pub(super) fn drain_inputs(&mut self, now: Instant) {
        let Some(rx) = &self.inputs else {
            return;
        };
        let now_us = self.host_us(now);
        for _ in 0..INPUTS_PER_PASS {
            match rx.try_recv() {
                Ok(event) => self.forwarder.take(event, now_us, &self.wall, &self.clock),
                Err(_) => break,
            }
        }
    }

    /// The host wall time of the device's `device_us`, if the mapping is known.
    pub(super) fn wall_time_of(&self, device_us: u32) -> Option<SystemTime> {
        let host_us = self.clock.to_host(device_us)?;
        let wall_us = u64::try_from(self.wall.to_wall(host_us)?).ok()?;
        UNIX_EPOCH.checked_add(Duration::from_micros(wall_us))
    }

    pub(super) fn report(&self) -> TimeSyncReport {
        let e = self.clock.estimate();
        let counters = self.clock.counters();
        TimeSyncReport {
            synced: self.clock.is_synced(),
            offset_us: e.map(|e| e.offset_us),
            drift_ppm: e.map(|e| e.drift_ppm),
            accuracy_us: e.map(|e| e.accuracy_us),
            round_trip_us: e.map(|e| e.round_trip_us),
            requests_sent: self.requests_sent,
            counters,
            resets: counters.resets(),
            observed: self.observed,
            observed_unmapped: self.observed_unmapped,
        }
    }

    pub(super) fn poses_report(&self) -> Option<PosesReport> {
        (!self.sources.is_empty()).then(|| PosesReport {
            sources: self.sources.iter().map(|s| s.name.clone()).collect(),
            frame: self.forwarder.frame().map(str::to_string),
            counters: self.forwarder.counters(),
            ros2_publishers: self.sources.iter().find_map(Source::publishers),
        })
    }

    /// The `/diagnostics` statuses of the clock and (when on) the pose inputs.
    pub(super) fn diagnostics(&mut self, hardware_id: &str) -> Vec<ros_msgs::DiagnosticStatus> {
        let kv = |key: &str, value: String| ros_msgs::KeyValue {
            key: key.to_string(),
            value,
        };
        let r = self.report();
        let fmt =
            |v: Option<f64>, digits: usize| v.map_or_else(String::new, |v| format!("{v:.digits$}"));
        let clock = ros_msgs::DiagnosticStatus {
            level: ros_msgs::level(r.synced),
            name: "terrain_pyramid: clock".into(),
            message: match (r.drift_ppm, r.accuracy_us) {
                (Some(drift), Some(acc)) if r.synced => {
                    format!("synced: drift {drift:.1} ppm, accuracy {acc:.0} µs")
                }
                _ => "not synced: no pose is forwarded".into(),
            },
            hardware_id: hardware_id.to_string(),
            values: vec![
                kv("synced", r.synced.to_string()),
                kv("offset_us", fmt(r.offset_us, 1)),
                kv("drift_ppm", fmt(r.drift_ppm, 3)),
                kv("accuracy_us", fmt(r.accuracy_us, 1)),
                kv(
                    "round_trip_us",
                    r.round_trip_us.map_or_else(String::new, |v| v.to_string()),
                ),
                kv("requests_sent", r.requests_sent.to_string()),
                kv("exchanges", r.counters.exchanges.to_string()),
                kv("discarded", r.counters.discarded.to_string()),
                kv("queued_replies", r.counters.queued_replies.to_string()),
                kv("resets", r.resets.to_string()),
                kv("resets_boot", r.counters.resets_boot.to_string()),
                kv("resets_reconnect", r.counters.resets_reconnect.to_string()),
                kv(
                    "resets_inconsistent",
                    r.counters.resets_inconsistent.to_string(),
                ),
                kv("observed", r.observed.to_string()),
                kv("observed_unmapped", r.observed_unmapped.to_string()),
            ],
        };
        let mut out = vec![clock];
        if let Some(p) = self.poses_report() {
            let dropped = p.counters.dropped();
            let rising = dropped > self.dropped_before;
            self.dropped_before = dropped;
            let refused = p.ros2_publishers.is_some_and(|m| m.incompatible > 0);
            let publishers = p.ros2_publishers.map_or_else(String::new, |m| {
                format!(
                    "; {} publisher(s) matched{}",
                    m.matched,
                    if m.incompatible > 0 {
                        format!(", {} refused for their QoS", m.incompatible)
                    } else {
                        String::new()
                    }
                )
            });
            out.push(ros_msgs::DiagnosticStatus {
                level: ros_msgs::level(!(rising || refused || p.counters.forwarded == 0)),
                name: "terrain_pyramid: poses".into(),
                message: format!(
                    "{} forwarded, {} dropped ({}){publishers}{}",
                    p.counters.forwarded,
                    dropped,
                    p.sources.join(", "),
                    if rising {
                        ": poses dropped since the last report"
                    } else {
                        ""
                    }
                ),
                hardware_id: hardware_id.to_string(),
                values: p
                    .counters
                    .named()
                    .iter()
                    .map(|(n, v)| kv(n, v.to_string()))
                    .chain(std::iter::once(kv("frame", p.frame.unwrap_or_default())))
                    .chain(p.ros2_publishers.iter().flat_map(|m| {
                        [
                            kv("publishers_matched", m.matched.to_string()),
                            kv("publishers_matched_total", m.matched_total.to_string()),
                            kv("publishers_incompatible", m.incompatible.to_string()),
                        ]
                    }))
                    .collect(),
            });
        }
        out
    }
}

/// Starts the pose inputs `args` asks for, each on a thread of its own feeding one channel.
pub(super) fn start_pose_inputs(args: &Args) -> Result<Timing, String> {
    let mut timing = Timing::new(Instant::now());
    if args.odom_topic.is_none() && args.pose_udp.is_none() {
        return Ok(timing);
    }
    let (tx, rx) = mpsc::sync_channel(INPUT_CHANNEL);
    if let Some(addr) = &args.pose_udp {
        let (source, _) = pose_input::spawn_udp(addr, tx.clone())?;
        timing.sources.push(source);
    }
    if let Some(topic) = &args.odom_topic {
        let domain = args
            .outputs
            .config(crate::export::default_fused_margin())
            .ros2_domain
            .unwrap_or(0);
        timing
            .sources
            .push(pose_input::spawn_odometry(domain, topic, tx)?);
    }
    timing.inputs = Some(rx);
    Ok(timing)
}

/// The clock mapping (host ↔ device, [`ClockSync`](crate::clock_sync::ClockSync)) at the end of a session.
#[derive(Serialize, Debug, Clone)]
pub struct TimeSyncReport {
    /// Whether the mapping was known at the end.
    pub synced: bool,
    /// Device µs minus host µs (the host's count starts 10 s before the session) at the
    /// mapping's anchor; `None` when not synced.
    pub offset_us: Option<f64>,
    /// The device's clock rate minus the host's, ppm.
    pub drift_ppm: Option<f64>,
    /// The stated bound on the mapping's error at its anchor, µs.
    pub accuracy_us: Option<f64>,
    /// The anchor exchange's round trip, µs.
    pub round_trip_us: Option<u64>,
    /// TimeRequests sent.
    pub requests_sent: u64,
    /// The filter's counters (replies taken, discarded, resets by reason).
    #[serde(flatten)]
    pub counters: ClockCounters,
    /// Every reset, whatever its reason.
    pub resets: u64,
    /// Observed frames received.
    pub observed: u64,
    /// Observed frames whose time could not be mapped (no mapping yet): the maps were
    /// stamped with the hand-off's time meanwhile.
    pub observed_unmapped: u64,
}

/// The pose inputs of a session.
#[derive(Serialize, Debug, Clone)]
pub struct PosesReport {
    /// The inputs (`ros2 /odom`, `udp 127.0.0.1:7420`).
    pub sources: Vec<String>,
    /// The poses' frame (the first named).
    pub frame: Option<String>,
    /// What became of the poses, by reason.
    #[serde(flatten)]
    pub counters: PoseCounters,
    /// The Odometry subscription's DDS publishers (`--odom-topic`), matched and refused;
    /// `None` without it.
    pub ros2_publishers: Option<OdometryPublishers>,
}
