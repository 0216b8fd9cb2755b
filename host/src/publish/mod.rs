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
use crate::link::{Mirror, MirrorCounters};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{mpsc, Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};
use terrain_pyramid::wire::link::{Message, Stats};
use terrain_pyramid::LogOddsFixed;

mod device;
mod foxglove_sink;
pub mod grids;
mod ros2_sink;
pub mod ros_msgs;
pub mod subprotocol;

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

// ------------------------------------------------------------------ configuration

/// The outputs' command-line flags, shared by every command that receives the device's maps.
#[derive(clap::Args, Debug, Clone)]
pub struct OutputArgs {
    /// Publish the maps as ROS 2 topics over DDS (no ROS installation needed): /terrain/fused,
    /// /terrain/layer_K (nav_msgs/OccupancyGrid; reliable, transient local, keep last 1) and
    /// /diagnostics. See docs/ros2.md.
    #[arg(long)]
    pub ros2: bool,
    /// The DDS domain for --ros2 [default: $ROS_DOMAIN_ID, else 0].
    #[arg(long, value_name = "N", requires = "ros2", value_parser = clap::value_parser!(u16).range(0..=232))]
    pub ros_domain_id: Option<u16>,
    /// Serve the maps live to Foxglove (foxglove.websocket.v1) on ADDR [default:
    /// 127.0.0.1:8765]: each layer and the fused map as foxglove.Grid, the pose, the windows.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = DEFAULT_FOXGLOVE_ADDR)]
    pub foxglove: Option<String>,
    /// Record the same channels (and the ROS 2 messages, CDR) to an indexed, chunked MCAP file.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// At most this many updates per second on each topic (only changed maps are sent).
    #[arg(long, value_name = "HZ", default_value_t = DEFAULT_PUBLISH_HZ, value_parser = positive_hz)]
    pub publish_hz: f64,
    /// The frame the maps are in: the device's world frame, that of the poses it is sent
    /// [default: the poses' frame (`pyramid listen`: the Odometry's header.frame_id, the UDP
    /// input's `frame`), else odom].
    #[arg(long, value_name = "FRAME")]
    pub frame_id: Option<String>,
    /// The fused map's half side around the robot, metres, at the finest layer's resolution;
    /// 0 = the coarsest layer's whole window (as fused.pgm).
    #[arg(long, value_name = "M", default_value_t = DEFAULT_FUSED_HALF_EXTENT_M, value_parser = extent)]
    pub fused_extent_m: f64,
}

fn positive_hz(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1000.0 {
        Ok(v)
    } else {
        Err(format!("{s:?} is not a rate in (0, 1000] per second"))
    }
}

fn extent(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && (0.0..=1000.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s:?} is not a distance in [0, 1000] m"))
    }
}

/// What the outputs publish and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// ROS 2 over DDS: the domain id, `None` = off.
    pub ros2_domain: Option<u16>,
    /// The Foxglove WebSocket server's address (`HOST:PORT`), `None` = off.
    pub foxglove: Option<String>,
    /// The MCAP file, `None` = off.
    pub mcap: Option<PathBuf>,
    /// Updates per second per topic, at most; > 0.
    pub publish_hz: f64,
    /// The frame id of every map, pose and outline (until the poses name theirs, when
    /// `frame_from_poses`).
    pub frame_id: String,
    /// Whether the poses' frame replaces `frame_id` once known ([`Outputs::set_pose_frame`]):
    /// `--frame-id` was not given.
    pub frame_from_poses: bool,
    /// The fused map's half side, metres (0 = the coarsest window).
    pub fused_half_extent_m: f64,
    /// The fused query's margin (Q8.8 nats, ≥ 0), as for the files.
    pub fused_margin: LogOddsFixed,
}

impl Config {
    /// No outputs, the defaults otherwise.
    // For callers that build a configuration by hand (the tests; `pyramid run` next).
    #[cfg_attr(not(test), allow(dead_code))]
    #[must_use]
    pub fn off() -> Self {
        Self {
            ros2_domain: None,
            foxglove: None,
            mcap: None,
            publish_hz: DEFAULT_PUBLISH_HZ,
            frame_id: DEFAULT_FRAME_ID.to_string(),
            frame_from_poses: false,
            fused_half_extent_m: DEFAULT_FUSED_HALF_EXTENT_M,
            fused_margin: LogOddsFixed::ZERO,
        }
    }

    /// Whether any output is on.
    #[must_use]
    pub fn any(&self) -> bool {
        self.ros2_domain.is_some() || self.foxglove.is_some() || self.mcap.is_some()
    }
}

