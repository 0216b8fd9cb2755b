//! The step from the last observation's lowest return (`docs/core.md`, the section of that
//! name): the first return an observation puts in a cell is paired with the lowest return the
//! last finished observation put in the same cell, as two consecutive returns are
//! ([`rule::pair_shown`]). Where the new return stands higher, more steeply than the largest
//! slope beyond the noise and by more than a step, the cell keeps the step the pair shows. The
//! last observation's cell is not marked again: its evidence is in the map, and ground that
//! rose since it looked (a car that arrived) marks the new observation's cell, while ground
//! that fell (a car that left) marks nothing.
//!
//! It finds what one observation cannot: a cell that straddles a kerb or a riser, the ground
//! before it lit by one observation and the top by the next (a tilting laser's sweeps, whose
//! lines interleave; the far rings of a laser that pans).
//!
//! # No memory of its own
//! A slot vacated at an observation's end keeps its cell's key, its lowest return and where
//! it lay; it only notes which layer it held and the observation's stamp ([`Held`], 2 bytes).
//! When the next observation takes that slot for the same cell, which it does where the cell
//! hashes to the same place and no cell of its own took that slot first, the pair is judged
//! before the slot is written. Elsewhere the pair is not made: the recall may miss a step,
//! never invent one. A stamp runs 1 ..= 255; when it comes round, every slot's is cleared.

#[cfg(feature = "plane-rule")]
use super::rule::{self, PairScale};
#[cfg(feature = "plane-rule")]
use super::scratch::Held;
use super::scratch::Slot;
use super::Classifier;

/// The last finished observation: its stamp (0: none to recall) and reference height.
#[derive(Debug, Clone, Copy)]
pub(super) struct RecallState {
    /// The stamp its vacated slots carry, 1 ..= 255; 0 when nothing may be recalled (a new
    /// configuration or design, the paper's rule).
    pub(super) last: u8,
    /// The stamp the last observation took (0 before the first).
    pub(super) counter: u8,
    /// Its reference height, raw Q16.16.
    pub(super) reference_z: i32,
}

impl RecallState {
    /// Nothing recalled.
    pub(super) const EMPTY: Self = Self {
        last: 0,
        counter: 0,
        reference_z: 0,
    };
}

impl<const C: usize, const L: usize> Classifier<C, L> {
    /// The stamp of the observation now ending; when the counter comes round, every slot's
    /// stamp is cleared first (so no slot 255 observations old is taken for the last one's).
    pub(super) fn next_stamp(&mut self) -> u8 {
        let stamp = self.recall_state.counter.wrapping_add(1);
        if stamp != 0 {
            return stamp;
        }
        self.clear_stamps();
        1
    }

    /// Clears every slot's stamp. Out of line: once in 255 observations.
    #[cold]
    #[inline(never)]
    fn clear_stamps(&mut self) {
        for slot in &mut self.slots {
            slot.held = super::scratch::Held::NONE;
        }
    }

    /// Forgets the last observation (a new configuration or design: its cells and heights no
    /// longer compare).
    pub(super) fn forget_last_observation(&mut self) {
        self.recall_state.last = 0;
    }
}

/// A slot vacated by the observation of stamp `stamp` (not 0): it notes the cell it held.
#[cfg(feature = "plane-rule")]
#[inline]
pub(super) fn vacate_held(slot: &mut Slot, stamp: u8) {
    slot.held = Held {
        layer: slot.layer,
        stamp,
    };
}

/// Without the `plane-rule` feature nothing is held.
#[cfg(not(feature = "plane-rule"))]
#[inline]
pub(super) fn vacate_held(_slot: &mut Slot, _stamp: u8) {}

/// The pair of a cell's first return (`z` mm relative to this observation's reference, at
/// `at`) with the lowest return `vacant` held for the same cell in the last observation (its
/// heights `shift` mm below this observation's once brought to one reference): the step it
/// shows, if the new return is the upper one and the step is beyond the layer's
/// (`scale`), else 0. Heights are `i32` words of `i16` values: nothing overflows.
#[cfg(feature = "plane-rule")]
#[cold]
#[inline(never)]
pub(super) fn step_from_held(
    vacant: &Slot,
    shift: i32,
    z: i32,
    at: (i8, i8),
    scale: PairScale,
    (step_mm, robot_height_mm): (i32, i32),
) -> u8 {
    let rise = z - (i32::from(vacant.z_low) + shift);
    if rise <= step_mm || rise > robot_height_mm {
        return 0;
    }
    let (u, v) = vacant.plane.low_at();
    let run = (i32::from(at.0) - i32::from(u)).unsigned_abs()
        + (i32::from(at.1) - i32::from(v)).unsigned_abs();
    // 0 < rise ≤ the robot's height (an i16): the cast is exact.
    #[allow(clippy::cast_sign_loss)]
    let shown = rule::pair_shown(rise as u32, run, scale);
    if u32::from(shown) > scale.step_mm() {
        shown
    } else {
        0
    }
}
