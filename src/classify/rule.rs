//! The navigability rule of one layer cell: its per-slot state, how a point folds into it, and
//! the decision (`docs/core.md`, "The navigability rule").
//!
//! Two rules, chosen by [`NavigabilityRule`] in [`super::ClassifierConfig`]:
//! - [`NavigabilityRule::Spread`], the paper's: the spread of the points below the overhang
//!   cut over the step threshold. State: the lowest and highest z (kept by every slot).
//! - [`NavigabilityRule::Plane`], the default (with the `plane-rule` feature): a least-squares plane per cell from running sums
//!   of the points below the overhang cut. Not navigable when the points stray from their
//!   plane by more than a residual allowance, when the plane is steeper than the largest
//!   traversable slope, rises beyond it by more than its noise and rises more than a step in
//!   all (a kerb whose face spreads over the cell), or when the cell's
//!   lowest and highest points stand apart by more than the plane explains between them and
//!   a step allows (the extremes test: a kerb or a step inside a coarse cell, which the plane
//!   takes for a slope), or when two consecutive returns of the cell lie on a surface steeper
//!   than the largest slope and rise more than a step (the pair test: a kerb's face, where two
//!   beams' returns stand on each other or one beam crosses it). The allowances grow
//!   with the sensor's height noise at the cell's distance,
//!   `σ_z(d) = √((σ·h/r)² + (σ_a·r)²)`, `r = √(h² + d²)`: the range noise σ along the beam and
//!   the beam's elevation error σ_a, each seen in the vertical.
//!
//! The plane rule is built in with the library's `plane-rule` feature (on by default). Without
//! it `PlaneState` is zero-sized (a classifier slot is 16 bytes instead of 68), the default
//! rule is the spread rule, and the classifier applies the spread rule whatever its
//! configuration asks ([`NavigabilityRule::is_built_in`]; the link refuses the plane rule).
//!
//! # Fixed point (`PlaneState`, 52 bytes a slot)
//! Per point: its position in the cell as two 6-bit coordinates `u, v ∈ −32 ..= 31` (units of
//! the cell's side / 64, from the cell's centre: `⌊64·(x − x_cell)/c⌋ − 32`, by a multiplication
//! with the layer's cached reciprocal), its height `z − z₀` in millimetres relative to the
//! slot's first summed point (clamped to −8192 ..= 8191 mm), and the sums n, Σu, Σv, Σuu, Σvv, Σuv, Σz,
//! Σuz, Σvz, Σzz. No float, no division. When n reaches 62 every sum is halved and from then
//! on only every 2nd point is summed (then every 4th, …): the sums stay a uniform sample of
//! the cell's points within their widths (|Σu| ≤ 62·32, Σuu ≤ 62·32², |Σuz| ≤ 62·32·8192,
//! Σzz ≤ 62·8192² < 2³²). A point is summed when it lies below the overhang cut as it arrives. A new lowest
//! point that puts summed points above the cut restarts the sums from it and from the previous
//! lowest when that is still below the cut (the best bound still known, as the spread rule
//! keeps it; its position was not kept, so it is summed where the new point is).
//!
//! Per cell, when the observation finishes, in integers (the centred moments, the determinant
//! and the plane's numerators in 64 bits by the sums' bounds, the products with the plane in
//! 128): the centred moments, the ridge-regularised plane `w = (C + λI)⁻¹c` with `λ = 1` (one
//! unit², `(c/64)²`, so points with no horizontal spread in some direction fit no slope in
//! it), the residual
//! `r² = C_zz − 2wᵀc + wᵀCw`, the plane's rise over the points' extent `R = √(12·wᵀCw)` and its
//! gradient `g = |w|`; σ_z from the sensor's height above the robot's ground plane and the
//! cell's closest look (the lower edge of its gate bin). The extremes test reads the spread
//! (from the slot's lowest and highest z) and the positions `(u, v)` of those two points,
//! which the slot keeps as they change (4 bytes): `spread − max(0, w·Δ) > step + 2·k·σ·h/r`
//! with `Δ` from the lowest to the highest (mm Q16, in 128 bits).
//!
//! The pair test is folded per return: the slot keeps its last return below the cut (its
//! `(u, v)` and z, 4 bytes), the two before it (8 bytes, paired too when the rule's pair depth
//! asks: [`PlaneRule::pair_depth`]) and the largest step a pair has shown so far,
//! `min(|Δz|, |Δz| − s·(|Δu| + |Δv|) + step)` (mm, saturated to 0 ..= 255, 1 byte), s the
//! layer's `tan θ_max·c/64` in mm Q8; the decision compares it with the extremes test's
//! allowance `step + 2·k·σ·h/r`: beyond it exactly when the rise beyond the slope exceeds the
//! noise `2·k·σ·h/r` and the whole rise the allowance. A pair across a cell's edge (two
//! consecutive returns of the observation that one of the first eight layers takes in
//! neighbouring cells, less than a cell's side apart) folds its step into the cell of its
//! upper return (the classifier finds such pairs; `docs/core.md`, "The pair test across a
//! cell's edge"), and so does the pair of a cell's lowest return and a neighbour's at the
//! observation's end ("The step between neighbouring cells' lowest returns"). A cell of one
//! return is judged by such pairs alone.

