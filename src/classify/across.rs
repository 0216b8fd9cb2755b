//! The pair test across a cell's edge (`docs/core.md`, "The pair test across a cell's edge"):
//! two consecutive returns of an observation that one of the first eight layers takes in
//! neighbouring cells, less than a cell's side apart, are a pair as two in one cell are; the
//! cell of the upper return keeps the step they show ([`rule::pair_shown`]).
//!
//! Every return compares its height with the previous one's against a threshold (the step
//! plus one); only a rise beyond the step keeps the slots the previous return went to, and the
//! next return (or the observation's end) judges the pair against the slots this one went to,
//! out of line. 36 bytes, all zero in an unconfigured classifier (its first return finds
//! nothing pending and sets the threshold).

use super::rule;
use super::scratch::{Recent, Slot, RECENT_LAYERS};

/// The previous return, and the pair across a cell's edge that waits to be judged.
#[derive(Debug, Clone, Copy)]
pub(super) struct AcrossEdge {
    /// The previous return's z (mm, as a slot's).
    previous_z: i32,
    /// The layers of the first eight whose cells took the previous return (0: none, at an
    /// observation's start).
    previous_fed: u32,
    /// A return whose height differs from the previous one's by this much or more (mm) goes
    /// to [`AcrossEdge::at_return`]: the step plus one, or 0 while a pair waits to be judged
    /// (and in an unconfigured classifier).
    threshold: u32,
    /// The waiting pair's earlier return: its slots (entry k for layer k), its layers and its z.
    before: [u16; RECENT_LAYERS],
    before_fed: u32,
    before_z: i32,
}

impl AcrossEdge {
    /// All zero bits (for a classifier in `.bss`).
    pub(super) const ZERO: Self = Self {
        previous_z: 0,
        previous_fed: 0,
        threshold: 0,
        before: [0; RECENT_LAYERS],
        before_fed: 0,
        before_z: 0,
    };

    /// Nothing pending, no previous return, with a step of `step_mm` (mm, ≥ 0).
    pub(super) const fn resting(step_mm: i16) -> Self {
        let mut across = Self::ZERO;
        across.threshold = resting_threshold(step_mm);
        across
    }

    /// Forgets the previous return and any waiting pair (an observation's end or discard).
    pub(super) fn forget(&mut self, step_mm: i16) {
        self.previous_fed = 0;
        self.threshold = resting_threshold(step_mm);
    }

    /// Whether a return at `z` (mm, as a slot's) must go to [`AcrossEdge::at_return`] before
    /// the layers take it: it differs from the previous one by the threshold or more.
    #[inline(always)]
    pub(super) const fn wants(&self, z: i32) -> bool {
        z.abs_diff(self.previous_z) >= self.threshold
    }

    /// The layers took the return at `z` (mm): `fed`, those of the first eight whose cells
    /// took it. It is the next one's previous.
    #[inline(always)]
    pub(super) fn took(&mut self, z: i32, fed: u32) {
        self.previous_z = z;
        self.previous_fed = fed;
    }

    /// At a return of height `z` (mm) that [`AcrossEdge::wants`], before the layers take it:
    /// the waiting pair is judged ([`AcrossEdge::settle`]); when this return rises more than
    /// `step_mm` from the previous one, which some layers took, the previous one's slots
    /// (named by the layers' entries `recent`) and height are kept and its pair waits until
    /// the next return or the observation's end. Out of line: rare.
    #[cold]
    #[inline(never)]
    pub(super) fn at_return(
        &mut self,
        z: i32,
        step_mm: i16,
        robot_height_mm: i16,
        slots: &mut [Slot],
        recent: &[Recent; RECENT_LAYERS],
    ) {
        self.settle(step_mm, robot_height_mm, slots, recent);
        if z.abs_diff(self.previous_z) > u32::from(step_mm.unsigned_abs()) && self.previous_fed != 0
        {
            for (slot, entry) in self.before.iter_mut().zip(recent) {
                *slot = entry.slot;
            }
            self.before_fed = self.previous_fed;
            self.before_z = self.previous_z;
            // The next return comes here whatever its height.
            self.threshold = 0;
        }
    }

    /// Judges the waiting pair, if any: the earlier return (`before_z`, its slots `before`)
    /// and the previous one (`previous_z`), in each layer that took both, whose slot its entry
    /// in `recent` names. In each such layer whose two cells differ, are neighbours and hold
    /// the two returns less than a cell's side apart ([`run_between`]), with a rise of at most
    /// the robot's height (a higher return is overhang to the lower one's cell), the slot of
    /// the upper return keeps the step the pair shows ([`rule::pair_shown`]).
    pub(super) fn settle(
        &mut self,
        step_mm: i16,
        robot_height_mm: i16,
        slots: &mut [Slot],
        recent: &[Recent; RECENT_LAYERS],
    ) {
        if self.threshold == 0 {
            self.threshold = resting_threshold(step_mm);
            self.judge(robot_height_mm, slots, recent);
        }
    }

