//! The host's end of one `pyramid listen` session: greeting the device (its Setup, SetRule
//! and snapshot request), the receive loop, reconnecting, and what the device's answers tell
//! the user.
use super::design::{Verdict, WantedDesign};
use super::status::{status_line, Counts, RateMeter, StatusOutput, SyncState};
use super::timing::Timing;
use super::transport::{Received, Transport};
use super::{
    clock_name, Args, READ_TIMEOUT, RECONNECT_INTERVAL, SNAPSHOT_RETRY, STATUS_INTERVAL,
    TIME_REQUEST_FAST_FOR,
};
use crate::clock_sync::{Exchange, Outcome, ResetReason};
use crate::link::{HostLink, LinkEvent};
use crate::publish::{Outputs, RobotPose};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use terrain_pyramid::link::convert::ReplyText;
use terrain_pyramid::wire::link::RxCounters;
use terrain_pyramid::wire::link::{
    Hello, HelloReason, Message, MessageType, PoseReport, Reply, ReplyCode, SetRule, Setup,
    SnapshotScope, POSE_STAMPED,
};

/// The host's end of one session: the link, and when it last asked for a snapshot.
pub(super) struct Session {
    pub(super) transport: Transport,
    pub(super) host: HostLink,
    /// The live outputs, when any is on.
    pub(super) outputs: Option<Outputs>,
    pub(super) reconnects: u64,
    /// When the outstanding snapshot request was sent (`None`: none outstanding).
    pub(super) requested: Option<Instant>,
    pub(super) snapshots_requested: u64,
    /// The rule to set on the device on connecting (`--rule` and its parameters).
    pub(super) set_rule: Option<SetRule>,
    /// The rig's Setup, sent on connecting before the rule (`--rig` and the rig flags).
    pub(super) setup: Option<Setup>,
    /// Setups sent (one per connection, and one more after each boot Hello).
    pub(super) setups_sent: u64,
    /// The rig's design (`[design]`), sent as a Configure when the device runs another.
    pub(super) design: Option<WantedDesign>,
    /// Configures sent.
    pub(super) configures_sent: u64,
    /// The clocks and the poses.
    pub(super) timing: Timing,
}

impl Session {
    /// Sends the rig's Setup (if given), the SetRule of `--rule` (if given) and then
    /// `RequestSnapshot(all)`; `Err` when the stream is gone.
    fn greet(&mut self, now: Instant) -> Result<(), String> {
        if let Some(setup) = self.setup {
            self.send(&Message::Setup(setup))?;
            self.setups_sent += 1;
        }
        if let Some(set) = self.set_rule {
            let bytes = self
                .host
                .command(&Message::SetRule(set))
                .map_err(|e| format!("cannot encode SetRule: {e:?}"))?;
            self.transport
                .write_all(&bytes)
                .map_err(|e| format!("cannot send to the device: {e}"))?;
        }
        self.request_snapshot(now)
    }

    /// Sends `RequestSnapshot(all)`; `Err` when the stream is gone.
    fn request_snapshot(&mut self, now: Instant) -> Result<(), String> {
        let bytes = self
            .host
            .command(&Message::RequestSnapshot(SnapshotScope::All))
            .map_err(|e| format!("cannot encode RequestSnapshot: {e:?}"))?;
        self.transport
            .write_all(&bytes)
            .map_err(|e| format!("cannot send to the device: {e}"))?;
        self.requested = Some(now);
        self.snapshots_requested += 1;
        Ok(())
    }

    /// Sends `message`; `Err` when the stream is gone.
    pub(super) fn send(&mut self, message: &Message<'_>) -> Result<(), String> {
        let bytes = self
            .host
            .command(message)
            .map_err(|e| format!("cannot encode a command: {e:?}"))?;
        self.transport
            .write_all(&bytes)
            .map_err(|e| format!("cannot send to the device: {e}"))
    }

    /// The clocks' and the poses' part of a pass at `now`: the wall clock read, the inputs
    /// taken, a pose forwarded and a TimeRequest sent when due.
    fn tend(&mut self, now: Instant) -> Result<(), String> {
        self.timing.observe_wall(now);
        self.timing.drain_inputs(now);
        let now_us = self.timing.host_us(now);
        if let Some(p) = self.timing.forwarder.poll(now_us, &self.timing.clock) {
            self.send(&Message::Pose(PoseReport {
                x_m: p.x,
                y_m: p.y,
                z_m: p.z,
                roll_rad: p.roll,
                pitch_rad: p.pitch,
                yaw_rad: p.yaw,
                stamp_us: p.stamp_us,
                flags: POSE_STAMPED,
            }))?;
            self.timing.last_pose = Some(RobotPose {
                x: f64::from(p.x),
                y: f64::from(p.y),
                yaw: f64::from(p.yaw),
            });
        }
        if let Some(request) = self.timing.request_due(now) {
            self.send(&Message::TimeRequest(request))?;
        }
        Ok(())
    }

