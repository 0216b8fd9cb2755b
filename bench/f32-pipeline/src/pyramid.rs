//! The `f32` pyramid: per layer a W × W circular window of `f32` log-odds (NaN = unknown),
//! recentred with row and column resets, clamped to OctoMap's −2 ..= 3.5, with dirty tiles.

use super::*;

/// One layer: a circular window of f32 log-odds, NaN = unknown.
pub struct Layer<const W: usize> {
    pub(crate) cells: [[f32; W]; W],
    pub(crate) origin_x: i32,
    pub(crate) origin_y: i32,
    pub(crate) start_x: usize,
    pub(crate) start_y: usize,
    pub(crate) inv_res: f32,
    /// A unit of position in the cell (c/64), mm: the plane rule's pair test reads the
    /// largest slope's rise over it.
    pub(crate) unit_mm: f32,
    pub(crate) dirty: u64,
}

impl<const W: usize> Layer<W> {
    pub(crate) const fn new() -> Self {
        Self {
            cells: [[f32::NAN; W]; W],
            origin_x: 0,
            origin_y: 0,
            start_x: 0,
            start_y: 0,
            inv_res: 1.0,
            unit_mm: 1000.0 / 64.0,
            dirty: 0,
        }
    }

    #[inline]
    pub(crate) fn slot(start: usize, offset: usize) -> usize {
        let s = start + offset;
        if s >= W {
            s - W
        } else {
            s
        }
    }

    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn update(
        &mut self,
        i: i32,
        j: i32,
        g: f32,
        reach: f32,
        initial: f32,
        min: f32,
        max: f32,
    ) {
        #[allow(clippy::cast_sign_loss)]
        let (ox, oy) = (
            i.wrapping_sub(self.origin_x) as u32 as usize,
            j.wrapping_sub(self.origin_y) as u32 as usize,
        );
        if ox >= W || oy >= W {
            return;
        }
        let (col, row) = (Self::slot(self.start_x, ox), Self::slot(self.start_y, oy));
        if let Some(cell) = self.cells.get_mut(row).and_then(|r| r.get_mut(col)) {
            let start = if cell.is_nan() { initial } else { *cell };
            // Comparisons, not `f32::clamp`/`min`/`max`: those are `fminf`/`fmaxf` calls on an
            // FPv4 (NaN rules), and no value here is NaN.
            let sum = start + g;
            // The record carries the cell toward g's sign no further than its reach (the
            // bound on that side scaled by the gate's weight), a cell beyond it stays.
            let sum = if g < 0.0 {
                let floor = if start < reach { start } else { reach };
                if sum < floor {
                    floor
                } else {
                    sum
                }
            } else {
                let ceiling = if start > reach { start } else { reach };
                if sum > ceiling {
                    ceiling
                } else {
                    sum
                }
            };
            let new = if sum < min {
                min
            } else if sum > max {
                max
            } else {
                sum
            };
            if new != *cell {
                *cell = new;
                let tile = (row * TILES_PER_SIDE / W) * TILES_PER_SIDE + col * TILES_PER_SIDE / W;
                self.dirty |= 1 << (tile & 63);
            }
        }
    }

    /// The ring slots a move of `delta` cells (|delta| < W) brings in along an axis whose
    /// oldest slot is `start`: the first of them and how many, in order from there.
    #[allow(clippy::cast_possible_truncation)]
    fn entering(start: usize, delta: i64) -> (usize, usize) {
        let count = delta.unsigned_abs() as usize;
        let first = if delta > 0 {
            start
        } else {
            Self::slot(start, W - count)
        };
        (first, count)
    }

    /// Moves the origin to world cell (nx, ny), resetting what enters; returns cells reset.
    pub(crate) fn move_origin(&mut self, nx: i32, ny: i32) -> usize {
        let w = W as i64;
        let (dx, dy) = (
            i64::from(nx) - i64::from(self.origin_x),
            i64::from(ny) - i64::from(self.origin_y),
        );
        let reset = if dx.abs() >= w || dy.abs() >= w {
            for row in &mut self.cells {
                row.fill(f32::NAN);
            }
            W * W
        } else {
            let mut n = 0;
            if dy != 0 {
                let (first, count) = Self::entering(self.start_y, dy);
                for t in 0..count {
                    if let Some(row) = self.cells.get_mut(Self::slot(first, t)) {
                        row.fill(f32::NAN);
                    }
                }
                n += count * W;
            }
            #[allow(clippy::cast_possible_truncation)]
            if dx != 0 {
                let (first, count) = Self::entering(self.start_x, dx);
                for row in &mut self.cells {
                    for t in 0..count {
                        if let Some(c) = row.get_mut(Self::slot(first, t)) {
                            *c = f32::NAN;
                        }
                    }
                }
                n += count * (W - dy.unsigned_abs() as usize);
            }
            n
        };
        self.origin_x = nx;
        self.origin_y = ny;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        {
            self.start_x = i64::from(nx).rem_euclid(w) as usize;
            self.start_y = i64::from(ny).rem_euclid(w) as usize;
        }
        reset
    }
}

