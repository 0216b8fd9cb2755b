//! The firmware on QEMU's MPS2 AN386 (`boards/qemu-mps2`), as a [`Device`]: built if needed,
//! booted in `qemu-system-arm` with UART0 (the laser) and UART1 (the host link) on Unix
//! sockets, and driven as a main computer would drive the real board.
//!
//! QEMU's two UARTs are independent streams, so a harness that must keep the pose and angle
//! in step with the telegrams works lock-step ([`crate::play`]): it sends the host frames,
//! waits for the Stats that shows them applied, then writes the telegram.

use crate::device::Device;
use crate::link::{HostLink, LinkEvent};
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};
use terrain_pyramid::wire::link::Message;

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
