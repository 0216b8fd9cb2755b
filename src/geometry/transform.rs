//! The per-line transform: from (beam index, range in mm) to a world point and its horizontal
//! distance from the scanner, in integer arithmetic.
//!
//! # Formats
//! [`LineTransform::new`] folds the robot's rotation, the actuator's rotation and the scan
//! plane into one 3 × 2 matrix `M` (world direction = `M·(cos θ, sin θ)`), and pre-scales it so
//! that ranges in millimetres and the beam table's Q1.15 directions need no division: each
//! entry is stored as `K = round(M_ij · 2³³ / 1 000)`, metres Q48 per mm per Q1.15 unit
//! (|K| ≤ 8 589 935 < 2²³·⁰²). The scanner's world position O is kept in Q24.40 (`i64`). Per
//! point, with (c, s) the beam's Q1.15 direction and r the range in mm:
//!
//! ```text
//! D_i = K_ic·(r·c) + K_is·(r·s)                offset from the scanner, metres Q48 (< 2⁵⁶·¹)
//! p_i = sat_i32(⌊(O_i·2⁸ + 2³¹ + D_i) / 2³²⌋)    world coordinate, Q16.16, rounded once
//! õ_i = round(O_i / 2²⁴)                        the scanner's centre, Q16.16
//! d   = round(√((p_x − õ_x)² + (p_y − õ_y)²))   horizontal distance, Q16.16
//! ```
//!
//! No division, no float, no trigonometry. [`LineTransform::locate_squared`], the per-point
//! path, computes these bits in 32-bit words on a line whose origin is within 32 256 m and
//! for a range below 2¹⁶ mm (65.536 m; others take the `i64` path, same bits): the origin is
//! kept as the 64-bit sum `O·2⁸ + 2³¹`, and a coordinate is the high word of that sum plus two
//! 32 × 32 → 64 products (`r·c` and `r·s` fit an `i32`). On a Cortex-M4 that is two `smlal`
//! per axis after the two `muls` shared by the three axes; the distance's square is the
//! offsets' two squares (`smull`, `smlal`). A Cortex-M0 has no 64-bit product: it splits the
//! entries into 16-bit halves and gets the same quotient from seven 32 × 32 → 32 `muls` per
//! axis (`Row::coordinate_halves`), with no `__aeabi_lmul` call. Measured in the bench
//! firmware's profile on the full stairs recording (BENCHMARKS.md, "The seventh pass"), from
//! `locate_squared` to the squares: about 39 instructions per point on the M4F and 156 on the
//! M0. The other entry points ([`LineTransform::locate`], [`LineTransform::point`]) take
//! the `i64` path. The horizontal distance of [`LineTransform::locate`] adds a bit-by-bit
//! integer square root (one iteration per result bit: about 19 at 8 m, 23 at 80 m).
//!
//! # Error
//! Against the exact geometry of the same inputs (range, beam angle, actuator angle, pose):
//! - the beam table's Q1.15 rounding: at most 2⁻¹⁵ · r ≈ 3.05·10⁻⁵ · r (a direction error
//!   of ≤ √2·2⁻¹⁶ in general, up to 2⁻¹⁵ where a component saturates near 1, see
//!   [`super::beams`]);
//! - the matrix (sines, cosines and products in Q2.30, the entries rounded to 2⁻³³ m per mm
//!   per Q1.15 unit, 5.8·10⁻⁸ of a unit component): below 1.7·10⁻⁷ · r;
//! - the one rounding of each coordinate to Q16.16 (2⁻¹⁷ m per axis), that of the pose's
//!   position through [`Pose::from_f32`] (2⁻¹⁷ m per axis), and the mount offset rotated in
//!   Q2.30: below 0.03 mm together. The horizontal offsets are taken between the rounded point
//!   and the rounded centre (the pose's position cancels): at most 2⁻¹⁶ m per axis.
//!
//! So a world point is within **0.03 mm + 3.1·10⁻⁵ · r** of the exact one (0.28 mm at 8 m,
//! 0.96 mm at 30 m, 2.6 mm at 81.91 m), and so is the horizontal distance (its square root is
//! correctly rounded to 2⁻¹⁶ m). `host-tests` holds the library to this bound against an f64
//! reference, and `cargo run --release -p terrain-pyramid-host-tests --example
//! geometry_error` measures the actual figures. Coordinates beyond ±32 768 m saturate.

