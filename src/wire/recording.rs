//! The recording format (`docs/recording.md`): timestamped laser bytes, actuator angles, poses
//! and the setup, as converters and the simulator write them and the tools replay them.
//!
//! [`Reader`] walks a recording held in memory without copying; [`Event::emit`] writes one
//! event into a caller's buffer. Both follow the crate's panic contract: bad input is an error.

use core::fmt;

/// The file's magic bytes: ASCII `TPYRREC\n`.
pub const MAGIC: [u8; 8] = *b"TPYRREC\n";
/// The newest version this module reads and writes (a file with a rig event); it reads
/// versions 1 (whose lasers are all SICK LMS2xx: it has no sensor event) to this one.
/// [`emit_header`] writes version 2 (no rig event), [`emit_header_version`] either.
pub const VERSION: u16 = 3;
/// The version of a file without a rig event, which [`emit_header`] writes: readers of
/// version 2 read it.
pub const VERSION_WITHOUT_RIG: u16 = 2;
/// Bytes of the file header (versions 1 and 2).
pub const HEADER_LEN: usize = 16;
/// Bytes of an event header (kind, time, length).
pub const EVENT_HEADER_LEN: usize = 11;
/// The largest payload of one event.
pub const MAX_PAYLOAD: usize = 4096;
/// Bytes of a setup payload.
pub const SETUP_LEN: usize = 28;
/// Bytes of a sensor payload (version 2).
pub const SENSOR_LEN: usize = 4;
/// Bytes of a rig payload (version 3): the mount byte, 3 reserved, the link's mount block (20)
/// and filter block (38).
pub const RIG_LEN: usize = 62;

/// Event kinds.
mod kind {
    pub const LASER: u8 = 0x01;
    pub const ANGLE: u8 = 0x02;
    pub const POSE: u8 = 0x03;
    pub const SETUP: u8 = 0x04;
    pub const MARKER: u8 = 0x05;
    pub const SENSOR: u8 = 0x06;
    pub const RIG: u8 = 0x07;
}

/// How the laser is mounted on its actuator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MountKind {
    /// A vertical scan plane panned about the vertical axis (the paper's robot).
    PannedVertical,
    /// A horizontal scan plane tilted about the sideways axis (positive tilt looks down).
    TiltedHorizontal,
}

/// The setup a recording was taken with.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SetupEvent {
    /// How the laser is mounted.
    pub mount: MountKind,
    /// The SICK measuring mode (0x77 mode number; 0 = factory default).
    pub measuring_mode: u8,
    /// Field of view, degrees (180 or 100).
    pub field_deg: u16,
    /// Angular resolution, hundredths of a degree (25, 50 or 100).
    pub resolution_cdeg: u16,
    /// Sensor position in the robot frame, metres (x forward, y left, z up above the ground).
    pub sensor_m: [f32; 3],
    /// Scan lines per observation; 0 = one observation per full sweep.
    pub lines_per_observation: u32,
}

/// Which laser a recording's laser bytes come from (version 2; a file without this event
/// recorded a SICK LMS2xx, as every version-1 file did).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorEvent {
    /// The sensor, as Setup codes it (`docs/protocol.md`): 0 SICK LMS2xx, 1 LDROBOT
    /// LD06/LD19/STL-19P, 2 Slamtec RPLIDAR, 3 YDLIDAR; 0 ..= 3.
    pub sensor: u8,
    /// The sensor's mode as Setup codes it (RPLIDAR 0 standard, 1 express; YDLIDAR 0 with the
    /// X4/X2 angle correction, 1 without; LD06 0); for a SICK the setup event's measuring
    /// mode applies and this is 0.
    pub mode: u8,
}

impl SensorEvent {
    /// The SICK LMS2xx of every version-1 file.
    pub const SICK: Self = Self { sensor: 0, mode: 0 };

    fn parse(data: &[u8]) -> Option<Self> {
        let &[sensor, mode, 0, 0] = data else {
            return None;
        };
        (sensor <= 3).then_some(Self { sensor, mode })
    }
}

/// How the laser was mounted and which returns were refused before geometry (version 3): the
/// host link's Setup fields of the same meaning (`docs/protocol.md`, "0x87 Setup": the mount
/// byte, the mount block, the filter block). It overrides the setup event's mount.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RigEvent {
    /// 0 the panned-vertical preset, 1 the tilted-horizontal preset, 2 the general mount.
    pub mount: u8,
    /// The actuator's axis, sense and zero, the sensor frame's roll, pitch and yaw.
    pub mount_block: crate::wire::link::MountSetup,
    /// The masks and filters.
    pub filter: crate::wire::link::FilterSetup,
}

