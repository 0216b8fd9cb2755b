//! What the decode-rate examples share.

/// A xorshift64 generator (Marsaglia's 13, 7, 17): the examples' streams, the same on every
/// run for the same seed (which must not be 0).
pub struct XorShift(pub u64);

impl XorShift {
    /// The next 64-bit value.
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}
