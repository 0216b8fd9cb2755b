//! A co-processor as the main computer sees it: two byte streams (the laser's UART and the
//! host link) and a mirror of its maps. [`Device`] is what every harness drives, with two
//! implementations:
//!
//! - [`InProcess`]: the library's own [`CoProcessor`] in this process, handed exactly the
//!   bytes a board's UARTs would deliver, its output decoded by a [`HostLink`];
//! - [`crate::emulator::Emulator`]: the firmware on QEMU's emulated Cortex-M4F.
//!
//! Both run the same application core, so the same bytes give the same maps: "firmware =
//! host" by construction, and the tests that compare them bit for bit check it.

use crate::link::{HostLink, LinkEvent};
use terrain_pyramid::app::{CoProcessor, NoAngleSource, StackUsage};
use terrain_pyramid::link::convert::{configure_of_design, ReplyText};
use terrain_pyramid::link::{LinkConfig, PollReport};
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{Message, Reply, SnapshotScope, Stats};
use terrain_pyramid::{Config, Design};

/// How many polls (of [`InProcess::POLL_STEP_MS`] each) an in-process wait may take.
const MAX_IN_PROCESS_POLLS: u32 = 1_000_000;

/// Wall time a device on real time is left between two questions of [`Device::sync`]: at the
/// default budget (46 080 B/s) it earns about 920 bytes, seven Stats' worth, so the tiles
/// still waiting are sent ahead of the next answer.
pub const IDLE_PAUSE: std::time::Duration = std::time::Duration::from_millis(20);

/// How many rounds (a Stats, then [`Device::idle`]) [`Device::sync`] waits for the last
/// changed tile: 1 500 rounds are 30 s of a board's time at [`IDLE_PAUSE`], 15 s of an
/// in-process clock, enough for a whole snapshot of the largest pyramid at the default budget.
pub const SYNC_ROUNDS: usize = 1_500;

/// How many questions a wait for the device's laser input asks before it gives up: about
/// 32 s of a board's time with [`Device::back_off`]'s pauses.
pub const INPUT_ROUNDS: u32 = 2_000;

/// A co-processor driven over its byte streams.
pub trait Device {
    /// Writes laser bytes (what the laser's UART delivers).
    ///
    /// # Errors
    /// The stream failed.
    fn laser(&mut self, bytes: &[u8]) -> Result<(), String>;

    /// Sends a command frame on the host link; returns its sequence number.
    ///
    /// # Errors
    /// The stream failed, or the message cannot be encoded.
    fn send(&mut self, message: &Message<'_>) -> Result<u16, String>;

    /// Feeds what the device sends to the mirror until `done` says so for one of the events
    /// (or, with `None`, for the mirror's state after each chunk).
    ///
    /// # Errors
    /// `what` did not happen in time, or the device stopped.
    fn wait_for(
        &mut self,
        what: &str,
        done: impl FnMut(&HostLink, Option<&LinkEvent>) -> bool,
    ) -> Result<(), String>;

    /// The host's end of the link: the decoder and the mirror.
    fn link(&self) -> &HostLink;

    /// Frames sent to the device since it booted, over every connection: the Stats that
    /// answers the last RequestStats counts at least as many received frames.
    fn frames_sent(&self) -> u64;

    /// Sends `message` and waits for its Reply; a refusal is an error that reads as the
    /// Reply's sentence.
    ///
    /// # Errors
    /// No Reply, or a refusal.
    fn command(&mut self, name: &str, message: &Message<'_>) -> Result<Reply, String> {
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
            Err(format!("the device refused {name}: {}", ReplyText(&reply)))
        }
    }

    /// Waits for the device's Hello (it has booted), then configures its pyramid with
    /// `design` and `config` (Configure) and waits for the Reply: the start every harness
    /// gives the firmware.
    ///
    /// # Errors
    /// No Hello in time, no Reply, or a refusal.
    fn configure_after_hello<const L: usize>(
        &mut self,
        design: &Design<L>,
        config: &Config,
    ) -> Result<(), String>
    where
        Self: Sized,
    {
        self.wait_for("Hello", |link, _| link.mirror().firmware().is_some())?;
        self.command(
            "Configure",
            &Message::Configure(configure_of_design(design, config)),
        )?;
        Ok(())
    }

    /// RequestStats, and the Stats that answers it (every frame sent before it is applied).
    /// The device also sends Stats on its own (every `stats_interval_ms`): one made before
    /// it had taken every frame sent (by its receive counters) is not the answer.
    ///
    /// # Errors
    /// No Stats in time.
    fn stats(&mut self) -> Result<Stats, String> {
        self.send(&Message::RequestStats)?;
        let sent = self.frames_sent();
        let mut stats = None;
        self.wait_for("Stats", |_, e| match e {
            Some(LinkEvent::Stats(s)) if frames_received(s) >= sent => {
                stats = Some(*s);
                true
            }
            _ => false,
        })?;
        stats.ok_or_else(|| "no Stats".to_string())
    }

