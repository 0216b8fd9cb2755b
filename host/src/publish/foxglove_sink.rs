//! The Foxglove output: one Foxglove SDK context whose sinks are the WebSocket server
//! (`--foxglove`) and the MCAP writer (`--mcap`).
//!
//! Channels (every message stamped with the frame's host time, log time = stamp):
//! - `/terrain/grid/layer_K` (`foxglove.Grid`, protobuf): layer K's window at its cell size;
//!   fields `log_odds` (FLOAT32 nats, NaN unknown) at offset 0 and `occupancy` (INT8, −1
//!   unknown, else 0 ..= 100) at offset 4, cell stride 5.
//! - `/terrain/grid/fused` (`foxglove.Grid`): the fused map, field `occupancy` (INT8: 100
//!   obstacle, 0 navigable, −1 unknown).
//! - `/terrain/pose` (`foxglove.PoseInFrame`): the robot's pose.
//! - `/terrain/windows` (`foxglove.SceneUpdate`): entity `windows`, one closed line per layer.
//! - `/terrain/fused`, `/terrain/layer_K` (`nav_msgs/msg/OccupancyGrid`) and `/diagnostics`
//!   (`diagnostic_msgs/msg/DiagnosticArray`): the ROS 2 messages, CDR with `ros2msg` schemas,
//!   so the recording plays into ROS 2 (`ros2 bag play`) and Foxglove shows them as ROS maps.
//!
//! The WebSocket server queues at most [`BACKLOG`] messages per client and drops the oldest
//! beyond (the SDK's policy): logging never waits for a client. A client that subscribes is
//! sent the channel's latest message at once, so a map that no longer changes still shows.
use super::{count, grids::GridData, ros_msgs, subprotocol, Config, RobotPose, StartError, Update};
use foxglove::messages::{
    packed_element_field::NumericType, Color, Grid, LinePrimitive, PackedElementField, Point3,
    Pose, PoseInFrame, Quaternion, SceneEntity, SceneUpdate, Timestamp, Vector2, Vector3,
};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{
    ChannelId, Context, Encode, McapWriterHandle, PartialMetadata, RawChannel, Schema, SinkId,
    WebSocketServer, WebSocketServerHandle,
};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{SystemTime, UNIX_EPOCH};

/// Messages queued per WebSocket client before the oldest are dropped.
pub const BACKLOG: usize = 256;

/// Subscriptions not yet served their channel's latest message.
#[derive(Default)]
struct Subscriptions(Mutex<Vec<(Option<SinkId>, ChannelId)>>);

impl ServerListener for Subscriptions {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((client.sink_id(), channel.id()));
    }
}

struct Channel {
    raw: Arc<RawChannel>,
    /// The latest message and its log time.
    last: Option<(Vec<u8>, u64)>,
}

/// The Foxglove context and its sinks.
pub struct FoxgloveSink {
    context: Arc<Context>,
    server: Option<WebSocketServerHandle>,
    /// The listener on the user's address, in front of the server.
    gate: Option<subprotocol::Gate>,
    mcap: Option<McapWriterHandle<BufWriter<File>>>,
    subscriptions: Arc<Subscriptions>,
    channels: HashMap<String, Channel>,
    addr: Option<String>,
}

/// Splits `HOST:PORT` (`[v6]:PORT` too).
fn host_port(addr: &str) -> Option<(String, u16)> {
    let (host, port) = addr.rsplit_once(':')?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return None;
    }
    Some((host.to_string(), port.parse().ok()?))
}

fn nanos(t: SystemTime) -> u64 {
    t.duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

fn timestamp(t: SystemTime) -> Timestamp {
    let d = t.duration_since(UNIX_EPOCH).unwrap_or_default();
    Timestamp::new(
        u32::try_from(d.as_secs()).unwrap_or(u32::MAX),
        d.subsec_nanos(),
    )
}

fn identity() -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    }
}

fn field(name: &str, offset: u32, kind: NumericType) -> PackedElementField {
    PackedElementField {
        name: name.to_string(),
        offset,
        r#type: kind as i32,
    }
}

