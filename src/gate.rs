//! The precomputed gating tables: `w_k(d)` for every layer over quantised distance, and
//! [`Gates`], everything a point needs to know to feed the layers of a design: their cell
//! sizes, their tables, and which layers a distance may feed at all.
//!
//! The per-point path never calls `exp`: it quantises the distance at measurement into one of
//! [`GATE_BINS`] bins with a shift ([`DistanceBins::bin`]) and reads a Q1.15 weight.
//!
//! - **Bin width** `b = 2⁻ˢ` m, the finest power of two (s ≤ 10) for which
//!   `GATE_BINS · b` exceeds the maximum range: 1/32 m (31.25 mm) for 10 m, 1/4 m for 81.92 m.
//! - **Range covered**: `0 ..= GATE_BINS · b`; longer distances read the last bin. Bins whose
//!   lower edge lies beyond the maximum range R weigh 0 in every layer: the last band is
//!   closed at R, and nothing beyond it feeds the pyramid.
//! - **Weights** are evaluated at bin centres and rounded to Q1.15: the rounding error is
//!   at most 2⁻¹⁶, and the soft gate's binning error at most `e^{−½}·b / (2σ_g,k)`
//!   ([`binning_error_bound`]), e.g. 0.036 for layer 0 of the default design
//!   (σ_g = 0.265 m, b = 1/32 m). The hard gate's band edges move to bin boundaries:
//!   by at most b/2.

use crate::design::{Design, DesignError, GateShape, LayerDesign, Param};
use crate::fmath;
use crate::grid::Resolution;
use crate::logodds::Increments;
use crate::units::{Meters, Weight};
use crate::wide;

/// Number of distance bins in every gate table.
pub const GATE_BINS: usize = 512;

/// The finest bin shift: bins of 2⁻¹⁰ m ≈ 1 mm.
const MAX_BIN_SHIFT: u32 = 10;

/// How distances are quantised into gate bins: `bin = floor(d / 2⁻ˢ)`, capped at the last.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DistanceBins {
    /// s: the bin width is 2⁻ˢ m; 0 ..= 10 (held by every constructor). All zero bits are
    /// a valid value (s = 0: the unconfigured binning), so a zeroed classifier or pyramid
    /// stays in `.bss`.
    shift: u32,
}

impl DistanceBins {
    /// The finest binning whose [`GATE_BINS`] bins cover `max_range_m` (> 0, ≤ 512 m).
    #[must_use]
    pub fn for_range(max_range_m: f32) -> Self {
        let mut shift = MAX_BIN_SHIFT;
        while shift > 0 && bins_f32() * pow2_neg(shift) <= max_range_m {
            shift -= 1;
        }
        Self::with_shift(shift)
    }

    /// Bins of 2⁻ˢ m for `shift` = s (clamped to 0 ..= 10).
    const fn with_shift(shift: u32) -> Self {
        Self {
            shift: if shift > MAX_BIN_SHIFT {
                MAX_BIN_SHIFT
            } else {
                shift
            },
        }
    }

    /// m = 16 − s: a bin's edge is `k·2ᵐ` in raw Q16.16; 6 ..= 16.
    #[inline]
    const fn edge_shift(self) -> u32 {
        16 - self.shift
    }

    /// The binning of an unconfigured pyramid (bins of 1 m; all zero bits).
    pub const UNCONFIGURED: Self = Self::with_shift(0);

    /// The bin width, metres.
    #[must_use]
    pub fn width_m(self) -> f32 {
        pow2_neg(self.shift)
    }

    /// The bin of a distance: `min(floor(d / b), GATE_BINS − 1)`, 0 for negative distances.
    #[must_use]
    #[inline]
    pub fn bin(self, distance: Meters) -> usize {
        let raw = distance.to_bits().max(0);
        // d / 2⁻ˢ = raw · 2ˢ / 2¹⁶ = raw >> (16 − s); s ≤ 10 keeps the shift in range.
        #[allow(clippy::cast_sign_loss)]
        let bin = (raw as u32) >> self.edge_shift();
        (bin as usize).min(GATE_BINS - 1)
    }

