//! The host's end of the link (`docs/protocol.md`): a decoder over the device's byte stream
//! (the library's [`terrain_pyramid::wire::link`]), a [`Mirror`] that keeps a copy of every
//! layer from Hello, WindowMoved and LayerPatch, and an encoder for the host's commands.
//!
//! The mirror applies window moves with its own copy of the rule of `docs/core.md` (cells in
//! both windows keep their value, the rest become unknown), applies each decay step the device
//! announces (`Decayed`) to the same rows with the library's own step
//! ([`terrain_pyramid::decay::decayed`]), so that it ages alike with no patch in between, and
//! reports the cells that faded ([`LinkEvent::Faded`]); it checks the sequence numbers, and
//! says when its copy may be wrong and a snapshot should be requested
//! ([`LinkEvent::SnapshotNeeded`]).
//!
//! ```
//! use terrain_pyramid_host::link::{HostLink, LinkEvent};
//! use terrain_pyramid::wire::link::{Message, SnapshotScope};
//! let mut host = HostLink::new();
//! // Bytes from the serial port: the device's boot Hello would normally come first.
//! for event in host.feed(&[0x00]) {
//!     if event == LinkEvent::SnapshotNeeded {
//!         let _bytes = host.command(&Message::RequestSnapshot(SnapshotScope::All)).unwrap();
//!     }
//! }
//! assert!(host.mirror().needs_snapshot());
//! ```

use terrain_pyramid::decay::{decayed, DecayMode};
use terrain_pyramid::wire::link::{
    encode, ClockSource, Decayed, DecodeError, Decoded, EncodeError, FirmwareVersion,
    FrameAccumulator, Header, Hello, HelloReason, LayerPatch, Message, Observed, Reply, RxCounters,
    Stats, TimeReply, Undecoded, WindowMoved, MAX_ENCODED_FRAME, MAX_FRAME,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::Cell;

/// The raw value of an unknown cell.
pub const UNKNOWN: i16 = i16::MIN;

/// What the host side saw that its user may act on.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkEvent {
    /// The device said Hello (boot, configured, reset, or a snapshot follows).
    Hello(Box<Hello>),
    /// The device answered a command.
    Reply(Reply),
    /// The device's counters.
    Stats(Stats),
    /// The mirror may have missed something (a gap, an old frame, a patch it could not
    /// place): send `RequestSnapshot(All)`.
    SnapshotNeeded,
    /// A bad frame was dropped (and counted).
    BadFrame(DecodeError),
    /// A decay step made these cells unknown (they held evidence before): what a planner that
    /// keeps its own map must forget.
    Faded(Vec<FadedCell>),
    /// The device answered a TimeRequest (protocol version 4): the request's host time
    /// echoed, the device's µs clock when it took the request, the bytes queued ahead of the
    /// reply. Leaves the mirror as it is.
    TimeReply(TimeReply),
    /// The device applied an observation (protocol version 4): its count and the device µs
    /// times of its earliest and latest return. Queued ahead of the patches it changed;
    /// leaves the mirror as it is.
    Observed(Observed),
}

/// A cell that decay made unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FadedCell {
    /// The layer, 0 = finest.
    pub layer: usize,
    /// World cell index along x, in the layer's cells.
    pub x: i32,
    /// World cell index along y.
    pub y: i32,
    /// Its raw log-odds before the step (Q8.8: > 0 it was an obstacle, < 0 navigable).
    pub was: i16,
}

