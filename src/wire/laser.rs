//! What every spinning-lidar format of [`crate::wire`] decodes to, and what they share.
//!
//! - [`LaserReturn`]: one return as the sensor reports it, in the sensor's own angle
//!   convention.
//! - [`LidarCommand`]: a request to a lidar, encoded in full into a small fixed buffer, so a
//!   driver (`crate::drivers::lidar::send`) writes it to any `embedded_io::Write`.
//!
//! # Angle convention
//! The LDROBOT LD06/LD19/STL-19P, the Slamtec RPLIDARs and the YDLIDAR X4/X2 all count their
//! angle **clockwise seen from above** (from the top cover, the connector side down), from the
//! direction each manual calls 0°. A [`LaserReturn::angle`] keeps that convention: it is the
//! manual's angle, as a fraction of a turn. The geometry counts counter-clockwise (right-hand
//! rule about the up axis); turning a sensor angle into a geometry angle (`angle.reversed()`
//! plus the mounting offset) is the mount's job, not this module's.

use crate::angle::FineAngle;

/// One laser return as a spinning lidar reports it.
///
/// - `angle`: the direction of the return in the scanner's own convention (clockwise seen
///   from above, from the manual's 0°; see the [module documentation](self)), as a fraction
///   of a turn, after whatever per-format interpolation and correction the manual defines.
/// - `range_mm`: the distance in millimetres, rounded to the nearest millimetre where the
///   sensor reports finer units; 0 where the sensor reports no return (the three formats use
///   0 for "no measurement"). At most 65 535 for every format here.
/// - `quality`: the intensity or quality value where the format carries one (LD06: intensity
///   0..=255; RPLIDAR standard scan: quality 0..=63), `None` where it does not (RPLIDAR
///   express capsules, YDLIDAR X4/X2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LaserReturn {
    /// Direction, in the sensor's own clockwise convention, as a fraction of a turn.
    pub angle: FineAngle,
    /// Distance, millimetres; 0 = no return.
    pub range_mm: u32,
    /// Intensity or quality, where the format has one.
    pub quality: Option<u8>,
}

/// The longest request any [`LidarCommand`] encodes to, bytes (RPLIDAR EXPRESS_SCAN: 9).
pub const LIDAR_COMMAND_MAX_LEN: usize = 9;

/// A request a host sends to a lidar: a few bytes, known in full before sending.
///
/// Implemented by [`crate::wire::rplidar::RplidarRequest`] and
/// [`crate::wire::ydlidar::YdlidarCommand`]; `crate::drivers::lidar::send` writes one to an
/// `embedded_io::Write`.
pub trait LidarCommand {
    /// Writes the request's bytes to the front of `out` and returns how many (1 ..=
    /// [`LIDAR_COMMAND_MAX_LEN`]). Never fails: every request fits the buffer.
    fn encode(&self, out: &mut [u8; LIDAR_COMMAND_MAX_LEN]) -> usize;
}

/// `numerator / denominator` of a turn as a [`FineAngle`], rounded to the nearest 2⁻³² turn
/// (ties up), modulo one turn: exact to the LSB for every `numerator < 2⁹⁰` and
/// `0 < denominator < 2⁶⁴`. A zero denominator gives [`FineAngle::ZERO`].
pub(crate) fn turn_fraction(numerator: u64, denominator: u64) -> FineAngle {
    if denominator == 0 {
        return FineAngle::ZERO;
    }
    // Every caller's numerator is below 2³² (a turn in wire units times a step count), so
    // the scaled value fits a u64 and the division is a 64-bit one; u128 otherwise.
    if numerator >> 32 == 0 {
        if let Some(scaled) = (numerator << 32).checked_add(denominator / 2) {
            // A 32-bit denominator (every lidar's): 32-bit divisions where the core has them.
            let quotient = match u32::try_from(denominator) {
                Ok(d) => crate::wide::div_rem_u64_u32(scaled, d).0,
                Err(_) => scaled / denominator,
            };
            #[allow(clippy::cast_possible_truncation)]
            return FineAngle::from_bits(quotient as u32);
        }
    }
    let scaled = (u128::from(numerator) << 32) + u128::from(denominator / 2);
    let turns = scaled / u128::from(denominator);
    // Modulo one turn: the low 32 bits.
    #[allow(clippy::cast_possible_truncation)]
    let bits = turns as u32;
    FineAngle::from_bits(bits)
}

