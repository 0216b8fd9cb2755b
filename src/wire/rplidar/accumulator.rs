//! Stream reassembly: descriptors, responses, nodes and capsules out of UART chunks.

use super::capsule::RplidarExpressScan;
use super::descriptor::{known, Follow, RplidarResponse};
use super::node::node_is_valid;
use super::plausible::NodeFollower;
use super::{
    RplidarCapsule, RplidarDescriptor, RplidarError, RplidarNode, RPLIDAR_CAPSULE_LEN,
    RPLIDAR_DESCRIPTOR_LEN, RPLIDAR_DESCRIPTOR_SYNC, RPLIDAR_NODE_LEN, RPLIDAR_NODE_RUN,
};
use crate::wire::resync::{self, Resync, Scan};
use crate::wire::window::{bump, bump_by, Window};
use crate::wire::FeedResult;

/// The window: a capsule (84 bytes) or a run of 16 nodes (80 bytes), with room to spare.
const WINDOW: usize = 96;

/// The data the accumulator expects when no descriptor announced it (a device already
/// streaming when the accumulator starts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RplidarScanMode {
    /// Standard-scan nodes (SCAN, FORCE_SCAN).
    Standard,
    /// Legacy express-scan capsules (EXPRESS_SCAN, working mode 0).
    Express,
}

/// What an [`RplidarAccumulator`] hands out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RplidarItem<'a> {
    /// A known response descriptor; the data it announces follows.
    Descriptor(RplidarDescriptor<&'a [u8]>),
    /// A single response (GET_HEALTH, GET_INFO, GET_SAMPLERATE) after its descriptor.
    Response(RplidarResponse<'a>),
    /// A standard-scan node that passed its checks.
    Node(RplidarNode<&'a [u8]>),
    /// A capsule placed with the start angle of the capsule that directly followed it.
    Express(RplidarExpressScan<'a>),
}

impl<'a> RplidarItem<'a> {
    /// The bytes of the unit as they arrived (for [`Express`](Self::Express), the capsule
    /// whose points it places).
    #[must_use]
    pub fn as_bytes(&self) -> &'a [u8] {
        match *self {
            Self::Descriptor(d) => d.into_inner(),
            Self::Response(r) => r.data,
            Self::Node(n) => n.into_inner(),
            Self::Express(e) => e.capsule().into_inner(),
        }
    }
}

/// What an [`RplidarAccumulator`] has seen since it was made (or since
/// [`RplidarAccumulator::clear_counters`]). Every counter saturates at `u32::MAX`.
///
/// Every byte fed is accounted for exactly once: after [`RplidarAccumulator::flush`], the
/// stream length is `7·descriptors + (response bytes) + 5·nodes + 84·(capsules +
/// capsules_unpaired) + node_check + checksum + truncated + garbage_bytes +
/// 5·implausible` (a rejected
/// candidate accounts for its first byte; the bytes after it are hunted through again).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarCounters {
    /// Known descriptors handed out.
    pub descriptors: u32,
    /// Single responses handed out.
    pub responses: u32,
    /// Standard-scan nodes handed out.
    pub nodes: u32,
    /// Capsules whose returns were handed out (paired with their successor).
    pub capsules: u32,
    /// Nodes that failed their checks while the accumulator was locked on to the node
    /// stream (it then hunts for a new run of 16).
    pub node_check: u32,
    /// Candidate capsules (sync nibbles right) whose checksum did not match.
    pub checksum: u32,
    /// Valid capsules dropped because no capsule followed them directly or the next one
    /// started a new scan: their points could not be placed.
    pub capsules_unpaired: u32,
    /// Descriptors announcing data this module does not decode (dense or ultra capsules);
    /// the data is counted as garbage until the next known descriptor.
    pub unsupported: u32,
    /// Units cut short by the end of the stream ([`RplidarAccumulator::flush`]).
    pub truncated: u32,
    /// Bytes outside every unit: between responses, in an unsupported data stream, or
    /// skipped while hunting for the node or capsule alignment (nodes still waiting for a run
    /// of 16 at the end of the stream included).
    pub garbage_bytes: u32,
    /// Nodes that passed their check bits but whose angle cannot follow their neighbours
    /// ([`RplidarError::Implausible`]): refused whole, 5 bytes each, the lock kept.
    pub implausible: u32,
}

/// What the accumulator expects next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// A response descriptor; anything else is garbage.
    Descriptor,
    /// A single response of this data type and length.
    Response(u8, usize),
    /// Standard-scan nodes, locked on to their alignment or hunting for it.
    Nodes { locked: bool },
    /// Legacy capsules.
    Capsules,
}

