//! The laser the co-processor reads, chosen by the host's Setup at run time: which one it is
//! ([`Sensor`], its UART's baud rate), the decoder of its byte stream ([`LaserDecoder`]: one
//! accumulator of [`crate::wire`], the one the setup names), what a spinning lidar's packet
//! holds for the pipeline ([`Packet`]: returns, a revolution's start, its angular span), and
//! when each packet's returns were measured ([`PacketTimer`]).
//!
//! | sensor | code | decoder | default baud | packet |
//! | --- | --- | --- | --- | --- |
//! | SICK LMS2xx | 0 | [`SickAccumulator`] | 500 000 (the LMS fast mode) | a measured-values telegram (one line) |
//! | LDROBOT LD06 / LD19 / STL-19P | 1 | [`Ld06Accumulator`] | 230 400 | 12 returns |
//! | Slamtec RPLIDAR (A1, A2) | 2 | [`RplidarAccumulator`] | 115 200 | a standard node (1 return) or an express capsule (32) |
//! | YDLIDAR X4 (X2) | 3 | [`YdlidarAccumulator`] | 128 000 | LSN returns (1 ..= 255) |
//!
//! The RPLIDAR's default is the A1's and A2's rate; an A3 or S1 runs at 256 000 and a C1 at
//! 460 800, which the Setup gives explicitly. The X2 runs at 115 200 (give it explicitly too).
//!
//! # Counters
//! Stats carries four telegram counters; each decoder's own counters map onto them
//! ([`LaserCounts`]):
//!
//! | Stats | SICK | LD06 | RPLIDAR | YDLIDAR |
//! | --- | --- | --- | --- | --- |
//! | `telegrams_ok` | telegrams | packets | nodes + capsules | packets |
//! | `telegrams_bad_checksum` | CRC | CRC-8 | capsule checksum + node check bits | check code + check bits |
//! | `telegrams_bad_framing` | length + truncated | truncated | truncated + unpaired capsules + unsupported descriptors | bad LSN + truncated |
//!
//! Garbage bytes are not a telegram counter (a resynchronisation skips them); `laser_bytes`
//! counts every byte taken. When the setup switches sensors, the old decoder's counts are
//! kept, so Stats' counters never go back.

pub mod timing;

pub use timing::{PacketTimer, SickBeamTimes, DEFAULT_REVOLUTION_US};

use core::fmt;

use crate::angle::FineAngle;
use crate::wire::laser::TurnSteps;
use crate::wire::ld06::{Ld06Accumulator, Ld06Counters, Ld06Error, Ld06Packet};
use crate::wire::rplidar::{
    RplidarAccumulator, RplidarCounters, RplidarError, RplidarExpressScan, RplidarItem,
    RplidarNode, RplidarScanMode, RPLIDAR_CAPSULE_LEN, RPLIDAR_CAPSULE_POINTS, RPLIDAR_NODE_LEN,
    RPLIDAR_Q6_PER_TURN,
};
use crate::wire::sick::{SickAccumulator, SickCounters, SickFrameError, SickItem, Telegram};
use crate::wire::ydlidar::{
    YdlidarAccumulator, YdlidarAngleCorrection, YdlidarCounters, YdlidarError, YdlidarItem,
    YdlidarPacket, YDLIDAR_Q6_PER_TURN,
};
use crate::wire::{FeedResult, LaserReturn};

byte_enum! {
/// A laser kind: the Setup's sensor code (`docs/protocol.md`, Setup).
pub enum SensorKind {
    /// SICK LMS2xx (code 0).
    Sick = 0,
    /// LDROBOT LD06, LD19 or STL-19P (code 1).
    Ld06 = 1,
    /// Slamtec RPLIDAR (code 2).
    Rplidar = 2,
    /// YDLIDAR X4 or X2 (code 3).
    Ydlidar = 3,
}
/// The kind of a Setup's sensor code, if it names one.
pub fn from_code;
/// The Setup's sensor code.
pub fn code;
}