impl RigEvent {
    fn parse(data: &[u8]) -> Option<Self> {
        if data.len() != RIG_LEN {
            return None;
        }
        let mount = *data.first()?;
        if mount > 2 || take::<3>(data, 1)? != [0; 3] {
            return None;
        }
        let u16_at = |at| take::<2>(data, at).map(u16::from_le_bytes);
        let mut sectors = [(0, 0); crate::wire::link::SETUP_SECTORS];
        for (i, s) in sectors.iter_mut().enumerate() {
            *s = (u16_at(30 + 4 * i)?, u16_at(32 + 4 * i)?);
        }
        Some(Self {
            mount,
            mount_block: crate::wire::link::MountSetup {
                axis: *data.get(4)?,
                sense: i8::from_le_bytes([*data.get(5)?]),
                zero_deg: f32_at(data, 8)?,
                rpy_deg: [f32_at(data, 12)?, f32_at(data, 16)?, f32_at(data, 20)?],
            },
            filter: crate::wire::link::FilterSetup {
                min_range_cm: u16_at(24)?,
                max_range_cm: u16_at(26)?,
                min_quality: *data.get(28)?,
                sector_count: *data.get(29)?,
                sectors,
            },
        })
    }

    fn emit(&self, out: &mut [u8]) {
        out.fill(0);
        let m = &self.mount_block;
        put(out, 0, &[self.mount]);
        put(out, 4, &[m.axis]);
        put(out, 5, &m.sense.to_le_bytes());
        put(out, 8, &m.zero_deg.to_le_bytes());
        for (i, v) in m.rpy_deg.iter().enumerate() {
            put(out, 12 + 4 * i, &v.to_le_bytes());
        }
        let f = &self.filter;
        put(out, 24, &f.min_range_cm.to_le_bytes());
        put(out, 26, &f.max_range_cm.to_le_bytes());
        put(out, 28, &[f.min_quality, f.sector_count]);
        for (i, (a, b)) in f.sectors.iter().enumerate() {
            put(out, 30 + 4 * i, &a.to_le_bytes());
            put(out, 32 + 4 * i, &b.to_le_bytes());
        }
    }
}

/// One event's content.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Payload<'a> {
    /// Bytes as they came off the laser's UART (1 ..= 4096).
    Laser(&'a [u8]),
    /// The actuator angle as a fraction of a turn (value / 65536 turns).
    Angle(u16),
    /// The robot pose: x, y, z (m), roll, pitch, yaw (rad).
    Pose([f32; 6]),
    /// The setup.
    Setup(SetupEvent),
    /// A marker id.
    Marker(u32),
    /// The laser the recording's bytes come from (version 2).
    Sensor(SensorEvent),
    /// The mount and the filters (version 3).
    Rig(RigEvent),
    /// An event of a kind this version does not know; skipped by its length.
    Unknown {
        /// The kind byte.
        kind: u8,
        /// The payload.
        data: &'a [u8],
    },
}

/// One timestamped event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event<'a> {
    /// Microseconds since the start of the recording.
    pub time_us: u64,
    /// What happened.
    pub payload: Payload<'a>,
}

/// Why a recording could not be read or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RecordingError {
    /// The file does not start with the magic bytes.
    BadMagic,
    /// The version is not one this module reads.
    UnsupportedVersion {
        /// The version found.
        version: u16,
    },
    /// The header length is below 16 or beyond the file.
    BadHeader,
    /// An event is cut off by the end of the data.
    Truncated {
        /// Byte offset of the event.
        offset: usize,
    },
    /// An event's payload is longer than 4096 bytes, empty laser bytes, or the wrong length
    /// for its kind.
    BadLength {
        /// Byte offset of the event.
        offset: usize,
    },
    /// An event's time is before the previous event's.
    TimeWentBack {
        /// Byte offset of the event.
        offset: usize,
    },
    /// A setup or sensor field holds a value this version does not know.
    BadSetup {
        /// Byte offset of the event.
        offset: usize,
    },
    /// The output buffer is too small.
    BufferTooSmall,
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadMagic => f.write_str("not a recording (bad magic bytes)"),
            Self::UnsupportedVersion { version } => {
                write!(
                    f,
                    "recording version {version} is not supported (this reads versions 1 to \
                     {VERSION})"
                )
            }
            Self::BadHeader => f.write_str("bad recording header length"),
            Self::Truncated { offset } => write!(f, "event at byte {offset} is truncated"),
            Self::BadLength { offset } => write!(f, "event at byte {offset} has a bad length"),
            Self::TimeWentBack { offset } => {
                write!(f, "event at byte {offset} goes back in time")
            }
            Self::BadSetup { offset } => write!(f, "setup event at byte {offset} is invalid"),
            Self::BufferTooSmall => f.write_str("output buffer too small"),
        }
    }
}

