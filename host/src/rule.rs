//! The navigability rule's flags, shared by `pyramid replay`, `run` and `listen` and the lab's
//! experiments: which rule judges a cell (`--rule plane|paper`) and its parameters
//! (`docs/core.md`, "The navigability rule").
//!
//! - `--rule plane` (the default): a least-squares plane per cell, not navigable when the
//!   points stray from it by more than the residual allowance plus the noise, or when it rises
//!   across the points by more than the step plus the largest slope plus the noise.
//! - `--rule paper`: Montemerlo & Thrun's rule, not navigable when the points spread over more
//!   than the step height.
//!
//! The numeric flags accept values that start with a hyphen so that [`RuleArgs::apply`], not the
//! parser, refuses them with its own message.

use terrain_pyramid::classify::{
    ClassifierConfig, NavigabilityRule, PlaneRule, Ratio, MAX_PAIR_DEPTH,
};
use terrain_pyramid::Meters;

/// Which rule, as the command line names it.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RuleArg {
    /// The least-squares plane per cell (the library's default).
    #[default]
    Plane,
    /// The paper's rule: the points' height spread against the step height.
    Paper,
}

impl RuleArg {
    /// The name the flag takes.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Plane => "plane",
            Self::Paper => "paper",
        }
    }
}

/// The largest value a metre parameter of the rule may take (exclusive), as the link's Setup
/// accepts it.
const LIMIT_M: f64 = 1_000.0;

/// The navigability rule's flags. Unset parameters keep the library's defaults
/// ([`ClassifierConfig::DEFAULT`], [`PlaneRule::DEFAULT`]).
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct RuleArgs {
    /// How a cell's points are judged: `plane` (a least-squares plane, tolerant of slopes,
    /// roughness and sensor noise) or `paper` (the points' height spread against the step)
    /// [default: plane].
    #[arg(long, value_enum)]
    pub rule: Option<RuleArg>,
    /// The step height, metres: under `paper` the largest spread of a navigable cell, under
    /// `plane` the rise allowed across a cell on top of its slope [default: 0.05].
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    pub step_m: Option<f64>,
    /// `plane`: the largest slope the robot drives, degrees, 0 ≤ v < 89 [default: 20].
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub max_slope_deg: Option<f64>,
    /// `plane`: the RMS by which a navigable cell's points may stray from their plane beyond
    /// the noise (grass, gravel), metres [default: 0.015].
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    pub residual_m: Option<f64>,
    /// `plane`: the sensor's range noise σ the allowances grow with, metres [default: 0.02].
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    pub noise_sigma_m: Option<f64>,
    /// `plane`: the sensor's elevation error σ_a, degrees [default: 0.075].
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub angle_sigma_deg: Option<f64>,
    /// `plane`: how many σ of height noise the allowances hold, 0 ≤ v < 100 [default: 2].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub noise_factor: Option<f64>,
    /// `plane`: how many of a cell's previous returns each return is paired with, 1 ..= 3:
    /// 1 for a laser whose returns sweep a cell line by line (a tilting or nodding 2-D
    /// laser), 3 for a spinning multi-beam laser's returns in firing order [default: 1;
    /// `pyramid replay`: 3 when it sorts the file into firing order].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub pair_depth: Option<i64>,
}

impl RuleArgs {
    /// The paper's rule with the default step.
    #[must_use]
    pub fn paper() -> Self {
        Self {
            rule: Some(RuleArg::Paper),
            ..Self::default()
        }
    }

    /// Whether any of the flags was given (`pyramid listen` sends the rule only then).
    #[must_use]
    pub fn given(&self) -> bool {
        self.rule.is_some()
            || [
                self.step_m,
                self.max_slope_deg,
                self.residual_m,
                self.noise_sigma_m,
                self.angle_sigma_deg,
                self.noise_factor,
            ]
            .iter()
            .any(Option::is_some)
            || self.pair_depth.is_some()
    }

    /// `base` with the rule and the parameters the flags set.
    ///
    /// # Errors
    /// A parameter that is not finite or out of its range (named by its flag), or a plane
    /// parameter given with `--rule paper`.
    pub fn apply(&self, base: ClassifierConfig) -> Result<ClassifierConfig, String> {
        let mut config = base;
        if let Some(v) = self.step_m {
            config.step_threshold = metres("--step-m", v)?;
        }
        let plane_flags = [
            ("--max-slope-deg", self.max_slope_deg),
            ("--residual-m", self.residual_m),
            ("--noise-sigma-m", self.noise_sigma_m),
            ("--angle-sigma-deg", self.angle_sigma_deg),
            ("--noise-factor", self.noise_factor),
        ];
        config.rule = match self.rule.unwrap_or_default() {
            RuleArg::Paper => {
                if let Some((flag, _)) = plane_flags.iter().find(|(_, v)| v.is_some()) {
                    return Err(format!("{flag} is a parameter of --rule plane"));
                }
                if self.pair_depth.is_some() {
                    return Err("--pair-depth is a parameter of --rule plane".to_string());
                }
                NavigabilityRule::Spread
            }
            RuleArg::Plane => {
                let mut rule = match base.rule {
                    NavigabilityRule::Plane(rule) => rule,
                    NavigabilityRule::Spread => PlaneRule::DEFAULT,
                };
                if let Some(v) = self.max_slope_deg {
                    let deg = within("--max-slope-deg", v, 89.0)?;
                    rule.max_grade = Ratio::saturating_from_num(deg.to_radians().tan());
                }
                if let Some(v) = self.residual_m {
                    rule.residual = metres("--residual-m", v)?;
                }
                if let Some(v) = self.noise_sigma_m {
                    rule.range_sigma = metres("--noise-sigma-m", v)?;
                }
                if let Some(v) = self.angle_sigma_deg {
                    let deg = within("--angle-sigma-deg", v, 45.0)?;
                    rule.angle_sigma = Ratio::saturating_from_num(deg.to_radians());
                }
                if let Some(v) = self.noise_factor {
                    rule.noise_factor =
                        Ratio::saturating_from_num(within("--noise-factor", v, 100.0)?);
                }
                if let Some(v) = self.pair_depth {
                    rule.pair_depth = u8::try_from(v)
                        .ok()
                        .filter(|d| (1..=MAX_PAIR_DEPTH).contains(d))
                        .ok_or_else(|| {
                            format!("--pair-depth: {v} is outside 1 ..= {MAX_PAIR_DEPTH}")
                        })?;
                }
                NavigabilityRule::Plane(rule)
            }
        };
        Ok(config)
    }
}

