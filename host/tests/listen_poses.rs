//! `pyramid listen --pose-udp` end to end: an in-process device (the library's `Link`, serving
//! TimeRequests with the µs clock of a board of its own: an offset, 100 ppm fast, wrapping
//! 2 s into the run) on 127.0.0.1; the `pyramid` binary syncs its clock with the device's and
//! forwards the poses a robot sends it as NDJSON datagrams. The device must receive them
//! stamped with its own time of the moment each pose names, within the link's accuracy; a
//! bad line, an out-of-order pose and poses before the clock was synced are counted, never
//! sent.
//!
//! The truth is computed here: the test knows the device's clock as a function of its own
//! monotonic clock, and its own wall clock against that.
#[path = "support/netns.rs"]
mod netns;
#[path = "support/device.rs"]
mod support;
use netns::{run_in_own_network_namespace, NETNS_MARK};

use serde_json::Value;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, UdpSocket};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use support::{booted, PATIENCE};
use terrain_pyramid::geometry::PoseTrack;
use terrain_pyramid::link::{Command as DeviceCommand, SensorCounters};
use terrain_pyramid::wire::FeedResult;

/// The device's clock: `start + elapsed × (1 + PPM / 10⁶)` µs, wrapping.
const PPM: i128 = 100;
const DEVICE_START_US: u32 = u32::MAX - 2_000_000;

/// The rebooted device's clock at its boot, µs: far from where the first boot's had got to.
const REBOOT_START_US: u32 = 1_000_000_000;

#[derive(Clone, Copy)]
struct DeviceClock {
    zero: Instant,
    start_us: u32,
}

impl DeviceClock {
    /// The clock at `t`, also before `zero` (what it would have read: wrapping).
    fn at(&self, t: Instant) -> u32 {
        let e = if t >= self.zero {
            t.duration_since(self.zero).as_nanos() as i128
        } else {
            -(self.zero.duration_since(t).as_nanos() as i128)
        };
        let us = e / 1_000 + e * PPM / 1_000_000_000;
        (i128::from(self.start_us) + us).rem_euclid(1 << 32) as u32
    }
}

/// A stamped pose the device took: its x (the test's index), stamp, and the boot it came in
/// (0 the first, 1 after the reboot).
#[derive(Debug, Clone, Copy)]
struct Received {
    x: f64,
    stamp_us: u32,
    boot: usize,
    /// Whether the device's track took it.
    taken: bool,
}

/// The device's boots: each one's clock.
type Boots = Arc<Mutex<Vec<DeviceClock>>>;