    /// The bin of a distance given by its square: exactly
    /// `self.bin(Meters::from_bits(⌊√squared⌋))`, the bin of the square root rounded down, for
    /// every `u64` (a root beyond `i32` in the last bin), without the square root of the
    /// distance itself: `squared` is in raw Q16.16 units squared (2⁻³² m²).
    ///
    /// How: the bin is `⌊⌊√S⌋ / 2ᵐ⌋ = ⌊√S / 2ᵐ⌋ = ⌊√(S >> 2m)⌋` (m = 16 − s; the floor of a
    /// root changes only at an integer), the nine-bit square root of a value below 512² (at
    /// and beyond it, the last bin).
    ///
    /// The root is rounded down, where [`LineTransform::locate`](crate::geometry::LineTransform::locate)
    /// rounds a distance to the nearest raw unit: a distance within half a raw unit
    /// (2⁻¹⁷ m, 7.6 µm) below a bin edge is binned below it here. A laser's range is
    /// quantised to a millimetre, 131 times coarser.
    #[must_use]
    #[inline]
    pub fn bin_of_squared(self, squared: u64) -> usize {
        match self.coarse_below_2_18(squared) {
            Some(coarse) => isqrt_floor_below_2_18(coarse) as usize,
            None => GATE_BINS - 1,
        }
    }

    /// [`DistanceBins::bin_of_squared`] (the same result for every input), trying bin `hint`
    /// and its neighbours first: consecutive returns of a line mostly fall in the same or a
    /// neighbouring bin. The square root `f` of `S >> 2m` is `hint`, `hint + 1` or
    /// `hint − 1` when `f² ≤ S >> 2m < (f + 1)²` holds for it (32-bit squares), else the
    /// square root of a value below 2¹⁸ finds it (Newton's iteration where the core divides,
    /// the restoring method elsewhere).
    #[must_use]
    #[inline]
    pub fn bin_of_squared_near(self, squared: u64, hint: usize) -> usize {
        let Some(q) = self.coarse_below_2_18(squared) else {
            return GATE_BINS - 1;
        };
        // g ≤ 511: every square below is below 2¹⁹.
        #[allow(clippy::cast_possible_truncation)]
        let g = hint.min(GATE_BINS - 1) as u32;
        let f = if g * g <= q {
            if q < (g + 1) * (g + 1) {
                g
            } else if q < (g + 2) * (g + 2) {
                g + 1
            } else {
                isqrt_floor_below_2_18(q)
            }
        } else if (g - 1) * (g - 1) <= q {
            // g ≥ 1 here: g² > q ≥ 0.
            g - 1
        } else {
            isqrt_floor_below_2_18(q)
        };
        // q < 512²: f ≤ 511.
        f as usize
    }

    /// `S >> 2m` when it is below 512² (the last bin's lower edge squared, coarse), else
    /// `None` (the last bin). In 32-bit words, for 12 ≤ 2m ≤ 32: the result's high word is
    /// the high word shifted down by 2m, which must be 0; its low word the high word shifted
    /// up by 32 − 2m beside the low word shifted down by 2m (as 1, then 2m − 1: each shift
    /// below 32).
    #[inline]
    fn coarse_below_2_18(self, squared: u64) -> Option<u32> {
        const LIMIT: u32 = (GATE_BINS * GATE_BINS) as u32;
        #[allow(clippy::cast_possible_truncation)]
        let (hi, lo) = ((squared >> 32) as u32, squared as u32);
        // s ≤ 10: 2m − 1 = 31 − 2s is 11 ..= 31, 32 − 2m = 2s is 0 ..= 20.
        let (down, up) = (31 - 2 * self.shift, 2 * self.shift);
        let above = (hi >> 1) >> down;
        let coarse = (hi << up) | ((lo >> 1) >> down);
        (above == 0 && coarse < LIMIT).then_some(coarse)
    }

    /// The lower edge of bin `i` as [`Meters`] (exact: a multiple of 2⁻¹⁰ m), saturating; a
    /// distance there falls in bin `i` again.
    #[must_use]
    pub fn lower_edge(self, i: usize) -> Meters {
        let i = i32::try_from(i.min(GATE_BINS - 1)).unwrap_or(0);
        Meters::from_bits(i << self.edge_shift())
    }

    /// The lower edge of bin `i`, metres.
    #[must_use]
    pub fn lower_edge_m(self, i: usize) -> f32 {
        #[allow(clippy::cast_precision_loss)]
        let fi = i as f32;
        fi * self.width_m()
    }

    /// The centre of bin `i`, metres.
    #[must_use]
    pub fn center_m(self, i: usize) -> f32 {
        #[allow(clippy::cast_precision_loss)]
        let fi = i as f32;
        (fi + 0.5) * self.width_m()
    }
}

/// `⌊√x⌋` for `x < 2¹⁸` (nine result bits): Newton's iteration where the target divides
/// in hardware (ARMv7-M's `udiv`: about four divisions), the restoring method elsewhere
/// (ARMv6-M has no divide instruction; nine steps of a compare and a subtraction).
#[inline]
fn isqrt_floor_below_2_18(x: u32) -> u32 {
    if wide::DIVIDES_WORDS {
        isqrt_floor_newton(x)
    } else {
        isqrt_floor_restoring(x)
    }
}

