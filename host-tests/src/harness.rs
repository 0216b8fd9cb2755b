//! The bridge between the library and the reference: conversions of inputs (the library's
//! `f32`/fixed-point configuration widened to `f64`), of outputs (classes, fused answers),
//! and the cell-by-cell comparison of a library pyramid with a reference pyramid.
//!
//! Nothing here computes an expected value from the library: inputs go one way (library
//! configuration → reference), observations the other (library state → comparison).

use terrain_pyramid as tp;
use tp::units::Meters;

use crate::reference::bands::{self, GateKind, Violation};
use crate::reference::bound::Sensor;
use crate::reference::fused::Fused;
use crate::reference::logodds::{self, Class, InverseModel, ULP};
use crate::reference::window::{self, Pyramid};

/// The library's sensor model, widened.
#[must_use]
pub fn sensor(s: &tp::SensorModel) -> Sensor {
    Sensor {
        phi: f64::from(s.phi_rad),
        psi: f64::from(s.psi_rad),
        sigma: f64::from(s.sigma_m),
        height: f64::from(s.height_m),
        max_range: f64::from(s.max_range_m),
    }
}

/// The reference design ([`bands::design`]) for the library's sensor model and schedule,
/// widened: a window of `cells` cells a side, at most `capacity` layers.
#[must_use]
pub fn reference_design(
    model: &tp::SensorModel,
    plan: &tp::Schedule,
    cells: usize,
    capacity: usize,
) -> bands::Outcome {
    bands::design(&sensor(model), &schedule(plan), cells, capacity)
}

/// The library's schedule, widened.
#[must_use]
pub fn schedule(s: &tp::Schedule) -> bands::Schedule {
    bands::Schedule {
        base: f64::from(s.base_m),
        gamma: f64::from(s.gamma),
        gate: match s.gate {
            tp::GateShape::Hard => GateKind::Hard,
            tp::GateShape::Soft { width_factor } => GateKind::Soft {
                width_factor: f64::from(width_factor),
            },
        },
    }
}

fn param(p: tp::Param) -> Option<bands::Param> {
    Some(match p {
        tp::Param::Phi => bands::Param::Phi,
        tp::Param::Psi => bands::Param::Psi,
        tp::Param::Sigma => bands::Param::Sigma,
        tp::Param::Height => bands::Param::Height,
        tp::Param::MaxRange => bands::Param::MaxRange,
        tp::Param::Base => bands::Param::Base,
        tp::Param::Gamma => bands::Param::Gamma,
        tp::Param::GateWidth => bands::Param::GateWidth,
        tp::Param::Cells => bands::Param::Cells,
        _ => return None,
    })
}

/// Does the library's refusal name one of the rules the reference says are broken?
///
/// A `TooManyLayers` must agree on the count needed within one (below); a `WindowTooSmall` on
/// the layer and the cells needed.
#[must_use]
pub fn refusal_matches(error: &tp::DesignError, violations: &[Violation]) -> bool {
    use tp::DesignError as E;
    violations.iter().any(|v| match (*error, *v) {
        (E::NotFinite { param: p }, Violation::NotFinite(q))
        | (E::NotPositive { param: p, .. }, Violation::NotPositive(q))
        | (E::OutOfRange { param: p, .. }, Violation::OutOfRange(q)) => param(p) == Some(q),
        (E::BadWindow { .. }, Violation::OutOfRange(q)) => q == bands::Param::Cells,
        (E::GammaNotAboveOne { .. }, Violation::GammaNotAboveOne)
        | (E::BaseBelowBound { .. }, Violation::BaseBelowBound) => true,
        // The count walks every band edge to the range, in f32 in the library and in f64 in
        // the reference: over thousands of edges (a 0.014 m base to 75 m needs 6 900) the last
        // one can fall on either side of the range within rounding, so the count may differ
        // by one. Both refuse for the same rule; the count only says by how much.
        (E::TooManyLayers { needed, .. }, Violation::TooManyLayers { needed: n }) => {
            needed.abs_diff(n) <= 1
        }
        (
            E::WindowTooSmall { layer, needed, .. },
            Violation::WindowTooSmall {
                layer: l,
                needed: n,
            },
        ) => layer == l && needed == n,
        _ => false,
    })
}

