//! The fused map at the returns, by range ring and by obstacle kind: [`fused_points`]'s
//! counts split by each return's horizontal distance from its sensor (rings 0–5, 5–10, 10–15
//! and 15–20 m) and, for the returns on a true obstacle cell, by the kind of the cell's
//! tallest feature (curb, post, step edge, block, other).
//!
//! The judgement of a return is [`fused_points`]'s: on truly navigable ground clear of every
//! feature by `clear_m`, right when the fused answer at its 0.1 m cell is navigable; on a true
//! obstacle cell, marked when an obstacle cell of the fused map lies within 0.2 m (the cell's
//! neighbours up to two cells away); on anything else (a feature lower than the truth's
//! obstacle step, or navigable ground near a feature), not counted. Summed over the rings and
//! kinds the counts are [`fused_points`]'s with a 20 m range ([`RingTally::total`]).
//!
//! The clear ground again in **ground-only cells**: the returns on it whose fused answer came
//! from a map cell clear of every feature below the robot's height (or from no cell: the map
//! did not know the place). A map's cells coarsen with range, and a far cell that holds a
//! curb is an obstacle cell however much road it holds besides: the road beside the curb
//! within it is clear ground (no feature within `clear_m` of its 0.1 m cell) that the map
//! cannot resolve, and those returns leave this row. The rest are the navigable ground the
//! map's own cells could have told apart, as `host-tests/examples/semantic_kitti` counts real
//! streets.
//!
//! [`fused_points`]: super::fused_points

use super::Tally;
use crate::sim::cloud::Observation;
use crate::sim::scene::{FeatureKind, Scene};
use crate::sim::terrain::{cell_truth, clear_of_features, Rect, Truth};
use std::collections::BTreeMap;
use terrain_pyramid::{Fused, Meters, Pyramid, Resolution};

/// The rings' edges, metres: ring r holds the returns at a horizontal distance d from their
/// sensor with `RING_EDGES_M[r] ≤ d < RING_EDGES_M[r + 1]` (the last ring includes its outer
/// edge); returns beyond the last edge are not counted.
pub const RING_EDGES_M: [f64; RINGS + 1] = [0.0, 5.0, 10.0, 15.0, 20.0];

/// The number of range rings.
pub const RINGS: usize = 4;

/// The number of obstacle kinds ([`ObstacleKind::ALL`]).
pub const KINDS: usize = 5;

/// The ring of a return at horizontal distance `d_m` from its sensor (`None` beyond the last
/// edge, or for a distance that is not a number).
#[must_use]
pub fn ring_of(d_m: f64) -> Option<usize> {
    if !(0.0..=RING_EDGES_M[RINGS]).contains(&d_m) {
        return None;
    }
    Some(
        RING_EDGES_M[1..RINGS]
            .iter()
            .take_while(|&&edge| d_m >= edge)
            .count(),
    )
}

/// A ring's name, `"0-5 m"`.
#[must_use]
pub fn ring_name(r: usize) -> String {
    match (RING_EDGES_M.get(r), RING_EDGES_M.get(r + 1)) {
        (Some(lo), Some(hi)) => format!("{lo:.0}-{hi:.0} m"),
        _ => String::from("?"),
    }
}

/// The kind of a true obstacle cell, from the truth's tallest feature there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ObstacleKind {
    /// A curb's edge (also a ramp's or a slope's side).
    Curb,
    /// A post.
    Post,
    /// A stair step's edge.
    StepEdge,
    /// A solid block on the ground: the parked car, the facade.
    Block,
    /// Anything else: a ditch, a bar or a branch below the robot's height, or a slope beyond
    /// the truth's limit with no feature.
    Other,
}

impl ObstacleKind {
    /// Every kind, in the tables' order.
    pub const ALL: [Self; KINDS] = [
        Self::Curb,
        Self::Post,
        Self::StepEdge,
        Self::Block,
        Self::Other,
    ];

    /// The kind of a cell whose tallest feature is `kind`.
    #[must_use]
    pub fn of(kind: Option<FeatureKind>) -> Self {
        match kind {
            Some(FeatureKind::Curb) => Self::Curb,
            Some(FeatureKind::Post) => Self::Post,
            Some(FeatureKind::StepEdge) => Self::StepEdge,
            Some(FeatureKind::Block) => Self::Block,
            Some(FeatureKind::Bar | FeatureKind::Ditch | FeatureKind::Branch) | None => Self::Other,
        }
    }

