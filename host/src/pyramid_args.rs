//! The flags `pyramid replay` and `pyramid run` share: the pyramid's design, the clamping of
//! its stored log-odds, the inverse sensor model, and the classifier's height thresholds and
//! navigability rule.

use crate::design::DesignArgs;
use crate::rule::RuleArgs;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{Clamp, InverseSensorModel, Meters};

/// The pyramid's and the classifier's flags of `pyramid replay` and `pyramid run`.
#[derive(clap::Args, Debug, Clone)]
pub struct PyramidArgs {
    /// The sensor, the schedule, the window and the gate, as for `pyramid design`.
    #[command(flatten)]
    pub design: DesignArgs,
    /// Clamping of the stored log-odds: none (the paper's baseline), or OctoMap's bounds
    /// (−2 ..= 3.5 nats).
    #[arg(long, value_enum, default_value_t = ClampArg::Octomap)]
    pub clamp: ClampArg,
    /// The inverse sensor model's p(not navigable | the classifier calls the cell not
    /// navigable), 0.5 < P ≤ 0.999: an obstacle verdict adds `logit(P)` nats to its cells
    /// (the library's default 0.7; `docs/core.md`, "Inverse sensor model and increments").
    #[arg(long, value_name = "P")]
    pub p_obstacle: Option<f32>,
    /// The inverse sensor model's p(not navigable | the classifier calls the cell navigable),
    /// 0.001 ≤ P < 0.5: a navigable verdict adds `logit(P)` nats (the library's default 0.4).
    #[arg(long, value_name = "P")]
    pub p_free: Option<f32>,
    /// Returns higher than this above the robot's ground plane are overhang whatever the cell
    /// holds (a roof seen where the floor under it was not), metres; off by default (the
    /// paper's rule judges overhang only against the cell's lowest point).
    #[arg(long, value_name = "M")]
    pub ceiling_m: Option<f64>,
    /// Returns this far below the robot's ground plane mark a drop-off (a negative
    /// obstacle), metres; off by default.
    #[arg(long, value_name = "M")]
    pub drop_m: Option<f64>,
    /// The navigability rule and its parameters.
    #[command(flatten)]
    pub rule: RuleArgs,
}

impl PyramidArgs {
    /// The clamping `--clamp` names.
    #[must_use]
    pub const fn clamp(&self) -> Clamp {
        match self.clamp {
            ClampArg::Off => Clamp::Off,
            ClampArg::Octomap => Clamp::OCTOMAP,
        }
    }

    /// The inverse sensor model of `--p-obstacle` and `--p-free` (the library's defaults where
    /// not given; the prior stays the library's, 0.5).
    ///
    /// # Errors
    /// A probability the library refuses (outside 0.001 ..= 0.999, or on the wrong side of
    /// the prior), named by its flag.
    pub fn model(&self) -> Result<InverseSensorModel, String> {
        let default = InverseSensorModel::default();
        let model = InverseSensorModel {
            p_obstacle: self.p_obstacle.unwrap_or(default.p_obstacle),
            p_free: self.p_free.unwrap_or(default.p_free),
            ..default
        };
        model.increments().map_err(|e| e.to_string())?;
        Ok(model)
    }

    /// The library's default classifier with `--ceiling-m` and `--drop-m` (metres, saturated
    /// to Q16.16; absent when not given) and the navigability rule's flags applied.
    ///
    /// # Errors
    /// A rule parameter [`RuleArgs::apply`] refuses, named by its flag.
    pub fn classifier(&self) -> Result<ClassifierConfig, String> {
        self.rule.apply(ClassifierConfig {
            ceiling: self.ceiling_m.map(Meters::saturating_from_num),
            drop_threshold: self.drop_m.map(Meters::saturating_from_num),
            ..ClassifierConfig::default()
        })
    }
}

/// The clamping, as the command line names it.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClampArg {
    /// No clamping: only the Q8.8 format saturates.
    Off,
    /// OctoMap's default bounds, −2.0 ..= 3.5 nats.
    Octomap,
}
