//! Stream reassembly: telegrams out of arbitrary UART chunks, as postcard's `CobsAccumulator`.
//!
//! The accumulator hunts for the reply header `02 80`, buffers the candidate telegram it
//! starts, and checks it as soon as LEN and then the CRC can be read:
//! - a valid telegram is handed out as a [`Telegram`] view borrowing the accumulator's buffer,
//!   valid until the next call that takes `&mut self`;
//! - a candidate with an impossible LEN (0, above 812, or above the capacity) or a CRC
//!   mismatch is rejected, and the hunt restarts at the byte after its STX, not after the
//!   bytes it claimed: a telegram cut short by the next header costs nothing but itself, and
//!   a false `02 80` inside garbage never swallows the valid telegram that follows;
//! - lone ACK (0x06) and NAK (0x15) bytes between telegrams are reported;
//! - everything else is garbage, counted and dropped without being buffered.
//!
//! Every outcome is counted in [`SickCounters`] (saturating u32 counters). The buffer holds one
//! telegram at most ([`DEFAULT_CAPACITY`] = 818 bytes, the largest); bytes are copied once,
//! into it, and garbage is skipped in place.
//!
//! A false candidate passes only if its 16-bit CRC matches by chance (about 1 in 65 536 per
//! false `02 80` with a plausible LEN); it then hides whatever telegram starts inside it.

use super::telegram::{
    Telegram, ADDRESS_REPLY, CRC_LEN, HEADER_LEN, MAX_PAYLOAD_LEN, MAX_TELEGRAM_LEN, STX,
};
use super::{crc16, read_u16_le, ACK, NAK};
use crate::wire::FeedResult;
use core::fmt;

/// The default capacity of an [`SickAccumulator`]: the largest telegram, 818 bytes.
pub const DEFAULT_CAPACITY: usize = MAX_TELEGRAM_LEN;

/// The smallest capacity: the smallest telegram (header, one payload byte, CRC), 7 bytes.
const MIN_CAPACITY: usize = HEADER_LEN + 1 + CRC_LEN;

/// What the accumulator has seen since it was made (or since [`SickAccumulator::clear_stats`]).
/// Every counter saturates at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SickCounters {
    /// Telegrams handed out: header `02 80`, LEN in 1..=812, CRC matching.
    pub telegrams_ok: u32,
    /// Candidates whose CRC did not match, with no `02 80` inside them.
    pub crc_errors: u32,
    /// Candidates with LEN 0 or above 812, or longer than the accumulator's capacity.
    pub length_errors: u32,
    /// Candidates cut short: the CRC did not match and a `02 80` header starts inside them,
    /// or the stream ended inside them ([`SickAccumulator::flush`]).
    pub truncated: u32,
    /// Bytes outside every candidate, dropped while hunting for `02 80` (a STX not followed
    /// by 0x80 included). Bytes inside a rejected candidate, up to the next `02 80` in it, are
    /// counted with the candidate, not here.
    pub garbage_bytes: u32,
    /// ACK bytes (0x06) seen outside candidates.
    pub ack: u32,
    /// NAK bytes (0x15) seen outside candidates.
    pub nak: u32,
}

/// Why a candidate telegram was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SickFrameError {
    /// LEN is 0 or above 812 ([`SickCounters::length_errors`]).
    BadLength {
        /// The LEN read, bytes.
        len: u16,
    },
    /// LEN is valid but the telegram exceeds the accumulator's capacity
    /// ([`SickCounters::length_errors`]).
    TooLong {
        /// The LEN read, bytes.
        len: u16,
        /// The accumulator's capacity, bytes.
        capacity: usize,
    },
    /// The CRC did not match ([`SickCounters::crc_errors`]).
    BadCrc {
        /// The CRC carried by the candidate.
        stored: u16,
        /// The CRC computed over it.
        computed: u16,
    },
    /// The candidate was cut short by a new `02 80` header or by the end of the stream
    /// ([`SickCounters::truncated`]).
    Truncated,
}

impl fmt::Display for SickFrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadLength { len } => write!(f, "impossible telegram length {len}"),
            Self::TooLong { len, capacity } => write!(
                f,
                "telegram length {len} exceeds the accumulator's capacity of {capacity} bytes"
            ),
            Self::BadCrc { stored, computed } => write!(
                f,
                "telegram CRC mismatch: stored 0x{stored:04x}, computed 0x{computed:04x}"
            ),
            Self::Truncated => f.write_str("telegram truncated"),
        }
    }
}

impl core::error::Error for SickFrameError {}

#[cfg(feature = "defmt")]
impl<const N: usize> defmt::Format for SickAccumulator<N> {
    fn format(&self, f: defmt::Formatter<'_>) {
        // The buffer itself is not worth a log line; its fill level and counters are.
        defmt::write!(
            f,
            "SickAccumulator {{ buffered: {=usize}, capacity: {=usize}, stats: {} }}",
            self.end.saturating_sub(self.start),
            N,
            self.stats
        );
    }
}

/// What the SICK accumulator hands out in a [`FeedResult::Item`]: a telegram that passed its
/// checks, or a lone acknowledgement byte between telegrams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SickItem<'s> {
    /// A valid telegram (reply header `02 80`, LEN in 1..=812, CRC checked), borrowing the
    /// accumulator's buffer until the next call.
    Telegram(Telegram<&'s [u8]>),
    /// A lone ACK byte (0x06).
    Ack,
    /// A lone NAK byte (0x15).
    Nak,
}

