//! The device's side of the host link (`docs/protocol.md`): an outgoing frame queue, the
//! token bucket that holds map traffic to a byte budget, the patches of changed tiles, window
//! moves, Hello and Stats; and the receive side, which decodes the host's frames and hands
//! back validated commands ([`Command`], converted by [`convert`]).
//!
//! Like smoltcp's `Interface::poll`, the [`Link`] is handed everything: the time, the pyramid,
//! the bytes the UART received, the counters of other modules. It reads no clock, touches no
//! peripheral and allocates nothing. What to do with a command is the application's
//! ([`crate::app::CoProcessor`] carries them out); a board drains the queue into the UART
//! with [`Link::pop_bytes`] (or [`Link::peek`] + [`Link::consume`] for DMA).
//!
//! RAM: a `Link` with the default 4 096-byte queue takes about 6.2 KiB (queue, a 543-byte
//! encode scratch, the 102-byte receive buffer, 1 KiB of tile ages, counters).
//!
//! Scan intake never waits for the link: [`Link::poll`] sends a changed tile only while the
//! budget and the queue allow, and **puts the tile's dirty bit back** otherwise, so the tile
//! goes later with whatever else changed in it meanwhile. Patches are never dropped; only a
//! control frame (a Reply) that finds no room is dropped, and it still uses its sequence
//! number, so the host sees the gap and asks for a snapshot.
//!
//! ```
//! use terrain_pyramid::link::{Command, Link, LinkConfig, SensorCounters};
//! use terrain_pyramid::wire::link::{encode, Message, Reply};
//! use terrain_pyramid::wire::FeedResult;
//! use terrain_pyramid::{Config, DefaultDesign, DefaultPyramid, Schedule, SensorModel, Meters};
//!
//! let mut pyramid = DefaultPyramid::new();
//! let mut link: Link = Link::new(LinkConfig::default());
//! let design = DefaultDesign::new(SensorModel::default(), Schedule::default(), 64).unwrap();
//! pyramid.configure(&design, &Config::default()).unwrap();
//! link.adopt(&design);
//! // Bytes from the host: a Ping.
//! let mut frame = [0_u8; 16];
//! let n = encode(0, &Message::Ping, &mut frame).unwrap();
//! let mut input = &frame[..n];
//! while let FeedResult::Item { item, remaining, .. } = link.receive(input) {
//!     assert_eq!(item.command, Command::Ping);
//!     link.answer(Reply::ok(item.header));
//!     input = remaining;
//! }
//! // ... evidence integrated, the pyramid recentred on the robot ...
//! pyramid.recentre(Meters::from_num(0.1), Meters::ZERO);
//! link.poll(0, &mut pyramid, &SensorCounters::default());
//! let mut uart = [0_u8; 64];
//! while link.pop_bytes(&mut uart) > 0 { /* write to the UART */ }
//! ```

mod bucket;
mod command;
pub mod convert;
mod counters;
mod poll;
mod queue;

pub use bucket::TokenBucket;
pub use command::{Command, Rejection, Request};
pub use counters::{FilterCounters, LinkCounters, PoseCounters, SensorCounters};
pub use poll::PollReport;
pub use queue::FrameQueue;

use crate::grid::TILES_PER_SIDE;
use crate::pyramid::Pyramid;
use crate::wire::link::{
    encode, ClockSource, FirmwareVersion, FrameAccumulator, HelloReason, Message, Observed, Reply,
    RxCounters, SnapshotScope, Stats, TimeReply, MAX_COMMAND_FRAME, MAX_ENCODED_FRAME, MAX_LAYERS,
    MAX_PATCH_SIDE, MIN_FRAME,
};
use crate::Design;

/// The default outgoing queue, bytes: 26 default patches, 44 ms of the link at 921 600 Bd.
pub const DEFAULT_QUEUE_BYTES: usize = 4096;

/// Queue room kept free of patches and Stats for control frames (WindowMoved, Reply), bytes.
pub const CONTROL_RESERVE: usize = 256;

/// Tiles per layer.
const TILES: usize = TILES_PER_SIDE * TILES_PER_SIDE;

