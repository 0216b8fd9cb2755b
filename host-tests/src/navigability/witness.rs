//! The most a navigability rule can mark from one observation's returns: the **witness
//! pairs**.
//!
//! A rule that keeps every surface the robot drives navigable (no steeper than the largest
//! slope θ_max, with steps of at most `step`) can call a return an obstacle only where the
//! returns it reads do not lie on such a surface. By the McShane–Whitney extension theorem a
//! set of points lies on a surface whose grade is nowhere steeper than `tan θ_max` exactly
//! when every pair of them rises by at most `tan θ_max` times their horizontal distance. So
//! the returns of one observation near an obstacle give a rule something to mark only where
//! two of them, a **witness pair**, rise more steeply than the largest slope, and (that a step
//! of at most `step` is drivable) by more than `step`; and not by more than the robot's
//! height (a higher return is overhang, which a rule ignores).
//!
//! [`witnesses`] finds the pairs among a set of points (the true points of the returns, with
//! no noise: the bound is the geometry's, before any noise allowance), within a horizontal
//! `reach` of each other, and returns each pair's upper point, the return whose cell the
//! library's pair test marks; [`PastReturns`] does the same between a new observation's
//! returns and every earlier one. Used as a map (a return marked where an upper point lies in
//! a 0.1 m cell within 0.2 m, [`super::rings::far_obstacles_with`]), it bounds what a rule
//! marking near its evidence can mark.

use std::collections::HashMap;

/// What a witness pair must show ([`witnesses`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Witness {
    /// The largest drivable grade, `tan θ_max` (> 0).
    pub max_grade: f64,
    /// The largest drivable step, metres (≥ 0).
    pub step_m: f64,
    /// The robot's height, metres: a pair rising more is overhang, no witness.
    pub robot_height_m: f64,
    /// The largest horizontal distance between a pair's points, metres (> 0).
    pub reach_m: f64,
}

impl Witness {
    /// The library's defaults (`docs/core.md`): grade tan 20°, step 0.05 m, robot height
    /// 1.0 m; a reach of 1 m (a pair further apart rises more than 0.36 m to be steeper than
    /// the largest slope: no kerb does).
    #[must_use]
    pub fn library() -> Self {
        Self {
            max_grade: 20f64.to_radians().tan(),
            step_m: 0.05,
            robot_height_m: 1.0,
            reach_m: 1.0,
        }
    }

    /// Whether the pair `a`, `b` is a witness: within reach, rising more than the step and no
    /// more than the robot's height, and steeper than the largest grade by more than 1 mm (a
    /// slope of exactly the largest grade, rounded, is no witness).
    #[must_use]
    pub fn pair(&self, a: &[f64; 3], b: &[f64; 3]) -> bool {
        let run = (a[0] - b[0]).hypot(a[1] - b[1]);
        let rise = (a[2] - b[2]).abs();
        run <= self.reach_m
            && rise > self.step_m
            && rise <= self.robot_height_m
            && rise > self.max_grade * run + 1e-3
    }
}

/// The upper points of the witness pairs of `w` among `points` (in the order of `points`,
/// each once): of a pair, the higher return, which marks its cell as the library's pair test
/// marks the upper return's. Points that are not finite are skipped.
#[must_use]
pub fn witnesses(points: &[[f64; 3]], w: &Witness) -> Vec<[f64; 3]> {
    let indexed: Vec<(usize, [f64; 3])> = points.iter().copied().enumerate().collect();
    let own = Buckets::of(&indexed, w.reach_m);
    let mut upper = vec![false; points.len()];
    for &(_, p) in &indexed {
        own.each_above(&p, w, |j, _| {
            if let Some(u) = upper.get_mut(j) {
                *u = true;
            }
        });
    }
    points
        .iter()
        .zip(upper)
        .filter_map(|(p, u)| u.then_some(*p))
        .collect()
}

/// Every return of the observations so far, for the witness pairs a new observation's returns
/// make with them: the bound of a map that kept every return's height (perfect poses, no
/// noise), not one observation's.
#[derive(Debug, Clone, Default)]
pub struct PastReturns {
    /// The returns so far (index, point), in buckets of the reach's side.
    past: Option<Buckets>,
    /// Per earlier return: already reported as an upper point.
    reported: Vec<bool>,
}

