//! Decay of stale evidence toward unknown: a world that changes.
//!
//! The paper's recursion (eq. 6) never forgets: a cell that saw a pedestrian for a second and
//! is not looked at again keeps its obstacle evidence for ever (a *ghost*). With decay on, the
//! log-odds of every observed cell shrink toward 0 with a time constant τ per layer, in fixed
//! point, and a cell whose log-odds reach 0 becomes **unknown**. Off by default (the paper's
//! behaviour). Rules in `docs/core.md`, "Decay".
//!
//! # The rule (fixed)
//! - **Steps.** Layer k decays in steps of period `P_k = τ_k / 8`: each step multiplies a
//!   cell's log-odds by `F = e^{−1/8}` (after 8 steps, e⁻¹). In Q0.16, `F = 57 835`
//!   ([`STEP_FACTOR_Q16`]). On the magnitude m = |L| (raw Q8.8):
//!   `m' = ⌊(m·F + 2¹⁵) / 2¹⁶⌋`, and if that is not smaller than m, `m' = m − 1` (every step
//!   makes progress, so every cell fades in finite time: from m ≤ 4 on, one raw unit a step).
//!   The sign stays; `m' = 0` makes the cell unknown. ([`decayed`])
//! - **Which cells** ([`DecayMode`]): all observed cells, only obstacle evidence (L > 0), or
//!   only free evidence (L < 0). An undecided cell (L = 0) fades at the first step in mode
//!   [`DecayMode::All`] and is left alone otherwise.
//! - **Clamping**: a step only shrinks |L|, so a clamped cell stays within its bounds
//!   (`c_min < 0 < c_max`).
//! - **Fresh evidence dominates**: an update adds its increment to the decayed value, so the
//!   older the evidence, the less it weighs against a new observation.
//!
//! # Time constants
//! One byte per layer ([`TimeConstant`]): code 0 = the layer does not decay; code c in
//! 1 ..= 255 gives the step period `P(c) = ⌊(125 · 2^q · T_r + 2¹⁵) / 2¹⁶⌋` ms with
//! `c − 1 = 16q + r` and `T_r = round(2¹⁶ · 2^(r/16))` ([`OCTAVE_Q16`]), i.e.
//! `P ≈ 125 ms · 2^((c−1)/16)`, and the time constant `τ = 8·P`: 1 s (c = 1) to 60 097 s
//! (16.7 h, c = 255) in steps of 4.4 %. Integer maths only, so the device and every host
//! derive the same periods.
//!
//! # The sweep: bounded cost, no per-cell state
//! Cells are decayed by an **amortised sweep** over each layer's storage rows, not lazily by
//! per-tile time stamps: a lazy cell would only fade when something touched it, so nobody
//! would learn that a ghost had gone, and time stamps would cost RAM the default firmware does
//! not have (8 layers × 64 tiles × 4 bytes = 2 KiB). Per layer the sweep keeps a cursor (the
//! next storage row) and an accumulator of elapsed time; the clock is the caller's
//! (`now_ms`, the one the application core's `poll` is given). Layer k owes `W` rows every
//! `P_k` ms; each call decays the rows owed since the last one, at most one step (W rows) per
//! layer; a backlog beyond one step is dropped (a device that polls less often than every
//! `P_k` decays at its poll rate). The cost is bounded by the rule that a layer sweeps at most
//! [`MAX_CELLS_PER_SECOND`] cells a second ([`Decay::validate`]).
//!
//! The host link announces every row it decays (a `Decayed` frame, `docs/protocol.md`), so the
//! host's mirror ages alike, cell for cell, with no patch in between.

use crate::design::{DesignError, Param};
use crate::logodds::Cell;

/// The step factor `F = round(2¹⁶ · e^{−1/8}) = 57 835`, Q0.16: one step multiplies a
/// log-odds by about 0.8825.
pub const STEP_FACTOR_Q16: u32 = 57_835;

/// Steps per time constant: a layer's step period is τ / 8.
pub const STEPS_PER_TAU: u32 = 8;

