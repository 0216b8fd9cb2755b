//! The lab's tasks: `cargo xtask experiments|faults|soak|size|demo` build the lab (the `tools`
//! profile: release without fat LTO; `XTASK_LAB_PROFILE=dev` for the test build's) and run
//! `lab COMMAND FLAGS` from the root. The lab's stdout (its one JSON object with `--json`) is the task's; progress goes to stderr.
//!
//! - `faults [--json] [--quick] [--only KIND,..] [--lines N] [--jobs N]`: fault injection
//!   through the emulated board (RELIABILITY.md), N kinds at once (default: the cores); the
//!   firmware's logs in `target/faults`.
//! - `soak [--json] [--quick] [-- LAB-SOAK-FLAGS]`: the soak (RELIABILITY.md, "Soak"); the
//!   firmware's log in `target/soak`.
//! - `experiments [FLAGS]`, `size [FLAGS]`: `lab experiments` (its output in
//!   `target/experiments` unless `--out` is given) and `lab size`, every flag forwarded.
//! - `latency [--quick] [--json] [--no-ros2] [--publish-hz HZ] [--rate-hz HZ]`: `lab latency` with every
//!   output on (the readers installed first): telegram into the emulated board → each output's
//!   message out of the host. With ROS 2 (the default) the whole run, DDS publisher and reader
//!   together, is inside a network namespace of its own (`unshare -n`, loopback up with
//!   multicast routed to it), so no DDS traffic can leave the machine; root is needed.
//! - `live [--json] [--check] [--no-forward]`: `lab live --ros2` (a recording played as a robot lives: the
//!   laser paced into the emulated board, Odometry from a Cyclone DDS publisher, `pyramid
//!   listen --ros2 --odom-topic /odom`) inside a network namespace of its own, as `latency`.
//! - `demo [FLAGS]`: installs what the emulated board needs, as `cargo xtask test` does (the
//!   Cortex-M targets, QEMU, `defmt-print`), runs `lab demo` (on the emulated board unless
//!   `--board host` is given; into `target/demo` unless `--out` is given) and turns each
//!   run's defmt log into text beside it (`firmware.log`).
use crate::install::{
    ensure_defmt_print, ensure_python_readers, ensure_qemu, ensure_targets, root,
};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// Which build of the lab a task runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LabProfile {
    /// The `tools` profile of the root Cargo.toml: release without fat LTO (the default).
    Tools,
    /// The dev profile, as the workspace's tests build it (`cargo test --workspace
    /// --no-run`): right after `cargo test --workspace` it exists already, so the test suite's
    /// live check and CI's fault and soak smokes reuse it rather than compile the lab and its
    /// dependencies a second time (the dev profile optimises the library, the host side and
    /// the lab: root Cargo.toml).
    Dev,
}

impl LabProfile {
    /// `XTASK_LAB_PROFILE` (`tools` or `dev`; `tools` when unset).
    fn from_env() -> Result<Self, String> {
        match std::env::var("XTASK_LAB_PROFILE").as_deref() {
            Err(_) | Ok("tools") => Ok(Self::Tools),
            Ok("dev") => Ok(Self::Dev),
            Ok(other) => Err(format!(
                "XTASK_LAB_PROFILE={other}: use tools (the default) or dev"
            )),
        }
    }

    /// Builds the lab and the other `packages` in this profile (cargo does nothing when they
    /// are up to date); returns the lab's binary, beside which `pyramid` lies.
    fn build(self, packages: &[&str]) -> Result<PathBuf, String> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut build = Command::new(&cargo);
        let dir = match self {
            Self::Tools => {
                build.args(["build", "--profile", "tools", "--quiet", "-p", LAB]);
                for p in packages {
                    build.args(["-p", p]);
                }
                "tools"
            }
            // What `cargo test --workspace` builds, with its features (the dev-dependencies'
            // included): every package's binaries, the lab's and `pyramid` among them.
            Self::Dev => {
                build.args(["test", "--quiet", "--workspace", "--no-run"]);
                "debug"
            }
        };
        let built = build
            .current_dir(root())
            .status()
            .map_err(|e| format!("cannot run cargo: {e}"))?;
        if !built.success() {
            return Err(format!("building the lab ({self:?}) failed ({built})"));
        }
        Ok(root().join("target").join(dir).join("lab"))
    }
}

/// The lab's package.
const LAB: &str = "terrain-pyramid-lab";

