//! The linear resolution schedule, the range bands of eq. 20 (as read in
//! `docs/paper-notes.md`), the soft gate's centres and widths, and the rules that refuse a
//! configuration, all in `f64`.
//!
//! - `r_0 = Δd`, `r_k = k·γ·Δd` for k ≥ 1;
//! - `d_0 = 0`, `d_{k+1} = sup{d ∈ [0, R] : δ(d) ≤ r_k}`, found by bisection to the last bit
//!   of an `f64` (δ is increasing);
//! - N is the smallest count with `r_{N−1} ≥ δ(R)`, and `d_N = R`;
//! - `c_k = (d_k + d_{k+1})/2`, `σ_g,k = f·(d_{k+1} − d_k)`.
//!
//! A refused configuration reports *every* rule it breaks (not just the first), so that a test
//! can accept whichever one the library names first. Decisions that sit so close to their
//! threshold that `f32` configuration maths could go either way are reported as [`Fragile`].

use super::bound::Sensor;

/// The gate that assigns an observation at distance d to a layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GateKind {
    /// Weight 1 inside the band `[d_k, d_{k+1})` (the last band reaches the end of the table),
    /// 0 outside.
    Hard,
    /// `exp(−½((d − c_k)/σ_g,k)²)` with `σ_g,k = width_factor·(d_{k+1} − d_k)`.
    Soft {
        /// f, the gate width as a fraction of the band's width.
        width_factor: f64,
    },
}

/// The resolution schedule and the gate, in `f64`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Schedule {
    /// Δd, the finest cell size, metres.
    pub base: f64,
    /// γ, the linear scaling parameter.
    pub gamma: f64,
    /// The gate.
    pub gate: GateKind,
}

impl Default for Schedule {
    /// Δd = 0.1 m, γ = 2, soft gate with f = 0.5.
    fn default() -> Self {
        Self {
            base: 0.1,
            gamma: 2.0,
            gate: GateKind::Soft { width_factor: 0.5 },
        }
    }
}

impl Schedule {
    /// `r_k`: Δd for k = 0, `k·γ·Δd` otherwise, metres.
    #[must_use]
    pub fn resolution(&self, k: usize) -> f64 {
        if k == 0 {
            self.base
        } else {
            k as f64 * self.gamma * self.base
        }
    }
}

/// A configuration parameter (the reference's own names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// φ.
    Phi,
    /// ψ.
    Psi,
    /// σ.
    Sigma,
    /// h.
    Height,
    /// R.
    MaxRange,
    /// Δd.
    Base,
    /// γ.
    Gamma,
    /// The soft gate's width factor.
    GateWidth,
    /// The window, cells per side.
    Cells,
}

/// One rule of `docs/core.md` ("Refused") that a configuration breaks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Violation {
    /// NaN or infinite.
    NotFinite(Param),
    /// ≤ 0.
    NotPositive(Param),
    /// Outside its allowed range (φ ≥ π/2, ψ ≥ π, σ or h > 100 m, R > 81.92 m, Δd < 0.01 m or
    /// > 100 m, γ > 100, gate factor > 4, W odd or outside 4 ..= 1024).
    OutOfRange(Param),
    /// γ ≤ 1.
    GammaNotAboveOne,
    /// Δd ≤ φ·h.
    BaseBelowBound,
    /// N > L.
    TooManyLayers {
        /// N.
        needed: usize,
    },
    /// Layer `layer`'s band does not fit the window: `2·(⌈d_{k+1}/r_k⌉ + 1) > W`.
    WindowTooSmall {
        /// k.
        layer: usize,
        /// `2·(⌈d_{k+1}/r_k⌉ + 1)`.
        needed: usize,
    },
}

/// A decision taken within `FRAGILE_REL` of its threshold: `f32` configuration maths may
/// legitimately take it the other way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fragile {
    /// γ within the tolerance of 1.
    Gamma,
    /// Δd within the tolerance of φ·h.
    Base,
    /// Some `r_k` within the tolerance of δ(R): the layer count may differ by one.
    LayerCount,
    /// `d_{k+1}/r_k` within the tolerance of an integer: layer k's window need may differ by 2.
    Window {
        /// k.
        layer: usize,
    },
}

/// The relative closeness to a threshold below which a decision is [`Fragile`]. The library
/// computes in `f32` (relative error ~10⁻⁶ on δ); 10⁻⁵ leaves a factor of ten.
pub const FRAGILE_REL: f64 = 1e-5;

/// One layer of the reference design, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    /// `r_k`.
    pub resolution: f64,
    /// `d_k`.
    pub inner: f64,
    /// `d_{k+1}`.
    pub outer: f64,
    /// `c_k`.
    pub centre: f64,
    /// `σ_g,k` (0 for the hard gate).
    pub sigma_g: f64,
    /// The window this layer's band needs: `2·(⌈d_{k+1}/r_k⌉ + 1)` cells per side.
    pub cells_needed: usize,
}