/// `v` when finite and in `0 ..< max`.
fn within(flag: &str, v: f64, max: f64) -> Result<f64, String> {
    if v.is_finite() && (0.0..max).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{flag}: {v} is outside 0 ..< {max}"))
    }
}

/// Metres when finite and in `0 ..< 1000`.
fn metres(flag: &str, v: f64) -> Result<Meters, String> {
    within(flag, v, LIMIT_M).map(Meters::saturating_from_num)
}

/// A short description of a rule in force, for summaries and reports: `paper (step 0.05 m)`
/// or `plane (step 0.05 m, slope 20.0°, residual 0.015 m, σ 0.02 m, σ_a 0.075°, k 2)`, with
/// `, pairs 3 back` when the pair test looks further back than the last return.
#[must_use]
pub fn describe(config: &ClassifierConfig) -> String {
    let step = round(config.step_threshold.to_num::<f64>());
    match config.rule {
        NavigabilityRule::Spread => format!("paper (step {step} m)"),
        NavigabilityRule::Plane(r) => format!(
            "plane (step {step} m, slope {:.1}°, residual {} m, σ {} m, σ_a {:.3}°, k {}{})",
            r.max_grade.to_num::<f64>().atan().to_degrees(),
            round(r.residual.to_num::<f64>()),
            round(r.range_sigma.to_num::<f64>()),
            r.angle_sigma.to_num::<f64>().to_degrees(),
            round(r.noise_factor.to_num::<f64>()),
            if r.pair_depth > 1 {
                format!(", pairs {} back", r.pair_depth)
            } else {
                String::new()
            }
        ),
    }
}

/// `v` to 4 decimals (Q16.16 values print with their binary tails otherwise).
fn round(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_flags_is_the_librarys_default() {
        let c = RuleArgs::default()
            .apply(ClassifierConfig::DEFAULT)
            .unwrap();
        assert_eq!(c, ClassifierConfig::DEFAULT);
    }

    #[test]
    fn paper_is_the_spread_rule_and_refuses_plane_parameters() {
        let c = RuleArgs::paper().apply(ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(c.rule, NavigabilityRule::Spread);
        let e = RuleArgs {
            residual_m: Some(0.02),
            ..RuleArgs::paper()
        }
        .apply(ClassifierConfig::DEFAULT)
        .unwrap_err();
        assert!(e.contains("--residual-m"), "{e}");
    }

    #[test]
    fn plane_parameters_are_converted_and_checked() {
        let c = RuleArgs {
            step_m: Some(0.08),
            max_slope_deg: Some(45.0),
            residual_m: Some(0.03),
            noise_sigma_m: Some(0.05),
            angle_sigma_deg: Some(0.2),
            noise_factor: Some(3.0),
            pair_depth: Some(3),
            ..RuleArgs::default()
        }
        .apply(ClassifierConfig::DEFAULT)
        .unwrap();
        assert_eq!(c.step_threshold, Meters::from_num(0.08));
        let NavigabilityRule::Plane(r) = c.rule else {
            panic!("plane")
        };
        assert!((r.max_grade.to_num::<f64>() - 1.0).abs() < 1e-4);
        assert_eq!(r.residual, Meters::from_num(0.03));
        assert_eq!(r.range_sigma, Meters::from_num(0.05));
        assert!((r.angle_sigma.to_num::<f64>() - 0.2_f64.to_radians()).abs() < 1e-4);
        assert_eq!(r.noise_factor, Ratio::from_num(3));
        assert_eq!(r.pair_depth, 3);
        assert!(
            describe(&c).ends_with(", pairs 3 back)"),
            "{}",
            describe(&c)
        );
        for bad in [
            RuleArgs {
                pair_depth: Some(0),
                ..RuleArgs::default()
            },
            RuleArgs {
                pair_depth: Some(4),
                ..RuleArgs::default()
            },
            RuleArgs {
                pair_depth: Some(-1),
                ..RuleArgs::default()
            },
            RuleArgs {
                pair_depth: Some(2),
                ..RuleArgs::paper()
            },
            RuleArgs {
                max_slope_deg: Some(90.0),
                ..RuleArgs::default()
            },
            RuleArgs {
                residual_m: Some(-0.01),
                ..RuleArgs::default()
            },
            RuleArgs {
                step_m: Some(f64::NAN),
                ..RuleArgs::default()
            },
        ] {
            assert!(bad.apply(ClassifierConfig::DEFAULT).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn describe_names_the_rule() {
        assert_eq!(
            describe(&RuleArgs::paper().apply(ClassifierConfig::DEFAULT).unwrap()),
            "paper (step 0.05 m)"
        );
        let d = describe(&ClassifierConfig::DEFAULT);
        assert!(d.starts_with("plane (step 0.05 m, slope 20.0°"), "{d}");
    }
}