impl SensorKind {
    /// A short name: `sick`, `ld06`, `rplidar`, `ydlidar`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sick => "sick",
            Self::Ld06 => "ld06",
            Self::Rplidar => "rplidar",
            Self::Ydlidar => "ydlidar",
        }
    }

    /// The UART's baud rate when the Setup gives 0: SICK 500 000 (the LMS fast mode this
    /// firmware runs it at), LD06 230 400, RPLIDAR 115 200 (A1, A2), YDLIDAR 128 000 (X4).
    #[must_use]
    pub const fn default_baud(self) -> u32 {
        match self {
            Self::Sick => 500_000,
            Self::Ld06 => 230_400,
            Self::Rplidar => 115_200,
            Self::Ydlidar => 128_000,
        }
    }
}

impl fmt::Display for SensorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A laser and the mode its stream is read in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sensor {
    /// A SICK LMS2xx: measured-values telegrams through the beam table of the configured
    /// variant, in the configured measuring mode (the pipeline's configuration holds both).
    Sick,
    /// An LDROBOT LD06 / LD19 / STL-19P.
    Ld06,
    /// A Slamtec RPLIDAR in standard (SCAN, Setup mode 0) or legacy express (EXPRESS_SCAN,
    /// mode 1) scanning.
    Rplidar(RplidarScanMode),
    /// A YDLIDAR X4 or X2, with the manuals' second-level angle correction (Setup mode 0) or
    /// without it (mode 1, firmware that corrects on board).
    Ydlidar(YdlidarAngleCorrection),
}

impl Sensor {
    /// The sensor's kind.
    #[must_use]
    pub const fn kind(self) -> SensorKind {
        match self {
            Self::Sick => SensorKind::Sick,
            Self::Ld06 => SensorKind::Ld06,
            Self::Rplidar(_) => SensorKind::Rplidar,
            Self::Ydlidar(_) => SensorKind::Ydlidar,
        }
    }

    /// The sensor of a kind and a Setup mode byte (for SICK the mode is its measuring mode,
    /// checked elsewhere, so any byte gives [`Sensor::Sick`]); `None` for a mode the kind
    /// does not have (LD06: 0; RPLIDAR: 0 standard, 1 express; YDLIDAR: 0 corrected, 1 not).
    #[must_use]
    pub const fn from_kind_and_mode(kind: SensorKind, mode: u8) -> Option<Self> {
        Some(match (kind, mode) {
            (SensorKind::Sick, _) => Self::Sick,
            (SensorKind::Ld06, 0) => Self::Ld06,
            (SensorKind::Rplidar, 0) => Self::Rplidar(RplidarScanMode::Standard),
            (SensorKind::Rplidar, 1) => Self::Rplidar(RplidarScanMode::Express),
            (SensorKind::Ydlidar, 0) => Self::Ydlidar(YdlidarAngleCorrection::SecondLevel),
            (SensorKind::Ydlidar, 1) => Self::Ydlidar(YdlidarAngleCorrection::Off),
            _ => return None,
        })
    }

    /// The largest Setup mode of a lidar kind (0 for LD06, 1 for RPLIDAR and YDLIDAR);
    /// `None` for SICK (its measuring modes are checked by [`crate::wire::sick`]).
    #[must_use]
    pub const fn max_mode(kind: SensorKind) -> Option<u8> {
        match kind {
            SensorKind::Sick => None,
            SensorKind::Ld06 => Some(0),
            SensorKind::Rplidar | SensorKind::Ydlidar => Some(1),
        }
    }

    /// The Setup mode byte of a lidar (0 for SICK: its mode is the measuring mode).
    #[must_use]
    pub const fn mode(self) -> u8 {
        match self {
            Self::Sick | Self::Ld06 => 0,
            Self::Rplidar(RplidarScanMode::Standard)
            | Self::Ydlidar(YdlidarAngleCorrection::SecondLevel) => 0,
            Self::Rplidar(RplidarScanMode::Express)
            | Self::Ydlidar(YdlidarAngleCorrection::Off) => 1,
        }
    }

    /// Whether the sensor is a spinning lidar (its lines are packets of returns with their
    /// own angles).
    #[must_use]
    pub const fn is_lidar(self) -> bool {
        !matches!(self, Self::Sick)
    }
}

