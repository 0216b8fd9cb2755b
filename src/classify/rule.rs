//! The navigability rule of one layer cell: its per-slot state, how a point folds into it, and
//! the decision (`docs/core.md`, "The navigability rule").
//!
//! Two rules, chosen by [`NavigabilityRule`] in [`super::ClassifierConfig`]:
//! - [`NavigabilityRule::Spread`], the paper's: the spread of the points below the overhang
//!   cut over the step threshold. State: the lowest and highest z (kept by every slot).
//! - [`NavigabilityRule::Plane`], the default (with the `plane-rule` feature): a least-squares plane per cell from running sums
//!   of the points below the overhang cut. Not navigable when the points stray from their
//!   plane by more than a residual allowance, or when the plane rises across the points'
//!   extent by more than the largest traversable slope and a step allow. The allowances grow
//!   with the sensor's height noise at the cell's distance,
//!   `σ_z(d) = √((σ·h/r)² + (σ_a·r)²)`, `r = √(h² + d²)`: the range noise σ along the beam and
//!   the beam's elevation error σ_a, each seen in the vertical.
//!
//! The plane rule is built in with the library's `plane-rule` feature (on by default). Without
//! it `PlaneState` is zero-sized (a classifier slot is 16 bytes instead of 48), the default
//! rule is the spread rule, and the classifier applies the spread rule whatever its
//! configuration asks ([`NavigabilityRule::is_built_in`]; the link refuses the plane rule).
//!
//! # Fixed point (`PlaneState`, 32 bytes a slot)
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
//! cell's closest look (the lower edge of its gate bin).

use crate::units::Meters;
use fixed::types::I16F16;

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
/// - the plane rises across the points' extent D by more than `step + D·max_grade +
///   a·√(12/n)`.
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
}

impl PlaneRule {
    /// The defaults: 20°, 1.5 cm, σ = 2 cm, σ_a = 0.075°, k = 2 (chosen by measurement,
    /// `host-tests/examples/terrain_rules.rs`).
    pub const DEFAULT: Self = Self {
        max_grade: DEFAULT_MAX_GRADE,
        residual: DEFAULT_RESIDUAL,
        range_sigma: DEFAULT_RANGE_SIGMA,
        angle_sigma: DEFAULT_ANGLE_SIGMA,
        noise_factor: DEFAULT_NOISE_FACTOR,
    };
}

impl Default for PlaneRule {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for PlaneRule {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "PlaneRule {{ max_grade: {=i32}, residual: {=i32}, range_sigma: {=i32}, angle_sigma: {=i32}, noise_factor: {=i32} }} (raw Q16.16)",
            self.max_grade.to_bits(),
            self.residual.to_bits(),
            self.range_sigma.to_bits(),
            self.angle_sigma.to_bits(),
            self.noise_factor.to_bits()
        );
    }
}

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
/// The plane rule's running sums of one slot. 32 bytes.
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
    };

    /// Sums of the one point `(u, v, z)`.
    pub(super) fn first(u: i8, v: i8, z: i16) -> Self {
        let mut s = Self::EMPTY;
        s.z0 = z;
        s.add_next(u, v, z);
        s
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
            quick_mm: i32::try_from(quick - 1).unwrap_or(i32::MAX).max(-1),
        }
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

#[cfg(feature = "plane-rule")]
/// `√x` through 64 bits: exact (`⌊√x⌋`) when `x` fits them, else `⌊√(x/4ˢ)⌋·2ˢ` with the
/// smallest s that makes `x/4ˢ` fit (at most 2ˢ below `⌊√x⌋`, a relative error under 2⁻³¹).
fn isqrt(x: u128) -> u128 {
    match u64::try_from(x) {
        Ok(small) => u128::from(small.isqrt()),
        Err(_) => {
            let s = (128 - x.leading_zeros() - 63) / 2;
            let scaled = u64::try_from(x >> (2 * s)).unwrap_or(u64::MAX);
            u128::from(scaled.isqrt()) << s
        }
    }
}

