//! The ROS 2 messages the outputs publish, as serde structs whose field order is the `.msg`
//! definitions' (CDR serialises fields in declaration order, with no names), and those
//! definitions as text (`ros2msg`, the MCAP profile's schema encoding).
//!
//! - `nav_msgs/msg/OccupancyGrid`: `/terrain/fused` and `/terrain/layer_K`.
//! - `diagnostic_msgs/msg/DiagnosticArray`: `/diagnostics`.
//!
//! DDS carries them as `nav_msgs::msg::dds_::OccupancyGrid_` and
//! `diagnostic_msgs::msg::dds_::DiagnosticArray_` (the ROS 2 type names), CDR little-endian.
use serde::{Deserialize, Serialize};
use std::time::{SystemTime, UNIX_EPOCH};

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the Unix epoch.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds, 0 ..= 999 999 999.
    pub nanosec: u32,
}

impl Time {
    /// The time `t` (saturating at the limits of the `i32` seconds).
    #[must_use]
    pub fn of(t: SystemTime) -> Self {
        let d = t.duration_since(UNIX_EPOCH).unwrap_or_default();
        Self {
            sec: i32::try_from(d.as_secs()).unwrap_or(i32::MAX),
            nanosec: d.subsec_nanos(),
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// When the data was received (the host's clock).
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point`, metres.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct Point {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z, metres.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::yaw(0.0)
    }
}

impl Quaternion {
    /// A rotation of `yaw` radians about z.
    #[must_use]
    pub fn yaw(yaw: f64) -> Self {
        let h = yaw / 2.0;
        Self {
            x: 0.0,
            y: 0.0,
            z: h.sin(),
            w: h.cos(),
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// Position, metres.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct MapMetaData {
    /// When the map was loaded (here: the stamp of the data).
    pub map_load_time: Time,
    /// Cell size, metres.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The lower-left corner of cell (0, 0) in the frame, metres.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`: row-major from the lowest y, each row from the lowest x;
/// 0 ..= 100 occupancy probability in percent, −1 unknown.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct OccupancyGrid {
    /// Stamp and frame.
    pub header: Header,
    /// Geometry.
    pub info: MapMetaData,
    /// `width · height` cells.
    pub data: Vec<i8>,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Eq, Default)]
pub struct KeyValue {
    /// The name.
    pub key: String,
    /// The value, as text.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Eq, Default)]
pub struct DiagnosticStatus {
    /// 0 OK, 1 WARN, 2 ERROR, 3 STALE.
    pub level: u8,
    /// What is reported on.
    pub name: String,
    /// A summary.
    pub message: String,
    /// The device.
    pub hardware_id: String,
    /// The counters.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct DiagnosticArray {
    /// Stamp and frame (frame empty).
    pub header: Header,
    /// One status per component.
    pub status: Vec<DiagnosticStatus>,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6 × 6 covariance of (x, y, z, roll, pitch, yaw); CDR carries the 36 values
    /// with no length, as a 6 × 6 array does.
    pub covariance: [[f64; 6]; 6],
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Row-major 6 × 6 covariance.
    pub covariance: [[f64; 6]; 6],
}

/// `nav_msgs/msg/Odometry`: the robot's pose (`pyramid listen --odom-topic`).
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct Odometry {
    /// When the robot was at the pose (ROS time) and the pose's frame (`odom`).
    pub header: Header,
    /// The robot's body frame.
    pub child_frame_id: String,
    /// The pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// The velocity in `child_frame_id`.
    pub twist: TwistWithCovariance,
}

/// `DiagnosticStatus.level`: OK.
pub const LEVEL_OK: u8 = 0;
/// `DiagnosticStatus.level`: WARN.
pub const LEVEL_WARN: u8 = 1;

/// `DiagnosticStatus.level` of a check: [`LEVEL_OK`] when it passed (`ok`), else
/// [`LEVEL_WARN`].
#[must_use]
pub const fn level(ok: bool) -> u8 {
    if ok {
        LEVEL_OK
    } else {
        LEVEL_WARN
    }
}

/// The separator between the definitions of a `ros2msg` schema.
const SEPARATOR: &str =
    "================================================================================\n";

const HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";

/// The `ros2msg` schema of `nav_msgs/msg/OccupancyGrid` (its definition and those it uses).
#[must_use]
pub fn occupancy_grid_definition() -> String {
    [
        "std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n",
        HEADER,
        TIME,
        "MSG: nav_msgs/MapMetaData\nbuiltin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\ngeometry_msgs/Pose origin\n",
        "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
        "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n",
        "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    ]
    .join(SEPARATOR)
}

/// The `ros2msg` schema of `diagnostic_msgs/msg/DiagnosticArray`.
#[must_use]
pub fn diagnostic_array_definition() -> String {
    [
        "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n",
        HEADER,
        TIME,
        "MSG: diagnostic_msgs/DiagnosticStatus\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] values\n",
        "MSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n",
    ]
    .join(SEPARATOR)
}

/// A message as DDS and the MCAP `cdr` encoding carry it: the 4-byte encapsulation header
/// (CDR little-endian, `00 01 00 00`) and the CDR body.
///
/// # Errors
/// The serialiser's (none for these types).
pub fn to_cdr<T: Serialize>(message: &T) -> Result<Vec<u8>, String> {
    let body = cdr_encoding::to_vec::<T, byteorder::LittleEndian>(message)
        .map_err(|e| format!("cannot encode a ROS message as CDR: {e}"))?;
    let mut out = Vec::with_capacity(body.len() + 4);
    out.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    out.extend_from_slice(&body);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_occupancy_grid_in_cdr_has_the_layout_of_the_msg_definition() {
        let grid = OccupancyGrid {
            header: Header {
                stamp: Time { sec: 7, nanosec: 9 },
                frame_id: "odom".into(),
            },
            info: MapMetaData {
                map_load_time: Time { sec: 7, nanosec: 9 },
                resolution: 0.5,
                width: 2,
                height: 1,
                origin: Pose {
                    position: Point {
                        x: 1.0,
                        y: -2.0,
                        z: 0.0,
                    },
                    orientation: Quaternion::default(),
                },
            },
            data: vec![100, -1],
        };
        let bytes = to_cdr(&grid).unwrap();
        let mut expected = vec![0, 1, 0, 0];
        expected.extend(7_i32.to_le_bytes());
        expected.extend(9_u32.to_le_bytes());
        // "odom" with its terminating NUL, length-prefixed.
        expected.extend(5_u32.to_le_bytes());
        expected.extend(b"odom\0");
        expected.extend([0, 0, 0]); // align to 4
        expected.extend(7_i32.to_le_bytes());
        expected.extend(9_u32.to_le_bytes());
        expected.extend(0.5_f32.to_le_bytes());
        expected.extend(2_u32.to_le_bytes());
        expected.extend(1_u32.to_le_bytes());
        // The body offset is 40 here: the f64s are aligned to 8 already (alignment counts from
        // the body, not the encapsulation header).
        for v in [1.0_f64, -2.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            expected.extend(v.to_le_bytes());
        }
        expected.extend(2_u32.to_le_bytes());
        expected.extend([100_u8, 0xFF]);
        assert_eq!(bytes, expected);
    }

    #[test]
    fn the_definitions_name_every_type_they_use() {
        let grid = occupancy_grid_definition();
        for t in [
            "MSG: std_msgs/Header",
            "MSG: builtin_interfaces/Time",
            "MSG: nav_msgs/MapMetaData",
            "MSG: geometry_msgs/Pose",
            "MSG: geometry_msgs/Point",
            "MSG: geometry_msgs/Quaternion",
        ] {
            assert!(grid.contains(t), "{t}");
        }
        assert!(diagnostic_array_definition().contains("MSG: diagnostic_msgs/KeyValue"));
    }
}
