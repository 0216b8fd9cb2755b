//! The classifier's scratch: one [`Slot`] per touched layer cell, the per-layer [`Recent`]
//! cell that lets consecutive returns skip the hash, how a point folds into a slot, and the
//! 32-bit cell arithmetic (millimetres, a point's cell and its position in it, a cell's corner,
//! the hash).

use super::rule::{self, PairScale, PlaneState};
use crate::units::{Meters, Point3};

/// The layers for which the classifier remembers the cell and slot of their last point.
pub(super) const RECENT_LAYERS: usize = 8;

/// A cell whose lower corner lies within ±`ORIGIN_LIMIT` raw (±16 384 m) and whose size is
/// below it can be remembered in a [`Recent`]: then a coordinate's wrapped 32-bit difference
/// from the corner is below the size exactly when the coordinate lies in the cell.
pub(super) const ORIGIN_LIMIT: i32 = 1 << 30;

/// Per layer (the first [`RECENT_LAYERS`]): the layer's cell reciprocal and the cell of its last
/// point. Consecutive returns of a line mostly fall in the same cell of a layer; such a point
/// is recognised by two subtractions and two compares, and folded into the cell's slot without
/// a division, a hash or a probe.
#[derive(Debug, Clone, Copy)]
pub(super) struct Recent {
    /// The lower corner of the cell of the layer's last point, raw Q16.16, within
    /// ±[`ORIGIN_LIMIT`].
    pub(super) origin_x: i32,
    /// Likewise along y.
    pub(super) origin_y: i32,
    /// The cell's size, raw (below [`ORIGIN_LIMIT`]), while the entry holds a cell; 0 when it
    /// holds none (no difference is below 0: every point misses).
    pub(super) span: u32,
    /// The layer's cell reciprocal ([`crate::grid::cell_reciprocal`]), set by
    /// [`Classifier::adopt_design`]: where there is no hardware division, cell indices are
    /// found by a multiplication; the plane rule's position in the cell on every target.
    pub(super) reciprocal: u32,
    /// The slot of the cell of the layer's last point, whether or not the shortcut (`span`)
    /// holds its cell (the pair test across a cell's edge reads it): valid while the layer has
    /// a last point in the observation (slots are vacated only when the observation ends).
    pub(super) slot: u16,
    /// The pair test's constants in the layer's cells, set by [`Classifier::configure`] and
    /// [`Classifier::adopt_design`]; [`PairScale::NONE`] without the plane rule.
    pub(super) pair_scale: PairScale,
    /// The layer's cell size, set with the reciprocal ([`Resolution::UNSET`] for a layer not
    /// in force): read where a point leaves the cell of the layer's last one.
    ///
    /// [`Resolution::UNSET`]: crate::grid::Resolution::UNSET
    pub(super) resolution: crate::grid::Resolution,
}

impl Recent {
    pub(super) const NONE: Self = Self {
        origin_x: 0,
        origin_y: 0,
        span: 0,
        reciprocal: 0,
        slot: 0,
        pair_scale: PairScale::NONE,
        resolution: crate::grid::Resolution::UNSET,
    };
}

/// The marker of an empty slot: slots store their layer plus one, so that an empty slot (and
/// a fresh classifier) is all zero bits.
pub(super) const EMPTY: u8 = 0;

/// One touched layer cell of the current observation. 72 bytes (16 without the `plane-rule`
/// feature).
#[derive(Debug, Clone, Copy)]
pub(super) struct Slot {
    /// The plane rule's sums (kept only while the plane rule is in force; zero-sized without
    /// the `plane-rule` feature).
    pub(super) plane: PlaneState,
    pub(super) cell_x: i32,
    pub(super) cell_y: i32,
    /// The gate bin of the smallest horizontal distance of the cell's points from the sensor.
    pub(super) bin: u16,
    /// Lowest z, millimetres relative to the observation's reference height.
    pub(super) z_low: i16,
    /// Highest z not above `z_low + robot height`, same units.
    pub(super) z_high: i16,
    /// The layer plus one, or [`EMPTY`].
    pub(super) layer: u8,
    /// Whether a drop-off or missing ground was seen in the cell.
    pub(super) hole: bool,
    /// Once vacated: which cell it held, and when (module `recall`).
    pub(super) held: Held,
}

/// What a vacated slot held: the layer plus one of its cell (whose key and lowest return stay
/// in the slot until it is taken again) and the stamp of the observation that held it (0:
/// none). Zero-sized without the `plane-rule` feature, whose rule has no pair test.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Held {
    /// The layer plus one, or [`EMPTY`].
    #[cfg(feature = "plane-rule")]
    pub(super) layer: u8,
    /// The observation's stamp, 1 ..= 255 (0: none).
    #[cfg(feature = "plane-rule")]
    pub(super) stamp: u8,
}

