//! The gates of `docs/core.md` in `f64`: the hard top-hat and the paper's soft Gaussian, both
//! continuous (at the actual distance) and binned (at the centre of the distance bin, as the
//! library's tables are), and the Q1.15 rounding of a table entry.

use super::bands::{Design, GateKind};

/// B, the number of distance bins of a gate table.
pub const BINS: usize = 512;

/// The Q1.15 weight of 1.0, raw.
pub const WEIGHT_ONE_RAW: u32 = 1 << 15;

/// s, the largest integer in 0 ..= 10 with `R < B·2⁻ˢ`: the bins are `2⁻ˢ` m wide.
///
/// Returns `None` when no s fits (R ≥ 512 m, which validation refuses).
#[must_use]
pub fn bin_shift(max_range: f64) -> Option<u32> {
    (0..=10u32)
        .rev()
        .find(|&s| max_range < BINS as f64 / f64::from(1u32 << s))
}

/// The bin width `b = 2⁻ˢ`, metres.
#[must_use]
pub fn bin_width(shift: u32) -> f64 {
    1.0 / f64::from(1u32 << shift)
}

/// The bin of a distance given as a raw Q16.16 value: `min(floor(D/b), B − 1)`; negative
/// distances fall in bin 0. Computed on the real value `D_raw / 2¹⁶`.
#[must_use]
pub fn bin_of_raw(distance_raw: i32, shift: u32) -> usize {
    let d = f64::from(distance_raw) / 65_536.0;
    if d < 0.0 {
        return 0;
    }
    let i = (d / bin_width(shift)).floor();
    (i as usize).min(BINS - 1)
}

/// The centre of bin i, `(i + ½)·b`, metres.
#[must_use]
pub fn bin_centre(i: usize, shift: u32) -> f64 {
    (i as f64 + 0.5) * bin_width(shift)
}

/// The hard gate of layer k at distance x: 1 when `d_k ≤ x < d_{k+1}`, for the last layer
/// when `x ≥ d_k`; 0 otherwise.
#[must_use]
pub fn hard(design: &Design, k: usize, x: f64) -> f64 {
    let layer = &design.layers[k];
    let last = k + 1 == design.layers.len();
    if x >= layer.inner && (last || x < layer.outer) {
        1.0
    } else {
        0.0
    }
}

/// The soft gate `exp(−½((x − c)/σ_g)²)`.
#[must_use]
pub fn soft(centre: f64, sigma_g: f64, x: f64) -> f64 {
    let z = (x - centre) / sigma_g;
    (-0.5 * z * z).exp()
}

/// The continuous gate of layer k at the actual distance x (no binning).
#[must_use]
pub fn continuous(design: &Design, k: usize, x: f64) -> f64 {
    match design.schedule.gate {
        GateKind::Hard => hard(design, k, x),
        GateKind::Soft { .. } => {
            let l = &design.layers[k];
            soft(l.centre, l.sigma_g, x)
        }
    }
}

/// `round(w·2¹⁵)`, ties away from zero, for w in 0 ..= 1.
#[must_use]
pub fn quantise_weight(w: f64) -> u32 {
    (w * f64::from(WEIGHT_ONE_RAW)).round() as u32
}

/// One table entry as the update rule sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateWeight {
    /// The `f64` gate at the bin centre.
    pub exact: f64,
    /// `round(exact·2¹⁵)`: the entry `docs/core.md` specifies.
    pub raw: u32,
    /// The smallest Q1.15 entry a device that builds its table from an `f32` design may hold
    /// (within the design's and the evaluation's tolerated error, then rounded).
    pub raw_lo: u32,
    /// The largest such entry.
    pub raw_hi: u32,
}

/// The gate tables of a design: for each layer, the gate at every bin centre.
#[derive(Debug, Clone, PartialEq)]
pub struct Tables {
    /// s (bins are `2⁻ˢ` m wide).
    pub shift: u32,
    /// `w_k(x_i)` in `f64`, per layer.
    pub exact: Vec<[f64; BINS]>,
    /// `round(w_k(x_i)·2¹⁵)`, per layer.
    pub raw: Vec<[u32; BINS]>,
    /// The range of entries an `f32`-built table may legitimately hold, per layer: the
    /// rounding of `w ± tolerance` for the soft gate ([`design_tolerance`]), 0 ..= 1 for a
    /// hard-gate bin whose centre lies within an edge's tolerance ([`hard_bin_is_fragile`]).
    pub raw_range: Vec<[(u32, u32); BINS]>,
}

