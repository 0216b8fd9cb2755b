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
//! A cell holding a single point always looks navigable: that is the systematic far-range miss
//! the pyramid exists to fix, and it is deliberately not "fixed" here.
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
//! The touched cells live in an open-addressing table of `C` slots (a power of two, 48 bytes
//! each: 16 for the key, the closest look and the lowest and highest z, 32 for the plane rule's
//! sums; 16 bytes in a build without the `plane-rule` feature, which has no sums). A point that finds the table full is dropped and
//! counted in [`ClassifierStats::overflow_points`]; nothing panics. One 361-beam line touches
//! at most 361 cells per layer it feeds (2 to 4 with the default soft gate); 1024 slots (48 KiB)
//! hold a line with room to spare, a whole 3-D sweep needs a window's worth.
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

use rule::{CellGeometry, PlaneParams, PlaneState};
pub use rule::{NavigabilityRule, PlaneRule, Ratio};

/// The default step threshold, 0.05 m, evaluated at compile time (`fixed`'s `lit` parses a
/// string: in a non-const context it would run, and weigh 11 KB of code, on the device).
const DEFAULT_STEP_THRESHOLD: Meters = Meters::lit("0.05");

/// What the classifier looks for, metres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClassifierConfig {
    /// Points higher than the cell's ground plus this are overhang and ignored. Default 1.0 m.
    pub robot_height: Meters,
    /// A spread of the remaining points above this makes the cell not navigable. Default 0.05 m.
    pub step_threshold: Meters,
    /// A return this far below the robot's ground plane marks a drop-off; `None` (the
    /// default) turns the check off. 0.3 m is a sensible value when on.
    pub drop_threshold: Option<Meters>,
    /// Returns higher than this above the robot's ground plane are overhang whatever the
    /// cell holds (a roof or a ceiling seen where the floor under it was not); `None` (the
    /// default, the paper's rule) judges overhang only against the cell's own lowest point.
    pub ceiling: Option<Meters>,
    /// How a cell's points below the overhang cut are judged. Default
    /// [`NavigabilityRule::DEFAULT`]: [`NavigabilityRule::Plane`] with [`PlaneRule::DEFAULT`]
    /// with the `plane-rule` feature (the library's default), [`NavigabilityRule::Spread`] (the
    /// paper's rule) without it.
    pub rule: NavigabilityRule,
}

impl ClassifierConfig {
    /// The defaults (`const`): robot height 1.0 m, step threshold 0.05 m, no drop-off check, no
    /// ceiling, [`NavigabilityRule::DEFAULT`] (the plane rule with the `plane-rule` feature,
    /// the paper's spread rule without it).
    pub const DEFAULT: Self = Self {
        robot_height: Meters::ONE,
        step_threshold: DEFAULT_STEP_THRESHOLD,
        drop_threshold: None,
        ceiling: None,
        rule: NavigabilityRule::DEFAULT,
    };
}

impl Default for ClassifierConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ClassifierConfig {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "ClassifierConfig {{ robot_height: {=i32}, step_threshold: {=i32} }} (raw Q16.16), rule {}",
            self.robot_height.to_bits(),
            self.step_threshold.to_bits(),
            self.rule
        );
    }
}

/// Counters of the classifier. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClassifierStats {
    /// Points offered.
    pub points: u32,
    /// Points that fed at least one layer cell.
    pub points_used: u32,
    /// Points that fed no layer cell: every gate zero at their distance, or every cell they
    /// would have fed dropped because the scratch table was full (those additions counted in
    /// [`ClassifierStats::overflow_points`] too). `points_used + points_gated_out` is the
    /// count of points that reached the gates (not overhang).
    pub points_gated_out: u32,
    /// Point-to-cell additions dropped because the scratch table was full (one per layer
    /// cell a point could not get).
    pub overflow_points: u32,
    /// Points ignored as overhang (above ground + robot height) when they arrived.
    pub overhang_points: u32,
    /// Points below the drop threshold (drop-offs).
    pub drop_points: u32,
    /// Observations finished.
    pub observations: u32,
    /// Evidence records produced.
    pub records: u32,
}

/// The layers for which the classifier remembers the cell and slot of their last point.
const RECENT_LAYERS: usize = 8;

/// A cell whose lower corner lies within ±`ORIGIN_LIMIT` raw (±16 384 m) and whose size is
/// below it can be remembered in a [`Recent`]: then a coordinate's wrapped 32-bit difference
/// from the corner is below the size exactly when the coordinate lies in the cell.
const ORIGIN_LIMIT: i32 = 1 << 30;

/// Per layer (the first [`RECENT_LAYERS`]): the layer's cell reciprocal and the cell of its last
/// point. Consecutive returns of a line mostly fall in the same cell of a layer; such a point
/// is recognised by two subtractions and two compares, and folded into the cell's slot without
/// a division, a hash or a probe.
#[derive(Debug, Clone, Copy)]
struct Recent {
    /// The lower corner of the cell of the layer's last point, raw Q16.16, within
    /// ±[`ORIGIN_LIMIT`].
    origin_x: i32,
    /// Likewise along y.
    origin_y: i32,
    /// The cell's size, raw (below [`ORIGIN_LIMIT`]), while the entry holds a cell; 0 when it
    /// holds none (no difference is below 0: every point misses).
    span: u32,
    /// The layer's cell reciprocal ([`crate::grid::cell_reciprocal`]), set by
    /// [`Classifier::adopt_design`]: where there is no hardware division, cell indices are
    /// found by a multiplication; the plane rule's position in the cell on every target.
    reciprocal: u32,
    /// The slot of the cell (valid while `span` is not 0: slots are vacated only when the
    /// observation ends, and every entry is forgotten then).
    slot: u16,
}