/// A grid as `foxglove.Grid`: the layers with `log_odds` and `occupancy`, the fused map with
/// `occupancy` only.
#[must_use]
pub fn grid_message(grid: &GridData, stamp: SystemTime, frame_id: &str) -> Grid {
    let (fields, stride, data): (Vec<PackedElementField>, u32, Vec<u8>) = match &grid.log_odds {
        Some(l) => {
            let mut data = Vec::with_capacity(grid.occupancy.len() * 5);
            for (v, o) in l.iter().zip(&grid.occupancy) {
                data.extend_from_slice(&v.to_le_bytes());
                data.extend_from_slice(&o.to_le_bytes());
            }
            (
                vec![
                    field("log_odds", 0, NumericType::Float32),
                    field("occupancy", 4, NumericType::Int8),
                ],
                5,
                data,
            )
        }
        None => (
            vec![field("occupancy", 0, NumericType::Int8)],
            1,
            grid.occupancy
                .iter()
                .flat_map(|o| o.to_le_bytes())
                .collect(),
        ),
    };
    let columns = u32::try_from(grid.width).unwrap_or(u32::MAX);
    Grid {
        timestamp: Some(timestamp(stamp)),
        frame_id: frame_id.to_string(),
        pose: Some(Pose {
            position: Some(Vector3 {
                x: grid.origin_m.0,
                y: grid.origin_m.1,
                z: 0.0,
            }),
            orientation: Some(identity()),
        }),
        column_count: columns,
        cell_size: Some(Vector2 {
            x: grid.resolution_m,
            y: grid.resolution_m,
        }),
        row_stride: columns.saturating_mul(stride),
        cell_stride: stride,
        fields,
        data: data.into(),
    }
}

fn pose_message(pose: RobotPose, stamp: SystemTime, frame_id: &str) -> PoseInFrame {
    let q = ros_msgs::Quaternion::yaw(pose.yaw);
    PoseInFrame {
        timestamp: Some(timestamp(stamp)),
        frame_id: frame_id.to_string(),
        pose: Some(Pose {
            position: Some(Vector3 {
                x: pose.x,
                y: pose.y,
                z: 0.0,
            }),
            orientation: Some(Quaternion {
                x: q.x,
                y: q.y,
                z: q.z,
                w: q.w,
            }),
        }),
    }
}

fn windows_message(
    windows: &[super::WindowOutline],
    stamp: SystemTime,
    frame_id: &str,
) -> SceneUpdate {
    let n = windows.len().max(1);
    let lines = windows
        .iter()
        .enumerate()
        .map(|(k, w)| {
            // From red (finest) to blue (coarsest).
            #[allow(clippy::cast_precision_loss)]
            let t = k as f64 / n as f64;
            #[allow(clippy::cast_precision_loss)]
            let z = 0.01 * k as f64;
            let corner = |x: f64, y: f64| Point3 { x, y, z };
            LinePrimitive {
                r#type: foxglove::messages::line_primitive::Type::LineLoop as i32,
                pose: Some(Pose {
                    position: Some(Vector3 {
                        x: 0.0,
                        y: 0.0,
                        z: 0.0,
                    }),
                    orientation: Some(identity()),
                }),
                thickness: 2.0,
                scale_invariant: true,
                points: vec![
                    corner(w.min.0, w.min.1),
                    corner(w.max.0, w.min.1),
                    corner(w.max.0, w.max.1),
                    corner(w.min.0, w.max.1),
                ],
                color: Some(Color {
                    r: 1.0 - t,
                    g: 0.3,
                    b: t,
                    a: 1.0,
                }),
                colors: Vec::new(),
                indices: Vec::new(),
            }
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(timestamp(stamp)),
            frame_id: frame_id.to_string(),
            id: "windows".to_string(),
            lifetime: None,
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines,
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }],
    }
}

/// The schema and encoding of a message type.
struct Kind {
    schema: Option<Schema>,
    encoding: String,
}

