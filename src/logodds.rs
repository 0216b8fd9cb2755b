//! Fixed-point log-odds: the cell type, the inverse sensor model as increments, clamping.
//!
//! A cell holds `L = log(p / (1 − p))` of "not navigable" in signed Q8.8 nats
//! ([`LogOddsFixed`]), or the explicit **unknown** state, which is distinct from "observed,
//! L = 0". Updates saturate (nothing wraps) and may be clamped to OctoMap-style bounds.
//! See `docs/core.md` for the exact rules.

use crate::design::{DesignError, Param};
use crate::fmath;
use crate::units::{LogOddsFixed, Weight};
use core::fmt;

/// The raw value reserved for "unknown".
const UNKNOWN_RAW: i16 = i16::MIN;
/// The largest magnitude a stored log-odds may have, raw Q8.8 (127.996 nats).
const STORED_MAX_RAW: i16 = i16::MAX;

/// One grid cell: a log-odds value in Q8.8 nats, or unknown. Two bytes.
///
/// Its raw value ([`Cell::to_raw`], as exported over the link) is the Q8.8 log-odds, with
/// `i16::MIN` for unknown; every observed value lies in −32 767 ..= +32 767 raw
/// (±127.996 nats). In memory the raw value is stored with its sign bit flipped, so that an
/// unknown cell is all zero bits: a fresh pyramid is zero-initialised (it lives in `.bss`,
/// costing no flash) and resetting cells is a plain zero fill.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
#[repr(transparent)]
pub struct Cell(u16);

/// The stored form of a raw value: the sign bit flipped.
#[inline]
const fn encode(raw: i16) -> u16 {
    (raw as u16) ^ 0x8000
}

/// The raw value of a stored form.
#[inline]
const fn decode(stored: u16) -> i16 {
    (stored ^ 0x8000) as i16
}

/// What a cell says about its place.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CellClass {
    /// Never observed.
    Unknown,
    /// Observed, and the evidence cancels exactly (L = 0).
    Undecided,
    /// Observed with L > 0: not navigable.
    Obstacle,
    /// Observed with L < 0: navigable.
    Navigable,
}

impl Cell {
    /// The state of a cell that has never been observed (all zero bits in memory).
    pub const UNKNOWN: Self = Self(0);

    /// An observed cell holding `value` (never unknown: the reserved raw value maps to the
    /// smallest stored value).
    #[must_use]
    pub const fn observed(value: LogOddsFixed) -> Self {
        let raw = value.to_bits();
        Self(encode(if raw == UNKNOWN_RAW {
            -STORED_MAX_RAW
        } else {
            raw
        }))
    }

    /// The raw 16-bit representation (`i16::MIN` = unknown), as exported over the link.
    #[must_use]
    pub const fn to_raw(self) -> i16 {
        decode(self.0)
    }

    /// The cell whose raw representation is `raw` (`i16::MIN` = unknown).
    #[must_use]
    pub const fn from_raw(raw: i16) -> Self {
        Self(encode(raw))
    }

    /// Whether the cell has received at least one non-zero increment since it entered the
    /// window.
    #[must_use]
    pub const fn is_observed(self) -> bool {
        self.0 != 0
    }

    /// The log-odds value, or `None` when unknown.
    #[must_use]
    pub const fn log_odds(self) -> Option<LogOddsFixed> {
        if self.is_observed() {
            Some(LogOddsFixed::from_bits(decode(self.0)))
        } else {
            None
        }
    }

    /// The class of the cell: unknown, undecided (L = 0), obstacle (L > 0), navigable (L < 0).
    #[must_use]
    pub const fn class(self) -> CellClass {
        match decode(self.0) {
            UNKNOWN_RAW => CellClass::Unknown,
            0 => CellClass::Undecided,
            v if v > 0 => CellClass::Obstacle,
            _ => CellClass::Navigable,
        }
    }

