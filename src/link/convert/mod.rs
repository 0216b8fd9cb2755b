//! Between the link's messages ([`crate::wire::link`], pure wire values) and the core's types:
//! every host command is validated here, once, by the rule that converts it, and every refusal
//! is turned into the Reply that names the parameter and the rule.
//!
//! - A [`Configure`] becomes a [`Design`] by [`Design::new`]'s rules and a [`Config`] by the
//!   inverse sensor model's and [`Clamp::bounds`]' ([`design_of`], [`config_of`]); the host
//!   builds one from the same types ([`configure_message`]).
//! - A [`PoseReport`] becomes a [`Pose`] by [`Pose::from_f32`] ([`pose_of`]).
//! - A [`Setup`] becomes a [`FrontendConfig`] ([`frontend_config`]); a recording's setup event
//!   goes through the same rule ([`setup_message`], then [`frontend_config`]).
//! - A refusal becomes a [`Reply`] ([`design_refusal`], [`pose_refusal`], [`setup_refusal`],
//!   [`layer_refusal`]) whose `param` codes ([`param_code`], [`pose_field_code`],
//!   [`SetupField`], [`PARAM_LAYER`]) `docs/protocol.md` lists, and a Reply reads back as a
//!   sentence with [`ReplyText`].
//!
//! [`Configure`]: crate::wire::link::Configure
//! [`Design`]: crate::design::Design
//! [`Design::new`]: crate::design::Design::new
//! [`Config`]: crate::pyramid::Config
//! [`Clamp::bounds`]: crate::logodds::Clamp::bounds
//! [`PoseReport`]: crate::wire::link::PoseReport
//! [`Pose`]: crate::geometry::Pose
//! [`Pose::from_f32`]: crate::geometry::Pose::from_f32
//! [`Setup`]: crate::wire::link::Setup
//! [`FrontendConfig`]: crate::pipeline::FrontendConfig
//! [`Reply`]: crate::wire::link::Reply
//! [`PARAM_LAYER`]: crate::wire::link::PARAM_LAYER

mod configure;
mod frontend;
mod pose;
mod reply;
mod rule;
mod setup;
#[cfg(test)]
mod tests;

pub use configure::{config_of, configure_message, configure_of_design, decay_of, design_of};
pub use frontend::{fine_of_centidegrees, fine_of_degrees, frontend_config, MOUNT_LIMIT_DEG};
pub use pose::{pose_field_code, pose_flags_refusal, pose_of, stamp_of, PARAM_POSE_FLAGS};
pub use reply::{
    design_refusal, layer_refusal, param_code, param_of_code, pose_refusal, setup_refusal,
    ReplyReason, ReplyText,
};
pub use rule::{navigability_rule, rule_setup, set_rule_message, set_rule_of, RULE_MAX};
pub use setup::{
    frontend_config_of_event, setup_message, setup_message_with_sensor, setup_with_rig, SetupError,
    SetupField, SERVO_LIMIT_DEG, SERVO_MAX_LATENCY_MS, SERVO_MAX_RATE_DEG_S, SETUP_BAUD,
    SETUP_LIMIT_M,
};
