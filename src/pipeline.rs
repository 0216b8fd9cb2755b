//! The per-line pipeline: a validated measured-values telegram, the actuator angle and the
//! robot pose in; points, evidence and pyramid updates out.
//!
//! ```text
//! MeasuredValues --> ranges (mm) --> [geometry] world points + horizontal distance
//!                                 --> [classify] per-layer cells of this observation
//!                   end of observation --> recentre on the pose --> [pyramid] gated updates
//! ```
//!
//! The core is handed data and never fetches it (smoltcp's `Interface::poll`): the board's
//! main loop calls [`Frontend::set_actuator`] when the encoder (or the host) reports an angle,
//! [`Frontend::set_pose`] when the host sends a pose, and [`Frontend::line`] for each telegram.
//!
//! A line applies whole or not at all: its value count is checked against the scanner
//! variant before any of its points reaches the classifier.
//!
//! # Spinning lidars
//! A spinning lidar's line is a packet ([`Frontend::packet`]): its returns, each at its own
//! angle in the sensor's clockwise convention (turned into the geometry's beam angle by
//! [`crate::geometry::beam_angle_of_clockwise`], which also states how the lidar is mounted),
//! and the actuator's angle at the packet's first and at its last return. Return k of n gets
//! the angle interpolated linearly between the two (`first + k·(last − first)/(n − 1)`: the
//! returns are measured evenly in time), and is placed by [`SweepTransform`] from its own
//! beam angle and its own actuator angle, in fixed point. A range of 0 is no return.
//!
//! # Observations
//! An observation ends after a fixed number of lines, or, with `lines_per_observation = 0`,
//! when the actuator turns back (the end of a sweep). For a spinning lidar a "line" is a
//! **revolution**: with `lines_per_observation = n`, an observation ends where the (n+1)-th
//! revolution since its start begins (the packet that starts it opens the next observation;
//! the first observation also holds the partial revolution before the first start); with 0,
//! at the end of each sweep of the nodding actuator, as for a SICK (the turn is seen at the
//! packet whose last actuator angle moves the other way). At its end the pyramid is recentred
//! on the robot and the observation's evidence is applied.

use crate::actuator::Actuator;
use crate::angle::FineAngle;
use crate::classify::{Classifier, ClassifierConfig, ClassifierStats};
use crate::design::{Design, DesignError};
use crate::geometry::{
    beam_angle_of_clockwise, ActuatedPlane, BeamTable, LinePoint, LineTransform, Mount, NoPose,
    Placement, Pose, PoseFrame, PoseTrack, SweepTransform, POSE_QUANTUM_US,
};
use crate::laser::{Sensor, SensorKind, SickBeamTimes};
use crate::pyramid::{Config, Pyramid};
use crate::units::Meters;
use crate::units::Point3;
use crate::wire::sick::Variant;
use crate::wire::sick::{MeasuredValues, MeasuringMode};
use crate::wire::LaserReturn;
use core::fmt;

/// How the laser is set up and how its lines are grouped into observations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrontendConfig {
    /// How the laser is mounted on its actuator, and where.
    pub mount: Mount,
    /// The laser: a SICK LMS2xx (read through `variant` and `measuring_mode`) or a spinning
    /// lidar (whose packets carry their own angles; `variant` and `measuring_mode` unused).
    pub sensor: Sensor,
    /// The laser UART's baud rate, bits per second (the board sets its UART to it).
    pub baud: u32,
    /// What moves the scan plane: an external actuator whose angle the board or the host
    /// reports, or a nodding servo the co-processor commands.
    pub actuator: Actuator,
    /// The scanner's field and angular resolution (SICK).
    pub variant: Variant,
    /// The measuring mode the scanner is in (its distance mask and no-echo value; SICK).
    pub measuring_mode: MeasuringMode,
    /// Lines per observation, ≥ 1; 0 = one observation per sweep of the actuator.
    pub lines_per_observation: u32,
    /// The navigability rule's thresholds and options.
    pub classifier: ClassifierConfig,
    /// Missing ground: a beam that returns nothing although it points down at flat ground
    /// (the robot's ground plane) closer than this range marks the cell where the ground
    /// should have been as not navigable (a hole, a drop-off). `None` (the default) treats a
    /// missing return as no information: dark or wet ground also returns nothing.
    pub missing_ground_within: Option<Meters>,
}

impl FrontendConfig {
    /// The setup a co-processor boots with until the host sends its own: a SICK LMS 291 at
    /// 180°/0.5° in the 8 m mode, its scan centre 0.5 m above the ground at the robot's
    /// origin, on a mount of the given kind, one observation per sweep, the default
    /// classifier, missing ground off.
    #[must_use]
    pub fn lms291_boot(plane: crate::geometry::ScanPlane) -> Self {
        Self {
            mount: Mount::new(
                plane,
                crate::units::Point3 {
                    x: Meters::ZERO,
                    y: Meters::ZERO,
                    z: Meters::from_bits(1 << 15),
                },
            ),
            sensor: Sensor::Sick,
            baud: SensorKind::Sick.default_baud(),
            actuator: Actuator::External,
            variant: Variant::Fov180StepHalf,
            measuring_mode: MeasuringMode::Mm8Cm80,
            lines_per_observation: 0,
            classifier: ClassifierConfig::default(),
            missing_ground_within: None,
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for FrontendConfig {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "FrontendConfig {{ mount: {}, sensor: {} at {=u32} Bd, actuator: {}, variant: {}, mode: {}, lines/observation: {=u32}, classifier: {}, missing ground within: {=i32} raw Q16.16 (0 = off) }}",
            self.mount,
            self.sensor,
            self.baud,
            self.actuator,
            self.variant,
            self.measuring_mode,
            self.lines_per_observation,
            self.classifier,
            self.missing_ground_within.map_or(0, |m| m.to_bits())
        );
    }
}

/// Counters of the pipeline. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrontendStats {
    /// Lines whose points all went to the classifier.
    pub lines_applied: u32,
    /// Lines (or lidar packets) refused whole (a value count that does not fit the variant,
    /// no setup, a packet of another sensor).
    pub lines_rejected: u32,
    /// Lidar packets whose returns all went to the classifier.
    pub packets_applied: u32,
    /// Lidar revolutions started (packets that start one).
    pub revolutions: u32,
    /// Returns with a distance.
    pub returns: u32,
    /// Values that carried "no echo".
    pub no_return: u32,
    /// Returns whose geometry could not be computed (out of the transform's range).
    pub returns_dropped: u32,
    /// No-return beams taken as missing ground.
    pub missing_ground: u32,
    /// Observations finished and applied.
    pub observations: u32,
    /// Returns placed with a pose extrapolated (or held) past the newest stamped pose
    /// ([`Placement::Extrapolated`], [`Placement::Held`]; timed placement only).
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose: later than the newest stamped pose by more than
    /// the extrapolation bound, or earlier than the oldest kept (timed placement only). They
    /// are counted in `returns` too, and placed nowhere.
    pub returns_without_pose: u32,
}