/// A spinning lidar's packet, as the pipeline takes it: its returns (each with its own angle,
/// in the sensor's clockwise convention), whether a revolution starts in it, and the span of
/// angles its returns were measured over (for their times).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Packet<'a> {
    /// An LD06 packet: 12 returns.
    Ld06(Ld06Packet<&'a [u8]>),
    /// An RPLIDAR standard-scan node: one return.
    RplidarNode(RplidarNode<&'a [u8]>),
    /// An RPLIDAR express capsule placed with its successor: 32 returns.
    RplidarExpress(RplidarExpressScan<'a>),
    /// A YDLIDAR packet with the correction to apply: LSN returns.
    Ydlidar(YdlidarPacket<&'a [u8]>, YdlidarAngleCorrection),
}

impl Packet<'_> {
    /// The number of returns.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Self::Ld06(_) => crate::wire::ld06::LD06_POINTS,
            Self::RplidarNode(_) => 1,
            Self::RplidarExpress(_) => RPLIDAR_CAPSULE_POINTS,
            Self::Ydlidar(p, _) => usize::from(p.sample_count()),
        }
    }

    /// Whether the packet has no return (a YDLIDAR packet with LSN 0 never passes its checks).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Return `k` (in the order the sensor measured them); `None` for `k ≥ len()`.
    #[must_use]
    pub fn get(&self, k: usize) -> Option<LaserReturn> {
        match self {
            Self::Ld06(p) => Some(LaserReturn {
                angle: p.angle(k)?,
                range_mm: u32::from(p.point(k)?.distance_mm),
                quality: Some(p.point(k)?.intensity),
            }),
            Self::RplidarNode(n) => (k == 0).then(|| n.to_return()),
            Self::RplidarExpress(e) => Some(LaserReturn {
                angle: e.angle(k)?,
                range_mm: u32::from(e.capsule().distance_mm(k)?),
                quality: None,
            }),
            Self::Ydlidar(p, correction) => Some(LaserReturn {
                angle: p.angle(k, *correction)?,
                range_mm: (u32::from(p.sample(k)?) + 2) >> 2,
                quality: None,
            }),
        }
    }

    /// The returns in order.
    pub fn returns(&self) -> impl ExactSizeIterator<Item = LaserReturn> + '_ {
        let n = self.len();
        Returns {
            packet: self,
            next: 0,
            len: n,
            angles: match self {
                Self::Ld06(p) => p.angle_steps(),
                Self::Ydlidar(p, _) => p.first_level_angle_steps(),
                _ => None,
            },
        }
    }

    /// Whether a revolution (the sensor's 0°) starts within the packet: LD06 a packet that
    /// crosses 0°; RPLIDAR a node with its S flag, a capsule whose points pass 360°; YDLIDAR
    /// the zero packet (CT bit 0). An LD06 revolution that starts between two packets is
    /// seen only across packets: [`RevolutionTracker`].
    #[must_use]
    pub fn starts_revolution(&self) -> bool {
        match self {
            Self::Ld06(p) => p.starts_revolution(),
            Self::RplidarNode(n) => n.starts_revolution(),
            Self::RplidarExpress(e) => e.starts_revolution(),
            Self::Ydlidar(p, _) => p.starts_revolution(),
        }
    }

    /// Bytes the packet takes on the wire (47, 5, 84, 10 + 2·LSN).
    #[must_use]
    pub fn wire_len(&self) -> usize {
        match self {
            Self::Ld06(_) => crate::wire::ld06::LD06_PACKET_LEN,
            Self::RplidarNode(_) => RPLIDAR_NODE_LEN,
            Self::RplidarExpress(_) => RPLIDAR_CAPSULE_LEN,
            Self::Ydlidar(p, _) => p.total_len(),
        }
    }

    /// The clockwise angle the sensor turned from its first return to its last, as the wire
    /// gives it before any per-return correction (the returns are measured evenly over it):
    /// LD06 end − start; a capsule 31/32 of the turn to the next capsule; YDLIDAR LSA − FSA;
    /// a node 0.
    #[must_use]
    pub fn span(&self) -> FineAngle {
        match self {
            Self::Ld06(p) => {
                let turn = u64::from(crate::wire::ld06::LD06_CENTIDEG_PER_TURN);
                let start = u64::from(p.start_angle_centideg()) % turn;
                let end = u64::from(p.end_angle_centideg()) % turn;
                turn_fraction((end + turn - start) % turn, turn)
            }
            Self::RplidarNode(_) => FineAngle::ZERO,
            Self::RplidarExpress(e) => {
                let turn = u64::from(RPLIDAR_Q6_PER_TURN);
                let diff = capsule_diff_q6(e);
                turn_fraction(diff * 31, turn * 32)
            }
            Self::Ydlidar(p, _) => {
                let turn = u64::from(YDLIDAR_Q6_PER_TURN);
                let first = u64::from(p.first_angle_q6()) % turn;
                let last = u64::from(p.last_angle_q6()) % turn;
                turn_fraction((last + turn - first) % turn, turn)
            }
        }
    }

    /// For an express capsule, the angle from its first point to the next capsule's (the
    /// capsule is handed out once that one has arrived): the sensor's turn between the two
    /// capsules' transmissions. `None` for other packets.
    #[must_use]
    pub fn lag(&self) -> Option<FineAngle> {
        match self {
            Self::RplidarExpress(e) => Some(turn_fraction(
                capsule_diff_q6(e),
                u64::from(RPLIDAR_Q6_PER_TURN),
            )),
            _ => None,
        }
    }

    /// The rotation rate the packet itself reports, degrees per second (LD06's speed field);
    /// `None` for the others (their rate is measured between revolution starts).
    #[must_use]
    pub fn reported_rate_deg_per_s(&self) -> Option<u16> {
        match self {
            Self::Ld06(p) => Some(p.speed_deg_per_s()),
            _ => None,
        }
    }
}