impl Recent {
    const NONE: Self = Self {
        origin_x: 0,
        origin_y: 0,
        span: 0,
        reciprocal: 0,
        slot: 0,
    };
}

/// The marker of an empty slot: slots store their layer plus one, so that an empty slot (and
/// a fresh classifier) is all zero bits.
const EMPTY: u8 = 0;

/// One touched layer cell of the current observation. 48 bytes (16 without the `plane-rule`
/// feature).
#[derive(Debug, Clone, Copy)]
struct Slot {
    /// The plane rule's sums (kept only while the plane rule is in force; zero-sized without
    /// the `plane-rule` feature).
    plane: PlaneState,
    cell_x: i32,
    cell_y: i32,
    /// The gate bin of the smallest horizontal distance of the cell's points from the sensor.
    bin: u16,
    /// Lowest z, millimetres relative to the observation's reference height.
    z_low: i16,
    /// Highest z not above `z_low + robot height`, same units.
    z_high: i16,
    /// The layer plus one, or [`EMPTY`].
    layer: u8,
    /// Whether a drop-off or missing ground was seen in the cell.
    hole: bool,
}

impl Slot {
    const VACANT: Self = Self {
        plane: PlaneState::EMPTY,
        cell_x: 0,
        cell_y: 0,
        bin: 0,
        z_low: 0,
        z_high: 0,
        layer: EMPTY,
        hole: false,
    };
}

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
    /// layers keep theirs in `recent`), the cell size (raw) of its last point and its
    /// reciprocal ([`crate::grid::cell_reciprocal`]). Sized by the design's L, so that a small
    /// pyramid (the micro:bit's four layers) carries no entries it cannot use.
    layer_cells: [(i32, u32); L],
    /// The robot's ground plane as of the last point (raw Q16.16).
    ground_z: i32,
    stats: ClassifierStats,
    /// The indices of the slots in use, in the order they were taken (the first `used`
    /// entries; each below C ≤ 65 536): the observation's end visits these, not all C slots.
    order: [u16; C],
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

/// Metres (raw Q16.16) to millimetres, `⌊raw · 1000 / 2¹⁶⌋`, saturated to `i16`.
///
/// On ARMv7-M one `smull` by 1000·2¹⁶ and the product's high word (`⌊raw · 1000·2¹⁶ / 2³²⌋`
/// is the same floor), then `ssat`. On ARMv6-M in 32-bit words (a 64-bit multiply is a
/// library call there): 1000/2¹⁶ = 125/2¹³, and with `raw = hi·2¹³ + lo` (0 ≤ lo < 2¹³) the
/// floor is `hi·125 + ⌊lo·125 / 2¹³⌋` exactly (|hi·125| < 2²⁵).
#[inline]
fn mm_i16(raw: i32) -> i16 {
    let mm = if crate::wide::HALVES {
        mm_halves(raw)
    } else {
        // |raw · 65 536 000| < 2⁵⁷: its high word is the floor, within ±2²⁵.
        #[allow(clippy::cast_possible_truncation)]
        let mm = ((i64::from(raw) * 65_536_000) >> 32) as i32;
        mm
    };
    // Clamped to the i16 range: the cast is exact.
    #[allow(clippy::cast_possible_truncation)]
    let saturated = mm.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
    saturated
}

/// [`mm_i16`]'s floor from 13-bit halves, without a 64-bit product.
#[inline]
fn mm_halves(raw: i32) -> i32 {
    let hi = raw >> 13;
    let lo = raw & 0x1FFF;
    hi * 125 + ((lo * 125) >> 13)
}

/// The position of `point` in its cell `(cx, cy)` of side `bits` (raw) with reciprocal `m`
/// ([`rule::sub_cell`] of the remainders `0 ≤ rem < bits`, exact in wrapping 32-bit
/// arithmetic).
#[inline]
fn position_in_cell(point: Point3, cx: i32, cy: i32, bits: i32, m: u32) -> (i8, i8) {
    #[allow(clippy::cast_sign_loss)]
    let rem = |v: Meters, c: i32| v.to_bits().wrapping_sub(c.wrapping_mul(bits)) as u32;
    (
        rule::sub_cell(rem(point.x, cx), m),
        rule::sub_cell(rem(point.y, cy), m),
    )
}

/// The lower corner `c · bits` of cell `c = ⌊x / bits⌋` (for some `i32` x) of size
/// `0 < bits < ORIGIN_LIMIT`, or `None` when it lies beyond ±[`ORIGIN_LIMIT`]: as
/// `c.checked_mul(bits)` within the limit, in one 32-bit multiplication (a `checked_mul` of
/// `i32` is a 64-bit product, a library call on a Cortex-M0).
///
/// Exact: the true corner lies in `(x − bits, x]`, within `(−2³¹ − 2³⁰, 2³¹)`; wrapped to 32
/// bits, a corner below −2³¹ lands in `(2³⁰, 2³¹)`, beyond the limit like every other corner
/// outside ±2³⁰, and a corner within the limit is its own wrapped value. For other arguments
/// the result is some corner or `None`, never a panic.
#[inline]
fn corner(c: i32, bits: i32) -> Option<i32> {
    let corner = c.wrapping_mul(bits);
    (-ORIGIN_LIMIT..=ORIGIN_LIMIT)
        .contains(&corner)
        .then_some(corner)
}