/// `⌊√x⌋` for `x < 2¹⁸` by Newton's iteration in integers, `r ← ⌊(r + ⌊x/r⌋)/2⌋`, from
/// `2^⌈b/2⌉` (b the bit length of x), which is above √x. From any `r ≥ ⌊√x⌋` the next value
/// is at least `⌊√x⌋`, and below `r` while `r > ⌊√x⌋`: the first value that does not fall is
/// the root. At most 2⁹ = 512 to start with: at most five divisions for x < 2¹⁸.
#[inline]
fn isqrt_floor_newton(x: u32) -> u32 {
    if x == 0 {
        return 0;
    }
    let bits = 32 - x.leading_zeros();
    let mut root = 1_u32 << bits.div_ceil(2);
    loop {
        // root ≥ 1: the division is defined; root ≤ 2¹⁶ and x/root < 2¹⁸: no overflow.
        let next = (root + x / root) >> 1;
        if next >= root {
            return root;
        }
        root = next;
    }
}

/// `⌊√x⌋` for `x < 2¹⁸` by the restoring method in 32-bit words.
#[inline]
fn isqrt_floor_restoring(x: u32) -> u32 {
    let mut rem = x;
    let mut root = 0_u32;
    // The highest power of four not above x (x < 2¹⁸: at most 2¹⁶).
    let mut bit = if x == 0 {
        0
    } else {
        1_u32 << ((31 - x.leading_zeros()) & !1)
    };
    while bit != 0 {
        let trial = root + bit;
        root >>= 1;
        if rem >= trial {
            rem -= trial;
            root += bit;
        }
        bit >>= 2;
    }
    root
}

/// 2⁻ˢ as `f32`, s ≤ 10.
fn pow2_neg(shift: u32) -> f32 {
    #[allow(clippy::cast_precision_loss)]
    let denominator = (1_u32 << shift.min(MAX_BIN_SHIFT)) as f32;
    1.0 / denominator
}

/// [`GATE_BINS`] as `f32`.
fn bins_f32() -> f32 {
    #[allow(clippy::cast_precision_loss)]
    let b = GATE_BINS as f32;
    b
}

/// The index of the lowest set bit of each byte (8 for 0): the next layer of a fed-layer mask
/// by one load on ARMv6-M, which has no count-leading-zeros instruction ([`lowest_layer`]).
const LOWEST_SET_BIT: [u8; 256] = {
    let mut table = [8_u8; 256];
    let mut mask = 1;
    while mask < 256 {
        // Evaluated at compile time (an index out of range would fail the build, not panic):
        // below 8 for a non-zero byte.
        #[allow(clippy::cast_possible_truncation, clippy::indexing_slicing)]
        {
            table[mask] = (mask as u8).trailing_zeros() as u8;
        }
        mask += 1;
    }
    table
};

/// The index of the lowest set bit of `mask` (8 for 0): the lowest layer left in a fed-layer
/// mask. On ARMv6-M one load from [`LOWEST_SET_BIT`]; elsewhere `trailing_zeros`, two
/// instructions on ARMv7-M (`rbit`, `clz`) and no table address to keep in a register.
#[inline(always)]
pub(crate) fn lowest_layer(mask: u8) -> u8 {
    if cfg!(all(target_arch = "arm", not(target_has_atomic = "32"))) {
        // A byte indexes the 256 entries: the bound check compiles away.
        LOWEST_SET_BIT.get(usize::from(mask)).copied().unwrap_or(8)
    } else {
        // At most 8.
        #[allow(clippy::cast_possible_truncation)]
        {
            mask.trailing_zeros() as u8
        }
    }
}

/// One layer's gate: a weight per distance bin, Q1.15. 1 KiB.
#[derive(Clone, PartialEq, Eq)]
pub struct GateTable {
    weights: [Weight; GATE_BINS],
}

impl core::fmt::Debug for GateTable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let nonzero = self.weights.iter().filter(|w| **w != Weight::ZERO).count();
        write!(f, "GateTable {{ nonzero bins: {nonzero} }}")
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for GateTable {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "GateTable");
    }
}

impl GateTable {
    /// A table of zeros: the layer receives nothing.
    pub const ZERO: Self = Self {
        weights: [Weight::ZERO; GATE_BINS],
    };

    /// Builds layer `k`'s table of a design (rules in `docs/core.md`): the top-hat over the
    /// band, or the Gaussian around the band's centre, at every bin centre.
    #[must_use]
    pub fn build<const L: usize>(design: &Design<L>, k: usize, bins: DistanceBins) -> Self {
        let mut table = Self::ZERO;
        table.rebuild(design, k, bins);
        table
    }

