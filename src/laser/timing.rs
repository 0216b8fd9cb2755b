//! When a packet's returns were measured, from when its bytes arrived.
//!
//! The board hands the core each chunk of laser bytes with its clock (µs, wrapping) at the
//! chunk's arrival. A packet's last byte arrived `remaining · byte time` before that (the
//! bytes of the chunk after it; a byte is 10 bits at the baud rate: start, 8 data, stop). The
//! model, per packet:
//!
//! 1. **Sent when measured.** A spinning lidar sends a packet as soon as its last return is
//!    measured, so that return was measured one packet transmission time before the last
//!    byte arrived (LD06 at 230 400 Bd: 2.04 ms; an X4 packet of 40 samples at 128 000 Bd:
//!    7.0 ms; an RPLIDAR node at 115 200 Bd: 0.43 ms, a capsule 7.3 ms). An express capsule
//!    is handed out only when the next one has arrived: its bytes ended one capsule turn (the
//!    angle between the two start angles, at the rotation rate) before the item.
//! 2. **Evenly in time.** The returns of a packet are measured evenly over its span (the angle
//!    the sensor turned from the first to the last, before per-return corrections), at the
//!    rotation rate: LD06 reports it in every packet (degrees per second); the RPLIDAR and
//!    the YDLIDAR do not, so it is measured between consecutive revolution starts (averaged
//!    over the last two; [`DEFAULT_REVOLUTION_US`] until two starts were seen). A revolution
//!    start is timed at its packet's last return.
//!
//! So return k of n is at `first + k·(last − first)/(n − 1)` with `last = end − transmission`
//! and `first = last − span / rate`. The pipeline needs only `first` and `last`: it
//! interpolates the actuator's angle between them.

use super::Packet;
use crate::angle::FineAngle;

/// The revolution period assumed until two revolution starts were seen: 100 ms (10 Hz, the
/// LD06's, and within the 5 – 12 Hz of the others).
pub const DEFAULT_REVOLUTION_US: u32 = 100_000;

/// Revolution periods measured outside 20 ms ..= 1 s (a missed start, a stalled motor) are
/// ignored.
const PERIOD_RANGE_US: core::ops::RangeInclusive<u32> = 20_000..=1_000_000;

/// The times of packets' returns (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PacketTimer {
    /// Microseconds per byte on the wire, Q16: 10 bits at the baud rate.
    byte_q16: u32,
    /// The revolution period in use, µs.
    period_us: u32,
    /// Whether `period_us` was measured.
    measured: bool,
    /// When the last revolution started, µs.
    last_start_us: Option<u32>,
}

impl Default for PacketTimer {
    fn default() -> Self {
        Self::new(crate::laser::SensorKind::Ld06.default_baud())
    }
}

impl PacketTimer {
    /// A timer of zero bits (no baud rate: every byte takes "forever"; no period), the
    /// placeholder of a `const`-built co-processor until its setup [`reset`](Self::reset)s
    /// it: a `static` holding it stays in `.bss`.
    pub const ZERO: Self = Self {
        byte_q16: 0,
        period_us: 0,
        measured: false,
        last_start_us: None,
    };

    /// A timer for a UART at `baud` (at least 1), with no revolution seen.
    #[must_use]
    pub const fn new(baud: u32) -> Self {
        Self {
            byte_q16: byte_q16(baud),
            period_us: DEFAULT_REVOLUTION_US,
            measured: false,
            last_start_us: None,
        }
    }

    /// Starts afresh at `baud`: the revolution period is forgotten.
    pub fn reset(&mut self, baud: u32) {
        *self = Self::new(baud);
    }

    /// The transmission time of `bytes` bytes, µs (saturating).
    #[must_use]
    pub fn bytes_us(&self, bytes: usize) -> u32 {
        let n = u64::try_from(bytes).unwrap_or(u64::MAX);
        u32::try_from(n.saturating_mul(u64::from(self.byte_q16)) >> 16).unwrap_or(u32::MAX)
    }

    /// The revolution period in use, µs, and whether it was measured.
    #[must_use]
    pub const fn revolution_us(&self) -> (u32, bool) {
        (self.period_us, self.measured)
    }

