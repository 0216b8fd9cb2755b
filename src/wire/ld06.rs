//! The LDROBOT LD06 / LD19 / STL-19P measurement packet (one protocol for the three): a
//! zero-copy view, its CRC-8, its returns, an emitter, and a resynchronising accumulator.
//!
//! The authority is the LDROBOT "LD06 Development Manual" (v1.0): §3.1 "Data Packet Format",
//! §3.2 "Measurement Data Analysis", §3.3 "Reference Example" and §4 "Coordinate System". The
//! LD19 and STL-19P manuals define the same packet. LDROBOT's `ldlidar_stl_sdk`
//! (`lipkg.cpp`) is the independent implementation the tests check the CRC table against.
//!
//! # Wire format (§3.1), little-endian, 47 bytes
//! ```text
//! 0x54 | 0x2C | speed u16 (°/s) | start angle u16 (0.01°) | 12 × [distance u16 (mm), intensity u8]
//!      | end angle u16 (0.01°) | timestamp u16 (ms, wraps at 30 000) | CRC-8
//! ```
//! - Byte 1 ("VerLen") holds 3 reserved bits and a 5-bit point count, fixed at 12: the pair
//!   `54 2C` is the packet header a receiver synchronises on.
//! - The CRC-8 ([`ld06_crc8`]) runs over the first 46 bytes: polynomial 0x4D, initial value
//!   0, no reflection, no final XOR; table-driven ([`LD06_CRC_TABLE`], built at compile time).
//! - The device streams packets unasked once powered (about 4 500 points/s at 10 Hz).
//!
//! # Angles (§3.2, §4)
//! Point k of 12 lies at `start + k·(end − start)/11`, where an end angle below the start
//! angle means the packet crossed 360° (36 000 is added to the end before interpolating, and
//! the result wraps). [`Ld06Packet::angle`] evaluates it in integer arithmetic on the exact
//! rational value `(11·start + k·span) / (11 · 36 000)` of a turn, rounded once to the
//! nearest [`FineAngle`] LSB (2⁻³² turn): exact to the LSB. (LDROBOT's SDK divides the span
//! by 11 in integer centidegrees first, which truncates by up to 0.01° per step; this module
//! follows the manual's formula instead.) Angles from the wire above 35 999 are taken modulo
//! 36 000.
//!
//! The angle grows **clockwise seen from above** (§4: left-handed frame, 0° straight ahead of
//! the sensor, increasing clockwise); see [`crate::wire::laser`] for what that means for the
//! geometry. A distance of 0 means no return.
//!
//! # Stream reassembly
//! [`Ld06Accumulator`] hunts for `54 2C`, buffers 47 bytes and checks the CRC. A bad CRC is
//! counted and the hunt restarts one byte after the rejected header, so a valid packet
//! starting inside a damaged one is still found; other bytes are garbage, counted and skipped
//! without being buffered. A false `54 2C` in garbage passes only if its CRC-8 matches by
//! chance (1 in 256), and then hides the packet that starts inside it.

use core::fmt;

use super::laser::{turn_fraction, LaserReturn, TurnSteps};
use super::resync::{self, Resync, Scan};
use super::window::{bump, bump_by, Window};
use super::FeedResult;
use super::{check, view};
use crate::angle::FineAngle;

/// The first byte of every packet.
pub const LD06_HEADER: u8 = 0x54;
/// The second byte ("VerLen": 3 reserved bits, 12 points).
pub const LD06_VER_LEN: u8 = 0x2C;
/// Points per packet.
pub const LD06_POINTS: usize = 12;
/// Bytes per packet.
pub const LD06_PACKET_LEN: usize = 47;
/// Angle units per turn: the wire counts hundredths of a degree.
pub const LD06_CENTIDEG_PER_TURN: u16 = 36_000;
/// The timestamp wraps to 0 at this value, milliseconds.
pub const LD06_TIMESTAMP_WRAP_MS: u16 = 30_000;

/// The CRC-8 table: `LD06_CRC_TABLE[i]` is the CRC of the byte `i` (polynomial 0x4D, MSB
/// first), computed at compile time.
pub const LD06_CRC_TABLE: [u8; 256] = crc_table();

const fn crc_table() -> [u8; 256] {
    let mut table = [0_u8; 256];
    let mut i = 0_usize;
    while i < 256 {
        #[allow(clippy::cast_possible_truncation)]
        let mut crc = i as u8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0x4D
            } else {
                crc << 1
            };
            bit += 1;
        }
        if let Some((_, rest)) = table.split_at_mut_checked(i) {
            if let Some(slot) = rest.first_mut() {
                *slot = crc;
            }
        }
        i += 1;
    }
    table
}

/// The LD06 CRC-8 of `bytes` (a packet's first 46 bytes): polynomial 0x4D, initial 0, no
/// reflection, no final XOR.
#[must_use]
pub fn ld06_crc8(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0_u8, |crc, &b| {
        LD06_CRC_TABLE
            .get(usize::from(crc ^ b))
            .copied()
            .unwrap_or(0)
    })
}