/// Counters of the mirror. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MirrorCounters {
    /// Frames applied.
    pub frames: u64,
    /// Frames missing by their sequence numbers.
    pub missing: u64,
    /// Gaps (each one or more missing frames).
    pub gaps: u64,
    /// Old or repeated frames refused.
    pub out_of_order: u64,
    /// Hello frames.
    pub hellos: u64,
    /// Patches applied.
    pub patches: u64,
    /// Patches refused (unknown layer, outside the window, before any Hello).
    pub patches_refused: u64,
    /// Layer moves applied (WindowMoved entries, or a patch's own origin).
    pub moves: u64,
    /// Moves taken from a patch's origin rather than a WindowMoved.
    pub implicit_moves: u64,
    /// Snapshot requests advised.
    pub snapshots_advised: u64,
    /// Decayed frames applied.
    pub decay_frames: u64,
    /// Storage rows decayed (a row is W cells).
    pub rows_decayed: u64,
    /// Cells the mirror's decay made unknown.
    pub cells_faded: u64,
    /// Cells the device said its decay made unknown (equal to `cells_faded` when no change
    /// was in flight while the rows decayed).
    pub cells_faded_device: u64,
    /// Cells a snapshot resent into a layer that was in step before it (not stale): each is
    /// compared with the mirror's own value before it is overwritten.
    pub resent_cells_compared: u64,
    /// Of those, the cells whose resent value differed from the mirror's: 0 when the device
    /// and the mirror were equal cell for cell (the mirror's decay, computed here, against the
    /// device's, for cells that changed only by decay since they were last sent). A cell the
    /// device changed and had not yet sent also differs here: a caller that reads this as a
    /// check of the mirror first waits until the device has sent every change (Stats
    /// `tiles_dirty` = 0), as `pyramid run` does before its final snapshot.
    pub resent_cells_differing: u64,
}

/// One layer as the host knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct MirrorLayer {
    /// The window's origin, world cell indices.
    pub origin: (i32, i32),
    /// The cell size, raw Q16.16 metres.
    pub resolution_q16: i32,
    /// The band, metres (zeros when the device did not know it).
    pub band_m: (f32, f32),
    /// W × W raw Q8.8 cells, row-major by window offset, row 0 = lowest y.
    cells: Vec<i16>,
    /// During a resend: whether each cell has come since the snapshot's Hello.
    covered: Vec<bool>,
    /// Frames were lost since the last snapshot: the layer may differ from the device's.
    stale: bool,
    /// A snapshot's Hello came: the layer is complete once every cell has been resent.
    resyncing: bool,
    /// The resend under way is into a layer that was in step: resent cells are compared.
    verifying: bool,
}

impl MirrorLayer {
    fn new(w: usize, origin: (i32, i32), resolution_q16: i32, band_m: (f32, f32)) -> Self {
        Self {
            origin,
            resolution_q16,
            band_m,
            cells: vec![UNKNOWN; w * w],
            covered: vec![true; w * w],
            stale: false,
            resyncing: false,
            verifying: false,
        }
    }

    /// The cells, row-major, row 0 = lowest y.
    #[must_use]
    pub fn cells(&self) -> &[i16] {
        &self.cells
    }

    /// Whether the layer may differ from the device's: frames were lost, or a resend is
    /// under way.
    #[must_use]
    pub fn is_stale(&self) -> bool {
        self.stale || self.resyncing
    }

    /// Starts waiting for every cell of a resend; a layer that was in step has its resent
    /// cells compared with its own.
    fn start_resync(&mut self) {
        self.verifying = !self.stale && !self.resyncing;
        self.stale = false;
        self.resyncing = true;
        self.covered.fill(false);
    }

    /// Moves the window: cells in both windows keep their value, entering cells are unknown
    /// (and known to be so).
    fn move_to(&mut self, w: usize, origin: (i32, i32)) {
        if origin == self.origin {
            return;
        }
        let mut cells = vec![UNKNOWN; w * w];
        let mut covered = vec![true; w * w];
        let wi = w as i64;
        for dy in 0..w {
            let oy = i64::from(origin.1) + dy as i64 - i64::from(self.origin.1);
            if !(0..wi).contains(&oy) {
                continue;
            }
            for dx in 0..w {
                let ox = i64::from(origin.0) + dx as i64 - i64::from(self.origin.0);
                if (0..wi).contains(&ox) {
                    let from = oy as usize * w + ox as usize;
                    cells[dy * w + dx] = self.cells[from];
                    covered[dy * w + dx] = self.covered[from];
                }
            }
        }
        self.cells = cells;
        self.covered = covered;
        self.origin = origin;
    }

