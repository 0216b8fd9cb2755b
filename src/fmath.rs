//! Configuration-time `f32` maths for a target without `libm`: square root, arctangent,
//! exponential and natural logarithm, accurate to a few units in the last place.
//!
//! `micromath` 2.1's functions are fast approximations, too coarse for band edges and
//! log-odds increments (its `sqrt(2.0)` returns 1.5, its `atan(0.0175)` is 6 % low and its
//! `ln(2/3)` reads −0.51 for −0.405). So `sqrt` takes micromath's value as the seed of three
//! Newton steps, and the others reduce the argument and sum a short series. The unit tests
//! hold every function to a relative error below 2·10⁻⁶ against `f64`.
//!
//! None of this runs per point: only when a configuration changes.

use micromath::F32Ext;

/// `ln 2`, for range reduction.
const LN_2: f32 = core::f32::consts::LN_2;
/// `ln 2` split in two (Cody–Waite): the high part has few enough bits that `k·LN_2_HI` is
/// exact for |k| < 256, so reducing a large argument loses no precision.
const LN_2_HI: f32 = 0.693_145_75;
/// The rest of `ln 2` after [`LN_2_HI`].
const LN_2_LO: f32 = 1.428_606_8e-6;

/// √x for x ≥ 0 (0 for negative or NaN input).
#[must_use]
pub fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut y = F32Ext::sqrt(x);
    if y.is_nan() || y <= 0.0 {
        y = x;
    }
    for _ in 0..3 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// arctan(x), radians, for any finite x (NaN gives NaN).
///
/// No recursion: the two reductions (`atan(−x) = −atan(x)`, `atan(x) = π/2 − atan(1/x)` for
/// x > 1) are applied in a straight line around `atan_unit`.
#[must_use]
pub fn atan(x: f32) -> f32 {
    use core::f32::consts::FRAC_PI_2;
    if x.is_nan() {
        return x;
    }
    let negative = x < 0.0;
    let magnitude = if negative { -x } else { x };
    let positive = if magnitude > 1.0 {
        FRAC_PI_2 - atan_unit(1.0 / magnitude)
    } else {
        atan_unit(magnitude)
    };
    if negative {
        -positive
    } else {
        positive
    }
}

/// arctan(x) for 0 ≤ x ≤ 1 (and −0).
fn atan_unit(x: f32) -> f32 {
    // Halve the angle once: atan(x) = 2·atan(x / (1 + √(1 + x²))), so |t| ≤ tan(π/8) ≈ 0.414.
    let t = x / (1.0 + sqrt(1.0 + x * x));
    let t2 = t * t;
    // atan(t) = t − t³/3 + t⁵/5 − …; 10 terms leave < 0.414²¹/21 ≈ 4·10⁻¹⁰.
    let mut sum = 0.0_f32;
    let mut power = t;
    let mut sign = 1.0_f32;
    let mut denominator = 1.0_f32;
    for _ in 0..10 {
        sum += sign * power / denominator;
        power *= t2;
        sign = -sign;
        denominator += 2.0;
    }
    2.0 * sum
}

/// eˣ (0 below −87, +∞ above 88, NaN for NaN).
#[must_use]
pub fn exp(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x < -87.0 {
        return 0.0;
    }
    if x > 88.0 {
        return f32::INFINITY;
    }
    // x = k·ln2 + r with |r| ≤ ln2/2; eʳ by its Taylor series (|r|⁹/9! < 3·10⁻¹⁰).
    let k = F32Ext::floor(x / LN_2 + 0.5);
    let r = (x - k * LN_2_HI) - k * LN_2_LO;
    let mut term = 1.0_f32;
    let mut sum = 1.0_f32;
    let mut n = 1.0_f32;
    for _ in 0..9 {
        term *= r / n;
        sum += term;
        n += 1.0;
    }
    sum * pow2(k)
}

/// ln x for x > 0 (NaN for x ≤ 0 or NaN, +∞ for +∞).
#[must_use]
pub fn ln(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return f32::NAN;
    }
    if x.is_infinite() {
        return x;
    }
    // x = m·2ᵉ with m in [1/√2, √2); ln m = 2·atanh(s), s = (m − 1)/(m + 1), |s| ≤ 0.172.
    let mut e = 0.0_f32;
    let mut m = x;
    while m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1.0;
    }
    while m < core::f32::consts::FRAC_1_SQRT_2 {
        m *= 2.0;
        e -= 1.0;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut sum = 0.0_f32;
    let mut power = s;
    let mut denominator = 1.0_f32;
    for _ in 0..7 {
        sum += power / denominator;
        power *= s2;
        denominator += 2.0;
    }
    2.0 * sum + e * LN_2
}