/// The outcome of one [`SickAccumulator::feed`]: the generic [`FeedResult`] with SICK items
/// and [`SickFrameError`] refusals. `offset` is the stream position of the telegram's or
/// candidate's STX, or of the ACK/NAK byte.
pub type SickFeed<'s, 'c> = FeedResult<'c, SickItem<'s>, SickFrameError>;

/// One event found in the buffer.
#[derive(Debug, Clone, Copy)]
enum Step {
    /// A valid telegram of this length at `start`.
    Telegram(usize),
    Ack,
    Nak,
    Rejected(SickFrameError),
}

/// What the buffer holds.
#[derive(Debug, Clone, Copy)]
enum Scan {
    /// An event, at this stream position.
    Step(Step, u64),
    /// An incomplete candidate that needs this many more bytes (≥ 1, and it fits).
    Need(usize),
    /// Nothing.
    Empty,
}

/// Reassembles LMS2xx reply telegrams from a byte stream fed in chunks of any size.
///
/// `N` is the capacity in bytes: [`DEFAULT_CAPACITY`] (818) holds every telegram; a smaller
/// one (at least 7) saves RAM and rejects longer telegrams as [`SickFrameError::TooLong`].
///
/// ```
/// use terrain_pyramid::wire::sick::{emit_telegram, SickAccumulator, SickItem, ADDRESS_REPLY};
/// use terrain_pyramid::wire::FeedResult;
///
/// // Noise, an ACK, then an 0xA0 reply.
/// let mut stream = [0u8; 12];
/// stream[..3].copy_from_slice(&[0xFF, 0x06, 0x00]);
/// emit_telegram(ADDRESS_REPLY, &[0xA0, 0x00, 0x10], &mut stream[3..]).unwrap();
///
/// let mut acc: SickAccumulator = SickAccumulator::new();
/// for chunk in stream.chunks(5) {
///     let mut window = chunk;
///     loop {
///         window = match acc.feed(window) {
///             FeedResult::Consumed => break,
///             FeedResult::Item { item: SickItem::Telegram(telegram), offset, remaining } => {
///                 assert_eq!((telegram.command(), offset), (0xA0, 3));
///                 remaining
///             }
///             other => other.remaining(),
///         };
///     }
/// }
/// let stats = acc.stats();
/// assert_eq!((stats.telegrams_ok, stats.ack, stats.garbage_bytes), (1, 1, 2));
/// ```
#[derive(Debug, Clone)]
pub struct SickAccumulator<const N: usize = DEFAULT_CAPACITY> {
    buf: [u8; N],
    /// First live byte; when the buffer is not empty, where the candidate (or the bytes still
    /// to hunt through, after a rejection) starts.
    start: usize,
    /// One past the last live byte.
    end: usize,
    /// Live bytes from `start` that belong to a rejected candidate: not garbage, and no
    /// ACK/NAK among them is reported.
    shadow: usize,
    /// Length of the telegram handed out by the last call, at `start`; dropped on the next.
    delivered: usize,
    /// Bytes taken from chunks so far.
    consumed: u64,
    stats: SickCounters,
}

impl<const N: usize> Default for SickAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SickAccumulator<N> {
    const CAPACITY_OK: () = assert!(N >= MIN_CAPACITY, "capacity below the smallest telegram");

    /// An empty accumulator with zeroed counters. `N` below 7 does not compile.
    #[must_use]
    pub const fn new() -> Self {
        let () = Self::CAPACITY_OK;
        Self {
            buf: [0; N],
            start: 0,
            end: 0,
            shadow: 0,
            delivered: 0,
            consumed: 0,
            stats: SickCounters {
                telegrams_ok: 0,
                crc_errors: 0,
                length_errors: 0,
                truncated: 0,
                garbage_bytes: 0,
                ack: 0,
                nak: 0,
            },
        }
    }

    /// Feeds a chunk of the stream and returns the first event it completes, with the rest of
    /// the chunk. Call it again with `remaining` until it returns [`FeedResult::Consumed`]; an
    /// empty chunk is fine (it drains events already buffered).
    ///
    /// A telegram handed out stays valid until the next call; the one after drops it.
    pub fn feed<'s, 'c>(&'s mut self, chunk: &'c [u8]) -> SickFeed<'s, 'c> {
        self.release();
        let mut chunk = chunk;
        loop {
            let need = match self.scan() {
                Scan::Step(step, offset) => return self.result(step, offset, chunk),
                Scan::Need(need) => need,
                Scan::Empty => {
                    // Hunt in place: garbage never touches the buffer.
                    let Some(at) = chunk.iter().position(|&b| matches!(b, STX | ACK | NAK)) else {
                        self.garbage(chunk.len());
                        self.take(chunk.len());
                        return FeedResult::Consumed;
                    };
                    self.garbage(at);
                    self.take(at);
                    let Some((&byte, rest)) = chunk.get(at..).and_then(<[u8]>::split_first) else {
                        return FeedResult::Consumed;
                    };
                    let offset = self.consumed;
                    match byte {
                        ACK => {
                            self.take(1);
                            bump(&mut self.stats.ack);
                            return FeedResult::Item {
                                item: SickItem::Ack,
                                offset,
                                remaining: rest,
                            };
                        }
                        NAK => {
                            self.take(1);
                            bump(&mut self.stats.nak);
                            return FeedResult::Item {
                                item: SickItem::Nak,
                                offset,
                                remaining: rest,
                            };
                        }
                        _ => {
                            chunk = chunk.get(at..).unwrap_or(&[]);
                            HEADER_LEN
                        }
                    }
                }
            };
            if chunk.is_empty() {
                return FeedResult::Consumed;
            }
            if self.end.saturating_add(need) > N {
                self.compact();
            }
            let take = need.min(chunk.len()).min(N.saturating_sub(self.end));
            let (head, rest) = chunk.split_at_checked(take).unwrap_or((&[], chunk));
            match self.buf.get_mut(self.end..self.end.saturating_add(take)) {
                Some(dst) if take > 0 && dst.len() == head.len() => {
                    crate::wire::copy_bytes(dst, head)
                }
                // Unreachable by the capacity checks; drop the candidate to keep moving.
                _ => {
                    let (step, offset) = self.reject(1, SickFrameError::Truncated);
                    return self.result(step, offset, chunk);
                }
            }
            self.end += take;
            self.take(take);
            chunk = rest;
        }
    }