#[cfg(feature = "plane-rule")]
/// `⌊√(12/n)·2¹⁶⌋` for n = 0 ..= [`HALVE_AT`] (0 at n = 0), computed at compile time.
const ROOT_12_OVER_N: [u32; HALVE_AT as usize + 1] = {
    let mut table = [0_u32; HALVE_AT as usize + 1];
    let mut n = 1;
    while n <= HALVE_AT as usize {
        // ⌊√(12·2³²/n)⌋ by bisection (below 2²²).
        let x = (12_u64 << 32) / n as u64;
        let (mut lo, mut hi) = (0_u64, 1_u64 << 22);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid * mid <= x {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Evaluated at compile time: an index out of range would fail the build, not panic.
        #[allow(clippy::cast_possible_truncation, clippy::indexing_slicing)]
        {
            table[n] = lo as u32;
        }
        n += 1;
    }
    table
};

#[cfg(feature = "plane-rule")]
/// The noise allowance `k·σ_z(d)`, mm Q16.
fn noise_q16(params: &PlaneParams, geometry: &CellGeometry) -> i64 {
    noise_q16_narrow(params, geometry).unwrap_or_else(|| noise_q16_wide(params, geometry))
}

#[cfg(feature = "plane-rule")]
/// [`noise_q16`] in 64 bits, or `None` where a value would not fit them (σ·h or σ_a·r of 2⁶³
/// or more, or σ_z's terms of 2³¹ mm Q16 or more: with the default rule only beyond 24 km).
/// h < 2³¹ and d < 2²⁵ mm, so `h² + d² < 2⁶³` and `r < 2³²`; terms below 2³¹ keep their
/// squares' sum below 2⁶³. The same integers as [`noise_q16_wide`] (tested).
fn noise_q16_narrow(params: &PlaneParams, geometry: &CellGeometry) -> Option<i64> {
    let h = i64::from(geometry.sensor_height_mm.max(0));
    let d = (i64::from(geometry.distance.to_bits()).max(0) * 1000) >> 16;
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let r = ((h * h + d * d) as u64).isqrt() as i64;
    let range = if r == 0 {
        params.sigma_q16
    } else {
        params.sigma_q16.checked_mul(h)? / r
    };
    let angle = params.angle_q16.checked_mul(r)?;
    if range >= 1 << 31 || angle >= 1 << 31 {
        return None;
    }
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let sigma_z = ((range * range + angle * angle) as u64).isqrt() as i64;
    sigma_z.checked_mul(params.factor_q16).map(|v| v >> 16)
}

#[cfg(feature = "plane-rule")]
/// [`noise_q16`] in 128 bits, saturating.
fn noise_q16_wide(params: &PlaneParams, geometry: &CellGeometry) -> i64 {
    let h = i128::from(geometry.sensor_height_mm.max(0));
    let d = (i128::from(geometry.distance.to_bits()).max(0) * 1000) >> 16;
    // r = √(h² + d²), mm.
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let r = isqrt((h * h + d * d) as u128) as i128;
    // The range noise seen in the vertical, σ·h/r (σ itself at r = 0), and the elevation
    // error's, σ_a·r; mm Q16. σ·h/r in 64 bits when σ·h fits them (any σ below 32 km).
    let range = if r == 0 {
        i128::from(params.sigma_q16)
    } else {
        let product = i128::from(params.sigma_q16) * h;
        match (i64::try_from(product), i64::try_from(r)) {
            (Ok(p), Ok(r)) => i128::from(p / r),
            _ => product / r,
        }
    };
    let angle = i128::from(params.angle_q16).saturating_mul(r);
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let sigma_z = isqrt(
        range
            .saturating_mul(range)
            .saturating_add(angle.saturating_mul(angle)) as u128,
    ) as i128;
    ((sigma_z * i128::from(params.factor_q16)) >> 16)
        .clamp(0, i128::from(i64::MAX))
        .try_into()
        .unwrap_or(i64::MAX)
}

#[cfg(feature = "plane-rule")]
/// `⌊num·2¹⁶/den⌉` towards zero, for `den > 0`: in 64-bit divisions when `num` and `den` fit
/// 64 bits (always for the plane's sums: |num| < 2⁵⁴, den < 2⁴⁵): one division of `num·2¹⁶`
/// when |num| < 2⁴⁷ (most cells), else the integer quotient and the quotient of the remainder
/// times 2¹⁶ (< 2⁶¹); in 128 bits otherwise.
fn q16_quotient(num: i128, den: i128) -> i128 {
    match (i64::try_from(num), i64::try_from(den)) {
        (Ok(n), Ok(d)) if d > 0 && d < (1_i64 << 46) => {
            if n.unsigned_abs() < 1 << 47 {
                // num·2¹⁶ fits 64 bits: one division, of the magnitudes ([`crate::wide::div_u64`],
                // in `udiv`s on ARMv7-M), the quotient's sign restored (towards zero, as
                // `i64` division rounds).
                #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
                let q = crate::wide::div_u64(n.unsigned_abs() << 16, d as u64) as i64;
                return i128::from(if n < 0 { -q } else { q });
            }
            let (q, r) = (n / d, n % d);
            (i128::from(q) << 16) + i128::from((r << 16) / d)
        }
        _ => (num << 16) / den,
    }
}

#[cfg(feature = "plane-rule")]
/// The centred moments of a cell's sums times n² (u, v in units of c/64; z in mm).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Moments {
    /// The summed points, 0 ..= 62.
    n: i32,
    /// n·Σuu − (Σu)², within ±2²².
    cuu: i32,
    /// n·Σvv − (Σv)², within ±2²².
    cvv: i32,
    /// n·Σuv − Σu·Σv, within ±2²².
    cuv: i32,
    /// n·Σuz − Σu·Σz, below 2³¹ in magnitude.
    cuz: i32,
    /// n·Σvz − Σv·Σz, below 2³¹ in magnitude.
    cvz: i32,
    /// n·Σzz − (Σz)², below 2³⁹ in magnitude.
    czz: i64,
}

#[cfg(feature = "plane-rule")]
/// [`Moments`] of `state` in 32-bit words where they fit (their products `muls`, not a 64-bit
/// library call, on a Cortex-M0). With n ≤ 62 and |u|, |v| ≤ 32, |dz| ≤ 8192 per summed point
/// (a halving keeps the bounds: |Σu| ≤ 32n, Σuu ≤ 1024n, |Σuz| ≤ 32·8192·n, …; |Σuv| ≤ 2¹⁵
/// saturated): the moments of u and v lie within ±2²², |C_uz|, |C_vz| ≤ 2·62²·32·8192 < 2³¹,
/// and C_zz = n·Σzz − (Σz)² from two 64-bit products ([`crate::wide`]). Wrapping operations:
/// sums outside their bounds (never made) give wrong moments, not a panic. Tested against the
/// 128-bit moments.
fn moments(state: &PlaneState) -> Moments {
    let n = i32::from(state.n);
    let (su, sv) = (i32::from(state.su()), i32::from(state.sv()));
    let sz = state.sz;
    let moment = |nsum: i32, a: i32, b: i32| nsum.wrapping_sub(a.wrapping_mul(b));
    #[allow(clippy::cast_possible_wrap, clippy::cast_sign_loss)]
    let czz = (crate::wide::umul(n as u32, state.szz) as i64)
        .wrapping_sub(crate::wide::square(sz) as i64);
    Moments {
        n,
        cuu: moment(n.wrapping_mul(i32::from(state.suu())), su, su),
        cvv: moment(n.wrapping_mul(i32::from(state.svv())), sv, sv),
        cuv: moment(n.wrapping_mul(i32::from(state.suv)), su, sv),
        cuz: moment(n.wrapping_mul(state.suz), su, sz),
        cvz: moment(n.wrapping_mul(state.svz), sv, sz),
        czz,
    }
}

