//! `pyramid design --revolution-hz F`: what a 2-D lidar nodding on an actuator can show of a
//! step, from the design's φ (the tilt between two revolutions) and h (docs/lidars.md, "What
//! the laser gave").
//!
//! A revolution at tilt τ meets flat ground on a line `d = h / tan τ` ahead; the next, φ
//! further down or up, `φ·(d² + h²) / h` nearer or farther (`|dd/dτ| = (d² + h²) / h`). A
//! step of height S is told from a ramp only where a line falls on the ground less than its
//! run `S / g` before the riser (g the plane rule's largest grade, tan 20°): over a longer run
//! the rise from that line to the step is a slope the robot climbs. Where the lines lie at most
//! that run apart (`d ≤ d*`, `d*² = (S / g)·h / φ − h²`) every step of S has such a line in each
//! sweep; farther out it is the nod's phase that decides. φ is the nod's rate over the
//! revolutions per second, so the slowest nod that makes every step sure from D metres is
//! `F · (S / g)·h / (D² + h²)` radians a second.
//!
//! The maths here is plain f64 geometry for planning a rig: the firmware never runs it.

use serde::Serialize;

/// The steps the plan is for unless `--step-m` gives another: 0.15 m, a town kerb's and a
/// stair riser's usual height.
pub const DEFAULT_STEP_M: f64 = 0.15;

/// The distances (metres) at which the lines' spacing on the ground is listed: those within
/// the design's range.
pub const SPACING_DISTANCES_M: [f64; 6] = [1.0, 2.0, 3.0, 4.0, 6.0, 8.0];

/// The nodding lidar's flags of `pyramid design`.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct NodArgs {
    /// For a 2-D lidar on a nodding actuator: its revolutions per second. Then φ is the tilt
    /// between two revolutions (the nod's rate over this), and the report adds what the nod
    /// shows of a step: the lines' spacing on the ground, the range within which every step
    /// of `--step-m` has a line close enough before it to be told from a ramp, and the nod's
    /// rate.
    #[arg(long, value_name = "HZ", allow_hyphen_values = true)]
    pub revolution_hz: Option<f64>,
    /// The step height the nod is planned for, metres (with `--revolution-hz`; default 0.15).
    #[arg(
        long,
        value_name = "M",
        requires = "revolution_hz",
        allow_hyphen_values = true
    )]
    pub step_m: Option<f64>,
    /// Also the nod for which every such step is sure from this distance, metres: the largest
    /// φ and the fastest nod (with `--revolution-hz`).
    #[arg(
        long,
        value_name = "M",
        requires = "revolution_hz",
        allow_hyphen_values = true
    )]
    pub sure_from_m: Option<f64>,
}

/// The lines' spacing on the ground at one distance.
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct Spacing {
    /// Distance from the lidar along the ground, metres.
    pub d_m: f64,
    /// Between two revolutions' lines there, metres.
    pub spacing_m: f64,
}

/// The nod that makes every step sure from a distance.
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct SureFrom {
    /// The distance asked, metres.
    pub d_m: f64,
    /// The largest φ that does it, degrees.
    pub max_phi_deg: f64,
    /// The fastest nod that does it, degrees per second.
    pub max_nod_deg_s: f64,
}

/// What the design's nod shows of a step (module documentation).
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct NodPlan {
    /// The lidar's revolutions per second.
    pub revolution_hz: f64,
    /// The nod's rate the design's φ means, degrees per second: φ · revolutions per second.
    pub nod_deg_s: f64,
    /// The step height planned for, metres.
    pub step_m: f64,
    /// The plane rule's largest grade (rise over run).
    pub max_grade: f64,
    /// The most ground before a riser from which the rise to the step is steeper than the
    /// grade, metres: step / grade.
    pub run_m: f64,
    /// Within this distance every step of `step_m` has a line within `run_m` before it in
    /// each sweep, metres (0: nowhere, the lines lie farther apart than the run even at the
    /// lidar's foot).
    pub sure_within_m: f64,
    /// The lines' spacing on the ground at [`SPACING_DISTANCES_M`] within the range.
    pub spacing: Vec<Spacing>,
    /// With `--sure-from-m`: the nod that makes every step sure from there.
    pub sure_from: Option<SureFrom>,
}

