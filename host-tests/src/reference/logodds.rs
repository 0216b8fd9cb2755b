//! The log-odds recursion of eq. 6 with gating, clamping and the "observed" rule.
//!
//! `L_T = logit p(x) + Σ_t w_k(d_t)·[logit p(x|z_t) − logit p(x)]` (eq. 6, gated), one cell at
//! a time, in one of two arithmetics:
//! - [`Arithmetic::Ideal`]: everything in `f64` — the exact increments `l = logit p(x|z) −
//!   logit p(x)`, the exact `L_0 = logit p(x)`, the unrounded binned gate weight, the clamping
//!   bounds as given. An update whose gated increment |w·l| is below half a Q8.8 step (2⁻⁹)
//!   does not observe the cell and adds nothing. Under clamping an update carries the cell
//!   toward its sign no further than `w·c`, c the bound on that side, and leaves a cell already
//!   beyond it where it is. The value saturates at the Q8.8 format's range (±32 767/256) like
//!   the device's, so that "clamping off" means the same thing.
//!   Each cell also carries a bound on how far a spec-conforming fixed-point cell can have
//!   drifted from it (see [`Cell::budget`]).
//! - [`Arithmetic::Quantised`]: the rules of `docs/core.md` ("One update") taken literally —
//!   increments, `L_0` and clamping bounds rounded to Q8.8 (ties away from zero), the weight
//!   rounded to Q1.15, `g = floor((l·w + 2¹⁴)/2¹⁵)`, `g = 0` does nothing, saturation to
//!   ±32 767 raw, the reach `floor((c·w + 2¹⁴)/2¹⁵)` of the bound c on g's side. The values
//!   are held in `f64` but are exact multiples of 2⁻⁸. Where a table entry a conforming `f32`-built table may hold differs from the reference's
//!   rounding and that changes g, the cell's budget grows by the difference (see
//!   [`super::gate::GateWeight`]).

use super::gate::{GateWeight, WEIGHT_ONE_RAW};

/// One Q8.8 step (one unit in the last place of a log-odds), nats.
pub const ULP: f64 = 1.0 / 256.0;
/// Half a Q8.8 step: the smallest |w·l| that observes a cell in the ideal arithmetic.
pub const HALF_ULP: f64 = 1.0 / 512.0;
/// The largest stored log-odds, raw (the format's range; `i16::MIN` means unknown).
pub const MAX_RAW: i32 = 32_767;
/// The largest stored log-odds, nats.
pub const MAX_NATS: f64 = MAX_RAW as f64 / 256.0;

/// `ln(p / (1 − p))`.
#[must_use]
pub fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// `round(x·2⁸)` with ties away from zero, saturated to ±32 767: a value in Q8.8, raw.
#[must_use]
pub fn q88(x: f64) -> i32 {
    let r = (x * 256.0).round();
    r.clamp(-f64::from(MAX_RAW), f64::from(MAX_RAW)) as i32
}

/// The inverse sensor model: p(x|z) for each classification, and the prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InverseModel {
    /// p(x|z) when the cell looked non-navigable.
    pub p_obstacle: f64,
    /// p(x|z) when the cell looked navigable.
    pub p_free: f64,
    /// p(x).
    pub prior: f64,
}

impl Default for InverseModel {
    /// 0.7, 0.4, 0.5 (`docs/core.md`).
    fn default() -> Self {
        Self {
            p_obstacle: 0.7,
            p_free: 0.4,
            prior: 0.5,
        }
    }
}

impl InverseModel {
    /// Each probability in [0.001, 0.999], `p_free < prior < p_obstacle`, and neither
    /// increment rounds to 0 in Q8.8, i.e. `|l| ≥ 2⁻⁹` (`docs/core.md`). A configuration is
    /// given in `f32`, so the bounds are the `f32` values nearest 0.001 and 0.999.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let open = |p: f64| p >= f64::from(0.001_f32) && p <= f64::from(0.999_f32);
        let half_step = 1.0 / 512.0;
        open(self.p_obstacle)
            && open(self.p_free)
            && open(self.prior)
            && self.p_free < self.prior
            && self.prior < self.p_obstacle
            && self.l_obs() >= half_step
            && self.l_free() <= -half_step
    }

    /// `l_obs = logit(p_obstacle) − logit(prior)`.
    #[must_use]
    pub fn l_obs(&self) -> f64 {
        logit(self.p_obstacle) - logit(self.prior)
    }

    /// `l_free = logit(p_free) − logit(prior)`.
    #[must_use]
    pub fn l_free(&self) -> f64 {
        logit(self.p_free) - logit(self.prior)
    }

    /// `L_0 = logit(prior)`.
    #[must_use]
    pub fn l0(&self) -> f64 {
        logit(self.prior)
    }

    /// `(l_obs, l_free, L_0)` rounded to Q8.8, raw.
    #[must_use]
    pub fn quantised(&self) -> (i32, i32, i32) {
        (q88(self.l_obs()), q88(self.l_free()), q88(self.l0()))
    }
}

