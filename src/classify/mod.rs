//! The navigability classifier: one observation's points → per-layer cell evidence.
//!
//! For each layer cell that the points of one observation touch (a whole sweep, or N scan
//! lines: the caller decides by when it calls [`Classifier::finish`]):
//! - the **ground** is the lowest point in the cell;
//! - points higher than ground + **robot height** are **overhang** the robot passes under,
//!   and are ignored;
//! - the remaining points are judged by the [`NavigabilityRule`] in force
//!   ([`ClassifierConfig::rule`], module [`rule`]): by default a least-squares plane per cell
//!   (not navigable when the points stray from their plane, or the plane is steeper than the
//!   robot can drive); or the paper's rule after Ferguson et al.: not navigable when the points
//!   spread over more than the **step threshold**.
//!
//! A point joins the cell of every layer whose gate gives it a non-zero increment at the
//! point's horizontal distance from the sensor, so with the hard gate each point feeds exactly
//! one layer. A record carries the smallest such distance among its points (the closest look),
//! which the pyramid gates with; the scratch keeps it as its gate bin, so the record's distance
//! is the lower edge of that bin (which the pyramid bins to the same bin again).
//!
//! A cell holding a single point looks navigable by its own points: that is the systematic
//! far-range miss the pyramid exists to fix, and it is deliberately not "fixed" here. Only a
//! pair with a return beside it (module `across`, and the step between neighbouring cells'
//! lowest returns, module `edges`) can mark it.
//!
//! # Beyond the paper (options, off by default)
//! - **Drop-offs**: a return more than [`ClassifierConfig::drop_threshold`] below the robot's
//!   ground plane marks its cell not navigable (a hole, a ditch, the top of stairs going down).
//! - **Ceilings**: with [`ClassifierConfig::ceiling`], returns higher than that above the
//!   robot's ground plane are overhang before any cell sees them, so a cell that only saw a
//!   roof stays unknown instead of looking like an uneven obstacle.
//! - **Missing ground**: a beam that points below the horizon and should have met flat ground
//!   within range, but returned nothing, marks the cell where the ground should have been
//!   ([`Classifier::add_missing_ground`]); the caller decides when a beam qualifies.
//!
//! # Bounded scratch
//! Besides its slots the classifier keeps 36 bytes for the pair test across a cell's edge
//! (module `across`). The step between neighbouring cells' lowest returns (module `edges`)
//! keeps nothing: it reads the slots at the observation's end, two lookups a cell. The step
//! from the last observation's lowest return (module `recall`) reads what a vacated slot still
//! holds of the cell it held, which it notes in 2 bytes.
//!
//! The touched cells live in an open-addressing table of `C` slots (a power of two, 72 bytes
//! each: 16 for the key, the closest look and the lowest and highest z, 52 for the plane rule's
//! sums, where the lowest and highest points lie and the pair test's last three returns and
//! largest rise, 2 for the cell a vacated slot held, 2 of padding; 16 bytes in a build without
//! the `plane-rule` feature, which has no sums). A point that finds the table full is dropped
//! and counted in [`ClassifierStats::overflow_points`]; nothing panics. One 361-beam line
//! touches at most 361 cells per layer it feeds (2 to 4 with the default soft gate); 1024 slots
//! (74 KiB with the slots' order) hold a line with room to spare, a whole 3-D sweep needs a
//! window's worth.
//!
//! # The incremental rule
//! The scratch keeps, per cell, the lowest z and the highest z not above lowest + robot height.
//! When a new lowest point lowers the cut below the stored highest, the highest is lowered to
//! the best bound still known (the previous lowest, if under the new cut, else the new point):
//! the spread can only be underestimated, never invented. The f64 reference keeps every point
//! and applies the rule exactly; `host-tests` measures the agreement.