    /// Ends the stream: rejects the candidate still incomplete, if any, as
    /// [`SickFrameError::Truncated`] (a lone STX as garbage), and returns the events its bytes
    /// still hold, one per call, until [`FeedResult::Consumed`]. A telegram that started
    /// inside a bogus candidate and is complete is delivered.
    pub fn flush(&mut self) -> SickFeed<'_, 'static> {
        self.release();
        loop {
            match self.scan() {
                Scan::Step(step, offset) => return self.result(step, offset, &[]),
                Scan::Empty => return FeedResult::Consumed,
                Scan::Need(_) => {
                    let live = self.end.saturating_sub(self.start);
                    if live >= 2 {
                        let (step, offset) = self.reject(live, SickFrameError::Truncated);
                        return self.result(step, offset, &[]);
                    }
                    self.discard(live);
                }
            }
        }
    }

    /// The telegram handed out by the last call, while it is valid (until the next call
    /// taking `&mut self`).
    #[must_use]
    pub fn telegram(&self) -> Option<Telegram<&[u8]>> {
        if self.delivered == 0 {
            return None;
        }
        self.buf
            .get(self.start..self.start.saturating_add(self.delivered))
            .map(Telegram::new_unchecked)
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> SickCounters {
        self.stats
    }

    /// Zeroes the counters.
    pub fn clear_stats(&mut self) {
        self.stats = SickCounters::default();
    }

    /// Bytes buffered and not yet resolved (a candidate in progress, or bytes still to hunt
    /// through after a rejection).
    #[must_use]
    pub const fn buffered(&self) -> usize {
        self.end
            .saturating_sub(self.start)
            .saturating_sub(self.delivered)
    }

    /// Bytes taken from chunks since the accumulator was made (wrapping at 2⁶⁴): the stream
    /// position of the next byte fed.
    #[must_use]
    pub const fn position(&self) -> u64 {
        self.consumed
    }

    /// Drops everything buffered (after a baud-rate change, say), uncounted; keeps the counters
    /// and the stream position.
    pub fn reset(&mut self) {
        self.clear_buffer();
    }

    /// Drops the telegram handed out by the last call.
    fn release(&mut self) {
        if self.delivered > 0 {
            self.start = self.start.saturating_add(self.delivered).min(self.end);
            self.delivered = 0;
        }
    }

    /// Resolves what the buffer holds as far as it goes.
    fn scan(&mut self) -> Scan {
        loop {
            let live = match self.buf.get(self.start..self.end) {
                Some(live) if !live.is_empty() => live,
                _ => {
                    self.clear_buffer();
                    return Scan::Empty;
                }
            };
            let len = live.len();
            if live.first() != Some(&STX) {
                let shadow = self.shadow.min(len);
                let hit = live
                    .iter()
                    .enumerate()
                    .position(|(i, &b)| b == STX || (i >= shadow && (b == ACK || b == NAK)));
                let Some(at) = hit else {
                    self.discard(len);
                    continue;
                };
                let byte = live.get(at).copied();
                self.discard(at);
                let step = match byte {
                    Some(ACK) => {
                        bump(&mut self.stats.ack);
                        Step::Ack
                    }
                    Some(NAK) => {
                        bump(&mut self.stats.nak);
                        Step::Nak
                    }
                    _ => continue,
                };
                let offset = self.offset_of(self.start);
                self.start += 1;
                return Scan::Step(step, offset);
            }
            // A candidate starts at `start`.
            let Some(&address) = live.get(1) else {
                return Scan::Need(1);
            };
            if address != ADDRESS_REPLY {
                self.discard(1);
                continue;
            }
            let Some(len_field) = read_u16_le(live, 2) else {
                return Scan::Need(HEADER_LEN - len);
            };
            let payload = usize::from(len_field);
            if payload == 0 || payload > MAX_PAYLOAD_LEN {
                let span = first_inner_header(live, HEADER_LEN);
                let (step, offset) =
                    self.reject(span, SickFrameError::BadLength { len: len_field });
                return Scan::Step(step, offset);
            }
            let total = payload + HEADER_LEN + CRC_LEN;
            if total > N {
                let span = first_inner_header(live, HEADER_LEN);
                let error = SickFrameError::TooLong {
                    len: len_field,
                    capacity: N,
                };
                let (step, offset) = self.reject(span, error);
                return Scan::Step(step, offset);
            }
            let Some(frame) = live.get(..total) else {
                return Scan::Need(total - len);
            };
            let Some((body, &crc)) = frame.split_last_chunk::<CRC_LEN>() else {
                return Scan::Need(1);
            };
            let stored = u16::from_le_bytes(crc);
            let computed = crc16(body);
            if stored == computed {
                bump(&mut self.stats.telegrams_ok);
                self.delivered = total;
                self.shadow = 0;
                return Scan::Step(Step::Telegram(total), self.offset_of(self.start));
            }
            let span = first_inner_header(live, total);
            let error = if span < total {
                SickFrameError::Truncated
            } else {
                SickFrameError::BadCrc { stored, computed }
            };
            let (step, offset) = self.reject(span, error);
            return Scan::Step(step, offset);
        }
    }

    /// Rejects the candidate at `start`, whose own bytes are the first `span`: counts it, and
    /// resumes the hunt at the byte after its STX.
    fn reject(&mut self, span: usize, error: SickFrameError) -> (Step, u64) {
        let counter = match error {
            SickFrameError::BadLength { .. } | SickFrameError::TooLong { .. } => {
                &mut self.stats.length_errors
            }
            SickFrameError::BadCrc { .. } => &mut self.stats.crc_errors,
            SickFrameError::Truncated => &mut self.stats.truncated,
        };
        bump(counter);
        let offset = self.offset_of(self.start);
        self.shadow = self.shadow.saturating_sub(1).max(span.saturating_sub(1));
        self.start = self.start.saturating_add(1).min(self.end);
        (Step::Rejected(error), offset)
    }

    /// Drops `n` live bytes while hunting, counting those outside the shadow as garbage.
    fn discard(&mut self, n: usize) {
        let hidden = n.min(self.shadow);
        self.shadow -= hidden;
        self.garbage(n - hidden);
        self.start = self.start.saturating_add(n).min(self.end);
    }

    fn garbage(&mut self, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.stats.garbage_bytes = self.stats.garbage_bytes.saturating_add(n);
    }

    /// Counts `n` bytes taken from a chunk.
    fn take(&mut self, n: usize) {
        let n = u64::try_from(n).unwrap_or(u64::MAX);
        self.consumed = self.consumed.wrapping_add(n);
    }

    /// The stream position of buffer index `at` (≤ `end`).
    fn offset_of(&self, at: usize) -> u64 {
        let behind = u64::try_from(self.end.saturating_sub(at)).unwrap_or(u64::MAX);
        self.consumed.wrapping_sub(behind)
    }

    /// Moves the live bytes to the front of the buffer.
    fn compact(&mut self) {
        if self.start > 0 && self.start <= self.end && self.end <= N {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
    }

    fn clear_buffer(&mut self) {
        self.start = 0;
        self.end = 0;
        self.shadow = 0;
        self.delivered = 0;
    }

    fn result<'s, 'c>(&'s self, step: Step, offset: u64, remaining: &'c [u8]) -> SickFeed<'s, 'c> {
        match step {
            Step::Telegram(len) => FeedResult::Item {
                item: SickItem::Telegram(Telegram::new_unchecked(
                    self.buf
                        .get(self.start..self.start.saturating_add(len))
                        .unwrap_or(&[]),
                )),
                offset,
                remaining,
            },
            Step::Ack => FeedResult::Item {
                item: SickItem::Ack,
                offset,
                remaining,
            },
            Step::Nak => FeedResult::Item {
                item: SickItem::Nak,
                offset,
                remaining,
            },
            Step::Rejected(error) => FeedResult::Rejected {
                error,
                offset,
                remaining,
            },
        }
    }
}

/// The index of the first `02 80` pair at index 1 or later that lies within `live[..limit]`,
/// or `limit` when there is none: how many bytes a rejected candidate claims for itself.
/// It reads no byte past `limit`, so the answer does not depend on how the stream was cut.
fn first_inner_header(live: &[u8], limit: usize) -> usize {
    let end = limit.min(live.len());
    live.get(..end)
        .and_then(|bytes| {
            bytes
                .windows(2)
                .skip(1)
                .position(|w| w == [STX, ADDRESS_REPLY])
        })
        .map_or(limit, |p| p + 1)
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::test_rng::XorShift;
    use crate::wire::sick::{emit_telegram, MeasuredValues, OperatingModeReply, Unit, MAX_VALUES};
    use std::vec;
    use std::vec::Vec;

    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Ev {
        T(u64, Vec<u8>),
        Ack(u64),
        Nak(u64),
        R(u64, SickFrameError),
    }

    fn record(r: &SickFeed<'_, '_>, out: &mut Vec<Ev>) -> bool {
        match r {
            FeedResult::Consumed => return false,
            FeedResult::Item {
                item: SickItem::Telegram(telegram),
                offset,
                ..
            } => {
                assert!(Telegram::new_checked(telegram.as_bytes()).is_ok());
                out.push(Ev::T(*offset, telegram.as_bytes().to_vec()));
            }
            FeedResult::Item {
                item: SickItem::Ack,
                offset,
                ..
            } => out.push(Ev::Ack(*offset)),
            FeedResult::Item {
                item: SickItem::Nak,
                offset,
                ..
            } => out.push(Ev::Nak(*offset)),
            FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(*offset, *error)),
        }
        true
    }

    fn drive<const N: usize>(acc: &mut SickAccumulator<N>, chunk: &[u8], out: &mut Vec<Ev>) {
        let mut window = chunk;
        loop {
            let r = acc.feed(window);
            window = r.remaining();
            if !record(&r, out) {
                assert!(window.is_empty());
                break;
            }
        }
    }

    fn finish<const N: usize>(acc: &mut SickAccumulator<N>, out: &mut Vec<Ev>) {
        loop {
            let r = acc.flush();
            if !record(&r, out) {
                break;
            }
        }
        assert_eq!(acc.buffered(), 0);
    }

    /// Feeds `stream` cut at the given chunk sizes (cycled), then flushes.
    fn run<const N: usize>(stream: &[u8], sizes: &[usize]) -> (Vec<Ev>, SickCounters) {
        let mut acc = SickAccumulator::<N>::new();
        let out = crate::wire::resync::run_in_chunks!(
            acc,
            stream,
            sizes,
            |r: SickFeed<'_, '_>, out: &mut Vec<Ev>| record(&r, out)
        );
        (out, acc.stats())
    }

    fn whole(stream: &[u8]) -> (Vec<Ev>, SickCounters) {
        run::<DEFAULT_CAPACITY>(stream, &[usize::MAX])
    }

    /// A measured-values reply of `n` values; its bytes hold no `02 80` pair.
    fn scan(n: usize, seed: u16) -> Vec<u8> {
        let values: Vec<u8> = (0..n)
            .flat_map(|i| (0x2000 | ((seed as usize * 7 + i * 13) % 0x1FFF) as u16).to_le_bytes())
            .collect();
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10).unwrap();
        let mut buf = vec![0u8; m.buffer_len()];
        m.emit(&mut buf).unwrap();
        buf
    }