/// Writes the file header of a recording without a rig event (version
/// [`VERSION_WITHOUT_RIG`]) into `out`; returns the bytes written (16).
///
/// # Errors
/// [`RecordingError::BufferTooSmall`].
pub fn emit_header(out: &mut [u8]) -> Result<usize, RecordingError> {
    emit_header_version(out, VERSION_WITHOUT_RIG)
}

/// Writes the file header of `version` (2, or [`VERSION`] for a file with a rig event) into
/// `out`; returns the bytes written (16).
///
/// # Errors
/// [`RecordingError::BufferTooSmall`].
pub fn emit_header_version(out: &mut [u8], version: u16) -> Result<usize, RecordingError> {
    let header = out
        .get_mut(..HEADER_LEN)
        .ok_or(RecordingError::BufferTooSmall)?;
    header.fill(0);
    let (magic, rest) = header.split_at_mut(8);
    magic.copy_from_slice(&MAGIC);
    put(rest, 0, &version.to_le_bytes());
    #[allow(clippy::cast_possible_truncation)]
    put(rest, 2, &(HEADER_LEN as u16).to_le_bytes());
    Ok(HEADER_LEN)
}

/// Copies `bytes` into `out` at `at` if it fits (callers size `out` first).
fn put(out: &mut [u8], at: usize, bytes: &[u8]) {
    if let Some(dst) = out.get_mut(at..at + bytes.len()) {
        dst.copy_from_slice(bytes);
    }
}

/// Reads `N` bytes at `at`.
fn take<const N: usize>(data: &[u8], at: usize) -> Option<[u8; N]> {
    data.get(at..at.checked_add(N)?)?.try_into().ok()
}

fn f32_at(data: &[u8], at: usize) -> Option<f32> {
    take::<4>(data, at).map(f32::from_le_bytes)
}

impl SetupEvent {
    fn parse(data: &[u8]) -> Option<Self> {
        if data.len() != SETUP_LEN {
            return None;
        }
        let mount = match data.first()? {
            0 => MountKind::PannedVertical,
            1 => MountKind::TiltedHorizontal,
            _ => return None,
        };
        let field_deg = u16::from_le_bytes(take(data, 2)?);
        let resolution_cdeg = u16::from_le_bytes(take(data, 4)?);
        if !matches!(field_deg, 100 | 180) || !matches!(resolution_cdeg, 25 | 50 | 100) {
            return None;
        }
        let sensor_m = [f32_at(data, 8)?, f32_at(data, 12)?, f32_at(data, 16)?];
        if sensor_m.iter().any(|v| !v.is_finite()) {
            return None;
        }
        Some(Self {
            mount,
            measuring_mode: *data.get(1)?,
            field_deg,
            resolution_cdeg,
            sensor_m,
            lines_per_observation: u32::from_le_bytes(take(data, 20)?),
        })
    }

    fn emit(&self, out: &mut [u8]) {
        out.fill(0);
        put(
            out,
            0,
            &[
                match self.mount {
                    MountKind::PannedVertical => 0,
                    MountKind::TiltedHorizontal => 1,
                },
                self.measuring_mode,
            ],
        );
        put(out, 2, &self.field_deg.to_le_bytes());
        put(out, 4, &self.resolution_cdeg.to_le_bytes());
        for (i, v) in self.sensor_m.iter().enumerate() {
            put(out, 8 + 4 * i, &v.to_le_bytes());
        }
        put(out, 20, &self.lines_per_observation.to_le_bytes());
    }
}

