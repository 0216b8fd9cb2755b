//! The pyramid: the layers together. Integration of gated evidence, recentring on the robot,
//! the fused query, and per-layer counts. Rules in `docs/core.md`.
//!
//! A `Pyramid<W, L>` holds up to `L` layers of W × W cells, about `L · 2·W²` bytes (plus a few
//! words per layer), all inline: put it in a `static` (its constructor is `const`) and
//! [`Pyramid::configure`] it in place, so that it never sits on the stack.
//!
//! Evidence flows one way: the classifier ([`crate::classify`]) owns the gating tables and
//! hands each record over with its gate weight already looked up; the pyramid only applies
//! it, with the inverse sensor model's increments and clamping.

use crate::decay::{Decay, DecayMode, DecayRows, Sweep, TimeConstant};
use crate::design::{Design, DesignError, Param};
use crate::grid::{Layer, LayerCounts, Resolution};
use crate::logodds::{Cell, Clamp, Increments, InverseSensorModel};
use crate::units::{LogOddsFixed, Meters, Weight};

/// What the classifier concluded about one layer cell from one observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EvidenceClass {
    /// The points in the cell spread beyond the step threshold: not navigable.
    Obstacle,
    /// The points in the cell lie close together (or overhang above the robot): navigable.
    Navigable,
}

/// One observation's evidence for one layer cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Evidence {
    /// The layer, 0 = finest.
    pub layer: u8,
    /// The cell's world index along x in that layer: `floor(x / r_k)`.
    pub cell_x: i32,
    /// The cell's world index along y in that layer: `floor(y / r_k)`.
    pub cell_y: i32,
    /// What the observation says about the cell.
    pub class: EvidenceClass,
    /// The layer's gate weight `w_k(d)` at the cell's closest distance from the sensor at the
    /// time of measurement, Q1.15 in `0 ..= 1` (the classifier looks it up in its
    /// [`crate::gate::Gates`]): the class's increment is scaled by it.
    pub weight: Weight,
}

#[cfg(feature = "defmt")]
impl defmt::Format for Evidence {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "Evidence {{ layer: {=u8}, cell: ({=i32}, {=i32}), class: {}, weight: {=u16} raw Q1.15 }}",
            self.layer,
            self.cell_x,
            self.cell_y,
            self.class,
            self.weight.to_bits()
        );
    }
}

/// The fused answer for a place.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fused {
    /// No layer has a confident answer.
    Unknown,
    /// Not navigable, according to this layer (the finest that answered, or one of the
    /// [`fused_reach`] layers after it whose obstacle evidence outweighed the finer layer's
    /// free evidence).
    Obstacle {
        /// The layer that answered.
        layer: u8,
    },
    /// Navigable, according to this layer (the finest that answered).
    Navigable {
        /// The layer that answered.
        layer: u8,
    },
}

/// The fused rule over one point's cell in every layer, the finest first (`None` where a
/// layer does not hold the point): the first observed cell with L > 0 answers obstacle, with
/// L < −`margin_raw` (Q8.8 raw log-odds) navigable unless one of the next
/// [`fused_reach`]`(k)` layers' cells (k the navigable layer) holds L greater than the −L of
/// this layer and of every observed layer between them (then the first such layer answers
/// obstacle); unknown when none does.
/// [`Pyramid::fused`] asks it of a pyramid, the host of the maps a device sends.
// Out of line: inlined into the boot's self-check it grew that frame by 560 B of stack
// (`boards/check.sh`, qemu-mps2).
#[inline(never)]
pub fn fused_answer(margin_raw: i16, cells: impl IntoIterator<Item = Option<Cell>>) -> Fused {
    // A navigable answer waiting on the next layers: its layer, its free evidence (−L, raw)
    // and how many layers may still overrule it.
    let mut pending: Option<(u8, i32, usize)> = None;
    for (k, cell) in cells.into_iter().enumerate() {
        let layer = u8::try_from(k).unwrap_or(u8::MAX);
        let value = cell
            .and_then(Cell::log_odds)
            .map(|v| i32::from(v.to_bits()));
        if let Some((finer, free, left)) = pending {
            // A coarser layer's obstacle evidence, stronger than the free evidence of every
            // layer from the answering one to it.
            let v = value.unwrap_or(0);
            if v > free {
                return Fused::Obstacle { layer };
            }
            if left <= 1 {
                return Fused::Navigable { layer: finer };
            }
            pending = Some((finer, free.max(-v), left - 1));
            continue;
        }
        let Some(raw) = value else {
            continue;
        };
        if raw > 0 {
            return Fused::Obstacle { layer };
        }
        if raw < -i32::from(margin_raw) {
            pending = Some((layer, -raw, fused_reach(k)));
        }
    }
    match pending {
        Some((finer, _, _)) => Fused::Navigable { layer: finer },
        None => Fused::Unknown,
    }
}

/// How many coarser layers may at least overrule a layer's navigable answer with stronger
/// obstacle evidence at the same point (3: layers k + 1 ..= k + 3; `docs/core.md`, "The fused
/// query", gives the measured choice).
pub const FUSED_REACH: usize = 3;