    /// One decay step in `mode` for every cell of `count` storage rows from `first` (the
    /// world rows j of the window with `j mod w` among them); the cells that became unknown
    /// are appended to `faded`.
    fn decay_rows(
        &mut self,
        w: usize,
        layer: usize,
        (first, count): (usize, usize),
        mode: DecayMode,
        faded: &mut Vec<FadedCell>,
    ) {
        let wi = w as i64;
        for t in 0..count.min(w) {
            let storage = ((first + t) % w) as i64;
            let dy = (storage - i64::from(self.origin.1)).rem_euclid(wi) as usize;
            for dx in 0..w {
                let at = dy * w + dx;
                let before = Cell::from_raw(self.cells[at]);
                let after = decayed(before, mode);
                if before.is_observed() && !after.is_observed() {
                    faded.push(FadedCell {
                        layer,
                        x: self.origin.0.saturating_add(dx as i32),
                        y: self.origin.1.saturating_add(dy as i32),
                        was: before.to_raw(),
                    });
                }
                self.cells[at] = after.to_raw();
            }
        }
    }

    /// Writes a patch's cells; `false` when the rectangle is not inside the window. During a
    /// verified resend, each cell not yet resent is compared first: `(compared, differing)`
    /// are added to `check`.
    fn write(&mut self, w: usize, patch: &LayerPatch<'_>, check: &mut (u64, u64)) -> bool {
        let a = &patch.area;
        let ox = i64::from(a.x) - i64::from(self.origin.0);
        let oy = i64::from(a.y) - i64::from(self.origin.1);
        let wi = w as i64;
        let inside =
            ox >= 0 && oy >= 0 && ox + i64::from(a.width) <= wi && oy + i64::from(a.height) <= wi;
        if !inside {
            return false;
        }
        for (i, value) in patch.cells.iter().enumerate() {
            let (c, r) = (i % usize::from(a.width), i / usize::from(a.width));
            let at = (oy as usize + r) * w + ox as usize + c;
            if self.verifying && !self.covered[at] {
                check.0 += 1;
                check.1 += u64::from(self.cells[at] != value);
            }
            self.cells[at] = value;
            self.covered[at] = true;
        }
        if self.resyncing && self.covered.iter().all(|&c| c) {
            self.resyncing = false;
            self.verifying = false;
        }
        true
    }
}

/// The host's copy of the device's pyramid.
#[derive(Debug, Clone, Default)]
pub struct Mirror {
    cells_per_side: usize,
    layers: Vec<MirrorLayer>,
    firmware: Option<FirmwareVersion>,
    clock: ClockSource,
    expected_seq: Option<u16>,
    snapshot_advised: bool,
    last_stats: Option<Stats>,
    counters: MirrorCounters,
}

impl Mirror {
    /// A mirror that knows nothing yet (it needs a Hello).
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// W, cells per side (0 before the first Hello).
    #[must_use]
    pub fn cells_per_side(&self) -> usize {
        self.cells_per_side
    }

    /// The number of layers.
    #[must_use]
    pub fn layer_count(&self) -> usize {
        self.layers.len()
    }

    /// Layer `k`.
    #[must_use]
    pub fn layer(&self, k: usize) -> Option<&MirrorLayer> {
        self.layers.get(k)
    }

    /// Layer `k`'s window origin, resolution (raw Q16.16) and W × W raw cells, row-major,
    /// row 0 = lowest y.
    #[must_use]
    pub fn layer_cells(&self, k: usize) -> Option<((i32, i32), i32, Vec<i16>)> {
        self.layers
            .get(k)
            .map(|l| (l.origin, l.resolution_q16, l.cells.clone()))
    }