use crate::units::Meters;
use fixed::types::I16F16;

#[cfg(feature = "plane-rule")]
mod decision;
#[cfg(feature = "plane-rule")]
pub(super) use decision::plane_obstacle;
mod pair;
pub(super) use pair::{pair_shown, PairScale};
#[cfg(feature = "plane-rule")]
use pair::{pair_slope_q8, Back};

/// A dimensionless ratio (a slope's rise per unit of run, a multiplier): signed Q16.16.
pub type Ratio = I16F16;

/// tan 20°, the default largest traversable slope (evaluated at compile time).
const DEFAULT_MAX_GRADE: Ratio = Ratio::lit("0.36397");
/// The default residual allowance, 1.5 cm.
const DEFAULT_RESIDUAL: Meters = Meters::lit("0.015");
/// The default range noise σ, 2 cm.
const DEFAULT_RANGE_SIGMA: Meters = Meters::lit("0.02");
/// The default noise factor k, 2.
const DEFAULT_NOISE_FACTOR: Ratio = Ratio::lit("2");
/// The default angular noise σ_a, 0.075° in radians.
const DEFAULT_ANGLE_SIGMA: Ratio = Ratio::lit("0.001309");

/// How a layer cell's points are judged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NavigabilityRule {
    /// The paper's rule: not navigable when the points below the overhang cut spread over
    /// more than [`super::ClassifierConfig::step_threshold`], whatever the cell's size, the
    /// slope and the noise.
    Spread,
    /// A least-squares plane per cell (the default): not navigable when the points stray from
    /// it, or when it is steeper than the robot can drive.
    Plane(PlaneRule),
}

impl NavigabilityRule {
    /// The default: [`NavigabilityRule::Plane`] with [`PlaneRule::DEFAULT`] (a build with the
    /// `plane-rule` feature, the library's default).
    #[cfg(feature = "plane-rule")]
    pub const DEFAULT: Self = Self::Plane(PlaneRule::DEFAULT);
    /// The default: [`NavigabilityRule::Spread`], the paper's rule (a build without the
    /// `plane-rule` feature, which cannot apply the plane rule).
    #[cfg(not(feature = "plane-rule"))]
    pub const DEFAULT: Self = Self::Spread;

    /// The rule as a spinning multi-beam laser's returns in firing order ask for it: the
    /// plane rule pairing each return with the last [`FIRING_ORDER_PAIR_DEPTH`] of its cell
    /// ([`PlaneRule::pair_depth`]); the spread rule as it is.
    #[must_use]
    pub const fn for_firing_order(self) -> Self {
        match self {
            Self::Spread => Self::Spread,
            Self::Plane(rule) => Self::Plane(rule.with_pair_depth(FIRING_ORDER_PAIR_DEPTH)),
        }
    }

    /// Whether this build can apply the rule: the spread rule always, the plane rule only
    /// with the `plane-rule` feature (the library's default).
    #[must_use]
    pub const fn is_built_in(&self) -> bool {
        match self {
            Self::Spread => true,
            Self::Plane(_) => cfg!(feature = "plane-rule"),
        }
    }
}

