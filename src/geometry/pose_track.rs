//! The robot's poses with the times they held ([`PoseTrack`]), and the pose at any moment
//! between or just after them ([`PoseTrack::at`]): each return is placed with the pose of its
//! own measurement time, not with the latest pose to arrive.
//!
//! # The rule
//! Times are the device's microsecond clock (`u32`, wrapping every 71.6 minutes); every
//! comparison is on the wrapping difference read as an `i32` (`b − a > 0`: b is later), so a
//! track and its returns may straddle the clock's wrap.
//!
//! - **Taking a pose** stamped s ([`PoseTrack::push`]): refused when s is not later than the
//!   newest stamp ([`PoseRefusal::NotNewer`]), more than [`MAX_POSE_LEAD_US`] ahead of the
//!   device's clock ([`PoseRefusal::TooFarAhead`]) or more than [`MAX_POSE_AGE_US`] behind it
//!   ([`PoseRefusal::TooOld`]); when s is more than [`MAX_POSE_GAP_US`]
//!   after the newest the track restarts at it ([`Taken::Restarted`]: nothing is interpolated
//!   across a gap); else it is appended, the oldest dropped when the `N` slots are full.
//! - **The pose at t** ([`PoseTrack::at`]):
//!   - oldest ≤ t ≤ newest: linear interpolation between the two poses that bracket t
//!     ([`Placement::Interpolated`]; exact at a stamp);
//!   - newest < t ≤ newest + [`MAX_EXTRAPOLATION_US`]: linear extrapolation along the last two
//!     poses ([`Placement::Extrapolated`]), or the one pose held ([`Placement::Held`]);
//!   - otherwise none ([`NoPose`]): the caller refuses the return.
//!
//! # Arithmetic
//! One division per evaluation: the fraction `f = (t − a)/(b − a)` of the pair (a, b) in
//! Q32.32, truncated (`⌊(t − a)·2³² / (b − a)⌋`, by a 64-by-32-bit division). Then each of the
//! six components is `a + round(Δ·f / 2³²)`, halves rounded up, in 128 bits:
//! - x, y, z: Δ the Q16.16 difference `b − a`; the result saturates at the bounds of
//!   [`Meters`];
//! - roll, pitch, yaw: Δ the wrapping difference `b − a` of the [`FineAngle`]s read as an
//!   `i32`: the shorter arc (exactly half a turn apart goes the negative way); the result
//!   wraps, as angles do.
//!
//! Truncating f costs less than 2⁻³² of Δ, so an interpolated component is within one LSB of
//! the exact one (0.5 for the rounding, under 0.5 for f while |Δ| < 2³¹ LSB: 32 768 m, half
//! a turn); extrapolated, the truncation is multiplied by the ratio (t − a)/(b − a), still
//! under one LSB for any ratio below 2³²/|Δ|. At a stamp (f = 0 or f = 2³²) the pose is
//! that stamp's, bit for bit.
//!
//! The track spans at most `N · MAX_POSE_GAP_US`; `N` must stay below 4 000 for that to be
//! less than half the clock's wrap (a board uses 2 to 64).

use crate::angle::FineAngle;
use crate::geometry::Pose;
use crate::units::Meters;

/// Returns whose times lie closer than this to the time the pose in force was evaluated at
/// keep that pose (the pipeline re-evaluates only when a return's time is this far from it),
/// µs: 1 ms, 1 mm of travel at 1 m/s, 1 mrad at 1 rad/s.
pub const POSE_QUANTUM_US: u32 = 1_000;

/// How far past the newest pose a return may be placed by extrapolation, µs: 100 ms.
pub const MAX_EXTRAPOLATION_US: u32 = 100_000;

/// A stamped pose more than this after the newest restarts the track (no interpolation
/// across the gap), µs: 500 ms.
pub const MAX_POSE_GAP_US: u32 = 500_000;

/// A stamped pose more than this ahead of the device's clock is refused, µs: 1 s.
pub const MAX_POSE_LEAD_US: u32 = 1_000_000;

/// A stamped pose more than this before the device's clock is refused, µs: 1 s. No return
/// measured now could take it (the next pose, more than [`MAX_POSE_GAP_US`] later, restarts
/// the track), and a pose stamped in a clock the device no longer runs (sent before it
/// rebooted, taken after) is such a pose.
pub const MAX_POSE_AGE_US: u32 = 1_000_000;