    /// The kind's name in tables and JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Curb => "curb",
            Self::Post => "post",
            Self::StepEdge => "step edge",
            Self::Block => "block",
            Self::Other => "other",
        }
    }

    /// The kind's index in [`ObstacleKind::ALL`].
    #[must_use]
    pub fn index(self) -> usize {
        match self {
            Self::Curb => 0,
            Self::Post => 1,
            Self::StepEdge => 2,
            Self::Block => 3,
            Self::Other => 4,
        }
    }
}

/// Returns counted and, of those, judged right.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Count {
    /// Returns counted.
    pub points: usize,
    /// Of those, judged right (navigable ground read navigable; an obstacle marked).
    pub right: usize,
}

impl Count {
    /// Adds another count.
    pub fn add(&mut self, other: &Self) {
        self.points += other.points;
        self.right += other.right;
    }

    /// The counts summed.
    #[must_use]
    pub fn sum<'a>(counts: impl IntoIterator<Item = &'a Self>) -> Self {
        let mut c = Self::default();
        for k in counts {
            c.add(k);
        }
        c
    }

    /// The share judged right, percent (NaN with none).
    #[must_use]
    pub fn pct(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let v = 100.0 * self.right as f64 / self.points as f64;
        v
    }
}

/// The counts of [`far_obstacles`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RingTally {
    /// Per ring: returns on clear navigable ground, and of those read navigable.
    pub ground: [Count; RINGS],
    /// Per ring: the returns of `ground` whose fused answer came from a map cell clear of
    /// every feature below the robot's height, or from none (unknown), and of those read
    /// navigable (see the module documentation).
    pub ground_only: [Count; RINGS],
    /// Per kind (as [`ObstacleKind::ALL`]), per ring: returns on a true obstacle cell of the
    /// kind, and of those with an obstacle cell of the fused map within 0.2 m.
    pub obstacles: [[Count; RINGS]; KINDS],
}

impl RingTally {
    /// Adds another tally.
    pub fn add(&mut self, other: &Self) {
        for (a, b) in self.ground.iter_mut().zip(&other.ground) {
            a.add(b);
        }
        for (a, b) in self.ground_only.iter_mut().zip(&other.ground_only) {
            a.add(b);
        }
        for (ka, kb) in self.obstacles.iter_mut().zip(&other.obstacles) {
            for (a, b) in ka.iter_mut().zip(kb) {
                a.add(b);
            }
        }
    }

    /// The clear ground over every ring.
    #[must_use]
    pub fn ground_total(&self) -> Count {
        Count::sum(&self.ground)
    }

    /// The clear ground in ground-only cells over every ring.
    #[must_use]
    pub fn ground_only_total(&self) -> Count {
        Count::sum(&self.ground_only)
    }

    /// One kind over every ring.
    #[must_use]
    pub fn kind_total(&self, kind: ObstacleKind) -> Count {
        Count::sum(&self.obstacles[kind.index()])
    }

    /// Every kind in one ring.
    #[must_use]
    pub fn ring_obstacles(&self, r: usize) -> Count {
        Count::sum(self.obstacles.iter().filter_map(|k| k.get(r)))
    }

    /// Everything, as [`fused_points`](super::fused_points) counts it.
    #[must_use]
    pub fn total(&self) -> Tally {
        let ground = self.ground_total();
        let obstacle = Count::sum(self.obstacles.iter().flatten());
        Tally {
            navigable: ground.points,
            navigable_ok: ground.right,
            obstacle: obstacle.points,
            obstacle_ok: obstacle.right,
        }
    }
}

/// The fused map of `pyramid` at the returns of `observations`, by ring and kind (see the
/// module documentation).
#[must_use]
pub fn far_obstacles<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    scene: &Scene,
    observations: &[Observation],
    clear_m: f64,
    robot_height_m: f64,
) -> RingTally {
    far_obstacles_with(
        |x, y| {
            pyramid.fused(
                Meters::saturating_from_num(x),
                Meters::saturating_from_num(y),
            )
        },
        |k, x, y| pyramid_cell(pyramid, k, x, y),
        scene,
        observations,
        clear_m,
        robot_height_m,
    )
}