/// The most bytes one storage tile of a `cells_per_side` window takes on the wire: its cells
/// (a tile is ⌈W/8⌉ cells on a side), cut by the window's wrap point and into pieces of at
/// most 16 × 16, each piece a LayerPatch frame. 248 bytes for W = 64.
#[must_use]
pub const fn max_tile_bytes(cells_per_side: usize) -> usize {
    let side = cells_per_side.div_ceil(TILES_PER_SIDE);
    let per_axis = side.div_ceil(MAX_PATCH_SIDE) + 1;
    let pieces = per_axis * per_axis;
    let cells = 2 * side * side;
    // Per piece: header, area, CRC, COBS code byte, delimiter; plus COBS' 1 in 254.
    pieces * (MIN_FRAME + PATCH_AREA_BYTES + 2) + cells + (pieces * 27 + cells) / 254 + pieces
}

/// The smallest queue a `Link` of a pyramid of `layers` layers (≤ [`MAX_LAYERS`]) and windows
/// of `cells_per_side` may have: room for the largest tile beside [`CONTROL_RESERVE`], and for
/// a Hello of `layers` layers (16 + 20 bytes a layer, framed). 504 bytes for W = 64, 8 layers.
#[must_use]
pub const fn min_queue_bytes(cells_per_side: usize, layers: usize) -> usize {
    let tile = max_tile_bytes(cells_per_side) + CONTROL_RESERVE;
    let hello = crate::wire::link::encoded_len_max(MIN_FRAME + 16 + 20 * layers);
    if tile > hello {
        tile
    } else {
        hello
    }
}

/// Bytes of a LayerPatch body before its cells.
const PATCH_AREA_BYTES: usize = 19;

/// The link's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkConfig {
    /// The byte budget of all outgoing traffic, bytes per second. Default 46 080: half of
    /// 921 600 Bd.
    pub budget_bytes_per_s: u32,
    /// The most bytes sent in a burst (the bucket's depth). Default 2 048.
    pub burst_bytes: u32,
    /// How often a Stats frame goes out, ms; 0 = never. Default 1 000.
    pub stats_interval_ms: u32,
    /// The firmware's version, for Hello. Default: this crate's version
    /// ([`LIBRARY_VERSION`]).
    pub firmware: FirmwareVersion,
    /// The clock the board started, for Hello. Default: not reported.
    pub clock: ClockSource,
}

/// This crate's version (`CARGO_PKG_VERSION`), as Hello carries it.
pub const LIBRARY_VERSION: FirmwareVersion = FirmwareVersion {
    major: version_part(env!("CARGO_PKG_VERSION_MAJOR")),
    minor: version_part(env!("CARGO_PKG_VERSION_MINOR")),
    patch: version_part(env!("CARGO_PKG_VERSION_PATCH")),
};

/// A decimal version number as a `u8`, evaluated at compile time; a number past 255
/// saturates, a non-digit ends it.
const fn version_part(digits: &str) -> u8 {
    let mut rest = digits.as_bytes();
    let mut value: u32 = 0;
    while let [b, tail @ ..] = rest {
        if !b.is_ascii_digit() {
            break;
        }
        value = value * 10 + (*b - b'0') as u32;
        if value > 255 {
            return u8::MAX;
        }
        rest = tail;
    }
    value as u8
}

impl LinkConfig {
    /// The defaults: half of 921 600 Bd, 2 KiB bursts, Stats every second.
    pub const DEFAULT: Self = Self {
        budget_bytes_per_s: 46_080,
        burst_bytes: 2048,
        stats_interval_ms: 1000,
        firmware: LIBRARY_VERSION,
        clock: ClockSource::NotReported,
    };
}

impl Default for LinkConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
/// A Hello waiting to be sent, stored so that "none waiting" is all zero bits (an
/// `Option<(HelloReason, u32)>` would put `None` in the reason's niche, a non-zero byte, and a
/// `static` link into `.data`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct PendingHello {
    waiting: bool,
    reason: HelloReason,
    resend: u32,
}

impl PendingHello {
    /// Nothing waiting.
    const NONE: Self = Self {
        waiting: false,
        reason: HelloReason::Boot,
        resend: 0,
    };

    /// A Hello for `reason`, announcing the layers of `resend`.
    const fn some(reason: HelloReason, resend: u32) -> Self {
        Self {
            waiting: true,
            reason,
            resend,
        }
    }

