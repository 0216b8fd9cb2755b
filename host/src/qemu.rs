//! `pyramid run --board qemu`: a recording through the firmware on QEMU's MPS2 AN386.
//!
//! The firmware (`boards/qemu-mps2`) is built if needed and booted in `qemu-system-arm` with
//! UART0 (the laser) and UART1 (the host link) on Unix sockets. The harness then drives it
//! as a main computer would, but lock-step, so that nothing is dropped and everything happens
//! in the recording's order:
//!
//! 1. wait for Hello, send Configure (the design flags) and Setup (the recording's setup event
//!    and the classifier flags), and wait for their Replies;
//! 2. for each telegram the recording's laser bytes hold: send the actuator angle (and the
//!    pose) that are in force at that point as PanAngle (and Pose), then RequestStats, and
//!    wait for the Stats (frames are handled in order: the angle is applied); write the
//!    telegram to UART0; RequestStats until the device counts it (a telegram is applied in
//!    the main-loop step that decodes it);
//! 3. EndObservation (as `--board host` ends the last observation), RequestSnapshot(all),
//!    wait until the mirror is complete, Shutdown, wait for QEMU to exit with 0;
//! 4. write the maps from the mirror (`HostLink`) with the same export as `--board host`.

use crate::export::MapSnapshot;
use crate::run::{run_config, write_outputs, Args, Board, RunCounts};
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::logodds::round_to_log_odds;
use terrain_pyramid::wire::link::{
    ClampRequest, Configure, Message, PanAngle, Pose, Reply, Setup, SnapshotScope, Stats,
};
use terrain_pyramid::wire::recording::{Payload, Reader};
use terrain_pyramid::wire::sick::{MeasuredValues, SickAccumulator, SickItem};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{Clamp, Config, DefaultDesign};
use terrain_pyramid_host::link::{HostLink, LinkEvent};

/// The firmware's crate, from this crate's manifest.
pub const BOARD_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../boards/qemu-mps2");
/// The Cortex-M4F target the firmware is built for.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// How to install what an emulated run needs.
pub const INSTALL_HINT: &str = "install QEMU and the Cortex-M target: \
     `sudo apt-get install -y qemu-system-arm` and `rustup target add thumbv7em-none-eabihf`";

/// How long any single answer of the firmware may take.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(20);

/// Whether `qemu-system-arm` can be run.
#[must_use]
pub fn qemu_available() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The firmware's ELF, built with `cargo build --release` in `boards/qemu-mps2` (cargo does
/// nothing when it is up to date). `board_dir` is a board crate, `bin` its binary.
///
/// # Errors
/// The target is missing or the build failed, with how to fix it.
pub fn build_firmware(board_dir: &Path, bin: &str) -> Result<PathBuf, String> {
    build_firmware_variant(board_dir, bin, None)
}

/// [`build_firmware`] with a cargo feature of the board (`--features F`), built into its own
/// target directory (`target/F`) so that it and the default build do not overwrite each
/// other; `None` is the default build.
///
/// # Errors
/// The target is missing or the build failed, with how to fix it.
pub fn build_firmware_variant(
    board_dir: &Path,
    bin: &str,
    feature: Option<&str>,
) -> Result<PathBuf, String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains(TARGET))
        .unwrap_or(true);
    if !installed {
        return Err(format!(
            "the Cortex-M target {TARGET} is missing: `rustup target add {TARGET}`"
        ));
    }
    eprintln!(
        "building the firmware in {}{} ...",
        board_dir.display(),
        feature.map_or_else(String::new, |f| format!(" with --features {f}"))
    );
    let target_dir = feature.map_or_else(
        || board_dir.join("target"),
        |f| board_dir.join("target").join(f),
    );
    let mut cargo = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cargo.args(["build", "--release", "--quiet"]);
    if let Some(f) = feature {
        cargo
            .args(["--features", f])
            .arg("--target-dir")
            .arg(&target_dir);
    }
    let status = cargo
        .current_dir(board_dir)
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("RUSTFLAGS")
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!(
            "the firmware build failed in {} ({INSTALL_HINT})",
            board_dir.display()
        ));
    }
    let elf = target_dir.join(TARGET).join("release").join(bin);
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(format!(
            "the firmware build left no ELF at {}",
            elf.display()
        ))
    }
}