/// `turn_fraction(n, 45·2³²⁻ˢ)` for `1 ≤ s ≤ 26`, in 32-bit words: the angle of `n` units
/// of 1/(45·2³²⁻ˢ) turn, as RPLIDAR angles are (degrees·64: s = 23; degrees·2¹⁶: s = 13).
/// The rounded quotient is `⌊(n·2ˢ + 22.5)/45⌋ = ⌊(n·2ˢ + 22)/45⌋` (n·2ˢ is an integer), and
/// with n = 45a + b it is `a·2ˢ + ⌊(b·2ˢ + 22)/45⌋` (b·2ˢ < 45·2²⁶ < 2³²), all modulo 2³²
/// as the angle is: a division by the constant 45 instead of a 64-bit one. Other `s` take
/// [`turn_fraction`].
pub(crate) fn turn_fraction_45ths(n: u32, s: u32) -> FineAngle {
    if !(1..=26).contains(&s) {
        let d = 45_u64 << 32_u32.saturating_sub(s).min(63);
        return turn_fraction(u64::from(n), d);
    }
    let (a, b) = (n / 45, n % 45);
    FineAngle::from_bits((a << s).wrapping_add(((b << s) + 22) / 45))
}

/// The angles `turn_fraction(first + k·step, denominator)` for k = 0, 1, 2, … in order, each
/// exactly as [`turn_fraction`] rounds it, by two divisions in all instead of one per
/// angle: the quotient and remainder of the first, and of the step, then one add and one
/// compare per angle (a packet's evenly spaced returns: an LD06's 12 per packet). In 32-bit
/// words: the angle is the quotient modulo 2³², and the remainders are below a 32-bit
/// denominator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TurnSteps {
    /// `⌊(first·2³² + ⌊d/2⌋ + k·step·2³²) / d⌋` for the next k, modulo 2³² (the angle modulo
    /// one turn).
    quotient: u32,
    /// The remainder that goes with it, `< d`.
    remainder: u32,
    /// `⌊step·2³² / d⌋` modulo 2³².
    step_quotient: u32,
    /// `step·2³² mod d`.
    step_remainder: u32,
    denominator: u32,
}

impl TurnSteps {
    /// The steps from `first` by `step` over `denominator`, all in the same units (e.g.
    /// centidegrees × steps); `None` when `denominator` is 0 or a value is 2³² or more
    /// (then [`turn_fraction`] per angle is the way: no lidar's packet comes near).
    pub(crate) fn new(first: u64, step: u64, denominator: u64) -> Option<Self> {
        let d = u32::try_from(denominator).ok().filter(|&d| d > 0)?;
        if first >> 32 != 0 || step >> 32 != 0 {
            return None;
        }
        let scaled = (first << 32).checked_add(u64::from(d / 2))?;
        // 32-bit divisions where the core has them.
        let (quotient, remainder) = crate::wide::div_rem_u64_u32(scaled, d);
        let (step_quotient, step_remainder) = crate::wide::div_rem_u64_u32(step << 32, d);
        // Modulo one turn: the low 32 bits.
        #[allow(clippy::cast_possible_truncation)]
        Some(Self {
            quotient: quotient as u32,
            remainder,
            step_quotient: step_quotient as u32,
            step_remainder,
            denominator: d,
        })
    }

    /// The current angle; then moves to the next.
    pub(crate) fn next_angle(&mut self) -> FineAngle {
        let angle = FineAngle::from_bits(self.quotient);
        self.quotient = self.quotient.wrapping_add(self.step_quotient);
        // remainder, step_remainder < d: the sum carries into the quotient at most once,
        // exactly when remainder ≥ d − step_remainder (no sum formed: it could pass 2³²).
        let room = self.denominator - self.step_remainder;
        if self.remainder >= room {
            self.remainder -= room;
            self.quotient = self.quotient.wrapping_add(1);
        } else {
            self.remainder += self.step_remainder;
        }
        angle
    }
}