/// Where revolutions start, across packets: a packet's own flag (an RPLIDAR node's S, a
/// capsule passing 360°, the YDLIDAR zero packet, an LD06 packet crossing 0°), or, for the
/// LD06 whose packets carry no flag, a packet whose start angle lies below the previous
/// packet's end angle (the revolution began between the two).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RevolutionTracker {
    /// The last LD06 packet's end angle, hundredths of a degree (below 36 000).
    last_end: Option<u16>,
}

impl RevolutionTracker {
    /// No packet seen.
    #[must_use]
    pub const fn new() -> Self {
        Self { last_end: None }
    }

    /// Whether a revolution starts with or within `packet` (the packets in stream order).
    pub fn starts(&mut self, packet: &Packet<'_>) -> bool {
        match packet {
            Packet::Ld06(p) => {
                let turn = crate::wire::ld06::LD06_CENTIDEG_PER_TURN;
                let start = p.start_angle_centideg() % turn;
                let end = p.end_angle_centideg() % turn;
                let between = self.last_end.is_some_and(|last| start < last);
                self.last_end = Some(end);
                between || p.starts_revolution()
            }
            other => other.starts_revolution(),
        }
    }
}

/// The clockwise turn between a capsule's start angle and the next one's, degrees·64.
fn capsule_diff_q6(e: &RplidarExpressScan<'_>) -> u64 {
    let turn = u64::from(RPLIDAR_Q6_PER_TURN);
    let start = u64::from(e.capsule().start_angle_q6()) % turn;
    let next = u64::from(e.next_start_angle_q6()) % turn;
    (next + turn - start) % turn
}

/// `numerator / denominator` of a turn, rounded (the wire module's exact rule).
fn turn_fraction(numerator: u64, denominator: u64) -> FineAngle {
    crate::wire::laser::turn_fraction(numerator, denominator)
}

/// The returns of a [`Packet`], in order.
struct Returns<'p, 'a> {
    packet: &'p Packet<'a>,
    next: usize,
    len: usize,
    /// An LD06 packet's angles or a YDLIDAR packet's first-level angles, step by step (each
    /// exactly the packet's own per-index angle).
    angles: Option<TurnSteps>,
}

impl Iterator for Returns<'_, '_> {
    type Item = LaserReturn;