/// `round(2¹⁶ · 2^(r/16))` for r = 0 ..= 15: the sixteenth-octave table of the time constants.
pub const OCTAVE_Q16: [u32; 16] = [
    65_536, 68_438, 71_468, 74_632, 77_936, 81_386, 84_990, 88_752, 92_682, 96_785, 101_070,
    105_545, 110_218, 115_098, 120_194, 125_515,
];

/// The most layers that carry their own time constant (the host link's 32); a pyramid with
/// more layers gives the rest the 32nd's.
pub const DECAY_LAYERS: usize = 32;

/// The most cells one layer's sweep may decay per second: a layer of W × W cells needs
/// `τ ≥ 8 · W² / MAX_CELLS_PER_SECOND` s (1 s for W = 64, 58 s for W = 488).
pub const MAX_CELLS_PER_SECOND: u64 = 32_768;

byte_enum! {
/// Which evidence ages.
#[derive(Default)]
pub enum DecayMode {
    /// Nothing decays: the paper's behaviour (the default).
    #[default]
    Off = 0,
    /// Every observed cell decays toward unknown.
    All = 1,
    /// Only obstacle evidence (L > 0) decays; free ground is kept.
    Obstacle = 2,
    /// Only free evidence (L < 0) decays; obstacles are kept.
    Free = 3,
}
/// The mode of a wire byte (0 ..= 3), or `None`.
pub fn from_u8;
/// The wire byte.
pub fn to_u8;
}

impl DecayMode {
    /// Whether a cell holding raw log-odds `raw` (not unknown) ages in this mode.
    #[must_use]
    #[inline]
    pub const fn ages(self, raw: i16) -> bool {
        match self {
            Self::Off => false,
            Self::All => true,
            Self::Obstacle => raw > 0,
            Self::Free => raw < 0,
        }
    }

    /// The mode's name: `off`, `all`, `obstacle`, `free`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::All => "all",
            Self::Obstacle => "obstacle",
            Self::Free => "free",
        }
    }
}

/// One decay step of a cell in `mode` (see the module documentation): unknown cells and cells
/// the mode leaves alone are returned as they are; a step to 0 makes the cell unknown.
#[must_use]
#[inline]
pub fn decayed(cell: Cell, mode: DecayMode) -> Cell {
    let raw = cell.to_raw();
    if !cell.is_observed() || !mode.ages(raw) {
        return cell;
    }
    let m = u32::from(raw.unsigned_abs());
    // m ≤ 32 767 (a stored value), so m·F < 2³¹.
    let mut n = (m * STEP_FACTOR_Q16 + 0x8000) >> 16;
    if n >= m {
        n = m.saturating_sub(1);
    }
    // n < m ≤ 32 767: fits an i16.
    let n = i16::try_from(n).unwrap_or(i16::MAX);
    match n {
        0 => Cell::UNKNOWN,
        _ if raw < 0 => Cell::from_raw(-n),
        _ => Cell::from_raw(n),
    }
}

/// A layer's time constant, as one byte (the link carries it so): code 0 = no decay; code c
/// in 1 ..= 255 a step period of about `125 ms · 2^((c−1)/16)` and τ = 8 steps (1 s ..=
/// 60 097 s). All zero bits = none.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeConstant(u8);

impl TimeConstant {
    /// No decay for the layer.
    pub const NONE: Self = Self(0);
    /// The shortest: τ = 1 s (code 1).
    pub const MIN: Self = Self(1);
    /// The longest: τ = 60 097 s (code 255).
    pub const MAX: Self = Self(255);

    /// The time constant of a code (0 = none).
    #[must_use]
    pub const fn from_code(code: u8) -> Self {
        Self(code)
    }

    /// The code (0 = none).
    #[must_use]
    pub const fn code(self) -> u8 {
        self.0
    }

    /// Whether the layer does not decay.
    #[must_use]
    pub const fn is_none(self) -> bool {
        self.0 == 0
    }

    /// The step period, ms: `⌊(125 · 2^q · T_r + 2¹⁵) / 2¹⁶⌋` with `code − 1 = 16q + r`
    /// (125 ..= 7 512 125); `None` for no decay.
    #[must_use]
    pub fn step_ms(self) -> Option<u32> {
        let c = u32::from(self.0).checked_sub(1)?;
        let (q, r) = (c / 16, (c % 16) as usize);
        let t = u64::from(*OCTAVE_Q16.get(r)?);
        let p = (125 * (1_u64 << q) * t + (1 << 15)) >> 16;
        // p ≤ 7 512 125.
        u32::try_from(p).ok()
    }

