//! A small seeded random number generator for the simulator: SplitMix64 (Steele, Lea &
//! Flood 2014, the seeding generator of `java.util.SplittableRandom` and of the xoshiro
//! family), with uniform and Gaussian draws. No dependency, no unseeded state: the same seed
//! gives the same sequence on every run (and, floating-point functions permitting, on every
//! machine).

/// A SplitMix64 generator: 64 bits of state, period 2⁶⁴, every seed valid (0 included).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator seeded with `seed` (any value).
    #[must_use]
    pub const fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform draw in `[0, 1)`, with 53 random bits (every value a multiple of 2⁻⁵³).
    pub fn uniform(&mut self) -> f64 {
        // The top 53 bits fit an f64 mantissa exactly.
        #[allow(clippy::cast_precision_loss)]
        let v = (self.next_u64() >> 11) as f64;
        v * (1.0 / 9_007_199_254_740_992.0)
    }

    /// A uniform integer in `0 ..= n − 1`; 0 when `n` is 0 or 1. (The modulo bias is below
    /// `n / 2⁶⁴`, negligible for the small `n` the simulator asks for.)
    pub fn below(&mut self, n: u64) -> u64 {
        if n <= 1 {
            0
        } else {
            self.next_u64() % n
        }
    }

    /// A standard normal draw (mean 0, standard deviation 1), by the Box–Muller transform of
    /// two uniform draws (one value per call; the second of the pair is not kept).
    pub fn gaussian(&mut self) -> f64 {
        // u1 in (0, 1], so the logarithm is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (core::f64::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_reference_values() {
        // The first outputs of SplitMix64 seeded with 1234567 (the reference implementation).
        let mut r = Rng::new(1_234_567);
        assert_eq!(r.next_u64(), 6_457_827_717_110_365_317);
        assert_eq!(r.next_u64(), 3_203_168_211_198_807_973);
    }

    #[test]
    fn gaussian_has_unit_moments() {
        let mut r = Rng::new(7);
        let n = 20_000;
        let draws: Vec<f64> = (0..n).map(|_| r.gaussian()).collect();
        let mean = draws.iter().sum::<f64>() / f64::from(n);
        let var = draws.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f64::from(n);
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
    }
}