    fn next(&mut self) -> Option<LaserReturn> {
        while self.next < self.len {
            let k = self.next;
            self.next += 1;
            if let Some(steps) = self.angles.as_mut() {
                let angle = steps.next_angle();
                match self.packet {
                    Packet::Ld06(p) => {
                        if let Some(point) = p.point(k) {
                            return Some(LaserReturn {
                                angle,
                                range_mm: u32::from(point.distance_mm),
                                quality: Some(point.intensity),
                            });
                        }
                    }
                    Packet::Ydlidar(p, correction) => {
                        if let Some(si) = p.sample(k) {
                            return Some(LaserReturn {
                                angle: crate::wire::ydlidar::corrected(angle, si, *correction),
                                range_mm: (u32::from(si) + 2) >> 2,
                                quality: None,
                            });
                        }
                    }
                    _ => {}
                }
                continue;
            }
            if let Some(r) = self.packet.get(k) {
                return Some(r);
            }
        }
        None
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.len.saturating_sub(self.next);
        (left, Some(left))
    }
}

impl ExactSizeIterator for Returns<'_, '_> {}

/// What a [`LaserDecoder`] hands out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LaserItem<'a> {
    /// A SICK telegram that passed its checks (measured values or another reply).
    Telegram(Telegram<&'a [u8]>),
    /// A spinning lidar's packet that passed its checks.
    Packet(Packet<'a>),
    /// Something valid that carries no returns (an ACK, a response descriptor, a health or
    /// info response).
    Other,
}

/// Why a [`LaserDecoder`] refused a candidate: the decoder's own error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LaserError {
    /// The SICK accumulator's.
    Sick(SickFrameError),
    /// The LD06 accumulator's.
    Ld06(Ld06Error),
    /// The RPLIDAR accumulator's.
    Rplidar(RplidarError),
    /// The YDLIDAR accumulator's.
    Ydlidar(YdlidarError),
}

impl fmt::Display for LaserError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sick(e) => e.fmt(f),
            Self::Ld06(e) => e.fmt(f),
            Self::Rplidar(e) => e.fmt(f),
            Self::Ydlidar(e) => e.fmt(f),
        }
    }
}

/// A decoder's counters as Stats carries them (see the [module documentation](self)). They
/// saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LaserCounts {
    /// Units that passed every check (telegrams, packets, nodes, capsules).
    pub ok: u32,
    /// Candidates whose checksum or check bits failed.
    pub bad_checksum: u32,
    /// Candidates with bad framing (length, truncation, an unpaired capsule).
    pub bad_framing: u32,
    /// Units that passed their checks but were refused as implausible (an RPLIDAR
    /// standard-scan node whose angle cannot follow its neighbours; `docs/lidars.md`).
    /// Not in `ok`.
    pub implausible: u32,
}

impl LaserCounts {
    fn saturating_add(self, other: Self) -> Self {
        Self {
            ok: self.ok.saturating_add(other.ok),
            bad_checksum: self.bad_checksum.saturating_add(other.bad_checksum),
            bad_framing: self.bad_framing.saturating_add(other.bad_framing),
            implausible: self.implausible.saturating_add(other.implausible),
        }
    }
}

/// The current decoder's own counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LaserCounters {
    /// The SICK accumulator's.
    Sick(SickCounters),
    /// The LD06 accumulator's.
    Ld06(Ld06Counters),
    /// The RPLIDAR accumulator's.
    Rplidar(RplidarCounters),
    /// The YDLIDAR accumulator's.
    Ydlidar(YdlidarCounters),
}

impl Default for LaserCounters {
    /// A SICK accumulator's, zero.
    fn default() -> Self {
        Self::Sick(SickCounters::default())
    }
}

impl LaserCounters {
    /// The counters mapped onto Stats' (see the [module documentation](self)).
    #[must_use]
    pub fn counts(&self) -> LaserCounts {
        match *self {
            Self::Sick(c) => LaserCounts {
                ok: c.telegrams_ok,
                bad_checksum: c.crc_errors,
                bad_framing: c.length_errors.saturating_add(c.truncated),
                implausible: 0,
            },
            Self::Ld06(c) => LaserCounts {
                ok: c.packets,
                bad_checksum: c.checksum,
                bad_framing: c.truncated,
                implausible: 0,
            },
            Self::Rplidar(c) => LaserCounts {
                ok: c.nodes.saturating_add(c.capsules),
                bad_checksum: c.checksum.saturating_add(c.node_check),
                bad_framing: c
                    .truncated
                    .saturating_add(c.capsules_unpaired)
                    .saturating_add(c.unsupported),
                implausible: c.implausible,
            },
            Self::Ydlidar(c) => LaserCounts {
                ok: c.packets,
                bad_checksum: c.checksum.saturating_add(c.check_bits),
                bad_framing: c.bad_length.saturating_add(c.truncated),
                implausible: 0,
            },
        }
    }