mod field {
    pub const HEADER: usize = 0;
    pub const VER_LEN: usize = 1;
    pub const SPEED: usize = 2;
    pub const START: usize = 4;
    pub const POINTS: usize = 6;
    pub const POINT_LEN: usize = 3;
    pub const END: usize = 42;
    pub const TIMESTAMP: usize = 44;
    pub const CRC: usize = 46;
}

/// Why an LD06 packet or candidate was refused, or why an emit could not proceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Ld06Error {
    /// The buffer is shorter than a packet (47 bytes), or the stream ended inside a candidate
    /// ([`Ld06Counters::truncated`]).
    Truncated,
    /// The first byte is not 0x54.
    BadHeader {
        /// The byte found instead.
        found: u8,
    },
    /// The second byte is not 0x2C (12 points).
    BadVerLen {
        /// The byte found instead.
        found: u8,
    },
    /// The CRC-8 carried by the packet differs from the one computed over its first 46 bytes
    /// ([`Ld06Counters::checksum`]).
    BadCrc {
        /// The CRC carried by the packet.
        stored: u8,
        /// The CRC computed over it.
        computed: u8,
    },
    /// The output buffer is shorter than a packet; nothing was written.
    BufferTooSmall {
        /// Bytes needed (47).
        needed: usize,
        /// Bytes the buffer holds.
        available: usize,
    },
}

impl fmt::Display for Ld06Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Truncated => f.write_str("LD06 packet truncated"),
            Self::BadHeader { found } => {
                write!(f, "LD06 packet does not start with 0x54 (0x{found:02x})")
            }
            Self::BadVerLen { found } => {
                write!(f, "LD06 VerLen byte is 0x{found:02x}, not 0x2c (12 points)")
            }
            Self::BadCrc { stored, computed } => write!(
                f,
                "LD06 CRC mismatch: stored 0x{stored:02x}, computed 0x{computed:02x}"
            ),
            Self::BufferTooSmall { needed, available } => write!(
                f,
                "output buffer too small: {needed} bytes needed, {available} available"
            ),
        }
    }
}

impl core::error::Error for Ld06Error {}

/// One measurement point of a packet as the wire carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ld06Point {
    /// Distance, millimetres; 0 = no return.
    pub distance_mm: u16,
    /// Intensity (signal strength), 0..=255; the manual gives no unit.
    pub intensity: u8,
}

view::fixed_view! {
    /// A zero-copy view over one 47-byte LD06 packet held in `T`.
    ///
    /// Made with [`Ld06Packet::new_checked`], the buffer holds 47 bytes, starts `54 2C` and the
    /// CRC matches; bytes after the 47th are ignored. Made with [`Ld06Packet::new_unchecked`],
    /// the accessors still never panic: absent bytes read as zero (see the
    /// [panic contract](crate::wire)).
    pub struct Ld06Packet: LD06_PACKET_LEN bytes, a "packet",
        refused with Ld06Error;

    /// Wraps a buffer after [`check_len`](Self::check_len), the header check and the CRC
    /// check.
    ///
    /// # Errors
    /// [`Ld06Error::Truncated`], [`Ld06Error::BadHeader`], [`Ld06Error::BadVerLen`] or
    /// [`Ld06Error::BadCrc`].
    fn new_checked: check_header, check_crc;
}

impl<T: AsRef<[u8]>> Ld06Packet<T> {
    /// Checks the two header bytes `54 2C`.
    ///
    /// # Errors
    /// [`Ld06Error::Truncated`] for fewer than 2 bytes, [`Ld06Error::BadHeader`] or
    /// [`Ld06Error::BadVerLen`] for other bytes.
    pub fn check_header(&self) -> Result<(), Ld06Error> {
        match *self.buffer.as_ref() {
            [LD06_HEADER, LD06_VER_LEN, ..] => Ok(()),
            [LD06_HEADER, found, ..] => Err(Ld06Error::BadVerLen { found }),
            [found, _, ..] => Err(Ld06Error::BadHeader { found }),
            _ => Err(Ld06Error::Truncated),
        }
    }

    /// Checks the CRC-8 in byte 46 against the one computed over bytes 0..46.
    ///
    /// # Errors
    /// [`Ld06Error::Truncated`] for a short buffer, [`Ld06Error::BadCrc`] on a mismatch.
    pub fn check_crc(&self) -> Result<(), Ld06Error> {
        self.check_len()?;
        let (stored, computed) = (self.crc(), self.computed_crc());
        check::stored_matches(stored, computed, |stored, computed| Ld06Error::BadCrc {
            stored,
            computed,
        })
    }

    /// Byte 0 (0x54 in a valid packet); 0 if absent.
    pub fn header(&self) -> u8 {
        self.byte(field::HEADER)
    }