impl Default for NavigabilityRule {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The parameters of [`NavigabilityRule::Plane`]. The rise allowance is the classifier's
/// [`step_threshold`](super::ClassifierConfig::step_threshold).
///
/// A cell is not navigable when (d the cell's closest look, h the sensor's height above the
/// robot's ground plane, `r = √(h² + d²)`,
/// `σ_z = √((range_sigma·h/r)² + (angle_sigma·r)²)`, `a = noise_factor·σ_z`, n the summed
/// points):
/// - the RMS of the points about their plane exceeds `√(residual² + a²)`, or
/// - the plane is steeper than `max_grade` and rises across the points' extent D by more than
///   `D·max_grade + 1.5·a·√(12/n)` and by more than `step + a·√(12/n)` in all, or
/// - the lowest and the highest point stand apart by more than the plane explains between
///   them and `step + 2·noise_factor·range_sigma·h/r` (the extremes test), or
/// - a return and one of the `pair_depth` returns of the cell before it rise more than
///   `max_grade` explains over their horizontal distance (|Δx| + |Δy|) by more than
///   `2·noise_factor·range_sigma·h/r`, and more than that allowance and a step in all (the
///   pair test: a surface steeper than the robot climbs that rises more than a step, as the
///   second test asks of the plane).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlaneRule {
    /// The largest traversable slope as its grade (rise per unit of run, the tangent of its
    /// angle), ≥ 0. Default tan 20° = 0.364.
    pub max_grade: Ratio,
    /// The RMS by which a navigable cell's points may stray from their plane on top of the
    /// noise, metres, ≥ 0 (texture: grass, gravel, cobbles). Default 0.015 m.
    pub residual: Meters,
    /// The standard deviation of the sensor's range noise, metres, ≥ 0. Default 0.02 m.
    pub range_sigma: Meters,
    /// The standard deviation of a beam's elevation error (its calibration), radians, ≥ 0.
    /// Default 0.001309 (0.075°).
    pub angle_sigma: Ratio,
    /// How many σ_z the noise allowance is, ≥ 0. Default 2.
    pub noise_factor: Ratio,
    /// How many of a cell's previous returns the pair test pairs each return with,
    /// 1 ..= [`MAX_PAIR_DEPTH`] (a value outside is taken as the nearest bound). Default 1: the
    /// last one, for a laser whose returns sweep a cell line by line (a tilting or nodding
    /// 2-D laser). 3 for a spinning multi-beam laser whose returns come in firing order:
    /// there the returns of one azimuth step, beam over beam, come between a return and its
    /// neighbour along the ring (`docs/core.md`, "How far back the pair test looks").
    pub pair_depth: u8,
}

/// The most returns back the pair test looks ([`PlaneRule::pair_depth`]).
pub const MAX_PAIR_DEPTH: u8 = 3;

/// The pair depth a spinning multi-beam laser's returns in firing order ask for
/// ([`PlaneRule::pair_depth`]; measured in `docs/core.md`, "How far back the pair test looks").
pub const FIRING_ORDER_PAIR_DEPTH: u8 = 3;

impl PlaneRule {
    /// The defaults: 20°, 1.5 cm, σ = 2 cm, σ_a = 0.075°, k = 2 (chosen by measurement,
    /// `host-tests/examples/terrain_rules.rs`).
    pub const DEFAULT: Self = Self {
        max_grade: DEFAULT_MAX_GRADE,
        residual: DEFAULT_RESIDUAL,
        range_sigma: DEFAULT_RANGE_SIGMA,
        angle_sigma: DEFAULT_ANGLE_SIGMA,
        noise_factor: DEFAULT_NOISE_FACTOR,
        pair_depth: 1,
    };

    /// The rule with `pair_depth` returns back paired ([`PlaneRule::pair_depth`]).
    #[must_use]
    pub const fn with_pair_depth(self, pair_depth: u8) -> Self {
        Self { pair_depth, ..self }
    }
}

impl Default for PlaneRule {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(feature = "defmt")]
defmt_raw!(PlaneRule, "PlaneRule {{ max_grade: {=i32}, residual: {=i32}, range_sigma: {=i32}, angle_sigma: {=i32}, noise_factor: {=i32} }} (raw Q16.16), pair depth {=u8}", [max_grade, residual, range_sigma, angle_sigma, noise_factor], [pair_depth]);

#[cfg(feature = "plane-rule")]
/// The number of summed points at which the sums are halved.
const HALVE_AT: u8 = 62;
#[cfg(feature = "plane-rule")]
/// The largest halving level by its own bound (every 2¹⁵-th point summed); the saturating
/// 16-bit phase stops the sampling at level 12 first (`docs/core.md`, the plane rule).
const MAX_LEVEL: u8 = 15;
#[cfg(feature = "plane-rule")]
/// The signed width of a summed z − z₀ (millimetres), bits: z − z₀ is clamped to
/// −8192 ..= 8191, one saturating instruction (`ssat`) on ARMv7-M
/// ([`crate::saturate::to_signed_bits`]).
const DZ_BITS: u32 = 14;

