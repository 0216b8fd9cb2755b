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
pub mod convert;
mod queue;

pub use bucket::TokenBucket;
pub use queue::FrameQueue;

use crate::angle::Angle;
use crate::decay::DecayMode;
use crate::geometry::Pose;
use crate::grid::{CellRect, TILES_PER_SIDE};
use crate::logodds::Cell;
use crate::pipeline::FrontendConfig;
use crate::pyramid::{Config, Pyramid};
use crate::wire::link::{
    encode, encode_patch, ClockSource, Decayed, DecayedRows, DecodeError, Decoded, FirmwareVersion,
    FrameAccumulator, Header, Hello, HelloReason, LayerInfo, Message, Observed, PatchArea, Reply,
    ReplyCode, RxCounters, SnapshotScope, Stats, TimeReply, Undecoded, WindowMoved,
    MAX_COMMAND_FRAME, MAX_ENCODED_FRAME, MAX_LAYERS, MAX_PATCH_SIDE, MIN_FRAME, VERSION,
};
use crate::wire::FeedResult;
use crate::Design;

/// The default outgoing queue, bytes: 26 default patches, 44 ms of the link at 921 600 Bd.
pub const DEFAULT_QUEUE_BYTES: usize = 4096;

/// Queue room kept free of patches and Stats for control frames (WindowMoved, Reply), bytes.
pub const CONTROL_RESERVE: usize = 256;

/// Tiles per layer.
const TILES: usize = TILES_PER_SIDE * TILES_PER_SIDE;

/// The tiles (bit indices, ascending) set in `bits`.
fn tiles_of(mut bits: u64) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        if bits == 0 {
            return None;
        }
        let tile = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        Some(tile)
    })
}

/// The bits `first ..< end` of a tile mask (`first ≤ end ≤ 64`).
const fn tile_range(first: usize, end: usize) -> u64 {
    let below_end = if end >= TILES {
        u64::MAX
    } else {
        (1 << end) - 1
    };
    let below_first = if first >= TILES {
        u64::MAX
    } else {
        (1 << first) - 1
    };
    below_end & !below_first
}

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

/// Counters of other modules that Stats carries: the firmware fills them in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorCounters {
    /// SICK telegrams decoded.
    pub telegrams_ok: u32,
    /// SICK telegrams with a bad checksum.
    pub telegrams_bad_checksum: u32,
    /// SICK telegrams with bad framing.
    pub telegrams_bad_framing: u32,
    /// SICK telegrams refused for another reason.
    pub telegrams_bad_other: u32,
    /// Points offered to the classifier.
    pub points: u32,
    /// Points dropped by a full classifier scratch table.
    pub classifier_overflows: u32,
    /// Bytes the laser's UART delivered to the SICK decoder (wrapping).
    pub laser_bytes: u32,
    /// Observations finished and applied (`FrontendStats::observations`).
    pub observations: u32,
    /// The pose track's counters (protocol version 4).
    pub pose: PoseCounters,
}

/// The device's pose-track counters that Stats carries (protocol version 4, Stats i = 30 ..=
/// 34): the firmware fills them in from its placement of returns. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseCounters {
    /// Stamped poses taken into the track.
    pub poses_stamped: u32,
    /// Stamped poses refused: not newer than the newest, or more than 1 s ahead of the
    /// device's clock.
    pub poses_refused: u32,
    /// Stamped poses more than 500 ms after the newest: the track restarted at them.
    pub pose_gaps: u32,
    /// Returns placed with a pose extrapolated past the newest (within the bound).
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u32,
}

impl PoseCounters {
    /// All zero, `const` (for a `static`).
    pub const ZERO: Self = Self {
        poses_stamped: 0,
        poses_refused: 0,
        pose_gaps: 0,
        returns_extrapolated: 0,
        returns_without_pose: 0,
    };
}