/// How many coarser layers may overrule layer `k`'s navigable answer: [`FUSED_REACH`], or
/// k where that is more. Under the schedule's `r_k = k·γ·Δd` the layers k + 1 ..= 2k are
/// those whose cells are at most twice as wide as layer k's: the design sizes layer k's cell
/// to the bound δ(d), which holds a tilting laser's line spacing `φ·(d² + h²)/h`, so at its
/// band's end a cell of layer k holds one line a sweep and a cell twice as wide two, what
/// tells a step from a ramp (`docs/core.md`, "The fused query"). Only designs of more than 8
/// layers reach further than three (layer 4 and up, to a layer beyond 7).
#[must_use]
pub const fn fused_reach(k: usize) -> usize {
    if k > FUSED_REACH {
        k
    } else {
        FUSED_REACH
    }
}

/// The fused query's default margin for "navigable", nats (0.055, 14/256 in Q8.8): the free
/// evidence of one return that the soft gate feeds to a layer two gate widths from its centre,
/// `e^{−2}·|l_free|` with the default model's `l_free = ln(0.4/0.6)`. A layer whose free
/// evidence at a place is weaker (its gate's far tail) leaves the answer to the coarser
/// layers, where a small obstacle may already be marked (`docs/core.md`, "The fused query").
pub const DEFAULT_FUSED_MARGIN: f32 = 0.055;

/// What the pyramid does with evidence, beyond the design.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The inverse sensor model. Default 0.7 / 0.4 / prior 0.5.
    pub model: InverseSensorModel,
    /// Clamping of stored log-odds. Default: OctoMap's −2 ..= 3.5 nats.
    pub clamp: Clamp,
    /// The fused query's confidence margin for "navigable", nats, finite and ≥ 0: a layer
    /// answers navigable only below −margin. Default [`DEFAULT_FUSED_MARGIN`].
    pub fused_margin: f32,
    /// Decay of stale evidence toward unknown ([`crate::decay`]). Default: off, the paper's
    /// behaviour.
    pub decay: Decay,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            model: InverseSensorModel::default(),
            clamp: Clamp::default(),
            fused_margin: DEFAULT_FUSED_MARGIN,
            decay: Decay::OFF,
        }
    }
}

/// Counters of what integration did. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PyramidStats {
    /// Records that changed a cell.
    pub applied: u32,
    /// Records whose gated increment rounded to zero for their layer (not an error).
    pub gated_out: u32,
    /// Records outside their layer's window.
    pub outside_window: u32,
    /// Records naming a layer the design does not have.
    pub bad_layer: u32,
    /// Cells reset to unknown by window moves.
    pub cells_reset: u32,
    /// Storage rows that took a decay step (a row is W cells).
    pub rows_decayed: u32,
    /// Cells that became unknown by decay.
    pub cells_faded: u32,
}

/// What became of one evidence record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Applied {
    /// The cell took the gated increment.
    Updated,
    /// The gated increment was zero: nothing changed.
    GatedOut,
    /// The cell lies outside its layer's window.
    OutsideWindow,
    /// The layer index is beyond the design's layers.
    BadLayer,
}

/// Why a region export was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RegionError {
    /// The output buffer holds fewer than `width · height` cells.
    BufferTooSmall {
        /// Cells needed.
        needed: usize,
        /// Cells in the buffer.
        got: usize,
    },
    /// The step is zero or negative.
    BadStep,
}

impl core::fmt::Display for RegionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BufferTooSmall { needed, got } => {
                write!(f, "region needs {needed} cells, the buffer holds {got}")
            }
            Self::BadStep => f.write_str("region step must be positive"),
        }
    }
}

/// The terrain pyramid: up to `L` robot-centric layers of `W × W` cells.
#[derive(Clone)]
pub struct Pyramid<const W: usize, const L: usize> {
    layers: [Layer<W>; L],
    state: State,
    sweep: Sweep<L>,
}

/// Everything of a pyramid but its layers and gates; its size is the same on every target.
#[derive(Debug, Clone, Copy)]
struct State {
    /// Active layers, ≤ L ≤ 255; 0 until configured.
    active: u8,
    increments: Increments,
    clamp: Clamp,
    /// Raw Q8.8, ≥ 0.
    margin: i16,
    stats: PyramidStats,
}

impl<const W: usize, const L: usize> core::fmt::Debug for Pyramid<W, L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Pyramid")
            .field("cells_per_side", &W)
            .field("layers", &self.state.active)
            .field("stats", &self.state.stats)
            .finish()
    }
}

/// Access to one layer's dirty tiles only: the link takes and re-marks them; cells stay
/// read-only outside [`Pyramid::apply`].
#[derive(Debug)]
pub struct DirtyTiles<'a, const W: usize>(&'a mut Layer<W>);

impl<const W: usize> DirtyTiles<'_, W> {
    /// Returns the changed tiles and clears them (see [`Layer::take_dirty`]).
    pub fn take(&mut self) -> u64 {
        self.0.take_dirty()
    }

    /// Marks tiles as changed again (see [`Layer::mark_dirty`]).
    pub fn mark(&mut self, tiles: u64) {
        self.0.mark_dirty(tiles);
    }
}

/// The static RAM of a `Pyramid<W, L>`, bytes: what the firmware reserves for it.
#[must_use]
pub const fn static_ram_bytes<const W: usize, const L: usize>() -> usize {
    core::mem::size_of::<Pyramid<W, L>>()
}