/// Runs `lab command args` from the root, the lab built in `XTASK_LAB_PROFILE`'s profile
/// ([`LabProfile`]; by default `tools`, as `cargo run --profile tools -p terrain-pyramid-lab`).
fn lab(command: &str, args: &[String]) -> Result<(), String> {
    let started = Instant::now();
    let lab = LabProfile::from_env()?.build(&[])?;
    let status = Command::new(lab)
        .arg(command)
        .args(args)
        .current_dir(root())
        .status()
        .map_err(|e| format!("cannot run the lab: {e}"))?;
    finished(command, started, status, &format!("lab {command}"))
}

/// Reports how long `cargo xtask command` took, and its run's exit `status` as the result:
/// an error that names the run (`run`) unless it succeeded.
fn finished(
    command: &str,
    started: Instant,
    status: std::process::ExitStatus,
    run: &str,
) -> Result<(), String> {
    eprintln!(
        "xtask {command}: done in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    if status.success() {
        Ok(())
    } else {
        Err(format!("{run} failed ({status})"))
    }
}

/// Whether `args` give `flag` (as `--flag V` or `--flag=V`).
fn has(args: &[String], flag: &str) -> bool {
    args.iter()
        .any(|a| a == flag || a.starts_with(&format!("{flag}=")))
}

/// The value of `--flag` in `args`, if given.
fn value(args: &[String], flag: &str) -> Option<String> {
    let prefix = format!("{flag}=");
    args.iter().enumerate().find_map(|(i, a)| {
        if a == flag {
            args.get(i + 1).cloned()
        } else {
            a.strip_prefix(&prefix).map(str::to_string)
        }
    })
}

/// `args` with `--out DIR` added when they do not give one.
fn with_out(args: &[String], dir: &str) -> Vec<String> {
    let mut pass = args.to_vec();
    if !has(args, "--out") {
        pass.extend(["--out".to_string(), dir.to_string()]);
    }
    pass
}

/// Passes the option `flag` on to the lab with the value that follows it in `rest`.
fn pass_with_value<'a>(
    flag: &str,
    rest: &mut impl Iterator<Item = &'a String>,
    pass: &mut Vec<String>,
) -> Result<(), String> {
    let value = rest.next().ok_or(format!("{flag} needs a value"))?;
    pass.push(flag.to_string());
    pass.push(value.clone());
    Ok(())
}

/// `cargo xtask faults`.
pub fn faults(args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    let mut rest = args.iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--json" | "--quick" => pass.push(a.clone()),
            "--only" | "--lines" | "--jobs" => pass_with_value(a, &mut rest, &mut pass)?,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask faults [--json] [--quick] \
                     [--only KIND,..] [--lines N] [--jobs N]"
                ))
            }
        }
    }
    lab("faults", &with_out(&pass, "target/faults"))
}

/// `cargo xtask latency`.
pub fn latency(args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    let mut ros2 = true;
    let mut rest = args.iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--json" | "--quick" => pass.push(a.clone()),
            "--no-ros2" => ros2 = false,
            "--publish-hz" | "--rate-hz" => pass_with_value(a, &mut rest, &mut pass)?,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask latency [--quick] [--json] \
                     [--no-ros2] [--publish-hz HZ] [--rate-hz HZ]"
                ))
            }
        }
    }
    ensure_targets()?;
    ensure_qemu()?;
    ensure_python_readers()?;
    let pass = with_out(&pass, "target/latency");
    if !ros2 {
        return lab("latency", &pass);
    }
    in_network_namespace("latency", &pass, &[], LabProfile::from_env()?)
}

/// Runs `lab COMMAND --ros2 PASS…` inside a network namespace of its own (`unshare -n`,
/// loopback up with multicast on and the multicast route on it: DDS discovery stays on this
/// machine). The lab and the other `packages` (in `profile`) and the emulated board's firmware
/// are built outside it first: crates.io is not reachable inside.
fn in_network_namespace(
    command: &str,
    pass: &[String],
    packages: &[&str],
    profile: LabProfile,
) -> Result<(), String> {
    let lab = profile.build(packages)?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let firmware = Command::new(&cargo)
        .args([
            "build",
            "--release",
            "--quiet",
            "--target",
            "thumbv7em-none-eabihf",
        ])
        .current_dir(root().join("boards/qemu-mps2"))
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !firmware.success() {
        return Err(format!("building the firmware failed ({firmware})"));
    }
    let started = Instant::now();
    let status = Command::new("unshare")
        .args([
            "-n",
            "sh",
            "-c",
            "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo && exec \"$0\" \"$@\"",
        ])
        .arg(lab)
        .arg(command)
        .arg("--ros2")
        .args(pass)
        .current_dir(root())
        .status()
        .map_err(|e| format!("cannot run unshare (util-linux; root needed): {e}"))?;
    finished(
        command,
        started,
        status,
        &format!("lab {command} --ros2 inside `unshare -n`"),
    )
}