    /// The SICK accumulator's counters, when SICK is the sensor.
    #[must_use]
    pub const fn sick(&self) -> Option<SickCounters> {
        match *self {
            Self::Sick(c) => Some(c),
            _ => None,
        }
    }
}

/// The accumulator in use.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
enum Accumulator {
    Sick(SickAccumulator),
    Ld06(Ld06Accumulator),
    Rplidar(RplidarAccumulator),
    Ydlidar(YdlidarAccumulator, YdlidarAngleCorrection),
}

impl Accumulator {
    const fn new(sensor: Sensor) -> Self {
        match sensor {
            Sensor::Sick => Self::Sick(SickAccumulator::new()),
            Sensor::Ld06 => Self::Ld06(Ld06Accumulator::new()),
            Sensor::Rplidar(mode) => Self::Rplidar(RplidarAccumulator::with_mode(mode)),
            Sensor::Ydlidar(correction) => Self::Ydlidar(YdlidarAccumulator::new(), correction),
        }
    }

    fn position(&self) -> u64 {
        match self {
            Self::Sick(a) => a.position(),
            Self::Ld06(a) => a.position(),
            Self::Rplidar(a) => a.position(),
            Self::Ydlidar(a, _) => a.position(),
        }
    }

    fn counters(&self) -> LaserCounters {
        match self {
            Self::Sick(a) => LaserCounters::Sick(a.stats()),
            Self::Ld06(a) => LaserCounters::Ld06(a.counters()),
            Self::Rplidar(a) => LaserCounters::Rplidar(a.counters()),
            Self::Ydlidar(a, _) => LaserCounters::Ydlidar(a.counters()),
        }
    }
}

/// The result of one [`LaserDecoder::feed`].
pub type LaserFeed<'s, 'c> = FeedResult<'c, LaserItem<'s>, LaserError>;

/// The decoder of the laser's byte stream: the one accumulator the setup names (an enum: its
/// RAM is the largest one's, the SICK accumulator's 818-byte buffer), the counts of the
/// decoders it replaced, and the bytes taken over all of them.
#[derive(Debug, Clone)]
pub struct LaserDecoder {
    sensor: Sensor,
    accumulator: Accumulator,
    /// Counts of the decoders replaced by a sensor change.
    retired: LaserCounts,
    /// Bytes taken by the decoders replaced.
    retired_bytes: u64,
}

impl Default for LaserDecoder {
    fn default() -> Self {
        Self::new(Sensor::Sick)
    }
}

impl LaserDecoder {
    /// A decoder for `sensor`, at stream position 0, with zeroed counters. `const`.
    #[must_use]
    pub const fn new(sensor: Sensor) -> Self {
        Self {
            sensor,
            accumulator: Accumulator::new(sensor),
            retired: LaserCounts {
                ok: 0,
                bad_checksum: 0,
                bad_framing: 0,
                implausible: 0,
            },
            retired_bytes: 0,
        }
    }

    /// The sensor decoded.
    #[must_use]
    pub const fn sensor(&self) -> Sensor {
        self.sensor
    }

    /// Decodes `sensor` from now on: the same sensor in the same mode keeps the accumulator
    /// (and what it holds); another gets a fresh one, whatever was buffered dropped, the old
    /// one's counts kept. Returns whether the decoder changed.
    // Never inlined: the new accumulator (up to a kilobyte) is built in this frame, which
    // then does not add to the stack of the setup's other work (the micro:bit's deepest
    // path).
    #[inline(never)]
    pub fn set_sensor(&mut self, sensor: Sensor) -> bool {
        if sensor == self.sensor {
            return false;
        }
        self.retired = self
            .retired
            .saturating_add(self.accumulator.counters().counts());
        self.retired_bytes = self.retired_bytes.wrapping_add(self.accumulator.position());
        self.accumulator = Accumulator::new(sensor);
        self.sensor = sensor;
        true
    }