    /// Adds a gated increment `g` (raw Q8.8) of full weight: [`Cell::updated_by`] with
    /// [`GatedIncrement::unbounded`]. Zero leaves the cell untouched (it does not become
    /// observed); otherwise an unknown cell first takes `initial`, the sum saturates at
    /// ±127.996 nats, and `clamp` applies.
    #[must_use]
    #[inline]
    pub fn updated(self, g: i16, initial: LogOddsFixed, clamp: Clamp) -> Self {
        self.updated_by(GatedIncrement::unbounded(g), initial, clamp)
    }

    /// Applies one record's [`GatedIncrement`]: its increment `g` (raw Q8.8), carrying the cell
    /// toward `g`'s sign no further than `increment.reach` (a cell already beyond it keeps its
    /// value). Zero leaves the cell untouched (it does not become observed); otherwise an
    /// unknown cell first takes `initial`, the sum saturates at ±127.996 nats, and `clamp`
    /// applies.
    #[must_use]
    #[inline]
    pub fn updated_by(
        self,
        increment: GatedIncrement,
        initial: LogOddsFixed,
        clamp: Clamp,
    ) -> Self {
        let g = increment.g;
        if g == 0 {
            return self;
        }
        let start = if self.is_observed() {
            decode(self.0)
        } else {
            initial.to_bits()
        };
        let sum = start.saturating_add(g).max(-STORED_MAX_RAW);
        let reached = if g < 0 {
            sum.max(start.min(increment.reach))
        } else {
            sum.min(start.max(increment.reach))
        };
        Self(encode(clamp.apply_raw(reached)))
    }
}

/// What one evidence record does to a cell: its gated increment, and how far toward the
/// increment's sign it may carry the cell (`docs/core.md`, "One update").
///
/// Under clamping the reach is the bound on that side scaled by the record's gate weight,
/// `round(c·w)`: a layer never believes more of what it saw at a distance than its gate trusts
/// it with there, however often it looks. With weight 1 (the hard gate, the flat grid) the
/// reach is the bound itself, and the rule is OctoMap's clamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GatedIncrement {
    /// The gated increment, raw Q8.8 (0: the record changes nothing).
    pub g: i16,
    /// The farthest value, raw Q8.8, the record may carry the cell to in `g`'s direction:
    /// −32 767 ..= 0 when `g < 0`, 0 ..= 32 767 when `g > 0`.
    pub reach: i16,
}

impl GatedIncrement {
    /// The increment `g` (raw Q8.8) with no reach but the format's (±127.996 nats).
    #[must_use]
    pub const fn unbounded(g: i16) -> Self {
        Self {
            g,
            reach: if g < 0 {
                -STORED_MAX_RAW
            } else {
                STORED_MAX_RAW
            },
        }
    }
}

impl Default for Cell {
    fn default() -> Self {
        Self::UNKNOWN
    }
}

impl fmt::Debug for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.log_odds() {
            Some(v) => write!(f, "Cell({v})"),
            None => f.write_str("Cell(unknown)"),
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Cell {
    fn format(&self, f: defmt::Formatter<'_>) {
        if self.is_observed() {
            defmt::write!(f, "Cell({=i16} raw Q8.8)", decode(self.0));
        } else {
            defmt::write!(f, "Cell(unknown)");
        }
    }
}

/// Clamping of stored log-odds, after OctoMap's `clamping_thres_min/max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clamp {
    /// No clamping: the paper's baseline. Only the format saturates, at ±127.996 nats.
    Off,
    /// Keep `min ≤ L ≤ max` (`min < 0 < max`), so that a cell can change its mind quickly.
    Bounds {
        /// The lower bound, nats (OctoMap default −2.0, p = 0.1192).
        min: LogOddsFixed,
        /// The upper bound, nats (OctoMap default 3.5, p = 0.971).
        max: LogOddsFixed,
    },
}

impl Clamp {
    /// OctoMap's default bounds, −2.0 ..= 3.5 nats.
    pub const OCTOMAP: Self = Self::Bounds {
        min: LogOddsFixed::lit("-2"),
        max: LogOddsFixed::lit("3.5"),
    };