    /// Rebuilds this table as [`GateTable::build`] of layer `k` (all zero if the design has no
    /// layer `k`), in place: without a second 1 KiB table on the stack.
    pub fn rebuild<const L: usize>(&mut self, design: &Design<L>, k: usize, bins: DistanceBins) {
        self.weights.fill(Weight::ZERO);
        let layers = design.layers();
        let Some(layer) = layers.get(k) else {
            return;
        };
        let last = k + 1 == layers.len();
        let shape = design.schedule().gate;
        let range = design.sensor().max_range_m;
        for (i, w) in self.weights.iter_mut().enumerate() {
            // Nothing is measured beyond the maximum range: bins that start past it feed no
            // layer (the last band is closed at R).
            if bins.lower_edge_m(i) > range {
                break;
            }
            *w = round_weight(weight_at(layer, last, shape, bins.center_m(i)));
        }
    }

    /// The weight of a distance bin (0 past the table, which [`DistanceBins::bin`] never
    /// returns).
    #[must_use]
    #[inline]
    pub fn weight(&self, bin: usize) -> Weight {
        self.weights.get(bin).copied().unwrap_or(Weight::ZERO)
    }

    /// All weights, bin 0 first.
    #[must_use]
    pub fn weights(&self) -> &[Weight; GATE_BINS] {
        &self.weights
    }
}

/// The continuous gate of a layer at distance `d_m`, as a real number in 0 ..= 1.
fn weight_at(layer: &LayerDesign, last: bool, shape: GateShape, d_m: f32) -> f32 {
    match shape {
        GateShape::Hard => {
            let inside = d_m >= layer.band_inner_m && (last || d_m < layer.band_outer_m);
            if inside {
                1.0
            } else {
                0.0
            }
        }
        GateShape::Soft { .. } => {
            let sigma = layer.gate_sigma_m;
            if sigma > 0.0 {
                let z = (d_m - layer.gate_center_m) / sigma;
                fmath::exp(-0.5 * z * z)
            } else {
                0.0
            }
        }
    }
}

/// Rounds a weight in 0 ..= 1 to Q1.15, to nearest (ties up); out-of-range values saturate.
fn round_weight(w: f32) -> Weight {
    let raw = (w * 32_768.0 + 0.5).clamp(0.0, 32_768.0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    Weight::from_bits(raw as u16)
}

/// The worst-case error of a soft gate's table against the continuous gate, in weight units:
/// the binning error `e^{−½}·b/(2σ)` plus the rounding error 2⁻¹⁶. For the hard gate, 0 away
/// from the band edges (which move by at most b/2).
#[must_use]
pub fn binning_error_bound(layer: &LayerDesign, bins: DistanceBins) -> f32 {
    if layer.gate_sigma_m > 0.0 {
        // max |w'| = e^{−½}/σ at d = c ± σ.
        0.606_530_66 * bins.width_m() / (2.0 * layer.gate_sigma_m) + 1.0 / 65_536.0
    } else {
        0.0
    }
}

/// Gate bins per byte of the fed-layer mask ([`Gates::fed_layers`]): 8 bins of 1/32 m
/// (25 cm) with the default range, so 64 bytes for the whole table.
pub const FED_GROUP_BINS: usize = 8;

/// Bytes of the fed-layer mask.
const FED_GROUPS: usize = GATE_BINS / FED_GROUP_BINS;

/// The smallest raw Q1.15 weight `w` with `gated(l_obs, w) ≠ 0` or `gated(l_free, w) ≠ 0`.
///
/// `gated` rounds half up: `g = ⌊(l·w + 2¹⁴) / 2¹⁵⌋` is non-zero exactly when `l·w ≥ 2¹⁴` or
/// `l·w < −2¹⁴`, i.e. for `l > 0` when `w ≥ ⌈2¹⁴ / l⌉`, and for `l < 0` when
/// `w ≥ ⌊2¹⁴ / |l|⌋ + 1`. Both conditions grow with `w`, so their union starts at the smaller.
/// A zero increment never feeds (the validator refuses it); the result is at most 2¹⁵ + 1
/// (no weight feeds).
fn min_feeding_weight(increments: Increments) -> u16 {
    const HALF: u32 = 1 << 14;
    let never = (1_u32 << 15) + 1;
    let threshold = |l: i16| -> u32 {
        let magnitude = u32::from(l.unsigned_abs());
        match (l > 0, magnitude) {
            (_, 0) => never,
            (true, m) => HALF.div_ceil(m),
            (false, m) => HALF / m + 1,
        }
    };
    let t = threshold(increments.obstacle.to_bits()).min(threshold(increments.free.to_bits()));
    u16::try_from(t).unwrap_or(u16::MAX)
}

/// The gating of a design, for up to `L` layers: each layer's cell size and gate table, the
/// distance binning, the smallest weight that changes a cell, and per group of
/// [`FED_GROUP_BINS`] bins the layers it feeds somewhere and everywhere. About
/// `L · 1 KiB + 4·L + 136` bytes ([`ram_bytes`]).
///
/// The classifier owns it and reads it for every point; the pyramid never does: evidence
/// reaches the pyramid with its weight already looked up ([`crate::pyramid::Evidence`]).
/// `const`-built all zero bits ([`Gates::new`]: no layers, nothing fed), so a `static` holding
/// one sits in `.bss`.
#[derive(Clone)]
pub struct Gates<const L: usize> {
    tables: [GateTable; L],
    resolutions: [Resolution; L],
    /// Layers in force, ≤ L ≤ 255.
    active: u8,
    bins: DistanceBins,
    /// Raw Q1.15; 2¹⁵ + 1 and above: nothing feeds.
    min_feeding_weight: u16,
    /// Per group of [`FED_GROUP_BINS`] gate bins, bit k set when layer k < 8 is fed at some
    /// bin of the group (its weight reaches `min_feeding_weight` there).
    fed: [u8; FED_GROUPS],
    /// Per group, bit k set when layer k < 8 is fed at every bin of the group: those layers
    /// need no weight check ([`Gates::layers_fed_at`]).
    fed_everywhere: [u8; FED_GROUPS],
}

impl<const L: usize> core::fmt::Debug for Gates<L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Gates")
            .field("layers", &self.active)
            .field("bins", &self.bins)
            .field("min_feeding_weight", &self.min_feeding_weight)
            .finish()
    }
}