/// The library's inverse sensor model, widened.
#[must_use]
pub fn inverse(m: &tp::InverseSensorModel) -> InverseModel {
    InverseModel {
        p_obstacle: f64::from(m.p_obstacle),
        p_free: f64::from(m.p_free),
        prior: f64::from(m.prior),
    }
}

/// The library's clamping, in nats.
#[must_use]
pub fn clamp(c: &tp::Clamp) -> logodds::Clamp {
    match *c {
        tp::Clamp::Off => logodds::Clamp::Off,
        tp::Clamp::Bounds { min, max } => logodds::Clamp::Bounds {
            min: min.to_num::<f64>(),
            max: max.to_num::<f64>(),
        },
    }
}

/// One layer's look at one cell from a distance: an evidence record before its gate weight
/// is looked up. The library weighs it with its own gating ([`Observation::evidence`]), the
/// reference with its own tables ([`evidence`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Observation {
    /// The layer, 0 = finest.
    pub layer: u8,
    /// The cell's world index along x in that layer.
    pub cell_x: i32,
    /// The cell's world index along y in that layer.
    pub cell_y: i32,
    /// What the observation says about the cell.
    pub class: tp::EvidenceClass,
    /// The horizontal distance from the sensor at the time of measurement.
    pub distance: tp::Meters,
}

impl Observation {
    /// The library's record: the layer's weight at the distance from the library's gating.
    #[must_use]
    pub fn evidence<const L: usize>(&self, gates: &tp::gate::Gates<L>) -> tp::Evidence {
        tp::Evidence {
            layer: self.layer,
            cell_x: self.cell_x,
            cell_y: self.cell_y,
            class: self.class,
            weight: gates.weight_at(usize::from(self.layer), self.distance),
        }
    }
}

/// The library's gating of a design and configuration (boxed: `L` KiB of tables).
///
/// # Panics
/// When the configuration's increments or the design's resolutions are invalid (a test's
/// own setup).
#[must_use]
pub fn gates<const L: usize>(
    design: &tp::Design<L>,
    config: &tp::Config,
) -> Box<tp::gate::Gates<L>> {
    let mut gates = Box::new(tp::gate::Gates::new());
    gates
        .configure(design, config.model.increments().expect("valid increments"))
        .expect("representable resolutions");
    gates
}

/// An observation as the reference's evidence record.
#[must_use]
pub fn evidence(o: &Observation) -> window::Evidence {
    window::Evidence {
        layer: usize::from(o.layer),
        i: i64::from(o.cell_x),
        j: i64::from(o.cell_y),
        obstacle: o.class == tp::EvidenceClass::Obstacle,
        distance_raw: o.distance.to_bits(),
    }
}

/// The library's class of a cell as the reference's.
#[must_use]
pub fn class(c: tp::CellClass) -> Class {
    match c {
        tp::CellClass::Unknown => Class::Unknown,
        tp::CellClass::Undecided => Class::Undecided,
        tp::CellClass::Obstacle => Class::Obstacle,
        tp::CellClass::Navigable => Class::Navigable,
    }
}

/// The library's fused answer as the reference's.
#[must_use]
pub fn fused(f: tp::Fused) -> Fused {
    match f {
        tp::Fused::Unknown => Fused::Unknown,
        tp::Fused::Obstacle { layer } => Fused::Obstacle {
            layer: usize::from(layer),
        },
        tp::Fused::Navigable { layer } => Fused::Navigable {
            layer: usize::from(layer),
        },
    }
}

/// The class as exported (undecided counts as unknown): obstacle / navigable / unknown.
#[must_use]
pub fn exported(c: Class) -> Class {
    if c == Class::Undecided {
        Class::Unknown
    } else {
        c
    }
}