    fn a0() -> Vec<u8> {
        let mut buf = vec![0u8; 9];
        OperatingModeReply {
            result: 0,
            status: 0x10,
        }
        .emit(&mut buf)
        .unwrap();
        buf
    }

    fn stats(f: impl FnOnce(&mut SickCounters)) -> SickCounters {
        let mut s = SickCounters::default();
        f(&mut s);
        s
    }

    /// One kind of damage followed by a valid telegram: what the accumulator must report.
    struct Case {
        name: &'static str,
        damage: Vec<u8>,
        /// Rejections expected, at offsets relative to the damage's start.
        rejected: Vec<(u64, SickFrameError)>,
        /// ACK/NAK events expected, relative offsets.
        acks: Vec<Ev>,
        expect: SickCounters,
    }

    fn cases() -> Vec<Case> {
        let v = scan(361, 1);
        let mut bad_crc = scan(361, 2);
        let last = bad_crc.len() - 1;
        bad_crc[last] ^= 0x01;
        let mut bad_payload = scan(181, 3);
        bad_payload[100] ^= 0x40;
        let (stored, computed) = {
            let t = Telegram::new_unchecked(&bad_crc[..]);
            (t.crc(), t.computed_crc())
        };
        let (stored_p, computed_p) = {
            let t = Telegram::new_unchecked(&bad_payload[..]);
            (t.crc(), t.computed_crc())
        };
        // A telegram with ACK and NAK bytes among its values and a bad CRC.
        let ack_values: Vec<u8> = [0x0606_u16, 0x1515, 0x0615]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let m = MeasuredValues::new(Unit::Millimetre, 0, &ack_values, None, 0).unwrap();
        let mut acky = vec![0u8; m.buffer_len()];
        m.emit(&mut acky).unwrap();
        let last = acky.len() - 1;
        acky[last] ^= 0xFF;
        let (stored_a, computed_a) = {
            let t = Telegram::new_unchecked(&acky[..]);
            (t.crc(), t.computed_crc())
        };
        let len_v = u16::try_from(v.len() - 6).unwrap();
        // Whatever follows starts with STX, which completes the cut telegram's CRC.
        let cut_crc_error = {
            let mut t = v.clone();
            let last = t.len() - 1;
            t[last] = STX;
            let t = Telegram::new_unchecked(&t[..]);
            SickFrameError::BadCrc {
                stored: t.crc(),
                computed: t.computed_crc(),
            }
        };
        vec![
            Case {
                name: "garbage",
                damage: vec![0x11, 0x22, 0x33, 0x80, 0x00],
                rejected: vec![],
                acks: vec![],
                expect: stats(|s| s.garbage_bytes = 5),
            },
            Case {
                name: "ack, nak and garbage",
                damage: vec![0x06, 0x44, 0x15, 0x06],
                rejected: vec![],
                acks: vec![Ev::Ack(0), Ev::Nak(2), Ev::Ack(3)],
                expect: stats(|s| {
                    s.ack = 2;
                    s.nak = 1;
                    s.garbage_bytes = 1;
                }),
            },
            Case {
                name: "lone STX",
                damage: vec![0x02],
                rejected: vec![],
                acks: vec![],
                expect: stats(|s| s.garbage_bytes = 1),
            },
            Case {
                name: "STX then ACK",
                damage: vec![0x02, 0x02, 0x06],
                rejected: vec![],
                acks: vec![Ev::Ack(2)],
                expect: stats(|s| {
                    s.garbage_bytes = 2;
                    s.ack = 1;
                }),
            },
            Case {
                name: "false header with a short LEN",
                damage: vec![0x02, 0x80, 0x05, 0x00],
                rejected: vec![(0, SickFrameError::Truncated)],
                acks: vec![],
                expect: stats(|s| s.truncated = 1),
            },
            Case {
                name: "false header inside garbage",
                damage: vec![0xAA, 0x02, 0x80, 0x10, 0x00, 0xBB, 0x06],
                rejected: vec![(1, SickFrameError::Truncated)],
                acks: vec![],
                expect: stats(|s| {
                    s.truncated = 1;
                    s.garbage_bytes = 1;
                }),
            },
            Case {
                name: "LEN 0",
                damage: vec![0x02, 0x80, 0x00, 0x00],
                rejected: vec![(0, SickFrameError::BadLength { len: 0 })],
                acks: vec![],
                expect: stats(|s| s.length_errors = 1),
            },
            Case {
                name: "LEN 813",
                damage: vec![0x02, 0x80, 0x2D, 0x03, 0x99],
                rejected: vec![(0, SickFrameError::BadLength { len: 813 })],
                acks: vec![],
                expect: stats(|s| {
                    s.length_errors = 1;
                    s.garbage_bytes = 1;
                }),
            },
            Case {
                name: "LEN 0xFFFF",
                damage: vec![0x02, 0x80, 0xFF, 0xFF],
                rejected: vec![(0, SickFrameError::BadLength { len: 0xFFFF })],
                acks: vec![],
                expect: stats(|s| s.length_errors = 1),
            },
            Case {
                name: "header cut after 02 80",
                damage: vec![0x02, 0x80],
                rejected: vec![(0, SickFrameError::BadLength { len: 0x8002 })],
                acks: vec![],
                expect: stats(|s| s.length_errors = 1),
            },
            Case {
                name: "header cut after LEN's first byte",
                damage: v[..3].to_vec(),
                rejected: vec![(0, SickFrameError::Truncated)],
                acks: vec![],
                expect: stats(|s| s.truncated = 1),
            },
            Case {
                name: "telegram cut in its header",
                damage: v[..4].to_vec(),
                rejected: vec![(0, SickFrameError::Truncated)],
                acks: vec![],
                expect: stats(|s| s.truncated = 1),
            },
            Case {
                name: "telegram cut in its payload",
                damage: v[..300].to_vec(),
                rejected: vec![(0, SickFrameError::Truncated)],
                acks: vec![],
                expect: stats(|s| s.truncated = 1),
            },
            Case {
                // The next telegram's STX lands in the CRC: no `02 80` inside the candidate.
                name: "telegram cut in its CRC",
                damage: v[..v.len() - 1].to_vec(),
                rejected: vec![(0, cut_crc_error)],
                acks: vec![],
                expect: stats(|s| s.crc_errors = 1),
            },
            Case {
                name: "bad CRC",
                damage: bad_crc,
                rejected: vec![(0, SickFrameError::BadCrc { stored, computed })],
                acks: vec![],
                expect: stats(|s| s.crc_errors = 1),
            },
            Case {
                name: "bad payload byte",
                damage: bad_payload,
                rejected: vec![(
                    0,
                    SickFrameError::BadCrc {
                        stored: stored_p,
                        computed: computed_p,
                    },
                )],
                acks: vec![],
                expect: stats(|s| s.crc_errors = 1),
            },
            Case {
                name: "ACK and NAK bytes inside a rejected telegram",
                damage: acky,
                rejected: vec![(
                    0,
                    SickFrameError::BadCrc {
                        stored: stored_a,
                        computed: computed_a,
                    },
                )],
                acks: vec![],
                expect: stats(|s| s.crc_errors = 1),
            },
            Case {
                name: "two false headers in a row",
                damage: [&[0x02, 0x80, 0x02, 0x80][..], &len_v.to_le_bytes()].concat(),
                rejected: vec![
                    (0, SickFrameError::BadLength { len: 0x8002 }),
                    (2, SickFrameError::Truncated),
                ],
                acks: vec![],
                expect: stats(|s| {
                    s.length_errors = 1;
                    s.truncated = 1;
                }),
            },
        ]
    }