/// What the unit handed out by the last call is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Descriptor,
    Response(u8),
    Node,
    /// A capsule placed with the next one, which sits at the front of the window.
    Express,
}

/// Follows an RPLIDAR byte stream fed in chunks of any size: response descriptors, then the
/// data each announces (a single response, standard-scan nodes or legacy capsules), and the
/// next descriptor whenever one starts at a unit boundary.
///
/// Capsules are handed out one behind: a capsule's returns need the next capsule's start
/// angle, so the accumulator keeps the latest valid capsule (84 bytes, besides its 96-byte
/// window) and hands out [`RplidarItem::Express`] for it when the next one arrives directly
/// after it. A gap, a rejected candidate, a new-scan flag, a descriptor or the end of the
/// stream drops the kept capsule, reported as [`RplidarError::CapsuleUnpaired`].
///
/// After sending a request whose answer it wants, a host calls
/// [`expect_response`](Self::expect_response); a device already streaming when the
/// accumulator starts is followed with [`with_mode`](Self::with_mode).
///
/// ```
/// use terrain_pyramid::wire::rplidar::{RplidarAccumulator, RplidarItem, RplidarNodeRepr};
/// use terrain_pyramid::wire::FeedResult;
///
/// // The SCAN descriptor, then two nodes.
/// let mut stream = vec![0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
/// for angle_q6 in [0, 64] {
///     let mut node = [0; 5];
///     RplidarNodeRepr { quality: 47, start: angle_q6 == 0, angle_q6, distance_q2: 4000 }
///         .emit(&mut node)
///         .unwrap();
///     stream.extend_from_slice(&node);
/// }
/// let mut acc = RplidarAccumulator::new();
/// let mut ranges = Vec::new();
/// let mut window = &stream[..];
/// loop {
///     window = match acc.feed(window) {
///         FeedResult::Consumed => break,
///         FeedResult::Item { item: RplidarItem::Node(n), remaining, .. } => {
///             ranges.push(n.to_return().range_mm);
///             remaining
///         }
///         FeedResult::Item { remaining, .. } | FeedResult::Rejected { remaining, .. } => remaining,
///     };
/// }
/// assert_eq!(ranges, [1000, 1000]);
/// ```
#[derive(Debug, Clone)]
pub struct RplidarAccumulator {
    window: Window<WINDOW>,
    mode: Mode,
    /// The kind of the unit handed out by the last call, at the front.
    kind: Kind,
    /// The latest valid capsule, waiting for its successor.
    prev: [u8; RPLIDAR_CAPSULE_LEN],
    prev_valid: bool,
    prev_offset: u64,
    /// Whether the kept capsule's point 0 starts a revolution.
    prev_wraps: bool,
    /// The nodes a new node's angle is judged against.
    follower: NodeFollower,
    counters: RplidarCounters,
}

resync::accumulator_impls!(RplidarAccumulator);

