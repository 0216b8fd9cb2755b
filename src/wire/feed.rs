//! What an accumulator hands out: the one result type of every `feed` in [`crate::wire`], in
//! the manner of postcard's `FeedResult`. An accumulator takes a chunk of a byte stream, stops
//! at the first unit it completes (a telegram, a packet, a frame) or refuses, and returns the
//! rest of the chunk, so the caller loops until [`FeedResult::Consumed`]:
//!
//! ```text
//! let mut chunk = bytes;
//! loop {
//!     chunk = match accumulator.feed(chunk) {
//!         FeedResult::Consumed => break,
//!         FeedResult::Item { item, remaining, .. } => { use(item); remaining }
//!         FeedResult::Rejected { remaining, .. } => remaining, // counted by the accumulator
//!     };
//! }
//! ```

/// The outcome of one `feed` of an accumulator of [`crate::wire`]: `T` is what it completes
/// (usually a view borrowing its buffer, valid until the next call), `E` why it refuses a
/// candidate.
///
/// `offset` is the position in the stream (bytes fed since the accumulator was made,
/// wrapping at 2⁶⁴) of the first byte of the unit or of the refused candidate.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FeedResult<'c, T, E> {
    /// The whole chunk was taken and nothing complete is buffered: feed the next chunk.
    Consumed,
    /// A unit that passed every check.
    Item {
        /// The unit.
        item: T,
        /// Stream position of its first byte.
        offset: u64,
        /// The part of the chunk not yet taken.
        remaining: &'c [u8],
    },
    /// A candidate failed a check (and was counted); the hunt for the next one goes on.
    Rejected {
        /// Why.
        error: E,
        /// Stream position of the candidate's first byte.
        offset: u64,
        /// The part of the chunk not yet taken.
        remaining: &'c [u8],
    },
}

impl<'c, T, E> FeedResult<'c, T, E> {
    /// The part of the chunk not yet taken (empty for `Consumed`).
    #[must_use]
    pub fn remaining(&self) -> &'c [u8] {
        match self {
            Self::Consumed => &[],
            Self::Item { remaining, .. } | Self::Rejected { remaining, .. } => remaining,
        }
    }
}