impl PastReturns {
    /// No returns yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The upper points of the witness pairs of `w` between a return of `points` and one
    /// of the earlier observations' (either may be the upper; an earlier return once over
    /// every call), then keeps `points` among the earlier ones. With [`witnesses`] of `points`
    /// by their own, the witnesses of every return so far.
    pub fn witnesses_then_keep(&mut self, points: &[[f64; 3]], w: &Witness) -> Vec<[f64; 3]> {
        let mut upper: Vec<[f64; 3]> = Vec::new();
        let first = self.reported.len();
        let indexed: Vec<(usize, [f64; 3])> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (first + i, *p))
            .collect();
        if let Some(past) = &self.past {
            // An earlier return above a new one: the earlier is the upper.
            for &(_, p) in &indexed {
                past.each_above(&p, w, |j, q| {
                    if let Some(r) = self.reported.get_mut(j) {
                        if !*r {
                            *r = true;
                            upper.push(*q);
                        }
                    }
                });
            }
            // A new return above an earlier one: the new is the upper.
            upper.extend(
                indexed
                    .iter()
                    .filter(|(_, p)| past.any_below(p, w))
                    .map(|(_, p)| *p),
            );
        }
        self.reported.resize(first + points.len(), false);
        match &mut self.past {
            Some(past) => past.extend(&indexed),
            None => self.past = Some(Buckets::of(&indexed, w.reach_m)),
        }
        upper
    }
}

/// A bucket's points: (index, point), lowest first.
type Bucket = Vec<(usize, [f64; 3])>;

/// Points (index, point) hashed into square buckets of the reach's side (a pair within reach
/// lies in one bucket or two neighbouring ones), each bucket sorted by height.
#[derive(Debug, Clone)]
struct Buckets {
    /// The bucket's side, metres (> 0).
    side: f64,
    /// Per bucket: its points, lowest first.
    cells: HashMap<(i64, i64), Bucket>,
}

impl Buckets {
    /// `points` (those finite) in buckets of side `reach_m` (1 m if it is not > 0).
    fn of(points: &[(usize, [f64; 3])], reach_m: f64) -> Self {
        let mut b = Self {
            side: if reach_m > 0.0 { reach_m } else { 1.0 },
            cells: HashMap::new(),
        };
        b.extend(points);
        b
    }

    /// Adds `points` (those finite), keeping each bucket sorted by height.
    fn extend(&mut self, points: &[(usize, [f64; 3])]) {
        let mut touched = Vec::new();
        for &(i, p) in points {
            if let Some(key) = self.key(&p) {
                self.cells.entry(key).or_default().push((i, p));
                touched.push(key);
            }
        }
        touched.sort_unstable();
        touched.dedup();
        for key in touched {
            if let Some(bucket) = self.cells.get_mut(&key) {
                bucket.sort_by(|a, b| a.1[2].total_cmp(&b.1[2]));
            }
        }
    }

    /// The bucket of a finite point.
    #[allow(clippy::cast_possible_truncation)]
    fn key(&self, p: &[f64; 3]) -> Option<(i64, i64)> {
        p.iter().all(|v| v.is_finite()).then(|| {
            (
                (p[0] / self.side).floor() as i64,
                (p[1] / self.side).floor() as i64,
            )
        })
    }

