//! The robot-centric windows of the layers, implemented the plain way: each layer is a
//! `HashMap` from *world* cell indices to cells, and a recentre simply forgets every cell that
//! left the window (`retain`). No circular buffer, no modular indexing: a deliberately
//! different mechanism from the library's.

use std::collections::HashMap;

use super::bands::Design;
use super::decay::{self, Mode};
use super::gate::Tables;
use super::logodds::{Arithmetic, Cell, Class, Model, ULP};

/// `round(r·2¹⁶)` (ties away from zero): a cell size in raw Q16.16, as all cell maths uses it.
#[must_use]
pub fn resolution_raw(resolution: f64) -> i64 {
    (resolution * 65_536.0).round() as i64
}

/// The cell index of a raw Q16.16 coordinate: `floor(X / rq)`.
#[must_use]
pub fn cell_of(coordinate_raw: i64, rq: i64) -> i64 {
    coordinate_raw.div_euclid(rq)
}

/// A piece of evidence for one cell of one layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Evidence {
    /// k.
    pub layer: usize,
    /// The cell's world index along x.
    pub i: i64,
    /// The cell's world index along y.
    pub j: i64,
    /// Non-navigable (true) or navigable (false).
    pub obstacle: bool,
    /// The distance at which it was measured, raw Q16.16.
    pub distance_raw: i32,
}

/// What an update did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Applied {
    /// The cell was updated (and is observed).
    Updated,
    /// The gated increment was zero: nothing happened.
    NoEffect,
    /// The cell lies outside the layer's window: dropped (and counted).
    OutsideWindow,
    /// There is no such layer.
    NoSuchLayer,
}

/// One layer's window.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerWindow {
    /// The cell size, raw Q16.16.
    pub rq: i64,
    /// `(ox, oy)`: the window covers `[ox, ox+W) × [oy, oy+W)`.
    pub origin: (i64, i64),
    /// The observed cells, by world index (absent = unknown).
    pub cells: HashMap<(i64, i64), Cell>,
}

/// Per-layer counts over the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Observed cells (including L = 0).
    pub observed: usize,
    /// L > 0.
    pub obstacle: usize,
    /// L < 0.
    pub free: usize,
}

/// The reference pyramid: a design's layers, their tables and windows, and an update model.
#[derive(Debug, Clone)]
pub struct Pyramid {
    /// W, cells per side.
    pub cells: i64,
    /// The update rule.
    pub model: Model,
    /// The gate tables.
    pub tables: Tables,
    /// The layers, finest first.
    pub layers: Vec<LayerWindow>,
    /// Records whose cell was outside the window and whose gated increment is surely non-zero
    /// (for every table entry a conforming device may hold).
    pub dropped: u64,
    /// Records whose cell was outside the window, whatever their increment.
    pub outside: u64,
    /// Records naming a layer the design does not have.
    pub bad_layer: u64,
    /// The fused query's margin, nats (≥ 0).
    pub margin: f64,
    /// Decay: the mode and the sweep (`None`: no decay, the paper's behaviour).
    pub decay: Option<(Mode, decay::Sweep)>,
}

impl Pyramid {
    /// A new pyramid for `design`, centred on (0, 0), every cell unknown.
    #[must_use]
    pub fn new(design: &Design, model: Model, margin: f64) -> Self {
        let cells = design.cells as i64;
        let half = cells / 2;
        Self {
            cells,
            model,
            tables: Tables::new(design),
            layers: design
                .layers
                .iter()
                .map(|l| LayerWindow {
                    rq: resolution_raw(l.resolution),
                    origin: (-half, -half),
                    cells: HashMap::new(),
                })
                .collect(),
            dropped: 0,
            outside: 0,
            bad_layer: 0,
            margin,
            decay: None,
        }
    }

    /// Decays in `mode` with each layer's time-constant byte (`codes[k]`, 0 = none; missing
    /// entries none), from a fresh sweep.
    pub fn set_decay(&mut self, mode: Mode, codes: &[u8]) {
        let mut all = vec![0_u8; self.layers.len()];
        for (a, c) in all.iter_mut().zip(codes) {
            *a = *c;
        }
        self.decay =
            (mode != Mode::Off).then(|| (mode, decay::Sweep::new(self.cells as usize, &all)));
    }

