//! One robot-centric layer as a circular buffer, and its index maths.
//!
//! A layer is a W × W window of [`Cell`]s over world cells `[ox, ox+W) × [oy, oy+W)`. World
//! cell `(i, j)` lives at storage slot `(i mod W, j mod W)`, so when the robot moves the
//! window moves by changing its origin: only the rows and columns that enter are reset to
//! unknown, and nothing is copied (grid_map's `GridMap::move`). The index maths are small free
//! functions: [`cell_of`], [`window_offset`], [`slot`], [`entering`].

use crate::decay::{decayed, DecayMode};
use crate::logodds::{Cell, CellClass, Clamp, GatedIncrement};
use crate::units::{LogOddsFixed, Meters};

/// A layer's cell size in fixed point: `rq = round(r · 2¹⁶)` raw Q16.16, at least 1 cm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Resolution {
    /// Raw Q16.16 metres; ≥ 655 (0.01 m).
    bits: i32,
}

impl Resolution {
    /// The smallest raw value accepted: 0.01 m.
    const MIN_BITS: i32 = 655;

    /// No cell size: the resolution of an unconfigured layer (every coordinate maps to cell
    /// 0, see [`cell_of`]). All zero bits.
    pub const UNSET: Self = Self { bits: 0 };

    /// Rounds a cell size in metres to Q16.16 (ties away from zero), refusing sizes below
    /// 1 cm, above 32 000 m, or not finite.
    #[must_use]
    pub fn from_m(resolution_m: f32) -> Option<Self> {
        if !resolution_m.is_finite() || !(0.01..=32_000.0).contains(&resolution_m) {
            return None;
        }
        // In range: the product is below 2³¹ and the conversion is exact after rounding.
        #[allow(clippy::cast_possible_truncation)]
        let bits = (resolution_m * 65_536.0 + 0.5) as i32;
        (bits >= Self::MIN_BITS).then_some(Self { bits })
    }

    /// The cell size as [`Meters`].
    #[must_use]
    pub const fn meters(self) -> Meters {
        Meters::from_bits(self.bits)
    }

    /// The raw Q16.16 value.
    #[must_use]
    pub const fn to_bits(self) -> i32 {
        self.bits
    }

    /// The cell that contains a coordinate: `floor(x / r)`, see [`cell_of`].
    #[must_use]
    #[inline]
    pub fn cell_of(self, coordinate: Meters) -> i32 {
        cell_of(coordinate.to_bits(), self.bits)
    }

    /// The lower edge of cell `index`, metres: `index · r` (saturating).
    #[must_use]
    pub fn cell_edge(self, index: i32) -> Meters {
        Meters::from_bits(index.saturating_mul(self.bits))
    }
}

/// The cell index of a coordinate: `floor(x_bits / r_bits)`, exact, flooring toward −∞ for
/// negative coordinates. `r_bits` must be positive; a non-positive one yields cell 0.
#[must_use]
#[inline]
pub fn cell_of(x_bits: i32, r_bits: i32) -> i32 {
    if r_bits <= 0 {
        return 0;
    }
    // With a positive divisor Euclidean division is floor division and cannot overflow.
    x_bits.checked_div_euclid(r_bits).unwrap_or(0)
}

/// `⌊2³² / r_bits⌋`, the reciprocal [`cell_of_reciprocal`] multiplies by (0 for a
/// non-positive `r_bits`). One division: compute it once per cell size.
#[must_use]
pub fn cell_reciprocal(r_bits: i32) -> u32 {
    if r_bits <= 0 {
        return 0;
    }
    u32::try_from((1_u64 << 32) / u64::from(r_bits.unsigned_abs())).unwrap_or(u32::MAX)
}

