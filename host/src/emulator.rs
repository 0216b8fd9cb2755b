//! A board's firmware on an emulated machine ([`Machine`]: QEMU's MPS2 AN386 with
//! `boards/qemu-mps2`, the default; `netduinoplus2` with `boards/stm32f4`; `microbit` with
//! `boards/microbit`), as a [`Device`]: built if needed, booted in `qemu-system-arm` with its
//! UARTs on Unix sockets, and driven as a main computer would drive the real board.
//!
//! Two UARTs (mps2, netduinoplus2) are independent streams, the laser's and the host link's,
//! so a harness that must keep the pose and angle in step with the telegrams works lock-step
//! ([`crate::play`]): it sends the host frames, waits for the Stats that shows them applied,
//! then writes the telegram. The micro:bit has one UART: the laser's telegrams go onto it
//! whole, between the link's frames (`terrain_pyramid::wire::shared_line`), which the
//! lock-step play does by construction. On the netduinoplus2 a stand-in scanner answers the
//! firmware's scanner bring-up on USART1.

use crate::device::Device;
use crate::link::{HostLink, LinkEvent};
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};
use terrain_pyramid::wire::link::Message;
use terrain_pyramid::wire::sick::{
    OperatingMode, OperatingModeReply, SickRequest, Telegram, ACK, ADDRESS_HOST, STX,
};

/// The firmware's crate, from this crate's manifest.
pub const BOARD_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../boards/qemu-mps2");
/// The Cortex-M4F target the firmware is built for.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// How to install what an emulated run needs.
pub const INSTALL_HINT: &str = "install QEMU and the Cortex-M target: \
     `sudo apt-get install -y qemu-system-arm` and `rustup target add thumbv7em-none-eabihf`";

/// An emulated machine and the board crate whose firmware it runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Machine {
    /// QEMU's `mps2-an386` (Cortex-M4F, 25 MHz) with `boards/qemu-mps2`: the laser on UART0,
    /// the host link on UART1.
    #[default]
    Mps2An386,
    /// QEMU's `netduinoplus2` (STM32F405, Cortex-M4F at 168 MHz) with `boards/stm32f4` built
    /// for it (`chip-f405`, `log-semihosting`): the laser on USART1, the host link on USART2.
    Netduinoplus2,
    /// QEMU's `microbit` (nRF51822, Cortex-M0 at 16 MHz, 16 KiB of RAM) with
    /// `boards/microbit`: the laser's telegrams and the host link on its one UART.
    Microbit,
}

impl Machine {
    /// The board crate's directory.
    #[must_use]
    pub fn board_dir(self) -> PathBuf {
        let crate_dir = match self {
            Self::Mps2An386 => "qemu-mps2",
            Self::Netduinoplus2 => "stm32f4",
            Self::Microbit => "microbit",
        };
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../boards")).join(crate_dir)
    }

    /// The firmware binary's name.
    #[must_use]
    pub const fn bin(self) -> &'static str {
        match self {
            Self::Mps2An386 => "qemu-mps2",
            Self::Netduinoplus2 => "stm32f4-board",
            Self::Microbit => "microbit-board",
        }
    }

    /// The Rust target the firmware is built for.
    #[must_use]
    pub const fn target(self) -> &'static str {
        match self {
            Self::Mps2An386 | Self::Netduinoplus2 => TARGET,
            Self::Microbit => "thumbv6m-none-eabi",
        }
    }

    /// QEMU's `-machine`.
    #[must_use]
    pub const fn qemu_machine(self) -> &'static str {
        match self {
            Self::Mps2An386 => "mps2-an386",
            Self::Netduinoplus2 => "netduinoplus2",
            Self::Microbit => "microbit",
        }
    }

    /// The cargo features of the build, without the board's defaults, when it is not the
    /// board's default build (then built into `boards/target/variants`).
    #[must_use]
    pub const fn features(self) -> Option<&'static str> {
        match self {
            Self::Netduinoplus2 => Some("chip-f405,log-semihosting"),
            Self::Mps2An386 | Self::Microbit => None,
        }
    }

    /// The UARTs the emulator connects: two independent ones, or one shared by both streams.
    #[must_use]
    pub const fn uarts(self) -> usize {
        match self {
            Self::Mps2An386 | Self::Netduinoplus2 => 2,
            Self::Microbit => 1,
        }
    }

    /// Builds the firmware (`cargo build --release`, which does nothing when it is up to
    /// date); returns its ELF.
    ///
    /// # Errors
    /// The target is missing or the build failed, with how to fix it.
    pub fn build(self) -> Result<PathBuf, String> {
        let target = self.target();
        if !target_installed(target) {
            return Err(format!(
                "the target {target} is missing: `rustup target add {target}`"
            ));
        }
        let dir = self.board_dir();
        eprintln!(
            "building the {} firmware in {} ...",
            self.qemu_machine(),
            dir.display()
        );
        let mut target_dir = boards_target_dir(&dir);
        let mut cargo = cargo();
        cargo.args(["build", "--release", "--quiet", "--target", target]);
        if let Some(features) = self.features() {
            target_dir = variants_target_dir(&dir);
            cargo
                .args(["--no-default-features", "--features", features])
                .arg("--target-dir")
                .arg(&target_dir);
        }
        run_build(&mut cargo, &dir, &format!("`rustup target add {target}`"))?;
        built_elf(target_dir.join(target).join("release").join(self.bin()))
    }
}

