//! The per-line transform: from (beam index, range in mm) to a world point and its horizontal
//! distance from the scanner, in integer arithmetic.
//!
//! # Formats
//! [`LineTransform::new`] folds the robot's rotation, the actuator's rotation and the scan
//! plane into one 3 × 2 matrix `M` (world direction = `M·(cos θ, sin θ)`), and pre-scales it by
//! 1/1 000 so that ranges in millimetres need no division: each entry is stored as
//! `M_ij · 2⁴⁰ / 1 000` in an `i32` (|entry| ≤ 1 099 511 628 < 2³⁰·⁰³). The scanner's world
//! position is kept in Q24.40 (`i64`). Per point, with (c, s) the beam's Q1.15 direction and
//! r the range in mm:
//!
//! ```text
//! u_i = round((K_ic·c + K_is·s) / 2¹⁵)     world direction per mm, Q40 (|u_i| < 2³¹)
//! Δ_i = u_i · r                             offset from the scanner, metres Q40 (< 2⁴⁸)
//! p_i = sat_i32(round((o_i + Δ_i) / 2²⁴))   world coordinate, Q16.16
//! d   = round(√(Δx² + Δy²)) with Δ in Q16  horizontal distance, Q16.16
//! ```
//!
//! No division, no float, no trigonometry. [`LineTransform::locate_squared`], the per-point
//! path, computes these bits in 32-bit words where it can: u_i from the entries split into
//! 16-bit halves (`K = hi·2¹⁶ + lo`, four 32-bit multiplies: `2·A + ⌊(B + 2¹⁴)/2¹⁵⌋` with A
//! from the high halves and B from the low ones, exact), then one 32 × 32 → 64 product per
//! axis (`Δ_i = u_i·r`), the coordinate as `(o_i + 2²³ + Δ_i) >> 24` without saturation on
//! a line whose origin is within 32 256 m (no point of it can saturate; others take the
//! saturating path, same bits), and the squares of the rounded Δx, Δy as 32 × 32 → 64
//! products. On a Cortex-M4 a product is one `smull` (or `umull` and a sign correction); on
//! a Cortex-M0 it is two (the range is below 2¹⁷) or three (a square) 16 × 16 `muls` inline
//! (the crate's `wide` module), not an `__aeabi_lmul` call. Measured out of line in a
//! profiling build of the bench firmware: 100 instructions per point on the M4F and 240 on
//! the M0, against 218, and 308 plus the `__aeabi_lmul` calls, of the saturating `i64` form
//! (BENCHMARKS.md, "The per-return path before the classifier"). The other entry points
//! ([`LineTransform::locate`], [`LineTransform::point`]) keep the saturating `i64` form
//! (nine 64-bit products; the same bits). The horizontal distance of
//! [`LineTransform::locate`] adds a bit-by-bit integer square root (one iteration per
//! result bit: about 19 at 8 m, 23 at 80 m).
//!
//! # Error
//! Against the exact geometry of the same inputs (range, beam angle, actuator angle, pose):
//! - the beam table's Q1.15 rounding: at most 2⁻¹⁵ · r ≈ 3.05·10⁻⁵ · r (a direction error
//!   of ≤ √2·2⁻¹⁶ in general, up to 2⁻¹⁵ where a component saturates near 1, see
//!   [`super::beams`]);
//! - the matrix (sines, cosines and products in Q2.30, the 1/1 000 scale in Q40): below
//!   2·10⁻⁸ · r;
//! - the rounding of u_i (2⁻⁴¹ m per mm), of the outputs to Q16.16 (2⁻¹⁷ m per axis) and,
//!   through [`Pose::from_f32`], of the pose's position (2⁻¹⁷ m per axis), and the mount
//!   offset rotated in Q2.30: below 0.03 mm together.
//!
//! So a world point is within **0.03 mm + 3.1·10⁻⁵ · r** of the exact one (0.28 mm at 8 m,
//! 0.96 mm at 30 m, 2.6 mm at 81.91 m), and so is the horizontal distance (its square root is
//! correctly rounded to 2⁻¹⁶ m). `host-tests` holds the library to this bound against an f64
//! reference, and `cargo run --release -p terrain-pyramid-host-tests --example
//! geometry_error` measures the actual figures. Coordinates beyond ±32 768 m saturate.

use core::fmt;

use super::beams::{BeamDir, BeamTable};
use super::mount::{Mount, ScanPlane};
use super::pose::{Pose, PoseFrame};
use crate::angle::FineAngle;
use crate::units::{Meters, Point3};
use crate::wide;

/// The longest range [`LineTransform::point`] places, millimetres: 2¹⁷ − 1 = 131 071
/// (131.071 m, beyond every LMS2xx mode: 81.91 m in the 80 m mode). Longer ranges give
/// `None`; this bound keeps every product within 64 bits.
pub const MAX_RANGE_MM: u32 = (1 << 17) - 1;

/// 2⁴⁰/1 000, rounded: the largest magnitude of a per-mm matrix entry (a unit component).
const MM_Q40: i64 = 1_099_511_628;

/// 1.024 = 2¹⁰/1 000 in Q32, rounded: turns a Q2.30 unit component into Q40 per mm.
const Q30_TO_MM_Q40: i64 = 4_398_046_511;

/// One row of the direction matrix: the world-axis component per mm of range, for cos θ and
/// sin θ, Q40; and each split as `K = hi·2¹⁶ + lo` with `lo` in −2¹⁵ ..< 2¹⁵, for
/// [`Row::per_mm_dir`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
struct Row {
    c: i32,
    s: i32,
    c_hi: i32,
    c_lo: i32,
    s_hi: i32,
    s_lo: i32,
}

/// `k = hi·2¹⁶ + lo` with `lo` in −2¹⁵ ..< 2¹⁵ (exact for `k` below 2³¹ − 2¹⁵; a row's
/// entries are at most 2⁴⁰/1 000).
fn split_q16(k: i32) -> (i32, i32) {
    let lo = (k.wrapping_add(1 << 15) & 0xFFFF) - (1 << 15);
    (k.wrapping_sub(lo) >> 16, lo)
}