/// Mixes a cell key into a slot index (multiplicative hashing of 32-bit words).
#[inline]
fn hash(layer: u8, x: i32, y: i32) -> u32 {
    #[allow(clippy::cast_sign_loss)]
    let (xu, yu) = (x as u32, y as u32);
    let h = xu.wrapping_mul(0x9E37_79B1)
        ^ yu.wrapping_mul(0x85EB_CA77).rotate_left(13)
        ^ u32::from(layer).wrapping_mul(0xC2B2_AE3D);
    h ^ (h >> 15)
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
            recent: [Recent::NONE; RECENT_LAYERS],
            last_bin: 0,
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
            layer_cells: [(0, 0); L],
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
        self.discard();
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
        for (k, recent) in self.recent.iter_mut().enumerate() {
            recent.reciprocal = self
                .gates
                .resolution(k)
                .map_or(0, |r| crate::grid::cell_reciprocal(r.to_bits()));
        }
        self.discard();
        Ok(())
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

    /// Starts an observation whose z values are stored relative to `reference_z` (the
    /// sensor's or robot's height now; z within ±32 m of it is kept exactly, beyond saturates).
    /// Forgets any unfinished observation.
    pub fn begin(&mut self, reference_z: Meters) {
        self.discard();
        self.reference_z = reference_z.to_bits();
    }

    /// Forgets the current observation without producing evidence.
    pub fn discard(&mut self) {
        if self.used > 0 {
            self.vacate();
        }
        self.forget_recent();
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
        let mut fed = u32::from(offered) & !refused != 0;
        // Layers from the ninth on (pyramids of more than eight), by their weights.
        if self.gates.layer_count() > 8 {
            fed |= self.feed_beyond_eight(point, bin, z, HOLE);
        }
        fed
    }

    /// [`Classifier::feed`] for layers 8 and up, by their gate weights (out of line: the
    /// default pyramid has eight layers).
    #[inline(never)]
    fn feed_beyond_eight(&mut self, point: Point3, bin: usize, z: i16, hole: bool) -> bool {
        let bin_index = u16::try_from(bin).unwrap_or(u16::MAX);
        let min_weight = self.gates.min_feeding_weight();
        let mut fed = false;
        for k in 8..self.gates.layer_count() {
            let (Some(r), Some(gate)) = (self.gates.resolution(k), self.gates.table(k)) else {
                break;
            };
            if gate.weight(bin) < min_weight {
                continue;
            }
            // Stored as k + 1; k < L ≤ 254.
            let Ok(layer_index) = u8::try_from(k + 1) else {
                break;
            };
            let bits = r.to_bits();
            let reciprocal = match self.layer_cells.get_mut(k) {
                Some(cell) => {
                    if cell.0 != bits || cell.1 == 0 {
                        *cell = (bits, crate::grid::cell_reciprocal(bits));
                    }
                    cell.1
                }
                None => crate::grid::cell_reciprocal(bits),
            };
            fed |= self.feed_layer(layer_index, r, reciprocal, point, bin_index, z, hole);
        }
        fed
    }

    /// Adds a point to its cell of layer `k` (< [`RECENT_LAYERS`]); `false` when the table is
    /// full (counted). A point in the cell of the layer's last point goes
    /// straight to that cell's slot, its position in the cell from its difference to the cell's
    /// corner; otherwise [`Classifier::cell_of`], the hash and the probe, and the cell is
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
                fold(slot, z, sub, bin, HOLE, robot_height_mm, PLANE);
                return true;
            }
        }
        let Some(r) = self.gates.resolution(usize::from(k)) else {
            return false;
        };
        let (cx, cy, sub) = Self::cell_of(r, recent.reciprocal, point, PLANE);
        // Stored as k + 1 (0 marks an empty slot); k < 8.
        match self.insert(k + 1, cx, cy, sub, bin, z, HOLE, PLANE) {
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
    /// of the last point of layer `k`, or nothing when its corner or size is beyond
    /// [`ORIGIN_LIMIT`].
    #[inline]
    fn remember(&mut self, k: usize, bits: i32, cx: i32, cy: i32, index: usize) {
        let Some(entry) = self.recent.get_mut(k) else {
            return;
        };
        match (
            corner(cx, bits),
            corner(cy, bits),
            u32::try_from(bits),
            u16::try_from(index),
        ) {
            (Some(origin_x), Some(origin_y), Ok(span), Ok(slot)) if bits < ORIGIN_LIMIT => {
                entry.origin_x = origin_x;
                entry.origin_y = origin_y;
                entry.span = span;
                entry.slot = slot;
            }
            _ => entry.span = 0,
        }
    }

    /// The cell of `point` for cell size `r` with reciprocal `m`
    /// ([`crate::grid::cell_reciprocal`]), and (while the plane rule is in force) the point's
    /// position in it ([`rule::sub_cell`]): the cell by a hardware division where the target
    /// has one (ARMv7-M, told apart from ARMv6-M by its atomic compare-and-swap: stable Rust
    /// has no `cfg` for the divide instruction), a multiplication by the reciprocal elsewhere
    /// (Cortex-M0, the host); both are exactly `r.cell_of`. The position is a multiplication
    /// by the reciprocal on every target.
    #[inline]
    fn cell_of(
        r: crate::grid::Resolution,
        m: u32,
        point: Point3,
        plane: bool,
    ) -> (i32, i32, (i8, i8)) {
        let bits = r.to_bits();
        let (cx, cy) = if cfg!(all(target_arch = "arm", target_has_atomic = "32")) {
            (r.cell_of(point.x), r.cell_of(point.y))
        } else {
            (
                crate::grid::cell_of_reciprocal(point.x.to_bits(), bits, m),
                crate::grid::cell_of_reciprocal(point.y.to_bits(), bits, m),
            )
        };
        if !plane {
            return (cx, cy, (0, 0));
        }
        (cx, cy, position_in_cell(point, cx, cy, bits, m))
    }

    /// [`Classifier::cell_of`] for layers 8 and up: the cell by `r.cell_of`, the position
    /// (when `plane`) by the layer's reciprocal `m`.
    fn locate(
        r: crate::grid::Resolution,
        m: u32,
        point: Point3,
        plane: bool,
    ) -> (i32, i32, (i8, i8)) {
        let (cx, cy) = (r.cell_of(point.x), r.cell_of(point.y));
        if !plane {
            return (cx, cy, (0, 0));
        }
        (cx, cy, position_in_cell(point, cx, cy, r.to_bits(), m))
    }

    /// Adds a point to its cell of one layer (stored as `layer_index` = k + 1); `false` when
    /// the table is full (counted).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn feed_layer(
        &mut self,
        layer_index: u8,
        r: crate::grid::Resolution,
        reciprocal: u32,
        point: Point3,
        bin: u16,
        z: i16,
        hole: bool,
    ) -> bool {
        let (cx, cy, sub) = Self::locate(r, reciprocal, point, self.plane.is_some());
        self.feed_cell(layer_index, cx, cy, sub, bin, z, hole)
    }

    /// Adds a point to cell `(cx, cy)` of one layer (stored as `layer_index` = k + 1); `false`
    /// when the table is full (counted).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn feed_cell(
        &mut self,
        layer_index: u8,
        cx: i32,
        cy: i32,
        sub: (i8, i8),
        bin: u16,
        z: i16,
        hole: bool,
    ) -> bool {
        let (bin, z) = (u32::from(bin), i32::from(z));
        if self
            .insert(layer_index, cx, cy, sub, bin, z, hole, self.plane.is_some())
            .is_some()
        {
            true
        } else {
            self.stats.overflow_points = self.stats.overflow_points.saturating_add(1);
            false
        }
    }

    /// Folds one point (at `sub` in its cell, [`rule::sub_cell`]) into the slot of
    /// `(layer, cx, cy)`, found by the hash and the probe or taken; the slot's index, `None`
    /// when the table is full. `bin` is a `u16` and `z` an `i16`, held in words as [`fold`]
    /// takes them.
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
                };
                return Some(index);
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                let robot_height_mm = i32::from(self.robot_height_mm);
                fold(slot, z, sub, bin, hole, robot_height_mm, plane);
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
        let records = u32::try_from(self.used).unwrap_or(u32::MAX);
        if self.used > 0 {
            for &index in self.order.iter().take(self.used) {
                // Masked to C − 1 (every index is below C): the bound check compiles away.
                let Some(slot) = self.slots.get_mut(usize::from(index) & Self::MASK) else {
                    continue;
                };
                if slot.layer == EMPTY {
                    continue;
                }
                let distance = self.gates.distance_bins().lower_edge(usize::from(slot.bin));
                let spread = i32::from(slot.z_high) - i32::from(slot.z_low);
                let layer = slot.layer.saturating_sub(1);
                let cell = self
                    .gates
                    .resolution(usize::from(layer))
                    .map(crate::grid::Resolution::to_bits);
                let obstacle = slot.hole
                    || match (&self.plane, cell) {
                        (Some(params), _) if params.flat_enough(spread) => false,
                        (Some(params), Some(cell)) => rule::plane_obstacle(
                            &slot.plane,
                            params,
                            &CellGeometry {
                                cell,
                                sensor_height_mm: i32::from(mm_i16(
                                    self.reference_z.saturating_sub(self.ground_z),
                                )),
                                distance,
                            },
                        ),
                        _ => spread > i32::from(self.step_mm),
                    };
                let class = if obstacle {
                    EvidenceClass::Obstacle
                } else {
                    EvidenceClass::Navigable
                };
                let layer = slot.layer.saturating_sub(1);
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
                slot.layer = EMPTY;
            }
            self.used = 0;
        }
        self.forget_recent();
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