    /// What a Hello means for the rig's design: a Configure sent when the device runs
    /// another pyramid; the line to show the user, if any.
    fn design_on_hello(&mut self, hello: &Hello) -> Option<String> {
        let verdict = self.design.as_mut()?.on_hello(hello);
        match verdict {
            Verdict::Quiet => None,
            Verdict::Runs(ours) => Some(format!("device: runs the rig's design ({ours})")),
            Verdict::Configure(configure, theirs, ours, again) => {
                let sent = self.send(&Message::Configure(*configure)).map(|()| {
                    self.configures_sent += 1;
                });
                // A device that ran the rig's design and runs another booted unseen, most
                // likely: its Setup and rule go again too, as after a boot Hello.
                let resent = if again && (self.setup.is_some() || self.set_rule.is_some()) {
                    sent.and_then(|()| self.greet(Instant::now()))
                        .map(|()| " (it ran it before: the rig's setup and rule sent again)")
                } else {
                    sent.map(|()| "")
                };
                Some(match resent {
                    Ok(also) => format!(
                        "device: runs {theirs}; the rig's design sent ({ours}): its maps start afresh{also}"
                    ),
                    Err(e) => format!("warning: {e}"),
                })
            }
            Verdict::StillOther(theirs, ours) => Some(format!(
                "warning: after the rig's design ({ours}) the device runs {theirs}: it keeps that"
            )),
            Verdict::Unbuildable(e) => Some(format!(
                "warning: the rig's [design] does not fit the device's {} cells a side: {e}; it keeps its pyramid",
                hello.cells_per_side
            )),
        }
    }

    pub(super) fn counts(&self) -> Counts {
        let c = self.host.mirror().counters();
        Counts {
            frames: c.frames,
            errors: total_errors(&self.host.rx_counters()),
            patches: c.patches,
            gaps: c.gaps,
            snapshots: self.snapshots_requested,
        }
    }
}

/// Looks for the device again every [`RECONNECT_INTERVAL`], keeping the mirror; once it is
/// back, asks for a snapshot (whatever happened meanwhile, the mirror may be behind). `Some`
/// when the session ends first.
pub(super) fn reconnect(
    session: &mut Session,
    args: &Args,
    stop: &AtomicBool,
    deadline: Option<Instant>,
    out: &mut StatusOutput,
) -> Option<Ending> {
    // Close the old connection (and a serial port's lock) first.
    session.transport = Transport::Closed;
    session.requested = None;
    let mut next_try = Instant::now() + RECONNECT_INTERVAL;
    let mut attempts = 0_u64;
    loop {
        if stop.load(Ordering::SeqCst) {
            return Some(Ending::Interrupted);
        }
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            return Some(Ending::Duration);
        }
        if now >= next_try {
            attempts += 1;
            match Transport::open(args) {
                Ok((transport, source)) => {
                    session.transport = transport;
                    session.reconnects += 1;
                    if let Some(design) = &mut session.design {
                        design.restart();
                    }
                    session
                        .timing
                        .restart(ResetReason::Reconnect, Instant::now());
                    let resumed = session
                        .transport
                        .write_all(&[0])
                        .map_err(|e| format!("cannot send to the device: {e}"))
                        .and_then(|()| session.greet(Instant::now()));
                    match resumed {
                        Ok(()) => out.notice(&format!(
                            "reconnected to {source} after {attempts} attempts; snapshot requested"
                        )),
                        Err(e) => out.notice(&format!("warning: {e}")),
                    }
                    return None;
                }
                Err(_) => next_try = Instant::now() + RECONNECT_INTERVAL,
            }
        }
        std::thread::sleep(READ_TIMEOUT);
    }
}

