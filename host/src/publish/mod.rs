//! Live outputs of the host's mirror of the device's maps: ROS 2 topics over DDS (`--ros2`), a
//! Foxglove WebSocket server (`--foxglove`) and an MCAP recording (`--mcap`). `docs/ros2.md`
//! describes the topics, their types and QoS, and the Nav2 costmap that consumes them.
//!
//! # Use from a receive loop
//! ```text
//! let mut outputs = Outputs::start(&config)?;     // binds, opens, joins DDS: errors name the flag
//! loop {
//!     link.feed(bytes);
//!     outputs.offer(link.mirror(), pose);         // cheap; never blocks on a viewer
//! }
//! let report = outputs.finish(link.mirror(), pose)?; // the final state, then the file closed
//! ```
//!
//! # The hand-off
//! [`Outputs::offer`] is called from the loop that reads the device, as often as it likes (each
//! pass). At most `publish_hz` times a second, and only when a frame has come or the pose has
//! moved since the last hand-off, it copies the maps (W² cells per layer: 64 KiB for the
//! default pyramid) into a one-place slot and wakes the publishing thread. If the thread has
//! not taken the previous copy yet, the new one replaces it (latest map wins; counted as
//! `coalesced`). The reader never waits for the publisher beyond the slot's lock, which the
//! publisher holds only to take the copy: a slow or stalled subscriber, viewer or disk costs
//! map updates on the outputs, never a frame of the link.
//!
//! The publishing thread compares each layer with what it last published and sends only the
//! changed ones; the fused map, the pose, the windows' outlines and the diagnostics likewise.
//! So every topic gets at most `publish_hz` messages a second (plus the final state at
//! [`Outputs::finish`]).
//!
//! # The pose
//! The device's maps are windows the device recentres on the poses the host sends it. A caller
//! that sends poses passes the latest one to `offer`; without one (`pyramid listen` hears only
//! the device) the finest layer's window centre stands for the robot's position, with yaw 0,
//! and the report says so (`pose_source: window_centre`).
pub use device::Publishing;

use crate::export::MapSnapshot;
use crate::link::Mirror;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::{mpsc, Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

mod device;
mod foxglove_sink;
pub mod grids;
mod ros2_sink;
pub mod ros_msgs;
pub mod subprotocol;

mod config;
mod published;
mod worker;

use grids::GridData;

/// `--foxglove`'s address when none is given.
pub const DEFAULT_FOXGLOVE_ADDR: &str = "127.0.0.1:8765";
/// `--publish-hz`'s default: updates per second per topic, at most.
pub const DEFAULT_PUBLISH_HZ: f64 = 10.0;
/// `--frame-id`'s default: the device's world frame is the frame of the poses it is sent,
/// on a robot its odometry frame.
pub const DEFAULT_FRAME_ID: &str = "odom";
/// `--fused-extent-m`'s default: the fused map covers ±10 m around the robot.
pub const DEFAULT_FUSED_HALF_EXTENT_M: f64 = 10.0;

/// The topic of the fused map (ROS 2 and MCAP, `nav_msgs/msg/OccupancyGrid`).
pub const TOPIC_FUSED: &str = "/terrain/fused";
/// The topic of the device's counters (`diagnostic_msgs/msg/DiagnosticArray`).
pub const TOPIC_DIAGNOSTICS: &str = "/diagnostics";
/// The Foxglove topic of the fused map (`foxglove.Grid`).
pub const TOPIC_GRID_FUSED: &str = "/terrain/grid/fused";
/// The Foxglove topic of the robot's pose (`foxglove.PoseInFrame`).
pub const TOPIC_POSE: &str = "/terrain/pose";
/// The Foxglove topic of the windows' outlines (`foxglove.SceneUpdate`).
pub const TOPIC_WINDOWS: &str = "/terrain/windows";

/// The ROS topic of layer `k` (`nav_msgs/msg/OccupancyGrid`).
#[must_use]
pub fn topic_layer(k: usize) -> String {
    format!("/terrain/layer_{k}")
}

/// The Foxglove topic of layer `k` (`foxglove.Grid`).
#[must_use]
pub fn topic_grid_layer(k: usize) -> String {
    format!("/terrain/grid/layer_{k}")
}

pub use config::{Config, OutputArgs};
use published::Sink;
pub use published::{Frame, FusedOut, LayerOut, PoseSource, RobotPose, Update, WindowOutline};
pub use worker::PublishCounts;
use worker::{worker, Shared, Slot};

/// Whether this process sees no network interface but loopback (a network namespace of its
/// own, as `unshare -n` makes): where `--ros2`'s DDS multicast stays on this machine.
#[must_use]
pub fn only_loopback() -> bool {
    // /proc/net/dev lists the interfaces of the reader's network namespace (sysfs would show
    // those of the namespace it was mounted in).
    std::fs::read_to_string("/proc/net/dev").is_ok_and(|t| {
        t.lines()
            .skip(2)
            .filter_map(|l| l.split(':').next())
            .all(|name| name.trim() == "lo")
    })
}

/// An output that could not start: which flag, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StartError {
    /// The flag (`--foxglove`, `--mcap`, `--ros2`).
    pub flag: &'static str,
    /// What went wrong.
    pub message: String,
}