#[cfg(feature = "plane-rule")]
/// wᵀCw and the residual `C_zz·2³² − 2·wᵀc·2¹⁶ + wᵀCw` (both times n², Q32 mm²) for the plane
/// `w = (wa, wb)` (mm per unit, Q16) in 64-bit words, where they surely fit them: |wa|, |wb|
/// below 2¹⁹ and |C_zz| below 2²⁹ (a plane of gradient below 8 mm per unit, z spread within
/// metres), and the partial results within the bounds below; `None` otherwise (the caller
/// computes in 128 bits). The same integers as the 128-bit computation (tested).
fn residual_narrow(wa: i128, wb: i128, m: &Moments) -> Option<(i64, i64)> {
    const W: u32 = 1 << 19;
    let (wa, wb) = (i32::try_from(wa).ok()?, i32::try_from(wb).ok()?);
    if wa.unsigned_abs() >= W || wb.unsigned_abs() >= W || m.czz.unsigned_abs() >= 1 << 29 {
        return None;
    }
    let product = crate::wide::smul;
    // Squares and products of w below 2³⁸, the moments of u and v within ±2²²: the terms
    // below 2⁶⁰, 2⁶¹ and 2⁶⁰. |C_uz|, |C_vz| < 2³¹: wᵀc below 2⁵¹.
    let explained = product(wa, wa) * i64::from(m.cuu)
        + 2 * product(wa, wb) * i64::from(m.cuv)
        + product(wb, wb) * i64::from(m.cvv);
    let wc = product(wa, m.cuz) + product(wb, m.cvz);
    if explained.unsigned_abs() >= 1 << 61 || wc.unsigned_abs() >= 1 << 44 {
        return None;
    }
    // Three terms below 2⁶¹ each: the sum below 2⁶³.
    Some((explained, (m.czz << 32) - 2 * (wc << 16) + explained))
}

#[cfg(feature = "plane-rule")]
/// `x²` as `i128`, saturating: from a 32 × 32 → 64-bit square when |x| < 2³¹.
fn square_saturating(x: i64) -> i128 {
    match i32::try_from(x) {
        Ok(x) => i128::from(crate::wide::square(x)),
        Err(_) => i128::from(x).saturating_mul(i128::from(x)),
    }
}

#[cfg(feature = "plane-rule")]
/// `a·n2` saturating, for `n2 = n²` with n ≤ 62: in 64 bits when `0 ≤ a < 2⁵¹` (the product
/// below 2⁶³).
fn times_n2(a: i128, n2: i32) -> i128 {
    match i64::try_from(a) {
        Ok(a) if (0..1 << 51).contains(&a) && (0..=62 * 62).contains(&n2) => {
            i128::from(a * i64::from(n2))
        }
        _ => a.saturating_mul(i128::from(n2)),
    }
}

#[cfg(feature = "plane-rule")]
/// `⌊tan·c⌋` in mm Q16 for the largest slope `grade_q16` (tan, Q16, ≥ 0) and the cell side
/// `cell` (raw Q16.16 metres; taken as at least 1): `⌊grade·c·1000 / 2¹⁶⌋` exactly, in 64-bit
/// words (`grade·c` below 2⁶², split at 2¹⁶ so that the product with 1 000 fits).
fn tan_times_cell(grade_q16: i64, cell: i32) -> i64 {
    let grade = u32::try_from(grade_q16.max(0)).unwrap_or(u32::MAX);
    let cell = cell.max(1).unsigned_abs();
    let gc = crate::wide::umul(grade, cell);
    // gc = h·2¹⁶ + l: ⌊gc·1000 / 2¹⁶⌋ = h·1000 + ⌊l·1000 / 2¹⁶⌋, h·1000 below 2⁵⁶.
    #[allow(clippy::cast_possible_wrap)]
    let t = ((gc >> 16) * 1000 + (((gc & 0xFFFF) * 1000) >> 16)) as i64;
    t
}

#[cfg(feature = "plane-rule")]
/// Whether the gradient `⌊√(wa² + wb²)⌋` (mm per unit, Q16) is surely not steeper than the
/// largest slope, `64·⌊√(wa² + wb²)⌋ ≤ tan_c` (mm Q16), decided without the root: exactly
/// when `wa² + wb² < (⌊tan_c / 64⌋ + 1)²`, in 64-bit words where the squares fit them (|wa|,
/// |wb| below 2³¹ and the bound below 2³²; most cells). `false` also where they do not (the
/// caller takes the root).
fn not_steeper(wa: i128, wb: i128, tan_c: i128) -> bool {
    match (
        i32::try_from(wa),
        i32::try_from(wb),
        u32::try_from((tan_c >> 6) + 1),
    ) {
        // Squares below 2⁶² each: the sum fits a u64.
        (Ok(a), Ok(b), Ok(bound)) => {
            crate::wide::square(a) + crate::wide::square(b) < crate::wide::umul(bound, bound)
        }
        _ => false,
    }
}

