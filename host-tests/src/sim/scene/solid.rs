//! The solids of a scene: axis-aligned boxes and vertical cylinders ([`Solid`]), each
//! intersected with a ray analytically.
use super::{Ray, Vec3};

/// A solid primitive the laser sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// An axis-aligned box between two corners, metres.
    Box {
        /// The corner with the smallest coordinates.
        min: Vec3,
        /// The corner with the largest coordinates.
        max: Vec3,
    },
    /// A vertical cylinder (a post), metres.
    Cylinder {
        /// Its axis, (x, y).
        centre: [f64; 2],
        /// Its radius, > 0.
        radius_m: f64,
        /// Its bottom.
        z_min: f64,
        /// Its top.
        z_max: f64,
    },
}

/// Smallest distance along a ray that counts as a hit (not the ray's own origin), metres.
const T_EPSILON: f64 = 1e-9;

impl Solid {
    /// The distance along `ray` to the first hit with this solid in `(0, t_max]`, metres.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<f64> {
        match *self {
            Self::Box { min, max } => {
                let (mut t0, mut t1) = (T_EPSILON, t_max);
                for axis in 0..3 {
                    let (o, d) = (ray.origin[axis], ray.dir[axis]);
                    if d.abs() < 1e-15 {
                        if o < min[axis] || o > max[axis] {
                            return None;
                        }
                    } else {
                        let (a, b) = ((min[axis] - o) / d, (max[axis] - o) / d);
                        let (near, far) = if a < b { (a, b) } else { (b, a) };
                        t0 = t0.max(near);
                        t1 = t1.min(far);
                        if t0 > t1 {
                            return None;
                        }
                    }
                }
                Some(t0)
            }
            Self::Cylinder {
                centre,
                radius_m,
                z_min,
                z_max,
            } => {
                let r2 = radius_m * radius_m;
                let (ox, oy) = (ray.origin[0] - centre[0], ray.origin[1] - centre[1]);
                let (dx, dy) = (ray.dir[0], ray.dir[1]);
                let mut best: Option<f64> = None;
                let mut take = |t: f64| {
                    if t > T_EPSILON && t <= t_max && best.is_none_or(|b| t < b) {
                        best = Some(t);
                    }
                };
                // The side: |o + t·d − c|² = r² in the plane, with z within the post.
                let a = dx * dx + dy * dy;
                if a > 1e-15 {
                    let b = ox * dx + oy * dy;
                    let c = ox * ox + oy * oy - r2;
                    let disc = b * b - a * c;
                    if disc >= 0.0 {
                        let t = (-b - disc.sqrt()) / a;
                        let z = ray.origin[2] + t * ray.dir[2];
                        if (z_min..=z_max).contains(&z) {
                            take(t);
                        }
                    }
                }
                // The caps.
                if ray.dir[2].abs() > 1e-15 {
                    for z_cap in [z_min, z_max] {
                        let t = (z_cap - ray.origin[2]) / ray.dir[2];
                        let (px, py) = (ox + t * dx, oy + t * dy);
                        if px * px + py * py <= r2 {
                            take(t);
                        }
                    }
                }
                best
            }
        }
    }
}
