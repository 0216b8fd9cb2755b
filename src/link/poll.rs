//! The link's scheduler ([`Link::poll`]): Hello, window moves, Stats, decay and the patches
//! of changed tiles, queued in turn within the token bucket's budget and the queue's room;
//! a tile that does not fit keeps its dirty bit for a later poll.

use crate::decay::DecayMode;
use crate::grid::{CellRect, TILES_PER_SIDE};
use crate::logodds::Cell;
use crate::pyramid::Pyramid;
use crate::wire::link::{
    encode_patch, Decayed, DecayedRows, Hello, HelloReason, LayerInfo, Message, PatchArea,
    WindowMoved, MAX_LAYERS, MAX_PATCH_SIDE, MIN_FRAME, VERSION,
};

use super::{
    layers_of, min_queue_bytes, Link, PendingHello, SensorCounters, CONTROL_RESERVE,
    PATCH_AREA_BYTES, TILES,
};

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

/// The layers a poll schedules (`count`: the pyramid's, at most `N`), their tiles
/// (`total`: 64 a layer) and their dirty tiles, taken (the pyramid's dirty bits cleared; bit
/// `t` of entry `k` is tile `t` of layer `k`); `None` when there is no tile.
pub(super) fn take_dirty<const N: usize, const W: usize, const L: usize>(
    pyramid: &mut Pyramid<W, L>,
) -> Option<(usize, usize, [u64; N])> {
    let count = layers_of(pyramid).min(N);
    let total = count * TILES;
    if total == 0 {
        return None;
    }
    let mut dirty = [0_u64; N];
    for (k, bits) in dirty.iter_mut().enumerate().take(count) {
        if let Some(mut tiles) = pyramid.layer_dirty_mut(k) {
            *bits = tiles.take();
        }
    }
    Some((count, total, dirty))
}

/// Marks the tiles still set in `dirty` (of the first `count` layers) dirty again in
/// `pyramid`, for a later poll, and counts them: all of them, and those at age 1 in `ages`.
pub(super) fn put_back<const N: usize, const W: usize, const L: usize>(
    pyramid: &mut Pyramid<W, L>,
    dirty: &[u64; N],
    ages: &[[u8; TILES]; N],
    count: usize,
) -> (u32, u32) {
    let mut deferred = 0_u32;
    let mut newly_deferred = 0_u32;
    for ((k, &bits), ages) in dirty.iter().enumerate().zip(ages.iter()).take(count) {
        if bits != 0 {
            if let Some(mut tiles) = pyramid.layer_dirty_mut(k) {
                tiles.mark(bits);
            }
            deferred += bits.count_ones();
            // Age 1: the tile's first poll since it changed (or was last sent). A tile that
            // keeps waiting is counted once, not at every poll.
            newly_deferred += tiles_of(bits)
                .filter(|&tile| ages.get(tile) == Some(&1))
                .count() as u32;
        }
    }
    (deferred, newly_deferred)
}

impl<const Q: usize, const N: usize> Link<Q, N> {
    /// Sends the pending Hello; `true` when none is pending any more.
    pub(super) fn flush_hello<const W: usize, const L: usize>(
        &mut self,
        pyramid: &Pyramid<W, L>,
        report: &mut PollReport,
    ) -> bool {
        let Some((reason, resend)) = self.hello.get() else {
            return true;
        };
        let count = layers_of(pyramid).min(N);
        // The message is built in place, its layers filled inside it: a Hello holds room for
        // 32 layers (640 bytes), and a layer list, a Hello and a Message built one from the
        // other cost the micro:bit's deepest stack path that twice more.
        let mut message = Message::Hello(Hello {
            protocol: VERSION,
            firmware: self.config.firmware,
            reason,
            cells_per_side: u16::try_from(W).unwrap_or(u16::MAX),
            resend,
            clock: self.config.clock,
            layers: heapless::Vec::new(),
        });
        if let Message::Hello(hello) = &mut message {
            for k in 0..count {
                let (Some(layer), Some(&(inner, outer))) = (pyramid.layer(k), self.bands.get(k))
                else {
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
                if hello.layers.push(info).is_err() {
                    break;
                }
            }
        }
        if !self.send(&message, 0, report) {
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
    pub(super) fn send_patches<const W: usize, const L: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        report: &mut PollReport,
    ) {
        let Some((count, total, mut dirty)) = take_dirty::<N, W, L>(pyramid) else {
            return;
        };
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
        let (deferred, newly_deferred) = put_back(pyramid, &dirty, &self.ages, count);
        report.deferred_tiles = deferred;
        self.counters.patches_deferred = self
            .counters
            .patches_deferred
            .saturating_add(newly_deferred);
    }

    /// Sends one tile of layer `k` as one or more patches, all or none.
    pub(super) fn send_tile<const W: usize, const L: usize>(
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
    /// that is less ([`Link::STATS_RESERVE`]: the micro:bit's 400-byte queue keeps 246 bytes).
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