/// 2ᵏ for an integral k in −126 ..= 127, built from the exponent bits.
fn pow2(k: f32) -> f32 {
    let k = k.clamp(-126.0, 127.0);
    // k is integral and within ±127 here, so the conversion is exact.
    #[allow(clippy::cast_possible_truncation)]
    let biased = (k as i32) + 127;
    #[allow(clippy::cast_sign_loss)]
    f32::from_bits((biased as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f32, b: f64) -> f64 {
        if b == 0.0 {
            f64::from(a).abs()
        } else {
            ((f64::from(a) - b) / b).abs()
        }
    }

    fn sweep(mut f: impl FnMut(f64)) {
        let mut x = 1e-4_f64;
        while x < 80.0 {
            f(x);
            x *= 1.013;
        }
    }

    #[test]
    fn sqrt_is_accurate_over_the_configuration_range() {
        sweep(|x| assert!(rel(sqrt(x as f32), (x as f32 as f64).sqrt()) < 2e-7, "{x}"));
        assert_eq!(sqrt(-1.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
    }

    /// The recursive `atan` this module had before it was made iterative (at most 3 frames
    /// deep), kept as the oracle of the iterative one.
    fn atan_recursive(x: f32) -> f32 {
        use core::f32::consts::FRAC_PI_2;
        if x.is_nan() {
            return x;
        }
        if x < 0.0 {
            return -atan_recursive(-x);
        }
        if x > 1.0 {
            return FRAC_PI_2 - atan_recursive(1.0 / x);
        }
        atan_unit(x)
    }

    /// Compares `atan` with `atan_recursive` on every `stride`-th f32 bit pattern (both
    /// signs, subnormals, infinities, NaNs); returns how many were compared.
    fn compare_atan(stride: u32) -> u64 {
        let mut bits = 0_u32;
        let mut checked = 0_u64;
        loop {
            let x = f32::from_bits(bits);
            let (new, old) = (atan(x), atan_recursive(x));
            assert!(
                new.to_bits() == old.to_bits() || (new.is_nan() && old.is_nan()),
                "{x:e} ({bits:#010x}): {new:e} != {old:e}"
            );
            checked += 1;
            match bits.checked_add(stride) {
                Some(next) => bits = next,
                None => return checked,
            }
        }
    }

    #[test]
    fn atan_is_bit_identical_to_the_recursive_version() {
        assert!(compare_atan(1021) > 4_000_000);
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1.0 + f32::EPSILON,
            -1.0 - f32::EPSILON,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ] {
            assert_eq!(atan(x).to_bits(), atan_recursive(x).to_bits(), "{x:e}");
        }
    }

    /// All 2³² inputs: `cargo test --release -p terrain-pyramid --lib fmath -- --ignored` (about 7
    /// CPU minutes).
    #[test]
    #[ignore = "exhaustive, slow in debug"]
    fn atan_is_bit_identical_to_the_recursive_version_everywhere() {
        assert_eq!(compare_atan(1), 1 << 32);
    }

    #[test]
    fn atan_is_accurate_on_both_sides_of_one() {
        sweep(|x| assert!(rel(atan(x as f32), (x as f32 as f64).atan()) < 1e-6, "{x}"));
        assert!(rel(atan(-0.3), (-0.3_f32 as f64).atan()) < 1e-6);
    }

    #[test]
    fn exp_is_accurate_for_gate_arguments() {
        let mut x = -80.0_f64;
        while x < 10.0 {
            let xf = x as f32;
            assert!(rel(exp(xf), f64::from(xf).exp()) < 2e-6, "{x}");
            x += 0.0371;
        }
        assert_eq!(exp(-100.0), 0.0);
    }

    #[test]
    fn ln_is_accurate_for_probability_ratios() {
        sweep(|x| {
            let xf = x as f32;
            let expected = f64::from(xf).ln();
            assert!(
                (f64::from(ln(xf)) - expected).abs() < 2e-6 * expected.abs().max(1.0),
                "{x}"
            );
        });
        assert!(ln(0.0).is_nan());
        assert!(ln(-1.0).is_nan());
    }
}