impl Event<'_> {
    fn kind(&self) -> u8 {
        match self.payload {
            Payload::Laser(_) => kind::LASER,
            Payload::Angle(_) => kind::ANGLE,
            Payload::Pose(_) => kind::POSE,
            Payload::Setup(_) => kind::SETUP,
            Payload::Marker(_) => kind::MARKER,
            Payload::Sensor(_) => kind::SENSOR,
            Payload::Rig(_) => kind::RIG,
            Payload::Unknown { kind, .. } => kind,
        }
    }

    fn payload_len(&self) -> usize {
        match self.payload {
            Payload::Laser(bytes) => bytes.len(),
            Payload::Angle(_) => 2,
            Payload::Pose(_) => 24,
            Payload::Setup(_) => SETUP_LEN,
            Payload::Marker(_) => 4,
            Payload::Sensor(_) => SENSOR_LEN,
            Payload::Rig(_) => RIG_LEN,
            Payload::Unknown { data, .. } => data.len(),
        }
    }

    /// Bytes this event takes when emitted.
    #[must_use]
    pub fn buffer_len(&self) -> usize {
        EVENT_HEADER_LEN + self.payload_len()
    }

    /// Writes the event into `out`; returns the bytes written.
    ///
    /// # Errors
    /// [`RecordingError::BufferTooSmall`], or [`RecordingError::BadLength`] for laser bytes
    /// that are empty or longer than 4096.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RecordingError> {
        let len = self.payload_len();
        if len > MAX_PAYLOAD || (matches!(self.payload, Payload::Laser(_)) && len == 0) {
            return Err(RecordingError::BadLength { offset: 0 });
        }
        let total = self.buffer_len();
        let out = out.get_mut(..total).ok_or(RecordingError::BufferTooSmall)?;
        let (header, body) = out.split_at_mut(EVENT_HEADER_LEN);
        put(header, 0, &[self.kind()]);
        put(header, 1, &self.time_us.to_le_bytes());
        #[allow(clippy::cast_possible_truncation)]
        put(header, 9, &(len as u16).to_le_bytes());
        match self.payload {
            Payload::Laser(bytes) | Payload::Unknown { data: bytes, .. } => put(body, 0, bytes),
            Payload::Angle(a) => put(body, 0, &a.to_le_bytes()),
            Payload::Pose(p) => {
                for (i, v) in p.iter().enumerate() {
                    put(body, 4 * i, &v.to_le_bytes());
                }
            }
            Payload::Setup(s) => s.emit(body),
            Payload::Marker(m) => put(body, 0, &m.to_le_bytes()),
            Payload::Sensor(e) => put(body, 0, &[e.sensor, e.mode, 0, 0]),
            Payload::Rig(r) => r.emit(body),
        }
        Ok(total)
    }
}

/// Walks the events of a recording held in memory.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    data: &'a [u8],
    version: u16,
    offset: usize,
    last_time: u64,
    failed: bool,
    unknown: u32,
}

impl<'a> Reader<'a> {
    /// Checks the file header and positions the reader at the first event.
    ///
    /// # Errors
    /// Bad magic, an unsupported version, or a bad header length.
    pub fn new(data: &'a [u8]) -> Result<Self, RecordingError> {
        if data.get(..8) != Some(&MAGIC[..]) {
            return Err(RecordingError::BadMagic);
        }
        let version = take::<2>(data, 8)
            .map(u16::from_le_bytes)
            .ok_or(RecordingError::BadHeader)?;
        if !(1..=VERSION).contains(&version) {
            return Err(RecordingError::UnsupportedVersion { version });
        }
        let header_len = take::<2>(data, 10)
            .map(|b| usize::from(u16::from_le_bytes(b)))
            .ok_or(RecordingError::BadHeader)?;
        if header_len < HEADER_LEN || header_len > data.len() {
            return Err(RecordingError::BadHeader);
        }
        Ok(Self {
            data,
            version,
            offset: header_len,
            last_time: 0,
            failed: false,
            unknown: 0,
        })
    }

    /// The file's version (1 ..= 3).
    #[must_use]
    pub const fn version(&self) -> u16 {
        self.version
    }

    /// Events of unknown kinds skipped so far.
    #[must_use]
    pub const fn unknown_events(&self) -> u32 {
        self.unknown
    }

    /// The byte offset of the next event.
    #[must_use]
    pub const fn offset(&self) -> usize {
        self.offset
    }