    /// The firmware's version, from the last Hello.
    #[must_use]
    pub fn firmware(&self) -> Option<FirmwareVersion> {
        self.firmware
    }

    /// The clock the device's board runs on, from the last Hello (not reported before one).
    #[must_use]
    pub fn clock(&self) -> ClockSource {
        self.clock
    }

    /// The last Stats.
    #[must_use]
    pub fn last_stats(&self) -> Option<Stats> {
        self.last_stats
    }

    /// The counters.
    #[must_use]
    pub fn counters(&self) -> MirrorCounters {
        self.counters
    }

    /// Whether a snapshot should be requested: no Hello yet, or frames lost since the last
    /// snapshot's Hello.
    #[must_use]
    pub fn needs_snapshot(&self) -> bool {
        self.firmware.is_none() || self.layers.iter().any(|l| l.stale)
    }

    /// Whether the copy equals the device's maps as of the last frame: a Hello came, nothing
    /// was lost since, and every resend is complete.
    #[must_use]
    pub fn is_synced(&self) -> bool {
        self.firmware.is_some() && !self.layers.iter().any(MirrorLayer::is_stale)
    }

    /// Whether a snapshot was advised since the last call (and clears the advice).
    pub fn take_snapshot_advice(&mut self) -> bool {
        std::mem::take(&mut self.snapshot_advised)
    }

    fn advise_snapshot(&mut self) {
        self.snapshot_advised = true;
        self.counters.snapshots_advised += 1;
    }

    /// Checks a frame's sequence number; `false` when the frame must be refused (old or
    /// repeated). A gap marks every layer stale.
    fn check_seq(&mut self, header: &Header, is_hello: bool) -> bool {
        let seq = header.seq;
        let Some(expected) = self.expected_seq else {
            self.expected_seq = Some(seq.wrapping_add(1));
            return true;
        };
        let d = seq.wrapping_sub(expected);
        if d >= 0x8000 && !is_hello {
            self.counters.out_of_order += 1;
            self.advise_snapshot();
            return false;
        }
        if d != 0 && d < 0x8000 {
            self.counters.gaps += 1;
            self.counters.missing += u64::from(d);
            for layer in &mut self.layers {
                layer.stale = true;
                layer.verifying = false;
            }
            if !is_hello {
                self.advise_snapshot();
            }
        }
        self.expected_seq = Some(seq.wrapping_add(1));
        true
    }

    /// Applies one frame from the device. Returns the events it gives rise to.
    pub fn apply(&mut self, header: &Header, message: &Message<'_>) -> Vec<LinkEvent> {
        let mut events = Vec::new();
        let is_hello = matches!(message, Message::Hello(_));
        if !self.check_seq(header, is_hello) {
            events.push(LinkEvent::SnapshotNeeded);
            return events;
        }
        self.counters.frames += 1;
        let known = self.firmware.is_some();
        match message {
            // docs/protocol.md: W is even, 4 ..= 1024. The decoder does not check it, and the
            // mirror allocates W² cells per layer: a Hello with W = 65 534 and 16 layers asked
            // for about 200 GB and aborted the host (found by fuzzing, link_host_rx). Refuse
            // it whole and ask for a snapshot.
            Message::Hello(hello)
                if !(4..=terrain_pyramid::design::MAX_CELLS_PER_SIDE)
                    .contains(&usize::from(hello.cells_per_side))
                    || hello.cells_per_side % 2 != 0 =>
            {
                self.advise_snapshot();
            }
            Message::Hello(hello) => {
                self.apply_hello(hello);
                events.push(LinkEvent::Hello(Box::new(hello.clone())));
            }
            Message::WindowMoved(moved) if known => self.apply_moves(moved),
            Message::LayerPatch(patch) if known => self.apply_patch(patch),
            Message::Decayed(decay) if known => {
                let faded = self.apply_decay(decay);
                if !faded.is_empty() {
                    events.push(LinkEvent::Faded(faded));
                }
            }
            Message::WindowMoved(_) | Message::LayerPatch(_) | Message::Decayed(_) => {
                self.counters.patches_refused +=
                    u64::from(matches!(message, Message::LayerPatch(_)));
                if !self.snapshot_advised {
                    self.advise_snapshot();
                }
            }
            Message::Stats(stats) => {
                self.last_stats = Some(*stats);
                events.push(LinkEvent::Stats(*stats));
            }
            Message::Reply(reply) => events.push(LinkEvent::Reply(*reply)),
            Message::TimeReply(reply) => events.push(LinkEvent::TimeReply(*reply)),
            Message::Observed(observed) => events.push(LinkEvent::Observed(*observed)),
            // Commands travel the other way; a device never sends them.
            _ => {}
        }
        if self.snapshot_advised {
            events.push(LinkEvent::SnapshotNeeded);
            self.snapshot_advised = false;
        }
        events
    }