#[cfg(feature = "plane-rule")]
/// Whether the plane rule calls the cell of `state` not navigable: two to four 64-bit
/// divisions (the plane), up to two integer square roots (the gradient, the rise), and the
/// noise (one division, two roots) only for a cell whose residual exceeds the allowance
/// without noise or that is steeper than the largest slope.
pub(super) fn plane_obstacle(
    state: &PlaneState,
    params: &PlaneParams,
    geometry: &CellGeometry,
) -> bool {
    if state.n < 2 {
        return false;
    }
    let m = moments(state);
    let Moments {
        n,
        cuu,
        cvv,
        cuv,
        cuz,
        cvz,
        czz,
    } = m;
    // The ridge λ = 1 unit², times n²; the determinant and the plane's numerators from
    // 32 × 32 → 64-bit products: |det| < 2⁴⁷, the numerators < 2⁵⁵. The rest in 128 bits.
    let n2 = n * n;
    let (a, b) = (cuu + n2, cvv + n2);
    let product = crate::wide::smul;
    let det = product(a, b) - product(cuv, cuv);
    if det <= 0 {
        return false;
    }
    // w = (C + λI)⁻¹ c, mm per unit, Q16.
    let wa = q16_quotient(
        i128::from(product(b, cuz) - product(cuv, cvz)),
        i128::from(det),
    );
    let wb = q16_quotient(
        i128::from(product(a, cvz) - product(cuv, cuz)),
        i128::from(det),
    );
    // wᵀCw and the residual, times n² (Q32 mm²).
    let (explained, residual) = match residual_narrow(wa, wb, &m) {
        Some((explained, residual)) => (i128::from(explained), i128::from(residual)),
        None => {
            let (cuu, cvv, cuv) = (i128::from(cuu), i128::from(cvv), i128::from(cuv));
            let (cuz, cvz, czz) = (i128::from(cuz), i128::from(cvz), i128::from(czz));
            let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
            // wᵀc, Q16 mm² times n².
            let wc = wa * cuz + wb * cvz;
            (explained, (czz << 32) - 2 * (wc << 16) + explained)
        }
    };
    // Saturating where extreme configurations (σ or k in the thousands) could overflow.
    let quiet = square_saturating(params.residual_q16);
    // The noise (two roots and a division) only where a decision needs it: a residual within
    // the allowance without noise is within it with noise (the saturating sums only grow).
    let mut noise = None;
    if residual > times_n2(quiet, n2) {
        let sigma = noise_q16(params, geometry);
        let allowed = quiet.saturating_add(square_saturating(sigma));
        if residual > times_n2(allowed, n2) {
            return true;
        }
        noise = Some(i128::from(sigma));
    }
    let n = i128::from(n);
    // The gradient G = |w| (mm per unit, Q16), g = 64·G/c: steeper than the largest slope
    // when 64·G > tan·c (c in mm; both sides mm, Q16), with G = ⌊√(wa² + wb²)⌋.
    let tan_c = i128::from(tan_times_cell(params.grade_q16, geometry.cell));
    if not_steeper(wa, wb, tan_c) {
        return false;
    }
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let slope = isqrt((wa * wa + wb * wb) as u128) as i128;
    let steep = 64 * slope - tan_c;
    if steep <= 0 {
        return false;
    }
    // The rise times n, R·n = √(12·wᵀCw·n²) (mm, Q16). R·(g − tan) > g·(step + a·√(12/n)),
    // times n·c/64: R·n·(64·G − tan·c) > 64·G·n·(step + a·√(12/n)).
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let rise_n = isqrt((12 * explained.max(0)) as u128) as i128;
    let root = ROOT_12_OVER_N
        .get(usize::from(state.n))
        .map_or(0, |&r| i128::from(r));
    let noise = noise.unwrap_or_else(|| i128::from(noise_q16(params, geometry)));
    let allowance = i128::from(params.step_q16).saturating_add(noise.saturating_mul(root) >> 16);
    rise_n.saturating_mul(steep) > (64 * slope * n).saturating_mul(allowance)
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
    }

    /// The plane rule's parameters, in a build without the rule: uninhabited.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub(in crate::classify) enum PlaneParams {}

    impl PlaneParams {
        /// Never called: no value exists.
        pub(in crate::classify) fn flat_enough(&self, _spread_mm: i32) -> bool {
            match *self {}
        }
    }

    /// Never called: no [`PlaneParams`] value exists.
    pub(in crate::classify) fn plane_obstacle(
        _state: &PlaneState,
        params: &PlaneParams,
        _geometry: &CellGeometry,
    ) -> bool {
        match *params {}
    }
}

#[cfg(test)]
#[cfg(feature = "plane-rule")]
mod tests {
    use super::*;
    use crate::test_rng::XorShift;
    extern crate std;

    fn geometry(cell_m: f32) -> CellGeometry {
        CellGeometry {
            cell: Meters::from_num(cell_m).to_bits(),
            sensor_height_mm: 1000,
            distance: Meters::from_num(5),
        }
    }

    fn params(sigma: f32) -> PlaneParams {
        PlaneParams::new(
            &PlaneRule {
                range_sigma: Meters::from_num(sigma),
                angle_sigma: Ratio::ZERO,
                ..PlaneRule::DEFAULT
            },
            Meters::from_num(0.05),
        )
    }

    /// The sums of points on a lattice of the cell, height `f(u, v)` mm.
    fn lattice(f: impl Fn(i32, i32) -> i32) -> PlaneState {
        let mut s = PlaneState::EMPTY;
        for i in 0..7 {
            for j in 0..7 {
                let (u, v) = (-30 + 10 * i, -30 + 10 * j);
                s.add(
                    i8::try_from(u).unwrap(),
                    i8::try_from(v).unwrap(),
                    i16::try_from(f(u, v)).unwrap(),
                );
            }
        }
        s
    }

    #[test]
    fn a_slope_below_the_limit_is_navigable_and_a_step_is_not() {
        // A 1 m cell: a unit is 1/64 m = 15.6 mm.
        let g = geometry(1.0);
        let p = params(0.0);
        // 10°: 2.76 mm per unit.
        let slope = lattice(|u, v| (f64::from(u + v) * 15.625 * 0.176).round() as i32);
        assert!(!plane_obstacle(&slope, &p, &g));
        // 30°: steeper than 20°, rising 0.58 m across the cell.
        let steep = lattice(|u, _| (f64::from(u) * 15.625 * 0.577).round() as i32);
        assert!(plane_obstacle(&steep, &p, &g));
        // A 10 cm step across the middle: RMS 2.4 cm about the best plane.
        let step = lattice(|u, _| if u > 0 { 100 } else { 0 });
        assert!(plane_obstacle(&step, &p, &g));
        // 1 cm of texture: within the residual allowance.
        let texture = lattice(|u, v| if (u + v) % 20 == 0 { 10 } else { -10 });
        assert!(!plane_obstacle(&texture, &p, &g));
    }

    #[test]
    fn noise_widens_the_allowance() {
        let g = geometry(1.0);
        // ±25 mm of alternating "noise": RMS 25 mm, over 1.5 cm.
        let noisy = lattice(|u, v| if (u / 10 + v / 10) % 2 == 0 { 25 } else { -25 });
        assert!(plane_obstacle(&noisy, &params(0.0), &g));
        // σ = 2 cm at 5 m from a sensor 1 m up: σ_z = 3.9 mm; k = 2 → √(15² + 7.8²) = 17 mm.
        assert!(plane_obstacle(&noisy, &params(0.02), &g));
        // σ = 10 cm: σ_z = 19.6 mm, allowance √(15² + 39²) = 42 mm.
        assert!(!plane_obstacle(&noisy, &params(0.10), &g));
    }

    #[test]
    fn a_single_point_or_a_vertical_line_of_points() {
        let g = geometry(0.1);
        let p = params(0.0);
        assert!(!plane_obstacle(&PlaneState::first(3, 4, 100), &p, &g));
        // A post: points at one (u, v), 0 … 300 mm: no slope fits, the residual is the spread.
        let mut post = PlaneState::EMPTY;
        for z in 0..30 {
            post.add(5, 5, z * 10);
        }
        assert!(plane_obstacle(&post, &p, &g));
    }