impl Tables {
    /// Builds the tables of `design`.
    ///
    /// # Panics
    /// If the design's range admits no bin width (validation refuses such a range).
    #[must_use]
    pub fn new(design: &Design) -> Self {
        let shift = bin_shift(design.sensor.max_range).expect("range within the table");
        let mut exact = Vec::new();
        let mut raw = Vec::new();
        let mut raw_range = Vec::new();
        for k in 0..design.layers.len() {
            let mut e = [0.0; BINS];
            let mut r = [0u32; BINS];
            let mut rr = [(0u32, 0u32); BINS];
            for i in 0..BINS {
                // docs/core.md: bins that start beyond the maximum range weigh 0 in every
                // layer (the last band is closed at R).
                let lower_edge = i as f64 / f64::from(1u32 << shift);
                if lower_edge > design.sensor.max_range {
                    continue;
                }
                let x = bin_centre(i, shift);
                e[i] = continuous(design, k, x);
                r[i] = quantise_weight(e[i]);
                rr[i] = match design.schedule.gate {
                    GateKind::Hard if hard_bin_is_fragile(design, k, x) => (0, WEIGHT_ONE_RAW),
                    GateKind::Hard => (r[i], r[i]),
                    GateKind::Soft { .. } => {
                        let t = design_tolerance(design, k, x);
                        (
                            quantise_weight((e[i] - t).max(0.0)),
                            quantise_weight((e[i] + t).min(1.0)),
                        )
                    }
                };
            }
            exact.push(e);
            raw.push(r);
            raw_range.push(rr);
        }
        Self {
            shift,
            exact,
            raw,
            raw_range,
        }
    }

    /// Layer k's entry for a raw Q16.16 distance.
    #[must_use]
    pub fn weight(&self, k: usize, distance_raw: i32) -> GateWeight {
        let i = bin_of_raw(distance_raw, self.shift);
        GateWeight {
            exact: self.exact[k][i],
            raw: self.raw[k][i],
            raw_lo: self.raw_range[k][i].0,
            raw_hi: self.raw_range[k][i].1,
        }
    }
}

/// The binning error of one layer's gate: the largest `|w(d) − w(x_bin(d))|` over d in
/// `[0, R]`, found by sampling every bin at its two ends, at the gate's peak when the bin holds
/// it, and at 32 interior points; and the analytic bound `e^{−½}·b/(2σ_g)` of `docs/core.md`.
///
/// Returns `(measured, bound)`; the hard gate's binning error is 1 wherever an edge falls
/// inside a bin, and its bound is reported as infinite.
#[must_use]
pub fn binning_error(design: &Design, k: usize) -> (f64, f64) {
    let shift = bin_shift(design.sensor.max_range).expect("range within the table");
    let b = bin_width(shift);
    let r = design.sensor.max_range;
    let layer = &design.layers[k];
    let mut worst = 0.0_f64;
    let last_bin = ((r / b).floor() as usize).min(BINS - 1);
    for i in 0..=last_bin {
        let centre_w = continuous(design, k, bin_centre(i, shift));
        let lo = i as f64 * b;
        let hi = (lo + b).min(r);
        let mut probe = |d: f64| {
            if (0.0..=r).contains(&d) {
                worst = worst.max((continuous(design, k, d) - centre_w).abs());
            }
        };
        for step in 0..=32 {
            probe(lo + (hi - lo) * f64::from(step) / 32.0);
        }
        // The top end of a bin is open: approach it from below.
        probe(hi - hi * f64::EPSILON);
        if (lo..hi).contains(&layer.centre) {
            probe(layer.centre);
        }
    }
    let bound = match design.schedule.gate {
        GateKind::Hard => f64::INFINITY,
        GateKind::Soft { .. } => (-0.5_f64).exp() * b / (2.0 * layer.sigma_g),
    };
    (worst, bound)
}