    /// Byte 1, "VerLen" (0x2C in a valid packet); 0 if absent.
    pub fn ver_len(&self) -> u8 {
        self.byte(field::VER_LEN)
    }

    /// The rotation speed, degrees per second (e.g. 3 600 at 10 Hz); 0 if absent.
    pub fn speed_deg_per_s(&self) -> u16 {
        self.u16_at(field::SPEED)
    }

    /// The angle of point 0, hundredths of a degree (0..=35 999 from a sound sensor); 0 if
    /// absent.
    pub fn start_angle_centideg(&self) -> u16 {
        self.u16_at(field::START)
    }

    /// The angle of point 11, hundredths of a degree; below the start angle when the packet
    /// crossed 360°; 0 if absent.
    pub fn end_angle_centideg(&self) -> u16 {
        self.u16_at(field::END)
    }

    /// The sensor's timestamp of the packet, milliseconds, wrapping at 30 000; 0 if absent.
    pub fn timestamp_ms(&self) -> u16 {
        self.u16_at(field::TIMESTAMP)
    }

    /// The CRC-8 carried in byte 46; 0 if absent.
    pub fn crc(&self) -> u8 {
        self.byte(field::CRC)
    }

    /// The CRC-8 computed over bytes 0..46 (over the bytes present when the buffer is short).
    pub fn computed_crc(&self) -> u8 {
        let data = self.buffer.as_ref();
        ld06_crc8(data.get(..field::CRC).unwrap_or(data))
    }

    /// Point `k` (0..12) as the wire carries it; `None` for `k ≥ 12`. Absent bytes read as 0.
    pub fn point(&self, k: usize) -> Option<Ld06Point> {
        if k >= LD06_POINTS {
            return None;
        }
        let at = field::POINTS + k * field::POINT_LEN;
        Some(Ld06Point {
            distance_mm: self.u16_at(at),
            intensity: self.byte(at + 2),
        })
    }

    /// The 12 points in order.
    pub fn points(&self) -> impl Iterator<Item = Ld06Point> + '_ {
        (0..LD06_POINTS).filter_map(|k| self.point(k))
    }

    /// The start angle and the clockwise span to the end angle, both in hundredths of a
    /// degree and below 36 000.
    fn start_and_span(&self) -> (u64, u64) {
        let turn = u64::from(LD06_CENTIDEG_PER_TURN);
        let start = u64::from(self.start_angle_centideg()) % turn;
        let end = u64::from(self.end_angle_centideg()) % turn;
        (start, (end + turn - start) % turn)
    }

    /// The angle of point `k` (0..12): `start + k·(end − start)/11` across the 360° wrap,
    /// exact to the [`FineAngle`] LSB (see the [module documentation](self)); `None` for
    /// `k ≥ 12`. Clockwise seen from above.
    pub fn angle(&self, k: usize) -> Option<FineAngle> {
        let k = u64::try_from(k).ok().filter(|&k| k < LD06_POINTS as u64)?;
        let (start, span) = self.start_and_span();
        let steps = LD06_POINTS as u64 - 1;
        let numerator = steps * start + k * span;
        Some(turn_fraction(
            numerator,
            steps * u64::from(LD06_CENTIDEG_PER_TURN),
        ))
    }

    /// The angles of points 0, 1, 2, … in order, each exactly [`angle`](Self::angle), by two
    /// divisions per packet rather than one per point.
    pub(crate) fn angle_steps(&self) -> Option<TurnSteps> {
        let (start, span) = self.start_and_span();
        let steps = LD06_POINTS as u64 - 1;
        TurnSteps::new(
            steps * start,
            span,
            steps * u64::from(LD06_CENTIDEG_PER_TURN),
        )
    }

    /// The 12 returns: angle as [`angle`](Self::angle), range the distance in millimetres (0
    /// = no return), quality the intensity.
    pub fn returns(&self) -> impl Iterator<Item = LaserReturn> + '_ {
        let mut angles = self.angle_steps();
        (0..LD06_POINTS).filter_map(move |k| {
            let point = self.point(k)?;
            let angle = match angles.as_mut() {
                Some(steps) => steps.next_angle(),
                None => self.angle(k)?,
            };
            Some(LaserReturn {
                angle,
                range_mm: u32::from(point.distance_mm),
                quality: Some(point.intensity),
            })
        })
    }

    /// The index (1..12) of the first point past 360°, when the packet's span crosses 0°
    /// (its end angle is below its start angle); `None` otherwise. A revolution that starts
    /// exactly between two packets shows as the second packet's start angle being below the
    /// first one's end angle, which one packet cannot see.
    pub fn wrap_index(&self) -> Option<usize> {
        let (start, span) = self.start_and_span();
        let steps = LD06_POINTS as u64 - 1;
        let turn = steps * u64::from(LD06_CENTIDEG_PER_TURN);
        (1..LD06_POINTS).find(|&k| steps * start + k as u64 * span >= turn)
    }

    /// Whether a new revolution (the 0° direction) starts inside this packet:
    /// [`wrap_index`](Self::wrap_index) is `Some`.
    pub fn starts_revolution(&self) -> bool {
        self.wrap_index().is_some()
    }

    fn u16_at(&self, at: usize) -> u16 {
        let data = self.buffer.as_ref();
        match data.get(at..).and_then(<[u8]>::first_chunk::<2>) {
            Some(&pair) => u16::from_le_bytes(pair),
            None => 0,
        }
    }
}

