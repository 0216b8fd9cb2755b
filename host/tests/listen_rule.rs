//! `pyramid listen --rule …`: the host tells a device its navigability rule with a SetRule
//! command before it asks for the maps, and only when a rule flag is given. A TCP server on
//! 127.0.0.1 stands for the device and decodes what the binary sends.
use std::io::Read;
use std::net::TcpListener;
use std::process::Command;
use std::time::{Duration, Instant};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::set_rule_message;
use terrain_pyramid::wire::link::{
    FrameAccumulator, Message, RuleSetup, SetRule, SnapshotScope, MAX_FRAME,
};
use terrain_pyramid::Meters;

#[path = "support/listen_device.rs"]
mod listen_device;
use listen_device::{each_frame, refused_before_connecting};

/// The frames `pyramid listen` sends with `flags` in its first second, decoded: (type, the
/// SetRule if it is one).
fn sent(flags: &[&str]) -> Vec<(u8, Option<SetRule>)> {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out =
        std::env::temp_dir().join(format!("pyramid-listen-rule-{}-{port}", std::process::id()));
    let mut child = Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args([
            "listen",
            "--tcp",
            &format!("127.0.0.1:{port}"),
            "--duration-s",
            "1",
        ])
        .arg("--out")
        .arg(&out)
        .args(flags)
        .spawn()
        .unwrap();
    let (mut stream, _) = listener.accept().unwrap();
    stream
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut bytes = Vec::new();
    let start = Instant::now();
    let mut buf = [0_u8; 1024];
    while start.elapsed() < Duration::from_millis(1500) {
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => bytes.extend_from_slice(&buf[..n]),
            Err(_) => {}
        }
    }
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&out);
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut frames = Vec::new();
    each_frame(&mut acc, &bytes, |_, message| {
        let set = match message {
            Message::SetRule(s) => Some(s),
            _ => None,
        };
        if let Message::RequestSnapshot(scope) = message {
            assert_eq!(scope, SnapshotScope::All);
        }
        // The time exchange's requests go on beside the commands (docs/poses.md).
        if !matches!(message, Message::TimeRequest(_)) {
            frames.push((message.msg_type().to_u8(), set));
        }
    });
    frames
}

#[test]
fn a_rule_flag_sends_set_rule_before_the_snapshot_request() {
    let frames = sent(&["--rule", "paper", "--step-m", "0.08"]);
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert_eq!(frames[0].0, 0x8B);
    assert_eq!(
        frames[0].1,
        Some(SetRule {
            step_threshold_m: Meters::from_num(0.08).to_num::<f32>(),
            rule: RuleSetup::SPREAD,
        })
    );
    assert_eq!(frames[1].0, 0x85);
    // The plane rule's parameters alone: the plane rule with them, the rest the defaults.
    let frames = sent(&["--max-slope-deg", "10"]);
    let mut expected = ClassifierConfig::DEFAULT;
    if let terrain_pyramid::classify::NavigabilityRule::Plane(ref mut p) = expected.rule {
        p.max_grade = terrain_pyramid::classify::Ratio::from_num(10_f64.to_radians().tan());
    }
    assert_eq!(frames[0].1, Some(set_rule_message(&expected)));
}

#[test]
fn without_rule_flags_the_device_keeps_its_rule() {
    let frames = sent(&[]);
    assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), [0x85]);
}

#[test]
fn a_bad_rule_flag_is_refused_before_connecting() {
    let stderr = refused_before_connecting(&["--rule", "plane", "--noise-factor", "-1"]);
    assert!(stderr.contains("--noise-factor"), "{stderr}");
}
