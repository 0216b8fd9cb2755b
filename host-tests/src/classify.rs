//! f64 reference of the navigability classifier, written from the paper's rule (Ferguson et
//! al. as the paper summarises it, read in paper-notes) and `docs/core.md`, not from
//! `src/classify.rs`.
//!
//! It keeps every point of an observation, so it applies the rule exactly: per layer cell,
//! ground = the lowest z; points above ground + robot height are dropped; the cell is not
//! navigable when the rest spread over more than the step threshold. A record's distance is
//! the smallest horizontal distance among the cell's points.

use std::collections::BTreeMap;

/// A point of an observation, metres, with its horizontal distance from the sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefPoint {
    /// World x, m.
    pub x: f64,
    /// World y, m.
    pub y: f64,
    /// World z, m.
    pub z: f64,
    /// Horizontal distance from the sensor at measurement, m.
    pub distance: f64,
}

/// The classifier's thresholds, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefClassifierConfig {
    /// Overhang cut above the cell's ground.
    pub robot_height: f64,
    /// Largest spread of a navigable cell.
    pub step_threshold: f64,
    /// A point this far below the ground plane marks a drop-off (`None`: off).
    pub drop_threshold: Option<f64>,
}

impl Default for RefClassifierConfig {
    fn default() -> Self {
        Self {
            robot_height: 1.0,
            step_threshold: 0.05,
            drop_threshold: None,
        }
    }
}

/// The reference's verdict on one layer cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefRecord {
    /// Layer index.
    pub layer: usize,
    /// World cell index along x.
    pub cell_x: i64,
    /// World cell index along y.
    pub cell_y: i64,
    /// Not navigable?
    pub obstacle: bool,
    /// The spread of the points below the overhang cut, m.
    pub spread: f64,
    /// The closest look, m.
    pub distance: f64,
    /// How close any point came to the overhang cut (ground + robot height), m.
    pub cut_margin: f64,
}

/// Classifies one observation.
///
/// `resolutions[k]` is layer k's cell size (m); `feeds(k, d)` says whether a point at
/// horizontal distance d feeds layer k (its gated increment is non-zero); `ground_z` is the
/// robot's ground plane.
pub fn classify(
    points: &[RefPoint],
    resolutions: &[f64],
    mut feeds: impl FnMut(usize, f64) -> bool,
    ground_z: f64,
    config: &RefClassifierConfig,
) -> BTreeMap<(usize, i64, i64), RefRecord> {
    struct Acc {
        zs: Vec<f64>,
        distance: f64,
        hole: bool,
    }
    let mut cells: BTreeMap<(usize, i64, i64), Acc> = BTreeMap::new();
    for p in points {
        let hole = config
            .drop_threshold
            .is_some_and(|drop| p.z < ground_z - drop);
        for (k, &r) in resolutions.iter().enumerate() {
            if !feeds(k, p.distance) {
                continue;
            }
            let key = (k, (p.x / r).floor() as i64, (p.y / r).floor() as i64);
            let acc = cells.entry(key).or_insert(Acc {
                zs: Vec::new(),
                distance: f64::INFINITY,
                hole: false,
            });
            acc.zs.push(p.z);
            acc.distance = acc.distance.min(p.distance);
            acc.hole |= hole;
        }
    }
    cells
        .into_iter()
        .map(|((layer, cell_x, cell_y), acc)| {
            let ground = acc.zs.iter().copied().fold(f64::INFINITY, f64::min);
            let top = acc
                .zs
                .iter()
                .copied()
                .filter(|&z| z <= ground + config.robot_height)
                .fold(f64::NEG_INFINITY, f64::max);
            let spread = top - ground;
            let cut = ground + config.robot_height;
            let cut_margin = acc
                .zs
                .iter()
                .map(|z| (z - cut).abs())
                .fold(f64::INFINITY, f64::min);
            let record = RefRecord {
                layer,
                cell_x,
                cell_y,
                obstacle: acc.hole || spread > config.step_threshold,
                spread,
                distance: acc.distance,
                cut_margin,
            };
            ((layer, cell_x, cell_y), record)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> RefPoint {
        RefPoint {
            x,
            y,
            z,
            distance: 1.0,
        }
    }

    #[test]
    fn the_rule_by_hand() {
        let pts = [
            p(0.05, 0.05, 0.0),
            p(0.06, 0.05, 0.04),
            p(0.15, 0.05, 0.0),
            p(0.16, 0.05, 0.08),
            p(0.25, 0.05, 0.0),
            p(0.26, 0.05, 1.6),
        ];
        let out = classify(
            &pts,
            &[0.1],
            |_, _| true,
            0.0,
            &RefClassifierConfig::default(),
        );
        assert!(!out[&(0, 0, 0)].obstacle);
        assert!(out[&(0, 1, 0)].obstacle);
        assert!(!out[&(0, 2, 0)].obstacle, "overhang ignored");
    }
}