impl Held {
    /// Nothing held.
    pub(super) const NONE: Self = Self {
        #[cfg(feature = "plane-rule")]
        layer: EMPTY,
        #[cfg(feature = "plane-rule")]
        stamp: 0,
    };
}

impl Slot {
    pub(super) const VACANT: Self = Self {
        plane: PlaneState::EMPTY,
        cell_x: 0,
        cell_y: 0,
        bin: 0,
        z_low: 0,
        z_high: 0,
        layer: EMPTY,
        hole: false,
        held: Held::NONE,
    };
}
/// Metres (raw Q16.16) to millimetres, `⌊raw · 1000 / 2¹⁶⌋`, saturated to `i16`.
///
/// On ARMv7-M one `smull` by 1000·2¹⁶ and the product's high word (`⌊raw · 1000·2¹⁶ / 2³²⌋`
/// is the same floor), then `ssat`. On ARMv6-M in 32-bit words (a 64-bit multiply is a
/// library call there): 1000/2¹⁶ = 125/2¹³, and with `raw = hi·2¹³ + lo` (0 ≤ lo < 2¹³) the
/// floor is `hi·125 + ⌊lo·125 / 2¹³⌋` exactly (|hi·125| < 2²⁵).
#[inline]
pub(super) fn mm_i16(raw: i32) -> i16 {
    let mm = if crate::wide::HALVES {
        mm_halves(raw)
    } else {
        // |raw · 65 536 000| < 2⁵⁷: its high word is the floor, within ±2²⁵.
        #[allow(clippy::cast_possible_truncation)]
        let mm = ((i64::from(raw) * 65_536_000) >> 32) as i32;
        mm
    };
    // Clamped to the i16 range: the cast is exact.
    #[allow(clippy::cast_possible_truncation)]
    let saturated = mm.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
    saturated
}

/// [`mm_i16`]'s floor from 13-bit halves, without a 64-bit product.
#[inline]
pub(super) fn mm_halves(raw: i32) -> i32 {
    let hi = raw >> 13;
    let lo = raw & 0x1FFF;
    hi * 125 + ((lo * 125) >> 13)
}

/// The position of `point` in its cell `(cx, cy)` of side `bits` (raw) with reciprocal `m`
/// ([`rule::sub_cell`] of the remainders `0 ≤ rem < bits`, exact in wrapping 32-bit
/// arithmetic).
#[inline]
pub(super) fn position_in_cell(point: Point3, cx: i32, cy: i32, bits: i32, m: u32) -> (i8, i8) {
    #[allow(clippy::cast_sign_loss)]
    let rem = |v: Meters, c: i32| v.to_bits().wrapping_sub(c.wrapping_mul(bits)) as u32;
    (
        rule::sub_cell(rem(point.x, cx), m),
        rule::sub_cell(rem(point.y, cy), m),
    )
}

/// The cell of `point` for cell size `r` with reciprocal `m`
/// ([`crate::grid::cell_reciprocal`]), and (while the plane rule is in force) the point's
/// position in it ([`rule::sub_cell`]): the cell by a hardware division where the target
/// has one (ARMv7-M, told apart from ARMv6-M by its atomic compare-and-swap: stable Rust
/// has no `cfg` for the divide instruction), a multiplication by the reciprocal elsewhere
/// (Cortex-M0, the host); both are exactly `r.cell_of`. The position is a multiplication
/// by the reciprocal on every target.
#[inline]
pub(super) fn cell_of(
    r: crate::grid::Resolution,
    m: u32,
    point: Point3,
    plane: bool,
) -> (i32, i32, (i8, i8)) {
    let bits = r.to_bits();
    let (cx, cy) = if cfg!(all(target_arch = "arm", target_has_atomic = "32")) {
        (r.cell_of(point.x), r.cell_of(point.y))
    } else {
        (
            crate::grid::cell_of_reciprocal(point.x.to_bits(), bits, m),
            crate::grid::cell_of_reciprocal(point.y.to_bits(), bits, m),
        )
    };
    if !plane {
        return (cx, cy, (0, 0));
    }
    (cx, cy, position_in_cell(point, cx, cy, bits, m))
}

/// [`cell_of`] for layers 8 and up: the cell by `r.cell_of`, the position
/// (when `plane`) by the layer's reciprocal `m`.
pub(super) fn locate(
    r: crate::grid::Resolution,
    m: u32,
    point: Point3,
    plane: bool,
) -> (i32, i32, (i8, i8)) {
    let (cx, cy) = (r.cell_of(point.x), r.cell_of(point.y));
    if !plane {
        return (cx, cy, (0, 0));
    }
    (cx, cy, position_in_cell(point, cx, cy, r.to_bits(), m))
}