    /// RequestStats until the device has counted `target` telegrams (decoded or refused for
    /// their checksum or framing: a telegram is counted when its last byte is taken); returns
    /// its count.
    ///
    /// # Errors
    /// No Stats in time, or the count never reaching `target`.
    fn wait_for_telegrams(&mut self, target: u64) -> Result<u64, String> {
        let mut counted = 0;
        for round in 0..INPUT_ROUNDS {
            let s = self.stats()?;
            counted = u64::from(s.telegrams_ok)
                + u64::from(s.telegrams_bad_checksum)
                + u64::from(s.telegrams_bad_framing);
            if counted >= target {
                return Ok(counted);
            }
            self.back_off(round);
        }
        Err(format!(
            "telegram {target}: the device counts only {counted} telegrams"
        ))
    }

    /// RequestStats until the device has taken `target` laser bytes since it booted
    /// (`laser_bytes`, compared modulo 2³²); returns its count.
    ///
    /// # Errors
    /// No Stats in time, or the count never reaching `target`.
    fn wait_for_laser_bytes(&mut self, target: u64) -> Result<u64, String> {
        let mut taken = 0;
        for round in 0..INPUT_ROUNDS {
            let s = self.stats()?;
            taken = s.laser_bytes;
            #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
            if taken.wrapping_sub(target as u32) as i32 >= 0 {
                return Ok(u64::from(taken));
            }
            self.back_off(round);
        }
        Err(format!(
            "laser byte {target}: the device has taken only {taken} (mod 2^32)"
        ))
    }

    /// RequestStats until the device has no changed tile left to queue: every change it made
    /// before that Stats was then on the wire ahead of it, so the mirror holds the device's
    /// maps cell for cell (`tiles_dirty`, `docs/protocol.md`). Between two questions the
    /// device is left [`idle`](Self::idle): each Stats it answers is charged to the same byte
    /// budget as its tiles, and a host that asked without pause would spend that budget on
    /// answers and starve the tiles it waits for.
    ///
    /// # Errors
    /// No Stats in time, or tiles still waiting after [`SYNC_ROUNDS`] rounds.
    fn sync(&mut self) -> Result<Stats, String> {
        for _ in 0..SYNC_ROUNDS {
            let stats = self.stats()?;
            if stats.tiles_dirty == 0 {
                return Ok(stats);
            }
            self.idle();
        }
        Err("the device's tiles never stopped changing".into())
    }

    /// Waits before question `round + 1` of a wait for the device's laser input, so that a
    /// device on real time spends its cycles on the laser's bytes rather than on answering:
    /// 1, 2, 4 and 8 ms after the first four questions, then 16 ms (the default). An
    /// in-process device, which has taken every byte when it answers, does not wait.
    fn back_off(&mut self, round: u32) {
        std::thread::sleep(std::time::Duration::from_millis(1 << round.min(4)));
    }

    /// Lets the device's clock move on while the host waits between two questions, so that
    /// its link's budget refills for the tiles still waiting to go out. A device on real time
    /// (a board, the emulator) is given [`IDLE_PAUSE`] of wall time (the default); an
    /// in-process device moves its clock instead.
    fn idle(&mut self) {
        std::thread::sleep(IDLE_PAUSE);
    }

    /// RequestSnapshot(all), and wait until the mirror holds every layer whole.
    ///
    /// # Errors
    /// Refused, or not complete in time.
    fn snapshot(&mut self) -> Result<(), String> {
        let hellos = self.link().mirror().counters().hellos;
        self.command(
            "RequestSnapshot",
            &Message::RequestSnapshot(SnapshotScope::All),
        )?;
        self.wait_for("the snapshot", |link, _| {
            let m = link.mirror();
            m.counters().hellos > hellos && m.is_synced()
        })
    }
}

/// Host frames a Stats counts as received (good or refused for their framing), as the
/// device's frame accumulator counts them: each frame exactly once.
#[must_use]
pub fn frames_received(s: &Stats) -> u64 {
    u64::from(s.rx_frames_ok)
        + u64::from(s.rx_bad_cobs)
        + u64::from(s.rx_bad_crc)
        + u64::from(s.rx_bad_length)
        + u64::from(s.rx_bad_other)
}

