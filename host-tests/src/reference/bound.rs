//! The cell-size lower bound δ(d) of eq. 17, in `f64`.
//!
//! `δ(d) = σ/√(1+(h/d)²) + 2d·atan(ψ/2) + φ·(d²+h²)/h`, with `δ(0) = φ·h` (the first two terms
//! vanish as d → 0⁺). Written from the paper (eqs. 10, 14, 16, 17) and `docs/core.md`.

/// The range sensor and its mounting, in `f64`: angles in radians, lengths in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensor {
    /// φ, the vertical angular resolution, radians.
    pub phi: f64,
    /// ψ, the horizontal angular resolution, radians.
    pub psi: f64,
    /// σ, the standard deviation of the range noise, metres.
    pub sigma: f64,
    /// h, the height of the sensor above the ground, metres.
    pub height: f64,
    /// R, the maximum range, metres.
    pub max_range: f64,
}

impl Default for Sensor {
    /// The paper's Figure 2 sensor (φ = 0.5°, ψ = 2°, σ = 0.15 m), h = 1 m, R = 10 m.
    fn default() -> Self {
        Self {
            phi: 0.5_f64.to_radians(),
            psi: 2.0_f64.to_radians(),
            sigma: 0.15,
            height: 1.0,
            max_range: 10.0,
        }
    }
}

/// The three terms of δ(d) and their sum, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terms {
    /// Range noise projected on the ground, `σ/√(1+(h/d)²)` (eq. 10), written as
    /// `σ·d/√(d²+h²)` so that d = 0 needs no special case.
    pub noise: f64,
    /// Horizontal angular resolution, `2d·atan(ψ/2)` (eq. 16, the printed form).
    pub horizontal: f64,
    /// Vertical angular resolution, `φ·(d²+h²)/h` (eq. 14).
    pub vertical: f64,
    /// δ(d) = the sum of the three.
    pub total: f64,
}

impl Sensor {
    /// The three terms of the bound at horizontal distance `d` ≥ 0 (negative d is taken as 0).
    #[must_use]
    pub fn terms(&self, d: f64) -> Terms {
        let d = d.max(0.0);
        let h = self.height;
        let noise = self.sigma * d / d.hypot(h);
        let horizontal = 2.0 * d * (0.5 * self.psi).atan();
        let vertical = self.phi * (d * d + h * h) / h;
        Terms {
            noise,
            horizontal,
            vertical,
            total: noise + horizontal + vertical,
        }
    }

    /// δ(d), metres (eq. 17).
    #[must_use]
    pub fn delta(&self, d: f64) -> f64 {
        self.terms(d).total
    }

    /// dδ/dd at d, metres per metre: used to turn an error in δ into an error in a band edge.
    #[must_use]
    pub fn delta_slope(&self, d: f64) -> f64 {
        let d = d.max(0.0);
        let h = self.height;
        let noise = self.sigma * h * h / (d * d + h * h).powf(1.5);
        noise + 2.0 * (0.5 * self.psi).atan() + 2.0 * self.phi * d / h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_notes_check_values() {
        // docs/paper-notes.md: with h = 1 m, δ(1) ≈ 0.158, δ(5) ≈ 0.548, δ(10) ≈ 1.380.
        let s = Sensor::default();
        assert!((s.delta(1.0) - 0.158).abs() < 5e-4, "{}", s.delta(1.0));
        assert!((s.delta(5.0) - 0.548).abs() < 5e-4, "{}", s.delta(5.0));
        assert!((s.delta(10.0) - 1.380).abs() < 5e-4, "{}", s.delta(10.0));
        assert_eq!(s.delta(0.0), s.phi * s.height);
    }

    #[test]
    fn delta_is_increasing_and_slope_matches_a_difference_quotient() {
        let s = Sensor::default();
        let mut d = 0.0;
        while d < 80.0 {
            assert!(s.delta(d + 0.01) > s.delta(d));
            let h = 1e-6;
            let fd = (s.delta(d + h) - s.delta(d)) / h;
            assert!(
                (fd - s.delta_slope(d + 0.5 * h)).abs() < 1e-5 * fd.max(1.0),
                "{d}"
            );
            d += 0.37;
        }
    }
}