#[cfg(feature = "plane-rule")]
/// The plane rule's running sums of one slot, where in the cell its lowest and highest
/// points lie, and the pair test's last returns and largest rise. 52 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct PlaneState {
    sz: i32,
    suz: i32,
    svz: i32,
    szz: u32,
    /// Points offered since the last halving, saturating: the decimation's phase (0 before
    /// the first halving, where every point is summed).
    offered: u16,
    /// z₀, millimetres relative to the observation's reference height.
    z0: i16,
    /// Σu·2¹⁶ + Σv, wrapping: one add for both sums (|Σu|, |Σv| < 2¹⁵, so each decodes
    /// exactly: [`PlaneState::su`], [`PlaneState::sv`]).
    su_sv: u32,
    /// Σu²·2¹⁶ + Σv² (each below 2¹⁶, so neither carries into the other).
    suu_svv: u32,
    suv: i16,
    /// Summed points (≤ [`HALVE_AT`]).
    n: u8,
    /// Halvings so far: every 2^level-th offered point is summed.
    level: u8,
    /// The position `(u, v)` of the slot's lowest point (the spread's foot): set by the
    /// classifier as the lowest changes ([`PlaneState::set_low_at`]).
    low_at: (i8, i8),
    /// The position of the slot's highest point below the overhang cut (the spread's top).
    high_at: (i8, i8),
    /// The position of the slot's last point below the cut as it arrived (the pair test's
    /// previous return).
    last_at: (i8, i8),
    /// That point's z, millimetres relative to the observation's reference height.
    last_z: i16,
    /// The two returns below the cut before the last, the more recent first: paired too
    /// when the layer's [`PairScale`] asks for more than the last
    /// ([`PlaneRule::pair_depth`]); kept only then.
    earlier: [Back; 2],
    /// How many of `earlier` hold a return (0 ..= 2).
    earlier_held: u8,
    /// The largest step two consecutive returns below the cut have shown,
    /// `min(|Δz|, |Δz| − tan θ_max·(|Δx| + |Δy|) + step)` (the part beyond the largest slope
    /// floored at 0), millimetres, saturated to 0 ..= 255 (the pair test,
    /// [`PlaneState::keep_rise`]).
    pair_rise: u8,
}

#[cfg(feature = "plane-rule")]
impl PlaneState {
    /// No point.
    pub(super) const EMPTY: Self = Self {
        sz: 0,
        suz: 0,
        svz: 0,
        szz: 0,
        offered: 0,
        z0: 0,
        su_sv: 0,
        suu_svv: 0,
        suv: 0,
        n: 0,
        level: 0,
        low_at: (0, 0),
        high_at: (0, 0),
        last_at: (0, 0),
        last_z: 0,
        earlier: [Back::NONE; 2],
        earlier_held: 0,
        pair_rise: 0,
    };

    /// Sums of the one point `(u, v, z)`, the lowest and the highest.
    pub(super) fn first(u: i8, v: i8, z: i16) -> Self {
        let mut s = Self::EMPTY;
        s.z0 = z;
        s.low_at = (u, v);
        s.high_at = (u, v);
        s.last_at = (u, v);
        s.last_z = z;
        s.add_next(u, v, z);
        s
    }

    /// The pair test's fold of a return below the cut at `(u, v, z)` (z mm), following the
    /// slot's last one, with the layer's `scale` ([`PlaneParams::pair_scale`]): when the two
    /// differ in height by more than the scale's step, the step the pair shows
    /// ([`PlaneState::keep_rise`]) is kept when it is the largest so far (saturated to
    /// 255 mm); a rise within the step shows none and is not computed. When the scale asks
    /// for deeper pairs ([`PairScale::earlier`]), the point is paired with as many of the
    /// returns before the last too ([`PlaneState::step_from_earlier`]). The point becomes the
    /// last. In 32-bit words, one multiplication: the run is at most 510 units and the slope
    /// below 2¹⁶, so their product is below 2²⁵.
    #[inline(always)]
    pub(super) fn step_from_last(&mut self, u: i8, v: i8, z: i16, scale: PairScale) {
        let rise = u32::from(z.abs_diff(self.last_z));
        if rise > scale.step_mm() {
            self.keep_rise(self.last_at, u, v, rise, scale);
        }
        if scale.earlier() != 0 {
            self.step_from_earlier(u, v, z, scale);
        }
        self.last_at = (u, v);
        self.last_z = z;
    }

