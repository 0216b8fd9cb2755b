//! The board soak (`--board qemu`): the firmware on the emulated board, fed the drive's
//! telegrams and frames for simulated minutes, its counters checked against an in-process
//! reference's every sample.

use super::*;

/// The counters the device and the in-process reference must agree on.
pub(super) const SHARED: [&str; 9] = [
    "telegrams_ok",
    "telegrams_bad_checksum",
    "telegrams_bad_framing",
    "telegrams_bad_other",
    "points",
    "classifier_overflows",
    "evidence_applied",
    "evidence_gated_out",
    "observations",
];

/// The emulated board, counting the Stats round trips.
pub(super) struct Board {
    emu: Emulator,
    round_trips: u64,
}

impl Board {
    fn send(&mut self, message: &Message<'_>) -> Result<(), String> {
        self.emu.send(message).map(|_| ())
    }

    /// RequestStats, and the Stats that answers it (every frame sent so far, the RequestStats
    /// included, has been carried out: [`Device::stats`]).
    fn stats(&mut self) -> Result<Stats, String> {
        self.round_trips += 1;
        self.emu.stats()
    }

    fn command(&mut self, name: &str, message: &Message<'_>) -> Result<(), String> {
        self.emu.command(name, message).map(|_| ())
    }
}

pub(super) fn counted(s: &Stats) -> u64 {
    u64::from(s.telegrams_ok)
        + u64::from(s.telegrams_bad_checksum)
        + u64::from(s.telegrams_bad_framing)
}