/// [`cell_of`] by a multiplication (in 16-bit halves on a Cortex-M0, without its 64-bit
/// library call) instead of a division (a library call of about 100 instructions on a
/// Cortex-M0, and slow on x86), given `reciprocal = cell_reciprocal(r_bits)`:
/// equal to `cell_of(x_bits, r_bits)` for every `x_bits` and every positive `r_bits` (cell
/// sizes of 2¹⁴ m and more, and a reciprocal that does not match, fall back to the division
/// only when `r_bits` is outside 655 ..< 2³⁰; a wrong reciprocal gives a wrong cell).
///
/// With m = ⌊2³²/r⌋ = 2³²/r − ε (0 ≤ ε < 1) and |x| ≤ 2³¹, q₀ = ⌊x·m / 2³²⌋ lies in
/// (x/r − 3/2, x/r + 1/2], so ⌊x/r⌋ is q₀ − 1, q₀ or q₀ + 1, told apart by the remainder
/// x − q₀·r ∈ (−r/2, 3r/2), which fits an `i32` for r < 2³⁰ (the wrapping arithmetic below
/// gives it exactly).
#[must_use]
#[inline]
pub fn cell_of_reciprocal(x_bits: i32, r_bits: i32, reciprocal: u32) -> i32 {
    if !(655..1 << 30).contains(&r_bits) {
        return cell_of(x_bits, r_bits);
    }
    #[allow(clippy::cast_possible_truncation)]
    let q = (crate::wide::smul_u32(x_bits, reciprocal) >> 32) as i32;
    let rem = x_bits.wrapping_sub(q.wrapping_mul(r_bits));
    if rem < 0 {
        q.wrapping_sub(1)
    } else if rem >= r_bits {
        q.wrapping_add(1)
    } else {
        q
    }
}

/// The offset of world index `index` inside a window that starts at `origin` and spans
/// `width` cells, or `None` outside it.
#[must_use]
#[inline]
pub fn window_offset(origin: i32, index: i32, width: usize) -> Option<usize> {
    // A difference beyond the i32 range is beyond any window: no 64-bit arithmetic needed.
    let offset = index.checked_sub(origin)?;
    usize::try_from(offset).ok().filter(|&o| o < width)
}

/// The storage slot of window offset `offset` when the window's origin is stored at slot
/// `start`: `(start + offset) mod width`, for `start, offset < width`.
#[must_use]
#[inline]
pub fn slot(start: usize, offset: usize, width: usize) -> usize {
    let s = start + offset;
    if s >= width {
        s - width
    } else {
        s
    }
}

/// The storage slot of a window origin: `origin mod width` (Euclidean).
#[must_use]
pub fn start_of(origin: i32, width: usize) -> usize {
    let w = i64::try_from(width).unwrap_or(i64::MAX).max(1);
    usize::try_from(i64::from(origin).rem_euclid(w)).unwrap_or(0)
}

/// Which storage slots along one axis enter the window when its origin moves from `old` to
/// `new` (their contents must be reset).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Entering {
    /// No move along this axis.
    None,
    /// `count` slots starting at slot `first`, wrapping modulo the width.
    Slots {
        /// The first slot to reset.
        first: usize,
        /// How many consecutive slots (mod width) to reset; < width.
        count: usize,
    },
    /// The move is a whole window or more: every slot enters.
    All,
}

/// The slots that enter along one axis when a window of `width` cells whose origin is stored
/// at slot `start` moves its origin from `old` to `new`.
///
/// Moving up by n (n < width) replaces the n lowest world indices, whose slots start at
/// `start`; moving down by n replaces the n highest, whose slots start at `start − n`.
#[must_use]
pub fn entering(old: i32, new: i32, start: usize, width: usize) -> Entering {
    let delta = i64::from(new) - i64::from(old);
    let w = i64::try_from(width).unwrap_or(i64::MAX);
    if delta == 0 {
        Entering::None
    } else if delta.abs() >= w {
        Entering::All
    } else {
        let n = usize::try_from(delta.unsigned_abs()).unwrap_or(width);
        let first = if delta > 0 {
            start
        } else {
            slot(start, width - n, width)
        };
        Entering::Slots { first, count: n }
    }
}

