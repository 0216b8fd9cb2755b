//! The resynchronising loop the spinning lidars' accumulators share (LD06, RPLIDAR,
//! YDLIDAR), in the manner of postcard's feed accumulator.
//!
//! Each accumulator keeps a [`Window`] and says, through [`Resync`], what its units look
//! like: which byte may start one, how many bytes to take first, what the front of the window
//! resolves to ([`Resync::scan`]), and what the end of the stream does to a unit in progress.
//! [`feed`] and [`flush`] are the loop around it, written once: garbage is skipped in place
//! while nothing is buffered, and the window takes from each chunk only the bytes the unit at
//! its front still needs. Nothing here panics.

use super::window::Window;
use super::FeedResult;

/// The accessors each accumulator has over its `counters` and `window` fields, written once:
/// `counters`, `clear_counters`, `buffered` (with the doc given, as what it leaves out differs
/// between the accumulators) and `position`. Expands inside the accumulator's `impl` block;
/// `$counters` is its counters' type.
macro_rules! stream_accessors {
    ($counters:ty, $buffered_doc:literal) => {
        /// The counters.
        #[must_use]
        pub const fn counters(&self) -> $counters {
            self.counters
        }

        /// Zeroes the counters.
        pub fn clear_counters(&mut self) {
            self.counters = <$counters>::default();
        }

        #[doc = $buffered_doc]
        #[must_use]
        pub const fn buffered(&self) -> usize {
            self.window.unresolved()
        }

        /// Bytes taken from chunks since the accumulator was made (wrapping at 2⁶⁴): the
        /// stream position of the next byte fed.
        #[must_use]
        pub const fn position(&self) -> u64 {
            self.window.position()
        }
    };
}
pub(crate) use stream_accessors;

/// `feed` and `flush` for an accumulator handing out `$item<'_>`s and refusing candidates
/// with `$error`, written once: they are [`feed`] and [`flush`] on it. Expands inside the
/// accumulator's `impl` block, where [`FeedResult`] is in scope; `$flush_doc` says what the
/// end of the stream does to what it holds.
macro_rules! feed_and_flush {
    ($item:ident, $error:ty, $flush_doc:literal) => {
        /// Feeds a chunk of the stream and returns the first item or rejection it completes,
        /// with the rest of the chunk. Call it again with `remaining` until it returns
        /// [`FeedResult::Consumed`]; an empty chunk is fine.
        ///
        /// An item handed out borrows the accumulator until the next call.
        pub fn feed<'s, 'c>(&'s mut self, chunk: &'c [u8]) -> FeedResult<'c, $item<'s>, $error> {
            $crate::wire::resync::feed(self, chunk)
        }

        #[doc = $flush_doc]
        pub fn flush(&mut self) -> FeedResult<'static, $item<'_>, $error> {
            $crate::wire::resync::flush(self)
        }
    };
}
pub(crate) use feed_and_flush;

/// `Default` (what `new` makes) and, with the `defmt` feature, `defmt::Format` (the bytes
/// buffered, the stream position and the counters, on one line) for the accumulator `$name`,
/// one without a capacity parameter, written once.
macro_rules! accumulator_impls {
    ($name:ident) => {
        impl Default for $name {
            fn default() -> Self {
                Self::new()
            }
        }

        #[cfg(feature = "defmt")]
        impl defmt::Format for $name {
            fn format(&self, f: defmt::Formatter<'_>) {
                defmt::write!(
                    f,
                    "{=str} {{ buffered: {=usize}, position: {=u64}, counters: {} }}",
                    stringify!($name),
                    self.buffered(),
                    self.position(),
                    self.counters
                );
            }
        }
    };
}
pub(crate) use accumulator_impls;

/// What the front of an accumulator's window resolves to.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Scan<E> {
    /// A unit handed out (its length recorded by the accumulator), at this stream position.
    Item(u64),
    /// A candidate refused and counted, at this stream position.
    Rejected(E, u64),
    /// The front needs `more` bytes (≥ 1). `candidate` when the front is a unit in progress
    /// (truncated at the end of the stream) rather than bytes still being hunted through (a
    /// lone sync byte, counted as garbage at the end).
    Need {
        /// Bytes still needed, at least 1.
        more: usize,
        /// Whether the front is a unit in progress.
        candidate: bool,
    },
    /// Nothing buffered.
    Empty,
}

/// An accumulator over a [`Window`] of `N` bytes, as [`feed`] and [`flush`] drive it.
pub(crate) trait Resync<const N: usize> {
    /// What it hands out, borrowing its window.
    type Item<'a>
    where
        Self: 'a;
    /// Why it refuses a candidate.
    type Error;

    /// The window units are reassembled in.
    fn window(&mut self) -> &mut Window<N>;

