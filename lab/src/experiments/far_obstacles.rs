//! Far obstacles: how far out each kind of obstacle is marked, and clear ground read
//! navigable, under each of the library's navigability rules.
//!
//! The car's 68-beam ring laser (`RingLaser::car(0.02)`: h 1.3 m, beams every 0.4° from
//! −24.8° to +2.0°, 0.2° azimuth step, σ 2 cm, 20 m) on the simulated street
//! (`Scene::street(0.05)`: a cambered road with 15 cm and 10 cm curbs at |y| = 3.5 m, a kerb
//! cut, two poles, a parked car, stairs, a 15° ramp, a facade), one revolution from each of
//! several places along the road (x = −4, 3, 10 m with `--quick`; −4, 0, 3, 6, 10, 14 m
//! otherwise), each revolution into a fresh pyramid of the street design (`--max-range-m 20
//! --gamma 3 --height-m 1.3 --phi-deg 0.4 --psi-deg 0.2 --sigma-m 0.02 --cells 128`) through
//! the library's classifier (fixed point), once with the default plane rule and once with the
//! paper's spread rule. The laser fires beam over beam at each azimuth step, so the plane
//! rule pairs each return with the last three of its cell (`PlaneRule::pair_depth`, as
//! `pyramid replay` sets it for a spinning laser's file); the SICK and the nodding lidars
//! ([`rigs`]) with the last.
//!
//! The score is the fused map at the returns
//! ([`terrain_pyramid_host_tests::navigability::rings`]): a return on clear navigable ground
//! (a truly navigable 0.1 m cell with no feature within 0.5 m) is right when the fused map
//! reads navigable there; a return on a true obstacle cell is marked when an obstacle cell of
//! the fused map lies within 0.2 m. The counts are split by the return's horizontal distance
//! from the laser (rings 0–5, 5–10, 10–15, 15–20 m) and by the kind of the obstacle cell's
//! tallest feature: curb (the curbs, the kerb cut's and the ramp's sides), post (the poles),
//! step edge (the stairs), block (the parked car, the facade), other (a slope beyond 20° with
//! no feature, a ditch). Per rule: clear ground navigable % (again in ground-only cells: those
//! whose fused answer came from a map cell holding no feature), and per kind and ring the returns,
//! those marked and the share.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-lab -- experiments --far-obstacles-only [--quick] --out DIR [--json]
//! ```
//! A real laser's beams are calibrated only so well: `--elevation-bias-deg DEG` and
//! `--range-bias-m M` draw each beam's elevation error and range offset once (σ DEG and M),
//! as `host-tests/examples/terrain_rules` does for its car bench (0.1°, 2 cm). The calibration
//! errors are the car laser's alone.
//!
//! The same street is then driven by the paper's SICK and the nodding lidars
//! ([`rigs`], `rigs` in the results), scored the same way.
//! (`lab experiments` runs it among the others: its table in `DIR/report.md`, its results
//! under `far_obstacles` in `DIR/results.json` and in the `--json` object.)

pub mod rigs;
pub mod witnessed;

use super::stairs::round3;
use serde::Serialize;
use std::fmt::Write as _;
use terrain_pyramid::classify::{Classifier, ClassifierConfig, NavigabilityRule, PlaneRule};
use terrain_pyramid::{Design, Pyramid};
use terrain_pyramid_host_tests::navigability::rings::{
    ring_name, Count, ObstacleKind, RingTally, RINGS,
};
use terrain_pyramid_host_tests::navigability::{
    self, far_obstacles, fused_points, integrate_library, Tally,
};
use terrain_pyramid_host_tests::sim::cloud::{car_design, Observation, RingLaser};
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Pose;

/// A return of a rig's run: its time (seconds since the run's start) and true point (world
/// metres).
pub(crate) type Hit = (f64, [f64; 3]);

/// Layer capacity of the street design (γ 3 to 20 m needs fewer).
const L: usize = 16;
/// Cells per layer side.
const W: usize = 128;
/// The library classifier's slots: a whole revolution of the car laser in one observation.
const SLOTS: usize = 65_536;
/// The robot's height: the overhang cut and the truth's obstacles below it, metres.
pub(crate) const ROBOT_HEIGHT_M: f64 = 1.0;
/// Clear ground: no feature within this distance, metres.
pub(crate) const CLEAR_M: f64 = 0.5;
/// The laser's and the design's range, metres.
const MAX_RANGE_M: f64 = 20.0;