/// The fields of one packet, to [`emit`](Ld06Repr::emit) (test streams, the simulator) or as
/// [`parse`](Ld06Repr::parse)d from a view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ld06Repr {
    /// Rotation speed, degrees per second.
    pub speed_deg_per_s: u16,
    /// Angle of point 0, hundredths of a degree (the sensor sends 0..=35 999).
    pub start_angle_centideg: u16,
    /// Angle of point 11, hundredths of a degree (below the start when crossing 360°).
    pub end_angle_centideg: u16,
    /// Timestamp, milliseconds (the sensor wraps it at 30 000).
    pub timestamp_ms: u16,
    /// The 12 points.
    pub points: [Ld06Point; LD06_POINTS],
}

impl Ld06Repr {
    /// The fields of a packet view (checked or not: absent bytes read as 0).
    pub fn parse<T: AsRef<[u8]>>(packet: &Ld06Packet<T>) -> Self {
        let mut points = [Ld06Point::default(); LD06_POINTS];
        for (slot, point) in points.iter_mut().zip(packet.points()) {
            *slot = point;
        }
        Self {
            speed_deg_per_s: packet.speed_deg_per_s(),
            start_angle_centideg: packet.start_angle_centideg(),
            end_angle_centideg: packet.end_angle_centideg(),
            timestamp_ms: packet.timestamp_ms(),
            points,
        }
    }

    /// Bytes of the emitted packet: 47.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        LD06_PACKET_LEN
    }

    /// Writes the packet (header, fields, CRC-8) to the front of `out` and returns its length
    /// (47). Every field value is representable, so only a short buffer fails.
    ///
    /// # Errors
    /// [`Ld06Error::BufferTooSmall`] when `out` is shorter than 47 bytes; nothing is written.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, Ld06Error> {
        let available = out.len();
        let Some(packet) = out.first_chunk_mut::<LD06_PACKET_LEN>() else {
            return Err(Ld06Error::BufferTooSmall {
                needed: LD06_PACKET_LEN,
                available,
            });
        };
        let mut bytes = [0_u8; LD06_PACKET_LEN];
        let mut w = Writer(&mut bytes, 0);
        w.put(&[LD06_HEADER, LD06_VER_LEN]);
        w.put(&self.speed_deg_per_s.to_le_bytes());
        w.put(&self.start_angle_centideg.to_le_bytes());
        for point in &self.points {
            w.put(&point.distance_mm.to_le_bytes());
            w.put(&[point.intensity]);
        }
        w.put(&self.end_angle_centideg.to_le_bytes());
        w.put(&self.timestamp_ms.to_le_bytes());
        let crc = ld06_crc8(bytes.get(..field::CRC).unwrap_or(&[]));
        if let Some(slot) = bytes.get_mut(field::CRC) {
            *slot = crc;
        }
        *packet = bytes;
        Ok(LD06_PACKET_LEN)
    }
}

/// Appends bytes to a fixed array, dropping what does not fit (callers size it exactly).
struct Writer<'a, const N: usize>(&'a mut [u8; N], usize);

impl<const N: usize> Writer<'_, N> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.0.get_mut(self.1..self.1.saturating_add(bytes.len())) {
            dst.copy_from_slice(bytes);
        }
        self.1 = self.1.saturating_add(bytes.len());
    }
}

/// What an [`Ld06Accumulator`] has seen since it was made (or since
/// [`Ld06Accumulator::clear_counters`]). Every counter saturates at `u32::MAX`.
///
/// Every byte fed is accounted for exactly once, so after [`Ld06Accumulator::flush`]
/// `position = 47·packets + checksum + truncated + garbage_bytes`: a rejected candidate
/// accounts for its header byte, the bytes after it are hunted through again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ld06Counters {
    /// Packets handed out: header `54 2C`, CRC matching.
    pub packets: u32,
    /// Candidates (`54 2C` and 45 more bytes) whose CRC did not match.
    pub checksum: u32,
    /// Candidates cut short by the end of the stream ([`Ld06Accumulator::flush`]).
    pub truncated: u32,
    /// Bytes outside every candidate, dropped while hunting for `54 2C` (a 0x54 not followed
    /// by 0x2C included).
    pub garbage_bytes: u32,
}