/// How [`PoseTrack::push`] took a pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Taken {
    /// Appended after the newest (the oldest dropped if the track was full), or the first
    /// pose of an empty track.
    Appended,
    /// More than [`MAX_POSE_GAP_US`] after the newest: the track now holds this pose alone.
    Restarted,
}

/// Why [`PoseTrack::push`] refused a pose; the track is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PoseRefusal {
    /// Its stamp is not later than the newest pose's.
    NotNewer,
    /// Its stamp is more than [`MAX_POSE_LEAD_US`] ahead of the device's clock.
    TooFarAhead,
    /// Its stamp is more than [`MAX_POSE_AGE_US`] before the device's clock.
    TooOld,
}

/// How [`PoseTrack::at`] found the pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Placement {
    /// Between the oldest and the newest pose (inclusive): interpolated.
    Interpolated,
    /// After the newest, within [`MAX_EXTRAPOLATION_US`]: extrapolated along the last two.
    Extrapolated,
    /// After the newest, within [`MAX_EXTRAPOLATION_US`], and the track holds one pose: that
    /// pose.
    Held,
}

/// Why [`PoseTrack::at`] has no pose for a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoPose {
    /// The track is empty.
    Empty,
    /// The time is earlier than the oldest pose kept.
    BeforeOldest,
    /// The time is more than [`MAX_EXTRAPOLATION_US`] after the newest pose.
    TooLate,
}

/// A bounded ring of up to `N` stamped poses (no heap), oldest first, stamps strictly
/// increasing (in the wrapping sense). See the [module documentation](self) for the rule.
///
/// `const`-built all zero bits ([`PoseTrack::new`]): a `static` holding one sits in `.bss`.
/// `N` · 28 bytes (24 a pose, 4 a stamp) and two words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseTrack<const N: usize> {
    /// The stamps, µs, in ring order from `head`.
    stamps: [u32; N],
    /// The poses, in the same slots.
    poses: [Pose; N],
    /// The slot of the oldest pose.
    head: usize,
    /// How many poses are kept, `0 ..= N`.
    len: usize,
}

impl<const N: usize> Default for PoseTrack<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> PoseTrack<N> {
    /// An empty track.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            stamps: [0; N],
            poses: [Pose::IDENTITY; N],
            head: 0,
            len: 0,
        }
    }

    /// Forgets every pose.
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    /// How many poses are kept.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether the track holds no pose.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The slot of the `k`-th oldest pose (`k < len`).
    fn slot(&self, k: usize) -> usize {
        // head < N and k < N: no overflow for any N that fits memory.
        let i = self.head + k;
        if i >= N {
            i - N
        } else {
            i
        }
    }

    /// The `k`-th oldest stamp and pose (`None` past the newest).
    fn entry(&self, k: usize) -> Option<(u32, Pose)> {
        if k >= self.len {
            return None;
        }
        let i = self.slot(k);
        Some((*self.stamps.get(i)?, *self.poses.get(i)?))
    }

    /// The newest stamp and pose.
    #[must_use]
    pub fn newest(&self) -> Option<(u32, Pose)> {
        self.entry(self.len.checked_sub(1)?)
    }

    /// The oldest stamp and pose.
    #[must_use]
    pub fn oldest(&self) -> Option<(u32, Pose)> {
        self.entry(0)
    }

    /// Takes `pose`, at which the robot was at `stamp_us`, given the device's clock
    /// `device_now_us` (both µs, wrapping).
    ///
    /// # Errors
    /// The stamp is not later than the newest one, more than [`MAX_POSE_LEAD_US`] ahead of
    /// `device_now_us`, or more than [`MAX_POSE_AGE_US`] before it; the track is unchanged.
    pub fn push(
        &mut self,
        stamp_us: u32,
        pose: Pose,
        device_now_us: u32,
    ) -> Result<Taken, PoseRefusal> {
        let after_newest = self.newest().map(|(s, _)| later_by(stamp_us, s));
        if after_newest.is_some_and(|d| d <= 0) {
            return Err(PoseRefusal::NotNewer);
        }
        let ahead = later_by(stamp_us, device_now_us);
        if ahead > lead_i32(MAX_POSE_LEAD_US) {
            return Err(PoseRefusal::TooFarAhead);
        }
        if ahead < -lead_i32(MAX_POSE_AGE_US) {
            return Err(PoseRefusal::TooOld);
        }
        if N == 0 {
            // Nowhere to keep it: taken, and forgotten (such a track never has a pose).
            return Ok(Taken::Appended);
        }
        let restarted = after_newest.is_some_and(|d| d > lead_i32(MAX_POSE_GAP_US));
        if restarted {
            self.clear();
        }
        if self.len == N {
            self.head = self.slot(1);
            self.len -= 1;
        }
        let i = self.slot(self.len);
        if let (Some(s), Some(p)) = (self.stamps.get_mut(i), self.poses.get_mut(i)) {
            *s = stamp_us;
            *p = pose;
            self.len += 1;
        }
        Ok(if restarted {
            Taken::Restarted
        } else {
            Taken::Appended
        })
    }

    /// The pose at `t_us` (µs, wrapping) and how it was found.
    ///
    /// # Errors
    /// The track is empty, `t_us` is earlier than its oldest pose, or more than
    /// [`MAX_EXTRAPOLATION_US`] after its newest.
    pub fn at(&self, t_us: u32) -> Result<(Pose, Placement), NoPose> {
        let Some((newest_s, newest)) = self.newest() else {
            return Err(NoPose::Empty);
        };
        let past_newest = later_by(t_us, newest_s);
        if past_newest > 0 {
            if past_newest > lead_i32(MAX_EXTRAPOLATION_US) {
                return Err(NoPose::TooLate);
            }
            return Ok(match self.entry(self.len.saturating_sub(2)) {
                Some((s, p)) if self.len >= 2 => (
                    interpolate(&p, &newest, t_us.wrapping_sub(s), newest_s.wrapping_sub(s)),
                    Placement::Extrapolated,
                ),
                _ => (newest, Placement::Held),
            });
        }
        // Newest first: returns are mostly timed near the newest pose.
        let mut k = self.len - 1;
        let mut later = (newest_s, newest);
        loop {
            let Some((s, p)) = self.entry(k) else {
                return Err(NoPose::BeforeOldest);
            };
            let after = later_by(t_us, s);
            if after == 0 {
                return Ok((p, Placement::Interpolated));
            }
            if after > 0 {
                let (b_s, b) = later;
                return Ok((
                    interpolate(&p, &b, t_us.wrapping_sub(s), b_s.wrapping_sub(s)),
                    Placement::Interpolated,
                ));
            }
            later = (s, p);
            k = k.checked_sub(1).ok_or(NoPose::BeforeOldest)?;
        }
    }
}