/// Folds a point (z mm, position `sub` in the cell, distance bin) into a used slot under the
/// overhang rule; with `plane`, into the plane rule's sums too when it lies below the cut.
/// `bin` is a `u16`, `z` and `robot_height_mm` are `i16`, held in words: the per-layer loop
/// keeps them so, and extends nothing again per layer.
#[inline(always)]
fn fold(
    slot: &mut Slot,
    z: i32,
    sub: (i8, i8),
    bin: u32,
    hole: bool,
    robot_height_mm: i32,
    plane: bool,
) {
    // The narrow values again, for the slot's fields (exact: see above).
    #[allow(clippy::cast_possible_truncation)]
    let (bin16, z16) = (bin as u16, z as i16);
    if bin < u32::from(slot.bin) {
        slot.bin = bin16;
    }
    if hole {
        slot.hole = true;
    }
    if z < i32::from(slot.z_low) {
        let cut = z + robot_height_mm;
        if i32::from(slot.z_high) > cut {
            // The stored highest is overhang now; the best bound still known below the cut.
            let low_stays = i32::from(slot.z_low) <= cut;
            slot.z_high = if low_stays { slot.z_low } else { z16 };
            if plane {
                restart_sums(slot, sub, z16, low_stays);
            }
        } else if plane {
            slot.plane.add_next(sub.0, sub.1, z16);
        }
        slot.z_low = z16;
    } else if z <= i32::from(slot.z_low) + robot_height_mm {
        if z > i32::from(slot.z_high) {
            slot.z_high = z16;
        }
        if plane {
            slot.plane.add_next(sub.0, sub.1, z16);
        }
    }
}