/// `numerator / denominator` of a turn for a signed numerator, rounded to the nearest
/// 2⁻³² turn (ties up), reduced modulo one turn. A zero denominator gives
/// [`FineAngle::ZERO`].
pub(crate) fn signed_turn_fraction(numerator: i64, denominator: u64) -> FineAngle {
    if denominator == 0 {
        return FineAngle::ZERO;
    }
    let Ok(den) = i64::try_from(denominator) else {
        return FineAngle::ZERO;
    };
    // Reduce to one turn first: the fraction of a whole number of turns is 0 modulo 2³².
    let reduced = numerator.rem_euclid(den);
    #[allow(clippy::cast_sign_loss)]
    turn_fraction(reduced as u64, denominator)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::test_rng::XorShift;

    #[test]
    fn quarter_and_half_turns_are_exact() {
        assert_eq!(turn_fraction(1, 4), FineAngle::QUARTER);
        assert_eq!(turn_fraction(18_000, 36_000), FineAngle::HALF);
        assert_eq!(turn_fraction(36_000, 36_000), FineAngle::ZERO);
        assert_eq!(turn_fraction(5, 0), FineAngle::ZERO);
        assert_eq!(signed_turn_fraction(-1, 4), FineAngle::QUARTER.reversed());
        assert_eq!(signed_turn_fraction(-36_000 * 3, 36_000), FineAngle::ZERO);
        assert_eq!(signed_turn_fraction(7, 0), FineAngle::ZERO);
    }

    #[test]
    fn rounds_to_nearest() {
        // 1/3 turn = 1 431 655 765.33… LSB → 1 431 655 765; 2/3 → …530.67 → 2 863 311 531.
        assert_eq!(turn_fraction(1, 3).to_bits(), 1_431_655_765);
        assert_eq!(turn_fraction(2, 3).to_bits(), 2_863_311_531);
        // 0.01° = 2³²/36 000 = 119 304.647… LSB → 119 305.
        assert_eq!(turn_fraction(1, 36_000).to_bits(), 119_305);
        // The u64 and u128 paths agree (a numerator of 2³² takes the u128 one).
        assert_eq!(turn_fraction(1 << 32, 3 << 32), turn_fraction(1, 3));
        assert_eq!(turn_fraction(u64::MAX >> 32, u64::MAX).to_bits(), 1);
        assert_eq!(turn_fraction(7, u64::MAX), FineAngle::ZERO);
    }

    #[test]
    fn turn_steps_are_turn_fraction_at_every_step() {
        // The LD06's own case (11 steps over 36 000 centidegrees), the wrap past a turn, and
        // random firsts, steps and denominators of every size, 300 steps each.
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
        let mut next = move || rng.next();
        let mut cases = std::vec![(11 * 35_900, 220, 11 * 36_000), (0, 0, 1), (1, 1, 3)];
        for _ in 0..2_000 {
            let d = match next() % 3 {
                0 => next() % 1_000 + 1,
                1 => next() % (1 << 20) + 1,
                _ => next() >> (next() % 64).max(1),
            }
            .max(1);
            cases.push((next() >> 32, next() >> (32 + next() % 32), d));
        }
        for (first, step, d) in cases {
            let Some(mut steps) = TurnSteps::new(first, step, d) else {
                // Only for a denominator of 2³² or more, or where the first scaled value
                // passes 2⁶⁴ (turn_fraction's u128 path).
                assert!(d >> 32 != 0 || (first << 32).checked_add(d / 2).is_none());
                continue;
            };
            for k in 0..300_u64 {
                // first, step < 2³² and k < 300: the numerator fits a u64.
                let expected = turn_fraction(first + k * step, d);
                assert_eq!(
                    steps.next_angle(),
                    expected,
                    "{first} + {k}·{step} over {d}"
                );
            }
        }
        assert_eq!(TurnSteps::new(1, 1, 0), None);
        assert_eq!(TurnSteps::new(1 << 32, 1, 3), None);
        assert_eq!(TurnSteps::new(1, 1 << 32, 3), None);
        assert_eq!(TurnSteps::new(1, 1, 1 << 32), None);
        // Remainders near 2³²: the carry is taken without forming the sum.
        let d = u64::from(u32::MAX);
        let mut steps = TurnSteps::new(d - 1, d - 2, d).unwrap();
        for k in 0..300_u64 {
            assert_eq!(
                steps.next_angle(),
                turn_fraction(d - 1 + k * (d - 2), d),
                "{k}"
            );
        }
    }

    #[test]
    fn turn_fraction_45ths_is_turn_fraction() {
        // Every 16-bit numerator at the RPLIDAR's two scales, then random ones at every scale.
        for n in 0..=u32::from(u16::MAX) {
            for s in [13, 23] {
                assert_eq!(
                    turn_fraction_45ths(n, s),
                    turn_fraction(u64::from(n), 45 << (32 - s)),
                    "{n} at 2^{s}"
                );
            }
        }
        let mut rng = XorShift(0x1234_5678_9ABC_DEF1_u64);
        for _ in 0..200_000 {
            let r = rng.next();
            let n = (r >> 32) as u32 >> (r % 32);
            let s = (r % 26 + 1) as u32;
            assert_eq!(
                turn_fraction_45ths(n, s),
                turn_fraction(u64::from(n), 45 << (32 - s)),
                "{n} at 2^{s}"
            );
        }
        assert_eq!(
            turn_fraction_45ths(u32::MAX, 26),
            turn_fraction(u64::from(u32::MAX), 45 << 6)
        );
        assert_eq!(turn_fraction_45ths(7, 30), turn_fraction(7, 45 << 2));
    }
}
