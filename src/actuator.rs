//! What moves the scan plane, and its angle at any moment: the nodding servo's sweep model
//! ([`ServoSweep`]) and the interpolation between readings of an angle source
//! ([`AngleTrack`]). Pure and I/O-free: times are the board's microsecond clock (`u32`,
//! wrapping every 71.6 minutes), handed in; angles are [`FineAngle`]s read as signed
//! (`to_bits() as i32`, ±180°) where a sweep needs an order.
//!
//! # The servo model
//! A hobby servo (or any position-commanded actuator) driven by PWM is commanded along a
//! triangle wave: from `min` up to `max` at `rate` degrees per second, back down at the same
//! rate, and so on ([`ServoProfile`]). The servo is taken to follow its command with a
//! constant delay, `latency` (the PWM period, the servo's control loop and its mechanical
//! lag): its angle at time t is the command at t − latency. After the sweep is begun
//! ([`ServoSweep::begin`]) the command holds `min` for [`SERVO_SETTLE_US`] (the servo travels
//! there from wherever it was), so no angle is known ([`ServoSweep::estimate`] gives `None`)
//! until then. The model is exact integer arithmetic: phase in 2⁻⁴⁸ turn, rate in 2⁻⁴⁸ turn
//! per µs (rounded at configuration, relative error below 10⁻⁶ at 1 °/s).
//!
//! What the model cannot know: a servo that lags more (load, low supply) or overshoots at the
//! turns. An angle source on the axis (the AS5047P, a potentiometer) removes that error: the
//! board passes it to the core, which then prefers it to the model.
//!
//! # Readings of an angle source
//! An encoder is read when a chunk of laser bytes arrives; a packet's returns were measured
//! up to tens of milliseconds earlier. [`AngleTrack`] keeps the last two readings with their
//! times and gives the angle at any time between them by linear interpolation (and up to one
//! reading interval beyond them by extrapolation): exact while the actuator moves at a
//! constant rate, off by at most `rate × interval / 2` at a turn.

use crate::angle::FineAngle;

/// What moves the scan plane, as the setup says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Actuator {
    /// An actuator the co-processor does not command: its angle comes from the board's angle
    /// source (an encoder) or, failing that, from the host's PanAngle.
    #[default]
    External,
    /// A nodding servo the co-processor commands along this sweep; its angle comes from the
    /// board's angle source when there is one (feedback), else from the sweep model.
    Servo(ServoProfile),
}

/// How long a servo sweep holds its lower end after [`ServoSweep::begin`] before it starts:
/// 500 ms, enough for a hobby servo to cross 180° (about 0.3 s unloaded) and settle.
pub const SERVO_SETTLE_US: u32 = 500_000;

/// Readings of an [`AngleTrack`] more than this apart are not interpolated (the older is
/// stale): 200 ms.
pub const TRACK_MAX_GAP_US: u32 = 200_000;

/// 2⁴⁸ / (360 000 · 10⁶): milli-degrees per second to 2⁻⁴⁸ turn per µs, as the exact
/// fraction's numerator and denominator.
const RATE_NUM: u128 = 1 << 48;
const RATE_DEN: u128 = 360_000 * 1_000_000;

/// A nodding servo's sweep: its ends, its rate and its delay, validated
/// ([`crate::link::convert::frontend_config`] converts the host's Setup into one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoProfile {
    /// The lower end of the sweep, read as signed (−180° ..= 180°); below `max`.
    pub min: FineAngle,
    /// The upper end of the sweep, read as signed; above `min`.
    pub max: FineAngle,
    /// The sweep's rate, milli-degrees per second, 1 ..= 1 000 000 (0.001 ..= 1 000 °/s).
    pub rate_mdeg_per_s: u32,
    /// The servo's delay behind its command, µs (below 1 s).
    pub latency_us: u32,
}

impl ServoProfile {
    /// The span `max − min` in 2⁻³² turn (positive for a valid profile; 0 otherwise).
    #[must_use]
    pub const fn span_bits(&self) -> u64 {
        #[allow(clippy::cast_possible_wrap)]
        let (lo, hi) = (
            self.min.to_bits() as i32 as i64,
            self.max.to_bits() as i32 as i64,
        );
        if hi > lo {
            #[allow(clippy::cast_sign_loss)]
            let span = (hi - lo) as u64;
            span
        } else {
            0
        }
    }

    /// How long one way of the sweep takes, µs (0 for an invalid profile).
    #[must_use]
    pub fn half_period_us(&self) -> u32 {
        let rate = rate_q48(self.rate_mdeg_per_s);
        if rate == 0 {
            return 0;
        }
        u32::try_from((self.span_bits() << 16) / rate).unwrap_or(u32::MAX)
    }
}