impl Kind {
    fn of<T: Encode>() -> Self {
        Self {
            schema: T::get_schema(),
            encoding: T::get_message_encoding(),
        }
    }

    fn ros2(name: &str, definition: String) -> Self {
        Self {
            schema: Some(Schema::new(name, "ros2msg", definition.into_bytes())),
            encoding: "cdr".to_string(),
        }
    }
}

impl FoxgloveSink {
    /// Starts the server and/or creates the file.
    ///
    /// # Errors
    /// The address is taken or invalid (`--foxglove`), the file cannot be created (`--mcap`).
    pub fn start(config: &Config) -> Result<Self, StartError> {
        let context = Context::new();
        let subscriptions = Arc::new(Subscriptions::default());
        let mut sink = Self {
            context: Arc::clone(&context),
            server: None,
            gate: None,
            mcap: None,
            subscriptions: Arc::clone(&subscriptions),
            channels: HashMap::new(),
            addr: None,
        };
        if let Some(path) = &config.mcap {
            let handle = context
                .mcap_writer()
                .create_new_buffered_file(path)
                .map_err(|e| StartError {
                    flag: "--mcap",
                    message: format!("cannot create {}: {e}", path.display()),
                })?;
            sink.mcap = Some(handle);
        }
        if let Some(addr) = &config.foxglove {
            let (host, port) = host_port(addr).ok_or_else(|| StartError {
                flag: "--foxglove",
                message: format!("{addr:?} is not an address HOST:PORT"),
            })?;
            // The user's address is the gate's (both names of the protocol, see
            // `subprotocol`); the SDK's server listens on loopback behind it.
            let listener = std::net::TcpListener::bind((host.as_str(), port)).map_err(|io| {
                let message = if io.kind() == std::io::ErrorKind::AddrInUse {
                    format!("{addr} is already in use")
                } else {
                    format!("cannot listen on {addr}: {io}")
                };
                StartError {
                    flag: "--foxglove",
                    message,
                }
            })?;
            let server = WebSocketServer::new()
                .name("terrain-pyramid")
                .bind("127.0.0.1", 0)
                .context(&context)
                .message_backlog_size(BACKLOG)
                .listener(subscriptions)
                .start_blocking()
                .map_err(|e| StartError {
                    flag: "--foxglove",
                    message: format!("cannot start the server behind {addr}: {e}"),
                })?;
            let inner = std::net::SocketAddr::from(([127, 0, 0, 1], server.port()));
            let gate = subprotocol::Gate::start(listener, inner).map_err(|e| StartError {
                flag: "--foxglove",
                message: format!("cannot serve {addr}: {e}"),
            })?;
            let bound = if host.contains(':') {
                format!("[{host}]:{}", gate.addr().port())
            } else {
                format!("{host}:{}", gate.addr().port())
            };
            sink.gate = Some(gate);
            sink.addr = Some(bound);
            sink.server = Some(server);
        }
        Ok(sink)
    }

    /// The server's bound address, when on.
    pub fn addr(&self) -> Option<String> {
        self.addr.clone()
    }

    fn log(&mut self, topic: &str, kind: impl FnOnce() -> Kind, bytes: Vec<u8>, time: u64) -> bool {
        let channel = match self.channels.get_mut(topic) {
            Some(c) => c,
            None => {
                let kind = kind();
                let built = self
                    .context
                    .channel_builder(topic)
                    .message_encoding(kind.encoding)
                    .schema(kind.schema)
                    .build_raw();
                let Ok(raw) = built else {
                    return false;
                };
                self.channels
                    .entry(topic.to_string())
                    .or_insert(Channel { raw, last: None })
            }
        };
        channel
            .raw
            .log_with_meta(&bytes, PartialMetadata::with_log_time(time));
        channel.last = Some((bytes, time));
        true
    }