    fn next_event(&mut self) -> Result<Event<'a>, RecordingError> {
        let offset = self.offset;
        let data = self.data;
        let header = data
            .get(offset..offset + EVENT_HEADER_LEN)
            .ok_or(RecordingError::Truncated { offset })?;
        let kind = *header.first().ok_or(RecordingError::Truncated { offset })?;
        let time_us = take::<8>(header, 1)
            .map(u64::from_le_bytes)
            .ok_or(RecordingError::Truncated { offset })?;
        let len = take::<2>(header, 9)
            .map(|b| usize::from(u16::from_le_bytes(b)))
            .ok_or(RecordingError::Truncated { offset })?;
        if len > MAX_PAYLOAD {
            return Err(RecordingError::BadLength { offset });
        }
        let start = offset + EVENT_HEADER_LEN;
        let body = data
            .get(start..start + len)
            .ok_or(RecordingError::Truncated { offset })?;
        if time_us < self.last_time {
            return Err(RecordingError::TimeWentBack { offset });
        }
        let bad_len = RecordingError::BadLength { offset };
        let payload = match kind {
            kind::LASER if len > 0 => Payload::Laser(body),
            kind::ANGLE => {
                Payload::Angle(take::<2>(body, 0).map(u16::from_le_bytes).ok_or(bad_len)?)
            }
            kind::POSE if len == 24 => {
                let mut p = [0.0_f32; 6];
                for (i, v) in p.iter_mut().enumerate() {
                    *v = f32_at(body, 4 * i).ok_or(bad_len)?;
                }
                Payload::Pose(p)
            }
            kind::SETUP => {
                Payload::Setup(SetupEvent::parse(body).ok_or(RecordingError::BadSetup { offset })?)
            }
            kind::MARKER if len == 4 => {
                Payload::Marker(take::<4>(body, 0).map(u32::from_le_bytes).ok_or(bad_len)?)
            }
            kind::SENSOR if self.version >= 2 => {
                if len != SENSOR_LEN {
                    return Err(bad_len);
                }
                Payload::Sensor(
                    SensorEvent::parse(body).ok_or(RecordingError::BadSetup { offset })?,
                )
            }
            kind::RIG if self.version >= 3 => {
                if len != RIG_LEN {
                    return Err(bad_len);
                }
                Payload::Rig(RigEvent::parse(body).ok_or(RecordingError::BadSetup { offset })?)
            }
            kind::LASER | kind::POSE | kind::MARKER => return Err(bad_len),
            other => {
                self.unknown = self.unknown.saturating_add(1);
                Payload::Unknown {
                    kind: other,
                    data: body,
                }
            }
        };
        if matches!(payload, Payload::Angle(_)) && len != 2 {
            return Err(bad_len);
        }
        self.offset = start + len;
        self.last_time = time_us;
        Ok(Event { time_us, payload })
    }
}

impl<'a> Iterator for Reader<'a> {
    type Item = Result<Event<'a>, RecordingError>;

    /// The next event; after the first error, `None`.
    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.offset >= self.data.len() {
            return None;
        }
        let item = self.next_event();
        self.failed = item.is_err();
        Some(item)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    /// The example of docs/recording.md, byte for byte.
    const DOC_EXAMPLE: &[u8] = &[
        0x54, 0x50, 0x59, 0x52, 0x52, 0x45, 0x43, 0x0A, 0x02, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00,
        0x00, //
        0x04, 0, 0, 0, 0, 0, 0, 0, 0, 0x1C, 0x00, //
        0x01, 0x00, 0xB4, 0x00, 0x32, 0x00, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0xCD, 0xCC, 0xCC,
        0x3E, 0xE2, 0x00, 0x00, 0x00, 0, 0, 0, 0, //
        0x01, 0x15, 0x34, 0, 0, 0, 0, 0, 0, 0x04, 0x00, 0x06, 0x02, 0x80, 0xD6,
    ];

    fn setup() -> SetupEvent {
        SetupEvent {
            mount: MountKind::TiltedHorizontal,
            measuring_mode: 0,
            field_deg: 180,
            resolution_cdeg: 50,
            sensor_m: [0.0, 0.0, 0.4],
            lines_per_observation: 226,
        }
    }

    #[test]
    fn reads_the_documented_example() {
        let events: Vec<_> = Reader::new(DOC_EXAMPLE).unwrap().collect();
        assert_eq!(events.len(), 2);
        assert_eq!(
            events[0],
            Ok(Event {
                time_us: 0,
                payload: Payload::Setup(setup())
            })
        );
        assert_eq!(
            events[1],
            Ok(Event {
                time_us: 13_333,
                payload: Payload::Laser(&[0x06, 0x02, 0x80, 0xD6])
            })
        );
    }