impl RplidarAccumulator {
    /// An accumulator expecting a response descriptor, at stream position 0, with zeroed
    /// counters.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            window: Window::new(),
            mode: Mode::Descriptor,
            kind: Kind::Descriptor,
            prev: [0; RPLIDAR_CAPSULE_LEN],
            prev_valid: false,
            prev_offset: 0,
            prev_wraps: false,
            follower: NodeFollower::NEW,
            counters: RplidarCounters {
                descriptors: 0,
                responses: 0,
                nodes: 0,
                capsules: 0,
                node_check: 0,
                checksum: 0,
                capsules_unpaired: 0,
                unsupported: 0,
                truncated: 0,
                garbage_bytes: 0,
                implausible: 0,
            },
        }
    }

    /// An accumulator joining a device already streaming in `mode`, whose descriptor it has
    /// not seen: nodes are accepted once a run of 16 aligns them, capsules once two in a row
    /// pass.
    #[must_use]
    pub const fn with_mode(mode: RplidarScanMode) -> Self {
        let mut acc = Self::new();
        acc.mode = match mode {
            RplidarScanMode::Standard => Mode::Nodes { locked: false },
            RplidarScanMode::Express => Mode::Capsules,
        };
        acc
    }

    /// Expects a response descriptor next (call it after sending a request): whatever
    /// precedes the descriptor is garbage. A kept capsule is dropped (counted in
    /// [`RplidarCounters::capsules_unpaired`], not reported).
    pub fn expect_response(&mut self) {
        if self.prev_valid {
            self.prev_valid = false;
            bump(&mut self.counters.capsules_unpaired);
        }
        self.mode = Mode::Descriptor;
    }

    resync::feed_and_flush!(
        RplidarItem,
        RplidarError,
        "Ends the stream: rejects a unit still incomplete as [`RplidarError::Truncated`], counts \
         bytes still being hunted through as garbage, and drops a kept capsule \
         ([`RplidarError::CapsuleUnpaired`]). Call it until it returns [`FeedResult::Consumed`]."
    );

    resync::stream_accessors!(
        RplidarCounters,
        "Bytes buffered and not yet resolved (the kept capsule not included)."
    );

    /// Drops everything buffered and the kept capsule, uncounted, and expects a descriptor;
    /// keeps the counters and the stream position.
    pub fn reset(&mut self) {
        self.window.clear();
        self.prev_valid = false;
        self.mode = Mode::Descriptor;
    }

    /// The kept capsule placed with the capsule at the front of the window.
    fn express(&self) -> Option<RplidarExpressScan<'_>> {
        let next = RplidarCapsule::new_unchecked(self.window.live());
        self.prev_valid.then(|| {
            RplidarExpressScan::new(
                RplidarCapsule::new_unchecked(&self.prev[..]),
                next.start_angle_q6(),
            )
            .wrapping_at_start(self.prev_wraps)
        })
    }

    /// Drops the kept capsule, counting it; its stream position when there was one.
    fn drop_prev(&mut self) -> Option<u64> {
        if !self.prev_valid {
            return None;
        }
        self.prev_valid = false;
        bump(&mut self.counters.capsules_unpaired);
        Some(self.prev_offset)
    }

    fn deliver(&mut self, kind: Kind, len: usize) -> Scan<RplidarError> {
        self.kind = kind;
        self.window.hand_out(len);
        Scan::Item(self.window.offset_of(0))
    }

    /// Hands out a node that passed its check bits at the front, or refuses it whole (its 5
    /// bytes; the lock kept) when its angle cannot follow its neighbours.
    fn deliver_node(&mut self, node: &[u8; RPLIDAR_NODE_LEN]) -> Scan<RplidarError> {
        let view = RplidarNode::new_unchecked(&node[..]);
        let offset = self.window.offset_of(0);
        if self.follower.judge(
            view.angle_q6(),
            view.starts_revolution(),
            view.distance_q2(),
            offset,
        ) {
            bump(&mut self.counters.nodes);
            return self.deliver(Kind::Node, RPLIDAR_NODE_LEN);
        }
        bump(&mut self.counters.implausible);
        self.window.drop_front(RPLIDAR_NODE_LEN);
        Scan::Rejected(RplidarError::Implausible, offset)
    }

    fn garbage(&mut self, n: usize) {
        bump_by(&mut self.counters.garbage_bytes, n);
        self.window.drop_front(n);
    }

    /// Rejects the unit at the front: counts it in `counter` and drops its first byte.
    fn reject(&mut self, error: RplidarError) -> Scan<RplidarError> {
        let counter = match error {
            RplidarError::BadNode => &mut self.counters.node_check,
            RplidarError::BadChecksum { .. } => &mut self.counters.checksum,
            _ => &mut self.counters.truncated,
        };
        bump(counter);
        let offset = self.window.offset_of(0);
        self.window.drop_front(1);
        Scan::Rejected(error, offset)
    }
}

impl Resync<WINDOW> for RplidarAccumulator {
    type Item<'a> = RplidarItem<'a>;
    type Error = RplidarError;

    fn window(&mut self) -> &mut Window<WINDOW> {
        &mut self.window
    }

    /// Drops the unit handed out by the last call; a capsule placed by the one at the front
    /// makes way for it.
    fn release(&mut self) {
        if self.kind == Kind::Express && !self.window.handed_out().is_empty() {
            let wraps = self.express().is_some_and(|e| e.wraps_at_end());
            if let Some(front) = self.window.live().first_chunk::<RPLIDAR_CAPSULE_LEN>() {
                self.prev = *front;
                self.prev_offset = self.window.offset_of(0);
                self.prev_valid = true;
                self.prev_wraps = wraps;
            }
        }
        self.window.release();
    }