    /// Accrues the decay owed at `now_ms` and pays it, layer by layer (`docs/core.md`,
    /// "Decay"). Returns the cells that became unknown.
    pub fn decay(&mut self, now_ms: u32) -> usize {
        let Some((mode, mut sweep)) = self.decay.take() else {
            return 0;
        };
        sweep.accrue(now_ms);
        let mut faded = 0;
        for k in 0..self.layers.len() {
            if let Some((first, count)) = sweep.take(k) {
                faded += self.decay_rows(k, first as i64, count as i64, mode);
            }
        }
        self.decay = Some((mode, sweep));
        faded
    }

    /// Is world cell (i, j) inside layer k's window?
    #[must_use]
    pub fn in_window(&self, k: usize, i: i64, j: i64) -> bool {
        let (ox, oy) = self.layers[k].origin;
        (ox..ox + self.cells).contains(&i) && (oy..oy + self.cells).contains(&j)
    }

    /// Layer k's cell (i, j): `None` outside the window, an unknown cell if never observed.
    #[must_use]
    pub fn cell(&self, k: usize, i: i64, j: i64) -> Option<Cell> {
        if !self.in_window(k, i, j) {
            return None;
        }
        Some(
            self.layers[k]
                .cells
                .get(&(i, j))
                .copied()
                .unwrap_or_default(),
        )
    }

    /// Applies one piece of evidence (`docs/core.md`, "One update").
    pub fn apply(&mut self, e: &Evidence) -> Applied {
        if e.layer >= self.layers.len() {
            self.bad_layer += 1;
            return Applied::NoSuchLayer;
        }
        let w = self.tables.weight(e.layer, e.distance_raw);
        if !self.in_window(e.layer, e.i, e.j) {
            self.outside += 1;
            if self.model.applies(e.obstacle, w) == Some(true) {
                self.dropped += 1;
            }
            return Applied::OutsideWindow;
        }
        let model = self.model;
        let cell = self.layers[e.layer].cells.entry((e.i, e.j)).or_default();
        // A cell that stays unknown keeps its entry (and so its error budget and threshold
        // flags); it still counts as unknown everywhere.
        if model.update(cell, e.obstacle, w) {
            Applied::Updated
        } else {
            Applied::NoEffect
        }
    }

    /// Recentres every layer on the robot at raw Q16.16 position (x, y): the new origin is the
    /// robot's cell minus W/2; every cell that left the window is forgotten.
    pub fn recentre(&mut self, x_raw: i32, y_raw: i32) {
        let half = self.cells / 2;
        let cells = self.cells;
        for layer in &mut self.layers {
            let cx = cell_of(i64::from(x_raw), layer.rq);
            let cy = cell_of(i64::from(y_raw), layer.rq);
            let (ox, oy) = (cx - half, cy - half);
            layer.origin = (ox, oy);
            layer.cells.retain(|&(i, j), _| {
                (ox..ox + cells).contains(&i) && (oy..oy + cells).contains(&j)
            });
        }
    }

    /// One decay step (`docs/core.md`, "Decay") for every cell of layer k whose world row j
    /// has `j mod W` among the `count` storage rows from `first` (modulo W). Quantised
    /// arithmetic: the fixed-point step; ideal: `L·e^{−1/8}`, a value under 2⁻⁹ nats reads
    /// unknown, and the cell's error budget shrinks by the factor and grows by one raw unit
    /// (a conforming device's step rounds by at most that). Returns the cells that became
    /// unknown.
    pub fn decay_rows(&mut self, k: usize, first: i64, count: i64, mode: Mode) -> usize {
        let w = self.cells;
        let arithmetic = self.model.arithmetic;
        let l0 = self.model.inverse.l0();
        let rows = |j: i64| (j.rem_euclid(w) - first).rem_euclid(w) < count.min(w);
        let mut faded = 0;
        self.layers[k].cells.retain(|&(_, j), cell| {
            if !rows(j) || !cell.is_observed() {
                return true;
            }
            let next = match arithmetic {
                Arithmetic::Quantised => {
                    let raw = cell.value.map(|v| (v * 256.0).round() as i64);
                    decay::step_quantised(raw, mode).map(|r| r as f64 / 256.0)
                }
                Arithmetic::Ideal => {
                    let before = cell.value.unwrap_or(0.0);
                    if !mode.ages(before) {
                        return true;
                    }
                    let stepped = decay::step_ideal(cell.value, mode);
                    // |q' − F·x| ≤ 1 raw unit + F_q·|q − x| + |F − F_q|·|x|, F_q < F and
                    // |F − F_q| < 3·10⁻⁷.
                    cell.budget = cell.budget * decay::factor() + ULP + 3e-7 * before.abs();
                    let next = if decay::ideal_is_unknown(stepped) {
                        // A device that has not faded yet continues from its value (within
                        // the budget of 0), this cell from L_0.
                        cell.budget += l0.abs();
                        None
                    } else {
                        stepped
                    };
                    if next.is_none_or(|v| v.abs() <= cell.budget) {
                        // A conforming device may have faded, or not.
                        cell.threshold_case = true;
                        cell.surely_observed = false;
                    }
                    next
                }
            };
            if next.is_none() {
                faded += 1;
            }
            cell.value = next;
            // A cell that became unknown keeps its entry (its error budget and flags), as
            // one that never became observed does.
            true
        });
        faded
    }

