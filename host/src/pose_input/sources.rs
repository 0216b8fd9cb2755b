//! The pose sources of `pyramid listen`: a UDP socket of newline-delimited JSON and a ROS 2
//! Odometry subscription, each a thread that sends [`SourceEvent`]s down a channel, and the
//! DDS publishers the subscription has matched ([`OdometryPublishers`]).

use super::{odometry_pose, parse_line, BadInput, SourceEvent};
use serde::Serialize;
use std::net::UdpSocket;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

/// The largest UDP datagram read, bytes (several lines may share one).
const MAX_DATAGRAM: usize = 65_536;

/// How long a source thread waits for input before looking at its stop flag.
const SOURCE_POLL: Duration = Duration::from_millis(100);

/// How often the Odometry subscription is polled for new messages.
const ODOMETRY_POLL: Duration = Duration::from_millis(1);

/// A running source thread: stopped and joined when dropped.
pub struct Source {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
    /// What it listens on, in words (`udp 127.0.0.1:7420`, `ros2 /odom`).
    pub name: String,
    /// The DDS publishers matched, for an Odometry subscription (`None` for UDP).
    publishers: Option<Arc<PublisherCounts>>,
}

impl Source {
    /// The DDS publishers the subscription has matched so far (an Odometry source; `None`
    /// for the UDP input, which has no publishers to match).
    #[must_use]
    pub fn publishers(&self) -> Option<OdometryPublishers> {
        self.publishers.as_deref().map(PublisherCounts::snapshot)
    }
}

/// The DDS publishers (writers) an Odometry subscription has met, as its DDS library
/// (RustDDS) reports them: matched ones (their QoS compatible with the subscription's) and
/// those refused for their QoS. Counts of distinct writers; they saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct OdometryPublishers {
    /// Publishers matched now (matched and not lost since).
    pub matched: u64,
    /// Publishers matched since the subscription began, each counted once.
    pub matched_total: u64,
    /// Publishers on the topic whose QoS the subscription cannot match, each counted once
    /// (with the subscription's best effort, volatile QoS, none should be).
    pub incompatible: u64,
}

/// [`OdometryPublishers`] shared between the subscribing thread and the session.
#[derive(Debug, Default)]
struct PublisherCounts {
    matched: AtomicU64,
    matched_total: AtomicU64,
    incompatible: AtomicU64,
}

impl PublisherCounts {
    fn snapshot(&self) -> OdometryPublishers {
        OdometryPublishers {
            matched: self.matched.load(Ordering::Relaxed),
            matched_total: self.matched_total.load(Ordering::Relaxed),
            incompatible: self.incompatible.load(Ordering::Relaxed),
        }
    }
}

/// Follows the DDS discovery events of one subscription (its reader's GUID): the writers
/// matched, lost and refused for their QoS.
#[derive(Debug)]
struct PublisherTracker {
    reader: ros2_client::dds::rustdds::GUID,
    matched: std::collections::BTreeSet<ros2_client::dds::rustdds::GUID>,
    ever: std::collections::BTreeSet<ros2_client::dds::rustdds::GUID>,
    incompatible: std::collections::BTreeSet<ros2_client::dds::rustdds::GUID>,
    counts: Arc<PublisherCounts>,
}

impl PublisherTracker {
    /// Takes one event of the participant (those of other readers are ignored).
    fn take(&mut self, event: ros2_client::dds::rustdds::DomainParticipantStatusEvent) {
        use ros2_client::dds::rustdds::DomainParticipantStatusEvent as E;
        match event {
            E::RemoteWriterMatched {
                local_reader,
                remote_writer,
            } if local_reader == self.reader => {
                self.matched.insert(remote_writer);
                self.ever.insert(remote_writer);
            }
            E::WriterLost { guid, .. } => {
                self.matched.remove(&guid);
            }
            E::RemoteWriterQosIncompatible {
                local_reader,
                remote_writer,
                ..
            } if local_reader == self.reader => {
                self.incompatible.insert(remote_writer);
            }
            _ => return,
        }
        let n = |s: &std::collections::BTreeSet<_>| u64::try_from(s.len()).unwrap_or(u64::MAX);
        self.counts
            .matched
            .store(n(&self.matched), Ordering::Relaxed);
        self.counts
            .matched_total
            .store(n(&self.ever), Ordering::Relaxed);
        self.counts
            .incompatible
            .store(n(&self.incompatible), Ordering::Relaxed);
    }
}

