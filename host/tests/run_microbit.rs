//! The micro:bit firmware (`boards/microbit`, QEMU's `microbit`: nRF51822, Cortex-M0, 16 KiB of
//! RAM) against the library's co-processor of the same configuration in this process,
//! `InProcess<16, 4, 16, 400>` booted as the firmware boots: the same recording through both,
//! driven the same way (`run::drive`), must give bit-identical layers.
//!
//! The firmware is built without the plane rule (the library's `plane-rule` feature off, for
//! 16-byte classifier slots): it takes the paper's rule only, so both run `--rule paper`. The
//! reference here has the feature (48-byte slots) but under the paper's rule does not read the
//! plane's sums, so its maps must be the same bit for bit.
//!
//! The micro:bit has one UART: the emulator writes each telegram onto it whole, between the
//! link's frames, and the firmware splits the line (`wire::shared_line`). Its classifier has 32
//! slots, so an observation may touch 32 cells: the recordings here end an observation at every
//! line (their setup's `lines_per_observation` rewritten to 1; a sweep-long observation of the
//! 3DTK scan would drop most of its points, counted as overflows, on both sides alike).
//!
//! QEMU and the `thumbv6m-none-eabi` target are required: without them the test FAILS, unless
//! `PYRAMID_SKIP_QEMU=1` is set. The 3DTK scan is used when present; the synthetic recording
//! always runs.
use clap::Parser;
use std::path::Path;
use std::time::Instant;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::recording::{emit_header, Event, Payload, Reader};
use terrain_pyramid::{Config, Design, Schedule, SensorModel};
use terrain_pyramid_host::device::InProcess;
use terrain_pyramid_host::emulator::{Emulator, Machine};
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::play::{steps, RunCounts};
use terrain_pyramid_host::run::{drive, layers_hash, run_config, Args};

mod common;
use common::{qemu_ready, record_3dtk, synthetic_recording, tmp};

/// The firmware's co-processor: `CoProcessor<CELLS, LAYERS, SLOTS, QUEUE>` of
/// `boards/microbit/src/main.rs`.
type Reference = InProcess<16, 4, 16, 400>;

/// The firmware's boot: its design (`boot_design`), a tilt unit, the default link.
fn boot_reference() -> Reference {
    let sensor = SensorModel {
        max_range_m: 4.0,
        height_m: 0.4,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gamma: 3.0,
        ..Schedule::default()
    };
    let design = Design::<4>::new(sensor, schedule, 16).unwrap();
    let setup = FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal);
    Reference::boot(LinkConfig::DEFAULT, &design, &Config::default(), setup).unwrap()
}

/// The only rule the firmware has (it is built without the plane rule).
const PAPER_RULE: [&str; 2] = ["--rule", "paper"];

/// `pyramid run`'s flags, parsed as the tool parses them.
#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    run: Args,
}

/// `recording` with every observation one line long.
fn one_line_observations(recording: &Path, out: &Path) {
    let data = std::fs::read(recording).unwrap();
    let mut file = vec![0_u8; 16];
    emit_header(&mut file).unwrap();
    let mut setups = 0;
    for event in Reader::new(&data).unwrap() {
        let mut event: Event<'_> = event.unwrap();
        if let Payload::Setup(setup) = &mut event.payload {
            setup.lines_per_observation = 1;
            setups += 1;
        }
        let mut buf = vec![0_u8; event.buffer_len()];
        let n = event.emit(&mut buf).unwrap();
        file.extend_from_slice(&buf[..n]);
    }
    assert_eq!(setups, 1);
    std::fs::write(out, file).unwrap();
}