    /// Counts over layer k's window.
    #[must_use]
    pub fn counts(&self, k: usize) -> Counts {
        let mut c = Counts::default();
        for cell in self.layers[k].cells.values() {
            match cell.class() {
                Class::Unknown => {}
                Class::Undecided => c.observed += 1,
                Class::Obstacle => {
                    c.observed += 1;
                    c.obstacle += 1;
                }
                Class::Navigable => {
                    c.observed += 1;
                    c.free += 1;
                }
            }
        }
        c
    }
}

/// The default sensor's and schedule's design (64 cells, at most 16 layers) and its reference
/// pyramid at the origin, in quantised arithmetic with the default inverse model and clamp:
/// the tests' pyramid.
#[cfg(test)]
pub(crate) fn default_quantised() -> (crate::reference::bands::Design, Pyramid) {
    use crate::reference::bands::{design, Schedule};
    use crate::reference::bound::Sensor;
    use crate::reference::logodds::{Arithmetic, Clamp, InverseModel};
    let d = design(&Sensor::default(), &Schedule::default(), 64, 16)
        .result
        .unwrap();
    let model = Model {
        arithmetic: Arithmetic::Quantised,
        inverse: InverseModel::default(),
        clamp: Clamp::DEFAULT,
    };
    let pyramid = Pyramid::new(&d, model, 0.0);
    (d, pyramid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pyramid() -> Pyramid {
        default_quantised().1
    }

    #[test]
    fn floor_division_rounds_toward_minus_infinity() {
        assert_eq!(cell_of(-1, 6_554), -1);
        assert_eq!(cell_of(0, 6_554), 0);
        assert_eq!(cell_of(6_553, 6_554), 0);
        assert_eq!(cell_of(-6_554, 6_554), -1);
        assert_eq!(cell_of(-6_555, 6_554), -2);
        assert_eq!(resolution_raw(0.1), 6_554);
    }

    #[test]
    fn recentre_keeps_the_overlap_and_forgets_the_rest() {
        let mut p = pyramid();
        let near = 65_536 / 64; // 1/64 m: inside bin 0
        for (i, j) in [(-32, -32), (31, 31), (0, 0), (10, -5)] {
            let e = Evidence {
                layer: 0,
                i,
                j,
                obstacle: true,
                distance_raw: near * 16,
            };
            assert_eq!(p.apply(&e), Applied::Updated, "{i},{j}");
        }
        let out = Evidence {
            layer: 0,
            i: 32,
            j: 0,
            obstacle: true,
            distance_raw: near * 16,
        };
        assert_eq!(p.apply(&out), Applied::OutsideWindow);
        assert_eq!((p.dropped, p.outside), (1, 1));
        // Robot to x = +1 m: layer 0 (rq = 6 554) robot cell 9 → origin (−23, −32).
        p.recentre(65_536, 0);
        assert_eq!(p.layers[0].origin, (-23, -32));
        assert!(p.cell(0, -32, -32).is_none());
        assert!(p.cell(0, 31, 31).unwrap().is_observed());
        assert!(p.cell(0, 10, -5).unwrap().is_observed());
        assert_eq!(p.counts(0).observed, 3);
        // Back: the forgotten cell stays forgotten.
        p.recentre(0, 0);
        assert!(!p.cell(0, -32, -32).unwrap().is_observed());
        // A far jump resets the layer.
        p.recentre(1_000 * 65_536, 0);
        assert_eq!(p.counts(0).observed, 0);
    }
}