impl Row {
    /// The row from two Q2.30 components (each clamped to ±1: rounding can pass 1 by a few
    /// LSBs).
    fn from_q30(c: i64, s: i64) -> Self {
        let (c, s) = (per_mm(c), per_mm(s));
        let ((c_hi, c_lo), (s_hi, s_lo)) = (split_q16(c), split_q16(s));
        Self {
            c,
            s,
            c_hi,
            c_lo,
            s_hi,
            s_lo,
        }
    }

    /// The offset along this axis for a beam direction and a range, metres Q40.
    #[inline]
    fn offset(self, c: i64, s: i64, range_mm: i64) -> i64 {
        // |K|·2¹⁵·√2 < 2⁴⁵·⁶ for every table direction, so the sum fits easily, and the
        // rounded quotient below 2³¹; saturating it costs two compares and keeps any
        // direction safe.
        let u = sat_i32((i64::from(self.c) * c + i64::from(self.s) * s + (1 << 14)) >> 15);
        // |u| < 2³¹ and the range < 2¹⁷: the product is below 2⁴⁸.
        i64::from(u) * range_mm
    }

    /// `u = round((K_c·c + K_s·s) / 2¹⁵)`, the world direction per mm (Q40) of a beam
    /// direction (c, s) in Q1.15, in 32-bit words: with `K = hi·2¹⁶ + lo`,
    /// `K_c·c + K_s·s = A·2¹⁶ + B` (A from the high parts, B from the low ones), so
    /// `⌊(A·2¹⁶ + B + 2¹⁴) / 2¹⁵⌋ = 2A + ⌊(B + 2¹⁴) / 2¹⁵⌋` exactly. For a direction of a
    /// [`BeamDir`] (|c| + |s| ≤ √2·2¹⁵ + 1) and |K| ≤ 2⁴⁰/1 000: |A| < 2²⁹·⁶, |B| < 2³⁰·⁶, and
    /// the result, below 2³⁰·⁶, equals the `i64` computation of [`Row::offset`].
    #[inline]
    fn per_mm_dir(self, c: i32, s: i32) -> i32 {
        let a = self
            .c_hi
            .wrapping_mul(c)
            .wrapping_add(self.s_hi.wrapping_mul(s));
        let b = self
            .c_lo
            .wrapping_mul(c)
            .wrapping_add(self.s_lo.wrapping_mul(s));
        a.wrapping_mul(2)
            .wrapping_add(b.wrapping_add(1 << 14) >> 15)
    }
}

/// A Q2.30 unit component as Q40 metres per millimetre, clamped to ±2⁴⁰/1 000.
pub(super) fn per_mm(q30: i64) -> i32 {
    // A unit vector's component: |q30| ≤ 2³⁰ up to rounding; clamped, the product with the
    // factor (< 2³²·⁰⁴) stays below 2⁶²·⁰⁴.
    let unit = q30.clamp(-(1 << 30), 1 << 30);
    let q40 = (unit * Q30_TO_MM_Q40 + (1 << 31)) >> 32;
    // ±MM_Q40 fits an i32.
    sat_i32(q40.clamp(-MM_Q40, MM_Q40))
}

/// [`per_mm`] in 32-bit words and one 32 × 32 → 64 product ([`wide::smul`], no library
/// call on ARMv6-M): the factor is 2³² + 103 079 215, so
/// `⌊(u·(2³² + f) + 2³¹) / 2³²⌋ = u + ⌊(u·f + 2³¹) / 2³²⌋` exactly (u·2³² is a multiple of
/// 2³²), with |u| ≤ 2³⁰ and f < 2²⁷.
pub(super) fn per_mm_words(q30: i64) -> i32 {
    const FRACTION: i32 = (Q30_TO_MM_Q40 - (1 << 32)) as i32;
    // |unit| ≤ 2³⁰ fits an i32.
    #[allow(clippy::cast_possible_truncation)]
    let unit = q30.clamp(-(1 << 30), 1 << 30) as i32;
    let q40 = i64::from(unit) + ((wide::smul(unit, FRACTION) + (1 << 31)) >> 32);
    sat_i32(q40.clamp(-MM_Q40, MM_Q40))
}

/// Saturates an `i64` to the `i32` range.
#[inline]
pub(super) fn sat_i32(value: i64) -> i32 {
    i32::try_from(value).unwrap_or(if value < 0 { i32::MIN } else { i32::MAX })
}

/// A Q40 metres coordinate rounded to Q16.16 [`Meters`], saturating.
#[inline]
pub(super) fn meters_q40(value: i64) -> Meters {
    Meters::from_bits(sat_i32(value.saturating_add(1 << 23) >> 24))
}