    /// The time constant, ms: `8 · step_ms` (1 000 ..= 60 097 000); `None` for no decay.
    #[must_use]
    pub fn millis(self) -> Option<u32> {
        self.step_ms().map(|p| p * STEPS_PER_TAU)
    }

    /// The time constant, seconds; `None` for no decay.
    #[must_use]
    #[allow(clippy::cast_precision_loss)]
    pub fn seconds(self) -> Option<f32> {
        self.millis().map(|ms| ms as f32 / 1000.0)
    }

    /// The code nearest (on a log scale) to `seconds`, for `seconds` within
    /// [`MIN`](Self::MIN)'s and [`MAX`](Self::MAX)'s time constants (1 ..= 60 097 s); `None`
    /// when not finite or outside (nothing is clamped).
    #[must_use]
    pub fn from_seconds(seconds: f32) -> Option<Self> {
        if !seconds.is_finite() {
            return None;
        }
        let lo = Self::MIN.millis().unwrap_or(1000);
        let hi = Self::MAX.millis().unwrap_or(u32::MAX);
        let ms = seconds * 1000.0;
        #[allow(clippy::cast_precision_loss)]
        if !(lo as f32..=hi as f32).contains(&ms) {
            return None;
        }
        // In range: below 2³² after rounding.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let ms = u64::from((ms + 0.5) as u32);
        let mut best = Self::MIN;
        for code in 1..=u8::MAX {
            let t = Self(code);
            let Some(m) = t.millis() else { continue };
            if u64::from(m) > ms {
                // Between the previous code and this one: the nearer on a log scale, i.e.
                // compare ms² with the product of the two.
                let prev = u64::from(best.millis().unwrap_or(m));
                if ms * ms >= prev * u64::from(m) {
                    best = t;
                }
                return Some(best);
            }
            best = t;
        }
        Some(best)
    }
}

/// Decay as the pyramid is configured with it: the mode and each layer's time constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Decay {
    /// Which evidence ages (default [`DecayMode::Off`]: nothing).
    pub mode: DecayMode,
    /// Layer k's time constant, finest first ([`TimeConstant::NONE`]: the layer does not
    /// decay). Layers beyond the 32nd take the 32nd's.
    pub tau: [TimeConstant; DECAY_LAYERS],
}

impl Default for Decay {
    fn default() -> Self {
        Self::OFF
    }
}

impl Decay {
    /// No decay (the paper's behaviour).
    pub const OFF: Self = Self {
        mode: DecayMode::Off,
        tau: [TimeConstant::NONE; DECAY_LAYERS],
    };

    /// `mode`, with the first `layers` layers (at most 32) at time constant `tau` and the
    /// others not decaying.
    #[must_use]
    pub fn uniform(mode: DecayMode, tau: TimeConstant, layers: usize) -> Self {
        let mut out = Self {
            mode,
            tau: [TimeConstant::NONE; DECAY_LAYERS],
        };
        for t in out.tau.iter_mut().take(layers) {
            *t = tau;
        }
        out
    }

    /// Whether anything decays.
    #[must_use]
    pub fn is_on(&self) -> bool {
        self.mode != DecayMode::Off && self.tau.iter().any(|t| !t.is_none())
    }

    /// Layer k's time constant (layers beyond the 32nd take the 32nd's).
    #[must_use]
    pub fn tau_of(&self, k: usize) -> TimeConstant {
        self.tau
            .get(k.min(DECAY_LAYERS - 1))
            .copied()
            .unwrap_or(TimeConstant::NONE)
    }

    /// The shortest step period a layer of `cells_per_side` cells may have, ms:
    /// `⌈1000 · W² / MAX_CELLS_PER_SECOND⌉`.
    #[must_use]
    pub const fn min_step_ms(cells_per_side: usize) -> u64 {
        let w = cells_per_side as u64;
        (1000 * w * w).div_ceil(MAX_CELLS_PER_SECOND)
    }

