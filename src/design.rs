//! The pyramid's design: the sensor model, the cell-size bound δ(d) of eq. 17, the linear
//! resolution schedule and the range bands of eq. 20, and the validation of a configuration.
//!
//! Everything here runs when a configuration changes, never per point, so it computes in
//! `f32` with [`crate::fmath`] (micromath seeds, refined; the device has no `libm`), called by
//! name so that host builds, where `std`'s inherent float methods would win, run the same maths. Its results that the hot path needs
//! (resolutions, band edges) are converted to fixed point once, in [`crate::gate`] and
//! [`crate::grid`].
//!
//! Reading of the paper (see `docs/design.md`):
//! - `δ(d) = σ/√(1 + (h/d)²) + 2d·atan(ψ/2) + φ·(d² + h²)/h`, increasing in d, `δ(0⁺) = φ·h`;
//! - `r_0 = Δd`, `r_k = k·γ·Δd` for k ≥ 1;
//! - `d_0 = 0`, `d_{k+1} = sup{d : δ(d) ≤ r_k}`; the last band is closed at the maximum range;
//! - layers are added until `d_N ≥ max range`.

use crate::fmath;
use core::fmt;
use heapless::Vec;
use micromath::F32Ext;

/// The largest supported maximum range, metres: the SICK LMS2xx "80 m" (cm) mode reads up to
/// 81.91 m. Larger ranges are refused.
pub const MAX_RANGE_LIMIT_M: f32 = 81.92;

/// The smallest supported cell size, metres (1 cm). Finer cells are refused: they would not
/// fit a useful window into a microcontroller's RAM, and the fixed-point index maths assume it.
pub const MIN_RESOLUTION_M: f32 = 0.01;

/// The largest supported window, cells per side.
pub const MAX_CELLS_PER_SIDE: usize = 1024;

/// Iterations of the bisection that finds a band edge. Each halves a bracket that starts at the
/// maximum range (≤ 81.92 m), so 32 iterations reach below `f32` resolution.
const BISECTION_STEPS: u32 = 32;

/// The range sensor and its mounting, as the bound of eq. 17 sees them.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorModel {
    /// φ, the vertical angular resolution, radians; > 0 and < π/2 (strictly). Default 0.5° (SICK LMS at 0.5°).
    pub phi_rad: f32,
    /// ψ, the horizontal angular resolution (the pan step between lines), radians; > 0 and
    /// < π (strictly).
    /// Default 2°, as in the paper's Figure 2.
    pub psi_rad: f32,
    /// σ, the standard deviation of the range noise, metres; > 0. Default 0.15 m (Figure 2).
    pub sigma_m: f32,
    /// h, the height of the sensor above the ground, metres; > 0. Default 1.0 m.
    pub height_m: f32,
    /// The maximum range, metres; > 0 and ≤ [`MAX_RANGE_LIMIT_M`]. Default 10 m.
    pub max_range_m: f32,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self {
            phi_rad: 0.5_f32.to_radians(),
            psi_rad: 2.0_f32.to_radians(),
            sigma_m: 0.15,
            height_m: 1.0,
            max_range_m: 10.0,
        }
    }
}

/// The shape of the gate that assigns an observation at distance d to layer k.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GateShape {
    /// The top-hat over the band `[d_k, d_{k+1})`: weight 1 inside, 0 outside (eq. 8).
    Hard,
    /// The paper's soft gate `w_k(d) = exp(−½ (d − c_k)² / σ_g,k²)`, with `c_k` the centre of
    /// band k and `σ_g,k = width_factor · (d_{k+1} − d_k)`.
    Soft {
        /// The gate width as a fraction of the band's width; > 0 and ≤ 4. Default 0.5.
        width_factor: f32,
    },
}

impl Default for GateShape {
    fn default() -> Self {
        Self::Soft { width_factor: 0.5 }
    }
}