impl OutputArgs {
    /// The configuration these flags ask for; `fused_margin` as the caller's files use.
    #[must_use]
    pub fn config(&self, fused_margin: LogOddsFixed) -> Config {
        let domain = || {
            self.ros_domain_id.unwrap_or_else(|| {
                std::env::var("ROS_DOMAIN_ID")
                    .ok()
                    .and_then(|v| v.trim().parse().ok())
                    .filter(|&d: &u16| d <= 232)
                    .unwrap_or(0)
            })
        };
        Config {
            ros2_domain: self.ros2.then(domain),
            foxglove: self.foxglove.clone(),
            mcap: self.mcap.clone(),
            publish_hz: self.publish_hz,
            frame_id: self
                .frame_id
                .clone()
                .unwrap_or_else(|| DEFAULT_FRAME_ID.to_string()),
            frame_from_poses: self.frame_id.is_none(),
            fused_half_extent_m: self.fused_extent_m,
            fused_margin,
        }
    }
}

// ------------------------------------------------------------------ what is published

/// The robot's pose in the maps' frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RobotPose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians counter-clockwise from +x.
    pub yaw: f64,
}

impl RobotPose {
    /// The pose a host `message` sends the device, if it is a Pose (x, y and yaw as sent).
    #[must_use]
    pub fn sent_in(message: &Message<'_>) -> Option<Self> {
        match message {
            Message::Pose(p) => Some(Self {
                x: f64::from(p.x_m),
                y: f64::from(p.y_m),
                yaw: f64::from(p.yaw_rad),
            }),
            _ => None,
        }
    }
}

/// Where the published pose came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// The caller's pose (the one it sent the device).
    Given,
    /// None was given: the finest window's centre, yaw 0.
    WindowCentre,
}

/// One hand-off: the maps, the pose and the counters at one moment.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The time of the data: the host's wall clock at the device's latest measurement
    /// ([`Outputs::set_data_stamp`]) or, before one is known, at the hand-off. The stamp of
    /// every map, pose and outline message of it.
    pub stamp: SystemTime,
    /// The host's clock at the hand-off (the stamp of the diagnostics).
    pub handed_off: SystemTime,
    /// The frame id of every message of it.
    pub frame_id: String,
    /// More diagnostics the caller adds (its clock, its pose inputs), published with the
    /// device's and the link's ([`Outputs::set_diagnostics`]).
    pub extra_diagnostics: Vec<ros_msgs::DiagnosticStatus>,
    /// The maps.
    pub snapshot: MapSnapshot,
    /// The robot's pose.
    pub pose: RobotPose,
    /// The device's last counters.
    pub stats: Option<Stats>,
    /// The mirror's counters.
    pub counters: MirrorCounters,
    /// Whether the mirror equals the device's maps.
    pub synced: bool,
    /// The firmware's version, `major.minor.patch`.
    pub firmware: String,
}

/// A layer, ready to publish.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerOut {
    /// The layer's index.
    pub index: usize,
    /// The grid.
    pub grid: GridData,
    /// As ROS 2 carries it.
    pub ros: ros_msgs::OccupancyGrid,
}

/// The fused map, ready to publish.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedOut {
    /// The grid.
    pub grid: GridData,
    /// As ROS 2 carries it.
    pub ros: ros_msgs::OccupancyGrid,
}

/// One layer's window: its corners, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowOutline {
    /// The lower-left corner.
    pub min: (f64, f64),
    /// The upper-right corner.
    pub max: (f64, f64),
}

/// What changed in one round, for the sinks.
#[derive(Debug, Default)]
pub struct Update<'a> {
    /// The stamp of every message.
    pub stamp: Option<SystemTime>,
    /// The frame id.
    pub frame_id: &'a str,
    /// Changed layers.
    pub layers: Vec<&'a LayerOut>,
    /// The fused map, when changed.
    pub fused: Option<&'a FusedOut>,
    /// The pose, when changed.
    pub pose: Option<RobotPose>,
    /// Every layer's window, when one moved.
    pub windows: Option<&'a [WindowOutline]>,
    /// The counters, when new.
    pub diagnostics: Option<&'a ros_msgs::DiagnosticArray>,
}