/// The static RAM of a pyramid of `layers` layers of `cells_per_side` (even) cells per side,
/// bytes: `layers · (2·W² + 24) + 32`, plus the decay sweep's `6 + 7 · layers` rounded up to a
/// multiple of 4, all rounded up to a multiple of 8. Equal to [`static_ram_bytes`] for the
/// same shape (a unit test holds them together), for designs chosen at run time.
#[must_use]
pub const fn ram_bytes(cells_per_side: usize, layers: usize) -> usize {
    let raw = layers * crate::grid::layer_bytes(cells_per_side)
        + core::mem::size_of::<State>()
        + crate::decay::sweep_bytes(layers);
    // The pyramid is aligned like its layers' dirty-tile word (a u64).
    let align = core::mem::align_of::<u64>();
    raw.div_ceil(align) * align
}

impl<const W: usize, const L: usize> Pyramid<W, L> {
    /// An unconfigured pyramid (no layers; every query answers unknown). `const` and all zero
    /// bits, so that firmware can place it in a `static` (in `.bss`: it costs no flash) and
    /// [`configure`](Self::configure) it in place. Build it in a `static` (e.g. a
    /// `ConstStaticCell`), not on the stack: a `DefaultPyramid` is 72 KiB.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            layers: [const { Layer::new() }; L],
            state: State {
                active: 0,
                // Unconfigured: nothing but zero bits, so that a `static` pyramid lands in
                // `.bss` and costs no flash. `configure` sets every field before use.
                increments: Increments {
                    obstacle: LogOddsFixed::ZERO,
                    free: LogOddsFixed::ZERO,
                    initial: LogOddsFixed::ZERO,
                },
                clamp: Clamp::Off,
                margin: 0,
                stats: PyramidStats {
                    applied: 0,
                    gated_out: 0,
                    outside_window: 0,
                    bad_layer: 0,
                    cells_reset: 0,
                    rows_decayed: 0,
                    cells_faded: 0,
                },
            },
            sweep: Sweep::OFF,
        }
    }

    /// Adopts a design and a configuration: the layers' cell sizes and the increments; every
    /// layer is reset to unknown, centred on the world origin. (The gate tables of the same
    /// design belong to the classifier: [`crate::gate::Gates::configure`].)
    ///
    /// On error nothing changes: the maps and the configuration in force stay as they were.
    ///
    /// # Errors
    /// The design's window differs from `W`; a probability, a clamping bound or the margin is
    /// invalid; a resolution cannot be represented.
    pub fn configure(&mut self, design: &Design<L>, config: &Config) -> Result<(), DesignError> {
        if design.cells_per_side() != W {
            #[allow(clippy::cast_precision_loss)]
            return Err(DesignError::OutOfRange {
                param: Param::Cells,
                value: design.cells_per_side() as f32,
                min: W as f32,
                max: W as f32,
            });
        }
        let increments = config.model.increments()?;
        if !config.fused_margin.is_finite() {
            return Err(DesignError::NotFinite {
                param: Param::ClampMax,
            });
        }
        let margin = crate::logodds::round_to_log_odds(config.fused_margin).to_bits();
        if margin < 0 {
            return Err(DesignError::OutOfRange {
                param: Param::ClampMax,
                value: config.fused_margin,
                min: 0.0,
                max: 127.0,
            });
        }
        let mut resolutions = [None; L];
        for (slot, layer) in resolutions.iter_mut().zip(design.layers()) {
            *slot = Some(Resolution::from_m(layer.resolution_m).ok_or(
                DesignError::OutOfRange {
                    param: Param::Base,
                    value: layer.resolution_m,
                    min: crate::design::MIN_RESOLUTION_M,
                    max: 32_000.0,
                },
            )?);
        }
        let active = design.layers().len().min(L).min(usize::from(u8::MAX));
        config.decay.validate(W, active)?;
        for (k, (layer, resolution)) in self.layers.iter_mut().zip(resolutions).enumerate() {
            match resolution {
                Some(r) if k < active => layer.reset(r),
                _ => layer.reset(Resolution::UNSET),
            }
        }
        self.state = State {
            active: u8::try_from(active).unwrap_or(u8::MAX),
            increments,
            clamp: config.clamp,
            margin,
            stats: PyramidStats::default(),
        };
        self.sweep = Sweep::new(&config.decay, active);
        debug!("pyramid configured: {} layers", active);
        Ok(())
    }

    /// Forgets every observation: all layers unknown, windows kept where they are.
    pub fn clear(&mut self) {
        let active = self.layer_count();
        for layer in self.layers.iter_mut().take(active) {
            let (x, y) = layer.origin();
            let r = layer.resolution();
            layer.reset(r);
            layer.move_origin(x, y);
        }
    }

    /// The number of layers in force (0 before [`configure`](Self::configure)).
    #[must_use]
    pub const fn layer_count(&self) -> usize {
        self.state.active as usize
    }

    /// Layer `k`, finest first, or `None` beyond the layers in force.
    #[must_use]
    pub fn layer(&self, k: usize) -> Option<&Layer<W>> {
        self.layers.get(..self.layer_count())?.get(k)
    }

    /// Layer `k` for changes that keep its cells (taking or marking dirty tiles), or `None`
    /// beyond the layers in force.
    pub fn layer_dirty_mut(&mut self, k: usize) -> Option<DirtyTiles<'_, W>> {
        let active = self.layer_count();
        self.layers.get_mut(..active)?.get_mut(k).map(DirtyTiles)
    }

    /// The increments in force.
    #[must_use]
    pub const fn increments(&self) -> Increments {
        self.state.increments
    }

    /// The counters since the last [`configure`](Self::configure).
    #[must_use]
    pub const fn stats(&self) -> PyramidStats {
        self.state.stats
    }

    /// Applies one record: the gated increment `round(l_class · w)` to its cell, carrying it
    /// under clamping no further than the bound scaled by `w` ([`Clamp::gated`]).
    #[inline]
    pub fn apply(&mut self, record: &Evidence) -> Applied {
        let k = usize::from(record.layer);
        let active = self.layer_count();
        let state = &mut self.state;
        let Some(layer) = self.layers.get_mut(..active).and_then(|l| l.get_mut(k)) else {
            state.stats.bad_layer = state.stats.bad_layer.saturating_add(1);
            return Applied::BadLayer;
        };
        let l = match record.class {
            EvidenceClass::Obstacle => state.increments.obstacle,
            EvidenceClass::Navigable => state.increments.free,
        };
        let increment = state.clamp.gated(l, record.weight);
        if increment.g == 0 {
            state.stats.gated_out = state.stats.gated_out.saturating_add(1);
            return Applied::GatedOut;
        }
        if layer.update_by(
            record.cell_x,
            record.cell_y,
            increment,
            state.increments.initial,
            state.clamp,
        ) {
            state.stats.applied = state.stats.applied.saturating_add(1);
            Applied::Updated
        } else {
            state.stats.outside_window = state.stats.outside_window.saturating_add(1);
            Applied::OutsideWindow
        }
    }

    /// Applies every record of one observation, in order.
    pub fn integrate(&mut self, records: &[Evidence]) {
        for record in records {
            self.apply(record);
        }
    }

    /// Moves every layer's window so that the robot at `(x, y)` sits in its centre cell.
    /// Returns the number of cells reset to unknown.
    pub fn recentre(&mut self, x: Meters, y: Meters) -> usize {
        let mut reset = 0_usize;
        let active = self.layer_count();
        for layer in self.layers.iter_mut().take(active) {
            reset = reset.saturating_add(layer.recentre(x, y));
        }
        let counted = u32::try_from(reset).unwrap_or(u32::MAX);
        self.state.stats.cells_reset = self.state.stats.cells_reset.saturating_add(counted);
        reset
    }

    /// The fused answer at world point `(x, y)` ([`fused_answer`] over each layer's cell at
    /// it, with the configured margin): the finest layer whose cell is observed with L > 0
    /// (obstacle) or L < −margin (navigable); unknown when none. A navigable answer of layer k
    /// gives way to layer k + 1 when that layer's cell holds more obstacle evidence than layer
    /// k's holds free evidence (`L_{k+1} > −L_k`): then layer k + 1 answers obstacle
    /// (`docs/core.md`, "The fused query").
    #[must_use]
    pub fn fused(&self, x: Meters, y: Meters) -> Fused {
        fused_answer(
            self.state.margin,
            self.layers.iter().take(self.layer_count()).map(|layer| {
                let r = layer.resolution();
                layer.get(r.cell_of(x), r.cell_of(y))
            }),
        )
    }

    /// Samples the fused query over a grid of `width × height` cells of size `step` whose
    /// lower-left corner is `(x0, y0)`, at the cell centres, row `j = 0` (lowest y) first,
    /// into `out`.
    ///
    /// # Errors
    /// A non-positive step, or `out` shorter than `width · height`.
    pub fn fused_region(
        &self,
        x0: Meters,
        y0: Meters,
        step: Meters,
        width: usize,
        height: usize,
        out: &mut [Fused],
    ) -> Result<(), RegionError> {
        if step <= Meters::ZERO {
            return Err(RegionError::BadStep);
        }
        let needed = width.saturating_mul(height);
        let got = out.len();
        let Some(out) = out.get_mut(..needed) else {
            return Err(RegionError::BufferTooSmall { needed, got });
        };
        let half = step / 2;
        let mut y = y0.saturating_add(half);
        for row in out.chunks_mut(width.max(1)) {
            let mut x = x0.saturating_add(half);
            for cell in row {
                *cell = self.fused(x, y);
                x = x.saturating_add(step);
            }
            y = y.saturating_add(step);
        }
        Ok(())
    }

    /// Counts of observed, obstacle and free cells of layer `k`.
    #[must_use]
    pub fn counts(&self, k: usize) -> Option<LayerCounts> {
        self.layer(k).map(Layer::counts)
    }

    // ------------------------------------------------------------ decay

    /// The decay mode in force ([`DecayMode::Off`] unless configured).
    #[must_use]
    pub const fn decay_mode(&self) -> DecayMode {
        self.sweep.mode
    }

    /// Layer `k`'s decay time constant in force ([`TimeConstant::NONE`]: it does not decay).
    #[must_use]
    pub fn time_constant(&self, k: usize) -> TimeConstant {
        if k < self.layer_count() {
            self.sweep.tau(k)
        } else {
            TimeConstant::NONE
        }
    }

    /// Accrues the decay owed since the last call, by the caller's clock (`now_ms`, ms,
    /// wrapping; the first call only starts the clock). Nothing is decayed until
    /// [`decay_layer`](Self::decay_layer) (or [`decay`](Self::decay)) pays it.
    pub fn accrue_decay(&mut self, now_ms: u32) {
        self.sweep.accrue(now_ms, W);
    }

    /// The storage rows layer `k` owes now (0 ..= W): what [`decay_layer`](Self::decay_layer)
    /// would decay.
    #[must_use]
    pub fn decay_due(&self, k: usize) -> usize {
        if k < self.layer_count() {
            self.sweep.due(k, W)
        } else {
            0
        }
    }

    /// Pays layer `k`'s decay: one step for every cell of the rows owed, from the sweep's
    /// cursor on. Returns the rows and the cells that became unknown; `None` when nothing is
    /// owed. Tiles are not marked dirty (see [`Layer::decay_rows`]).
    pub fn decay_layer(&mut self, k: usize) -> Option<DecayRows> {
        let mode = self.sweep.mode;
        let active = self.layer_count();
        let layer = self.layers.get_mut(..active)?.get_mut(k)?;
        let (first, rows) = self.sweep.take(k, W)?;
        let faded = layer.decay_rows(first, rows, mode);
        let stats = &mut self.state.stats;
        let rows32 = u32::try_from(rows).unwrap_or(u32::MAX);
        stats.rows_decayed = stats.rows_decayed.saturating_add(rows32);
        stats.cells_faded = stats.cells_faded.saturating_add(faded);
        Some(DecayRows {
            first: u16::try_from(first).unwrap_or(u16::MAX),
            rows: u16::try_from(rows).unwrap_or(u16::MAX),
            faded,
        })
    }

    /// Accrues and pays every layer's decay at `now_ms`, for a pyramid without a host link
    /// (the link pays it itself and tells the host, `crate::link::Link::poll`). Returns the
    /// cells that became unknown.
    pub fn decay(&mut self, now_ms: u32) -> u32 {
        self.accrue_decay(now_ms);
        let mut faded = 0_u32;
        for k in 0..self.layer_count() {
            if let Some(rows) = self.decay_layer(k) {
                faded = faded.saturating_add(rows.faded);
            }
        }
        faded
    }
}