/// Clamping of a cell's log-odds after each update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Clamp {
    /// Only the format saturates (the paper's baseline).
    Off,
    /// `L ← min(max(L, min), max)`, nats, and an update of gate weight w carries the cell
    /// toward its sign no further than `w·min` (free) or `w·max` (obstacle).
    Bounds {
        /// c_min.
        min: f64,
        /// c_max.
        max: f64,
    },
}

impl Clamp {
    /// The default: `c_min = −2.0`, `c_max = 3.5` nats.
    pub const DEFAULT: Self = Self::Bounds {
        min: -2.0,
        max: 3.5,
    };
}

/// Which arithmetic a model computes in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arithmetic {
    /// Exact `f64` (the truth the fixed-point library approximates).
    Ideal,
    /// The quantisation rules of `docs/core.md`, computed exactly.
    Quantised,
}

/// The class of a cell (`docs/core.md`, "A cell's class").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Class {
    /// Never observed.
    Unknown,
    /// Observed with L = 0 exactly.
    Undecided,
    /// Observed, L > 0.
    Obstacle,
    /// Observed, L < 0.
    Navigable,
}

/// One cell of the reference.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cell {
    /// The log-odds, nats; `None` while unknown.
    pub value: Option<f64>,
    /// Ideal arithmetic only: a bound, nats, on |L_fixed − L| for a fixed-point cell that
    /// follows `docs/core.md` and received the same updates (0 in the quantised arithmetic).
    /// Each update adds the rounding it can cause; clamping never widens it beyond the
    /// distance between the ideal and the rounded clamping bounds (min and max are
    /// non-expansive).
    pub budget: f64,
    /// Ideal arithmetic only: some update observed the cell with a margin that the fixed-point
    /// rounding cannot erase, so a conforming fixed-point cell is observed too.
    pub surely_observed: bool,
    /// Ideal arithmetic only: some update's |w·l| lay so close to 2⁻⁹ that a conforming
    /// fixed-point cell may have been observed by it (or not) where this one was not (or was).
    pub threshold_case: bool,
}

impl Cell {
    /// The class of the cell.
    #[must_use]
    pub fn class(&self) -> Class {
        match self.value {
            None => Class::Unknown,
            Some(l) if l > 0.0 => Class::Obstacle,
            Some(l) if l < 0.0 => Class::Navigable,
            Some(_) => Class::Undecided,
        }
    }

    /// Is the cell observed?
    #[must_use]
    pub fn is_observed(&self) -> bool {
        self.value.is_some()
    }
}

/// The per-cell update rule: increments, clamping and arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model {
    /// The arithmetic.
    pub arithmetic: Arithmetic,
    /// The inverse sensor model.
    pub inverse: InverseModel,
    /// Clamping.
    pub clamp: Clamp,
}

impl Model {
    /// The clamping bounds in Q8.8, raw, as the quantised arithmetic uses them.
    #[must_use]
    pub fn clamp_raw(&self) -> Option<(i32, i32)> {
        match self.clamp {
            Clamp::Off => None,
            Clamp::Bounds { min, max } => Some((q88(min), q88(max))),
        }
    }

    /// How far the rounded clamping bounds lie from the ideal ones, nats.
    fn clamp_rounding(&self) -> f64 {
        match self.clamp {
            Clamp::Off => 0.0,
            Clamp::Bounds { min, max } => {
                let (qmin, qmax) = (q88(min), q88(max));
                (min - f64::from(qmin) * ULP)
                    .abs()
                    .max((max - f64::from(qmax) * ULP).abs())
            }
        }
    }

    /// Applies one piece of evidence to `cell`: `obstacle` selects `l_obs` or `l_free`, `w` is
    /// the table entry (the binned `f64` gate, its Q1.15 rounding, and the range of entries a
    /// conforming `f32`-built table may hold instead).
    ///
    /// Returns whether the update observed (touched) the cell.
    pub fn update(&self, cell: &mut Cell, obstacle: bool, w: GateWeight) -> bool {
        match self.arithmetic {
            Arithmetic::Quantised => self.update_quantised(cell, obstacle, w),
            Arithmetic::Ideal => self.update_ideal(cell, obstacle, w),
        }
    }

