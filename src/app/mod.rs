//! The application core: the whole co-processor as one `no_std` type, [`CoProcessor`], with
//! an I/O-free surface in the manner of smoltcp's `Interface::poll`. It owns the laser's
//! accumulator, the per-line pipeline (with the classifier and its gating), the pyramid, the
//! device side of the host link and the counters; a board (or a host harness) hands it what
//! it has and drains what it produces:
//!
//! ```text
//! laser UART bytes ──▶ laser(bytes, now_us, angle source) ──▶ telegrams / packets ─▶ pipeline ─▶ pyramid
//! host UART bytes  ──▶ host(bytes) ──▶ validated commands, carried out here
//! clock            ──▶ poll(now_ms) ──▶ Hello, WindowMoved, Stats, patches queued
//! host UART        ◀── drain(writer, limit) / take_output(buf)
//! laser UART       ◀── take_laser_change(): the sensor and baud rate to set up
//! servo PWM        ◀── actuator_command(now_us): the angle to command a nodding servo
//! ```
//!
//! What differs per board comes in as an argument: the time (`poll(now_ms)`, and the µs clock
//! of the laser bytes' arrival), the actuator angle's source (any [`AngleSource`];
//! [`NoAngleSource`] where there is none), the stack measurement (given to
//! [`CoProcessor::answer_shutdown`]); the watchdog and the peripherals stay with the board.
//! Every board and every host harness drives this one type, so "firmware = host" holds by
//! construction.
//!
//! # Behaviour, decided once
//! - **Boot** ([`CoProcessor::boot`]): the design, the configuration and the setup are
//!   adopted, the pyramid passes a self-check (three records, three fused answers, then
//!   forgotten), and Hello (reason boot) goes out at the first poll.
//! - **The laser** is the one the setup names ([`crate::laser`]): one decoder, chosen by
//!   the boot setup and by every Setup (a new sensor gets a fresh decoder; its counts carry
//!   on), at the baud rate the board reads from [`CoProcessor::take_laser_change`].
//! - **The actuator angle of a SICK line** is read from the board's source when the line's
//!   telegram completes. When the source fails (counted in
//!   [`AppCounters::angle_source_errors`]), the host's last PanAngle stands in (a nodding
//!   servo's model, when the setup has one); with neither, the line is dropped and counted
//!   ([`AppCounters::lines_without_angle`]): a line placed at a wrong angle would corrupt the
//!   map.
//! - **The actuator angles of a lidar packet** are those at its first and its last return,
//!   timed back from the arrival of its bytes ([`PacketTimer`]); the pipeline interpolates
//!   between them per return. They come from the board's source, read once per call of
//!   [`CoProcessor::laser`] that completes a packet and interpolated between its last two
//!   readings ([`AngleTrack`]); when it fails, from the servo's model at those times (a
//!   nodding servo the setup names), else the host's last PanAngle for the whole packet;
//!   with none, the packet is dropped and counted. `docs/lidars.md` states the timing
//!   model and its error budget.
//! - **Host commands** are validated by the link ([`Link::receive`]) and carried out here in
//!   the order they arrive: Pose and PanAngle take effect for the next line; Setup
//!   reconfigures the pipeline (the observation under way is discarded); Configure and Reset
//!   clear the maps, discard the observation and announce themselves with Hello right after
//!   their Reply; EndObservation applies the observation under way; Shutdown stops the intake
//!   (bytes after it are dropped) until the board answers it
//!   ([`CoProcessor::answer_shutdown`]).
//! - **Stats** carry the laser decoder's counters mapped onto the telegram counters (ok,
//!   bad checksum, bad framing: [`crate::laser::LaserCounts`]), the pipeline's and the
//!   classifier's; `telegrams_bad_other` adds telegrams that are not measured values, lines
//!   and packets the pipeline refused and those without an angle.

#[cfg(test)]
mod lidar_tests;
#[cfg(test)]
mod rule_tests;
#[cfg(test)]
mod tests;