    /// The valid telegram that follows each damage.
    fn after(i: usize) -> Vec<u8> {
        if i.is_multiple_of(2) {
            scan(361, 100 + i as u16)
        } else {
            a0()
        }
    }

    fn sum(a: SickCounters, b: SickCounters) -> SickCounters {
        SickCounters {
            telegrams_ok: a.telegrams_ok + b.telegrams_ok,
            crc_errors: a.crc_errors + b.crc_errors,
            length_errors: a.length_errors + b.length_errors,
            truncated: a.truncated + b.truncated,
            garbage_bytes: a.garbage_bytes + b.garbage_bytes,
            ack: a.ack + b.ack,
            nak: a.nak + b.nak,
        }
    }

    /// The stream of every case (damage then a valid telegram), with the events and stats it
    /// must produce.
    fn combined() -> (Vec<u8>, Vec<Ev>, SickCounters) {
        let mut stream = a0();
        let mut events = vec![Ev::T(0, stream.clone())];
        let mut total = stats(|s| s.telegrams_ok = 1);
        for (i, case) in cases().into_iter().enumerate() {
            let base = stream.len() as u64;
            let mut evs: Vec<Ev> = case
                .rejected
                .iter()
                .map(|&(o, e)| Ev::R(base + o, e))
                .chain(case.acks.iter().map(|e| match e {
                    Ev::Ack(o) => Ev::Ack(base + o),
                    Ev::Nak(o) => Ev::Nak(base + o),
                    other => other.clone(),
                }))
                .collect();
            evs.sort_by_key(|e| match e {
                Ev::T(o, _) | Ev::Ack(o) | Ev::Nak(o) | Ev::R(o, _) => *o,
            });
            events.extend(evs);
            stream.extend_from_slice(&case.damage);
            let good = after(i);
            events.push(Ev::T(stream.len() as u64, good.clone()));
            stream.extend_from_slice(&good);
            total = sum(total, case.expect);
            total.telegrams_ok += 1;
        }
        (stream, events, total)
    }

