//! The robot's pose in the world ([`Pose`]), its validation from the host's `f32` values
//! ([`Pose::from_f32`], [`PoseError`]), and its rotation matrix ([`Rotation`], [`PoseFrame`]),
//! computed in fixed point once per pose change.
//!
//! A robot-frame point q maps to the world as `T + R_z(yaw)·R_y(pitch)·R_x(roll)·q`, with
//! T = (x, y, z). All three turn counter-clockwise about their axis (right-hand rule): with
//! x forward, y left and z up, a positive roll raises the left side, a positive pitch turns
//! the nose *down* and a positive yaw turns the nose to the left.

use core::fmt;

use fixed::types::I2F30;

use crate::angle::{FineAngle, SinCos};
use crate::units::{meters_from_f32, Meters, Point3};

/// The largest horizontal coordinate a pose may have, metres (exclusive): |x|, |y| < 30 000,
/// so that a point 82 m away still fits [`Meters`] (±32 768 m) with room to spare.
pub const MAX_HORIZONTAL_M: f32 = 30_000.0;

/// The largest height a pose may have, metres (exclusive): |z| < 1 000.
pub const MAX_VERTICAL_M: f32 = 1_000.0;

/// The largest angle a pose may have, radians (exclusive): |roll|, |pitch|, |yaw| < 32 768
/// (≈ 5 215 turns; see [`FineAngle::from_radians_f32`]).
pub const MAX_ANGLE_RAD: f32 = 32_768.0;

/// One in Q2.30, raw.
const ONE_Q30: i64 = 1 << 30;

/// A field of a [`Pose`], for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PoseField {
    /// x, metres.
    X,
    /// y, metres.
    Y,
    /// z, metres.
    Z,
    /// Roll, radians.
    Roll,
    /// Pitch, radians.
    Pitch,
    /// Yaw, radians.
    Yaw,
}

impl PoseField {
    /// The field's name as the host link and messages spell it: `x`, `y`, `z`, `roll`,
    /// `pitch`, `yaw`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::X => "x",
            Self::Y => "y",
            Self::Z => "z",
            Self::Roll => "roll",
            Self::Pitch => "pitch",
            Self::Yaw => "yaw",
        }
    }

    /// The field's unit: `m` or `rad`.
    #[must_use]
    pub const fn unit(self) -> &'static str {
        match self {
            Self::X | Self::Y | Self::Z => "m",
            Self::Roll | Self::Pitch | Self::Yaw => "rad",
        }
    }
}

/// Why [`Pose::from_f32`] refused a pose. Nothing is clamped: a refused pose is not used.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PoseError {
    /// The field is NaN or infinite.
    NotFinite {
        /// The offending field.
        field: PoseField,
    },
    /// The field's magnitude is at or above its limit ([`MAX_HORIZONTAL_M`],
    /// [`MAX_VERTICAL_M`] or [`MAX_ANGLE_RAD`]).
    OutOfRange {
        /// The offending field.
        field: PoseField,
        /// Its value (metres or radians).
        value: f32,
        /// The limit its magnitude must stay below (metres or radians).
        limit: f32,
    },
}

impl PoseError {
    /// The field this error is about.
    #[must_use]
    pub const fn field(&self) -> PoseField {
        match *self {
            Self::NotFinite { field } | Self::OutOfRange { field, .. } => field,
        }
    }
}

impl fmt::Display for PoseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = self.field().name();
        match *self {
            Self::NotFinite { .. } => write!(f, "pose {name}: must be a finite number"),
            Self::OutOfRange {
                field,
                value,
                limit,
            } => {
                let unit = field.unit();
                write!(
                    f,
                    "pose {name}: must lie strictly between -{limit} and {limit} {unit} (got {value} {unit})"
                )
            }
        }
    }
}

impl core::error::Error for PoseError {}

/// The robot's pose in the world frame: the position of the robot frame's origin (its ground
/// contact point) and its orientation as roll, pitch, yaw (applied in that order: roll about
/// x, then pitch about y, then yaw about z, all in the fixed world axes).
///
/// Any value is accepted here; world coordinates saturate at the bounds of [`Meters`]. The
/// host link builds poses with [`Pose::from_f32`], which validates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Pose {
    /// x of the robot's origin in the world, metres.
    pub x: Meters,
    /// y of the robot's origin in the world, metres.
    pub y: Meters,
    /// z of the robot's origin in the world, metres.
    pub z: Meters,
    /// Roll, about x.
    pub roll: FineAngle,
    /// Pitch, about y (positive: nose down).
    pub pitch: FineAngle,
    /// Yaw, about z (positive: nose to the left).
    pub yaw: FineAngle,
}