impl std::fmt::Display for StartError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.flag, self.message)
    }
}

impl std::error::Error for StartError {}

/// What the outputs did, for the session's summary.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct OutputsReport {
    /// Hand-offs from the reader (each a copy of the maps).
    pub handoffs: u64,
    /// Hand-offs replaced by a newer one before the publishing thread took them.
    pub coalesced: u64,
    /// Where the published pose came from.
    pub pose_source: Option<PoseSource>,
    /// Hand-offs stamped with the data's time (the rest: with the hand-off's).
    pub data_stamped: u64,
    /// The frame id of the last hand-off.
    pub frame_id: String,
    /// The publishing thread's counts.
    #[serde(flatten)]
    pub published: PublishCounts,
    /// The Foxglove server's address, when on.
    pub foxglove: Option<String>,
    /// The MCAP file, when on.
    pub mcap: Option<String>,
}

/// What makes a hand-off news: the mirror's frame count and the pose's bits.
type OfferKey = (u64, Option<(u64, u64, u64)>);

/// The running outputs. See the module's documentation.
pub struct Outputs {
    shared: Arc<Shared>,
    worker: Option<JoinHandle<Result<PublishCounts, String>>>,
    config: Config,
    period: Duration,
    last_handoff: Option<Instant>,
    last_stamp: Option<SystemTime>,
    last_key: Option<OfferKey>,
    handoffs: u64,
    pose_source: Option<PoseSource>,
    foxglove_addr: Option<String>,
    /// The frame id the next hand-offs carry.
    frame_id: String,
    /// The data's time for the next hand-offs ([`Outputs::set_data_stamp`]).
    data_stamp: Option<SystemTime>,
    /// Hand-offs stamped with the data's time.
    data_stamped: u64,
    extra_diagnostics: Vec<ros_msgs::DiagnosticStatus>,
}

impl std::fmt::Debug for Outputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Outputs")
            .field("config", &self.config)
            .field("handoffs", &self.handoffs)
            .finish_non_exhaustive()
    }
}

impl Outputs {
    /// Starts the outputs `config` asks for (none: an `Outputs` that does nothing): binds the
    /// Foxglove server, creates the MCAP file, joins the DDS domain, then starts the
    /// publishing thread.
    ///
    /// # Errors
    /// The first output that cannot start, naming its flag (e.g. `--foxglove: 127.0.0.1:8765
    /// is already in use`); nothing is left running.
    pub fn start(config: &Config) -> Result<Self, StartError> {
        if !config.any() {
            return Ok(Self::idle(config));
        }
        Self::start_with(config, make_sinks)
    }

    fn idle(config: &Config) -> Self {
        Self {
            shared: Arc::new(Shared {
                slot: Mutex::new(Slot::default()),
                wake: Condvar::new(),
            }),
            worker: None,
            config: config.clone(),
            period: Duration::from_secs_f64(1.0 / config.publish_hz.clamp(1e-3, 1e3)),
            last_handoff: None,
            last_stamp: None,
            last_key: None,
            handoffs: 0,
            pose_source: None,
            foxglove_addr: None,
            frame_id: config.frame_id.clone(),
            data_stamp: None,
            data_stamped: 0,
            extra_diagnostics: Vec::new(),
        }
    }