/// `cargo xtask live [--json] [--check] [--no-forward]`: `lab live --ros2` inside a network
/// namespace of its own (the lab, `pyramid` and the firmware built outside it first; the
/// Python readers installed). `--check` holds the run to `lab live`'s bounds (`cargo xtask
/// test` runs it); `--no-forward` runs listen without `--odom-topic`, the broken chain the
/// bounds must fail. The lab is built in `XTASK_LAB_PROFILE`'s profile ([`LabProfile`]).
pub fn live(args: &[String]) -> Result<(), String> {
    live_in(LabProfile::from_env()?, args)
}

/// [`live`] with the lab of `profile`.
pub fn live_in(profile: LabProfile, args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    for a in args {
        match a.as_str() {
            "--json" | "--check" | "--no-forward" => pass.push(a.clone()),
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask live [--json] [--check] \
                     [--no-forward]"
                ))
            }
        }
    }
    ensure_targets()?;
    ensure_qemu()?;
    ensure_python_readers()?;
    in_network_namespace(
        "live",
        &with_out(&pass, "target/live"),
        &["terrain-pyramid-host"],
        profile,
    )
}

/// `cargo xtask soak`.
pub fn soak(args: &[String]) -> Result<(), String> {
    let mut pass = Vec::new();
    let mut rest = false;
    for a in args {
        match a.as_str() {
            _ if rest => pass.push(a.clone()),
            "--json" | "--quick" => pass.push(a.clone()),
            "--" => rest = true,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask soak [--json] [--quick] \
                     [-- options of `lab soak`]"
                ))
            }
        }
    }
    lab("soak", &with_out(&pass, "target/soak"))
}

/// `cargo xtask experiments`.
pub fn experiments(args: &[String]) -> Result<(), String> {
    lab("experiments", &with_out(args, "target/experiments"))
}

/// `cargo xtask size`.
pub fn size(args: &[String]) -> Result<(), String> {
    lab("size", args)
}

/// `cargo xtask demo`.
pub fn demo(args: &[String]) -> Result<(), String> {
    ensure_targets()?;
    ensure_qemu()?;
    ensure_defmt_print()?;
    let pass = with_out(args, "target/demo");
    lab("demo", &pass)?;
    if value(&pass, "--board").as_deref() != Some("host") {
        let out = value(&pass, "--out").map_or_else(|| root().join("target/demo"), PathBuf::from);
        decode_logs(&root().join(out));
    }
    Ok(())
}

/// Turns each scenario's raw defmt log (`DIR/NAME/maps/firmware.defmt`) into text
/// (`firmware.log` beside it) with `defmt-print` and the firmware's ELF. A log that cannot
/// be decoded is reported, not an error: the maps are the demo's result.
fn decode_logs(out: &Path) {
    let elf = crate::install::boards_target_dir().join("thumbv7em-none-eabihf/release/qemu-mps2");
    let Ok(entries) = std::fs::read_dir(out) else {
        return;
    };
    let mut dirs: Vec<PathBuf> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
    dirs.sort();
    for dir in dirs {
        let raw = dir.join("maps").join("firmware.defmt");
        let (Ok(input), Ok(output)) = (
            std::fs::File::open(&raw),
            std::fs::File::create(dir.join("maps").join("firmware.log")),
        ) else {
            continue;
        };
        let decoded = Command::new("defmt-print")
            .arg("-e")
            .arg(&elf)
            .stdin(Stdio::from(input))
            .stdout(Stdio::from(output))
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if decoded {
            eprintln!(
                "firmware log: {}",
                dir.join("maps").join("firmware.log").display()
            );
        } else {
            eprintln!("note: defmt-print could not decode {}", raw.display());
        }
    }
}

/// Whether `cargo xtask live` can run here: root (for `unshare -n`) and `unshare` present;
/// why not otherwise.
pub fn live_can_run() -> Result<(), String> {
    let root_user = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0\n"));
    if !root_user {
        return Err("not root: `unshare -n` needs it".into());
    }
    if !Command::new("unshare")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Err("no `unshare` (util-linux)".into());
    }
    Ok(())
}
