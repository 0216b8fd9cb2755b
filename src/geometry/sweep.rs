//! The geometry of returns that carry their own beam angle and come at their own actuator
//! angle: a spinning lidar's packets on a nodding (or panning) actuator.
//!
//! A SICK line has a fixed beam table and one actuator angle, so [`super::LineTransform`]
//! folds everything into one 3 × 2 matrix per line and reads (cos θ, sin θ) from the table. A
//! spinning lidar reports each return at an angle of its own (interpolated within a packet,
//! corrected per return), and while the actuator moves, every return of a packet sees the
//! plane at another angle. [`SweepTransform`] therefore keeps the parts that depend on neither
//! (the pose, the mount, the sensor's origin) and builds, per actuator angle, an
//! [`ActuatedPlane`]; that places a return from its own beam angle θ.
//!
//! # Formats and method
//! With R the pose's rotation (Q2.30 columns r₀, r₁, r₂), A(a) the actuator's rotation and
//! m₀, m₁ the mount's columns, the world direction of beam θ at actuator angle a is
//! `cos θ·C(a) + sin θ·S(a)` with `C(a) = −R·A(a)·m₁`, `S(a) = R·A(a)·m₀` (the frames of
//! [`super::mount`]). Each is split once per pose as `fixed + cos a·u + sin a·w` (a pan
//! leaves the z part fixed, a tilt the y part); for the presets:
//!
//! ```text
//! panned vertical:    C = −r₂,  S(a) = cos a·r₀ + sin a·r₁
//! tilted horizontal:  C = −r₁,  S(a) = cos a·r₀ − sin a·r₂
//! ```
//!
//! C and S cost one [`FineAngle::sin_cos`] and twelve 64-bit products per actuator angle
//! ([`SweepTransform::at`]), each part `fixed + ((cos a·u + sin a·w + 2²⁹) >> 30)`: a
//! preset's exact unit columns give the bits of the fixed mounts' six products. Per return, θ's sine and cosine come from the
//! same quarter-wave table with its Taylor correction ([`FineAngle::sin_cos`]: 257 entries,
//! no 36 000-entry table, no float); the direction `d_i = (C_i·cos θ + S_i·sin θ) / 2³⁰`
//! stays in Q2.30, is turned into Q40 metres per millimetre (as the line transform's rows)
//! and multiplied by the range. Per return: one `sin_cos` (two table reads, eight 64-bit
//! products), six products for the direction, three for the scale, three for the range: no
//! division, no float.
//!
//! # Error
//! Against the exact geometry of the same inputs (range, θ, actuator angle, pose, mount):
//! - the sines and cosines (each within 1.4·10⁻⁹) and the Q2.30 products: below 10⁻⁸ of the
//!   range;
//! - the rounding of the per-mm scale (2⁻⁴¹ m per mm), of the outputs to Q16.16 (2⁻¹⁷ m per
//!   axis), of the pose's position ([`super::Pose::from_f32`], 2⁻¹⁷ m per axis) and the mount
//!   offset rotated in Q2.30: below 0.03 mm together.
//!
//! So a world point is within **0.03 mm + 10⁻⁸ · r** of the exact one: 0.03 mm at 12 m and
//! at 40 m. (The SICK path's bound is 3.1·10⁻⁵ · r larger: its beam table is Q1.15.) The unit
//! tests hold it against `f64`; `cargo run --release -p terrain-pyramid-host-tests --example
//! lidar_geometry_error` measures the figures.

use core::fmt;

use super::fixed::{
    horizontal, horizontal_squared, meters_q40, per_mm_words, point_q40, sat_i32, LinePoint,
    LinePointSquared, MAX_RANGE_MM,
};
use super::mount::{ActuatorAxis, Mount};
use super::pose::PoseFrame;
use crate::angle::FineAngle;
use crate::units::Point3;
use crate::wide;

/// One world direction as a function of the actuator angle a: `fixed + cos a·u + sin a·w`,
/// each part Q2.30 (a unit component at most: saturated to `i32` once, never reached).
#[derive(Clone, Copy, PartialEq, Eq)]
struct Swept {
    fixed: [i32; 3],
    u: [i32; 3],
    w: [i32; 3],
    /// `u` or `w` is not zero: the direction turns with the actuator (a preset's direction
    /// along the actuator's axis does not, and costs no product per return).
    turns: bool,
}