use core::fmt;

use super::beams::{BeamDir, BeamTable};
use super::fixed::{point_q40, root_meters, sat_i32};
pub use super::fixed::{LinePoint, LinePointSquared, MAX_RANGE_MM};
use super::mount::Mount;
use super::pose::{Pose, PoseFrame};
use super::sweep::SweepTransform;
use crate::angle::FineAngle;
use crate::units::{Meters, Point3};
use crate::wide;

/// One row of the direction matrix in the per-point form: the world-axis component that
/// multiplies cos θ (`c`) and sin θ (`s`), as metres Q48 per millimetre of range per Q1.15
/// unit of the beam's direction: `K = M_ij · 2³³ / 1 000`, rounded ([`k_entry`];
/// |K| ≤ 8 589 935 < 2²³·⁰²). Each is also split as `K = hi·2¹⁶ + lo` with `lo` in
/// −2¹⁵ ..< 2¹⁵ for [`Row::coordinate_halves`].
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
/// entries are below 2²³·⁰²).
fn split_q16(k: i32) -> (i32, i32) {
    let lo = (k.wrapping_add(1 << 15) & 0xFFFF) - (1 << 15);
    (k.wrapping_sub(lo) >> 16, lo)
}

/// `round(2³⁸ / 125)`: turns a Q2.30 unit component into a [`Row`] entry (`2³³/1 000/2³⁰`
/// = 1/125) with one product and a shift.
const Q30_TO_ROW: u32 = 2_199_023_256;

/// A Q2.30 unit component (clamped to ±2³⁰: rounding can pass 1 by a few LSBs) as a [`Row`]
/// entry: `round(q30 / 125)` = `⌊(q30 · Q30_TO_ROW + 2³⁷) / 2³⁸⌋`, exactly (the factor's
/// rounding moves the quotient by less than 0.002, and no quotient lies within 0.004 of a
/// half). |result| ≤ 8 589 935.
fn k_entry(q30: i64) -> i32 {
    // |unit| ≤ 2³⁰ fits an i32; the product is below 2⁶¹·⁰³.
    #[allow(clippy::cast_possible_truncation)]
    let unit = q30.clamp(-(1 << 30), 1 << 30) as i32;
    sat_i32((wide::smul_u32(unit, Q30_TO_ROW) + (1 << 37)) >> 38)
}