use core::fmt;

use crate::actuator::{Actuator, AngleTrack, ServoSweep};
use crate::angle::{Angle, FineAngle};
use crate::classify::ClassifierStats;
use crate::design::{Design, DesignError};
use crate::drivers::angle::AngleSource;
use crate::geometry::{Pose, PoseRefusal, PoseTrack, Taken};
use crate::laser::{
    LaserCounters, LaserDecoder, LaserItem, PacketTimer, RevolutionTracker, Sensor,
};
use crate::link::convert;
use crate::link::{
    Command, Link, LinkConfig, LinkCounters, PollReport, Rejection, Request, SensorCounters,
};
use crate::pipeline::{
    Frontend, FrontendConfig, FrontendStats, ObservedSpan, PacketActuator, PacketTimes,
};
use crate::pyramid::{Applied, Config, Evidence, EvidenceClass, Fused, Pyramid, PyramidStats};
use crate::units::{Meters, Weight};
use crate::wire::link::{Header, Reply};
use crate::wire::sick::MeasuredValues;
use crate::wire::FeedResult;

/// The co-processor's own counters (the modules' counters are in [`Counters`]). They
/// saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AppCounters {
    /// Valid telegrams that are not measured values, or whose values did not parse.
    pub telegrams_unparsed: u32,
    /// Lines and lidar packets dropped: no angle for them (the angle source failed, no
    /// servo model has settled and the host has sent no PanAngle).
    pub lines_without_angle: u32,
    /// Readings of the board's angle source that failed (the host's angle stood in, if any).
    pub angle_source_errors: u32,
    /// Overruns of the laser's UART the board reported ([`CoProcessor::laser_overrun`]).
    pub laser_overruns: u32,
    /// Host commands carried out.
    pub commands: u32,
    /// Host bytes dropped after a Shutdown.
    pub bytes_after_shutdown: u32,
    /// Stamped poses taken into the pose track ([`CoProcessor::stamped_pose`]).
    pub poses_stamped: u32,
    /// Stamped poses refused: not later than the newest, or more than 1 s ahead of the
    /// device's clock ([`crate::geometry::MAX_POSE_LEAD_US`]).
    pub poses_refused: u32,
    /// Stamped poses more than 500 ms after the newest ([`crate::geometry::MAX_POSE_GAP_US`]):
    /// the track restarted at them.
    pub pose_gaps: u32,
}

/// Every counter of the co-processor, by module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// The co-processor's own.
    pub app: AppCounters,
    /// The laser decoder's own (the current sensor's accumulator).
    pub laser: LaserCounters,
    /// The per-line pipeline's.
    pub frontend: FrontendStats,
    /// The classifier's.
    pub classifier: ClassifierStats,
    /// The pyramid's (since its last configuration).
    pub pyramid: PyramidStats,
    /// The host link's.
    pub link: LinkCounters,
}

/// The stack's use, as a board measures it (for the Reply to Shutdown), bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StackUsage {
    /// The high-water mark: the deepest the stack has reached.
    pub used: u32,
    /// The size of the stack region.
    pub size: u32,
}

/// Why [`CoProcessor::boot`] failed.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum BootError {
    /// The design or the configuration was refused.
    Design(DesignError),
    /// The pyramid answered the self-check wrongly; the check that failed.
    SelfCheck(&'static str),
}

impl fmt::Display for BootError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Design(e) => write!(f, "boot design refused: {e}"),
            Self::SelfCheck(what) => write!(f, "boot self-check failed: {what}"),
        }
    }
}

impl core::error::Error for BootError {}

impl From<DesignError> for BootError {
    fn from(e: DesignError) -> Self {
        Self::Design(e)
    }
}

/// An angle source for boards without one (an actuator driven open-loop, or angles that come
/// only from the host): every reading fails, so the host's PanAngle is used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoAngleSource;

/// The error of [`NoAngleSource`]: there is no source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoSource;