/// The resolution schedule of the pyramid.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Schedule {
    /// Δd, the finest cell size (layer 0), metres; must exceed φ·h. Default 0.1 m.
    pub base_m: f32,
    /// γ, the linear scaling parameter: `r_k = k·γ·Δd`; > 1. Default 2.
    pub gamma: f32,
    /// The gate that assigns observations to layers. Default: soft, width factor 0.5.
    pub gate: GateShape,
    /// Every layer at the base cell size Δd, the bands still those of the linear schedule:
    /// the paper's stairs experiment ("all levels of the pyramid were chosen to have a fixed
    /// resolution for the purposes of comparison"), where only the range banding differs
    /// from a flat grid. Default `false`. Windows must then hold the bands at Δd.
    pub uniform_resolution: bool,
}

impl Default for Schedule {
    fn default() -> Self {
        Self {
            base_m: 0.1,
            gamma: 2.0,
            gate: GateShape::default(),
            uniform_resolution: false,
        }
    }
}

/// A configuration parameter, for error messages: each names itself and its command-line flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Param {
    /// φ, [`SensorModel::phi_rad`].
    Phi,
    /// ψ, [`SensorModel::psi_rad`].
    Psi,
    /// σ, [`SensorModel::sigma_m`].
    Sigma,
    /// h, [`SensorModel::height_m`].
    Height,
    /// The maximum range, [`SensorModel::max_range_m`].
    MaxRange,
    /// Δd, [`Schedule::base_m`].
    Base,
    /// γ, [`Schedule::gamma`].
    Gamma,
    /// The soft gate's width factor, [`GateShape::Soft`].
    GateWidth,
    /// The window size in cells per side.
    Cells,
    /// p(x|z) for a non-navigable classification.
    PObstacle,
    /// p(x|z) for a navigable classification.
    PFree,
    /// The prior p(x).
    Prior,
    /// The lower clamping bound.
    ClampMin,
    /// The upper clamping bound.
    ClampMax,
    /// The decay mode ([`crate::decay::Decay::mode`]).
    DecayMode,
    /// The decay's time constant of a layer ([`crate::decay::Decay::tau`]).
    DecayTau {
        /// The layer, 0 = finest.
        layer: u8,
    },
}

impl Param {
    /// The command-line flag of `pyramid design` (and friends) that sets this parameter.
    #[must_use]
    pub const fn flag(self) -> &'static str {
        match self {
            Self::Phi => "--phi-deg",
            Self::Psi => "--psi-deg",
            Self::Sigma => "--sigma-m",
            Self::Height => "--height-m",
            Self::MaxRange => "--max-range-m",
            Self::Base => "--base-m",
            Self::Gamma => "--gamma",
            Self::GateWidth => "--gate-width",
            Self::Cells => "--cells",
            Self::PObstacle => "--p-obstacle",
            Self::PFree => "--p-free",
            Self::Prior => "--prior",
            Self::ClampMin => "--clamp-min",
            Self::ClampMax => "--clamp-max",
            Self::DecayMode => "--decay",
            Self::DecayTau { .. } => "--decay-tau-s",
        }
    }
}

/// Why a configuration was refused. Each variant names the parameter and the rule it broke;
/// nothing is ever silently clamped.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DesignError {
    /// The parameter is NaN or infinite.
    NotFinite {
        /// The offending parameter.
        param: Param,
    },
    /// The parameter is zero or negative, and must be positive.
    NotPositive {
        /// The offending parameter.
        param: Param,
        /// Its value, in the library's units (radians, metres).
        value: f32,
    },
    /// The parameter lies outside its supported range `[min, max]`.
    OutOfRange {
        /// The offending parameter.
        param: Param,
        /// Its value, in the library's units (radians, metres).
        value: f32,
        /// The smallest value allowed.
        min: f32,
        /// The largest value allowed.
        max: f32,
    },
    /// γ ≤ 1 would make `r_1 ≤ r_0`: the resolutions must coarsen.
    GammaNotAboveOne {
        /// The value of γ given.
        gamma: f32,
    },
    /// Δd ≤ φ·h makes layer 0's band empty: even at d → 0 the bound δ exceeds the cell.
    BaseBelowBound {
        /// Δd, metres.
        base_m: f32,
        /// φ·h = δ(0⁺), metres: Δd must exceed it.
        bound_m: f32,
    },
    /// The bands need more layers than the pyramid was compiled for.
    TooManyLayers {
        /// Layers needed to reach the maximum range.
        needed: usize,
        /// Layers the pyramid can hold (its const generic `L`).
        capacity: usize,
    },
    /// The window size is odd, below 4 or above [`MAX_CELLS_PER_SIDE`].
    BadWindow {
        /// The window given, cells per side.
        cells: usize,
    },
    /// A layer's window cannot hold its band around the robot.
    WindowTooSmall {
        /// The layer whose band does not fit.
        layer: usize,
        /// The window, cells per side.
        cells: usize,
        /// The smallest window that holds the band, cells per side.
        needed: usize,
    },
}

