//! The most any navigability rule could mark on the street
//! ([`terrain_pyramid_host_tests::navigability::witness`]), scored as the maps are
//! ([`super`], [`super::rigs`]): a map that reads obstacle in the 0.1 m cells of the witness
//! pairs' upper returns, navigable everywhere else.
//!
//! For a rig's run, two bounds, from the laser's true returns (no noise) with the library's
//! allowances (20°, 5 cm, the robot's 1 m):
//! - **one observation**: the pairs within each observation the pipeline ended, kept as the
//!   map keeps its verdicts: what a rule that judges one observation at a time (the
//!   library's classifier) could mark;
//! - **every return**: the pairs between any two returns so far, what a map that kept every
//!   return's height with perfect poses could mark.
//!
//! The car's revolutions, each into a fresh map, have one bound (`of_observation`): the
//! pairs of the revolution's returns.

use super::{rule_result, Hit, RuleResult, CLEAR_M, ROBOT_HEIGHT_M};
use serde::Serialize;
use std::collections::HashSet;
use terrain_pyramid::Fused;
use terrain_pyramid_host_tests::navigability::rings::{far_obstacles_with, square_cell, RingTally};
use terrain_pyramid_host_tests::navigability::witness::{witnesses, PastReturns, Witness};
use terrain_pyramid_host_tests::sim::cloud::Observation;
use terrain_pyramid_host_tests::sim::scene::Scene;

/// The two bounds of one rig's run, as the rules' results.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bounds {
    /// Witness pairs within one observation (`rule`: [`ONE`]).
    pub one_observation: RuleResult,
    /// Witness pairs between any returns so far (`rule`: [`EVERY`]).
    pub every_return: RuleResult,
}

/// [`Bounds::one_observation`]'s name.
pub const ONE: &str = "bound: one observation's returns";
/// [`Bounds::every_return`]'s name.
pub const EVERY: &str = "bound: every return so far";

/// [`super::FarObstaclesResult::bound`]'s name.
pub const REVOLUTION: &str = "bound: the revolution's returns";

/// The report's paragraph before the car's bound (Markdown).
pub(crate) const REVOLUTION_TEXT: &str = "\nThe most any rule could mark on each revolution, \
    one that keeps every surface no steeper than 20° with steps of at most 5 cm navigable, at \
    the same returns: a return marked where, within 0.2 m, lies the upper point of a witness \
    pair (the true points of two returns, where the beams met the scene, rising more steeply \
    than 20° and by more than 5 cm, by no more than 1 m); clear ground right unless one lies \
    in its 0.1 m cell.\n";

/// The report's paragraph before a rig's bounds (Markdown).
pub(crate) const TEXT: &str = "\nThe most any rule could mark on the same returns, one that \
    keeps every surface no steeper than 20° with steps of at most 5 cm navigable: a return is \
    marked where, within 0.2 m, lies the upper return of a witness pair (two of the laser's \
    true returns rising more steeply than 20° and by more than 5 cm, by no more than 1 m); \
    clear ground is right unless one lies in its 0.1 m cell. Pairs within one observation (the \
    library's classifier judges one at a time), or between any two returns so far (a map \
    that kept every height, with perfect poses). The design's range does not apply.\n";

/// The witnesses of a run so far and the bounds' tallies.
#[derive(Default)]
pub(super) struct Witnessed {
    /// The 0.1 m cells of the upper returns of pairs within one observation.
    one: HashSet<(i64, i64)>,
    /// The same of pairs between any two returns so far.
    every: HashSet<(i64, i64)>,
    /// The returns of the observations so far.
    past: PastReturns,
    /// The end of the last observation, seconds.
    since: Option<f64>,
    /// The bounds' counts so far.
    one_tally: RingTally,
    every_tally: RingTally,
}

/// The scoring's 0.1 m cell of a point (as [`far_obstacles_with`] queries its cells' centres).
#[allow(clippy::cast_possible_truncation)]
fn cell_of(x: f64, y: f64) -> (i64, i64) {
    ((x / 0.1).floor() as i64, (y / 0.1).floor() as i64)
}

/// The map that reads obstacle in `cells` (0.1 m) and navigable elsewhere, scored at the
/// returns of `obs`.
fn marked_at(cells: &HashSet<(i64, i64)>, obs: &Observation, scene: &Scene) -> RingTally {
    far_obstacles_with(
        |x, y| {
            if cells.contains(&cell_of(x, y)) {
                Fused::Obstacle { layer: 0 }
            } else {
                Fused::Navigable { layer: 0 }
            }
        },
        |_, x, y| Some(square_cell(0.1, x, y)),
        scene,
        std::slice::from_ref(obs),
        CLEAR_M,
        ROBOT_HEIGHT_M,
    )
}

/// The bound of one observation by its own, [`Witnessed`]'s "one observation" for a map that
/// sees nothing else (the car's revolutions, each into a fresh map): the witness pairs of the
/// true points `truth` of its returns, scored at the returns `measured` as the map is.
pub(super) fn of_observation(
    truth: &Observation,
    measured: &Observation,
    scene: &Scene,
) -> RingTally {
    let cells: HashSet<(i64, i64)> = witnesses(&truth.points, &Witness::library())
        .iter()
        .map(|p| cell_of(p[0], p[1]))
        .collect();
    marked_at(&cells, measured, scene)
}

impl Witnessed {
    /// An observation ended at `t_s`: its returns are those of `hits` since the last one's end.
    pub(super) fn observation_ended(&mut self, hits: &[Hit], t_s: f64) {
        let since = self.since.unwrap_or(f64::NEG_INFINITY);
        let points: Vec<[f64; 3]> = hits
            .iter()
            .filter(|(t, _)| *t > since && *t <= t_s)
            .map(|h| h.1)
            .collect();
        let w = Witness::library();
        let own = witnesses(&points, &w);
        let with_past = self.past.witnesses_then_keep(&points, &w);
        self.one.extend(own.iter().map(|p| cell_of(p[0], p[1])));
        self.every
            .extend(own.iter().chain(&with_past).map(|p| cell_of(p[0], p[1])));
        self.since = Some(t_s);
    }

    /// Scores both bounds at the returns of `obs`, as the rigs' maps are scored.
    pub(super) fn score(&mut self, obs: &Observation, scene: &Scene) {
        self.one_tally.add(&marked_at(&self.one, obs, scene));
        self.every_tally.add(&marked_at(&self.every, obs, scene));
    }

    /// The bounds as results.
    pub(super) fn bounds(&self) -> Bounds {
        Bounds {
            one_observation: rule_result(ONE, &self.one_tally, self.one_tally.total()),
            every_return: rule_result(EVERY, &self.every_tally, self.every_tally.total()),
        }
    }
}