/// The outcome of comparing every cell of every layer of a library pyramid with a reference.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Comparison {
    /// Cells compared (W² per layer).
    pub cells: u64,
    /// Cells whose exported class (obstacle / navigable / unknown) agrees.
    pub class_agree: u64,
    /// Cells whose four-way class (with undecided) agrees.
    pub class4_agree: u64,
    /// Cells observed in both.
    pub both_observed: u64,
    /// Cells observed in exactly one.
    pub observed_differs: u64,
    /// The largest |ΔL| over the cells observed in both, Q8.8 ULPs.
    pub max_ulps: f64,
    /// The sum of |ΔL| over the cells observed in both, Q8.8 ULPs.
    pub sum_ulps: f64,
    /// Disagreements a spec-conforming library cannot have (beyond the reference's
    /// per-cell error budget and threshold flags): `(layer, i, j, what)`.
    pub violations: Vec<(usize, i64, i64, String)>,
}

impl Comparison {
    /// The mean |ΔL| over the cells observed in both, ULPs.
    #[must_use]
    pub fn mean_ulps(&self) -> f64 {
        if self.both_observed == 0 {
            0.0
        } else {
            self.sum_ulps / self.both_observed as f64
        }
    }

    /// The share of cells whose exported class agrees.
    #[must_use]
    pub fn class_share(&self) -> f64 {
        if self.cells == 0 {
            1.0
        } else {
            self.class_agree as f64 / self.cells as f64
        }
    }
}

/// Compares every cell of every layer of `lib` with `reference`.
///
/// A violation is recorded when
/// - a window origin differs, or the layer counts differ;
/// - observed-ness differs, unless the reference flags a threshold case for the cell (an
///   update whose |w·l| lay within rounding of 2⁻⁹) and the reference's side is not surely
///   observed;
/// - |ΔL| exceeds the reference's error budget for the cell (0 in the quantised arithmetic);
/// - the class differs although |L_ref| exceeds the budget.
#[must_use]
pub fn compare<const W: usize, const L: usize>(
    lib: &tp::Pyramid<W, L>,
    reference: &Pyramid,
) -> Comparison {
    let mut out = Comparison::default();
    let tolerance = 1e-9;
    if lib.layer_count() != reference.layers.len() {
        out.violations.push((
            usize::MAX,
            0,
            0,
            format!(
                "layer count: library {}, reference {}",
                lib.layer_count(),
                reference.layers.len()
            ),
        ));
        return out;
    }
    for (k, ref_layer) in reference.layers.iter().enumerate() {
        let Some(layer) = lib.layer(k) else {
            out.violations
                .push((k, 0, 0, "library has no such layer".to_string()));
            continue;
        };
        let origin = layer.origin();
        if (i64::from(origin.0), i64::from(origin.1)) != ref_layer.origin {
            out.violations.push((
                k,
                0,
                0,
                format!(
                    "origin: library {origin:?}, reference {:?}",
                    ref_layer.origin
                ),
            ));
            continue;
        }
        let (ox, oy) = ref_layer.origin;
        for j in oy..oy + reference.cells {
            for i in ox..ox + reference.cells {
                out.cells += 1;
                let lib_cell = layer.get(i as i32, j as i32);
                let ref_cell = reference.cell(k, i, j);
                let (Some(lc), Some(rc)) = (lib_cell, ref_cell) else {
                    out.violations.push((
                        k,
                        i,
                        j,
                        format!("in-window: library {lib_cell:?}, reference {ref_cell:?}"),
                    ));
                    continue;
                };
                let lclass = class(lc.class());
                let rclass = rc.class();
                if exported(lclass) == exported(rclass) {
                    out.class_agree += 1;
                }
                if lclass == rclass {
                    out.class4_agree += 1;
                }
                let budget = rc.budget + tolerance * ULP;
                match (lc.log_odds(), rc.value) {
                    (Some(l), Some(r)) => {
                        out.both_observed += 1;
                        let diff = (l.to_num::<f64>() - r).abs();
                        out.max_ulps = out.max_ulps.max(diff / ULP);
                        out.sum_ulps += diff / ULP;
                        if diff > budget {
                            out.violations.push((
                                k,
                                i,
                                j,
                                format!(
                                    "|ΔL| = {:.3} ULP > budget {:.3} ULP (library {l}, reference {r})",
                                    diff / ULP,
                                    rc.budget / ULP
                                ),
                            ));
                        } else if r.abs() > budget && lclass != rclass {
                            out.violations.push((
                                k,
                                i,
                                j,
                                format!(
                                    "class: library {lclass:?} ({l}), reference {rclass:?} ({r})"
                                ),
                            ));
                        }
                    }
                    (None, None) => {}
                    (l, r) => {
                        out.observed_differs += 1;
                        let excused = rc.threshold_case && !(r.is_some() && rc.surely_observed);
                        if !excused {
                            out.violations.push((
                                k,
                                i,
                                j,
                                format!("observed: library {l:?}, reference {r:?}"),
                            ));
                        }
                    }
                }
            }
        }
        if let Some(c) = lib.counts(k) {
            let rc = reference.counts(k);
            let lc = (c.observed as usize, c.obstacle as usize, c.free as usize);
            // Counts agree exactly in the quantised comparison, unless some cell of the layer
            // has a legitimately open outcome (a table entry that may differ).
            let open = ref_layer
                .cells
                .values()
                .any(|c| c.budget > 0.0 || c.threshold_case);
            if reference.model.arithmetic == logodds::Arithmetic::Quantised
                && !open
                && lc != (rc.observed, rc.obstacle, rc.free)
            {
                out.violations
                    .push((k, 0, 0, format!("counts: library {lc:?}, reference {rc:?}")));
            }
        }
    }
    out
}