impl Row {
    /// The row from two Q2.30 components.
    fn from_q30(c: i64, s: i64) -> Self {
        let (c, s) = (k_entry(c), k_entry(s));
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

    /// `D = K_c·(r·c) + K_s·(r·s)`: the offset along this axis of the beam direction (c, s)
    /// (Q1.15) at `range_mm` (at most [`MAX_RANGE_MM`]), metres Q48, exactly: each product
    /// is below 2²³·⁰²·2³², the sum below 2⁵⁶·¹.
    #[inline]
    fn offset_q48(self, c: i64, s: i64, range_mm: i64) -> i64 {
        i64::from(self.c) * (range_mm * c) + i64::from(self.s) * (range_mm * s)
    }

    /// `⌊(acc + D) / 2³²⌋` with `D` as [`Row::offset_q48`], from `rc = r·c` and `rs = r·s`
    /// (a range below 2¹⁶ mm, so each fits an `i32`): two `smlal` on ARMv7-M. `acc` is the
    /// origin in Q48 plus the rounding half ([`LineTransform::origin_sum`]); the caller
    /// guarantees that the quotient fits an `i32` (an unsaturated line).
    #[inline]
    fn coordinate_words(&self, acc: i64, rc: i32, rs: i32) -> i32 {
        let sum = acc
            .wrapping_add(i64::from(self.c) * i64::from(rc))
            .wrapping_add(i64::from(self.s) * i64::from(rs));
        // The caller's bound: the quotient fits.
        #[allow(clippy::cast_possible_truncation)]
        let coordinate = (sum >> 32) as i32;
        coordinate
    }

    /// [`Row::coordinate_words`] with 32 × 32 → 32 products only (ARMv6-M), from the beam
    /// direction (c, s) and the range `r` below 2¹⁶ mm; exactly the same value.
    ///
    /// `U = K_c·c + K_s·s = A·2¹⁶ + B` (A from the entries' high parts, |A| < 2²²·²; B from
    /// the low ones, |B| < 2³⁰·⁶), regrouped as `U = H_hi·2³² + H_lo·2¹⁶ + B_lo` with
    /// `H = A + (B >> 16)`. Then `r·U = r·H_hi·2³² + r·H_lo·2¹⁶ + r·B_lo`, where the last two
    /// products are below 2³², and with `acc = acc_hi·2³² + acc_lo`:
    /// `⌊(acc + r·U) / 2³²⌋ = acc_hi + r·H_hi + ⌊(acc_lo + r·H_lo·2¹⁶ + r·B_lo) / 2³²⌋`, the
    /// last term summed in 16-bit steps without overflow. Seven `muls`.
    #[inline]
    fn coordinate_halves(&self, acc: i64, c: i32, s: i32, range_mm: u32) -> i32 {
        let a = self
            .c_hi
            .wrapping_mul(c)
            .wrapping_add(self.s_hi.wrapping_mul(s));
        let b = self
            .c_lo
            .wrapping_mul(c)
            .wrapping_add(self.s_lo.wrapping_mul(s));
        let h = a.wrapping_add(b >> 16);
        // Masked to 16 bits: non-negative.
        #[allow(clippy::cast_sign_loss)]
        let (b_lo, h_lo) = ((b & 0xFFFF) as u32, (h & 0xFFFF) as u32);
        // Both factors below 2¹⁶: each product below 2³².
        let (low, mid) = (range_mm.wrapping_mul(b_lo), range_mm.wrapping_mul(h_lo));
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (acc_hi, acc_lo) = ((acc >> 32) as i32, acc as u32);
        // (acc_lo mod 2¹⁶) + low ≤ 2³² − 2¹⁶; then (… >> 16) + mid + (acc_lo >> 16) ≤ 2³² − 1.
        let carry = ((acc_lo & 0xFFFF).wrapping_add(low) >> 16)
            .wrapping_add(mid)
            .wrapping_add(acc_lo >> 16)
            >> 16;
        // r < 2¹⁶ fits an i32; carry < 2¹⁶.
        #[allow(clippy::cast_possible_wrap)]
        let (r, carry) = (range_mm as i32, carry as i32);
        acc_hi
            .wrapping_add(r.wrapping_mul(h >> 16))
            .wrapping_add(carry)
    }
}

/// The geometry of one scan line: built once per line from the beam table, the mount, the
/// actuator angle and the robot's pose; then [`LineTransform::point`] places each return.
///
/// See the [module documentation](self) for the formats, the cost and the error.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct LineTransform<'a> {
    beams: &'a BeamTable,
    /// The direction matrix per mm per Q1.15 unit, rows x, y, z.
    rows: [Row; 3],
    /// The scanner's centre in the world, metres Q40.
    origin: [i64; 3],
    /// The origin in Q48 plus the rounding half, `O·2⁸ + 2³¹` for the Q40 origin O: a
    /// point's coordinate is `⌊(origin_sum + D) / 2³²⌋`. Meaningful only on an
    /// [`unsaturated`](Self::unsaturated) line.
    origin_sum: [i64; 3],
    /// The scanner's centre rounded to Q16.16, raw, x and y (on an unsaturated line; the
    /// horizontal offsets are taken from it).
    centre: [i32; 2],
    /// Every |origin| ≤ 2⁵⁵ − 2⁴⁹ (within 32 256 m): no point of this line closer than
    /// 2¹⁶ mm can saturate, and [`LineTransform::locate_squared`] takes the 32-bit path.
    unsaturated: bool,
}