/// The link's own counters. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkCounters {
    /// Frames queued.
    pub frames_sent: u32,
    /// Encoded bytes queued.
    pub bytes_sent: u32,
    /// LayerPatch frames queued.
    pub patches_sent: u32,
    /// Tiles whose send was put back for lack of budget or room, each counted once per dirty
    /// period (the first poll that could not send it since it changed or was last sent), not
    /// at every poll it keeps waiting.
    pub patches_deferred: u32,
    /// Control frames dropped for lack of room.
    pub frames_dropped: u32,
    /// Host frames missing by their sequence numbers.
    pub rx_seq_gaps: u32,
    /// Commands refused.
    pub commands_refused: u32,
    /// Snapshots served.
    pub snapshots: u32,
    /// Full resends after window moves collapsed between two polls.
    pub resyncs: u32,
    /// Decayed frames queued (each announces the decay steps it accompanies).
    pub decay_frames: u32,
    /// Polls whose owed decay waited for queue room (it is paid at a later poll).
    pub decay_deferred: u32,
    /// TimeRequests answered with a TimeReply (queued, or dropped for lack of room).
    pub time_requests: u32,
    /// Observed frames queued.
    pub observed_frames: u32,
}

/// A host command, decoded, validated and converted into the core's types by the link
/// ([`convert`]): what the application carries out. Commands that fail validation never
/// become one: the link refuses them itself ([`Rejection::Refused`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Command<const L: usize> {
    /// The robot's pose (checked by [`Pose::from_f32`]'s rule) and its stamp: `None`, an
    /// unstamped pose, in force for every return from now on (version 3's latest-pose rule);
    /// `Some(stamp_us)`, a stamped pose (Pose `flags` bit 0), the robot's pose at `stamp_us` of
    /// the device's µs clock (wrapping), for the pose track. Flags other than bit 0 are
    /// refused by the link (Reply OutOfRange, param [`convert::PARAM_POSE_FLAGS`]).
    Pose(Pose, Option<u32>),
    /// The actuator angle from the host (boards without an encoder, or when it fails).
    PanAngle(Angle),
    /// A new design and configuration (checked by [`Design::new`] and the increments' and
    /// clamp's rules; the window and the margin are checked when it is applied).
    Configure(Design<L>, Config),
    /// Forget every observation.
    Reset,
    /// Send every tile of these layers again.
    Snapshot(SnapshotScope),
    /// Answer Ok.
    Ping,
    /// Answer with a TimeReply (the link does, in [`Link::serve`]; no Reply).
    TimeRequest {
        /// The host's clock, echoed, µs.
        host_us: u64,
        /// The device's µs clock (wrapping) the board passed with the host bytes that
        /// completed the request ([`Link::receive_at`]).
        device_us: u32,
    },
    /// The laser's mounting, its lines' grouping and the classifier (checked by
    /// [`convert::frontend_config`]).
    Setup(FrontendConfig),
    /// The classifier's step threshold (metres) and navigability rule, the rest of the setup
    /// unchanged (checked by [`convert::set_rule_of`]).
    SetRule(crate::units::Meters, crate::classify::NavigabilityRule),
    /// Send a Stats frame at the next poll, whatever the interval.
    RequestStats,
    /// End the current observation now (no Reply).
    EndObservation,
    /// Answer with the stack's high-water mark (Reply Ok, `value` the bytes used, `a` the
    /// stack's size), drain the queue, stop.
    Shutdown,
}

/// A command and the header of the frame that carried it (its Reply names it).
#[derive(Debug, Clone, PartialEq)]
pub struct Request<const L: usize> {
    /// The frame's header.
    pub header: Header,
    /// What it asks.
    pub command: Command<L>,
}

/// Why a host frame became no [`Request`]. Both are counted; a Reply has been queued where
/// the frame could be answered.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// The frame did not decode (framing, CRC, version, type, body); answered when its header
    /// was readable.
    BadFrame(DecodeError),
    /// The command failed validation; this Reply, queued, says why.
    Refused(Reply),
}