/// Counts of one layer's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerCounts {
    /// Observed cells, including those with L = 0.
    pub observed: u32,
    /// Observed cells with L > 0.
    pub obstacle: u32,
    /// Observed cells with L < 0.
    pub free: u32,
}

/// Where a layer's window lies and how it is stored: 16 bytes, the same on every target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Window {
    /// World cell index of the window's lower-left cell, x.
    origin_x: i32,
    /// World cell index of the window's lower-left cell, y.
    origin_y: i32,
    /// Storage slot of `origin_x` (< W ≤ 1024).
    start_x: u16,
    /// Storage slot of `origin_y` (< W ≤ 1024).
    start_y: u16,
    /// The cell size.
    resolution: Resolution,
}

/// One robot-centric layer: a W × W circular buffer of cells, `2·W² + 24` bytes.
#[derive(Clone)]
pub struct Layer<const W: usize> {
    /// `cells[row][col]`: row = storage slot along y, col = along x.
    cells: [[Cell; W]; W],
    window: Window,
    /// One bit per storage tile (8 × 8 tiles, bit `8·ty + tx`) changed by an update since the
    /// link last took them.
    dirty: u64,
}

/// A rectangle of world cells of one layer: `[x, x + width) × [y, y + height)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CellRect {
    /// World cell index of the lower-left cell, x.
    pub x: i32,
    /// World cell index of the lower-left cell, y.
    pub y: i32,
    /// Cells along x, ≥ 1.
    pub width: u16,
    /// Cells along y, ≥ 1.
    pub height: u16,
}

/// Tiles per side of the dirty map: 8, so a layer has 64 tiles and its dirty set is a `u64`.
pub const TILES_PER_SIDE: usize = 8;

/// The storage range `[first, end)` of tile `t` along an axis of `width` slots.
fn tile_span(t: usize, width: usize) -> (usize, usize) {
    (t * width / TILES_PER_SIDE, (t + 1) * width / TILES_PER_SIDE)
}

/// The window-offset ranges that a storage range `[first, end)` covers, when the window's
/// origin is stored at slot `start`: one range, or two when it straddles the wrap point.
fn offset_spans(
    first: usize,
    end: usize,
    start: usize,
    width: usize,
) -> [Option<(usize, usize)>; 2] {
    let offset = |s: usize| {
        if s >= start {
            s - start
        } else {
            s + width - start
        }
    };
    if first < start && start < end {
        [Some((offset(first), width)), Some((0, end - start))]
    } else if first < end {
        let o = offset(first);
        [Some((o, o + (end - first))), None]
    } else {
        [None, None]
    }
}

/// The bytes of one `Layer<W>` for `cells_per_side` = W (even): `2·W² + 24` (cells, the
/// window, the dirty tiles).
#[must_use]
pub const fn layer_bytes(cells_per_side: usize) -> usize {
    2 * cells_per_side * cells_per_side + core::mem::size_of::<Window>() + 8
}

impl<const W: usize> core::fmt::Debug for Layer<W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Layer")
            .field("cells_per_side", &W)
            .field("window", &self.window)
            .finish()
    }
}

/// Half a window, as a cell offset; W ≤ 1024 keeps it exact.
const fn half<const W: usize>() -> i32 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
    let h = (W / 2) as i32;
    h
}