    #[test]
    fn writes_the_documented_example() {
        let mut buf = [0_u8; 128];
        let mut n = emit_header(&mut buf).unwrap();
        for e in [
            Event {
                time_us: 0,
                payload: Payload::Setup(setup()),
            },
            Event {
                time_us: 13_333,
                payload: Payload::Laser(&[0x06, 0x02, 0x80, 0xD6]),
            },
        ] {
            n += e.emit(&mut buf[n..]).unwrap();
        }
        assert_eq!(&buf[..n], DOC_EXAMPLE);
    }

    #[test]
    fn every_kind_round_trips() {
        let events = [
            Event {
                time_us: 1,
                payload: Payload::Angle(0x4000),
            },
            Event {
                time_us: 2,
                payload: Payload::Pose([1.0, -2.0, 0.5, 0.01, -0.02, 3.0]),
            },
            Event {
                time_us: 2,
                payload: Payload::Marker(7),
            },
            Event {
                time_us: 3,
                payload: Payload::Unknown {
                    kind: 0x7F,
                    data: &[1, 2, 3],
                },
            },
        ];
        let mut buf = [0_u8; 256];
        let mut n = emit_header(&mut buf).unwrap();
        for e in &events {
            n += e.emit(&mut buf[n..]).unwrap();
        }
        let mut reader = Reader::new(&buf[..n]).unwrap();
        let back: Vec<_> = reader.by_ref().map(Result::unwrap).collect();
        assert_eq!(back, events);
        assert_eq!(reader.unknown_events(), 1);
    }

    /// Version 2's sensor event; a version-1 file still reads (as SICK: its kind 0x06 is an
    /// unknown event there).
    #[test]
    fn the_sensor_event_and_version_1_files() {
        let sensor = Event {
            time_us: 0,
            payload: Payload::Sensor(SensorEvent { sensor: 1, mode: 0 }),
        };
        let mut buf = [0_u8; 128];
        let mut n = emit_header(&mut buf).unwrap();
        assert_eq!(buf[8], 2);
        n += sensor.emit(&mut buf[n..]).unwrap();
        assert_eq!(
            &buf[HEADER_LEN..n],
            &[0x06, 0, 0, 0, 0, 0, 0, 0, 0, 0x04, 0x00, 0x01, 0x00, 0x00, 0x00]
        );
        let mut r = Reader::new(&buf[..n]).unwrap();
        assert_eq!(r.version(), 2);
        assert_eq!(r.next(), Some(Ok(sensor)));
        // The same bytes in a version-1 file: an unknown event, skipped.
        assert_eq!(first_unknown(&buf[..n], 1, 0x06), 1);
        // A sensor code past 3, reserved bytes set, a wrong length: refused.
        for (at, byte) in [(HEADER_LEN + 11, 4), (HEADER_LEN + 13, 1)] {
            let mut bad = buf[..n].to_vec();
            bad[at] = byte;
            assert!(matches!(
                Reader::new(&bad).unwrap().next(),
                Some(Err(RecordingError::BadSetup { .. }))
            ));
        }
        let mut short = buf[..n - 1].to_vec();
        short[HEADER_LEN + 9] = 3;
        assert!(matches!(
            Reader::new(&short).unwrap().next(),
            Some(Err(RecordingError::BadLength { .. }))
        ));
        // The documented example as version 1 reads the same.
        let mut old = DOC_EXAMPLE.to_vec();
        old[8] = 1;
        assert_eq!(Reader::new(&old).unwrap().count(), 2);
    }

    /// Reads `file` as a file of version `version`, whose first event must be an unknown one
    /// of kind `kind`; the unknown events counted once it is skipped.
    fn first_unknown(file: &[u8], version: u8, kind: u8) -> u32 {
        let mut older = file.to_vec();
        older[8] = version;
        let mut r = Reader::new(&older).unwrap();
        assert!(matches!(
            r.next(),
            Some(Ok(Event {
                payload: Payload::Unknown { kind: k, .. },
                ..
            })) if k == kind
        ));
        r.unknown_events()
    }

