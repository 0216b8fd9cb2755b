//! The report's table of every nodding rig's stairs: the standing rows, the nod's phases and
//! the same phases after [`LONG_STAND_NODS`] more nods, and what standing longer did.

use super::riser_sight::{self, FAR_M};
use super::{nod_period_s, pct, rig_servo, RigStairs, StandingRow, LONG_STAND_NODS, RIGS};

/// Appends every nodding rig's stairs table to `s`, and what standing longer did.
pub(super) fn rigs_report(s: &mut String, rigs: &[RigStairs]) {
    use std::fmt::Write as _;
    let m = |v: Option<f64>| v.map_or_else(|| "never".to_string(), |d| format!("{d:.2} m"));
    let nods: Vec<String> = RIGS
        .iter()
        .map(|&(kind, name)| {
            format!(
                "{name} {} °/s, a {:.2} s nod",
                rig_servo(kind).2,
                nod_period_s(kind)
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "\nEvery nodding rig on its own nod (2°..35°, φ = 1.5° between two revolutions, the plan for 0.17 m steps sure from 4 m: {}; h = 1.0 m), standing its range less 0.95 m from the stairs, then driving at 1 m/s to 1 m. Step cells obstacle at the stop (flat grid; pyramid of the rig's design, hard gate; soft gate) with the observation in progress flushed into the map, and where the first step was first seen; the soft-gated pyramid at arrival without that flush (the map a device shows: it integrates an observation when the servo turns, never on arrival), its false obstacles on the ground before the stairs at the stop (flushed; at arrival), and on the ground 0.5–2.5 m before the first riser when it first saw the first step. The next column: the same pyramid when the robot, arrived, stands until the observation in progress ends, and how long it waited. The last: what the laser itself put on the first step (the simulator's true points on the riser's face or the first tread, at least the step threshold up), the bound on any map's first sighting: the lines (revolutions) that lit it while the robot stood, those that lit it from 4 m or more while it drove, and the farthest it lit it from while driving, with where the robot was when that line's sweep ended (a map shows a line's evidence up to a sweep, half a nod, later). Rows \"phase\": 120 s plus a fraction of the nod's period; rows \"phase, long\": the same phases {} nods later, so that each differs from its \"phase\" row in the standing alone.\n\n| rig (φ, ψ) | standing s | flat | hard | hard: first seen | soft, flushed | soft: at arrival | soft: first seen | soft: false obstacles, flushed; at arrival | soft: ground 0.5–2.5 m before, at first sight | soft, after the sweep in progress (wait; false obstacles) | first step lit: lines standing; driving from ≥ 4 m; farthest driving (its sweep's end) |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        nods.join(", "),
        LONG_STAND_NODS
    );
    for r in rigs {
        for (label, row) in r
            .standing
            .iter()
            .map(|x| ("", x))
            .chain(r.phases.iter().map(|x| (" (phase)", x)))
            .chain(r.phases_long.iter().map(|x| (" (phase, long)", x)))
        {
            let _ = writeln!(
                s,
                "| {} (φ {:.2}°, ψ {:.2}°) | {:.3}{label} | {} | {} | {} | {} | {} | {} | {}; {} | {} | {} | {}; {}; {} ({}) |",
                r.rig,
                r.design.phi_deg,
                r.design.psi_deg,
                row.stand_s,
                pct(row.flat_at_stop),
                pct(row.hard_at_stop),
                m(row.hard_first_seen_m),
                pct(row.soft_at_stop),
                pct(row.soft_at_arrival),
                m(row.soft_first_seen_m),
                pct(row.soft_false_obstacles),
                pct(row.soft_false_obstacles_at_arrival),
                row.soft_ground_at_first_sight
                    .map_or_else(|| "–".to_string(), pct),
                row.soft_after_sweep.map_or_else(
                    || "no sweep ended".to_string(),
                    |a| format!(
                        "{} ({:.2} s; {})",
                        pct(a.step_cells),
                        a.wait_s,
                        pct(a.false_obstacles)
                    )
                ),
                row.lit.standing_lines,
                row.lit.driving_lines_from_far,
                m(row.lit.farthest_driving_m),
                m(row.lit.farthest_sweep_end_m)
            );
        }
    }
    let _ = writeln!(s);
    for r in rigs {
        if let Some(line) = longer_standing(r) {
            let _ = writeln!(s, "{line}");
        }
        if let Some(line) = first_sight_against_the_laser(r) {
            let _ = writeln!(s, "{line}");
        }
    }
    let _ = writeln!(s);
}

/// A rig's phases whose first sighting came nearer than [`FAR_M`], against what the laser
/// gave: those where no sweep that lit the first step ended that far out (the laser's lines
/// and the sweep's delay), and those where one did, with how near its returns came to the
/// riser on the ground before it; `None` without phase rows.
fn first_sight_against_the_laser(r: &RigStairs) -> Option<String> {
    if r.phases.is_empty() {
        return None;
    }
    let m = |v: Option<f64>| v.map_or_else(|| "–".to_string(), |d| format!("{d:.2} m"));
    let late: Vec<&StandingRow> = r
        .phases
        .iter()
        .filter(|row| row.soft_first_seen_m.unwrap_or(0.0) < FAR_M)
        .collect();
    if late.is_empty() {
        return Some(format!(
            "- {}: the first step first seen {FAR_M} m or more before it in every phase.",
            r.rig
        ));
    }
    let (far, near): (Vec<&StandingRow>, Vec<&StandingRow>) = late
        .iter()
        .partition(|row| row.lit.farthest_sweep_end_m.is_some_and(|d| d >= FAR_M));
    let list = |rows: &[&StandingRow], what: &dyn Fn(&StandingRow) -> String| {
        if rows.is_empty() {
            return "none".to_string();
        }
        rows.iter()
            .map(|row| format!("{:.3} s: {}", row.stand_s, what(row)))
            .collect::<Vec<_>>()
            .join("; ")
    };
    let near_text = list(&near, &|row| {
        format!(
            "lit from {}, that sweep ended at {}, seen at {}",
            m(row.lit.farthest_driving_m),
            m(row.lit.farthest_sweep_end_m),
            m(row.soft_first_seen_m)
        )
    });
    let far_text = list(&far, &|row| {
        format!(
            "ground {} before the riser, seen at {}",
            m(row.lit.far_ground_gap_m),
            m(row.soft_first_seen_m)
        )
    });
    let (ramp_run_m, rise_m) = riser_sight::ramp_run_m();
    Some(format!(
        "- {}: the first step first seen nearer than {FAR_M} m in {} of {} phases. In {} no sweep that lit it while driving ended {FAR_M} m or more before it ({near_text}). In {} one did, and the ground its returns came nearest the riser lay ({far_text}); over more than {:.2} m a {:.2} m riser rises less steeply than the plane rule's largest grade, as a ramp would.",
        r.rig,
        late.len(),
        r.phases.len(),
        near.len(),
        far.len(),
        ramp_run_m,
        rise_m,
    ))
}

/// What standing [`LONG_STAND_NODS`] nods longer did to a rig's phases: the phases whose step
/// cells at arrival (the device's map) fell, and those whose first sighting came more than 0.1 m nearer (a
/// tenth of a second's drive); `None` without long rows.
fn longer_standing(r: &RigStairs) -> Option<String> {
    if r.phases_long.is_empty() {
        return None;
    }
    let seen = |row: &StandingRow| row.soft_first_seen_m.unwrap_or(0.0);
    let pairs = || r.phases.iter().zip(&r.phases_long);
    let lower: Vec<String> = pairs()
        .filter(|(a, b)| b.soft_at_arrival < a.soft_at_arrival)
        .map(|(a, b)| {
            format!(
                "{:.3} s: {} → {}",
                a.stand_s,
                pct(a.soft_at_arrival),
                pct(b.soft_at_arrival)
            )
        })
        .collect();
    let nearer: Vec<String> = pairs()
        .filter(|(a, b)| seen(b) < seen(a) - 0.1)
        .map(|(a, b)| format!("{:.3} s: {:.2} → {:.2} m", a.stand_s, seen(a), seen(b)))
        .collect();
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    Some(format!(
        "- {}, standing {} nods longer at the same phase: step cells at arrival lower in {} of {} phases ({}); the first step first seen more than 0.1 m nearer in {} ({}).",
        r.rig,
        LONG_STAND_NODS,
        lower.len(),
        r.phases.len(),
        list(&lower),
        nearer.len(),
        list(&nearer)
    ))
}

#[cfg(test)]
mod tests {
    use super::super::riser_sight::Lit;
    use super::super::Ld19Design;
    use super::*;

    fn row(
        stand_s: f64,
        seen_m: Option<f64>,
        sweep_end_m: Option<f64>,
        gap_m: Option<f64>,
    ) -> StandingRow {
        StandingRow {
            stand_s,
            flat_at_stop: 0.0,
            hard_at_stop: 1.0,
            hard_first_seen_m: seen_m,
            soft_at_stop: 1.0,
            soft_at_arrival: 1.0,
            soft_first_seen_m: seen_m,
            soft_false_obstacles: 0.0,
            soft_false_obstacles_at_arrival: 0.0,
            soft_ground_at_first_sight: None,
            soft_after_sweep: None,
            lit: Lit {
                standing_lines: 10,
                driving_lines_from_far: 1,
                farthest_driving_m: sweep_end_m.map(|d| d + 1.0),
                farthest_sweep_end_m: sweep_end_m,
                far_ground_gap_m: gap_m,
            },
        }
    }

    fn rig(phases: Vec<StandingRow>) -> RigStairs {
        RigStairs {
            rig: "test rig",
            design: Ld19Design::from_datasheet(),
            stand_distance_m: 11.05,
            standing: Vec::new(),
            phases,
            phases_long: Vec::new(),
        }
    }

    #[test]
    fn late_sightings_are_sorted_by_what_the_laser_gave() {
        let line = first_sight_against_the_laser(&rig(vec![
            row(120.0, Some(6.0), Some(5.0), Some(0.3)),
            row(120.5, Some(3.46), Some(3.47), None),
            row(121.0, Some(2.2), Some(5.5), Some(1.48)),
            row(121.5, None, None, None),
        ]))
        .unwrap();
        assert!(line.contains("nearer than 4 m in 3 of 4 phases"), "{line}");
        assert!(
            line.contains("In 2 no sweep that lit it while driving ended 4 m or more before it (120.500 s: lit from 4.47 m, that sweep ended at 3.47 m, seen at 3.46 m; 121.500 s: lit from –, that sweep ended at –, seen at –)"),
            "{line}"
        );
        assert!(
            line.contains("In 1 one did, and the ground its returns came nearest the riser lay (121.000 s: ground 1.48 m before the riser, seen at 2.20 m)"),
            "{line}"
        );
    }

    #[test]
    fn a_rig_seen_from_far_in_every_phase_says_so_and_no_phases_say_nothing() {
        let line =
            first_sight_against_the_laser(&rig(vec![row(120.0, Some(6.0), Some(5.0), None)]))
                .unwrap();
        assert!(
            line.ends_with("4 m or more before it in every phase."),
            "{line}"
        );
        assert!(first_sight_against_the_laser(&rig(Vec::new())).is_none());
    }
}
