//! The mapping between the host's clock and the device's microsecond clock, learnt from
//! TimeRequest/TimeReply exchanges (`docs/protocol.md`). Pure logic: the caller times the
//! exchanges and feeds them in; nothing here reads a clock or does I/O.
//!
//! # The model
//! The host's clock is a monotonic count of µs (`u64`, any origin: `pyramid listen` counts
//! from the session's start). The device's clock is a `u32` count of µs that wraps every
//! 2³² µs (71.6 min); every device time is unwrapped here to an `i64` near the newest
//! exchange's. The two are related by a line, `device = host + offset(host)`, with
//! `offset(host) = offset₀ + drift × (host − host₀)`: an offset and a rate difference (the
//! drift, in ppm: a crystal's tens, an internal oscillator's up to 1 %).
//!
//! # One exchange
//! The host sends a TimeRequest at `t1` (its clock), the device takes it at `t2` (its clock)
//! and answers; the answer is read at `t4` (host). With the unknown up and down delays
//! `d_up + d_down = t4 − t1` (the round trip), `t2 − (t1 + t4) / 2` is the offset at the
//! midpoint `(t1 + t4) / 2` plus `(d_up − d_down) / 2`: wrong by at most half the round trip,
//! and by less the more symmetric the delays are. A reply that waited behind map data
//! (the device's UART queue) or a busy host has a long round trip and a large, one-sided
//! error.
//!
//! # The filter (minimum delay, as NTP and PTP servos do)
//! - The accepted exchanges of the last [`WINDOW_US`] (at most [`MAX_SAMPLES`]) are kept,
//!   grouped in blocks of [`BLOCK`] consecutive exchanges; each complete block contributes its
//!   least-round-trip exchange (the one that queued least).
//! - Drift: the least-squares line through those per-block minima (midpoint, offset), leaving
//!   out the spikes (a minimum whose round trip is over twice the minima's median: every
//!   exchange of its block queued); with fewer than [`MIN_BLOCKS`] complete blocks there is no
//!   mapping yet ([`ClockSync::is_synced`]).
//! - Offset: from the least-round-trip exchange of the last [`ANCHOR_WINDOW_US`] (the
//!   anchor), carried along the fitted drift: `offset(h) = o_anchor + drift × (h − m_anchor)`.
//! - Accuracy (the stated bound on the mapping's error at host time `h`): half the anchor's
//!   round trip (the most its own asymmetry can be) + the RMS residual of the block minima about
//!   the line + the drift's uncertainty times `|h − m_anchor|`. The drift's uncertainty is the
//!   most the minima's own bounds allow (each offset wrong by at most half its round trip, so
//!   the slope by at most `Σ |mᵢ − m̄| · rttᵢ / 2 / Σ (mᵢ − m̄)²`) + the RMS residual over
//!   `√Σ (mᵢ − m̄)²` (a drift that wanders). With the clocks related by a line, the first and
//!   last terms are a bound, not an estimate.
//!
//! # Resets
//! [`ClockSync::reset`] forgets everything (the device booted, the link was reconnected).
//! An exchange inconsistent with the current mapping by more than [`MAX_INCONSISTENCY_US`]
//! (the mapping's offset lies outside `[t2 − t4, t2 − t1]`, every offset the exchange allows,
//! by more than that) means the device's clock jumped (a reboot whose Hello was lost): the
//! mapping is reset, counted, and the exchange starts the new one. An exchange with a
//! negative round trip or one longer than [`MAX_ROUND_TRIP_US`] is discarded (counted).
use serde::Serialize;
use std::collections::VecDeque;

/// Exchanges per block of the minimum filter.
pub const BLOCK: usize = 5;

/// Complete blocks needed before the mapping is given (10 exchanges: 1 s at 10 Hz).
pub const MIN_BLOCKS: usize = 2;

/// How far back accepted exchanges are kept, host µs (60 s).
pub const WINDOW_US: u64 = 60_000_000;

/// The most exchanges kept (bounds the work per exchange; 60 s at 10 Hz is 600).
pub const MAX_SAMPLES: usize = 600;

/// How far back the anchor (the least-round-trip exchange the offset is taken from) is
/// looked for, host µs (10 s).
pub const ANCHOR_WINDOW_US: u64 = 10_000_000;

/// An exchange whose offset bounds miss the mapping by more than this resets it, µs (50 ms).
pub const MAX_INCONSISTENCY_US: i64 = 50_000;

/// An exchange with a longer round trip is discarded, µs (1 s): a reply to a request from
/// before a reconnection, or a link too slow to say anything about the clocks.
pub const MAX_ROUND_TRIP_US: u64 = 1_000_000;

/// The device's clock period: its µs counter wraps after 2³² µs.
const DEVICE_WRAP: i64 = 1 << 32;