/// The board soak.
#[allow(clippy::too_many_lines, clippy::cast_precision_loss)]
pub(super) fn board_soak(
    minutes: f64,
    hold_lines: u32,
    out_dir: &std::path::Path,
    failures: &mut Vec<String>,
) -> Result<BoardReport, String> {
    if !qemu_available() {
        return Err(format!("qemu-system-arm is missing: {INSTALL_HINT}"));
    }
    let (design, config) = design_and_config()?;
    let drive_config = DriveConfig {
        hold_lines: hold_lines.max(1),
        ..DriveConfig::new(minutes * 60.0)
    };
    let setup = drive_config.setup();
    let classifier = ClassifierConfig::default();
    let mut reference = in_process(&design, &config, &setup)?;

    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let elf = build_firmware(std::path::Path::new(BOARD_DIR), "qemu-mps2")?;
    let started = Instant::now();
    let emu = Emulator::start(Machine::Mps2An386, &elf, &out_dir.join("firmware.defmt"))?;
    let mut board = Board {
        emu,
        round_trips: 0,
    };
    board.emu.configure_after_hello(&design, &config)?;
    board.command("Setup", &Message::Setup(setup_message(&setup, &classifier)))?;

    let drive = Drive::new(drive_config);
    let total = drive.lines();
    eprintln!(
        "soak (qemu): {total} telegrams, {minutes} simulated minutes, bursts of {} telegrams",
        drive_config.hold_lines
    );
    let mut report = BoardReport {
        hold_lines: drive_config.hold_lines,
        counters_match_reference: true,
        ..BoardReport::default()
    };
    let mut last_pose = None;
    let mut burst: Vec<u8> = Vec::with_capacity(8 * 512);
    let mut previous = Stats::default();
    let mut interval_start = Instant::now();
    let mut sim_s = 0.0;
    let mut lines = drive.peekable();
    let mut sent: u64 = 0;
    let mut sampled: u64 = 0;
    let mut seconds_per_byte = 0.0_f64;
    while let Some(first) = lines.next() {
        // The burst's angle and pose, applied before its telegrams.
        for frame in hold_frames(&first, &mut last_pose) {
            board.send(&frame)?;
            reference.send(&frame)?;
        }
        board.stats()?;
        burst.clear();
        let mut burst_lines = vec![first];
        while let Some(next) = lines.next_if(|l| !l.new_hold) {
            burst_lines.push(next);
        }
        for line in &burst_lines {
            burst.extend_from_slice(&line.telegram);
            reference.laser(&line.telegram)?;
            sent += 1;
            sim_s = line.time_us as f64 / 1e6;
        }
        board.emu.laser(&burst)?;
        // Until the device counts the whole burst. The emulated UART takes the bytes one at a
        // time: wait most of what the last burst took before asking, rather than flooding
        // UART1 (whose bytes compete with UART0's) with RequestStats.
        let written = Instant::now();
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        std::thread::sleep(std::time::Duration::from_secs_f64(
            (0.8 * seconds_per_byte * burst.len() as f64).min(1.0),
        ));
        let mut tries = 0_u32;
        let stats = loop {
            let s = board.stats()?;
            if counted(&s) >= sent {
                break s;
            }
            tries += 1;
            std::thread::sleep(std::time::Duration::from_millis(1));
            if tries > 10_000 {
                return Err(format!(
                    "telegram {sent}: the firmware counts only {}",
                    counted(&s)
                ));
            }
        };
        seconds_per_byte = written.elapsed().as_secs_f64() / burst.len().max(1) as f64;
        if counted(&stats) != sent {
            failures.push(format!(
                "qemu: {} telegrams counted of {sent}",
                counted(&stats)
            ));
        }
        let before = report.telegrams;
        report.telegrams = sent;
        if before / BOARD_SAMPLE_LINES != sent / BOARD_SAMPLE_LINES || sent == total {
            let wall = interval_start.elapsed().as_secs_f64();
            interval_start = Instant::now();
            check_counters("qemu", &previous, &stats, failures);
            previous = stats;
            // The reference has seen exactly the same frames and telegrams.
            let r = reference.stats()?;
            let (dev, refv) = (named(&stats), named(&r));
            for name in SHARED {
                let d = dev.iter().find(|(n, _)| n == name).map(|x| x.1);
                let e = refv.iter().find(|(n, _)| n == name).map(|x| x.1);
                if d != e {
                    report.counters_match_reference = false;
                    failures.push(format!(
                        "qemu: {name} is {d:?} on the device, {e:?} in the reference at telegram {sent}"
                    ));
                }
            }
            let m = board.emu.link().mirror().counters();
            if m.gaps + m.missing + m.patches_refused > 0 {
                failures.push(format!("qemu: the mirror lost frames: {m:?}"));
            }
            let lines_in = sent - sampled;
            sampled = sent;
            let sample = Sample::new(sim_s, started, (lines_in, wall), None, &stats);
            eprintln!(
                "  {:6.0} s simulated, {:6.1} s wall: {:5.0} telegrams/s, points {}, patches {}, deferred {}, queue high-water {}",
                sample.sim_s,
                sample.wall_s,
                sample.telegrams_per_s,
                stats.points,
                stats.patches_sent,
                stats.patches_deferred,
                stats.queue_high_water
            );
            report.samples.push(sample);
        }
    }
    report.sim_s = sim_s;
    // The last observation on both sides, then the mirror must converge to the reference
    // from the patches alone.
    board.send(&Message::EndObservation)?;
    reference.send(&Message::EndObservation)?;
    let expected = layers(&reference);
    report.incremental_mirror_equal = board
        .emu
        .wait_for("the patches to bring the mirror up to date", |link, _| {
            mirror_equals(link, &expected)
        })
        .is_ok();
    if !report.incremental_mirror_equal {
        failures.push("qemu: the mirror built from patches differs from the reference".into());
    }
    board.emu.snapshot()?;
    report.snapshot_mirror_equal = mirror_equals(board.emu.link(), &expected);
    if !report.snapshot_mirror_equal {
        failures.push("qemu: the device's maps (snapshot) differ from the reference".into());
    }
    let stats = board.stats()?;
    check_counters("qemu (end)", &previous, &stats, failures);
    report.final_stats = named(&stats);
    report.projections = projections(&report.final_stats, report.sim_s);
    report.round_trips = board.round_trips;
    report.stack_bytes = board.emu.shutdown()?;
    report.wall_s = started.elapsed().as_secs_f64();
    report.telegrams_per_s = report.telegrams as f64 / report.wall_s.max(1e-9);
    Ok(report)
}