/// `round(√x)` for any `u64`, by the bit-by-bit (restoring) method: no multiply, no divide.
/// One iteration per result bit.
pub(crate) fn isqrt_round(x: u64) -> u64 {
    if x >> 50 == 0 {
        return u64::from(isqrt_round_below_2_50(x));
    }
    // The highest power of four not above x.
    let mut bit: u64 = 1 << ((63 - x.leading_zeros()) & !1);
    let mut rem = x;
    let mut root: u64 = 0;
    while bit != 0 {
        let trial = root + bit;
        if rem >= trial {
            rem -= trial;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    // Now root = ⌊√x⌋ and rem = x − root²; √x ≥ root + ½ exactly when rem > root.
    if rem > root {
        root + 1
    } else {
        root
    }
}

/// [`isqrt_round`] for `x < 2⁵⁰` (every horizontal distance of the per-line path), the same
/// restoring method one result bit at a time, but with 32-bit words only: the root stays
/// below 2²⁵ and the partial remainder below 2²⁸, so `x` is shifted in two bits at a time
/// from its two halves and no 64-bit arithmetic is left in the loop.
#[inline]
fn isqrt_round_below_2_50(x: u64) -> u32 {
    #[allow(clippy::cast_possible_truncation)]
    let (hi, lo) = ((x >> 32) as u32, x as u32);
    let mut root = 0_u32;
    let mut rem = 0_u32;
    // One step: bring down the next two bits of x (`pair`), try the next root bit.
    let step = |root: &mut u32, rem: &mut u32, pair: u32| {
        *rem = (*rem << 2) | pair;
        let trial = (*root << 2) | 1;
        *root <<= 1;
        if *rem >= trial {
            *rem -= trial;
            *root |= 1;
        }
    };
    if hi != 0 {
        // The pairs of `hi` from its highest non-zero one (hi < 2¹⁸: at most 9 pairs).
        let mut shift = (31 - hi.leading_zeros()) & !1;
        loop {
            step(&mut root, &mut rem, (hi >> shift) & 3);
            if shift == 0 {
                break;
            }
            shift -= 2;
        }
        let mut bits = lo;
        for _ in 0..16 {
            step(&mut root, &mut rem, bits >> 30);
            bits <<= 2;
        }
    } else if lo != 0 {
        let lead = lo.leading_zeros() & !1;
        let mut bits = lo << lead;
        for _ in 0..(32 - lead) / 2 {
            step(&mut root, &mut rem, bits >> 30);
            bits <<= 2;
        }
    }
    // root = ⌊√x⌋, rem = x − root²; round up exactly when rem > root.
    if rem > root {
        root + 1
    } else {
        root
    }
}

/// A world point and its horizontal distance from the scanner.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinePoint {
    /// The point in the world frame, metres (saturated at ±32 768 m).
    pub point: Point3,
    /// The horizontal distance from the scanner's centre to the point, `√(Δx² + Δy²)`,
    /// metres, 0 ..= 131.071 m.
    pub horizontal: Meters,
}

#[cfg(feature = "defmt")]
impl defmt::Format for LinePoint {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "LinePoint({}, d {=i32} raw Q16.16)",
            self.point,
            self.horizontal.to_bits()
        );
    }
}

/// A world point and the square of its horizontal distance from the scanner: what
/// [`LineTransform::locate_squared`] gives for the per-point path, which needs the distance
/// only to find its gate bin ([`crate::gate::DistanceBins::bin_of_squared`]), not the
/// distance itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinePointSquared {
    /// The point in the world frame, metres (saturated at ±32 768 m).
    pub point: Point3,
    /// `Δx² + Δy²` with Δx, Δy the point's offsets from the scanner's centre rounded to
    /// Q16.16 metres: raw units squared (2⁻³² m²), below 2⁵⁰ (the range is at most
    /// 131.071 m). [`LinePoint::horizontal`] is its rounded square root.
    pub horizontal_squared: u64,
}

/// The geometry of one scan line: built once per line from the beam table, the mount, the
/// actuator angle and the robot's pose; then [`LineTransform::point`] places each return.
///
/// See the [module documentation](self) for the formats, the cost and the error.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct LineTransform<'a> {
    beams: &'a BeamTable,
    /// The direction matrix per mm, rows x, y, z.
    rows: [Row; 3],
    /// The scanner's centre in the world, metres Q40.
    origin: [i64; 3],
    /// `origin + 2²³`: a point's coordinate is `(origin + Δ + 2²³) >> 24` rounded to Q16.16.
    origin_round: [i64; 3],
    /// No point of this line can saturate (every |origin| ≤ 2⁵⁵ − 2⁴⁹, i.e. within
    /// 32 256 m): [`LineTransform::locate_squared`] skips the saturation.
    unsaturated: bool,
}

/// The largest |origin| (Q40) of a [`LineTransform::unsaturated`] line: 2⁵⁵ − 2⁴⁹
/// (32 256 m). An offset is below 2⁴⁷·⁶ (|u| < 2³⁰·⁶, range < 2¹⁷), so `origin + Δ + 2²³`
/// stays within ±(2⁵⁵ − 2²⁴) and its rounded Q16.16 value within the `i32` range.
const UNSATURATED_ORIGIN: i64 = (1 << 55) - (1 << 49);

impl<'a> LineTransform<'a> {
    /// The transform of one line: `beams` for the scanner's variant, `mount` for how it sits,
    /// `actuator` the pan angle p ([`ScanPlane::PannedVertical`]) or tilt angle τ
    /// ([`ScanPlane::TiltedHorizontal`]) at this line, `frame` the robot's pose
    /// ([`Pose::frame`], computed once per pose change).
    ///
    /// Costs one [`FineAngle::sin_cos`] and about twenty 64-bit multiplies.
    #[must_use]
    pub fn new(
        beams: &'a BeamTable,
        mount: &Mount,
        actuator: FineAngle,
        frame: &PoseFrame,
    ) -> Self {
        let [r0, r1, r2] = frame.rotation.columns();
        let sc = actuator.sin_cos();
        let (sa, ca) = (i64::from(sc.sin.to_bits()), i64::from(sc.cos.to_bits()));
        // The world images of the sensor-frame directions that multiply cos θ and sin θ.
        // Panned: d = sin θ·R_z(p)·x̂ − cos θ·ẑ. Tilted: d = sin θ·R_y(τ)·x̂ − cos θ·ŷ, with
        // R_y(τ)·x̂ = (cos τ, 0, −sin τ).
        let (col_c, aux, sign) = match mount.plane {
            ScanPlane::PannedVertical => (r2, r1, 1),
            ScanPlane::TiltedHorizontal => (r1, r2, -1),
        };
        let row = |i: usize| {
            let pick = |col: [i64; 3]| col.get(i).copied().unwrap_or(0);
            let s = (ca * pick(r0) + sign * sa * pick(aux) + (1 << 29)) >> 30;
            Row::from_q30(-pick(col_c), s)
        };
        let rows = [row(0), row(1), row(2)];

        // The scanner's centre: T + R·position, in Q40.
        let t = frame.translation;
        let p = mount.position;
        let [px, py, pz] = [p.x, p.y, p.z].map(|m| i64::from(m.to_bits()));
        let rotated = |i: usize| {
            let pick = |col: [i64; 3]| col.get(i).copied().unwrap_or(0);
            // Each product < 2⁶¹, the sum of three < 2⁶²·⁶; Q46 → Q40 with rounding.
            let q46 = pick(r0) * px + pick(r1) * py + pick(r2) * pz;
            (q46 + (1 << 5)) >> 6
        };
        let origin = [
            (i64::from(t.x.to_bits()) << 24) + rotated(0),
            (i64::from(t.y.to_bits()) << 24) + rotated(1),
            (i64::from(t.z.to_bits()) << 24) + rotated(2),
        ];
        let unsaturated = origin
            .iter()
            .all(|o| o.unsigned_abs() <= UNSATURATED_ORIGIN.unsigned_abs());
        Self {
            beams,
            rows,
            origin,
            origin_round: origin.map(|o| o.saturating_add(1 << 23)),
            unsaturated,
        }
    }