impl DesignError {
    /// The parameter this error is about.
    #[must_use]
    pub const fn param(&self) -> Param {
        match *self {
            Self::NotFinite { param }
            | Self::NotPositive { param, .. }
            | Self::OutOfRange { param, .. } => param,
            Self::GammaNotAboveOne { .. } => Param::Gamma,
            Self::BaseBelowBound { .. } => Param::Base,
            Self::TooManyLayers { .. } => Param::MaxRange,
            Self::WindowTooSmall { .. } | Self::BadWindow { .. } => Param::Cells,
        }
    }
}

impl fmt::Display for DesignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let flag = self.param().flag();
        match *self {
            Self::NotFinite { .. } => write!(f, "{flag}: must be a finite number"),
            Self::NotPositive { value, .. } => {
                write!(f, "{flag}: must be greater than 0 (got {value})")
            }
            Self::OutOfRange {
                param,
                value,
                min,
                max,
            } => {
                // Angles are radians in the library and degrees on the command line.
                let (value, min, max) = if matches!(param, Param::Phi | Param::Psi) {
                    (value.to_degrees(), min.to_degrees(), max.to_degrees())
                } else {
                    (value, min, max)
                };
                if let Param::DecayTau { layer } = param {
                    return if max <= 0.0 {
                        write!(
                            f,
                            "{flag} (layer {layer}): the design has no layer {layer}, so it takes no time constant (got {value} s)"
                        )
                    } else {
                        write!(
                            f,
                            "{flag} (layer {layer}): must lie within [{min}, {max}] s, the sweep's budget for this window (got {value} s)"
                        )
                    };
                }
                write!(f, "{flag}: must lie within [{min}, {max}] (got {value})")
            }
            Self::BadWindow { cells } => write!(
                f,
                "{flag}: must be an even number of cells from 4 to {MAX_CELLS_PER_SIDE} (got {cells})"
            ),
            Self::GammaNotAboveOne { gamma } => write!(
                f,
                "{flag}: must be greater than 1, or r_1 = gamma*base would not coarsen past r_0 = base (got {gamma})"
            ),
            Self::BaseBelowBound { base_m, bound_m } => write!(
                f,
                "{flag}: the base cell must exceed phi*h = {bound_m} m, or layer 0's band is empty (got {base_m} m; raise --base-m or lower --phi-deg / --height-m)"
            ),
            Self::TooManyLayers { needed, capacity } => write!(
                f,
                "{flag}: reaching the maximum range needs {needed} layers, more than the {capacity} compiled in (raise --base-m or --gamma, or lower the range)"
            ),
            Self::WindowTooSmall {
                layer,
                cells,
                needed,
            } => write!(
                f,
                "{flag}: layer {layer}'s band needs a window of at least {needed} cells per side around the robot (got {cells})"
            ),
        }
    }
}

/// The three terms of the cell-size bound δ(d) (eq. 17) at one distance, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoundTerms {
    /// The horizontal distance d, metres.
    pub d_m: f32,
    /// Range noise projected on the ground, `σ / √(1 + (h/d)²)` (eq. 10).
    pub noise_m: f32,
    /// Horizontal angular resolution, `2d·atan(ψ/2)` (eq. 16).
    pub horizontal_m: f32,
    /// Vertical angular resolution, `φ·(d² + h²)/h` (eq. 14).
    pub vertical_m: f32,
    /// δ(d), the sum of the three.
    pub total_m: f32,
}