impl<const W: usize, const L: usize> Default for Pyramid<W, L> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{GateShape, Schedule, SensorModel};
    use crate::gate::Gates;
    use crate::logodds::CellClass;
    extern crate std;

    type P = Pyramid<64, 8>;

    // The gating of the last pyramid built by `pyramid` (tests run on their own threads).
    std::thread_local! {
        static GATES: core::cell::RefCell<Gates<8>> =
            const { core::cell::RefCell::new(Gates::new()) };
    }

    fn pyramid(gate: GateShape, clamp: Clamp) -> P {
        let schedule = Schedule {
            gate,
            ..Schedule::default()
        };
        let design = Design::<8>::new(SensorModel::default(), schedule, 64).unwrap();
        let config = Config {
            clamp,
            ..Config::default()
        };
        let mut p = P::new();
        p.configure(&design, &config).unwrap();
        GATES.with(|g| {
            g.borrow_mut()
                .configure(&design, config.model.increments().unwrap())
                .unwrap();
        });
        p
    }

    /// A record of layer `layer` seen at distance `d`, weighted by that layer's gate.
    fn record(layer: u8, x: i32, y: i32, class: EvidenceClass, d: f32) -> Evidence {
        let weight = GATES.with(|g| {
            g.borrow()
                .weight_at(usize::from(layer), Meters::from_num(d))
        });
        Evidence {
            layer,
            cell_x: x,
            cell_y: y,
            class,
            weight,
        }
    }

    #[test]
    fn unconfigured_pyramid_knows_nothing() {
        let mut p = P::new();
        assert_eq!(p.layer_count(), 0);
        assert_eq!(p.fused(Meters::ZERO, Meters::ZERO), Fused::Unknown);
        assert_eq!(
            p.apply(&record(0, 0, 0, EvidenceClass::Obstacle, 0.2)),
            Applied::BadLayer
        );
    }

    #[test]
    fn hard_gate_feeds_only_the_layer_of_the_band() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        // 0.2 m lies in layer 0's band [0, 0.53): layer 1 refuses it.
        assert_eq!(
            p.apply(&record(0, 1, 1, EvidenceClass::Obstacle, 0.2)),
            Applied::Updated
        );
        assert_eq!(
            p.apply(&record(1, 1, 1, EvidenceClass::Obstacle, 0.2)),
            Applied::GatedOut
        );
        assert_eq!(p.layer(0).unwrap().get(1, 1).unwrap().to_raw(), 217);
        assert!(!p.layer(1).unwrap().get(1, 1).unwrap().is_observed());
        assert_eq!(
            p.apply(&record(0, 40, 0, EvidenceClass::Obstacle, 0.2)),
            Applied::OutsideWindow
        );
        assert_eq!(p.stats().applied, 1);
        assert_eq!(p.stats().gated_out, 1);
        assert_eq!(p.stats().outside_window, 1);
    }

    #[test]
    fn far_free_evidence_cannot_mask_a_close_obstacle_in_the_pyramid() {
        // The paper's failure (eq. 7): n far "free" readings bury m close "obstacle" readings
        // in a flat grid; in the pyramid they land in different layers.
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        let far = 4.0; // a band of a coarse layer
        let k_far = (0..p.layer_count())
            .find(|&k| {
                GATES.with(|g| g.borrow().weight_at(k, Meters::from_num(far))) > Weight::ZERO
            })
            .unwrap();
        assert!(k_far > 0);
        for _ in 0..300 {
            p.apply(&record(k_far as u8, 0, 0, EvidenceClass::Navigable, far));
        }
        for _ in 0..5 {
            p.apply(&record(0, 0, 0, EvidenceClass::Obstacle, 0.3));
        }
        assert_eq!(
            p.fused(Meters::from_num(0.05), Meters::from_num(0.05)),
            Fused::Obstacle { layer: 0 }
        );
        // A flat grid is one layer fed by both: 300 × −104 + 5 × 217 stays deeply negative.
        let flat: i32 = 300 * -104 + 5 * 217;
        assert!(flat < 0);
    }

    #[test]
    fn fused_prefers_the_finest_confident_layer() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        let (x, y) = (Meters::from_num(0.05), Meters::from_num(0.05));
        assert_eq!(p.fused(x, y), Fused::Unknown);
        // Layer 1 (0.2 m cells, band ~[0.53, 1.4)) says free.
        p.apply(&record(1, 0, 0, EvidenceClass::Navigable, 1.0));
        assert_eq!(p.fused(x, y), Fused::Navigable { layer: 1 });
        // Layer 0 says obstacle: it wins.
        p.apply(&record(0, 0, 0, EvidenceClass::Obstacle, 0.3));
        assert_eq!(p.fused(x, y), Fused::Obstacle { layer: 0 });
    }

    #[test]
    fn the_next_layers_stronger_obstacle_evidence_answers() {
        let c = |raw: i16| Some(Cell::from_raw(raw));
        // Free −104 (one look) under the next layer's +217: the next layer answers.
        assert_eq!(
            fused_answer(14, [c(-104), c(217)]),
            Fused::Obstacle { layer: 1 }
        );
        // Free −312 outweighs +217; equal evidence keeps the finer answer.
        assert_eq!(
            fused_answer(14, [c(-312), c(217)]),
            Fused::Navigable { layer: 0 }
        );
        assert_eq!(
            fused_answer(14, [c(-217), c(217)]),
            Fused::Navigable { layer: 0 }
        );
        // The next three layers, observed or not: an unknown or absent layer 1 lets layer
        // 2 or 3 answer; layer 4 is too far.
        assert_eq!(
            fused_answer(14, [c(-104), c(i16::MIN), c(900)]),
            Fused::Obstacle { layer: 2 }
        );
        assert_eq!(
            fused_answer(14, [c(-104), None, c(-50), c(900)]),
            Fused::Obstacle { layer: 3 }
        );
        assert_eq!(
            fused_answer(14, [c(-104), None, None, c(50), c(900)]),
            Fused::Navigable { layer: 0 }
        );
        // The first stronger one answers, a weaker one before it does not.
        assert_eq!(
            fused_answer(14, [c(-104), c(50), c(217), c(900)]),
            Fused::Obstacle { layer: 2 }
        );
        // Stronger free evidence of a layer between raises the bar: +217 does not outweigh
        // layer 1's −300, +900 does.
        assert_eq!(
            fused_answer(14, [c(-104), c(-300), c(217)]),
            Fused::Navigable { layer: 0 }
        );
        assert_eq!(
            fused_answer(14, [c(-104), c(-300), c(217), c(900)]),
            Fused::Obstacle { layer: 3 }
        );
        // Fewer layers than the reach: the finer answer stands.
        assert_eq!(
            fused_answer(14, [c(-104), c(50)]),
            Fused::Navigable { layer: 0 }
        );
        // Within the margin layer 0 does not answer; layer 1's obstacle does.
        assert_eq!(
            fused_answer(14, [c(-10), c(217)]),
            Fused::Obstacle { layer: 1 }
        );
    }

    #[test]
    fn a_far_layer_reaches_every_layer_of_cells_at_most_twice_as_wide() {
        let c = |raw: i16| Some(Cell::from_raw(raw));
        let reach: [usize; 12] = core::array::from_fn(fused_reach);
        assert_eq!(reach, [3, 3, 3, 3, 4, 5, 6, 7, 8, 9, 10, 11]);
        // Layer `free` navigable at −33 raw, layer `at` obstacle at +92, nothing else.
        let answer = |free: usize, at: usize| {
            let mut cells = [None; 24];
            for (k, raw) in [(free, -33), (at, 92)] {
                if let (Some(cell), Some(v)) = (cells.get_mut(k), c(raw)) {
                    *cell = Some(v);
                }
            }
            fused_answer(14, cells)
        };
        // Layer 7 (cells 7·γ·Δd): layer 14 (twice as wide) may overrule it, layer 15 (15/7
        // ≈ 2.14 times) may not.
        assert_eq!(answer(7, 14), Fused::Obstacle { layer: 14 });
        assert_eq!(answer(7, 15), Fused::Navigable { layer: 7 });
        // Layer 11 reaches layer 22, not 23.
        assert_eq!(answer(11, 22), Fused::Obstacle { layer: 22 });
        assert_eq!(answer(11, 23), Fused::Navigable { layer: 11 });
        // Layer 2 (cells 2·γ·Δd) keeps the reach of three: layer 5 may, layer 6 may not.
        assert_eq!(answer(2, 5), Fused::Obstacle { layer: 5 });
        assert_eq!(answer(2, 6), Fused::Navigable { layer: 2 });
    }

    #[test]
    fn weaker_free_evidence_gives_way_to_the_next_layers_obstacle() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        let (x, y) = (Meters::from_num(0.05), Meters::from_num(0.05));
        // In its own band a layer's record has weight 1: free −104, obstacle +217 raw.
        let in_band = |k: usize| {
            (1..200)
                .map(|i| i as f32 * 0.05)
                .find(|&d| {
                    GATES.with(|g| g.borrow().weight_at(k, Meters::from_num(d))) == Weight::ONE
                })
                .unwrap()
        };
        let (d0, d1, d4) = (in_band(0), in_band(1), in_band(4));
        p.apply(&record(0, 0, 0, EvidenceClass::Navigable, d0));
        // A coarser layer four steps away, beyond the reach, does not answer for layer 0.
        p.apply(&record(4, 0, 0, EvidenceClass::Obstacle, d4));
        assert_eq!(p.fused(x, y), Fused::Navigable { layer: 0 });
        // The next layer's +217 outweighs layer 0's −104: it answers.
        p.apply(&record(1, 0, 0, EvidenceClass::Obstacle, d1));
        assert_eq!(p.fused(x, y), Fused::Obstacle { layer: 1 });
        // Two more free looks (−312) outweigh it again.
        p.apply(&record(0, 0, 0, EvidenceClass::Navigable, d0));
        p.apply(&record(0, 0, 0, EvidenceClass::Navigable, d0));
        assert_eq!(p.fused(x, y), Fused::Navigable { layer: 0 });
        // A second obstacle look (+434 against −312) outweighs them once more.
        p.apply(&record(1, 0, 0, EvidenceClass::Obstacle, d1));
        assert_eq!(p.fused(x, y), Fused::Obstacle { layer: 1 });
    }

    #[test]
    fn an_observed_zero_defers_to_coarser_layers() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        p.layers[0].update(0, 0, 1, LogOddsFixed::ZERO, Clamp::Off);
        p.layers[0].update(0, 0, -1, LogOddsFixed::ZERO, Clamp::Off);
        assert_eq!(
            p.layer(0).unwrap().get(0, 0).unwrap().class(),
            CellClass::Undecided
        );
        p.apply(&record(1, 0, 0, EvidenceClass::Navigable, 1.0));
        assert_eq!(
            p.fused(Meters::from_num(0.05), Meters::from_num(0.05)),
            Fused::Navigable { layer: 1 }
        );
    }

    #[test]
    fn soft_gate_spreads_an_observation_over_neighbouring_layers() {
        let mut p = pyramid(GateShape::default(), Clamp::Off);
        let d = 1.4; // the edge between layers 1 and 2
        let touched = (0..p.layer_count())
            .filter(|&k| {
                p.apply(&record(k as u8, 0, 0, EvidenceClass::Obstacle, d)) == Applied::Updated
            })
            .count();
        assert!(touched >= 2, "{touched}");
    }

    #[test]
    fn recentre_moves_every_layer_and_counts_resets() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        p.apply(&record(0, -32, -32, EvidenceClass::Obstacle, 0.1));
        let reset = p.recentre(Meters::from_num(0.1), Meters::ZERO);
        // Layer 0 moves one column (64 cells); coarser layers stay put.
        assert_eq!(reset, 64);
        assert_eq!(p.layer(0).unwrap().origin(), (-31, -32));
        assert_eq!(p.stats().cells_reset, 64);
        assert_eq!(p.counts(0).unwrap().observed, 0);
    }

    #[test]
    fn region_export_checks_its_buffer() {
        let p = pyramid(GateShape::Hard, Clamp::Off);
        let mut out = [Fused::Unknown; 4];
        assert_eq!(
            p.fused_region(Meters::ZERO, Meters::ZERO, Meters::ONE, 3, 2, &mut out),
            Err(RegionError::BufferTooSmall { needed: 6, got: 4 })
        );
        assert_eq!(
            p.fused_region(Meters::ZERO, Meters::ZERO, Meters::ZERO, 2, 2, &mut out),
            Err(RegionError::BadStep)
        );
        assert_eq!(
            p.fused_region(Meters::ZERO, Meters::ZERO, Meters::ONE, 2, 2, &mut out),
            Ok(())
        );
    }

    #[test]
    fn a_refused_configuration_changes_nothing() {
        let mut p = pyramid(GateShape::Hard, Clamp::Off);
        p.apply(&record(0, 0, 0, EvidenceClass::Obstacle, 0.1));
        let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let bad = Config {
            model: InverseSensorModel {
                p_free: 0.9,
                ..InverseSensorModel::default()
            },
            ..Config::default()
        };
        assert!(p.configure(&design, &bad).is_err());
        assert_eq!(p.layer(0).unwrap().get(0, 0).unwrap().to_raw(), 217);
    }

    fn decaying(mode: DecayMode, tau_s: f32) -> P {
        let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let tau = TimeConstant::from_seconds(tau_s).unwrap();
        let config = Config {
            decay: Decay::uniform(mode, tau, 8),
            ..Config::default()
        };
        let mut p = P::new();
        p.configure(&design, &config).unwrap();
        p
    }

    #[test]
    fn decay_fades_evidence_to_unknown_without_dirtying_tiles() {
        let mut p = decaying(DecayMode::All, 1.0);
        let obstacle = Evidence {
            layer: 0,
            cell_x: 3,
            cell_y: 0,
            class: EvidenceClass::Obstacle,
            weight: Weight::ONE,
        };
        for _ in 0..10 {
            p.apply(&obstacle);
        }
        let free = Evidence {
            cell_x: 5,
            class: EvidenceClass::Navigable,
            ..obstacle
        };
        for _ in 0..10 {
            p.apply(&free);
        }
        assert_eq!(p.layer(0).unwrap().get(3, 0).unwrap().to_raw(), 896); // clamped at 3.5
        assert_eq!(p.layer(0).unwrap().get(5, 0).unwrap().to_raw(), -512);
        p.layer_dirty_mut(0).unwrap().take();
        assert_eq!(p.decay(0), 0, "the first call starts the clock");
        // One step period (125 ms): every row of every layer, one step.
        assert_eq!(p.decay(125), 0);
        assert_eq!(p.layer(0).unwrap().get(3, 0).unwrap().to_raw(), 791);
        assert_eq!(p.layer(0).unwrap().get(5, 0).unwrap().to_raw(), -452);
        assert_eq!(p.layer(0).unwrap().dirty(), 0);
        assert_eq!(p.stats().rows_decayed, 8 * 64);
        // 47 more steps fade 3.5 nats (the exponential, then one raw unit a step).
        let mut t = 125;
        let mut faded = 0;
        while p.layer(0).unwrap().get(3, 0).unwrap().is_observed() {
            t += 125;
            faded += p.decay(t);
            assert!(t < 125 * 60, "never faded");
        }
        assert_eq!(faded, 2);
        assert_eq!(p.stats().cells_faded, 2);
        assert_eq!(
            p.fused(Meters::from_num(0.35), Meters::from_num(0.05)),
            Fused::Unknown
        );
    }

    #[test]
    fn decay_modes_and_fresh_evidence() {
        let mut p = decaying(DecayMode::Obstacle, 1.0);
        let at = |x| Evidence {
            layer: 0,
            cell_x: x,
            cell_y: 0,
            class: EvidenceClass::Obstacle,
            weight: Weight::ONE,
        };
        for _ in 0..10 {
            p.apply(&at(3));
            p.apply(&Evidence {
                class: EvidenceClass::Navigable,
                ..at(5)
            });
        }
        p.decay(0);
        for step in 1..=16 {
            p.decay(125 * step);
        }
        // Two time constants: 3.5 nats to about 3.5·e⁻² = 0.47 nats; free ground untouched.
        let obstacle = p.layer(0).unwrap().get(3, 0).unwrap().to_raw();
        assert!((110..=130).contains(&obstacle), "{obstacle}");
        assert_eq!(p.layer(0).unwrap().get(5, 0).unwrap().to_raw(), -512);
        // Fresh free evidence now outweighs the aged obstacle at once (without decay it would
        // take 9 observations to cross 0).
        p.apply(&Evidence {
            class: EvidenceClass::Navigable,
            ..at(3)
        });
        p.apply(&Evidence {
            class: EvidenceClass::Navigable,
            ..at(3)
        });
        assert_eq!(
            p.layer(0).unwrap().get(3, 0).unwrap().class(),
            CellClass::Navigable
        );
        // A refused decay (a time constant for a ninth layer) changes nothing.
        let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let mut bad = Decay::uniform(DecayMode::All, TimeConstant::MIN, 8);
        bad.tau[8] = TimeConstant::MIN;
        let config = Config {
            decay: bad,
            ..Config::default()
        };
        assert_eq!(
            p.configure(&design, &config).map_err(|e| e.param()),
            Err(Param::DecayTau { layer: 8 })
        );
        assert_eq!(p.decay_mode(), DecayMode::Obstacle);
    }

    #[test]
    fn ram_bytes_matches_the_layout() {
        assert_eq!(ram_bytes(64, 8), static_ram_bytes::<64, 8>());
        assert_eq!(ram_bytes(8, 2), static_ram_bytes::<8, 2>());
        assert_eq!(ram_bytes(6, 3), static_ram_bytes::<6, 3>());
        assert_eq!(ram_bytes(128, 1), static_ram_bytes::<128, 1>());
        assert_eq!(ram_bytes(32, 16), static_ram_bytes::<32, 16>());
    }

    #[test]
    fn the_default_pyramid_fits_its_budget() {
        // 8 layers × 2 · 64² cells plus a few words.
        let bytes = static_ram_bytes::<64, 8>();
        assert!(bytes >= 8 * 2 * 64 * 64);
        assert!(bytes < 8 * 2 * 64 * 64 + 8 * 64 + 256, "{bytes}");
    }
}
