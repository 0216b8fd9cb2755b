//! The publishing thread: it takes the latest offered frame, works out what changed since
//! the last one it published, and hands that to each sink.

use super::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::{Condvar, Mutex, PoisonError};
use std::time::Duration;
use terrain_pyramid::wire::link::Stats;

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
        level: ros_msgs::level(frame.synced),
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
pub(super) struct Slot {
    pub(super) frame: Option<Box<Frame>>,
    pub(super) stop: bool,
    /// Hand-offs replaced before the thread took them.
    pub(super) coalesced: u64,
}

pub(super) struct Shared {
    pub(super) slot: Mutex<Slot>,
    pub(super) wake: Condvar,
}

impl Shared {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, Slot> {
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

pub(super) fn worker(
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