impl AngleSource for NoAngleSource {
    type Error = NoSource;

    fn read_angle(&mut self) -> Result<Angle, NoSource> {
        Err(NoSource)
    }
}

/// The laser as the board sets up its UART for it ([`CoProcessor::take_laser_change`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LaserPort {
    /// The sensor (the board sends it whatever starts its stream: a SCAN request, the SICK's
    /// continuous-output command).
    pub sensor: Sensor,
    /// The UART's baud rate, bits per second.
    pub baud: u32,
}

/// The co-processor's life: it runs until the host asks it to stop, and stops once the board
/// has answered that.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shutdown {
    /// Taking laser and host bytes.
    Running,
    /// The host sent Shutdown (this header); the board has not answered it yet.
    Requested(Header),
    /// Answered: nothing is taken any more.
    Answered,
}

/// The co-processor: a pyramid of up to `L` layers of `W × W` cells, a classifier of `C`
/// slots, and a host link with a `Q`-byte outgoing queue. About the pyramid's RAM plus the
/// pipeline's (`C` · 20 bytes, `L` KiB of gate tables, a 1.6 KiB beam table), the link's
/// (`Q` plus about 100 bytes a layer) and the laser decoder's (the largest accumulator, the
/// SICK's 818 bytes, and about 100 bytes of timing and actuator state); `const`-built all
/// zero bits, so a `static` one sits in `.bss` (build it in a `ConstStaticCell`, never on
/// the stack).
///
/// `N` is the capacity of the track of stamped poses ([`CoProcessor::stamped_pose`]; 28
/// bytes a pose): 16 (320 ms at 50 Hz) unless the board chooses.
pub struct CoProcessor<
    const W: usize,
    const L: usize,
    const C: usize,
    const Q: usize,
    const N: usize = 16,
