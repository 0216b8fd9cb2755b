//! What the classifier is asked to look for ([`ClassifierConfig`]) and what it counts
//! ([`ClassifierStats`]).

use super::rule::NavigabilityRule;
use crate::units::Meters;

/// The default step threshold, 0.05 m, evaluated at compile time (`fixed`'s `lit` parses a
/// string: in a non-const context it would run, and weigh 11 KB of code, on the device).
const DEFAULT_STEP_THRESHOLD: Meters = Meters::lit("0.05");

/// What the classifier looks for, metres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClassifierConfig {
    /// Points higher than the cell's ground plus this are overhang and ignored. Default 1.0 m.
    pub robot_height: Meters,
    /// A spread of the remaining points above this makes the cell not navigable. Default 0.05 m.
    pub step_threshold: Meters,
    /// A return this far below the robot's ground plane marks a drop-off; `None` (the
    /// default) turns the check off. 0.3 m is a sensible value when on.
    pub drop_threshold: Option<Meters>,
    /// Returns higher than this above the robot's ground plane are overhang whatever the
    /// cell holds (a roof or a ceiling seen where the floor under it was not); `None` (the
    /// default, the paper's rule) judges overhang only against the cell's own lowest point.
    pub ceiling: Option<Meters>,
    /// How a cell's points below the overhang cut are judged. Default
    /// [`NavigabilityRule::DEFAULT`]: [`NavigabilityRule::Plane`] with [`PlaneRule::DEFAULT`](super::PlaneRule::DEFAULT)
    /// with the `plane-rule` feature (the library's default), [`NavigabilityRule::Spread`] (the
    /// paper's rule) without it.
    pub rule: NavigabilityRule,
}

impl ClassifierConfig {
    /// The defaults (`const`): robot height 1.0 m, step threshold 0.05 m, no drop-off check, no
    /// ceiling, [`NavigabilityRule::DEFAULT`] (the plane rule with the `plane-rule` feature,
    /// the paper's spread rule without it).
    pub const DEFAULT: Self = Self {
        robot_height: Meters::ONE,
        step_threshold: DEFAULT_STEP_THRESHOLD,
        drop_threshold: None,
        ceiling: None,
        rule: NavigabilityRule::DEFAULT,
    };
}

impl Default for ClassifierConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(feature = "defmt")]
defmt_raw!(
    ClassifierConfig,
    "ClassifierConfig {{ robot_height: {=i32}, step_threshold: {=i32} }} (raw Q16.16), rule {}",
    [robot_height, step_threshold],
    [rule]
);

/// Counters of the classifier. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClassifierStats {
    /// Points offered.
    pub points: u32,
    /// Points that fed at least one layer cell.
    pub points_used: u32,
    /// Points that fed no layer cell: every gate zero at their distance, or every cell they
    /// would have fed dropped because the scratch table was full (those additions counted in
    /// [`ClassifierStats::overflow_points`] too). `points_used + points_gated_out` is the
    /// count of points that reached the gates (not overhang).
    pub points_gated_out: u32,
    /// Point-to-cell additions dropped because the scratch table was full (one per layer
    /// cell a point could not get).
    pub overflow_points: u32,
    /// Points ignored as overhang (above ground + robot height) when they arrived.
    pub overhang_points: u32,
    /// Points below the drop threshold (drop-offs).
    pub drop_points: u32,
    /// Observations finished.
    pub observations: u32,
    /// Evidence records produced.
    pub records: u32,
}
