//! The token bucket that holds map traffic to a byte budget, fed by the caller's clock.

/// A token bucket in milli-bytes: `rate` bytes per second up to `burst` bytes. The caller
/// hands in the time; the bucket never reads a clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TokenBucket {
    rate: u32,
    burst_milli: i64,
    tokens_milli: i64,
    last_ms: Option<u32>,
}

/// The longest gap between two refills that counts, ms: a clock that jumps (or goes back,
/// which wraps) refills at most this much.
const MAX_GAP_MS: u32 = 60_000;

impl TokenBucket {
    /// A full bucket.
    #[must_use]
    pub const fn new(rate_bytes_per_s: u32, burst_bytes: u32) -> Self {
        let burst_milli = burst_bytes as i64 * 1000;
        Self {
            rate: rate_bytes_per_s,
            burst_milli,
            tokens_milli: burst_milli,
            last_ms: None,
        }
    }

    /// Adds the tokens earned since the last refill.
    pub fn refill(&mut self, now_ms: u32) {
        if let Some(last) = self.last_ms {
            let dt = now_ms.wrapping_sub(last).min(MAX_GAP_MS);
            let earned = i64::from(dt) * i64::from(self.rate);
            self.tokens_milli = self
                .tokens_milli
                .saturating_add(earned)
                .min(self.burst_milli);
        }
        self.last_ms = Some(now_ms);
    }

    /// Whole bytes available now (negative after an overdraft).
    #[must_use]
    pub const fn available(&self) -> i64 {
        self.tokens_milli / 1000
    }

    /// Whether `bytes` can be taken without overdraft.
    #[must_use]
    pub fn allows(&self, bytes: usize) -> bool {
        let need = i64::try_from(bytes)
            .unwrap_or(i64::MAX)
            .saturating_mul(1000);
        self.tokens_milli >= need
    }

    /// Takes `bytes`, overdrawing down to −burst at most.
    pub fn take(&mut self, bytes: usize) {
        let need = i64::try_from(bytes)
            .unwrap_or(i64::MAX)
            .saturating_mul(1000);
        self.tokens_milli = self
            .tokens_milli
            .saturating_sub(need)
            .max(-self.burst_milli);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refills_at_the_rate_up_to_the_burst() {
        let mut b = TokenBucket::new(1000, 100);
        b.refill(0);
        assert!(b.allows(100));
        b.take(100);
        assert!(!b.allows(1));
        b.refill(50); // 50 ms at 1000 B/s
        assert_eq!(b.available(), 50);
        b.refill(10_000);
        assert_eq!(b.available(), 100);
        b.take(250);
        assert_eq!(b.available(), -100);
        // The clock going back refills at most MAX_GAP_MS' worth, not forever.
        b.refill(5);
        assert_eq!(b.available(), 100);
    }
}