    /// The waiting Hello's reason and resend mask.
    const fn get(self) -> Option<(HelloReason, u32)> {
        if self.waiting {
            Some((self.reason, self.resend))
        } else {
            None
        }
    }
}

impl From<(HelloReason, u32)> for PendingHello {
    fn from((reason, resend): (HelloReason, u32)) -> Self {
        Self::some(reason, resend)
    }
}

/// The device's end of the host link, with an outgoing queue of `Q` bytes, for pyramids of at
/// most `N` layers (≤ [`MAX_LAYERS`]; default [`crate::DEFAULT_LAYERS`]: its per-layer state,
/// about 100 bytes a layer, is sized by `N`).
///
/// `Q` must be at least [`min_queue_bytes`]`(W, L)` and `L` at most `N` (both checked at
/// compile time by [`Link::poll`]): 504 bytes for W = 64, 8 layers. The default 4 096 bytes
/// hold 26 default patches.
#[derive(Debug, Clone)]
pub struct Link<const Q: usize = DEFAULT_QUEUE_BYTES, const N: usize = { crate::DEFAULT_LAYERS }> {
    config: LinkConfig,
    queue: FrameQueue<Q>,
    scratch: [u8; MAX_ENCODED_FRAME],
    bucket: TokenBucket,
    rx: FrameAccumulator<MAX_COMMAND_FRAME>,
    rx_expected: Option<u16>,
    tx_seq: u16,
    /// A Hello to send before anything else: its reason and the layers it announces for resend.
    hello: PendingHello,
    /// What the host was last told: layers, resolutions, origins.
    sent_layers: usize,
    sent_resolution: [i32; N],
    sent_origin: [(i32, i32); N],
    /// The pyramid's `cells_reset` counter when the host's origins were last brought up to date.
    reset_baseline: u32,
    /// Band edges of the design in force, metres (zeros until the link is told).
    bands: [(f32, f32); N],
    /// Where the round-robin over `layer · 64 + tile` resumes.
    cursor: usize,
    /// Polls each dirty tile has waited (0 = not waiting), for oldest-first sending.
    ages: [[u8; TILES]; N],
    /// Per layer, the tiles whose age is not 0: a poll visits only these and the dirty ones,
    /// not all `64 · N` ages.
    aged: [u64; N],
    last_stats_ms: Option<u32>,
    /// A Stats frame was requested: it goes out at the next poll whatever the interval.
    stats_requested: bool,
    /// The device's µs clock of the latest host bytes ([`Link::receive_at`]; 0 until then).
    rx_clock_us: u32,
    counters: LinkCounters,
}

impl<const Q: usize, const N: usize> Link<Q, N> {
    /// The room a Stats frame leaves free: [`CONTROL_RESERVE`], or less in a queue too small
    /// to hold the largest Stats frame (154 bytes in version 4) beside it, so that an empty
    /// queue always takes a Stats.
    pub const STATS_RESERVE: usize = {
        let stats =
            crate::wire::link::encoded_len_max(MIN_FRAME + 4 * crate::wire::link::STATS_COUNTERS);
        let room = Q.saturating_sub(stats);
        if room < CONTROL_RESERVE {
            room
        } else {
            CONTROL_RESERVE
        }
    };

    /// A link that will announce itself with Hello (reason boot) at its first poll. `const`,
    /// for a `static`.
    #[must_use]
    pub const fn new(config: LinkConfig) -> Self {
        Self {
            config,
            queue: FrameQueue::new(),
            scratch: [0; MAX_ENCODED_FRAME],
            bucket: TokenBucket::new(config.budget_bytes_per_s, config.burst_bytes),
            rx: FrameAccumulator::new(),
            rx_expected: None,
            tx_seq: 0,
            hello: PendingHello::some(HelloReason::Boot, 0),
            sent_layers: 0,
            sent_resolution: [0; N],
            sent_origin: [(0, 0); N],
            reset_baseline: 0,
            bands: [(0.0, 0.0); N],
            cursor: 0,
            ages: [[0; TILES]; N],
            aged: [0; N],
            last_stats_ms: None,
            stats_requested: false,
            rx_clock_us: 0,
            counters: LinkCounters {
                frames_sent: 0,
                bytes_sent: 0,
                patches_sent: 0,
                patches_deferred: 0,
                frames_dropped: 0,
                rx_seq_gaps: 0,
                commands_refused: 0,
                snapshots: 0,
                resyncs: 0,
                decay_frames: 0,
                decay_deferred: 0,
                time_requests: 0,
                observed_frames: 0,
            },
        }
    }