    /// Checks the decay against a design of `layers` layers of `cells_per_side` cells (when
    /// the mode is off, the time constants are ignored): a layer the design does not have may
    /// not have a time constant, and every layer's sweep must stay within
    /// [`MAX_CELLS_PER_SECOND`] (`8 · step ≥ 8 · min_step_ms(W)`).
    ///
    /// # Errors
    /// [`DesignError::OutOfRange`] naming the first layer's time constant that breaks a rule
    /// ([`Param::DecayTau`]): value τ in seconds, limits `[0, 0]` for a layer the design does
    /// not have, else the shortest and longest τ allowed.
    #[allow(clippy::cast_precision_loss)]
    pub fn validate(&self, cells_per_side: usize, layers: usize) -> Result<(), DesignError> {
        if self.mode == DecayMode::Off {
            return Ok(());
        }
        let min_step = Self::min_step_ms(cells_per_side);
        let max_s = TimeConstant::MAX.seconds().unwrap_or(0.0);
        for (k, tau) in self.tau.iter().enumerate() {
            let Some(step) = tau.step_ms() else { continue };
            let param = Param::DecayTau {
                layer: u8::try_from(k).unwrap_or(u8::MAX),
            };
            let value = tau.seconds().unwrap_or(0.0);
            if k >= layers {
                return Err(DesignError::OutOfRange {
                    param,
                    value,
                    min: 0.0,
                    max: 0.0,
                });
            }
            if u64::from(step) < min_step {
                return Err(DesignError::OutOfRange {
                    param,
                    value,
                    min: (min_step * u64::from(STEPS_PER_TAU)) as f32 / 1000.0,
                    max: max_s,
                });
            }
        }
        Ok(())
    }
}

/// What one layer's sweep did in one call: `rows` storage rows from `first` (wrapping modulo
/// W) took one step each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecayRows {
    /// The first storage row (`j mod W` of the world rows j it covers), < W.
    pub first: u16,
    /// Rows decayed, 1 ..= W.
    pub rows: u16,
    /// Cells of those rows that became unknown.
    pub faded: u32,
}

/// The per-layer state of the sweep: all zero bits when nothing decays.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sweep<const L: usize> {
    /// The mode in force.
    pub(crate) mode: DecayMode,
    /// Whether `last_ms` holds a time yet.
    started: bool,
    /// The clock at the last accrual, ms.
    last_ms: u32,
    /// Each layer's time constant.
    tau: [TimeConstant; L],
    /// The next storage row to decay, per layer.
    cursor: [u16; L],
    /// Time owed, per layer, in units of ms·W (a row is owed per `P_k` units), at most one
    /// step (`W · P_k`, saturating at `u32::MAX`).
    owed: [u32; L],
}

impl<const L: usize> Sweep<L> {
    /// Nothing decays.
    pub(crate) const OFF: Self = Self {
        mode: DecayMode::Off,
        started: false,
        last_ms: 0,
        tau: [TimeConstant::NONE; L],
        cursor: [0; L],
        owed: [0; L],
    };

    /// A fresh sweep of `decay` over `layers` layers (cursors at row 0, nothing owed).
    pub(crate) fn new(decay: &Decay, layers: usize) -> Self {
        let mut sweep = Self::OFF;
        if decay.mode == DecayMode::Off {
            return sweep;
        }
        sweep.mode = decay.mode;
        for (k, t) in sweep.tau.iter_mut().enumerate().take(layers) {
            *t = decay.tau_of(k);
        }
        sweep
    }

    /// Layer k's time constant in force.
    pub(crate) fn tau(&self, k: usize) -> TimeConstant {
        self.tau.get(k).copied().unwrap_or(TimeConstant::NONE)
    }

