//! The fused query of `docs/core.md`: walk the layers from the finest; the first layer whose
//! cell at the point is observed and either positive (obstacle) or below −margin (navigable)
//! answers, except that a navigable answer of layer k gives way to the first of layers
//! k + 1 ..= k + max(3, k) whose cell holds more obstacle evidence than layer k's, and
//! every observed layer's between them, hold free evidence; otherwise unknown. And the region
//! export that samples it at a grid's centres.

use super::logodds::Cell;
use super::window::{cell_of, Pyramid};

/// How many coarser layers may overrule layer `k`'s navigable answer (`docs/core.md`, "The
/// fused query"): three, and every layer whose cells are at most twice as wide under the
/// schedule `r_k = k·γ·Δd` (j ≤ 2k).
fn reach(k: usize) -> usize {
    3.max(k)
}

/// The answer of the fused query.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fused {
    /// No layer answers.
    Unknown,
    /// The first answering layer holds L > 0.
    Obstacle {
        /// The answering layer.
        layer: usize,
    },
    /// The first answering layer holds L < −margin.
    Navigable {
        /// The answering layer.
        layer: usize,
    },
}

impl Pyramid {
    /// The fused answer at the raw Q16.16 point (x, y).
    #[must_use]
    pub fn fused(&self, x_raw: i32, y_raw: i32) -> Fused {
        for k in 0..self.layers.len() {
            match self.value_at(k, x_raw, y_raw) {
                Some(l) if l > 0.0 => return Fused::Obstacle { layer: k },
                Some(l) if l < -self.margin => {
                    // The strongest free evidence from layer k to the one looked at.
                    let mut free = -l;
                    for j in k + 1..=k + reach(k) {
                        let value = self.value_at(j, x_raw, y_raw).unwrap_or(0.0);
                        if value > free {
                            return Fused::Obstacle { layer: j };
                        }
                        free = free.max(-value);
                    }
                    return Fused::Navigable { layer: k };
                }
                _ => {}
            }
        }
        Fused::Unknown
    }

    /// Layer `k`'s log-odds at the raw point, `None` where there is no such layer or its cell
    /// there is outside the window or unknown.
    fn value_at(&self, k: usize, x_raw: i32, y_raw: i32) -> Option<f64> {
        self.cell_at(k, x_raw, y_raw)?.value
    }

    /// Layer `k`'s log-odds and error budget at the raw point: `Some(None)` where it holds
    /// none (no such layer, outside its window, or unknown), `None` where a fixed-point
    /// pyramid that follows the spec could hold that cell observed or not (a threshold case).
    fn settled_value(&self, k: usize, x_raw: i32, y_raw: i32) -> Option<Option<(f64, f64)>> {
        let Some(cell) = self.cell_at(k, x_raw, y_raw) else {
            return Some(None);
        };
        if cell.threshold_case && !cell.surely_observed {
            return None;
        }
        Some(cell.value.map(|l| (l, cell.budget)))
    }

    /// Layer `k`'s cell at the raw point, `None` where there is no such layer or the point
    /// lies outside its window.
    fn cell_at(&self, k: usize, x_raw: i32, y_raw: i32) -> Option<Cell> {
        let layer = self.layers.get(k)?;
        let i = cell_of(i64::from(x_raw), layer.rq);
        let j = cell_of(i64::from(y_raw), layer.rq);
        self.cell(k, i, j)
    }

    /// The fused answer, or `None` when a fixed-point pyramid that follows the spec could
    /// legitimately answer differently from this one: some layer visited before (or at) the
    /// answering one has a cell whose observed-ness or whose comparison with 0 or −margin
    /// lies within its error budget. (In the quantised arithmetic the budget is 0 unless a
    /// table entry may legitimately differ, so this is nearly always [`Pyramid::fused`].)
    #[must_use]
    pub fn fused_robust(&self, x_raw: i32, y_raw: i32) -> Option<Fused> {
        for k in 0..self.layers.len() {
            let Some((l, e)) = self.settled_value(k, x_raw, y_raw)? else {
                continue;
            };
            if e > 0.0 && (l.abs() <= e || (l + self.margin).abs() <= e) {
                return None;
            }
            if l > 0.0 {
                return Some(Fused::Obstacle { layer: k });
            }
            if l < -self.margin {
                // Each coarser layer's comparison with the strongest free evidence before it
                // (from layer k on), within their budgets, or its observed-ness on a
                // threshold, could go either way.
                let (mut free, mut free_budget) = (-l, e);
                for j in k + 1..=k + reach(k) {
                    let Some((n, n_budget)) = self.settled_value(j, x_raw, y_raw)? else {
                        continue;
                    };
                    let budget = free_budget + n_budget;
                    if (n - free).abs() <= budget && budget > 0.0 {
                        return None;
                    }
                    if n > free {
                        return Some(Fused::Obstacle { layer: j });
                    }
                    if -n > free {
                        (free, free_budget) = (-n, n_budget);
                    }
                }
                return Some(Fused::Navigable { layer: k });
            }
        }
        Some(Fused::Unknown)
    }

