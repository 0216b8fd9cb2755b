//! What the laser itself put on the first step of the stairs: the simulator's true points of
//! the returns that met the first riser's face or the first tread above the classifier's step
//! threshold, grouped into the lines (revolutions) that carried them, and the robot's distance
//! from the riser when each line swept it.
//!
//! Beside each line, the ground the same sweep saw nearest before the riser: the rise from
//! there to the step is what tells a step from a ramp.
//!
//! Beside "first step seen at" this says what any navigability rule and any pyramid had to
//! work with: a map shows the first step from its own returns no sooner than a sweep that lit
//! it ends. (A coarse cell can show it sooner from the flight's upper risers, which this does
//! not count.)

use super::StairsSetup;
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid_host_tests::sim::lidar::{HitBox, TrueHit};
use terrain_pyramid_host_tests::sim::scene::StairsSpec;

/// The distance from which the first step's sighting is asked, metres.
pub const FAR_M: f64 = 4.0;

/// The run over which the default stairs' riser rises at the plane rule's largest grade,
/// metres, and that rise: ground returns farther before the riser than this rise to the step
/// less steeply than a ramp the robot climbs.
#[must_use]
pub fn ramp_run_m() -> (f64, f64) {
    let rise = StairsSpec::default().rise_m;
    let grade = terrain_pyramid::classify::PlaneRule::DEFAULT
        .max_grade
        .to_num::<f64>();
    (rise / grade, rise)
}

/// One line that lit the first step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LitLine {
    /// The robot's distance from the first riser when the line swept it, metres.
    pub distance_m: f64,
    /// The line's returns on the first step (riser face or first tread, above the step
    /// threshold).
    pub returns: usize,
    /// Of those, the returns on the riser's face (below the tread's top by more than 1 cm).
    pub on_face: usize,
    /// The nearest the same sweep's returns came to the first riser on the ground before it,
    /// metres (null: none within 3 m): over less than `step / max_grade` (0.47 m for a
    /// 0.17 m riser at the plane rule's 20°) the rise to the step is steeper than a robot
    /// climbs; over more, a sweep's returns hold it as well as a ramp's.
    pub ground_gap_m: Option<f64>,
    /// Whether the robot was still standing.
    pub standing: bool,
    /// The robot's distance from the first riser when the map next integrated an observation
    /// after the line (on a nodding rig, when the servo turned), metres: no map shows the
    /// line's evidence before (`None`: the recording ended first).
    pub sweep_end_m: Option<f64>,
}

/// The first step as the laser lit it over one stairs run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RiserSight {
    /// Every line that lit the first step, in time order.
    pub lines: Vec<LitLine>,
}

/// A stairs run's first step as the laser lit it, in brief (the report's and the JSON's).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Lit {
    /// Lines that lit the first step while the robot stood.
    pub standing_lines: usize,
    /// Lines that lit it from [`FAR_M`] or more while the robot drove.
    pub driving_lines_from_far: usize,
    /// The farthest distance a line lit it from while the robot drove, metres (null: none).
    pub farthest_driving_m: Option<f64>,
    /// The farthest distance at which a sweep that lit it while the robot drove ended, metres
    /// (null: none did, or the recording ended first): the farthest a map integrating each
    /// sweep at its turn can first show the first step from what it saw of the first step
    /// while driving.
    pub farthest_sweep_end_m: Option<f64>,
    /// Of the lines that lit it while the robot drove and whose sweep ended [`FAR_M`] or more
    /// before the riser, the nearest their sweeps' returns came to the riser on the ground
    /// before it, metres (null: no such line, or no ground within 3 m).
    pub far_ground_gap_m: Option<f64>,
}

impl RiserSight {
    /// The run in brief.
    #[must_use]
    pub fn summary(&self) -> Lit {
        let driving = || self.lines.iter().filter(|l| !l.standing);
        Lit {
            standing_lines: self.lines.iter().filter(|l| l.standing).count(),
            driving_lines_from_far: driving().filter(|l| l.distance_m >= FAR_M).count(),
            farthest_driving_m: driving().map(|l| l.distance_m).reduce(f64::max),
            farthest_sweep_end_m: driving().filter_map(|l| l.sweep_end_m).reduce(f64::max),
            far_ground_gap_m: driving()
                .filter(|l| l.sweep_end_m.is_some_and(|d| d >= FAR_M))
                .filter_map(|l| l.ground_gap_m)
                .reduce(f64::min),
        }
    }
}

