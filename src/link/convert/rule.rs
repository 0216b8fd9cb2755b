//! The navigability rule on the link: a rule as Setup's and SetRule's rule block
//! ([`rule_setup`], [`set_rule_message`]) and back, validated ([`navigability_rule`],
//! [`set_rule_of`]), and the rules this build takes ([`RULE_MAX`]).

use super::{SetupError, SetupField, SETUP_LIMIT_M};
use crate::classify::{ClassifierConfig, NavigabilityRule, PlaneRule, Ratio, MAX_PAIR_DEPTH};
use crate::units::Meters;
use crate::wire::link::{RuleSetup, SetRule};

/// The link's rule block of a navigability rule (exact: every Q16.16 value below 256 is exact
/// in `f32`, so [`frontend_config`](super::frontend_config) gives back the same parameters).
#[must_use]
pub fn rule_setup(rule: &NavigabilityRule) -> RuleSetup {
    match rule {
        NavigabilityRule::Spread => RuleSetup::SPREAD,
        NavigabilityRule::Plane(p) => RuleSetup {
            rule: 1,
            max_grade: p.max_grade.to_num::<f32>(),
            residual_m: p.residual.to_num::<f32>(),
            range_sigma_m: p.range_sigma.to_num::<f32>(),
            angle_sigma_rad: p.angle_sigma.to_num::<f32>(),
            noise_factor: p.noise_factor.to_num::<f32>(),
            pair_depth: p.pair_depth,
        },
    }
}

/// The step threshold and navigability rule of a SetRule command, validated in wire order:
/// the step as Setup's (finite, 0 ≤ v < 1 000 m; param 55), then the rule block
/// ([`navigability_rule`]).
///
/// # Errors
/// The first bad field.
pub fn set_rule_of(set: &SetRule) -> Result<(Meters, NavigabilityRule), SetupError> {
    let v = non_negative_length(SetupField::StepThreshold, set.step_threshold_m)?;
    Ok((
        Meters::saturating_from_num(v),
        navigability_rule(&set.rule)?,
    ))
}

/// The SetRule command that sets a classifier's step threshold and navigability rule (exact,
/// as [`setup_message`](super::setup_message)).
#[must_use]
pub fn set_rule_message(classifier: &ClassifierConfig) -> SetRule {
    SetRule {
        step_threshold_m: classifier.step_threshold.to_num::<f32>(),
        rule: rule_setup(&classifier.rule),
    }
}

/// The largest navigability rule number this build takes: 1 (the plane rule) with the
/// `plane-rule` feature, 0 (the paper's spread rule only) without it.
pub const RULE_MAX: u8 = if cfg!(feature = "plane-rule") { 1 } else { 0 };

/// The navigability rule of a Setup's rule block, validated in wire order: the rule exists (0
/// spread, 1 plane) and this build has it; under the plane rule every parameter is finite with
/// 0 ≤ v < 1 000 and the pair depth within 1 ..= [`MAX_PAIR_DEPTH`] (the parameters are
/// ignored under the spread rule).
///
/// # Errors
/// The first bad field. A rule beyond [`RULE_MAX`] is out of range `[0, RULE_MAX]`
/// ([`SetupField::Rule`]): a build without the `plane-rule` feature refuses rule 1 with
/// value 1 in `[0, 0]`, which [`ReplyText`](super::ReplyText) reads as "not built in".
pub fn navigability_rule(block: &RuleSetup) -> Result<NavigabilityRule, SetupError> {
    match block.rule {
        0 => Ok(NavigabilityRule::Spread),
        1 if cfg!(feature = "plane-rule") => {
            let value = non_negative_length;
            let max_grade = value(SetupField::MaxGrade, block.max_grade)?;
            let residual = value(SetupField::Residual, block.residual_m)?;
            let range_sigma = value(SetupField::RangeSigma, block.range_sigma_m)?;
            let angle_sigma = value(SetupField::AngleSigma, block.angle_sigma_rad)?;
            let noise_factor = value(SetupField::NoiseFactor, block.noise_factor)?;
            if !(1..=MAX_PAIR_DEPTH).contains(&block.pair_depth) {
                return Err(SetupError::OutOfRange {
                    field: SetupField::PairDepth,
                    value: f32::from(block.pair_depth),
                    min: 1.0,
                    max: f32::from(MAX_PAIR_DEPTH),
                });
            }
            Ok(NavigabilityRule::Plane(PlaneRule {
                max_grade: Ratio::saturating_from_num(max_grade),
                residual: Meters::saturating_from_num(residual),
                range_sigma: Meters::saturating_from_num(range_sigma),
                angle_sigma: Ratio::saturating_from_num(angle_sigma),
                noise_factor: Ratio::saturating_from_num(noise_factor),
                pair_depth: block.pair_depth,
            }))
        }
        other => Err(SetupError::OutOfRange {
            field: SetupField::Rule,
            value: f32::from(other),
            min: 0.0,
            max: f32::from(RULE_MAX),
        }),
    }
}

/// `v` when finite and within `0 ..` [`SETUP_LIMIT_M`] (a threshold or a noise of the Setup);
/// else the error naming `field`.
pub(super) fn non_negative_length(field: SetupField, v: f32) -> Result<f32, SetupError> {
    if !v.is_finite() {
        return Err(SetupError::NotFinite { field });
    }
    if !(0.0..SETUP_LIMIT_M).contains(&v) {
        return Err(SetupError::OutOfRange {
            field,
            value: v,
            min: 0.0,
            max: SETUP_LIMIT_M,
        });
    }
    Ok(v)
}
