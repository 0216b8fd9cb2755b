//! The host side of the co-processor: host bytes validated by the link and carried out, the
//! Shutdown handshake, and what goes out on the host link (poll, drain).

use super::{bump, CoProcessor, Shutdown, StackUsage};
use crate::link::convert;
use crate::link::{Command, PollReport, Rejection, Request};
use crate::wire::link::Reply;
use crate::wire::FeedResult;

impl<const W: usize, const L: usize, const C: usize, const Q: usize, const N: usize>
    CoProcessor<W, L, C, Q, N>
{
    /// Takes bytes from the host: every command they complete is validated by the link and
    /// carried out here, in order. After a Shutdown the rest is dropped (and counted) until
    /// the board answers it.
    ///
    /// The bytes carry no time: a TimeRequest they complete is answered with the device time
    /// of the last [`host_at`](Self::host_at) (0 before any). A board with a µs clock calls
    /// `host_at`.
    pub fn host(&mut self, bytes: &[u8]) {
        let mut chunk = bytes;
        while !chunk.is_empty() {
            if self.shutdown != Shutdown::Running {
                let n = u32::try_from(chunk.len()).unwrap_or(u32::MAX);
                self.counters.bytes_after_shutdown =
                    self.counters.bytes_after_shutdown.saturating_add(n);
                return;
            }
            chunk = match self.link.receive_at(chunk, self.host_clock_us) {
                FeedResult::Consumed => return,
                FeedResult::Item {
                    item, remaining, ..
                } => {
                    self.execute(item);
                    remaining
                }
                FeedResult::Rejected {
                    error, remaining, ..
                } => {
                    match error {
                        Rejection::Refused(reply) => warn!("refused: {:?}", reply),
                        Rejection::BadFrame(e) => warn!("bad frame: {:?}", e),
                    }
                    remaining
                }
            };
        }
    }

    /// [`host`](Self::host) for bytes the board took from the host UART at `now_us` of its
    /// µs clock (wrapping; the clock the laser's bytes are timed with): a TimeRequest they
    /// complete is answered with this time, the device's side of the host's clock
    /// exchange.
    pub fn host_at(&mut self, bytes: &[u8], now_us: u32) {
        self.host_clock_us = now_us;
        // The stamped poses' lead is checked against the latest device time seen.
        self.clock_us = now_us;
        self.clock_known = true;
        self.host(bytes);
    }

    /// Carries out one validated command and answers it.
    fn execute(&mut self, request: Request<L>) {
        bump(&mut self.counters.commands);
        let Some(Request { header, command }) = self.link.serve(&mut self.pyramid, request) else {
            return;
        };
        match command {
            Command::Pose(pose, None) => self.set_pose(pose),
            Command::Pose(pose, Some(stamp_us)) => self.stamped_pose(stamp_us, pose),
            Command::PanAngle(angle) => self.host_angle = Some(angle),
            Command::Configure(design, config) => match self.configure(&design, &config) {
                Ok(()) => {
                    self.link.answer(Reply::ok(header));
                    self.link.announce(&self.pyramid);
                }
                Err(e) => self.link.refuse(convert::design_refusal(header, &e)),
            },
            Command::Reset => {
                self.pyramid.clear();
                self.frontend.restart_observation();
                self.link.answer(Reply::ok(header));
                self.link.maps_cleared();
                self.link.announce(&self.pyramid);
            }
            Command::Setup(setup) => {
                self.link.answer(Reply::ok(header));
                self.adopt_setup(setup);
            }
            Command::SetRule(step_threshold, rule) => {
                self.link.answer(Reply::ok(header));
                let mut config = *self.frontend.config();
                config.classifier.step_threshold = step_threshold;
                config.classifier.rule = rule;
                // The observation under way is discarded, as by a Setup.
                self.frontend.configure(config);
            }
            Command::EndObservation => self.end_observation(),
            Command::Shutdown => self.shutdown = Shutdown::Requested(header),
            // Carried out by the link (`Link::serve`).
            Command::Snapshot(_)
            | Command::Ping
            | Command::RequestStats
            | Command::TimeRequest { .. } => {}
        }
    }

    /// Whether the host asked the device to stop and the board has not answered yet.
    #[must_use]
    pub const fn shutdown_requested(&self) -> bool {
        matches!(self.shutdown, Shutdown::Requested(_))
    }

    /// Whether the Shutdown was answered: the co-processor takes nothing any more; the board
    /// drains the queue and stops.
    #[must_use]
    pub const fn stopped(&self) -> bool {
        matches!(self.shutdown, Shutdown::Answered)
    }

    /// Answers the host's Shutdown with Reply Ok carrying the stack's high-water mark in
    /// `value` and its size in `a` (bytes); the board then drains the queue and stops. Does
    /// nothing when no Shutdown is waiting.
    pub fn answer_shutdown(&mut self, stack: StackUsage) {
        let Shutdown::Requested(header) = self.shutdown else {
            return;
        };
        let mut reply = Reply::ok(header);
        #[allow(clippy::cast_precision_loss)]
        {
            reply.value = stack.used as f32;
            reply.a = stack.size as f32;
        }
        self.link.answer(reply);
        self.shutdown = Shutdown::Answered;
    }

    /// Queues what is due on the host link (Hello, WindowMoved, Stats, changed tiles within
    /// the budget); `now_ms` is the board's clock in milliseconds (wrapping).
    pub fn poll(&mut self, now_ms: u32) -> PollReport {
        // The last observation placed with stamped poses goes out ahead of its patches.
        if let Some(span) = self.frontend.take_observed() {
            // A full queue drops it (counted by the link as a lost control frame).
            let _ = self
                .link
                .observed(span.observation, span.first_us, span.last_us);
        }
        let sensor = self.sensor_counters();
        self.link.poll(now_ms, &mut self.pyramid, &sensor)
    }

    /// Writes up to `limit` queued bytes to `out` (as many as it takes: a blocking UART all of
    /// them, a non-blocking one what fits); returns how many were written.
    ///
    /// # Errors
    /// The writer's error; the bytes it did not take stay queued.
    pub fn drain<T: embedded_io::Write>(
        &mut self,
        out: &mut T,
        limit: usize,
    ) -> Result<usize, T::Error> {
        let mut sent = 0;
        while sent < limit {
            let chunk = self.link.peek();
            let n = chunk.len().min(limit - sent);
            let Some(piece) = chunk.get(..n) else {
                break;
            };
            if piece.is_empty() {
                break;
            }
            let written = out.write(piece)?;
            if written == 0 {
                break;
            }
            self.link.consume(written);
            sent += written;
        }
        Ok(sent)
    }

    /// Moves up to `out.len()` queued bytes into `out`; returns how many.
    pub fn take_output(&mut self, out: &mut [u8]) -> usize {
        self.link.pop_bytes(out)
    }
}