/// How far before the first riser the ground is watched, metres.
const GROUND_BEFORE_M: f64 = 3.0;

/// The box the run keeps returns from: the stairs' width, from [`GROUND_BEFORE_M`] before the
/// first riser to the end of the first tread, from the ground to the tread's top.
fn watched_box(spec: &StairsSpec) -> HitBox {
    let half = 0.5 * spec.width_m;
    HitBox {
        min: [spec.first_riser_x - GROUND_BEFORE_M, -half, -0.01],
        max: [spec.first_riser_x + spec.run_m, half, spec.rise_m + 0.005],
    }
}

/// Whether a kept return lies on the first step (its riser's face or its tread) at least
/// `step_m` up.
fn on_step(spec: &StairsSpec, step_m: f64, p: [f64; 3]) -> bool {
    p[0] >= spec.first_riser_x - 0.005 && p[2] >= step_m
}

/// Whether a kept return lies on the flat ground before the first riser.
fn on_ground_before(spec: &StairsSpec, p: [f64; 3]) -> bool {
    p[0] < spec.first_riser_x - 0.005 && p[2] < 0.01
}

/// Groups hits into lines: a gap longer than half the lidar's revolution starts a new line.
fn group(hits: &[TrueHit], revolution_s: f64) -> Vec<Vec<TrueHit>> {
    let mut lines: Vec<Vec<TrueHit>> = Vec::new();
    for h in hits {
        match lines.last_mut() {
            Some(line)
                if line
                    .last()
                    .is_some_and(|p| h.t_s - p.t_s < 0.5 * revolution_s) =>
            {
                line.push(*h);
            }
            _ => lines.push(vec![*h]),
        }
    }
    lines
}

/// The first step of `setup`'s stairs.
fn first_step(setup: &StairsSetup) -> StairsSpec {
    StairsSpec {
        first_riser_x: setup.scene_config().scene.target_x.unwrap_or(0.0),
        ..StairsSpec::default()
    }
}

/// The box a stairs run of `setup` keeps the true points of (its simulation's `hit_box`).
#[must_use]
pub fn hit_box(setup: &StairsSetup) -> HitBox {
    watched_box(&first_step(setup))
}

/// Reads the returns a stairs run of `setup` kept in its [`hit_box`] against the times
/// (seconds) at which its map integrated an observation, and groups those on the first step
/// into lines.
#[must_use]
pub fn sight(
    setup: &StairsSetup,
    classifier: &ClassifierConfig,
    hits: &[TrueHit],
    integrated_s: &[f64],
) -> RiserSight {
    let spec = first_step(setup);
    let step_m = f64::from(classifier.step_threshold.to_num::<f32>());
    let trajectory = setup.scene_config().trajectory;
    let scene = setup.scene_config().scene;
    let distance_at = |t_s: f64| spec.first_riser_x - trajectory.pose_at(t_s, &scene).x;
    // The observation a time falls in: the integrations before and after it.
    let observation_of = |t_s: f64| {
        let i = integrated_s.partition_point(|&t| t <= t_s);
        let start = i
            .checked_sub(1)
            .and_then(|j| integrated_s.get(j))
            .copied()
            .unwrap_or(0.0);
        (start, integrated_s.get(i).copied())
    };
    let ground: Vec<&TrueHit> = hits
        .iter()
        .filter(|h| on_ground_before(&spec, h.point_m))
        .collect();
    let step: Vec<TrueHit> = hits
        .iter()
        .filter(|h| on_step(&spec, step_m, h.point_m))
        .copied()
        .collect();
    let revolution_s = 1.0 / setup.kind.rotation_hz();
    let lines = group(&step, revolution_s)
        .iter()
        .filter_map(|line| {
            let first = line.first()?;
            let last = line.last()?;
            let (start, end) = observation_of(last.t_s);
            let ground_gap_m = ground
                .iter()
                .filter(|h| h.t_s > start && end.is_none_or(|e| h.t_s <= e))
                .map(|h| spec.first_riser_x - h.point_m[0])
                .reduce(f64::min);
            Some(LitLine {
                distance_m: distance_at(first.t_s),
                sweep_end_m: end.map(distance_at),
                returns: line.len(),
                on_face: line
                    .iter()
                    .filter(|h| h.point_m[2] < spec.rise_m - 0.01)
                    .count(),
                ground_gap_m,
                standing: first.t_s < setup.stand_s,
            })
        })
        .collect();
    RiserSight { lines }
}