    /// [`LineTransform::new`] from a [`Pose`]: computes the pose's rotation (three sines and
    /// cosines) on the way. Prefer [`LineTransform::new`] with a [`PoseFrame`] kept across
    /// lines when the pose changes less often than the lines arrive.
    #[must_use]
    pub fn from_pose(
        beams: &'a BeamTable,
        mount: &Mount,
        actuator: FineAngle,
        pose: &Pose,
    ) -> Self {
        Self::new(beams, mount, actuator, &pose.frame())
    }

    /// The beam table this line reads.
    #[must_use]
    pub const fn beams(&self) -> &'a BeamTable {
        self.beams
    }

    /// The scanner's centre in the world frame, metres (saturated at ±32 768 m).
    #[must_use]
    pub fn sensor_origin(&self) -> Point3 {
        let [x, y, z] = self.origin;
        Point3 {
            x: meters_q40(x),
            y: meters_q40(y),
            z: meters_q40(z),
        }
    }

    /// The world point of beam `beam_index` at `range_mm` millimetres.
    ///
    /// `None` when the beam index is past the table's last beam or the range exceeds
    /// [`MAX_RANGE_MM`]. Coordinates saturate at ±32 768 m. Never panics.
    #[must_use]
    pub fn point(&self, beam_index: usize, range_mm: u32) -> Option<Point3> {
        self.point_at(self.beams.get(beam_index)?, range_mm)
    }

    /// The world point of beam `beam_index` at `range_mm` and its horizontal distance from
    /// the scanner, as [`LineTransform::point`] and [`LineTransform::horizontal_distance`]
    /// together (computing the offsets once).
    #[must_use]
    pub fn locate(&self, beam_index: usize, range_mm: u32) -> Option<LinePoint> {
        self.locate_at(self.beams.get(beam_index)?, range_mm)
    }

    /// The horizontal distance `√(Δx² + Δy²)` from the scanner's centre to the point of beam
    /// `beam_index` at `range_mm`, metres; `None` as for [`LineTransform::point`].
    #[must_use]
    pub fn horizontal_distance(&self, beam_index: usize, range_mm: u32) -> Option<Meters> {
        let dir = self.beams.get(beam_index)?;
        let [dx, dy, _] = self.offsets(dir, range_mm)?;
        Some(horizontal(dx, dy))
    }

    /// [`LineTransform::point`] for a beam direction of the caller's (e.g. from another
    /// table); `None` when the range exceeds [`MAX_RANGE_MM`].
    #[must_use]
    pub fn point_at(&self, dir: BeamDir, range_mm: u32) -> Option<Point3> {
        let offsets = self.offsets(dir, range_mm)?;
        Some(self.world(offsets))
    }

    /// [`LineTransform::locate`] for a beam direction of the caller's; `None` when the range
    /// exceeds [`MAX_RANGE_MM`].
    #[must_use]
    pub fn locate_at(&self, dir: BeamDir, range_mm: u32) -> Option<LinePoint> {
        let offsets = self.offsets(dir, range_mm)?;
        let [dx, dy, _] = offsets;
        Some(LinePoint {
            point: self.world(offsets),
            horizontal: horizontal(dx, dy),
        })
    }

    /// [`LineTransform::locate`] without the square root: the world point of beam
    /// `beam_index` at `range_mm` and the square of its horizontal distance; `None` as for
    /// [`LineTransform::point`].
    #[must_use]
    #[inline]
    pub fn locate_squared(&self, beam_index: usize, range_mm: u32) -> Option<LinePointSquared> {
        let dir = self.beams.get(beam_index)?;
        if range_mm > MAX_RANGE_MM {
            return None;
        }
        if self.unsaturated {
            return Some(self.locate_squared_unsaturated(dir, range_mm));
        }
        let offsets = self.offsets(dir, range_mm)?;
        let [dx, dy, _] = offsets;
        Some(LinePointSquared {
            point: self.world(offsets),
            horizontal_squared: horizontal_squared(dx, dy),
        })
    }

    /// [`LineTransform::locate_squared`] of a line that cannot saturate, for a range within
    /// [`MAX_RANGE_MM`]: the same bits in 32-bit words and one 32 × 32 → 64 product per axis
    /// (u per mm by [`Row::per_mm_dir`], `Δ = u·r`, the coordinate
    /// `(origin + Δ + 2²³) >> 24` without saturation, the distance's square from `Δ` rounded
    /// to Q16).
    #[inline]
    fn locate_squared_unsaturated(&self, dir: BeamDir, range_mm: u32) -> LinePointSquared {
        let (c, s) = dir.to_bits();
        let (c, s) = (i32::from(c), i32::from(s));
        // range_mm ≤ MAX_RANGE_MM < 2¹⁷: the product is exact.
        let [rx, ry, rz] = self.rows;
        let [dx, dy, dz] = [rx, ry, rz].map(|row| wide::smul_u17(row.per_mm_dir(c, s), range_mm));
        let [ox, oy, oz] = self.origin_round;
        // |origin| ≤ 2⁵⁵ − 2⁴⁹ and |Δ| < 2⁴⁸: the sum and its value >> 24 fit (see
        // UNSATURATED_ORIGIN).
        #[allow(clippy::cast_possible_truncation)]
        let coordinate = |o: i64, d: i64| Meters::from_bits(((o + d) >> 24) as i32);
        LinePointSquared {
            point: Point3 {
                x: coordinate(ox, dx),
                y: coordinate(oy, dy),
                z: coordinate(oz, dz),
            },
            horizontal_squared: horizontal_squared(dx, dy),
        }
    }

    /// The offsets from the scanner's centre, metres Q40 (each below 2⁴⁸ in magnitude).
    #[inline]
    fn offsets(&self, dir: BeamDir, range_mm: u32) -> Option<[i64; 3]> {
        if range_mm > MAX_RANGE_MM {
            return None;
        }
        let (c, s) = dir.to_bits();
        let (c, s, r) = (i64::from(c), i64::from(s), i64::from(range_mm));
        let [x, y, z] = self.rows;
        Some([x.offset(c, s, r), y.offset(c, s, r), z.offset(c, s, r)])
    }

    /// The world point of offsets from the scanner's centre.
    #[inline]
    fn world(&self, offsets: [i64; 3]) -> Point3 {
        let [ox, oy, oz] = self.origin;
        let [dx, dy, dz] = offsets;
        // |origin| < 2⁵⁷ and |offset| < 2⁴⁸: the sums cannot overflow.
        Point3 {
            x: meters_q40(ox + dx),
            y: meters_q40(oy + dy),
            z: meters_q40(oz + dz),
        }
    }
}