/// A raw Q16.16 value as [`Meters`].
#[must_use]
pub fn meters(raw: i32) -> Meters {
    Meters::from_bits(raw)
}

/// Hands the library classifier the reference's points (world metres and horizontal
/// distances, to fixed point), each above a ground at −1 m (below every point: no drop-off).
pub fn add_ref_points<const C: usize, const L: usize>(
    classifier: &mut tp::classify::Classifier<C, L>,
    points: &[crate::classify::RefPoint],
) {
    for r in points {
        let point = tp::Point3 {
            x: Meters::from_num(r.x),
            y: Meters::from_num(r.y),
            z: Meters::from_num(r.z),
        };
        classifier.add_point(point, Meters::from_num(r.distance), Meters::from_num(-1.0));
    }
}

/// Ends the library classifier's observation and keeps its evidence by (layer, cell x,
/// cell y), each as `value_of` makes it.
pub fn evidence_by_cell<const C: usize, const L: usize, T>(
    classifier: &mut tp::classify::Classifier<C, L>,
    value_of: impl Fn(tp::Evidence) -> T,
) -> std::collections::BTreeMap<(usize, i64, i64), T> {
    let mut by_cell = std::collections::BTreeMap::new();
    classifier.finish(|e| {
        by_cell.insert(
            (
                usize::from(e.layer),
                i64::from(e.cell_x),
                i64::from(e.cell_y),
            ),
            value_of(e),
        );
    });
    by_cell
}

/// Every layer's cell side of the library pyramid `pyramid`, metres (the reference
/// classifier's resolutions).
#[must_use]
pub fn layer_resolutions_m<const W: usize, const L: usize>(
    pyramid: &tp::Pyramid<W, L>,
) -> Vec<f64> {
    (0..pyramid.layer_count())
        .map(|k| {
            let layer = pyramid.layer(k).expect("every layer below the count");
            f64::from(layer.resolution().to_bits()) / 65536.0
        })
        .collect()
}

/// Whether the library's `gates` let a point `d` metres away feed layer `k` any evidence: its
/// obstacle or its free increment (`increments`) gated is not 0 (the reference classifier's
/// `feeds`).
pub fn gate_feeds<const L: usize>(
    gates: &tp::gate::Gates<L>,
    increments: tp::logodds::Increments,
) -> impl Fn(usize, f64) -> bool + '_ {
    move |k, d| {
        let w = gates.weight_at(k, Meters::from_num(d));
        tp::logodds::gated(increments.obstacle, w) != 0
            || tp::logodds::gated(increments.free, w) != 0
    }
}