    /// The raw increment `l` (Q8.8) for a class.
    fn l_raw(&self, obstacle: bool) -> i64 {
        let (l_obs, l_free, _) = self.inverse.quantised();
        i64::from(if obstacle { l_obs } else { l_free })
    }

    /// Would a conforming device apply this update at all, for every entry it may hold?
    /// `Some(true)`: surely; `Some(false)`: surely not; `None`: it depends on the entry.
    #[must_use]
    pub fn applies(&self, obstacle: bool, w: GateWeight) -> Option<bool> {
        let l = self.l_raw(obstacle);
        let (a, b) = (gated(l, w.raw_lo), gated(l, w.raw_hi));
        match (a != 0, b != 0) {
            (true, true) => Some(true),
            (false, false) => Some(false),
            _ => None,
        }
    }

    fn update_quantised(&self, cell: &mut Cell, obstacle: bool, w: GateWeight) -> bool {
        let (_, _, l0) = self.inverse.quantised();
        let l = self.l_raw(obstacle);
        let g = gated(l, w.raw);
        // g is monotone in w: the entries a device may hold give g between these two.
        let (ga, gb) = (gated(l, w.raw_lo), gated(l, w.raw_hi));
        let spread = (ga - gb).unsigned_abs().max((g - ga).unsigned_abs());
        let zero_is_possible = ga == 0 || gb == 0 || g == 0;
        let surely = ga != 0 && gb != 0 && g != 0;
        if surely {
            cell.surely_observed = true;
        }
        if zero_is_possible && !(ga == 0 && gb == 0 && g == 0) {
            cell.threshold_case = true;
        }
        cell.budget += spread as f64 * ULP;
        if g == 0 {
            return false;
        }
        let current = cell.value.map_or(i64::from(l0), |v| (v * 256.0) as i64);
        let mut next = (current + g).clamp(-i64::from(MAX_RAW), i64::from(MAX_RAW));
        if let Some((lo, hi)) = self.clamp_raw() {
            // The bound on g's side, scaled by the same weight and rounded the same way.
            let c = i64::from(if g < 0 { lo } else { hi });
            let reach = gated(c, w.raw);
            let (ra, rb) = (gated(c, w.raw_lo), gated(c, w.raw_hi));
            let reach_spread = (ra - rb).unsigned_abs().max((reach - ra).unsigned_abs());
            // max(a, min(b, r)) moves by no more than the most any of a, b, r moves.
            cell.budget = cell.budget.max(reach_spread as f64 * ULP);
            next = if g < 0 {
                next.max(current.min(reach))
            } else {
                next.min(current.max(reach))
            };
            next = next.max(i64::from(lo)).min(i64::from(hi));
        }
        cell.value = Some(next as f64 * ULP);
        true
    }

    fn update_ideal(&self, cell: &mut Cell, obstacle: bool, w: GateWeight) -> bool {
        let inv = &self.inverse;
        let (_, _, q_l0) = inv.quantised();
        let l = if obstacle { inv.l_obs() } else { inv.l_free() };
        let l_q = self.l_raw(obstacle) as f64 * ULP;
        let increment = w.exact * l;
        // max |l_q·w_dev − l·w| over the entries w_dev a conforming device may hold.
        let one = f64::from(WEIGHT_ONE_RAW);
        let margin = [w.raw_lo, w.raw_hi, w.raw]
            .iter()
            .map(|&r| (l_q * f64::from(r) / one - increment).abs())
            .fold(0.0, f64::max);
        let step = if increment.abs() > HALF_ULP + margin {
            cell.surely_observed = true;
            Some(margin + HALF_ULP)
        } else if increment.abs() < HALF_ULP - margin {
            None
        } else {
            cell.threshold_case = true;
            Some(margin + ULP)
        };
        if let Some(e) = step {
            if cell.budget == 0.0 && !cell.is_observed() {
                cell.budget = (inv.l0() - f64::from(q_l0) * ULP).abs();
            }
            cell.budget = (cell.budget + e).max(self.clamp_rounding());
        }
        if increment.abs() < HALF_ULP {
            return false;
        }
        let current = cell.value.unwrap_or_else(|| inv.l0());
        let mut next = (current + increment).clamp(-MAX_NATS, MAX_NATS);
        if let Clamp::Bounds { min, max } = self.clamp {
            // How far a layer may believe what it saw at this weight: the bound on the
            // increment's side, scaled by the weight.
            let c = if increment < 0.0 { min } else { max };
            let reach = w.exact * c;
            // A device rounds c to Q8.8, uses its table's entry and rounds the product to
            // the nearest raw step: within half a step of c_q·w_dev.
            let c_q = f64::from(q88(c)) * ULP;
            let reach_error = [w.raw_lo, w.raw_hi, w.raw]
                .iter()
                .map(|&r| (c_q * f64::from(r) / one - reach).abs())
                .fold(0.0, f64::max)
                + HALF_ULP;
            cell.budget = cell.budget.max(reach_error);
            next = if increment < 0.0 {
                next.max(current.min(reach))
            } else {
                next.min(current.max(reach))
            };
            next = next.max(min).min(max);
        }
        cell.value = Some(next);
        true
    }
}