#[cfg(test)]
mod tests {
    use super::super::{nod_period_s, run_stairs, PHASES, RIGS};
    use super::*;

    #[test]
    fn the_ramp_run_is_the_default_stairs_at_the_plane_rules_grade() {
        let (run, rise) = ramp_run_m();
        assert!((rise - 0.17).abs() < 1e-12);
        assert!((run - 0.17 / 0.363_97).abs() < 1e-3, "{run}");
    }

    #[test]
    fn returns_sort_into_the_step_and_the_ground_before_it() {
        let spec = StairsSpec::default();
        let x = spec.first_riser_x;
        assert!(on_step(&spec, 0.05, [x, 0.0, 0.1]));
        assert!(on_step(&spec, 0.05, [x + 0.2, 0.0, 0.17]));
        assert!(!on_step(&spec, 0.05, [x, 0.0, 0.03]));
        assert!(on_ground_before(&spec, [x - 0.5, 0.0, 0.0]));
        assert!(!on_ground_before(&spec, [x + 0.1, 0.0, 0.0]));
        let watched = watched_box(&spec);
        assert!(watched.contains([x - 2.9, 1.5, 0.0]));
        assert!(!watched.contains([x - 3.1, 0.0, 0.0]));
        assert!(!watched.contains([x + 0.4, 0.0, 0.34]));
    }

    #[test]
    fn hits_group_into_lines_by_the_revolution() {
        let hit = |t_s| TrueHit {
            t_s,
            point_m: [0.0; 3],
        };
        let hits = [hit(0.0), hit(0.01), hit(0.1), hit(0.11), hit(0.3)];
        let lines = group(&hits, 0.1);
        let sizes: Vec<usize> = lines.iter().map(Vec::len).collect();
        assert_eq!(sizes, [2, 2, 1]);
    }

    /// Prints, for every nodding rig and the 8 phases of the nod after 120 s of standing, the
    /// lines that lit the first step. `RISER_SIGHT_STAND_S` = the first phase's standing time
    /// (default 120 s).
    #[test]
    #[ignore = "a diagnostic, a minute long: run by hand"]
    fn riser_sight() {
        let from: f64 = std::env::var("RISER_SIGHT_STAND_S")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(120.0);
        let handle = std::thread::Builder::new()
            .stack_size(512 << 20)
            .spawn(move || print_phases(from))
            .unwrap();
        handle.join().unwrap();
    }

    /// Every rig's 8 phases after `from` seconds of standing, one line each.
    fn print_phases(from: f64) {
        let classifier = ClassifierConfig::default();
        for (kind, name) in RIGS {
            let (_, range) = kind.range_m();
            #[allow(clippy::cast_precision_loss)]
            for i in 0..PHASES {
                let stand_s = from + nod_period_s(kind) * i as f64 / PHASES as f64;
                let setup = StairsSetup {
                    stand_s: (stand_s * 1000.0).round() / 1000.0,
                    kind,
                    range_m: range,
                    stand_distance_m: range - 0.95,
                    ..StairsSetup::FULL
                };
                let sight = run_stairs(&setup, &classifier, None).unwrap().sight;
                let lit = sight.summary();
                let driving: Vec<String> = sight
                    .lines
                    .iter()
                    .filter(|l| !l.standing)
                    .map(|l| {
                        format!(
                            "{:.2}:{}/{} (sweep ends {:.2}, ground gap {:.2})",
                            l.distance_m,
                            l.on_face,
                            l.returns,
                            l.sweep_end_m.unwrap_or(f64::NAN),
                            l.ground_gap_m.unwrap_or(f64::NAN)
                        )
                    })
                    .collect();
                println!(
                    "{name} {:.3} s: standing lines {}, driving from ≥ {FAR_M} m {}, farthest {:?}; {}",
                    setup.stand_s,
                    lit.standing_lines,
                    lit.driving_lines_from_far,
                    lit.farthest_driving_m,
                    driving.join(" ")
                );
            }
        }
    }
}