/// The horizontal distance `√(Δx² + Δy²)` between two points, rounded to Q16.16 metres with
/// the same integer square root as the per-line path (saturating at 32 768 m).
///
/// For points that did not come through a [`LineTransform`] (a point file, a simulator).
#[must_use]
pub fn horizontal_distance(from: Point3, to: Point3) -> Meters {
    let dx = i64::from(to.x.to_bits()) - i64::from(from.x.to_bits());
    let dy = i64::from(to.y.to_bits()) - i64::from(from.y.to_bits());
    // |Δ| < 2³², so each square fits a u64; their sum saturates (a distance ≥ 2¹⁶ m).
    let sum = dx
        .unsigned_abs()
        .pow(2)
        .saturating_add(dy.unsigned_abs().pow(2));
    Meters::from_bits(sat_i32(i64::try_from(isqrt_round(sum)).unwrap_or(i64::MAX)))
}

/// `Δx² + Δy²` of two Q40 offsets (each below 2⁴⁸) rounded to Q16: raw Q16.16 units squared.
#[inline]
pub(super) fn horizontal_squared(dx: i64, dy: i64) -> u64 {
    // Q40 → Q16, rounded: |Δ| < 2²⁴ (an i32), so each square is < 2⁴⁸ and their sum < 2⁴⁹.
    #[allow(clippy::cast_possible_truncation)]
    let round = |d: i64| ((d + (1 << 23)) >> 24) as i32;
    let (dx, dy) = (round(dx), round(dy));
    wide::square(dx) + wide::square(dy)
}

/// `√(Δx² + Δy²)` of two Q40 offsets (each below 2⁴⁸), as Q16.16 metres.
#[inline]
pub(super) fn horizontal(dx: i64, dy: i64) -> Meters {
    let sum = horizontal_squared(dx, dy);
    // The root of a sum below 2⁴⁹ is below 2²⁵: it fits an i32.
    Meters::from_bits(sat_i32(i64::try_from(isqrt_round(sum)).unwrap_or(i64::MAX)))
}

