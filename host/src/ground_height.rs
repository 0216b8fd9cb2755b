//! How far below the laser a point cloud's ground lies, found in the cloud itself, so that
//! `pyramid replay` can tell a user whose `--height-m` disagrees with the scan.
//!
//! The design's height h sets the paper's cell-size bound (its vertical term grows as 1/h), so
//! a laser described lower than it stands gets coarser far cells than it needs, and reads more
//! far ground as obstacle: on the eleven SemanticKITTI streets (laser 1.73 m up) described as
//! 1.3 m, clear ground 97.9 → 96.3 % (`docs/core.md`, "The laser described otherwise"). The
//! classifier's ground plane is also put h below the laser.
//!
//! The finding: every point between [`NEAR_M`] and [`FAR_M`] from the laser horizontally and
//! below it goes into bins of [`BIN_M`] by its depth below the laser, down to [`DEPTH_M`];
//! the ground is where three neighbouring bins together hold the most points (a flat floor
//! puts most of a scan's near returns into one or two bins; a wall or a pole spreads its returns
//! over many), at the mean depth of their points. On those streets it lies 1.57–1.88 m below
//! the laser (the roads' own slopes and cambers), hence the [`TOLERANCE_M`] before a warning.

/// The bins' width, metres.
pub const BIN_M: f64 = 0.05;
/// The deepest depth below the laser binned, metres.
pub const DEPTH_M: f64 = 10.0;
/// The nearest horizontal distance counted, metres (nearer returns are often the robot's own
/// body).
pub const NEAR_M: f64 = 1.0;
/// The farthest horizontal distance counted, metres (far ground tilts with the terrain).
pub const FAR_M: f64 = 8.0;
/// The fewest points the three densest bins must hold for a finding.
pub const MIN_POINTS: u64 = 200;
/// How far the found depth may lie from the described height before `pyramid replay` warns,
/// metres.
pub const TOLERANCE_M: f64 = 0.25;

/// The number of bins.
const BINS: usize = 200;
// The bins cover exactly DEPTH_M.
const _: () = assert!((BINS as f64) * BIN_M == DEPTH_M);

/// The depths below the laser of a cloud's points, binned.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GroundDepths {
    bins: [u64; BINS],
}

impl Default for GroundDepths {
    fn default() -> Self {
        Self::new()
    }
}

impl GroundDepths {
    /// No points yet.
    #[must_use]
    pub const fn new() -> Self {
        Self { bins: [0; BINS] }
    }

    /// Counts a point `below_m` metres below the laser (negative: above it) and `horizontal_m`
    /// metres from it horizontally; points outside [`NEAR_M`]..=[`FAR_M`] or
    /// 0..[`DEPTH_M`] below, or not finite, are not counted.
    pub fn add(&mut self, below_m: f64, horizontal_m: f64) {
        if !(NEAR_M..=FAR_M).contains(&horizontal_m) || !(0.0..DEPTH_M).contains(&below_m) {
            return;
        }
        // 0 ≤ below_m / BIN_M < BINS: the cast truncates toward zero, as floor does here.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let bin = (below_m / BIN_M) as usize;
        if let Some(count) = self.bins.get_mut(bin) {
            *count = count.saturating_add(1);
        }
    }

    /// The ground's depth below the laser, metres: the mean depth (bin centres) of the three
    /// neighbouring bins holding the most points, the shallowest such three on a tie; `None`
    /// when they hold fewer than [`MIN_POINTS`].
    #[must_use]
    pub fn found_m(&self) -> Option<f64> {
        let (start, points) = self
            .bins
            .windows(3)
            .enumerate()
            .map(|(i, w)| (i, w.iter().sum::<u64>()))
            .fold(
                (0, 0),
                |best, (i, n)| if n > best.1 { (i, n) } else { best },
            );
        if points < MIN_POINTS {
            return None;
        }
        #[allow(clippy::cast_precision_loss)]
        let weighted: f64 = (start..start + 3)
            .filter_map(|i| {
                self.bins
                    .get(i)
                    .map(|&n| n as f64 * (i as f64 + 0.5) * BIN_M)
            })
            .sum();
        #[allow(clippy::cast_precision_loss)]
        Some(weighted / points as f64)
    }
}

/// The warning `pyramid replay` prints when the ground found `found_m` metres below the laser
/// lies more than [`TOLERANCE_M`] from the described height `height_m` (metres); `None` when
/// they agree. It says what the difference does to the design: the paper's cell-size bound
/// grows as 1/h, so a laser described lower than it stands gets coarser far cells than its
/// rings need, and one described higher finer cells than its rings fill.
#[must_use]
pub fn disagreement(found_m: f64, height_m: f64) -> Option<String> {
    if (found_m - height_m).abs() <= TOLERANCE_M {
        return None;
    }
    let effect = if found_m > height_m {
        "a design for a laser lower than it stands has coarser far cells than it needs and \
         reads more far ground as obstacle"
    } else {
        "a design for a laser higher than it stands has finer far cells than its returns fill, \
         and more of them stay unknown"
    };
    Some(format!(
        "the scan's ground lies mostly {found_m:.2} m below the laser (within {FAR_M} m), but \
         --height-m says {height_m} m: {effect} (docs/core.md, \"The laser described \
         otherwise\"); give the laser's height above the ground the robot drives on"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A floor `h` below the laser seen from 1 to 8 m, with 2 cm of texture, and a wall 5 m
    /// away from the floor to 3 m up.
    fn floor_and_wall(h: f64) -> GroundDepths {
        let mut g = GroundDepths::new();
        for i in 0..700 {
            let d = 1.0 + f64::from(i) * 0.01;
            g.add(h + 0.02 * f64::from(i % 3) - 0.02, d);
        }
        for i in 0..300 {
            g.add(h - f64::from(i) * 0.01, 5.0);
        }
        g
    }

    #[test]
    fn finds_the_floor_under_a_wall() {
        for h in [0.35, 1.0, 1.73, 2.5] {
            let found = floor_and_wall(h).found_m().unwrap();
            assert!((found - h).abs() < 0.05, "{h}: {found}");
        }
    }

    #[test]
    fn too_few_points_find_nothing() {
        let mut g = GroundDepths::new();
        for _ in 0..MIN_POINTS - 1 {
            g.add(1.0, 3.0);
        }
        assert_eq!(g.found_m(), None);
        g.add(1.0, 3.0);
        assert!((g.found_m().unwrap() - 1.025).abs() < 1e-9);
    }

    #[test]
    fn points_outside_the_counted_region_are_not_counted() {
        let mut g = GroundDepths::new();
        for (below, d) in [
            (1.0, 0.5),
            (1.0, 9.0),
            (-0.5, 3.0),
            (DEPTH_M, 3.0),
            (f64::NAN, 3.0),
            (1.0, f64::NAN),
            (f64::INFINITY, 3.0),
        ] {
            for _ in 0..MIN_POINTS {
                g.add(below, d);
            }
        }
        assert_eq!(g, GroundDepths::new());
    }

    #[test]
    fn warns_only_beyond_the_tolerance() {
        assert_eq!(disagreement(1.73, 1.73), None);
        assert_eq!(disagreement(1.5, 1.73), None);
        let text = disagreement(1.73, 1.3).unwrap();
        assert!(
            text.contains("1.73 m below") && text.contains("says 1.3 m"),
            "{text}"
        );
        assert!(text.contains("lower than it stands"), "{text}");
        let text = disagreement(0.43, 1.0).unwrap();
        assert!(text.contains("higher than it stands"), "{text}");
    }
}