/// Serves one host connection until it goes away: Hello and Stats from `poll`, TimeReplies
/// from `serve` with the device time of the bytes that completed each request; Poses kept.
/// With `reboot_after`, the device reboots then, the connection kept (a board reset behind a
/// UART): a new link and pyramid (a boot Hello at the next poll) and a clock restarted at
/// [`REBOOT_START_US`], pushed to `boots`.
fn serve(
    listener: TcpListener,
    boots: Boots,
    poses: Arc<Mutex<Vec<Received>>>,
    reboot_after: Option<Duration>,
) {
    let (mut stream, _) = listener.accept().unwrap();
    // A blocking read that returns as soon as bytes come: the device's time of a request is
    // taken within microseconds of its arrival, as a board's receive interrupt does.
    stream
        .set_read_timeout(Some(Duration::from_millis(1)))
        .unwrap();
    stream.set_nodelay(true).unwrap();
    let (mut pyramid, mut link) = booted();
    let mut out = vec![0_u8; 4096];
    let mut rx = vec![0_u8; 4096];
    let start = Instant::now();
    let mut reboot_at = reboot_after.map(|d| start + d);
    let mut boot = 0;
    let mut clock = boots.lock().unwrap()[0];
    let mut track = PoseTrack::<16>::new();
    loop {
        assert!(start.elapsed() < PATIENCE, "the host never went away");
        if reboot_at.is_some_and(|r| Instant::now() >= r) {
            reboot_at = None;
            clock = DeviceClock {
                zero: Instant::now(),
                start_us: REBOOT_START_US,
            };
            boots.lock().unwrap().push(clock);
            boot += 1;
            track = PoseTrack::<16>::new();
            (pyramid, link) = booted();
        }
        let now_ms = u32::try_from(start.elapsed().as_millis()).unwrap();
        link.poll(now_ms, &mut *pyramid, &SensorCounters::default());
        match stream.read(&mut rx) {
            Ok(0) => return,
            Ok(n) => {
                let taken_at = clock.at(Instant::now());
                let mut input = &rx[..n];
                loop {
                    input = match link.receive_at(input, taken_at) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item, remaining, ..
                        } => {
                            if let Some(other) = link.serve(&mut pyramid, item) {
                                if let DeviceCommand::Pose(pose, Some(stamp_us)) = other.command {
                                    // The device's track decides what it takes
                                    // (`CoProcessor::stamped_pose`); a refused pose is never
                                    // placed.
                                    let taken = track.push(stamp_us, pose, taken_at).is_ok();
                                    poses.lock().unwrap().push(Received {
                                        x: pose.x.to_num::<f64>(),
                                        stamp_us,
                                        boot,
                                        taken,
                                    });
                                }
                            }
                            remaining
                        }
                        FeedResult::Rejected { remaining, .. } => remaining,
                    };
                }
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return,
        }
        let n = link.pop_bytes(&mut out);
        if stream.write_all(&out[..n]).is_err() {
            return;
        }
    }
}

fn wall_us() -> i128 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_micros() as i128
}

/// A simulated device on a free 127.0.0.1 port, its clock starting at [`DEVICE_START_US`]
/// (rebooting once after `reboot_after`): the port, the thread serving it ([`serve`]), its
/// boots' clocks and the poses it takes.
fn spawn_device(
    reboot_after: Option<Duration>,
) -> (
    u16,
    std::thread::JoinHandle<()>,
    Boots,
    Arc<Mutex<Vec<Received>>>,
) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let boots: Boots = Arc::new(Mutex::new(vec![DeviceClock {
        zero: Instant::now(),
        start_us: DEVICE_START_US,
    }]));
    let poses = Arc::new(Mutex::new(Vec::new()));
    let device = {
        let (poses, boots) = (Arc::clone(&poses), Arc::clone(&boots));
        std::thread::spawn(move || serve(listener, boots, poses, reboot_after))
    };
    (port, device, boots, poses)
}

/// `pyramid listen` on the device at 127.0.0.1:`port` for `duration_s` seconds, writing into
/// `dir`; more arguments may follow.
fn listen_command(port: u16, dir: &Path, duration_s: &str) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_pyramid"));
    command.args([
        "listen",
        "--tcp",
        &format!("127.0.0.1:{port}"),
        "--out",
        dir.to_str().unwrap(),
        "--duration-s",
        duration_s,
    ]);
    command
}

/// Waits for `pyramid listen` (`child`, which must succeed) and the device's thread; the
/// summary it wrote into `dir` and its stderr.
fn finished(
    child: std::process::Child,
    device: std::thread::JoinHandle<()>,
    dir: &Path,
) -> (Value, String) {
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    device.join().unwrap();
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    (summary, stderr)
}

/// An NDJSON pose line stamped `stamp_us` (wall-clock µs, written as seconds), the other
/// fields `fields` (JSON members, comma-separated).
fn pose_line(stamp_us: i128, fields: &str) -> String {
    format!(
        "{{\"t\": {}.{:06}, {fields}}}\n",
        stamp_us.div_euclid(1_000_000),
        stamp_us.rem_euclid(1_000_000)
    )
}