impl<const L: usize> Default for Gates<L> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const L: usize> Gates<L> {
    /// No layers: every point feeds nothing. `const` and all zero bits.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            tables: [const { GateTable::ZERO }; L],
            resolutions: [Resolution::UNSET; L],
            active: 0,
            bins: DistanceBins::UNCONFIGURED,
            min_feeding_weight: 0,
            fed: [0; FED_GROUPS],
            fed_everywhere: [0; FED_GROUPS],
        }
    }

    /// Builds the gating of `design` with the increments in force (they decide which weights
    /// can change a cell). On error nothing changes.
    ///
    /// # Errors
    /// A layer's resolution cannot be represented ([`Param::Base`]).
    pub fn configure(
        &mut self,
        design: &Design<L>,
        increments: Increments,
    ) -> Result<(), DesignError> {
        let mut resolutions = [Resolution::UNSET; L];
        for (slot, layer) in resolutions.iter_mut().zip(design.layers()) {
            *slot = resolution_of(layer)?;
        }
        let bins = DistanceBins::for_range(design.sensor().max_range_m);
        let active = design.layers().len().min(L).min(usize::from(u8::MAX));
        for (k, table) in self.tables.iter_mut().enumerate() {
            // In place: a table built on the stack and copied would cost 1 KiB of frame.
            if k < active {
                table.rebuild(design, k, bins);
            } else {
                table.weights.fill(Weight::ZERO);
            }
        }
        let min_weight = min_feeding_weight(increments);
        let mut fed = [0_u8; FED_GROUPS];
        let mut fed_everywhere = [0_u8; FED_GROUPS];
        for (group, (some, every)) in fed.iter_mut().zip(&mut fed_everywhere).enumerate() {
            *every = u8::MAX;
            let first = group * FED_GROUP_BINS;
            for bin in first..first + FED_GROUP_BINS {
                let mut at_bin = 0_u8;
                for (k, table) in self.tables.iter().take(active.min(8)).enumerate() {
                    if table.weight(bin) >= Weight::from_bits(min_weight) {
                        at_bin |= 1 << k;
                    }
                }
                *some |= at_bin;
                *every &= at_bin;
            }
        }
        self.resolutions = resolutions;
        self.active = u8::try_from(active).unwrap_or(u8::MAX);
        self.bins = bins;
        self.min_feeding_weight = min_weight;
        self.fed = fed;
        self.fed_everywhere = fed_everywhere;
        Ok(())
    }

    /// The number of layers in force (0 before [`configure`](Self::configure)).
    #[must_use]
    pub const fn layer_count(&self) -> usize {
        self.active as usize
    }

    /// The distance binning of the tables.
    #[must_use]
    pub const fn distance_bins(&self) -> DistanceBins {
        self.bins
    }

    /// Layer `k`'s gate table, or `None` beyond the layers in force.
    #[must_use]
    pub fn table(&self, k: usize) -> Option<&GateTable> {
        self.tables.get(..self.layer_count())?.get(k)
    }

    /// The tables of the layers in force, finest first.
    #[must_use]
    #[inline]
    pub fn tables(&self) -> &[GateTable] {
        self.tables.get(..self.layer_count()).unwrap_or(&[])
    }

    /// Layer `k`'s weight at gate bin `bin`: `table(k)`'s, 0 for a layer not in force (the
    /// tables past the layers in force are kept all zero) and past the table. One bound check
    /// against `L`, not against the layers in force: for the per-point path.
    #[must_use]
    #[inline]
    pub fn weight_in(&self, k: usize, bin: usize) -> Weight {
        self.tables.get(k).map_or(Weight::ZERO, |t| t.weight(bin))
    }

    /// Layer `k`'s cell size, or `None` beyond the layers in force.
    #[must_use]
    #[inline]
    pub fn resolution(&self, k: usize) -> Option<Resolution> {
        self.resolutions.get(..self.layer_count())?.get(k).copied()
    }

    /// Layer `k`'s weight at a distance (0 beyond the layers in force).
    #[must_use]
    pub fn weight_at(&self, k: usize, distance: Meters) -> Weight {
        self.table(k)
            .map_or(Weight::ZERO, |t| t.weight(self.bins.bin(distance)))
    }

    /// The smallest gate weight at which an observation changes a cell: `gated(l, w) ≠ 0`
    /// for either class exactly when `w` reaches it.
    #[must_use]
    pub const fn min_feeding_weight(&self) -> Weight {
        Weight::from_bits(self.min_feeding_weight)
    }

    /// The layers among the first eight that a distance in gate bin `bin` may feed, bit k
    /// for layer k: bit k is set when `table(k).weight(b) ≥ min_feeding_weight()` for some
    /// bin `b` of `bin`'s group of [`FED_GROUP_BINS`] (0 for bins past the table). A clear
    /// bit means the layer is not fed; a set bit still needs the weight check. Layers from
    /// the ninth on are not in the mask: check their weights.
    #[must_use]
    #[inline]
    pub fn fed_layers(&self, bin: usize) -> u8 {
        self.fed.get(bin / FED_GROUP_BINS).copied().unwrap_or(0)
    }

    /// The layers among the first eight that a distance in gate bin `bin` feeds, exactly:
    /// bit k set when `table(k).weight(bin) ≥ min_feeding_weight()` (0 for bins past the
    /// table). The layers fed at every bin of `bin`'s group come from a mask; only those fed
    /// at some of its bins (a layer's gate edge falls in the group) have their weight read.
    #[must_use]
    #[inline]
    pub fn layers_fed_at(&self, bin: usize) -> u8 {
        let group = bin / FED_GROUP_BINS;
        let every = self.fed_everywhere.get(group).copied().unwrap_or(0);
        let mut edge = self.fed.get(group).copied().unwrap_or(0) & !every;
        let mut exact = every;
        let min = self.min_feeding_weight();
        while edge != 0 {
            let k = lowest_layer(edge);
            edge &= edge - 1;
            if self.weight_in(usize::from(k), bin) >= min {
                exact |= 1 << k;
            }
        }
        exact
    }
}

