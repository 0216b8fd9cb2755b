//! What the live outputs cost `pyramid listen`: CPU time and peak memory (RSS) of the binary
//! while a simulated device streams in real time at the SICK LMS2xx's full rate (13 575
//! points/s as evidence, the link's default budget of 46 080 B/s), with no output and with
//! every output on (ROS 2, Foxglove with a reading client, MCAP).
//!
//! A measurement, not a check: ignored by default, and run inside a network namespace of its
//! own (DDS multicast), against the binary named by `PYRAMID_BIN` (a release build):
//!
//! ```sh
//! cargo build --release -p terrain-pyramid-host --bin pyramid
//! cargo test -p terrain-pyramid-host --test outputs_cost --no-run   # prints the test binary
//! PYRAMID_BIN=$PWD/target/release/pyramid MEASURE_S=30 unshare -n sh -c \
//!   'ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && \
//!    exec "$0" --ignored --nocapture' target/debug/deps/outputs_cost-HASH
//! ```
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[path = "support/device.rs"]
mod support;
use support::{device, Plan, PATIENCE};
use terrain_pyramid_host::publish::only_loopback;

/// Clock ticks per second of /proc/PID/stat (Linux: 100 on every common configuration).
const TICKS: f64 = 100.0;

/// utime + stime, seconds, and the peak RSS, KiB, of a process.
fn usage(pid: u32) -> (f64, u64) {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .unwrap()
        .1
        .split_whitespace()
        .collect();
    let cpu = (fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap()) / TICKS;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let hwm = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .unwrap()
        .trim()
        .trim_end_matches(" kB")
        .parse()
        .unwrap();
    (cpu, hwm)
}

fn measure(bin: &str, seconds: u64, outputs: &[&str], name: &str) {
    let plan = Plan {
        steps: usize::MAX,
        step_sleep: Duration::from_millis(13),
        evidence_per_step: 176,
        close_when_settled: false,
        ..Plan::clean(99)
    };
    let dev = device(plan, true);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cost-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let addr = format!("127.0.0.1:{}", dev.port);
    let mut child = Command::new(bin)
        .args([
            "listen",
            "--tcp",
            &addr,
            "--out",
            dir.to_str().unwrap(),
            "--json",
        ])
        .args(outputs)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let err = BufReader::new(child.stderr.take().unwrap());
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in err.lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let py = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/py");
    let mut clients = Vec::new();
    if outputs.contains(&"--foxglove") {
        let url = loop {
            let line = rx.recv_timeout(PATIENCE).unwrap();
            if let Some(u) = line.strip_prefix("foxglove: serving ") {
                break u.to_string();
            }
        };
        std::thread::sleep(Duration::from_secs(1));
        clients.push(
            Command::new("python3")
                .arg(py.join("foxglove_client.py"))
                .arg(url)
                .stdout(Stdio::null())
                .spawn()
                .unwrap(),
        );
    }
    if outputs.contains(&"--ros2") {
        clients.push(
            Command::new("python3")
                .arg(py.join("dds_sub.py"))
                .args(["8", &seconds.to_string()])
                .stdout(Stdio::null())
                .spawn()
                .unwrap(),
        );
    }
    let start = Instant::now();
    let (cpu0, _) = usage(child.id());
    std::thread::sleep(Duration::from_secs(seconds));
    let (cpu1, hwm) = usage(child.id());
    let wall = start.elapsed().as_secs_f64();
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let out = child.wait_with_output().unwrap();
    dev.go.store(false, Ordering::SeqCst);
    let summary: serde_json::Value = serde_json::from_slice(out.stdout.trim_ascii()).unwrap();
    for mut c in clients {
        let _ = c.kill();
        let _ = c.wait();
    }
    let mcap = dir.join("s.mcap");
    let mcap_size = std::fs::metadata(&mcap).map(|m| m.len()).unwrap_or(0);
    println!(
        "{name}: cpu {:.1} % of one core over {wall:.1} s, peak RSS {:.1} MiB, frames {}, patches {}, gaps {}, synced {}, outputs {}, mcap {:.1} MiB",
        100.0 * (cpu1 - cpu0) / wall,
        hwm as f64 / 1024.0,
        summary["frames"],
        summary["patches"],
        summary["gaps"],
        summary["synced"],
        summary["outputs"]["frames_published"],
        mcap_size as f64 / 1_048_576.0,
    );
}

#[test]
#[ignore = "a measurement: run inside `unshare -n` with PYRAMID_BIN (see the file's doc)"]
fn listen_cost_with_and_without_outputs() {
    assert!(only_loopback(), "run inside `unshare -n` (DDS multicast)");
    let bin = std::env::var("PYRAMID_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_pyramid").into());
    let seconds: u64 = std::env::var("MEASURE_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cost-all");
    let mcap = dir.join("s.mcap");
    measure(&bin, seconds, &[], "no outputs");
    let mcap_arg = mcap.to_str().unwrap().to_string();
    measure(
        &bin,
        seconds,
        &["--ros2", "--foxglove", "127.0.0.1:0", "--mcap", &mcap_arg],
        "all",
    );
}