    /// Builds bounds from nats, refusing non-finite values, `min ≥ 0` or `max ≤ 0`.
    ///
    /// # Errors
    /// [`DesignError::NotFinite`] or [`DesignError::OutOfRange`] naming the bound.
    pub fn bounds(min: f32, max: f32) -> Result<Self, DesignError> {
        // min in [−127, 0), max in (0, 127].
        let limit = 127.0;
        for (param, value, ok, lo, hi) in [
            (
                Param::ClampMin,
                min,
                (-limit..0.0).contains(&min),
                -limit,
                0.0,
            ),
            (Param::ClampMax, max, max > 0.0 && max <= limit, 0.0, limit),
        ] {
            if !value.is_finite() {
                return Err(DesignError::NotFinite { param });
            }
            if !ok {
                return Err(DesignError::OutOfRange {
                    param,
                    value,
                    min: lo,
                    max: hi,
                });
            }
        }
        let (min_q, max_q) = (round_to_log_odds(min), round_to_log_odds(max));
        // Bounds that round to 0 in Q8.8 would pin every cell at 0: refused, not clamped.
        if min_q.to_bits() >= 0 {
            return Err(DesignError::OutOfRange {
                param: Param::ClampMin,
                value: min,
                min: -limit,
                max: -1.0 / 512.0,
            });
        }
        if max_q.to_bits() <= 0 {
            return Err(DesignError::OutOfRange {
                param: Param::ClampMax,
                value: max,
                min: 1.0 / 512.0,
                max: limit,
            });
        }
        Ok(Self::Bounds {
            min: min_q,
            max: max_q,
        })
    }

    /// Applies the bounds to a raw Q8.8 value.
    #[must_use]
    pub fn apply_raw(self, raw: i16) -> i16 {
        match self {
            Self::Off => raw,
            Self::Bounds { min, max } => raw.clamp(min.to_bits(), max.to_bits().max(min.to_bits())),
        }
    }

    /// The [`GatedIncrement`] of a record of class increment `l` (raw Q8.8) and gate weight
    /// `w`: the gated increment `round(l·w)` and, with bounds, the bound on its side scaled by
    /// the same weight, `round(c·w)` (the same rounding, [`gated`]); without, the format's
    /// limit.
    #[must_use]
    #[inline]
    pub fn gated(self, l: LogOddsFixed, w: Weight) -> GatedIncrement {
        let g = gated(l, w);
        match self {
            Self::Off => GatedIncrement::unbounded(g),
            Self::Bounds { min, max } => GatedIncrement {
                g,
                reach: gated(if g < 0 { min } else { max }, w),
            },
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Clamp {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Self::Off => defmt::write!(f, "Clamp::Off"),
            Self::Bounds { min, max } => defmt::write!(
                f,
                "Clamp::Bounds {{ min: {=i16}, max: {=i16} }} (raw Q8.8)",
                min.to_bits(),
                max.to_bits()
            ),
        }
    }
}

#[cfg(feature = "defmt")]
defmt_raw!(
    Increments,
    "Increments {{ obstacle: {=i16}, free: {=i16}, initial: {=i16} }} (raw Q8.8)",
    [obstacle, free, initial]
);

impl Default for Clamp {
    fn default() -> Self {
        Self::OCTOMAP
    }
}

/// The inverse sensor model: p(x | z) for each class of a cell's observation, and the prior.
///
/// Probabilities of "not navigable". Defaults `p_obstacle = 0.7`, `p_free = 0.4`,
/// `prior = 0.5`; each must lie in (0, 1) with `p_free < prior < p_obstacle`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InverseSensorModel {
    /// p(x | z) when the classifier finds the cell non-navigable.
    pub p_obstacle: f32,
    /// p(x | z) when the classifier finds the cell navigable.
    pub p_free: f32,
    /// The prior p(x).
    pub prior: f32,
}

impl Default for InverseSensorModel {
    fn default() -> Self {
        Self {
            p_obstacle: 0.7,
            p_free: 0.4,
            prior: 0.5,
        }
    }
}

/// The inverse sensor model in fixed point: what one observation adds to a cell, before gating.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Increments {
    /// `logit(p_obstacle) − logit(prior)`, > 0.
    pub obstacle: LogOddsFixed,
    /// `logit(p_free) − logit(prior)`, < 0.
    pub free: LogOddsFixed,
    /// `logit(prior)`: the value a cell takes before its first increment (eq. 6).
    pub initial: LogOddsFixed,
}