/// The target directory every board crate builds into (`boards/target`, set in each board's
/// `.cargo/config.toml`): the parent of the board crate `board_dir`, then `target`.
fn boards_target_dir(board_dir: &Path) -> PathBuf {
    board_dir
        .parent()
        .map_or_else(|| board_dir.join("target"), |boards| boards.join("target"))
}

/// Where a board crate built with other features than its default goes when its binary keeps
/// its name (`boards/target/variants`; the STM32F4 for QEMU's `netduinoplus2`): it cannot share
/// the default build's folder.
fn variants_target_dir(board_dir: &Path) -> PathBuf {
    boards_target_dir(board_dir).join("variants")
}

/// Whether rustup lists `target` as installed (true when rustup cannot be asked: the build
/// then says what is missing).
fn target_installed(target: &str) -> bool {
    Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains(target))
        .unwrap_or(true)
}

/// The cargo that runs this program (`$CARGO`), else `cargo`.
fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// Runs the firmware build `cargo` in the board crate `dir`, without the caller's
/// `CARGO_TARGET_DIR` and `RUSTFLAGS`; a failure says `hint` (how to fix it).
fn run_build(cargo: &mut Command, dir: &Path, hint: &str) -> Result<(), String> {
    let status = cargo
        .current_dir(dir)
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("RUSTFLAGS")
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "the firmware build failed in {} ({hint})",
            dir.display()
        ))
    }
}

/// `elf` when the build left it there, else the error that says so.
fn built_elf(elf: PathBuf) -> Result<PathBuf, String> {
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(format!(
            "the firmware build left no ELF at {}",
            elf.display()
        ))
    }
}

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

/// [`build_firmware`] with a cargo feature of the board (`--features F`): then the firmware
/// is the board's binary `<bin>-<F>` (declared with `required-features = ["F"]`, as
/// `boards/qemu-mps2` declares `qemu-mps2-paper-stairs`), built alone (`--bin <bin>-<F>`) into
/// the boards' target directory beside the default build, whose dependencies' builds it
/// shares; `None` is the default build of `bin`.
///
/// # Errors
/// The target is missing or the build failed, with how to fix it.
pub fn build_firmware_variant(
    board_dir: &Path,
    bin: &str,
    feature: Option<&str>,
) -> Result<PathBuf, String> {
    if !target_installed(TARGET) {
        return Err(format!(
            "the Cortex-M target {TARGET} is missing: `rustup target add {TARGET}`"
        ));
    }
    eprintln!(
        "building the firmware in {}{} ...",
        board_dir.display(),
        feature.map_or_else(String::new, |f| format!(" with --features {f}"))
    );
    let bin = feature.map_or_else(|| bin.to_string(), |f| format!("{bin}-{f}"));
    let mut cargo = cargo();
    cargo.args(["build", "--release", "--quiet"]);
    if let Some(f) = feature {
        cargo.args(["--features", f, "--bin", &bin]);
    }
    // Anything the build prints goes to stderr: a caller's stdout may be its JSON.
    cargo.stdout(std::io::stderr());
    run_build(&mut cargo, board_dir, INSTALL_HINT)?;
    built_elf(
        boards_target_dir(board_dir)
            .join(TARGET)
            .join("release")
            .join(bin),
    )
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
    /// Frames written to UART1 since boot, over every connection.
    frames_sent: u64,
    _dir: TempDir,
}

/// A temporary directory removed on drop.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// QEMU started to boot `elf` on `machine` without graphics or monitor, semihosting on, its
/// UARTs (the first [`Machine::uarts`] of `uart_sockets`) served on those Unix sockets and
/// waiting for a connection ([`connect`]); the firmware's raw defmt log (semihosting's
/// stdout) into `defmt_log`, QEMU's own messages to `stderr`, no stdin.
///
/// # Errors
/// QEMU cannot be started.
pub fn spawn_qemu(
    machine: Machine,
    elf: &Path,
    uart_sockets: [&Path; 2],
    defmt_log: std::fs::File,
    stderr: Stdio,
) -> Result<Child, String> {
    qemu_command(machine, elf, uart_sockets)
        .stdin(Stdio::null())
        .stdout(defmt_log)
        .stderr(stderr)
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e} ({INSTALL_HINT})"))
}