/// A valid reference design.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// The sensor.
    pub sensor: Sensor,
    /// The schedule.
    pub schedule: Schedule,
    /// W.
    pub cells: usize,
    /// The layers, finest first.
    pub layers: Vec<Layer>,
}

/// The reference's verdict on a configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The design, or every rule broken (parameter rules first; the layer count and the
    /// windows only when the parameters are valid).
    pub result: Result<Design, Vec<Violation>>,
    /// Decisions too close to their threshold to be sure of.
    pub fragile: Vec<Fragile>,
}

/// The largest maximum range, metres.
pub const MAX_RANGE_LIMIT: f64 = 81.92;
/// The smallest and largest base cell, metres.
pub const BASE_LIMITS: (f64, f64) = (0.01, 100.0);

/// `sup{d ∈ [0, R] : δ(d) ≤ cell}`: R when δ(R) ≤ cell, 0 when δ(0) > cell, otherwise by
/// bisection until the bracket is two adjacent `f64`s.
#[must_use]
pub fn reach(sensor: &Sensor, cell: f64) -> f64 {
    let r = sensor.max_range;
    if sensor.delta(r) <= cell {
        return r;
    }
    if sensor.delta(0.0) > cell {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0_f64, r);
    loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            return lo;
        }
        if sensor.delta(mid) <= cell {
            lo = mid;
        } else {
            hi = mid;
        }
    }
}

/// N: the smallest count with `r_{N−1} ≥ δ(R)`.
#[must_use]
pub fn layers_needed(sensor: &Sensor, schedule: &Schedule) -> usize {
    let delta_max = sensor.delta(sensor.max_range);
    if schedule.base >= delta_max {
        return 1;
    }
    let estimate = (delta_max / (schedule.gamma * schedule.base)).ceil();
    let mut k = if estimate.is_finite() && estimate >= 1.0 {
        estimate.min(1e12) as usize
    } else {
        1
    };
    while k > 1 && schedule.resolution(k - 1) >= delta_max {
        k -= 1;
    }
    while schedule.resolution(k) < delta_max {
        k += 1;
    }
    k + 1
}

fn check(out: &mut Vec<Violation>, param: Param, value: f64, max: f64, max_inclusive: bool) {
    if !value.is_finite() {
        out.push(Violation::NotFinite(param));
    } else if value <= 0.0 {
        out.push(Violation::NotPositive(param));
    } else if value > max || (!max_inclusive && value >= max) {
        out.push(Violation::OutOfRange(param));
    }
}

fn near(a: f64, b: f64) -> bool {
    (a - b).abs() <= FRAGILE_REL * a.abs().max(b.abs())
}

/// The reference design for a configuration, or every rule it breaks.
///
/// Limits written as decimals in the spec are compared as the `f32` a caller would type
/// (`0.01_f32`, `81.92_f32`, `π/2` as `FRAC_PI_2_f32`), widened; the inputs themselves are the
/// caller's `f32` values widened to `f64`.
#[must_use]
pub fn design(sensor: &Sensor, schedule: &Schedule, cells: usize, capacity: usize) -> Outcome {
    let mut violations = Vec::new();
    let mut fragile = Vec::new();
    let s = sensor;
    // φ ≥ π/2 and ψ ≥ π are refused: the bounds are exclusive.
    check(
        &mut violations,
        Param::Phi,
        s.phi,
        f64::from(core::f32::consts::FRAC_PI_2),
        false,
    );
    check(
        &mut violations,
        Param::Psi,
        s.psi,
        f64::from(core::f32::consts::PI),
        false,
    );
    check(&mut violations, Param::Sigma, s.sigma, 100.0, true);
    check(&mut violations, Param::Height, s.height, 100.0, true);
    check(
        &mut violations,
        Param::MaxRange,
        s.max_range,
        f64::from(MAX_RANGE_LIMIT as f32),
        true,
    );
    let sch = schedule;
    check(&mut violations, Param::Base, sch.base, BASE_LIMITS.1, true);
    if sch.base.is_finite() && sch.base > 0.0 && sch.base < f64::from(BASE_LIMITS.0 as f32) {
        violations.push(Violation::OutOfRange(Param::Base));
    }
    if !sch.gamma.is_finite() {
        violations.push(Violation::NotFinite(Param::Gamma));
    } else if sch.gamma <= 1.0 {
        violations.push(Violation::GammaNotAboveOne);
        if sch.gamma <= 0.0 {
            violations.push(Violation::NotPositive(Param::Gamma));
        }
    } else if sch.gamma > 100.0 {
        violations.push(Violation::OutOfRange(Param::Gamma));
    }
    if sch.gamma.is_finite() && near(sch.gamma, 1.0) {
        fragile.push(Fragile::Gamma);
    }
    if let GateKind::Soft { width_factor } = sch.gate {
        check(&mut violations, Param::GateWidth, width_factor, 4.0, true);
    }
    let phi_h = s.phi * s.height;
    if phi_h.is_finite() && sch.base.is_finite() {
        if sch.base <= phi_h {
            violations.push(Violation::BaseBelowBound);
        }
        if near(sch.base, phi_h) {
            fragile.push(Fragile::Base);
        }
    }
    if !cells.is_multiple_of(2) || !(4..=1024).contains(&cells) {
        violations.push(Violation::OutOfRange(Param::Cells));
    }
    if !violations.is_empty() {
        return Outcome {
            result: Err(violations),
            fragile,
        };
    }

    let needed = layers_needed(s, sch);
    let delta_max = s.delta(s.max_range);
    for k in 0..needed.min(capacity + 2) {
        if near(sch.resolution(k), delta_max) {
            fragile.push(Fragile::LayerCount);
        }
    }
    if needed > capacity {
        violations.push(Violation::TooManyLayers { needed });
    }
    let mut layers = Vec::new();
    let mut inner = 0.0;
    for k in 0..needed.min(capacity) {
        let resolution = sch.resolution(k);
        let outer = if k + 1 == needed {
            s.max_range
        } else {
            reach(s, resolution)
        };
        let sigma_g = match sch.gate {
            GateKind::Hard => 0.0,
            GateKind::Soft { width_factor } => width_factor * (outer - inner),
        };
        let ratio = outer / resolution;
        let cells_needed = 2 * (ratio.ceil() as usize + 1);
        // The library's edge comes from f32 maths: its error is about that of δ over δ'.
        let edge_tol = 10.0 * edge_tolerance(s, outer) / resolution + FRAGILE_REL * ratio;
        if (ratio - ratio.round()).abs() <= edge_tol {
            fragile.push(Fragile::Window { layer: k });
        }
        if cells_needed > cells {
            violations.push(Violation::WindowTooSmall {
                layer: k,
                needed: cells_needed,
            });
        }
        layers.push(Layer {
            resolution,
            inner,
            outer,
            centre: 0.5 * (inner + outer),
            sigma_g,
            cells_needed,
        });
        inner = outer;
    }
    let result = if violations.is_empty() {
        Ok(Design {
            sensor: *s,
            schedule: *sch,
            cells,
            layers,
        })
    } else {
        Err(violations)
    };
    Outcome { result, fragile }
}

