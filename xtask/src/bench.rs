//! `cargo xtask bench [--json] [--quick]`:
//!
//! 1. simulates the paper's stairs (`host-tests`' simulator) into `target/bench/*.rec`;
//! 2. builds the bench firmware (`boards/bench`) for thumbv7em-none-eabihf (M4F) and
//!    thumbv6m-none-eabi (M0 code) with that recording embedded;
//! 3. runs each variant in QEMU (`mps2-an386`) with `-singlestep -d exec,nochain`, streams the
//!    trace through a FIFO and counts the instructions executed between `bench_start` and
//!    `bench_end` (one trace line per instruction), with a per-function histogram
//!    (`profile-*.txt`) and a per-source-line one through the DWARF inline frames
//!    (`lines-*.txt`, `bench/lines.rs`);
//! 4. reads flash and static RAM from the ELF (`object`);
//! 5. times the library's pipeline on the host (`bench-host`, release) and OctoMap
//!    (`bench/octomap/harness.cpp`, built with g++) on the same returns;
//! 6. prints a table (stderr) and the results (stdout; one JSON object with `--json`).
//!
//! The variants run the library's default navigability rule (the plane rule);
//! `pyramid-paper` is `pyramid-nolink` under the paper's spread rule; `pyramid-hard` is
//! `pyramid` with the hard gate (one fed layer per point, where the default soft gate feeds
//! about three).
//!
//! A fresh machine: the missing rustup targets, `qemu-system-arm` and `liboctomap-dev` are
//! installed (apt-get, through sudo when not root).

use crate::install::root;
use object::{Object, ObjectSection};
use std::collections::HashMap;
use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};

mod count;
mod lidar;
mod lines;

use count::{symbol_address, trace, Run};

type Result<T> = std::result::Result<T, String>;

const M4F: &str = "thumbv7em-none-eabihf";
const M0: &str = "thumbv6m-none-eabi";

/// `cargo xtask bench [--json] [--quick] [--singlestep]`.
pub fn task(args: &[String]) -> std::result::Result<(), String> {
    let mut opts = Opts::default();
    for a in args {
        match a.as_str() {
            "--json" => opts.json = true,
            "--quick" => opts.quick = true,
            "--singlestep" => opts.singlestep = true,
            "--lidars" => opts.lidars = true,
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask bench [--json] [--quick] [--singlestep]"
                ))
            }
        }
    }
    let t = Instant::now();
    if opts.lidars {
        // Only the spinning lidars' rows (bench/lidar.rs).
        ensure_tools()?;
        let rows = serde_json::json!({ "lidars": lidar::rows(opts.quick)? });
        print_json(&rows, opts.json)?;
        eprintln!("xtask bench: done in {:.1} s", t.elapsed().as_secs_f64());
        return Ok(());
    }
    bench(&opts)?;
    eprintln!("xtask bench: done in {:.1} s", t.elapsed().as_secs_f64());
    Ok(())
}

#[derive(Default)]
struct Opts {
    json: bool,
    quick: bool,
    singlestep: bool,
    lidars: bool,
}

/// Runs a command, failing with its stderr.
fn run(cmd: &mut Command) -> Result<String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{cmd:?} failed ({}):\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Runs a command with its output (stdout too) on our stderr (builds, installs): stdout holds
/// only the results.
fn run_loud(cmd: &mut Command) -> Result<()> {
    let status = cmd
        .stdout(std::io::stderr())
        .stderr(Stdio::inherit())
        .status()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{cmd:?} failed ({status})"))
    }
}