    /// [`AcrossEdge::settle`]'s judgement of the waiting pair. Out of line: rare.
    #[cold]
    #[inline(never)]
    fn judge(&self, robot_height_mm: i16, slots: &mut [Slot], recent: &[Recent; RECENT_LAYERS]) {
        let (z, layers) = (self.previous_z, self.before_fed & self.previous_fed);
        let rise = z.abs_diff(self.before_z);
        if rise > u32::from(robot_height_mm.unsigned_abs()) {
            return;
        }
        for (k, (&last, entry)) in self.before.iter().zip(recent).enumerate() {
            let (last, index) = (usize::from(last), usize::from(entry.slot));
            if layers & (1 << k) == 0 || last == index {
                continue;
            }
            let (Some(previous), Some(current)) = (slots.get(last), slots.get(index)) else {
                continue;
            };
            let Some(run) = run_between(previous, current) else {
                continue;
            };
            let scale = entry.pair_scale;
            let shown = rule::pair_shown(rise, run, scale);
            if u32::from(shown) <= scale.step_mm() {
                continue;
            }
            let upper = if z > self.before_z { index } else { last };
            if let Some(slot) = slots.get_mut(upper) {
                slot.plane.keep_shown(shown);
            }
        }
    }
}

/// The threshold with nothing pending: the step plus one (mm).
const fn resting_threshold(step_mm: i16) -> u32 {
    step_mm.unsigned_abs() as u32 + 1
}

/// The run from the last return of slot `previous` to that of slot `current` (one layer's
/// cells), in units of c/64 (|Δu| + |Δv|, each from the cells' indices and the returns'
/// positions as their cells hold them, [`rule::PlaneState::last_at`]): `None` unless the cells are
/// neighbours and the run is below a cell's side (64 units).
fn run_between(previous: &Slot, current: &Slot) -> Option<u32> {
    let along = |cells: i32, to: i8, from: i8| {
        // Neighbouring cells only (a wrapped difference beyond ±1 is not one): within
        // ±(64 + 63) units.
        (-1..=1)
            .contains(&cells)
            .then(|| (cells * 64 + i32::from(to) - i32::from(from)).unsigned_abs())
    };
    let ((u, v), (to_u, to_v)) = (previous.plane.last_at(), current.plane.last_at());
    let du = along(current.cell_x.wrapping_sub(previous.cell_x), to_u, u)?;
    let dv = along(current.cell_y.wrapping_sub(previous.cell_y), to_v, v)?;
    Some(du + dv).filter(|&run| run < 64)
}

#[cfg(all(test, feature = "plane-rule"))]
mod tests {
    use super::*;

    /// A slot of cell `(cx, cy)` whose last return lies at `(u, v)` (units of c/64 from the
    /// cell's centre).
    fn slot(cx: i32, cy: i32, u: i8, v: i8) -> Slot {
        let mut s = Slot::VACANT;
        s.cell_x = cx;
        s.cell_y = cy;
        s.plane = rule::PlaneState::first(u, v, 0);
        s
    }

    #[test]
    fn a_run_is_taken_between_neighbours_less_than_a_side_apart() {
        // Across the edge x = 3 from both sides of it: 2 units.
        assert_eq!(
            run_between(&slot(2, 0, 31, 0), &slot(3, 0, -31, 0)),
            Some(2)
        );
        // And back, and to the north.
        assert_eq!(
            run_between(&slot(3, 0, -31, 0), &slot(2, 0, 31, 0)),
            Some(2)
        );
        assert_eq!(
            run_between(&slot(0, 2, 0, 31), &slot(0, 3, 5, -31)),
            Some(7)
        );
        // Just below a side, and a side apart.
        assert_eq!(run_between(&slot(2, 0, 0, 0), &slot(3, 0, -1, 0)), Some(63));
        assert_eq!(run_between(&slot(2, 0, 0, 0), &slot(3, 0, 0, 0)), None);
        // Cells that are not neighbours, however close the returns' positions.
        assert_eq!(run_between(&slot(2, 0, 31, 0), &slot(4, 0, -32, 0)), None);
        assert_eq!(run_between(&slot(2, 0, 0, 0), &slot(3, 2, 0, 0)), None);
    }
}