/// One TimeRequest/TimeReply exchange, as the host timed it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Exchange {
    /// The host's clock when the TimeRequest was sent (`t1`), µs; the reply echoes it.
    pub host_sent_us: u64,
    /// The device's clock when it took the request (`t2`), µs, wrapping.
    pub device_us: u32,
    /// The host's clock when the TimeReply was read (`t4`), µs; `≥ host_sent_us` to be used.
    pub host_received_us: u64,
    /// Bytes queued at the device ahead of the reply (the reply's `queued_ahead`): counted
    /// (replies that queued), the filter needs nothing else (their round trips are longer).
    pub queued_ahead: u16,
}

/// What became of one exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Taken into the filter.
    Taken,
    /// Discarded: a negative round trip or one over [`MAX_ROUND_TRIP_US`].
    Discarded,
    /// Inconsistent with the mapping by more than [`MAX_INCONSISTENCY_US`]: the mapping was
    /// reset and this exchange starts the new one.
    Reset,
}

/// Why the mapping was forgotten.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResetReason {
    /// The device booted (a Hello with reason boot).
    DeviceBoot,
    /// The link was reconnected (the device may be another, or have restarted unseen).
    Reconnect,
}

/// The filter's counters since it was made. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct ClockCounters {
    /// Exchanges fed in (taken, discarded or resetting).
    pub exchanges: u64,
    /// Exchanges discarded (negative or over-long round trip).
    pub discarded: u64,
    /// Exchanges whose reply queued behind other bytes at the device (`queued_ahead > 0`).
    pub queued_replies: u64,
    /// Resets for a device boot.
    pub resets_boot: u64,
    /// Resets for a reconnection.
    pub resets_reconnect: u64,
    /// Resets for an exchange inconsistent with the mapping (a clock jump).
    pub resets_inconsistent: u64,
}

impl ClockCounters {
    /// Every reset, whatever its reason.
    #[must_use]
    pub fn resets(&self) -> u64 {
        self.resets_boot
            .saturating_add(self.resets_reconnect)
            .saturating_add(self.resets_inconsistent)
    }
}

/// The mapping as it stands, for reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// Device µs (unwrapped) minus host µs at the anchor's midpoint.
    pub offset_us: f64,
    /// The device's clock rate minus the host's, ppm (positive: the device runs fast).
    pub drift_ppm: f64,
    /// The stated bound on the mapping's error at the anchor, µs.
    pub accuracy_us: f64,
    /// The anchor's round trip, µs.
    pub round_trip_us: u64,
    /// The host time the offset refers to (the anchor's midpoint), µs.
    pub host_us: u64,
}

/// An accepted exchange: midpoint and round trip on the host's clock, the device's time
/// unwrapped, and its index since the last reset (which block it is in).
#[derive(Debug, Clone, Copy)]
struct Sample {
    index: u64,
    t1: u64,
    t4: u64,
    device: i64,
}

impl Sample {
    fn rtt(&self) -> u64 {
        self.t4 - self.t1
    }
    /// The midpoint `(t1 + t4) / 2`, host µs.
    fn mid(&self) -> f64 {
        (self.t1 as f64 + self.t4 as f64) / 2.0
    }
    /// Device minus host at the midpoint, µs.
    fn offset(&self) -> f64 {
        self.device as f64 - self.mid()
    }
}

/// The fitted mapping.
#[derive(Debug, Clone, Copy)]
struct Fit {
    /// Anchor midpoint, host µs.
    m0: f64,
    /// Offset at `m0`, µs.
    o0: f64,
    /// Drift, µs per µs.
    k: f64,
    /// Half the anchor's round trip + RMS residual, µs.
    base_us: f64,
    /// The drift's uncertainty, µs per µs.
    k_err: f64,
    /// The anchor's round trip.
    rtt: u64,
    /// The anchor's device time (unwrapped), for unwrapping device times near it.
    device0: i64,
}

/// The host ↔ device clock mapping. See the module's documentation.
#[derive(Debug, Clone, Default)]
pub struct ClockSync {
    samples: VecDeque<Sample>,
    next_index: u64,
    fit: Option<Fit>,
    counters: ClockCounters,
}

impl ClockSync {
    /// A filter with no exchanges.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The counters.
    #[must_use]
    pub fn counters(&self) -> ClockCounters {
        self.counters
    }

    /// Whether there is a mapping ([`MIN_BLOCKS`] complete blocks since the last reset).
    #[must_use]
    pub fn is_synced(&self) -> bool {
        self.fit.is_some()
    }

