//! The report's table of every nodding rig's stairs: the standing rows, the nod's phases and
//! the same phases after [`LONG_STAND_NODS`] more nods, and what standing longer did.

use super::{nod_period_s, pct, RigStairs, StandingRow, LONG_STAND_NODS};

/// Appends every nodding rig's stairs table to `s`, and what standing longer did.
pub(super) fn rigs_report(s: &mut String, rigs: &[RigStairs]) {
    use std::fmt::Write as _;
    let m = |v: Option<f64>| v.map_or_else(|| "never".to_string(), |d| format!("{d:.2} m"));
    let _ = writeln!(
        s,
        "\nEvery nodding rig on the same servo (2°..35° at 20 °/s, h = 1.0 m), standing its range less 0.95 m from the stairs, then driving at 1 m/s to 1 m; step cells obstacle at the stop and where the first step was first seen (flat grid; pyramid of the rig's design, hard gate; soft gate), the soft-gated pyramid's false obstacles on the ground before the stairs at the stop, and on the ground 0.5–2.5 m before the first riser when it first saw the first step. The last column: the same pyramid when the robot, arrived, stands until the observation in progress ends (the device integrates an observation when the servo turns; the other columns flush the partial sweep at arrival), and how long it waited. Rows \"phase\": 120 s plus a fraction of the nod's {:.1} s period; rows \"phase, long\": the same phases {} nods later, so that each differs from its \"phase\" row in the standing alone.\n\n| rig (φ, ψ) | standing s | flat | hard | hard: first seen | soft | soft: first seen | soft: false obstacles | soft: ground 0.5–2.5 m before, at first sight | soft, after the sweep in progress (wait; false obstacles) |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        nod_period_s(),
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
                "| {} (φ {:.2}°, ψ {:.2}°) | {:.3}{label} | {} | {} | {} | {} | {} | {} | {} | {} |",
                r.rig,
                r.design.phi_deg,
                r.design.psi_deg,
                row.stand_s,
                pct(row.flat_at_stop),
                pct(row.hard_at_stop),
                m(row.hard_first_seen_m),
                pct(row.soft_at_stop),
                m(row.soft_first_seen_m),
                pct(row.soft_false_obstacles),
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
                )
            );
        }
    }
    let _ = writeln!(s);
    for r in rigs {
        if let Some(line) = longer_standing(r) {
            let _ = writeln!(s, "{line}");
        }
    }
    let _ = writeln!(s);
}

/// What standing [`LONG_STAND_NODS`] nods longer did to a rig's phases: the phases whose step
/// cells at the stop fell, and those whose first sighting came more than 0.1 m nearer (a
/// tenth of a second's drive); `None` without long rows.
fn longer_standing(r: &RigStairs) -> Option<String> {
    if r.phases_long.is_empty() {
        return None;
    }
    let seen = |row: &StandingRow| row.soft_first_seen_m.unwrap_or(0.0);
    let pairs = || r.phases.iter().zip(&r.phases_long);
    let lower: Vec<String> = pairs()
        .filter(|(a, b)| b.soft_at_stop < a.soft_at_stop)
        .map(|(a, b)| {
            format!(
                "{:.3} s: {} → {}",
                a.stand_s,
                pct(a.soft_at_stop),
                pct(b.soft_at_stop)
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
        "- {}, standing {} nods longer at the same phase: step cells at the stop lower in {} of {} phases ({}); the first step first seen more than 0.1 m nearer in {} ({}).",
        r.rig,
        LONG_STAND_NODS,
        lower.len(),
        r.phases.len(),
        list(&lower),
        nearer.len(),
        list(&nearer)
    ))
}