impl SensorModel {
    /// Checks every field: finite, positive, angles below their geometric limits, the range
    /// within [`MAX_RANGE_LIMIT_M`].
    ///
    /// # Errors
    /// The first rule broken, naming its parameter.
    pub fn validate(&self) -> Result<(), DesignError> {
        use core::f32::consts::{FRAC_PI_2, PI};
        check_below(Param::Phi, self.phi_rad, FRAC_PI_2)?;
        check_below(Param::Psi, self.psi_rad, PI)?;
        check_in(Param::Sigma, self.sigma_m, 100.0)?;
        check_in(Param::Height, self.height_m, 100.0)?;
        check_in(Param::MaxRange, self.max_range_m, MAX_RANGE_LIMIT_M)?;
        Ok(())
    }

    /// The bound δ(d) and its three terms at horizontal distance `d_m` ≥ 0 (eq. 17).
    ///
    /// At `d_m = 0` the noise and horizontal terms vanish and δ = φ·h. Computed in `f32` with
    /// [`crate::fmath`]; its error against the f64 reference is measured in `host-tests`.
    #[must_use]
    pub fn bound(&self, d_m: f32) -> BoundTerms {
        let d = d_m.max(0.0);
        let h = self.height_m;
        let noise_m = if d > 0.0 {
            let ratio = h / d;
            self.sigma_m / fmath::sqrt(1.0 + ratio * ratio)
        } else {
            0.0
        };
        let horizontal_m = 2.0 * d * fmath::atan(self.psi_rad * 0.5);
        let vertical_m = self.phi_rad * (d * d + h * h) / h;
        BoundTerms {
            d_m: d,
            noise_m,
            horizontal_m,
            vertical_m,
            total_m: noise_m + horizontal_m + vertical_m,
        }
    }

    /// `sup { d ∈ [0, max range] : δ(d) ≤ cell_m }` by bisection (δ is increasing in d).
    ///
    /// Returns the maximum range when the whole range satisfies the bound, and 0 when none does.
    #[must_use]
    pub fn reach(&self, cell_m: f32) -> f32 {
        if self.bound(self.max_range_m).total_m <= cell_m {
            return self.max_range_m;
        }
        if self.bound(0.0).total_m > cell_m {
            return 0.0;
        }
        let (mut lo, mut hi) = (0.0_f32, self.max_range_m);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if self.bound(mid).total_m <= cell_m {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }
}

/// Checks that `value` is finite and lies in `(0, limit)`: an angle must stay below its
/// geometric limit.
fn check_below(param: Param, value: f32, limit: f32) -> Result<(), DesignError> {
    check_in(param, value, limit)?;
    if value >= limit {
        return Err(DesignError::OutOfRange {
            param,
            value,
            min: 0.0,
            max: limit,
        });
    }
    Ok(())
}

/// Checks that `value` is finite and lies in `(0, max]`.
fn check_in(param: Param, value: f32, max: f32) -> Result<(), DesignError> {
    if !value.is_finite() {
        return Err(DesignError::NotFinite { param });
    }
    if value <= 0.0 {
        return Err(DesignError::NotPositive { param, value });
    }
    if value > max {
        return Err(DesignError::OutOfRange {
            param,
            value,
            min: 0.0,
            max,
        });
    }
    Ok(())
}

impl Schedule {
    /// The cell size `r_k` of layer k in the linear schedule, metres: `Δd` for k = 0,
    /// `k·γ·Δd` otherwise. It sets the band edges; with [`Schedule::uniform_resolution`] every
    /// layer's cells are nevertheless `Δd`.
    #[must_use]
    pub fn resolution(&self, k: usize) -> f32 {
        if k == 0 {
            self.base_m
        } else {
            // Layer counts are small (≤ 255), so the conversion is exact.
            #[allow(clippy::cast_precision_loss)]
            let kf = k as f32;
            kf * self.gamma * self.base_m
        }
    }