/// The f32 pyramid: L layers of W × W cells and their gate tables.
pub struct Pyramid<const W: usize, const L: usize> {
    pub(crate) layers: [Layer<W>; L],
    pub(crate) gates: [[f32; GATE_BINS]; L],
    pub(crate) count: usize,
    pub(crate) bins_per_m: f32,
    pub(crate) obstacle: f32,
    pub(crate) free: f32,
    pub(crate) initial: f32,
    pub(crate) min: f32,
    pub(crate) max: f32,
    /// Cells reset by window moves.
    pub cells_reset: u32,
}

impl<const W: usize, const L: usize> Pyramid<W, L> {
    /// An unconfigured pyramid (no layers). `const`, for a `static`.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            layers: [const { Layer::new() }; L],
            gates: [[0.0; GATE_BINS]; L],
            count: 0,
            bins_per_m: 1.0,
            obstacle: 0.0,
            free: 0.0,
            initial: 0.0,
            min: -2.0,
            max: 3.5,
            cells_reset: 0,
        }
    }

    /// Configures the layers and gates from the library's design (configuration time).
    ///
    /// # Errors
    /// The design or configuration the library refuses.
    pub fn configure(&mut self, design: &Design<L>, config: &Config) -> Result<(), DesignError> {
        let increments = config.model.increments()?;
        let bins = DistanceBins::for_range(design.sensor().max_range_m);
        self.bins_per_m = 1.0 / bins.width_m();
        self.obstacle = increments.obstacle.to_num();
        self.free = increments.free.to_num();
        self.initial = increments.initial.to_num();
        if let terrain_pyramid::Clamp::Bounds { min, max } = config.clamp {
            self.min = min.to_num();
            self.max = max.to_num();
        } else {
            self.min = -128.0;
            self.max = 128.0;
        }
        self.count = design.layers().len();
        for (k, ((layer, gate), d)) in self
            .layers
            .iter_mut()
            .zip(self.gates.iter_mut())
            .zip(design.layers())
            .enumerate()
        {
            *layer = Layer::new();
            layer.inv_res = 1.0 / d.resolution_m;
            layer.unit_mm = d.resolution_m * 1000.0 / 64.0;
            let table = GateTable::build(design, k, bins);
            for (w, q) in gate.iter_mut().zip(table.weights()) {
                let skip = gated(increments.obstacle, *q) == 0 && gated(increments.free, *q) == 0;
                *w = if skip { 0.0 } else { q.to_num() };
            }
            let _ = layer.move_origin(-(W as i32) / 2, -(W as i32) / 2);
        }
        Ok(())
    }

    #[inline]
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    pub(crate) fn bin(&self, distance: f32) -> usize {
        let d = if distance > 0.0 { distance } else { 0.0 };
        let b = (d * self.bins_per_m) as usize;
        b.min(GATE_BINS - 1)
    }

    /// Recentres every layer on the robot at (x, y); returns cells reset.
    pub fn recentre(&mut self, x: f32, y: f32) -> usize {
        let mut reset = 0;
        for layer in self.layers.iter_mut().take(self.count) {
            let half = (W / 2) as i32;
            let nx = floor_i32(x * layer.inv_res) - half;
            let ny = floor_i32(y * layer.inv_res) - half;
            reset += layer.move_origin(nx, ny);
        }
        self.cells_reset = self
            .cells_reset
            .saturating_add(u32::try_from(reset).unwrap_or(u32::MAX));
        reset
    }

    /// The log-odds of world cell (i, j) of layer k; `None` when unknown or outside.
    #[must_use]
    pub fn get(&self, k: usize, i: i32, j: i32) -> Option<f32> {
        let layer = self.layers.get(k)?;
        let ox = usize::try_from(i.checked_sub(layer.origin_x)?)
            .ok()
            .filter(|&o| o < W)?;
        let oy = usize::try_from(j.checked_sub(layer.origin_y)?)
            .ok()
            .filter(|&o| o < W)?;
        let v = *layer
            .cells
            .get(Layer::<W>::slot(layer.start_y, oy))?
            .get(Layer::<W>::slot(layer.start_x, ox))?;
        (!v.is_nan()).then_some(v)
    }
}

impl<const W: usize, const L: usize> Default for Pyramid<W, L> {
    fn default() -> Self {
        Self::new()
    }
}