/// A rate in milli-degrees per second as 2⁻⁴⁸ turn per µs, rounded (at most 2³⁰ for the
/// largest rate allowed).
fn rate_q48(mdeg_per_s: u32) -> u64 {
    let scaled = (u128::from(mdeg_per_s) * RATE_NUM + RATE_DEN / 2) / RATE_DEN;
    u64::try_from(scaled).unwrap_or(u64::MAX)
}

/// The commanded and the estimated angle of a servo swept by a [`ServoProfile`] (see the
/// [module documentation](self)). [`ServoSweep::OFF`], all zero bits, stands for no servo.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoSweep {
    profile: ServoProfile,
    /// Whether a profile is in force (not [`ServoSweep::OFF`]).
    on: bool,
    /// 2⁻⁴⁸ turn per µs.
    rate: u64,
    /// One whole period (up and down), 2⁻⁴⁸ turn: 2 · span · 2¹⁶.
    period: u64,
    /// Whether [`begin`](Self::begin) was called.
    begun: bool,
    /// Where the sweep's clock stands: the phase (2⁻⁴⁸ turn along the triangle, 0 = at `min`
    /// going up) at a time (µs).
    anchor_us: u32,
    anchor_phase: u64,
    /// Whether the settling hold is over (the anchor may then move).
    settled: bool,
}

impl ServoSweep {
    /// No servo: zero bits (a `const`-built co-processor holding it stays in `.bss`); it
    /// commands and estimates nothing.
    pub const OFF: Self = Self {
        profile: ServoProfile {
            min: FineAngle::ZERO,
            max: FineAngle::ZERO,
            rate_mdeg_per_s: 0,
            latency_us: 0,
        },
        on: false,
        rate: 0,
        period: 0,
        begun: false,
        anchor_us: 0,
        anchor_phase: 0,
        settled: false,
    };

    /// A sweep of `profile`, not begun: it commands nothing until [`begin`](Self::begin).
    #[must_use]
    pub fn new(profile: ServoProfile) -> Self {
        Self {
            profile,
            on: true,
            rate: rate_q48(profile.rate_mdeg_per_s),
            period: profile.span_bits() << 17,
            ..Self::OFF
        }
    }

    /// Whether a profile is in force (not [`ServoSweep::OFF`]).
    #[must_use]
    pub const fn is_on(&self) -> bool {
        self.on
    }

    /// The profile.
    #[must_use]
    pub const fn profile(&self) -> &ServoProfile {
        &self.profile
    }

    /// Whether [`begin`](Self::begin) was called.
    #[must_use]
    pub const fn begun(&self) -> bool {
        self.begun
    }

    /// Starts the sweep at `now_us`: the command holds `min` for [`SERVO_SETTLE_US`], then
    /// sweeps. A second call restarts it.
    pub fn begin(&mut self, now_us: u32) {
        self.begun = true;
        self.anchor_us = now_us.wrapping_add(SERVO_SETTLE_US);
        self.anchor_phase = 0;
        self.settled = false;
    }

    /// The phase at `t_us`, from the anchor (within ±2³¹ µs of it).
    fn phase_at(&self, t_us: u32) -> u64 {
        if self.period == 0 {
            return 0;
        }
        #[allow(clippy::cast_possible_wrap)]
        let dt = i128::from(t_us.wrapping_sub(self.anchor_us) as i32);
        // In i128 whatever the rate: |dt| ≤ 2³¹, the rate below 2⁶⁴, the period below 2⁵⁰.
        let p = (i128::from(self.anchor_phase) + dt * i128::from(self.rate))
            .rem_euclid(i128::from(self.period));
        u64::try_from(p).unwrap_or(0)
    }

    /// The angle at phase `p`: up from `min` in the first half, down from `max` in the second.
    fn angle_at(&self, p: u64) -> FineAngle {
        let half = self.period >> 1;
        // p and half are below 2⁵⁰: the offsets in 2⁻³² turn are below 2³⁴, and within the
        // span (below 2³²) by construction.
        #[allow(clippy::cast_possible_truncation)]
        if p < half {
            self.profile
                .min
                .wrapping_add(FineAngle::from_bits((p >> 16) as u32))
        } else {
            self.profile
                .max
                .wrapping_sub(FineAngle::from_bits(((p - half) >> 16) as u32))
        }
    }