/// The footprint (metres) of layer `k`'s cell at world point `(x, y)` of `pyramid`: the
/// cells lie on the world's multiples of the layer's size, wherever the window stands
/// (`None`: no layer `k`, or a layer not in force).
#[must_use]
pub fn pyramid_cell<const W: usize, const L: usize>(
    pyramid: &Pyramid<W, L>,
    k: u8,
    x: f64,
    y: f64,
) -> Option<Rect> {
    let r = pyramid.layer(usize::from(k))?.resolution();
    if r == Resolution::UNSET {
        return None;
    }
    let edges = |v: f64| {
        let i = r.cell_of(Meters::saturating_from_num(v));
        (
            r.cell_edge(i).to_num::<f64>(),
            r.cell_edge(i.saturating_add(1)).to_num::<f64>(),
        )
    };
    let ((x_min, x_max), (y_min, y_max)) = (edges(x), edges(y));
    Some(Rect::new(x_min, x_max, y_min, y_max))
}

/// The footprint (metres) of the cell of a grid of `cell_m` squares on the world's multiples
/// of `cell_m` that holds `(x, y)`: [`far_obstacles_with`]'s `cell` for a map of one layer
/// at one cell size.
#[must_use]
pub fn square_cell(cell_m: f64, x: f64, y: f64) -> Rect {
    let (i, j) = ((x / cell_m).floor(), (y / cell_m).floor());
    Rect::new(
        i * cell_m,
        (i + 1.0) * cell_m,
        j * cell_m,
        (j + 1.0) * cell_m,
    )
}