impl<const W: usize> Layer<W> {
    /// An unconfigured layer: every cell unknown, no resolution (every coordinate maps to
    /// cell 0) and the window at cell (0, 0); [`Layer::reset`] gives it its resolution and
    /// centres it. All zero bits, and `const`, so a pyramid in a `static` costs no flash.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            cells: [[Cell::UNKNOWN; W]; W],
            window: Window {
                origin_x: 0,
                origin_y: 0,
                start_x: 0,
                start_y: 0,
                resolution: Resolution::UNSET,
            },
            dirty: 0,
        }
    }

    /// Forgets everything: every cell unknown, the given resolution, the window centred on
    /// the world origin.
    pub fn reset(&mut self, resolution: Resolution) {
        for row in &mut self.cells {
            row.fill(Cell::UNKNOWN);
        }
        self.window.resolution = resolution;
        self.dirty = 0;
        self.set_origin(-half::<W>(), -half::<W>());
    }

    /// The cell size.
    #[must_use]
    pub const fn resolution(&self) -> Resolution {
        self.window.resolution
    }

    /// Where the window lies and how it is stored.
    #[must_use]
    pub const fn window(&self) -> Window {
        self.window
    }

    fn set_origin(&mut self, x: i32, y: i32) {
        self.window.origin_x = x;
        self.window.origin_y = y;
        self.window.start_x = u16::try_from(start_of(x, W)).unwrap_or(0);
        self.window.start_y = u16::try_from(start_of(y, W)).unwrap_or(0);
    }

    fn start(&self) -> (usize, usize) {
        (
            usize::from(self.window.start_x),
            usize::from(self.window.start_y),
        )
    }

    /// The world cell index of the window's lower-left cell, `(ox, oy)`.
    #[must_use]
    pub const fn origin(&self) -> (i32, i32) {
        (self.window.origin_x, self.window.origin_y)
    }

    /// Storage `(row, col)` of world cell `(i, j)`, or `None` outside the window.
    #[inline]
    fn slot_of(&self, i: i32, j: i32) -> Option<(usize, usize)> {
        let (start_x, start_y) = self.start();
        let col = slot(start_x, window_offset(self.window.origin_x, i, W)?, W);
        let row = slot(start_y, window_offset(self.window.origin_y, j, W)?, W);
        Some((row, col))
    }

    /// The cell at world cell index `(i, j)`, or `None` outside the window.
    #[must_use]
    pub fn get(&self, i: i32, j: i32) -> Option<Cell> {
        let (row, col) = self.slot_of(i, j)?;
        self.cells.get(row)?.get(col).copied()
    }

    /// The cell at window offset `(dx, dy)` (0 ..< W each, from the lower-left corner), or
    /// `None` outside.
    #[must_use]
    pub fn at_offset(&self, dx: usize, dy: usize) -> Option<Cell> {
        if dx >= W || dy >= W {
            return None;
        }
        let (start_x, start_y) = self.start();
        let col = slot(start_x, dx, W);
        let row = slot(start_y, dy, W);
        self.cells.get(row)?.get(col).copied()
    }

    /// Adds a gated increment `g` (raw Q8.8) of full weight to world cell `(i, j)`
    /// ([`Cell::updated`]); returns `false` (and changes nothing) when the cell is outside
    /// the window.
    #[inline]
    pub fn update(&mut self, i: i32, j: i32, g: i16, initial: LogOddsFixed, clamp: Clamp) -> bool {
        self.update_by(i, j, GatedIncrement::unbounded(g), initial, clamp)
    }

    /// Applies one record's [`GatedIncrement`] to world cell `(i, j)` ([`Cell::updated_by`]);
    /// returns `false` (and changes nothing) when the cell is outside the window.
    #[inline]
    pub fn update_by(
        &mut self,
        i: i32,
        j: i32,
        increment: GatedIncrement,
        initial: LogOddsFixed,
        clamp: Clamp,
    ) -> bool {
        let Some((row, col)) = self.slot_of(i, j) else {
            return false;
        };
        match self.cells.get_mut(row).and_then(|r| r.get_mut(col)) {
            Some(cell) => {
                let new = cell.updated_by(increment, initial, clamp);
                if new != *cell {
                    *cell = new;
                    let tile =
                        (row * TILES_PER_SIDE / W) * TILES_PER_SIDE + col * TILES_PER_SIDE / W;
                    // The tile's bit by a 32-bit shift into its half (a variable 64-bit
                    // shift is a dozen instructions on a Cortex-M4 and a library call on a
                    // Cortex-M0; a shift by 32 is a register move).
                    let bit = u64::from(1_u32 << (tile & 31));
                    self.dirty |= if tile & 32 == 0 { bit } else { bit << 32 };
                }
                true
            }
            None => false,
        }
    }

    /// Moves the window so that the robot at `(x, y)` sits in its centre cell:
    /// origin = robot cell − W/2. Returns the number of cells reset to unknown.
    pub fn recentre(&mut self, x: Meters, y: Meters) -> usize {
        let r = self.window.resolution;
        let new_x = r.cell_of(x).saturating_sub(half::<W>());
        let new_y = r.cell_of(y).saturating_sub(half::<W>());
        self.move_origin(new_x, new_y)
    }

    /// Moves the window's origin to world cell `(new_x, new_y)`, resetting the rows and
    /// columns that enter. Returns the number of cells reset.
    pub fn move_origin(&mut self, new_x: i32, new_y: i32) -> usize {
        // Most calls at a robot's speed leave a coarse layer where it is: no slot, no origin
        // to recompute.
        if new_x == self.window.origin_x && new_y == self.window.origin_y {
            return 0;
        }
        let (start_x, start_y) = self.start();
        let along_x = entering(self.window.origin_x, new_x, start_x, W);
        let along_y = entering(self.window.origin_y, new_y, start_y, W);
        let reset = match (along_x, along_y) {
            (Entering::All, _) | (_, Entering::All) => {
                for row in &mut self.cells {
                    row.fill(Cell::UNKNOWN);
                }
                W * W
            }
            (ex, ey) => {
                let mut n = 0;
                if let Entering::Slots { first, count } = ey {
                    for t in 0..count {
                        if let Some(row) = self.cells.get_mut(slot(first, t, W)) {
                            row.fill(Cell::UNKNOWN);
                        }
                    }
                    n += count * W;
                }
                if let Entering::Slots { first, count } = ex {
                    // Column by column: one strided store per row, the slot computed once
                    // per column (not per cell).
                    for t in 0..count {
                        let col = slot(first, t, W);
                        // slot() < W: checked once here, the row accesses below need none.
                        if col >= W {
                            continue;
                        }
                        for row in &mut self.cells {
                            if let Some(c) = row.get_mut(col) {
                                *c = Cell::UNKNOWN;
                            }
                        }
                    }
                    let rows_done = match ey {
                        Entering::Slots { count: dy, .. } => dy,
                        _ => 0,
                    };
                    n += count * (W - rows_done);
                }
                n
            }
        };
        self.set_origin(new_x, new_y);
        reset
    }

    /// One decay step ([`crate::decay::decayed`]) for every cell of `count` storage rows
    /// from row `first` (wrapping modulo W; every world row j of the window with
    /// `j mod W` among them). Returns the cells that became unknown. Decay does not mark
    /// tiles dirty: a consumer that mirrors the layer applies the same step to the same rows.
    pub fn decay_rows(&mut self, first: usize, count: usize, mode: DecayMode) -> u32 {
        let mut faded = 0_u32;
        for t in 0..count.min(W) {
            let Some(row) = self.cells.get_mut(slot(first % W.max(1), t, W)) else {
                continue;
            };
            for cell in row.iter_mut() {
                if !cell.is_observed() {
                    continue;
                }
                let new = decayed(*cell, mode);
                faded += u32::from(!new.is_observed());
                *cell = new;
            }
        }
        faded
    }

    /// The tiles changed by updates since [`take_dirty`](Self::take_dirty) last ran: bit
    /// `8·ty + tx` for storage tile (tx, ty). Window moves do not mark tiles: a consumer that
    /// mirrors the window applies the same move and the same resets.
    #[must_use]
    pub const fn dirty(&self) -> u64 {
        self.dirty
    }

    /// Returns the changed tiles and clears them.
    pub fn take_dirty(&mut self) -> u64 {
        core::mem::take(&mut self.dirty)
    }

    /// Marks tiles as changed (bits as in [`dirty`](Self::dirty)), e.g. to resend them.
    pub fn mark_dirty(&mut self, tiles: u64) {
        self.dirty |= tiles;
    }

    /// The world rectangles that storage tile `tile` (0 ..< 64) covers now: one, or up to
    /// four when the tile straddles the window's wrap point. `None` entries are unused.
    #[must_use]
    pub fn tile_rects(&self, tile: usize) -> [Option<CellRect>; 4] {
        let mut out = [None; 4];
        if tile >= TILES_PER_SIDE * TILES_PER_SIDE {
            return out;
        }
        let (x0, x1) = tile_span(tile % TILES_PER_SIDE, W);
        let (y0, y1) = tile_span(tile / TILES_PER_SIDE, W);
        let (start_x, start_y) = self.start();
        let xs = offset_spans(x0, x1, start_x, W);
        let ys = offset_spans(y0, y1, start_y, W);
        let mut n = 0;
        for (ya, yb) in ys.iter().flatten() {
            for (xa, xb) in xs.iter().flatten() {
                let rect = CellRect {
                    x: self
                        .window
                        .origin_x
                        .saturating_add(i32::try_from(*xa).unwrap_or(0)),
                    y: self
                        .window
                        .origin_y
                        .saturating_add(i32::try_from(*ya).unwrap_or(0)),
                    width: u16::try_from(xb - xa).unwrap_or(0),
                    height: u16::try_from(yb - ya).unwrap_or(0),
                };
                if let Some(slot) = out.get_mut(n) {
                    *slot = Some(rect);
                    n += 1;
                }
            }
        }
        out
    }

    /// Counts of observed, obstacle and free cells over the whole window.
    #[must_use]
    pub fn counts(&self) -> LayerCounts {
        let mut counts = LayerCounts::default();
        for cell in self.cells.iter().flatten() {
            match cell.class() {
                CellClass::Unknown => continue,
                CellClass::Obstacle => counts.obstacle += 1,
                CellClass::Navigable => counts.free += 1,
                CellClass::Undecided => {}
            }
            counts.observed += 1;
        }
        counts
    }
}