impl Swept {
    const ZERO: Self = Self {
        fixed: [0; 3],
        u: [0; 3],
        w: [0; 3],
        turns: false,
    };

    /// `R·A(a)·v` split by the actuator's axis, for `v` (Q2.30, actuator frame at zero) and
    /// the robot's rotation columns r₀, r₁, r₂ (Q2.30). With `A = R_z(a)`:
    /// `fixed = v_z·r₂`, `u = v_x·r₀ + v_y·r₁`, `w = v_x·r₁ − v_y·r₀`; with `A = R_y(a)`:
    /// `fixed = v_y·r₁`, `u = v_x·r₀ + v_z·r₂`, `w = v_z·r₀ − v_x·r₂`; without an actuator
    /// `fixed = R·v`. Each component is rounded once from Q4.60: a unit entry of `v` (0 or
    /// ±2³⁰) gives the column itself, bit for bit.
    fn new(v: [i32; 3], axis: ActuatorAxis, r: [[i32; 3]; 3]) -> Self {
        let [vx, vy, vz] = v;
        let [r0, r1, r2] = r;
        // Each term as (factor, column); a component is Σ factor·column[i], rounded.
        let (fixed, u, w) = match axis {
            ActuatorAxis::Pan => (
                combine([(vz, r2)]),
                combine([(vx, r0), (vy, r1)]),
                combine([(vx, r1), (vy.saturating_neg(), r0)]),
            ),
            ActuatorAxis::Tilt => (
                combine([(vy, r1)]),
                combine([(vx, r0), (vz, r2)]),
                combine([(vz, r0), (vx.saturating_neg(), r2)]),
            ),
            ActuatorAxis::Fixed => (combine([(vx, r0), (vy, r1), (vz, r2)]), [0; 3], [0; 3]),
        };
        // Word by word (an array comparison compiles to a `memcmp` call).
        let ([u0, u1, u2], [w0, w1, w2]) = (u, w);
        Self {
            fixed,
            u,
            w,
            turns: (u0 | u1 | u2 | w0 | w1 | w2) != 0,
        }
    }

    /// The direction at an actuator angle of sine `sa` and cosine `ca` (Q2.30):
    /// `fixed + ((ca·u + sa·w + 2²⁹) >> 30)`, six 32 × 32 → 64 products, none when the
    /// direction does not turn (the same bits: the turned part rounds to 0).
    #[inline]
    fn at(&self, ca: i32, sa: i32) -> [i32; 3] {
        if !self.turns {
            return self.fixed;
        }
        let mut out = [0_i32; 3];
        for (((o, &f), &u), &w) in out.iter_mut().zip(&self.fixed).zip(&self.u).zip(&self.w) {
            // |u|, |w|, |ca|, |sa| ≤ 2³⁰ (up to rounding): each product fits 32 × 32 → 64 bits
            // (a library call avoided on ARMv6-M, `wide`), the sum below 2⁶¹.
            let swept = sat_i32((wide::smul(ca, u) + wide::smul(sa, w) + (1 << 29)) >> 30);
            *o = f.saturating_add(swept);
        }
        out
    }
}

/// `Σ factor·column` per component, rounded once from Q4.60 to Q2.30 (|factor|, |entry|
/// ≤ 2³⁰ up to rounding: each product 32 × 32 → 64 bits, a sum of three below 2⁶²·⁶).
#[inline]
fn combine<const N: usize>(terms: [(i32, [i32; 3]); N]) -> [i32; 3] {
    let mut q60 = [0_i64; 3];
    for (f, col) in terms {
        for (acc, &c) in q60.iter_mut().zip(&col) {
            *acc += wide::smul(f, c);
        }
    }
    q60.map(|v| sat_i32((v + (1 << 29)) >> 30))
}

/// The parts of the geometry that the actuator angle does not change: the world images of
/// the mount's directions, split by the actuator's axis, and the scanner's centre. Built once
/// per pose (or mount) change; [`SweepTransform::at`] gives the plane at an actuator angle.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct SweepTransform {
    /// `C(a) = −R·A(a)·m₁`, the world direction that multiplies cos θ.
    c: Swept,
    /// `S(a) = R·A(a)·m₀`, the world direction that multiplies sin θ.
    s: Swept,
    /// The reported actuator angle that is the geometry's 0.
    zero: FineAngle,
    /// The actuator's sense is reversed.
    reversed: bool,
    /// The scanner's centre in the world, metres Q40.
    origin: [i64; 3],
}