impl Pose {
    /// The identity pose: at the world origin, axes aligned.
    pub const IDENTITY: Self = Self {
        x: Meters::ZERO,
        y: Meters::ZERO,
        z: Meters::ZERO,
        roll: FineAngle::ZERO,
        pitch: FineAngle::ZERO,
        yaw: FineAngle::ZERO,
    };

    /// A pose from the host's `f32` values: metres and radians.
    ///
    /// Positions are rounded to the nearest 2⁻¹⁶ m; angles are reduced modulo 2π and rounded
    /// to the nearest 2⁻³² turn (see [`FineAngle::from_radians_f32`]).
    ///
    /// # Errors
    /// The first field, in the order x, y, z, roll, pitch, yaw, that is NaN or infinite
    /// ([`PoseError::NotFinite`]) or too large ([`PoseError::OutOfRange`]: |x| or |y| ≥
    /// 30 000 m, |z| ≥ 1 000 m, an angle ≥ 32 768 rad in magnitude).
    pub fn from_f32(
        x: f32,
        y: f32,
        z: f32,
        roll_rad: f32,
        pitch_rad: f32,
        yaw_rad: f32,
    ) -> Result<Self, PoseError> {
        Ok(Self {
            x: position(PoseField::X, x, MAX_HORIZONTAL_M)?,
            y: position(PoseField::Y, y, MAX_HORIZONTAL_M)?,
            z: position(PoseField::Z, z, MAX_VERTICAL_M)?,
            roll: angle(PoseField::Roll, roll_rad)?,
            pitch: angle(PoseField::Pitch, pitch_rad)?,
            yaw: angle(PoseField::Yaw, yaw_rad)?,
        })
    }

    /// The position of the robot's origin in the world.
    #[must_use]
    pub const fn translation(&self) -> Point3 {
        Point3 {
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }

    /// The rotation `R_z(yaw)·R_y(pitch)·R_x(roll)`, in fixed point.
    #[must_use]
    pub fn rotation(&self) -> Rotation {
        Rotation::from_rpy(self.roll, self.pitch, self.yaw)
    }

    /// The pose's rotation and translation, ready for [`super::LineTransform::new`]: compute
    /// it once per pose change and reuse it for every line until the pose changes.
    #[must_use]
    pub fn frame(&self) -> PoseFrame {
        PoseFrame {
            rotation: self.rotation(),
            translation: self.translation(),
        }
    }
}

/// Checks a position field and converts it.
fn position(field: PoseField, value: f32, limit: f32) -> Result<Meters, PoseError> {
    if !value.is_finite() {
        return Err(PoseError::NotFinite { field });
    }
    if value.abs() >= limit {
        return Err(PoseError::OutOfRange {
            field,
            value,
            limit,
        });
    }
    Ok(meters_from_f32(value))
}

/// Checks an angle field and converts it.
fn angle(field: PoseField, value: f32) -> Result<FineAngle, PoseError> {
    if !value.is_finite() {
        return Err(PoseError::NotFinite { field });
    }
    FineAngle::from_radians_f32(value).ok_or(PoseError::OutOfRange {
        field,
        value,
        limit: MAX_ANGLE_RAD,
    })
}

#[cfg(feature = "defmt")]
defmt_raw!(
    Pose,
    "Pose({=i32}, {=i32}, {=i32} raw Q16.16; rpy {=u32}, {=u32}, {=u32} raw Q0.32 turn)",
    [x, y, z, roll, pitch, yaw]
);

/// A rotation matrix in signed Q2.30 (entries within −1 ..= +1).
///
/// Built from sines and cosines within 1.4·10⁻⁹ of exact and products rounded to Q2.30, each
/// entry is within 10⁻⁸ of the exact matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rotation {
    rows: [[i32; 3]; 3],
}

/// `round(a·b)` of two Q2.30 values, Q2.30 in an `i64`.
const fn mul(a: i64, b: i64) -> i64 {
    (a * b + (1 << 29)) >> 30
}