    /// Feeds a chunk of the stream and returns the first item or refusal it completes, with
    /// the rest of the chunk (the accumulators' `feed`): call it again with `remaining` until
    /// [`FeedResult::Consumed`]. An item borrows the decoder until the next call.
    pub fn feed<'s, 'c>(&'s mut self, chunk: &'c [u8]) -> LaserFeed<'s, 'c> {
        match &mut self.accumulator {
            Accumulator::Sick(a) => map(a.feed(chunk), sick_item, LaserError::Sick),
            Accumulator::Ld06(a) => map(
                a.feed(chunk),
                |p| LaserItem::Packet(Packet::Ld06(p)),
                LaserError::Ld06,
            ),
            Accumulator::Rplidar(a) => map(a.feed(chunk), rplidar_item, LaserError::Rplidar),
            Accumulator::Ydlidar(a, correction) => {
                let correction = *correction;
                map(
                    a.feed(chunk),
                    move |i| ydlidar_item(i, correction),
                    LaserError::Ydlidar,
                )
            }
        }
    }

    /// Ends the stream: what the accumulator still holds is handed out or refused (the
    /// accumulators' `flush`); call it until [`FeedResult::Consumed`].
    pub fn flush(&mut self) -> LaserFeed<'_, 'static> {
        match &mut self.accumulator {
            Accumulator::Sick(a) => map(a.flush(), sick_item, LaserError::Sick),
            Accumulator::Ld06(a) => map(
                a.flush(),
                |p| LaserItem::Packet(Packet::Ld06(p)),
                LaserError::Ld06,
            ),
            Accumulator::Rplidar(a) => map(a.flush(), rplidar_item, LaserError::Rplidar),
            Accumulator::Ydlidar(a, correction) => {
                let correction = *correction;
                map(
                    a.flush(),
                    move |i| ydlidar_item(i, correction),
                    LaserError::Ydlidar,
                )
            }
        }
    }

    /// The current accumulator's own counters.
    #[must_use]
    pub fn counters(&self) -> LaserCounters {
        self.accumulator.counters()
    }

    /// The counts Stats carries: the current decoder's and those it replaced.
    #[must_use]
    pub fn counts(&self) -> LaserCounts {
        self.retired
            .saturating_add(self.accumulator.counters().counts())
    }

    /// Bytes taken since the decoder was made, over every sensor (wrapping at 2⁶⁴).
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.retired_bytes.wrapping_add(self.accumulator.position())
    }
}

fn map<'c, T, E, I>(
    result: FeedResult<'c, T, E>,
    item: impl FnOnce(T) -> I,
    error: impl FnOnce(E) -> LaserError,
) -> FeedResult<'c, I, LaserError> {
    match result {
        FeedResult::Consumed => FeedResult::Consumed,
        FeedResult::Item {
            item: i,
            offset,
            remaining,
        } => FeedResult::Item {
            item: item(i),
            offset,
            remaining,
        },
        FeedResult::Rejected {
            error: e,
            offset,
            remaining,
        } => FeedResult::Rejected {
            error: error(e),
            offset,
            remaining,
        },
    }
}

fn sick_item(item: SickItem<'_>) -> LaserItem<'_> {
    match item {
        SickItem::Telegram(t) => LaserItem::Telegram(t),
        SickItem::Ack | SickItem::Nak => LaserItem::Other,
    }
}

fn rplidar_item(item: RplidarItem<'_>) -> LaserItem<'_> {
    match item {
        RplidarItem::Node(n) => LaserItem::Packet(Packet::RplidarNode(n)),
        RplidarItem::Express(e) => LaserItem::Packet(Packet::RplidarExpress(e)),
        RplidarItem::Descriptor(_) | RplidarItem::Response(_) => LaserItem::Other,
    }
}

fn ydlidar_item(item: YdlidarItem<'_>, correction: YdlidarAngleCorrection) -> LaserItem<'_> {
    match item {
        YdlidarItem::Packet(p) => LaserItem::Packet(Packet::Ydlidar(p, correction)),
        YdlidarItem::Descriptor(_) => LaserItem::Other,
    }
}

#[cfg(test)]
mod tests;