    /// A link with no settings and nothing to say, all zero bits (a `static` holding one sits
    /// in `.bss`): [`start`](Self::start) it before use. Until then its budget is zero, so it
    /// queues no map traffic.
    #[must_use]
    pub const fn unconfigured() -> Self {
        let mut link = Self::new(LinkConfig {
            budget_bytes_per_s: 0,
            burst_bytes: 0,
            stats_interval_ms: 0,
            firmware: FirmwareVersion {
                major: 0,
                minor: 0,
                patch: 0,
            },
            clock: ClockSource::NotReported,
        });
        link.hello = PendingHello::NONE;
        link
    }

    /// Starts the link with its settings, as [`new`](Self::new) would have built it: Hello
    /// (reason boot) at the next poll, a full bucket; counters and sequence numbers are kept.
    pub fn start(&mut self, config: LinkConfig) {
        self.config = config;
        self.bucket = TokenBucket::new(config.budget_bytes_per_s, config.burst_bytes);
        self.hello = PendingHello::some(HelloReason::Boot, 0);
    }

    /// The settings.
    #[must_use]
    pub const fn config(&self) -> &LinkConfig {
        &self.config
    }

    /// The link's counters.
    #[must_use]
    pub const fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// The receive side's counters.
    #[must_use]
    pub const fn rx_counters(&self) -> RxCounters {
        self.rx.counters()
    }

    /// The outgoing queue.
    #[must_use]
    pub const fn queue(&self) -> &FrameQueue<Q> {
        &self.queue
    }

    /// The token bucket.
    #[must_use]
    pub const fn bucket(&self) -> &TokenBucket {
        &self.bucket
    }

    /// The sequence number the next frame will carry.
    #[must_use]
    pub const fn next_seq(&self) -> u16 {
        self.tx_seq
    }

    /// Moves up to `out.len()` queued bytes into `out` for the UART; returns how many.
    pub fn pop_bytes(&mut self, out: &mut [u8]) -> usize {
        self.queue.pop_bytes(out)
    }

    /// The oldest queued bytes that lie contiguously (for a DMA or a non-blocking write).
    #[must_use]
    pub fn peek(&self) -> &[u8] {
        self.queue.peek()
    }

    /// Drops `n` bytes the UART took after [`peek`](Self::peek).
    pub fn consume(&mut self, n: usize) {
        self.queue.consume(n);
    }

    /// Tells the link that the pyramid now runs `design` (configured outside the link, e.g.
    /// at boot): records its bands and announces it with Hello (maps cleared).
    pub fn adopt<const L: usize>(&mut self, design: &Design<L>) {
        self.bands = [(0.0, 0.0); N];
        for (band, layer) in self.bands.iter_mut().zip(design.layers()) {
            *band = (layer.band_inner_m, layer.band_outer_m);
        }
        self.want_hello(HelloReason::Configured, 0);
    }

    /// Tells the link that the maps were cleared (windows kept): the host is told with Hello
    /// (reason reset).
    pub fn maps_cleared(&mut self) {
        self.want_hello(HelloReason::Reset, 0);
    }