/// Clamps a Q2.30 value to −1 ..= +1.
const fn unit(raw: i64) -> i32 {
    if raw > ONE_Q30 {
        ONE_Q30 as i32
    } else if raw < -ONE_Q30 {
        -ONE_Q30 as i32
    } else {
        raw as i32
    }
}

/// The sine and cosine of an angle as raw Q2.30 in `i64`.
fn sc(angle: FineAngle) -> (i64, i64) {
    let SinCos { sin, cos } = angle.sin_cos();
    (i64::from(sin.to_bits()), i64::from(cos.to_bits()))
}

impl Rotation {
    /// The identity.
    pub const IDENTITY: Self = Self {
        rows: [
            [ONE_Q30 as i32, 0, 0],
            [0, ONE_Q30 as i32, 0],
            [0, 0, ONE_Q30 as i32],
        ],
    };

    /// `R_z(yaw)·R_y(pitch)·R_x(roll)`: roll about x first, then pitch about y, then yaw
    /// about z (fixed axes). Three [`FineAngle::sin_cos`] and a dozen 64-bit multiplies.
    #[must_use]
    pub fn from_rpy(roll: FineAngle, pitch: FineAngle, yaw: FineAngle) -> Self {
        let (sr, cr) = sc(roll);
        let (sp, cp) = sc(pitch);
        let (sy, cy) = sc(yaw);
        let cy_sp = mul(cy, sp);
        let sy_sp = mul(sy, sp);
        Self {
            rows: [
                [
                    unit(mul(cy, cp)),
                    unit(mul(cy_sp, sr) - mul(sy, cr)),
                    unit(mul(cy_sp, cr) + mul(sy, sr)),
                ],
                [
                    unit(mul(sy, cp)),
                    unit(mul(sy_sp, sr) + mul(cy, cr)),
                    unit(mul(sy_sp, cr) - mul(cy, sr)),
                ],
                [unit(-sp), unit(mul(cp, sr)), unit(mul(cp, cr))],
            ],
        }
    }

    /// The entries, row by row, signed Q2.30.
    #[must_use]
    pub fn rows(&self) -> [[I2F30; 3]; 3] {
        self.rows.map(|row| row.map(I2F30::from_bits))
    }

    /// The entries as raw Q2.30 bits, row by row.
    #[must_use]
    pub const fn to_bits(&self) -> [[i32; 3]; 3] {
        self.rows
    }

    /// The three columns as raw Q2.30 in `i64`: the images of the x, y and z axes.
    pub(crate) const fn columns(&self) -> [[i64; 3]; 3] {
        let [[a, b, c], [d, e, f], [g, h, i]] = self.rows;
        [
            [a as i64, d as i64, g as i64],
            [b as i64, e as i64, h as i64],
            [c as i64, f as i64, i as i64],
        ]
    }
}

impl Default for Rotation {
    fn default() -> Self {
        Self::IDENTITY
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Rotation {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "Rotation({} raw Q2.30)", self.rows);
    }
}

/// A pose ready for the per-line transform: its rotation matrix and translation.
///
/// Build it with [`Pose::frame`] when the pose changes (the trigonometry runs there), and
/// hand it to [`super::LineTransform::new`] for every line until the next change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseFrame {
    /// `R_z(yaw)·R_y(pitch)·R_x(roll)`.
    pub rotation: Rotation,
    /// The robot's origin in the world, metres.
    pub translation: Point3,
}

impl PoseFrame {
    /// A frame of zero bits (a zero matrix at the origin): the placeholder of an unconfigured
    /// pipeline, replaced by [`Pose::frame`] before any line uses it.
    pub const ZERO: Self = Self {
        rotation: Rotation { rows: [[0; 3]; 3] },
        translation: Point3 {
            x: Meters::ZERO,
            y: Meters::ZERO,
            z: Meters::ZERO,
        },
    };
}

