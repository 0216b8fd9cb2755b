//! The ROS 2 output: a DDS participant (RustDDS, through `ros2-client`) with node
//! `/terrain_pyramid` publishing
//! - `/terrain/fused` and `/terrain/layer_K`: `nav_msgs/msg/OccupancyGrid`, QoS as Nav2's map
//!   topics expect: reliable, transient local, keep last 1 (a late subscriber, such as a
//!   costmap started after the maps, gets the latest map at once);
//! - `/diagnostics`: `diagnostic_msgs/msg/DiagnosticArray`, reliable, volatile, keep last 10.
//!
//! On the wire (RTPS) the topics are `rt/terrain/fused`, …, the types
//! `nav_msgs::msg::dds_::OccupancyGrid_` and `diagnostic_msgs::msg::dds_::DiagnosticArray_`.
//! A reliable writer whose history is full fails at once instead of waiting
//! ([`WhenFull::Fail`]): with keep last 1 the history never is, and a stuck reader can never
//! hold up the publishing thread.
use super::{count, ros_msgs, StartError, Update};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher,
    QosProfile,
};
use std::collections::BTreeMap;

/// The QoS of the map topics (Nav2's static layer subscribes reliable, transient local).
#[must_use]
pub fn map_qos() -> QosProfile {
    reliable_qos(Durability::TransientLocal, 1)
}

/// The QoS of `/diagnostics` (ROS 2's default publisher QoS, never waiting).
#[must_use]
pub fn diagnostics_qos() -> QosProfile {
    reliable_qos(Durability::Volatile, 10)
}

/// ROS 2's default publisher QoS, reliable without waiting when full, with `durability` and
/// the last `depth` messages kept.
fn reliable_qos(durability: Durability, depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Fail,
        })
        .durability(durability)
        .history(History::KeepLast { depth })
}

/// The node and its publishers.
pub struct Ros2Sink {
    node: Node,
    fused: Publisher<ros_msgs::OccupancyGrid>,
    layers: Vec<Publisher<ros_msgs::OccupancyGrid>>,
    diagnostics: Publisher<ros_msgs::DiagnosticArray>,
    // Dropped last: the participant.
    _context: Context,
}

fn err(message: String) -> StartError {
    StartError {
        flag: "--ros2",
        message,
    }
}

fn grid_publisher(
    node: &mut Node,
    name: &str,
) -> Result<Publisher<ros_msgs::OccupancyGrid>, String> {
    let qos = map_qos();
    let topic = node
        .create_topic(
            &Name::new("/terrain", name).map_err(|e| format!("topic {name}: {e:?}"))?,
            MessageTypeName::new("nav_msgs", "OccupancyGrid"),
            &qos,
        )
        .map_err(|e| format!("topic /terrain/{name}: {e:?}"))?;
    node.create_publisher(&topic, Some(qos))
        .map_err(|e| format!("publisher /terrain/{name}: {e:?}"))
}

impl Ros2Sink {
    /// Joins DDS domain `domain` and creates the node and its fixed publishers.
    ///
    /// # Errors
    /// The participant cannot be created (no usable network interface, …).
    pub fn start(domain: u16) -> Result<Self, StartError> {
        let context = Context::with_options(ContextOptions::new().domain_id(domain))
            .map_err(|e| err(format!("cannot join DDS domain {domain}: {e:?}")))?;
        let mut node = context
            .new_node(
                NodeName::new("/", "terrain_pyramid").map_err(|e| err(format!("{e:?}")))?,
                NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| err(format!("cannot create the node: {e:?}")))?;
        let fused = grid_publisher(&mut node, "fused").map_err(err)?;
        let qos = diagnostics_qos();
        let topic = node
            .create_topic(
                &Name::new("/", "diagnostics").map_err(|e| err(format!("{e:?}")))?,
                MessageTypeName::new("diagnostic_msgs", "DiagnosticArray"),
                &qos,
            )
            .map_err(|e| err(format!("topic /diagnostics: {e:?}")))?;
        let diagnostics = node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| err(format!("publisher /diagnostics: {e:?}")))?;
        Ok(Self {
            node,
            fused,
            layers: Vec::new(),
            diagnostics,
            _context: context,
        })
    }
}

impl super::Sink for Ros2Sink {
    fn publish(&mut self, update: &Update<'_>, counts: &mut BTreeMap<String, u64>) {
        for layer in &update.layers {
            while self.layers.len() <= layer.index {
                let name = format!("layer_{}", self.layers.len());
                match grid_publisher(&mut self.node, &name) {
                    Ok(p) => self.layers.push(p),
                    Err(_) => break,
                }
            }
            if let Some(p) = self.layers.get(layer.index) {
                if p.publish(layer.ros.clone()).is_ok() {
                    count(counts, "ros2", &super::topic_layer(layer.index));
                }
            }
        }
        if let Some(fused) = update.fused {
            if self.fused.publish(fused.ros.clone()).is_ok() {
                count(counts, "ros2", super::TOPIC_FUSED);
            }
        }
        if let Some(d) = update.diagnostics {
            if self.diagnostics.publish(d.clone()).is_ok() {
                count(counts, "ros2", super::TOPIC_DIAGNOSTICS);
            }
        }
    }

    fn finish(self: Box<Self>) -> Result<(), String> {
        Ok(())
    }
}