    fn log_typed<T: Encode>(&mut self, topic: &str, message: &T, time: u64) -> bool {
        let mut bytes = Vec::new();
        if message.encode(&mut bytes).is_err() {
            return false;
        }
        self.log(topic, Kind::of::<T>, bytes, time)
    }

    fn log_ros<T: serde::Serialize>(
        &mut self,
        topic: &str,
        name: &str,
        definition: fn() -> String,
        message: &T,
        time: u64,
    ) -> bool {
        let Ok(bytes) = ros_msgs::to_cdr(message) else {
            return false;
        };
        self.log(topic, || Kind::ros2(name, definition()), bytes, time)
    }
}

impl super::Sink for FoxgloveSink {
    fn publish(&mut self, update: &Update<'_>, counts: &mut BTreeMap<String, u64>) {
        let Some(stamp) = update.stamp else {
            return;
        };
        let time = nanos(stamp);
        let frame_id = update.frame_id;
        let mut sent = |ok: bool, topic: &str| {
            if ok {
                count(counts, "foxglove", topic);
            }
        };
        for layer in &update.layers {
            let topic = super::topic_grid_layer(layer.index);
            let ok = self.log_typed(&topic, &grid_message(&layer.grid, stamp, frame_id), time);
            sent(ok, &topic);
            let topic = super::topic_layer(layer.index);
            let ok = self.log_ros(
                &topic,
                "nav_msgs/msg/OccupancyGrid",
                ros_msgs::occupancy_grid_definition,
                &layer.ros,
                time,
            );
            sent(ok, &topic);
        }
        if let Some(fused) = update.fused {
            let ok = self.log_typed(
                super::TOPIC_GRID_FUSED,
                &grid_message(&fused.grid, stamp, frame_id),
                time,
            );
            sent(ok, super::TOPIC_GRID_FUSED);
            let ok = self.log_ros(
                super::TOPIC_FUSED,
                "nav_msgs/msg/OccupancyGrid",
                ros_msgs::occupancy_grid_definition,
                &fused.ros,
                time,
            );
            sent(ok, super::TOPIC_FUSED);
        }
        if let Some(pose) = update.pose {
            let ok = self.log_typed(
                super::TOPIC_POSE,
                &pose_message(pose, stamp, frame_id),
                time,
            );
            sent(ok, super::TOPIC_POSE);
        }
        if let Some(windows) = update.windows {
            let ok = self.log_typed(
                super::TOPIC_WINDOWS,
                &windows_message(windows, stamp, frame_id),
                time,
            );
            sent(ok, super::TOPIC_WINDOWS);
        }
        if let Some(diagnostics) = update.diagnostics {
            let ok = self.log_ros(
                super::TOPIC_DIAGNOSTICS,
                "diagnostic_msgs/msg/DiagnosticArray",
                ros_msgs::diagnostic_array_definition,
                diagnostics,
                time,
            );
            sent(ok, super::TOPIC_DIAGNOSTICS);
        }
    }

    fn service(&mut self) {
        let pending: Vec<(Option<SinkId>, ChannelId)> = std::mem::take(
            &mut *self
                .subscriptions
                .0
                .lock()
                .unwrap_or_else(PoisonError::into_inner),
        );
        for (sink, id) in pending {
            let Some(sink) = sink else { continue };
            if let Some(channel) = self.channels.values().find(|c| c.raw.id() == id) {
                if let Some((bytes, time)) = &channel.last {
                    channel.raw.log_with_meta_to_sink(
                        bytes,
                        PartialMetadata::with_log_time(*time),
                        Some(sink),
                    );
                }
            }
        }
    }

    fn finish(self: Box<Self>) -> Result<(), String> {
        let this = *self;
        // No new connection, then the server and (with it) the open ones.
        drop(this.gate);
        if let Some(server) = this.server {
            // The server's tasks end by themselves once stopped.
            server.stop().detach_all();
        }
        if let Some(mcap) = this.mcap {
            mcap.close()
                .map_err(|e| format!("cannot finish the MCAP file: {e}"))?;
        }
        drop(this.channels);
        Ok(())
    }
}