    /// How long the sensor takes to turn `angle` (clockwise), µs: at the packet's reported
    /// rate if it has one, else at the revolution period.
    fn duration_us(&self, packet: &Packet<'_>, angle: FineAngle) -> u32 {
        let bits = u64::from(angle.to_bits());
        let us = match packet.reported_rate_deg_per_s() {
            // bits·360·10⁶ < 2⁶¹, so ⌊bits·360·10⁶ / 2³²⌋ < 2²⁹; and ⌊⌊a/b⌋/c⌋ = ⌊a/(b·c)⌋:
            // ⌊bits·360·10⁶ / (rate·2³²)⌋ by one 32-bit division.
            Some(rate) if rate > 0 => duration_at_rate_us(angle.to_bits(), rate),
            _ => (bits * u64::from(self.period_us)) >> 32,
        };
        u32::try_from(us).unwrap_or(u32::MAX)
    }

    /// The times of the packet's first and last return, µs (the board's clock), for a packet
    /// whose last byte arrived at `end_us`; notes a revolution start when `starts_revolution`
    /// ([`super::RevolutionTracker`]).
    pub fn times(
        &mut self,
        packet: &Packet<'_>,
        end_us: u32,
        starts_revolution: bool,
    ) -> (u32, u32) {
        let mut end = end_us;
        if let Some(lag) = packet.lag() {
            end = end.wrapping_sub(self.duration_us(packet, lag));
        }
        let last = end.wrapping_sub(self.bytes_us(packet.wire_len()));
        let first = last.wrapping_sub(self.duration_us(packet, packet.span()));
        if starts_revolution {
            self.note_start(last);
        }
        (first, last)
    }

    fn note_start(&mut self, t_us: u32) {
        if let Some(previous) = self.last_start_us.replace(t_us) {
            let period = t_us.wrapping_sub(previous);
            if PERIOD_RANGE_US.contains(&period) {
                self.period_us = if self.measured {
                    // The mean of the last two, rounded: jitter halves, a drift follows.
                    u32::try_from((u64::from(self.period_us) + u64::from(period)).div_ceil(2))
                        .unwrap_or(period)
                } else {
                    period
                };
                self.measured = true;
            }
        }
    }
}

/// Microseconds per 10-bit byte at `baud`, Q16 (saturating for a zero rate).
const fn byte_q16(baud: u32) -> u32 {
    if baud == 0 {
        return u32::MAX;
    }
    let q = (10_000_000_u64 << 16) / baud as u64;
    if q > u32::MAX as u64 {
        u32::MAX
    } else {
        q as u32
    }
}

/// How long a turn of `bits` 2⁻³² turn takes at `rate` degrees per second (> 0), µs:
/// `⌊bits·360·10⁶ / (rate·2³²)⌋` by one 32-bit division, since `⌊⌊a/b⌋/c⌋ = ⌊a/(b·c)⌋` and
/// `⌊bits·360·10⁶ / 2³²⌋ < 2²⁹`. `rate = 0` gives 0 (no panic).
fn duration_at_rate_us(bits: u32, rate: u16) -> u64 {
    // Below 2²⁹.
    #[allow(clippy::cast_possible_truncation)]
    let turned = ((u64::from(bits) * 360_000_000) >> 32) as u32;
    u64::from(turned.checked_div(u32::from(rate)).unwrap_or(0))
}

/// The SICK LMS2xx's mirror turn, µs (75 Hz: 13 333.3 µs), Q16.
const SICK_TURN_US_Q16: u64 = (1_000_000_u64 << 16) / 75;

/// When each beam of a SICK measured-values telegram was measured, relative to its last
/// measured beam (see `docs/lidars.md`, "When a SICK beam was measured"). The model:
///
/// - the mirror turns at 75 Hz, counter-clockwise seen from above, so the scan runs from the
///   field's first beam (0°, or 40° in the 100° field) to its last; beam angle θ is passed
///   `(θ − θ₀)/360° · 13.33 ms` after the first;
/// - an interlaced variant (0.5°, 0.25°) measures one 1° phase per turn, in the order of the
///   partial-scan index (0.25° phase 0 first): a full telegram spans 2 or 4 turns, a partial
///   one (a single phase) one turn;
/// - the telegram is sent as soon as the last beam is measured (its last beam was measured
///   one transmission time before the telegram's last byte arrived).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SickBeamTimes {
    /// The beam step, quarter degrees (1, 2 or 4).
    step: u32,
    /// Whether the telegram holds every beam of an interlaced variant (several turns).
    full_interlaced: bool,
    /// The time of the last measured beam after the first turn's start, µs Q16.
    last_q16: u64,
}

