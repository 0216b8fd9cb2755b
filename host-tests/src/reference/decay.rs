//! Decay toward unknown (`docs/core.md`, "Decay"), written from the specification: the step
//! of one cell in two arithmetics, the time constants, and the sweep that decides which rows
//! of which layer take a step at each call.
//!
//! - [`step_quantised`]: the fixed-point rule taken literally (`m' = ⌊(m·F + 2¹⁵)/2¹⁶⌋`, at
//!   least one raw unit of progress, 0 = unknown), with F computed here as
//!   `round(2¹⁶·e^{−1/8})` in `f64`.
//! - [`step_ideal`]: the exact exponential, `L·e^{−1/8}` per step; a value under half a Q8.8
//!   step (2⁻⁹ nats) reads unknown ([`ideal_is_unknown`]), as an update that small observes
//!   nothing (`docs/core.md`, "One update").
//! - [`step_period_ms`]: the time constants from their byte, with the sixteenth-octave table
//!   computed here in `f64`.
//! - [`Sweep`]: the rows each layer owes, from the caller's clock, by the rule of the spec.
//!
//! [`ERROR_BOUND_ULP`] bounds how far the quantised value may drift from the ideal one over
//! any number of steps: each step adds at most one raw unit (half a unit of rounding, or the
//! forced unit of the tail), and the steps shrink what came before by F, so the drift stays
//! below `1/(1 − F) + 1` units.

/// The step factor in Q0.16: `round(2¹⁶ · e^{−1/8})`.
#[must_use]
pub fn factor_q16() -> u64 {
    (65_536.0 * (-0.125_f64).exp()).round() as u64
}

/// The exact step factor `e^{−1/8}`.
#[must_use]
pub fn factor() -> f64 {
    (-0.125_f64).exp()
}

/// Steps per time constant.
pub const STEPS_PER_TAU: u64 = 8;

/// A bound on `|quantised − ideal|` after any number of steps from the same raw value, raw
/// Q8.8 units: `1/(1 − F) + 1` (see the module documentation).
#[must_use]
pub fn error_bound_ulp() -> f64 {
    1.0 / (1.0 - factor_q16() as f64 / 65_536.0) + 1.0
}

/// [`error_bound_ulp`], for tests that want a constant (8.51 + 1).
pub const ERROR_BOUND_ULP: f64 = 9.52;

/// Which evidence ages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Nothing.
    Off,
    /// Every observed cell.
    All,
    /// Cells with L > 0.
    Obstacle,
    /// Cells with L < 0.
    Free,
}

impl Mode {
    /// Whether a cell holding `l` ages.
    #[must_use]
    pub fn ages(self, l: f64) -> bool {
        match self {
            Self::Off => false,
            Self::All => true,
            Self::Obstacle => l > 0.0,
            Self::Free => l < 0.0,
        }
    }
}

/// One step of a cell holding raw Q8.8 `raw` (`None`: unknown) in the quantised arithmetic.
#[must_use]
pub fn step_quantised(raw: Option<i64>, mode: Mode) -> Option<i64> {
    let v = raw?;
    if !mode.ages(v as f64) {
        return Some(v);
    }
    let m = v.abs();
    let mut n = (m * factor_q16() as i64 + (1 << 15)) >> 16;
    if n >= m {
        n = m - 1;
    }
    if n <= 0 {
        None
    } else {
        Some(n * v.signum())
    }
}

/// One step of a cell holding `l` nats in the ideal arithmetic (`None`: unknown).
#[must_use]
pub fn step_ideal(l: Option<f64>, mode: Mode) -> Option<f64> {
    let v = l?;
    if mode.ages(v) {
        Some(v * factor())
    } else {
        Some(v)
    }
}

/// Whether an ideal value reads unknown: below half a Q8.8 step in magnitude.
#[must_use]
pub fn ideal_is_unknown(l: Option<f64>) -> bool {
    l.is_none_or(|v| v.abs() < 1.0 / 512.0)
}

/// `round(2¹⁶ · 2^(r/16))`.
#[must_use]
pub fn octave_q16(r: u32) -> u64 {
    (65_536.0 * 2.0_f64.powf(f64::from(r) / 16.0)).round() as u64
}