    /// Forgets the mapping (counted by `reason`); the next exchanges build a new one.
    pub fn reset(&mut self, reason: ResetReason) {
        let c = &mut self.counters;
        match reason {
            ResetReason::DeviceBoot => c.resets_boot = c.resets_boot.saturating_add(1),
            ResetReason::Reconnect => c.resets_reconnect = c.resets_reconnect.saturating_add(1),
        }
        self.clear();
    }

    fn clear(&mut self) {
        self.samples.clear();
        self.next_index = 0;
        self.fit = None;
    }

    /// Feeds one exchange in; see [`Outcome`].
    pub fn add(&mut self, exchange: Exchange) -> Outcome {
        let c = &mut self.counters;
        c.exchanges = c.exchanges.saturating_add(1);
        if exchange.queued_ahead > 0 {
            c.queued_replies = c.queued_replies.saturating_add(1);
        }
        let Exchange {
            host_sent_us: t1,
            device_us,
            host_received_us: t4,
            ..
        } = exchange;
        if t4 < t1 || t4 - t1 > MAX_ROUND_TRIP_US {
            c.discarded = c.discarded.saturating_add(1);
            return Outcome::Discarded;
        }
        let device = self.unwrap(device_us, (t1 as f64 + t4 as f64) / 2.0);
        let mut outcome = Outcome::Taken;
        if let Some(predicted) = self.predicted_offset((t1 as f64 + t4 as f64) / 2.0) {
            // Every offset this exchange allows: [t2 − t4, t2 − t1].
            let lo = device as f64 - t4 as f64;
            let hi = device as f64 - t1 as f64;
            let limit = MAX_INCONSISTENCY_US as f64;
            if predicted < lo - limit || predicted > hi + limit {
                self.counters.resets_inconsistent =
                    self.counters.resets_inconsistent.saturating_add(1);
                self.clear();
                outcome = Outcome::Reset;
            }
        }
        // Unwrapped again after a reset: relative to nothing but itself.
        let device = if outcome == Outcome::Reset {
            i64::from(device_us)
        } else {
            device
        };
        self.samples.push_back(Sample {
            index: self.next_index,
            t1,
            t4,
            device,
        });
        self.next_index += 1;
        self.trim(t4);
        self.refit();
        outcome
    }

    /// The device's time unwrapped near what the mapping (or, before one, the newest
    /// exchange) expects at host midpoint `mid`.
    fn unwrap(&self, device_us: u32, mid: f64) -> i64 {
        let expected = match (self.fit, self.samples.back()) {
            (Some(f), _) => (mid + f.o0 + f.k * (mid - f.m0)).round() as i64,
            (None, Some(s)) => s.device + (mid - s.mid()).round() as i64,
            (None, None) => return i64::from(device_us),
        };
        unwrap_near(device_us, expected)
    }

    /// The offset the mapping (or, before one, the least-round-trip exchange so far) expects
    /// at `mid`.
    fn predicted_offset(&self, mid: f64) -> Option<f64> {
        match self.fit {
            Some(f) => Some(f.o0 + f.k * (mid - f.m0)),
            None => self
                .samples
                .iter()
                .min_by_key(|s| s.rtt())
                .map(Sample::offset),
        }
    }

    /// Drops what is older than the window (whole blocks, so that blocks stay whole).
    fn trim(&mut self, now: u64) {
        while self.samples.len() > MAX_SAMPLES
            || self
                .samples
                .front()
                .is_some_and(|s| now.saturating_sub(s.t4) > WINDOW_US)
        {
            let Some(first) = self.samples.pop_front() else {
                break;
            };
            let block = first.index / BLOCK as u64;
            while self
                .samples
                .front()
                .is_some_and(|s| s.index / BLOCK as u64 == block)
            {
                self.samples.pop_front();
            }
        }
    }

    fn refit(&mut self) {
        self.fit = self.compute_fit();
    }