impl std::fmt::Debug for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Source").field("name", &self.name).finish()
    }
}

impl Drop for Source {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// Binds `addr` (UDP) and reads newline-delimited JSON poses ([`parse_line`]) on a thread of
/// its own, sending each line's pose or fault down `tx`. Returns the source and the bound
/// address.
///
/// # Errors
/// The address cannot be bound.
pub fn spawn_udp(
    addr: &str,
    tx: mpsc::SyncSender<SourceEvent>,
) -> Result<(Source, std::net::SocketAddr), String> {
    let socket =
        UdpSocket::bind(addr).map_err(|e| format!("--pose-udp: cannot bind {addr}: {e}"))?;
    socket
        .set_read_timeout(Some(SOURCE_POLL))
        .map_err(|e| format!("--pose-udp: {e}"))?;
    let local = socket
        .local_addr()
        .map_err(|e| format!("--pose-udp: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let handle = std::thread::Builder::new()
        .name("pose-udp".into())
        .spawn(move || {
            let mut buf = vec![0_u8; MAX_DATAGRAM];
            while !flag.load(Ordering::SeqCst) {
                let Ok(n) = socket.recv(&mut buf) else {
                    continue;
                };
                for event in datagram_events(buf.get(..n).unwrap_or_default()) {
                    if tx.send(event).is_err() {
                        return;
                    }
                }
            }
        })
        .map_err(|e| format!("--pose-udp: cannot start its thread: {e}"))?;
    Ok((
        Source {
            stop,
            handle: Some(handle),
            name: format!("udp {local}"),
            publishers: None,
        },
        local,
    ))
}

/// The events of one datagram: one per non-blank line.
#[must_use]
pub fn datagram_events(bytes: &[u8]) -> Vec<SourceEvent> {
    bytes
        .split(|&b| b == b'\n')
        .filter(|l| !l.iter().all(u8::is_ascii_whitespace))
        .map(|l| {
            std::str::from_utf8(l)
                .map_err(|_| BadInput::NotJson)
                .and_then(parse_line)
                .map_or_else(SourceEvent::Bad, SourceEvent::Pose)
        })
        .collect()
}

/// Subscribes `topic` (`nav_msgs/msg/Odometry`) in DDS domain `domain` on a thread of its own
/// (a participant of its own, node `/terrain_pyramid_odometry`), sending each message's pose
/// ([`odometry_pose`]) or fault down `tx`. QoS best effort, volatile, keep last 10: it matches
/// reliable and best-effort publishers, volatile and transient-local ones. The publishers it
/// matches (and any refused for their QoS) are counted from the participant's discovery
/// events ([`Source::publishers`]).
///
/// # Errors
/// The participant, the node or the subscription cannot be made (reported before the
/// session starts).
pub fn spawn_odometry(
    domain: u16,
    topic: &str,
    tx: mpsc::SyncSender<SourceEvent>,
) -> Result<Source, String> {
    use ros2_client::dds::rustdds::StatusEvented;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let counts = Arc::new(PublisherCounts::default());
    let shared = Arc::clone(&counts);
    let (ready_tx, ready_rx) = mpsc::channel::<Result<(), String>>();
    let topic_name = topic.to_string();
    let handle = std::thread::Builder::new()
        .name("pose-ros2".into())
        .spawn(move || {
            let subscription = match odometry_subscription(domain, &topic_name) {
                Ok(s) => {
                    let _ = ready_tx.send(Ok(()));
                    s
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            let (context, _node, subscription) = subscription;
            // Nothing else reads the participant's events (no spinner runs): the matches
            // are this subscription's to follow.
            let status = context.domain_participant().status_listener();
            let mut tracker = PublisherTracker {
                reader: subscription.guid(),
                matched: std::collections::BTreeSet::new(),
                ever: std::collections::BTreeSet::new(),
                incompatible: std::collections::BTreeSet::new(),
                counts: shared,
            };
            while !flag.load(Ordering::SeqCst) {
                while let Some(event) = status.try_recv_status() {
                    tracker.take(event);
                }
                match subscription.take() {
                    Ok(Some((message, _info))) => {
                        let event = odometry_pose(&message)
                            .map_or_else(SourceEvent::Bad, SourceEvent::Pose);
                        if tx.send(event).is_err() {
                            return;
                        }
                    }
                    Ok(None) => std::thread::sleep(ODOMETRY_POLL),
                    // A sample that does not decode as Odometry (another type on the topic).
                    Err(_) => {
                        if tx.send(SourceEvent::Bad(BadInput::Fields)).is_err() {
                            return;
                        }
                    }
                }
            }
        })
        .map_err(|e| format!("--odom-topic: cannot start its thread: {e}"))?;
    let source = Source {
        stop,
        handle: Some(handle),
        name: format!("ros2 {topic}"),
        publishers: Some(counts),
    };
    match ready_rx.recv() {
        Ok(Ok(())) => Ok(source),
        Ok(Err(e)) => Err(e),
        Err(_) => Err("--odom-topic: the subscribing thread ended before it was ready".into()),
    }
}

type OdometrySubscription = (
    ros2_client::Context,
    ros2_client::Node,
    ros2_client::Subscription<crate::publish::ros_msgs::Odometry>,
);

/// The QoS of the Odometry subscription: best effort, volatile, keep last 10. A best-effort
/// reader matches reliable and best-effort writers, a volatile one volatile and
/// transient-local ones: every publisher's QoS is taken.
#[must_use]
pub fn odometry_qos() -> ros2_client::QosProfile {
    use ros2_client::qos::{Durability, History, Reliability};
    ros2_client::QosProfile::subscription_default()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

fn odometry_subscription(domain: u16, topic: &str) -> Result<OdometrySubscription, String> {
    use ros2_client::{Context, ContextOptions, MessageTypeName, NodeName, NodeOptions};
    let err = |what: &str, e: &dyn std::fmt::Debug| format!("--odom-topic {topic}: {what}: {e:?}");
    let context = Context::with_options(ContextOptions::new().domain_id(domain))
        .map_err(|e| err("cannot join the DDS domain", &e))?;
    let mut node = context
        .new_node(
            NodeName::new("/", "terrain_pyramid_odometry").map_err(|e| err("node name", &e))?,
            NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| err("cannot create the node", &e))?;
    let name = topic_name(topic).map_err(|e| format!("--odom-topic {topic}: {e}"))?;
    let qos = odometry_qos();
    let t = node
        .create_topic(&name, MessageTypeName::new("nav_msgs", "Odometry"), &qos)
        .map_err(|e| err("cannot create the topic", &e))?;
    let subscription = node
        .create_subscription(&t, Some(qos))
        .map_err(|e| err("cannot subscribe", &e))?;
    Ok((context, node, subscription))
}

/// A ROS 2 topic name (`/odom`, `/robot/odom`, `odom`) as namespace and base name.
pub(super) fn topic_name(topic: &str) -> Result<ros2_client::Name, String> {
    let t = topic.trim();
    let absolute = t.strip_prefix('/').unwrap_or(t);
    let (namespace, base) = match absolute.rsplit_once('/') {
        Some((ns, base)) => (format!("/{ns}"), base),
        None => ("/".to_string(), absolute),
    };
    ros2_client::Name::new(&namespace, base).map_err(|e| format!("not a topic name: {e:?}"))
}