    #[test]
    fn each_damage_is_counted_and_the_next_telegram_delivered() {
        for (i, case) in cases().into_iter().enumerate() {
            let good = after(i);
            let stream = [case.damage.clone(), good.clone()].concat();
            let (events, got) = whole(&stream);
            let mut expect = case.expect;
            expect.telegrams_ok += 1;
            assert_eq!(got, expect, "{}", case.name);
            assert_eq!(
                events.last(),
                Some(&Ev::T(case.damage.len() as u64, good)),
                "{}",
                case.name
            );
            let rejected: Vec<_> = events
                .iter()
                .filter_map(|e| match e {
                    Ev::R(o, e) => Some((*o, *e)),
                    _ => None,
                })
                .collect();
            assert_eq!(rejected, case.rejected, "{}", case.name);
            let acks: Vec<_> = events
                .iter()
                .filter(|e| matches!(e, Ev::Ack(_) | Ev::Nak(_)))
                .cloned()
                .collect();
            assert_eq!(acks, case.acks, "{}", case.name);
        }
    }

    #[test]
    fn combined_stream_in_one_chunk() {
        let (stream, events, total) = combined();
        let (got_events, got) = whole(&stream);
        assert_eq!(got, total);
        assert_eq!(got_events, events);
    }

    #[test]
    fn combined_stream_one_byte_at_a_time() {
        let (stream, events, total) = combined();
        let (got_events, got) = run::<DEFAULT_CAPACITY>(&stream, &[1]);
        assert_eq!(got, total);
        assert_eq!(got_events, events);
    }