    fn validate(&self, sensor: &SensorModel) -> Result<(), DesignError> {
        check_in(Param::Base, self.base_m, 100.0)?;
        if self.base_m < MIN_RESOLUTION_M {
            return Err(DesignError::OutOfRange {
                param: Param::Base,
                value: self.base_m,
                min: MIN_RESOLUTION_M,
                max: 100.0,
            });
        }
        if !self.gamma.is_finite() {
            return Err(DesignError::NotFinite {
                param: Param::Gamma,
            });
        }
        if self.gamma <= 1.0 {
            return Err(DesignError::GammaNotAboveOne { gamma: self.gamma });
        }
        check_in(Param::Gamma, self.gamma, 100.0)?;
        if let GateShape::Soft { width_factor } = self.gate {
            check_in(Param::GateWidth, width_factor, 4.0)?;
        }
        let bound_m = sensor.phi_rad * sensor.height_m;
        if self.base_m <= bound_m {
            return Err(DesignError::BaseBelowBound {
                base_m: self.base_m,
                bound_m,
            });
        }
        Ok(())
    }
}

/// One layer of the designed pyramid, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerDesign {
    /// The cell size `r_k`.
    pub resolution_m: f32,
    /// `d_k`, the inner edge of the band (inclusive).
    pub band_inner_m: f32,
    /// `d_{k+1}`, the outer edge of the band (exclusive, except the last layer's, which is the
    /// maximum range and inclusive).
    pub band_outer_m: f32,
    /// The soft gate's centre `c_k`: the middle of the band.
    pub gate_center_m: f32,
    /// The soft gate's width `σ_g,k` (0 for the hard gate).
    pub gate_sigma_m: f32,
}

/// A validated pyramid design for at most `L` layers and windows of `cells_per_side` cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Design<const L: usize> {
    sensor: SensorModel,
    schedule: Schedule,
    cells_per_side: usize,
    layers: Vec<LayerDesign, L>,
}

#[cfg(feature = "defmt")]
impl<const L: usize> defmt::Format for Design<L> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "Design {{ layers: {=usize}, cells_per_side: {=usize} }}",
            self.layers.len(),
            self.cells_per_side
        );
    }
}

impl<const L: usize> Design<L> {
    /// Validates the configuration and derives the layers: resolutions, bands, gates.
    ///
    /// # Errors
    /// The first rule broken, in this order: the sensor's fields, the schedule's fields
    /// (γ > 1, Δd > φ·h), the window size, the number of layers against `L`, each layer's
    /// window against its band.
    pub fn new(
        sensor: SensorModel,
        schedule: Schedule,
        cells_per_side: usize,
    ) -> Result<Self, DesignError> {
        sensor.validate()?;
        schedule.validate(&sensor)?;
        if !(4..=MAX_CELLS_PER_SIDE).contains(&cells_per_side) || !cells_per_side.is_multiple_of(2)
        {
            return Err(DesignError::BadWindow {
                cells: cells_per_side,
            });
        }
        let needed = layers_needed(&sensor, &schedule);
        if needed > L {
            return Err(DesignError::TooManyLayers {
                needed,
                capacity: L,
            });
        }
        let mut layers = Vec::new();
        let mut inner = 0.0_f32;
        for k in 0..needed {
            let schedule_m = schedule.resolution(k);
            let outer = if k + 1 == needed {
                sensor.max_range_m
            } else {
                sensor.reach(schedule_m)
            };
            let resolution_m = if schedule.uniform_resolution {
                schedule.base_m
            } else {
                schedule_m
            };
            let gate_sigma_m = match schedule.gate {
                GateShape::Hard => 0.0,
                GateShape::Soft { width_factor } => width_factor * (outer - inner),
            };
            let layer = LayerDesign {
                resolution_m,
                band_inner_m: inner,
                band_outer_m: outer,
                gate_center_m: 0.5 * (inner + outer),
                gate_sigma_m,
            };
            // With f32 rounding at extreme inputs the bound can exceed r_0 at every d > 0 even
            // though Δd > φ·h: an empty band is refused, never kept.
            if outer <= inner {
                return Err(DesignError::BaseBelowBound {
                    base_m: schedule.base_m,
                    bound_m: sensor.phi_rad * sensor.height_m,
                });
            }
            let fit = cells_to_hold(outer, resolution_m);
            if fit > cells_per_side {
                return Err(DesignError::WindowTooSmall {
                    layer: k,
                    cells: cells_per_side,
                    needed: fit,
                });
            }
            if layers.push(layer).is_err() {
                // Unreachable: `needed ≤ L` was checked above; report it the same way.
                return Err(DesignError::TooManyLayers {
                    needed,
                    capacity: L,
                });
            }
            inner = outer;
        }
        Ok(Self {
            sensor,
            schedule,
            cells_per_side,
            layers,
        })
    }