/// The largest |origin| (Q40) of a [`LineTransform::unsaturated`] line: 2⁵⁵ − 2⁴⁹
/// (32 256 m), so `⌊O/2²⁴⌋` is within ±(2³¹ − 2²⁵). An offset at a range below 2¹⁶ mm is
/// below 2²²·⁶ raw Q16.16 units, so every coordinate of the 32-bit path, and its `i64` sum
/// before the shift, fits.
const UNSATURATED_ORIGIN: i64 = (1 << 55) - (1 << 49);

/// The 32-bit path's ranges are below this, millimetres (65.536 m): `r·c` then fits an
/// `i32`, and the ARMv6-M form's 16 × 16 products stay below 2³².
const WORDS_RANGE_MM: u32 = 1 << 16;

/// A point placed by the general path: its coordinates and its offsets from the scanner's
/// rounded centre, raw Q16.16, not yet saturated.
#[derive(Clone, Copy)]
struct Placed {
    point: [i64; 3],
    dx: i64,
    dy: i64,
}

impl Placed {
    /// The point, saturated at ±32 768 m.
    fn world(&self) -> Point3 {
        let [x, y, z] = self.point.map(|v| Meters::from_bits(sat_i32(v)));
        Point3 { x, y, z }
    }

    /// `Δx² + Δy²`, raw units squared (each |Δ| < 2²⁴, so the sum is below 2⁴⁹).
    fn horizontal_squared(&self) -> u64 {
        self.dx
            .unsigned_abs()
            .saturating_mul(self.dx.unsigned_abs())
            .saturating_add(
                self.dy
                    .unsigned_abs()
                    .saturating_mul(self.dy.unsigned_abs()),
            )
    }

    /// `√(Δx² + Δy²)`, rounded.
    fn horizontal(&self) -> Meters {
        root_meters(self.horizontal_squared())
    }
}

