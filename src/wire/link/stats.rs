//! The device's counters, Stats (`docs/protocol.md`, "0x04 Stats"): 42 `u32` in wire order.

/// Bytes of a Stats body.
pub(crate) const STATS_LEN: usize = 4 * STATS_COUNTERS;
/// The number of counters in a [`Stats`].
pub const STATS_COUNTERS: usize = 42;

macro_rules! stats_struct {
    ($($(#[$doc:meta])* $name:ident),* $(,)?) => {
        /// Device to host: counters (`docs/protocol.md`, "Stats"). Each saturates.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct Stats {
            $($(#[$doc])* pub $name: u32,)*
        }

        impl Stats {
            /// The counters in wire order.
            #[must_use]
            pub const fn to_array(&self) -> [u32; STATS_COUNTERS] {
                [$(self.$name),*]
            }

            /// Counters from wire order.
            #[must_use]
            pub const fn from_array(values: [u32; STATS_COUNTERS]) -> Self {
                let [$($name),*] = values;
                Self { $($name),* }
            }

            /// The counters' names in wire order.
            pub const NAMES: [&'static str; STATS_COUNTERS] = [$(stringify!($name)),*];
        }
    };
}

stats_struct! {
    /// The device's time when the Stats was queued, ms.
    uptime_ms,
    /// SICK telegrams decoded.
    telegrams_ok,
    /// SICK telegrams with a bad checksum.
    telegrams_bad_checksum,
    /// SICK telegrams with bad framing (sync, length, header).
    telegrams_bad_framing,
    /// SICK telegrams refused for another reason.
    telegrams_bad_other,
    /// Points offered to the classifier.
    points,
    /// Points dropped by a full classifier scratch table.
    classifier_overflows,
    /// Evidence records that changed a cell.
    evidence_applied,
    /// Evidence records gated out (increment zero).
    evidence_gated_out,
    /// Evidence records outside their layer's window.
    evidence_outside_window,
    /// Frames queued (all types).
    frames_sent,
    /// Encoded bytes queued.
    bytes_sent,
    /// LayerPatch frames queued.
    patches_sent,
    /// Tiles whose send was put back for lack of budget or queue room, once per dirty period
    /// (not once per poll while they wait).
    patches_deferred,
    /// Control frames dropped for lack of queue room (each used a sequence number).
    frames_dropped,
    /// Bytes in the queue now.
    queue_used,
    /// The most bytes the queue has held.
    queue_high_water,
    /// The queue's capacity, bytes.
    queue_capacity,
    /// Host frames received good.
    rx_frames_ok,
    /// Host frames with bad COBS.
    rx_bad_cobs,
    /// Host frames with a bad CRC.
    rx_bad_crc,
    /// Host frames too short or too long.
    rx_bad_length,
    /// Host frames with an unknown version or type, a bad body or an out-of-range field.
    rx_bad_other,
    /// Host frames missing by their sequence numbers.
    rx_seq_gaps,
    /// Commands refused with an error Reply.
    commands_refused,
    /// Snapshots served.
    snapshots,
    /// Full resends after window moves the link did not see one by one.
    resyncs,
    /// Observations finished and applied to the pyramid.
    observations,
    /// Bytes the laser's UART delivered to the SICK decoder (wraps at 2³²; a test harness
    /// uses it to know the device has taken every byte it wrote, whatever became of them).
    laser_bytes,
    /// Tiles changed and not yet queued, over every layer, at the time of the Stats (a level,
    /// 0 ..= 64 · layers): with `queue_used` 0 too, every change made before this Stats is
    /// already on the wire ahead of it, so the host's copy is current once it has read it.
    tiles_dirty,
    /// Stamped poses taken into the device's pose track (version 4).
    poses_stamped,
    /// Stamped poses refused: not newer than the newest, or more than 1 s ahead of the
    /// device's clock.
    poses_refused,
    /// Stamped poses more than 500 ms after the newest: the track restarted at them.
    pose_gaps,
    /// Returns placed with a pose extrapolated past the newest (within the bound).
    returns_extrapolated,
    /// Returns refused for want of a pose: later than the newest by more than the bound, or
    /// earlier than the oldest kept pose.
    returns_without_pose,
    /// TimeRequests answered.
    time_requests,
    /// Returns refused before geometry: in a masked sector (version 5).
    returns_masked,
    /// Returns refused before geometry: nearer than the minimum range (version 5).
    returns_too_near,
    /// Returns refused before geometry: farther than the maximum range (version 5).
    returns_too_far,
    /// Returns refused before geometry: quality below the minimum (version 5).
    returns_low_quality,
    /// Observations applied early because the classifier's scratch could not be sure to hold
    /// the next return: the returns after it start the next observation, none is dropped
    /// (version 5; counted in `observations` too).
    observations_split,
    /// Returns refused as implausible: a weakly checked unit (an RPLIDAR standard-scan node)
    /// whose angle cannot follow its neighbours (version 5; `docs/lidars.md`).
    returns_implausible,
}