    /// The sensor model this design was made for.
    #[must_use]
    pub const fn sensor(&self) -> &SensorModel {
        &self.sensor
    }

    /// The resolution schedule this design was made for.
    #[must_use]
    pub const fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// The window of every layer, cells per side (even, 4 ..= [`MAX_CELLS_PER_SIDE`]).
    #[must_use]
    pub const fn cells_per_side(&self) -> usize {
        self.cells_per_side
    }

    /// The layers, finest first; between 1 and `L` of them.
    #[must_use]
    pub fn layers(&self) -> &[LayerDesign] {
        &self.layers
    }
}

/// How many layers the bands need to reach the maximum range: the smallest N with
/// `r_{N−1} ≥ δ(max range)`. Saturates at `usize::MAX` for absurd inputs (caught as too many).
fn layers_needed(sensor: &SensorModel, schedule: &Schedule) -> usize {
    let delta_max = sensor.bound(sensor.max_range_m).total_m;
    if schedule.base_m >= delta_max {
        return 1;
    }
    // r_k = k·γ·Δd ≥ δ_max  ⇔  k ≥ δ_max / (γ·Δd).
    let k = F32Ext::ceil(delta_max / (schedule.gamma * schedule.base_m));
    // A layer whose r_k only just reaches δ_max by rounding is checked exactly.
    let mut k = float_to_count(k).max(1);
    while k > 1 && schedule.resolution(k - 1) >= delta_max {
        k -= 1;
    }
    // The estimate saturates at MAX_COUNT; counting on past it could take up to 2⁶⁴ steps
    // (δ_max is +∞ for a tiny height, found by fuzzing), so past it the answer is "too many".
    while schedule.resolution(k) < delta_max {
        if k >= MAX_COUNT {
            return usize::MAX;
        }
        k += 1;
    }
    k.saturating_add(1)
}

/// Where [`float_to_count`] saturates.
const MAX_COUNT: usize = 65_535;

/// A non-negative finite float to a count, saturating.
fn float_to_count(value: f32) -> usize {
    if value.is_nan() || value <= 0.0 {
        0
    } else if value >= 65_535.0 {
        MAX_COUNT
    } else {
        // In range and non-negative: the conversion truncates an integer-valued float.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = value as usize;
        n
    }
}