    /// Moves the anchor forward (so that every time asked about stays within 2³¹ µs of it) and
    /// ends the settling hold once it is over; call it with the current time at least every
    /// half hour.
    fn advance(&mut self, now_us: u32) {
        if !self.begun {
            return;
        }
        #[allow(clippy::cast_possible_wrap)]
        let since = now_us.wrapping_sub(self.anchor_us) as i32;
        if !self.settled {
            // Settled one second after the hold: every packet still to come is later than it.
            if since > 1_000_000 {
                self.settled = true;
            }
        } else if since > 1 << 29 {
            self.anchor_phase = self.phase_at(now_us);
            self.anchor_us = now_us;
        }
    }

    /// The angle to command at `now_us` (begins the sweep if it was not): `min` during the
    /// settling hold, then the triangle wave.
    pub fn command(&mut self, now_us: u32) -> FineAngle {
        if !self.begun {
            self.begin(now_us);
        }
        self.advance(now_us);
        self.command_at(now_us).unwrap_or(self.profile.min)
    }

    /// The command at `t_us` (within 2³¹ µs of the last call), `None` before
    /// [`begin`](Self::begin).
    fn command_at(&self, t_us: u32) -> Option<FineAngle> {
        if !self.begun {
            return None;
        }
        #[allow(clippy::cast_possible_wrap)]
        if !self.settled && (t_us.wrapping_sub(self.anchor_us) as i32) < 0 {
            return Some(self.profile.min);
        }
        Some(self.angle_at(self.phase_at(t_us)))
    }

    /// The servo's estimated angle at `t_us`: the command at `t_us − latency`; `None` before
    /// the sweep was begun and during its settling hold. `t_us` must lie within a few seconds
    /// of the last [`command`](Self::command) or [`track`](Self::track).
    #[must_use]
    pub fn estimate(&self, t_us: u32) -> Option<FineAngle> {
        if !self.begun {
            return None;
        }
        #[allow(clippy::cast_possible_wrap)]
        if !self.settled && (t_us.wrapping_sub(self.anchor_us) as i32) < 0 {
            return None;
        }
        self.command_at(t_us.wrapping_sub(self.profile.latency_us))
    }

    /// Keeps the model's clock with the board's at `now_us` when nothing commands the servo
    /// (an emulated board: the model runs open loop); begins the sweep if it was not.
    pub fn track(&mut self, now_us: u32) {
        if !self.begun {
            self.begin(now_us);
        }
        self.advance(now_us);
    }
}

/// The last two readings of an angle source with their times, and the angle between them
/// (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AngleTrack {
    last: Option<(u32, FineAngle)>,
    prev: Option<(u32, FineAngle)>,
}

impl AngleTrack {
    /// No readings.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            last: None,
            prev: None,
        }
    }

    /// Forgets every reading.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Adds a reading taken at `t_us`; one at the same time as the last replaces it.
    pub fn push(&mut self, t_us: u32, angle: FineAngle) {
        match self.last {
            Some((t, _)) if t == t_us => {}
            last => self.prev = last,
        }
        self.last = Some((t_us, angle));
    }

    /// The last reading, if any.
    #[must_use]
    pub const fn last(&self) -> Option<(u32, FineAngle)> {
        self.last
    }

    /// The angle at `t_us`: interpolated between the two readings, extrapolated up to one
    /// reading interval beyond either (and held beyond that); the last reading alone when
    /// there is one, or the two are more than [`TRACK_MAX_GAP_US`] apart. `None` before the
    /// first reading. Between readings, the actuator is taken to have turned less than half
    /// a turn.
    #[must_use]
    pub fn at(&self, t_us: u32) -> Option<FineAngle> {
        let (t1, a1) = self.last?;
        let Some((t0, a0)) = self.prev else {
            return Some(a1);
        };
        let gap = t1.wrapping_sub(t0);
        if gap == 0 || gap > TRACK_MAX_GAP_US {
            return Some(a1);
        }
        let span = i64::from(gap);
        #[allow(clippy::cast_possible_wrap)]
        let d = i64::from(t_us.wrapping_sub(t0) as i32).clamp(-span, 2 * span);
        #[allow(clippy::cast_possible_wrap)]
        let delta = a1.wrapping_sub(a0).to_bits() as i32;
        // |delta| ≤ 2³¹, |d| ≤ 2·2¹⁸: the product is below 2⁵⁰. Where there is a 32-bit
        // divide instruction (ARMv7-M, told by its atomics) five of them beat the 64-bit
        // division's library call; on ARMv6-M each would be a call too, and the host divides
        // 64 bits natively.
        let bits = if cfg!(all(target_arch = "arm", target_has_atomic = "32")) {
            floor_product_quotient(delta, d, gap)
        } else {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            {
                (i64::from(delta) * d).div_euclid(span) as u32
            }
        };
        Some(a0.wrapping_add(FineAngle::from_bits(bits)))
    }
}