use crate::design::{Design, DesignError};
use crate::gate::Gates;
use crate::logodds::Increments;
use crate::pyramid::{Evidence, EvidenceClass, Pyramid};
use crate::units::{Meters, Point3};

pub mod rule;

mod across;
mod beyond_eight;
mod edges;
mod recall;
use across::AcrossEdge;

use rule::{CellGeometry, PairScale, PlaneParams, PlaneState};
pub use rule::{NavigabilityRule, PlaneRule, Ratio, FIRING_ORDER_PAIR_DEPTH, MAX_PAIR_DEPTH};

mod config;
mod scratch;

pub use config::{ClassifierConfig, ClassifierStats};
use scratch::{
    cell_of, corner, fold, hash, mm_i16, Recent, Slot, EMPTY, ORIGIN_LIMIT, RECENT_LAYERS,
};

/// Scratch and counters for classifying observations with `C` cell slots (a power of two),
/// and the gating of a design of up to `L` layers.
pub struct Classifier<const C: usize, const L: usize> {
    slots: [Slot; C],
    /// Slots in use.
    used: usize,
    /// Per layer (the first [`RECENT_LAYERS`]), its reciprocal and the cell and slot of its
    /// last point.
    recent: [Recent; RECENT_LAYERS],
    /// The gate bin of the last point given by its squared distance (a first guess only).
    last_bin: u16,
    /// The previous return and the pair across a cell's edge that waits to be judged.
    across: AcrossEdge,
    /// The design's gating: which layers a point feeds, with which weight.
    gates: Gates<L>,
    config: ClassifierConfig,
    /// The observation's reference height, raw Q16.16: z values are stored relative to it.
    reference_z: i32,
    /// Robot height and step threshold in millimetres, saturated to `i16`.
    robot_height_mm: i16,
    step_mm: i16,
    /// The plane rule's parameters in its units, and whether it is in force.
    plane: Option<PlaneParams>,
    /// For layers 8 and up (entry k for layer k; the first eight entries are unused: those
    /// layers keep theirs in `recent`), the cell size (raw) of its last point, its reciprocal
    /// ([`crate::grid::cell_reciprocal`]) and the pair test's constants. Sized by the design's L, so that a small
    /// pyramid (the micro:bit's four layers) carries no entries it cannot use.
    layer_cells: [(i32, u32, PairScale); L],
    /// The robot's ground plane as of the last point (raw Q16.16).
    ground_z: i32,
    stats: ClassifierStats,
    /// The indices of the slots in use, in the order they were taken (the first `used`
    /// entries; each below C ≤ 65 536): the observation's end visits these, not all C slots.
    order: [u16; C],
    /// The last finished observation's stamp and reference height (module `recall`).
    recall_state: recall::RecallState,
    /// The last observation's heights less this one's, mm (its reference height less this
    /// one's, saturated to `i16`): set by [`Classifier::begin`].
    recall_shift: i32,
}