impl Default for Increments {
    fn default() -> Self {
        // logit(0.7) = 0.8473 → raw 217; logit(0.4) = −0.4055 → raw −104; logit(0.5) = 0.
        Self {
            obstacle: LogOddsFixed::from_bits(217),
            free: LogOddsFixed::from_bits(-104),
            initial: LogOddsFixed::ZERO,
        }
    }
}

impl InverseSensorModel {
    /// Validates the probabilities and converts them into Q8.8 increments (rounded to nearest,
    /// ties away from zero), with the device's own `f32` maths.
    ///
    /// # Errors
    /// A non-finite probability, one outside (0.001, 0.999), or the order
    /// `p_free < prior < p_obstacle` broken (reported against the parameter out of order).
    pub fn increments(&self) -> Result<Increments, DesignError> {
        for (param, value) in [
            (Param::PObstacle, self.p_obstacle),
            (Param::PFree, self.p_free),
            (Param::Prior, self.prior),
        ] {
            if !value.is_finite() {
                return Err(DesignError::NotFinite { param });
            }
            if !(0.001..=0.999).contains(&value) {
                return Err(DesignError::OutOfRange {
                    param,
                    value,
                    min: 0.001,
                    max: 0.999,
                });
            }
        }
        if self.p_obstacle <= self.prior {
            return Err(DesignError::OutOfRange {
                param: Param::PObstacle,
                value: self.p_obstacle,
                min: self.prior,
                max: 0.999,
            });
        }
        if self.p_free >= self.prior {
            return Err(DesignError::OutOfRange {
                param: Param::PFree,
                value: self.p_free,
                min: 0.001,
                max: self.prior,
            });
        }
        let prior = logit(self.prior);
        let increments = Increments {
            obstacle: round_to_log_odds(logit(self.p_obstacle) - prior),
            free: round_to_log_odds(logit(self.p_free) - prior),
            initial: round_to_log_odds(prior),
        };
        // A probability within half a Q8.8 step (in logit) of the prior would add nothing:
        // refused, so that every observation counts.
        if increments.obstacle.to_bits() <= 0 {
            return Err(DesignError::OutOfRange {
                param: Param::PObstacle,
                value: self.p_obstacle,
                min: self.prior,
                max: 0.999,
            });
        }
        if increments.free.to_bits() >= 0 {
            return Err(DesignError::OutOfRange {
                param: Param::PFree,
                value: self.p_free,
                min: 0.001,
                max: self.prior,
            });
        }
        Ok(increments)
    }
}

/// `ln(p / (1 − p))`, nats, for p in (0, 1).
#[must_use]
pub fn logit(p: f32) -> f32 {
    fmath::ln(p / (1.0 - p))
}

/// Rounds nats to Q8.8, to nearest with ties away from zero, saturating at ±127.996.
#[must_use]
pub fn round_to_log_odds(nats: f32) -> LogOddsFixed {
    let raw = nats * 256.0;
    let rounded = if raw >= 0.0 { raw + 0.5 } else { raw - 0.5 };
    // Saturate before the truncating conversion; NaN gives 0.
    let clamped = if rounded.is_nan() {
        0.0
    } else {
        rounded.clamp(-f32::from(STORED_MAX_RAW), f32::from(STORED_MAX_RAW))
    };
    #[allow(clippy::cast_possible_truncation)]
    LogOddsFixed::from_bits(clamped as i16)
}