/// Reassembles LD06 packets from a byte stream fed in chunks of any size.
///
/// It holds one packet (47 bytes): garbage is skipped in place, never copied.
///
/// ```
/// use terrain_pyramid::wire::ld06::Ld06Accumulator;
/// use terrain_pyramid::wire::FeedResult;
///
/// // The manual's reference example (§3.3), after two bytes of noise.
/// let stream = [
///     0xFF, 0x54, 0x54, 0x2C, 0x68, 0x08, 0xAB, 0x7E, 0xE0, 0x00, 0xE4, 0xDC, 0x00, 0xE2,
///     0xD9, 0x00, 0xE5, 0xD5, 0x00, 0xE3, 0xD3, 0x00, 0xE4, 0xD0, 0x00, 0xE9, 0xCD, 0x00,
///     0xE4, 0xCA, 0x00, 0xE2, 0xC7, 0x00, 0xE9, 0xC5, 0x00, 0xE5, 0xC2, 0x00, 0xE5, 0xC0,
///     0x00, 0xE5, 0xBE, 0x82, 0x3A, 0x1A, 0x50,
/// ];
/// let mut acc = Ld06Accumulator::new();
/// let mut window = &stream[..];
/// loop {
///     window = match acc.feed(window) {
///         FeedResult::Consumed => break,
///         FeedResult::Item { item, offset, remaining } => {
///             assert_eq!((offset, item.speed_deg_per_s(), item.start_angle_centideg()), (2, 2152, 32427));
///             remaining
///         }
///         FeedResult::Rejected { remaining, .. } => remaining,
///     };
/// }
/// assert_eq!((acc.counters().packets, acc.counters().garbage_bytes), (1, 2));
/// ```
#[derive(Debug, Clone)]
pub struct Ld06Accumulator {
    window: Window<LD06_PACKET_LEN>,
    counters: Ld06Counters,
}

resync::accumulator_impls!(Ld06Accumulator);

impl Ld06Accumulator {
    /// An empty accumulator at stream position 0 with zeroed counters.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            window: Window::new(),
            counters: Ld06Counters {
                packets: 0,
                checksum: 0,
                truncated: 0,
                garbage_bytes: 0,
            },
        }
    }

    /// Feeds a chunk of the stream and returns the first packet or rejection it completes,
    /// with the rest of the chunk. Call it again with `remaining` until it returns
    /// [`FeedResult::Consumed`]; an empty chunk is fine.
    ///
    /// A packet handed out borrows the accumulator's buffer until the next call.
    pub fn feed<'s, 'c>(
        &'s mut self,
        chunk: &'c [u8],
    ) -> FeedResult<'c, Ld06Packet<&'s [u8]>, Ld06Error> {
        resync::feed(self, chunk)
    }

    /// Ends the stream: rejects a candidate still incomplete (`54 2C` and fewer than 45 more
    /// bytes) as [`Ld06Error::Truncated`] and counts a lone trailing 0x54 as garbage. Call it
    /// until it returns [`FeedResult::Consumed`].
    pub fn flush(&mut self) -> FeedResult<'static, Ld06Packet<&[u8]>, Ld06Error> {
        resync::flush(self)
    }

    /// The packet handed out by the last call, while it is valid (until the next call taking
    /// `&mut self`).
    #[must_use]
    pub fn packet(&self) -> Option<Ld06Packet<&[u8]>> {
        (!self.window.handed_out().is_empty()).then(|| self.item())
    }

    resync::stream_accessors!(
        Ld06Counters,
        "Bytes buffered and not yet resolved (a candidate in progress)."
    );

    /// Drops everything buffered, uncounted; keeps the counters and the stream position.
    pub fn reset(&mut self) {
        self.window.clear();
    }
}

impl Resync<LD06_PACKET_LEN> for Ld06Accumulator {
    type Item<'a> = Ld06Packet<&'a [u8]>;
    type Error = Ld06Error;

    fn window(&mut self) -> &mut Window<LD06_PACKET_LEN> {
        &mut self.window
    }

    fn item(&self) -> Ld06Packet<&[u8]> {
        Ld06Packet::new_unchecked(self.window.handed_out())
    }

    fn scan(&mut self) -> Scan<Ld06Error> {
        loop {
            let live = self.window.live();
            let Some(&first) = live.first() else {
                self.window.clear();
                return Scan::Empty;
            };
            if first != LD06_HEADER {
                let skip = live
                    .iter()
                    .position(|&b| b == LD06_HEADER)
                    .unwrap_or(live.len());
                bump_by(&mut self.counters.garbage_bytes, skip);
                self.window.drop_front(skip);
                continue;
            }
            match live.get(1) {
                None => {
                    return Scan::Need {
                        more: 1,
                        candidate: false,
                    }
                }
                Some(&LD06_VER_LEN) => {}
                Some(_) => {
                    bump(&mut self.counters.garbage_bytes);
                    self.window.drop_front(1);
                    continue;
                }
            }
            let Some(packet) = live.first_chunk::<LD06_PACKET_LEN>() else {
                return Scan::Need {
                    more: LD06_PACKET_LEN - live.len(),
                    candidate: true,
                };
            };
            let offset = self.window.offset_of(0);
            let (body, &[stored]) = packet.split_at(field::CRC) else {
                return Scan::Need {
                    more: 1,
                    candidate: true,
                };
            };
            let computed = ld06_crc8(body);
            if stored == computed {
                bump(&mut self.counters.packets);
                self.window.hand_out(LD06_PACKET_LEN);
                return Scan::Item(offset);
            }
            bump(&mut self.counters.checksum);
            self.window.drop_front(1);
            return Scan::Rejected(Ld06Error::BadCrc { stored, computed }, offset);
        }
    }