/// How much later `b` is than `a`, µs: their wrapping difference read as an `i32`.
#[allow(clippy::cast_possible_wrap)]
const fn later_by(b: u32, a: u32) -> i32 {
    b.wrapping_sub(a) as i32
}

/// A bound of this module (all below 2³¹) as an `i32`.
#[allow(clippy::cast_possible_wrap)]
const fn lead_i32(us: u32) -> i32 {
    us as i32
}

/// `a + (b − a)·d/span` component by component (see the [module documentation](self)): one
/// division; `d` and `span` in µs, `span > 0` (0 gives `a`).
fn interpolate(a: &Pose, b: &Pose, d: u32, span: u32) -> Pose {
    if span == 0 {
        return *a;
    }
    // d < 2³² so d·2³² < 2⁶⁴; the quotient by span ≥ 1 fits a u64.
    let f = crate::wide::div_rem_u64_u32(u64::from(d) << 32, span).0;
    let f = i128::from(f);
    // |Δ| < 2³³ and f < 2⁶⁴: the product is below 2⁹⁷.
    let step = |delta: i64| -> i128 { (i128::from(delta) * f + (1 << 31)) >> 32 };
    let metres = |a: Meters, b: Meters| -> Meters {
        let delta = i64::from(b.to_bits()) - i64::from(a.to_bits());
        let v = i128::from(a.to_bits()) + step(delta);
        Meters::from_bits(i32::try_from(v).unwrap_or(if v < 0 { i32::MIN } else { i32::MAX }))
    };
    let angle = |a: FineAngle, b: FineAngle| -> FineAngle {
        let delta = i64::from(later_by(b.to_bits(), a.to_bits()));
        // The angle wraps: keep the low 32 bits of the turn.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let turn = step(delta) as u32;
        a.wrapping_add(FineAngle::from_bits(turn))
    };
    Pose {
        x: metres(a.x, b.x),
        y: metres(a.y, b.y),
        z: metres(a.z, b.z),
        roll: angle(a.roll, b.roll),
        pitch: angle(a.pitch, b.pitch),
        yaw: angle(a.yaw, b.yaw),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::XorShift;
    extern crate std;

    fn m(v: f64) -> Meters {
        Meters::from_num(v)
    }

    fn deg(d: f64) -> FineAngle {
        FineAngle::from_bits((d / 360.0 * 4_294_967_296.0).rem_euclid(4_294_967_296.0) as u32)
    }

    fn pose(x: f64, y: f64, yaw_deg: f64) -> Pose {
        Pose {
            x: m(x),
            y: m(y),
            yaw: deg(yaw_deg),
            ..Pose::IDENTITY
        }
    }

    #[test]
    fn interpolation_is_exact_at_the_stamps_and_halfway_between() {
        let mut t = PoseTrack::<4>::new();
        let a = pose(1.0, -2.0, 10.0);
        let b = pose(3.0, 2.0, 30.0);
        assert_eq!(t.push(1_000, a, 0), Ok(Taken::Appended));
        assert_eq!(t.push(21_000, b, 0), Ok(Taken::Appended));
        assert_eq!(t.at(1_000), Ok((a, Placement::Interpolated)));
        assert_eq!(t.at(21_000), Ok((b, Placement::Interpolated)));
        let (mid, how) = t.at(11_000).unwrap();
        assert_eq!(how, Placement::Interpolated);
        assert_eq!(mid.x, m(2.0));
        assert_eq!(mid.y, m(0.0));
        assert_eq!(mid.z, Meters::ZERO);
        // 20° in 2⁻³² turn is not an integer; halfway lies within one LSB of 20°.
        assert!(mid.yaw.to_bits().abs_diff(deg(20.0).to_bits()) <= 1);
        let (quarter, _) = t.at(6_000).unwrap();
        assert_eq!(quarter.x, m(1.5));
        assert_eq!(quarter.y, m(-1.0));
        assert_eq!(t.at(999), Err(NoPose::BeforeOldest));
    }

    #[test]
    fn the_microsecond_clock_may_wrap_inside_the_track() {
        let mut t = PoseTrack::<4>::new();
        let s0 = u32::MAX - 9_999; // 10 ms before the wrap
        t.push(s0, pose(0.0, 0.0, 0.0), s0).unwrap();
        t.push(s0.wrapping_add(20_000), pose(2.0, 0.0, 0.0), s0)
            .unwrap();
        // 5 ms before the wrap and 5 ms after it.
        assert_eq!(t.at(s0.wrapping_add(5_000)).unwrap().0.x, m(0.5));
        assert_eq!(t.at(5_000).unwrap().0.x, m(1.5));
        assert_eq!(t.at(s0.wrapping_sub(1)), Err(NoPose::BeforeOldest));
        // Extrapolated across nothing more: 10 ms after the newest (at 10 000 past the wrap).
        let (p, how) = t.at(20_000).unwrap();
        assert_eq!(how, Placement::Extrapolated);
        assert_eq!(p.x, m(3.0));
        // A stamp "before" the newest in wrapping terms is refused although larger as u32.
        assert_eq!(
            t.push(u32::MAX, pose(0.0, 0.0, 0.0), 0),
            Err(PoseRefusal::NotNewer)
        );
    }

    #[test]
    fn angles_take_the_shorter_arc_across_half_a_turn() {
        let mut t = PoseTrack::<4>::new();
        // From 170° to −170°: 20° through 180°, not 340° back through 0°.
        let mut a = pose(0.0, 0.0, 170.0);
        a.roll = deg(-179.0);
        a.pitch = deg(1.0);
        let mut b = pose(0.0, 0.0, -170.0);
        b.roll = deg(179.0);
        b.pitch = deg(-1.0);
        t.push(0, a, 0).unwrap();
        t.push(10_000, b, 0).unwrap();
        let (mid, _) = t.at(5_000).unwrap();
        let near = |got: FineAngle, want: f64| {
            let d = got.wrapping_sub(deg(want)).to_bits() as i32;
            assert!(d.abs() <= 1, "{} vs {want}", got.to_degrees_f32());
        };
        near(mid.yaw, 180.0);
        near(mid.roll, 180.0);
        near(mid.pitch, 0.0);
        let (q, _) = t.at(2_500).unwrap();
        near(q.yaw, 175.0);
        near(q.roll, -179.5);
    }

    #[test]
    fn poses_more_than_a_second_old_are_refused_across_the_wrap() {
        let mut t = PoseTrack::<4>::new();
        // The device's clock just past its wrap; a pose stamped before it.
        let now = 200_000_u32;
        let old = now.wrapping_sub(1_000_001);
        assert_eq!(
            t.push(old, pose(0.0, 0.0, 0.0), now),
            Err(PoseRefusal::TooOld)
        );
        assert!(t.is_empty());
        assert_eq!(
            t.push(old.wrapping_add(1), pose(0.0, 0.0, 0.0), now),
            Ok(Taken::Appended)
        );
        // A stamp of a clock the device no longer runs (sent before a reboot): refused.
        let mut t = PoseTrack::<4>::new();
        assert_eq!(
            t.push(u32::MAX - 1_500_000, pose(0.0, 0.0, 0.0), 1_000_000_000),
            Err(PoseRefusal::TooOld)
        );
    }

    #[test]
    fn out_of_order_and_far_ahead_poses_are_refused() {
        let mut t = PoseTrack::<4>::new();
        let now = 5_000_000;
        assert_eq!(
            t.push(now + 1_000_001, pose(0.0, 0.0, 0.0), now),
            Err(PoseRefusal::TooFarAhead)
        );
        assert_eq!(
            t.push(now + 1_000_000, pose(0.0, 0.0, 0.0), now),
            Ok(Taken::Appended)
        );
        assert_eq!(
            t.push(now + 1_000_000, pose(1.0, 0.0, 0.0), now),
            Err(PoseRefusal::NotNewer)
        );
        assert_eq!(
            t.push(now, pose(1.0, 0.0, 0.0), now),
            Err(PoseRefusal::NotNewer)
        );
        assert_eq!(t.len(), 1);
        assert_eq!(t.newest().unwrap().1, pose(0.0, 0.0, 0.0));
        // Long past stamps are refused (`poses_more_than_a_second_old_are_refused_across_the_wrap`);
        // a second is not long.
        let mut u = PoseTrack::<4>::new();
        assert_eq!(
            u.push(0, pose(0.0, 0.0, 0.0), now),
            Err(PoseRefusal::TooOld)
        );
        assert_eq!(
            u.push(now - 1_000_000, pose(0.0, 0.0, 0.0), now),
            Ok(Taken::Appended)
        );
    }

    #[test]
    fn a_gap_restarts_the_track() {
        let mut t = PoseTrack::<4>::new();
        t.push(0, pose(0.0, 0.0, 0.0), 0).unwrap();
        t.push(500_000, pose(1.0, 0.0, 0.0), 0).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t.at(250_000).unwrap().0.x, m(0.5));
        assert_eq!(
            t.push(1_000_001, pose(5.0, 0.0, 0.0), 1_000_000),
            Ok(Taken::Restarted)
        );
        assert_eq!(t.len(), 1);
        assert_eq!(t.at(750_000), Err(NoPose::BeforeOldest));
        // One pose: held for up to the extrapolation bound, then nothing.
        assert_eq!(t.at(1_050_000), Ok((pose(5.0, 0.0, 0.0), Placement::Held)));
        assert_eq!(t.at(1_100_001), Ok((pose(5.0, 0.0, 0.0), Placement::Held)));
        assert_eq!(t.at(1_100_002), Err(NoPose::TooLate));
        t.clear();
        assert_eq!(t.at(1_000_001), Err(NoPose::Empty));
    }

    #[test]
    fn extrapolation_follows_the_last_two_poses_up_to_its_bound() {
        let mut t = PoseTrack::<4>::new();
        t.push(0, pose(0.0, 0.0, 0.0), 0).unwrap();
        t.push(20_000, pose(0.0, 0.0, 0.0), 0).unwrap();
        t.push(40_000, pose(0.02, 0.0, 1.0), 0).unwrap();
        let (p, how) = t.at(140_000).unwrap();
        assert_eq!(how, Placement::Extrapolated);
        assert_eq!(p.x.to_bits(), 6 * m(0.02).to_bits());
        // 6 × the 1° pose's own rounding, within a few LSB of 6°.
        assert!(p.yaw.to_bits().abs_diff(deg(6.0).to_bits()) <= 6);
        assert_eq!(t.at(140_001), Err(NoPose::TooLate));
        // Far ahead in wrapping terms is "before the oldest", not extrapolated.
        assert_eq!(t.at(40_000 + (1 << 31)), Err(NoPose::BeforeOldest));
    }

    #[test]
    fn a_full_track_drops_its_oldest() {
        let mut t = PoseTrack::<3>::new();
        for k in 0..5_u32 {
            t.push(k * 20_000, pose(f64::from(k), 0.0, 0.0), 0).unwrap();
        }
        assert_eq!(t.len(), 3);
        assert_eq!(t.oldest().unwrap().0, 40_000);
        assert_eq!(t.newest().unwrap().0, 80_000);
        assert_eq!(t.at(39_999), Err(NoPose::BeforeOldest));
        assert_eq!(t.at(50_000).unwrap().0.x, m(2.5));
        assert_eq!(t.at(70_000).unwrap().0.x, m(3.5));
        // A track of no slots takes poses and keeps none.
        let mut none = PoseTrack::<0>::new();
        assert_eq!(none.push(1, Pose::IDENTITY, 0), Ok(Taken::Appended));
        assert_eq!(none.at(1), Err(NoPose::Empty));
    }

    #[test]
    fn positions_saturate_when_extrapolated_past_the_bounds() {
        let mut t = PoseTrack::<2>::new();
        let far = Pose {
            x: Meters::from_bits(i32::MAX - 10),
            ..Pose::IDENTITY
        };
        t.push(0, Pose::IDENTITY, 0).unwrap();
        t.push(1, far, 0).unwrap();
        assert_eq!(t.at(100_001).unwrap().0.x, Meters::MAX);
    }

    /// Random tracks of random poses against the rule computed in f64 from its definition:
    /// every component within one LSB (interpolated) or a few (extrapolated).
    #[test]
    fn random_tracks_agree_with_the_rule_in_f64() {
        let mut rng = XorShift(0x5EED_7AC4_0001);
        for _ in 0..400 {
            let mut t = PoseTrack::<8>::new();
            let mut s = rng.next() as u32;
            let first = s;
            let mut kept = std::vec::Vec::new();
            for _ in 0..(1 + rng.below(10)) {
                let p = Pose {
                    x: Meters::from_bits((rng.next() as i32) >> 2),
                    y: Meters::from_bits((rng.next() as i32) >> 8),
                    z: Meters::from_bits((rng.next() as i32) >> 12),
                    roll: FineAngle::from_bits(rng.next() as u32),
                    pitch: FineAngle::from_bits(rng.next() as u32),
                    yaw: FineAngle::from_bits(rng.next() as u32),
                };
                assert_eq!(t.push(s, p, first), Ok(Taken::Appended));
                kept.push((s, p));
                s = s.wrapping_add(1 + rng.below(100_000) as u32);
            }
            let kept = &kept[kept.len().saturating_sub(8)..];
            let span = kept.last().unwrap().0.wrapping_sub(kept[0].0);
            for _ in 0..50 {
                let off = rng.below(u64::from(span) + 100_001) as u32;
                let tt = kept[0].0.wrapping_add(off);
                let (got, how) = t.at(tt).unwrap();
                // The bracketing pair (or the last two), from the list, in f64.
                let n = kept.len();
                let i = match kept
                    .iter()
                    .rposition(|(s, _)| s.wrapping_sub(kept[0].0) <= off)
                {
                    Some(i) if i + 1 < n => i,
                    _ => n.saturating_sub(2),
                };
                if n == 1 {
                    assert_eq!((got, how), (kept[0].1, Placement::Held));
                    continue;
                }
                let (sa, a) = kept[i];
                let (sb, b) = kept[i + 1];
                let f = f64::from(tt.wrapping_sub(sa)) / f64::from(sb.wrapping_sub(sa));
                let extrapolated = off > span;
                assert_eq!(how == Placement::Extrapolated, extrapolated);
                let tol = if extrapolated { 1.0 + f } else { 1.0 };
                let lin = |a: i32, b: i32| f64::from(a) + (f64::from(b) - f64::from(a)) * f;
                for (g, a, b) in [(got.x, a.x, b.x), (got.y, a.y, b.y), (got.z, a.z, b.z)] {
                    let want =
                        lin(a.to_bits(), b.to_bits()).clamp(-2_147_483_648.0, 2_147_483_647.0);
                    assert!(
                        (f64::from(g.to_bits()) - want).abs() <= tol,
                        "{g:?} {want} {f}"
                    );
                }
                for (g, a, b) in [
                    (got.roll, a.roll, b.roll),
                    (got.pitch, a.pitch, b.pitch),
                    (got.yaw, a.yaw, b.yaw),
                ] {
                    let d = f64::from(b.to_bits().wrapping_sub(a.to_bits()) as i32);
                    let want = (f64::from(a.to_bits()) + d * f).rem_euclid(4_294_967_296.0);
                    let err = (f64::from(g.to_bits()) - want).rem_euclid(4_294_967_296.0);
                    let err = err.min(4_294_967_296.0 - err);
                    assert!(err <= tol, "{g:?} {want} {f}");
                }
            }
        }
    }
}
