//! `pyramid listen --rig FILE`: the host sends the device its Setup (the rig's sensor, mount,
//! actuator and observation policy, the classifier's thresholds) on connecting and again on
//! every reconnection, before it asks for the maps; a device that refuses it has the field
//! and its rule shown on the terminal. A TCP server on 127.0.0.1 stands for the device: it
//! decodes what the binary sends, drops the connection once, and answers with the library's
//! own link.
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::{setup_refusal, SetupError, SetupField};
use terrain_pyramid::link::{Link, LinkConfig};
use terrain_pyramid::wire::link::{
    encode, ClockSource, FirmwareVersion, FrameAccumulator, Header, Hello, HelloReason, Message,
    Setup, MAX_FRAME, VERSION,
};
use terrain_pyramid_host::rigfile::{device_setup, read_rig_file};

#[path = "support/listen_device.rs"]
mod listen_device;
#[path = "support/accept.rs"]
mod support_accept;
use listen_device::{each_frame, refused_before_connecting};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/rigs")
        .join(name)
}

/// The next connection, or a failed test after 30 s (the host exited early).
fn accept(listener: &TcpListener) -> TcpStream {
    support_accept::accept(listener, Duration::from_secs(30), false)
}

fn listen(port: u16, out: &Path, flags: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args(["listen", "--tcp", &format!("127.0.0.1:{port}")])
        .arg("--out")
        .arg(out)
        .args(flags)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The commands a connection carries until `until` passes or the host closes it (time
/// requests left out), with their headers; `answer` may write back on the stream.
fn frames(
    stream: &mut TcpStream,
    until: Duration,
    mut answer: impl FnMut(&mut TcpStream, Header, &Message<'_>),
) -> Vec<(u8, Option<Setup>)> {
    stream
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut out = Vec::new();
    let start = Instant::now();
    let mut buf = [0_u8; 1024];
    while start.elapsed() < until {
        let n = match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(_) => continue,
        };
        each_frame(&mut acc, &buf[..n], |header, message| {
            answer(stream, header, &message);
            if !matches!(message, Message::TimeRequest(_)) {
                let setup = match message {
                    Message::Setup(s) => Some(s),
                    _ => None,
                };
                out.push((message.msg_type().to_u8(), setup));
            }
        });
    }
    out
}

#[test]
fn the_rig_s_setup_is_sent_at_connect_and_again_after_a_reconnect() {
    let rig_path = example("rplidar-panned.toml");
    let rig = read_rig_file(&rig_path).unwrap();
    let classifier = rig.classifier.apply(ClassifierConfig::DEFAULT).unwrap();
    let expected = device_setup(&rig, &classifier).unwrap();
    assert_eq!(expected.laser.sensor, 2);
    assert!(
        expected.ceiling_m > 1.7,
        "the rig file's classifier is carried"
    );

    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out = std::env::temp_dir().join(format!("pyramid-listen-setup-{}", std::process::id()));
    let rig_arg = rig_path.to_str().unwrap();
    let child = listen(
        port,
        &out,
        &["--reconnect", "--duration-s", "4", "--rig", rig_arg],
    );
    let mut first = accept(&listener);
    let before = frames(&mut first, Duration::from_millis(800), |_, _, _| {});
    drop(first); // the device goes away: the host reconnects
    let mut second = accept(&listener);
    let after = frames(&mut second, Duration::from_secs(6), |_, _, _| {});
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    let _ = std::fs::remove_dir_all(&out);
    for (name, got) in [("at connect", &before), ("after the reconnect", &after)] {
        assert!(got.len() >= 2, "{name}: {got:?}\n{stderr}");
        assert_eq!(got[0].0, 0x87, "{name}: Setup first: {got:?}");
        assert_eq!(got[0].1, Some(expected), "{name}");
        assert_eq!(got[1].0, 0x85, "{name}: then RequestSnapshot: {got:?}");
        assert_eq!(got.iter().filter(|f| f.0 == 0x87).count(), 1, "{name}");
    }
    assert!(stderr.contains("reconnected"), "{stderr}");
}

#[test]
fn a_device_that_boots_while_connected_is_sent_the_rig_s_setup_and_rule_again() {
    // A watchdog reset behind a serial port that stays open: the connection goes on, and
    // the device says it booted.
    let rig_path = example("ld19-nodding.toml");
    let rig = read_rig_file(&rig_path).unwrap();
    let classifier = rig.classifier.apply(ClassifierConfig::DEFAULT).unwrap();
    let expected = device_setup(&rig, &classifier).unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out = std::env::temp_dir().join(format!("pyramid-listen-setup-b-{}", std::process::id()));
    let child = listen(
        port,
        &out,
        &[
            "--duration-s",
            "3",
            "--rig",
            rig_path.to_str().unwrap(),
            "--rule",
            "plane",
        ],
    );
    let mut stream = accept(&listener);
    let before = frames(&mut stream, Duration::from_millis(800), |_, _, _| {});
    let hello = Hello {
        protocol: VERSION,
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        reason: HelloReason::Boot,
        cells_per_side: 64,
        resend: 0,
        clock: ClockSource::NotReported,
        layers: Default::default(),
    };
    let mut buf = [0_u8; 128];
    let n = encode(0, &Message::Hello(hello), &mut buf).unwrap();
    stream.write_all(&buf[..n]).unwrap();
    let after = frames(&mut stream, Duration::from_millis(4000), |_, _, _| {});
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    let _ = std::fs::remove_dir_all(&out);
    let types = |got: &[(u8, Option<Setup>)]| got.iter().map(|f| f.0).collect::<Vec<_>>();
    assert_eq!(types(&before), [0x87, 0x8B, 0x85], "{before:?}\n{stderr}");
    // After the boot Hello: the rig's design (a Configure: the Hello describes another
    // pyramid, `host/tests/listen_design.rs`), then the Setup, the SetRule and a snapshot
    // request again, once.
    assert_eq!(
        types(&after).get(..4),
        Some(&[0x83, 0x87, 0x8B, 0x85][..]),
        "{after:?}\n{stderr}"
    );
    assert_eq!(after[1].1, Some(expected));
    assert_eq!(after.iter().filter(|f| f.0 == 0x87).count(), 1, "{after:?}");
    assert!(
        stderr.contains("device booted: the rig's setup and rule sent again"),
        "{stderr}"
    );
    assert!(!stderr.contains("reconnected"), "{stderr}");
}

#[test]
fn rule_flags_override_the_rig_file_and_follow_its_setup_as_set_rule() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out = std::env::temp_dir().join(format!("pyramid-listen-setup-r-{}", std::process::id()));
    let rig_arg = example("ld19-nodding.toml");
    let child = listen(
        port,
        &out,
        &[
            "--duration-s",
            "1",
            "--rig",
            rig_arg.to_str().unwrap(),
            "--rule",
            "paper",
            "--mount-xyz-m",
            "0.2,0,0.35",
        ],
    );
    let mut stream = accept(&listener);
    let got = frames(&mut stream, Duration::from_millis(1500), |_, _, _| {});
    let _ = child.wait_with_output().unwrap();
    let _ = std::fs::remove_dir_all(&out);
    let types: Vec<u8> = got.iter().map(|f| f.0).collect();
    assert_eq!(types, [0x87, 0x8B, 0x85], "{got:?}");
    let setup = got[0].1.unwrap();
    assert_eq!(setup.rule.rule, 0, "--rule paper over the file's plane");
    assert_eq!(setup.sensor_m, [0.2, 0.0, 0.35]);
    assert_eq!((setup.laser.sensor, setup.laser.actuator), (1, 1));
}

#[test]
fn a_refused_setup_shows_the_field_and_its_rule() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let out = std::env::temp_dir().join(format!("pyramid-listen-setup-x-{}", std::process::id()));
    let child = listen(
        port,
        &out,
        &["--duration-s", "1.5", "--sensor", "ld19", "--rule", "plane"],
    );
    let mut stream = accept(&listener);
    // A device built without the plane rule refuses it (param 65, value 1 in [0, 0]), with
    // the library's own refusal, framed by the library's link.
    let mut link: Link = Link::new(LinkConfig::DEFAULT);
    let got = frames(&mut stream, Duration::from_millis(2500), |s, header, m| {
        if let Message::Setup(setup) = m {
            assert_eq!(setup.rule.rule, 1);
            link.refuse(setup_refusal(
                header,
                &SetupError::OutOfRange {
                    field: SetupField::Rule,
                    value: 1.0,
                    min: 0.0,
                    max: 0.0,
                },
            ));
            let mut buf = [0_u8; 256];
            let n = link.pop_bytes(&mut buf);
            assert!(n > 0);
            s.write_all(&buf[..n]).unwrap();
        }
    });
    let o = child.wait_with_output().unwrap();
    let _ = std::fs::remove_dir_all(&out);
    assert_eq!(got.first().map(|f| f.0), Some(0x87), "{got:?}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("refused the rig's setup: setup navigability rule")
            && stderr.contains("plane rule (1) is not built into the device"),
        "{stderr}"
    );
}

#[test]
fn a_rig_the_device_would_refuse_is_refused_before_connecting() {
    let stderr = refused_before_connecting(&[
        "--sensor",
        "ld06",
        "--mask-deg",
        "170:190",
        "--filter-min-range-m",
        "0.5",
        "--filter-max-range-m",
        "0.2",
    ]);
    assert!(stderr.contains("--filter-max-range-m"), "{stderr}");
}