    /// The deeper pairs of [`PlaneState::step_from_last`]: the return at `(u, v, z)` paired
    /// with each of the first [`PairScale::earlier`] returns before the last that the slot
    /// holds, as with the last; then the last joins them (the oldest drops out). Out of line:
    /// only a layer that asks for deeper pairs (a spinning multi-beam laser's returns in
    /// firing order) comes here, and the fold of every other keeps its registers.
    #[inline(never)]
    fn step_from_earlier(&mut self, u: i8, v: i8, z: i16, scale: PairScale) {
        let held = usize::from(self.earlier_held).min(scale.earlier());
        let earlier = self.earlier;
        for back in earlier.iter().take(held) {
            let rise = u32::from(z.abs_diff(back.z));
            if rise > scale.step_mm() {
                self.keep_rise(back.at, u, v, rise, scale);
            }
        }
        let [newer, _] = earlier;
        self.earlier = [
            Back {
                at: self.last_at,
                z: self.last_z,
            },
            newer,
        ];
        self.earlier_held = (self.earlier_held + 1).min(2);
    }

    /// [`PlaneState::step_from_last`]'s pair: a rise `rise` (mm) from an earlier return at
    /// `from` to one at `(u, v)`. Its part beyond the slope is
    /// `b = rise − slope·(|Δu| + |Δv|)` (≥ 0); the step it shows is `min(rise, b + step)`
    /// (mm, the scale's step), so that the pair test's `min(rise, b + step) > step + noise`
    /// holds exactly when the surface between the two is steeper than the largest slope
    /// beyond the noise (`b > noise`) and rises more than a step beyond it
    /// (`rise > step + noise`), as the rise test asks of a plane (`docs/core.md`, "Why the
    /// pair test"). Kept when it is the largest so far. Out of line: only rises beyond the
    /// step come here.
    #[cold]
    #[inline(never)]
    fn keep_rise(&mut self, from: (i8, i8), u: i8, v: i8, rise: u32, scale: PairScale) {
        let run = u32::from(u.abs_diff(from.0)) + u32::from(v.abs_diff(from.1));
        self.keep_shown(pair_shown(rise, run, scale));
    }

    /// The position `(u, v)` in the cell of the slot's last return below the cut as it
    /// arrived.
    pub(super) const fn last_at(&self) -> (i8, i8) {
        self.last_at
    }

    /// Keeps `shown` (mm, [`pair_shown`]) as the largest step a pair has shown when it is
    /// larger: the pair test's fold of a pair across the cell's edge
    /// ([`super::Classifier`]'s cross-cell pair), as of one within the cell.
    #[inline]
    pub(super) fn keep_shown(&mut self, shown: u8) {
        self.pair_rise = self.pair_rise.max(shown);
    }

    /// The largest step a pair of consecutive returns below the cut shows
    /// ([`PlaneState::keep_rise`]), mm (0 ..= 255, saturated; 0 when no pair rises more
    /// than the layer's step).
    pub(super) const fn pair_rise(&self) -> u8 {
        self.pair_rise
    }

    /// The slot's lowest point is now at `at`.
    #[inline(always)]
    pub(super) fn set_low_at(&mut self, at: (i8, i8)) {
        self.low_at = at;
    }

    /// The slot's highest point below the cut is now at `at`.
    #[inline(always)]
    pub(super) fn set_high_at(&mut self, at: (i8, i8)) {
        self.high_at = at;
    }

    /// Where the slot's lowest point lies.
    pub(super) const fn low_at(&self) -> (i8, i8) {
        self.low_at
    }

    /// Where the slot's highest point below the cut lies.
    pub(super) const fn high_at(&self) -> (i8, i8) {
        self.high_at
    }

    /// [`PlaneState::add_next`] to any sums, empty ones too: the first point summed sets z₀
    /// (for the tests, which build sums point by point from [`PlaneState::EMPTY`]).
    #[cfg(test)]
    pub(super) fn add(&mut self, u: i8, v: i8, z: i16) {
        if self.n == 0 {
            self.z0 = z;
        }
        self.add_next(u, v, z);
    }