    /// Accrues the time since the last call (`now_ms`, wrapping; a clock that went back, by
    /// 2³¹ ms or more, accrues nothing) for windows of `w` cells per side.
    pub(crate) fn accrue(&mut self, now_ms: u32, w: usize) {
        if self.mode == DecayMode::Off {
            return;
        }
        let delta = if self.started {
            now_ms.wrapping_sub(self.last_ms)
        } else {
            0
        };
        self.started = true;
        self.last_ms = now_ms;
        if delta == 0 || delta >= 1 << 31 {
            return;
        }
        let w64 = u64::try_from(w).unwrap_or(u64::MAX);
        let units = u64::from(delta).saturating_mul(w64);
        for (tau, owed) in self.tau.iter().zip(self.owed.iter_mut()) {
            let Some(p) = tau.step_ms() else { continue };
            let cap = (u64::from(p) * w64).min(u64::from(u32::MAX));
            let total = (u64::from(*owed).saturating_add(units)).min(cap);
            *owed = u32::try_from(total).unwrap_or(u32::MAX);
        }
    }

    /// Rows layer k owes, ≤ w.
    pub(crate) fn due(&self, k: usize, w: usize) -> usize {
        let (Some(p), Some(&owed)) = (self.tau(k).step_ms(), self.owed.get(k)) else {
            return 0;
        };
        usize::try_from(owed / p.max(1))
            .unwrap_or(usize::MAX)
            .min(w)
    }

    /// Takes the rows layer k owes: `(first row, rows)`, advancing the cursor; `None` when it
    /// owes none.
    pub(crate) fn take(&mut self, k: usize, w: usize) -> Option<(usize, usize)> {
        let rows = self.due(k, w);
        if rows == 0 {
            return None;
        }
        let p = self.tau(k).step_ms()?;
        let (owed, cursor) = (self.owed.get_mut(k)?, self.cursor.get_mut(k)?);
        let paid = u32::try_from(rows).unwrap_or(u32::MAX).saturating_mul(p);
        *owed = owed.saturating_sub(paid);
        let first = usize::from(*cursor) % w.max(1);
        *cursor = u16::try_from((first + rows) % w.max(1)).unwrap_or(0);
        Some((first, rows))
    }
}