    /// Starts the publishing thread with the sinks `make` builds on it.
    fn start_with(
        config: &Config,
        make: impl FnOnce(&Config) -> Result<Sinks, StartError> + Send + 'static,
    ) -> Result<Self, StartError> {
        let mut outputs = Self::idle(config);
        let shared = Arc::clone(&outputs.shared);
        // The outputs are made on the publishing thread (the DDS and WebSocket handles stay
        // there), which reports back before the session starts.
        let (ready_tx, ready_rx) = mpsc::channel::<Result<Option<String>, StartError>>();
        let thread_config = config.clone();
        let handle = std::thread::Builder::new()
            .name("publish".into())
            .spawn(move || match make(&thread_config) {
                Ok((sinks, addr)) => {
                    let _ = ready_tx.send(Ok(addr));
                    worker(&shared, sinks, &thread_config)
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    Ok(PublishCounts::default())
                }
            })
            .map_err(|e| StartError {
                flag: "--publish-hz",
                message: format!("cannot start the publishing thread: {e}"),
            })?;
        let ready = ready_rx.recv().unwrap_or_else(|_| {
            Err(StartError {
                flag: "--publish-hz",
                message: "the publishing thread ended before it was ready".into(),
            })
        });
        match ready {
            Ok(addr) => {
                outputs.foxglove_addr = addr;
                outputs.worker = Some(handle);
                Ok(outputs)
            }
            Err(e) => {
                let _ = handle.join();
                Err(e)
            }
        }
    }

    /// Whether any output is on.
    #[must_use]
    pub fn is_on(&self) -> bool {
        self.worker.is_some()
    }

    /// The Foxglove server's bound address, when on.
    #[must_use]
    pub fn foxglove_addr(&self) -> Option<&str> {
        self.foxglove_addr.as_deref()
    }

    /// The poses' frame (the Odometry's `header.frame_id`, the UDP input's `frame`): the
    /// frame id of the next hand-offs, unless `--frame-id` was given ([`Config::frame_from_poses`]
    /// false). A map already published in another frame is published again in this one.
    pub fn set_pose_frame(&mut self, frame: &str) {
        if self.config.frame_from_poses && !frame.is_empty() {
            frame.clone_into(&mut self.frame_id);
        }
    }

    /// The frame id the next hand-offs carry.
    #[must_use]
    pub fn frame_id(&self) -> &str {
        &self.frame_id
    }

    /// The time of the data the maps hold (`pyramid listen`: the device's latest Observed
    /// `last_us`, mapped to the host's wall clock): the stamp of the next hand-offs instead of
    /// the hand-off's own time.
    pub fn set_data_stamp(&mut self, stamp: SystemTime) {
        self.data_stamp = Some(stamp);
    }

    /// More `/diagnostics` statuses (the caller's clock and pose inputs), sent with the next
    /// hand-offs after the device's and the link's.
    pub fn set_diagnostics(&mut self, statuses: Vec<ros_msgs::DiagnosticStatus>) {
        self.extra_diagnostics = statuses;
    }

    /// The stamp of the last hand-off (the data's time, [`Outputs::set_data_stamp`], or else
    /// the host clock when it copied the maps): every message published from that copy
    /// carries it (header stamps, Foxglove timestamps and MCAP log times). `None` before the
    /// first.
    #[must_use]
    pub fn last_handoff_stamp(&self) -> Option<SystemTime> {
        self.last_stamp
    }

    /// Offers the mirror's current maps and the robot's pose (`None`: not known, the finest
    /// window's centre stands for it). Cheap when nothing changed or the last hand-off was
    /// less than `1 / publish_hz` ago; otherwise copies the maps into the slot (replacing a copy
    /// not yet taken). Never waits for an output. Returns whether it handed off.
    pub fn offer(&mut self, mirror: &Mirror, pose: Option<RobotPose>) -> bool {
        if self.worker.is_none() {
            return false;
        }
        let now = Instant::now();
        if self
            .last_handoff
            .is_some_and(|t| now.duration_since(t) < self.period)
        {
            return false;
        }
        self.hand_off(mirror, pose, now)
    }