    #[test]
    fn combined_stream_split_at_every_point() {
        let (stream, events, total) = combined();
        for split in 1..stream.len() {
            let (got_events, got) = run::<DEFAULT_CAPACITY>(&stream, &[split, usize::MAX]);
            assert_eq!(got, total, "split at {split}");
            assert_eq!(got_events, events, "split at {split}");
        }
    }

    #[test]
    fn combined_stream_in_random_chunks() {
        let (stream, events, total) = combined();
        for seed in 1..=200u64 {
            let mut rng = XorShift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let sizes: Vec<usize> = (0..64)
                .map(|_| 1 + rng.below(if seed.is_multiple_of(2) { 16 } else { 900 }) as usize)
                .collect();
            let (got_events, got) = run::<DEFAULT_CAPACITY>(&stream, &sizes);
            assert_eq!(got, total, "seed {seed}");
            assert_eq!(got_events, events, "seed {seed}");
        }
    }

    #[test]
    fn random_noise_never_costs_a_valid_telegram() {
        for seed in 1..=60u64 {
            let mut rng = XorShift(seed.wrapping_mul(0x2545_F491_4F6C_DD1D));
            let mut stream = Vec::new();
            let mut expected = Vec::new();
            for k in 0..40u16 {
                let noise = rng.below(40) as usize;
                for _ in 0..noise {
                    // Plenty of STX, 0x80, ACK and NAK bytes.
                    let b = match rng.below(6) {
                        0 => 0x02,
                        1 => 0x80,
                        2 => 0x06,
                        3 => 0x15,
                        _ => rng.next() as u8,
                    };
                    stream.push(b);
                }
                let t = if k.is_multiple_of(3) {
                    a0()
                } else {
                    scan(1 + rng.below(404) as usize, k)
                };
                if rng.below(5) == 0 {
                    // A cut-off copy before the real one.
                    let cut = 1 + rng.below(t.len() as u64 - 1) as usize;
                    stream.extend_from_slice(&t[..cut]);
                }
                expected.push((stream.len() as u64, t.clone()));
                stream.extend_from_slice(&t);
            }
            let sizes: Vec<usize> = (0..32).map(|_| 1 + rng.below(100) as usize).collect();
            let (events, got) = run::<DEFAULT_CAPACITY>(&stream, &sizes);
            let delivered: Vec<_> = events
                .into_iter()
                .filter_map(|e| match e {
                    Ev::T(o, b) => Some((o, b)),
                    _ => None,
                })
                .collect();
            assert_eq!(delivered, expected, "seed {seed}");
            assert_eq!(got.telegrams_ok, 40);
        }
    }