/// The gated increment of `docs/core.md`: `floor((l·w + 2¹⁴)/2¹⁵)` (round half up), exact.
#[must_use]
pub fn gated(l_raw: i64, w_raw: u32) -> i64 {
    (l_raw * i64::from(w_raw) + (1 << 14)).div_euclid(1 << 15)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gw(exact: f64, raw: u32) -> GateWeight {
        GateWeight {
            exact,
            raw,
            raw_lo: raw,
            raw_hi: raw,
        }
    }

    #[test]
    fn default_increments_match_the_spec() {
        let m = InverseModel::default();
        assert!((m.l_obs() - 0.8473).abs() < 1e-4);
        assert!((m.l_free() + 0.4055).abs() < 1e-4);
        assert_eq!(m.quantised(), (217, -104, 0));
    }

    #[test]
    fn q88_rounds_ties_away_from_zero() {
        assert_eq!(q88(0.5 / 256.0), 1);
        assert_eq!(q88(-0.5 / 256.0), -1);
        assert_eq!(q88(1.49 / 256.0), 1);
        assert_eq!(q88(1e9), MAX_RAW);
        assert_eq!(q88(-1e9), -MAX_RAW);
    }

    #[test]
    fn quantised_gated_increment_rounds_half_up() {
        let model = Model {
            arithmetic: Arithmetic::Quantised,
            inverse: InverseModel::default(),
            clamp: Clamp::Off,
        };
        // l_free = −104 raw; w = 16 384/32 768 = ½: g = floor((−52·2¹⁵ + 2¹⁴)/2¹⁵) = −52.
        let mut c = Cell::default();
        assert!(model.update(&mut c, false, gw(0.5, 16_384)));
        assert_eq!(c.value, Some(-52.0 / 256.0));
        // l_obs = 217 raw, w = 1 raw: 217 + 16 384 < 32 768 → g = 0: nothing happens.
        let mut c = Cell::default();
        assert!(!model.update(&mut c, true, gw(0.0, 1)));
        assert_eq!(c.class(), Class::Unknown);
        // w = 76 raw: 217·76 = 16 492 ≥ 16 384 → g = 1.
        assert!(model.update(&mut c, true, gw(0.0, 76)));
        assert_eq!(c.value, Some(1.0 / 256.0));
        // l_free·w = −104·157 = −16 328 → floor((−16 328 + 16 384)/32 768) = 0.
        let mut c = Cell::default();
        assert!(!model.update(&mut c, false, gw(0.0, 157)));
    }

    #[test]
    fn clamping_and_saturation() {
        let mut model = Model {
            arithmetic: Arithmetic::Quantised,
            inverse: InverseModel::default(),
            clamp: Clamp::DEFAULT,
        };
        let mut c = Cell::default();
        for _ in 0..100 {
            model.update(&mut c, true, gw(1.0, 32_768));
        }
        assert_eq!(c.value, Some(3.5));
        model.clamp = Clamp::Off;
        for _ in 0..200 {
            model.update(&mut c, true, gw(1.0, 32_768));
        }
        assert_eq!(c.value, Some(MAX_NATS));
        model.arithmetic = Arithmetic::Ideal;
        let mut c = Cell::default();
        for _ in 0..400 {
            model.update(&mut c, false, gw(1.0, 32_768));
        }
        assert_eq!(c.value, Some(-MAX_NATS));
    }

    #[test]
    fn ideal_observed_rule_is_half_a_step() {
        let model = Model {
            arithmetic: Arithmetic::Ideal,
            inverse: InverseModel::default(),
            clamp: Clamp::Off,
        };
        let l = InverseModel::default().l_obs();
        let mut c = Cell::default();
        assert!(!model.update(&mut c, true, gw(0.99 * HALF_ULP / l, 0)));
        assert_eq!(c.class(), Class::Unknown);
        assert!(model.update(&mut c, true, gw(1.01 * HALF_ULP / l, 1)));
        assert_eq!(c.class(), Class::Obstacle);
        assert!(c.threshold_case);
    }
}