/// The bytes the sweep of a pyramid of `layers` layers takes: 6 bytes, and 7 a layer (a time
/// constant, a cursor, the time owed), rounded up to a multiple of 4.
#[must_use]
pub const fn sweep_bytes(layers: usize) -> usize {
    (6 + 7 * layers).div_ceil(4) * 4
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    fn step(raw: i16, mode: DecayMode) -> i16 {
        decayed(Cell::from_raw(raw), mode).to_raw()
    }

    #[test]
    fn the_factor_and_the_table_are_the_spec_s() {
        // Independent of the code: 2^16·e^(−1/8) = 57 835.317; 2^16·2^(r/16).
        assert_eq!(STEP_FACTOR_Q16, 57_835);
        assert_eq!(OCTAVE_Q16[8], 92_682); // 2^16·√2 = 92 681.9
        assert_eq!(TimeConstant::MIN.step_ms(), Some(125));
        assert_eq!(TimeConstant::from_code(17).step_ms(), Some(250));
        assert_eq!(TimeConstant::from_code(2).step_ms(), Some(131)); // 125·2^(1/16) = 130.5
        assert_eq!(TimeConstant::MAX.step_ms(), Some(7_512_125));
        assert_eq!(TimeConstant::MIN.millis(), Some(1000));
        assert_eq!(TimeConstant::NONE.step_ms(), None);
    }

    #[test]
    fn a_step_shrinks_toward_unknown() {
        // 896 raw (3.5 nats): 896·57835/65536 = 790.7 → 791.
        assert_eq!(step(896, DecayMode::All), 791);
        assert_eq!(step(-512, DecayMode::All), -452); // 451.8
                                                      // The tail: one unit a step, then unknown.
        assert_eq!(step(4, DecayMode::All), 3);
        assert_eq!(step(1, DecayMode::All), i16::MIN);
        assert_eq!(step(-1, DecayMode::All), i16::MIN);
        assert_eq!(step(0, DecayMode::All), i16::MIN);
        assert_eq!(step(i16::MIN, DecayMode::All), i16::MIN);
        assert_eq!(step(32_767, DecayMode::All), 28_917); // 28 916.6
                                                          // Modes.
        assert_eq!(step(100, DecayMode::Free), 100);
        assert_eq!(step(-100, DecayMode::Free), -88);
        assert_eq!(step(-100, DecayMode::Obstacle), -100);
        assert_eq!(step(0, DecayMode::Obstacle), 0);
        assert_eq!(step(100, DecayMode::Off), 100);
    }

    #[test]
    fn every_value_fades_in_bounded_steps_and_keeps_its_sign() {
        for raw in -32_767..=32_767_i16 {
            let mut v = raw;
            let mut n = 0;
            while v != i16::MIN {
                let next = step(v, DecayMode::All);
                assert!(next == i16::MIN || (next.signum() == v.signum() && next.abs() < v.abs()));
                v = next;
                n += 1;
            }
            // ⌈8·ln(32 767/4)⌉ + 4 = 77 bounds it: the exponential part, then the tail.
            assert!(n <= 77, "{raw}: {n} steps");
        }
    }

    #[test]
    fn from_seconds_takes_the_nearest_code() {
        assert_eq!(TimeConstant::from_seconds(1.0), Some(TimeConstant::MIN));
        assert_eq!(TimeConstant::from_seconds(0.99), None);
        assert_eq!(TimeConstant::from_seconds(f32::NAN), None);
        assert_eq!(
            TimeConstant::from_seconds(60_097.0),
            Some(TimeConstant::MAX)
        );
        assert_eq!(TimeConstant::from_seconds(70_000.0), None);
        // 10 s: 2^((c−1)/16) = 10 → c − 1 = 53.15 → c = 54 (τ = 8·1242 ms = 9.936 s).
        let t = TimeConstant::from_seconds(10.0).unwrap();
        assert_eq!(t.code(), 54);
        assert_eq!(t.millis(), Some(9936));
        for code in 1..=255_u8 {
            let t = TimeConstant::from_code(code);
            assert_eq!(TimeConstant::from_seconds(t.seconds().unwrap()), Some(t));
        }
    }

    #[test]
    fn validation_names_the_layer() {
        let mut d = Decay::uniform(DecayMode::All, TimeConstant::MIN, 8);
        assert_eq!(d.validate(64, 8), Ok(()));
        // W = 128: τ ≥ 8·128²/32768 = 4 s.
        let e = d.validate(128, 8).unwrap_err();
        assert_eq!(e.param(), Param::DecayTau { layer: 0 });
        assert!(matches!(e, DesignError::OutOfRange { min, .. } if (min - 4.0).abs() < 1e-6));
        d.tau[9] = TimeConstant::MIN;
        assert_eq!(
            d.validate(64, 8).unwrap_err().param(),
            Param::DecayTau { layer: 9 }
        );
        d.mode = DecayMode::Off;
        assert_eq!(d.validate(128, 8), Ok(()));
    }

    #[test]
    fn the_sweep_owes_w_rows_per_step() {
        let decay = Decay::uniform(DecayMode::All, TimeConstant::MIN, 2);
        let mut s = Sweep::<2>::new(&decay, 2);
        s.accrue(1000, 64);
        assert_eq!(s.due(0, 64), 0);
        // 125 ms: 64 rows, one step.
        s.accrue(1125, 64);
        assert_eq!(s.due(0, 64), 64);
        s.accrue(1300, 64);
        assert_eq!(s.due(0, 64), 64, "at most one step waits");
        assert_eq!(s.take(0, 64), Some((0, 64)));
        assert_eq!(s.take(0, 64), None);
        s.accrue(1302, 64); // 2 ms · 64 = 128 units: one row (125)
        assert_eq!(s.take(0, 64), Some((0, 1)));
        s.accrue(1302 + 125 * 2, 64);
        assert_eq!(s.take(0, 64), Some((1, 64)));
        // A clock that went back accrues nothing.
        s.accrue(10, 64);
        assert_eq!(s.due(1, 64), 64);
        s.accrue(20, 64);
        assert_eq!(s.take(1, 64), Some((0, 64)));
        assert_eq!(sweep_bytes(8), core::mem::size_of::<Sweep<8>>());
        assert_eq!(sweep_bytes(3), core::mem::size_of::<Sweep<3>>());
        assert_eq!(sweep_bytes(32), core::mem::size_of::<Sweep<32>>());
        assert_eq!(sweep_bytes(0), core::mem::size_of::<Sweep<0>>());
    }
}