impl SweepTransform {
    /// A placeholder of zero bits (every return lands on the origin): an unconfigured
    /// pipeline's, replaced before any return uses it.
    pub const ZERO: Self = Self {
        c: Swept::ZERO,
        s: Swept::ZERO,
        zero: FineAngle::ZERO,
        reversed: false,
        origin: [0; 3],
    };

    /// The transform of `mount` on a robot at `frame` ([`super::Pose::frame`]): about 40
    /// 64-bit products, at each pose change.
    #[must_use]
    pub fn new(mount: &Mount, frame: &PoseFrame) -> Self {
        let r = frame.rotation.columns();
        let [r0, r1, r2] = r;
        // The columns are Q2.30 words widened: narrowing them back is exact.
        let r32 = r.map(|col| col.map(sat_i32));
        let [m0, m1] = mount.columns();
        let c = Swept::new(m1.map(i32::wrapping_neg), mount.axis(), r32);
        let s = Swept::new(m0, mount.axis(), r32);
        let t = frame.translation;
        let p = mount.position;
        let [px, py, pz] = [p.x, p.y, p.z].map(|m| i64::from(m.to_bits()));
        let rotated = |i: usize| {
            let pick = |col: [i64; 3]| col.get(i).copied().unwrap_or(0);
            // As the line transform's: each product < 2⁶¹, Q46 → Q40 with rounding.
            let q46 = pick(r0) * px + pick(r1) * py + pick(r2) * pz;
            (q46 + (1 << 5)) >> 6
        };
        let origin = [
            (i64::from(t.x.to_bits()) << 24) + rotated(0),
            (i64::from(t.y.to_bits()) << 24) + rotated(1),
            (i64::from(t.z.to_bits()) << 24) + rotated(2),
        ];
        Self {
            c,
            s,
            zero: mount.zero(),
            reversed: mount.reversed(),
            origin,
        }
    }

    /// The scanner's centre in the world frame, metres (saturated at ±32 768 m).
    #[must_use]
    pub fn sensor_origin(&self) -> Point3 {
        point_q40(self.origin)
    }

    /// The scan plane at the reported actuator angle `actuator` (the mount's zero and sense
    /// applied, [`Mount::actuator_angle`]): one [`FineAngle::sin_cos`] and twelve 64-bit
    /// products. Of a preset mount, the same bits as the fixed mounts' six products gave:
    /// the parts that do not turn are exact columns, and the rounding of the ones that turn
    /// is the same.
    #[must_use]
    pub fn at(&self, actuator: FineAngle) -> ActuatedPlane {
        let a = actuator.wrapping_sub(self.zero);
        let a = if self.reversed { a.reversed() } else { a };
        let sc = a.sin_cos();
        let (sa, ca) = (sc.sin.to_bits(), sc.cos.to_bits());
        ActuatedPlane {
            actuator,
            c: self.c.at(ca, sa),
            s: self.s.at(ca, sa),
            origin: self.origin,
        }
    }
}

impl fmt::Debug for SweepTransform {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SweepTransform")
            .field("origin", &self.sensor_origin())
            .finish_non_exhaustive()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for SweepTransform {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "SweepTransform(origin {})", self.sensor_origin());
    }
}

/// The scan plane at one actuator angle ([`SweepTransform::at`]): places returns from their
/// own beam angle θ (the geometry's convention: see [`super`]; a spinning lidar's clockwise
/// angle converts with [`super::mount::beam_angle_of_clockwise`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct ActuatedPlane {
    actuator: FineAngle,
    /// The world direction that multiplies cos θ, Q2.30.
    c: [i32; 3],
    /// The world direction that multiplies sin θ, Q2.30.
    s: [i32; 3],
    /// The scanner's centre in the world, metres Q40.
    origin: [i64; 3],
}

impl ActuatedPlane {
    /// C and S (Q2.30) and the scanner's centre (metres Q40): what a SICK line folds into its
    /// matrix ([`super::LineTransform::new`]).
    pub(super) const fn parts(&self) -> ([i32; 3], [i32; 3], [i64; 3]) {
        (self.c, self.s, self.origin)
    }

    /// The actuator angle this plane was built for.
    #[must_use]
    pub const fn actuator(&self) -> FineAngle {
        self.actuator
    }