    fn may_start(&self, byte: u8) -> bool {
        byte == LD06_HEADER
    }

    fn first_need(&self) -> usize {
        LD06_PACKET_LEN
    }

    fn count_garbage(&mut self, n: usize) {
        bump_by(&mut self.counters.garbage_bytes, n);
    }

    fn truncate(&mut self) -> (Ld06Error, u64) {
        let offset = self.window.offset_of(0);
        bump(&mut self.counters.truncated);
        self.window.drop_front(1);
        (Ld06Error::Truncated, offset)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// The manual's reference example (§3.3), as quoted in `docs/uart-lidars.md`.
    const EXAMPLE: [u8; 47] = [
        0x54, 0x2C, 0x68, 0x08, 0xAB, 0x7E, 0xE0, 0x00, 0xE4, 0xDC, 0x00, 0xE2, 0xD9, 0x00, 0xE5,
        0xD5, 0x00, 0xE3, 0xD3, 0x00, 0xE4, 0xD0, 0x00, 0xE9, 0xCD, 0x00, 0xE4, 0xCA, 0x00, 0xE2,
        0xC7, 0x00, 0xE9, 0xC5, 0x00, 0xE5, 0xC2, 0x00, 0xE5, 0xC0, 0x00, 0xE5, 0xBE, 0x82, 0x3A,
        0x1A, 0x50,
    ];

    fn degrees(a: FineAngle) -> f64 {
        f64::from(a.to_bits()) * 360.0 / 4_294_967_296.0
    }

    #[test]
    fn crc_table_matches_ldrobot_sdk() {
        // Entries of `CrcTable` in ldrobotSensorTeam/ldlidar_stl_sdk, src/lipkg.cpp (12 per
        // line in that file): [0], [1], [2], [3], [12], [128], [254], [255].
        let sdk = [
            (0, 0x00),
            (1, 0x4d),
            (2, 0x9a),
            (3, 0xd7),
            (12, 0x8b),
            (128, 0x7c),
            (254, 0xe5),
            (255, 0xa8),
        ];
        for (i, v) in sdk {
            assert_eq!(LD06_CRC_TABLE[i], v, "entry {i}");
        }
        // And the bitwise definition, for every entry: poly 0x4D, MSB first.
        for (i, &v) in LD06_CRC_TABLE.iter().enumerate() {
            let mut crc = i as u8;
            for _ in 0..8 {
                crc = if crc & 0x80 != 0 {
                    (crc << 1) ^ 0x4D
                } else {
                    crc << 1
                };
            }
            assert_eq!(v, crc);
        }
    }

    #[test]
    fn manual_example_decodes() {
        let p = Ld06Packet::new_checked(&EXAMPLE[..]).unwrap();
        assert_eq!(p.computed_crc(), 0x50);
        // Speed 0x0868 = 2 152 °/s (5.98 Hz); start 0x7EAB = 32 427 → 324.27°;
        // end 0x82BE = 33 470 → 334.70°; timestamp 0x1A3A = 6 714 ms.
        assert_eq!(p.speed_deg_per_s(), 2152);
        assert_eq!(p.start_angle_centideg(), 32_427);
        assert_eq!(p.end_angle_centideg(), 33_470);
        assert_eq!(p.timestamp_ms(), 6714);
        // Point 0: E0 00 E4 → 224 mm, intensity 228; point 11: C0 00 E5 → 192 mm, 229.
        assert_eq!(
            p.point(0),
            Some(Ld06Point {
                distance_mm: 224,
                intensity: 228
            })
        );
        assert_eq!(
            p.point(11),
            Some(Ld06Point {
                distance_mm: 192,
                intensity: 229
            })
        );
        assert_eq!(p.point(12), None);
        // Angles: span 33 470 − 32 427 = 1 043 centidegrees, step 1 043/11 = 94.818…;
        // point 5: 32 427 + 5·1 043/11 = 32 901.0909… → 329.010909…°.
        let a5 = degrees(p.angle(5).unwrap());
        assert!((a5 - 329.010_909_09).abs() < 1e-7, "{a5}");
        // Exactly: (11·32 427 + 5·1 043)·2³²/396 000 = 1 410 945 591 125.33… / 396 000 …
        let exact = ((11 * 32_427 + 5 * 1043) as u128) << 32;
        let want = ((exact + 198_000) / 396_000) as u32;
        assert_eq!(p.angle(5).unwrap().to_bits(), want);
        assert_eq!(p.angle(0).unwrap(), turn_fraction(32_427, 36_000));
        assert_eq!(p.angle(11).unwrap(), turn_fraction(33_470, 36_000));
        assert!(!p.starts_revolution());
        let returns: Vec<_> = p.returns().collect();
        assert_eq!(returns.len(), 12);
        assert_eq!(returns[0].range_mm, 224);
        assert_eq!(returns[0].quality, Some(228));
        // Point 3: D5 00 E3 → 213 mm.
        assert_eq!(returns[3].range_mm, 0xD5);
    }

    #[test]
    fn angles_across_the_wrap() {
        // Start 359.00°, end 1.20°: span 36 000 + 120 − 35 900 = 220, step 20 centidegrees.
        let repr = Ld06Repr {
            start_angle_centideg: 35_900,
            end_angle_centideg: 120,
            ..Ld06Repr::default()
        };
        let mut buf = [0; 47];
        repr.emit(&mut buf).unwrap();
        let p = Ld06Packet::new_checked(&buf[..]).unwrap();
        for k in 0..12 {
            let want = (35_900 + 20 * k as u64) % 36_000;
            assert_eq!(p.angle(k).unwrap(), turn_fraction(want, 36_000), "{k}");
        }
        // 35 900 + 20k ≥ 36 000 first at k = 5.
        assert_eq!(p.wrap_index(), Some(5));
        assert!(p.starts_revolution());
        // Equal start and end: every point at the start angle.
        let flat = Ld06Repr {
            start_angle_centideg: 100,
            end_angle_centideg: 100,
            ..Ld06Repr::default()
        };
        flat.emit(&mut buf).unwrap();
        let p = Ld06Packet::new_unchecked(&buf[..]);
        assert!(p.returns().all(|r| r.angle == turn_fraction(100, 36_000)));
        // Out-of-range wire angles are taken modulo one turn.
        let odd = Ld06Repr {
            start_angle_centideg: 36_000 + 50,
            end_angle_centideg: 65_535,
            ..Ld06Repr::default()
        };
        odd.emit(&mut buf).unwrap();
        let p = Ld06Packet::new_unchecked(&buf[..]);
        assert_eq!(p.angle(0).unwrap(), turn_fraction(50, 36_000));
        assert_eq!(p.angle(11).unwrap(), turn_fraction(65_535 % 36_000, 36_000));
    }

    #[test]
    fn emit_parse_round_trip_and_checks() {
        let repr = Ld06Repr::parse(&Ld06Packet::new_unchecked(&EXAMPLE[..]));
        let mut buf = [0; 50];
        assert_eq!(repr.emit(&mut buf), Ok(47));
        assert_eq!(&buf[..47], &EXAMPLE[..]);
        assert_eq!(
            repr.emit(&mut buf[..46]),
            Err(Ld06Error::BufferTooSmall {
                needed: 47,
                available: 46
            })
        );
        let mut bad = EXAMPLE;
        bad[10] ^= 1;
        assert!(matches!(
            Ld06Packet::new_checked(&bad[..]),
            Err(Ld06Error::BadCrc { stored: 0x50, .. })
        ));
        bad = EXAMPLE;
        bad[1] = 0x2D;
        assert_eq!(
            Ld06Packet::new_checked(&bad[..]),
            Err(Ld06Error::BadVerLen { found: 0x2D })
        );
        bad[0] = 0x55;
        assert_eq!(
            Ld06Packet::new_checked(&bad[..]),
            Err(Ld06Error::BadHeader { found: 0x55 })
        );
        assert_eq!(
            Ld06Packet::new_checked(&EXAMPLE[..46]),
            Err(Ld06Error::Truncated)
        );
        // An unchecked view over nothing reads zeros and never panics.
        let empty = Ld06Packet::new_unchecked(&[][..]);
        assert_eq!(empty.speed_deg_per_s(), 0);
        assert_eq!(empty.returns().count(), 12);
        assert_eq!(empty.check_header(), Err(Ld06Error::Truncated));
        assert_eq!(empty.as_bytes(), &[] as &[u8]);
    }

    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Ev {
        P(u64, Vec<u8>),
        R(u64, Ld06Error),
    }

    fn record(r: FeedResult<'_, Ld06Packet<&[u8]>, Ld06Error>, out: &mut Vec<Ev>) -> bool {
        match r {
            FeedResult::Consumed => return false,
            FeedResult::Item { item, offset, .. } => {
                assert!(Ld06Packet::new_checked(item.as_bytes()).is_ok());
                out.push(Ev::P(offset, item.as_bytes().to_vec()));
            }
            FeedResult::Rejected { error, offset, .. } => out.push(Ev::R(offset, error)),
        }
        true
    }

    fn run(stream: &[u8], sizes: &[usize]) -> (Vec<Ev>, Ld06Counters) {
        let mut acc = Ld06Accumulator::new();
        let out = resync::run_in_chunks!(acc, stream, sizes, record);
        let c = acc.counters();
        assert_eq!(
            u64::from(c.packets) * 47
                + u64::from(c.checksum)
                + u64::from(c.truncated)
                + u64::from(c.garbage_bytes),
            stream.len() as u64,
            "every byte accounted for"
        );
        (out, c)
    }

    fn packet(seed: u16) -> Vec<u8> {
        let mut points = [Ld06Point::default(); 12];
        for (k, p) in points.iter_mut().enumerate() {
            p.distance_mm = seed.wrapping_mul(31).wrapping_add(k as u16 * 7);
            p.intensity = (seed as u8).wrapping_add(k as u8);
        }
        let repr = Ld06Repr {
            speed_deg_per_s: 3600,
            start_angle_centideg: (seed.wrapping_mul(97)) % 36_000,
            end_angle_centideg: (seed.wrapping_mul(97) + 800) % 36_000,
            timestamp_ms: seed % 30_000,
            points,
        };
        let mut buf = vec![0; 47];
        repr.emit(&mut buf).unwrap();
        buf
    }

    #[test]
    fn damaged_streams_at_every_chunking() {
        let good = [packet(1), packet(2), packet(3), EXAMPLE.to_vec()];
        let mut flipped = packet(4);
        flipped[20] ^= 0x08;
        // Garbage with a false header, a flipped packet (one header byte rejected, the rest
        // hunted through), a cut packet, then good ones.
        let mut stream = vec![0x00, 0x54, 0x11, 0x54];
        stream.extend_from_slice(&good[0]);
        stream.extend_from_slice(&flipped);
        stream.extend_from_slice(&good[1]);
        stream.extend_from_slice(&good[2][..30]);
        stream.extend_from_slice(&good[3]);
        stream.extend_from_slice(&good[2][..10]);
        let offsets = [4_u64, 98, 145 + 30];
        for sizes in [
            &[usize::MAX][..],
            &[1],
            &[2, 3],
            &[46, 47, 48],
            &[5, 100, 1],
        ] {
            let (events, c) = run(&stream, sizes);
            let packets: Vec<_> = events
                .iter()
                .filter_map(|e| match e {
                    Ev::P(o, b) => Some((*o, b.clone())),
                    Ev::R(..) => None,
                })
                .collect();
            assert_eq!(
                packets,
                vec![
                    (offsets[0], good[0].clone()),
                    (offsets[1], good[1].clone()),
                    (offsets[2], good[3].clone())
                ],
                "{sizes:?}"
            );
            assert!(events.contains(&Ev::R(
                51,
                Ld06Error::BadCrc {
                    stored: flipped[46],
                    computed: ld06_crc8(&flipped[..46])
                }
            )));
            // The cut packet is swallowed by the CRC check of the example that follows it
            // (its 47 bytes straddle both): one more CRC rejection, then the example.
            assert_eq!(c.checksum, 2, "{sizes:?}");
            // The trailing 10 bytes: a truncated candidate at flush.
            assert_eq!(
                events.last(),
                Some(&Ev::R(stream.len() as u64 - 10, Ld06Error::Truncated))
            );
            assert_eq!((c.packets, c.truncated), (3, 1));
        }
    }

    #[test]
    fn packet_accessor_reset_and_counters() {
        let mut acc = Ld06Accumulator::default();
        assert!(acc.packet().is_none());
        assert!(matches!(acc.feed(&EXAMPLE), FeedResult::Item { .. }));
        assert_eq!(
            acc.packet().map(|p| p.as_bytes().to_vec()),
            Some(EXAMPLE.to_vec())
        );
        assert!(matches!(acc.feed(&EXAMPLE[..20]), FeedResult::Consumed));
        assert!(acc.packet().is_none());
        assert_eq!(acc.buffered(), 20);
        acc.reset();
        assert_eq!(acc.buffered(), 0);
        assert_eq!(acc.position(), 67);
        acc.counters.garbage_bytes = u32::MAX - 1;
        let _ = acc.feed(&[1, 2, 3]);
        assert_eq!(acc.counters().garbage_bytes, u32::MAX);
        acc.clear_counters();
        assert_eq!(acc.counters(), Ld06Counters::default());
    }

    #[test]
    fn errors_display() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(Ld06Error::Truncated.to_string(), "LD06 packet truncated");
        assert_eq!(
            Ld06Error::BadCrc {
                stored: 1,
                computed: 2
            }
            .to_string(),
            "LD06 CRC mismatch: stored 0x01, computed 0x02"
        );
    }
}
