//! The pair test's per-layer constants ([`PairScale`]), the step a pair of returns shows
//! ([`pair_shown`]) and the earlier returns a slot keeps for it ([`Back`]): the parts of the
//! pair test that the slot's fold, the pairs across a cell's edge and the step between
//! neighbouring cells share (`docs/core.md`, "Why the pair test").

use super::MAX_PAIR_DEPTH;

#[cfg(feature = "plane-rule")]
/// One earlier return of a slot that the pair test keeps ([`PlaneState::step_from_earlier`](super::PlaneState::step_from_earlier)):
/// its position `(u, v)` in the cell and its z (mm relative to the observation's reference
/// height). 4 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Back {
    pub(super) at: (i8, i8),
    pub(super) z: i16,
}

#[cfg(feature = "plane-rule")]
impl Back {
    /// No return (never read: the slot counts the returns it holds).
    pub(in crate::classify) const NONE: Self = Self { at: (0, 0), z: 0 };
}

/// The largest step allowance a [`PairScale`] holds, whole mm (16.383 m; a larger step is
/// taken as this).
pub(super) const PAIR_STEP_MAX_MM: u16 = (1 << 14) - 1;

/// The pair test's constants for one layer ([`PlaneState::step_from_last`](super::PlaneState::step_from_last)), set per layer
/// when the rule or the design changes ([`PlaneParams::pair_scale`](super::PlaneParams::pair_scale)), in one word (one load
/// on the per-point path): the step allowance in whole millimetres (floored, at most
/// [`PAIR_STEP_MAX_MM`]; a rise within it is not computed) in bits 18..=31, how many returns
/// before the last are paired too (0 ..= 2, [`PlaneRule::pair_depth`](super::PlaneRule::pair_depth) − 1) in bits 16..=17,
/// and the largest slope's rise per unit of position (c/64) in mm Q8 in the low half.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::classify) struct PairScale(u32);

#[cfg_attr(not(feature = "plane-rule"), allow(dead_code))]
impl PairScale {
    /// All zero: a layer's constants before a design, or without the plane rule (no fold
    /// reads them then).
    pub(in crate::classify) const NONE: Self = Self(0);

    /// The constants `step_mm` (mm, at most [`PAIR_STEP_MAX_MM`], a larger step taken as
    /// it) and `slope_q8` (mm Q8 per unit), each return paired with the last only.
    pub(in crate::classify) const fn new(step_mm: u16, slope_q8: u16) -> Self {
        let step = if step_mm > PAIR_STEP_MAX_MM {
            PAIR_STEP_MAX_MM
        } else {
            step_mm
        };
        Self(((step as u32) << 18) | slope_q8 as u32)
    }

    /// These constants with each return paired with the last `depth` returns of its cell
    /// (1 ..= [`MAX_PAIR_DEPTH`]; outside, the nearest bound).
    pub(in crate::classify) const fn with_depth(self, depth: u8) -> Self {
        let depth = if depth == 0 {
            1
        } else if depth > MAX_PAIR_DEPTH {
            MAX_PAIR_DEPTH
        } else {
            depth
        };
        Self((self.0 & !(3 << 16)) | ((depth as u32 - 1) << 16))
    }

    /// The step allowance, whole mm.
    pub(in crate::classify) const fn step_mm(self) -> u32 {
        self.0 >> 18
    }

    /// How many returns before the last each return is paired with too (0 ..= 2).
    pub(in crate::classify) const fn earlier(self) -> usize {
        ((self.0 >> 16) & 3) as usize
    }

    /// The largest slope's rise per unit of position, mm Q8.
    pub(in crate::classify) const fn slope_q8(self) -> u32 {
        self.0 & 0xFFFF
    }
}

/// The step a pair of returns shows (the pair test, [`PlaneState::keep_rise`](super::PlaneState::keep_rise)): for a rise of
/// `rise` mm over a horizontal run of `run` units of the layer's cells (c/64, L1), its part
/// beyond the largest slope `b = rise − slope·run` (floored at 0) plus the scale's step, at
/// most the rise: `min(rise, b + step)`, mm, saturated to 255. `min(rise, b + step) > step +
/// noise` exactly when `b > noise` and `rise > step + noise`. In 32-bit words (one
/// multiplication): a run of at most 510 units times a slope below 2¹⁶ stays below 2²⁵; a
/// larger run only saturates the slope's part.
#[cfg_attr(not(feature = "plane-rule"), allow(dead_code))]
#[inline]
pub(in crate::classify) fn pair_shown(rise: u32, run: u32, scale: PairScale) -> u8 {
    let beyond = (rise << 8).saturating_sub(scale.slope_q8().saturating_mul(run)) >> 8;
    let shown = (beyond + scale.step_mm()).min(rise);
    // At most 255 after the clamp: the cast is exact.
    #[allow(clippy::cast_possible_truncation)]
    let shown = shown.min(255) as u8;
    shown
}

#[cfg(feature = "plane-rule")]
/// The largest slope's rise per unit of a cell's position (c/64), mm Q8, for the pair test
/// ([`PlaneState::step_from_last`](super::PlaneState::step_from_last)): `⌊tan θ_max·c·1000/64 · 2⁸⌋` (from `grade_q16`, tan Q16,
/// and the cell side `cell_bits`, raw Q16.16 metres), saturated to `u16::MAX` (a slope of
/// 256 mm per unit: cells of 45 m and more at 20°). In 64 bits, saturating.
pub(super) fn pair_slope_q8(grade_q16: i64, cell_bits: i32) -> u16 {
    let grade = u64::try_from(grade_q16.max(0))
        .unwrap_or(0)
        .min(u64::from(u32::MAX));
    let cell = u64::from(cell_bits.max(0).unsigned_abs());
    // grade·c·1000 / 2¹⁶ / 64 · 2⁸ / 2¹⁶ = grade·c·1000 / 2³⁰ (below 2⁶³ / 2³⁰).
    let q8 = grade.saturating_mul(cell).saturating_mul(1000) >> 30;
    u16::try_from(q8).unwrap_or(u16::MAX)
}
