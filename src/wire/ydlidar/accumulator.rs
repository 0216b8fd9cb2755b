//! Stream reassembly: packets and descriptors out of arbitrary UART chunks.

use super::command::known_content_len;
use super::{
    read_u16_le, ydlidar_checksum, YdlidarDescriptor, YdlidarError, YdlidarPacket,
    YDLIDAR_DESCRIPTOR_LEN, YDLIDAR_DESCRIPTOR_SYNC, YDLIDAR_MAX_PACKET_LEN, YDLIDAR_PACKET_HEADER,
    YDLIDAR_PACKET_HEADER_LEN,
};
use crate::wire::resync::{self, Resync, Scan};
use crate::wire::window::{bump, bump_by, Window};
use crate::wire::FeedResult;

/// The default capacity of a [`YdlidarAccumulator`]: the longest packet, 520 bytes.
pub const YDLIDAR_DEFAULT_CAPACITY: usize = YDLIDAR_MAX_PACKET_LEN;

/// The smallest capacity: a device-information descriptor and its 20 bytes.
const MIN_CAPACITY: usize = YDLIDAR_DESCRIPTOR_LEN + 20;

/// What a [`YdlidarAccumulator`] hands out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YdlidarItem<'a> {
    /// A point-cloud packet that passed every check.
    Packet(YdlidarPacket<&'a [u8]>),
    /// A known response descriptor (scan, device information, health), with the content of a
    /// single response.
    Descriptor(YdlidarDescriptor<&'a [u8]>),
}

impl<'a> YdlidarItem<'a> {
    /// The item's bytes as they arrived.
    #[must_use]
    pub fn as_bytes(&self) -> &'a [u8] {
        match *self {
            Self::Packet(p) => p.into_inner(),
            Self::Descriptor(d) => d.into_inner(),
        }
    }
}

/// What a [`YdlidarAccumulator`] has seen since it was made (or since
/// [`YdlidarAccumulator::clear_counters`]). Every counter saturates at `u32::MAX`.
///
/// Every byte fed is accounted for exactly once: after [`YdlidarAccumulator::flush`], the
/// stream length is the bytes of the items handed out plus `checksum + check_bits +
/// bad_length + truncated + garbage_bytes` (a rejected candidate accounts for its first
/// byte; the bytes after it are hunted through again).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YdlidarCounters {
    /// Packets handed out.
    pub packets: u32,
    /// Known descriptors handed out.
    pub descriptors: u32,
    /// Candidate packets whose check code did not match.
    pub checksum: u32,
    /// Candidate packets with the check bit of FSA or LSA clear.
    pub check_bits: u32,
    /// Candidate packets with LSN 0 or longer than the capacity.
    pub bad_length: u32,
    /// Candidates (a sync pair and less than the rest) cut short by the end of the stream.
    pub truncated: u32,
    /// Bytes outside every candidate (an `AA` or `A5` not followed by its pair, an unknown
    /// descriptor's bytes included).
    pub garbage_bytes: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Packet,
    Descriptor,
}

/// Reassembles YDLIDAR packets and descriptors from a byte stream fed in chunks of any size.
///
/// `N` is the capacity in bytes: [`YDLIDAR_DEFAULT_CAPACITY`] (520) holds every packet; a
/// smaller one (at least 27) saves RAM and refuses longer packets as
/// [`YdlidarError::TooLong`] (the X4 sends packets of up to 40 samples, 90 bytes).
///
/// ```
/// use terrain_pyramid::wire::ydlidar::{YdlidarAccumulator, YdlidarItem, YdlidarRepr};
/// use terrain_pyramid::wire::FeedResult;
///
/// let mut stream = vec![0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81, 0x13];
/// let repr = YdlidarRepr { packet_type: 1, first_angle_q6: 0, last_angle_q6: 0, samples: &[4000] };
/// let mut packet = [0; 12];
/// repr.emit(&mut packet).unwrap();
/// stream.extend_from_slice(&packet);
///
/// let mut acc: YdlidarAccumulator = YdlidarAccumulator::new();
/// let mut kinds = Vec::new();
/// for chunk in stream.chunks(3) {
///     let mut window = chunk;
///     loop {
///         window = match acc.feed(window) {
///             FeedResult::Consumed => break,
///             FeedResult::Item { item: YdlidarItem::Packet(p), remaining, .. } => {
///                 assert!(p.starts_revolution());
///                 kinds.push("packet");
///                 remaining
///             }
///             FeedResult::Item { remaining, .. } => { kinds.push("descriptor"); remaining }
///             FeedResult::Rejected { remaining, .. } => remaining,
///         };
///     }
/// }
/// assert_eq!(kinds, ["descriptor", "packet"]);
/// assert_eq!(acc.counters().garbage_bytes, 1);
/// ```
#[derive(Debug, Clone)]
pub struct YdlidarAccumulator<const N: usize = YDLIDAR_DEFAULT_CAPACITY> {
    window: Window<N>,
    /// The kind of the item handed out by the last call, at the front.
    kind: Kind,
    counters: YdlidarCounters,
}

