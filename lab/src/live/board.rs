//! The emulated board of `lab live`: QEMU started with the firmware, its UARTs on sockets,
//! and the recording's Setup sent over the host link.
use super::Reaped;
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::link::convert::setup_message_with_sensor;
use terrain_pyramid::wire::link::Message;
use terrain_pyramid_host::emulator::{connect, spawn_qemu, Machine};
use terrain_pyramid_host::link::{HostLink, LinkEvent};
use terrain_pyramid_host::play::Steps;

/// QEMU with the firmware, its UARTs on sockets in `dir`.
pub(super) fn start_qemu(
    elf: &Path,
    dir: &Path,
) -> Result<(Reaped, UnixStream, UnixStream), String> {
    let machine = Machine::Mps2An386;
    let (s0, s1) = (dir.join("uart0.sock"), dir.join("uart1.sock"));
    let log = std::fs::File::create(dir.join("firmware.defmt"))
        .map_err(|e| format!("cannot create the firmware's log: {e}"))?;
    let mut child = spawn_qemu(machine, elf, [&s0, &s1], log, Stdio::null())?;
    let uart0 = connect(&s0, &mut child);
    let uart1 = connect(&s1, &mut child);
    let child = Reaped(Some(child));
    Ok((child, uart0?, uart1?))
}

/// Sends the recording's Setup over the link and waits for its Reply (and the Hello before).
pub(super) fn setup_device(uart1: &mut UnixStream, steps: &Steps) -> Result<(), String> {
    let setup = steps.setup().ok_or("the recording has no setup")?;
    let message = setup_message_with_sensor(&setup, &steps.sensor, &ClassifierConfig::DEFAULT);
    let mut host = HostLink::new();
    let seq = host.next_seq();
    let frame = host
        .command(&Message::Setup(message))
        .map_err(|e| e.to_string())?;
    uart1
        .set_read_timeout(Some(Duration::from_millis(50)))
        .map_err(|e| e.to_string())?;
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut sent = false;
    let mut buf = [0_u8; 4096];
    while Instant::now() < deadline {
        if !sent && host.mirror().firmware().is_some() {
            uart1.write_all(&frame).map_err(|e| e.to_string())?;
            sent = true;
        }
        let n = match uart1.read(&mut buf) {
            Ok(n) => n,
            Err(e) if super::read_timed_out(&e) => 0,
            Err(e) => return Err(format!("the link: {e}")),
        };
        for event in host.feed(buf.get(..n).unwrap_or_default()) {
            if let LinkEvent::Reply(r) = event {
                if sent && r.to_seq == seq {
                    return if r.is_ok() {
                        Ok(())
                    } else {
                        Err(format!("the device refused the Setup: {r:?}"))
                    };
                }
            }
        }
    }
    Err("no Reply to the Setup in 20 s".into())
}
