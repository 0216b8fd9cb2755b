//! The hunt-and-refill loop the spinning lidars' accumulators share (LD06, RPLIDAR, YDLIDAR):
//! what [`feed`] and [`flush`] do around a protocol's own checks.
//!
//! An accumulator keeps its candidate unit in a [`Window`] and knows how to resolve the
//! window's front ([`Resync::scan`]): a unit that passed every check, a refused candidate
//! (counted, its first byte dropped, so the bytes after it are hunted through again), a unit
//! that needs more bytes, or nothing buffered. Around that, every accumulator does the same:
//! - **feed**: drop the unit handed out by the last call; scan; when nothing is buffered, skip
//!   in place the bytes of the chunk that cannot start a unit (counted as garbage, never
//!   copied); otherwise copy as many bytes as the unit at the front still needs; until the
//!   chunk is used up or a unit or a refusal comes out.
//! - **flush**: the same without a chunk; a unit still incomplete at the end of the stream is
//!   the accumulator's to refuse or to count as garbage ([`Resync::cut_short`]).
//!
//! Both are `#[inline(always)]`: each accumulator's `feed` compiles to the loop it had when it
//! was written out in full (the per-return instruction counts of `cargo xtask bench --lidars`).

use crate::wire::window::{bump_by, Window};
use crate::wire::FeedResult;

/// What a scan of the window's front found.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Scan<E, W = usize> {
    /// A unit that passed every check is at the front (its length is the accumulator's
    /// `delivered`); the stream position of its first byte.
    Item(u64),
    /// A candidate was refused (counted, its first byte dropped); its stream position.
    Rejected(E, u64),
    /// The unit at the front needs more bytes: how many ([`Need::more`]), with what the
    /// accumulator wants to know should the stream end there.
    Need(W),
    /// Nothing is buffered.
    Empty,
}

/// How many more bytes a unit at the window's front needs.
pub(crate) trait Need: Copy {
    /// The bytes to copy before the next scan.
    fn more(self) -> usize;
}

impl Need for usize {
    #[inline(always)]
    fn more(self) -> usize {
        self
    }
}

/// A protocol's part of an accumulator: its window, its checks and its units.
pub(crate) trait Resync<const N: usize> {
    /// What the accumulator hands out (borrowing its buffer).
    type Item<'s>
    where
        Self: 's;
    /// Why it refuses a candidate.
    type Error;
    /// What a scan says of a unit still incomplete.
    type Need: Need;

    /// The window the units are reassembled in.
    fn window(&mut self) -> &mut Window<N>;
    /// Drops the unit handed out by the last call.
    fn release(&mut self);
    /// Resolves the front of the window as far as it goes.
    fn scan(&mut self) -> Scan<Self::Error, Self::Need>;
    /// The unit at the front, after [`Scan::Item`].
    fn item(&self) -> Self::Item<'_>;
    /// Whether byte `b` may start a unit (with nothing buffered, the bytes before one are
    /// garbage, skipped in place).
    fn may_start(&self, b: u8) -> bool;
    /// How many bytes to take first for a unit starting at the front.
    fn first_need(&self) -> usize;
    /// The counter of the bytes outside every candidate.
    fn garbage_bytes(&mut self) -> &mut u32;
    /// The stream ends with an incomplete unit at the front: a refusal, or `None` once the
    /// accumulator has dropped (and counted) what it does not refuse.
    fn cut_short(&mut self, need: Self::Need) -> Option<(Self::Error, u64)>;
    /// The stream ends with nothing buffered: what is still kept outside the window to
    /// refuse, if anything.
    fn ends_empty(&mut self) -> Option<(Self::Error, u64)> {
        None
    }
}

/// Feeds `chunk` to `acc`: the first unit or refusal it completes, with the rest of the chunk
/// ([`FeedResult`]).
#[inline(always)]
pub(crate) fn feed<'s, 'c, const N: usize, A: Resync<N>>(
    acc: &'s mut A,
    chunk: &'c [u8],
) -> FeedResult<'c, A::Item<'s>, A::Error> {
    acc.release();
    let mut chunk = chunk;
    loop {
        let need = match acc.scan() {
            Scan::Item(offset) => {
                return FeedResult::Item {
                    item: acc.item(),
                    offset,
                    remaining: chunk,
                }
            }
            Scan::Rejected(error, offset) => {
                return FeedResult::Rejected {
                    error,
                    offset,
                    remaining: chunk,
                }
            }
            Scan::Need(need) => need.more(),
            Scan::Empty => {
                // Hunt in place: garbage never touches the buffer.
                let at = chunk
                    .iter()
                    .position(|&b| acc.may_start(b))
                    .unwrap_or(chunk.len());
                bump_by(acc.garbage_bytes(), at);
                acc.window().skip(at);
                chunk = chunk.get(at..).unwrap_or(&[]);
                acc.first_need()
            }
        };
        if chunk.is_empty() {
            return FeedResult::Consumed;
        }
        chunk = acc.window().fill(chunk, need);
    }
}

/// Ends the stream of `acc`: the units and refusals its buffered bytes still hold, one per
/// call, until [`FeedResult::Consumed`].
#[inline(always)]
pub(crate) fn flush<const N: usize, A: Resync<N>>(
    acc: &mut A,
) -> FeedResult<'static, A::Item<'_>, A::Error> {
    acc.release();
    loop {
        let refused = match acc.scan() {
            Scan::Item(offset) => {
                return FeedResult::Item {
                    item: acc.item(),
                    offset,
                    remaining: &[],
                }
            }
            Scan::Rejected(error, offset) => Some((error, offset)),
            Scan::Empty => match acc.ends_empty() {
                None => return FeedResult::Consumed,
                refused => refused,
            },
            Scan::Need(need) => acc.cut_short(need),
        };
        if let Some((error, offset)) = refused {
            return FeedResult::Rejected {
                error,
                offset,
                remaining: &[],
            };
        }
    }
}