/// Runs the session until it ends; returns the link and why it ended.
pub(super) fn receive(
    mut session: Session,
    args: &Args,
    stop: &AtomicBool,
    out: &mut StatusOutput,
) -> (Session, Ending, Duration) {
    let start = Instant::now();
    let deadline = args.duration_s.map(|s| start + Duration::from_secs_f64(s));
    let mut meter = RateMeter::default();
    let mut next_status = start;
    let mut next_diagnostics = start;
    let mut buf = vec![0_u8; 4096];
    // One delimiter ends whatever the device's receiver holds, then the first request.
    let opened = session
        .transport
        .write_all(&[0])
        .map_err(|e| format!("cannot send to the device: {e}"))
        .and_then(|()| session.greet(start));
    if let Err(e) = opened {
        out.notice(&format!("warning: {e}"));
    }
    session.timing.fast_until = start + TIME_REQUEST_FAST_FOR;
    session.timing.next_request = start;
    let mut announced_sync = false;
    let ending = loop {
        if stop.load(Ordering::SeqCst) {
            break Ending::Interrupted;
        }
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            break Ending::Duration;
        }
        if now >= next_status {
            let counts = session.counts();
            let rates = meter.sample(now, counts);
            let state = SyncState::of(session.host.mirror());
            out.status(&status_line(now - start, &counts, &rates, state));
            next_status += STATUS_INTERVAL;
            if next_status < now {
                next_status = now + STATUS_INTERVAL;
            }
        }
        let read = session.transport.read(&mut buf);
        let read_at = session.timing.host_us(Instant::now());
        let n = match read {
            Received::Bytes(n) => n,
            Received::Nothing => 0,
            Received::Ended(error) => {
                if !(args.reconnect || args.port.is_some()) {
                    if let Some(e) = error {
                        out.notice(&format!("warning: the stream ended: {e}"));
                    }
                    break Ending::EndOfStream;
                }
                out.notice(&format!(
                    "warning: the device's stream ended ({}): trying to reconnect every {} s; the maps are kept",
                    error.as_deref().unwrap_or("closed by the device"),
                    RECONNECT_INTERVAL.as_secs()
                ));
                match reconnect(&mut session, args, stop, deadline, out) {
                    Some(ending) => break ending,
                    None => continue,
                }
            }
        };
        let mut wants = false;
        let mut rebooted = false;
        for event in session.host.feed(buf.get(..n).unwrap_or_default()) {
            match event {
                LinkEvent::Hello(hello) => {
                    // Any Hello answers (or supersedes) an outstanding request.
                    session.requested = None;
                    if hello.reason == HelloReason::Boot {
                        // A new clock: the old mapping is void, poses wait for the new one.
                        session
                            .timing
                            .restart(ResetReason::DeviceBoot, Instant::now());
                        rebooted = true;
                        if let Some(design) = &mut session.design {
                            design.restart();
                        }
                    }
                    if hello.reason != HelloReason::Snapshot {
                        out.notice(&format!(
                            "device: Hello ({}), firmware {}.{}.{}, {} layers of {} cells, clock: {}",
                            match hello.reason {
                                HelloReason::Boot => "boot",
                                HelloReason::Configured => "configured",
                                HelloReason::Reset => "reset",
                                HelloReason::Snapshot => "snapshot",
                            },
                            hello.firmware.major,
                            hello.firmware.minor,
                            hello.firmware.patch,
                            hello.layers.len(),
                            hello.cells_per_side,
                            clock_name(hello.clock)
                        ));
                    }
                    if let Some(notice) = session.design_on_hello(&hello) {
                        out.notice(&notice);
                    }
                }
                LinkEvent::SnapshotNeeded => wants = true,
                LinkEvent::Reply(reply) if reply.to_type == MessageType::SetRule.to_u8() => {
                    out.notice(&set_rule_answer(&reply));
                }
                LinkEvent::Reply(reply) if reply.to_type == MessageType::Setup.to_u8() => {
                    out.notice(&setup_answer(&reply));
                }
                LinkEvent::Reply(reply) if reply.to_type == MessageType::Configure.to_u8() => {
                    out.notice(&configure_answer(&reply));
                }
                LinkEvent::TimeReply(reply) => {
                    let outcome = session.timing.clock.add(Exchange {
                        host_sent_us: reply.host_us,
                        device_us: reply.device_us,
                        host_received_us: read_at,
                        queued_ahead: reply.queued_ahead,
                    });
                    if outcome == Outcome::Reset {
                        out.notice(
                            "warning: the device's clock jumped (a reboot whose Hello was lost?): \
                             time sync restarted, poses wait for it",
                        );
                        session.timing.forwarder.drop_pending();
                        session.timing.fast_until = Instant::now() + TIME_REQUEST_FAST_FOR;
                    }
                }
                LinkEvent::Observed(observed) => {
                    session.timing.observed += 1;
                    match session.timing.wall_time_of(observed.last_us) {
                        Some(stamp) => {
                            if let Some(outputs) = &mut session.outputs {
                                outputs.set_data_stamp(stamp);
                            }
                        }
                        None => session.timing.observed_unmapped += 1,
                    }
                }
                LinkEvent::Reply(_)
                | LinkEvent::Stats(_)
                | LinkEvent::BadFrame(_)
                | LinkEvent::Faded(_) => {}
            }
        }
        // A device that booted runs its boot setup and rule: the rig's go again (a watchdog
        // reset behind a serial port that stays open ends no connection). One that boots as
        // the host connects has them twice, which costs at most its first observation.
        if rebooted && (session.setup.is_some() || session.set_rule.is_some()) {
            match session.greet(Instant::now()) {
                Ok(()) => out.notice(
                    "device booted: the rig's setup and rule sent again; snapshot requested",
                ),
                Err(e) => out.notice(&format!("warning: {e}")),
            }
        }
        let now = Instant::now();
        // A write that fails means the stream is gone: the next read says so and ends or
        // reconnects the session.
        let _ = session.tend(now);
        match (session.timing.clock.estimate(), announced_sync) {
            (Some(e), false) => {
                out.notice(&format!(
                    "clock: synced with the device (drift {:.1} ppm, accuracy {:.0} µs, round trip {} µs)",
                    e.drift_ppm, e.accuracy_us, e.round_trip_us
                ));
                announced_sync = true;
            }
            (None, true) => announced_sync = false,
            _ => {}
        }
        if let Some(outputs) = &mut session.outputs {
            if let Some(frame) = session.timing.forwarder.frame() {
                outputs.set_pose_frame(frame);
            }
            if now >= next_diagnostics {
                let hardware_id = session.host.mirror().firmware().map_or_else(
                    || "terrain-pyramid".to_string(),
                    |f| {
                        format!(
                            "terrain-pyramid firmware {}.{}.{}",
                            f.major, f.minor, f.patch
                        )
                    },
                );
                outputs.set_diagnostics(session.timing.diagnostics(&hardware_id));
                next_diagnostics = now + STATUS_INTERVAL;
            }
            outputs.offer(session.host.mirror(), session.timing.last_pose);
        }
        let overdue = session
            .requested
            .is_none_or(|t| now.duration_since(t) >= SNAPSHOT_RETRY);
        let needed = wants || session.host.mirror().needs_snapshot();
        if needed && overdue {
            if let Err(e) = session.request_snapshot(now) {
                out.notice(&format!("warning: the stream ended: {e}"));
                break Ending::EndOfStream;
            }
        }
    };
    let elapsed = start.elapsed();
    let counts = session.counts();
    let rates = meter.sample(Instant::now(), counts);
    out.status(&status_line(
        elapsed,
        &counts,
        &rates,
        SyncState::of(session.host.mirror()),
    ));
    out.finish();
    (session, ending, elapsed)
}