/// The summed points of `slot` lie above the cut of a new lowest point `z` (at `sub`): its
/// sums restart from this point and, when `low_stays` (still below the cut), the previous
/// lowest (where this point is: its position was not kept). Out of line: rare.
#[cold]
#[inline(never)]
fn restart_sums(slot: &mut Slot, sub: (i8, i8), z: i16, low_stays: bool) {
    slot.plane = PlaneState::first(sub.0, sub.1, z);
    if low_stays {
        slot.plane.add_next(sub.0, sub.1, slot.z_low);
    }
}

impl<const C: usize, const L: usize> Default for Classifier<C, L> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{Design, GateShape, Schedule, SensorModel};
    use crate::pyramid::Config;
    use crate::test_rng::XorShift;
    use crate::Fused;
    extern crate std;
    use std::vec::Vec;

    fn design(gate: GateShape) -> Design<8> {
        let schedule = Schedule {
            gate,
            ..Schedule::default()
        };
        Design::<8>::new(SensorModel::default(), schedule, 64).unwrap()
    }

    fn pyramid(gate: GateShape) -> Pyramid<64, 8> {
        let mut p = Pyramid::new();
        p.configure(&design(gate), &Config::default()).unwrap();
        p
    }

    /// A classifier of `C` slots with the default thresholds and the gating of the default
    /// design with `gate`.
    fn classifier<const C: usize>(gate: GateShape) -> Classifier<C, 8> {
        let mut c = Classifier::new();
        adopt(&mut c, gate);
        c
    }

    fn adopt<const C: usize>(c: &mut Classifier<C, 8>, gate: GateShape) {
        let increments = Config::default().model.increments().unwrap();
        c.adopt_design(&design(gate), increments).unwrap();
    }

    fn pt(x: f32, y: f32, z: f32) -> Point3 {
        Point3 {
            x: Meters::from_num(x),
            y: Meters::from_num(y),
            z: Meters::from_num(z),
        }
    }

    fn records(c: &mut Classifier<256, 8>) -> Vec<Evidence> {
        let mut out = Vec::new();
        c.finish(|r| out.push(r));
        out
    }

    #[test]
    fn flat_ground_is_navigable_and_a_step_is_an_obstacle() {
        let mut c = classifier::<256>(GateShape::Hard);
        c.begin(Meters::ZERO);
        let d = Meters::from_num(0.3);
        // Cell (3, 0) of layer 0: flat within 2 cm.
        c.add_point(pt(0.31, 0.02, 0.00), d, Meters::ZERO);
        c.add_point(pt(0.35, 0.05, 0.02), d, Meters::ZERO);
        // Cell (2, 0): a 10 cm step.
        c.add_point(pt(0.21, 0.02, 0.00), d, Meters::ZERO);
        c.add_point(pt(0.25, 0.05, 0.10), d, Meters::ZERO);
        let mut r = records(&mut c);
        r.sort_by_key(|e| e.cell_x);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].cell_x, r[0].class), (2, EvidenceClass::Obstacle));
        assert_eq!((r[1].cell_x, r[1].class), (3, EvidenceClass::Navigable));
        let w = c.gates().weight_at(0, d);
        assert!(r.iter().all(|e| e.layer == 0 && e.weight == w));
        assert_eq!(c.cells_in_use(), 0);
    }

    #[test]
    fn overhang_above_the_robot_is_ignored_in_any_order() {
        let d = Meters::from_num(0.2);
        for order in [[0.0, 1.5, 0.01], [1.5, 0.0, 0.01], [1.5, 0.01, 0.0]] {
            let mut c = classifier::<256>(GateShape::Hard);
            c.begin(Meters::ZERO);
            for z in order {
                c.add_point(pt(0.05, 0.05, z), d, Meters::ZERO);
            }
            let r = records(&mut c);
            assert_eq!(r.len(), 1);
            assert_eq!(r[0].class, EvidenceClass::Navigable, "{order:?}");
        }
    }

    #[test]
    fn mm_i16_is_the_64_bit_floor() {
        let reference = |raw: i32| {
            let mm = (i64::from(raw) * 1000) >> 16;
            i16::try_from(mm).unwrap_or(if mm < 0 { i16::MIN } else { i16::MAX })
        };
        let mut state = 0x9E37_79B9_u32;
        for raw in (-300_000..300_000)
            .chain([i32::MIN, i32::MIN + 1, i32::MAX, i32::MAX - 1])
            .chain((0..200_000).map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                state as i32
            }))
        {
            assert_eq!(mm_i16(raw), reference(raw), "{raw}");
            // And the ARMv6-M form, whichever target runs the tests.
            let halves = mm_halves(raw);
            let want = (i64::from(raw) * 1000) >> 16;
            assert_eq!(i64::from(halves), want, "{raw}");
        }
        // Around the saturation points ±32 768 mm.
        for raw in 2_147_000_i32..2_148_000 {
            assert_eq!(mm_i16(raw), reference(raw));
            assert_eq!(mm_i16(-raw), reference(-raw));
        }
    }

    #[test]
    fn add_point_squared_is_add_point_with_the_floored_root() {
        let mut a = classifier::<256>(GateShape::default());
        let mut b = classifier::<256>(GateShape::default());
        a.begin(Meters::ZERO);
        b.begin(Meters::ZERO);
        for i in 0..2000_u64 {
            let sq = (i * 7_919_u64).pow(2) * 37 + i;
            let d = Meters::from_bits(i32::try_from(sq.isqrt()).unwrap());
            let q = pt(0.01 * i as f32 - 10.0, 0.3, 0.001 * (i % 97) as f32);
            a.add_point(q, d, Meters::ZERO);
            b.add_point_squared(q, sq, Meters::ZERO);
        }
        let (ra, rb) = (records(&mut a), records(&mut b));
        assert!(!ra.is_empty());
        assert_eq!(ra, rb);
        assert_eq!(a.stats(), b.stats());
    }

    #[test]
    #[cfg(feature = "plane-rule")]
    fn a_slot_is_48_bytes() {
        assert_eq!(core::mem::size_of::<PlaneState>(), 32);
        assert_eq!(core::mem::size_of::<Slot>(), 48);
    }

    #[test]
    #[cfg(not(feature = "plane-rule"))]
    fn without_the_plane_rule_a_slot_is_16_bytes_and_the_paper_rule_applies() {
        assert_eq!(core::mem::size_of::<PlaneState>(), 0);
        assert_eq!(core::mem::size_of::<Slot>(), 16);
        assert_eq!(ClassifierConfig::default().rule, NavigabilityRule::Spread);
        assert!(!NavigabilityRule::Plane(PlaneRule::DEFAULT).is_built_in());
        // A plane rising 6 cm across the cell, which the plane rule would call navigable: asked
        // for, the plane rule becomes the spread rule, which calls the cell an obstacle.
        let d = Meters::from_num(0.3);
        let mut c = classifier::<256>(GateShape::Hard);
        c.configure(ClassifierConfig {
            rule: NavigabilityRule::Plane(PlaneRule::DEFAULT),
            ..ClassifierConfig::default()
        });
        assert_eq!(c.config().rule, NavigabilityRule::Spread);
        assert_eq!(c.plane, None);
        c.begin(Meters::ZERO);
        for q in [pt(0.301, 0.01, 0.00), pt(0.399, 0.09, 0.06)] {
            c.add_point(q, d, Meters::ZERO);
        }
        assert_eq!(records(&mut c)[0].class, EvidenceClass::Obstacle);
    }

    #[test]
    #[cfg(feature = "plane-rule")]
    fn the_paper_rule_stays_available() {
        let d = Meters::from_num(0.3);
        // A plane rising 6 cm across the cell's 0.1 m (31°), four points at its corners.
        let cell = [
            pt(0.301, 0.01, 0.00),
            pt(0.399, 0.01, 0.06),
            pt(0.301, 0.09, 0.00),
            pt(0.399, 0.09, 0.06),
        ];
        let mut c = classifier::<256>(GateShape::Hard);
        let classify = |c: &mut Classifier<256, 8>| {
            c.begin(Meters::ZERO);
            for q in cell {
                c.add_point(q, d, Meters::ZERO);
            }
            records(c)[0].class
        };
        // The plane rule weighs the plane's rise over the points' extent D = √12·s = 0.17 m
        // (10.4 cm) against the step and the largest slope over D (5 + 6.2 cm): navigable.
        assert_eq!(classify(&mut c), EvidenceClass::Navigable);
        // The paper's rule: a spread of 6 cm, over the 5 cm step threshold.
        c.configure(ClassifierConfig {
            rule: NavigabilityRule::Spread,
            ..ClassifierConfig::default()
        });
        assert_eq!(classify(&mut c), EvidenceClass::Obstacle);
    }

    #[test]
    fn new_is_the_default_configuration() {
        let fresh = Classifier::<8, 8>::new();
        let mut configured = Classifier::<8, 8>::unconfigured();
        configured.configure(ClassifierConfig::default());
        assert_eq!(fresh.config(), configured.config());
        assert_eq!(
            (fresh.robot_height_mm, fresh.step_mm, fresh.plane),
            (
                configured.robot_height_mm,
                configured.step_mm,
                configured.plane
            )
        );
    }

    #[test]
    fn a_single_point_always_looks_navigable() {
        let mut c = classifier::<256>(GateShape::Hard);
        c.begin(Meters::ZERO);
        c.add_point(pt(0.05, 0.05, 0.4), Meters::from_num(0.2), Meters::ZERO);
        assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
    }

    #[test]
    fn record_weight_is_the_gate_at_the_closest_look() {
        let mut c = classifier::<256>(GateShape::default());
        c.begin(Meters::ZERO);
        c.add_point(pt(0.05, 0.05, 0.0), Meters::from_num(0.4), Meters::ZERO);
        c.add_point(pt(0.06, 0.05, 0.0), Meters::from_num(0.2), Meters::ZERO);
        c.add_point(pt(0.07, 0.05, 0.0), Meters::from_num(0.3), Meters::ZERO);
        // The closest look, 0.2 m, is kept as its gate bin: 0.2 · 32 = 6.4 → bin 6, whose
        // lower edge is 6/32 = 0.1875 m; the record carries layer 0's weight there.
        let r = records(&mut c);
        let layer0 = r.iter().find(|e| e.layer == 0).unwrap();
        let gates = c.gates();
        assert_eq!(layer0.weight, gates.weight_at(0, Meters::from_num(0.1875)));
        assert_ne!(layer0.weight, gates.weight_at(0, Meters::from_num(0.4)));
    }

    #[test]
    fn hard_gate_sends_each_point_to_one_layer_soft_to_several() {
        let mut c = classifier::<256>(GateShape::Hard);
        c.begin(Meters::ZERO);
        c.add_point(pt(2.0, 0.0, 0.0), Meters::from_num(2.0), Meters::ZERO);
        assert_eq!(records(&mut c).len(), 1);
        adopt(&mut c, GateShape::default());
        c.add_point(pt(2.0, 0.0, 0.0), Meters::from_num(2.0), Meters::ZERO);
        assert!(records(&mut c).len() >= 2);
    }

    #[test]
    fn drop_offs_and_missing_ground_are_obstacles_when_enabled() {
        let d = Meters::from_num(0.3);
        for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
            let mut c = classifier::<256>(GateShape::Hard);
            c.configure(ClassifierConfig {
                rule,
                ..ClassifierConfig::default()
            });
            // A flat patch of ground 0.5 m below the robot's ground plane, and no return where
            // the ground should have been next to it.
            let patch = [
                pt(0.31, 0.01, -0.5),
                pt(0.39, 0.01, -0.5),
                pt(0.31, 0.09, -0.5),
                pt(0.39, 0.09, -0.5),
            ];
            c.begin(Meters::ZERO);
            for q in patch {
                c.add_point(q, d, Meters::ZERO);
            }
            assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
            c.configure(ClassifierConfig {
                drop_threshold: Some(Meters::from_num(0.3)),
                rule,
                ..ClassifierConfig::default()
            });
            c.begin(Meters::ZERO);
            for q in patch {
                c.add_point(q, d, Meters::ZERO);
            }
            c.add_missing_ground(pt(0.15, 0.05, 0.0), d);
            let r = records(&mut c);
            assert!(
                r.iter().all(|e| e.class == EvidenceClass::Obstacle),
                "{rule:?}"
            );
            assert_eq!(r.len(), 2);
            assert_eq!(c.stats().drop_points, 4);
        }
    }

    #[test]
    fn a_ceiling_cut_drops_roof_points_before_any_cell_sees_them() {
        let d = Meters::from_num(0.3);
        // A cell that saw only an uneven roof, 2.0 to 2.2 m above the robot's ground.
        let roof = [pt(0.35, 0.05, 2.0), pt(0.36, 0.05, 2.2)];
        for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
            let mut c = classifier::<256>(GateShape::Hard);
            c.configure(ClassifierConfig {
                rule,
                ..ClassifierConfig::default()
            });
            c.begin(Meters::ZERO);
            for r in roof {
                c.add_point(r, d, Meters::ZERO);
            }
            assert_eq!(
                records(&mut c)[0].class,
                EvidenceClass::Obstacle,
                "{rule:?}"
            );
            c.configure(ClassifierConfig {
                ceiling: Some(Meters::from_num(1.5)),
                rule,
                ..ClassifierConfig::default()
            });
            c.begin(Meters::ZERO);
            for r in roof {
                c.add_point(r, d, Meters::ZERO);
            }
            assert!(records(&mut c).is_empty());
            assert_eq!(c.stats().overhang_points, 2);
        }
    }

    #[test]
    #[cfg(feature = "plane-rule")]
    fn a_new_lowest_point_keeps_the_best_bound_in_the_plane_sums() {
        let d = Meters::from_num(0.3);
        let mut c = classifier::<256>(GateShape::Hard);
        let ground = [
            pt(0.31, 0.01, 0.0),
            pt(0.39, 0.01, 0.0),
            pt(0.31, 0.09, 0.0),
            pt(0.39, 0.09, 0.0),
        ];
        // A branch over flat ground, in either order: navigable.
        let branch = [pt(0.33, 0.04, 1.6), pt(0.37, 0.06, 1.7)];
        for order in [[&ground[..], &branch[..]], [&branch[..], &ground[..]]] {
            c.begin(Meters::ZERO);
            for q in order.concat() {
                c.add_point(q, d, Meters::ZERO);
            }
            assert_eq!(records(&mut c)[0].class, EvidenceClass::Navigable);
        }
        // A 0.3 m block top seen before a lower point moves the cut below a roof point: the
        // sums restart with the lowest and the block's top (the best bound below the new cut).
        let cell = [
            pt(0.33, 0.04, 0.3),
            pt(0.35, 0.05, 1.25),
            pt(0.37, 0.06, 0.0),
        ];
        c.begin(Meters::ZERO);
        for q in cell {
            c.add_point(q, d, Meters::ZERO);
        }
        assert_eq!(records(&mut c)[0].class, EvidenceClass::Obstacle);
    }

    #[test]
    fn remembering_the_last_cell_changes_nothing() {
        // Runs of points in and around cells (their corners ± 1 raw), jumps between far cells,
        // coordinates near ±32 768 m; each classifier once as is and once forgetting the last
        // cells before every point (every point through the cell index, hash and probe).
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
        let mut next = || rng.next();
        let cell = Meters::from_num(0.1).to_bits();
        for rule in [NavigabilityRule::DEFAULT, NavigabilityRule::Spread] {
            for gate in [GateShape::Hard, GateShape::default()] {
                let mut a = classifier::<256>(gate);
                let mut b = classifier::<256>(gate);
                for c in [&mut a, &mut b] {
                    c.configure(ClassifierConfig {
                        rule,
                        ..ClassifierConfig::default()
                    });
                }
                for _observation in 0..40 {
                    a.begin(Meters::ZERO);
                    b.begin(Meters::ZERO);
                    let mut x = (next() as i32) >> (next() % 32);
                    let mut y = (next() as i32) >> (next() % 32);
                    for _ in 0..200 {
                        match next() % 8 {
                            0 => x = next() as i32,
                            1 => y = (next() as i32) >> (next() % 32),
                            // A cell corner of some layer (cells of 0.1 m · 2ᵏ), ± 1.
                            2 => {
                                let size = cell << (next() % 8);
                                x = x.div_euclid(size).wrapping_mul(size) + (next() % 3) as i32 - 1;
                            }
                            _ => {
                                x = x.saturating_add((next() % 2001) as i32 - 1000);
                                y = y.saturating_add((next() % 2001) as i32 - 1000);
                            }
                        }
                        let z = Meters::from_bits((next() % 200_000) as i32 - 100_000);
                        let q = Point3 {
                            x: Meters::from_bits(x),
                            y: Meters::from_bits(y),
                            z,
                        };
                        let d = Meters::from_bits((next() % (20 << 16)) as i32);
                        a.add_point(q, d, Meters::ZERO);
                        b.forget_recent();
                        b.add_point(q, d, Meters::ZERO);
                    }
                    let (ra, rb) = (records(&mut a), records(&mut b));
                    assert!(!ra.is_empty());
                    assert_eq!(ra, rb, "{rule:?} {gate:?}");
                }
                assert_eq!(a.stats(), b.stats());
            }
        }
    }

    #[test]
    fn a_corner_in_32_bits_is_the_checked_product_within_the_limit() {
        let within = |o: Option<i32>| o.filter(|o| (-ORIGIN_LIMIT..=ORIGIN_LIMIT).contains(o));
        let mut rng = XorShift(0xD1B5_4A32_D192_ED03_u64);
        let sizes = [
            1,
            2,
            655,
            6_553,
            65_536,
            1 << 20,
            (1 << 29) + 7,
            ORIGIN_LIMIT - 1,
        ];
        for bits in sizes {
            let mut xs = std::vec![
                i32::MIN,
                i32::MIN + 1,
                i32::MIN + bits - 1,
                i32::MIN + bits,
                -ORIGIN_LIMIT - 1,
                -ORIGIN_LIMIT,
                -1,
                0,
                ORIGIN_LIMIT,
                ORIGIN_LIMIT + bits,
                i32::MAX - bits,
                i32::MAX,
            ];
            xs.extend((0..20_000).map(|_| rng.next() as i32 >> (rng.next() % 32)));
            for x in xs {
                let c = x.div_euclid(bits);
                assert_eq!(corner(c, bits), within(c.checked_mul(bits)), "{x} {bits}");
            }
        }
    }

    #[test]
    fn every_offered_point_is_counted_once() {
        // Overhang, drop-off, used, gated out (beyond the range) and dropped on a full table.
        let mut c = classifier::<8>(GateShape::Hard);
        c.configure(ClassifierConfig {
            ceiling: Some(Meters::from_num(1.5)),
            drop_threshold: Some(Meters::from_num(0.3)),
            ..ClassifierConfig::default()
        });
        c.begin(Meters::ZERO);
        let near = Meters::from_num(0.2);
        let mut offered = 0;
        for i in 0..30 {
            let x = 0.05 + 0.1 * i as f32;
            let (z, d) = match i % 5 {
                0 => (2.0, near),
                1 => (-1.0, near),
                2 => (0.0, Meters::from_num(1000.0)),
                _ => (0.0, near),
            };
            c.add_point(pt(x - 3.0, 0.05, z), d, Meters::ZERO);
            offered += 1;
        }
        let s = c.stats();
        assert!(s.overhang_points > 0 && s.points_gated_out > 0 && s.overflow_points > 0);
        assert!(s.drop_points > 0 && s.points_used > 0);
        assert_eq!(s.points, offered);
    }

    #[test]
    fn a_full_table_drops_and_counts_instead_of_panicking() {
        let mut c = classifier::<8>(GateShape::Hard);
        c.begin(Meters::ZERO);
        for i in 0..20 {
            let x = 0.05 + 0.1 * i as f32;
            c.add_point(pt(x - 3.0, 0.05, 0.0), Meters::from_num(0.2), Meters::ZERO);
        }
        assert_eq!(c.cells_in_use(), 8);
        assert_eq!(c.stats().overflow_points, 12);
        // A point that lost its only cell fed no layer: it is counted with the gated-out
        // ones, as `points_gated_out` says.
        assert_eq!(c.stats().points, 20);
        assert_eq!(c.stats().points_used, 8);
        assert_eq!(c.stats().points_gated_out, 12);
        let mut n = 0;
        c.finish(|_| n += 1);
        assert_eq!(n, 8);
    }

    #[test]
    fn a_point_refused_by_one_layer_and_taken_by_another_is_used() {
        // The soft gate feeds three layers at 2 m: 0.2, 0.4 and 0.6 m cells.
        let mut c = classifier::<4>(GateShape::default());
        c.begin(Meters::ZERO);
        let d = Meters::from_num(2.0);
        c.add_point(pt(2.001, 0.001, 0.0), d, Meters::ZERO);
        assert_eq!(c.cells_in_use(), 3);
        // Another 0.2 m cell, the same 0.4 and 0.6 m ones: the table is full.
        c.add_point(pt(2.201, 0.001, 0.0), d, Meters::ZERO);
        assert_eq!(c.cells_in_use(), 4);
        // Yet another 0.2 m cell (refused: no slot left), the same 0.4 and 0.6 m cells (taken):
        // the point is used, and its refusal counted.
        c.add_point(pt(2.201, 0.201, 0.0), d, Meters::ZERO);
        let stats = c.stats();
        assert_eq!(stats.overflow_points, 1);
        assert_eq!(stats.points, 3);
        assert_eq!(stats.points_used, 3);
        assert_eq!(stats.points_gated_out, 0);
        let mut layers = Vec::new();
        c.finish(|e| layers.push(e.layer));
        assert_eq!(layers, [1, 2, 3, 1]);
    }

    #[test]
    fn finish_into_updates_the_pyramid() {
        let mut p = pyramid(GateShape::Hard);
        let mut c = classifier::<256>(GateShape::Hard);
        c.begin(Meters::ZERO);
        let d = Meters::from_num(0.3);
        c.add_point(pt(0.21, 0.02, 0.00), d, Meters::ZERO);
        c.add_point(pt(0.25, 0.05, 0.12), d, Meters::ZERO);
        c.finish_into(&mut p);
        assert_eq!(
            p.fused(Meters::from_num(0.25), Meters::from_num(0.05)),
            Fused::Obstacle { layer: 0 }
        );
    }
}
