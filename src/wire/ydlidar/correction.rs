//! The X4/X2 second-level angle correction in integer arithmetic.

use crate::angle::FineAngle;

/// Which angle correction [`YdlidarPacket::returns_with`](super::YdlidarPacket::returns_with)
/// applies after the first-level interpolation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YdlidarAngleCorrection {
    /// The manuals' second-level analysis (X4 and X2): add
    /// `atan(21.8·(155.3 − d)/(155.3·d))` degrees for a distance d ≠ 0
    /// ([`ydlidar_angle_correction`]).
    #[default]
    SecondLevel,
    /// No correction: the first-level angles alone (for firmware that corrects on board).
    Off,
}

/// Segments of the arctangent table over [0, 1], as a power of two.
const SEGMENTS_LOG2: u32 = 8;
/// Segments of the arctangent table over [0, 1]: 256.
const SEGMENTS: usize = 1 << SEGMENTS_LOG2;
/// Fractional bits of the table argument t ∈ [0, 1].
const T_BITS: u32 = 30;
/// Bits of t below the table index.
const FRAC_BITS: u32 = T_BITS - SEGMENTS_LOG2;
/// A quarter turn in Q0.32 turns.
const QUARTER_TURN: u64 = 1 << 30;

/// `atan(k/256)` as a fraction of a turn, Q0.32, rounded to nearest, k = 0 ..= 256
/// (`ATAN_TURNS[256]` = 2²⁹, an eighth of a turn).
const ATAN_TURNS: [u32; SEGMENTS + 1] = atan_table();

/// Builds [`ATAN_TURNS`] at compile time with Euler's series
/// `atan x = Σₙ (2ⁿ n!)²/(2n+1)! · x^(2n+1)/(1+x²)^(n+1)`, whose terms shrink by at least
/// half for x ≤ 1: 60 terms leave an error below 10⁻¹⁸.
const fn atan_table() -> [u32; SEGMENTS + 1] {
    let mut table = [0_u32; SEGMENTS + 1];
    let mut k = 0;
    while k <= SEGMENTS {
        let x = k as f64 / SEGMENTS as f64;
        let y = x * x / (1.0 + x * x);
        let mut term = x / (1.0 + x * x);
        let mut sum = term;
        let mut n = 1;
        while n < 60 {
            term = term * y * (2.0 * n as f64) / (2.0 * n as f64 + 1.0);
            sum += term;
            n += 1;
        }
        let turns = sum / core::f64::consts::TAU * 4_294_967_296.0;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let raw = (turns + 0.5) as u32;
        if let Some((_, rest)) = table.split_at_mut_checked(k) {
            if let Some(slot) = rest.first_mut() {
                *slot = raw;
            }
        }
        k += 1;
    }
    table
}

/// `atan t` in Q0.32 turns for `t = t_q30 / 2³⁰ ∈ [0, 1]`, by linear interpolation in
/// [`ATAN_TURNS`] (error ≤ h²/8 · max|atan''| = 0.6495/(8·256²) rad ≈ 1.24·10⁻⁶ rad, plus
/// the table's rounding).
fn atan_unit(t_q30: u64) -> u64 {
    let t = t_q30.min(1 << T_BITS);
    let index = usize::try_from(t >> FRAC_BITS).unwrap_or(SEGMENTS);
    let frac = t & ((1 << FRAC_BITS) - 1);
    let a = u64::from(ATAN_TURNS.get(index).copied().unwrap_or(1 << 29));
    let b = u64::from(ATAN_TURNS.get(index + 1).copied().unwrap_or(1 << 29));
    // The table increases: b ≥ a, and (b − a)·frac < 2²¹·2²² fits easily.
    a + ((b.saturating_sub(a) * frac + (1 << (FRAC_BITS - 1))) >> FRAC_BITS)
}