/// What the device's answer to the rig's Setup tells the user: a refusal names the field and
/// its rule, as every refused command is rendered ([`ReplyText`]).
fn setup_answer(reply: &Reply) -> String {
    match reply.code {
        ReplyCode::Ok => "device: the rig's setup taken".to_string(),
        ReplyCode::Unsupported => {
            "warning: the device does not take Setup: it keeps its own setup".to_string()
        }
        _ => format!(
            "warning: the device refused the rig's setup: {} (it keeps its own setup)",
            ReplyText(reply).reason()
        ),
    }
}

/// What the device's answer to the rig's design (a Configure) tells the user: a refusal
/// names the value and its rule.
fn configure_answer(reply: &Reply) -> String {
    match reply.code {
        ReplyCode::Ok => "device: the rig's design taken".to_string(),
        _ => format!(
            "warning: the device refused the rig's design: {} (it keeps its pyramid)",
            ReplyText(reply).reason()
        ),
    }
}

/// What the device's answer to SetRule tells the user.
fn set_rule_answer(reply: &Reply) -> String {
    match reply.code {
        ReplyCode::Ok => "device: navigability rule set".to_string(),
        ReplyCode::Unsupported => "warning: the device does not take SetRule (its firmware is \
             older than this host): it keeps its own navigability rule"
            .to_string(),
        code => {
            let field = terrain_pyramid::link::convert::SetupField::from_param(reply.param)
                .map_or("a field", |f| f.name());
            format!(
                "warning: the device refused the navigability rule: {field} ({code:?}, value {})",
                reply.value
            )
        }
    }
}

/// Why a session ended.
#[derive(Serialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// Ctrl-C or SIGTERM.
    Interrupted,
    /// The device closed the stream (or the port failed).
    EndOfStream,
    /// `--duration-s` elapsed.
    Duration,
}

/// Every receive error of the link, summed.
pub(super) fn total_errors(rx: &RxCounters) -> u64 {
    [
        rx.cobs,
        rx.crc,
        rx.too_short,
        rx.too_long,
        rx.unknown_version,
        rx.unknown_type,
        rx.bad_body,
        rx.out_of_range,
    ]
    .iter()
    .map(|&n| u64::from(n))
    .sum()
}