    /// Marks every tile of the layers in `scope` for sending again and announces it with
    /// Hello (reason snapshot); `false` for a layer the pyramid does not have (nothing
    /// changes then: refuse it with [`convert::layer_refusal`]).
    pub fn snapshot<const W: usize, const L: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        scope: SnapshotScope,
    ) -> bool {
        let count = layers_of(pyramid).min(N);
        let layers = match scope {
            SnapshotScope::All => 0..count,
            SnapshotScope::Layer(k) if usize::from(k) < count => usize::from(k)..usize::from(k) + 1,
            SnapshotScope::Layer(_) => return false,
        };
        let mut mask = 0_u32;
        for k in layers {
            if let Some(mut dirty) = pyramid.layer_dirty_mut(k) {
                dirty.mark(u64::MAX);
            }
            mask |= 1 << k;
        }
        self.counters.snapshots = self.counters.snapshots.saturating_add(1);
        self.want_hello(HelloReason::Snapshot, mask);
        true
    }

    /// Queues a Reply the application composed (Ok to a command it carried out, or Ok to
    /// Shutdown with the stack's figures). Like every Reply it is dropped, and its sequence
    /// number counted as a gap, when the queue has no room.
    pub fn answer(&mut self, reply: Reply) {
        self.reply(reply);
    }

    /// Queues a refusal the application composed (a command that validated but could not be
    /// carried out, e.g. a Configure whose window the pyramid does not have) and counts it.
    pub fn refuse(&mut self, reply: Reply) {
        self.counters.commands_refused = self.counters.commands_refused.saturating_add(1);
        self.reply(reply);
    }

    /// Sends a pending Hello now, ahead of anything else (after a command that changed the
    /// maps), if the queue has room; otherwise it goes at the next poll.
    pub fn announce<const W: usize, const L: usize>(&mut self, pyramid: &Pyramid<W, L>) {
        self.flush_hello(pyramid, &mut PollReport::default());
    }

    /// Asks for a Stats frame at the next [`poll`](Self::poll), whatever the interval (it goes
    /// ahead of patches, after a pending Hello and WindowMoved).
    pub fn request_stats(&mut self) {
        self.stats_requested = true;
    }

    fn want_hello(&mut self, reason: HelloReason, resend: u32) {
        self.hello = PendingHello::from(match self.hello.get() {
            // A Hello that clears the host's maps stays one; resend masks add up.
            Some((pending, mask)) if pending.clears_maps() => (pending, mask | resend),
            Some((_, mask)) => (reason, mask | resend),
            None => (reason, resend),
        });
    }

    /// The Stats frame as it would go out now.
    #[must_use]
    pub fn stats<const W: usize, const L: usize>(
        &self,
        now_ms: u32,
        pyramid: &Pyramid<W, L>,
        sensor: &SensorCounters,
    ) -> Stats {
        let p = pyramid.stats();
        let rx = self.rx.counters();
        let c = &self.counters;
        let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        Stats {
            uptime_ms: now_ms,
            telegrams_ok: sensor.telegrams_ok,
            telegrams_bad_checksum: sensor.telegrams_bad_checksum,
            telegrams_bad_framing: sensor.telegrams_bad_framing,
            telegrams_bad_other: sensor.telegrams_bad_other,
            points: sensor.points,
            classifier_overflows: sensor.classifier_overflows,
            evidence_applied: p.applied,
            evidence_gated_out: p.gated_out,
            evidence_outside_window: p.outside_window,
            frames_sent: c.frames_sent,
            bytes_sent: c.bytes_sent,
            patches_sent: c.patches_sent,
            patches_deferred: c.patches_deferred,
            frames_dropped: c.frames_dropped,
            queue_used: count(self.queue.len()),
            queue_high_water: count(self.queue.high_water()),
            queue_capacity: count(Q),
            rx_frames_ok: rx.frames_ok,
            rx_bad_cobs: rx.cobs,
            rx_bad_crc: rx.crc,
            rx_bad_length: rx.too_short.saturating_add(rx.too_long),
            rx_bad_other: rx
                .unknown_version
                .saturating_add(rx.unknown_type)
                .saturating_add(rx.bad_body)
                .saturating_add(rx.out_of_range),
            rx_seq_gaps: c.rx_seq_gaps,
            commands_refused: c.commands_refused,
            snapshots: c.snapshots,
            resyncs: c.resyncs,
            laser_bytes: sensor.laser_bytes,
            observations: sensor.observations,
            tiles_dirty: count(
                (0..layers_of(pyramid).min(N))
                    .filter_map(|k| pyramid.layer(k))
                    .map(|layer| layer.dirty().count_ones() as usize)
                    .sum(),
            ),
            poses_stamped: sensor.pose.poses_stamped,
            poses_refused: sensor.pose.poses_refused,
            pose_gaps: sensor.pose.pose_gaps,
            returns_extrapolated: sensor.pose.returns_extrapolated,
            returns_without_pose: sensor.pose.returns_without_pose,
            time_requests: c.time_requests,
            returns_masked: sensor.filtered.returns_masked,
            returns_too_near: sensor.filtered.returns_too_near,
            returns_too_far: sensor.filtered.returns_too_far,
            returns_low_quality: sensor.filtered.returns_low_quality,
            observations_split: sensor.observations_split,
            returns_implausible: sensor.returns_implausible,
        }
    }

    // ---------------------------------------------------------------- sending

    /// Counts a queued frame and charges it to the bucket.
    fn account(&mut self, len: usize, report: &mut PollReport) {
        let len32 = u32::try_from(len).unwrap_or(u32::MAX);
        self.bucket.take(len);
        self.counters.frames_sent = self.counters.frames_sent.saturating_add(1);
        self.counters.bytes_sent = self.counters.bytes_sent.saturating_add(len32);
        report.frames = report.frames.saturating_add(1);
        report.bytes = report.bytes.saturating_add(len32);
    }

    /// Encodes `message` with the next sequence number and queues it if at least `reserve`
    /// bytes stay free after it. `false` when it did not fit (the number is not used).
    fn send(&mut self, message: &Message<'_>, reserve: usize, report: &mut PollReport) -> bool {
        let Ok(len) = encode(self.tx_seq, message, &mut self.scratch) else {
            return false;
        };
        self.push_scratch(len, reserve, report)
    }

    fn push_scratch(&mut self, len: usize, reserve: usize, report: &mut PollReport) -> bool {
        if self.queue.free() < len.saturating_add(reserve) {
            return false;
        }
        let Some(frame) = self.scratch.get(..len) else {
            return false;
        };
        if !self.queue.push(frame) {
            return false;
        }
        self.tx_seq = self.tx_seq.wrapping_add(1);
        self.account(len, report);
        true
    }

    /// Queues a Reply, or drops it (using its sequence number, so the host sees a gap).
    fn reply(&mut self, reply: Reply) {
        self.control(&Message::Reply(reply));
    }

    /// Queues a control frame (a Reply, a TimeReply, an Observed) in the room patches leave
    /// free, or drops it, using its sequence number so the host sees a gap; `true` if queued.
    fn control(&mut self, message: &Message<'_>) -> bool {
        let mut report = PollReport::default();
        if self.send(message, 0, &mut report) {
            true
        } else {
            self.tx_seq = self.tx_seq.wrapping_add(1);
            self.counters.frames_dropped = self.counters.frames_dropped.saturating_add(1);
            false
        }
    }

    /// Answers a TimeRequest: a TimeReply echoing `host_us`, with `device_us` and the bytes
    /// queued ahead of it (saturating at 65 535), counted in `time_requests`.
    fn time_reply(&mut self, host_us: u64, device_us: u32) {
        let reply = TimeReply {
            host_us,
            device_us,
            queued_ahead: u16::try_from(self.queue.len()).unwrap_or(u16::MAX),
        };
        self.counters.time_requests = self.counters.time_requests.saturating_add(1);
        self.control(&Message::TimeReply(reply));
    }

    /// Queues an Observed frame now (a control frame, ahead of the patches the observation
    /// changed, which go at the next [`poll`](Self::poll)): the observation count after it
    /// (Stats `observations`) and the device µs times (wrapping) of the earliest and the
    /// latest return it placed. Dropped, its sequence number used, when the queue has no
    /// room; `true` if queued.
    pub fn observed(&mut self, observation: u32, first_us: u32, last_us: u32) -> bool {
        let queued = self.control(&Message::Observed(Observed {
            observation,
            first_us,
            last_us,
        }));
        if queued {
            self.counters.observed_frames = self.counters.observed_frames.saturating_add(1);
        }
        queued
    }
}

impl<const Q: usize, const N: usize> Default for Link<Q, N> {
    fn default() -> Self {
        Self::new(LinkConfig::DEFAULT)
    }
}

/// The layers the link describes: the pyramid's, at most 32.
fn layers_of<const W: usize, const L: usize>(pyramid: &Pyramid<W, L>) -> usize {
    pyramid.layer_count().min(MAX_LAYERS)
}

#[cfg(test)]
pub(crate) mod tests;