    /// The offsets from the scanner's centre of beam θ at `range_mm`, metres Q40 (each below
    /// 2⁴⁸ in magnitude); `None` past [`MAX_RANGE_MM`].
    #[inline]
    fn offsets(&self, theta: FineAngle, range_mm: u32) -> Option<[i64; 3]> {
        if range_mm > MAX_RANGE_MM {
            return None;
        }
        let sc = theta.sin_cos();
        let (st, ct) = (sc.sin.to_bits(), sc.cos.to_bits());
        let mut out = [0_i64; 3];
        for ((o, &c), &s) in out.iter_mut().zip(&self.c).zip(&self.s) {
            // |c|, |s| ≤ 2³⁰ (up to rounding), |ct|, |st| ≤ 2³⁰: below 2⁶¹·¹.
            let dir = (wide::smul(c, ct) + wide::smul(s, st) + (1 << 29)) >> 30;
            // The Q40 per-mm scale (clamped to ±2⁴⁰/1 000) times a range below 2¹⁷.
            *o = wide::smul_u17(per_mm_words(dir), range_mm);
        }
        Some(out)
    }

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

    /// The world point of beam θ at `range_mm` millimetres; `None` past [`MAX_RANGE_MM`].
    /// Coordinates saturate at ±32 768 m. Never panics.
    #[must_use]
    pub fn point(&self, theta: FineAngle, range_mm: u32) -> Option<Point3> {
        Some(self.world(self.offsets(theta, range_mm)?))
    }

    /// The world point and its horizontal distance from the scanner; `None` past
    /// [`MAX_RANGE_MM`].
    #[must_use]
    pub fn locate(&self, theta: FineAngle, range_mm: u32) -> Option<LinePoint> {
        let offsets = self.offsets(theta, range_mm)?;
        let [dx, dy, _] = offsets;
        Some(LinePoint {
            point: self.world(offsets),
            horizontal: horizontal(dx, dy),
        })
    }

    /// The world point and the square of its horizontal distance (no square root: what the
    /// per-point path bins); `None` past [`MAX_RANGE_MM`].
    #[must_use]
    #[inline]
    pub fn locate_squared(&self, theta: FineAngle, range_mm: u32) -> Option<LinePointSquared> {
        let offsets = self.offsets(theta, range_mm)?;
        let [dx, dy, _] = offsets;
        Some(LinePointSquared {
            point: self.world(offsets),
            horizontal_squared: horizontal_squared(dx, dy),
        })
    }

    /// The scanner's centre in the world frame, metres.
    #[must_use]
    pub fn sensor_origin(&self) -> Point3 {
        point_q40(self.origin)
    }
}

impl fmt::Debug for ActuatedPlane {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ActuatedPlane")
            .field("actuator", &self.actuator)
            .field("origin", &self.sensor_origin())
            .finish_non_exhaustive()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ActuatedPlane {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "ActuatedPlane({}, origin {})",
            self.actuator,
            self.sensor_origin()
        );
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::geometry::mount::{beam_angle_of_clockwise, ScanPlane};

    use crate::geometry::{BeamDir, BeamTable, LineTransform, Pose};
    use crate::units::Meters;
    use crate::wire::sick::Variant;

    fn rad(a: FineAngle) -> f64 {
        f64::from(a.to_bits()) / 4_294_967_296.0 * core::f64::consts::TAU
    }

    fn q16(m: Meters) -> f64 {
        f64::from(m.to_bits()) / 65_536.0
    }

    /// The exact world point in f64, from the conventions (not from the fixed-point code).
    fn reference(
        plane: ScanPlane,
        position: [f64; 3],
        pose: [f32; 6],
        actuator: f64,
        theta: f64,
        range_m: f64,
    ) -> [f64; 3] {
        let (st, ct) = theta.sin_cos();
        let (sa, ca) = actuator.sin_cos();
        let d = match plane {
            ScanPlane::PannedVertical => [st * ca, st * sa, -ct],
            ScanPlane::TiltedHorizontal => [st * ca, -ct, -st * sa],
        };
        let robot = [0, 1, 2].map(|i| position[i] + range_m * d[i]);
        let [x, y, z, roll, pitch, yaw] = pose.map(f64::from);
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        // R_z(yaw)·R_y(pitch)·R_x(roll).
        let r = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        let w = [0, 1, 2].map(|i| r[i][0] * robot[0] + r[i][1] * robot[1] + r[i][2] * robot[2]);
        [x + w[0], y + w[1], z + w[2]]
    }