/// [`far_obstacles`] of any map: `fused(x, y)` answers the fused query at a point, metres;
/// `cell(k, x, y)` gives the footprint of layer k's cell there (metres; `None` for a layer
/// the map does not have), for the clear ground in ground-only cells.
#[must_use]
pub fn far_obstacles_with(
    fused: impl Fn(f64, f64) -> Fused,
    cell: impl Fn(u8, f64, f64) -> Option<Rect>,
    scene: &Scene,
    observations: &[Observation],
    clear_m: f64,
    robot_height_m: f64,
) -> RingTally {
    const C: f64 = 0.1;
    #[allow(clippy::cast_precision_loss)]
    let centre = |i: i64| (i as f64 + 0.5) * C;
    let fused_at = |i: i64, j: i64| fused(centre(i), centre(j));
    // Whether the fused answer at 0.1 m cell (i, j) came from a map cell clear of every
    // feature below the robot's height, or from none.
    let ground_only = |answer: Fused, i: i64, j: i64| match answer {
        Fused::Unknown => true,
        Fused::Navigable { layer } | Fused::Obstacle { layer } => cell(layer, centre(i), centre(j))
            .is_none_or(|r| clear_of_features(scene, &r, robot_height_m)),
    };
    #[allow(clippy::cast_possible_truncation)]
    let grow = (clear_m / C).ceil() as i64;
    // Per 0.1 m cell: None = not counted; Some(None) = clear navigable ground; Some(Some(k))
    // = a true obstacle cell of kind k.
    let mut verdict: BTreeMap<(i64, i64), Option<Option<ObstacleKind>>> = BTreeMap::new();
    let mut t = RingTally::default();
    for obs in observations {
        for p in &obs.points {
            let Some(r) = ring_of((p[0] - obs.sensor[0]).hypot(p[1] - obs.sensor[1])) else {
                continue;
            };
            #[allow(clippy::cast_possible_truncation)]
            let (i, j) = ((p[0] / C).floor() as i64, (p[1] / C).floor() as i64);
            let kind = *verdict.entry((i, j)).or_insert_with(|| {
                let truth = cell_truth(scene, C, i, j, robot_height_m);
                match truth.truth() {
                    Truth::Obstacle => Some(Some(ObstacleKind::of(truth.kind))),
                    Truth::Between => None,
                    Truth::Navigable => {
                        #[allow(clippy::cast_precision_loss)]
                        let grown = Rect::new(
                            (i - grow) as f64 * C,
                            (i + 1 + grow) as f64 * C,
                            (j - grow) as f64 * C,
                            (j + 1 + grow) as f64 * C,
                        );
                        clear_of_features(scene, &grown, robot_height_m).then_some(None)
                    }
                }
            });
            match kind {
                Some(None) => {
                    let answer = fused_at(i, j);
                    let right = usize::from(matches!(answer, Fused::Navigable { .. }));
                    t.ground[r].points += 1;
                    t.ground[r].right += right;
                    if ground_only(answer, i, j) {
                        t.ground_only[r].points += 1;
                        t.ground_only[r].right += right;
                    }
                }
                Some(Some(k)) => {
                    let near = (-2..=2).any(|di| {
                        (-2..=2)
                            .any(|dj| matches!(fused_at(i + di, j + dj), Fused::Obstacle { .. }))
                    });
                    let c = &mut t.obstacles[k.index()][r];
                    c.points += 1;
                    c.right += usize::from(near);
                }
                None => {}
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scene::{Feature, Footprint};

    #[test]
    fn rings_split_at_their_edges() {
        assert_eq!(ring_of(0.0), Some(0));
        assert_eq!(ring_of(4.99), Some(0));
        assert_eq!(ring_of(5.0), Some(1));
        assert_eq!(ring_of(14.99), Some(2));
        assert_eq!(ring_of(15.0), Some(3));
        assert_eq!(ring_of(20.0), Some(3));
        assert_eq!(ring_of(20.01), None);
        assert_eq!(ring_of(f64::NAN), None);
        assert_eq!(ring_name(2), "10-15 m");
        for (i, k) in ObstacleKind::ALL.iter().enumerate() {
            assert_eq!(k.index(), i);
        }
    }

    /// Each layer's cell at a point, from the design's cell size (metres, as the design
    /// reports it, rounded to the library's Q16.16): it holds the point, is one cell size
    /// wide, and lies on the world's multiples of that size, wherever the window stands.
    #[test]
    fn a_layers_cell_holds_the_point_on_the_worlds_lattice() {
        let design = crate::sim::cloud::car_design::<16>(0.02, 128).expect("the car's design");
        let p = super::super::pyramid::<128, 16>(&design);
        for (k, layer) in design.layers().iter().enumerate() {
            // The library holds cell sizes in Q16.16: the design's size rounded to 2⁻¹⁶ m.
            let size = (f64::from(layer.resolution_m) * 65_536.0).round() / 65_536.0;
            let k8 = u8::try_from(k).expect("16 layers");
            for &(x, y) in &[(0.05, 0.05), (3.33, -2.71), (-7.9, 11.2)] {
                let r = pyramid_cell(&p, k8, x, y).expect("a layer in force");
                assert!(
                    r.x_min <= x && x < r.x_max && r.y_min <= y && y < r.y_max,
                    "{k}"
                );
                for (lo, hi) in [(r.x_min, r.x_max), (r.y_min, r.y_max)] {
                    assert!(
                        (hi - lo - size).abs() < 1e-9,
                        "layer {k}: {lo}..{hi}, {size}"
                    );
                    let n = lo / size;
                    assert!((n - n.round()).abs() < 1e-9, "layer {k}: {lo} on {size}");
                }
            }
        }
        let beyond = u8::try_from(design.layers().len()).expect("16 layers");
        assert!(pyramid_cell(&p, beyond, 0.0, 0.0).is_none());
    }

    /// Flat ground, a 10 cm curb along x = 4.05 m and a post at (12.05, 0.05); a map that
    /// reads obstacle in the 0.1 m cells with 3.9 ≤ x < 4.0 and the one at (1.05, −3.05),
    /// navigable everywhere else; its layer 0 (0.1 m cells) answers for x < 6 m, its layer 1
    /// (4 m cells) beyond.
    ///
    /// By hand, the sensor at the origin:
    /// - (1.05, 3.05): clear ground (1 m from the curb), read navigable: ring 0, right; in a
    ///   ground-only cell.
    /// - (1.05, −3.05): clear ground read obstacle: ring 0, wrong; in a ground-only cell.
    /// - (4.05, 0.05): the curb's cell (40, 0); the obstacle cell (39, 0) is one cell away:
    ///   ring 0 (4.05 m), marked.
    /// - (4.05, 6.05): the curb's cell (40, 60), 7.30 m out: ring 1, marked.
    /// - (4.25, 0.05): cell (42, 0), 0.15 m past the curb: navigable but within 0.5 m of a
    ///   feature, not counted.
    /// - (12.05, 0.05) twice: the post's cell (120, 0), nothing read obstacle near it: ring 2,
    ///   two points, neither marked.
    /// - (7.05, 0.05): clear ground, read navigable: ring 1, right; but layer 1's cell
    ///   [4, 8) × [0, 4) holds the curb: not in a ground-only cell.
    /// - (19.95, 0.05): clear ground: ring 3, right; layer 1's cell [16, 20) × [0, 4) holds no
    ///   feature: in a ground-only cell. (25.0, 0.05): beyond 20 m, not counted.
    #[test]
    fn a_hand_made_case() {
        let mut scene = Scene::flat();
        scene.features.push(Feature {
            kind: FeatureKind::Curb,
            footprint: Footprint::Rect {
                x_min: 4.05,
                x_max: 4.05,
                y_min: f64::NEG_INFINITY,
                y_max: f64::INFINITY,
            },
            bottom_m: 0.0,
            height_m: 0.10,
        });
        scene.features.push(Feature {
            kind: FeatureKind::Post,
            footprint: Footprint::Disc {
                centre: [12.05, 0.05],
                radius_m: 0.03,
            },
            bottom_m: 0.0,
            height_m: 1.5,
        });
        let obs = Observation {
            sensor: [0.0, 0.0, 1.3],
            ground_z: 0.0,
            points: [
                (1.05, 3.05),
                (1.05, -3.05),
                (4.05, 0.05),
                (4.05, 6.05),
                (4.25, 0.05),
                (12.05, 0.05),
                (12.05, 0.05),
                (7.05, 0.05),
                (19.95, 0.05),
                (25.0, 0.05),
            ]
            .iter()
            .map(|&(x, y)| [x, y, 0.0])
            .collect(),
        };
        let map = |x: f64, y: f64| {
            let layer = u8::from(x >= 6.0);
            if (3.9..4.0).contains(&x) || ((1.0..1.1).contains(&x) && y < 0.0) {
                Fused::Obstacle { layer }
            } else {
                Fused::Navigable { layer }
            }
        };
        let cells = |k: u8, x: f64, y: f64| match k {
            0 => Some(square_cell(0.1, x, y)),
            1 => Some(square_cell(4.0, x, y)),
            _ => None,
        };
        let t = far_obstacles_with(map, cells, &scene, std::slice::from_ref(&obs), 0.5, 1.0);
        let c = |points, right| Count { points, right };
        assert_eq!(t.ground, [c(2, 1), c(1, 1), c(0, 0), c(1, 1)]);
        assert_eq!(t.ground_only, [c(2, 1), c(0, 0), c(0, 0), c(1, 1)]);
        assert_eq!(t.ground_only_total(), c(3, 2));
        let curb = ObstacleKind::Curb.index();
        let post = ObstacleKind::Post.index();
        assert_eq!(t.obstacles[curb], [c(1, 1), c(1, 1), c(0, 0), c(0, 0)]);
        assert_eq!(t.obstacles[post], [c(0, 0), c(0, 0), c(2, 0), c(0, 0)]);
        for kind in [
            ObstacleKind::StepEdge,
            ObstacleKind::Block,
            ObstacleKind::Other,
        ] {
            assert_eq!(t.kind_total(kind), c(0, 0), "{kind:?}");
        }
        assert_eq!(t.ring_obstacles(2), c(2, 0));
        assert_eq!(
            t.total(),
            Tally {
                navigable: 4,
                navigable_ok: 3,
                obstacle: 4,
                obstacle_ok: 2,
            }
        );
        assert!((t.kind_total(ObstacleKind::Curb).pct() - 100.0).abs() < 1e-9);
        assert!(t.kind_total(ObstacleKind::Block).pct().is_nan());
    }
}