/// A positive finite value of a flag, or its refusal in words.
fn positive(flag: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "{flag}: must be a positive number of its unit (got {v})"
        ))
    }
}

/// The plan of a nod for a design of tilt step `phi_deg` (degrees, > 0) and height `height_m`
/// (metres, > 0) to `max_range_m`, under the plane rule's largest grade `max_grade` (> 0);
/// `None` without `--revolution-hz`.
///
/// # Errors
/// A flag that is not a positive finite number, named.
pub fn plan(
    args: &NodArgs,
    phi_deg: f64,
    height_m: f64,
    max_range_m: f64,
    max_grade: f64,
) -> Result<Option<NodPlan>, String> {
    let Some(hz) = args.revolution_hz else {
        return Ok(None);
    };
    let hz = positive("--revolution-hz", hz)?;
    let step = positive("--step-m", args.step_m.unwrap_or(DEFAULT_STEP_M))?;
    let phi = positive("--phi-deg", phi_deg)?.to_radians();
    let h = positive("--height-m", height_m)?;
    let grade = positive("the plane rule's largest grade", max_grade)?;
    let run = step / grade;
    let sure_within_m = (run * h / phi - h * h).max(0.0).sqrt();
    let spacing = SPACING_DISTANCES_M
        .iter()
        .filter(|&&d| d <= max_range_m)
        .map(|&d| Spacing {
            d_m: d,
            spacing_m: phi * (d * d + h * h) / h,
        })
        .collect();
    let sure_from = match args.sure_from_m {
        Some(d) => {
            let d = positive("--sure-from-m", d)?;
            let max_phi = run * h / (d * d + h * h);
            Some(SureFrom {
                d_m: d,
                max_phi_deg: max_phi.to_degrees(),
                max_nod_deg_s: max_phi.to_degrees() * hz,
            })
        }
        None => None,
    };
    Ok(Some(NodPlan {
        revolution_hz: hz,
        nod_deg_s: phi_deg * hz,
        step_m: step,
        max_grade: grade,
        run_m: run,
        sure_within_m,
        spacing,
        sure_from,
    }))
}

