//! The classifier's layers from the ninth on (pyramids of more than eight layers): each point
//! by its gate weights, through the cell index, the hash and the probe (no remembered cell, no
//! pair across a cell's edge). Out of line: the default pyramid has eight layers.

use super::rule::PairScale;
use super::scratch::locate;
use super::Classifier;
use crate::units::Point3;

impl<const C: usize, const L: usize> Classifier<C, L> {
    /// [`Classifier::feed`] for layers 8 and up, by their gate weights (out of line: the
    /// default pyramid has eight layers).
    #[inline(never)]
    pub(super) fn feed_beyond_eight(
        &mut self,
        point: Point3,
        bin: usize,
        z: i16,
        hole: bool,
    ) -> bool {
        let bin_index = u16::try_from(bin).unwrap_or(u16::MAX);
        let min_weight = self.gates.min_feeding_weight();
        let mut fed = false;
        for k in 8..self.gates.layer_count() {
            let (Some(r), Some(gate)) = (self.gates.resolution(k), self.gates.table(k)) else {
                break;
            };
            if gate.weight(bin) < min_weight {
                continue;
            }
            // Stored as k + 1; k < L ≤ 254.
            let Ok(layer_index) = u8::try_from(k + 1) else {
                break;
            };
            let bits = r.to_bits();
            let known = self.layer_cells.get(k).copied();
            let (reciprocal, scale) = match known {
                Some((cell, m, scale)) if cell == bits && m != 0 => (m, scale),
                _ => {
                    let entry = (
                        bits,
                        crate::grid::cell_reciprocal(bits),
                        self.pair_scale(Some(bits)),
                    );
                    if let Some(cell) = self.layer_cells.get_mut(k) {
                        *cell = entry;
                    }
                    (entry.1, entry.2)
                }
            };
            fed |= self.feed_layer(layer_index, r, reciprocal, scale, point, bin_index, z, hole);
        }
        fed
    }

    /// Adds a point to its cell of one layer (stored as `layer_index` = k + 1); `false` when
    /// the table is full (counted).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn feed_layer(
        &mut self,
        layer_index: u8,
        r: crate::grid::Resolution,
        reciprocal: u32,
        scale: PairScale,
        point: Point3,
        bin: u16,
        z: i16,
        hole: bool,
    ) -> bool {
        let (cx, cy, sub) = locate(r, reciprocal, point, self.plane.is_some());
        self.feed_cell(layer_index, cx, cy, sub, bin, z, hole, scale)
    }

    /// Adds a point to cell `(cx, cy)` of one layer (stored as `layer_index` = k + 1), with the
    /// layer's pair test constants `scale` ([`fold`]); `false` when the table is full (counted).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn feed_cell(
        &mut self,
        layer_index: u8,
        cx: i32,
        cy: i32,
        sub: (i8, i8),
        bin: u16,
        z: i16,
        hole: bool,
        scale: PairScale,
    ) -> bool {
        let (bin, z) = (u32::from(bin), i32::from(z));
        if self
            .insert(
                layer_index,
                cx,
                cy,
                sub,
                bin,
                z,
                hole,
                self.plane.is_some(),
                scale,
            )
            .is_some()
        {
            true
        } else {
            self.stats.overflow_points = self.stats.overflow_points.saturating_add(1);
            false
        }
    }
}