/// The X4/X2 second-level correction for a sample `si` (distance d = si/4 mm):
/// `atan(21.8·(155.3 − d)/(155.3·d))` as a signed fraction of a turn (a [`FineAngle`] whose
/// bits are the two's complement of a negative correction), to be added to the first-level
/// angle; [`FineAngle::ZERO`] for `si = 0` (no return). Integer arithmetic only: one 64-bit
/// division and one table interpolation. Its error against `f64` stays below the bound the
/// unit tests hold over every `si` (see [`YDLIDAR_CORRECTION_MAX_ERROR_DEG`]).
///
/// With d = si/4: `21.8·(155.3 − d)/(155.3·d) = (677 108 − 1 090·si)/(7 765·si)` exactly.
#[must_use]
pub fn ydlidar_angle_correction(si: u16) -> FineAngle {
    if si == 0 {
        return FineAngle::ZERO;
    }
    let si = i64::from(si);
    let numerator = 677_108 - 1_090 * si;
    let denominator = 7_765 * si;
    let magnitude = numerator.unsigned_abs();
    let den = denominator.unsigned_abs();
    // |numerator| < 2²⁷ and den < 2²⁹, so the shifted operands stay below 2⁵⁹.
    let turns = if magnitude <= den {
        atan_unit(((magnitude << T_BITS) + den / 2) / den)
    } else {
        QUARTER_TURN - atan_unit(((den << T_BITS) + magnitude / 2) / magnitude)
    };
    #[allow(clippy::cast_possible_truncation)]
    let bits = turns as u32;
    FineAngle::from_bits(if numerator < 0 {
        bits.wrapping_neg()
    } else {
        bits
    })
}

/// The largest error of [`ydlidar_angle_correction`] against the `f64` formula, degrees: the
/// unit test measures 7.075·10⁻⁵° (at si = 116) over every sample value 1..=65 535 and holds
/// it below this bound.
pub const YDLIDAR_CORRECTION_MAX_ERROR_DEG: f64 = 8.0e-5;

#[cfg(test)]
mod tests {
    use super::*;

    fn signed_degrees(a: FineAngle) -> f64 {
        f64::from(a.to_bits() as i32) * 360.0 / 4_294_967_296.0
    }

    fn reference_degrees(si: u16) -> f64 {
        let d = f64::from(si) / 4.0;
        (21.8 * (155.3 - d) / (155.3 * d)).atan().to_degrees()
    }

    #[test]
    fn table_is_correctly_rounded() {
        for (k, &v) in ATAN_TURNS.iter().enumerate() {
            let want =
                ((k as f64 / 256.0).atan() / core::f64::consts::TAU * 4_294_967_296.0).round();
            assert_eq!(f64::from(v), want, "{k}");
        }
        assert_eq!(ATAN_TURNS[0], 0);
        assert_eq!(ATAN_TURNS[256], 1 << 29);
    }

    #[test]
    fn error_against_f64_over_every_sample() {
        let mut worst = (0.0_f64, 0_u16);
        for si in 1..=u16::MAX {
            let err = (signed_degrees(ydlidar_angle_correction(si)) - reference_degrees(si)).abs();
            if err > worst.0 {
                worst = (err, si);
            }
        }
        // Measured: 7.075·10⁻⁵° at si = 116 (printed with --nocapture); the bound is that,
        // rounded up.
        std::println!(
            "worst correction error {:.3e}° at si = {}",
            worst.0,
            worst.1
        );
        assert!(
            worst.0 <= YDLIDAR_CORRECTION_MAX_ERROR_DEG,
            "{:.3e}° at si = {}",
            worst.0,
            worst.1
        );
    }

    extern crate std;

    #[test]
    fn manual_values() {
        assert_eq!(ydlidar_angle_correction(0), FineAngle::ZERO);
        // d = 155.3 mm is not a quarter-millimetre sample; at si = 621 (155.25 mm) the
        // argument is (677 108 − 676 890)/(7 765·621) = 218/4 822 065 ≈ 4.5·10⁻⁵ → 0.0026°.
        let c = signed_degrees(ydlidar_angle_correction(621));
        assert!((c - 0.002_590_3).abs() < 1e-4, "{c}");
        // The X4 manual's worked example, Distance = 1 000 mm (si = 4 000):
        // 21.8·(155.3 − 1 000)/(155.3·1 000) = −18 414.46/155 300 = −0.118 573 47,
        // atan → −0.118 023 rad = −6.762 19°.
        let c = signed_degrees(ydlidar_angle_correction(4000));
        assert!((c + 6.762_186).abs() < 1e-4, "{c}");
        // The manual's distance example, Si = 0x6FE5 (7 161.25 mm):
        // 21.8·(155.3 − 7 161.25)/(155.3·7 161.25) = −152 729.71/1 112 142.1 = −0.137 329,
        // atan → −7.819 48°.
        let c = signed_degrees(ydlidar_angle_correction(0x6FE5));
        assert!((c + 7.819_478).abs() < 1e-4, "{c}");
        // si = 1 (0.25 mm): argument (677 108 − 1 090)/7 765 = 87.06, atan → 89.342°.
        let c = signed_degrees(ydlidar_angle_correction(1));
        assert!((c - 89.341_9).abs() < 1e-3, "{c}");
    }
}