/// A robot sending poses to `addr` for `duration`: one every 20 ms (50 Hz), each stamped
/// 30 ms before it is sent (the wall clock, as ROS time), x = its index (from 1) / 1000, its
/// fields `fields_of(x)`; `after_each(index, robot, sent)` runs after each is sent. The
/// monotonic and wall clocks read together at the start, and every (x, stamp µs) sent.
fn send_poses(
    addr: std::net::SocketAddr,
    duration: Duration,
    fields_of: impl Fn(f64) -> String,
    mut after_each: impl FnMut(u32, &UdpSocket, &[(f64, i128)]),
) -> ((Instant, i128), Vec<(f64, i128)>) {
    let robot = UdpSocket::bind("127.0.0.1:0").unwrap();
    let anchor = (Instant::now(), wall_us());
    let mut sent: Vec<(f64, i128)> = Vec::new();
    let stop_at = Instant::now() + duration;
    let mut i = 0_u32;
    while Instant::now() < stop_at {
        i += 1;
        let stamp = wall_us() - 30_000;
        let x = f64::from(i) / 1000.0;
        let line = pose_line(stamp, &fields_of(x));
        robot.send_to(line.as_bytes(), addr).unwrap();
        sent.push((x, stamp));
        after_each(i, &robot, &sent);
        std::thread::sleep(Duration::from_millis(20));
    }
    (anchor, sent)
}

/// A session under test: the device (rebooting once after `reboot_after`), its clocks and the
/// poses it took, and `pyramid listen` on it for `duration_s` seconds with a UDP pose input,
/// writing into a fresh directory.
struct Session {
    device: std::thread::JoinHandle<()>,
    boots: Boots,
    poses: Arc<Mutex<Vec<Received>>>,
    pose_addr: std::net::SocketAddr,
    dir: std::path::PathBuf,
    child: std::process::Child,
}