/// What the experiment runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setup {
    /// The car's places along the road (y = 0), metres.
    pub xs: Vec<f64>,
    /// The simulator's seed.
    pub seed: u64,
    /// The street's swell amplitude, metres.
    pub swell_m: f64,
    /// The laser's range noise σ (and the design's σ), metres.
    pub sigma_m: f64,
    /// The standard deviation of each beam's elevation error (a calibration error, drawn
    /// once per beam and kept for every revolution), degrees, ≥ 0; 0 for a perfect laser.
    pub elevation_bias_deg: f64,
    /// The standard deviation of each beam's range offset (drawn once per beam), metres,
    /// ≥ 0; 0 for a perfect laser.
    pub range_bias_m: f64,
}

impl Setup {
    /// `--quick`: three places (the terrain rules' car bench).
    #[must_use]
    pub fn quick(seed: u64) -> Self {
        Self {
            xs: vec![-4.0, 3.0, 10.0],
            seed,
            swell_m: 0.05,
            sigma_m: 0.02,
            elevation_bias_deg: 0.0,
            range_bias_m: 0.0,
        }
    }

    /// The full run: six places.
    #[must_use]
    pub fn full(seed: u64) -> Self {
        Self {
            xs: vec![-4.0, 0.0, 3.0, 6.0, 10.0, 14.0],
            ..Self::quick(seed)
        }
    }
}

/// One ring's counts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RingCount {
    /// The ring, `"0-5 m"`.
    pub ring: String,
    /// Returns counted.
    pub points: usize,
    /// Of those, right (clear ground read navigable; an obstacle marked).
    pub right: usize,
    /// The share right, percent (`None` with no returns).
    pub pct: Option<f64>,
}

impl RingCount {
    fn new(ring: String, c: &Count) -> Self {
        Self {
            ring,
            points: c.points,
            right: c.right,
            pct: (c.points > 0).then(|| round3(c.pct())),
        }
    }
}

/// One obstacle kind's counts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KindResult {
    /// The kind: `curb`, `post`, `step edge`, `block` or `other`.
    pub kind: &'static str,
    /// Per ring: returns on the kind's cells, marked, percent.
    pub rings: Vec<RingCount>,
    /// Over every ring.
    pub all: RingCount,
}

/// One rule's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RuleResult {
    /// The rule: `plane (default)` or `spread (paper)`.
    pub rule: &'static str,
    /// Clear ground read navigable, percent, over every ring.
    pub ground_navigable_pct: Option<f64>,
    /// Clear ground per ring.
    pub ground: Vec<RingCount>,
    /// Clear ground in ground-only cells read navigable, percent, over every ring: the clear
    /// ground whose fused answer came from a map cell that holds no feature below the robot's
    /// height (or from none), the ground the map's own cells could tell apart
    /// ([`terrain_pyramid_host_tests::navigability::rings`]).
    pub ground_only_navigable_pct: Option<f64>,
    /// Clear ground in ground-only cells per ring.
    pub ground_only: Vec<RingCount>,
    /// Every obstacle kind.
    pub kinds: Vec<KindResult>,
    /// Every kind per ring.
    pub obstacles: Vec<RingCount>,
    /// `fused_points` over the same returns (20 m): the rings and kinds sum to it.
    pub fused_points: Totals,
}

/// [`Tally`] as JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Totals {
    /// Returns on clear navigable ground.
    pub navigable: usize,
    /// Of those, read navigable.
    pub navigable_ok: usize,
    /// Returns on true obstacle cells.
    pub obstacle: usize,
    /// Of those, marked.
    pub obstacle_ok: usize,
}

impl From<Tally> for Totals {
    fn from(t: Tally) -> Self {
        Self {
            navigable: t.navigable,
            navigable_ok: t.navigable_ok,
            obstacle: t.obstacle,
            obstacle_ok: t.obstacle_ok,
        }
    }
}

/// The `far_obstacles` section of `results.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FarObstaclesResult {
    /// What ran.
    pub setup: Setup,
    /// The rings' names.
    pub rings: Vec<String>,
    /// Per rule.
    pub rules: Vec<RuleResult>,
    /// The most any rule could mark on each revolution ([`witnessed`]): the witness pairs of
    /// the true points of its returns (where each beam met the scene), scored at the returns
    /// as the maps are.
    pub bound: RuleResult,
    /// The same street seen by the SICK and the nodding lidars from a driving robot
    /// ([`rigs`]).
    pub rigs: Vec<rigs::RigResult>,
}