impl SickBeamTimes {
    /// The model for a telegram of `variant`: a full scan (`partial = None`) or a partial
    /// scan with that partial-scan index, whose last value lies on beam `last_beam`.
    #[must_use]
    pub fn new(variant: crate::wire::sick::Variant, partial: Option<u8>, last_beam: usize) -> Self {
        let step = u32::from(variant.step_quarter_degrees()).max(1);
        let full_interlaced = partial.is_none() && step < 4;
        let mut times = Self {
            step,
            full_interlaced,
            last_q16: 0,
        };
        times.last_q16 = if full_interlaced {
            // The last phase's last beam: the highest beam in phase 4 − step (at most three
            // steps back from the field's last beam).
            let mut k = variant.beam_count().saturating_sub(1);
            while k > 0 && times.turn_of(k) + 1 < u64::from(4 / step) {
                k -= 1;
            }
            times.after_start_q16(k)
        } else {
            times.after_start_q16(last_beam)
        };
        times
    }

    /// The turn (0-based) in which beam `beam` was measured: its 0.25° phase over the step in
    /// a full interlaced telegram, else 0.
    fn turn_of(&self, beam: usize) -> u64 {
        if !self.full_interlaced {
            return 0;
        }
        let q = u64::try_from(beam)
            .unwrap_or(0)
            .saturating_mul(u64::from(self.step));
        (q % 4) / u64::from(self.step)
    }

    /// When beam `beam` was measured after the first turn's start of the telegram's first
    /// beam, µs Q16.
    fn after_start_q16(&self, beam: usize) -> u64 {
        let q = u64::try_from(beam)
            .unwrap_or(0)
            .saturating_mul(u64::from(self.step));
        let turn = self.turn_of(beam);
        // q ≤ 720 quarter degrees: the turn's fraction q/1440 times the turn, below 2⁴⁰.
        turn * SICK_TURN_US_Q16 + q * SICK_TURN_US_Q16 / 1440
    }

    /// How long before the telegram's last measured beam `beam` was measured, µs (rounded).
    #[must_use]
    pub fn before_last_us(&self, beam: usize) -> u32 {
        let d = self.last_q16.saturating_sub(self.after_start_q16(beam));
        u32::try_from((d + (1 << 15)) >> 16).unwrap_or(u32::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::duration_at_rate_us;

    #[test]
    fn the_duration_at_a_rate_is_the_64_bit_quotient() {
        let mut x = 0x2545_F491_u32;
        for rate in (1..=u16::MAX).step_by(7).chain([1, 2, 3600, u16::MAX]) {
            for _ in 0..64 {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                for bits in [x, 0, 1, u32::MAX] {
                    let want = u64::from(bits) * 360_000_000 / (u64::from(rate) << 32);
                    assert_eq!(duration_at_rate_us(bits, rate), want, "{bits} {rate}");
                }
            }
        }
        assert_eq!(duration_at_rate_us(1 << 31, 0), 0);
    }

    #[test]
    fn sick_beams_are_timed_along_the_mirror_turns() {
        use super::SickBeamTimes;
        use crate::wire::sick::Variant;
        // 1°, 180°: one turn, 181 beams over half of it (6.667 ms), 37.04 µs apart.
        let t = SickBeamTimes::new(Variant::Fov180Step1, None, 180);
        assert_eq!(t.before_last_us(180), 0);
        assert_eq!(t.before_last_us(179), 37);
        assert_eq!(t.before_last_us(90), 3_333);
        assert_eq!(t.before_last_us(0), 6_667);
        // 0.5°, 180°, full: beams 0, 2, … in the first turn, 1, 3, … in the second; the last
        // measured is beam 359 (179.5°).
        let t = SickBeamTimes::new(Variant::Fov180StepHalf, None, 360);
        assert_eq!(t.before_last_us(359), 0);
        assert_eq!(t.before_last_us(1), 6_630);
        // Beam 360 (180°) ends the first turn: 13 333.3 + 6 648.1 − 6 666.7 µs before.
        assert_eq!(t.before_last_us(360), 13_315);
        assert_eq!(t.before_last_us(0), 19_981);
        // A partial scan of the same variant: one turn, its last value on beam 359.
        let t = SickBeamTimes::new(Variant::Fov180StepHalf, Some(2), 359);
        assert_eq!(t.before_last_us(359), 0);
        assert_eq!(t.before_last_us(1), 6_630);
        // 0.25°, 100°: four turns; the last measured is beam 399 (phase 3).
        let t = SickBeamTimes::new(Variant::Fov100StepQuarter, None, 400);
        assert_eq!(t.before_last_us(399), 0);
        // 3 turns (40 000 µs) and 99.75° of the fourth (3 694.4 µs).
        assert_eq!(t.before_last_us(0), 43_694);
    }
}