    /// The fused answer at the centres of a caller's grid: `(x0 + (i + ½)·s, y0 + (j + ½)·s)`
    /// for i < width, j < height, row j = 0 first. Coordinates are raw Q16.16; the centre's
    /// half step is computed exactly as `(2i + 1)·s / 2` and must be an integer (s even).
    ///
    /// # Panics
    /// If `step_raw` is odd.
    #[must_use]
    pub fn fused_region(
        &self,
        x0_raw: i32,
        y0_raw: i32,
        step_raw: i32,
        width: usize,
        height: usize,
    ) -> Vec<Fused> {
        assert!(step_raw % 2 == 0, "odd step: the centres are not exact");
        let mut out = Vec::with_capacity(width * height);
        for j in 0..height {
            for i in 0..width {
                let x = i64::from(x0_raw) + (2 * i as i64 + 1) * i64::from(step_raw) / 2;
                let y = i64::from(y0_raw) + (2 * j as i64 + 1) * i64::from(step_raw) / 2;
                out.push(self.fused(x as i32, y as i32));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::window::{default_quantised, Evidence};

    /// The reach written by index is the rule of `docs/core.md`: the next three layers, and
    /// every layer whose cells are at most twice as wide under `r_k = k·γ·Δd`.
    #[test]
    fn the_reach_is_three_layers_and_every_one_of_cells_at_most_twice_as_wide() {
        for gamma in [1.5, 2.0, 3.0, 4.5] {
            let r = |k: usize| if k == 0 { 0.1 } else { k as f64 * gamma * 0.1 };
            for k in 1..64 {
                let widest = (k + 1..k + 200)
                    .take_while(|&j| r(j) <= 2.0 * r(k) + 1e-12)
                    .last()
                    .unwrap_or(k);
                assert_eq!(reach(k), 3.max(widest - k), "γ {gamma}, layer {k}");
            }
        }
        assert_eq!(reach(0), 3);
    }

    #[test]
    fn finer_positive_evidence_wins_and_undecided_falls_through() {
        let (d, mut p) = default_quantised();
        assert_eq!(p.fused(0, 0), Fused::Unknown);
        // Layer 1 (r = 0.2 m) says free at the origin; layer 0 says nothing yet.
        let l1 = d.layers[1].centre;
        let dist = (l1 * 65_536.0) as i32;
        p.apply(&Evidence {
            layer: 1,
            i: 0,
            j: 0,
            obstacle: false,
            distance_raw: dist,
        });
        assert_eq!(p.fused(100, 100), Fused::Navigable { layer: 1 });
        // Layer 0 sees an obstacle: it answers first.
        p.apply(&Evidence {
            layer: 0,
            i: 0,
            j: 0,
            obstacle: true,
            distance_raw: (d.layers[0].centre * 65_536.0) as i32,
        });
        assert_eq!(p.fused(100, 100), Fused::Obstacle { layer: 0 });
        // With a large margin the free layer no longer answers.
        p.margin = 10.0;
        assert_eq!(p.fused(-100, -100), Fused::Unknown);
    }

    /// One look of `layer` at its cell (0, 0) from its band's centre.
    fn look_at_origin(
        d: &crate::reference::bands::Design,
        layer: usize,
        obstacle: bool,
    ) -> Evidence {
        Evidence {
            layer,
            i: 0,
            j: 0,
            obstacle,
            distance_raw: (d.layers[layer].centre * 65_536.0) as i32,
        }
    }

    #[test]
    fn the_next_layers_stronger_obstacle_evidence_answers() {
        let (d, mut p) = default_quantised();
        let look = |layer: usize, obstacle: bool| look_at_origin(&d, layer, obstacle);
        p.apply(&look(0, false));
        assert_eq!(p.fused(100, 100), Fused::Navigable { layer: 0 });
        // One obstacle look of layer 1 outweighs one free look of layer 0.
        p.apply(&look(1, true));
        assert_eq!(p.fused(100, 100), Fused::Obstacle { layer: 1 });
        assert_eq!(p.fused_robust(100, 100), Some(Fused::Obstacle { layer: 1 }));
        // Three free looks outweigh it.
        p.apply(&look(0, false));
        p.apply(&look(0, false));
        assert_eq!(p.fused(100, 100), Fused::Navigable { layer: 0 });
    }

    #[test]
    fn three_coarser_layers_may_answer_past_stronger_free_evidence_only() {
        let (d, mut p) = default_quantised();
        let look = |layer: usize, obstacle: bool| look_at_origin(&d, layer, obstacle);
        p.apply(&look(0, false));
        // Layer 3's obstacle, two unobserved layers between: it answers.
        p.apply(&look(3, true));
        assert_eq!(p.fused(100, 100), Fused::Obstacle { layer: 3 });
        // Layer 1's three free looks between outweigh it: layer 0's answer stands.
        for _ in 0..3 {
            p.apply(&look(1, false));
        }
        assert_eq!(p.fused(100, 100), Fused::Navigable { layer: 0 });
        assert_eq!(
            p.fused_robust(100, 100),
            Some(Fused::Navigable { layer: 0 })
        );
        // Layer 4 is beyond the reach, however strong.
        let (_, mut q) = default_quantised();
        q.apply(&look(0, false));
        for _ in 0..4 {
            q.apply(&look(4, true));
        }
        assert_eq!(q.fused(100, 100), Fused::Navigable { layer: 0 });
    }
}