/// The gated increment `g = round_half_up(l · w)` in raw Q8.8: exact integer maths.
///
/// `|l| ≤ 32 767` and `w ≤ 1.0` (raw 32 768), so the product fits an `i32` and the result
/// fits an `i16`.
#[must_use]
#[inline]
pub fn gated(l: LogOddsFixed, w: Weight) -> i16 {
    let product = i32::from(l.to_bits()) * i32::from(w.to_bits());
    let g = (product + (1 << 14)) >> 15;
    // |g| ≤ |l| ≤ 32 768 only when w ≤ 1; weights above 1 do not exist in a table, but
    // saturate anyway rather than wrap.
    i16::try_from(g).unwrap_or(if g < 0 { i16::MIN + 1 } else { i16::MAX })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_is_distinct_from_observed_zero() {
        let zero = Cell::observed(LogOddsFixed::ZERO);
        assert!(zero.is_observed());
        assert_eq!(zero.class(), CellClass::Undecided);
        assert!(!Cell::UNKNOWN.is_observed());
        assert_eq!(Cell::UNKNOWN.class(), CellClass::Unknown);
        assert_ne!(zero, Cell::UNKNOWN);
        assert_eq!(Cell::UNKNOWN.log_odds(), None);
    }

    #[test]
    fn default_increments_are_the_logits() {
        let inc = InverseSensorModel::default().increments().unwrap();
        assert_eq!(inc, Increments::default());
        // Independent of the code: logit(0.7) = ln(7/3) = 0.847298; ×256 = 216.9.
        assert_eq!(inc.obstacle.to_bits(), 217);
        assert_eq!(inc.free.to_bits(), -104);
        assert_eq!(inc.initial.to_bits(), 0);
    }

    #[test]
    fn zero_increment_does_not_observe() {
        assert_eq!(
            Cell::UNKNOWN.updated(0, LogOddsFixed::ZERO, Clamp::Off),
            Cell::UNKNOWN
        );
    }

    #[test]
    fn updates_saturate_and_never_reach_the_unknown_sentinel() {
        let mut c = Cell::UNKNOWN;
        for _ in 0..1000 {
            c = c.updated(-217, LogOddsFixed::ZERO, Clamp::Off);
        }
        assert_eq!(c.to_raw(), -32767);
        assert!(c.is_observed());
        for _ in 0..1000 {
            c = c.updated(i16::MAX, LogOddsFixed::ZERO, Clamp::Off);
        }
        assert_eq!(c.to_raw(), 32767);
    }

    #[test]
    fn clamping_holds_the_octomap_bounds() {
        let mut c = Cell::UNKNOWN;
        for _ in 0..100 {
            c = c.updated(-104, LogOddsFixed::ZERO, Clamp::OCTOMAP);
        }
        assert_eq!(c.log_odds(), Some(LogOddsFixed::from_num(-2)));
        for _ in 0..100 {
            c = c.updated(217, LogOddsFixed::ZERO, Clamp::OCTOMAP);
        }
        assert_eq!(c.log_odds(), Some(LogOddsFixed::from_num(3.5)));
    }

    #[test]
    fn a_step_reaches_the_bound_scaled_by_its_weight() {
        let (free, obstacle) = (LogOddsFixed::from_bits(-104), LogOddsFixed::from_bits(217));
        // Weight 1: the bounds themselves (−2 = −512 raw, 3.5 = 896 raw).
        let one = Clamp::OCTOMAP.gated(free, Weight::ONE);
        assert_eq!((one.g, one.reach), (-104, -512));
        // Weight 0.5: −52 and −256 exactly.
        let half = Clamp::OCTOMAP.gated(free, Weight::from_num(0.5));
        assert_eq!((half.g, half.reach), (-52, -256));
        // Weight 500/32 768 (a gate's tail): −104·500 = −52 000 → ⌊(−52 000 + 16 384) / 32 768⌋
        // = −2; −512·500 = −256 000 → −8; 217·500 = 108 500 → 3; 896·500 = 448 000 → 14.
        let tail = Weight::from_bits(500);
        let f = Clamp::OCTOMAP.gated(free, tail);
        assert_eq!((f.g, f.reach), (-2, -8));
        let o = Clamp::OCTOMAP.gated(obstacle, tail);
        assert_eq!((o.g, o.reach), (3, 14));
        // Without clamping, only the format bounds an increment.
        assert_eq!(Clamp::Off.gated(free, tail), GatedIncrement::unbounded(-2));
        assert_eq!(GatedIncrement::unbounded(-2).reach, -32_767);
        assert_eq!(GatedIncrement::unbounded(3).reach, 32_767);
    }

    #[test]
    fn looks_at_a_gates_tail_never_carry_a_cell_past_their_share_of_the_bound() {
        let clamp = Clamp::OCTOMAP;
        let free = LogOddsFixed::from_bits(-104);
        let tail = clamp.gated(free, Weight::from_bits(500));
        let mut c = Cell::UNKNOWN;
        for _ in 0..1000 {
            c = c.updated_by(tail, LogOddsFixed::ZERO, clamp);
        }
        // −2 a look, stopped at −8: a thousand looks weigh no more than four.
        assert_eq!(c.to_raw(), -8);
        // A full-weight look carries it on, to the bound itself.
        for _ in 0..10 {
            c = c.updated_by(clamp.gated(free, Weight::ONE), LogOddsFixed::ZERO, clamp);
        }
        assert_eq!(c.to_raw(), -512);
        // A tail look then leaves it where stronger looks put it: neither further nor back.
        assert_eq!(c.updated_by(tail, LogOddsFixed::ZERO, clamp).to_raw(), -512);
        // Obstacle evidence of the tail moves it toward its own reach (+14) as usual.
        let up = clamp.gated(LogOddsFixed::from_bits(217), Weight::from_bits(500));
        assert_eq!(c.updated_by(up, LogOddsFixed::ZERO, clamp).to_raw(), -509);
        let mut d = Cell::observed(LogOddsFixed::from_bits(12));
        d = d.updated_by(up, LogOddsFixed::ZERO, clamp);
        assert_eq!(d.to_raw(), 14);
        d = d.updated_by(up, LogOddsFixed::ZERO, clamp);
        assert_eq!(d.to_raw(), 14);
    }

    #[test]
    fn at_weight_one_a_step_is_octomaps_clamp() {
        let clamp = Clamp::OCTOMAP;
        let mut a = Cell::UNKNOWN;
        let mut b = Cell::UNKNOWN;
        // A fixed pattern of free and obstacle looks that hits both bounds.
        for n in 0..400_u32 {
            let l = if (n / 37) % 2 == 0 { -104 } else { 217 };
            let l = LogOddsFixed::from_bits(l);
            a = a.updated_by(clamp.gated(l, Weight::ONE), LogOddsFixed::ZERO, clamp);
            b = b.updated(l.to_bits(), LogOddsFixed::ZERO, clamp);
            assert_eq!(a, b);
        }
    }

    #[test]
    fn gated_rounds_half_up_and_hard_gate_is_exact() {
        assert_eq!(gated(LogOddsFixed::from_bits(-104), Weight::ONE), -104);
        assert_eq!(gated(LogOddsFixed::from_bits(217), Weight::ZERO), 0);
        // 217 · 0.5 = 108.5 → 109; −104 · 0.5 = −52 exactly; −105 · 0.5 = −52.5 → −52.
        let half = Weight::from_num(0.5);
        assert_eq!(gated(LogOddsFixed::from_bits(217), half), 109);
        assert_eq!(gated(LogOddsFixed::from_bits(-104), half), -52);
        assert_eq!(gated(LogOddsFixed::from_bits(-105), half), -52);
    }

    #[test]
    fn bad_probabilities_are_refused_by_name() {
        // A p(x|z) for an obstacle below the prior, and one so close to the prior that its
        // increment rounds to 0.
        for p_obstacle in [0.4, 0.5004] {
            let m = InverseSensorModel {
                p_obstacle,
                ..InverseSensorModel::default()
            };
            assert!(matches!(
                m.increments(),
                Err(DesignError::OutOfRange {
                    param: Param::PObstacle,
                    ..
                })
            ));
        }
        let m = InverseSensorModel {
            prior: f32::NAN,
            ..InverseSensorModel::default()
        };
        assert_eq!(
            m.increments(),
            Err(DesignError::NotFinite {
                param: Param::Prior
            })
        );
        assert!(Clamp::bounds(1.0, 3.0).is_err());
        // Bounds that round to 0 nats in Q8.8 are refused, not clamped.
        assert!(Clamp::bounds(-1e-10, 1e-10).is_err());
        assert!(Clamp::bounds(-2.0, f32::INFINITY).is_err());
        assert_eq!(Clamp::bounds(-2.0, 3.5), Ok(Clamp::OCTOMAP));
    }
}