fn have(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn apt_install(packages: &[&str]) -> Result<()> {
    let root_user = run(Command::new("id").arg("-u")).is_ok_and(|u| u.trim() == "0");
    let sudo = |args: &[&str]| {
        let mut c = if root_user {
            Command::new(args[0])
        } else {
            let mut c = Command::new("sudo");
            c.arg(args[0]);
            c
        };
        c.args(&args[1..]).env("DEBIAN_FRONTEND", "noninteractive");
        c
    };
    eprintln!("xtask bench: installing {packages:?} (apt-get)");
    run_loud(&mut sudo(&["apt-get", "update", "-qq"]))?;
    let mut args = vec!["apt-get", "install", "-y", "-qq"];
    args.extend_from_slice(packages);
    run_loud(&mut sudo(&args))
}

/// Installs what a fresh machine lacks.
fn ensure_tools() -> Result<()> {
    let installed =
        run(Command::new("rustup").args(["target", "list", "--installed"])).unwrap_or_default();
    for target in [M4F, M0] {
        if !installed.lines().any(|l| l.trim() == target) {
            eprintln!("xtask bench: rustup target add {target}");
            run_loud(Command::new("rustup").args(["target", "add", target]))?;
        }
    }
    let mut missing = Vec::new();
    if !have("qemu-system-arm") {
        missing.push("qemu-system-arm");
    }
    if !Path::new("/usr/include/octomap/octomap.h").exists() {
        missing.push("liboctomap-dev");
    }
    if !have("g++") {
        missing.push("g++");
    }
    if !missing.is_empty() {
        apt_install(&missing)?;
    }
    Ok(())
}

/// Writes `bytes` to `path` unless it holds them already (so that cargo does not rebuild).
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<()> {
    if fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// The 1-minute load average (`/proc/loadavg`), or NaN where there is none.
fn load_average() -> f64 {
    fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(f64::NAN)
}

/// Flash (loadable sections in the FLASH region, less the embedded recording) and static
/// RAM (allocated sections in RAM) of an ELF.
fn sizes(elf_path: &Path) -> Result<(u64, u64, u64)> {
    let elf = fs::read(elf_path).map_err(|e| format!("{}: {e}", elf_path.display()))?;
    let file = object::File::parse(&*elf).map_err(|e| e.to_string())?;
    let (mut flash, mut ram) = (0, 0);
    for s in file.sections() {
        let name = s.name().unwrap_or("");
        let size = s.size();
        if s.address() >= 0x2000_0000 {
            if matches!(name, ".data" | ".bss" | ".uninit") {
                ram += size;
            }
            if name == ".data" {
                flash += size; // its initial image
            }
        } else if matches!(name, ".vector_table" | ".text" | ".rodata") {
            flash += size;
        }
    }
    let (_, recording) = symbol_address(&elf, "BENCH_RECORDING")?;
    Ok((flash - recording, ram, recording))
}

/// One bench binary through the emulator's trace: its counts, and its profiles by function,
/// by address and by source line in `work` (`profile-`, `counts-`, `lines-TARGET-BIN.txt`).
fn measure(
    elf: &Path,
    target: &str,
    bin: &str,
    work: &Path,
    root: &Path,
    singlestep: bool,
) -> Result<Run> {
    let t = Instant::now();
    let fifo = work.join(format!("trace-{target}-{bin}.fifo"));
    let r = trace(elf, &fifo, singlestep)?;
    eprintln!(
        "xtask bench: {target} {bin}: {} instructions, {} returns, {} lines, {} cells reset, stack {} B ({:.1} s)",
        r.instructions,
        r.returns,
        r.lines,
        r.cells,
        r.stack,
        t.elapsed().as_secs_f64()
    );
    let mut profile = String::new();
    for (name, n) in &r.histogram {
        profile.push_str(&format!(
            "{n:>12} {:>6.1}% {:>8.2}/ret  {name}\n",
            100.0 * *n as f64 / r.instructions.max(1) as f64,
            *n as f64 / r.returns.max(1) as f64
        ));
    }
    write_if_changed(
        &work.join(format!("profile-{target}-{bin}.txt")),
        profile.as_bytes(),
    )?;
    // Every executed address with its count, for annotating a disassembly
    // (`arm-none-eabi-objdump -d` of the same ELF).
    let mut counts = String::new();
    let mut per_pc = r.per_pc.clone();
    per_pc.sort_unstable();
    for (pc, n) in per_pc {
        counts.push_str(&format!("{pc:08x} {n}\n"));
    }
    write_if_changed(
        &work.join(format!("counts-{target}-{bin}.txt")),
        counts.as_bytes(),
    )?;
    let by_line = lines::profile(elf, &r, root)?;
    write_if_changed(
        &work.join(format!("lines-{target}-{bin}.txt")),
        by_line.as_bytes(),
    )?;
    Ok(r)
}

fn bench(opts: &Opts) -> Result<()> {
    ensure_tools()?;
    let root = root();
    let work = root.join("target").join("bench");
    fs::create_dir_all(&work).map_err(|e| e.to_string())?;

    // 1. The recording.
    let (stand_s, distance_m) = if opts.quick { (0.2, 4.2) } else { (1.0, 1.0) };
    let sim = simulate(&SimConfig::paper_stairs(stand_s, 1.0, distance_m)).map_err(|e| e.0)?;
    let rec = work.join(if opts.quick {
        "stairs-quick.rec"
    } else {
        "stairs.rec"
    });
    write_if_changed(&rec, &sim.bytes)?;
    eprintln!(
        "xtask bench: recording {} ({} lines, {} bytes; stairs, stand {stand_s} s, 1 m/s to {distance_m} m)",
        rec.display(),
        sim.lines,
        sim.bytes.len()
    );

    // 2. The firmware, both targets (one cargo build each).
    let board = root.join("boards").join("bench");
    for target in [M4F, M0] {
        run_loud(
            Command::new("cargo")
                .current_dir(&board)
                .args(["build", "--release", "--quiet", "--target", target])
                .env("BENCH_RECORDING", &rec)
                .env_remove("CARGO_TARGET_DIR"),
        )?;
    }
    let target_dir = crate::install::boards_target_dir();
    let elf = |target: &str, bin: &str| target_dir.join(target).join("release").join(bin);

    // 3. Instruction counts.
    let mut runs: HashMap<(&str, &str), Run> = HashMap::new();
    let variants: &[(&str, &str)] = &[
        (M4F, "pyramid"),
        (M4F, "flat"),
        (M4F, "window"),
        (M4F, "pyramid-hard"),
        (M4F, "pyramid-nolink"),
        (M4F, "pyramid-paper"),
        (M4F, "f32"),
        (M4F, "f32-paper"),
        (M0, "pyramid"),
        (M0, "pyramid-hard"),
        (M0, "pyramid-nolink"),
        (M0, "pyramid-paper"),
        (M0, "f32"),
        (M0, "f32-paper"),
        (M4F, "pyramid-decay"),
        (M4F, "decay"),
        (M0, "pyramid-decay"),
        (M0, "decay"),
        (M4F, "pyramid-timed"),
        (M0, "pyramid-timed"),
    ];
    // `BENCH_ONLY=thumbv7em-none-eabihf/pyramid,…` restricts the runs (for profiling).
    let only = std::env::var("BENCH_ONLY").ok();
    let chosen: Vec<(&str, &str)> = variants
        .iter()
        .copied()
        .filter(|(target, bin)| {
            only.as_deref()
                .is_none_or(|o| o.split(',').any(|v| v == format!("{target}/{bin}")))
        })
        .collect();
    // Each count is exact whatever else runs: the emulator's trace, not a clock. Two runs at a
    // time (each an emulator and this process reading its trace), in the listed order.
    let jobs = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .clamp(1, 2);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<Option<Result<Run>>>> =
        std::sync::Mutex::new(vec![None; chosen.len()]);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(&(target, bin)) = chosen.get(i) else {
                    break;
                };
                let r = measure(
                    &elf(target, bin),
                    target,
                    bin,
                    &work,
                    &root,
                    opts.singlestep,
                );
                if let Ok(mut all) = results.lock() {
                    if let Some(slot) = all.get_mut(i) {
                        *slot = Some(r);
                    }
                }
            });
        }
    });
    let results = results
        .into_inner()
        .map_err(|_| "a bench run's worker panicked".to_string())?;
    for (&(target, bin), r) in chosen.iter().zip(results) {
        let r = r.ok_or_else(|| format!("{target} {bin}: not run"))??;
        runs.insert((target, bin), r);
    }
    let get = |t: &str, b: &str| runs.get(&(t, b)).cloned().unwrap_or_default();
    let (m4, flat, window, m4_nolink, m4_f32) = (
        get(M4F, "pyramid"),
        get(M4F, "flat"),
        get(M4F, "window"),
        get(M4F, "pyramid-nolink"),
        get(M4F, "f32"),
    );
    let (m0, m0_nolink, m0_f32) = (
        get(M0, "pyramid"),
        get(M0, "pyramid-nolink"),
        get(M0, "f32"),
    );
    // The hard gate against the default soft gate (both with the link): what the soft gate's
    // extra fed layers cost.
    let (m4_hard, m0_hard) = (get(M4F, "pyramid-hard"), get(M0, "pyramid-hard"));
    // The paper's navigability rule against the default plane rule (both without the link).
    let (m4_paper, m0_paper) = (get(M4F, "pyramid-paper"), get(M0, "pyramid-paper"));
    let (m4_f32_paper, m0_f32_paper) = (get(M4F, "f32-paper"), get(M0, "f32-paper"));
    let window_per_cell = window.instructions as f64 / window.cells.max(1) as f64;
    let per_cell = |r: &Run| r.instructions as f64 / r.cells.max(1) as f64;
    let (m4_decay, m0_decay) = (get(M4F, "pyramid-decay"), get(M0, "pyramid-decay"));
    let (m4_sweep, m0_sweep) = (get(M4F, "decay"), get(M0, "decay"));

    // 4. Memory of the M4F bench firmware (default pyramid, link).
    let (flash, ram, recording_bytes) = sizes(&elf(M4F, "pyramid"))?;

    // 5. Host: the library's pipeline, and OctoMap on the same points.
    run_loud(Command::new("cargo").current_dir(&root).args([
        "build",
        "--release",
        "--quiet",
        "-p",
        "terrain-pyramid-bench",
        "--bin",
        "bench-host",
    ]))?;
    let host_bin = root.join("target").join("release").join("bench-host");
    // The host rates are wall-clock: the machine's load is noted with them.
    let load_before = load_average();
    let seconds = if opts.quick { "0.3" } else { "3" };
    let out = run(Command::new(&host_bin)
        .arg("throughput")
        .arg(&rec)
        .arg(seconds))?;
    let host_rps: f64 = out
        .split_whitespace()
        .find_map(|w| w.strip_prefix("returns_per_second=")?.parse().ok())
        .ok_or_else(|| format!("bench-host said: {out}"))?;
    let points = work.join(if opts.quick {
        "points-quick.bin"
    } else {
        "points.bin"
    });
    run(Command::new(&host_bin).arg("export").arg(&rec).arg(&points))?;
    let harness_src = root.join("bench").join("octomap").join("harness.cpp");
    let harness = work.join("octomap-harness");
    let stale = match (fs::metadata(&harness_src), fs::metadata(&harness)) {
        (Ok(src), Ok(bin)) => src.modified().ok() > bin.modified().ok(),
        _ => true,
    };
    if stale {
        run(Command::new("g++")
            .args(["-O2", "-std=c++17", "-o"])
            .arg(&harness)
            .arg(&harness_src)
            .args(["-loctomap", "-loctomath"]))?;
    }
    let mut octomap: Vec<(String, f64, f64)> = Vec::new();
    let octomap_out = run(Command::new(&harness).arg(&points).arg("0.1"))?;
    for l in octomap_out.lines() {
        // "mode=insertPointCloud res=0.1 points=… seconds=… returns_per_second=…"
        let f = |k: &str| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix(k)?.strip_prefix('='))
                .unwrap_or("")
                .to_string()
        };
        if let (Ok(res), Ok(rps)) = (
            f("res").parse::<f64>(),
            f("returns_per_second").parse::<f64>(),
        ) {
            octomap.push((f("mode"), res, rps));
        }
    }
    let load_after = load_average();
    let cores = std::thread::available_parallelism().map_or(0, usize::from);
    let octomap_rps = octomap
        .iter()
        .find(|o| o.0 == "insertPointCloud")
        .map_or(0.0, |o| o.2);
    let octomap_update_rps = octomap
        .iter()
        .find(|o| o.0 == "updateNode")
        .map_or(0.0, |o| o.2);

    // 6. Report.
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    eprintln!();
    eprintln!("| measurement | value |");
    eprintln!("| --- | --- |");
    eprintln!(
        "| M4F instructions / return (default pyramid, pipeline + link) | {:.1} |",
        m4.per_return()
    );
    eprintln!(
        "| M4F instructions / return, flat 200² grid at 0.1 m (+ link) | {:.1} |",
        flat.per_return()
    );
    eprintln!(
        "| pyramid / flat | {:.2} |",
        ratio(m4.per_return(), flat.per_return())
    );
    eprintln!(
        "| M4F instructions / return, hard gate (+ link; the default is soft) | {:.1} |",
        m4_hard.per_return()
    );
    eprintln!(
        "| pyramid with the hard gate / flat | {:.2} |",
        ratio(m4_hard.per_return(), flat.per_return())
    );
    eprintln!(
        "| M4F instructions / return, no link | {:.1} |",
        m4_nolink.per_return()
    );
    eprintln!(
        "| M4F instructions / return, no link, paper's rule (plane rule: the line above) | {:.1} |",
        m4_paper.per_return()
    );
    eprintln!(
        "| M4F f32 instructions / return (no link, plane rule) | {:.1} |",
        m4_f32.per_return()
    );
    eprintln!(
        "| M4F f32 / fixed (no link, plane rule) | {:.2} |",
        ratio(m4_f32.per_return(), m4_nolink.per_return())
    );
    eprintln!(
        "| M4F f32 instructions / return (no link, paper's rule) | {:.1} |",
        m4_f32_paper.per_return()
    );
    eprintln!(
        "| M4F f32 / fixed (no link, paper's rule) | {:.2} |",
        ratio(m4_f32_paper.per_return(), m4_paper.per_return())
    );
    eprintln!(
        "| M0 instructions / return (pipeline + link) | {:.1} |",
        m0.per_return()
    );
    eprintln!(
        "| M0 instructions / return, hard gate (+ link) | {:.1} |",
        m0_hard.per_return()
    );
    eprintln!(
        "| M0 instructions / return, no link | {:.1} |",
        m0_nolink.per_return()
    );
    eprintln!(
        "| M0 instructions / return, no link, paper's rule (plane rule: the line above) | {:.1} |",
        m0_paper.per_return()
    );
    eprintln!(
        "| M0 f32 instructions / return (no link, plane rule) | {:.1} |",
        m0_f32.per_return()
    );
    eprintln!(
        "| M0 f32 / fixed (no link, plane rule) | {:.2} |",
        ratio(m0_f32.per_return(), m0_nolink.per_return())
    );
    eprintln!(
        "| M0 f32 instructions / return (no link, paper's rule) | {:.1} |",
        m0_f32_paper.per_return()
    );
    eprintln!(
        "| M0 f32 / fixed (no link, paper's rule) | {:.2} |",
        ratio(m0_f32_paper.per_return(), m0_paper.per_return())
    );
    eprintln!(
        "| M4F window move: instructions / reset cell ({} cells) | {:.2} |",
        window.cells, window_per_cell
    );
    for (name, with, without, sweep) in [
        ("M4F", &m4_decay, &m4, &m4_sweep),
        ("M0", &m0_decay, &m0, &m0_sweep),
    ] {
        eprintln!(
            "| {name} instructions / return with decay (all, τ = 1 s every layer; {} cells decayed) | {:.1} (+{:.1}) |",
            with.cells,
            with.per_return(),
            with.per_return() - without.per_return()
        );
        eprintln!(
            "| {name} decay sweep: instructions / decayed cell ({} observed cells) | {:.2} |",
            sweep.cells,
            per_cell(sweep)
        );
    }
    eprintln!(
        "| bench firmware flash (M4F, without the {} B recording) | {} B |",
        recording_bytes, flash
    );
    eprintln!("| bench firmware static RAM (M4F) | {} B |", ram);
    eprintln!(
        "| stack high-water of the measured pipeline (M4F / M0) | {} / {} B |",
        m4.stack, m0.stack
    );
    eprintln!("| host returns / s (library, release) | {:.3e} |", host_rps);
    for (mode, res, rps) in &octomap {
        eprintln!("| OctoMap {mode} at {res} m, returns / s | {rps:.3e} |");
    }
    eprintln!(
        "| host / OctoMap (insertPointCloud, 0.1 m) | {:.1} |",
        ratio(host_rps, octomap_rps)
    );
    eprintln!(
        "| machine load while the host rates were taken (1-min load average before / after, cores) | {load_before:.2} / {load_after:.2} on {cores} |"
    );
    eprintln!();
    eprintln!(
        "profiles: {0}/profile-*.txt (by function), {0}/lines-*.txt (by source line)",
        work.display()
    );

    let json = serde_json::json!({
        "m4f": {
            "instructions_per_return": m4.per_return(),
            "flat_instructions_per_return": flat.per_return(),
            "hard_gate_instructions_per_return": m4_hard.per_return(),
            "window_move_instructions_per_cell": window_per_cell,
            "decay_instructions_per_return": m4_decay.per_return(),
            "decay_instructions_per_cell": per_cell(&m4_sweep),
        },
        "m0": {
            "instructions_per_return": m0.per_return(),
            "hard_gate_instructions_per_return": m0_hard.per_return(),
            "decay_instructions_per_return": m0_decay.per_return(),
            "decay_instructions_per_cell": per_cell(&m0_sweep),
        },
        "m4f_nolink": {
            "plane_instructions_per_return": m4_nolink.per_return(),
            "paper_instructions_per_return": m4_paper.per_return(),
        },
        "m0_nolink": {
            "plane_instructions_per_return": m0_nolink.per_return(),
            "paper_instructions_per_return": m0_paper.per_return(),
        },
        "m4f_f32": {
            "instructions_per_return": m4_f32.per_return(),
            "paper_instructions_per_return": m4_f32_paper.per_return(),
        },
        "m0_f32": {
            "instructions_per_return": m0_f32.per_return(),
            "paper_instructions_per_return": m0_f32_paper.per_return(),
        },
        "host": { "returns_per_second": host_rps },
        "octomap": {
            "returns_per_second": octomap_rps,
            "update_node_returns_per_second": octomap_update_rps,
        },
        "host_over_octomap": ratio(host_rps, octomap_rps),
        "machine": { "load_before": load_before, "load_after": load_after, "cores": cores },
        "flash_bytes": flash,
        "ram_bytes": ram,
        "stack_bytes": m4.stack,
    });
    print_json(&json, opts.json)
}

/// The results on stdout, the only thing there: one JSON object, on one line with `--json`.
fn print_json(value: &serde_json::Value, one_line: bool) -> Result<()> {
    let text = if one_line {
        value.to_string()
    } else {
        serde_json::to_string_pretty(value).map_err(|e| e.to_string())?
    };
    println!("{text}");
    Ok(())
}
