//! `pyramid listen --rig FILE` with a `[design]`: the device is sent the rig's design (a
//! Configure) when it runs another pyramid, and only then, so that a device already running
//! it keeps its maps across sessions. The device is the library's whole co-processor
//! (`CoProcessor`, booted as the boards boot), served on 127.0.0.1: it takes the binary's
//! bytes and answers with its own.
use std::io::{ErrorKind, Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use terrain_pyramid::app::CoProcessor;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::grid::Resolution;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{FrameAccumulator, MessageType, MAX_FRAME};
use terrain_pyramid::{
    Config, DefaultCoProcessor, DEFAULT_CELLS_PER_SIDE, DEFAULT_CLASSIFIER_SLOTS, DEFAULT_LAYERS,
};
use terrain_pyramid_host::design::firmware_design;
use terrain_pyramid_host::rigfile::read_rig_file;

#[path = "support/listen_device.rs"]
mod listen_device;
#[path = "support/accept.rs"]
mod support_accept;
use listen_device::each_frame;

/// The longest a session waits for the other end.
const PATIENCE: Duration = Duration::from_secs(60);

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/rigs")
        .join(name)
}

/// What the device saw of one connection and the pyramid it ran when it ended.
struct Served {
    /// The host's commands, by message type, in order (time requests left out).
    commands: Vec<u8>,
    /// Each layer's cell, raw Q16.16, as the device's pyramid holds it.
    cells_q16: Vec<i32>,
}

/// Boots the library's co-processor as the boards boot (the firmware's design, a SICK's
/// setup) and serves `connections` connections from `listener` one after another with it,
/// each until the host goes away, keeping it (and its maps) between them. Runs on a thread
/// with a stack that holds a co-processor.
fn device(listener: TcpListener, connections: usize) -> mpsc::Receiver<Served> {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || {
            let mut core: Box<DefaultCoProcessor> = Box::new(CoProcessor::<
                DEFAULT_CELLS_PER_SIDE,
                DEFAULT_LAYERS,
                DEFAULT_CLASSIFIER_SLOTS,
                2048,
            >::new());
            core.boot(
                LinkConfig::DEFAULT,
                &firmware_design().unwrap(),
                &Config::default(),
                FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal),
            )
            .unwrap();
            let start = Instant::now();
            for _ in 0..connections {
                let mut stream = support_accept::accept(&listener, PATIENCE, true);
                let mut acc = FrameAccumulator::<MAX_FRAME>::new();
                let mut commands = Vec::new();
                let mut rx = [0_u8; 4096];
                let mut out = [0_u8; 4096];
                let opened = Instant::now();
                loop {
                    assert!(opened.elapsed() < PATIENCE, "the host never went away");
                    match stream.read(&mut rx) {
                        Ok(0) => break,
                        Ok(n) => {
                            each_frame(&mut acc, &rx[..n], |_, message| {
                                if message.msg_type() != MessageType::TimeRequest {
                                    commands.push(message.msg_type().to_u8());
                                }
                            });
                            core.host(&rx[..n]);
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {
                            std::thread::sleep(Duration::from_millis(1));
                        }
                        Err(_) => break,
                    }
                    let now_ms = u32::try_from(start.elapsed().as_millis()).unwrap();
                    core.poll(now_ms);
                    loop {
                        let n = core.take_output(&mut out);
                        if n == 0 {
                            break;
                        }
                        if stream.write_all(&out[..n]).is_err() {
                            break;
                        }
                    }
                }
                let cells_q16 = (0..DEFAULT_LAYERS)
                    .filter_map(|k| core.pyramid().layer(k))
                    .map(|l| l.resolution().to_bits())
                    .filter(|&bits| bits != 0)
                    .collect();
                tx.send(Served {
                    commands,
                    cells_q16,
                })
                .unwrap();
            }
        })
        .unwrap();
    rx
}

fn listen(port: u16, out: &Path, rig: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pyramid"))
        .args(["listen", "--tcp", &format!("127.0.0.1:{port}")])
        .arg("--out")
        .arg(out)
        .args(["--duration-s", "2.5", "--json", "--rig"])
        .arg(rig)
        .output()
        .unwrap()
}