    /// Offers a point below the overhang cut to sums that hold a point (made by
    /// [`PlaneState::first`], which sets z₀; a halving keeps at least 31): summed unless the
    /// decimation skips it. `u, v ∈ −32 ..= 31` as [`sub_cell`] gives them: the sums' bounds
    /// assume it; other values never panic but may wrap the sums. On empty sums z₀ stays 0
    /// (no panic).
    #[inline(always)]
    pub(super) fn add_next(&mut self, u: i8, v: i8, z: i16) {
        // Before the first halving every point is summed and the phase is not read (the
        // halving restarts it): it is counted from level 1 on only.
        if self.level != 0 {
            let phase = self.offered;
            self.offered = self.offered.saturating_add(1);
            let mask = (1_u32 << self.level) - 1;
            if u32::from(phase) & mask != 0 {
                return;
            }
        }
        // The signed 14-bit range.
        let dz = crate::saturate::to_signed_bits::<DZ_BITS>(i32::from(z) - i32::from(self.z0));
        let (u, v) = (i32::from(u), i32::from(v));
        // At most 61 points are summed before this one (n < 62: the sums are halved at 62;
        // at the last level at most two more points follow the halving to 31), each with
        // |u|, |v| ≤ 32 and |dz| ≤ 8192, so the sums stay within their widths without
        // saturating: |Σu| ≤ 62·32 < 2¹⁵, Σuu ≤ 62·32² < 2¹⁶, |Σz| ≤ 62·8192, |Σuz| ≤ 62·32·8192,
        // Σzz ≤ 62·8192² < 2³² (plain wrapping adds, which never wrap; tested against the
        // saturating ones). Σuv alone can leave its i16 (62·32·32 > 2¹⁵ − 1) and saturates.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        {
            self.su_sv = self
                .su_sv
                .wrapping_add(((u as u32) << 16).wrapping_add(v as u32));
            self.suu_svv = self
                .suu_svv
                .wrapping_add((((u * u) as u32) << 16).wrapping_add((v * v) as u32));
            self.szz = self.szz.wrapping_add((dz * dz) as u32);
        }
        self.suv = crate::saturate::to_i16(i32::from(self.suv) + u * v);
        self.sz = self.sz.wrapping_add(dz);
        self.suz = self.suz.wrapping_add(u * dz);
        self.svz = self.svz.wrapping_add(v * dz);
        self.n += 1;
        if self.n >= HALVE_AT {
            self.halve();
        }
    }

    /// Halves every sum and the count, unless the level is [`MAX_LEVEL`] already (then
    /// nothing changes); from now on every 2^(level + 1)-th offered point is summed. Out of
    /// line: at most once per 31 summed points below the last level, and the per-point path
    /// keeps no value alive for it, not even the level.
    #[cold]
    #[inline(never)]
    fn halve(&mut self) {
        if self.level >= MAX_LEVEL {
            return;
        }
        self.n /= 2;
        self.set_linear(self.su() >> 1, self.sv() >> 1);
        self.set_squares(self.suu() >> 1, self.svv() >> 1);
        self.suv >>= 1;
        self.sz >>= 1;
        self.suz >>= 1;
        self.svz >>= 1;
        self.szz >>= 1;
        self.level += 1;
        // The next summed point is the 2^level-th from now.
        self.offered = 0;
    }

    /// Summed points.
    #[cfg(test)]
    pub(super) const fn count(&self) -> u8 {
        self.n
    }

    /// Σv: the low half of `su_sv`.
    #[allow(clippy::cast_possible_truncation)]
    pub(super) const fn sv(&self) -> i16 {
        self.su_sv as u16 as i16
    }

    /// Σu: `su_sv` less Σv (sign-extended), shifted down.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    pub(super) const fn su(&self) -> i16 {
        (self.su_sv.wrapping_sub(self.sv() as i32 as u32) >> 16) as u16 as i16
    }

    /// Σu²: the high half of `suu_svv`.
    #[allow(clippy::cast_possible_truncation)]
    pub(super) const fn suu(&self) -> u16 {
        (self.suu_svv >> 16) as u16
    }

    /// Σv²: the low half of `suu_svv`.
    #[allow(clippy::cast_possible_truncation)]
    pub(super) const fn svv(&self) -> u16 {
        self.suu_svv as u16
    }

    /// Sets Σu and Σv.
    #[allow(clippy::cast_sign_loss)]
    fn set_linear(&mut self, su: i16, sv: i16) {
        self.su_sv = ((su as u32) << 16).wrapping_add(sv as i32 as u32);
    }

    /// Sets Σu² and Σv².
    fn set_squares(&mut self, suu: u16, svv: u16) {
        self.suu_svv = (u32::from(suu) << 16) | u32::from(svv);
    }
}