/// The static RAM of the gating of `layers` layers, bytes: a 1 KiB table and a cell size per
/// layer, and the fed-layer mask: the part of a design's RAM that sits with the classifier
/// (equal to `size_of::<Gates<L>>()` for `layers = L`, up to alignment; a unit test holds them
/// together).
#[must_use]
pub const fn ram_bytes(layers: usize) -> usize {
    let raw = layers * (core::mem::size_of::<GateTable>() + core::mem::size_of::<Resolution>())
        + core::mem::size_of::<DistanceBins>()
        + 4
        + 2 * FED_GROUPS;
    raw.div_ceil(4) * 4
}

/// A layer's cell size as the grid holds it.
fn resolution_of(layer: &LayerDesign) -> Result<Resolution, DesignError> {
    Resolution::from_m(layer.resolution_m).ok_or(DesignError::OutOfRange {
        param: Param::Base,
        value: layer.resolution_m,
        min: crate::design::MIN_RESOLUTION_M,
        max: 32_000.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{Schedule, SensorModel};
    use crate::logodds::{gated, InverseSensorModel};
    use crate::test_rng::XorShift;
    use crate::units::LogOddsFixed;

    #[test]
    fn min_feeding_weight_is_exactly_where_an_increment_survives() {
        for (obstacle, free) in [(217, -104), (1, -1), (1946, -1946), (3, -500), (200, -2)] {
            let inc = Increments {
                obstacle: LogOddsFixed::from_bits(obstacle),
                free: LogOddsFixed::from_bits(free),
                initial: LogOddsFixed::ZERO,
            };
            let min = min_feeding_weight(inc);
            for raw in 0..=(1_u16 << 15) {
                let w = Weight::from_bits(raw);
                let feeds = gated(inc.obstacle, w) != 0 || gated(inc.free, w) != 0;
                assert_eq!(feeds, raw >= min, "({obstacle}, {free}) at w = {raw}");
            }
        }
    }

    #[test]
    fn rebuild_in_place_is_build() {
        let designs = [
            Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap(),
            Design::<8>::new(
                SensorModel {
                    max_range_m: 4.0,
                    ..SensorModel::default()
                },
                Schedule {
                    gate: GateShape::Hard,
                    ..Schedule::default()
                },
                64,
            )
            .unwrap(),
        ];
        for a in &designs {
            for b in &designs {
                let (bins_a, bins_b) = (
                    DistanceBins::for_range(a.sensor().max_range_m),
                    DistanceBins::for_range(b.sensor().max_range_m),
                );
                for k in 0..9 {
                    let mut t = GateTable::build(a, k, bins_a);
                    t.rebuild(b, k, bins_b);
                    assert_eq!(t.weights(), GateTable::build(b, k, bins_b).weights(), "{k}");
                }
            }
        }
    }

    #[test]
    fn weight_in_is_the_table_weight_and_zero_past_the_layers_in_force() {
        let increments = InverseSensorModel::default().increments().unwrap();
        let long = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let short = SensorModel {
            max_range_m: 4.0,
            ..SensorModel::default()
        };
        let short = Design::<8>::new(short, Schedule::default(), 64).unwrap();
        assert!(short.layers().len() < long.layers().len());
        let mut p = Gates::<8>::new();
        // Fresh, then the long design, then the short one over it: the tables it leaves are zero.
        for design in [None, Some(&long), Some(&short)] {
            if let Some(design) = design {
                p.configure(design, increments).unwrap();
            }
            for k in 0..10 {
                for bin in 0..GATE_BINS + 3 {
                    let table = p.table(k).map_or(Weight::ZERO, |t| t.weight(bin));
                    assert_eq!(p.weight_in(k, bin), table, "layer {k} bin {bin}");
                }
            }
        }
    }

    #[test]
    fn the_fed_mask_is_exactly_where_the_weight_feeds() {
        for shape in [GateShape::Hard, GateShape::default()] {
            let schedule = Schedule {
                gate: shape,
                ..Schedule::default()
            };
            let design = Design::<8>::new(SensorModel::default(), schedule, 64).unwrap();
            let mut p = Gates::<8>::new();
            p.configure(&design, InverseSensorModel::default().increments().unwrap())
                .unwrap();
            let min = p.min_feeding_weight();
            let mut fed = 0;
            for k in 0..8 {
                let gate = p.table(k).unwrap();
                for bin in 0..GATE_BINS + 3 {
                    let feeds = gate.weight(bin) >= min;
                    let group = bin / FED_GROUP_BINS * FED_GROUP_BINS;
                    let any = (group..group + FED_GROUP_BINS).any(|b| gate.weight(b) >= min);
                    let bit = p.fed_layers(bin) >> k & 1 == 1;
                    assert_eq!(bit, any, "{shape:?} layer {k} bin {bin}");
                    let exact = p.layers_fed_at(bin) >> k & 1 == 1;
                    assert_eq!(exact, feeds, "{shape:?} layer {k} bin {bin}");
                    assert!(bit || !feeds);
                    fed += usize::from(feeds);
                }
            }
            assert!(fed > GATE_BINS / 2);
        }
    }

    #[test]
    fn ram_bytes_matches_the_layout() {
        assert_eq!(ram_bytes(8), core::mem::size_of::<Gates<8>>());
        assert_eq!(ram_bytes(1), core::mem::size_of::<Gates<1>>());
        assert_eq!(ram_bytes(32), core::mem::size_of::<Gates<32>>());
    }

    #[test]
    fn bins_for_ten_metres_are_1_32_m() {
        let b = DistanceBins::for_range(10.0);
        assert_eq!(b.width_m(), 1.0 / 32.0);
        assert_eq!(b.bin(Meters::from_num(0.0)), 0);
        assert_eq!(b.bin(Meters::from_num(0.031)), 0);
        assert_eq!(b.bin(Meters::from_num(0.0313)), 1);
        assert_eq!(b.bin(Meters::from_num(-3)), 0);
        assert_eq!(b.bin(Meters::from_num(1000)), GATE_BINS - 1);
        assert_eq!(DistanceBins::for_range(81.92).width_m(), 0.25);
        assert_eq!(DistanceBins::for_range(0.4).width_m(), 1.0 / 1024.0);
    }

    #[test]
    fn bin_of_squared_is_the_bin_of_the_floored_root() {
        let reference = |b: DistanceBins, sq: u64| {
            let root = i32::try_from(sq.isqrt()).unwrap_or(i32::MAX);
            b.bin(Meters::from_bits(root))
        };
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
        for shift in 0..=MAX_BIN_SHIFT {
            let b = DistanceBins::with_shift(shift);
            let m = 16 - shift;
            // Around every bin edge's threshold (T − 1)·T and the coarse square's steps.
            for k in 0..=(GATE_BINS as u64 + 2) {
                let t = k << m;
                for base in [t.saturating_sub(1) * t, t * t, (t + 1) * (t + 1)] {
                    for sq in base.saturating_sub(3)..=base + 3 {
                        let want = reference(b, sq);
                        assert_eq!(b.bin_of_squared(sq), want, "s {shift} sq {sq}");
                        // With hints at and around the bin (each path of the guess).
                        for hint in want.saturating_sub(3)..=want + 3 {
                            assert_eq!(b.bin_of_squared_near(sq, hint), want, "{sq} {hint}");
                        }
                    }
                }
            }
            // Every magnitude.
            for _ in 0..20_000 {
                let r = rng.next();
                let sq = r >> (r % 64);
                let want = reference(b, sq);
                assert_eq!(b.bin_of_squared(sq), want, "s {shift} sq {sq}");
                #[allow(clippy::cast_possible_truncation)]
                let hint = (r >> 40) as usize % 600;
                assert_eq!(b.bin_of_squared_near(sq, hint), want, "{sq} {hint}");
            }
        }
        // With every hint: the same bins.
        for shift in [0, 5, 10] {
            let b = DistanceBins::with_shift(shift);
            for _ in 0..20_000 {
                let r = rng.next();
                let sq = (r >> 20) >> (r % 40);
                let exact = b.bin_of_squared(sq);
                for hint in [0, 1, 2, 510, 511, 600, exact.saturating_sub(3)] {
                    assert_eq!(b.bin_of_squared_near(sq, hint), exact);
                }
                for hint in exact.saturating_sub(2)..=exact + 2 {
                    assert_eq!(b.bin_of_squared_near(sq, hint), exact, "{sq} {hint}");
                }
            }
        }
        // Both roots (each target uses one), every input.
        for x in 0..(1_u32 << 18) {
            for r in [isqrt_floor_newton(x), isqrt_floor_restoring(x)] {
                assert!(r * r <= x && (r + 1) * (r + 1) > x, "{x}");
            }
        }
    }

    #[test]
    fn the_lowest_set_bit_table_is_trailing_zeros() {
        for mask in 0..=u8::MAX {
            let expected = mask.trailing_zeros().min(8);
            assert_eq!(
                u32::from(LOWEST_SET_BIT[usize::from(mask)]),
                expected,
                "{mask}"
            );
            assert_eq!(u32::from(lowest_layer(mask)), expected, "{mask}");
        }
    }

    #[test]
    fn hard_gates_partition_the_bins() {
        let s = Schedule {
            gate: GateShape::Hard,
            ..Schedule::default()
        };
        let d = Design::<16>::new(SensorModel::default(), s, 64).unwrap();
        let bins = DistanceBins::for_range(10.0);
        let tables: heapless::Vec<GateTable, 16> = (0..d.layers().len())
            .map(|k| GateTable::build(&d, k, bins))
            .collect();
        for i in 0..GATE_BINS {
            let sum: u32 = tables
                .iter()
                .map(|t| u32::from(t.weight(i).to_bits()))
                .sum();
            if bins.lower_edge_m(i) <= 10.0 {
                assert_eq!(sum, 1 << 15, "bin {i} belongs to exactly one layer");
            } else {
                assert_eq!(sum, 0, "bin {i} lies beyond the range");
            }
        }
    }

    #[test]
    fn soft_gate_peaks_at_the_band_centre() {
        let d = Design::<16>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let bins = DistanceBins::for_range(10.0);
        let layer = d.layers()[2];
        let t = GateTable::build(&d, 2, bins);
        let centre = bins.bin(Meters::from_num(layer.gate_center_m));
        let w = t.weight(centre).to_num::<f32>();
        assert!(w > 0.99, "{w}");
        // One σ away: e^{−½} = 0.6065 within the binning error.
        let one_sigma = bins.bin(Meters::from_num(layer.gate_center_m + layer.gate_sigma_m));
        let w1 = t.weight(one_sigma).to_num::<f32>();
        assert!(
            (w1 - 0.6065).abs() < binning_error_bound(&layer, bins),
            "{w1}"
        );
    }
}
