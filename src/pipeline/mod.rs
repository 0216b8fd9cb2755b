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
//! # Each return at the pose of its own moment
//! [`Frontend::packet_timed`] and [`Frontend::line_timed`] take the returns' times (a packet's
//! first and last, interpolated per return as the actuator's angle is; a SICK line's last
//! measured beam, the others timed back along the mirror's turns by
//! [`crate::laser::SickBeamTimes`]) and a [`PoseTrack`] of stamped poses: each return is
//! placed with the track's pose at its time ([`crate::geometry::pose_track`]), re-evaluated
//! only when a return lies [`POSE_QUANTUM_US`] or more from the time the pose in force was
//! evaluated at (then the pose's frame and the sweep or line transform are rebuilt: at most
//! about 1 000 a second, none while the robot stands still). A return the track has no pose
//! for is refused and counted ([`FrontendStats::returns_without_pose`]); one placed with an
//! extrapolated or held pose is counted ([`FrontendStats::returns_extrapolated`]). The
//! untimed [`Frontend::packet`] and [`Frontend::line`] are their own code, unchanged: one loop
//! shared by both, even monomorphised, moved the compiler's inlining in the untimed loop and
//! cost it 18 instructions a return on the M4F. An observation
//! whose returns had times leaves their span for [`Frontend::take_observed`].
//!
//! # Observations
//! An observation ends after a fixed number of lines, or, with `lines_per_observation = 0`,
//! when the actuator turns back (the end of a sweep). For a spinning lidar a "line" is a
//! **revolution**: with `lines_per_observation = n`, an observation ends where the (n+1)-th
//! revolution since its start begins (the packet that starts it opens the next observation;
//! the first observation also holds the partial revolution before the first start); with 0,
//! at the end of each sweep of the nodding actuator, as for a SICK (the turn is seen at the
//! packet whose last actuator angle moves the other way), except for a lidar panned vertical or
//! one whose actuator has not moved, which get one observation per revolution
//! (`docs/lidars.md`, "Observations"). At its end the pyramid is recentred on the robot and the
//! observation's evidence is applied.
//!
//! # No return dropped
//! Before each return the pipeline checks that the classifier's scratch has as many free
//! slots as one return can take under the design in force
//! ([`Classifier::slots_per_point`]); when it has not, the observation is applied as it stands
//! and the returns that follow start the next one ([`FrontendStats::observations_split`]). So
//! the classifier's `overflow_points` stays 0 unless a single return needs more slots than `C`.
//!
//! [`PoseTrack`]: crate::geometry::PoseTrack
//! [`POSE_QUANTUM_US`]: crate::geometry::POSE_QUANTUM_US

mod config;
pub mod filter;
mod packet;
mod sick;
#[cfg(test)]
pub(crate) mod tests;
mod timed;

pub use config::{FrontendConfig, FrontendStats, LineError};
pub use filter::{Refusal, ReturnFilter, Sector, MAX_SECTORS};
pub use packet::{PacketActuator, PacketTimes};
pub use timed::ObservedSpan;
use timed::TimedPose;