    #[test]
    fn at_the_last_level_halving_changes_nothing() {
        let mut s = PlaneState::EMPTY;
        for i in 0..HALVE_AT {
            s.add_next(i8::try_from(i % 64).unwrap() - 32, 3, 100);
        }
        // The first halving happened at 62 summed points.
        assert_eq!((s.n, s.level), (HALVE_AT / 2, 1));
        s.level = MAX_LEVEL;
        s.n = HALVE_AT;
        let before = s;
        s.halve();
        assert_eq!(s, before);
        s.level = MAX_LEVEL - 1;
        s.halve();
        assert_eq!(
            (s.n, s.level, s.su()),
            (HALVE_AT / 2, MAX_LEVEL, before.su() >> 1)
        );
    }

    #[test]
    fn halving_keeps_the_sums_within_their_widths_and_the_decision() {
        let g = geometry(2.0);
        let p = params(0.0);
        let mut flat = PlaneState::EMPTY;
        let mut step = PlaneState::EMPTY;
        for i in 0..60_000_u32 {
            let u = i8::try_from((i * 7) % 64).unwrap() - 32;
            let v = i8::try_from((i * 13) % 64).unwrap() - 32;
            flat.add(u, v, i16::try_from((i * 31) % 9).unwrap());
            step.add(u, v, if u > 0 { 8191 } else { -8192 });
        }
        assert!(flat.count() < HALVE_AT && flat.level > 5);
        assert!(!plane_obstacle(&flat, &p, &g));
        assert!(plane_obstacle(&step, &p, &g));
        assert!(step.szz <= 62 * 8192 * 8192);
    }

    #[test]
    fn the_elevation_error_widens_the_allowance_with_range() {
        let with_angle = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
        let at = |d: f32| CellGeometry {
            cell: Meters::from_num(1).to_bits(),
            sensor_height_mm: 1300,
            distance: Meters::from_num(d),
        };
        // k·σ_z at 3 m: √((20·1.3/3.27)² + (1.309e-3·3270)²) = 9.0 mm, times 2; at 20 m:
        // √(1.3² + 26.2²) = 26.3 mm, times 2.
        let mm = |v: i64| v as f64 / 65_536.0;
        assert!((mm(noise_q16(&with_angle, &at(3.0))) - 18.0).abs() < 0.2);
        assert!((mm(noise_q16(&with_angle, &at(20.0))) - 52.5).abs() < 0.3);
    }

