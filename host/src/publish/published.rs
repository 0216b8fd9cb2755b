//! What is published: the robot's pose, one frame of the mirror's maps ([`Frame`]) and the
//! update a sink receives, and the sink's interface.

use super::*;
use crate::export::MapSnapshot;
use crate::link::MirrorCounters;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::SystemTime;
use terrain_pyramid::wire::link::{Message, Stats};

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
pub(super) trait Sink {
    /// Publishes what changed.
    fn publish(&mut self, update: &Update<'_>, counts: &mut BTreeMap<String, u64>);
    /// Regular service between updates (e.g. the latest messages to a new subscriber).
    fn service(&mut self) {}
    /// Ends the output (closes the file).
    fn finish(self: Box<Self>) -> Result<(), String>;
}
