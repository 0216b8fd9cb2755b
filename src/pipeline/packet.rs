//! The spinning lidar's packet path: each return at its own beam angle and its own
//! interpolated actuator angle (and, timed, at the pose of its own moment), placed by the
//! sweep transform and handed to the classifier.

use super::make_room;
use super::timed::{later_by, Poses};
use super::Frontend;
use super::LineError;
use crate::angle::FineAngle;
use crate::geometry::{beam_angle_of_clockwise, ActuatedPlane, PoseTrack, SweepTransform};
use crate::pyramid::Pyramid;
use crate::units::Meters;
use crate::wire::LaserReturn;

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

impl<const C: usize, const L: usize> Frontend<C, L> {
    /// Whether a return passes the setup's masks and filters (before any geometry): a
    /// return with a range is judged by all of them and a refusal counted under its reason;
    /// a no-echo return only by the masks, and a masked one counted as no return.
    #[inline]
    fn passes_filter(&mut self, ret: &LaserReturn) -> bool {
        if !self.config.filter.active() {
            return true;
        }
        if ret.range_mm != 0 {
            if let Some(why) = self
                .config
                .filter
                .judge(ret.angle, ret.range_mm, ret.quality)
            {
                self.stats.refused(why);
                return false;
            }
        } else if self.config.filter.masks() && self.config.filter.masked(ret.angle) {
            self.stats.no_return = self.stats.no_return.saturating_add(1);
            return false;
        }
        true
    }

    /// Feeds one packet of a spinning lidar: its returns in the order measured (angles in the
    /// sensor's clockwise convention, range 0 = no return), whether a revolution starts in
    /// it, and the actuator's angle at its first and last return (interpolated per return;
    /// see the [module documentation](super)). Its points join the current observation; an
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
        self.packet_start(pyramid, starts_revolution, actuator)?;
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
        let ground_z: Meters = self.pose.z;
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
            if !self.passes_filter(&ret) {
                continue;
            }
            if ret.range_mm == 0 && self.config.missing_ground_within.is_none() {
                self.stats.no_return = self.stats.no_return.saturating_add(1);
                continue;
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
                    make_room!(self, pyramid);
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
                    make_room!(self, pyramid);
                    self.classifier.add_point_squared(
                        located.point,
                        located.horizontal_squared,
                        ground_z,
                    );
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

    /// [`packet`](Self::packet) with each return placed at the pose of its own moment: return
    /// k of n measured at `first_us + k·(last_us − first_us)/(n − 1)` (as its actuator angle
    /// is interpolated), its pose from `track` by the rule of [`crate::geometry::pose_track`]
    /// (re-evaluated only [`POSE_QUANTUM_US`] or more from where it was evaluated). A return
    /// with no pose is refused and counted (`returns_without_pose`).
    ///
    /// # Errors
    /// As [`packet`](Self::packet).
    ///
    /// [`POSE_QUANTUM_US`]: crate::geometry::POSE_QUANTUM_US
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

    /// What every lidar packet does first: refuses it without a setup or for a SICK (counted),
    /// takes its last actuator angle, and ends the observation where the sweep turned or the
    /// revolutions it groups are complete.
    #[inline(always)]
    fn packet_start<const W: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        starts_revolution: bool,
        actuator: PacketActuator,
    ) -> Result<(), LineError> {
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
        let per = self.revolutions_per_observation(per);
        if starts_revolution {
            self.stats.revolutions = self.stats.revolutions.saturating_add(1);
            if per != 0 && self.revolutions_in_observation >= per {
                self.end_observation(pyramid);
            }
            self.revolutions_in_observation = self.revolutions_in_observation.saturating_add(1);
        }
        Ok(())
    }

    /// The revolutions an observation groups under the setup's `lines_per_observation`
    /// (`per`): `per` itself when not 0. With 0 (one observation per sweep), a revolution of
    /// a lidar on a pan actuator is already a whole profile, as a SICK line is (the panned
    /// vertical preset's, or any plane turned about z): one observation per revolution. A lidar
    /// on no actuator, or on one that has not moved (none reported yet), has no sweep to end:
    /// one per revolution too. Otherwise 0: the sweep's end closes it (a nodding lidar's
    /// revolutions each cover one tilt).
    fn revolutions_per_observation(&self, per: u32) -> u32 {
        let whole_profile = !matches!(
            self.config.mount.axis(),
            crate::geometry::ActuatorAxis::Tilt
        );
        if per == 0 && (whole_profile || self.direction == 0) {
            1
        } else {
            per
        }
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
        self.packet_start(pyramid, starts_revolution, actuator)?;
        if self.lines_in_observation == 0 {
            // Timed: the sensor's height at the packet's first return (the pose in force
            // stays as the rule leaves it).
            let origin = match poses.pose_at(times.first_us) {
                Ok((pose, _)) if P::TIMED => {
                    SweepTransform::new(&self.config.mount, &pose.frame()).sensor_origin()
                }
                _ => self.sweep.sensor_origin(),
            };
            self.classifier.begin(origin.z);
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
            if !self.passes_filter(&ret) {
                continue;
            }
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
                    make_room!(self, pyramid);
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
                    make_room!(self, pyramid);
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
}

/// `(turn·2¹⁶) / steps` rounded towards zero, as `i64` division does, for |turn| < 2³¹ and
/// `0 < steps < 2³²`: from the magnitude by a 32-bit divisor ([`crate::wide::div_rem_u64_u32`]:
/// no 64-bit division on ARMv7-M). Other arguments give some value, never a panic.
pub(super) fn step_q16(turn: i64, steps: i64) -> i64 {
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