    #[test]
    fn flush_reports_a_telegram_cut_by_the_end_of_the_stream() {
        let v = scan(10, 5);
        let mut acc = SickAccumulator::<DEFAULT_CAPACITY>::new();
        let mut out = Vec::new();
        drive(&mut acc, &v[..v.len() - 3], &mut out);
        assert!(out.is_empty());
        assert_eq!(acc.buffered(), v.len() - 3);
        finish(&mut acc, &mut out);
        assert_eq!(out, [Ev::R(0, SickFrameError::Truncated)]);
        assert_eq!(acc.stats(), stats(|s| s.truncated = 1));
    }

    #[test]
    fn flush_delivers_a_telegram_inside_a_bogus_candidate() {
        // A false header claiming 700 bytes, then a complete reply, then the end.
        let mut stream = vec![0x02, 0x80, 0xBC, 0x02, 0x77];
        let good = a0();
        stream.extend_from_slice(&good);
        stream.push(0x02);
        let mut acc = SickAccumulator::<DEFAULT_CAPACITY>::new();
        let mut out = Vec::new();
        drive(&mut acc, &stream, &mut out);
        assert!(out.is_empty());
        finish(&mut acc, &mut out);
        assert_eq!(
            out,
            [Ev::R(0, SickFrameError::Truncated), Ev::T(5, good.clone())]
        );
        // The lone STX at the end is garbage; the false candidate's bytes are not.
        assert_eq!(
            acc.stats(),
            stats(|s| {
                s.truncated = 1;
                s.telegrams_ok = 1;
                s.garbage_bytes = 1;
            })
        );
    }

    #[test]
    fn small_capacity_rejects_long_telegrams_and_keeps_short_ones() {
        let long = scan(100, 9);
        let short = a0();
        let stream = [long.clone(), short.clone()].concat();
        for sizes in [&[usize::MAX][..], &[1], &[7, 3]] {
            let (events, got) = run::<64>(&stream, sizes);
            assert_eq!(
                events.first(),
                Some(&Ev::R(
                    0,
                    SickFrameError::TooLong {
                        len: 204,
                        capacity: 64
                    }
                ))
            );
            assert_eq!(
                events.last(),
                Some(&Ev::T(long.len() as u64, short.clone()))
            );
            assert_eq!(got.length_errors, 1);
            assert_eq!(got.telegrams_ok, 1);
        }
        // The largest telegram fits the default capacity exactly.
        let max = scan(MAX_VALUES, 4);
        assert_eq!(max.len(), DEFAULT_CAPACITY);
        let (events, got) = run::<DEFAULT_CAPACITY>(&max, &[5]);
        assert_eq!(events, [Ev::T(0, max.clone())]);
        assert_eq!(got.telegrams_ok, 1);
        // The smallest capacity still works for the smallest telegram.
        let mut tiny = [0u8; 7];
        emit_telegram(ADDRESS_REPLY, &[0x99], &mut tiny).unwrap();
        let (events, _) = run::<7>(&[&[0x02, 0x80, 0x05, 0x00][..], &tiny].concat(), &[1]);
        assert_eq!(events.last(), Some(&Ev::T(4, tiny.to_vec())));
    }

    #[test]
    fn telegram_accessor_and_reset() {
        let good = a0();
        let mut acc = SickAccumulator::<DEFAULT_CAPACITY>::new();
        assert!(acc.telegram().is_none());
        let r = acc.feed(&good);
        assert!(matches!(
            r,
            FeedResult::Item {
                item: SickItem::Telegram(_),
                ..
            }
        ));
        assert_eq!(
            acc.telegram().map(|t| t.as_bytes().to_vec()),
            Some(good.clone())
        );
        assert!(matches!(acc.feed(&[]), FeedResult::Consumed));
        assert!(acc.telegram().is_none());
        drive(&mut acc, &good[..5], &mut Vec::new());
        assert_eq!(acc.buffered(), 5);
        acc.reset();
        assert_eq!(acc.buffered(), 0);
        let mut out = Vec::new();
        drive(&mut acc, &good, &mut out);
        assert_eq!(out, [Ev::T(14, good)]);
        acc.clear_stats();
        assert_eq!(acc.stats(), SickCounters::default());
    }

    #[test]
    fn counters_saturate() {
        let mut acc = SickAccumulator::<DEFAULT_CAPACITY>::new();
        acc.stats.garbage_bytes = u32::MAX - 1;
        acc.stats.ack = u32::MAX;
        drive(&mut acc, &[0x11, 0x22, 0x33, 0x06], &mut Vec::new());
        assert_eq!(acc.stats().garbage_bytes, u32::MAX);
        assert_eq!(acc.stats().ack, u32::MAX);
    }

    #[test]
    fn a_valid_telegram_may_carry_02_80_in_its_values() {
        let values: Vec<u8> = [0x8002_u16, 0x8002, 0x0280]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0).unwrap();
        let mut t = vec![0u8; m.buffer_len()];
        m.emit(&mut t).unwrap();
        let stream = [t.clone(), a0()].concat();
        for n in 1..stream.len() {
            let (events, got) = run::<DEFAULT_CAPACITY>(&stream, &[n]);
            assert_eq!(events, [Ev::T(0, t.clone()), Ev::T(t.len() as u64, a0())]);
            assert_eq!(got, stats(|s| s.telegrams_ok = 2));
        }
    }

    #[test]
    fn frame_errors_display() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            SickFrameError::BadLength { len: 0 }.to_string(),
            "impossible telegram length 0"
        );
        assert_eq!(SickFrameError::Truncated.to_string(), "telegram truncated");
    }
}