/// The plan as the table's last section.
#[must_use]
pub fn table(p: &NodPlan) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nNodding at {:.3} revolutions/s: phi is a nod of {:.2}°/s. A step of {} m shows as a step \
         where a line falls within {:.3} m before it (step / max grade {:.3}).",
        p.revolution_hz, p.nod_deg_s, p.step_m, p.run_m, p.max_grade
    );
    let _ = writeln!(s, "  lines on the ground:");
    for sp in &p.spacing {
        let _ = writeln!(s, "    at {:>5.2} m every {:.3} m", sp.d_m, sp.spacing_m);
    }
    let _ = writeln!(
        s,
        "  every such step has one in each sweep within {:.2} m; farther, the nod's phase decides.",
        p.sure_within_m
    );
    if let Some(f) = &p.sure_from {
        let _ = writeln!(
            s,
            "  sure from {} m: phi at most {:.3}°, a nod of at most {:.2}°/s.",
            f.d_m, f.max_phi_deg, f.max_nod_deg_s
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(hz: f64, step: f64, sure_from: Option<f64>) -> NodArgs {
        NodArgs {
            revolution_hz: Some(hz),
            step_m: Some(step),
            sure_from_m: sure_from,
        }
    }

    /// The nodding rigs of docs/lidars.md (h 1 m, the stairs' 0.17 m risers, tan 20°), worked
    /// by hand: run = 0.17 / 0.36397 = 0.46707 m; d*² = run·h/φ − h².
    /// - LD19, φ 2° = 0.034907 rad: 0.46707 / 0.034907 = 13.3806; d* = √12.3806 = 3.5186 m.
    /// - RPLIDAR A1, φ 20/5.5 = 3.6364° = 0.063467 rad: 7.3593; d* = √6.3593 = 2.5218 m.
    /// - YDLIDAR X4, φ 20/7 = 2.8571° = 0.049867 rad: 9.3664; d* = √8.3664 = 2.8925 m.
    ///
    /// Sure from 4 m: φ ≤ 0.46707 / 17 = 0.027475 rad = 1.5742°; at 10 Hz 15.742°/s. At 4 m
    /// the LD19's lines lie 0.034907 · 17 = 0.59342 m apart.
    #[test]
    fn the_rigs_of_the_docs_worked_by_hand() {
        let grade = 20_f64.to_radians().tan();
        for (phi, hz, sure) in [
            (2.0, 10.0, 3.5186),
            (20.0 / 5.5, 5.5, 2.5218),
            (20.0 / 7.0, 7.0, 2.8925),
        ] {
            let p = plan(&args(hz, 0.17, Some(4.0)), phi, 1.0, 12.0, grade)
                .unwrap()
                .unwrap();
            assert!((p.run_m - 0.46707).abs() < 1e-4, "{}", p.run_m);
            assert!(
                (p.sure_within_m - sure).abs() < 1e-3,
                "{phi}: {}",
                p.sure_within_m
            );
            assert!((p.nod_deg_s - 20.0).abs() < 1e-9);
            let f = p.sure_from.unwrap();
            assert!((f.max_phi_deg - 1.5742).abs() < 1e-3, "{}", f.max_phi_deg);
            assert!((f.max_nod_deg_s - 1.5742 * hz).abs() < 1e-2);
        }
        let ld19 = plan(&args(10.0, 0.17, None), 2.0, 1.0, 12.0, grade)
            .unwrap()
            .unwrap();
        let at_4 = ld19.spacing.iter().find(|s| s.d_m == 4.0).unwrap();
        assert!((at_4.spacing_m - 0.59342).abs() < 1e-4);
        assert_eq!(ld19.spacing.len(), SPACING_DISTANCES_M.len());
        assert!(ld19.sure_from.is_none());
    }

    #[test]
    fn spacing_is_listed_within_the_range_and_no_nod_is_planned_without_its_rate() {
        let p = plan(&args(10.0, 0.15, None), 2.0, 1.0, 3.5, 0.364)
            .unwrap()
            .unwrap();
        let ds: Vec<f64> = p.spacing.iter().map(|s| s.d_m).collect();
        assert_eq!(ds, [1.0, 2.0, 3.0]);
        assert_eq!(plan(&NodArgs::default(), 2.0, 1.0, 12.0, 0.364), Ok(None));
    }

    #[test]
    fn lines_too_far_apart_even_at_the_foot_are_sure_nowhere() {
        // run·h/φ = 0.05 / 0.5236 = 0.095 < h² = 1: no distance has lines within the run.
        let p = plan(&args(10.0, 0.0182, None), 30.0, 1.0, 12.0, 0.364)
            .unwrap()
            .unwrap();
        assert_eq!(p.sure_within_m, 0.0);
    }

    #[test]
    fn bad_values_are_refused_by_name() {
        for (a, phi, h, flag) in [
            (args(0.0, 0.15, None), 2.0, 1.0, "--revolution-hz"),
            (args(f64::NAN, 0.15, None), 2.0, 1.0, "--revolution-hz"),
            (args(10.0, -0.1, None), 2.0, 1.0, "--step-m"),
            (args(10.0, 0.15, Some(0.0)), 2.0, 1.0, "--sure-from-m"),
            (args(10.0, 0.15, None), 0.0, 1.0, "--phi-deg"),
            (args(10.0, 0.15, None), 2.0, f64::INFINITY, "--height-m"),
        ] {
            let e = plan(&a, phi, h, 12.0, 0.364).unwrap_err();
            assert!(e.starts_with(flag), "{e}");
        }
    }

    #[test]
    fn the_table_says_the_rate_the_range_and_the_nod() {
        let p = plan(&args(10.0, 0.17, Some(4.0)), 2.0, 1.0, 12.0, 0.364)
            .unwrap()
            .unwrap();
        let t = table(&p);
        assert!(t.contains("a nod of 20.00°/s"), "{t}");
        assert!(t.contains("within 3.52 m"), "{t}");
        assert!(t.contains("at most 15.74°/s"), "{t}");
        assert!(t.contains("at  4.00 m every 0.593 m"), "{t}");
    }
}