/// Why a line was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum LineError {
    /// The telegram's value count fits neither a full scan nor an interlaced partial scan of
    /// the configured variant.
    CountMismatch {
        /// Values in the telegram.
        count: u16,
        /// Beams of a full scan of the variant.
        expected: u16,
    },
    /// The partial-scan index does not fit the variant's interlacing.
    BadPartialIndex {
        /// The index in the telegram.
        partial_index: u8,
    },
    /// The pipeline has no setup yet ([`Frontend::unconfigured`]) or no design to feed
    /// ([`Frontend::adopt_design`]).
    NotConfigured,
    /// A SICK line while a spinning lidar is set up, or a lidar packet while a SICK is.
    WrongSensor {
        /// The sensor set up.
        configured: SensorKind,
    },
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::CountMismatch { count, expected } => write!(
                f,
                "a line of {count} values does not fit the scanner variant ({expected} beams)"
            ),
            Self::BadPartialIndex { partial_index } => {
                write!(
                    f,
                    "partial-scan index {partial_index} does not fit the variant"
                )
            }
            Self::NotConfigured => {
                f.write_str("the pipeline has no setup or no design to feed yet")
            }
            Self::WrongSensor { configured } => {
                write!(
                    f,
                    "the pipeline is set up for another sensor ({configured})"
                )
            }
        }
    }
}

/// How a telegram's values map onto the beam table.
#[derive(Clone, Copy)]
enum Layout {
    /// Value j is beam j.
    Full,
    /// An interlaced partial scan with this index.
    Partial(u8),
}

/// The actuator's angle at a lidar packet's first and last return ([`Frontend::packet`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PacketActuator {
    /// At the first return.
    pub first: FineAngle,
    /// At the last return.
    pub last: FineAngle,
}

impl PacketActuator {
    /// The same angle for every return (an actuator that stands still, or the host's angle).
    #[must_use]
    pub const fn still(angle: FineAngle) -> Self {
        Self {
            first: angle,
            last: angle,
        }
    }
}

/// When a lidar packet's first and last returns were measured, µs on the device's clock
/// (wrapping): return k of n is at `first_us + k·(last_us − first_us)/(n − 1)`
/// ([`Frontend::packet_timed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PacketTimes {
    /// The first return's time, µs.
    pub first_us: u32,
    /// The last return's time, µs.
    pub last_us: u32,
}

/// The times of the returns an observation placed, for the host to stamp the maps it
/// publishes ([`Frontend::take_observed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObservedSpan {
    /// The observation count (the counters' `observations`) after this one.
    pub observation: u32,
    /// The measurement time of the earliest return it placed, µs (device clock, wrapping).
    pub first_us: u32,
    /// The measurement time of the latest return it placed, µs.
    pub last_us: u32,
}

/// Timed placement's state: the pose in force and when it was evaluated, and the span of
/// the observation's placed returns. Zero bits: nothing in force, no span.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct TimedPose {
    /// The time the pose in force was evaluated at, µs (meaningful when `in_force`).
    at_us: u32,
    /// Whether a timed pose is in force.
    in_force: bool,
    /// Whether it was extrapolated (or held) past the newest stamped pose.
    extrapolated: bool,
    /// The earliest and latest times of the observation's placed returns (when `spanned`).
    first_us: u32,
    last_us: u32,
    spanned: bool,
}

impl TimedPose {
    const NONE: Self = Self {
        at_us: 0,
        in_force: false,
        extrapolated: false,
        first_us: 0,
        last_us: 0,
        spanned: false,
    };

    /// Notes a return placed at `t_us` in the observation's span.
    fn placed(&mut self, t_us: u32) {
        if !self.spanned {
            (self.first_us, self.last_us, self.spanned) = (t_us, t_us, true);
        } else if later_by(self.first_us, t_us) > 0 {
            self.first_us = t_us;
        } else if later_by(t_us, self.last_us) > 0 {
            self.last_us = t_us;
        }
    }
}

/// How much later `b` is than `a`, µs: the wrapping difference as an `i32`.
#[allow(clippy::cast_possible_wrap)]
const fn later_by(b: u32, a: u32) -> i32 {
    b.wrapping_sub(a) as i32
}

/// Where the poses of a line's returns come from: none (the pose in force for every
/// return: [`Untimed`]), or a track of stamped poses, evaluated at each return's time.
/// Monomorphised, so the untimed path carries nothing of the timed one.
trait Poses {
    /// Whether returns take the pose of their own times.
    const TIMED: bool;
    /// The pose at `t_us`.
    fn pose_at(&self, t_us: u32) -> Result<(Pose, Placement), NoPose>;
}

/// Every return takes the pose in force ([`Frontend::set_pose`]'s).
struct Untimed;

impl Poses for Untimed {
    const TIMED: bool = false;
    #[inline(always)]
    fn pose_at(&self, _: u32) -> Result<(Pose, Placement), NoPose> {
        Err(NoPose::Empty)
    }
}

impl<const N: usize> Poses for PoseTrack<N> {
    const TIMED: bool = true;
    fn pose_at(&self, t_us: u32) -> Result<(Pose, Placement), NoPose> {
        self.at(t_us)
    }
}

/// The per-line pipeline, with `C` classifier slots, for designs of up to `L` layers.
pub struct Frontend<const C: usize, const L: usize> {
    config: FrontendConfig,
    beams: BeamTable,
    /// The pose's and the mount's part of a lidar return's geometry.
    sweep: SweepTransform,
    classifier: Classifier<C, L>,
    pose: Pose,
    frame: PoseFrame,
    actuator: FineAngle,
    /// The actuator angle of the previous line, and the sign of its last move (−1, 0, +1).
    last_actuator: Option<FineAngle>,
    direction: i8,
    lines_in_observation: u32,
    /// Lidar revolutions started in the current observation.
    revolutions_in_observation: u32,
    stats: FrontendStats,
    /// Whether a configuration has been adopted (lines are refused until then).
    configured: bool,
    /// The pose in force of timed placement, and the observation's span of times.
    timed: TimedPose,
    /// The span of the last observation applied with timed returns, until taken.
    observed: ObservedSpan,
    /// Whether `observed` waits to be taken ([`Frontend::take_observed`]).
    observed_pending: bool,
}