use crate::actuator::Actuator;
use crate::angle::FineAngle;
use crate::classify::{Classifier, ClassifierConfig, ClassifierStats};
use crate::design::{Design, DesignError};
use crate::geometry::{
    BeamTable, LinePoint, LineTransform, Mount, Pose, PoseFrame, SweepTransform,
};
use crate::laser::Sensor;
use crate::pyramid::{Config, Pyramid};
use crate::units::Meters;
use crate::units::Point3;
use crate::wire::sick::MeasuringMode;
use crate::wire::sick::Variant;
use core::fmt;

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
    /// The most classifier slots one return can take under the design in force
    /// ([`Classifier::slots_per_point`]), at most `C`; 0 before a design (nothing is split).
    /// With fewer free, the observation is split first. 0 at rest, so that a fresh pipeline
    /// is all zero bits and a board keeps it in `.bss`, not in flash.
    slots_per_return: usize,
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
                filter: crate::pipeline::ReturnFilter::NONE,
                mount: Mount::ZERO,
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
            slots_per_return: 0,
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
                returns_masked: 0,
                returns_too_near: 0,
                returns_too_far: 0,
                returns_low_quality: 0,
                observations_split: 0,
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
        self.slots_per_return = self.classifier.slots_per_point().min(C);
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

    /// Ends the current observation now (if it holds any line): recentres the pyramid on the
    /// robot and applies the evidence.
    pub fn end_observation<const W: usize>(&mut self, pyramid: &mut Pyramid<W, L>) {
        if self.lines_in_observation == 0 {
            self.revolutions_in_observation = 0;
            return;
        }
        Self::apply_observation(
            &mut self.classifier,
            pyramid,
            &self.pose,
            &mut self.stats,
            &mut self.timed,
            &mut self.observed,
            &mut self.observed_pending,
        );
        self.lines_in_observation = 0;
        self.revolutions_in_observation = 0;
    }

    /// Whether the classifier's scratch may not hold the next return: fewer slots free than
    /// one return can take, and at least one cell in use (an empty scratch is never split).
    /// Then the observation is split before it
    /// ([`split_observation`](Self::split_observation)). One addition and one comparison
    /// per return: with `s ≤ C` the slots a return takes (clamped when adopted) and `u ≤ C`
    /// the cells in use, `C − u < s ∧ u > 0` is `u + s > C` (which, with `s ≤ C`, needs
    /// `u > 0`; `u + s ≤ 2C` does not overflow).
    #[inline(always)]
    fn scratch_short(&self) -> bool {
        self.classifier.cells_in_use() + self.slots_per_return > C
    }

    /// Applies what the observation under way holds (recentred on the robot, counted as an
    /// observation and as a split) and lets it go on with an empty scratch, at the same
    /// reference height: the returns that follow start the next observation, none is lost.
    /// The regular boundaries (revolutions, lines, sweeps) stay where they were.
    #[cold]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn split_observation<const W: usize>(
        classifier: &mut Classifier<C, L>,
        pyramid: &mut Pyramid<W, L>,
        pose: &Pose,
        stats: &mut FrontendStats,
        timed: &mut TimedPose,
        observed: &mut ObservedSpan,
        observed_pending: &mut bool,
    ) {
        Self::apply_observation(
            classifier,
            pyramid,
            pose,
            stats,
            timed,
            observed,
            observed_pending,
        );
        stats.observations_split = stats.observations_split.saturating_add(1);
    }

    /// Recentres the pyramid on `pose`, applies the classifier's evidence and counts the
    /// observation; a span of timed returns is left for [`take_observed`](Self::take_observed).
    fn apply_observation<const W: usize>(
        classifier: &mut Classifier<C, L>,
        pyramid: &mut Pyramid<W, L>,
        pose: &Pose,
        stats: &mut FrontendStats,
        timed: &mut TimedPose,
        observed: &mut ObservedSpan,
        observed_pending: &mut bool,
    ) {
        pyramid.recentre(pose.x, pose.y);
        classifier.finish_into(pyramid);
        stats.observations = stats.observations.saturating_add(1);
        if core::mem::take(&mut timed.spanned) {
            *observed = ObservedSpan {
                observation: stats.observations,
                first_us: timed.first_us,
                last_us: timed.last_us,
            };
            *observed_pending = true;
        }
    }
}

/// Splits the observation under way before the next return when the classifier's scratch may
/// not hold it ([`Frontend::split_observation`]). A macro, so that it borrows only the fields
/// it uses while a line's transform borrows others.
macro_rules! make_room {
    ($self:ident, $pyramid:expr) => {
        if $self.scratch_short() {
            Self::split_observation(
                &mut $self.classifier,
                $pyramid,
                &$self.pose,
                &mut $self.stats,
                &mut $self.timed,
                &mut $self.observed,
                &mut $self.observed_pending,
            );
        }
    };
}
use make_room;