/// The 6-bit position `⌊64·rem/c⌋ − 32 ∈ −32 ..= 31` of a coordinate whose remainder in its cell
/// is `rem` (raw Q16.16, `0 ≤ rem < c`), for a cell of `c` raw with reciprocal
/// `m = ⌊2³²/c⌋` ([`crate::grid::cell_reciprocal`]): `⌊rem·m/2²⁶⌋`, at most one unit below the
/// exact value.
///
/// In 32 bits: `rem·m ≤ (c − 1)·2³²/c < 2³²`, so the product of two `u32` cannot wrap and the
/// result is that of the 64-bit product (a library call on a Cortex-M0); tested against it. The
/// caller gives the remainder as the wrapped difference `x − ⌊x/c⌋·c`, which is exact because
/// the true remainder fits. A remainder of `c` or more (never given) yields some position in
/// range, never a panic.
#[inline]
pub(super) fn sub_cell(rem: u32, reciprocal: u32) -> i8 {
    // A u32 shifted right by 26 is below 64.
    #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
    let q = (rem.wrapping_mul(reciprocal) >> 26) as i8;
    q - 32
}

#[cfg(feature = "plane-rule")]
/// The parameters of the plane decision in the units it computes in, from a
/// [`PlaneRule`] and the step threshold (at `configure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct PlaneParams {
    /// tan of the largest slope, Q16.
    grade_q16: i64,
    /// The residual allowance, mm Q16.
    residual_q16: i64,
    /// σ, mm Q16.
    sigma_q16: i64,
    /// σ_a, radians Q16.
    angle_q16: i64,
    /// k, Q16.
    factor_q16: i64,
    /// The step allowance, mm Q16.
    step_q16: i64,
    /// How many returns back the pair test looks ([`PlaneRule::pair_depth`], as given).
    pair_depth: u8,
    /// A spread (highest − lowest summed z) of at most this many mm is navigable without the
    /// plane: the residual's RMS is at most half the spread and the rise at most √3 times it,
    /// so both tests fail below `min(2·residual, step/√3)` (less a millimetre of rounding).
    quick_mm: i32,
}

#[cfg(feature = "plane-rule")]
/// Metres (raw Q16.16) to millimetres in Q16, `raw·1000`, never negative.
fn mm_q16(m: Meters) -> i64 {
    i64::from(m.to_bits()).max(0) * 1000
}

#[cfg(feature = "plane-rule")]
impl PlaneParams {
    /// [`PlaneParams::new`] of [`PlaneRule::DEFAULT`] and the default step threshold (0.05 m),
    /// computed at compile time.
    pub(super) const DEFAULT: Self = Self {
        grade_q16: DEFAULT_MAX_GRADE.to_bits() as i64,
        residual_q16: DEFAULT_RESIDUAL.to_bits() as i64 * 1000,
        sigma_q16: DEFAULT_RANGE_SIGMA.to_bits() as i64 * 1000,
        angle_q16: DEFAULT_ANGLE_SIGMA.to_bits() as i64,
        factor_q16: DEFAULT_NOISE_FACTOR.to_bits() as i64,
        step_q16: Meters::lit("0.05").to_bits() as i64 * 1000,
        pair_depth: PlaneRule::DEFAULT.pair_depth,
        // min(2·15, ⌊50·1000/1732⌋) − 1 = 27 mm.
        quick_mm: 27,
    };

    /// From the rule and the step threshold; negative values are taken as zero.
    pub(super) fn new(rule: &PlaneRule, step: Meters) -> Self {
        let residual_q16 = mm_q16(rule.residual);
        let step_q16 = mm_q16(step);
        let quick = (2 * residual_q16).min(step_q16 * 1000 / 1732) >> 16;
        Self {
            grade_q16: i64::from(rule.max_grade.to_bits()).max(0),
            residual_q16,
            sigma_q16: mm_q16(rule.range_sigma),
            angle_q16: i64::from(rule.angle_sigma.to_bits()).max(0),
            factor_q16: i64::from(rule.noise_factor.to_bits()).max(0),
            step_q16,
            pair_depth: rule.pair_depth,
            quick_mm: i32::try_from(quick - 1).unwrap_or(i32::MAX).max(-1),
        }
    }

    /// The pair test's constants for a layer of cell side `cell_bits` (raw Q16.16 metres):
    /// the step allowance in whole mm (floored, at most [`pair::PAIR_STEP_MAX_MM`]), the largest
    /// slope's rise per unit of position ([`pair_slope_q8`], mm Q8) and the pair depth.
    pub(super) fn pair_scale(&self, cell_bits: i32) -> PairScale {
        PairScale::new(
            u16::try_from((self.step_q16 >> 16).max(0)).unwrap_or(u16::MAX),
            pair_slope_q8(self.grade_q16, cell_bits),
        )
        .with_depth(self.pair_depth)
    }

    /// Whether a spread of `spread_mm` (the slot's highest − lowest summed z) is navigable
    /// whatever the plane ([`PlaneParams::quick_mm`]).
    pub(super) const fn flat_enough(&self, spread_mm: i32) -> bool {
        spread_mm <= self.quick_mm
    }
}

