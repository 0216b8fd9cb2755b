//! The candidate rules' own tests: each on cells whose answer is known.

use super::*;

fn pts(v: &[(f64, f64, f64)]) -> Vec<RefPoint> {
    v.iter()
        .map(|&(x, y, z)| RefPoint {
            x,
            y,
            z,
            distance: 1.0,
        })
        .collect()
}

fn view(c: f64) -> CellView {
    CellView {
        cell_m: c,
        corner: (0.0, 0.0),
        sensor_height_m: 1.0,
        distance_m: 5.0,
    }
}

#[test]
fn a_tilted_plane_fits_with_no_residual_and_a_step_does_not() {
    let mut slope = Vec::new();
    let mut step = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (0.05 + 0.1 * f64::from(i), 0.05 + 0.1 * f64::from(j));
            slope.push((x, y, 0.2 * x - 0.1 * y));
            step.push((x, y, if x > 0.5 { 0.1 } else { 0.0 }));
        }
    }
    let fit = fit_plane(&pts(&slope), &view(1.0));
    assert!(fit.residual_rms_m < 1e-3, "{fit:?}");
    // The ridge shrinks the gradient by cxx/(cxx + λ), λ = (1/64)².
    let expected = 0.2f64.hypot(0.1) * 0.0825 / (0.0825 + (1.0f64 / 64.0).powi(2));
    assert!((fit.gradient - expected).abs() < 1e-3, "{fit:?}");
    let fit = fit_plane(&pts(&step), &view(1.0));
    // A 10 cm step across the middle: RMS 2.5 cm about the best line, rather less with
    // the ridge's shrunk slope counted against it.
    assert!(fit.residual_rms_m > 0.024, "{fit:?}");
}

#[test]
fn the_rules_by_hand() {
    let v = view(1.0);
    // A 10° slope over 1 m: the paper calls it an obstacle, the slope-aware rules don't.
    let mut slope = Vec::new();
    for i in 0..20 {
        let x = 0.025 + 0.05 * f64::from(i);
        slope.push((x, 0.5, x * 10f64.to_radians().tan()));
        slope.push((x, 0.6, x * 10f64.to_radians().tan()));
    }
    let slope = pts(&slope);
    assert!(Rule::Paper { step_m: 0.05 }.obstacle(&slope, &v));
    let tolerant = Rule::Tolerant {
        step_m: 0.05,
        max_slope_deg: 15.0,
        sigma_m: 0.0,
        k: 0.0,
    };
    assert!(!tolerant.obstacle(&slope, &v));
    let plane = Rule::Plane {
        step_m: 0.05,
        max_slope_deg: 15.0,
        residual_m: 0.015,
        sigma_m: 0.0,
        k: 0.0,
        rise_over_cell: true,
        backstop: false,
        angle_sigma_deg: 0.0,
        extremes: true,
    };
    assert!(!plane.obstacle(&slope, &v));
    let jump = Rule::Jump {
        step_m: 0.05,
        max_slope_deg: 15.0,
        radius_m: 0.15,
        sigma_m: 0.0,
        k: 0.0,
    };
    assert!(!jump.obstacle(&slope, &v));
    // A 12 cm step in the same cell, points on both sides 5 cm apart.
    let step = pts(&[
        (0.40, 0.5, 0.0),
        (0.45, 0.5, 0.0),
        (0.50, 0.5, 0.0),
        (0.55, 0.5, 0.12),
        (0.60, 0.5, 0.12),
        (0.65, 0.5, 0.12),
    ]);
    assert!(plane.obstacle(&step, &v));
    assert!(jump.obstacle(&step, &v));
    assert!(
        !tolerant.obstacle(&step, &v),
        "the tolerance of a 1 m cell hides it"
    );
}