    fn apply_hello(&mut self, hello: &Hello) {
        self.counters.hellos += 1;
        self.firmware = Some(hello.firmware);
        self.clock = hello.clock;
        let w = usize::from(hello.cells_per_side);
        let same_shape = w == self.cells_per_side
            && hello.layers.len() == self.layers.len()
            && hello
                .layers
                .iter()
                .zip(&self.layers)
                .all(|(h, l)| h.resolution_q16 == l.resolution_q16);
        if hello.reason.clears_maps() || !same_shape {
            self.cells_per_side = w;
            self.layers = hello
                .layers
                .iter()
                .map(|l| {
                    MirrorLayer::new(
                        w,
                        (l.origin_x, l.origin_y),
                        l.resolution_q16,
                        (l.band_inner_m, l.band_outer_m),
                    )
                })
                .collect();
            if hello.reason == HelloReason::Snapshot {
                // A snapshot of a shape we did not have: only what is resent can be trusted.
                for (k, layer) in self.layers.iter_mut().enumerate() {
                    if hello.resend & (1 << k) == 0 {
                        layer.stale = true;
                    } else {
                        layer.start_resync();
                        // Nothing of it was known: nothing to compare.
                        layer.verifying = false;
                    }
                }
            }
        } else {
            for (k, (layer, info)) in self.layers.iter_mut().zip(&hello.layers).enumerate() {
                layer.move_to(w, (info.origin_x, info.origin_y));
                layer.band_m = (info.band_inner_m, info.band_outer_m);
                if hello.resend & (1 << k) != 0 {
                    // Every cell will be resent: the layer is whole once all have come.
                    layer.start_resync();
                }
            }
        }
    }

    fn apply_moves(&mut self, moved: &WindowMoved) {
        let w = self.cells_per_side;
        for (k, origin) in moved.iter() {
            match self.layers.get_mut(k) {
                Some(layer) => {
                    layer.move_to(w, origin);
                    self.counters.moves += 1;
                }
                None => self.advise_snapshot(),
            }
        }
    }

    /// Applies a decay step to the rows it names; returns the cells that faded. A layer the
    /// mirror does not have, or rows outside its window, ask for a snapshot.
    fn apply_decay(&mut self, decay: &Decayed) -> Vec<FadedCell> {
        let w = self.cells_per_side;
        let mut faded = Vec::new();
        let Some(mode) = DecayMode::from_u8(decay.mode) else {
            self.advise_snapshot();
            return faded;
        };
        self.counters.decay_frames += 1;
        for (k, rows) in decay.iter() {
            let (first, count) = (usize::from(rows.first), usize::from(rows.rows));
            let Some(layer) = self.layers.get_mut(k).filter(|_| first < w && count <= w) else {
                self.advise_snapshot();
                continue;
            };
            let before = faded.len();
            layer.decay_rows(w, k, (first, count), mode, &mut faded);
            self.counters.rows_decayed += count as u64;
            self.counters.cells_faded += (faded.len() - before) as u64;
            self.counters.cells_faded_device += u64::from(rows.faded);
        }
        faded
    }