/// `⌊delta·d / gap⌋` modulo 2³² (an angle's bits), for `|d| < 2³¹` and `0 < gap < 2¹⁸` (a
/// track's readings are at most [`TRACK_MAX_GAP_US`] apart), exactly as the 64-bit
/// `(delta·d).div_euclid(gap)` truncated to 32 bits, but without a 64-bit division (a library
/// call on a Cortex-M): the product's magnitude (< 2⁶³) is divided 13 bits at a time, each
/// step a 32-bit division (the remainder stays below 2¹⁸, so `remainder·2¹³ + digit` fits),
/// keeping the quotient's low 32 bits. Other gaps take the 64-bit way.
fn floor_product_quotient(delta: i32, d: i64, gap: u32) -> u32 {
    let product = i64::from(delta).saturating_mul(d);
    if gap == 0 || gap >= 1 << 18 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        return product.div_euclid(i64::from(gap.max(1))) as u32;
    }
    let magnitude = product.unsigned_abs();
    let (mut quotient, mut remainder) = (0_u32, 0_u32);
    // 65 bits in five 13-bit digits, the highest first (the top digit holds bits 52..64).
    for shift in [52_u32, 39, 26, 13, 0] {
        #[allow(clippy::cast_possible_truncation)]
        let digit = ((magnitude >> shift) & 0x1FFF) as u32;
        let x = (remainder << 13) | digit;
        quotient = (quotient << 13) | (x / gap);
        remainder = x % gap;
    }
    if product >= 0 {
        quotient
    } else {
        // ⌊−m/g⌋ = −⌈m/g⌉.
        quotient
            .wrapping_add(u32::from(remainder != 0))
            .wrapping_neg()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::test_rng::XorShift;

    fn deg(d: f64) -> FineAngle {
        FineAngle::from_bits((d / 360.0 * 4_294_967_296.0).round() as i64 as u32)
    }

    fn signed_deg(a: FineAngle) -> f64 {
        f64::from(a.to_bits() as i32) * 360.0 / 4_294_967_296.0
    }

    fn profile() -> ServoProfile {
        ServoProfile {
            min: deg(-10.0),
            max: deg(50.0),
            rate_mdeg_per_s: 60_000,
            latency_us: 20_000,
        }
    }

    /// The triangle wave in f64, from the profile's definition.
    fn reference(p: &ServoProfile, since_start_s: f64) -> f64 {
        let (lo, hi) = (signed_deg(p.min), signed_deg(p.max));
        let span = hi - lo;
        // The rate as the model holds it (rounded to 2⁻⁴⁸ turn/µs): the commanded servo
        // follows the model, not the nominal rate (they differ by less than 10⁻⁸ at 60 °/s).
        let rate = rate_q48(p.rate_mdeg_per_s) as f64 * 360.0 / 2_f64.powi(48) * 1e6;
        assert!((rate * 1000.0 / f64::from(p.rate_mdeg_per_s) - 1.0).abs() < 1e-8);
        let travelled = (since_start_s * rate).rem_euclid(2.0 * span);
        if travelled < span {
            lo + travelled
        } else {
            hi - (travelled - span)
        }
    }

    #[test]
    fn the_sweep_follows_the_triangle_wave() {
        let p = profile();
        assert_eq!(p.half_period_us(), 1_000_000);
        let mut s = ServoSweep::new(p);
        assert_eq!(s.estimate(0), None);
        let t0 = 4_000_000_000_u32; // close to the clock's wrap
        assert_eq!(s.command(t0), p.min);
        assert_eq!(s.estimate(t0.wrapping_add(100_000)), None);
        let start = t0.wrapping_add(SERVO_SETTLE_US);
        let mut worst = 0.0_f64;
        // Two hours in 1.7 ms steps, across the clock's wrap and many anchor moves.
        let (mut t, mut elapsed_us) = (start, 0_u64);
        for _ in 0..4_000_000 {
            t = t.wrapping_add(1_777);
            elapsed_us += 1_777;
            let cmd = s.command(t);
            let since = elapsed_us as f64 / 1e6;
            let e = (signed_deg(cmd) - reference(&p, since)).abs();
            worst = worst.max(e);
            if let Some(est) = s.estimate(t) {
                if elapsed_us > u64::from(p.latency_us) {
                    let since = (elapsed_us - u64::from(p.latency_us)) as f64 / 1e6;
                    let e = (signed_deg(est) - reference(&p, since)).abs();
                    worst = worst.max(e);
                }
            }
        }
        // The wave's own 2⁻³² turn and the anchor moves: far below a microdegree.
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn settling_then_latency() {
        let p = profile();
        let mut s = ServoSweep::new(p);
        s.track(1_000);
        let start = 1_000 + SERVO_SETTLE_US;
        assert_eq!(s.estimate(start - 1), None);
        // During the latency after the hold, the servo still sits at min.
        assert_eq!(s.estimate(start), Some(p.min));
        assert_eq!(s.estimate(start + p.latency_us), Some(p.min));
        let later = s.estimate(start + p.latency_us + 500_000).unwrap();
        assert!(
            (signed_deg(later) - 20.0).abs() < 1e-6,
            "{}",
            signed_deg(later)
        );
        // The top, then down.
        let top = s.estimate(start + p.latency_us + 1_000_000).unwrap();
        assert!((signed_deg(top) - 50.0).abs() < 1e-6);
        let down = s.estimate(start + p.latency_us + 1_250_000).unwrap();
        assert!((signed_deg(down) - 35.0).abs() < 1e-6);
        // Restarting holds again.
        s.begin(start + 3_000_000);
        assert_eq!(s.estimate(start + 3_000_001), None);
    }

    #[test]
    fn degenerate_profiles_do_not_panic() {
        for p in [
            ServoProfile {
                max: deg(-10.0),
                ..profile()
            },
            ServoProfile {
                rate_mdeg_per_s: 0,
                ..profile()
            },
            ServoProfile {
                min: deg(-180.0),
                max: deg(179.999),
                rate_mdeg_per_s: u32::MAX,
                latency_us: u32::MAX,
            },
        ] {
            let mut s = ServoSweep::new(p);
            for t in (0..u32::MAX).step_by(99_991_777) {
                let _ = s.command(t);
                let _ = s.estimate(t);
            }
            let _ = p.half_period_us();
        }
    }

    #[test]
    fn the_track_interpolates_between_readings() {
        let mut track = AngleTrack::new();
        assert_eq!(track.at(5), None);
        track.push(1_000, deg(10.0));
        assert_eq!(track.at(0), Some(deg(10.0)));
        track.push(11_000, deg(11.0));
        let mid = signed_deg(track.at(6_000).unwrap());
        assert!((mid - 10.5).abs() < 1e-6, "{mid}");
        // Extrapolated up to one interval, held beyond.
        let before = signed_deg(track.at(0).unwrap());
        assert!((before - 9.9).abs() < 1e-6, "{before}");
        let far = signed_deg(track.at(100_000).unwrap());
        assert!((far - 12.0).abs() < 1e-6, "{far}");
        // Across 0° and the clock's wrap.
        let mut track = AngleTrack::new();
        track.push(u32::MAX - 999, deg(-0.5));
        track.push(9_000, deg(0.5));
        let mid = signed_deg(track.at(4_000).unwrap());
        assert!(mid.abs() < 1e-6, "{mid}");
        // Stale readings are not interpolated.
        let mut track = AngleTrack::new();
        track.push(0, deg(1.0));
        track.push(TRACK_MAX_GAP_US + 1, deg(2.0));
        assert_eq!(track.at(1_000), Some(deg(2.0)));
        track.clear();
        assert_eq!(track.last(), None);
    }

    #[test]
    fn the_interpolation_quotient_is_the_64_bit_floor_division() {
        let mut rng = XorShift(0xC0FF_EE00_1234_5678_u64);
        let mut next = move || rng.next();
        let mut cases: std::vec::Vec<(i32, i64, u32)> = std::vec![
            (i32::MIN, 2 * 200_000, 200_000),
            (i32::MIN, -200_000, 200_000),
            (i32::MAX, 2 * 200_000, 200_000),
            (-1, 1, 3),
            (1, -1, 3),
            (0, 5, 7),
            (7, 3, (1 << 18) - 1),
            (7, 3, 1 << 18),
            (5, 5, 0),
        ];
        for _ in 0..500_000 {
            let gap = (next() % 200_000) as u32 + 1;
            #[allow(clippy::cast_possible_truncation)]
            let delta = next() as i32 >> (next() % 32);
            let span = i64::from(gap);
            let d = (next() % (3 * span as u64 + 1)) as i64 - span;
            cases.push((delta, d, gap));
        }
        for (delta, d, gap) in cases {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let expected = (i64::from(delta) * d).div_euclid(i64::from(gap.max(1))) as u32;
            assert_eq!(
                floor_product_quotient(delta, d, gap),
                expected,
                "{delta}·{d}/{gap}"
            );
        }
    }
}