/// The library's co-processor in this process, with a host link's mirror of its maps and a
/// clock the harness moves ([`InProcess::set_time`]). Its queue is drained completely at every
/// poll, as a UART faster than the link's budget would.
pub struct InProcess<const W: usize, const L: usize, const C: usize, const Q: usize> {
    core: Box<CoProcessor<W, L, C, Q>>,
    host: HostLink,
    now_ms: u32,
    out: Vec<u8>,
    last_poll: PollReport,
    frames_sent: u64,
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize> InProcess<W, L, C, Q> {
    /// How far the clock moves at each poll of a wait that is not satisfied yet, ms.
    pub const POLL_STEP_MS: u32 = 10;

    /// Boots a co-processor with the link's settings, a design, a configuration and a setup,
    /// exactly as a board does. Build it on a thread whose stack holds a
    /// `CoProcessor<W, L, C, Q>` (the value is made on the stack, then boxed).
    ///
    /// # Errors
    /// The boot was refused (the message says why).
    pub fn boot(
        link: LinkConfig,
        design: &Design<L>,
        config: &Config,
        setup: FrontendConfig,
    ) -> Result<Self, String> {
        let mut core = Box::new(CoProcessor::new());
        core.boot(link, design, config, setup)
            .map_err(|e| e.to_string())?;
        Ok(Self {
            core,
            host: HostLink::new(),
            now_ms: 0,
            out: Vec::with_capacity(4096),
            last_poll: PollReport::default(),
            frames_sent: 0,
        })
    }

    /// The co-processor itself, to read its pyramid and counters directly.
    #[must_use]
    pub fn core(&self) -> &CoProcessor<W, L, C, Q> {
        &self.core
    }

    /// Sets the device's clock (ms, wrapping) for the next polls.
    pub fn set_time(&mut self, now_ms: u32) {
        self.now_ms = now_ms;
    }

    /// The device's clock, ms.
    #[must_use]
    pub fn time(&self) -> u32 {
        self.now_ms
    }

    /// Polls the device at its clock, drains everything it queued into the mirror and returns
    /// what the mirror made of it.
    pub fn poll(&mut self) -> Vec<LinkEvent> {
        self.last_poll = self.core.poll(self.now_ms);
        self.out.clear();
        let mut buf = [0_u8; 1024];
        loop {
            let n = self.core.take_output(&mut buf);
            if n == 0 {
                break;
            }
            self.out.extend_from_slice(&buf[..n]);
        }
        self.host.feed(&self.out)
    }

    /// What the device's last poll queued (and what it left for later).
    #[must_use]
    pub fn last_poll(&self) -> PollReport {
        self.last_poll
    }

    /// Answers a Shutdown the host sent, as a board does (a host process has no stack to
    /// measure: zero), and returns the Reply's events after a poll.
    pub fn answer_shutdown(&mut self) -> Vec<LinkEvent> {
        self.core.answer_shutdown(StackUsage::default());
        self.poll()
    }
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize> Device
    for InProcess<W, L, C, Q>
{
    fn laser(&mut self, bytes: &[u8]) -> Result<(), String> {
        // The in-process clock, in µs (it wraps with the board's every 71.6 minutes).
        let now_us = self.now_ms.wrapping_mul(1_000);
        self.core.laser(bytes, now_us, &mut NoAngleSource);
        Ok(())
    }

    fn send(&mut self, message: &Message<'_>) -> Result<u16, String> {
        let seq = self.host.next_seq();
        let bytes = self.host.command(message).map_err(|e| e.to_string())?;
        self.core.host(&bytes);
        self.frames_sent += 1;
        if self.core.shutdown_requested() {
            self.core.answer_shutdown(StackUsage::default());
        }
        Ok(seq)
    }

    fn wait_for(
        &mut self,
        what: &str,
        mut done: impl FnMut(&HostLink, Option<&LinkEvent>) -> bool,
    ) -> Result<(), String> {
        if done(&self.host, None) {
            return Ok(());
        }
        for _ in 0..MAX_IN_PROCESS_POLLS {
            let events = self.poll();
            for event in &events {
                if done(&self.host, Some(event)) {
                    return Ok(());
                }
            }
            if done(&self.host, None) {
                return Ok(());
            }
            self.now_ms = self.now_ms.wrapping_add(Self::POLL_STEP_MS);
        }
        Err(format!(
            "the in-process device never produced {what} ({MAX_IN_PROCESS_POLLS} polls)"
        ))
    }

    fn link(&self) -> &HostLink {
        &self.host
    }

    /// No wait: the co-processor has taken every byte when it answers.
    fn back_off(&mut self, _round: u32) {}

    /// The clock moves [`Self::POLL_STEP_MS`] and the co-processor polls once, as a board's
    /// main loop does between two questions: its tiles go out without a Stats ahead of them
    /// in the queue (a small queue, the micro:bit's 400 bytes, holds a Stats or a tile beside
    /// the control reserve, not both). What it sends reaches the mirror.
    fn idle(&mut self) {
        self.now_ms = self.now_ms.wrapping_add(Self::POLL_STEP_MS);
        let _ = self.poll();
    }

    fn frames_sent(&self) -> u64 {
        self.frames_sent
    }
}