    fn hand_off(&mut self, mirror: &Mirror, pose: Option<RobotPose>, now: Instant) -> bool {
        let key = (
            mirror.counters().frames,
            pose.map(|p| (p.x.to_bits(), p.y.to_bits(), p.yaw.to_bits())),
        );
        if self.last_key == Some(key) {
            return false;
        }
        let Some(snapshot) = MapSnapshot::from_mirror(mirror, self.config.fused_margin, (0.0, 0.0))
        else {
            return false;
        };
        let (pose, source) = match pose {
            Some(p) => (p, PoseSource::Given),
            None => {
                let (x, y) = grids::window_centre(&snapshot).unwrap_or((0.0, 0.0));
                (RobotPose { x, y, yaw: 0.0 }, PoseSource::WindowCentre)
            }
        };
        let mut snapshot = snapshot;
        snapshot.sensor_xy = (pose.x, pose.y);
        let handed_off = SystemTime::now();
        let stamp = self.data_stamp.unwrap_or(handed_off);
        if self.data_stamp.is_some() {
            self.data_stamped += 1;
        }
        let frame = Box::new(Frame {
            stamp,
            handed_off,
            frame_id: self.frame_id.clone(),
            extra_diagnostics: self.extra_diagnostics.clone(),
            snapshot,
            pose,
            stats: mirror.last_stats(),
            counters: mirror.counters(),
            synced: mirror.is_synced(),
            firmware: mirror.firmware().map_or_else(String::new, |f| {
                format!("{}.{}.{}", f.major, f.minor, f.patch)
            }),
        });
        {
            let mut slot = self.shared.lock();
            if slot.frame.replace(frame).is_some() {
                slot.coalesced += 1;
            }
        }
        self.shared.wake.notify_one();
        self.last_handoff = Some(now);
        self.last_stamp = Some(stamp);
        self.last_key = Some(key);
        self.handoffs += 1;
        self.pose_source = Some(source);
        true
    }

    /// Hands off the final state (whatever the rate), waits until it is published, and ends
    /// the outputs (the MCAP file is finished and closed).
    ///
    /// # Errors
    /// An output that failed (the MCAP file could not be written, …).
    pub fn finish(
        mut self,
        mirror: &Mirror,
        pose: Option<RobotPose>,
    ) -> Result<OutputsReport, String> {
        let Some(handle) = self.worker.take() else {
            return Ok(self.report(PublishCounts::default(), 0));
        };
        self.hand_off(mirror, pose, Instant::now());
        self.shared.lock().stop = true;
        self.shared.wake.notify_one();
        let counts = handle
            .join()
            .map_err(|_| "the publishing thread failed".to_string())??;
        let coalesced = self.shared.lock().coalesced;
        Ok(self.report(counts, coalesced))
    }

    fn report(&self, published: PublishCounts, coalesced: u64) -> OutputsReport {
        OutputsReport {
            handoffs: self.handoffs,
            coalesced,
            pose_source: self.pose_source,
            data_stamped: self.data_stamped,
            frame_id: self.frame_id.clone(),
            published,
            foxglove: self.foxglove_addr.clone(),
            mcap: self.config.mcap.as_ref().map(|p| p.display().to_string()),
        }
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if let Some(handle) = self.worker.take() {
            self.shared.lock().stop = true;
            self.shared.wake.notify_one();
            let _ = handle.join();
        }
    }
}

/// The sinks, and the Foxglove server's bound address.
type Sinks = (Vec<Box<dyn Sink>>, Option<String>);

fn make_sinks(config: &Config) -> Result<Sinks, StartError> {
    let mut sinks: Vec<Box<dyn Sink>> = Vec::new();
    let mut addr = None;
    if config.foxglove.is_some() || config.mcap.is_some() {
        let sink = foxglove_sink::FoxgloveSink::start(config)?;
        addr = sink.addr();
        sinks.push(Box::new(sink));
    }
    if let Some(domain) = config.ros2_domain {
        sinks.push(Box::new(ros2_sink::Ros2Sink::start(domain)?));
    }
    Ok((sinks, addr))
}

/// Counts one message on `output`'s `topic`.
fn count(counts: &mut BTreeMap<String, u64>, output: &str, topic: &str) {
    *counts.entry(format!("{output} {topic}")).or_default() += 1;
}

#[cfg(test)]
mod tests;