/// One output: DDS, or the Foxglove context (WebSocket server and MCAP writer).
trait Sink {
    /// Publishes what changed.
    fn publish(&mut self, update: &Update<'_>, counts: &mut BTreeMap<String, u64>);
    /// Regular service between updates (e.g. the latest messages to a new subscriber).
    fn service(&mut self) {}
    /// Ends the output (closes the file).
    fn finish(self: Box<Self>) -> Result<(), String>;
}

// ------------------------------------------------------------------ the publishing thread

/// What the publishing thread last published, to send only what changed.
#[derive(Default)]
struct Published {
    layers: Vec<LayerOut>,
    fused: Option<FusedOut>,
    pose: Option<RobotPose>,
    windows: Vec<WindowOutline>,
    diagnostics: Option<(Option<Stats>, bool, Vec<ros_msgs::DiagnosticStatus>)>,
    diagnostics_msg: ros_msgs::DiagnosticArray,
}

fn grid_message(grid: &GridData, stamp: ros_msgs::Time, frame_id: &str) -> ros_msgs::OccupancyGrid {
    #[allow(clippy::cast_possible_truncation)]
    ros_msgs::OccupancyGrid {
        header: ros_msgs::Header {
            stamp,
            frame_id: frame_id.to_string(),
        },
        info: ros_msgs::MapMetaData {
            map_load_time: stamp,
            resolution: grid.resolution_m as f32,
            width: u32::try_from(grid.width).unwrap_or(u32::MAX),
            height: u32::try_from(grid.height).unwrap_or(u32::MAX),
            origin: ros_msgs::Pose {
                position: ros_msgs::Point {
                    x: grid.origin_m.0,
                    y: grid.origin_m.1,
                    z: 0.0,
                },
                orientation: ros_msgs::Quaternion::default(),
            },
        },
        data: grid.occupancy.clone(),
    }
}

fn diagnostics_message(frame: &Frame, stamp: ros_msgs::Time) -> ros_msgs::DiagnosticArray {
    let kv = |key: &str, value: String| ros_msgs::KeyValue {
        key: key.to_string(),
        value,
    };
    let hardware_id = format!("terrain-pyramid firmware {}", frame.firmware);
    let device = frame.stats.map_or_else(
        || ros_msgs::DiagnosticStatus {
            level: ros_msgs::LEVEL_WARN,
            name: "terrain_pyramid: device".into(),
            message: "no Stats from the device yet".into(),
            hardware_id: hardware_id.clone(),
            values: Vec::new(),
        },
        |s| ros_msgs::DiagnosticStatus {
            level: ros_msgs::LEVEL_OK,
            name: "terrain_pyramid: device".into(),
            message: format!("uptime {:.1} s", f64::from(s.uptime_ms) / 1000.0),
            hardware_id: hardware_id.clone(),
            values: Stats::NAMES
                .iter()
                .zip(s.to_array())
                .map(|(n, v)| kv(n, v.to_string()))
                .collect(),
        },
    );
    let c = frame.counters;
    let host = ros_msgs::DiagnosticStatus {
        level: if frame.synced {
            ros_msgs::LEVEL_OK
        } else {
            ros_msgs::LEVEL_WARN
        },
        name: "terrain_pyramid: host link".into(),
        message: if frame.synced {
            "synced".into()
        } else {
            "syncing: the maps may differ from the device's".into()
        },
        hardware_id,
        values: vec![
            kv("frames", c.frames.to_string()),
            kv("missing", c.missing.to_string()),
            kv("gaps", c.gaps.to_string()),
            kv("out_of_order", c.out_of_order.to_string()),
            kv("hellos", c.hellos.to_string()),
            kv("patches", c.patches.to_string()),
            kv("patches_refused", c.patches_refused.to_string()),
            kv("moves", c.moves.to_string()),
            kv("snapshots_advised", c.snapshots_advised.to_string()),
        ],
    };
    ros_msgs::DiagnosticArray {
        header: ros_msgs::Header {
            stamp,
            frame_id: String::new(),
        },
        status: [device, host]
            .into_iter()
            .chain(frame.extra_diagnostics.iter().cloned())
            .collect(),
    }
}

/// Whether a published map message is in another frame than `frame_id` (the poses named
/// theirs): it is published again in the new one.
fn frame_id_changed(published: Option<&ros_msgs::OccupancyGrid>, frame_id: &str) -> bool {
    published.is_some_and(|m| m.header.frame_id != frame_id)
}

impl Published {
    /// Compares `frame` with what was published; keeps the new state and marks what changed.
    fn advance(&mut self, frame: &Frame, config: &Config) -> Changed {
        let stamp = ros_msgs::Time::of(frame.stamp);
        let frame_id = frame.frame_id.as_str();

        let mut changed = Changed::default();
        let layers = &frame.snapshot.layers;
        self.layers.truncate(layers.len());
        for (k, layer) in layers.iter().enumerate() {
            let grid = grids::layer_grid(layer);
            let same = self.layers.get(k).is_some_and(|old| {
                old.grid.origin_m == grid.origin_m
                    && old.grid.resolution_m == grid.resolution_m
                    && old.grid.occupancy == grid.occupancy
                    && old
                        .grid
                        .log_odds
                        .as_ref()
                        .map(|v| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>())
                        == grid
                            .log_odds
                            .as_ref()
                            .map(|v| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>())
            });
            if same && !frame_id_changed(self.layers.get(k).map(|l| &l.ros), frame_id) {
                continue;
            }
            let out = LayerOut {
                index: k,
                ros: grid_message(&grid, stamp, frame_id),
                grid,
            };
            if k < self.layers.len() {
                if let Some(slot) = self.layers.get_mut(k) {
                    *slot = out;
                }
            } else {
                self.layers.push(out);
            }
            changed.layers.push(k);
        }
        if let Some(grid) = grids::fused_grid(
            &frame.snapshot,
            (frame.pose.x, frame.pose.y),
            config.fused_half_extent_m,
        ) {
            let same = self
                .fused
                .as_ref()
                .is_some_and(|f| f.grid == grid && !frame_id_changed(Some(&f.ros), frame_id));
            if !same {
                self.fused = Some(FusedOut {
                    ros: grid_message(&grid, stamp, frame_id),
                    grid,
                });
                changed.fused = true;
            }
        }
        if self.pose != Some(frame.pose) {
            self.pose = Some(frame.pose);
            changed.pose = true;
        }
        let windows: Vec<WindowOutline> = layers
            .iter()
            .map(|l| {
                let (x, y) = l.origin_m();
                let e = l.extent_m();
                WindowOutline {
                    min: (x, y),
                    max: (x + e, y + e),
                }
            })
            .collect();
        if windows != self.windows {
            self.windows = windows;
            changed.windows = true;
        }
        let key = (frame.stats, frame.synced, frame.extra_diagnostics.clone());
        if self.diagnostics != Some(key.clone()) {
            self.diagnostics = Some(key);
            self.diagnostics_msg = diagnostics_message(frame, ros_msgs::Time::of(frame.handed_off));
            changed.diagnostics = true;
        }
        changed
    }