/// What one [`Link::poll`] queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PollReport {
    /// Frames queued.
    pub frames: u32,
    /// Bytes queued.
    pub bytes: u32,
    /// LayerPatch frames queued.
    pub patches: u32,
    /// Dirty tiles left for a later poll.
    pub deferred_tiles: u32,
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

    /// Sends the pending Hello; `true` when none is pending any more.
    fn flush_hello<const W: usize, const L: usize>(
        &mut self,
        pyramid: &Pyramid<W, L>,
        report: &mut PollReport,
    ) -> bool {
        let Some((reason, resend)) = self.hello.get() else {
            return true;
        };
        let count = layers_of(pyramid).min(N);
        let mut layers = heapless::Vec::new();
        for k in 0..count {
            let (Some(layer), Some(&(inner, outer))) = (pyramid.layer(k), self.bands.get(k)) else {
                continue;
            };
            let (origin_x, origin_y) = layer.origin();
            let info = LayerInfo {
                resolution_q16: layer.resolution().to_bits(),
                band_inner_m: inner,
                band_outer_m: outer,
                origin_x,
                origin_y,
            };
            if layers.push(info).is_err() {
                break;
            }
        }
        let hello = Hello {
            protocol: VERSION,
            firmware: self.config.firmware,
            reason,
            cells_per_side: u16::try_from(W).unwrap_or(u16::MAX),
            resend,
            clock: self.config.clock,
            layers,
        };
        if !self.send(&Message::Hello(hello), 0, report) {
            return false;
        }
        self.hello = PendingHello::NONE;
        self.remember_geometry(pyramid);
        true
    }

    /// Records what the host now knows: layers, resolutions, origins, the reset counter.
    fn remember_geometry<const W: usize, const L: usize>(&mut self, pyramid: &Pyramid<W, L>) {
        self.sent_layers = layers_of(pyramid).min(N);
        for k in 0..N {
            let (res, origin) = pyramid
                .layer(k)
                .map_or((0, (0, 0)), |l| (l.resolution().to_bits(), l.origin()));
            if let Some(slot) = self.sent_resolution.get_mut(k) {
                *slot = res;
            }
            if let Some(slot) = self.sent_origin.get_mut(k) {
                *slot = origin;
            }
        }
        self.reset_baseline = pyramid.stats().cells_reset;
    }

    /// Whether the pyramid's layers differ from what the host was told, or its counters went
    /// back: it was configured without the link's knowledge.
    fn reconfigured<const W: usize, const L: usize>(&self, pyramid: &Pyramid<W, L>) -> bool {
        let count = layers_of(pyramid).min(N);
        if count != self.sent_layers || pyramid.stats().cells_reset < self.reset_baseline {
            return true;
        }
        (0..count).any(|k| {
            pyramid.layer(k).map(|l| l.resolution().to_bits())
                != self.sent_resolution.get(k).copied()
        })
    }

    /// Sends one WindowMoved for the layers whose origin changed; `false` when it did not fit.
    /// Detects moves that collapsed between two polls and then resends everything.
    fn send_moves<const W: usize, const L: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        report: &mut PollReport,
    ) -> bool {
        let count = layers_of(pyramid).min(N);
        // First only whether any layer moved (most polls: none), so that the message, a
        // quarter kilobyte, is cleared and filled only when it is sent.
        let mut expected: u64 = 0;
        let mut any_moved = false;
        for k in 0..count {
            let (Some(layer), Some(&sent)) = (pyramid.layer(k), self.sent_origin.get(k)) else {
                continue;
            };
            let origin = layer.origin();
            if origin != sent {
                any_moved = true;
                expected = expected.saturating_add(cells_reset_by_move::<W>(sent, origin));
            }
        }
        let now = pyramid.stats().cells_reset;
        let delta = u64::from(now.saturating_sub(self.reset_baseline));
        // A saturated counter says nothing any more: trust the caller then.
        let collapsed = now != u32::MAX && delta != expected;
        if !any_moved && !collapsed {
            return true;
        }
        let mut moved = WindowMoved::new();
        for k in 0..count {
            let (Some(layer), Some(&sent)) = (pyramid.layer(k), self.sent_origin.get(k)) else {
                continue;
            };
            let origin = layer.origin();
            if origin != sent {
                moved.set(k, origin);
            }
        }
        if !moved.is_empty() && !self.send(&Message::WindowMoved(moved), 0, report) {
            return false;
        }
        if collapsed {
            for k in 0..count {
                if let Some(mut dirty) = pyramid.layer_dirty_mut(k) {
                    dirty.mark(u64::MAX);
                }
            }
            self.counters.resyncs = self.counters.resyncs.saturating_add(1);
            warn!("link: window moves collapsed between polls, resending every tile");
        }
        for (k, origin) in moved.iter() {
            if let Some(slot) = self.sent_origin.get_mut(k) {
                *slot = origin;
            }
        }
        self.reset_baseline = now;
        true
    }

    /// Sends the changed tiles, oldest first (round-robin among equals), while the budget and
    /// the queue allow; puts the rest back.
    ///
    /// The work is proportional to the tiles waiting, not to the `64 · N` tiles: a poll with
    /// nothing changed costs a few instructions per layer.
    fn send_patches<const W: usize, const L: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        report: &mut PollReport,
    ) {
        let count = layers_of(pyramid).min(N);
        let total = count * TILES;
        if total == 0 {
            return;
        }
        let mut dirty = [0_u64; N];
        for (k, bits) in dirty.iter_mut().enumerate().take(count) {
            if let Some(mut tiles) = pyramid.layer_dirty_mut(k) {
                *bits = tiles.take();
            }
        }
        // Each waiting tile ages by one poll (saturating); every other tile's age is 0.
        for ((bits, ages), aged) in dirty
            .iter()
            .zip(self.ages.iter_mut())
            .zip(self.aged.iter_mut())
            .take(count)
        {
            for tile in tiles_of(*aged & !*bits) {
                if let Some(age) = ages.get_mut(tile) {
                    *age = 0;
                }
            }
            for tile in tiles_of(*bits) {
                if let Some(age) = ages.get_mut(tile) {
                    *age = age.saturating_add(1);
                }
            }
            *aged = *bits;
        }
        let start = self.cursor % total;
        let mut level = u8::MAX;
        'ages: loop {
            // The oldest age not above `level` among the waiting tiles.
            let mut top = 0_u8;
            for (bits, ages) in dirty.iter().zip(self.ages.iter()).take(count) {
                for tile in tiles_of(*bits) {
                    let age = ages.get(tile).copied().unwrap_or(0);
                    if age <= level && age > top {
                        top = age;
                    }
                }
            }
            if top == 0 {
                break;
            }
            // The waiting tiles of that age in round-robin order from the cursor: global
            // index g = 64·k + tile from `start` up, then from 0 below `start`.
            for (low, high) in [(start, total), (0, start)] {
                for k in low / TILES..high.div_ceil(TILES).min(count) {
                    let first = low.saturating_sub(k * TILES).min(TILES);
                    let end = high.saturating_sub(k * TILES).min(TILES);
                    let Some(&bits) = dirty.get(k) else {
                        continue;
                    };
                    for tile in tiles_of(bits & tile_range(first, end)) {
                        let age = self.ages.get(k).and_then(|a| a.get(tile)).copied();
                        if age != Some(top) {
                            continue;
                        }
                        if !self.send_tile(pyramid, k, tile, report) {
                            self.cursor = k * TILES + tile;
                            break 'ages;
                        }
                        if let Some(bits) = dirty.get_mut(k) {
                            *bits &= !(1 << tile);
                        }
                        if let Some(age) = self.ages.get_mut(k).and_then(|a| a.get_mut(tile)) {
                            *age = 0;
                        }
                        if let Some(aged) = self.aged.get_mut(k) {
                            *aged &= !(1 << tile);
                        }
                    }
                }
            }
            level = top - 1;
        }
        let mut deferred = 0_u32;
        let mut newly_deferred = 0_u32;
        for ((k, &bits), ages) in dirty.iter().enumerate().zip(self.ages.iter()).take(count) {
            if bits != 0 {
                if let Some(mut tiles) = pyramid.layer_dirty_mut(k) {
                    tiles.mark(bits);
                }
                deferred += bits.count_ones();
                // Age 1: the tile's first poll since it changed (or was last sent). A tile
                // that keeps waiting is counted once, not at every poll.
                newly_deferred += tiles_of(bits)
                    .filter(|&tile| ages.get(tile) == Some(&1))
                    .count() as u32;
            }
        }
        report.deferred_tiles = deferred;
        self.counters.patches_deferred = self
            .counters
            .patches_deferred
            .saturating_add(newly_deferred);
    }

    /// Sends one tile of layer `k` as one or more patches, all or none.
    fn send_tile<const W: usize, const L: usize>(
        &mut self,
        pyramid: &Pyramid<W, L>,
        k: usize,
        tile: usize,
        report: &mut PollReport,
    ) -> bool {
        let Some(layer) = pyramid.layer(k) else {
            return true;
        };
        let rects = layer.tile_rects(tile);
        let need: usize = rects
            .iter()
            .flatten()
            .copied()
            .flat_map(pieces)
            .map(|r| patch_frame_len(&r))
            .sum();
        // A tile larger than the bucket's depth waits for a full bucket, then overdraws it.
        let burst = usize::try_from(self.config.burst_bytes).unwrap_or(usize::MAX);
        if !self.bucket.allows(need.min(burst))
            || self.queue.free() < need.saturating_add(CONTROL_RESERVE)
        {
            return false;
        }
        let (origin_x, origin_y) = layer.origin();
        let layer_byte = u8::try_from(k).unwrap_or(u8::MAX);
        for rect in rects.iter().flatten().copied().flat_map(pieces) {
            let area = PatchArea {
                layer: layer_byte,
                origin_x,
                origin_y,
                x: rect.x,
                y: rect.y,
                width: u8::try_from(rect.width).unwrap_or(0),
                height: u8::try_from(rect.height).unwrap_or(0),
            };
            let cell = |c: u8, r: u8| {
                layer
                    .get(
                        rect.x.saturating_add(i32::from(c)),
                        rect.y.saturating_add(i32::from(r)),
                    )
                    .map_or(Cell::UNKNOWN.to_raw(), Cell::to_raw)
            };
            let Ok(len) = encode_patch(self.tx_seq, &area, cell, &mut self.scratch) else {
                continue;
            };
            if self.push_scratch(len, 0, report) {
                self.counters.patches_sent = self.counters.patches_sent.saturating_add(1);
                report.patches = report.patches.saturating_add(1);
            }
        }
        true
    }

    /// Sends Stats when due and the queue has room for it beside [`CONTROL_RESERVE`], or
    /// beside what an empty queue of `Q` bytes holds next to the largest Stats frame when
    /// that is less ([`STATS_RESERVE`]: the micro:bit's 400-byte queue keeps 246 bytes).
    fn send_stats<const W: usize, const L: usize>(
        &mut self,
        now_ms: u32,
        pyramid: &Pyramid<W, L>,
        sensor: &SensorCounters,
        report: &mut PollReport,
    ) {
        let interval = self.config.stats_interval_ms;
        let due = match self.last_stats_ms {
            _ if self.stats_requested => true,
            _ if interval == 0 => false,
            None => true,
            Some(last) => now_ms.wrapping_sub(last) >= interval,
        };
        if !due {
            return;
        }
        // The counters as they will be once this frame is queued.
        let stats = self.stats(now_ms, pyramid, sensor);
        if self.send(&Message::Stats(stats), Self::STATS_RESERVE, report) {
            self.last_stats_ms = Some(now_ms);
            self.stats_requested = false;
        }
    }

    /// Pays the pyramid's decay owed at `now_ms` and announces it with one Decayed frame, or,
    /// when the queue has no room for that frame beside half the [`CONTROL_RESERVE`], pays
    /// nothing now (the debt waits for a later poll, up to one step a layer). It goes after the
    /// patches, so that a busy link delays the decay, never the map. A layer is paid once it
    /// owes a row of tiles (W/8 storage rows): a board that polls in a tight loop sends a few
    /// Decayed frames per step period, not one per poll.
    fn send_decay<const W: usize, const L: usize>(
        &mut self,
        now_ms: u32,
        pyramid: &mut Pyramid<W, L>,
        report: &mut PollReport,
    ) {
        pyramid.accrue_decay(now_ms);
        let mode = pyramid.decay_mode();
        if mode == DecayMode::Off {
            return;
        }
        let count = layers_of(pyramid).min(N);
        let batch = (W / TILES_PER_SIDE).max(1);
        let owes = |k: usize| pyramid.decay_due(k) >= batch;
        let due = (0..count).filter(|&k| owes(k)).count();
        if due == 0 {
            return;
        }
        let len = crate::wire::link::encoded_len_max(MIN_FRAME + 5 + 8 * due);
        if self.queue.free() < len.saturating_add(CONTROL_RESERVE / 2) {
            self.counters.decay_deferred = self.counters.decay_deferred.saturating_add(1);
            return;
        }
        let mut decayed = Decayed::new(mode.to_u8());
        for k in 0..count {
            if pyramid.decay_due(k) < batch {
                continue;
            }
            if let Some(rows) = pyramid.decay_layer(k) {
                decayed.set(
                    k,
                    DecayedRows {
                        first: rows.first,
                        rows: rows.rows,
                        faded: rows.faded,
                    },
                );
            }
        }
        if self.send(&Message::Decayed(decayed), 0, report) {
            self.counters.decay_frames = self.counters.decay_frames.saturating_add(1);
        } else {
            // Room was checked: never. Should it happen, the number is used, so the host
            // sees a gap and asks for a snapshot.
            self.tx_seq = self.tx_seq.wrapping_add(1);
            self.counters.frames_dropped = self.counters.frames_dropped.saturating_add(1);
        }
    }

    /// Refills the budget from `now_ms` (the caller's clock, ms, wrapping) and queues what is
    /// due, in order: a pending Hello, WindowMoved, Stats, changed tiles oldest first while
    /// the budget and the queue allow (the rest stay dirty for a later poll), then the decay
    /// owed (one Decayed frame, see [`Pyramid::accrue_decay`]).
    ///
    /// Call it after every [`Pyramid::recentre`]: the host replays each window move, and moves
    /// that collapse between two polls cost a full resend.
    pub fn poll<const W: usize, const L: usize>(
        &mut self,
        now_ms: u32,
        pyramid: &mut Pyramid<W, L>,
        sensor: &SensorCounters,
    ) -> PollReport {
        const {
            assert!(N <= MAX_LAYERS, "the host link describes at most 32 layers");
            assert!(L <= N, "the link holds state for at most N layers");
            assert!(
                Q >= min_queue_bytes(W, L),
                "the link's queue must hold min_queue_bytes(W, L) bytes"
            );
        }
        let mut report = PollReport::default();
        self.bucket.refill(now_ms);
        if self.hello.get().is_none() && self.reconfigured(pyramid) {
            warn!("link: the pyramid was configured behind the link's back");
            self.want_hello(HelloReason::Configured, 0);
        }
        if !self.flush_hello(pyramid, &mut report) {
            return report;
        }
        if !self.send_moves(pyramid, &mut report) {
            return report;
        }
        self.send_stats(now_ms, pyramid, sensor, &mut report);
        self.send_patches(pyramid, &mut report);
        self.send_decay(now_ms, pyramid, &mut report);
        report
    }

    // ---------------------------------------------------------------- receiving

    /// Carries out and answers the commands that concern only the link and the maps (a
    /// snapshot, a Stats request, a ping, a time request) and hands back the others, which
    /// are the application's ([`crate::app::CoProcessor`] carries them out).
    pub fn serve<const W: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, N>,
        request: Request<N>,
    ) -> Option<Request<N>> {
        let header = request.header;
        match request.command {
            Command::Snapshot(scope) => {
                if self.snapshot(pyramid, scope) {
                    self.answer(Reply::ok(header));
                    self.announce(pyramid);
                } else {
                    let layers = layers_of(pyramid).min(N);
                    self.refuse(convert::layer_refusal(header, scope, layers));
                }
                None
            }
            Command::RequestStats => {
                self.request_stats();
                None
            }
            Command::Ping => {
                self.answer(Reply::ok(header));
                None
            }
            Command::TimeRequest { host_us, device_us } => {
                self.time_reply(host_us, device_us);
                None
            }
            _ => Some(request),
        }
    }

    /// Takes bytes from the host and returns the first thing they complete, postcard-style:
    /// a validated [`Request`] to carry out, or a [`Rejection`] (counted, and answered where
    /// possible), each with the bytes not yet taken; [`FeedResult::Consumed`] when the bytes
    /// complete nothing. Call it again with `remaining` until `Consumed`.
    ///
    /// Invalid commands are refused here, by the rule that converts them, with a Reply that
    /// names the field; a valid one is the application's to carry out and to answer
    /// ([`answer`](Self::answer), [`refuse`](Self::refuse)).
    ///
    /// The device time a TimeRequest carries is the one of the last
    /// [`receive_at`](Self::receive_at) (0 before any): a board with a µs clock calls that.
    pub fn receive<'c>(&mut self, bytes: &'c [u8]) -> FeedResult<'c, Request<N>, Rejection> {
        // The message borrows the receive buffer: convert it into an owned command first.
        let (frame, offset, remaining) = match self.rx.feed(bytes) {
            FeedResult::Consumed => return FeedResult::Consumed,
            FeedResult::Item {
                item: Decoded { header, message },
                offset,
                remaining,
            } => (
                Ok((header, command(header, message, self.rx_clock_us))),
                offset,
                remaining,
            ),
            FeedResult::Rejected {
                error: Undecoded { error, header },
                offset,
                remaining,
            } => (Err((error, header)), offset, remaining),
        };
        match frame {
            Ok((header, Ok(command))) => {
                self.track_seq(header.seq);
                FeedResult::Item {
                    item: Request { header, command },
                    offset,
                    remaining,
                }
            }
            Ok((header, Err(reply))) => {
                self.track_seq(header.seq);
                self.refuse(reply);
                FeedResult::Rejected {
                    error: Rejection::Refused(reply),
                    offset,
                    remaining,
                }
            }
            Err((error, header)) => {
                if let Some(header) = header {
                    self.track_seq(header.seq);
                    let code = match error {
                        DecodeError::UnknownType(_) => ReplyCode::Unsupported,
                        _ => ReplyCode::Malformed,
                    };
                    self.refuse(Reply::code(header, code));
                }
                FeedResult::Rejected {
                    error: Rejection::BadFrame(error),
                    offset,
                    remaining,
                }
            }
        }
    }

    /// [`receive`](Self::receive) of host bytes the board took at `now_us` of its µs clock
    /// (wrapping): a TimeRequest they complete carries that time as its `device_us`. Later
    /// calls of `receive` (the rest of the same bytes) keep it.
    pub fn receive_at<'c>(
        &mut self,
        bytes: &'c [u8],
        now_us: u32,
    ) -> FeedResult<'c, Request<N>, Rejection> {
        self.rx_clock_us = now_us;
        self.receive(bytes)
    }

    fn track_seq(&mut self, seq: u16) {
        if let Some(expected) = self.rx_expected {
            let d = seq.wrapping_sub(expected);
            if d != 0 {
                let missing = if d < 0x8000 { u32::from(d) } else { 1 };
                self.counters.rx_seq_gaps = self.counters.rx_seq_gaps.saturating_add(missing);
            }
        }
        self.rx_expected = Some(seq.wrapping_add(1));
    }
}