impl<const C: usize, const L: usize> fmt::Debug for Frontend<C, L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Frontend")
            .field("config", &self.config)
            .field("lines_in_observation", &self.lines_in_observation)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<const C: usize, const L: usize> Frontend<C, L> {
    /// A pipeline for `config`, at the world origin with the actuator at zero.
    ///
    /// It returns the pipeline by value (about 24 KiB with 1024 classifier slots): firmware
    /// keeps it in a `static` built from [`Frontend::unconfigured`] and configures it in place
    /// instead, so that it never sits on the stack.
    #[must_use]
    pub fn new(config: FrontendConfig) -> Self {
        let mut frontend = Self::unconfigured();
        frontend.configure(config);
        frontend
    }

    /// A pipeline that refuses every line until [`configure`](Self::configure)d. `const` and
    /// all zero bits, so a `static` one sits in `.bss`: no flash, and never built on the stack.
    #[must_use]
    pub const fn unconfigured() -> Self {
        Self {
            config: FrontendConfig {
                mount: Mount::new(
                    crate::geometry::ScanPlane::PannedVertical,
                    crate::units::Point3 {
                        x: Meters::ZERO,
                        y: Meters::ZERO,
                        z: Meters::ZERO,
                    },
                ),
                sensor: Sensor::Sick,
                baud: 0,
                actuator: Actuator::External,
                variant: Variant::Fov180Step1,
                measuring_mode: MeasuringMode::Mm8Cm80,
                lines_per_observation: 0,
                classifier: ClassifierConfig {
                    robot_height: Meters::ZERO,
                    step_threshold: Meters::ZERO,
                    drop_threshold: None,
                    ceiling: None,
                    rule: crate::classify::NavigabilityRule::Spread,
                },
                missing_ground_within: None,
            },
            beams: BeamTable::EMPTY,
            sweep: SweepTransform::ZERO,
            classifier: Classifier::unconfigured(),
            pose: Pose::IDENTITY,
            frame: PoseFrame::ZERO,
            actuator: FineAngle::from_bits(0),
            last_actuator: None,
            direction: 0,
            lines_in_observation: 0,
            revolutions_in_observation: 0,
            stats: FrontendStats {
                lines_applied: 0,
                lines_rejected: 0,
                packets_applied: 0,
                revolutions: 0,
                returns: 0,
                no_return: 0,
                returns_dropped: 0,
                missing_ground: 0,
                observations: 0,
                returns_extrapolated: 0,
                returns_without_pose: 0,
            },
            timed: TimedPose::NONE,
            observed: ObservedSpan {
                observation: 0,
                first_us: 0,
                last_us: 0,
            },
            observed_pending: false,
            configured: false,
        }
    }

    /// Adopts a new configuration; the current observation is discarded.
    pub fn configure(&mut self, config: FrontendConfig) {
        self.config = config;
        // In place: a second beam table on the stack would not fit a 16 KiB part.
        self.beams.rebuild(config.variant);
        self.classifier.configure(config.classifier);
        self.frame = self.pose.frame();
        self.sweep = SweepTransform::new(&config.mount, &self.frame);
        self.configured = true;
        self.restart_observation();
    }

    /// Discards the observation under way and forgets the sweep's direction: the next line
    /// starts a new observation (after the maps were cleared, say).
    pub fn restart_observation(&mut self) {
        self.classifier.discard();
        self.timed.spanned = false;
        self.lines_in_observation = 0;
        self.revolutions_in_observation = 0;
        self.last_actuator = None;
        self.direction = 0;
    }

    /// Whether a setup has been adopted ([`configure`](Self::configure)).
    #[must_use]
    pub const fn is_configured(&self) -> bool {
        self.configured
    }

    /// The configuration in force.
    #[must_use]
    pub const fn config(&self) -> &FrontendConfig {
        &self.config
    }

    /// Adopts the gating of the pyramid's design and configuration (the classifier's
    /// [`Classifier::adopt_design`]); the current observation is discarded. On error nothing
    /// changes.
    ///
    /// # Errors
    /// The configuration's increments are invalid, or a layer's resolution cannot be
    /// represented.
    pub fn adopt_design(&mut self, design: &Design<L>, config: &Config) -> Result<(), DesignError> {
        let increments = config.model.increments()?;
        self.classifier.adopt_design(design, increments)?;
        self.lines_in_observation = 0;
        Ok(())
    }

    /// The gating in force.
    #[must_use]
    pub const fn gates(&self) -> &crate::gate::Gates<L> {
        self.classifier.gates()
    }

    /// The robot's pose from now on (validated by [`Pose::from_f32`] where it came in).
    pub fn set_pose(&mut self, pose: Pose) {
        self.pose = pose;
        self.frame = pose.frame();
        self.sweep = SweepTransform::new(&self.config.mount, &self.frame);
        self.timed.in_force = false;
    }

    /// Forgets the time the pose in force was evaluated at, so that the next timed return
    /// evaluates its own (call it when the track of stamped poses changed: a new pose may
    /// replace an extrapolation).
    pub fn forget_timed_pose(&mut self) {
        self.timed.in_force = false;
    }

    /// The span of times of the last observation applied whose returns had times
    /// ([`packet_timed`](Self::packet_timed), [`line_timed`](Self::line_timed)), once; `None`
    /// when there is none new.
    pub fn take_observed(&mut self) -> Option<ObservedSpan> {
        core::mem::take(&mut self.observed_pending).then_some(self.observed)
    }

    /// The pose for a return measured at `t_us`, by the placement rule: the pose in force
    /// when it was evaluated less than [`POSE_QUANTUM_US`] from `t_us` (`Ok(false)`), else the
    /// track's at `t_us`, now in force (`Ok(true)`: the caller rebuilds its transform).
    fn timed_pose<P: Poses>(
        timed: &mut TimedPose,
        pose: &mut Pose,
        frame: &mut PoseFrame,
        poses: &P,
        t_us: u32,
    ) -> Result<bool, NoPose> {
        if timed.in_force && later_by(t_us, timed.at_us).unsigned_abs() < POSE_QUANTUM_US {
            return Ok(false);
        }
        let (p, how) = poses.pose_at(t_us)?;
        timed.at_us = t_us;
        timed.in_force = true;
        timed.extrapolated = how != Placement::Interpolated;
        // A robot standing still keeps its frame: nothing to rebuild.
        if p == *pose {
            return Ok(false);
        }
        *pose = p;
        *frame = p.frame();
        Ok(true)
    }

    /// The robot's pose in force.
    #[must_use]
    pub const fn pose(&self) -> &Pose {
        &self.pose
    }

    /// The actuator (pan or tilt) angle for the lines that follow.
    pub fn set_actuator(&mut self, angle: FineAngle) {
        self.actuator = angle;
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> FrontendStats {
        self.stats
    }

    /// The classifier's counters.
    #[must_use]
    pub const fn classifier_stats(&self) -> ClassifierStats {
        self.classifier.stats()
    }

    /// Lines (SICK telegrams, or lidar packets) gathered in the current observation.
    #[must_use]
    pub const fn lines_in_observation(&self) -> u32 {
        self.lines_in_observation
    }

    fn layout(&self, values: &MeasuredValues<'_>) -> Result<Layout, LineError> {
        let variant = self.config.variant;
        let count = usize::from(values.count());
        let p = values.partial_index();
        let expected = u16::try_from(variant.beam_count()).unwrap_or(u16::MAX);
        if count == variant.beam_count() && p == 0 {
            Ok(Layout::Full)
        } else if count == variant.sweep_count() && count != variant.beam_count() {
            if variant.partial_scan_beam(p, 0).is_some() {
                Ok(Layout::Partial(p))
            } else {
                Err(LineError::BadPartialIndex { partial_index: p })
            }
        } else {
            Err(LineError::CountMismatch {
                count: values.count(),
                expected,
            })
        }
    }

    /// Whether the actuator turned back since the previous line (the end of a sweep).
    fn sweep_turned(&mut self) -> bool {
        let now = self.actuator;
        let Some(last) = self.last_actuator.replace(now) else {
            return false;
        };
        // The signed difference of two fractions of a turn.
        #[allow(clippy::cast_possible_wrap)]
        let delta = now.wrapping_sub(last).to_bits() as i32;
        let direction = delta.signum();
        #[allow(clippy::cast_possible_truncation)]
        let direction = direction as i8;
        if direction == 0 {
            return false;
        }
        let turned = self.direction != 0 && direction != self.direction;
        self.direction = direction;
        turned
    }

    /// Feeds one line. Its points join the current observation; when the observation is
    /// complete its evidence is applied to `pyramid`.
    ///
    /// # Errors
    /// The line does not fit the configured variant; nothing of it was used.
    pub fn line<const W: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        values: &MeasuredValues<'_>,
    ) -> Result<(), LineError> {
        self.line_with(pyramid, values, &Untimed, 0)
    }

    /// [`line`](Self::line) with each beam placed at the pose of its own moment: the beams'
    /// times from the mirror's turns ([`SickBeamTimes`]), the last measured one's at
    /// `last_beam_us` (µs, device clock), and the pose at each from `track` by the rule of
    /// [`crate::geometry::pose_track`] (re-evaluated only [`POSE_QUANTUM_US`] or more from
    /// where it was evaluated). A return with no pose is refused and counted
    /// (`returns_without_pose`).
    ///
    /// # Errors
    /// As [`line`](Self::line).
    pub fn line_timed<const W: usize, const N: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        values: &MeasuredValues<'_>,
        last_beam_us: u32,
        track: &PoseTrack<N>,
    ) -> Result<(), LineError> {
        self.line_with(pyramid, values, track, last_beam_us)
    }

    fn line_with<const W: usize, P: Poses>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        values: &MeasuredValues<'_>,
        poses: &P,
        last_beam_us: u32,
    ) -> Result<(), LineError> {
        if !self.configured || self.classifier.gates().layer_count() == 0 {
            self.stats.lines_rejected = self.stats.lines_rejected.saturating_add(1);
            return Err(LineError::NotConfigured);
        }
        if self.config.sensor.is_lidar() {
            self.stats.lines_rejected = self.stats.lines_rejected.saturating_add(1);
            return Err(LineError::WrongSensor {
                configured: self.config.sensor.kind(),
            });
        }
        let layout = match self.layout(values) {
            Ok(layout) => layout,
            Err(e) => {
                self.stats.lines_rejected = self.stats.lines_rejected.saturating_add(1);
                return Err(e);
            }
        };
        if self.config.lines_per_observation == 0 && self.sweep_turned() {
            self.end_observation(pyramid);
        }
        let variant = self.config.variant;
        // The beams' times (timed placement only), and the pose of the line's first beam in
        // force before the observation takes its sensor height.
        let times = P::TIMED.then(|| {
            let last = usize::from(values.count()).saturating_sub(1);
            match layout {
                Layout::Full => SickBeamTimes::new(variant, None, last),
                Layout::Partial(p) => SickBeamTimes::new(
                    variant,
                    Some(p),
                    variant.partial_scan_beam(p, last).unwrap_or(last),
                ),
            }
        });
        if let Some(times) = &times {
            let first = match layout {
                Layout::Full => Some(0),
                Layout::Partial(p) => variant.partial_scan_beam(p, 0),
            };
            let t = last_beam_us.wrapping_sub(times.before_last_us(first.unwrap_or(0)));
            if let Ok(true) =
                Self::timed_pose(&mut self.timed, &mut self.pose, &mut self.frame, poses, t)
            {
                self.sweep = SweepTransform::new(&self.config.mount, &self.frame);
            }
        }
        let mut transform =
            LineTransform::new(&self.beams, &self.config.mount, self.actuator, &self.frame);
        if self.lines_in_observation == 0 {
            self.classifier.begin(transform.sensor_origin().z);
        }
        let mut ground_z: Meters = self.pose.z;
        // Counted here and added once per line (at most 401 values each: the sums are exact,
        // and so are the saturating totals).
        let (mut no_return, mut returns, mut dropped) = (0_u32, 0_u32, 0_u32);
        let (mut extrapolated, mut without_pose) = (0_u32, 0_u32);
        for (j, range) in values.ranges_mm(self.config.measuring_mode).enumerate() {
            let beam = match layout {
                Layout::Full => Some(j),
                Layout::Partial(p) => variant.partial_scan_beam(p, j),
            };
            // Timed: the pose of this beam's moment (a value past the table has none; it is
            // dropped below).
            let mut t_us = 0;
            if let (Some(times), Some(b)) = (&times, beam) {
                t_us = last_beam_us.wrapping_sub(times.before_last_us(b));
                match Self::timed_pose(
                    &mut self.timed,
                    &mut self.pose,
                    &mut self.frame,
                    poses,
                    t_us,
                ) {
                    Ok(false) => {}
                    Ok(true) => {
                        self.sweep = SweepTransform::new(&self.config.mount, &self.frame);
                        transform = LineTransform::new(
                            &self.beams,
                            &self.config.mount,
                            self.actuator,
                            &self.frame,
                        );
                        ground_z = self.pose.z;
                    }
                    Err(_) => {
                        if range.is_some() {
                            returns += 1;
                            without_pose += 1;
                        } else {
                            no_return += 1;
                        }
                        continue;
                    }
                }
            }
            let Some(range_mm) = range else {
                no_return += 1;
                if let (Some(within), Some(b)) = (self.config.missing_ground_within, beam) {
                    Self::missing_ground(
                        &mut self.classifier,
                        &mut self.stats,
                        &transform,
                        b,
                        ground_z,
                        within,
                    );
                }
                continue;
            };
            returns += 1;
            match beam.and_then(|b| transform.locate_squared(b, range_mm)) {
                Some(located) => {
                    // The distance is needed only for its gate bin: no square root.
                    self.classifier.add_point_squared(
                        located.point,
                        located.horizontal_squared,
                        ground_z,
                    );
                    if P::TIMED {
                        extrapolated += u32::from(self.timed.extrapolated);
                        self.timed.placed(t_us);
                    }
                }
                None => dropped += 1,
            }
        }
        if P::TIMED {
            self.stats.returns_extrapolated =
                self.stats.returns_extrapolated.saturating_add(extrapolated);
            self.stats.returns_without_pose =
                self.stats.returns_without_pose.saturating_add(without_pose);
        }
        self.stats.no_return = self.stats.no_return.saturating_add(no_return);
        self.stats.returns = self.stats.returns.saturating_add(returns);
        self.stats.returns_dropped = self.stats.returns_dropped.saturating_add(dropped);
        self.stats.lines_applied = self.stats.lines_applied.saturating_add(1);
        self.lines_in_observation = self.lines_in_observation.saturating_add(1);
        let per = self.config.lines_per_observation;
        if per != 0 && self.lines_in_observation >= per {
            self.end_observation(pyramid);
        }
        Ok(())
    }

    /// Where a no-return beam should have met the ground plane, if it points down at it
    /// closer than `within`: that cell is marked as missing ground. One division, and only
    /// for beams that returned nothing.
    fn missing_ground(
        classifier: &mut Classifier<C, L>,
        stats: &mut FrontendStats,
        transform: &LineTransform<'_>,
        beam: usize,
        ground_z: Meters,
        within: Meters,
    ) {
        Self::missing_ground_along(
            classifier,
            stats,
            transform.sensor_origin(),
            |range| transform.locate(beam, range),
            ground_z,
            within,
        );
    }

    /// [`Self::missing_ground`] for a beam given by where it is at a range.
    fn missing_ground_along(
        classifier: &mut Classifier<C, L>,
        stats: &mut FrontendStats,
        origin: Point3,
        locate: impl Fn(u32) -> Option<LinePoint>,
        ground_z: Meters,
        within: Meters,
    ) {
        const METRE_MM: u32 = 1000;
        let Some(unit) = locate(METRE_MM) else {
            return;
        };
        // The beam's drop per metre of range; beams within ~1° of the horizon never meet the
        // ground in range and are skipped.
        let drop = origin.z.saturating_sub(unit.point.z);
        let height = origin.z.saturating_sub(ground_z);
        // 0.02 m per metre, as a constant evaluated at compile time.
        const SHALLOWEST_DROP: Meters = Meters::lit("0.02");
        if drop < SHALLOWEST_DROP || height <= Meters::ZERO {
            return;
        }
        let Some(range) = height.checked_div(drop) else {
            return;
        };
        if range > within {
            return;
        }
        let range_mm = range.saturating_mul_int(1000).to_num::<i64>();
        let Ok(range_mm) = u32::try_from(range_mm) else {
            return;
        };
        if let Some(expected) = locate(range_mm) {
            classifier.add_missing_ground(expected.point, expected.horizontal);
            stats.missing_ground = stats.missing_ground.saturating_add(1);
        }
    }

    /// Feeds one packet of a spinning lidar: its returns in the order measured (angles in the
    /// sensor's clockwise convention, range 0 = no return), whether a revolution starts in
    /// it, and the actuator's angle at its first and last return (interpolated per return;
    /// see the [module documentation](self)). Its points join the current observation; an
    /// observation that ends (its revolutions counted, or the sweep turned) is applied to
    /// `pyramid` first.
    ///
    /// # Errors
    /// No setup or design yet, or a SICK is set up; nothing of the packet was used.
    pub fn packet<const W: usize, I>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        returns: I,
        starts_revolution: bool,
        actuator: PacketActuator,
    ) -> Result<(), LineError>
    where
        I: IntoIterator<Item = LaserReturn>,
        I::IntoIter: ExactSizeIterator,
    {
        self.packet_with(
            pyramid,
            returns,
            starts_revolution,
            actuator,
            &Untimed,
            PacketTimes::default(),
        )
    }

    /// [`packet`](Self::packet) with each return placed at the pose of its own moment: return
    /// k of n measured at `first_us + k·(last_us − first_us)/(n − 1)` (as its actuator angle
    /// is interpolated), its pose from `track` by the rule of [`crate::geometry::pose_track`]
    /// (re-evaluated only [`POSE_QUANTUM_US`] or more from where it was evaluated). A return
    /// with no pose is refused and counted (`returns_without_pose`).
    ///
    /// # Errors
    /// As [`packet`](Self::packet).
    pub fn packet_timed<const W: usize, I, const N: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        returns: I,
        starts_revolution: bool,
        actuator: PacketActuator,
        times: PacketTimes,
        track: &PoseTrack<N>,
    ) -> Result<(), LineError>
    where
        I: IntoIterator<Item = LaserReturn>,
        I::IntoIter: ExactSizeIterator,
    {
        self.packet_with(pyramid, returns, starts_revolution, actuator, track, times)
    }

    fn packet_with<const W: usize, I, P: Poses>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        returns: I,
        starts_revolution: bool,
        actuator: PacketActuator,
        poses: &P,
        times: PacketTimes,
    ) -> Result<(), LineError>
    where
        I: IntoIterator<Item = LaserReturn>,
        I::IntoIter: ExactSizeIterator,
    {
        if !self.configured || self.classifier.gates().layer_count() == 0 {
            self.stats.lines_rejected = self.stats.lines_rejected.saturating_add(1);
            return Err(LineError::NotConfigured);
        }
        if !self.config.sensor.is_lidar() {
            self.stats.lines_rejected = self.stats.lines_rejected.saturating_add(1);
            return Err(LineError::WrongSensor {
                configured: self.config.sensor.kind(),
            });
        }
        self.actuator = actuator.last;
        let per = self.config.lines_per_observation;
        if per == 0 && self.sweep_turned() {
            self.end_observation(pyramid);
        }
        if starts_revolution {
            self.stats.revolutions = self.stats.revolutions.saturating_add(1);
            if per != 0 && self.revolutions_in_observation >= per {
                self.end_observation(pyramid);
            }
            self.revolutions_in_observation = self.revolutions_in_observation.saturating_add(1);
        }
        if P::TIMED {
            if let Ok(true) = Self::timed_pose(
                &mut self.timed,
                &mut self.pose,
                &mut self.frame,
                poses,
                times.first_us,
            ) {
                self.sweep = SweepTransform::new(&self.config.mount, &self.frame);
            }
        }
        if self.lines_in_observation == 0 {
            self.classifier.begin(self.sweep.sensor_origin().z);
        }
        let returns = returns.into_iter();
        let steps = i64::try_from(returns.len().saturating_sub(1).max(1)).unwrap_or(i64::MAX);
        // The actuator's turn over the packet, signed, and per return in 2⁻¹⁶ of its LSB: one
        // division per packet (|turn| < 2³¹, so the step is below 2⁴⁷).
        #[allow(clippy::cast_possible_wrap)]
        let turn = i64::from(actuator.last.wrapping_sub(actuator.first).to_bits() as i32);
        // A one-return packet (an RPLIDAR node) or a still actuator needs no division.
        let step_q16 = if steps == 1 || turn == 0 {
            turn << 16
        } else {
            step_q16(turn, steps)
        };
        // Timed: the packet's time span per return in 2⁻¹⁶ µs, by the same one division.
        let t_step_q16 = if P::TIMED {
            let span = i64::from(later_by(times.last_us, times.first_us));
            if steps == 1 || span == 0 {
                span << 16
            } else {
                self::step_q16(span, steps)
            }
        } else {
            0
        };
        let mut ground_z: Meters = self.pose.z;
        // The plane only where a point is placed, built for the return's actuator angle when
        // it differs from the last one built: a sample without a distance (most of a nodding
        // lidar's rear half-turn; most RPLIDAR nodes, each a packet) needs none unless missing
        // ground is looked for.
        let mut plane: Option<ActuatedPlane> = None;
        for (k, ret) in returns.enumerate() {
            // k ≤ 255 (the longest packet) and |step| < 2⁴⁷: the product is below 2⁵⁵.
            let k = i64::try_from(k).unwrap_or(0);
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let offset = ((step_q16 * k) >> 16) as u32;
            let angle = actuator.first.wrapping_add(FineAngle::from_bits(offset));
            if ret.range_mm == 0 && self.config.missing_ground_within.is_none() {
                self.stats.no_return = self.stats.no_return.saturating_add(1);
                continue;
            }
            // Timed: the pose of this return's moment (a new one needs a new plane).
            let mut t_us = 0;
            if P::TIMED {
                // |t_step| < 2⁴⁷ as the actuator's step: the product is below 2⁵⁵.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let offset = ((t_step_q16 * k) >> 16) as u32;
                t_us = times.first_us.wrapping_add(offset);
                match Self::timed_pose(
                    &mut self.timed,
                    &mut self.pose,
                    &mut self.frame,
                    poses,
                    t_us,
                ) {
                    Ok(false) => {}
                    Ok(true) => {
                        self.sweep = SweepTransform::new(&self.config.mount, &self.frame);
                        plane = None;
                        ground_z = self.pose.z;
                    }
                    Err(_) => {
                        if ret.range_mm == 0 {
                            self.stats.no_return = self.stats.no_return.saturating_add(1);
                        } else {
                            self.stats.returns = self.stats.returns.saturating_add(1);
                            self.stats.returns_without_pose =
                                self.stats.returns_without_pose.saturating_add(1);
                        }
                        continue;
                    }
                }
            }
            if plane.as_ref().is_none_or(|p| p.actuator() != angle) {
                plane = Some(self.sweep.at(angle));
            }
            let Some(plane) = plane.as_ref() else {
                continue;
            };
            let theta = beam_angle_of_clockwise(ret.angle);
            if ret.range_mm == 0 {
                self.stats.no_return = self.stats.no_return.saturating_add(1);
                if let Some(within) = self.config.missing_ground_within {
                    Self::missing_ground_along(
                        &mut self.classifier,
                        &mut self.stats,
                        plane.sensor_origin(),
                        |range| plane.locate(theta, range),
                        ground_z,
                        within,
                    );
                }
                continue;
            }
            self.stats.returns = self.stats.returns.saturating_add(1);
            match plane.locate_squared(theta, ret.range_mm) {
                Some(located) => {
                    self.classifier.add_point_squared(
                        located.point,
                        located.horizontal_squared,
                        ground_z,
                    );
                    if P::TIMED {
                        if self.timed.extrapolated {
                            self.stats.returns_extrapolated =
                                self.stats.returns_extrapolated.saturating_add(1);
                        }
                        self.timed.placed(t_us);
                    }
                }
                None => {
                    self.stats.returns_dropped = self.stats.returns_dropped.saturating_add(1);
                }
            }
        }
        self.stats.packets_applied = self.stats.packets_applied.saturating_add(1);
        self.lines_in_observation = self.lines_in_observation.saturating_add(1);
        Ok(())
    }

    /// Ends the current observation now (if it holds any line): recentres the pyramid on the
    /// robot and applies the evidence.
    pub fn end_observation<const W: usize>(&mut self, pyramid: &mut Pyramid<W, L>) {
        if self.lines_in_observation == 0 {
            self.revolutions_in_observation = 0;
            return;
        }
        pyramid.recentre(self.pose.x, self.pose.y);
        self.classifier.finish_into(pyramid);
        self.lines_in_observation = 0;
        self.revolutions_in_observation = 0;
        self.stats.observations = self.stats.observations.saturating_add(1);
        if core::mem::take(&mut self.timed.spanned) {
            self.observed = ObservedSpan {
                observation: self.stats.observations,
                first_us: self.timed.first_us,
                last_us: self.timed.last_us,
            };
            self.observed_pending = true;
        }
    }
}