/// The lower corner `c · bits` of cell `c = ⌊x / bits⌋` (for some `i32` x) of size
/// `0 < bits < ORIGIN_LIMIT`, or `None` when it lies beyond ±[`ORIGIN_LIMIT`]: as
/// `c.checked_mul(bits)` within the limit, in one 32-bit multiplication (a `checked_mul` of
/// `i32` is a 64-bit product, a library call on a Cortex-M0).
///
/// Exact: the true corner lies in `(x − bits, x]`, within `(−2³¹ − 2³⁰, 2³¹)`; wrapped to 32
/// bits, a corner below −2³¹ lands in `(2³⁰, 2³¹)`, beyond the limit like every other corner
/// outside ±2³⁰, and a corner within the limit is its own wrapped value. For other arguments
/// the result is some corner or `None`, never a panic.
#[inline]
pub(super) fn corner(c: i32, bits: i32) -> Option<i32> {
    let corner = c.wrapping_mul(bits);
    (-ORIGIN_LIMIT..=ORIGIN_LIMIT)
        .contains(&corner)
        .then_some(corner)
}

/// Mixes a cell key into a slot index (multiplicative hashing of 32-bit words).
#[inline]
pub(super) fn hash(layer: u8, x: i32, y: i32) -> u32 {
    #[allow(clippy::cast_sign_loss)]
    let (xu, yu) = (x as u32, y as u32);
    let h = xu.wrapping_mul(0x9E37_79B1)
        ^ yu.wrapping_mul(0x85EB_CA77).rotate_left(13)
        ^ u32::from(layer).wrapping_mul(0xC2B2_AE3D);
    h ^ (h >> 15)
}

/// Folds a point (z mm, position `sub` in the cell, distance bin) into a used slot under the
/// overhang rule; with `plane`, into the plane rule's sums and its pair test (with the layer's
/// `scale`, [`PlaneState::step_from_last`]) too when it lies below the cut.
/// `bin` is a `u16`, `z` and `robot_height_mm` are `i16`, held in words: the per-layer loop
/// keeps them so, and extends nothing again per layer.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn fold(
    slot: &mut Slot,
    z: i32,
    sub: (i8, i8),
    bin: u32,
    hole: bool,
    robot_height_mm: i32,
    plane: bool,
    scale: PairScale,
) {
    // The narrow values again, for the slot's fields (exact: see above).
    #[allow(clippy::cast_possible_truncation)]
    let (bin16, z16) = (bin as u16, z as i16);
    if bin < u32::from(slot.bin) {
        slot.bin = bin16;
    }
    if hole {
        slot.hole = true;
    }
    if z < i32::from(slot.z_low) {
        let cut = z + robot_height_mm;
        if i32::from(slot.z_high) > cut {
            // The stored highest is overhang now; the best bound still known below the cut.
            let low_stays = i32::from(slot.z_low) <= cut;
            slot.z_high = if low_stays { slot.z_low } else { z16 };
            if plane {
                restart_sums(slot, sub, z16, low_stays);
            }
        } else if plane {
            slot.plane.step_from_last(sub.0, sub.1, z16, scale);
            slot.plane.add_next(sub.0, sub.1, z16);
            slot.plane.set_low_at(sub);
        }
        slot.z_low = z16;
    } else if z <= i32::from(slot.z_low) + robot_height_mm {
        if z > i32::from(slot.z_high) {
            slot.z_high = z16;
            if plane {
                slot.plane.set_high_at(sub);
            }
        }
        if plane {
            slot.plane.step_from_last(sub.0, sub.1, z16, scale);
            slot.plane.add_next(sub.0, sub.1, z16);
        }
    }
}

/// The summed points of `slot` lie above the cut of a new lowest point `z` (at `sub`): its
/// sums restart from this point and, when `low_stays` (still below the cut), the previous
/// lowest, at its own position, which becomes the highest (as the caller sets `z_high`).
/// Out of line: rare.
#[cold]
#[inline(never)]
pub(super) fn restart_sums(slot: &mut Slot, sub: (i8, i8), z: i16, low_stays: bool) {
    let previous_low_at = slot.plane.low_at();
    slot.plane = PlaneState::first(sub.0, sub.1, z);
    if low_stays {
        slot.plane
            .add_next(previous_low_at.0, previous_low_at.1, slot.z_low);
        slot.plane.set_high_at(previous_low_at);
    }
}