    fn apply_patch(&mut self, patch: &LayerPatch<'_>) {
        let w = self.cells_per_side;
        let a = &patch.area;
        let Some(layer) = self.layers.get_mut(usize::from(a.layer)) else {
            self.counters.patches_refused += 1;
            self.advise_snapshot();
            return;
        };
        if layer.origin != (a.origin_x, a.origin_y) {
            // Only after a loss (which the sequence numbers report): follow the device.
            layer.move_to(w, (a.origin_x, a.origin_y));
            self.counters.moves += 1;
            self.counters.implicit_moves += 1;
        }
        let mut check = (0, 0);
        let written = layer.write(w, patch, &mut check);
        self.counters.resent_cells_compared += check.0;
        self.counters.resent_cells_differing += check.1;
        if written {
            self.counters.patches += 1;
        } else {
            self.counters.patches_refused += 1;
            self.advise_snapshot();
        }
    }
}

/// The host's end: decoder, mirror, and the sequence numbers of its own commands.
#[derive(Debug, Clone)]
pub struct HostLink {
    decoder: Box<FrameAccumulator<MAX_FRAME>>,
    mirror: Mirror,
    tx_seq: u16,
}

impl Default for HostLink {
    fn default() -> Self {
        Self::new()
    }
}

impl HostLink {
    /// A host end that has heard nothing yet.
    #[must_use]
    pub fn new() -> Self {
        Self {
            decoder: Box::new(FrameAccumulator::new()),
            mirror: Mirror::new(),
            tx_seq: 0,
        }
    }

    /// The mirror.
    #[must_use]
    pub fn mirror(&self) -> &Mirror {
        &self.mirror
    }

    /// The decoder's counters (bad frames by kind).
    #[must_use]
    pub fn rx_counters(&self) -> RxCounters {
        self.decoder.counters()
    }

    /// Takes bytes from the serial port: decodes every complete frame and applies it.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<LinkEvent> {
        let mut events = Vec::new();
        let mut input = bytes;
        loop {
            match self.decoder.feed(input) {
                FeedResult::Consumed => return events,
                FeedResult::Item {
                    item: Decoded { header, message },
                    remaining,
                    ..
                } => {
                    input = remaining;
                    events.extend(self.mirror.apply(&header, &message));
                }
                FeedResult::Rejected {
                    error: Undecoded { error, .. },
                    remaining,
                    ..
                } => {
                    input = remaining;
                    events.push(LinkEvent::BadFrame(error));
                }
            }
        }
    }

    /// Encodes a command with the host's next sequence number.
    ///
    /// # Errors
    /// A field the format cannot carry.
    pub fn command(&mut self, message: &Message<'_>) -> Result<Vec<u8>, EncodeError> {
        let mut out = vec![0_u8; MAX_ENCODED_FRAME];
        let n = encode(self.tx_seq, message, &mut out)?;
        out.truncate(n);
        self.tx_seq = self.tx_seq.wrapping_add(1);
        Ok(out)
    }

    /// The sequence number the next command will carry.
    #[must_use]
    pub fn next_seq(&self) -> u16 {
        self.tx_seq
    }
}

/// A sentence for a device that sent only frames of another protocol version (the firmware
/// and this host do not match: this host speaks version
/// [`terrain_pyramid::wire::link::VERSION`], 6, and a firmware of an earlier release version 5
/// or older); empty otherwise.
#[must_use]
pub fn version_hint(rx: &RxCounters) -> String {
    if rx.unknown_version > 0 && rx.frames_ok == 0 {
        let version = terrain_pyramid::wire::link::VERSION;
        format!(
            " ({} frames of another protocol version and none of version {version}: the \
             firmware and this host do not match (this host speaks protocol version {version}, \
             a firmware of an earlier release version {} or older); flash the firmware of \
             this release)",
            rx.unknown_version,
            version.saturating_sub(1)
        )
    } else {
        String::new()
    }
}
