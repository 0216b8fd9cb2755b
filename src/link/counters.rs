//! The counters the link reports: those of other modules that Stats carries
//! ([`SensorCounters`], [`PoseCounters`]) and the link's own ([`LinkCounters`]).

/// Counters of other modules that Stats carries: the firmware fills them in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorCounters {
    /// SICK telegrams decoded.
    pub telegrams_ok: u32,
    /// SICK telegrams with a bad checksum.
    pub telegrams_bad_checksum: u32,
    /// SICK telegrams with bad framing.
    pub telegrams_bad_framing: u32,
    /// SICK telegrams refused for another reason.
    pub telegrams_bad_other: u32,
    /// Points offered to the classifier.
    pub points: u32,
    /// Points dropped by a full classifier scratch table.
    pub classifier_overflows: u32,
    /// Bytes the laser's UART delivered to the SICK decoder (wrapping).
    pub laser_bytes: u32,
    /// Observations finished and applied (`FrontendStats::observations`).
    pub observations: u32,
    /// The pose track's counters (protocol version 4).
    pub pose: PoseCounters,
    /// Returns refused before geometry, by reason (protocol version 5).
    pub filtered: FilterCounters,
    /// Observations split because the classifier's scratch was full
    /// (`FrontendStats::observations_split`; protocol version 5).
    pub observations_split: u32,
    /// Returns the laser decoder refused as implausible (protocol version 5).
    pub returns_implausible: u32,
}

/// The returns the pipeline's masks and filters refused before geometry, by reason
/// (protocol version 5, Stats i = 36 ..= 39; `FrontendStats`' counters of the same names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilterCounters {
    /// In a masked sector.
    pub returns_masked: u32,
    /// Nearer than the minimum range.
    pub returns_too_near: u32,
    /// Farther than the maximum range.
    pub returns_too_far: u32,
    /// Quality below the minimum.
    pub returns_low_quality: u32,
}

/// The device's pose-track counters that Stats carries (protocol version 4, Stats i = 30 ..=
/// 34): the firmware fills them in from its placement of returns. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoseCounters {
    /// Stamped poses taken into the track.
    pub poses_stamped: u32,
    /// Stamped poses refused: not newer than the newest, or more than 1 s ahead of the
    /// device's clock.
    pub poses_refused: u32,
    /// Stamped poses more than 500 ms after the newest: the track restarted at them.
    pub pose_gaps: u32,
    /// Returns placed with a pose extrapolated past the newest (within the bound).
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u32,
}

impl PoseCounters {
    /// All zero, `const` (for a `static`).
    pub const ZERO: Self = Self {
        poses_stamped: 0,
        poses_refused: 0,
        pose_gaps: 0,
        returns_extrapolated: 0,
        returns_without_pose: 0,
    };
}

/// The link's own counters. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkCounters {
    /// Frames queued.
    pub frames_sent: u32,
    /// Encoded bytes queued.
    pub bytes_sent: u32,
    /// LayerPatch frames queued.
    pub patches_sent: u32,
    /// Tiles whose send was put back for lack of budget or room, each counted once per dirty
    /// period (the first poll that could not send it since it changed or was last sent), not
    /// at every poll it keeps waiting.
    pub patches_deferred: u32,
    /// Control frames dropped for lack of room.
    pub frames_dropped: u32,
    /// Host frames missing by their sequence numbers.
    pub rx_seq_gaps: u32,
    /// Commands refused.
    pub commands_refused: u32,
    /// Snapshots served.
    pub snapshots: u32,
    /// Full resends after window moves collapsed between two polls.
    pub resyncs: u32,
    /// Decayed frames queued (each announces the decay steps it accompanies).
    pub decay_frames: u32,
    /// Polls whose owed decay waited for queue room (it is paid at a later poll).
    pub decay_deferred: u32,
    /// TimeRequests answered with a TimeReply (queued, or dropped for lack of room).
    pub time_requests: u32,
    /// Observed frames queued.
    pub observed_frames: u32,
}