    fn item(&self) -> RplidarItem<'_> {
        let bytes = self.window.handed_out();
        match self.kind {
            Kind::Descriptor => RplidarItem::Descriptor(RplidarDescriptor::new_unchecked(bytes)),
            Kind::Response(data_type) => RplidarItem::Response(RplidarResponse {
                data_type,
                data: bytes,
            }),
            Kind::Node => RplidarItem::Node(RplidarNode::new_unchecked(bytes)),
            Kind::Express => match self.express() {
                Some(e) => RplidarItem::Express(e),
                None => RplidarItem::Express(RplidarExpressScan::new(
                    RplidarCapsule::new_unchecked(&self.prev[..]),
                    0,
                )),
            },
        }
    }

    fn scan(&mut self) -> Scan<RplidarError> {
        loop {
            let live = self.window.live();
            let len = live.len();
            let Some(&first) = live.first() else {
                self.window.clear();
                return Scan::Empty;
            };
            // A known descriptor may start at any unit boundary but inside a response.
            if first == RPLIDAR_DESCRIPTOR_SYNC[0] && !matches!(self.mode, Mode::Response(..)) {
                match live.get(1) {
                    None => {
                        return Scan::Need {
                            more: 1,
                            candidate: matches!(self.mode, Mode::Nodes { locked: true }),
                        }
                    }
                    Some(&second) if second == RPLIDAR_DESCRIPTOR_SYNC[1] => {
                        let Some(descriptor) = live.first_chunk::<RPLIDAR_DESCRIPTOR_LEN>() else {
                            return Scan::Need {
                                more: RPLIDAR_DESCRIPTOR_LEN - len,
                                candidate: true,
                            };
                        };
                        if let Some(follow) = known(descriptor) {
                            // The kept capsule lies before the descriptor: report it first.
                            if let Some(offset) = self.drop_prev() {
                                return Scan::Rejected(RplidarError::CapsuleUnpaired, offset);
                            }
                            bump(&mut self.counters.descriptors);
                            self.follower.forget();
                            self.mode = match follow {
                                Follow::Nodes => Mode::Nodes { locked: true },
                                Follow::Capsules => Mode::Capsules,
                                Follow::Response(data_type, len) => Mode::Response(data_type, len),
                                Follow::Unsupported => {
                                    bump(&mut self.counters.unsupported);
                                    Mode::Descriptor
                                }
                            };
                            return self.deliver(Kind::Descriptor, RPLIDAR_DESCRIPTOR_LEN);
                        }
                    }
                    Some(_) => {}
                }
            }
            match self.mode {
                Mode::Descriptor => {
                    let skip = live
                        .iter()
                        .skip(1)
                        .position(|&b| b == RPLIDAR_DESCRIPTOR_SYNC[0])
                        .map_or(len, |p| p + 1);
                    self.garbage(skip);
                }
                Mode::Response(data_type, rlen) => {
                    if len < rlen {
                        return Scan::Need {
                            more: rlen - len,
                            candidate: true,
                        };
                    }
                    bump(&mut self.counters.responses);
                    self.mode = Mode::Descriptor;
                    return self.deliver(Kind::Response(data_type), rlen);
                }
                Mode::Nodes { locked: true } => {
                    let Some(node) = live.first_chunk::<RPLIDAR_NODE_LEN>() else {
                        return Scan::Need {
                            more: RPLIDAR_NODE_LEN - len,
                            candidate: true,
                        };
                    };
                    if node_is_valid(node) {
                        let node = *node;
                        return self.deliver_node(&node);
                    }
                    self.mode = Mode::Nodes { locked: false };
                    return self.reject(RplidarError::BadNode);
                }
                Mode::Nodes { locked: false } => {
                    let mut run = 0;
                    while run < RPLIDAR_NODE_RUN {
                        let at = run * RPLIDAR_NODE_LEN;
                        let Some(node) = live
                            .get(at..)
                            .and_then(<[u8]>::first_chunk::<RPLIDAR_NODE_LEN>)
                        else {
                            return Scan::Need {
                                more: at + RPLIDAR_NODE_LEN - len,
                                candidate: false,
                            };
                        };
                        if !node_is_valid(node) {
                            break;
                        }
                        run += 1;
                    }
                    if run == RPLIDAR_NODE_RUN {
                        self.mode = Mode::Nodes { locked: true };
                        let node = live.first_chunk::<RPLIDAR_NODE_LEN>().copied();
                        if let Some(node) = node {
                            return self.deliver_node(&node);
                        }
                    }
                    self.garbage(1);
                }
                Mode::Capsules => {
                    let Some(&second) = live.get(1) else {
                        return Scan::Need {
                            more: 1,
                            candidate: false,
                        };
                    };
                    if first >> 4 != 0xA || second >> 4 != 0x5 {
                        self.garbage(1);
                        continue;
                    }
                    let Some(capsule) = live.first_chunk::<RPLIDAR_CAPSULE_LEN>() else {
                        return Scan::Need {
                            more: RPLIDAR_CAPSULE_LEN - len,
                            candidate: true,
                        };
                    };
                    let view = RplidarCapsule::new_unchecked(&capsule[..]);
                    let (stored, computed) = (view.checksum(), view.computed_checksum());
                    if stored != computed {
                        return self.reject(RplidarError::BadChecksum { stored, computed });
                    }
                    let offset = self.window.offset_of(0);
                    let follows = self.prev_valid
                        && self.prev_offset.wrapping_add(RPLIDAR_CAPSULE_LEN as u64) == offset;
                    if follows && !view.start_flag() {
                        bump(&mut self.counters.capsules);
                        self.kind = Kind::Express;
                        self.window.hand_out(RPLIDAR_CAPSULE_LEN);
                        return Scan::Item(self.prev_offset);
                    }
                    // Keep this one; the one kept before it cannot be placed.
                    let capsule = *capsule;
                    let dropped = self.drop_prev();
                    self.prev = capsule;
                    self.prev_valid = true;
                    self.prev_offset = offset;
                    self.prev_wraps = false;
                    self.window.drop_front(RPLIDAR_CAPSULE_LEN);
                    if let Some(old) = dropped {
                        return Scan::Rejected(RplidarError::CapsuleUnpaired, old);
                    }
                }
            }
        }
    }

    /// Whether byte `b` may start a unit in the current mode (garbage is skipped in place
    /// up to such a byte).
    fn may_start(&self, byte: u8) -> bool {
        match self.mode {
            Mode::Descriptor => byte == RPLIDAR_DESCRIPTOR_SYNC[0],
            Mode::Response(..) | Mode::Nodes { locked: true } => true,
            // S ≠ !S: bits 0 and 1 differ (0xA5 of a descriptor too).
            Mode::Nodes { locked: false } => matches!(byte & 3, 1 | 2),
            Mode::Capsules => byte >> 4 == 0xA,
        }
    }

    /// How many bytes to take first for a unit starting at the front.
    fn first_need(&self) -> usize {
        match self.mode {
            Mode::Descriptor => RPLIDAR_DESCRIPTOR_LEN,
            Mode::Response(_, len) => len.max(1),
            Mode::Nodes { locked: true } => RPLIDAR_NODE_LEN,
            Mode::Nodes { locked: false } => RPLIDAR_NODE_LEN * RPLIDAR_NODE_RUN,
            Mode::Capsules => RPLIDAR_CAPSULE_LEN,
        }
    }

    fn count_garbage(&mut self, n: usize) {
        bump_by(&mut self.counters.garbage_bytes, n);
    }

    /// Reports the kept capsule first (it lies before the unit in progress), then the unit,
    /// whose first byte it drops; a response or a node run is given up.
    fn truncate(&mut self) -> (RplidarError, u64) {
        if let Some(offset) = self.drop_prev() {
            return (RplidarError::CapsuleUnpaired, offset);
        }
        let offset = self.window.offset_of(0);
        bump(&mut self.counters.truncated);
        self.window.drop_front(1);
        if let Mode::Response(..) = self.mode {
            self.mode = Mode::Descriptor;
        }
        if let Mode::Nodes { .. } = self.mode {
            self.mode = Mode::Nodes { locked: false };
        }
        (RplidarError::Truncated, offset)
    }

    /// Drops the kept capsule: no capsule follows it.
    fn end(&mut self) -> Option<(RplidarError, u64)> {
        self.drop_prev()
            .map(|offset| (RplidarError::CapsuleUnpaired, offset))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::test_rng::XorShift;
    use crate::wire::rplidar::{
        RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarHealthRepr, RplidarNodeRepr,
    };
    use std::vec;
    use std::vec::Vec;

    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Ev {
        D(u64, Vec<u8>),
        Resp(u64, u8, Vec<u8>),
        N(u64, Vec<u8>),
        X(u64, Vec<u8>, u16),
        R(u64, RplidarError),
    }

    fn record(r: FeedResult<'_, RplidarItem<'_>, RplidarError>, out: &mut Vec<Ev>) -> bool {
        match r {
            FeedResult::Consumed => return false,
            FeedResult::Item { item, offset, .. } => out.push(match item {
                RplidarItem::Descriptor(d) => Ev::D(offset, d.as_bytes().to_vec()),
                RplidarItem::Response(r) => Ev::Resp(offset, r.data_type, r.data.to_vec()),
                RplidarItem::Node(n) => {
                    assert!(RplidarNode::new_checked(n.as_bytes()).is_ok());
                    Ev::N(offset, n.as_bytes().to_vec())
                }
                RplidarItem::Express(e) => {
                    assert!(RplidarCapsule::new_checked(e.capsule().as_bytes()).is_ok());
                    Ev::X(
                        offset,
                        e.capsule().as_bytes().to_vec(),
                        e.next_start_angle_q6(),
                    )
                }
            }),
            FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(offset, error)),
        }
        true
    }

    fn run_with(
        mut acc: RplidarAccumulator,
        stream: &[u8],
        sizes: &[usize],
    ) -> (Vec<Ev>, RplidarCounters) {
        let out = resync::run_in_chunks!(acc, stream, sizes, record);
        let c = acc.counters();
        let response_bytes: u64 = out
            .iter()
            .map(|e| match e {
                Ev::Resp(_, _, b) => b.len() as u64,
                _ => 0,
            })
            .sum();
        assert_eq!(
            7 * u64::from(c.descriptors)
                + response_bytes
                + 5 * u64::from(c.nodes)
                + 84 * u64::from(c.capsules + c.capsules_unpaired)
                + u64::from(c.node_check + c.checksum + c.truncated + c.garbage_bytes),
            stream.len() as u64,
            "every byte accounted for"
        );
        (out, c)
    }

    fn run(stream: &[u8], sizes: &[usize]) -> (Vec<Ev>, RplidarCounters) {
        run_with(RplidarAccumulator::new(), stream, sizes)
    }

    fn descriptor(repr: RplidarDescriptorRepr) -> Vec<u8> {
        let mut b = vec![0; 7];
        repr.emit(&mut b).unwrap();
        b
    }

    fn node(i: u16) -> Vec<u8> {
        let mut b = vec![0; 5];
        RplidarNodeRepr {
            quality: (i % 64) as u8,
            start: i.is_multiple_of(50),
            angle_q6: (i * 37) % 23_040,
            distance_q2: 1000 + i * 13,
        }
        .emit(&mut b)
        .unwrap();
        b
    }

    fn capsule(start_q6: u16, flag: bool) -> Vec<u8> {
        let mut repr = RplidarCapsuleRepr {
            start_angle_q6: start_q6,
            start_flag: flag,
            ..RplidarCapsuleRepr::default()
        };
        for k in 0..32 {
            repr.distances_mm[k] = 500 + k as u16 * 10 + start_q6 % 100;
            repr.angle_offsets_q3[k] = (k as u8 * 3) % 64;
        }
        let mut b = vec![0; 84];
        repr.emit(&mut b).unwrap();
        b
    }

    #[test]
    fn health_then_scan_then_a_damaged_node() {
        let mut stream = vec![0x00, 0xA5, 0x11];
        stream.extend(descriptor(RplidarDescriptorRepr::HEALTH));
        let mut health = vec![0; 3];
        RplidarHealthRepr {
            status: 1,
            error_code: 0x0203,
        }
        .emit(&mut health)
        .unwrap();
        stream.extend_from_slice(&health);
        let o_scan = stream.len();
        stream.extend(descriptor(RplidarDescriptorRepr::SCAN));
        let o_nodes = stream.len();
        for i in 0..10 {
            stream.extend(node(i));
        }
        // A node whose C bit is cleared: rejected; then 20 good nodes re-lock after 16.
        let o_bad = stream.len();
        let mut bad = node(10);
        bad[1] &= !1;
        stream.extend_from_slice(&bad);
        let o_after = stream.len();
        for i in 11..31 {
            stream.extend(node(i));
        }
        for sizes in [&[usize::MAX][..], &[1], &[3, 5, 7], &[80, 1]] {
            let (events, c) = run(&stream, sizes);
            assert_eq!(
                events[0],
                Ev::D(3, descriptor(RplidarDescriptorRepr::HEALTH))
            );
            assert_eq!(events[1], Ev::Resp(10, 6, health.clone()));
            assert_eq!(
                events[2],
                Ev::D(o_scan as u64, descriptor(RplidarDescriptorRepr::SCAN))
            );
            for i in 0..10 {
                assert_eq!(
                    events[3 + i],
                    Ev::N((o_nodes + 5 * i) as u64, node(i as u16))
                );
            }
            assert_eq!(events[13], Ev::R(o_bad as u64, RplidarError::BadNode));
            let nodes_after: Vec<_> = events[14..].to_vec();
            let want: Vec<_> = (0..20)
                .map(|i| Ev::N((o_after + 5 * i) as u64, node(11 + i as u16)))
                .collect();
            assert_eq!(nodes_after, want, "{sizes:?}");
            assert_eq!(
                (c.nodes, c.node_check, c.responses, c.descriptors),
                (30, 1, 1, 2)
            );
            // The garbage: 3 leading bytes and the 4 bytes of the bad node after its first.
            assert_eq!(c.garbage_bytes, 3 + 4);
        }
    }

    #[test]
    fn express_capsules_are_placed_by_their_successor() {
        let mut stream = descriptor(RplidarDescriptorRepr::EXPRESS_SCAN);
        let starts = [100_u16, 300, 500, 700, 23_000, 200];
        let caps: Vec<Vec<u8>> = starts
            .iter()
            .enumerate()
            .map(|(i, &s)| capsule(s, i == 0))
            .collect();
        for c in &caps[..4] {
            stream.extend_from_slice(c);
        }
        // Garbage breaks the chain: capsule 3 cannot be placed.
        stream.extend_from_slice(&[0x00, 0x01]);
        let o4 = stream.len();
        stream.extend_from_slice(&caps[4]);
        // A flipped capsule: rejected, and capsule 4 is dropped when capsule 5 arrives late.
        let o_flip = stream.len();
        let mut flipped = caps[5].clone();
        flipped[40] ^= 0x10;
        stream.extend_from_slice(&flipped);
        let o5 = stream.len();
        stream.extend_from_slice(&caps[5]);
        stream.extend_from_slice(&capsule(400, false));
        for sizes in [&[usize::MAX][..], &[1], &[84], &[83, 85, 2]] {
            let (events, c) = run(&stream, sizes);
            let o = |i: usize| (7 + 84 * i) as u64;
            let want_head = [
                Ev::D(0, descriptor(RplidarDescriptorRepr::EXPRESS_SCAN)),
                Ev::X(o(0), caps[0].clone(), 300),
                Ev::X(o(1), caps[1].clone(), 500),
                Ev::X(o(2), caps[2].clone(), 700),
                Ev::R(o(3), RplidarError::CapsuleUnpaired),
            ];
            assert_eq!(&events[..5], &want_head[..], "{sizes:?}");
            assert!(
                matches!(events[5], Ev::R(off, RplidarError::BadChecksum { .. }) if off == o_flip as u64)
            );
            assert_eq!(events[6], Ev::R(o4 as u64, RplidarError::CapsuleUnpaired));
            assert_eq!(events[7], Ev::X(o5 as u64, caps[5].clone(), 400));
            assert_eq!(
                events[8],
                Ev::R((o5 + 84) as u64, RplidarError::CapsuleUnpaired)
            );
            assert_eq!(events.len(), 9);
            assert_eq!((c.capsules, c.capsules_unpaired, c.checksum), (4, 3, 1));
        }
    }

    #[test]
    fn the_start_flag_drops_the_kept_capsule_and_revolutions_are_tracked() {
        let mut stream = descriptor(RplidarDescriptorRepr::EXPRESS_SCAN);
        // 358°, 0° (the raw angle reaches 360° exactly at the boundary), 2°, then S = 1.
        for (s, flag) in [
            (358 * 64, false),
            (0, false),
            (128, false),
            (256, true),
            (384, false),
        ] {
            stream.extend(capsule(s, flag));
        }
        let mut acc = RplidarAccumulator::new();
        let mut revolutions = Vec::new();
        let mut events = Vec::new();
        let mut window = &stream[..];
        loop {
            let r = acc.feed(window);
            window = r.remaining();
            if let FeedResult::Item {
                item: RplidarItem::Express(e),
                ..
            } = &r
            {
                revolutions.push(e.revolution_start());
            }
            if !record(r, &mut events) {
                break;
            }
        }
        while record(acc.flush(), &mut events) {}
        // Capsule 0 (358° → 0°): no wrap inside; capsule 1 starts the revolution at point 0.
        assert_eq!(revolutions, [None, Some(0), None]);
        let c = acc.counters();
        // Capsule 2 is dropped by capsule 3's S flag; capsule 4 by the end of the stream.
        assert_eq!((c.capsules, c.capsules_unpaired), (3, 2));
    }

    #[test]
    fn joining_a_running_node_stream() {
        // No descriptor: garbage, then nodes. The first 16 lock; every node is delivered.
        let mut stream = vec![0x3F, 0x00, 0x12];
        for i in 0..40 {
            stream.extend(node(i));
        }
        let (events, c) = run_with(
            RplidarAccumulator::with_mode(RplidarScanMode::Standard),
            &stream,
            &[7],
        );
        assert_eq!(c.nodes, 40);
        assert_eq!(events.first(), Some(&Ev::N(3, node(0))));
        assert_eq!(c.garbage_bytes, 3);
        // With fewer than 16 nodes after the garbage, nothing locks: garbage at the end.
        let short = &stream[..3 + 5 * 15];
        let (events, c) = run_with(
            RplidarAccumulator::with_mode(RplidarScanMode::Standard),
            short,
            &[7],
        );
        assert!(events.is_empty());
        assert_eq!(c.garbage_bytes, short.len() as u32);
        // An express stream joined mid-way: the first capsule waits for the second.
        let mut caps = vec![0x55];
        caps.extend(capsule(0, false));
        caps.extend(capsule(200, false));
        let (events, c) = run_with(
            RplidarAccumulator::with_mode(RplidarScanMode::Express),
            &caps,
            &[usize::MAX],
        );
        assert_eq!(events[0], Ev::X(1, capsule(0, false), 200));
        assert_eq!(
            (c.capsules, c.capsules_unpaired, c.garbage_bytes),
            (1, 1, 1)
        );
    }

    #[test]
    fn truncation_and_unsupported_descriptors() {
        // A response cut short, an unsupported (dense capsule) descriptor and its data, a
        // node descriptor and a cut node.
        let mut stream = descriptor(RplidarDescriptorRepr::INFO);
        stream.extend_from_slice(&[1, 2, 3]);
        let (events, c) = run(&stream, &[2]);
        assert_eq!(events.last(), Some(&Ev::R(7, RplidarError::Truncated)));
        assert_eq!((c.truncated, c.garbage_bytes), (1, 2));

        let mut stream = vec![0xA5, 0x5A, 0x54, 0x00, 0x00, 0x40, 0x85];
        stream.extend(capsule(10, false));
        stream.extend(descriptor(RplidarDescriptorRepr::SCAN));
        stream.extend(node(1));
        stream.extend_from_slice(&node(2)[..3]);
        let (events, c) = run(&stream, &[9]);
        assert_eq!(c.unsupported, 1);
        assert_eq!(c.descriptors, 2);
        assert_eq!(c.garbage_bytes, 84 + 2);
        assert_eq!(c.nodes, 1);
        assert_eq!(
            events.last(),
            Some(&Ev::R((stream.len() - 3) as u64, RplidarError::Truncated))
        );
    }

    /// Why a run of 16: read at a wrong alignment, a realistic node stream (a smooth wall
    /// with noise, 5 % no-return, random quality, the angle stepping 0.22° or 0.5° with
    /// jitter) passes the node checks for runs of 8 at some positions, never for 16.
    #[test]
    fn misaligned_runs_reach_8_but_not_16() {
        for (step, seed) in [(14_i64, 1_u64), (32, 2)] {
            let mut rng = XorShift(0x9E37_79B9_7F4A_7C15 ^ seed);
            let mut stream = Vec::new();
            let mut angle = 0_i64;
            for i in 0..40_000 {
                angle += step + (rng.next() % 5) as i64 - 2;
                let start = angle >= 23_040;
                angle %= 23_040;
                let wall = 1500.0 + 800.0 * (f64::from(i) / 300.0).sin();
                let noise = (rng.next() % 81) as i64 - 40;
                let dist = if rng.next().is_multiple_of(20) {
                    0
                } else {
                    (wall as i64 * 4 + noise).max(0)
                };
                let mut b = [0; 5];
                RplidarNodeRepr {
                    quality: (rng.next() % 64) as u8,
                    start,
                    angle_q6: angle as u16,
                    distance_q2: dist as u16,
                }
                .emit(&mut b)
                .unwrap();
                stream.extend_from_slice(&b);
            }
            let run_at = |p: usize| {
                (0..)
                    .take_while(|r| {
                        stream
                            .get(p + 5 * r..)
                            .and_then(<[u8]>::first_chunk::<5>)
                            .is_some_and(node_is_valid)
                    })
                    .count()
            };
            let misaligned: Vec<usize> = (0..stream.len() - 5)
                .filter(|p| p % 5 != 0)
                .map(run_at)
                .collect();
            let longest = misaligned.iter().copied().max().unwrap();
            let runs_of_8 = misaligned.iter().filter(|&&r| r >= 8).count();
            std::println!(
                "step {step}: longest misaligned run {longest}, runs ≥ 8: {runs_of_8} of {}",
                misaligned.len()
            );
            assert!(longest < RPLIDAR_NODE_RUN, "step {step}: {longest}");
            assert!(runs_of_8 > 0, "step {step}: 8 would be enough here");
            // And every aligned position starts a run to the end of the stream.
            assert_eq!(run_at(0), 40_000);
        }
    }

    #[test]
    fn expect_response_and_reset() {
        let mut acc = RplidarAccumulator::with_mode(RplidarScanMode::Express);
        let cap = capsule(0, false);
        assert!(matches!(acc.feed(&cap), FeedResult::Consumed));
        acc.expect_response();
        assert_eq!(acc.counters().capsules_unpaired, 1);
        let h = descriptor(RplidarDescriptorRepr::HEALTH);
        assert!(matches!(
            acc.feed(&h),
            FeedResult::Item {
                item: RplidarItem::Descriptor(_),
                ..
            }
        ));
        assert!(matches!(acc.feed(&[0, 0]), FeedResult::Consumed));
        assert_eq!(acc.buffered(), 2);
        acc.reset();
        assert_eq!(acc.buffered(), 0);
        acc.counters.garbage_bytes = u32::MAX;
        let _ = acc.feed(&[1, 2]);
        assert_eq!(acc.counters().garbage_bytes, u32::MAX);
        acc.clear_counters();
        assert_eq!(acc.counters(), RplidarCounters::default());
    }
}