> {
    pyramid: Pyramid<W, L>,
    frontend: Frontend<C, L>,
    link: Link<Q, L>,
    /// The laser's decoder: the setup's sensor.
    laser: LaserDecoder,
    /// The times of lidar packets' returns.
    timer: PacketTimer,
    /// Where the lidar's revolutions start.
    revolutions: RevolutionTracker,
    /// The board's angle source's last readings.
    track: AngleTrack,
    /// The nodding servo's model ([`ServoSweep::OFF`] without one; not an `Option`, whose
    /// `None` may not be zero bits).
    servo: ServoSweep,
    /// Whether the board has yet to set its laser UART up for the sensor in force.
    laser_change: bool,
    /// The host's last PanAngle: stands in when the board's angle source fails.
    host_angle: Option<Angle>,
    /// Where the co-processor is in its life: running, asked to stop, stopped.
    shutdown: Shutdown,
    counters: AppCounters,
    /// The robot's stamped poses: while it holds one, every return is placed with the pose
    /// of its own moment.
    poses: PoseTrack<N>,
    /// The latest device time seen (laser bytes' arrival, a servo command), µs, and whether
    /// any was: the bound on a stamped pose's lead is checked against it.
    clock_us: u32,
    clock_known: bool,
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize, const N: usize> fmt::Debug
    for CoProcessor<W, L, C, Q, N>
{
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CoProcessor")
            .field("pyramid", &self.pyramid)
            .field("frontend", &self.frontend)
            .field("counters", &self.counters)
            .finish()
    }
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize, const N: usize> Default
    for CoProcessor<W, L, C, Q, N>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize, const N: usize>
    CoProcessor<W, L, C, Q, N>
{
    /// An unconfigured co-processor: it refuses every line and sends nothing until
    /// [`boot`](Self::boot)ed. `const` and all zero bits, so a `static` one sits in `.bss` and
    /// costs no flash.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            pyramid: Pyramid::new(),
            frontend: Frontend::unconfigured(),
            link: Link::unconfigured(),
            laser: LaserDecoder::new(Sensor::Sick),
            timer: PacketTimer::ZERO,
            revolutions: RevolutionTracker::new(),
            track: AngleTrack::new(),
            servo: ServoSweep::OFF,
            laser_change: false,
            host_angle: None,
            shutdown: Shutdown::Running,
            counters: AppCounters {
                telegrams_unparsed: 0,
                lines_without_angle: 0,
                angle_source_errors: 0,
                laser_overruns: 0,
                commands: 0,
                bytes_after_shutdown: 0,
                poses_stamped: 0,
                poses_refused: 0,
                pose_gaps: 0,
            },
            poses: PoseTrack::new(),
            clock_us: 0,
            clock_known: false,
        }
    }

    /// Starts the link with its settings, adopts the boot design, configuration and setup,
    /// checks the pyramid (three records, three fused answers, then forgotten) and queues
    /// Hello (reason boot) for the first poll.
    ///
    /// # Errors
    /// The design or configuration was refused, or the self-check failed.
    pub fn boot(
        &mut self,
        link: LinkConfig,
        design: &Design<L>,
        config: &Config,
        setup: FrontendConfig,
    ) -> Result<(), BootError> {
        self.configure(design, config)?;
        self.self_check()?;
        self.adopt_setup(setup);
        self.laser_change = true;
        info!(
            "booted: {:?} ({} layers max, {} bytes of pyramid)",
            design,
            L,
            crate::pyramid::static_ram_bytes::<W, L>()
        );
        for (k, layer) in design.layers().iter().enumerate() {
            info!(
                "layer {}: cell {} m, band [{}, {}) m",
                k, layer.resolution_m, layer.band_inner_m, layer.band_outer_m
            );
        }
        // The link announces itself with Hello (reason boot), whatever was adopted.
        self.link.start(link);
        Ok(())
    }

    /// Configures the pyramid, the classifier's gating and the link with a design and a
    /// configuration: the maps are cleared and the observation under way is discarded; the
    /// host is told with Hello. On error nothing changes.
    ///
    /// # Errors
    /// The window is not `W`, the increments, clamp or margin are invalid, or a resolution
    /// cannot be represented.
    pub fn configure(&mut self, design: &Design<L>, config: &Config) -> Result<(), DesignError> {
        // The classifier's check first: it refuses exactly what the pyramid would (the
        // increments and the resolutions), so a refusal leaves both as they were.
        config.model.increments()?;
        self.pyramid.configure(design, config)?;
        self.frontend.adopt_design(design, config)?;
        self.frontend.restart_observation();
        self.link.adopt(design);
        Ok(())
    }

    /// Reconfigures the pipeline (mount, scanner, grouping, classifier) and the laser (its
    /// decoder, baud rate and actuator); the observation under way is discarded.
    pub fn setup(&mut self, setup: FrontendConfig) {
        self.adopt_setup(setup);
    }

    /// Adopts a setup: a new sensor or baud rate gets a fresh decoder and timer (and the board
    /// is told, [`take_laser_change`](Self::take_laser_change)); a new servo profile a fresh
    /// model (begun at the next laser bytes or command); then the pipeline.
    fn adopt_setup(&mut self, setup: FrontendConfig) {
        let old = *self.frontend.config();
        let sensor_changed = self.laser.set_sensor(setup.sensor);
        if sensor_changed || !self.frontend.is_configured() || old.baud != setup.baud {
            self.timer.reset(setup.baud);
            self.revolutions = RevolutionTracker::new();
            self.laser_change = true;
        }
        match setup.actuator {
            Actuator::External => self.servo = ServoSweep::OFF,
            Actuator::Servo(profile) => {
                if !self.servo.is_on() || *self.servo.profile() != profile {
                    self.servo = ServoSweep::new(profile);
                }
            }
        }
        self.frontend.configure(setup);
        // A new setup starts from the latest-pose rule.
        self.poses.clear();
    }

    /// Ends the observation under way now and applies it (the host's EndObservation does
    /// the same).
    pub fn end_observation(&mut self) {
        self.frontend.end_observation(&mut self.pyramid);
    }

    /// The robot's pose from now on, from a source on the board (odometry, an IMU); the
    /// host's unstamped Pose frames do the same. The track of stamped poses is cleared: every
    /// return takes this pose until the next (the latest-pose rule).
    pub fn set_pose(&mut self, pose: Pose) {
        self.poses.clear();
        self.frontend.set_pose(pose);
    }

    /// The robot was at `pose` at `stamp_us` (the device's µs clock, wrapping): the pose
    /// joins the track ([`crate::geometry::pose_track`]), and while the track holds a pose
    /// every return is placed with the pose of its own measurement time. Counted in
    /// [`AppCounters::poses_stamped`], or [`AppCounters::poses_refused`] (not later than the
    /// newest, or more than 1 s ahead of the latest device time the co-processor has seen:
    /// the laser bytes' arrival; before any, the lead is not checked); a gap of more than
    /// 500 ms restarts the track ([`AppCounters::pose_gaps`]).
    pub fn stamped_pose(&mut self, stamp_us: u32, pose: Pose) {
        let now = if self.clock_known {
            self.clock_us
        } else {
            // No clock seen yet: any stamp is within the lead of itself.
            stamp_us
        };
        match self.poses.push(stamp_us, pose, now) {
            Ok(taken) => {
                bump(&mut self.counters.poses_stamped);
                if taken == Taken::Restarted {
                    bump(&mut self.counters.pose_gaps);
                }
                // The newest pose may replace an extrapolation: evaluate afresh.
                self.frontend.forget_timed_pose();
            }
            Err(PoseRefusal::NotNewer | PoseRefusal::TooFarAhead) => {
                bump(&mut self.counters.poses_refused);
            }
        }
    }

    /// The track of stamped poses ([`stamped_pose`](Self::stamped_pose)).
    #[must_use]
    pub const fn pose_track(&self) -> &PoseTrack<N> {
        &self.poses
    }

    /// The observation count and the span of measurement times of the returns of the last
    /// observation applied with stamped poses in force, once (then `None` until the next):
    /// what the link's Observed frame carries. `None` for observations placed by the
    /// latest-pose rule.
    pub fn take_observed(&mut self) -> Option<ObservedSpan> {
        self.frontend.take_observed()
    }

    /// Applies a few records and checks what the pyramid makes of them, then forgets them.
    fn self_check(&mut self) -> Result<(), BootError> {
        let record = |layer, cell_x, class| Evidence {
            layer,
            cell_x,
            cell_y: 0,
            class,
            weight: Weight::ONE,
        };
        let layers = u8::try_from(self.pyramid.layer_count()).unwrap_or(u8::MAX);
        let checks = [
            // An obstacle seen by layer 0 in its cell (3, 0).
            (record(0, 3, EvidenceClass::Obstacle), Applied::Updated),
            // Free ground seen by layer 1 around the robot (a one-layer design, a flat grid,
            // has no layer 1).
            (
                record(1, 0, EvidenceClass::Navigable),
                if layers >= 2 {
                    Applied::Updated
                } else {
                    Applied::BadLayer
                },
            ),
            // A layer the design does not have.
            (
                record(layers, 0, EvidenceClass::Obstacle),
                Applied::BadLayer,
            ),
        ];
        for (record, expected) in &checks {
            if self.pyramid.apply(record) != *expected {
                return Err(BootError::SelfCheck("a record was applied unexpectedly"));
            }
        }
        let r0 = self
            .pyramid
            .layer(0)
            .map_or(Meters::ZERO, |l| l.resolution().meters());
        let r1 = self
            .pyramid
            .layer(1)
            .map_or(r0, |l| l.resolution().meters());
        // The centre of layer 0's cell (3, 0), and a point of layer 1's cell (0, 0) outside
        // layer 0's cells that were touched.
        let at = |p: &Pyramid<W, L>, x: Meters, y: Meters| p.fused(x, y);
        let obstacle = at(
            &self.pyramid,
            r0.saturating_mul_int(3).saturating_add(r0 / 2),
            r0 / 2,
        );
        if obstacle != (Fused::Obstacle { layer: 0 }) {
            return Err(BootError::SelfCheck("layer 0 lost the obstacle"));
        }
        if layers >= 2 && at(&self.pyramid, r1 / 2, r1 / 2) != (Fused::Navigable { layer: 1 }) {
            return Err(BootError::SelfCheck("layer 1 lost the free ground"));
        }
        if at(
            &self.pyramid,
            r1.saturating_mul_int(-3),
            r1.saturating_mul_int(-3),
        ) != Fused::Unknown
        {
            return Err(BootError::SelfCheck("an unobserved place is known"));
        }
        self.pyramid.clear();
        Ok(())
    }

    // ------------------------------------------------------------ laser

    /// Takes bytes from the laser's UART that arrived by `now_us` (the board's clock, µs,
    /// wrapping: when the chunk's last byte arrived, as near as the board knows). Every SICK
    /// telegram they complete is parsed and its line fed to the pipeline at the actuator
    /// angle of that moment; every lidar packet they complete is timed back from `now_us`
    /// and fed with the actuator's angles at its first and last return (see the
    /// [module documentation](self) for where the angles come from). Bytes of an incomplete
    /// telegram or packet are kept for the next call. Nothing is taken while a Shutdown waits
    /// for its answer.
    pub fn laser(&mut self, bytes: &[u8], now_us: u32, angle: &mut impl AngleSource) {
        self.laser_timed(bytes, now_us, now_us, angle);
    }

    /// [`laser`](Self::laser) for a board that knows when the chunk's last byte arrived
    /// (`arrival_us`, from its receive interrupt) apart from the time of the call (`now_us`,
    /// when the angle source is read): packets are timed back from `arrival_us`, the source's
    /// reading is kept with `now_us`. Both on the board's µs clock.
    pub fn laser_timed(
        &mut self,
        bytes: &[u8],
        arrival_us: u32,
        now_us: u32,
        angle: &mut impl AngleSource,
    ) {
        if self.shutdown != Shutdown::Running {
            return;
        }
        self.clock_us = now_us;
        self.clock_known = true;
        if self.servo.is_on() {
            self.servo.track(now_us);
        }
        // The board's source, read at most once per call (at `now_us`).
        let mut reading = Reading::NotYet;
        let mut chunk = bytes;
        loop {
            let result = self.laser.feed(chunk);
            chunk = result.remaining();
            let item = match result {
                FeedResult::Consumed => return,
                FeedResult::Item { item, .. } => item,
                // Refused candidates are counted by the decoder.
                FeedResult::Rejected { .. } => continue,
            };
            match item {
                LaserItem::Telegram(telegram) => match MeasuredValues::parse(&telegram) {
                    Ok(values) => {
                        let servo = self.servo.is_on().then_some(&self.servo);
                        match line_angle(
                            angle,
                            self.host_angle,
                            servo,
                            arrival_us,
                            &mut self.counters,
                        ) {
                            Some(a) => {
                                self.frontend.set_actuator(a);
                                // A refused line is counted by the pipeline.
                                let _ = if self.poses.is_empty() {
                                    self.frontend.line(&mut self.pyramid, &values)
                                } else {
                                    // The telegram's last byte arrived before the bytes
                                    // still in the chunk; its last beam was measured one
                                    // transmission time before that (docs/lidars.md).
                                    let end = arrival_us
                                        .wrapping_sub(self.timer.bytes_us(chunk.len()))
                                        .wrapping_sub(
                                            self.timer.bytes_us(telegram.as_bytes().len()),
                                        );
                                    self.frontend.line_timed(
                                        &mut self.pyramid,
                                        &values,
                                        end,
                                        &self.poses,
                                    )
                                };
                            }
                            None => bump(&mut self.counters.lines_without_angle),
                        }
                    }
                    Err(_) => bump(&mut self.counters.telegrams_unparsed),
                },
                LaserItem::Packet(packet) => {
                    // The packet's last byte arrived before the bytes still in the chunk.
                    let end = arrival_us.wrapping_sub(self.timer.bytes_us(chunk.len()));
                    let starts = self.revolutions.starts(&packet);
                    let (first, last) = self.timer.times(&packet, end, starts);
                    if reading == Reading::NotYet {
                        reading = match angle.read_angle() {
                            Ok(a) => {
                                self.track.push(now_us, FineAngle::from(a));
                                Reading::Read
                            }
                            Err(_) => {
                                bump(&mut self.counters.angle_source_errors);
                                Reading::Failed
                            }
                        };
                    }
                    // A packet of one return (an RPLIDAR node) has one time: one lookup.
                    let actuator = match reading {
                        Reading::Read if last == first => self.track.at(first).map(|a| (a, a)),
                        Reading::Read => self.track.at(first).zip(self.track.at(last)),
                        _ if self.servo.is_on() => {
                            self.servo.estimate(first).zip(self.servo.estimate(last))
                        }
                        _ => self.host_angle.map(|a| {
                            let a = FineAngle::from(a);
                            (a, a)
                        }),
                    };
                    match actuator {
                        Some((first_angle, last_angle)) => {
                            let actuator = PacketActuator {
                                first: first_angle,
                                last: last_angle,
                            };
                            // A refused packet is counted by the pipeline.
                            let _ = if self.poses.is_empty() {
                                self.frontend.packet(
                                    &mut self.pyramid,
                                    packet.returns(),
                                    starts,
                                    actuator,
                                )
                            } else {
                                self.frontend.packet_timed(
                                    &mut self.pyramid,
                                    packet.returns(),
                                    starts,
                                    actuator,
                                    PacketTimes {
                                        first_us: first,
                                        last_us: last,
                                    },
                                    &self.poses,
                                )
                            };
                        }
                        None => bump(&mut self.counters.lines_without_angle),
                    }
                }
                // ACKs, descriptors, responses: nothing to place.
                LaserItem::Other => {}
            }
        }
    }

    /// The angle to command a nodding servo at `now_us` (the board's clock, µs), when the
    /// setup has one: the board writes it to the servo's PWM (`drivers::servo`) every step of
    /// its main loop. The first call begins the sweep (a settling hold at its lower end);
    /// `None` without a servo.
    pub fn actuator_command(&mut self, now_us: u32) -> Option<FineAngle> {
        if self.servo.is_on() {
            self.clock_us = now_us;
            self.clock_known = true;
        }
        self.servo.is_on().then(|| self.servo.command(now_us))
    }

    /// The laser the setup in force names and its UART's baud rate.
    #[must_use]
    pub fn laser_port(&self) -> LaserPort {
        LaserPort {
            sensor: self.laser.sensor(),
            baud: self.frontend.config().baud,
        }
    }

    /// The laser UART's baud rate in force, bits per second.
    #[must_use]
    pub fn laser_baud(&self) -> u32 {
        self.frontend.config().baud
    }

    /// The laser the board must set its UART up for, once after boot and after each Setup
    /// that changed the sensor or the baud rate (then `None` until the next change): the board
    /// sets the rate (an emulated UART ignores it) and starts the sensor's stream.
    pub fn take_laser_change(&mut self) -> Option<LaserPort> {
        core::mem::take(&mut self.laser_change).then(|| self.laser_port())
    }

    /// Counts an overrun of the laser's UART (bytes lost before they reached [`laser`]).
    ///
    /// [`laser`]: Self::laser
    pub fn laser_overrun(&mut self) {
        bump(&mut self.counters.laser_overruns);
    }

    // ------------------------------------------------------------ host

    /// Takes bytes from the host: every command they complete is validated by the link and
    /// carried out here, in order. After a Shutdown the rest is dropped (and counted) until
    /// the board answers it.
    pub fn host(&mut self, bytes: &[u8]) {
        let mut chunk = bytes;
        while !chunk.is_empty() {
            if self.shutdown != Shutdown::Running {
                let n = u32::try_from(chunk.len()).unwrap_or(u32::MAX);
                self.counters.bytes_after_shutdown =
                    self.counters.bytes_after_shutdown.saturating_add(n);
                return;
            }
            chunk = match self.link.receive(chunk) {
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

    /// Carries out one validated command and answers it.
    fn execute(&mut self, request: Request<L>) {
        bump(&mut self.counters.commands);
        let Some(Request { header, command }) = self.link.serve(&mut self.pyramid, request) else {
            return;
        };
        match command {
            Command::Pose(pose) => self.set_pose(pose),
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
            Command::Snapshot(_) | Command::Ping | Command::RequestStats => {}
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

    // ------------------------------------------------------------ output

    /// Queues what is due on the host link (Hello, WindowMoved, Stats, changed tiles within
    /// the budget); `now_ms` is the board's clock in milliseconds (wrapping).
    pub fn poll(&mut self, now_ms: u32) -> PollReport {
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

    // ------------------------------------------------------------ state

    /// The counters of every module.
    #[must_use]
    pub fn counters(&self) -> Counters {
        Counters {
            app: self.counters,
            laser: self.laser.counters(),
            frontend: self.frontend.stats(),
            classifier: self.frontend.classifier_stats(),
            pyramid: self.pyramid.stats(),
            link: self.link.counters(),
        }
    }

    /// The counters Stats carries from the laser side.
    fn sensor_counters(&self) -> SensorCounters {
        let laser = self.laser.counts();
        let frontend = self.frontend.stats();
        let classifier = self.frontend.classifier_stats();
        SensorCounters {
            telegrams_ok: laser.ok,
            telegrams_bad_checksum: laser.bad_checksum,
            telegrams_bad_framing: laser.bad_framing,
            telegrams_bad_other: self
                .counters
                .telegrams_unparsed
                .saturating_add(frontend.lines_rejected)
                .saturating_add(self.counters.lines_without_angle),
            points: classifier.points,
            classifier_overflows: classifier.overflow_points,
            // Stats carries the low 32 bits (it wraps).
            laser_bytes: u32::try_from(self.laser.bytes() & u64::from(u32::MAX))
                .unwrap_or(u32::MAX),
            observations: frontend.observations,
        }
    }

    /// The pyramid.
    #[must_use]
    pub const fn pyramid(&self) -> &Pyramid<W, L> {
        &self.pyramid
    }

    /// The per-line pipeline.
    #[must_use]
    pub const fn frontend(&self) -> &Frontend<C, L> {
        &self.frontend
    }

    /// The host link.
    #[must_use]
    pub const fn link(&self) -> &Link<Q, L> {
        &self.link
    }

    /// The host's last PanAngle, if any.
    #[must_use]
    pub const fn host_angle(&self) -> Option<Angle> {
        self.host_angle
    }
}

/// Whether the board's angle source was read in this call of [`CoProcessor::laser`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reading {
    NotYet,
    Read,
    Failed,
}

/// The actuator angle of a SICK line: the source's, else the servo model's at `now_us` when
/// the setup has a servo, else the host's (the source's failure counted).
fn line_angle(
    source: &mut impl AngleSource,
    host: Option<Angle>,
    servo: Option<&ServoSweep>,
    now_us: u32,
    counters: &mut AppCounters,
) -> Option<FineAngle> {
    match source.read_angle() {
        Ok(angle) => Some(FineAngle::from(angle)),
        Err(_) => {
            bump(&mut counters.angle_source_errors);
            match servo {
                Some(servo) => servo.estimate(now_us),
                None => host.map(FineAngle::from),
            }
        }
    }
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}