impl<const C: usize, const L: usize> core::fmt::Debug for Classifier<C, L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Classifier")
            .field("slots", &C)
            .field("used", &self.used)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<const C: usize, const L: usize> Classifier<C, L> {
    const MASK: usize = {
        assert!(
            C.is_power_of_two() && C <= 65_536,
            "the scratch capacity C must be a power of two, at most 65536"
        );
        C - 1
    };

    /// An empty classifier with the default configuration and no gating yet
    /// ([`adopt_design`](Self::adopt_design) gives it one). `const`, for a `static`.
    #[must_use]
    pub const fn new() -> Self {
        let mut classifier = Self::unconfigured();
        classifier.config = ClassifierConfig::DEFAULT;
        classifier.robot_height_mm = 1000;
        classifier.step_mm = 50;
        classifier.across = AcrossEdge::resting(50);
        // The default rule's parameters (computed at compile time).
        classifier.plane = rule::DEFAULT_PARAMS;
        classifier
    }

    /// A classifier whose every byte is zero, to be [`configure`](Self::configure)d before
    /// use (until then its thresholds are zero): a `static` one sits in `.bss` and costs no
    /// flash.
    #[must_use]
    pub const fn unconfigured() -> Self {
        let _ = Self::MASK;
        Self {
            slots: [Slot::VACANT; C],
            used: 0,
            order: [0; C],
            recall_state: recall::RecallState::EMPTY,
            recall_shift: 0,
            recent: [Recent::NONE; RECENT_LAYERS],
            last_bin: 0,
            across: AcrossEdge::ZERO,
            gates: Gates::new(),
            config: ClassifierConfig {
                robot_height: Meters::ZERO,
                step_threshold: Meters::ZERO,
                drop_threshold: None,
                ceiling: None,
                rule: NavigabilityRule::Spread,
            },
            reference_z: 0,
            robot_height_mm: 0,
            step_mm: 0,
            plane: None,
            layer_cells: [(0, 0, PairScale::NONE); L],
            ground_z: 0,
            stats: ClassifierStats {
                points: 0,
                points_used: 0,
                points_gated_out: 0,
                overflow_points: 0,
                overhang_points: 0,
                drop_points: 0,
                observations: 0,
                records: 0,
            },
        }
    }

    /// Adopts a configuration and forgets the current observation. Negative heights or
    /// thresholds are taken as zero. A rule this build cannot apply
    /// ([`NavigabilityRule::is_built_in`]: the plane rule without the `plane-rule` feature)
    /// becomes [`NavigabilityRule::Spread`], and [`config`](Self::config) says so; the link
    /// refuses such a configuration before it gets here.
    pub fn configure(&mut self, mut config: ClassifierConfig) {
        if !config.rule.is_built_in() {
            config.rule = NavigabilityRule::Spread;
        }
        self.config = config;
        self.robot_height_mm = mm_i16(config.robot_height.to_bits()).max(0);
        self.step_mm = mm_i16(config.step_threshold.to_bits()).max(0);
        self.plane = rule::params_of(&config.rule, config.step_threshold);
        self.refresh_layers();
        self.discard();
        self.forget_last_observation();
    }

    /// The configuration in force.
    #[must_use]
    pub const fn config(&self) -> ClassifierConfig {
        self.config
    }

    /// Adopts the gating of a design with the increments in force, and forgets the current
    /// observation. On error nothing changes.
    ///
    /// # Errors
    /// A layer's resolution cannot be represented.
    pub fn adopt_design(
        &mut self,
        design: &Design<L>,
        increments: Increments,
    ) -> Result<(), DesignError> {
        self.gates.configure(design, increments)?;
        self.refresh_layers();
        self.discard();
        self.forget_last_observation();
        Ok(())
    }

    /// Sets the first eight layers' cell reciprocals and the pair test's scales from the
    /// gating and the rule in force, and forgets those of the layers from the ninth on.
    fn refresh_layers(&mut self) {
        for k in 0..RECENT_LAYERS {
            let resolution = self.gates.resolution(k);
            let bits = resolution.map(crate::grid::Resolution::to_bits);
            let scale = self.pair_scale(bits);
            if let Some(recent) = self.recent.get_mut(k) {
                recent.reciprocal = bits.map_or(0, crate::grid::cell_reciprocal);
                recent.pair_scale = scale;
                recent.resolution = resolution.unwrap_or(crate::grid::Resolution::UNSET);
            }
        }
        // Layers from the ninth on find theirs again at their next point.
        self.layer_cells = [(0, 0, PairScale::NONE); L];
    }

    /// The pair test's constants for a layer of cell side `bits` (raw), under the rule in
    /// force.
    fn pair_scale(&self, bits: Option<i32>) -> PairScale {
        match (&self.plane, bits) {
            (Some(params), Some(bits)) => params.pair_scale(bits),
            _ => PairScale::NONE,
        }
    }

    /// The gating in force.
    #[must_use]
    pub const fn gates(&self) -> &Gates<L> {
        &self.gates
    }

    /// The counters since construction.
    #[must_use]
    pub const fn stats(&self) -> ClassifierStats {
        let mut stats = self.stats;
        // Every offered point is counted once where it goes: overhang, used or gated out (the
        // per-point path keeps no fourth counter). Saturating sums of saturating counters
        // saturate exactly when the count of offered points would.
        stats.points = stats
            .overhang_points
            .saturating_add(stats.points_used)
            .saturating_add(stats.points_gated_out);
        stats
    }

    /// Cells touched so far in the current observation.
    #[must_use]
    pub fn cells_in_use(&self) -> usize {
        self.used
    }

    /// Slots still free in the current observation (`C` less [`cells_in_use`](Self::cells_in_use)):
    /// a point takes at most one per layer it feeds.
    #[must_use]
    #[inline]
    pub const fn slots_free(&self) -> usize {
        C.saturating_sub(self.used)
    }

    /// The most slots one point can take under the gating in force: the most layers among the
    /// first eight that any gate bin may feed ([`Gates::fed_layers`], an upper bound), and
    /// every layer from the ninth on. 0 before a design is adopted.
    #[must_use]
    pub fn slots_per_point(&self) -> usize {
        let first_eight = (0..crate::gate::GATE_BINS)
            .step_by(crate::gate::FED_GROUP_BINS)
            .map(|bin| self.gates.fed_layers(bin).count_ones())
            .max()
            .unwrap_or(0);
        usize::try_from(first_eight)
            .unwrap_or(8)
            .saturating_add(self.gates.layer_count().saturating_sub(8))
    }

    /// Starts an observation whose z values are stored relative to `reference_z` (the
    /// sensor's or robot's height now; z within ±32 m of it is kept exactly, beyond saturates).
    /// Forgets any unfinished observation.
    pub fn begin(&mut self, reference_z: Meters) {
        self.discard();
        self.reference_z = reference_z.to_bits();
        self.recall_shift = i32::from(mm_i16(
            self.recall_state
                .reference_z
                .saturating_sub(self.reference_z),
        ));
    }

    /// Forgets the current observation without producing evidence.
    pub fn discard(&mut self) {
        if self.used > 0 {
            self.vacate();
        }
        self.forget_recent();
        self.across.forget(self.step_mm);
    }

    /// Vacates the slots in use (out of line: `begin` finds none after a `finish`).
    #[cold]
    #[inline(never)]
    fn vacate(&mut self) {
        for &index in self.order.iter().take(self.used) {
            if let Some(slot) = self.slots.get_mut(usize::from(index)) {
                slot.layer = EMPTY;
            }
        }
        self.used = 0;
    }

    /// Forgets the cells of the layers' last points (their slots are vacated).
    fn forget_recent(&mut self) {
        for recent in &mut self.recent {
            recent.span = 0;
        }
    }

    /// Adds one world point measured at horizontal distance `distance` from the sensor, with
    /// the robot's ground plane at `ground_z`.
    pub fn add_point(&mut self, point: Point3, distance: Meters, ground_z: Meters) {
        let bin = self.gates.distance_bins().bin(distance);
        self.add_point_in_bin(point, bin, ground_z);
    }

    /// [`add_point`](Self::add_point) with the horizontal distance given by its square
    /// (raw Q16.16 units squared, 2⁻³² m², as
    /// [`LineTransform::locate_squared`](crate::geometry::LineTransform::locate_squared)
    /// gives it): exactly the same as `add_point` with the square root rounded down, without
    /// computing the root ([`DistanceBins::bin_of_squared`](crate::gate::DistanceBins::bin_of_squared),
    /// which says how little that differs from the rounded distance of
    /// [`LineTransform::locate`](crate::geometry::LineTransform::locate)).
    #[inline]
    pub fn add_point_squared(&mut self, point: Point3, horizontal_squared: u64, ground_z: Meters) {
        // The previous point's bin first: neighbouring returns mostly share it.
        let bin = self
            .gates
            .distance_bins()
            .bin_of_squared_near(horizontal_squared, usize::from(self.last_bin));
        // bin < GATE_BINS = 512.
        #[allow(clippy::cast_possible_truncation)]
        {
            self.last_bin = bin as u16;
        }
        self.add_point_in_bin(point, bin, ground_z);
    }

    /// [`add_point`](Self::add_point) for a distance already binned.
    #[inline]
    fn add_point_in_bin(&mut self, point: Point3, bin: usize, ground_z: Meters) {
        self.ground_z = ground_z.to_bits();
        if let Some(ceiling) = self.config.ceiling {
            if point.z > ground_z.saturating_add(ceiling) {
                self.stats.overhang_points = self.stats.overhang_points.saturating_add(1);
                return;
            }
        }
        let hole = match self.config.drop_threshold {
            Some(drop) => point.z < ground_z.saturating_sub(drop),
            None => false,
        };
        if hole {
            self.stats.drop_points = self.stats.drop_points.saturating_add(1);
        }
        let z = mm_i16(point.z.to_bits().saturating_sub(self.reference_z));
        if self.feed_by_rule(point, bin, z, hole) {
            self.stats.points_used = self.stats.points_used.saturating_add(1);
        } else {
            self.stats.points_gated_out = self.stats.points_gated_out.saturating_add(1);
        }
    }

    /// Marks the cells at `expected` (where a beam should have met the ground, at horizontal
    /// distance `distance`) as missing ground: not navigable, whatever else they hold.
    pub fn add_missing_ground(&mut self, expected: Point3, distance: Meters) {
        let z = mm_i16(expected.z.to_bits().saturating_sub(self.reference_z));
        let bin = self.gates.distance_bins().bin(distance);
        self.feed_by_rule(expected, bin, z, true);
    }

    /// [`Classifier::feed`] for the rule in force, chosen here once per point; a hole (a
    /// drop-off or missing ground, rare and off by default) out of line.
    #[inline(always)]
    fn feed_by_rule(&mut self, point: Point3, bin: usize, z: i16, hole: bool) -> bool {
        if hole {
            return self.feed_hole(point, bin, z);
        }
        if self.plane.is_some() {
            self.feed::<true, false>(point, bin, z)
        } else {
            self.feed::<false, false>(point, bin, z)
        }
    }

    /// [`Classifier::feed_by_rule`] for a point that marks its cells as holes.
    #[cold]
    #[inline(never)]
    fn feed_hole(&mut self, point: Point3, bin: usize, z: i16) -> bool {
        if self.plane.is_some() {
            self.feed::<true, true>(point, bin, z)
        } else {
            self.feed::<false, true>(point, bin, z)
        }
    }

    /// Adds a point (its distance in gate bin `bin`) to every layer cell whose gate passes
    /// it; `true` when at least one did. `PLANE`: whether the plane rule is in force; `HOLE`:
    /// whether the point marks its cells as holes (each chosen once per point, so that the
    /// per-layer path tests nothing for it).
    #[inline]
    fn feed<const PLANE: bool, const HOLE: bool>(
        &mut self,
        point: Point3,
        bin: usize,
        z: i16,
    ) -> bool {
        let bin_index = u16::try_from(bin).unwrap_or(u16::MAX);
        // The first eight layers that the bin feeds, exactly (a weight read only where a
        // layer's gate edge falls in the bin's group).
        let offered = self.gates.layers_fed_at(bin);
        // The layers that did not take the point (a full table): marked on those paths only,
        // so that the common one (a layer that takes it) spends nothing on the verdict.
        let mut refused = 0_u32;
        // In words, as the loop holds them (no narrow value to extend again per layer).
        let mut mask = u32::from(offered);
        let (bin_word, z_word) = (u32::from(bin_index), i32::from(z));
        // Read once per point, not per layer (the slots written in between are not them).
        let robot_height_mm = i32::from(self.robot_height_mm);
        // The pair test across a cell's edge: the previous return's pair, when it rose more
        // than the step from the one before (rare), is judged now that its cells are known;
        // this return's, when it rises more than the step from the previous one, keeps the
        // slots that one went to.
        if PLANE && self.across.wants(z_word) {
            self.across.at_return(
                z_word,
                self.step_mm,
                self.robot_height_mm,
                &mut self.slots,
                &self.recent,
            );
        }
        while mask != 0 {
            // The lowest layer left in the mask (a layer in force), then the mask without it.
            // The mask holds eight bits: the cast is exact.
            #[allow(clippy::cast_possible_truncation)]
            let k = crate::gate::lowest_layer(mask as u8);
            // The same bit as `1 << k`, which measured 15 instructions a return dearer on the
            // M4F (it moved the loop's registers).
            let bit = mask & mask.wrapping_neg();
            mask &= mask - 1;
            if !self.feed_recent::<PLANE, HOLE>(k, point, bin_word, z_word, robot_height_mm) {
                refused |= bit;
            }
        }
        let taken = u32::from(offered) & !refused;
        self.across.took(z_word, taken);
        let mut fed = taken != 0;
        // Layers from the ninth on (pyramids of more than eight), by their weights.
        if self.gates.layer_count() > 8 {
            fed |= self.feed_beyond_eight(point, bin, z, HOLE);
        }
        fed
    }

    /// Adds a point to its cell of layer `k` (< [`RECENT_LAYERS`]); `false` when the table is
    /// full (counted). A point in the cell of the layer's last point goes
    /// straight to that cell's slot, its position in the cell from its difference to the cell's
    /// corner; otherwise [`cell_of`], the hash and the probe, and the cell is
    /// remembered. `bin` is a `u16`, `z` and `robot_height_mm` are `i16`, held in words (as
    /// [`fold`] takes them).
    #[inline]
    fn feed_recent<const PLANE: bool, const HOLE: bool>(
        &mut self,
        k: u8,
        point: Point3,
        bin: u32,
        z: i32,
        robot_height_mm: i32,
    ) -> bool {
        let Some(&recent) = self.recent.get(usize::from(k)) else {
            return false;
        };
        // Exact: the corner is within ±2³⁰ and the size below 2³⁰ (`ORIGIN_LIMIT`).
        #[allow(clippy::cast_sign_loss)]
        let (dx, dy) = (
            point.x.to_bits().wrapping_sub(recent.origin_x) as u32,
            point.y.to_bits().wrapping_sub(recent.origin_y) as u32,
        );
        if dx < recent.span && dy < recent.span {
            // Masked to C − 1 (slots are below C): the bound check compiles away.
            if let Some(slot) = self.slots.get_mut(usize::from(recent.slot) & Self::MASK) {
                // dx, dy are the remainders in the cell, as `cell_of` computes them.
                let sub = if PLANE {
                    (
                        rule::sub_cell(dx, recent.reciprocal),
                        rule::sub_cell(dy, recent.reciprocal),
                    )
                } else {
                    (0, 0)
                };
                fold(
                    slot,
                    z,
                    sub,
                    bin,
                    HOLE,
                    robot_height_mm,
                    PLANE,
                    recent.pair_scale,
                );
                return true;
            }
        }
        let r = recent.resolution;
        if r == crate::grid::Resolution::UNSET {
            return false;
        }
        let (cx, cy, sub) = cell_of(r, recent.reciprocal, point, PLANE);
        // Stored as k + 1 (0 marks an empty slot); k < 8.
        match self.insert(k + 1, cx, cy, sub, bin, z, HOLE, PLANE, recent.pair_scale) {
            Some(index) => {
                self.remember(usize::from(k), r.to_bits(), cx, cy, index);
                true
            }
            None => {
                self.stats.overflow_points = self.stats.overflow_points.saturating_add(1);
                false
            }
        }
    }

    /// Remembers cell `(cx, cy)` of cell size `bits` in slot `index` (< C ≤ 65 536) as the cell
    /// of the last point of layer `k`: its slot always, its corner and size (the shortcut)
    /// unless beyond [`ORIGIN_LIMIT`].
    #[inline]
    fn remember(&mut self, k: usize, bits: i32, cx: i32, cy: i32, index: usize) {
        let Some(entry) = self.recent.get_mut(k) else {
            return;
        };
        // index < C ≤ 65 536: it fits a u16.
        #[allow(clippy::cast_possible_truncation)]
        {
            entry.slot = index as u16;
        }
        match (corner(cx, bits), corner(cy, bits), u32::try_from(bits)) {
            (Some(origin_x), Some(origin_y), Ok(span)) if bits < ORIGIN_LIMIT => {
                entry.origin_x = origin_x;
                entry.origin_y = origin_y;
                entry.span = span;
            }
            _ => entry.span = 0,
        }
    }

    /// Folds one point (at `sub` in its cell, [`rule::sub_cell`]) into the slot of
    /// `(layer, cx, cy)`, found by the hash and the probe or taken; the slot's index, `None`
    /// when the table is full. `bin` is a `u16` and `z` an `i16`, held in words as [`fold`]
    /// takes them, with the layer's pair test constants `scale`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn insert(
        &mut self,
        layer: u8,
        cx: i32,
        cy: i32,
        sub: (i8, i8),
        bin: u32,
        z: i32,
        hole: bool,
        plane: bool,
        scale: PairScale,
    ) -> Option<usize> {
        let mut index = hash(layer, cx, cy) as usize & Self::MASK;
        for _ in 0..C {
            let slot = self.slots.get_mut(index)?;
            if slot.layer == EMPTY {
                // Full (`None`) when every slot is taken: `order` has room while used < C.
                let entry = self.order.get_mut(self.used)?;
                // index < C ≤ 65 536: it fits a u16.
                #[allow(clippy::cast_possible_truncation)]
                {
                    *entry = index as u16;
                }
                self.used += 1;
                // The cell's first return against its lowest in the last observation, when
                // this slot held the cell then (`last` is 0 when nothing may be recalled: a new
                // configuration or design). Only a rise beyond the step is judged, out of
                // line: most cells lie as they lay.
                #[cfg(feature = "plane-rule")]
                let shown = if plane
                    && self.recall_state.last != 0
                    && slot.held.stamp == self.recall_state.last
                    && slot.held.layer == layer
                    && slot.cell_x == cx
                    && slot.cell_y == cy
                    && z - (i32::from(slot.z_low) + self.recall_shift) > i32::from(self.step_mm)
                {
                    recall::step_from_held(
                        slot,
                        self.recall_shift,
                        z,
                        sub,
                        scale,
                        (i32::from(self.step_mm), i32::from(self.robot_height_mm)),
                    )
                } else {
                    0
                };
                // The narrow values again, for the slot's fields (exact: see above).
                #[allow(clippy::cast_possible_truncation)]
                let (bin, z) = (bin as u16, z as i16);
                *slot = Slot {
                    plane: if plane {
                        PlaneState::first(sub.0, sub.1, z)
                    } else {
                        PlaneState::EMPTY
                    },
                    cell_x: cx,
                    cell_y: cy,
                    bin,
                    z_low: z,
                    z_high: z,
                    layer,
                    hole,
                    held: scratch::Held::NONE,
                };
                #[cfg(feature = "plane-rule")]
                if shown > 0 {
                    slot.plane.keep_shown(shown);
                }
                return Some(index);
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                let robot_height_mm = i32::from(self.robot_height_mm);
                fold(slot, z, sub, bin, hole, robot_height_mm, plane, scale);
                return Some(index);
            }
            index = (index + 1) & Self::MASK;
        }
        None
    }

    /// Ends the observation: classifies every touched cell, hands each record to `sink` in
    /// the order the cells were first touched (deterministic: the same points give the same
    /// order on every target), and clears the scratch. Visits the touched slots only.
    pub fn finish(&mut self, mut sink: impl FnMut(Evidence)) {
        // The last return's pair across a cell's edge, if it waits.
        self.across.settle(
            self.step_mm,
            self.robot_height_mm,
            &mut self.slots,
            &self.recent,
        );
        let records = u32::try_from(self.used).unwrap_or(u32::MAX);
        if self.plane.is_some() {
            self.steps_between_cells();
        }
        let stamp = self.next_stamp();
        let recalls = self.plane.is_some();
        if self.used > 0 {
            for &index in self.order.iter().take(self.used) {
                // Masked to C − 1 (every index is below C): the bound check compiles away.
                let Some(slot) = self.slots.get_mut(usize::from(index) & Self::MASK) else {
                    continue;
                };
                if slot.layer == EMPTY {
                    continue;
                }
                let spread = i32::from(slot.z_high) - i32::from(slot.z_low);
                let layer = slot.layer.saturating_sub(1);
                let obstacle = slot.hole
                    || match &self.plane {
                        // A pair across the cell's edge may mark a cell whose own points lie
                        // flat: its step is read before the quick answer.
                        Some(params)
                            if params.flat_enough(spread)
                                && i32::from(slot.plane.pair_rise()) <= i32::from(self.step_mm) =>
                        {
                            false
                        }
                        // The cell's side and closest look only where the plane is judged.
                        Some(params) => match self.gates.resolution(usize::from(layer)) {
                            Some(cell) => rule::plane_obstacle(
                                &slot.plane,
                                params,
                                &CellGeometry {
                                    cell: cell.to_bits(),
                                    sensor_height_mm: i32::from(mm_i16(
                                        self.reference_z.saturating_sub(self.ground_z),
                                    )),
                                    distance: self
                                        .gates
                                        .distance_bins()
                                        .lower_edge(usize::from(slot.bin)),
                                },
                                spread,
                            ),
                            None => spread > i32::from(self.step_mm),
                        },
                        None => spread > i32::from(self.step_mm),
                    };
                let class = if obstacle {
                    EvidenceClass::Obstacle
                } else {
                    EvidenceClass::Navigable
                };
                let weight = self
                    .gates
                    .table(usize::from(layer))
                    .map_or(crate::units::Weight::ZERO, |t| {
                        t.weight(usize::from(slot.bin))
                    });
                sink(Evidence {
                    layer,
                    cell_x: slot.cell_x,
                    cell_y: slot.cell_y,
                    class,
                    weight,
                });
                // Vacated: a slot is only read while its layer is set, and `insert` writes
                // all of it when it takes a vacant one.
                if recalls {
                    recall::vacate_held(slot, stamp);
                }
                slot.layer = EMPTY;
            }
            self.used = 0;
        }
        self.recall_state = recall::RecallState {
            last: if recalls { stamp } else { 0 },
            counter: stamp,
            reference_z: self.reference_z,
        };
        self.recall_shift = 0;
        self.forget_recent();
        self.across.forget(self.step_mm);
        self.stats.records = self.stats.records.saturating_add(records);
        self.stats.observations = self.stats.observations.saturating_add(1);
    }

    /// Ends the observation and integrates its evidence into `pyramid`.
    pub fn finish_into<const W: usize>(&mut self, pyramid: &mut Pyramid<W, L>) {
        self.finish(|record| {
            pyramid.apply(&record);
        });
    }
}

impl<const C: usize, const L: usize> Default for Classifier<C, L> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