    /// Whether some point makes a witness pair of `w` with `p` as its lower point: lower than
    /// `p` by more than the step and no more than the robot's height, in the buckets at and
    /// around `p`'s.
    fn any_below(&self, p: &[f64; 3], w: &Witness) -> bool {
        let Some(key) = self.key(p) else {
            return false;
        };
        (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                self.cells
                    .get(&(key.0 + dx, key.1 + dy))
                    .is_some_and(|bucket| {
                        let to = bucket.partition_point(|(_, q)| q[2] < p[2] - w.step_m);
                        bucket
                            .iter()
                            .take(to)
                            .rev()
                            .take_while(|(_, q)| q[2] >= p[2] - w.robot_height_m)
                            .any(|(_, q)| w.pair(q, p))
                    })
            })
        })
    }

    /// Calls `f(index, point)` for every point that makes a witness pair of `w` with `p` as
    /// its upper point: higher than `p` by more than the step and no more than the robot's
    /// height, in the buckets at and around `p`'s.
    fn each_above(&self, p: &[f64; 3], w: &Witness, mut f: impl FnMut(usize, &[f64; 3])) {
        let Some(key) = self.key(p) else {
            return;
        };
        for dx in -1..=1 {
            for dy in -1..=1 {
                let Some(bucket) = self.cells.get(&(key.0 + dx, key.1 + dy)) else {
                    continue;
                };
                let from = bucket.partition_point(|(_, q)| q[2] <= p[2] + w.step_m);
                for (j, q) in bucket.iter().skip(from) {
                    if q[2] > p[2] + w.robot_height_m {
                        break;
                    }
                    if w.pair(p, q) {
                        f(*j, q);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// By hand, with the library's allowance (grade 0.364, step 0.05 m, 1 m):
    /// - flat ground 0.1 m apart: no pair rises; no witness;
    /// - a 20° slope sampled every 0.1 m: each pair rises exactly the grade; no witness;
    /// - a 12 cm kerb: its foot (0, 0, 0) and its top (0.1, 0, 0.12) rise 1.2 m a metre, more
    ///   than a step: a witness pair, whose upper point is the top; the top and
    ///   (0.5, 0, 0.12) do not rise;
    /// - the same kerb seen as a ramp from 1 m away: (−1, 0, 0) and (0, 0, 0.12), 12 %:
    ///   no witness;
    /// - a return 1.2 m over the ground beside it: overhang, no witness.
    #[test]
    fn a_kerb_is_witnessed_and_a_slope_is_not() {
        let w = Witness::library();
        let flat: Vec<[f64; 3]> = (0..20).map(|i| [f64::from(i) * 0.1, 0.0, 0.0]).collect();
        assert!(witnesses(&flat, &w).is_empty());
        let slope: Vec<[f64; 3]> = (0..20)
            .map(|i| {
                let x = f64::from(i) * 0.1;
                [x, 0.0, x * 20f64.to_radians().tan()]
            })
            .collect();
        assert!(witnesses(&slope, &w).is_empty());
        let kerb = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.12], [0.5, 0.0, 0.12]];
        assert_eq!(witnesses(&kerb, &w), vec![kerb[1]]);
        let ramp = [[-1.0, 0.0, 0.0], [0.0, 0.0, 0.12]];
        assert!(witnesses(&ramp, &w).is_empty());
        let overhang = [[0.0, 0.0, 0.0], [0.1, 0.0, 1.2]];
        assert!(witnesses(&overhang, &w).is_empty());
    }

    /// Pairs are found across the reach's buckets (points either side of x = 1 m) and not
    /// beyond the reach; a point that is not finite is skipped.
    #[test]
    fn pairs_meet_across_buckets_and_not_beyond_reach() {
        let w = Witness::library();
        let across = [[0.95, 0.0, 0.0], [1.05, 0.0, 0.2], [f64::NAN, 0.0, 0.0]];
        assert_eq!(witnesses(&across, &w), vec![across[1]]);
        let far = [[0.0, 0.0, 0.0], [1.5, 0.0, 0.9]];
        assert!(witnesses(&far, &w).is_empty());
    }

    /// [`Witness::library`]'s allowances are the library's defaults (`ClassifierConfig`, the
    /// plane rule's largest grade), to within their fixed-point resolution.
    #[test]
    fn the_allowances_are_the_librarys_defaults() {
        use terrain_pyramid::classify::{ClassifierConfig, PlaneRule};
        let w = Witness::library();
        let config = ClassifierConfig::DEFAULT;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-4;
        assert!(close(w.step_m, config.step_threshold.to_num::<f64>()));
        assert!(close(w.robot_height_m, config.robot_height.to_num::<f64>()));
        let grade = PlaneRule::DEFAULT.max_grade.to_num::<f64>();
        assert!(close(w.max_grade, grade), "{} against {grade}", w.max_grade);
    }

    /// The kerb of the first test seen by two observations, its foot by the first and its top
    /// by the second: neither holds a pair, the two together do, and the upper point is
    /// reported whichever observation holds it; a third observation on flat ground far away
    /// adds none.
    #[test]
    fn past_returns_pair_with_a_new_observation() {
        let w = Witness::library();
        let mut past = PastReturns::new();
        assert!(past.witnesses_then_keep(&[[0.0, 0.0, 0.0]], &w).is_empty());
        let top = [0.1, 0.0, 0.12];
        assert!(witnesses(&[top], &w).is_empty());
        assert_eq!(past.witnesses_then_keep(&[top], &w), vec![top]);
        let mut past = PastReturns::new();
        assert!(past.witnesses_then_keep(&[top], &w).is_empty());
        assert_eq!(past.witnesses_then_keep(&[[0.0, 0.0, 0.0]], &w), vec![top]);
        assert!(past.witnesses_then_keep(&[[5.0, 5.0, 0.0]], &w).is_empty());
    }
}