fn start(name: &str, reboot_after: Option<Duration>, duration_s: &str) -> Session {
    let (port, device, boots, poses) = spawn_device(reboot_after);
    // A free UDP port for the pose input.
    let pose_addr = {
        let probe = UdpSocket::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap()
    };
    let dir = std::env::temp_dir().join(format!("pyramid-listen-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let child = listen_command(port, &dir, duration_s)
        .args(["--pose-udp", &pose_addr.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    Session {
        device,
        boots,
        poses,
        pose_addr,
        dir,
        child,
    }
}

#[test]
fn udp_poses_reach_the_device_stamped_in_its_own_clock() {
    let session = start("poses", None, "5");
    let clock = session.boots.lock().unwrap()[0];

    // The robot: 50 Hz poses, each stamped 30 ms before it is sent (the wall clock, as ROS
    // time), x = its index / 1000. Then one bad line and one pose older than the newest.
    let (anchor, sent) = send_poses(
        session.pose_addr,
        Duration::from_millis(4_000),
        |x| format!("\"frame\": \"odom\", \"x\": {x}, \"y\": 0.5, \"z\": 0, \"yaw\": 0.25"),
        |i, robot, sent| {
            if i == 150 {
                robot
                    .send_to(b"{\"t\": oops}\n", session.pose_addr)
                    .unwrap();
                let (_, old) = sent[sent.len() - 5];
                let line = pose_line(old, "\"x\": 9.0, \"y\": 0, \"yaw\": 0");
                robot.send_to(line.as_bytes(), session.pose_addr).unwrap();
            }
        },
    );
    let (summary, stderr) = finished(session.child, session.device, &session.dir);
    let sync = &summary["time_sync"];
    assert_eq!(sync["synced"], true, "{summary:#}");
    assert!(sync["exchanges"].as_u64().unwrap() >= 20, "{sync}");
    // The device's boot Hello may reset what the first exchanges taught; nothing else may.
    assert_eq!(sync["resets_inconsistent"], 0, "{sync}");
    assert_eq!(sync["resets_reconnect"], 0, "{sync}");
    assert!(sync["resets_boot"].as_u64().unwrap() <= 1, "{sync}");
    let drift = sync["drift_ppm"].as_f64().unwrap();
    assert!((drift - 100.0).abs() < 20.0, "drift {drift} ppm");
    let accuracy = sync["accuracy_us"].as_f64().unwrap();
    let p = &summary["poses"];
    assert_eq!(p["bad_not_json"], 1, "{p}");
    assert_eq!(p["out_of_order"], 1, "{p}");
    assert_eq!(p["frame"], "odom");
    assert_eq!(p["stale"], 0, "{p}");
    // The device's own count of the stamped poses.
    let received = session.poses.lock().unwrap().clone();
    assert_eq!(
        p["forwarded"].as_u64().unwrap(),
        received.len() as u64,
        "{p}"
    );
    assert!(received.iter().all(|r| r.taken), "every pose taken");
    // Most of 4 s at 50 Hz, less the first second's (the clock was not synced yet).
    assert!(received.len() > 75, "{} poses; {p}", received.len());
    assert!(p["unsynced"].as_u64().unwrap() > 0, "{p}");

    // Each stamp against the device's clock at the moment its pose names.
    let mut worst = 0_i64;
    for r in &received {
        let &(x, stamp) = sent
            .iter()
            .find(|(x, _)| (x - r.x).abs() < 1e-4)
            .unwrap_or_else(|| panic!("the device got a pose never sent: x {}", r.x));
        assert!((x - r.x).abs() < 1e-4);
        let at = anchor.0 + Duration::from_micros(u64::try_from(stamp - anchor.1).unwrap());
        let truth = clock.at(at);
        let error = i64::from(r.stamp_us.wrapping_sub(truth) as i32);
        worst = worst.max(error.abs());
    }
    eprintln!(
        "{} poses; worst stamp error {worst} µs, stated accuracy {accuracy:.0} µs, drift {drift:.1} ppm",
        received.len()
    );
    // The loopback's round trips are tens of µs (measured: errors of 4 to 21 µs); the margin
    // is for a loaded machine.
    assert!(worst <= 500, "worst stamp error {worst} µs");
    assert!(stderr.contains("clock: synced"), "{stderr}");
    let _ = std::fs::remove_dir_all(&session.dir);
}

/// The device reboots 2.5 s into the run (a new link, a boot Hello, its clock restarted far
/// from where it was) while the robot keeps sending: listen's clock sync resets on the boot
/// Hello, and every pose the device takes, before and after, is stamped in the clock of the
/// boot that takes it (none with the old mapping: that would be ~10⁹ µs off).
#[test]
fn a_device_reboot_resets_the_clock_and_no_pose_keeps_the_old_mapping() {
    let session = start("reboot", Some(Duration::from_millis(2_500)), "6");
    let (anchor, sent) = send_poses(
        session.pose_addr,
        Duration::from_millis(5_000),
        |x| format!("\"x\": {x}, \"y\": 0.5, \"yaw\": 0.25"),
        |_, _, _| {},
    );
    let (summary, _) = finished(session.child, session.device, &session.dir);
    let sync = &summary["time_sync"];
    assert_eq!(sync["synced"], true, "{summary:#}");
    assert!(sync["resets_boot"].as_u64().unwrap() >= 1, "{sync}");
    assert_eq!(sync["resets_reconnect"], 0, "{sync}");
    let boots = session.boots.lock().unwrap().clone();
    assert_eq!(boots.len(), 2, "the device rebooted once");
    let all = session.poses.lock().unwrap().clone();
    // A pose listen stamped before it heard of the reboot may reach the rebooted device: its
    // track must refuse it (it is ~10⁹ µs behind the new clock).
    let refused: Vec<_> = all.iter().filter(|r| !r.taken).collect();
    assert!(refused.iter().all(|r| r.boot == 1), "{refused:?}");
    let received: Vec<Received> = all.iter().copied().filter(|r| r.taken).collect();
    let per_boot = |b: usize| received.iter().filter(|r| r.boot == b).count();
    // Before: about 1.5 s once synced; after: about 2.5 s less the new sync.
    assert!(per_boot(0) > 25, "{} poses before the reboot", per_boot(0));
    assert!(per_boot(1) > 25, "{} poses after the reboot", per_boot(1));
    let mut worst = [0_i64; 2];
    for r in &received {
        let &(_, stamp) = sent
            .iter()
            .find(|(x, _)| (x - r.x).abs() < 1e-4)
            .unwrap_or_else(|| panic!("the device got a pose never sent: x {}", r.x));
        let at = anchor.0 + Duration::from_micros(u64::try_from(stamp - anchor.1).unwrap());
        let truth = boots[r.boot].at(at);
        let error = i64::from(r.stamp_us.wrapping_sub(truth) as i32);
        worst[r.boot] = worst[r.boot].max(error.abs());
    }
    eprintln!(
        "{} / {} poses taken before / after the reboot ({} refused); worst stamp error {} / {} µs; {sync}",
        per_boot(0),
        per_boot(1),
        refused.len(),
        worst[0],
        worst[1]
    );
    assert!(
        worst[0] <= 500 && worst[1] <= 500,
        "worst stamp errors {worst:?} µs"
    );
    let _ = std::fs::remove_dir_all(&session.dir);
}

// ------------------------------------------------------------------ ROS 2: publishers' QoS

/// `listen --odom-topic` takes the poses of publishers of another QoS than rclcpp's default:
/// one best effort (a sensor driver's), one transient local (a latched publisher's), both
/// Cyclone DDS (`lab/py/odom_pub.py`). The DDS traffic stays in a network namespace of its
/// own: this test binary again inside `unshare -n` (root), loopback up with multicast routed
/// to it, running [`odometry_qos_inner`].
#[test]
fn odometry_of_best_effort_and_transient_local_publishers_reaches_the_device() {
    let ok = Command::new("python3")
        .args(["-c", "import cyclonedds"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "the Python readers are missing: run host/tests/py/setup.sh (pip install -r host/tests/py/requirements.txt)"
    );
    let stderr = run_in_own_network_namespace("odometry_qos_inner");
    eprintln!(
        "{}",
        stderr
            .lines()
            .filter(|l| l.starts_with("qos:"))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// One Cyclone DDS publisher of the test: its QoS, and the x of its poses (its own range).
struct Publisher {
    reliability: &'static str,
    durability: &'static str,
    /// The poses' x: `x0 + k / 100`.
    x0: f64,
    /// When its first pose is stamped, seconds after the run's start.
    from_s: f64,
}

/// The poses a publisher is given: 1 s at 50 Hz from `from_s`, x = `x0 + k / 100`.
fn publisher_poses(p: &Publisher) -> String {
    (0..50)
        .map(|k| {
            let t = p.from_s + f64::from(k) * 0.02;
            let x = p.x0 + f64::from(k) / 100.0;
            format!("{{\"t\": {t}, \"pose\": [{x}, 0.5, 0.0, 0.0, 0.0, 0.25]}}\n")
        })
        .collect()
}

#[test]
#[ignore = "runs inside its own network namespace: odometry_of_best_effort_and_transient_local_publishers_reaches_the_device"]
fn odometry_qos_inner() {
    // DDS multicast must never leave the machine: refuse anywhere but an isolated namespace.
    assert!(
        std::env::var_os(NETNS_MARK).is_some() && terrain_pyramid_host::publish::only_loopback(),
        "odometry_qos_inner runs only inside `unshare -n` (see the test that calls it)"
    );
    let (port, device, boots, poses) = spawn_device(None);
    let clock = boots.lock().unwrap()[0];
    let dir = std::env::temp_dir().join(format!("pyramid-listen-qos-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let child = listen_command(port, &dir, "6")
        .args(["--ros2", "--ros-domain-id", "9", "--odom-topic", "/odom"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The publishers' poses: the best-effort one's first, then the transient-local one's; t = 0
    // 2.5 s from now (listen's clock synced after 1 s, DDS discovery done).
    let publishers = [
        Publisher {
            reliability: "best-effort",
            durability: "volatile",
            x0: 10.0,
            from_s: 0.0,
        },
        Publisher {
            reliability: "reliable",
            durability: "transient-local",
            x0: 20.0,
            from_s: 1.2,
        },
    ];
    let anchor = (Instant::now(), wall_us());
    let start_us = wall_us() + 2_500_000;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../lab/py/odom_pub.py");
    let running: Vec<_> = publishers
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let file = dir.join(format!("poses-{i}.ndjson"));
            std::fs::write(&file, publisher_poses(p)).unwrap();
            Command::new("python3")
                .arg(&script)
                .arg(&file)
                .arg(format!(
                    "{}.{:06}",
                    start_us.div_euclid(1_000_000),
                    start_us.rem_euclid(1_000_000)
                ))
                .args(["--domain", "9", "--wait-s", "4"])
                .args(["--reliability", p.reliability])
                .args(["--durability", p.durability])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("python3 runs")
        })
        .collect();
    let reports: Vec<Value> = running
        .into_iter()
        .map(|c| {
            let out = c.wait_with_output().unwrap();
            assert!(
                out.status.success(),
                "odom_pub.py: {}\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            serde_json::from_slice(&out.stdout).unwrap()
        })
        .collect();
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    device.join().unwrap();

    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["time_sync"]["synced"], true, "{summary:#}");
    let p = &summary["poses"];
    // Both publishers matched the subscription (each counted once), none refused for its QoS.
    let m = &p["ros2_publishers"];
    assert_eq!(m["matched_total"], 2, "{p}");
    assert_eq!(m["incompatible"], 0, "{p}");
    let received = poses.lock().unwrap().clone();
    for (r, publisher) in reports.iter().zip(&publishers) {
        assert_eq!(r["published"], 50, "{r}");
        assert_eq!(r["matched"], 1, "{r}");
        assert_eq!(r["reliability"], publisher.reliability, "{r}");
        assert_eq!(r["durability"], publisher.durability, "{r}");
    }
    // Each publisher's poses reached the device (its own range of x), stamped in its clock;
    // best effort on the loopback loses none but a loaded machine may drop a few.
    let mut worst = 0_i64;
    for publisher in &publishers {
        let mine: Vec<&Received> = received
            .iter()
            .filter(|r| (r.x - publisher.x0 - 0.25).abs() < 0.3)
            .collect();
        eprintln!(
            "qos: {} {}: {} of 50 poses taken by the device",
            publisher.reliability,
            publisher.durability,
            mine.iter().filter(|r| r.taken).count()
        );
        assert!(
            mine.iter().filter(|r| r.taken).count() >= 45,
            "{} {}: {} poses; {p}",
            publisher.reliability,
            publisher.durability,
            mine.len()
        );
        for r in mine {
            let k = ((r.x - publisher.x0) * 100.0).round();
            let stamp = start_us + ((publisher.from_s + k * 0.02) * 1e6).round() as i128;
            let at = anchor.0 + Duration::from_micros(u64::try_from(stamp - anchor.1).unwrap());
            let error = i64::from(r.stamp_us.wrapping_sub(clock.at(at)) as i32);
            worst = worst.max(error.abs());
        }
    }
    // Every pose received counted by listen, and forwarded as the device got it.
    assert_eq!(
        p["forwarded"].as_u64().unwrap(),
        received.len() as u64,
        "{p}"
    );
    assert!(p["received"].as_u64().unwrap() >= 90, "{p}");
    eprintln!("qos: worst stamp error {worst} µs; listen's poses {p}");
    // As the UDP test's (tens of µs on the loopback), with room for a loaded machine.
    assert!(worst <= 1_000, "worst stamp error {worst} µs");
    let _ = std::fs::remove_dir_all(&dir);
}