/// `(turn·2¹⁶) / steps` rounded towards zero, as `i64` division does, for |turn| < 2³¹ and
/// `0 < steps < 2³²`: from the magnitude by a 32-bit divisor ([`crate::wide::div_rem_u64_u32`]:
/// no 64-bit division on ARMv7-M). Other arguments give some value, never a panic.
fn step_q16(turn: i64, steps: i64) -> i64 {
    let steps = u32::try_from(steps).unwrap_or(u32::MAX);
    // |turn·2¹⁶| < 2⁴⁷: the quotient fits an i64.
    #[allow(clippy::cast_possible_wrap)]
    let magnitude =
        crate::wide::div_rem_u64_u32(turn.wrapping_shl(16).unsigned_abs(), steps).0 as i64;
    if turn < 0 {
        -magnitude
    } else {
        magnitude
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{Design, Schedule, SensorModel};
    use crate::geometry::ScanPlane;
    use crate::pyramid::Config;
    use crate::units::Point3;
    use crate::wire::sick::Unit;
    use crate::Fused;
    extern crate std;
    use std::vec::Vec;

    #[test]
    fn the_step_per_return_is_the_i64_quotient() {
        let mut x = 0x9E37_79B9_7F4A_7C15_u64;
        for steps in 2..=255_i64 {
            for _ in 0..500 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let turn = i64::from(x as i32);
                for t in [turn, -turn, 1, -1, i64::from(i32::MAX), i64::from(i32::MIN)] {
                    assert_eq!(super::step_q16(t, steps), (t << 16) / steps, "{t} {steps}");
                }
            }
        }
    }

    /// A SICK at 0.5 m on a tilt unit, looking at flat floor with a wall 2 m ahead.
    fn ranges_mm(tilt_deg: f64) -> Vec<u8> {
        let tau = tilt_deg.to_radians();
        let mut bytes = Vec::new();
        for i in 0..361 {
            let theta = (i as f64 * 0.5).to_radians();
            // Beam direction after the tilt: (sin θ cos τ, −cos θ, −sin θ sin τ).
            let (dx, dz) = (theta.sin() * tau.cos(), -theta.sin() * tau.sin());
            let floor = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
            let wall = if dx > 1e-6 { 2.0 / dx } else { f64::INFINITY };
            let r = floor.min(wall);
            let raw: u16 = if r < 8.0 {
                (r * 1000.0).round() as u16
            } else {
                0x1FFF
            };
            bytes.extend_from_slice(&raw.to_le_bytes());
        }
        bytes
    }

    /// A boxed pipeline (its 4096-slot scratch is 192 KiB) and pyramid of the default design.
    fn setup(
        lines: u32,
    ) -> (
        std::boxed::Box<Frontend<4096, 8>>,
        std::boxed::Box<Pyramid<64, 8>>,
    ) {
        let design = Design::<8>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        let mut p = std::boxed::Box::new(Pyramid::new());
        p.configure(&design, &Config::default()).unwrap();
        let config = FrontendConfig {
            mount: Mount::new(
                ScanPlane::TiltedHorizontal,
                Point3 {
                    z: Meters::from_num(0.5),
                    ..Point3::default()
                },
            ),
            sensor: Sensor::Sick,
            baud: 500_000,
            actuator: Actuator::External,
            variant: Variant::from_sick(180, 50).unwrap(),
            measuring_mode: MeasuringMode::Mm8Cm80,
            lines_per_observation: lines,
            classifier: ClassifierConfig::default(),
            missing_ground_within: None,
        };
        let mut f = std::boxed::Box::new(Frontend::unconfigured());
        f.configure(config);
        f.adopt_design(&design, &Config::default()).unwrap();
        (f, p)
    }

    fn sweep(
        f: &mut Frontend<4096, 8>,
        p: &mut Pyramid<64, 8>,
        degrees: impl Iterator<Item = u32>,
    ) {
        for tilt in degrees {
            let values = ranges_mm(f64::from(tilt));
            let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
            f.set_actuator(FineAngle::from_quarter_degrees(4 * tilt));
            f.line(p, &line).unwrap();
        }
    }

    #[test]
    fn a_sweep_over_floor_and_wall_marks_both() {
        let (mut f, mut p) = setup(36);
        sweep(&mut f, &mut p, 5..41);
        assert_eq!(f.stats().observations, 1);
        assert_eq!(f.stats().lines_applied, 36);
        let at = |x: f32, y: f32| p.fused(Meters::from_num(x), Meters::from_num(y));
        assert!(
            matches!(at(1.0, 0.05), Fused::Navigable { .. }),
            "{:?}",
            at(1.0, 0.05)
        );
        assert!(
            matches!(at(2.02, 0.05), Fused::Obstacle { .. }),
            "{:?}",
            at(2.02, 0.05)
        );
    }

    #[test]
    fn no_return_beams_mark_missing_ground_only_when_asked() {
        // The floor returns nothing between 1.2 and 1.6 m ahead (a hole), seen at 20° tilt.
        let holed = |tilt: f64| {
            let mut v = ranges_mm(tilt);
            for pair in v.chunks_mut(2) {
                let r = u16::from_le_bytes([pair[0], pair[1]]);
                let ahead = f64::from(r) / 1000.0 * tilt.to_radians().cos();
                if (1.2..1.6).contains(&ahead) {
                    pair.copy_from_slice(&0x1FFF_u16.to_le_bytes());
                }
            }
            v
        };
        for within in [None, Some(Meters::from_num(8))] {
            let (mut f, mut p) = setup(1);
            let mut config = *f.config();
            config.missing_ground_within = within;
            f.configure(config);
            let values = holed(20.0);
            let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
            f.set_actuator(FineAngle::from_quarter_degrees(80));
            f.line(&mut p, &line).unwrap();
            let at_hole = p.fused(Meters::from_num(1.4), Meters::from_num(0.02));
            if within.is_some() {
                assert!(f.stats().missing_ground > 0);
                assert!(matches!(at_hole, Fused::Obstacle { .. }), "{at_hole:?}");
            } else {
                assert_eq!(f.stats().missing_ground, 0);
                assert_eq!(at_hole, Fused::Unknown);
            }
        }
    }

    #[test]
    fn an_unconfigured_pipeline_refuses_lines() {
        let (_, mut p) = setup(1);
        let mut f = Frontend::<64, 8>::unconfigured();
        let values = ranges_mm(20.0);
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        assert_eq!(f.line(&mut p, &line), Err(LineError::NotConfigured));
        assert_eq!(f.stats().lines_rejected, 1);
    }

    #[test]
    fn a_line_that_does_not_fit_the_variant_is_refused_whole() {
        let (mut f, mut p) = setup(1);
        let values = ranges_mm(20.0);
        let short = MeasuredValues::new(Unit::Millimetre, 0, &values[..360], None, 0).unwrap();
        assert_eq!(
            f.line(&mut p, &short),
            Err(LineError::CountMismatch {
                count: 180,
                expected: 361
            })
        );
        assert_eq!(f.stats().lines_rejected, 1);
        assert_eq!(f.classifier_stats().points, 0);
        assert_eq!(p.stats().applied, 0);
    }

    /// The same frontend set up for an LD06 on the tilt unit, 0.5 m up.
    fn lidar(
        revolutions: u32,
    ) -> (
        std::boxed::Box<Frontend<4096, 8>>,
        std::boxed::Box<Pyramid<64, 8>>,
    ) {
        let (mut f, p) = setup(revolutions);
        let mut config = *f.config();
        config.sensor = Sensor::Ld06;
        config.baud = 230_400;
        f.configure(config);
        (f, p)
    }

    /// Twelve returns from `start_deg` clockwise 0.8° apart, as a lidar 0.5 m up tilted by
    /// `tilt_deg` sees flat floor (no return where the beam does not meet it within 8 m).
    fn floor_returns(start_deg: f64, tilt_deg: f64) -> Vec<LaserReturn> {
        let tau = tilt_deg.to_radians();
        (0..12)
            .map(|k| {
                let phi = start_deg + 0.8 * f64::from(k);
                let theta = (90.0 - phi).to_radians();
                let dz = -theta.sin() * tau.sin();
                let r = if dz < -1e-6 { 0.5 / -dz } else { f64::INFINITY };
                LaserReturn {
                    angle: FineAngle::from_bits(
                        (phi.rem_euclid(360.0) / 360.0 * 4_294_967_296.0) as u32,
                    ),
                    range_mm: if r < 8.0 {
                        (r * 1000.0).round() as u32
                    } else {
                        0
                    },
                    quality: Some(100),
                }
            })
            .collect()
    }

    fn all_cells(p: &Pyramid<64, 8>) -> Vec<Option<crate::Cell>> {
        let mut cells = Vec::new();
        for k in 0..p.layer_count() {
            let layer = p.layer(k).unwrap();
            let (ox, oy) = layer.origin();
            for j in 0..64 {
                for i in 0..64 {
                    cells.push(layer.get(ox + i, oy + j));
                }
            }
        }
        cells
    }

    #[test]
    fn lidar_packets_mark_the_floor_ahead() {
        let (mut f, mut p) = lidar(1);
        // A revolution: 0° ahead, packets of 9.6° all the way round, tilted 25° down.
        for n in 0..38 {
            let start = f64::from(n) * 9.6 - 4.8;
            let returns = floor_returns(start, 25.0);
            let wraps = n == 0 || n == 37;
            f.packet(
                &mut p,
                returns,
                wraps,
                PacketActuator::still(FineAngle::from_quarter_degrees(100)),
            )
            .unwrap();
        }
        assert_eq!(f.stats().packets_applied, 38);
        assert_eq!(f.stats().revolutions, 2);
        // The second start closed the first observation.
        assert_eq!(f.stats().observations, 1);
        assert!(f.stats().returns > 100 && f.stats().no_return > 100);
        let at = |x: f32, y: f32| p.fused(Meters::from_num(x), Meters::from_num(y));
        // 0.5 m up at 25°: the floor ahead at 1.07 m, behind the beams go up (no return).
        assert!(
            matches!(at(1.07, 0.0), Fused::Navigable { .. }),
            "{:?}",
            at(1.07, 0.0)
        );
        assert_eq!(at(-1.07, 0.0), Fused::Unknown);
        // A SICK line is refused while a lidar is set up, and a packet while a SICK is.
        let values = ranges_mm(20.0);
        let line = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        assert_eq!(
            f.line(&mut p, &line),
            Err(LineError::WrongSensor {
                configured: SensorKind::Ld06
            })
        );
        let (mut sick, mut q) = setup(1);
        assert_eq!(
            sick.packet(
                &mut q,
                floor_returns(0.0, 20.0),
                false,
                PacketActuator::default()
            ),
            Err(LineError::WrongSensor {
                configured: SensorKind::Sick
            })
        );
        assert_eq!(sick.stats().lines_rejected, 1);
    }

    #[test]
    fn each_return_gets_its_own_actuator_angle() {
        // One packet while the actuator turns from 10° to 21°, against twelve packets of one
        // return each at the interpolated angle (1° apart): the same points, the same cells.
        let first = FineAngle::from_quarter_degrees(40);
        let step = FineAngle::from_quarter_degrees(4).to_bits();
        let last = FineAngle::from_bits(first.to_bits() + 11 * step);
        let returns = floor_returns(-4.8, 15.0);
        let (mut whole, mut p) = lidar(0);
        whole
            .packet(
                &mut p,
                returns.clone(),
                false,
                PacketActuator { first, last },
            )
            .unwrap();
        whole.end_observation(&mut p);
        let (mut single, mut q) = lidar(0);
        for (k, r) in returns.iter().enumerate() {
            let a = FineAngle::from_bits(first.to_bits() + k as u32 * step);
            single
                .packet(&mut q, [*r], false, PacketActuator::still(a))
                .unwrap();
        }
        single.end_observation(&mut q);
        assert_eq!(whole.classifier_stats(), single.classifier_stats());
        assert_eq!(all_cells(&p), all_cells(&q));
        // And not the cells of a packet at one angle throughout.
        let (mut still, mut r) = lidar(0);
        still
            .packet(&mut r, returns, false, PacketActuator::still(first))
            .unwrap();
        still.end_observation(&mut r);
        assert_ne!(all_cells(&p), all_cells(&r));
    }

    #[test]
    fn a_lidar_sweep_ends_when_the_actuator_turns_back() {
        let (mut f, mut p) = lidar(0);
        let packet = |f: &mut Frontend<4096, 8>, p: &mut Pyramid<64, 8>, a: u32, b: u32| {
            let act = PacketActuator {
                first: FineAngle::from_quarter_degrees(a),
                last: FineAngle::from_quarter_degrees(b),
            };
            f.packet(p, floor_returns(0.0, 20.0), false, act).unwrap();
        };
        for a in 40..60 {
            packet(&mut f, &mut p, 4 * a, 4 * a + 2);
        }
        assert_eq!(f.stats().observations, 0);
        packet(&mut f, &mut p, 240, 236);
        assert_eq!(f.stats().observations, 1);
        assert_eq!(f.lines_in_observation(), 1);
    }

    #[test]
    fn a_sweep_ends_when_the_actuator_turns_back() {
        let (mut f, mut p) = setup(0);
        sweep(&mut f, &mut p, 5..41);
        assert_eq!(f.stats().observations, 0);
        sweep(&mut f, &mut p, (5..40).rev());
        assert_eq!(f.stats().observations, 1);
        f.end_observation(&mut p);
        assert_eq!(f.stats().observations, 2);
    }
}