/// How far a table entry built in `f32` from an `f32` design may lie from the reference's
/// `f64` gate of the `f64` design, weight units, *before* rounding to Q1.15.
///
/// The soft gate moves with its centre and width: `∂w/∂c = w·z/σ`, `∂w/∂σ = w·z²/σ` with
/// `z = (x − c)/σ`; the design's `f32` edges may each be off by
/// [`super::bands::edge_tolerance`] (except `d_0 = 0` and `d_N = R`, which are exact), so
/// `c` by their mean and `σ_g` by f times their sum, plus the rounding of each to `f32`. The
/// evaluation of `exp` in `f32` adds a relative `4·10⁻⁶ + 4·10⁻⁷·z²`. The hard gate has no
/// such tolerance: its bins near an edge are [`hard_bin_is_fragile`].
#[must_use]
pub fn design_tolerance(design: &Design, k: usize, x: f64) -> f64 {
    let GateKind::Soft { width_factor } = design.schedule.gate else {
        return 0.0;
    };
    let layer = &design.layers[k];
    let (e_in, e_out) = edge_errors(design, k);
    let sigma = layer.sigma_g;
    let z = (x - layer.centre) / sigma;
    let w = soft(layer.centre, sigma, x);
    let e_c = 0.5 * (e_in + e_out) + super::bands::ulp_f32(layer.centre);
    let e_s = width_factor * (e_in + e_out) + 2.0 * super::bands::ulp_f32(sigma);
    w * (z.abs() / sigma * e_c + z * z / sigma * e_s) + f32_evaluation_tolerance(w, z)
}

/// The error of evaluating `exp(−½z²)` in `f32` with the library's config-time maths,
/// relative `4·10⁻⁶ + 4·10⁻⁷·z²` (`fmath` is held to 2·10⁻⁶; the argument's rounding grows
/// with z²), weight units.
#[must_use]
pub fn f32_evaluation_tolerance(w: f64, z: f64) -> f64 {
    w * (4e-6 + 4e-7 * z * z)
}

/// The possible error of layer k's two band edges in an `f32` design, metres.
fn edge_errors(design: &Design, k: usize) -> (f64, f64) {
    let layer = &design.layers[k];
    let last = k + 1 == design.layers.len();
    let e_in = if k == 0 {
        0.0
    } else {
        super::bands::edge_tolerance(&design.sensor, layer.inner)
    };
    let e_out = if last {
        0.0
    } else {
        super::bands::edge_tolerance(&design.sensor, layer.outer)
    };
    (e_in, e_out)
}

/// Is bin i's centre so close to one of layer k's band edges that an `f32` design may put it
/// on the other side (so that the hard gate's entry may be 0 instead of 1 or the reverse)?
#[must_use]
pub fn hard_bin_is_fragile(design: &Design, k: usize, x: f64) -> bool {
    let layer = &design.layers[k];
    let (e_in, e_out) = edge_errors(design, k);
    let last = k + 1 == design.layers.len();
    (k > 0 && (x - layer.inner).abs() <= e_in) || (!last && (x - layer.outer).abs() <= e_out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::bands::{design, Schedule};
    use crate::reference::bound::Sensor;

    #[test]
    fn bin_widths_follow_the_spec_examples() {
        assert_eq!(bin_shift(10.0), Some(5));
        assert_eq!(bin_shift(81.92), Some(2));
        assert_eq!(bin_shift(16.0), Some(4)); // R < B·b is strict
        assert_eq!(bin_shift(0.4), Some(10));
        assert_eq!(bin_of_raw(-5, 5), 0);
        assert_eq!(bin_of_raw(65_536 / 32 - 1, 5), 0);
        assert_eq!(bin_of_raw(65_536 / 32, 5), 1);
        assert_eq!(bin_of_raw(i32::MAX, 5), BINS - 1);
    }

    #[test]
    fn weight_rounding_is_exact_at_one_and_zero_below_half_an_lsb() {
        assert_eq!(quantise_weight(1.0), 32_768);
        assert_eq!(quantise_weight(0.49 / 32_768.0), 0);
        assert_eq!(quantise_weight(0.5 / 32_768.0), 1);
    }

    #[test]
    fn soft_binning_error_is_within_the_bound() {
        let d = design(&Sensor::default(), &Schedule::default(), 64, 16)
            .result
            .unwrap();
        for k in 0..d.layers.len() {
            let (m, b) = binning_error(&d, k);
            assert!(m <= b * (1.0 + 1e-9), "layer {k}: {m} > {b}");
            assert!(m >= 0.5 * b, "layer {k}: {m} ≪ {b}: sampling too coarse?");
        }
    }
}