/// The street design: φ 0.4°, ψ 0.2°, σ `sigma_m`, h 1.3 m, 20 m, γ 3, 128 cells.
///
/// # Errors
/// When the library refuses the design.
pub fn design(sigma_m: f32) -> Result<Design<L>, String> {
    car_design(sigma_m, W).map_err(|e| format!("the street design: {e:?}"))
}

/// One revolution of the car laser from each place of `setup` on `scene`, and its returns'
/// true points.
fn scans(setup: &Setup, scene: &Scene) -> Vec<(Observation, Observation)> {
    let laser = RingLaser {
        elevation_bias_deg: setup.elevation_bias_deg,
        range_bias_m: setup.range_bias_m,
        ..RingLaser::car(setup.sigma_m)
    };
    let mut rng = Rng::new(setup.seed);
    setup
        .xs
        .iter()
        .map(|&x| {
            let pose = Pose {
                x,
                z: scene.ground_height(x, 0.0),
                ..Pose::default()
            };
            laser.scan_with_truth(scene, &pose, &mut rng)
        })
        .collect()
}

/// The rules measured, with their names.
pub const RULES: [(&str, NavigabilityRule); 2] = [
    (
        "plane (default)",
        NavigabilityRule::Plane(PlaneRule::DEFAULT),
    ),
    ("spread (paper)", NavigabilityRule::Spread),
];

/// Runs the experiment. Needs a large stack (the classifier's 3 MiB scratch and the pyramids
/// are built in place before they are boxed): `lab experiments` runs it on its own thread.
///
/// # Errors
/// A design the library refused, or a classifier whose scratch overflowed.
pub fn run(setup: &Setup) -> Result<FarObstaclesResult, String> {
    #[allow(clippy::cast_possible_truncation)]
    let design = design(setup.sigma_m as f32)?;
    let scene = Scene::street(setup.swell_m);
    let (observations, true_returns): (Vec<Observation>, Vec<Observation>) =
        scans(setup, &scene).into_iter().unzip();
    let mut classifier: Box<Classifier<SLOTS, L>> = navigability::classifier(&design);
    let mut rules = Vec::new();
    for (name, rule) in RULES {
        classifier.configure(ClassifierConfig {
            rule: rule.for_firing_order(),
            ..ClassifierConfig::default()
        });
        let mut tally = RingTally::default();
        let mut points = Tally::default();
        for obs in &observations {
            let mut p: Box<Pyramid<W, L>> = navigability::pyramid(&design);
            integrate_library(&mut p, obs, &mut classifier);
            if classifier.stats().overflow_points != 0 {
                return Err(format!("{name}: the classifier's scratch overflowed"));
            }
            let one = std::slice::from_ref(obs);
            tally.add(&far_obstacles(&p, &scene, one, CLEAR_M, ROBOT_HEIGHT_M));
            points.add(&fused_points(
                &p,
                &scene,
                one,
                MAX_RANGE_M,
                CLEAR_M,
                ROBOT_HEIGHT_M,
            ));
        }
        rules.push(rule_result(name, &tally, points));
    }
    let mut bound = RingTally::default();
    for (truth, measured) in true_returns.iter().zip(&observations) {
        bound.add(&witnessed::of_observation(truth, measured, &scene));
    }
    Ok(FarObstaclesResult {
        setup: setup.clone(),
        rings: (0..RINGS).map(ring_name).collect(),
        rules,
        bound: rule_result(witnessed::REVOLUTION, &bound, bound.total()),
        rigs: rigs::run(setup)?,
    })
}

pub(crate) fn rule_result(name: &'static str, t: &RingTally, points: Tally) -> RuleResult {
    let per_ring = |f: &dyn Fn(usize) -> Count| -> Vec<RingCount> {
        (0..RINGS)
            .map(|r| RingCount::new(ring_name(r), &f(r)))
            .collect()
    };
    let ground = t.ground_total();
    let ground_only = t.ground_only_total();
    RuleResult {
        rule: name,
        ground_navigable_pct: (ground.points > 0).then(|| round3(ground.pct())),
        ground: per_ring(&|r| t.ground[r]),
        ground_only_navigable_pct: (ground_only.points > 0).then(|| round3(ground_only.pct())),
        ground_only: per_ring(&|r| t.ground_only[r]),
        kinds: ObstacleKind::ALL
            .iter()
            .map(|&k| KindResult {
                kind: k.name(),
                rings: per_ring(&|r| t.obstacles[k.index()][r]),
                all: RingCount::new("all".into(), &t.kind_total(k)),
            })
            .collect(),
        obstacles: per_ring(&|r| t.ring_obstacles(r)),
        fused_points: points.into(),
    }
}