    #[test]
    fn the_quick_bound_is_the_default_and_never_hides_an_obstacle() {
        assert_eq!(
            PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05)),
            PlaneParams::DEFAULT
        );
        // Cells whose spread is at the bound: no plane through them is an obstacle, whatever
        // their layout, with no noise allowance at all.
        let p = params(0.0);
        let g = geometry(0.1);
        let top = i16::try_from(p.quick_mm).unwrap();
        let mut state = 0x9E37_79B9_u32;
        for _ in 0..2000 {
            let mut s = PlaneState::EMPTY;
            for _ in 0..(2 + state % 40) {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                let u = i8::try_from(state % 64).unwrap() - 32;
                let v = i8::try_from((state >> 8) % 64).unwrap() - 32;
                let z = if (state >> 16).is_multiple_of(2) {
                    0
                } else {
                    top
                };
                s.add(u, v, z);
            }
            assert!(!plane_obstacle(&s, &p, &g));
        }
    }

    /// [`plane_obstacle`] as it was, in 128 bits from the start.
    fn plane_obstacle_128(
        state: &PlaneState,
        params: &PlaneParams,
        geometry: &CellGeometry,
    ) -> bool {
        let n = i128::from(state.n);
        if n < 2 {
            return false;
        }
        let (su, sv) = (i128::from(state.su()), i128::from(state.sv()));
        let sz = i128::from(state.sz);
        let cuu = n * i128::from(state.suu()) - su * su;
        let cvv = n * i128::from(state.svv()) - sv * sv;
        let cuv = n * i128::from(state.suv) - su * sv;
        let cuz = n * i128::from(state.suz) - su * sz;
        let cvz = n * i128::from(state.svz) - sv * sz;
        let czz = n * i128::from(state.szz) - sz * sz;
        let n2 = n * n;
        let (a, b) = (cuu + n2, cvv + n2);
        let det = a * b - cuv * cuv;
        if det <= 0 {
            return false;
        }
        let wa = q16_quotient(b * cuz - cuv * cvz, det);
        let wb = q16_quotient(a * cvz - cuv * cuz, det);
        let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
        let wc = wa * cuz + wb * cvz;
        let residual = (czz << 32) - 2 * (wc << 16) + explained;
        let noise = i128::from(noise_q16(params, geometry));
        let allowed = i128::from(params.residual_q16)
            .saturating_mul(i128::from(params.residual_q16))
            .saturating_add(noise.saturating_mul(noise));
        if residual > allowed.saturating_mul(n2) {
            return true;
        }
        let slope = isqrt((wa * wa + wb * wb) as u128) as i128;
        let cell_mm_q16 = i128::from(geometry.cell.max(1)) * 1000;
        let steep = 64 * slope - ((i128::from(params.grade_q16) * cell_mm_q16) >> 16);
        if steep <= 0 {
            return false;
        }
        let rise_n = isqrt((12 * explained.max(0)) as u128) as i128;
        let root = ROOT_12_OVER_N
            .get(usize::from(state.n))
            .map_or(0, |&r| i128::from(r));
        let allowance =
            i128::from(params.step_q16).saturating_add(noise.saturating_mul(root) >> 16);
        rise_n.saturating_mul(steep) > (64 * slope * n).saturating_mul(allowance)
    }

    #[test]
    fn the_decision_in_64_bits_first_is_the_128_bit_one() {
        let mut rng = XorShift(0xD1B5_4A32_D192_ED03_u64);
        let mut next = || rng.next();
        let mut obstacles = 0;
        let total = 20_000;
        for run in 0..total {
            // Cells of 2 to 3000 points: at the corners and extreme heights (the sums' bounds),
            // planes with noise, steps, random clouds; under rules from strict to lax.
            let mut s = PlaneState::EMPTY;
            let points = 2 + next() % if run % 10 == 0 { 3000 } else { 80 };
            let kind = next() % 4;
            let (gu, gv, off) = ((next() % 200) as i32 - 100, (next() % 200) as i32 - 100, 0);
            for _ in 0..points {
                let r = next();
                let (u, v) = ((r % 64) as i8 - 32, ((r >> 8) % 64) as i8 - 32);
                let z = match kind {
                    0 => {
                        let c = [-32_i8, 31][(r >> 20) as usize % 2];
                        s.add(c, c, [i16::MIN, i16::MAX, 0][(r >> 24) as usize % 3]);
                        continue;
                    }
                    1 => {
                        off + gu * i32::from(u) / 10 + gv * i32::from(v) / 10 + (r >> 40) as i32 % 9
                    }
                    2 => (if u > 0 { 300 } else { 0 }) + (r >> 40) as i32 % 5,
                    _ => (r >> 32) as i16 as i32 / 4,
                };
                s.add(u, v, z.clamp(-32_768, 32_767) as i16);
            }
            let params = PlaneParams::new(
                &PlaneRule {
                    max_grade: Ratio::from_bits((next() % 80_000) as i32),
                    residual: Meters::from_bits((next() % 3000) as i32),
                    range_sigma: Meters::from_bits((next() % 3000) as i32),
                    ..PlaneRule::DEFAULT
                },
                Meters::from_bits((next() % 10_000) as i32),
            );
            let geometry = CellGeometry {
                cell: Meters::from_num(0.1).to_bits() << (next() % 8),
                sensor_height_mm: (next() % 2000) as i32,
                distance: Meters::from_bits((next() % (30 << 16)) as i32),
            };
            let got = plane_obstacle(&s, &params, &geometry);
            assert_eq!(got, plane_obstacle_128(&s, &params, &geometry), "run {run}");
            obstacles += usize::from(got);
        }
        // Both answers occur.
        assert!(
            obstacles > total / 20 && obstacles < total * 19 / 20,
            "{obstacles}"
        );
    }

    #[test]
    fn the_slope_bound_in_64_bits_is_the_root_comparison() {
        // tan·c against the 128-bit product, at the extremes and at random.
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let edges = [0_i64, 1, 2, 0xFFFF, 0x1_0000, 0x7FFF_FFFF];
        let cells = [
            i32::MIN,
            -1,
            0,
            1,
            655,
            6_554,
            0xFFFF,
            0x1_0000,
            1 << 29,
            i32::MAX,
        ];
        let mut pairs: std::vec::Vec<(i64, i32)> = edges
            .iter()
            .flat_map(|&g| cells.iter().map(move |&c| (g, c)))
            .collect();
        for _ in 0..100_000 {
            let g = (rng.next() >> (33 + rng.next() % 31)) as i64;
            let c = (rng.next() >> (32 + rng.next() % 32)) as u32 as i32;
            pairs.push((g, c));
        }
        for (grade, cell) in pairs {
            let expected = (i128::from(grade) * i128::from(cell.max(1)) * 1000) >> 16;
            assert_eq!(
                i128::from(tan_times_cell(grade, cell)),
                expected,
                "{grade} {cell}"
            );
        }
        // "Not steeper" exactly when 64·⌊√(wa² + wb²)⌋ ≤ tan·c, wherever it decides; next to
        // the bound (the squares of the bound ± 2) and at random.
        let root_says =
            |wa: i128, wb: i128, t: i128| 64 * isqrt((wa * wa + wb * wb) as u128) as i128 <= t;
        let mut decided = 0;
        for _ in 0..200_000 {
            let t = i128::from((rng.next() >> (24 + rng.next() % 40)) as i64);
            let m = (t >> 6) + 1;
            let (wa, wb) = if rng.next().is_multiple_of(2) {
                // wa² + wb² within a few of m² (wb small).
                let wb = (rng.next() % 8) as i128;
                let target = m * m - wb * wb + (rng.next() % 5) as i128 - 2;
                let wa = isqrt(target.max(0) as u128) as i128;
                (wa, wb)
            } else {
                let w = |r: u64| {
                    (r >> (30 + r % 34)) as i64 as i128 * if r.is_multiple_of(3) { -1 } else { 1 }
                };
                (w(rng.next()), w(rng.next()))
            };
            let fast = not_steeper(wa, wb, t);
            if fast {
                decided += 1;
                assert!(root_says(wa, wb, t), "{wa} {wb} {t}");
            } else if i32::try_from(wa).is_ok()
                && i32::try_from(wb).is_ok()
                && u32::try_from(m).is_ok()
            {
                assert!(!root_says(wa, wb, t), "{wa} {wb} {t}");
            }
        }
        assert!(decided > 20_000, "{decided}");
    }

    #[test]
    fn the_moments_in_32_bits_are_the_128_bit_moments() {
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
        let mut next = || rng.next();
        let mut widest = (0_i128, 0_i128);
        for run in 0..20_000 {
            // Up to 3000 points: the extreme corners and heights in opposite pairs (the
            // largest moments), or random ones.
            let mut s = PlaneState::EMPTY;
            let extreme = run % 2 == 0;
            for i in 0..(1 + next() % if run % 10 == 0 { 3000 } else { 70 }) {
                let r = next();
                let (u, v, z) = if extreme {
                    let high = (i + r % 2) % 2 == 0;
                    let (c, z) = if high { (31, 8191) } else { (-32, -8192) };
                    let flip = (r >> 8) % 4 == 0;
                    (c, if flip { -1 - c } else { c }, if i == 0 { 0 } else { z })
                } else {
                    let (u, v) = ((r % 64) as i8 - 32, ((r >> 8) % 64) as i8 - 32);
                    (u, v, (r >> 32) as i16)
                };
                s.add(u, v, z);
            }
            let m = moments(&s);
            let n = i128::from(s.n);
            let (su, sv, sz) = (i128::from(s.su()), i128::from(s.sv()), i128::from(s.sz));
            let cuz = n * i128::from(s.suz) - su * sz;
            let cvz = n * i128::from(s.svz) - sv * sz;
            assert_eq!(i128::from(m.n), n);
            assert_eq!(
                i128::from(m.cuu),
                n * i128::from(s.suu()) - su * su,
                "run {run}"
            );
            assert_eq!(
                i128::from(m.cvv),
                n * i128::from(s.svv()) - sv * sv,
                "run {run}"
            );
            assert_eq!(
                i128::from(m.cuv),
                n * i128::from(s.suv) - su * sv,
                "run {run}"
            );
            assert_eq!(i128::from(m.cuz), cuz, "run {run}");
            assert_eq!(i128::from(m.cvz), cvz, "run {run}");
            assert_eq!(
                i128::from(m.czz),
                n * i128::from(s.szz) - sz * sz,
                "run {run}"
            );
            widest = (widest.0.max(cuz.abs()), widest.1.max(i128::from(m.czz)));
        }
        // The extremes are reached: C_uz near its largest, C_zz beyond 32 bits.
        assert!(widest.0 > 1 << 29, "{widest:?}");
        assert!(widest.1 > 1 << 33, "{widest:?}");
    }

    #[test]
    fn the_residual_in_64_bits_is_the_128_bit_residual() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let mut next = || rng.next();
        let (mut narrow, mut wide) = (0, 0);
        for run in 0..200_000 {
            // Moments within their bounds (extremes one run in four), planes from flat to
            // beyond the narrow range.
            let extreme = run % 4 == 0;
            let mut within = |bits: u32| {
                let r = next();
                let magnitude = if extreme {
                    (1_i64 << bits) - 1 - (r % 4) as i64
                } else {
                    (r >> 8) as i64 % (1 << (r % u64::from(bits + 1)))
                };
                if r & 1 == 0 {
                    magnitude
                } else {
                    -magnitude
                }
            };
            let m = Moments {
                n: 62,
                cuu: within(22) as i32,
                cvv: within(22) as i32,
                cuv: within(22) as i32,
                cuz: within(31) as i32,
                cvz: within(31) as i32,
                czz: within(if run % 3 == 0 { 39 } else { 30 }),
            };
            let mut plane = || {
                let r = next();
                let magnitude = ((r >> 8) % (1 << (r % 24))) as i128;
                if r & 1 == 0 {
                    magnitude
                } else {
                    -magnitude
                }
            };
            let (wa, wb) = (plane(), plane());
            let (cuu, cvv, cuv) = (i128::from(m.cuu), i128::from(m.cvv), i128::from(m.cuv));
            let (cuz, cvz, czz) = (i128::from(m.cuz), i128::from(m.cvz), i128::from(m.czz));
            let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
            let residual = (czz << 32) - 2 * ((wa * cuz + wb * cvz) << 16) + explained;
            match residual_narrow(wa, wb, &m) {
                Some((e, r)) => {
                    assert_eq!(
                        (i128::from(e), i128::from(r)),
                        (explained, residual),
                        "{run}"
                    );
                    narrow += 1;
                }
                None => wide += 1,
            }
        }
        // Both paths taken, each about half the time.
        assert!(narrow > 50_000 && wide > 50_000, "{narrow} {wide}");
        for x in [
            0,
            1,
            -1,
            i64::from(i32::MAX),
            i64::from(i32::MIN),
            1 << 31,
            i64::MIN,
        ] {
            let square = i128::from(x).saturating_mul(i128::from(x));
            assert_eq!(square_saturating(x), square, "{x}");
            for n in [0, 1, 2, 61, 62] {
                for a in [square, (1 << 51) - 1, 1 << 51, i128::MAX, -5] {
                    assert_eq!(times_n2(a, n * n), a.saturating_mul(i128::from(n * n)));
                }
            }
        }
    }

    #[test]
    fn the_noise_in_64_bits_is_the_128_bit_noise() {
        let mut rng = XorShift(0x6A09_E667_F3BC_C908_u64);
        let mut next = || rng.next();
        let mut narrow = 0;
        let pick = |next: &mut dyn FnMut() -> u64| -> i32 {
            // Zero, small, typical and extreme raw values.
            match next() % 4 {
                0 => [0, 1, i32::MAX, i32::MIN][(next() % 4) as usize],
                1 => (next() % 5000) as i32,
                _ => (next() as i32) >> (next() % 31),
            }
        };
        for _ in 0..200_000 {
            let rule = PlaneRule {
                range_sigma: Meters::from_bits(pick(&mut next)),
                angle_sigma: Ratio::from_bits(pick(&mut next)),
                noise_factor: Ratio::from_bits(pick(&mut next)),
                ..PlaneRule::DEFAULT
            };
            let params = PlaneParams::new(&rule, Meters::from_num(0.05));
            let geometry = CellGeometry {
                cell: Meters::from_num(0.1).to_bits(),
                sensor_height_mm: pick(&mut next),
                distance: Meters::from_bits(pick(&mut next)),
            };
            let wide = noise_q16_wide(&params, &geometry);
            if let Some(v) = noise_q16_narrow(&params, &geometry) {
                narrow += 1;
                assert_eq!(v, wide, "{rule:?} {geometry:?}");
            }
            assert_eq!(noise_q16(&params, &geometry), wide);
        }
        assert!(narrow > 50_000, "{narrow}");
        let default = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
        for h in [0, 300, 1300, 32_767] {
            for d in [0.0, 0.5, 3.0, 20.0, 20_000.0] {
                let g = CellGeometry {
                    cell: Meters::from_num(0.1).to_bits(),
                    sensor_height_mm: h,
                    distance: Meters::from_num(d),
                };
                assert!(noise_q16_narrow(&default, &g).is_some(), "{h} {d}");
            }
        }
    }

    #[test]
    fn the_q16_quotient_is_the_128_bit_one() {
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
        let mut next = || rng.next();
        for _ in 0..100_000 {
            let num = i128::from((next() as i64) >> (next() % 60));
            let den = i128::from((next() >> (20 + next() % 40)).max(1) as i64);
            assert_eq!(q16_quotient(num, den), (num << 16) / den, "{num} / {den}");
        }
        assert_eq!(
            q16_quotient(i128::MAX >> 17, 3),
            (i128::MAX >> 17 << 16) / 3
        );
    }

    #[test]
    fn the_root_table_is_the_square_root_of_12_over_n() {
        for (n, &root) in ROOT_12_OVER_N.iter().enumerate().skip(1) {
            let exact = (12.0 / n as f64).sqrt() * 65_536.0;
            assert!((f64::from(root) - exact).abs() <= 1.0, "{n}");
        }
        assert_eq!(isqrt(u128::from(u64::MAX) + 1), 1 << 32);
        assert_eq!(isqrt(99), 9);
        for x in [1_u128 << 70, (1 << 100) + 12_345, u128::MAX, 3 << 90] {
            let (got, exact) = (isqrt(x), x.isqrt());
            assert!(
                got <= exact && exact - got <= exact >> 31,
                "{x}: {got} {exact}"
            );
        }
    }

    /// [`PlaneState::add`] as it was before its sums stopped saturating (and while it counted
    /// the decimation's phase before the first halving).
    fn add_saturating(s: &mut PlaneState, u: i8, v: i8, z: i16) {
        let satu16 = |v: i32| u16::try_from(v.max(0)).unwrap_or(u16::MAX);
        let phase = s.offered;
        s.offered = s.offered.saturating_add(1);
        if u32::from(phase) & ((1_u32 << s.level) - 1) != 0 {
            return;
        }
        if s.n == 0 {
            s.z0 = z;
        }
        let dz = (i32::from(z) - i32::from(s.z0)).clamp(-8192, 8191);
        let (u, v) = (i32::from(u), i32::from(v));
        s.set_linear(
            crate::saturate::to_i16(i32::from(s.su()) + u),
            crate::saturate::to_i16(i32::from(s.sv()) + v),
        );
        s.set_squares(
            satu16(i32::from(s.suu()) + u * u),
            satu16(i32::from(s.svv()) + v * v),
        );
        s.suv = crate::saturate::to_i16(i32::from(s.suv) + u * v);
        s.sz = s.sz.saturating_add(dz);
        s.suz = s.suz.saturating_add(u * dz);
        s.svz = s.svz.saturating_add(v * dz);
        s.szz = s.szz.saturating_add((dz * dz) as u32);
        s.n += 1;
        // The halving itself did not change.
        if s.n >= HALVE_AT && s.level < MAX_LEVEL {
            s.halve();
        }
    }

    #[test]
    fn the_sums_without_saturation_are_the_saturating_sums() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let mut next = || rng.next();
        // Runs at the extremes (corners ±32/31, z at ±32 767 and far from z₀), runs with the
        // signs alternating, random runs, and runs long enough to reach the last level.
        for run in 0..400_u32 {
            let mut s = PlaneState::EMPTY;
            let mut reference = PlaneState::EMPTY;
            let length = if run % 200 == 0 {
                2_200_000
            } else {
                1 + next() % 5000
            };
            let kind = next() % 4;
            for i in 0..length {
                let r = next();
                let (u, v, z) = match kind {
                    0 => {
                        let corner = [-32_i8, 31][(r & 1) as usize];
                        let z = [i16::MIN, i16::MAX, 0, -8192, 8191, -8193][(r >> 1) as usize % 6];
                        (corner, corner, z)
                    }
                    1 => {
                        let sign = if i % 2 == 0 { -32_i8 } else { 31 };
                        (sign, -32, if i % 3 == 0 { i16::MAX } else { i16::MIN })
                    }
                    2 => (-32, -32, (r >> 8) as i16),
                    _ => (
                        (r % 64) as i8 - 32,
                        ((r >> 8) % 64) as i8 - 32,
                        (r >> 16) as i16,
                    ),
                };
                s.add(u, v, z);
                add_saturating(&mut reference, u, v, z);
                // The reference counts the phase before the first halving too, unread there.
                let phase = if reference.level == 0 {
                    0
                } else {
                    reference.offered
                };
                assert_eq!(
                    s,
                    PlaneState {
                        offered: phase,
                        ..reference
                    },
                    "run {run} point {i}"
                );
            }
            if length > 2_000_000 {
                // As deep as the decimation goes: its phase saturates at 2¹⁶ − 1 offered
                // points, which at level 12 come before the 31 summed points that would halve.
                assert_eq!(s.level, 12);
            }
        }
    }

    /// The position as it was computed before: a 64-bit product, clamped.
    fn sub_cell_64(rem: i64, reciprocal: u32) -> i8 {
        let rem = rem.clamp(0, i64::from(u32::MAX)) as u64;
        let q = (rem * u64::from(reciprocal)) >> 26;
        q.min(63) as i8 - 32
    }

    #[test]
    fn sub_cell_in_32_bits_is_the_64_bit_product() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let mut next = || rng.next();
        // Every cell size of the default designs' layers and their neighbours, sizes from
        // 1 raw up to 2³⁰, and random sizes; each at its edges and random remainders.
        let mut sizes = std::vec![1, 2, 3, 655, 6553, 6554, 6555, 13_107, 26_214, 52_429];
        sizes.extend([
            104_858,
            209_715,
            419_430,
            838_861,
            65_536,
            1 << 20,
            (1 << 30) - 1,
        ]);
        sizes.extend([1 << 30, i32::MAX]);
        for _ in 0..300 {
            sizes.push(1 + (next() % (1 << (1 + next() % 30))) as i32);
        }
        for c in sizes {
            let m = crate::grid::cell_reciprocal(c);
            let edges = (0..64_i64).flat_map(|j| {
                let at = j * i64::from(c) / 64;
                [at - 1, at, at + 1]
            });
            let random = (0..200).map(|_| (next() % c as u64) as i64);
            for rem in edges.chain(random).chain([i64::from(c) - 1]) {
                if !(0..i64::from(c)).contains(&rem) {
                    continue;
                }
                assert_eq!(
                    sub_cell(rem as u32, m),
                    sub_cell_64(rem, m),
                    "c {c} rem {rem}"
                );
            }
        }
    }

    #[test]
    fn sub_cell_positions_cover_the_cell() {
        let c = Meters::from_num(0.3).to_bits();
        let m = crate::grid::cell_reciprocal(c);
        assert_eq!(sub_cell(0, m), -32);
        assert_eq!(sub_cell(c as u32 - 1, m), 31);
        assert!((-1..=0).contains(&sub_cell(c as u32 / 2, m)));
        // Every remainder lands within one unit of the exact value.
        for rem in (0..c).step_by(97) {
            let exact = (i64::from(rem) * 64 / i64::from(c)) as i8 - 32;
            let got = sub_cell(rem as u32, m);
            assert!(got == exact || got == exact - 1, "{rem}: {got} {exact}");
        }
    }
}