/// The smallest even window (cells per side) that holds a disc of radius `reach_m` around a
/// robot anywhere inside the centre cell: `2·(⌈reach / r⌉ + 1)`.
#[must_use]
pub fn cells_to_hold(reach_m: f32, resolution_m: f32) -> usize {
    let cells = float_to_count(F32Ext::ceil(reach_m / resolution_m));
    cells.saturating_add(1).saturating_mul(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn bound_matches_the_paper_notes_check_values() {
        // paper-notes: with h = 1 m, δ(1) ≈ 0.158, δ(5) ≈ 0.548, δ(10) ≈ 1.380.
        let s = SensorModel::default();
        assert!(close(s.bound(1.0).total_m, 0.158, 0.002));
        assert!(close(s.bound(5.0).total_m, 0.548, 0.002));
        assert!(close(s.bound(10.0).total_m, 1.380, 0.003));
        assert!(close(s.bound(0.0).total_m, s.phi_rad * s.height_m, 1e-6));
    }

    #[test]
    fn default_design_has_increasing_contiguous_bands_closed_at_max_range() {
        let d = Design::<16>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let layers = d.layers();
        assert!(layers.len() >= 2);
        assert_eq!(layers[0].band_inner_m, 0.0);
        assert!(close(layers[0].band_outer_m, 0.53, 0.01));
        for w in layers.windows(2) {
            assert_eq!(w[0].band_outer_m, w[1].band_inner_m);
            assert!(w[1].resolution_m > w[0].resolution_m);
            assert!(w[1].band_outer_m > w[0].band_outer_m);
        }
        assert_eq!(layers.last().unwrap().band_outer_m, 10.0);
    }

    #[test]
    fn each_band_edge_is_where_the_bound_reaches_the_cell() {
        let d = Design::<16>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let s = d.sensor();
        for l in &d.layers()[..d.layers().len() - 1] {
            assert!(s.bound(l.band_outer_m).total_m <= l.resolution_m * 1.0001);
            assert!(s.bound(l.band_outer_m + 0.001).total_m > l.resolution_m);
        }
    }

    #[test]
    fn uniform_resolution_keeps_the_bands_and_the_base_cell() {
        let linear = Design::<16>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let schedule = Schedule {
            uniform_resolution: true,
            ..Schedule::default()
        };
        // Layer 2's band ends at 3.68 m: 2·(37 + 1) = 76 cells of 0.1 m, more than 64.
        assert!(matches!(
            Design::<16>::new(SensorModel::default(), schedule, 64),
            Err(DesignError::WindowTooSmall {
                layer: 2,
                needed: 76,
                ..
            })
        ));
        let uniform = Design::<16>::new(SensorModel::default(), schedule, 256).unwrap();
        assert_eq!(uniform.layers().len(), linear.layers().len());
        for (u, l) in uniform.layers().iter().zip(linear.layers()) {
            assert_eq!(u.resolution_m, 0.1);
            assert_eq!(
                (u.band_inner_m, u.band_outer_m),
                (l.band_inner_m, l.band_outer_m)
            );
        }
    }

    #[test]
    fn invalid_configurations_are_refused_by_name() {
        let s = SensorModel::default();
        let sch = Schedule::default();
        let gamma_one = Schedule { gamma: 1.0, ..sch };
        assert_eq!(
            Design::<16>::new(s, gamma_one, 64),
            Err(DesignError::GammaNotAboveOne { gamma: 1.0 })
        );
        let tiny = Schedule {
            base_m: 0.005,
            ..sch
        };
        assert!(matches!(
            Design::<16>::new(s, tiny, 64),
            Err(DesignError::OutOfRange {
                param: Param::Base,
                ..
            })
        ));
        let below = SensorModel { phi_rad: 0.1, ..s };
        assert!(matches!(
            Design::<16>::new(below, sch, 64),
            Err(DesignError::BaseBelowBound { .. })
        ));
        let nan = SensorModel {
            sigma_m: f32::NAN,
            ..s
        };
        assert_eq!(
            Design::<16>::new(nan, sch, 64),
            Err(DesignError::NotFinite {
                param: Param::Sigma
            })
        );
        let neg = SensorModel {
            height_m: -1.0,
            ..s
        };
        assert!(matches!(
            Design::<16>::new(neg, sch, 64),
            Err(DesignError::NotPositive {
                param: Param::Height,
                ..
            })
        ));
        assert!(matches!(
            Design::<2>::new(s, sch, 64),
            Err(DesignError::TooManyLayers { capacity: 2, .. })
        ));
        assert!(matches!(
            Design::<16>::new(s, sch, 8),
            Err(DesignError::WindowTooSmall { layer: 0, .. })
        ));
        assert!(matches!(
            Design::<16>::new(s, sch, 63),
            Err(DesignError::BadWindow { cells: 63 })
        ));
    }

    #[test]
    fn error_messages_name_the_flag() {
        extern crate std;
        use std::string::ToString;
        let e = DesignError::GammaNotAboveOne { gamma: 1.0 };
        assert!(e.to_string().starts_with("--gamma"));
        let e = DesignError::BaseBelowBound {
            base_m: 0.001,
            bound_m: 0.0087,
        };
        assert!(e.to_string().starts_with("--base-m"));
    }

    /// Fuzzing (config_validator): a tiny sensor height makes δ(max range) infinite, and
    /// `layers_needed` counted layers one by one towards `usize::MAX`: a Configure from the
    /// host hung the device. It must answer TooManyLayers at once.
    #[test]
    fn a_tiny_height_is_refused_as_too_many_layers_without_hanging() {
        for height_m in [f32::MIN_POSITIVE, 1e-30, 1e-6] {
            let sensor = SensorModel {
                phi_rad: 0.5_f32.to_radians(),
                psi_rad: 8.5e-44,
                sigma_m: 0.15,
                height_m,
                max_range_m: 8.0,
            };
            assert!(matches!(
                Design::<8>::new(sensor, Schedule::default(), 64),
                Err(DesignError::TooManyLayers { capacity: 8, .. })
            ));
        }
    }
}