fn cell(c: &RingCount) -> String {
    match c.pct {
        Some(p) => format!("{p:.1} % ({} / {})", c.right, c.points),
        None => "–".into(),
    }
}

/// The experiment's table, Markdown: per rule, clear ground and each kind by ring.
#[must_use]
pub fn table(r: &FarObstaclesResult) -> String {
    let mut s = String::new();
    let xs: Vec<String> = r.setup.xs.iter().map(|x| format!("{x}")).collect();
    let _ = writeln!(
        s,
        "## Far obstacles: marked and clear by range ring\n\nThe car laser (h 1.3 m, 68 beams \
         every 0.4°, 0.2° azimuth, σ {} m, per-beam calibration errors σ {}° in elevation and \
         {} m in range, 20 m) on the street (swell {} m), one revolution from x = {} m, each into a fresh pyramid of the street design (γ 3, 20 m, 128 cells) \
         through the library's classifier. Clear ground: returns on truly navigable 0.1 m cells \
         with no feature within 0.5 m, right when the fused map reads navigable; again in \
         ground-only cells, those whose answer came from a map cell holding no feature (a far \
         cell that holds a curb is an obstacle cell, and the road beside it within the cell \
         ground it cannot resolve). Obstacles: \
         returns on true obstacle cells by the kind of the cell's tallest feature, marked when \
         an obstacle cell of the fused map lies within 0.2 m. Each entry: % (right / returns); \
         rings by the return's horizontal distance from the laser.",
        r.setup.sigma_m,
        r.setup.elevation_bias_deg,
        r.setup.range_bias_m,
        r.setup.swell_m,
        xs.join(", ")
    );
    rule_tables(&mut s, "###", &r.rings, &r.rules);
    s.push_str(witnessed::REVOLUTION_TEXT);
    rule_tables(&mut s, "###", &r.rings, std::slice::from_ref(&r.bound));
    for rig in &r.rigs {
        s.push_str(&rigs::heading(rig, &r.setup));
        rule_tables(&mut s, "####", &r.rings, &rig.rules);
        if let Some(b) = &rig.bounds {
            s.push_str(witnessed::TEXT);
            rule_tables(
                &mut s,
                "####",
                &r.rings,
                &[b.one_observation.clone(), b.every_return.clone()],
            );
        }
    }
    s
}

/// Per rule, under heading `level`: clear ground and each kind by ring.
fn rule_tables(s: &mut String, level: &str, rings: &[String], rules: &[RuleResult]) {
    for rule in rules {
        let pct = |p: Option<f64>| p.map_or_else(|| "–".to_string(), |p| format!("{p:.1} %"));
        let _ = writeln!(
            *s,
            "\n{level} {}: clear ground navigable {} (in ground-only cells {})\n",
            rule.rule,
            pct(rule.ground_navigable_pct),
            pct(rule.ground_only_navigable_pct),
        );
        let _ = writeln!(*s, "| returns on | {} | all |", rings.join(" | "));
        let _ = writeln!(*s, "| --- |{}", " --- |".repeat(rings.len() + 1));
        let mut line = |name: &str, rings: &[RingCount], all: &RingCount| {
            let cells: Vec<String> = rings.iter().map(cell).collect();
            let _ = writeln!(*s, "| {name} | {} | {} |", cells.join(" | "), cell(all));
        };
        line(
            "clear ground (navigable)",
            &rule.ground,
            &all_rings(&rule.ground),
        );
        line(
            "clear ground in ground-only cells",
            &rule.ground_only,
            &all_rings(&rule.ground_only),
        );
        for k in &rule.kinds {
            line(k.kind, &k.rings, &k.all);
        }
        line(
            "every obstacle (marked)",
            &rule.obstacles,
            &all_rings(&rule.obstacles),
        );
    }
}

/// A row's rings summed into its "all" entry.
fn all_rings(rings: &[RingCount]) -> RingCount {
    let all = Count {
        points: rings.iter().map(|c| c.points).sum(),
        right: rings.iter().map(|c| c.right).sum(),
    };
    RingCount::new("all".into(), &all)
}
