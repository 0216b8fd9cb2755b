//! The application core: the whole co-processor as one `no_std` type, [`CoProcessor`], with
//! an I/O-free surface in the manner of smoltcp's `Interface::poll`. It owns the laser's
//! accumulator, the per-line pipeline (with the classifier and its gating), the pyramid, the
//! device side of the host link and the counters; a board (or a host harness) hands it what
//! it has and drains what it produces:
//!
//! ```text
//! laser UART bytes ──▶ laser(bytes, now_us, angle source) ──▶ telegrams / packets ─▶ pipeline ─▶ pyramid
//! host UART bytes  ──▶ host_at(bytes, now_us) ──▶ validated commands, carried out here
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
//! - **The robot's pose** is the latest Pose (unstamped, or [`CoProcessor::set_pose`]) for
//!   every return, until stamped poses come in ([`CoProcessor::stamped_pose`]): then each
//!   return is placed with the pose of its own measurement time, from a track of the last `N`
//!   stamped poses ([`crate::geometry::pose_track`]; lidar returns timed as above, a SICK
//!   line's beams from its mirror's turns); a return without a pose is refused and counted.
//!   An unstamped pose or a Setup clears the track. When an observation placed timed returns,
//!   [`CoProcessor::take_observed`] hands out its span of times once.
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
//!
//! [`AngleSource`]: crate::drivers::angle::AngleSource

mod host;
mod laser;
#[cfg(test)]
mod lidar_tests;
#[cfg(test)]
mod rule_tests;
#[cfg(test)]
mod tests;

pub use laser::{LaserPort, NoAngleSource, NoSource};

use core::fmt;

use crate::actuator::{Actuator, AngleTrack, ServoSweep};
use crate::angle::Angle;
use crate::classify::ClassifierStats;
use crate::design::{Design, DesignError};
use crate::geometry::{Pose, PoseRefusal, PoseTrack, Taken};
use crate::laser::{LaserCounters, LaserDecoder, PacketTimer, RevolutionTracker, Sensor};
use crate::link::{FilterCounters, Link, LinkConfig, LinkCounters, PoseCounters, SensorCounters};
use crate::pipeline::{Frontend, FrontendConfig, FrontendStats, ObservedSpan};
use crate::pyramid::{Applied, Config, Evidence, EvidenceClass, Fused, Pyramid, PyramidStats};
use crate::units::{Meters, Weight};
use crate::wire::link::Header;

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
    /// Stamped poses refused: not later than the newest, more than 1 s ahead of the device's
    /// clock ([`crate::geometry::MAX_POSE_LEAD_US`]) or more than 1 s behind it
    /// ([`crate::geometry::MAX_POSE_AGE_US`]).
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
/// bytes a pose): 16 (320 ms at 50 Hz) unless the board chooses; with 0 a stamped pose is
/// taken as the latest pose.
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
    /// The board's µs clock of the latest host bytes ([`CoProcessor::host_at`]).
    host_clock_us: u32,
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
            host_clock_us: 0,
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
        // Only the old baud rate is compared: a copy of the whole old setup would cost the
        // micro:bit's deepest stack path its size again.
        let old_baud = self.frontend.config().baud;
        let sensor_changed = self.laser.set_sensor(setup.sensor);
        if sensor_changed || !self.frontend.is_configured() || old_baud != setup.baud {
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
        if N == 0 {
            // No track: the latest-pose rule, with the pose counted as taken.
            bump(&mut self.counters.poses_stamped);
            self.frontend.set_pose(pose);
            return;
        }
        match self.poses.push(stamp_us, pose, now) {
            Ok(taken) => {
                bump(&mut self.counters.poses_stamped);
                if taken == Taken::Restarted {
                    bump(&mut self.counters.pose_gaps);
                }
                // The newest pose may replace an extrapolation: evaluate afresh.
                self.frontend.forget_timed_pose();
            }
            Err(PoseRefusal::NotNewer | PoseRefusal::TooFarAhead | PoseRefusal::TooOld) => {
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
    /// latest-pose rule. [`poll`](Self::poll) takes it and queues the Observed frame, so a
    /// board that polls never needs this.
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
            pose: self.pose_counters(),
            filtered: FilterCounters {
                returns_masked: frontend.returns_masked,
                returns_too_near: frontend.returns_too_near,
                returns_too_far: frontend.returns_too_far,
                returns_low_quality: frontend.returns_low_quality,
            },
            observations_split: frontend.observations_split,
            returns_implausible: laser.implausible,
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

    /// The pose track's counters that Stats carries (Stats i = 30 ..= 34).
    fn pose_counters(&self) -> PoseCounters {
        let frontend = self.frontend.stats();
        PoseCounters {
            poses_stamped: self.counters.poses_stamped,
            poses_refused: self.counters.poses_refused,
            pose_gaps: self.counters.pose_gaps,
            returns_extrapolated: frontend.returns_extrapolated,
            returns_without_pose: frontend.returns_without_pose,
        }
    }
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}