impl<'a> LineTransform<'a> {
    /// The transform of one line: `beams` for the scanner's variant, `mount` for how it sits
    /// (any [`Mount`]: a SICK's own frame has x its centre beam, 90°, and z its top),
    /// `actuator` the reported actuator angle at this line (the mount's zero and sense
    /// applied), `frame` the robot's pose ([`Pose::frame`], computed once per pose change).
    ///
    /// Costs one [`FineAngle::sin_cos`] and about sixty 64-bit multiplies
    /// ([`SweepTransform::new`] and [`SweepTransform::at`]).
    #[must_use]
    pub fn new(
        beams: &'a BeamTable,
        mount: &Mount,
        actuator: FineAngle,
        frame: &PoseFrame,
    ) -> Self {
        // The world directions that multiply cos θ and sin θ at this actuator angle, and the
        // scanner's centre, as a spinning lidar's return gets them: of a preset mount, the
        // bits of the fixed mounts' matrix (C an exact column, S rounded once).
        let (c, s, origin) = SweepTransform::new(mount, frame).at(actuator).parts();
        let row = |i: usize| {
            let pick = |v: [i32; 3]| i64::from(v.get(i).copied().unwrap_or(0));
            Row::from_q30(pick(c), pick(s))
        };
        let rows = [row(0), row(1), row(2)];
        let unsaturated = origin
            .iter()
            .all(|o| o.unsigned_abs() <= UNSATURATED_ORIGIN.unsigned_abs());
        // O·2⁸ + 2³¹, wrapping: the sums matter only on an unsaturated line, where they fit.
        let origin_sum = origin.map(|o| (o << 8).wrapping_add(1 << 31));
        let [cx, cy, _] = origin.map(|o| sat_i32(centre_q16(o)));
        Self {
            beams,
            rows,
            origin,
            origin_sum,
            centre: [cx, cy],
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
        point_q40(self.origin)
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
    /// together (computing the point once).
    #[must_use]
    pub fn locate(&self, beam_index: usize, range_mm: u32) -> Option<LinePoint> {
        self.locate_at(self.beams.get(beam_index)?, range_mm)
    }

    /// The horizontal distance `√(Δx² + Δy²)` from the scanner's centre to the point of beam
    /// `beam_index` at `range_mm`, metres (both rounded to Q16.16 first); `None` as for
    /// [`LineTransform::point`].
    #[must_use]
    pub fn horizontal_distance(&self, beam_index: usize, range_mm: u32) -> Option<Meters> {
        let dir = self.beams.get(beam_index)?;
        Some(self.place(dir, range_mm)?.horizontal())
    }

    /// [`LineTransform::point`] for a beam direction of the caller's (e.g. from another
    /// table); `None` when the range exceeds [`MAX_RANGE_MM`].
    #[must_use]
    pub fn point_at(&self, dir: BeamDir, range_mm: u32) -> Option<Point3> {
        Some(self.place(dir, range_mm)?.world())
    }

    /// [`LineTransform::locate`] for a beam direction of the caller's; `None` when the range
    /// exceeds [`MAX_RANGE_MM`].
    #[must_use]
    pub fn locate_at(&self, dir: BeamDir, range_mm: u32) -> Option<LinePoint> {
        let placed = self.place(dir, range_mm)?;
        Some(LinePoint {
            point: placed.world(),
            horizontal: placed.horizontal(),
        })
    }

    /// [`LineTransform::locate`] without the square root: the world point of beam
    /// `beam_index` at `range_mm` and the square of its horizontal distance; `None` as for
    /// [`LineTransform::point`].
    #[must_use]
    #[inline]
    pub fn locate_squared(&self, beam_index: usize, range_mm: u32) -> Option<LinePointSquared> {
        let dir = self.beams.get(beam_index)?;
        if self.unsaturated && range_mm < WORDS_RANGE_MM {
            return Some(self.locate_squared_words(dir, range_mm));
        }
        let placed = self.place(dir, range_mm)?;
        Some(LinePointSquared {
            point: placed.world(),
            horizontal_squared: placed.horizontal_squared(),
        })
    }

    /// [`LineTransform::locate_squared`] of an unsaturated line for a range below 2¹⁶ mm: the
    /// same bits as [`LineTransform::place`], in 32-bit words. Per axis two `smlal` into the
    /// origin's sum on ARMv7-M ([`Row::coordinate_words`]), seven `muls` on ARMv6-M
    /// ([`Row::coordinate_halves`]); then the offsets from the rounded centre and their
    /// squares.
    #[inline]
    fn locate_squared_words(&self, dir: BeamDir, range_mm: u32) -> LinePointSquared {
        let (c, s) = dir.to_bits();
        let (c, s) = (i32::from(c), i32::from(s));
        // By reference and axis by axis: the entries are read where they are, not copied.
        let [rx, ry, rz] = &self.rows;
        let [ax, ay, az] = self.origin_sum;
        let (x, y, z) = if wide::HALVES {
            (
                rx.coordinate_halves(ax, c, s, range_mm),
                ry.coordinate_halves(ay, c, s, range_mm),
                rz.coordinate_halves(az, c, s, range_mm),
            )
        } else {
            // range_mm < 2¹⁶ fits an i32, and |r·c|, |r·s| < 2³¹.
            #[allow(clippy::cast_possible_wrap)]
            let r = range_mm as i32;
            let (rc, rs) = (r.wrapping_mul(c), r.wrapping_mul(s));
            (
                rx.coordinate_words(ax, rc, rs),
                ry.coordinate_words(ay, rc, rs),
                rz.coordinate_words(az, rc, rs),
            )
        };
        let [cx, cy] = self.centre;
        LinePointSquared {
            point: Point3 {
                x: Meters::from_bits(x),
                y: Meters::from_bits(y),
                z: Meters::from_bits(z),
            },
            horizontal_squared: wide::square(x.wrapping_sub(cx)) + wide::square(y.wrapping_sub(cy)),
        }
    }

    /// The general path: the point `p_i = ⌊O_i/2²⁴⌋ + ⌊((O_i mod 2²⁴)·2⁸ + 2³¹ + D_i) / 2³²⌋`
    /// (`D_i` by [`Row::offset_q48`]; the same value as the 32-bit path's
    /// `⌊(origin_sum + D) / 2³²⌋`) and its offsets from the rounded centre, in `i64`; `None`
    /// past [`MAX_RANGE_MM`].
    fn place(&self, dir: BeamDir, range_mm: u32) -> Option<Placed> {
        if range_mm > MAX_RANGE_MM {
            return None;
        }
        let (c, s) = dir.to_bits();
        let (c, s, r) = (i64::from(c), i64::from(s), i64::from(range_mm));
        let coordinate = |row: Row, o: i64| {
            // |O| < 2⁵⁷; the remainder's term is below 2³², D below 2⁵⁶·¹.
            (o >> 24) + ((((o & 0xFF_FFFF) << 8) + (1 << 31) + row.offset_q48(c, s, r)) >> 32)
        };
        let [rx, ry, rz] = self.rows;
        let [ox, oy, oz] = self.origin;
        let point = [coordinate(rx, ox), coordinate(ry, oy), coordinate(rz, oz)];
        let [x, y, _] = point;
        Some(Placed {
            point,
            dx: x - centre_q16(ox),
            dy: y - centre_q16(oy),
        })
    }
}

/// A Q40 origin coordinate rounded to Q16.16, raw, unsaturated (|O| < 2⁵⁷).
#[inline]
fn centre_q16(origin: i64) -> i64 {
    (origin + (1 << 23)) >> 24
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
    root_meters(sum)
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
    use crate::geometry::fixed::{isqrt_round, per_mm, per_mm_words};
    use crate::geometry::ScanPlane;
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

    /// Every point of the per-point formula in `i128`, written from the module
    /// documentation: `p_i = ⌊(O_i·2⁸ + 2³¹ + K_ic·r·c + K_is·r·s) / 2³²⌋` saturated, the
    /// offsets from the centre `round(O/2²⁴)`, and their squares.
    fn locate_squared_i128(
        line: &LineTransform<'_>,
        beam: usize,
        range_mm: u32,
    ) -> Option<LinePointSquared> {
        if range_mm > MAX_RANGE_MM {
            return None;
        }
        let (c, s) = line.beams.get(beam)?.to_bits();
        let (c, s, r) = (i128::from(c), i128::from(s), i128::from(range_mm));
        let p: std::vec::Vec<i128> = line
            .rows
            .iter()
            .zip(line.origin)
            .map(|(row, o)| {
                (i128::from(o) * 256
                    + (1 << 31)
                    + i128::from(row.c) * r * c
                    + i128::from(row.s) * r * s)
                    >> 32
            })
            .collect();
        let centre = |o: i64| (i128::from(o) + (1 << 23)) >> 24;
        let (dx, dy) = (p[0] - centre(line.origin[0]), p[1] - centre(line.origin[1]));
        let sat = |v: i128| {
            Meters::from_bits(i32::try_from(v).unwrap_or(if v < 0 { i32::MIN } else { i32::MAX }))
        };
        Some(LinePointSquared {
            point: Point3 {
                x: sat(p[0]),
                y: sat(p[1]),
                z: sat(p[2]),
            },
            horizontal_squared: u64::try_from(dx * dx + dy * dy).unwrap(),
        })
    }

    /// Q2.30 components to test a conversion on: every value within `near` of ±1 and of 0,
    /// the extremes of `i64` and ±2⁴⁰, and a million random ones of every magnitude.
    fn q30_cases(seed: u64, near: i64) -> std::vec::Vec<i64> {
        let mut x = XorShift(seed);
        let mut values: std::vec::Vec<i64> = (-(1_i64 << 30) - near..=-(1_i64 << 30) + near)
            .chain((1_i64 << 30) - near..=(1_i64 << 30) + near)
            .chain(-near..=near)
            .collect();
        values.extend([i64::MIN, i64::MAX, 1 << 40, -(1 << 40)]);
        for _ in 0..1_000_000 {
            #[allow(clippy::cast_possible_wrap)]
            let v = (x.next() as i64) >> (33 + x.next() % 30);
            values.push(v);
        }
        values
    }

    #[test]
    fn per_mm_in_words_is_per_mm() {
        for v in q30_cases(0x0DDB_A11C_AFE0_0001, 70_000) {
            assert_eq!(per_mm_words(v), per_mm(v), "{v}");
        }
    }

    /// `round(q30 / 125)` by a division, halves away from zero (no quotient is a half).
    fn k_entry_by_division(q30: i64) -> i32 {
        let unit = q30.clamp(-(1 << 30), 1 << 30);
        let rounded = (2 * unit.abs() + 125) / 250;
        i32::try_from(if unit < 0 { -rounded } else { rounded }).unwrap()
    }

    #[test]
    fn row_entries_are_the_rounded_quotient() {
        for v in q30_cases(0x51A7_E0F1_0A75_0003, 100_000) {
            assert_eq!(k_entry(v), k_entry_by_division(v), "{v}");
        }
        assert_eq!(k_entry(1 << 30), 8_589_935);
        assert_eq!(k_entry(-(1 << 30)), -8_589_935);
        // Near a half: 62/125 rounds down, 63/125 up.
        assert_eq!(k_entry(125 * 1_000 + 62), 1_000);
        assert_eq!(k_entry(125 * 1_000 + 63), 1_001);
        assert_eq!(k_entry(-(125 * 1_000 + 63)), -1_001);
    }

    #[test]
    fn the_armv6m_coordinate_is_the_armv7m_one() {
        let mut x = XorShift(0x2545_F491_4F6C_DD1D_u64);
        let mut rows = std::vec![
            Row::from_q30(1 << 30, 1 << 30),
            Row::from_q30(-(1 << 30), -(1 << 30)),
            Row::from_q30(1 << 30, -(1 << 30)),
            Row::from_q30(-(1 << 30), 1 << 30),
            Row::from_q30(0, 0),
        ];
        for _ in 0..200 {
            let v = x.next();
            #[allow(clippy::cast_possible_truncation)]
            let (c, s) = (i64::from(v as i32 >> 1), i64::from((v >> 32) as i32 >> 1));
            rows.push(Row::from_q30(c, s));
        }
        // Sums of every origin up to the unsaturated bound, either sign, every remainder.
        let limit = (UNSATURATED_ORIGIN >> 24) as i32;
        let mut sums = std::vec![];
        for _ in 0..24 {
            let v = x.next();
            #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
            let q = ((v as i32) % limit) >> (v >> 59);
            let rem = i64::try_from((v >> 32) & 0xFF_FFFF).unwrap();
            sums.push((i64::from(q) << 32) + (rem << 8) + (1 << 31));
        }
        for q in [limit, -limit, 0, -1] {
            for rem in [0, 0xFF_FFFF] {
                sums.push((i64::from(q) << 32) + (rem << 8) + (1 << 31));
            }
        }
        let mut checked = 0_u64;
        for v in Variant::ALL {
            let table = BeamTable::new(v);
            for beam in 0..table.len() {
                let (c, s) = table.get(beam).unwrap().to_bits();
                let (c, s) = (i32::from(c), i32::from(s));
                for row in &rows {
                    let w = x.next();
                    let acc = sums[(w % sums.len() as u64) as usize];
                    #[allow(clippy::cast_possible_truncation)]
                    let random = ((w >> 20) as u32) >> (16 + (w >> 58) % 16);
                    for r in [random, 0, 1, 0xFFFF, 0x8000] {
                        let (ri, want) = (i32::try_from(r).unwrap(), {
                            let d = i128::from(row.c) * i128::from(r) * i128::from(c)
                                + i128::from(row.s) * i128::from(r) * i128::from(s);
                            i32::try_from((i128::from(acc) + d) >> 32).unwrap()
                        });
                        assert_eq!(
                            row.coordinate_words(acc, ri * c, ri * s),
                            want,
                            "{row:?} {c} {s} {r} {acc}"
                        );
                        assert_eq!(
                            row.coordinate_halves(acc, c, s, r),
                            want,
                            "{row:?} {c} {s} {r} {acc}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 500_000, "{checked}");
        // The extreme directions of a Q1.15 table with the extreme entries.
        for row in &rows[..4] {
            for (c, s) in [
                (32_767, 0),
                (-32_768, 0),
                (0, 32_767),
                (23_170, 23_170),
                (-23_170, -23_171),
            ] {
                for acc in [sums[sums.len() - 8], sums[sums.len() - 6]] {
                    let d = i128::from(row.c) * 65_535 * i128::from(c)
                        + i128::from(row.s) * 65_535 * i128::from(s);
                    let want = i32::try_from((i128::from(acc) + d) >> 32).unwrap();
                    assert_eq!(row.coordinate_words(acc, 65_535 * c, 65_535 * s), want);
                    assert_eq!(row.coordinate_halves(acc, c, s, 65_535), want);
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
            8_589_935,
            -8_589_935,
            i32::MAX - 0x8000,
            i32::MIN,
        ] {
            let (hi, lo) = split_q16(k);
            assert!((-(1 << 15)..(1 << 15)).contains(&lo));
            assert_eq!(i64::from(hi) * 65_536 + i64::from(lo), i64::from(k));
        }
    }

    #[test]
    fn every_path_gives_the_formulas_bits() {
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
                        locate_squared_i128(&line, beam, r),
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
                locate_squared_i128(&line, beam, MAX_RANGE_MM)
            );
        }
    }

    /// The standard library's `u64` square root, rounded to the nearest (√x ≥ root + ½ exactly
    /// when x − root² > root): the reference of the 32-bit fast path.
    fn isqrt_round_u64(x: u64) -> u64 {
        let root = x.isqrt();
        root + u64::from(x - root * root > root)
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
    /// builds compute the same formulas; the firmware = host tests, `host/tests/run_qemu.rs`
    /// on a Cortex-M4F and `run_microbit.rs` on a Cortex-M0, hold the boards' maps to the
    /// host's). A change here is a change of the maths: the last was the per-point
    /// transform in Q48 with one rounding (BENCHMARKS.md, "The seventh pass").
    #[test]
    fn bits_are_pinned() {
        let pose = Pose::from_f32(123.456, -78.9, 1.25, 0.1, -0.2, 2.9).unwrap();
        let frame = pose.frame();
        let mut sum: u64 = 0;
        for v in Variant::ALL {
            let table = BeamTable::new(v);
            for plane in [
                crate::geometry::ScanPlane::PannedVertical,
                crate::geometry::ScanPlane::TiltedHorizontal,
            ] {
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
        assert_eq!(sum, 15_633_982_796_343_435_580);
    }
}