fn summary(o: &Output) -> serde_json::Value {
    let stdout = String::from_utf8_lossy(&o.stdout);
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

#[test]
fn the_rig_s_design_is_configured_once_and_a_device_running_it_keeps_its_maps() {
    let rig_path = example("ld19-nodding.toml");
    let spec = read_rig_file(&rig_path).unwrap().design.unwrap();
    let (_, wanted) = spec.design(DEFAULT_CELLS_PER_SIDE).unwrap();
    let wanted_q16: Vec<i32> = wanted
        .layers()
        .iter()
        .map(|l| Resolution::from_m(l.resolution_m).unwrap().to_bits())
        .collect();
    let boot_q16: Vec<i32> = firmware_design()
        .unwrap()
        .layers()
        .iter()
        .map(|l| Resolution::from_m(l.resolution_m).unwrap().to_bits())
        .collect();
    assert_ne!(
        wanted_q16, boot_q16,
        "the test needs a design other than the boot one"
    );

    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let served = device(listener, 2);
    let out = std::env::temp_dir().join(format!("pyramid-listen-design-{}", std::process::id()));

    // A device on its boot design: the rig's Setup, then the Configure once its Hello shows
    // another pyramid; the device takes it and runs the rig's design.
    let first = listen(port, &out, &rig_path);
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(first.status.success(), "{stderr}");
    let device_first = served.recv_timeout(PATIENCE).unwrap();
    let configure = MessageType::Configure.to_u8();
    assert_eq!(
        device_first
            .commands
            .iter()
            .filter(|&&t| t == configure)
            .count(),
        1,
        "{:?}\n{stderr}",
        device_first.commands
    );
    assert_eq!(device_first.cells_q16, wanted_q16, "{stderr}");
    assert!(stderr.contains("the rig's design sent"), "{stderr}");
    assert!(
        stderr.contains("device: the rig's design taken"),
        "{stderr}"
    );
    assert_eq!(summary(&first)["configures_sent"], 1);

    // The next session finds the device running it: no Configure, the maps kept.
    let second = listen(port, &out, &rig_path);
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{stderr}");
    let device_second = served.recv_timeout(PATIENCE).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    assert!(
        !device_second.commands.contains(&configure),
        "{:?}\n{stderr}",
        device_second.commands
    );
    assert_eq!(device_second.cells_q16, wanted_q16);
    assert!(stderr.contains("device: runs the rig's design"), "{stderr}");
    assert_eq!(summary(&second)["configures_sent"], 0);
}

#[test]
fn a_design_the_device_cannot_hold_is_refused_by_it_and_shown() {
    // Twelve layers: the library builds them on the host (16 layers), the boards hold 8.
    let dir = std::env::temp_dir().join(format!("pyramid-listen-design-r-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rig = dir.join("rig.toml");
    std::fs::write(
        &rig,
        "[sensor]\nkind = \"ld19\"\n[design]\nmax_range_m = 12\ngamma = 1.5\n",
    )
    .unwrap();
    let layers = read_rig_file(&rig)
        .unwrap()
        .design
        .unwrap()
        .design(DEFAULT_CELLS_PER_SIDE)
        .unwrap()
        .1
        .layers()
        .len();
    assert!(layers > DEFAULT_LAYERS && layers <= 16, "{layers}");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let served = device(listener, 1);
    let o = listen(port, &dir.join("out"), &rig);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let device = served.recv_timeout(PATIENCE).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: the device refused the rig's design"),
        "{stderr}"
    );
    // It keeps the pyramid it booted with, and is asked once.
    assert_eq!(device.cells_q16.len(), DEFAULT_LAYERS);
    assert_eq!(
        device
            .commands
            .iter()
            .filter(|&&t| t == MessageType::Configure.to_u8())
            .count(),
        1
    );
}

#[test]
fn a_rig_s_design_the_library_refuses_ends_the_command_before_connecting() {
    let dir = std::env::temp_dir().join(format!("pyramid-listen-design-x-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rig = dir.join("rig.toml");
    // Δd = 0.1 m is not above φ·h = 0.35 m: layer 0's band is empty.
    std::fs::write(
        &rig,
        "[sensor]\nkind = \"ld19\"\n[design]\nphi_deg = 10\nheight_m = 2\n",
    )
    .unwrap();
    let stderr = listen_device::refused_before_connecting(&["--rig", rig.to_str().unwrap()]);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(stderr.contains("the rig's [design]"), "{stderr}");
}