/// A host message as a validated command, or the Reply that refuses it; `now_us` is the
/// device time of the bytes that completed it.
fn command<const L: usize>(
    header: Header,
    message: Message<'_>,
    now_us: u32,
) -> Result<Command<L>, Reply> {
    Ok(match message {
        Message::Pose(report) => {
            let pose = convert::pose_of(&report).map_err(|e| convert::pose_refusal(header, &e))?;
            let stamp =
                convert::stamp_of(&report).map_err(|f| convert::pose_flags_refusal(header, f))?;
            Command::Pose(pose, stamp)
        }
        Message::TimeRequest(request) => Command::TimeRequest {
            host_us: request.host_us,
            device_us: now_us,
        },
        Message::PanAngle(pan) => Command::PanAngle(pan.angle()),
        Message::Configure(c) => {
            let refuse = |e: crate::DesignError| convert::design_refusal(header, &e);
            let design = convert::design_of::<L>(&c).map_err(refuse)?;
            let config = convert::config_of(&c).map_err(refuse)?;
            Command::Configure(design, config)
        }
        Message::Reset => Command::Reset,
        Message::RequestSnapshot(scope) => Command::Snapshot(scope),
        Message::Ping => Command::Ping,
        Message::Setup(setup) => Command::Setup(
            convert::frontend_config(&setup).map_err(|e| convert::setup_refusal(header, &e))?,
        ),
        Message::SetRule(set) => {
            let (step, rule) =
                convert::set_rule_of(&set).map_err(|e| convert::setup_refusal(header, &e))?;
            Command::SetRule(step, rule)
        }
        Message::RequestStats => Command::RequestStats,
        Message::EndObservation => Command::EndObservation,
        Message::Shutdown => Command::Shutdown,
        Message::Hello(_)
        | Message::LayerPatch(_)
        | Message::WindowMoved(_)
        | Message::Stats(_)
        | Message::Reply(_)
        | Message::Decayed(_)
        | Message::TimeReply(_)
        | Message::Observed(_) => return Err(Reply::code(header, ReplyCode::Unsupported)),
    })
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

/// The cells a window of W cells resets when its origin moves from `old` to `new` directly:
/// `W² − (W − |dx|)·(W − |dy|)`, or `W²` for a move of W or more.
fn cells_reset_by_move<const W: usize>(old: (i32, i32), new: (i32, i32)) -> u64 {
    let w = u64::try_from(W).unwrap_or(u64::MAX);
    let dx = (i64::from(new.0) - i64::from(old.0)).unsigned_abs();
    let dy = (i64::from(new.1) - i64::from(old.1)).unsigned_abs();
    if dx >= w || dy >= w {
        w.saturating_mul(w)
    } else {
        w * w - (w - dx) * (w - dy)
    }
}

/// A tile rectangle cut into pieces of at most 16 × 16 cells.
fn pieces(rect: CellRect) -> impl Iterator<Item = CellRect> {
    let side = u16::try_from(MAX_PATCH_SIDE).unwrap_or(16);
    let rows = rect.height.div_ceil(side);
    let cols = rect.width.div_ceil(side);
    (0..rows).flat_map(move |r| {
        (0..cols).map(move |c| {
            let (dx, dy) = (c * side, r * side);
            CellRect {
                x: rect.x.saturating_add(i32::from(dx)),
                y: rect.y.saturating_add(i32::from(dy)),
                width: (rect.width - dx).min(side),
                height: (rect.height - dy).min(side),
            }
        })
    })
}

/// The most bytes a patch of `rect` takes on the wire.
fn patch_frame_len(rect: &CellRect) -> usize {
    let cells = usize::from(rect.width) * usize::from(rect.height);
    crate::wire::link::encoded_len_max(MIN_FRAME + PATCH_AREA_BYTES + 2 * cells)
}

#[cfg(test)]
pub(crate) mod tests;