impl fmt::Debug for LineTransform<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LineTransform")
            .field("variant", &self.beams.variant())
            .field("rows", &self.rows)
            .field("origin", &self.sensor_origin())
            .finish()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for LineTransform<'_> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "LineTransform({}, origin {})",
            self.beams.variant(),
            self.sensor_origin()
        );
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::test_rng::XorShift;
    use crate::wire::sick::Variant;

    const TOL: f64 = 1e-4;

    fn m(x: f64) -> Meters {
        Meters::from_num(x)
    }

    fn f(x: Meters) -> f64 {
        x.to_num::<f64>()
    }

    fn at(x: f64, y: f64, z: f64) -> Point3 {
        Point3 {
            x: m(x),
            y: m(y),
            z: m(z),
        }
    }

    #[track_caller]
    fn close(p: Point3, want: [f64; 3], tol: f64) {
        let got = [f(p.x), f(p.y), f(p.z)];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() <= tol, "{got:?} vs {want:?}");
        }
    }

    fn degrees(d: u32) -> FineAngle {
        FineAngle::from_quarter_degrees(4 * d)
    }

    static T180: BeamTable = BeamTable::new(Variant::Fov180Step1);

    #[test]
    fn panned_beams_point_down_forward_up() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.0, 0.0, 1.0));
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &Pose::IDENTITY);
        close(line.sensor_origin(), [0.0, 0.0, 1.0], 0.0);
        close(line.point(0, 1_000).unwrap(), [0.0, 0.0, 0.0], TOL);
        close(line.point(90, 1_000).unwrap(), [1.0, 0.0, 1.0], TOL);
        close(line.point(180, 1_000).unwrap(), [0.0, 0.0, 2.0], TOL);
        // Range 0 is the scanner's centre.
        assert_eq!(line.point(45, 0), Some(line.sensor_origin()));
    }

    #[test]
    fn tilted_beams_point_right_forward_left() {
        let mount = Mount::new(ScanPlane::TiltedHorizontal, at(0.0, 0.0, 0.5));
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &Pose::IDENTITY);
        close(line.point(0, 2_000).unwrap(), [0.0, -2.0, 0.5], TOL);
        close(line.point(90, 2_000).unwrap(), [2.0, 0.0, 0.5], TOL);
        close(line.point(180, 2_000).unwrap(), [0.0, 2.0, 0.5], TOL);
    }

    #[test]
    fn pan_ninety_turns_forward_into_left() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.0, 0.0, 1.0));
        let line = LineTransform::from_pose(&T180, &mount, degrees(90), &Pose::IDENTITY);
        close(line.point(90, 3_000).unwrap(), [0.0, 3.0, 1.0], TOL);
        // Down and up stay down and up.
        close(line.point(0, 1_000).unwrap(), [0.0, 0.0, 0.0], TOL);
        let line = LineTransform::from_pose(&T180, &mount, degrees(270), &Pose::IDENTITY);
        close(line.point(90, 3_000).unwrap(), [0.0, -3.0, 1.0], TOL);
    }

    #[test]
    fn positive_tilt_looks_down() {
        let mount = Mount::new(ScanPlane::TiltedHorizontal, at(0.0, 0.0, 1.0));
        let line = LineTransform::from_pose(&T180, &mount, degrees(30), &Pose::IDENTITY);
        let p = line.point(90, 2_000).unwrap();
        close(p, [2.0 * 0.866_025_4, 0.0, 1.0 - 1.0], TOL);
        // The sideways beams are on the tilt axis: unchanged.
        close(line.point(0, 2_000).unwrap(), [0.0, -2.0, 1.0], TOL);
        // Negative tilt (a wrapped angle) looks up.
        let up = LineTransform::from_pose(&T180, &mount, degrees(30).reversed(), &Pose::IDENTITY);
        close(up.point(90, 2_000).unwrap(), [1.732_050_8, 0.0, 2.0], TOL);
    }

    #[test]
    fn yaw_ninety_turns_robot_forward_into_world_left() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.5, 0.0, 1.0));
        let pose = Pose {
            x: m(10.0),
            y: m(-4.0),
            z: m(0.25),
            yaw: FineAngle::QUARTER,
            ..Pose::IDENTITY
        };
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &pose);
        close(line.sensor_origin(), [10.0, -3.5, 1.25], 1e-6);
        close(line.point(90, 2_000).unwrap(), [10.0, -1.5, 1.25], TOL);
    }

    #[test]
    fn positive_pitch_puts_the_nose_down_and_roll_raises_the_left() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.0, 0.0, 0.0));
        let pitched = Pose {
            pitch: degrees(30),
            ..Pose::IDENTITY
        };
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &pitched);
        close(
            line.point(90, 2_000).unwrap(),
            [1.732_050_8, 0.0, -1.0],
            TOL,
        );
        let rolled = Pose {
            roll: degrees(30),
            ..Pose::IDENTITY
        };
        let line = LineTransform::from_pose(&T180, &mount, degrees(90), &rolled);
        close(line.point(90, 2_000).unwrap(), [0.0, 1.732_050_8, 1.0], TOL);
    }

    #[test]
    fn horizontal_distance_of_a_slanted_beam() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.3, 0.1, 1.0));
        let pose = Pose::from_f32(3.0, 4.0, 0.0, 0.0, 0.0, 1.0).unwrap();
        let line = LineTransform::from_pose(&T180, &mount, degrees(33), &pose);
        // θ = 45°: the horizontal part of the beam is r·sin 45°, whatever the pan and yaw.
        let lp = line.locate(45, 2_000).unwrap();
        assert!((f(lp.horizontal) - 2.0 * core::f64::consts::FRAC_1_SQRT_2).abs() < TOL);
        assert_eq!(line.horizontal_distance(45, 2_000), Some(lp.horizontal));
        assert_eq!(line.point(45, 2_000), Some(lp.point));
        // Straight down: no horizontal distance.
        assert_eq!(line.horizontal_distance(0, 5_000), Some(Meters::ZERO));
    }

    #[test]
    fn absurd_inputs_saturate_or_are_refused() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.0, 0.0, 0.0));
        let far = Pose {
            x: Meters::MAX,
            y: Meters::MIN,
            z: Meters::MAX,
            ..Pose::IDENTITY
        };
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &far);
        let p = line.point(90, MAX_RANGE_MM).unwrap();
        assert_eq!(p.x, Meters::MAX);
        assert_eq!(p.y, Meters::MIN);
        assert_eq!(line.point(180, MAX_RANGE_MM).unwrap().z, Meters::MAX);
        // Pointing back into range from the edge is not saturated.
        let back = Pose {
            yaw: FineAngle::HALF,
            ..far
        };
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &back);
        let x = f(line.point(90, 100_000).unwrap().x);
        assert!((x - (f(Meters::MAX) - 100.0)).abs() < 0.01, "{x}");
        // Ranges past the limit are refused.
        for r in [MAX_RANGE_MM + 1, 1 << 20, u32::MAX] {
            assert_eq!(line.point(90, r), None);
            assert_eq!(line.locate(90, r), None);
            assert_eq!(line.horizontal_distance(90, r), None);
        }
        // Mount offsets at the extremes of the type, with every orientation octant, do not
        // overflow.
        let extreme = Mount::new(
            ScanPlane::TiltedHorizontal,
            Point3 {
                x: Meters::MIN,
                y: Meters::MAX,
                z: Meters::MIN,
            },
        );
        for bits in (0..8_u32).map(|k| k << 29 | 0x1234_5678) {
            let a = FineAngle::from_bits(bits);
            let pose = Pose {
                roll: a,
                pitch: a.reversed(),
                yaw: a,
                ..far
            };
            let line = LineTransform::from_pose(&T180, &extreme, a, &pose);
            for beam in 0..T180.len() {
                let lp = line.locate(beam, MAX_RANGE_MM).unwrap();
                assert!(lp.horizontal <= m(131.072));
            }
        }
    }

    #[test]
    fn every_out_of_range_beam_is_none() {
        let mount = Mount::new(ScanPlane::PannedVertical, at(0.0, 0.0, 1.0));
        for v in Variant::ALL {
            let table = BeamTable::new(v);
            let line = LineTransform::from_pose(&table, &mount, degrees(10), &Pose::IDENTITY);
            for beam in 0..table.len() {
                assert!(line.locate(beam, 8_000).is_some());
            }
            let past = (table.len()..=crate::wire::sick::MAX_BEAMS + 8).chain([
                1_000,
                65_535,
                usize::MAX / 2,
                usize::MAX,
            ]);
            for beam in past {
                assert_eq!(line.point(beam, 1_000), None);
                assert_eq!(line.locate(beam, 1_000), None);
                assert_eq!(line.horizontal_distance(beam, 1_000), None);
            }
        }
    }

    #[test]
    fn horizontal_distance_between_points() {
        let p = |x: f32, y: f32, z: f32| Point3 {
            x: Meters::from_num(x),
            y: Meters::from_num(y),
            z: Meters::from_num(z),
        };
        assert_eq!(
            horizontal_distance(p(1.0, 1.0, 5.0), p(4.0, 5.0, -2.0)),
            Meters::from_num(5)
        );
        assert_eq!(
            horizontal_distance(p(-30_000.0, -30_000.0, 0.0), p(30_000.0, 30_000.0, 0.0)),
            Meters::MAX
        );
    }

    /// The i64 computation of every point before the 32-bit path: offsets by [`Row::offset`],
    /// saturating world coordinates, the distance's square in `u64`.
    fn locate_squared_i64(
        line: &LineTransform<'_>,
        beam: usize,
        range_mm: u32,
    ) -> Option<LinePointSquared> {
        let offsets = line.offsets(line.beams.get(beam)?, range_mm)?;
        let [dx, dy, _] = offsets;
        let q16 = |d: i64| (d + (1 << 23)) >> 24;
        Some(LinePointSquared {
            point: line.world(offsets),
            horizontal_squared: q16(dx).unsigned_abs().pow(2) + q16(dy).unsigned_abs().pow(2),
        })
    }

    #[test]
    fn per_mm_in_words_is_per_mm() {
        let mut x = XorShift(0x0DDB_A11C_AFE0_0001_u64);
        let mut values: std::vec::Vec<i64> = (-(1_i64 << 30) - 70_000..=-(1_i64 << 30) + 70_000)
            .chain((1_i64 << 30) - 70_000..=(1_i64 << 30) + 70_000)
            .chain(-70_000..=70_000)
            .collect();
        values.extend([i64::MIN, i64::MAX, 1 << 40, -(1 << 40)]);
        for _ in 0..1_000_000 {
            #[allow(clippy::cast_possible_wrap)]
            let v = (x.next() as i64) >> (33 + x.next() % 30);
            values.push(v);
        }
        for v in values {
            assert_eq!(per_mm_words(v), per_mm(v), "{v}");
        }
    }

    #[test]
    fn direction_per_mm_in_32_bit_words_is_the_i64_one() {
        let mut x = XorShift(0x2545_F491_4F6C_DD1D_u64);
        let mut rows = std::vec![
            Row::from_q30(1 << 30, 1 << 30),
            Row::from_q30(-(1 << 30), -(1 << 30)),
            Row::from_q30(1 << 30, -(1 << 30)),
            Row::from_q30(0, 0),
        ];
        for _ in 0..400 {
            let v = x.next();
            #[allow(clippy::cast_possible_truncation)]
            let (c, s) = (i64::from(v as i32 >> 1), i64::from((v >> 32) as i32 >> 1));
            rows.push(Row::from_q30(c, s));
        }
        for v in Variant::ALL {
            let table = BeamTable::new(v);
            for beam in 0..table.len() {
                let (c, s) = table.get(beam).unwrap().to_bits();
                for row in &rows {
                    let (c, s) = (i32::from(c), i32::from(s));
                    let want = sat_i32(
                        (i64::from(row.c) * i64::from(c)
                            + i64::from(row.s) * i64::from(s)
                            + (1 << 14))
                            >> 15,
                    );
                    assert_eq!(row.per_mm_dir(c, s), want, "{row:?} {c} {s}");
                    // And the whole offset.
                    assert_eq!(
                        wide::smul_u17(row.per_mm_dir(c, s), 131_071),
                        row.offset(i64::from(c), i64::from(s), 131_071)
                    );
                }
            }
        }
        for k in [
            0,
            1,
            -1,
            0x7FFF,
            0x8000,
            -0x8000,
            -0x8001,
            1 << 30,
            -(1 << 30),
            i32::MAX - 0x8000,
            i32::MIN,
        ] {
            let (hi, lo) = split_q16(k);
            assert!((-(1 << 15)..(1 << 15)).contains(&lo));
            assert_eq!(i64::from(hi) * 65_536 + i64::from(lo), i64::from(k));
        }
    }

    #[test]
    fn unsaturated_lines_give_the_i64_bits() {
        let mut x = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let mut fast = 0;
        for i in 0..300_u32 {
            let v = x.next();
            #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
            let angle = |k: u32| FineAngle::from_bits((v >> (k * 8)) as u32);
            // Positions of every magnitude, up to and past the unsaturated limit.
            let scale = f32::from(u16::try_from(i % 18).unwrap());
            let pos = |k: u32| {
                #[allow(clippy::cast_precision_loss)]
                let unit = ((v >> (k * 7)) & 0xFFFF) as f32 / 32_768.0 - 1.0;
                unit * 2.0_f32.powf(scale - 1.0)
            };
            let pose = Pose {
                x: Meters::saturating_from_num(pos(1)),
                y: Meters::saturating_from_num(pos(2)),
                z: Meters::saturating_from_num(pos(3)),
                roll: angle(0),
                pitch: angle(1),
                yaw: angle(2),
            };
            let plane = if i % 2 == 0 {
                ScanPlane::PannedVertical
            } else {
                ScanPlane::TiltedHorizontal
            };
            let mount = Mount::new(plane, at(0.4, -0.1, 0.9));
            let table = BeamTable::new(Variant::ALL[(i as usize) % Variant::ALL.len()]);
            let line = LineTransform::from_pose(&table, &mount, angle(3), &pose);
            fast += u32::from(line.unsaturated);
            for beam in 0..table.len() {
                let w = x.next();
                #[allow(clippy::cast_possible_truncation)]
                let range = (w as u32) >> (15 + (w >> 40) % 17);
                for r in [range, range.min(MAX_RANGE_MM), MAX_RANGE_MM, 0] {
                    assert_eq!(
                        line.locate_squared(beam, r),
                        locate_squared_i64(&line, beam, r),
                        "{pose:?} {beam} {r}"
                    );
                }
            }
        }
        // Both paths were taken.
        assert!(fast > 100 && fast < 300, "{fast}");
        // The limit itself.
        let edge = Pose {
            x: Meters::from_num(32_255.5),
            ..Pose::IDENTITY
        };
        let mount = Mount::new(ScanPlane::TiltedHorizontal, at(0.0, 0.0, 0.0));
        let line = LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &edge);
        assert!(line.unsaturated);
        let past = Pose {
            x: Meters::from_num(32_256.5),
            ..Pose::IDENTITY
        };
        assert!(!LineTransform::from_pose(&T180, &mount, FineAngle::ZERO, &past).unsaturated);
        for beam in 0..T180.len() {
            assert_eq!(
                line.locate_squared(beam, MAX_RANGE_MM),
                locate_squared_i64(&line, beam, MAX_RANGE_MM)
            );
        }
    }

    /// The restoring method on `u64` throughout: the reference of the 32-bit fast path.
    fn isqrt_round_u64(x: u64) -> u64 {
        if x == 0 {
            return 0;
        }
        let mut bit: u64 = 1 << ((63 - x.leading_zeros()) & !1);
        let (mut rem, mut root) = (x, 0_u64);
        while bit != 0 {
            let trial = root + bit;
            if rem >= trial {
                rem -= trial;
                root = (root >> 1) + bit;
            } else {
                root >>= 1;
            }
            bit >>= 2;
        }
        root + u64::from(rem > root)
    }

    #[test]
    fn isqrt_fast_path_matches_the_u64_method() {
        let mut x = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        for i in 0..200_000_u64 {
            // Every magnitude below 2⁵⁰, and the edges around squares and half-squares.
            let v = x.next() >> (14 + i % 50);
            for y in [v, v.saturating_sub(1), v + 1] {
                assert_eq!(isqrt_round(y), isqrt_round_u64(y), "{y}");
            }
            let r = (v >> 25) | 1;
            for y in [r * r - 1, r * r, r * r + r, r * r + r + 1] {
                assert_eq!(isqrt_round(y), isqrt_round_u64(y), "{y}");
            }
        }
        for y in [
            (1_u64 << 50) - 1,
            1 << 50,
            (1 << 32) - 1,
            1 << 32,
            (1 << 32) + 1,
        ] {
            assert_eq!(isqrt_round(y), isqrt_round_u64(y), "{y}");
        }
    }

    #[test]
    fn isqrt_rounds_to_nearest() {
        for x in 0..100_000_u64 {
            let r = isqrt_round(x);
            // r is the nearest integer: (r − ½)² ≤ x < (r + ½)², i.e. 4x in [(2r−1)², (2r+1)²).
            assert!((2 * r).saturating_sub(1).pow(2) <= 4 * x, "{x}");
            assert!(4 * x < (2 * r + 1).pow(2), "{x}");
        }
        for x in [
            1_u64 << 49,
            (1 << 49) - 1,
            u64::MAX,
            u64::MAX - 1,
            1 << 62,
            3 << 62,
        ] {
            let r = u128::from(isqrt_round(x));
            let x = u128::from(x);
            assert!(
                (2 * r - 1).pow(2) <= 4 * x && 4 * x < (2 * r + 1).pow(2),
                "{x}"
            );
        }
    }
}