/// The step period of time-constant byte `code`, ms: `⌊(125 · 2^q · T_r + 2¹⁵)/2¹⁶⌋` with
/// `code − 1 = 16q + r`; `None` for code 0.
#[must_use]
pub fn step_period_ms(code: u8) -> Option<u64> {
    let c = u32::from(code).checked_sub(1)?;
    let (q, r) = (c / 16, c % 16);
    Some((125 * (1_u64 << q) * octave_q16(r) + (1 << 15)) >> 16)
}

/// The time constant of `code`, seconds: 8 step periods.
#[must_use]
pub fn tau_s(code: u8) -> Option<f64> {
    step_period_ms(code).map(|p| (p * STEPS_PER_TAU) as f64 / 1000.0)
}

/// The sweep of `docs/core.md`: per layer a cursor over the W storage rows and the time owed,
/// counted here in milliseconds as a rational number of rows (`owed_ms_w / P` rows, where
/// `owed_ms_w` is in ms·W), capped at one step.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// W.
    pub w: u64,
    /// Each layer's step period, ms (`None`: no decay).
    pub periods: Vec<Option<u64>>,
    /// Each layer's next storage row.
    pub cursor: Vec<u64>,
    /// Each layer's time owed, ms·W.
    pub owed: Vec<u64>,
    /// The clock at the last accrual.
    pub last_ms: Option<u32>,
}

impl Sweep {
    /// A fresh sweep: cursors at row 0, nothing owed, the clock not started.
    #[must_use]
    pub fn new(w: usize, codes: &[u8]) -> Self {
        Self {
            w: w as u64,
            periods: codes.iter().map(|&c| step_period_ms(c)).collect(),
            cursor: vec![0; codes.len()],
            owed: vec![0; codes.len()],
            last_ms: None,
        }
    }

    /// Accrues the time since the last call: `now − last` modulo 2³², nothing when that is
    /// 2³¹ or more (the clock went back) or on the first call; each layer's debt grows by
    /// `Δ · W` and is capped at `W · P` (one step).
    pub fn accrue(&mut self, now_ms: u32) {
        let delta = match self.last_ms {
            Some(last) => now_ms.wrapping_sub(last),
            None => 0,
        };
        self.last_ms = Some(now_ms);
        if delta >= 1 << 31 {
            return;
        }
        for (owed, period) in self.owed.iter_mut().zip(&self.periods) {
            if let Some(p) = period {
                *owed = (*owed + u64::from(delta) * self.w).min(p * self.w);
            }
        }
    }

    /// The rows layer k owes: `⌊owed / P⌋`, at most W.
    #[must_use]
    pub fn due(&self, k: usize) -> u64 {
        match self.periods[k] {
            Some(p) => (self.owed[k] / p).min(self.w),
            None => 0,
        }
    }

    /// Takes layer k's rows: `(first, count)`; the cursor advances, the debt shrinks by
    /// `count · P`.
    pub fn take(&mut self, k: usize) -> Option<(u64, u64)> {
        let rows = self.due(k);
        if rows == 0 {
            return None;
        }
        let p = self.periods[k]?;
        self.owed[k] -= rows * p;
        let first = self.cursor[k];
        self.cursor[k] = (first + rows) % self.w;
        Some((first, rows))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants() {
        assert_eq!(factor_q16(), 57_835);
        assert!((error_bound_ulp() - ERROR_BOUND_ULP).abs() < 0.01);
        assert_eq!(step_period_ms(1), Some(125));
        assert_eq!(step_period_ms(255), Some(7_512_125));
        assert_eq!(tau_s(54), Some(9.936));
    }

    #[test]
    fn steps() {
        assert_eq!(step_quantised(Some(896), Mode::All), Some(791));
        assert_eq!(step_quantised(Some(-3), Mode::All), Some(-2));
        assert_eq!(step_quantised(Some(1), Mode::All), None);
        assert_eq!(step_quantised(Some(0), Mode::Obstacle), Some(0));
        assert!(ideal_is_unknown(step_ideal(Some(0.002), Mode::All)));
    }
}