impl From<&Pose> for PoseFrame {
    fn from(pose: &Pose) -> Self {
        pose.frame()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::format;

    fn q(raw: i32) -> f64 {
        f64::from(raw) / (1_u64 << 30) as f64
    }

    #[test]
    fn from_f32_accepts_and_converts() {
        let p = Pose::from_f32(1.5, -2.25, 0.5, 0.0, 0.0, core::f32::consts::FRAC_PI_2).unwrap();
        assert_eq!(p.x, Meters::from_num(1.5));
        assert_eq!(p.y, Meters::from_num(-2.25));
        assert_eq!(p.z, Meters::from_num(0.5));
        assert_eq!(p.roll, FineAngle::ZERO);
        // The f32 nearest π/2 is 4.37·10⁻⁸ rad above it: 29.9 units of 2⁻³² turn.
        assert_eq!(p.yaw.to_bits(), (1 << 30) + 30);
        assert_eq!(Pose::default(), Pose::IDENTITY);
        let big = Pose::from_f32(29_999.99, -29_999.99, -999.99, 1e3, -1e3, 3e4).unwrap();
        assert!(big.x > Meters::from_num(29_999.9));
    }

    #[test]
    fn from_f32_names_the_offending_field() {
        let ok = [0.0_f32; 6];
        let cases = [
            (0, f32::NAN, PoseField::X, false),
            (1, f32::INFINITY, PoseField::Y, false),
            (2, f32::NEG_INFINITY, PoseField::Z, false),
            (3, f32::NAN, PoseField::Roll, false),
            (4, f32::INFINITY, PoseField::Pitch, false),
            (5, f32::NAN, PoseField::Yaw, false),
            (0, 30_000.0, PoseField::X, true),
            (1, -30_000.0, PoseField::Y, true),
            (2, 1_000.0, PoseField::Z, true),
            (2, -1e30, PoseField::Z, true),
            (3, 32_768.0, PoseField::Roll, true),
            (4, -1e20, PoseField::Pitch, true),
            (5, f32::MAX, PoseField::Yaw, true),
        ];
        for (i, value, field, range) in cases {
            let mut v = ok;
            v[i] = value;
            let err = Pose::from_f32(v[0], v[1], v[2], v[3], v[4], v[5]).unwrap_err();
            assert_eq!(err.field(), field, "{i} {value}");
            assert_eq!(matches!(err, PoseError::OutOfRange { .. }), range);
            let text = format!("{err}");
            assert!(
                text.starts_with(&format!("pose {}:", field.name())),
                "{text}"
            );
        }
        assert_eq!(
            format!(
                "{}",
                Pose::from_f32(0.0, 31_000.0, 0.0, 0.0, 0.0, 0.0).unwrap_err()
            ),
            "pose y: must lie strictly between -30000 and 30000 m (got 31000 m)"
        );
        assert_eq!(
            format!(
                "{}",
                PoseError::NotFinite {
                    field: PoseField::Yaw
                }
            ),
            "pose yaw: must be a finite number"
        );
    }

    #[test]
    fn rotation_matches_the_composition() {
        for (r, p, y) in [
            (0.1_f64, -0.2, 0.3),
            (0.5, 0.5, -3.0),
            (-0.52, 0.52, 1.7),
            (0.0, 0.0, 0.0),
        ] {
            let fa = |x: f64| FineAngle::from_radians_f32(x as f32).unwrap();
            let rot = Rotation::from_rpy(fa(r), fa(p), fa(y));
            // Independent: multiply the three elementary matrices in f64.
            let (r, p, y) = (
                f64::from(r as f32),
                f64::from(p as f32),
                f64::from(y as f32),
            );
            let rx = [
                [1.0, 0.0, 0.0],
                [0.0, r.cos(), -r.sin()],
                [0.0, r.sin(), r.cos()],
            ];
            let ry = [
                [p.cos(), 0.0, p.sin()],
                [0.0, 1.0, 0.0],
                [-p.sin(), 0.0, p.cos()],
            ];
            let rz = [
                [y.cos(), -y.sin(), 0.0],
                [y.sin(), y.cos(), 0.0],
                [0.0, 0.0, 1.0],
            ];
            let mm = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
                let mut c = [[0.0; 3]; 3];
                for i in 0..3 {
                    for j in 0..3 {
                        c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
                    }
                }
                c
            };
            let want = mm(rz, mm(ry, rx));
            let got = rot.to_bits();
            for i in 0..3 {
                for j in 0..3 {
                    assert!((q(got[i][j]) - want[i][j]).abs() < 1e-8, "{i}{j}");
                }
            }
        }
        assert_eq!(
            Rotation::from_rpy(FineAngle::ZERO, FineAngle::ZERO, FineAngle::ZERO),
            Rotation::IDENTITY
        );
    }
}