/// How far an `f32` computation of a band edge at `d` may lie from the exact one, metres:
/// a relative error of [`EDGE_DEFECT_REL`] on δ, divided by δ'(d), plus two `f32` units in
/// the last place of d (the stored edge).
///
/// Measured (the `agreement` example, 2·10⁴ random configurations): the library's edges
/// satisfy `|δ(d_lib) − r_k| ≤ 3.7·10⁻⁷·r_k`; this tolerance allows 2·10⁻⁶.
#[must_use]
pub fn edge_tolerance(sensor: &Sensor, d: f64) -> f64 {
    EDGE_DEFECT_REL * sensor.delta(d) / sensor.delta_slope(d) + 2.0 * ulp_f32(d)
}

/// The relative error on δ at a band edge that [`edge_tolerance`] allows.
pub const EDGE_DEFECT_REL: f64 = 2e-6;

/// One unit in the last place of `x` as an `f32`.
#[must_use]
pub fn ulp_f32(x: f64) -> f64 {
    let x = (x.abs() as f32).max(f32::MIN_POSITIVE);
    f64::from(f32::from_bits(x.to_bits() + 1) - x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_design_is_contiguous_and_closed_at_the_range() {
        let o = design(&Sensor::default(), &Schedule::default(), 64, 16);
        assert!(o.fragile.is_empty());
        let d = o.result.unwrap();
        assert_eq!(d.layers[0].inner, 0.0);
        assert!((d.layers[0].outer - 0.53).abs() < 0.01);
        assert_eq!(d.layers.last().unwrap().outer, 10.0);
        let s = d.sensor;
        for (k, l) in d.layers.iter().enumerate() {
            if k + 1 < d.layers.len() {
                // The sup: δ ≤ r at the edge, > r just beyond it.
                assert!(s.delta(l.outer) <= l.resolution);
                assert!(s.delta(l.outer + 1e-12) > l.resolution);
                assert!(l.resolution < s.delta(s.max_range));
            } else {
                assert!(l.resolution >= s.delta(s.max_range));
            }
        }
    }

    #[test]
    fn refusals_are_all_reported() {
        let s = Sensor::default();
        let bad = Schedule {
            gamma: 1.0,
            base: 0.005,
            ..Schedule::default()
        };
        let o = design(&s, &bad, 63, 16);
        let v = o.result.unwrap_err();
        assert!(v.contains(&Violation::GammaNotAboveOne));
        assert!(v.contains(&Violation::OutOfRange(Param::Base)));
        assert!(v.contains(&Violation::OutOfRange(Param::Cells)));
        assert!(v.contains(&Violation::BaseBelowBound));
        let o = design(&s, &Schedule::default(), 8, 2);
        let v = o.result.unwrap_err();
        assert!(matches!(v[0], Violation::TooManyLayers { .. }));
        assert!(v.contains(&Violation::WindowTooSmall {
            layer: 0,
            needed: 2 * (6 + 1)
        }));
    }
}
