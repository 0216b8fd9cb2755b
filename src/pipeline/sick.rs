//! The SICK line path: a measured-values telegram mapped onto the beam table, each beam
//! placed (untimed, or at the pose of its own moment) and handed to the classifier, and
//! missing ground from beams that return nothing.

use super::make_room;
use super::timed::Poses;
use super::Frontend;
use super::LineError;
use super::{Refusal, ReturnFilter};
use crate::angle::FineAngle;
use crate::geometry::{LineTransform, PoseTrack};
use crate::laser::SickBeamTimes;
use crate::pyramid::Pyramid;
use crate::units::Meters;
use crate::wire::sick::MeasuredValues;
use crate::wire::sick::Variant;

/// How a telegram's values map onto the beam table.
#[derive(Clone, Copy)]
enum Layout {
    /// Value j is beam j.
    Full,
    /// An interlaced partial scan with this index.
    Partial(u8),
}

impl<const C: usize, const L: usize> Frontend<C, L> {
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
        let transform =
            LineTransform::new(&self.beams, &self.config.mount, self.actuator, &self.frame);
        if self.lines_in_observation == 0 {
            self.classifier.begin(transform.sensor_origin().z);
        }
        let ground_z: Meters = self.pose.z;
        let variant = self.config.variant;
        // Counted here and added once per line (at most 401 values each: the sums are exact,
        // and so are the saturating totals).
        let (mut no_return, mut returns, mut dropped) = (0_u32, 0_u32, 0_u32);
        for (j, range) in values.ranges_mm(self.config.measuring_mode).enumerate() {
            let beam = match layout {
                Layout::Full => Some(j),
                Layout::Partial(p) => variant.partial_scan_beam(p, j),
            };
            let Some(range_mm) = range else {
                no_return += 1;
                if let (Some(within), Some(b)) = (self.config.missing_ground_within, beam) {
                    if beam_masked(&self.config.filter, variant, b) {
                        continue;
                    }
                    make_room!(self, pyramid);
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
            if let Some(why) = beam.and_then(|b| refused(&self.config.filter, variant, b, range_mm))
            {
                self.stats.refused(why);
                continue;
            }
            match beam.and_then(|b| transform.locate_squared(b, range_mm)) {
                Some(located) => {
                    // The distance is needed only for its gate bin: no square root.
                    make_room!(self, pyramid);
                    self.classifier.add_point_squared(
                        located.point,
                        located.horizontal_squared,
                        ground_z,
                    );
                }
                None => dropped += 1,
            }
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

    /// [`line`](Self::line) with each beam placed at the pose of its own moment: the beams'
    /// times from the mirror's turns ([`SickBeamTimes`]), the last measured one's at
    /// `last_beam_us` (µs, device clock), and the pose at each from `track` by the rule of
    /// [`crate::geometry::pose_track`] (re-evaluated only [`POSE_QUANTUM_US`] or more from
    /// where it was evaluated). A return with no pose is refused and counted
    /// (`returns_without_pose`).
    ///
    /// # Errors
    /// As [`line`](Self::line).
    ///
    /// [`POSE_QUANTUM_US`]: crate::geometry::POSE_QUANTUM_US
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
        // The beams' times (timed placement only).
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
        let mut transform =
            LineTransform::new(&self.beams, &self.config.mount, self.actuator, &self.frame);
        if self.lines_in_observation == 0 {
            // Timed: the sensor's height at the line's first beam (the pose in force stays as
            // the rule leaves it).
            let origin = match &times {
                Some(times) => {
                    let first = match layout {
                        Layout::Full => Some(0),
                        Layout::Partial(p) => variant.partial_scan_beam(p, 0),
                    };
                    let t = last_beam_us.wrapping_sub(times.before_last_us(first.unwrap_or(0)));
                    match poses.pose_at(t) {
                        Ok((pose, _)) => LineTransform::new(
                            &self.beams,
                            &self.config.mount,
                            self.actuator,
                            &pose.frame(),
                        )
                        .sensor_origin(),
                        Err(_) => transform.sensor_origin(),
                    }
                }
                None => transform.sensor_origin(),
            };
            self.classifier.begin(origin.z);
        }
        let mut ground_z: Meters = self.pose.z;
        // Counted here and added once per line (at most 401 values each: the sums are exact,
        // and so are the saturating totals).
        let (mut no_return, mut returns, mut dropped) = (0_u32, 0_u32, 0_u32);
        let (mut extrapolated, mut without_pose) = (0_u32, 0_u32);
        let turns = times.as_ref().map_or(1, SickBeamTimes::turns);
        for turn in 0..turns {
            for (j, range) in values.ranges_mm(self.config.measuring_mode).enumerate() {
                let beam = match layout {
                    Layout::Full => Some(j),
                    Layout::Partial(p) => variant.partial_scan_beam(p, j),
                };
                // The beams in the order measured: one pass per mirror turn (an interlaced full
                // telegram alternates turns from beam to beam; in index order the pose in force
                // would be re-evaluated at every beam).
                if turns > 1
                    && beam.map_or(turn != 0, |b| {
                        times.as_ref().is_some_and(|t| t.turn_of(b) != turn)
                    })
                {
                    continue;
                }
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
                            // (The sweep follows at the next Setup or pose: only lidars use it.)
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
                        if beam_masked(&self.config.filter, variant, b) {
                            continue;
                        }
                        make_room!(self, pyramid);
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
                if let Some(why) =
                    beam.and_then(|b| refused(&self.config.filter, variant, b, range_mm))
                {
                    self.stats.refused(why);
                    continue;
                }
                match beam.and_then(|b| transform.locate_squared(b, range_mm)) {
                    Some(located) => {
                        // The distance is needed only for its gate bin: no square root.
                        make_room!(self, pyramid);
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
}

/// Whether beam `beam`'s angle θ lies in a masked sector of `filter` (its angle computed only
/// when a sector is masked).
#[inline]
fn beam_masked(filter: &ReturnFilter, variant: Variant, beam: usize) -> bool {
    filter.masks() && variant.beam_angle(beam).is_some_and(|a| filter.masked(a))
}

/// Why the return of beam `beam` at `range_mm` is refused by `filter`, if it is: the mask
/// tests the beam's angle θ, computed only when a sector is masked; a SICK reports no quality.
#[inline]
fn refused(filter: &ReturnFilter, variant: Variant, beam: usize, range_mm: u32) -> Option<Refusal> {
    if !filter.active() {
        return None;
    }
    let angle = if filter.masks() {
        variant.beam_angle(beam).unwrap_or(FineAngle::ZERO)
    } else {
        FineAngle::ZERO
    };
    filter.judge(angle, range_mm, None)
}