/// A running QEMU with the firmware, its UARTs connected.
pub struct Emulator {
    child: Child,
    uart0: UnixStream,
    uart1: UnixStream,
    rx: Receiver<Vec<u8>>,
    link: HostLink,
    /// While the host "does not listen": UART1's bytes go here, not to the mirror (a test
    /// harness still sees the Stats it needs to keep in step).
    tap: Option<HostLink>,
    /// Frames the tap decoded since the host stopped listening.
    tapped: u64,
    /// UART1's socket, to reconnect to.
    uart1_path: PathBuf,
    /// Bytes received from UART1.
    pub bytes_received: u64,
    _dir: TempDir,
}

/// A temporary directory removed on drop.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn connect(path: &Path, child: &mut Child) -> Result<UnixStream, String> {
    let start = Instant::now();
    loop {
        match UnixStream::connect(path) {
            Ok(s) => return Ok(s),
            Err(e) => {
                if let Ok(Some(status)) = child.try_wait() {
                    return Err(format!("QEMU exited before its UARTs opened ({status})"));
                }
                if start.elapsed() > Duration::from_secs(20) {
                    return Err(format!("cannot connect to {}: {e}", path.display()));
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    }
}

impl Emulator {
    /// Boots `elf` in QEMU; the raw defmt log goes to `defmt_log`.
    ///
    /// # Errors
    /// QEMU missing or failing to start.
    pub fn start(elf: &Path, defmt_log: &Path) -> Result<Self, String> {
        if !qemu_available() {
            return Err(format!("qemu-system-arm is missing: {INSTALL_HINT}"));
        }
        let dir = std::env::temp_dir().join(format!(
            "pyramid-qemu-{}-{}",
            std::process::id(),
            Instant::now().elapsed().as_nanos() ^ u128::from(rand_seed())
        ));
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let dir = TempDir(dir);
        let (s0, s1) = (dir.0.join("uart0.sock"), dir.0.join("uart1.sock"));
        let log = std::fs::File::create(defmt_log)
            .map_err(|e| format!("cannot create {}: {e}", defmt_log.display()))?;
        let mut child = Command::new("qemu-system-arm")
            .args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic"])
            .args(["-monitor", "none", "-semihosting-config"])
            .arg("enable=on,target=native")
            .arg("-serial")
            .arg(format!("unix:{},server=on,wait=on", s0.display()))
            .arg("-serial")
            .arg(format!("unix:{},server=on,wait=on", s1.display()))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(log)
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot start qemu-system-arm: {e} ({INSTALL_HINT})"))?;
        let uart0 = connect(&s0, &mut child)?;
        let uart1 = connect(&s1, &mut child)?;
        let rx = spawn_reader(&uart1)?;
        Ok(Self {
            child,
            uart0,
            uart1,
            rx,
            link: HostLink::new(),
            tap: None,
            tapped: 0,
            uart1_path: s1,
            bytes_received: 0,
            _dir: dir,
        })
    }

    /// Stops (`true`) or resumes (`false`) feeding UART1's bytes to the mirror, as a host that
    /// stalls and loses what the device sent meanwhile. While deaf, [`wait_for`](Self::wait_for)
    /// sees the frames through a separate decoder (the harness's tap).
    pub fn set_deaf(&mut self, deaf: bool) {
        if deaf {
            if self.tap.is_none() {
                self.tap = Some(HostLink::new());
                self.tapped = 0;
            }
        } else if let Some(tap) = self.tap.take() {
            self.tapped = tap.mirror().counters().frames + tap.mirror().counters().out_of_order;
        }
    }

    /// Frames the tap decoded during the last deaf stretch.
    #[must_use]
    pub fn tapped_frames(&self) -> u64 {
        self.tapped
    }

    /// Closes the host link's connection (QEMU drops what the device sends meanwhile).
    pub fn disconnect_link(&mut self) {
        let _ = self.uart1.shutdown(std::net::Shutdown::Both);
    }

    /// Connects to UART1 again, as a host that reopens its port: a fresh link and mirror
    /// (sequence numbers from 0, no Hello yet).
    ///
    /// # Errors
    /// QEMU does not accept the connection.
    pub fn reconnect_link(&mut self) -> Result<(), String> {
        let uart1 = connect(&self.uart1_path, &mut self.child)?;
        self.rx = spawn_reader(&uart1)?;
        self.uart1 = uart1;
        self.link = HostLink::new();
        self.tap = None;
        Ok(())
    }

    /// The host's end of the link.
    #[must_use]
    pub fn link(&self) -> &HostLink {
        &self.link
    }

    /// Sends a command on UART1; returns its sequence number.
    ///
    /// # Errors
    /// The socket failed.
    pub fn send(&mut self, message: &Message<'_>) -> Result<u16, String> {
        let seq = self.link.next_seq();
        let bytes = self.link.command(message).map_err(|e| e.to_string())?;
        self.uart1
            .write_all(&bytes)
            .map_err(|e| format!("UART1: {e}"))?;
        Ok(seq)
    }

    /// Writes laser bytes to UART0.
    ///
    /// # Errors
    /// The socket failed.
    pub fn laser(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.uart0
            .write_all(bytes)
            .map_err(|e| format!("UART0: {e}"))
    }

    /// Feeds UART1's bytes to the mirror until `done` says so for one of the events (or, with
    /// `None` events, for the mirror's state after each chunk).
    ///
    /// # Errors
    /// `what` did not happen within the timeout, or QEMU stopped.
    pub fn wait_for(
        &mut self,
        what: &str,
        mut done: impl FnMut(&HostLink, Option<&LinkEvent>) -> bool,
    ) -> Result<(), String> {
        let deadline = Instant::now() + ANSWER_TIMEOUT;
        if done(&self.link, None) {
            return Ok(());
        }
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(bytes) => {
                    self.bytes_received += bytes.len() as u64;
                    let link = self.tap.as_mut().unwrap_or(&mut self.link);
                    let events = link.feed(&bytes);
                    for event in &events {
                        if done(link, Some(event)) {
                            return Ok(());
                        }
                    }
                    if done(link, None) {
                        return Ok(());
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(format!(
                        "timed out after {} s waiting for {what} from the firmware",
                        ANSWER_TIMEOUT.as_secs()
                    ))
                }
                Err(RecvTimeoutError::Disconnected) => {
                    let status = self.child.try_wait().ok().flatten();
                    return Err(format!(
                        "the firmware's UART1 closed while waiting for {what} (QEMU: {})",
                        status.map_or("running".to_string(), |s| s.to_string())
                    ));
                }
            }
        }
    }

    /// Sends `message` and waits for its Reply; an error Reply is an error.
    ///
    /// # Errors
    /// No Reply, or a refusal.
    pub fn command(&mut self, name: &str, message: &Message<'_>) -> Result<Reply, String> {
        let seq = self.send(message)?;
        let to_type = message.msg_type().to_u8();
        let mut reply = None;
        self.wait_for(&format!("the Reply to {name}"), |_, e| match e {
            Some(LinkEvent::Reply(r)) if r.to_seq == seq && r.to_type == to_type => {
                reply = Some(*r);
                true
            }
            _ => false,
        })?;
        let reply = reply.ok_or("no reply")?;
        if reply.is_ok() {
            Ok(reply)
        } else {
            Err(format!("the firmware refused {name}: {reply}"))
        }
    }

    /// RequestStats, and the Stats that answers it (every frame sent before is applied).
    ///
    /// # Errors
    /// No Stats in time.
    pub fn stats(&mut self) -> Result<Stats, String> {
        self.send(&Message::RequestStats)?;
        let mut stats = None;
        self.wait_for("Stats", |_, e| match e {
            Some(LinkEvent::Stats(s)) => {
                stats = Some(*s);
                true
            }
            _ => false,
        })?;
        stats.ok_or_else(|| "no Stats".to_string())
    }

    /// RequestStats until the device has counted `target` telegrams (decoded or refused for
    /// their checksum or framing: a telegram is counted in the main-loop step that decodes
    /// it); returns its count.
    ///
    /// # Errors
    /// No Stats in time, or the count never reaching `target`.
    pub fn wait_for_telegrams(&mut self, target: u64) -> Result<u64, String> {
        let mut counted = 0;
        for _ in 0..100_000 {
            let s = self.stats()?;
            counted = u64::from(s.telegrams_ok)
                + u64::from(s.telegrams_bad_checksum)
                + u64::from(s.telegrams_bad_framing);
            if counted >= target {
                return Ok(counted);
            }
        }
        Err(format!(
            "telegram {target}: the firmware counts only {counted} telegrams"
        ))
    }

    /// RequestStats until the device has no changed tile left to queue: every change it
    /// made before that Stats was then on the wire ahead of it, so the mirror holds the
    /// device's maps cell for cell (`tiles_dirty`, `docs/protocol.md`).
    ///
    /// # Errors
    /// No Stats in time, or tiles still changing after many rounds.
    pub fn sync(&mut self) -> Result<Stats, String> {
        for _ in 0..100_000 {
            let stats = self.stats()?;
            if stats.tiles_dirty == 0 {
                return Ok(stats);
            }
        }
        Err("the firmware's tiles never stopped changing".into())
    }

    /// Shutdown: the Reply's stack high-water mark, then QEMU's exit, which must be 0.
    ///
    /// # Errors
    /// No Reply, or QEMU failed or did not stop.
    pub fn shutdown(mut self) -> Result<u32, String> {
        let reply = self.command("Shutdown", &Message::Shutdown)?;
        let deadline = Instant::now() + Duration::from_secs(20);
        let status = loop {
            if let Some(status) = self.child.try_wait().map_err(|e| e.to_string())? {
                break status;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                return Err("QEMU did not exit after Shutdown".into());
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        if !status.success() {
            let mut err = String::new();
            if let Some(mut e) = self.child.stderr.take() {
                let _ = e.read_to_string(&mut err);
            }
            return Err(format!(
                "QEMU exited with {status} (101 panic, 102 HardFault) {}",
                err.trim()
            ));
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Ok(reply.value as u32)
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A thread that reads UART1 into a channel until the socket closes.
fn spawn_reader(uart1: &UnixStream) -> Result<Receiver<Vec<u8>>, String> {
    let mut reader = uart1
        .try_clone()
        .map_err(|e| format!("UART1 socket: {e}"))?;
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let mut buf = vec![0_u8; 4096];
        loop {
            match reader.read(&mut buf) {
                Ok(0) | Err(_) => return,
                Ok(n) => {
                    if tx.send(buf[..n].to_vec()).is_err() {
                        return;
                    }
                }
            }
        }
    });
    Ok(rx)
}

fn rand_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// The Configure of a design and a configuration.
pub(crate) fn configure_message<const L: usize>(
    design: &terrain_pyramid::Design<L>,
    config: &Config,
) -> Configure {
    Configure {
        sensor: *design.sensor(),
        schedule: *design.schedule(),
        cells_per_side: u16::try_from(design.cells_per_side()).unwrap_or(u16::MAX),
        model: config.model,
        clamp: match config.clamp {
            Clamp::Off => ClampRequest::Off,
            Clamp::Bounds { min, max } => ClampRequest::Bounds {
                min: min.to_num(),
                max: max.to_num(),
            },
        },
        fused_margin: config.fused_margin,
    }
}

/// The state the pipeline should be in when the next telegram arrives.
#[derive(Default)]
pub(crate) struct Pending {
    /// The actuator angle to send before the next telegram, 2⁻¹⁶ turn.
    pub angle: Option<u16>,
    /// The pose to send before the next telegram (x, y, z, roll, pitch, yaw).
    pub pose: Option<[f32; 6]>,
}

/// Plays a recording through the emulated board; returns the counts, the sensor position,
/// the snapshot and the stack high-water mark.
fn play_qemu(
    emu: &mut Emulator,
    data: &[u8],
    classifier: &ClassifierConfig,
) -> Result<(RunCounts, (f64, f64)), String> {
    let reader = Reader::new(data).map_err(|e| format!("the recording: {e}"))?;
    let mut accumulator: Box<SickAccumulator> = Box::new(SickAccumulator::new());
    let mut counts = RunCounts::default();
    let mut sensor_xy = (0.0, 0.0);
    let mut pending = Pending::default();
    let mut have_setup = false;
    let mut counted: u64 = 0;
    for event in reader {
        let event = event.map_err(|e| format!("the recording: {e}"))?;
        match event.payload {
            Payload::Setup(setup) => {
                // The same check as --board host.
                crate::run::frontend_config(&setup, *classifier)?;
                emu.command(
                    "Setup",
                    &Message::Setup(Setup::from_recording(&setup, classifier)),
                )?;
                have_setup = true;
            }
            Payload::Angle(turns) => pending.angle = Some(turns),
            Payload::Pose(p) => {
                let [x, y, z, roll, pitch, yaw] = p;
                if terrain_pyramid::geometry::Pose::from_f32(x, y, z, roll, pitch, yaw).is_ok() {
                    sensor_xy = (f64::from(x), f64::from(y));
                    pending.pose = Some(p);
                } else {
                    counts.poses_rejected += 1;
                }
            }
            Payload::Laser(bytes) => {
                if !have_setup {
                    return Err("the recording has laser bytes before its setup event".into());
                }
                let mut rest = bytes;
                loop {
                    let telegram = match accumulator.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: SickItem::Telegram(telegram),
                            remaining,
                            ..
                        } => {
                            rest = remaining;
                            if MeasuredValues::parse(&telegram).is_err() {
                                continue;
                            }
                            telegram.as_bytes().to_vec()
                        }
                        FeedResult::Rejected { remaining, .. } => {
                            counts.telegrams_rejected += 1;
                            rest = remaining;
                            continue;
                        }
                        other => {
                            rest = other.remaining();
                            continue;
                        }
                    };
                    send_line(emu, &mut pending, &telegram)?;
                    counts.telegrams_sent += 1;
                    counted = emu.wait_for_telegrams(counts.telegrams_sent)?;
                }
            }
            Payload::Marker(_) | Payload::Unknown { .. } => {}
        }
    }
    if pending.angle.is_some() || pending.pose.is_some() {
        send_line(emu, &mut pending, &[])?;
    }
    emu.send(&Message::EndObservation)?;
    let s = emu.stats()?;
    counts.telegrams_applied = u64::from(s.telegrams_ok.saturating_sub(s.telegrams_bad_other));
    counts.lines_rejected = u64::from(s.telegrams_bad_other);
    counts.overflow_points = u64::from(s.classifier_overflows);
    counts.observations = u64::from(s.observations);
    if counted != counts.telegrams_sent {
        return Err(format!(
            "the firmware counted {counted} telegrams of {} sent",
            counts.telegrams_sent
        ));
    }
    Ok((counts, sensor_xy))
}

/// Brings the device's angle and pose up to date (and waits until they are applied), then
/// writes `telegram` to UART0.
pub(crate) fn send_line(
    emu: &mut Emulator,
    pending: &mut Pending,
    telegram: &[u8],
) -> Result<(), String> {
    let mut sent = false;
    if let Some(turns) = pending.angle.take() {
        emu.send(&Message::PanAngle(PanAngle {
            turns,
            timestamp_ms: 0,
        }))?;
        sent = true;
    }
    if let Some([x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad]) = pending.pose.take() {
        emu.send(&Message::Pose(Pose {
            x_m,
            y_m,
            z_m,
            roll_rad,
            pitch_rad,
            yaw_rad,
            timestamp_ms: 0,
        }))?;
        sent = true;
    }
    if sent {
        emu.stats()?;
    }
    if !telegram.is_empty() {
        emu.laser(telegram)?;
    }
    Ok(())
}

/// What an emulated run leaves besides the maps.
#[derive(Debug, Clone, Copy)]
#[allow(dead_code)]
pub struct QemuRun {
    /// The firmware's stack high-water mark, bytes.
    pub stack_bytes: u32,
}

/// `pyramid run --board qemu`: returns the summary's JSON and the run's extras.
///
/// # Errors
/// The exit status and the message.
pub fn run_qemu(args: &Args) -> Result<(String, QemuRun), (u8, String)> {
    let (design, config, classifier) = run_config(args)?;
    let data = std::fs::read(&args.recording).map_err(|e| {
        (
            1,
            format!(
                "error: cannot read the recording {}: {e}",
                args.recording.display()
            ),
        )
    })?;
    std::fs::create_dir_all(&args.out).map_err(|e| {
        (
            1,
            format!("error: cannot create {}: {e}", args.out.display()),
        )
    })?;
    let fail = |e: String| (1, format!("error: {e}"));
    if !qemu_available() {
        return Err((
            1,
            format!("error: qemu-system-arm is missing: {INSTALL_HINT}"),
        ));
    }
    let elf = build_firmware(Path::new(BOARD_DIR), "qemu-mps2").map_err(fail)?;
    let started = Instant::now();
    let mut emu = Emulator::start(&elf, &args.out.join("firmware.defmt")).map_err(fail)?;
    emu.wait_for("Hello", |link, _| link.mirror().firmware().is_some())
        .map_err(fail)?;
    emu.command(
        "Configure",
        &Message::Configure(configure_message(&design, &config)),
    )
    .map_err(fail)?;
    let (mut counts, sensor_xy) = play_qemu(&mut emu, &data, &classifier).map_err(fail)?;
    // Every cell again, and wait until the mirror holds all of them.
    let hellos = emu.link().mirror().counters().hellos;
    emu.command(
        "RequestSnapshot",
        &Message::RequestSnapshot(SnapshotScope::All),
    )
    .map_err(fail)?;
    emu.wait_for("the snapshot", |link, _| {
        let m = link.mirror();
        m.counters().hellos > hellos && m.is_synced()
    })
    .map_err(fail)?;
    let snapshot = mirror_snapshot(&emu, &design, &config, sensor_xy).map_err(fail)?;
    counts.frames_received = emu.link().mirror().counters().frames;
    counts.link_crc_errors = u64::from(emu.link().rx_counters().crc);
    let stack_bytes = emu.shutdown().map_err(fail)?;
    let elapsed = started.elapsed();
    eprintln!(
        "qemu: {} telegrams in {:.1} s, firmware stack high-water {stack_bytes} bytes",
        counts.telegrams_sent,
        elapsed.as_secs_f64()
    );
    let title = format!(
        "pyramid run --board qemu: {} ({} telegrams applied)",
        args.recording.display(),
        counts.telegrams_applied
    );
    let json = write_outputs(
        &args.out,
        &snapshot,
        &title,
        &counts,
        Board::Qemu,
        Some(stack_bytes),
    )
    .map_err(fail)?;
    Ok((json, QemuRun { stack_bytes }))
}

/// The maps of the mirror, with the design's resolutions and bands.
fn mirror_snapshot(
    emu: &Emulator,
    design: &DefaultDesign,
    config: &Config,
    sensor_xy: (f64, f64),
) -> Result<MapSnapshot, String> {
    let mirror = emu.link().mirror();
    let w = mirror.cells_per_side();
    let mut layers = Vec::new();
    for (k, d) in design.layers().iter().enumerate() {
        let (origin, resolution_q16, cells) = mirror
            .layer_cells(k)
            .ok_or_else(|| format!("the firmware has no layer {k}"))?;
        let resolution = terrain_pyramid::Resolution::from_m(d.resolution_m)
            .ok_or_else(|| format!("layer {k}: bad resolution"))?;
        if resolution.to_bits() != resolution_q16 {
            return Err(format!(
                "layer {k}: the firmware's resolution {resolution_q16} differs from the design's {}",
                resolution.to_bits()
            ));
        }
        layers.push(crate::export::LayerSnapshot {
            index: k,
            resolution,
            band_m: [f64::from(d.band_inner_m), f64::from(d.band_outer_m)],
            origin_cells: origin,
            cells_per_side: w,
            cells,
        });
    }
    Ok(MapSnapshot {
        layers,
        sensor_xy,
        fused_margin: round_to_log_odds(config.fused_margin),
    })
}
