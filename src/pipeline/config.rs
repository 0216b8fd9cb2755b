//! What the pipeline is set up with, what it counts, and why it refuses a line:
//! [`FrontendConfig`], [`FrontendStats`], [`LineError`].

use super::filter::{Refusal, ReturnFilter};
use crate::actuator::Actuator;
use crate::classify::ClassifierConfig;
use crate::geometry::Mount;
use crate::laser::{Sensor, SensorKind};
use crate::units::Meters;
use crate::wire::sick::MeasuringMode;
use crate::wire::sick::Variant;
use core::fmt;

/// How the laser is set up and how its lines are grouped into observations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrontendConfig {
    /// How the laser is mounted on its actuator, and where.
    pub mount: Mount,
    /// The masks and filters each return passes before geometry.
    pub filter: ReturnFilter,
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
    /// Lines (a SICK's telegrams, a lidar's revolutions) per observation, ≥ 1; 0 = one
    /// observation per sweep of the actuator (a lidar panned vertical, or one whose actuator has
    /// not moved: one per revolution).
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
            filter: crate::pipeline::ReturnFilter::NONE,
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
    ///
    /// [`Placement::Extrapolated`]: crate::geometry::Placement::Extrapolated
    /// [`Placement::Held`]: crate::geometry::Placement::Held
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose: later than the newest stamped pose by more than
    /// the extrapolation bound, or earlier than the oldest kept (timed placement only). They
    /// are counted in `returns` too, and placed nowhere.
    pub returns_without_pose: u32,
    /// Returns refused before geometry: their angle in a masked sector
    /// ([`ReturnFilter`]). Counted in `returns` too.
    pub returns_masked: u32,
    /// Returns refused before geometry: nearer than the minimum range. Counted in `returns`.
    pub returns_too_near: u32,
    /// Returns refused before geometry: farther than the maximum range. Counted in `returns`.
    pub returns_too_far: u32,
    /// Returns refused before geometry: quality below the minimum. Counted in `returns`.
    pub returns_low_quality: u32,
    /// Observations applied early because the classifier's scratch could not be sure to hold
    /// the next return (fewer slots free than one return can take): the returns that follow
    /// start the next observation, so none is dropped. Counted in `observations` too.
    pub observations_split: u32,
}

impl FrontendStats {
    /// Counts a return refused before geometry under its reason.
    pub(super) fn refused(&mut self, why: Refusal) {
        let counter = match why {
            Refusal::Masked => &mut self.returns_masked,
            Refusal::TooNear => &mut self.returns_too_near,
            Refusal::TooFar => &mut self.returns_too_far,
            Refusal::LowQuality => &mut self.returns_low_quality,
        };
        *counter = counter.saturating_add(1);
    }
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
    ///
    /// [`Frontend::unconfigured`]: super::Frontend::unconfigured
    /// [`Frontend::adopt_design`]: super::Frontend::adopt_design
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