/// The QEMU command of [`spawn_qemu`], its standard streams not set.
fn qemu_command(machine: Machine, elf: &Path, uart_sockets: [&Path; 2]) -> Command {
    let mut qemu = Command::new("qemu-system-arm");
    qemu.args(["-machine", machine.qemu_machine(), "-nographic"]);
    if machine == Machine::Mps2An386 {
        qemu.args(["-cpu", "cortex-m4"]);
    }
    qemu.args(["-monitor", "none", "-semihosting-config"])
        .arg("enable=on,target=native");
    for socket in uart_sockets.into_iter().take(machine.uarts()) {
        qemu.arg("-serial")
            .arg(format!("unix:{},server=on,wait=on", socket.display()));
    }
    qemu.arg("-kernel").arg(elf);
    qemu
}

/// Connects to the emulated board's UART socket at `path`, retrying every 20 ms while QEMU
/// (`child`) starts it.
///
/// # Errors
/// QEMU exited first, or the socket did not open within 20 s.
pub fn connect(path: &Path, child: &mut Child) -> Result<UnixStream, String> {
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

/// A booted QEMU's connected UARTs.
struct Uarts {
    /// The laser's UART.
    uart0: UnixStream,
    /// The host link's UART (UART0's socket again on a one-UART machine).
    uart1: UnixStream,
    /// UART1's socket, to reconnect to.
    uart1_path: PathBuf,
    /// What UART1 receives.
    rx: Receiver<Vec<u8>>,
}

/// Connects a booted QEMU's UARTs; on the netduinoplus2 also starts the stand-in scanner on
/// USART1.
fn connect_uarts(
    machine: Machine,
    s0: &Path,
    s1: &Path,
    child: &mut Child,
) -> Result<Uarts, String> {
    let uart0 = connect(s0, child)?;
    let (uart1, s1) = if machine.uarts() == 1 {
        let one = uart0.try_clone().map_err(|e| format!("UART socket: {e}"))?;
        (one, s0.to_path_buf())
    } else {
        (connect(s1, child)?, s1.to_path_buf())
    };
    if machine == Machine::Netduinoplus2 {
        let port = uart0
            .try_clone()
            .map_err(|e| format!("USART1 socket: {e}"))?;
        std::thread::spawn(move || stand_in_scanner(port));
    }
    let rx = spawn_reader(&uart1)?;
    Ok(Uarts {
        uart0,
        uart1,
        uart1_path: s1,
        rx,
    })
}

impl Emulator {
    /// Boots `elf` on `machine` in QEMU; the raw defmt log goes to `defmt_log`.
    ///
    /// # Errors
    /// QEMU missing or failing to start.
    pub fn start(machine: Machine, elf: &Path, defmt_log: &Path) -> Result<Self, String> {
        if !qemu_available() {
            return Err(format!("qemu-system-arm is missing: {INSTALL_HINT}"));
        }
        let dir = TempDir(own_socket_dir()?);
        let (s0, s1) = (dir.0.join("uart0.sock"), dir.0.join("uart1.sock"));
        let log = std::fs::File::create(defmt_log)
            .map_err(|e| format!("cannot create {}: {e}", defmt_log.display()))?;
        let mut child = spawn_qemu(machine, elf, [&s0, &s1], log, Stdio::piped())?;
        let Uarts {
            uart0,
            uart1,
            uart1_path,
            rx,
        } = match connect_uarts(machine, &s0, &s1, &mut child) {
            Ok(connected) => connected,
            Err(e) => {
                // A QEMU whose UARTs we never reached must not outlive the attempt.
                stop(&mut child);
                return Err(e);
            }
        };
        Ok(Self {
            child,
            uart0,
            uart1,
            rx,
            link: HostLink::new(),
            tap: None,
            tapped: 0,
            uart1_path,
            bytes_received: 0,
            frames_sent: 0,
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

    /// Feeds the mirror whatever the device has sent by now, without waiting (a reader that
    /// keeps up with a device it does not question); returns the bytes fed.
    pub fn poll_received(&mut self) -> usize {
        let mut fed = 0;
        while let Ok(bytes) = self.rx.try_recv() {
            fed += bytes.len();
            self.bytes_received += bytes.len() as u64;
            let link = self.tap.as_mut().unwrap_or(&mut self.link);
            link.feed(&bytes);
        }
        fed
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

impl Device for Emulator {
    fn send(&mut self, message: &Message<'_>) -> Result<u16, String> {
        let seq = self.link.next_seq();
        let bytes = self.link.command(message).map_err(|e| e.to_string())?;
        self.uart1
            .write_all(&bytes)
            .map_err(|e| format!("UART1: {e}"))?;
        self.frames_sent += 1;
        Ok(seq)
    }

    fn laser(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.uart0
            .write_all(bytes)
            .map_err(|e| format!("UART0: {e}"))
    }

    fn wait_for(
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
                        "timed out after {} s waiting for {what} from the firmware{}",
                        ANSWER_TIMEOUT.as_secs(),
                        crate::link::version_hint(&self.link.rx_counters())
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

    fn link(&self) -> &HostLink {
        &self.link
    }

    fn frames_sent(&self) -> u64 {
        self.frames_sent
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        stop(&mut self.child);
    }
}

/// Kills QEMU if it still runs, and reaps it.
fn stop(child: &mut Child) {
    if matches!(child.try_wait(), Ok(None)) {
        let _ = child.kill();
        let _ = child.wait();
    }
}

/// The stand-in for a SICK LMS2xx on the laser's UART, until the socket closes: answers the
/// firmware's scanner bring-up (`boards/stm32f4/src/scanner.rs`) as a scanner would. A speed
/// change (command 0x20 with a baud-rate mode) gets ACK and the mode-change reply telegram;
/// "continuous output" gets the ACK alone (a real LMS also sends a reply, which the firmware's
/// main loop would count as a telegram that is no measured values, upsetting a harness that
/// counts telegrams). Other bytes are ignored; the firmware sends nothing else on this UART.
fn stand_in_scanner(mut port: UnixStream) {
    let mut pending: Vec<u8> = Vec::new();
    let mut buf = [0_u8; 256];
    loop {
        let n = match port.read(&mut buf) {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        pending.extend_from_slice(&buf[..n]);
        // Every whole request telegram (STX, address 0, length, payload, CRC) in `pending`.
        loop {
            let Some(at) = pending
                .windows(2)
                .position(|w| w[0] == STX && w[1] == ADDRESS_HOST)
            else {
                // Keep a trailing STX: its address byte has not come yet.
                let keep = usize::from(pending.last() == Some(&STX));
                pending.drain(..pending.len() - keep);
                break;
            };
            pending.drain(..at);
            let Some(&[lo, hi]) = pending.get(2..4).and_then(|s| s.first_chunk::<2>()) else {
                break;
            };
            let total = 6 + usize::from(u16::from_le_bytes([lo, hi]));
            if pending.len() < total {
                break;
            }
            let answer = match Telegram::new_checked(&pending[..total])
                .ok()
                .and_then(|t| SickRequest::parse(&t).ok())
            {
                Some(SickRequest::SetOperatingMode(OperatingMode::Baud(_))) => {
                    let reply = OperatingModeReply {
                        result: 0x00,
                        status: 0x10,
                    };
                    let mut bytes = vec![ACK; 1 + reply.buffer_len()];
                    let _ = reply.emit(&mut bytes[1..]);
                    bytes
                }
                Some(SickRequest::SetOperatingMode(OperatingMode::ContinuousAll)) => vec![ACK],
                _ => Vec::new(),
            };
            pending.drain(..total);
            if !answer.is_empty() && port.write_all(&answer).is_err() {
                return;
            }
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

/// Emulators this process has started, for their socket directories' names.
static STARTED: AtomicU64 = AtomicU64::new(0);

/// A fresh directory for one emulator's UART sockets, named by the process and a per-process
/// count so that emulators started at the same instant (the stairs' four maps, in threads)
/// never share one. A directory left by an earlier process of the same id is not reused:
/// QEMU would unlink and rebind its sockets under another emulator's feet.
fn own_socket_dir() -> Result<PathBuf, String> {
    let base = std::env::temp_dir();
    for _ in 0..64 {
        let n = STARTED.fetch_add(1, Ordering::Relaxed);
        let dir = base.join(format!("pyramid-qemu-{}-{n}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(format!("{}: {e}", dir.display())),
        }
    }
    Err(format!(
        "no free socket directory pyramid-qemu-{}-* in {}",
        std::process::id(),
        base.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::own_socket_dir;
    use std::collections::HashSet;

    /// Emulators started in threads at the same instant each get their own sockets: a shared
    /// directory let one QEMU unlink another's sockets and left its emulator waiting for a
    /// Hello that never came.
    #[test]
    fn emulators_started_together_never_share_a_socket_directory() {
        let dirs: Vec<_> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..16).map(|_| scope.spawn(own_socket_dir)).collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("thread").expect("a directory"))
                .collect()
        });
        let distinct: HashSet<_> = dirs.iter().collect();
        assert_eq!(distinct.len(), dirs.len());
        for dir in &dirs {
            assert!(dir.is_dir(), "{}", dir.display());
            std::fs::remove_dir(dir).expect("empty");
        }
    }
}