    /// The rig event of version 3 (`docs/recording.md`, "Rig payload"): its bytes as the
    /// document lays them out, read back; a version-2 file's kind 0x07 is an unknown event; a
    /// bad mount byte or reserved byte is a bad setup.
    #[test]
    fn the_rig_event_of_version_3() {
        let mut sectors = [(0, 0); crate::wire::link::SETUP_SECTORS];
        sectors[0] = (13_500, 22_500);
        let rig = RigEvent {
            mount: 2,
            mount_block: crate::wire::link::examples::GENERAL_MOUNT,
            filter: crate::wire::link::examples::filter(1, sectors),
        };
        let mut file = std::vec![0_u8; 16 + EVENT_HEADER_LEN + RIG_LEN];
        emit_header_version(&mut file, 3).unwrap();
        let ev = Event {
            time_us: 0,
            payload: Payload::Rig(rig),
        };
        assert_eq!(
            ev.emit(&mut file[16..]).unwrap(),
            EVENT_HEADER_LEN + RIG_LEN
        );
        // The payload as docs/recording.md lays it out.
        let want: Vec<u8> = [
            &[2_u8, 0, 0, 0, 1, 0xFF, 0, 0][..],
            &5.0_f32.to_le_bytes(),
            &180.0_f32.to_le_bytes(),
            &0.0_f32.to_le_bytes(),
            &90.0_f32.to_le_bytes(),
            &[5, 0, 0xB0, 0x04, 10, 1, 0xBC, 0x34, 0xE4, 0x57],
            &[0; 28],
        ]
        .concat();
        assert_eq!(&file[16 + EVENT_HEADER_LEN..], &want[..]);
        let got: Vec<_> = Reader::new(&file).unwrap().map(Result::unwrap).collect();
        assert_eq!(got, [ev]);
        // A version-2 reader's view: an unknown kind, skipped.
        assert_eq!(first_unknown(&file, 2, 7), 1);
        // A bad mount byte, a reserved byte set.
        for (at, v) in [(0, 3_u8), (2, 1)] {
            let mut bad = file.clone();
            bad[16 + EVENT_HEADER_LEN + at] = v;
            assert!(matches!(
                Reader::new(&bad).unwrap().next(),
                Some(Err(RecordingError::BadSetup { .. }))
            ));
        }
        // emit_header writes version 2 (a file without a rig event).
        let mut h = [0_u8; 16];
        emit_header(&mut h).unwrap();
        assert_eq!(h[8], 2);
    }

    #[test]
    fn damage_is_reported_not_panicked() {
        assert_eq!(Reader::new(b"nope").err(), Some(RecordingError::BadMagic));
        let mut v = DOC_EXAMPLE.to_vec();
        v[8] = 4;
        let e = Reader::new(&v).err();
        assert_eq!(e, Some(RecordingError::UnsupportedVersion { version: 4 }));
        assert_eq!(
            std::format!("{}", e.unwrap()),
            "recording version 4 is not supported (this reads versions 1 to 3)"
        );
        // Every truncation of the example either reads cleanly up to the cut or reports it.
        let boundaries = [HEADER_LEN, HEADER_LEN + EVENT_HEADER_LEN + SETUP_LEN];
        for cut in HEADER_LEN..DOC_EXAMPLE.len() {
            let events: Vec<_> = Reader::new(&DOC_EXAMPLE[..cut]).unwrap().collect();
            if boundaries.contains(&cut) {
                assert!(events.iter().all(Result::is_ok), "{cut}");
            } else {
                let last = events.last().unwrap();
                assert!(
                    matches!(last, Err(RecordingError::Truncated { .. })),
                    "{cut}"
                );
            }
        }
        // Time going backwards.
        let mut v = DOC_EXAMPLE.to_vec();
        v[16 + 1] = 0xFF; // the setup event now says t = 255 µs, the next 13 333 µs: fine
        assert!(Reader::new(&v).unwrap().all(|e| e.is_ok()));
        v[16 + 11 + 28 + 2] = 0x00; // the laser event now says t = 21 µs < 255
        let events: Vec<_> = Reader::new(&v).unwrap().collect();
        assert_eq!(events[1], Err(RecordingError::TimeWentBack { offset: 55 }));
        // Any byte flipped anywhere: no panic.
        for i in 0..DOC_EXAMPLE.len() {
            for bit in 0..8 {
                let mut v = DOC_EXAMPLE.to_vec();
                v[i] ^= 1 << bit;
                if let Ok(r) = Reader::new(&v) {
                    for _ in r {}
                }
            }
        }
    }
}