    /// SplitMix64.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * ((self.next() >> 11) as f64 / (1_u64 << 53) as f64)
        }
    }

    #[test]
    fn every_return_is_within_the_bound_of_f64() {
        let mut rng = Rng(0x11D0_6E0A);
        let mut worst = 0.0_f64;
        for i in 0..200_000 {
            let plane = if i % 2 == 0 {
                ScanPlane::PannedVertical
            } else {
                ScanPlane::TiltedHorizontal
            };
            let mount_bits = [
                rng.range(-131_072.0, 131_072.0) as i32,
                rng.range(-131_072.0, 131_072.0) as i32,
                rng.range(0.0, 196_608.0) as i32,
            ];
            let pose = [
                rng.range(-29_999.0, 29_999.0) as f32,
                rng.range(-29_999.0, 29_999.0) as f32,
                rng.range(-999.0, 999.0) as f32,
                rng.range(-0.5, 0.5) as f32,
                rng.range(-0.5, 0.5) as f32,
                rng.range(-20.0, 20.0) as f32,
            ];
            let actuator = FineAngle::from_bits(rng.next() as u32);
            let theta = FineAngle::from_bits(rng.next() as u32);
            let range_mm = (rng.next() % 40_001) as u32;
            let p = Pose::from_f32(pose[0], pose[1], pose[2], pose[3], pose[4], pose[5]).unwrap();
            let mount = Mount::new(
                plane,
                Point3 {
                    x: Meters::from_bits(mount_bits[0]),
                    y: Meters::from_bits(mount_bits[1]),
                    z: Meters::from_bits(mount_bits[2]),
                },
            );
            let got = SweepTransform::new(&mount, &p.frame())
                .at(actuator)
                .locate(theta, range_mm)
                .unwrap();
            let want = reference(
                plane,
                mount_bits.map(|b| f64::from(b) / 65_536.0),
                pose,
                rad(actuator),
                rad(theta),
                f64::from(range_mm) / 1000.0,
            );
            let g = [got.point.x, got.point.y, got.point.z].map(q16);
            let e =
                ((g[0] - want[0]).powi(2) + (g[1] - want[1]).powi(2) + (g[2] - want[2]).powi(2))
                    .sqrt();
            let r = f64::from(range_mm) / 1000.0;
            assert!(e <= 3.0e-5 + 1e-8 * r, "{e} at {r} m");
            let origin = reference(
                plane,
                mount_bits.map(|b| f64::from(b) / 65_536.0),
                pose,
                0.0,
                0.0,
                0.0,
            );
            let h = (want[0] - origin[0]).hypot(want[1] - origin[1]);
            assert!((q16(got.horizontal) - h).abs() <= 3.0e-5 + 1e-8 * r);
            worst = worst.max(e);
        }
        assert!(worst > 0.0);
    }

    #[test]
    fn the_word_products_give_the_i64_geometry_bit_for_bit() {
        // The plane and the offsets as they were computed with i64 products (the reference
        // here), against the 32 × 32 → 64 products of `wide` on the same random transforms.
        let mut rng = Rng(0x005E_ED0F_5EED);
        for i in 0..100_000 {
            let plane = if i % 2 == 0 {
                ScanPlane::PannedVertical
            } else {
                ScanPlane::TiltedHorizontal
            };
            let pose = [
                rng.range(-100.0, 100.0) as f32,
                rng.range(-100.0, 100.0) as f32,
                rng.range(-5.0, 5.0) as f32,
                rng.range(-3.2, 3.2) as f32,
                rng.range(-1.6, 1.6) as f32,
                rng.range(-3.2, 3.2) as f32,
            ];
            let p = Pose::from_f32(pose[0], pose[1], pose[2], pose[3], pose[4], pose[5]).unwrap();
            let mount = Mount::new(plane, Point3::default());
            let sweep = SweepTransform::new(&mount, &p.frame());
            let actuator = FineAngle::from_bits(rng.next() as u32);
            let theta = FineAngle::from_bits(rng.next() as u32);
            let range_mm = (rng.next() % u64::from(MAX_RANGE_MM + 1)) as u32;
            // The i64 way.
            let sc = actuator.sin_cos();
            let (sa, ca) = (i64::from(sc.sin.to_bits()), i64::from(sc.cos.to_bits()));
            let st_c = theta.sin_cos();
            let (st, ct) = (i64::from(st_c.sin.to_bits()), i64::from(st_c.cos.to_bits()));
            let mut want = [0_i64; 3];
            for (k, w) in want.iter_mut().enumerate() {
                let swept = |p: &Swept| {
                    let (f, u, v) = (i64::from(p.fixed[k]), i64::from(p.u[k]), i64::from(p.w[k]));
                    f + ((ca * u + sa * v + (1 << 29)) >> 30)
                };
                let (c, s) = (swept(&sweep.c), swept(&sweep.s));
                let dir = (c * ct + s * st + (1 << 29)) >> 30;
                *w = i64::from(crate::geometry::fixed::per_mm(dir)) * i64::from(range_mm);
            }
            assert_eq!(
                sweep.at(actuator).offsets(theta, range_mm),
                Some(want),
                "case {i}"
            );
        }
    }

    #[test]
    fn agrees_with_the_line_transform_where_both_apply() {
        // The same beam through the SICK table (Q1.15) and through its own angle (Q2.30):
        // within the table's rounding, 2⁻¹⁵ of the range.
        let table = BeamTable::new(Variant::Fov180StepHalf);
        let pose = Pose::from_f32(3.0, -2.0, 0.1, 0.05, -0.1, 1.0).unwrap();
        for plane in [ScanPlane::PannedVertical, ScanPlane::TiltedHorizontal] {
            let mount = Mount::new(
                plane,
                Point3 {
                    x: Meters::from_num(0.2),
                    y: Meters::ZERO,
                    z: Meters::from_num(0.5),
                },
            );
            let actuator = FineAngle::from_quarter_degrees(4 * 17);
            let line = LineTransform::from_pose(&table, &mount, actuator, &pose);
            let sweep = SweepTransform::new(&mount, &pose.frame()).at(actuator);
            assert_eq!(sweep.sensor_origin(), line.sensor_origin());
            for beam in 0..table.len() {
                let theta = Variant::Fov180StepHalf.beam_angle(beam).unwrap();
                let a = line.point(beam, 10_000).unwrap();
                let b = sweep.point(theta, 10_000).unwrap();
                let d = (q16(a.x) - q16(b.x))
                    .abs()
                    .max((q16(a.y) - q16(b.y)).abs())
                    .max((q16(a.z) - q16(b.z)).abs());
                assert!(d <= 10.0 * 3.1e-5 + 3e-5, "{beam}: {d}");
                assert_eq!(BeamDir::new(theta), table.get(beam).unwrap());
            }
        }
    }

    #[test]
    fn a_lidar_on_a_tilt_unit_sees_forward_and_right() {
        // A lidar 0.5 m up on a horizontal mount: its 0° (clockwise convention) ahead, its
        // 90° to the right.
        let mount = Mount::new(
            ScanPlane::TiltedHorizontal,
            Point3 {
                z: Meters::from_num(0.5),
                ..Point3::default()
            },
        );
        let plane = SweepTransform::new(&mount, &Pose::IDENTITY.frame()).at(FineAngle::ZERO);
        let ahead = plane
            .point(beam_angle_of_clockwise(FineAngle::ZERO), 2_000)
            .unwrap();
        assert!((q16(ahead.x) - 2.0).abs() < 1e-4 && q16(ahead.y).abs() < 1e-4);
        let right = plane
            .point(beam_angle_of_clockwise(FineAngle::QUARTER), 2_000)
            .unwrap();
        assert!((q16(right.y) + 2.0).abs() < 1e-4 && q16(right.x).abs() < 1e-4);
        // Tilted 30° down: the return ahead drops by r·sin 30°.
        let tilted = SweepTransform::new(&mount, &Pose::IDENTITY.frame())
            .at(FineAngle::from_quarter_degrees(120));
        let p = tilted
            .point(beam_angle_of_clockwise(FineAngle::ZERO), 2_000)
            .unwrap();
        assert!((q16(p.z) - (0.5 - 1.0)).abs() < 1e-4, "{p:?}");
        // Behind the robot, tilting down looks up.
        let back = tilted
            .point(beam_angle_of_clockwise(FineAngle::HALF), 2_000)
            .unwrap();
        assert!((q16(back.z) - 1.5).abs() < 1e-4, "{back:?}");
        // Past the range limit: refused.
        assert_eq!(tilted.point(FineAngle::ZERO, MAX_RANGE_MM + 1), None);
        assert_eq!(tilted.locate_squared(FineAngle::ZERO, u32::MAX), None);
    }
}