#[cfg(test)]
mod golden {
    use super::*;
    use crate::wire::sick::Variant;

    /// A checksum of every point and distance of one line per variant and mount: the
    /// integer pipeline must give these bits on every target (the host and the Cortex-M
    /// builds run the same integer code; this checksum was reproduced in QEMU on a Cortex-M0
    /// (`microbit`, thumbv6m) and a Cortex-M4F (`mps2-an386`, thumbv7em). A change here is a
    /// change of the maths.
    #[test]
    fn bits_are_pinned() {
        let pose = Pose::from_f32(123.456, -78.9, 1.25, 0.1, -0.2, 2.9).unwrap();
        let frame = pose.frame();
        let mut sum: u64 = 0;
        for v in Variant::ALL {
            let table = BeamTable::new(v);
            for plane in [ScanPlane::PannedVertical, ScanPlane::TiltedHorizontal] {
                let mount = Mount::new(
                    plane,
                    Point3 {
                        x: Meters::from_num(0.4),
                        y: Meters::from_num(-0.1),
                        z: Meters::from_num(0.9),
                    },
                );
                let line =
                    LineTransform::new(&table, &mount, FineAngle::from_bits(0x1234_5678), &frame);
                for beam in 0..table.len() {
                    let range = (beam as u32 * 7_919) % 81_911;
                    let lp = line.locate(beam, range).unwrap();
                    for bits in [lp.point.x, lp.point.y, lp.point.z, lp.horizontal]
                        .map(|m| u64::from(m.to_bits() as u32))
                    {
                        sum = sum.wrapping_mul(1_000_003).wrapping_add(bits);
                    }
                }
            }
        }
        assert_eq!(sum, 3_725_009_530_582_713_458);
    }
}