impl<const N: usize> Default for YdlidarAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(feature = "defmt")]
impl<const N: usize> defmt::Format for YdlidarAccumulator<N> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "YdlidarAccumulator {{ buffered: {=usize}, capacity: {=usize}, position: {=u64}, counters: {} }}",
            self.buffered(),
            N,
            self.position(),
            self.counters
        );
    }
}

fn is_sync_start(b: u8) -> bool {
    b == YDLIDAR_PACKET_HEADER[0] || b == YDLIDAR_DESCRIPTOR_SYNC[0]
}

impl<const N: usize> YdlidarAccumulator<N> {
    const CAPACITY_OK: () = assert!(N >= MIN_CAPACITY, "capacity below 27 bytes");

    /// An empty accumulator at stream position 0 with zeroed counters. `N` below 27 does not
    /// compile.
    #[must_use]
    pub const fn new() -> Self {
        let () = Self::CAPACITY_OK;
        Self {
            window: Window::new(),
            kind: Kind::Packet,
            counters: YdlidarCounters {
                packets: 0,
                descriptors: 0,
                checksum: 0,
                check_bits: 0,
                bad_length: 0,
                truncated: 0,
                garbage_bytes: 0,
            },
        }
    }

    resync::feed_and_flush!(
        YdlidarItem,
        YdlidarError,
        "Ends the stream: rejects a candidate still incomplete (a sync pair and less than the \
         rest) as [`YdlidarError::Truncated`], counts a lone trailing sync byte as garbage, and \
         hands out what the bytes after a rejected candidate still hold. Call it until it returns \
         [`FeedResult::Consumed`]."
    );

    resync::stream_accessors!(YdlidarCounters, "Bytes buffered and not yet resolved.");

    /// Drops everything buffered, uncounted; keeps the counters and the stream position.
    pub fn reset(&mut self) {
        self.window.clear();
    }

    /// Counts a rejected candidate and drops its first byte.
    fn reject(&mut self, error: YdlidarError) -> (YdlidarError, u64) {
        let counter = match error {
            YdlidarError::BadChecksum { .. } => &mut self.counters.checksum,
            YdlidarError::BadCheckBit { .. } => &mut self.counters.check_bits,
            YdlidarError::NoSamples | YdlidarError::TooLong { .. } => &mut self.counters.bad_length,
            _ => &mut self.counters.truncated,
        };
        bump(counter);
        let offset = self.window.offset_of(0);
        self.window.drop_front(1);
        (error, offset)
    }

    fn deliver(&mut self, kind: Kind, len: usize) -> Scan<YdlidarError> {
        match kind {
            Kind::Packet => bump(&mut self.counters.packets),
            Kind::Descriptor => bump(&mut self.counters.descriptors),
        }
        self.kind = kind;
        self.window.hand_out(len);
        Scan::Item(self.window.offset_of(0))
    }

    fn garbage(&mut self, n: usize) {
        bump_by(&mut self.counters.garbage_bytes, n);
        self.window.drop_front(n);
    }
}

impl<const N: usize> Resync<N> for YdlidarAccumulator<N> {
    type Item<'a> = YdlidarItem<'a>;
    type Error = YdlidarError;

    fn window(&mut self) -> &mut Window<N> {
        &mut self.window
    }

