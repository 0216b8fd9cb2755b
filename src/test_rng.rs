//! The library's tests' pseudo-random numbers: xorshift64 (shifts 13, 7, 17), seeded by each
//! test so that every run draws the same values.

/// A xorshift64 generator; its state is the last value drawn (a seed must not be 0).
pub(crate) struct XorShift(pub(crate) u64);

impl XorShift {
    /// The next value, any of the 2⁶⁴ − 1 non-zero ones.
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// The next value reduced to `0 .. n` (`n` > 0).
    pub(crate) fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}