    fn update<'a>(&'a self, changed: &Changed, frame: &'a Frame) -> Update<'a> {
        let frame_id = frame.frame_id.as_str();
        Update {
            stamp: Some(frame.stamp),
            frame_id,
            layers: changed
                .layers
                .iter()
                .filter_map(|&k| self.layers.get(k))
                .collect(),
            fused: if changed.fused {
                self.fused.as_ref()
            } else {
                None
            },
            pose: if changed.pose { self.pose } else { None },
            windows: changed.windows.then_some(self.windows.as_slice()),
            diagnostics: changed.diagnostics.then_some(&self.diagnostics_msg),
        }
    }
}

#[derive(Default)]
struct Changed {
    layers: Vec<usize>,
    fused: bool,
    pose: bool,
    windows: bool,
    diagnostics: bool,
}

/// The one-place slot between the reader and the publishing thread.
#[derive(Default)]
struct Slot {
    frame: Option<Box<Frame>>,
    stop: bool,
    /// Hand-offs replaced before the thread took them.
    coalesced: u64,
}

struct Shared {
    slot: Mutex<Slot>,
    wake: Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Slot> {
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// What the publishing thread did.
#[derive(Debug, Clone, Default, Serialize, PartialEq, Eq)]
pub struct PublishCounts {
    /// Frames the thread took and published from.
    pub frames_published: u64,
    /// Messages sent, by output and topic (`ros2 /terrain/fused`, `foxglove /terrain/pose`, …).
    pub messages: BTreeMap<String, u64>,
}

/// How long the publishing thread sleeps when nothing comes, before its regular service.
const SERVICE_INTERVAL: Duration = Duration::from_millis(100);

fn worker(
    shared: &Shared,
    mut sinks: Vec<Box<dyn Sink>>,
    config: &Config,
) -> Result<PublishCounts, String> {
    let mut published = Published::default();
    let mut counts = PublishCounts::default();
    loop {
        let (frame, stop) = {
            let mut slot = shared.lock();
            if slot.frame.is_none() && !slot.stop {
                slot = shared
                    .wake
                    .wait_timeout(slot, SERVICE_INTERVAL)
                    .map_or_else(|e| e.into_inner().0, |(g, _)| g);
            }
            (slot.frame.take(), slot.stop)
        };
        for sink in &mut sinks {
            sink.service();
        }
        if let Some(frame) = frame {
            let changed = published.advance(&frame, config);
            let update = published.update(&changed, &frame);
            for sink in &mut sinks {
                sink.publish(&update, &mut counts.messages);
            }
            counts.frames_published += 1;
        } else if stop {
            break;
        }
    }
    let mut first_error = None;
    for sink in sinks {
        if let Err(e) = sink.finish() {
            first_error.get_or_insert(e);
        }
    }
    first_error.map_or(Ok(counts), Err)
}

// ------------------------------------------------------------------ the API

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
