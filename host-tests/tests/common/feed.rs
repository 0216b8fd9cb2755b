//! Feeding the spinning lidars' accumulators a chunked stream, and tallying what they hand
//! out.

use super::{feed_chunks, Units};
use terrain_pyramid::wire::ld06::{Ld06Accumulator, Ld06Counters, Ld06Error, Ld06Packet};
use terrain_pyramid::wire::rplidar::{
    RplidarAccumulator, RplidarCounters, RplidarError, RplidarItem, RplidarNode,
};
use terrain_pyramid::wire::ydlidar::{
    YdlidarAccumulator, YdlidarCounters, YdlidarError, YdlidarItem, YdlidarPacket,
};
use terrain_pyramid::wire::FeedResult;

/// An accumulator of a lidar's stream: `feed` a chunk, `flush` at the end of the stream.
pub trait Accumulate {
    /// The unit it hands out, borrowing the accumulator.
    type Unit<'s>
    where
        Self: 's;
    /// Why it refuses a candidate.
    type Error;
    /// The accumulator's `feed`: one result from `chunk`.
    fn feed_chunk<'s, 'c>(
        &'s mut self,
        chunk: &'c [u8],
    ) -> FeedResult<'c, Self::Unit<'s>, Self::Error>;
    /// The accumulator's `flush`: one result from what is buffered at the end of the stream.
    fn flush_end(&mut self) -> FeedResult<'static, Self::Unit<'_>, Self::Error>;
    /// Its counters.
    type Counters;
    /// The accumulator's `counters`.
    fn counters_now(&self) -> Self::Counters;
    /// The accumulator's `buffered`: bytes held, not yet handed out or refused.
    fn buffered_now(&self) -> usize;
    /// The accumulator's `position`: bytes fed so far.
    fn position_now(&self) -> u64;
}

/// `Accumulate` for an accumulator whose `feed` and `flush` hand out `$unit` (borrowing it
/// for `'s`) or refuse with `$error`: three accumulators of the library with the same two
/// inherent methods and no trait of their own.
macro_rules! accumulate {
    ($acc:ty, $unit:ty, $error:ty, $counters:ty) => {
        impl Accumulate for $acc {
            type Unit<'s> = $unit;
            type Error = $error;
            type Counters = $counters;
            fn counters_now(&self) -> $counters {
                self.counters()
            }
            fn buffered_now(&self) -> usize {
                self.buffered()
            }
            fn position_now(&self) -> u64 {
                self.position()
            }
            fn feed_chunk<'s, 'c>(&'s mut self, chunk: &'c [u8]) -> FeedResult<'c, $unit, $error> {
                self.feed(chunk)
            }
            fn flush_end(&mut self) -> FeedResult<'static, Self::Unit<'_>, $error> {
                self.flush()
            }
        }
    };
}

accumulate!(
    Ld06Accumulator,
    Ld06Packet<&'s [u8]>,
    Ld06Error,
    Ld06Counters
);
accumulate!(
    YdlidarAccumulator,
    YdlidarItem<'s>,
    YdlidarError,
    YdlidarCounters
);
accumulate!(
    RplidarAccumulator,
    RplidarItem<'s>,
    RplidarError,
    RplidarCounters
);

/// Feeds every chunk to `acc` (again on what is left of a chunk until it is consumed), then
/// flushes it until it has nothing more; `note` sees every result and says whether to go on
/// (`false` for `Consumed`).
pub fn feed_all<A: Accumulate>(
    acc: &mut A,
    chunks: &[&[u8]],
    mut note: impl FnMut(FeedResult<'_, A::Unit<'_>, A::Error>) -> bool,
) {
    feed_chunks(chunks, |window| {
        let r = acc.feed_chunk(window);
        (r.remaining(), note(r))
    });
    while note(acc.flush_end()) {}
}

/// What an accumulator handed out: the units a test keeps and the candidates it refused.
#[derive(Debug, Default)]
pub struct Tally {
    /// The units kept, in order: stream offset of the first byte and the unit's bytes.
    pub delivered: Units,
    /// Candidates refused.
    pub rejected: u32,
}

impl Tally {
    /// Notes `result`: a unit's offset and `bytes(unit)` when that is `Some`, or one refusal.
    /// `false` when the chunk was consumed (feed the next one), as [`feed_all`] wants.
    pub fn note<T, E>(
        &mut self,
        result: FeedResult<'_, T, E>,
        bytes: impl FnOnce(T) -> Option<Vec<u8>>,
    ) -> bool {
        match result {
            FeedResult::Consumed => false,
            FeedResult::Item { item, offset, .. } => {
                if let Some(b) = bytes(item) {
                    self.delivered.push((offset, b));
                }
                true
            }
            FeedResult::Rejected { .. } => {
                self.rejected += 1;
                true
            }
        }
    }
}

/// Feeds `chunks` to `acc` as [`feed_all`] and tallies what it hands out, keeping the units
/// `keep` gives bytes for.
pub fn tally<A: Accumulate>(
    acc: &mut A,
    chunks: &[&[u8]],
    mut keep: impl FnMut(A::Unit<'_>) -> Option<Vec<u8>>,
) -> Tally {
    let mut tally = Tally::default();
    feed_all(acc, chunks, |r| tally.note(r, &mut keep));
    tally
}

/// An LD06 packet's bytes, once it is checked to parse (panics if not).
pub fn checked_ld06(packet: Ld06Packet<&[u8]>) -> Option<Vec<u8>> {
    assert!(Ld06Packet::new_checked(packet.as_bytes()).is_ok());
    Some(packet.as_bytes().to_vec())
}

/// A YDLIDAR unit's bytes, a packet once it is checked to parse (panics if not).
pub fn checked_ydlidar(item: YdlidarItem<'_>) -> Option<Vec<u8>> {
    if let YdlidarItem::Packet(p) = item {
        assert!(YdlidarPacket::new_checked(p.as_bytes()).is_ok());
    }
    Some(item.as_bytes().to_vec())
}

/// An RPLIDAR node's bytes, once it is checked to parse (panics if not); `None` for every
/// other unit.
pub fn checked_node(item: RplidarItem<'_>) -> Option<Vec<u8>> {
    let RplidarItem::Node(n) = item else {
        return None;
    };
    assert!(RplidarNode::new_checked(n.as_bytes()).is_ok());
    Some(n.as_bytes().to_vec())
}

/// Feeds `chunks` to `acc` and flushes it, keeping the units `keep` gives bytes for; checks
/// that nothing stays buffered. Returns the kept units, the refusals, the counters and the
/// stream position (bytes).
pub fn run_to_end<A: Accumulate>(
    mut acc: A,
    chunks: &[&[u8]],
    keep: impl FnMut(A::Unit<'_>) -> Option<Vec<u8>>,
) -> (Units, usize, A::Counters, u64) {
    let t = tally(&mut acc, chunks, keep);
    assert_eq!(acc.buffered_now(), 0);
    (
        t.delivered,
        t.rejected as usize,
        acc.counters_now(),
        acc.position_now(),
    )
}
