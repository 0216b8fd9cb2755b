//! The step between neighbouring cells' lowest returns (`docs/core.md`, the section of that
//! name): at an observation's end, before any cell is judged, the lowest return of each cell
//! (its ground, the bound of its overhang cut) is paired with the lowest return of the cell
//! beside it in the same layer, to the east (+x) and to the north (+y). Two such returns,
//! however far apart in their cells (|Δu| + |Δv| up to 190 units of c/64), rising more than the
//! step and no more than the robot's height, are judged as two consecutive returns are
//! ([`rule::pair_shown`]): the largest slope's allowance grows with their run, so a rise over
//! a long run must be the steeper to count. The cell of the upper one keeps the step they
//! show.
//!
//! No bound on the run: a cell's lowest return lies anywhere on a flat cell, and a riser or a
//! kerb on the edge between two flat cells is a step whatever the two lowest returns' places
//! (a nodding lidar's treads: `docs/core.md`).
//!
//! It finds the kerb the pair tests cannot: one whose face lies on the edge between two cells
//! with no two consecutive returns across it (a kerb along a spinning laser's beams, where
//! consecutive returns in firing order run along it; a riser parallel to a nodding lidar's
//! lines). Its cost: two lookups of the scratch's table a cell, and the judgement only where
//! two lowest returns differ by more than the step. Plane rule only: the position of a cell's
//! lowest return is kept by the plane rule's state.

use super::scratch::{hash, EMPTY};
use super::{rule, Classifier};

impl<const C: usize, const L: usize> Classifier<C, L> {
    /// Pairs the lowest return of every cell in use with those of its east and north
    /// neighbours ([`Classifier::judge_lowest`]). Visits the cells in use only.
    pub(super) fn steps_between_cells(&mut self) {
        for i in 0..self.used {
            let Some(&index) = self.order.get(i) else {
                break;
            };
            let index = usize::from(index) & Self::MASK;
            let Some(cell) = self.slots.get(index) else {
                continue;
            };
            let (layer, x, y) = (cell.layer, cell.cell_x, cell.cell_y);
            if layer == EMPTY {
                continue;
            }
            if let Some(east) = self.find(layer, x.wrapping_add(1), y) {
                self.judge_lowest(index, east, (64, 0));
            }
            if let Some(north) = self.find(layer, x, y.wrapping_add(1)) {
                self.judge_lowest(index, north, (0, 64));
            }
        }
    }

    /// The slot of `(layer, cx, cy)` if the observation touched that cell: the probe of
    /// [`Classifier::insert`](super::Classifier), reading only. Written twice on purpose: the
    /// insert built on a shared probe cost 0.8 instructions a return more on the M4F (759.4
    /// against 758.6, `cargo xtask bench`), on the per-point path.
    fn find(&self, layer: u8, cx: i32, cy: i32) -> Option<usize> {
        let mut index = hash(layer, cx, cy) as usize & Self::MASK;
        for _ in 0..C {
            let slot = self.slots.get(index)?;
            if slot.layer == EMPTY {
                return None;
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                return Some(index);
            }
            index = (index + 1) & Self::MASK;
        }
        None
    }

    /// The lowest returns of slot `a` and of slot `b`, its neighbour `offset` (units of c/64:
    /// (64, 0) east, (0, 64) north) away: anything to judge only when their heights differ by
    /// more than the step.
    #[inline]
    fn judge_lowest(&mut self, a: usize, b: usize, offset: (i32, i32)) {
        let (Some(low_a), Some(low_b)) = (self.slots.get(a), self.slots.get(b)) else {
            return;
        };
        let rise = i32::from(low_b.z_low) - i32::from(low_a.z_low);
        if rise.unsigned_abs() > u32::from(self.step_mm.unsigned_abs()) {
            self.judge_step(a, b, offset, rise);
        }
    }

    /// [`Classifier::judge_lowest`]'s pair, rising `rise` mm from `a`'s lowest return to
    /// `b`'s: when the rise is at most the robot's height, the upper slot keeps the step the
    /// pair shows over their run if it is beyond the layer's step. Out of line: rare.
    #[cold]
    #[inline(never)]
    fn judge_step(&mut self, a: usize, b: usize, offset: (i32, i32), rise: i32) {
        let (Some(low_a), Some(low_b)) = (self.slots.get(a), self.slots.get(b)) else {
            return;
        };
        let rise_mm = rise.unsigned_abs();
        if rise_mm > u32::from(self.robot_height_mm.unsigned_abs()) {
            return;
        }
        let ((ua, va), (ub, vb)) = (low_a.plane.low_at(), low_b.plane.low_at());
        let du = i32::from(ub) + offset.0 - i32::from(ua);
        let dv = i32::from(vb) + offset.1 - i32::from(va);
        let run = du.unsigned_abs() + dv.unsigned_abs();
        let layer = usize::from(low_a.layer.saturating_sub(1));
        // The first eight layers keep their constants; the others compute them.
        let scale = match self.recent.get(layer) {
            Some(recent) => recent.pair_scale,
            None => self.pair_scale(
                self.gates
                    .resolution(layer)
                    .map(crate::grid::Resolution::to_bits),
            ),
        };
        let shown = rule::pair_shown(rise_mm, run, scale);
        if u32::from(shown) <= scale.step_mm() {
            return;
        }
        let upper = if rise > 0 { b } else { a };
        if let Some(slot) = self.slots.get_mut(upper) {
            slot.plane.keep_shown(shown);
        }
    }
}