    /// Drops the unit handed out by the last call.
    fn release(&mut self) {
        self.window().release();
    }

    /// Resolves the front of the window as far as it goes.
    fn scan(&mut self) -> Scan<Self::Error>;

    /// The unit [`Scan::Item`] announced.
    fn item(&self) -> Self::Item<'_>;

    /// Whether `byte` may start a unit (bytes before one are skipped in place as garbage).
    fn may_start(&self, byte: u8) -> bool;

    /// How many bytes to take first for a unit starting at the front.
    fn first_need(&self) -> usize;

    /// Counts `n` bytes outside every unit as garbage.
    fn count_garbage(&mut self, n: usize);

    /// At the end of the stream, refuses the unit in progress at the front (counts it and
    /// drops at least its first byte): the error and the stream position.
    fn truncate(&mut self) -> (Self::Error, u64);

    /// At the end of the stream, once the window is empty: a last refusal to report (a unit
    /// kept aside), or `None`.
    fn end(&mut self) -> Option<(Self::Error, u64)> {
        None
    }
}

/// Feeds a chunk to `acc` and returns the first unit or refusal it completes, with the rest
/// of the chunk ([`FeedResult::Consumed`] when the chunk is spent).
#[inline]
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
            Scan::Need { more, .. } => more,
            Scan::Empty => {
                // Hunt in place: garbage never touches the window.
                let at = chunk
                    .iter()
                    .position(|&b| acc.may_start(b))
                    .unwrap_or(chunk.len());
                acc.count_garbage(at);
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

/// Ends the stream for `acc`: refuses a unit still in progress ([`Resync::truncate`]),
/// counts a lone byte still hunted through as garbage, and hands out what the bytes after a
/// refusal still hold. Call it until it returns [`FeedResult::Consumed`].
#[inline]
pub(crate) fn flush<const N: usize, A: Resync<N>>(
    acc: &mut A,
) -> FeedResult<'static, A::Item<'_>, A::Error> {
    acc.release();
    loop {
        let (error, offset) = match acc.scan() {
            Scan::Item(offset) => {
                return FeedResult::Item {
                    item: acc.item(),
                    offset,
                    remaining: &[],
                }
            }
            Scan::Rejected(error, offset) => (error, offset),
            Scan::Empty => match acc.end() {
                Some(refused) => refused,
                None => return FeedResult::Consumed,
            },
            Scan::Need {
                candidate: true, ..
            } => acc.truncate(),
            Scan::Need {
                candidate: false, ..
            } => {
                acc.count_garbage(1);
                acc.window().drop_front(1);
                continue;
            }
        };
        return FeedResult::Rejected {
            error,
            offset,
            remaining: &[],
        };
    }
}

/// Feeds `stream` cut in chunks of the given sizes (cycled, each at least 1 byte): each chunk
/// goes to `feed`, then what `feed` returns of it, until `feed` returns `None` (the chunk
/// spent).
#[cfg(test)]
pub(crate) fn feed_in_chunks<'c>(
    stream: &'c [u8],
    sizes: &[usize],
    mut feed: impl FnMut(&'c [u8]) -> Option<&'c [u8]>,
) {
    let mut rest = stream;
    let mut i = 0;
    while !rest.is_empty() {
        let n = sizes
            .get(i % sizes.len().max(1))
            .copied()
            .unwrap_or(usize::MAX)
            .clamp(1, rest.len());
        i += 1;
        let (chunk, tail) = rest.split_at(n);
        rest = tail;
        let mut window = chunk;
        while let Some(left) = feed(window) {
            window = left;
        }
    }
}

/// Runs `stream` through the accumulator `$acc` in chunks of the sizes `$sizes`
/// ([`feed_in_chunks`]), one `feed` call at a time on what is left of each chunk, then
/// `flush` calls until one hands out nothing; `$record(result, &mut events)` records each
/// call's result and says whether it handed out something. Checks that nothing stays
/// buffered and that the position is the stream's length; evaluates to the events.
///
/// A macro: the accumulators share `feed`, `flush`, `buffered` and `position` by name, not
/// through a trait.
#[cfg(test)]
macro_rules! run_in_chunks {
    ($acc:expr, $stream:expr, $sizes:expr, $record:expr) => {{
        let acc = &mut $acc;
        let stream: &[u8] = $stream;
        let mut events = std::vec::Vec::new();
        $crate::wire::resync::feed_in_chunks(stream, $sizes, |window| {
            let r = acc.feed(window);
            let left = r.remaining();
            $record(r, &mut events).then_some(left)
        });
        while $record(acc.flush(), &mut events) {}
        assert_eq!(acc.buffered(), 0);
        assert_eq!(acc.position(), stream.len() as u64);
        events
    }};
}
#[cfg(test)]
pub(crate) use run_in_chunks;