    fn item(&self) -> YdlidarItem<'_> {
        let bytes = self.window.handed_out();
        match self.kind {
            Kind::Packet => YdlidarItem::Packet(YdlidarPacket::new_unchecked(bytes)),
            Kind::Descriptor => YdlidarItem::Descriptor(YdlidarDescriptor::new_unchecked(bytes)),
        }
    }

    fn scan(&mut self) -> Scan<YdlidarError> {
        loop {
            let live = self.window.live();
            let len = live.len();
            let (first, second) = match *live {
                [] => {
                    self.window.clear();
                    return Scan::Empty;
                }
                [_] => {
                    return Scan::Need {
                        more: 1,
                        candidate: false,
                    }
                }
                [a, b, ..] => (a, b),
            };
            if [first, second] == YDLIDAR_PACKET_HEADER {
                let Some(header) = live.first_chunk::<YDLIDAR_PACKET_HEADER_LEN>() else {
                    return Scan::Need {
                        more: YDLIDAR_PACKET_HEADER_LEN - len,
                        candidate: true,
                    };
                };
                let [_, _, _, lsn, fsa_lo, fsa_hi, lsa_lo, lsa_hi, _, _] = *header;
                let total = YDLIDAR_PACKET_HEADER_LEN + 2 * usize::from(lsn);
                let fsa = u16::from_le_bytes([fsa_lo, fsa_hi]);
                let lsa = u16::from_le_bytes([lsa_lo, lsa_hi]);
                let error = if lsn == 0 {
                    Some(YdlidarError::NoSamples)
                } else if total > N {
                    Some(YdlidarError::TooLong {
                        len: total,
                        capacity: N,
                    })
                } else if fsa & 1 == 0 {
                    Some(YdlidarError::BadCheckBit { field: fsa })
                } else if lsa & 1 == 0 {
                    Some(YdlidarError::BadCheckBit { field: lsa })
                } else {
                    None
                };
                if let Some(error) = error {
                    let (error, offset) = self.reject(error);
                    return Scan::Rejected(error, offset);
                }
                let Some(packet) = live.get(..total) else {
                    return Scan::Need {
                        more: total - len,
                        candidate: true,
                    };
                };
                let stored = read_u16_le(packet, 8).unwrap_or(0);
                let computed = ydlidar_checksum(packet);
                if stored == computed {
                    return self.deliver(Kind::Packet, total);
                }
                let (error, offset) = self.reject(YdlidarError::BadChecksum { stored, computed });
                return Scan::Rejected(error, offset);
            }
            if [first, second] == YDLIDAR_DESCRIPTOR_SYNC {
                let Some(descriptor) = live.first_chunk::<YDLIDAR_DESCRIPTOR_LEN>() else {
                    return Scan::Need {
                        more: YDLIDAR_DESCRIPTOR_LEN - len,
                        candidate: true,
                    };
                };
                let Some(content) = known_content_len(descriptor) else {
                    self.garbage(1);
                    continue;
                };
                let total = YDLIDAR_DESCRIPTOR_LEN + content;
                if len < total {
                    return Scan::Need {
                        more: total - len,
                        candidate: true,
                    };
                }
                return self.deliver(Kind::Descriptor, total);
            }
            // Not a candidate: drop up to the next possible sync byte after the first.
            let skip = live
                .iter()
                .skip(1)
                .position(|&b| is_sync_start(b))
                .map_or(len, |p| p + 1);
            self.garbage(skip);
        }
    }

    fn may_start(&self, byte: u8) -> bool {
        is_sync_start(byte)
    }

    fn first_need(&self) -> usize {
        YDLIDAR_PACKET_HEADER_LEN
    }

    fn count_garbage(&mut self, n: usize) {
        bump_by(&mut self.counters.garbage_bytes, n);
    }

    fn truncate(&mut self) -> (YdlidarError, u64) {
        self.reject(YdlidarError::Truncated)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::wire::ydlidar::YdlidarRepr;
    use std::vec;
    use std::vec::Vec;

    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Ev {
        P(u64, Vec<u8>),
        D(u64, Vec<u8>),
        R(u64, YdlidarError),
    }

    fn record(r: FeedResult<'_, YdlidarItem<'_>, YdlidarError>, out: &mut Vec<Ev>) -> bool {
        match r {
            FeedResult::Consumed => return false,
            FeedResult::Item {
                item: YdlidarItem::Packet(p),
                offset,
                ..
            } => {
                assert!(YdlidarPacket::new_checked(p.as_bytes()).is_ok());
                out.push(Ev::P(offset, p.as_bytes().to_vec()));
            }
            FeedResult::Item {
                item: YdlidarItem::Descriptor(d),
                offset,
                ..
            } => out.push(Ev::D(offset, d.as_bytes().to_vec())),
            FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(offset, error)),
        }
        true
    }

    fn run<const N: usize>(stream: &[u8], sizes: &[usize]) -> (Vec<Ev>, YdlidarCounters) {
        let mut acc = YdlidarAccumulator::<N>::new();
        let out = resync::run_in_chunks!(acc, stream, sizes, record);
        let c = acc.counters();
        let items: u64 = out
            .iter()
            .map(|e| match e {
                Ev::P(_, b) | Ev::D(_, b) => b.len() as u64,
                Ev::R(..) => 0,
            })
            .sum();
        assert_eq!(
            items
                + u64::from(c.checksum)
                + u64::from(c.check_bits)
                + u64::from(c.bad_length)
                + u64::from(c.truncated)
                + u64::from(c.garbage_bytes),
            stream.len() as u64
        );
        (out, c)
    }

    fn packet(ct: u8, first: u16, samples: &[u16]) -> Vec<u8> {
        let repr = YdlidarRepr {
            packet_type: ct,
            first_angle_q6: first,
            last_angle_q6: (first + 640) % 23_040,
            samples,
        };
        let mut buf = vec![0; repr.buffer_len()];
        repr.emit(&mut buf).unwrap();
        buf
    }

    #[test]
    fn descriptor_info_and_damaged_packets_at_every_chunking() {
        let scan = [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
        let mut info = vec![0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x04];
        info.extend((0..20).map(|i| 0x30 + i));
        let p1 = packet(1, 0, &[4000]);
        let p2 = packet(0, 100, &(0..40).map(|i| 1000 + i).collect::<Vec<_>>());
        let mut flipped = p2.clone();
        flipped[30] ^= 0x02;
        let mut clear_bit = p2.clone();
        clear_bit[6] &= !1;
        let mut stream = info.clone();
        stream.extend_from_slice(&[0x00, 0xAA, 0x00, 0xA5, 0x5A, 0x01, 0x02, 0x03, 0x04, 0x05]);
        stream.extend_from_slice(&scan);
        stream.extend_from_slice(&p1);
        stream.extend_from_slice(&flipped);
        stream.extend_from_slice(&clear_bit);
        stream.extend_from_slice(&[0xAA, 0x55, 0x00, 0x00]); // LSN 0 in a short header
        stream.extend_from_slice(&[0; 6]);
        stream.extend_from_slice(&p2);
        stream.extend_from_slice(&p2[..15]);
        let o_scan = 27 + 10;
        let o_p1 = o_scan + 7;
        let o_flip = o_p1 + 12;
        let o_clear = o_flip + 90;
        let o_lsn0 = o_clear + 90;
        let o_p2 = o_lsn0 + 10;
        for sizes in [&[usize::MAX][..], &[1], &[2, 7], &[9, 90, 1]] {
            let (events, c) = run::<YDLIDAR_DEFAULT_CAPACITY>(&stream, sizes);
            let want = vec![
                Ev::D(0, info.clone()),
                Ev::D(o_scan as u64, scan.to_vec()),
                Ev::P(o_p1 as u64, p1.clone()),
                Ev::R(
                    o_flip as u64,
                    YdlidarError::BadChecksum {
                        stored: u16::from_le_bytes([p2[8], p2[9]]),
                        computed: u16::from_le_bytes([p2[8], p2[9]]) ^ 0x0002,
                    },
                ),
                Ev::R(
                    o_clear as u64,
                    YdlidarError::BadCheckBit {
                        field: u16::from_le_bytes([clear_bit[6], clear_bit[7]]),
                    },
                ),
                Ev::R(o_lsn0 as u64, YdlidarError::NoSamples),
                Ev::P(o_p2 as u64, p2.clone()),
                Ev::R((o_p2 + 90) as u64, YdlidarError::Truncated),
            ];
            assert_eq!(events, want, "{sizes:?}");
            assert_eq!(
                (
                    c.packets,
                    c.descriptors,
                    c.checksum,
                    c.check_bits,
                    c.bad_length,
                    c.truncated
                ),
                (2, 2, 1, 1, 1, 1)
            );
        }
    }

    #[test]
    fn small_capacity_refuses_long_packets() {
        let long = packet(0, 0, &[7; 20]);
        let short = packet(0, 0, &[7; 5]);
        let stream = [long.clone(), short.clone()].concat();
        let (events, c) = run::<32>(&stream, &[3]);
        assert_eq!(
            events[0],
            Ev::R(
                0,
                YdlidarError::TooLong {
                    len: 50,
                    capacity: 32
                }
            )
        );
        assert_eq!(events.last(), Some(&Ev::P(50, short)));
        assert_eq!(c.bad_length, 1);
    }

    #[test]
    fn accessors() {
        let mut acc: YdlidarAccumulator = YdlidarAccumulator::default();
        let p = packet(0, 0, &[1, 2]);
        assert!(matches!(acc.feed(&p[..5]), FeedResult::Consumed));
        assert_eq!(acc.buffered(), 5);
        acc.reset();
        assert_eq!(acc.buffered(), 0);
        assert_eq!(acc.position(), 5);
        acc.counters.garbage_bytes = u32::MAX;
        let _ = acc.feed(&[1]);
        assert_eq!(acc.counters().garbage_bytes, u32::MAX);
        acc.clear_counters();
        assert_eq!(acc.counters(), YdlidarCounters::default());
        match acc.feed(&p) {
            FeedResult::Item { item, offset, .. } => {
                assert_eq!((offset, item.as_bytes()), (6, &p[..]));
            }
            other => panic!("{other:?}"),
        }
    }
}