impl<const W: usize> Default for Layer<W> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::XorShift;
    extern crate std;

    #[test]
    fn cell_of_floors_toward_negative_infinity() {
        assert_eq!(cell_of(0, 10), 0);
        assert_eq!(cell_of(9, 10), 0);
        assert_eq!(cell_of(10, 10), 1);
        assert_eq!(cell_of(-1, 10), -1);
        assert_eq!(cell_of(-10, 10), -1);
        assert_eq!(cell_of(-11, 10), -2);
        assert_eq!(cell_of(i32::MIN, 655), i32::MIN / 655 - 1);
        assert_eq!(cell_of(5, 0), 0);
    }

    #[test]
    fn cell_of_reciprocal_is_the_floor_division() {
        let mut rng = XorShift(0x1234_5678_9ABC_DEF1_u64);
        let mut next = || rng.next();
        let mut sizes = std::vec![655, 656, 1000, 6554, 13107, 26214, 52429, 65536, 104_858];
        sizes.extend([(1 << 30) - 1, 1 << 30, 2_097_152_000, 0, -5]);
        for _ in 0..200 {
            #[allow(clippy::cast_possible_truncation)]
            sizes.push(655 + (next() % 50_000_000) as i32);
        }
        for bits in sizes {
            let m = cell_reciprocal(bits);
            let check = |x: i32| {
                assert_eq!(
                    cell_of_reciprocal(x, bits, m),
                    cell_of(x, bits),
                    "{x} / {bits}"
                );
            };
            for x in [i32::MIN, i32::MIN + 1, i32::MAX, i32::MAX - 1, -1, 0, 1] {
                check(x);
            }
            // Around multiples of the cell size, all magnitudes.
            for k in [0_i64, 1, 2, 3, 100, 1000, 65_535, 1 << 20] {
                for sign in [-1_i64, 1] {
                    let edge = sign * k * i64::from(bits);
                    for d in -2..=2 {
                        if let Ok(x) = i32::try_from(edge + d) {
                            check(x);
                        }
                    }
                }
            }
            for _ in 0..5_000 {
                #[allow(clippy::cast_possible_truncation)]
                let x = next() as i32 >> (next() % 31);
                check(x);
            }
        }
        // A sweep of the default design's finest cell size over ±100 m.
        let bits = Resolution::from_m(0.1).unwrap().to_bits();
        let m = cell_reciprocal(bits);
        for x in (-6_553_600..6_553_600).step_by(7) {
            assert_eq!(cell_of_reciprocal(x, bits, m), cell_of(x, bits));
        }
    }

    #[test]
    fn resolution_rounds_to_q16_16() {
        let r = Resolution::from_m(0.1).unwrap();
        assert_eq!(r.to_bits(), 6554);
        assert!(Resolution::from_m(0.001).is_none());
        assert!(Resolution::from_m(f32::NAN).is_none());
        assert_eq!(r.cell_of(Meters::from_num(-0.05)), -1);
        assert_eq!(r.cell_of(Meters::from_num(0.25)), 2);
    }

    #[test]
    fn window_offsets_and_slots_wrap() {
        assert_eq!(window_offset(-32, -32, 64), Some(0));
        assert_eq!(window_offset(-32, 31, 64), Some(63));
        assert_eq!(window_offset(-32, 32, 64), None);
        assert_eq!(window_offset(-32, -33, 64), None);
        assert_eq!(window_offset(i32::MIN, i32::MAX, 64), None);
        assert_eq!(window_offset(i32::MAX, i32::MIN, 64), None);
        assert_eq!(window_offset(i32::MAX - 63, i32::MAX, 64), Some(63));
        assert_eq!(window_offset(i32::MIN, i32::MIN + 63, 64), Some(63));
        // Against the 64-bit difference, around the ends of the range.
        let edges = [
            i32::MIN,
            i32::MIN + 1,
            -64,
            -1,
            0,
            1,
            63,
            64,
            i32::MAX - 64,
            i32::MAX,
        ];
        for &origin in &edges {
            for &index in &edges {
                for d in [-1, 0, 1, 63] {
                    let index = index.wrapping_add(d);
                    let offset = i64::from(index) - i64::from(origin);
                    let expected = usize::try_from(offset).ok().filter(|&o| o < 64);
                    assert_eq!(
                        window_offset(origin, index, 64),
                        expected,
                        "{origin} {index}"
                    );
                }
            }
        }
        assert_eq!(slot(60, 3, 64), 63);
        assert_eq!(slot(60, 4, 64), 0);
        assert_eq!(start_of(-1, 64), 63);
        assert_eq!(start_of(-64, 64), 0);
        assert_eq!(start_of(130, 64), 2);
    }

    #[test]
    fn entering_slots_follow_the_move() {
        assert_eq!(entering(0, 0, 5, 8), Entering::None);
        assert_eq!(entering(0, 3, 5, 8), Entering::Slots { first: 5, count: 3 });
        assert_eq!(
            entering(0, -3, 5, 8),
            Entering::Slots { first: 2, count: 3 }
        );
        assert_eq!(entering(0, 8, 5, 8), Entering::All);
        assert_eq!(entering(0, -9, 5, 8), Entering::All);
        assert_eq!(entering(i32::MIN, i32::MAX, 0, 8), Entering::All);
    }

    fn mark(layer: &mut Layer<8>, i: i32, j: i32) {
        assert!(layer.update(i, j, 10, LogOddsFixed::ZERO, Clamp::Off));
    }

    #[test]
    fn a_move_keeps_the_overlap_and_resets_what_enters() {
        let mut layer = Layer::<8>::new();
        layer.reset(Resolution::from_m(1.0).unwrap());
        assert_eq!(layer.origin(), (-4, -4));
        for i in -4..4 {
            for j in -4..4 {
                mark(&mut layer, i, j);
            }
        }
        // Move by (+3, −2): the window becomes [-1, 7) × [-6, 2).
        let reset = layer.move_origin(-1, -6);
        assert_eq!(reset, 8 * 8 - 5 * 6);
        for i in -1..7 {
            for j in -6..2 {
                let was_inside = (-4..4).contains(&i) && (-4..4).contains(&j);
                assert_eq!(
                    layer.get(i, j).unwrap().is_observed(),
                    was_inside,
                    "({i}, {j})"
                );
            }
        }
        assert_eq!(layer.get(-2, 0), None);
        assert_eq!(layer.counts().observed, 30);
    }

    #[test]
    fn a_move_larger_than_the_window_resets_everything() {
        let mut layer = Layer::<8>::new();
        layer.reset(Resolution::from_m(1.0).unwrap());
        mark(&mut layer, 0, 0);
        assert_eq!(layer.move_origin(100, -4), 64);
        assert_eq!(layer.counts().observed, 0);
        assert_eq!(layer.origin(), (100, -4));
        mark(&mut layer, 107, 3);
        assert_eq!(layer.at_offset(7, 7).unwrap().class(), CellClass::Obstacle);
    }

    #[test]
    fn dirty_tiles_map_back_to_the_changed_cells() {
        let mut layer = Layer::<16>::new();
        layer.reset(Resolution::from_m(1.0).unwrap());
        layer.move_origin(5, -3); // a move that puts the wrap point inside the window
        for (i, j) in [(5, -3), (20, 12), (12, 4), (9, 0)] {
            assert!(layer.update(i, j, 10, LogOddsFixed::ZERO, Clamp::Off));
        }
        // An update that changes nothing marks nothing.
        let mut clamped = Layer::<16>::new();
        clamped.reset(Resolution::from_m(1.0).unwrap());
        assert!(clamped.update(0, 0, 0, LogOddsFixed::ZERO, Clamp::Off));
        assert_eq!(clamped.dirty(), 0);

        let dirty = layer.take_dirty();
        assert_eq!(layer.dirty(), 0);
        let mut covered = 0;
        let mut seen = std::vec::Vec::new();
        for tile in 0..64 {
            if dirty & (1 << tile) == 0 {
                continue;
            }
            for rect in layer.tile_rects(tile).into_iter().flatten() {
                covered += usize::from(rect.width) * usize::from(rect.height);
                for i in rect.x..rect.x + i32::from(rect.width) {
                    for j in rect.y..rect.y + i32::from(rect.height) {
                        assert!(layer.get(i, j).is_some(), "({i}, {j}) outside the window");
                        if layer.get(i, j).unwrap().is_observed() {
                            seen.push((i, j));
                        }
                    }
                }
            }
        }
        seen.sort_unstable();
        assert_eq!(seen, [(5, -3), (9, 0), (12, 4), (20, 12)]);
        assert!((4..=4 * 4).contains(&covered));
        // All 64 tiles together cover the window exactly once.
        let total: usize = (0..64)
            .flat_map(|t| layer.tile_rects(t))
            .flatten()
            .map(|r| usize::from(r.width) * usize::from(r.height))
            .sum();
        assert_eq!(total, 16 * 16);
    }

    #[test]
    fn recentre_puts_the_robot_in_the_centre_cell() {
        let mut layer = Layer::<8>::new();
        layer.reset(Resolution::from_m(0.5).unwrap());
        layer.recentre(Meters::from_num(10.2), Meters::from_num(-3.1));
        // Robot cell (20, −7) → origin (16, −11).
        assert_eq!(layer.origin(), (16, -11));
        assert!(!layer.update(15, 0, 10, LogOddsFixed::ZERO, Clamp::Off));
    }
}