/// Plays `recording` through the firmware on QEMU and through the reference, with `flags`;
/// compares every cell.
fn compare(recording: &Path, dir: &Path, flags: &[&str]) {
    let mut argv = vec!["run", "--board", "microbit", "--recording"];
    let rec = recording.to_str().unwrap();
    let out = dir.to_str().unwrap();
    argv.extend([rec, "--out", out, "--cells", "16"]);
    argv.extend(flags);
    let cli = Cli::try_parse_from(argv).unwrap();
    let (design, config, classifier) = run_config(&cli.run).unwrap();
    assert!(design.layers().len() <= 4, "the micro:bit holds 4 layers");
    let steps = steps(&std::fs::read(recording).unwrap()).unwrap();

    let mut reference = boot_reference();
    let (host_counts, host_maps) =
        drive(&mut reference, &steps, &design, &config, &classifier).unwrap();

    let elf = Machine::Microbit.build().unwrap();
    let started = Instant::now();
    let mut emu = Emulator::start(Machine::Microbit, &elf, &dir.join("firmware.defmt")).unwrap();
    let (counts, maps) = drive(&mut emu, &steps, &design, &config, &classifier).unwrap();
    let stack = emu.shutdown().unwrap();
    let seconds = started.elapsed().as_secs_f64();

    check(&host_counts, &counts, &host_maps, &maps);
    eprintln!(
        "microbit: {} telegrams in {seconds:.1} s, {} observations, {} overflow points; \
         layers_hash {} on both; stack high-water {stack} bytes",
        counts.telegrams_sent,
        counts.observations,
        counts.overflow_points,
        layers_hash(&maps)
    );
    assert!(
        stack > 0,
        "no stack high-water mark in the Reply to Shutdown"
    );
}

fn check(host: &RunCounts, device: &RunCounts, host_maps: &MapSnapshot, maps: &MapSnapshot) {
    assert_eq!(host.telegrams_sent, device.telegrams_sent);
    assert_eq!(device.telegrams_applied, device.telegrams_sent);
    assert_eq!(host.telegrams_applied, device.telegrams_applied);
    assert_eq!(host.observations, device.observations);
    assert_eq!(host.overflow_points, device.overflow_points);
    assert_eq!(device.link_crc_errors, 0);
    assert_eq!(host_maps.layers.len(), maps.layers.len());
    let mut observed = 0;
    for (a, b) in host_maps.layers.iter().zip(&maps.layers) {
        assert_eq!(a.cells.len(), 16 * 16);
        assert_eq!(a.origin_cells, b.origin_cells, "layer {}", a.index);
        assert_eq!(a.resolution, b.resolution, "layer {}", a.index);
        assert!(
            a.cells == b.cells,
            "layer {}: the raw cells differ",
            a.index
        );
        observed += a.cells.iter().filter(|&&c| c != i16::MIN).count();
    }
    assert_eq!(layers_hash(host_maps), layers_hash(maps));
    assert!(
        observed > 0,
        "nothing was observed: the comparison is empty"
    );
}

#[test]
fn microbit_matches_the_host_on_a_synthetic_recording() {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp("microbit-synthetic");
    let (sweep, recording) = (dir.join("sweep.rec"), dir.join("synthetic.rec"));
    synthetic_recording(&sweep);
    one_line_observations(&sweep, &recording);
    let flags = PAPER_RULE.iter().copied().chain([
        "--height-m",
        "0.5",
        "--max-range-m",
        "4",
        "--gamma",
        "3",
    ]);
    let flags: Vec<&str> = flags.collect();
    compare(&recording, &dir, &flags);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn microbit_matches_the_host_on_the_3dtk_scan() {
    if !qemu_ready() {
        eprintln!("PYRAMID_SKIP_QEMU=1: skipped");
        return;
    }
    let dir = tmp("microbit-3dtk");
    let Some(scan) = record_3dtk(&dir) else {
        return;
    };
    let recording = dir.join("scan000-lines.rec");
    one_line_observations(&scan, &recording);
    let flags = PAPER_RULE.iter().copied().chain([
        "--height-m",
        "0.4",
        "--max-range-m",
        "4",
        "--gamma",
        "3",
    ]);
    let flags: Vec<&str> = flags.collect();
    compare(&recording, &dir, &flags);
    if std::env::var_os("PYRAMID_QEMU_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}
