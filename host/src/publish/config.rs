//! The outputs' command-line flags ([`OutputArgs`]) and the configuration they make
//! ([`Config`]).

use super::*;
use std::path::PathBuf;
use terrain_pyramid::LogOddsFixed;

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