/// The geometry of one cell's judgement (read by the plane rule only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(not(feature = "plane-rule"), allow(dead_code))]
pub(super) struct CellGeometry {
    /// The cell's side, raw Q16.16 metres.
    pub(super) cell: i32,
    /// The sensor's height above the robot's ground plane, millimetres.
    pub(super) sensor_height_mm: i32,
    /// The cell's closest look, raw Q16.16 metres.
    pub(super) distance: Meters,
}

/// The plane rule's parameters in the classifier for `rule` with step threshold `step`:
/// `None` under the spread rule, and in a build without the `plane-rule` feature whatever the
/// rule.
pub(super) fn params_of(rule: &NavigabilityRule, step: Meters) -> Option<PlaneParams> {
    match rule {
        NavigabilityRule::Spread => None,
        #[cfg(feature = "plane-rule")]
        NavigabilityRule::Plane(rule) => Some(PlaneParams::new(rule, step)),
        #[cfg(not(feature = "plane-rule"))]
        NavigabilityRule::Plane(_) => {
            let _ = step;
            None
        }
    }
}

/// [`params_of`] the default rule and step threshold (0.05 m), at compile time.
#[cfg(feature = "plane-rule")]
pub(super) const DEFAULT_PARAMS: Option<PlaneParams> = Some(PlaneParams::DEFAULT);
/// [`params_of`] the default rule (the spread rule in this build), at compile time.
#[cfg(not(feature = "plane-rule"))]
pub(super) const DEFAULT_PARAMS: Option<PlaneParams> = None;

#[cfg(not(feature = "plane-rule"))]
pub(super) use absent::{plane_obstacle, PlaneParams, PlaneState};

/// The plane rule's state and decision in a build without the `plane-rule` feature: a
/// zero-sized state whose operations do nothing (a slot is 16 bytes), and parameters of which
/// no value exists, so the classifier's `Option<PlaneParams>` is always `None` and every plane
/// branch compiles away.
#[cfg(not(feature = "plane-rule"))]
mod absent {
    use super::CellGeometry;

    /// The plane rule's running sums of one slot, in a build without them: zero-sized.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(in crate::classify) struct PlaneState;

    impl PlaneState {
        /// No point.
        pub(in crate::classify) const EMPTY: Self = Self;

        /// Sums of one point: none kept.
        pub(in crate::classify) const fn first(_u: i8, _v: i8, _z: i16) -> Self {
            Self
        }

        /// Offers a point below the overhang cut: nothing is kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) fn add_next(&mut self, _u: i8, _v: i8, _z: i16) {}

        /// Where the lowest point lies: not kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) fn set_low_at(&mut self, _at: (i8, i8)) {}

        /// Where the highest point lies: not kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) fn set_high_at(&mut self, _at: (i8, i8)) {}

        /// Where the lowest point lies: nowhere kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) const fn low_at(&self) -> (i8, i8) {
            (0, 0)
        }

        /// The pair test's fold of a pair across the cell's edge: nothing is kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) fn keep_shown(&mut self, _shown: u8) {}

        /// The last return's position: not kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) const fn last_at(&self) -> (i8, i8) {
            (0, 0)
        }

        /// The pair test's largest step: none kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) const fn pair_rise(&self) -> u8 {
            0
        }

        /// The pair test's fold: nothing is kept.
        #[allow(clippy::unused_self)]
        pub(in crate::classify) fn step_from_last(
            &mut self,
            _u: i8,
            _v: i8,
            _z: i16,
            _scale: super::PairScale,
        ) {
        }
    }

    /// The plane rule's parameters, in a build without the rule: uninhabited.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(in crate::classify) enum PlaneParams {}

    impl PlaneParams {
        /// Never called: no value exists.
        pub(in crate::classify) fn flat_enough(&self, _spread_mm: i32) -> bool {
            match *self {}
        }

        /// Never called: no value exists.
        pub(in crate::classify) fn pair_scale(&self, _cell_bits: i32) -> super::PairScale {
            match *self {}
        }
    }

    /// Never called: no [`PlaneParams`] value exists.
    pub(in crate::classify) fn plane_obstacle(
        _state: &PlaneState,
        params: &PlaneParams,
        _geometry: &CellGeometry,
        _spread_mm: i32,
    ) -> bool {
        match *params {}
    }
}

#[cfg(test)]
#[cfg(feature = "plane-rule")]
mod tests;