    fn compute_fit(&self) -> Option<Fit> {
        // Per-block minima of the complete blocks.
        let mut minima: Vec<Sample> = Vec::new();
        let mut current: Option<(u64, Sample, usize)> = None;
        for s in &self.samples {
            let block = s.index / BLOCK as u64;
            match &mut current {
                Some((b, best, n)) if *b == block => {
                    *n += 1;
                    if s.rtt() < best.rtt() {
                        *best = *s;
                    }
                }
                _ => {
                    if let Some((_, best, n)) = current.take() {
                        if n == BLOCK {
                            minima.push(best);
                        }
                    }
                    current = Some((block, *s, 1));
                }
            }
        }
        if let Some((_, best, n)) = current {
            if n == BLOCK {
                minima.push(best);
            }
        }
        if minima.len() < MIN_BLOCKS {
            return None;
        }
        // Spikes out: a block whose every exchange queued says little about the clocks and
        // would pull the line. Kept: minima within twice the median round trip of them all.
        let mut rtts: Vec<u64> = minima.iter().map(Sample::rtt).collect();
        rtts.sort_unstable();
        let median = rtts.get(rtts.len() / 2).copied().unwrap_or(0);
        let calm: Vec<Sample> = minima
            .iter()
            .filter(|s| s.rtt() <= median.saturating_mul(2))
            .copied()
            .collect();
        if calm.len() >= MIN_BLOCKS {
            minima = calm;
        }
        // Least squares through (midpoint, offset), relative to the first for precision.
        let first = minima.first()?;
        let (x0, y0) = (first.mid(), first.offset());
        let n = minima.len() as f64;
        let (mut sx, mut sy) = (0.0, 0.0);
        for s in &minima {
            sx += s.mid() - x0;
            sy += s.offset() - y0;
        }
        let (mx, my) = (sx / n, sy / n);
        let (mut sxx, mut sxy) = (0.0, 0.0);
        for s in &minima {
            let dx = s.mid() - x0 - mx;
            sxx += dx * dx;
            sxy += dx * (s.offset() - y0 - my);
        }
        if sxx <= 0.0 {
            return None;
        }
        let k = sxy / sxx;
        let mut sum_r2 = 0.0;
        for s in &minima {
            let r = s.offset() - y0 - my - k * (s.mid() - x0 - mx);
            sum_r2 += r * r;
        }
        let rms = (sum_r2 / n).sqrt();
        // The drift's worst case: each minimum's offset is wrong by at most half its round
        // trip, and the slope is Σ wᵢ·offsetᵢ with wᵢ = (xᵢ − x̄) / Sxx, so it is wrong by at
        // most Σ |wᵢ| · rttᵢ / 2.
        let mut k_err = 0.0;
        for s in &minima {
            k_err += (s.mid() - x0 - mx).abs() * s.rtt() as f64 / 2.0;
        }
        let k_err = k_err / sxx + rms / sxx.sqrt();
        // The anchor: the least round trip of the recent exchanges.
        let newest = self.samples.back()?.t4;
        let anchor = self
            .samples
            .iter()
            .filter(|s| newest.saturating_sub(s.t4) <= ANCHOR_WINDOW_US)
            .min_by_key(|s| s.rtt())?;
        let base_us = anchor.rtt() as f64 / 2.0 + rms;
        Some(Fit {
            m0: anchor.mid(),
            o0: anchor.offset(),
            k,
            base_us,
            k_err,
            rtt: anchor.rtt(),
            device0: anchor.device,
        })
    }

    /// The device's clock (wrapping µs) at host time `host_us`; `None` before the mapping
    /// exists.
    #[must_use]
    pub fn to_device(&self, host_us: u64) -> Option<u32> {
        let f = self.fit?;
        let h = host_us as f64;
        let d = (h + f.o0 + f.k * (h - f.m0)).round();
        if !d.is_finite() {
            return None;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Some((d as i64).rem_euclid(DEVICE_WRAP) as u32)
    }

    /// The host time (µs) at which the device's clock read `device_us`, taking the device's
    /// time as the one nearest the anchor's (within ±35.8 min); `None` before the mapping
    /// exists or if it falls before the host's origin.
    #[must_use]
    pub fn to_host(&self, device_us: u32) -> Option<u64> {
        let f = self.fit?;
        let d = unwrap_near(device_us, f.device0) as f64;
        // d = h + o0 + k (h − m0)  ⇒  h = (d − o0 + k m0) / (1 + k)
        let h = (d - f.o0 + f.k * f.m0) / (1.0 + f.k);
        (h.is_finite() && h >= 0.0 && h < u64::MAX as f64).then(|| h.round() as u64)
    }

    /// The stated bound on the mapping's error at host time `host_us`, µs; `None` before the
    /// mapping exists.
    #[must_use]
    pub fn accuracy_at(&self, host_us: u64) -> Option<f64> {
        let f = self.fit?;
        Some(f.base_us + f.k_err * (host_us as f64 - f.m0).abs())
    }

    /// The mapping as it stands; `None` before it exists.
    #[must_use]
    pub fn estimate(&self) -> Option<Estimate> {
        let f = self.fit?;
        Some(Estimate {
            offset_us: f.o0,
            drift_ppm: f.k * 1e6,
            accuracy_us: f.base_us,
            round_trip_us: f.rtt,
            host_us: f.m0.max(0.0).round() as u64,
        })
    }
}

/// The `i64` that is `device_us` modulo 2³² nearest `expected`.
fn unwrap_near(device_us: u32, expected: i64) -> i64 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let base = expected.rem_euclid(DEVICE_WRAP) as u32;
    #[allow(clippy::cast_possible_wrap)]
    let delta = device_us.wrapping_sub(base) as i32;
    expected + i64::from(delta)
}

#[cfg(test)]
mod tests;
