//! The navigability rule the build has: a device built without the `plane-rule` feature boots
//! with the paper's spread rule, and refuses a Setup or SetRule that names the plane rule with
//! a Reply that names the rule field (param 65: rule 1 out of range `[0, 0]`); the setup in
//! force stays.
extern crate std;
use super::tests::{booted, output};
use super::*;
use crate::classify::{NavigabilityRule, PlaneRule};
use crate::link::convert::{rule_setup, set_rule_message, ReplyText, SetupField};
use crate::link::tests::command;
use crate::wire::link::Reply;
use crate::wire::link::{LaserSetup, Message, ReplyCode, RuleSetup, SetRule, Setup};
use std::vec::Vec;

fn replies(core: &mut super::tests::Core) -> Vec<Reply> {
    output(core)
        .into_iter()
        .filter_map(|(_, o)| o.reply())
        .collect()
}

#[test]
fn the_boot_configuration_names_the_rule_the_build_has() {
    let boot = FrontendConfig::lms291_boot(crate::geometry::ScanPlane::TiltedHorizontal);
    assert_eq!(boot.classifier.rule, NavigabilityRule::DEFAULT);
    assert!(boot.classifier.rule.is_built_in());
    if cfg!(feature = "plane-rule") {
        assert_eq!(
            boot.classifier.rule,
            NavigabilityRule::Plane(PlaneRule::DEFAULT)
        );
    } else {
        assert_eq!(boot.classifier.rule, NavigabilityRule::Spread);
    }
}

#[test]
fn a_setup_or_set_rule_that_names_the_plane_rule_is_taken_only_if_built_in() {
    let mut core = booted();
    let before = *core.frontend().config();
    let plane = rule_setup(&NavigabilityRule::Plane(PlaneRule::DEFAULT));
    let setup = Setup {
        mount_block: crate::wire::link::MountSetup::PRESET,
        filter: crate::wire::link::FilterSetup::NONE,
        mount: 1,
        measuring_mode: 3,
        field_deg: 180,
        resolution_cdeg: 50,
        sensor_m: [0.0, 0.0, 0.5],
        lines_per_observation: 1,
        robot_height_m: 1.0,
        step_threshold_m: 0.08,
        drop_threshold_m: 0.0,
        ceiling_m: 0.0,
        rule: plane,
        laser: LaserSetup::SICK,
    };
    let set_rule = SetRule {
        step_threshold_m: 0.08,
        rule: plane,
    };
    let mut bytes = command(0, &Message::Setup(setup));
    bytes.extend(command(1, &Message::SetRule(set_rule)));
    core.host(&bytes);
    let r = replies(&mut core);
    assert_eq!(r.len(), 2, "{r:?}");
    assert_eq!((r[0].to_type, r[1].to_type), (0x87, 0x8B));
    if cfg!(feature = "plane-rule") {
        assert!(r.iter().all(Reply::is_ok), "{r:?}");
        assert_eq!(
            core.frontend().config().classifier.rule,
            NavigabilityRule::Plane(PlaneRule::DEFAULT)
        );
        return;
    }
    for reply in &r {
        assert_eq!(
            (reply.code, reply.param),
            (ReplyCode::OutOfRange, SetupField::Rule as u8)
        );
        assert_eq!((reply.value, reply.a, reply.b), (1.0, 0.0, 0.0));
        let text = std::format!("{}", ReplyText(reply));
        assert!(
            text.contains(
                "setup navigability rule: the plane rule (1) is not built into the device"
            ),
            "{text}"
        );
    }
    // Nothing changed; the paper's rule is taken.
    assert_eq!(*core.frontend().config(), before);
    let paper = set_rule_message(&crate::classify::ClassifierConfig {
        rule: NavigabilityRule::Spread,
        step_threshold: Meters::from_num(0.08),
        ..before.classifier
    });
    core.host(&command(2, &Message::SetRule(paper)));
    let r = replies(&mut core);
    assert!(r.len() == 1 && r[0].is_ok(), "{r:?}");
    assert_eq!(
        core.frontend().config().classifier.rule,
        NavigabilityRule::Spread
    );
    // A rule beyond both is out of [0, 0] here, with the generic sentence.
    core.host(&command(
        3,
        &Message::SetRule(SetRule {
            rule: RuleSetup {
                rule: 2,
                ..RuleSetup::SPREAD
            },
            ..paper
        }),
    ));
    let r = replies(&mut core);
    assert_eq!((r[0].value, r[0].a, r[0].b), (2.0, 0.0, 0.0));
    assert!(std::format!("{}", ReplyText(&r[0])).contains("must lie within [0, 0] (got 2)"));
}
