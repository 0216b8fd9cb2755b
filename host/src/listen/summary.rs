//! What a finished `pyramid listen` session leaves: why it ended, its summary (what
//! `summary.json` holds and `--json` prints) and the maps and the summary written out.
pub use super::session::Ending;
use super::session::{total_errors, Session};
pub use super::timing::{PosesReport, TimeSyncReport};
use super::{clock_name, Args};
use crate::export::{self, MapSnapshot, MapSummary};
use crate::link::Mirror;
use crate::publish::OutputsReport;
use serde::Serialize;
use std::time::Duration;
use terrain_pyramid::wire::link::Stats;

/// The summary of a session: what `summary.json` holds and `--json` prints.
#[derive(Serialize, Debug, Clone)]
pub struct Summary {
    /// Per layer: counts of the cells of its window (as `pyramid replay`).
    pub layers: Vec<export::LayerSummary>,
    /// The fused map's counts (as `pyramid replay`).
    pub fused: export::FusedSummary,
    /// Good frames applied.
    pub frames: u64,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u64,
    /// Patches applied.
    pub patches: u64,
    /// Sequence gaps (each one or more frames lost).
    pub gaps: u64,
    /// Snapshots requested (the first one at the start included).
    pub snapshots_requested: u64,
    /// Bad frames of every kind (COBS, length, CRC, version, type, body, range).
    pub bad_frames: u64,
    /// Frames missing by their sequence numbers.
    pub missing_frames: u64,
    /// Old or repeated frames refused.
    pub out_of_order: u64,
    /// Hello frames.
    pub hellos: u64,
    /// Patches the mirror could not place.
    pub patches_refused: u64,
    /// Whether the maps written equal the device's as of the last frame.
    pub synced: bool,
    /// The device's firmware version, from its last Hello.
    pub firmware: String,
    /// The clock the device's board runs on, from its last Hello (`docs/protocol.md`).
    pub clock: String,
    /// What ended the session.
    pub ended_by: Ending,
    /// The session's length, seconds.
    pub duration_s: f64,
    /// Per layer, FNV-1a 64 of its raw cells, hex.
    pub layer_cells_fnv1a64: Vec<String>,
    /// The files written.
    pub files: Vec<String>,
    /// Times the device was reconnected after its stream ended (`--reconnect`, serial ports).
    pub reconnects: u64,
    /// Setups sent to the device (the rig's, one per connection and one more after each boot
    /// Hello; 0 without a rig).
    pub setups_sent: u64,
    /// The rig's design sent as a Configure (when the device ran another pyramid).
    pub configures_sent: u64,
    /// The live outputs (`--ros2`, `--foxglove`, `--mcap`), when any was on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outputs: Option<OutputsReport>,
    /// The clock mapping at the end and its counters.
    pub time_sync: TimeSyncReport,
    /// The pose inputs (`--odom-topic`, `--pose-udp`), when one was on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub poses: Option<PosesReport>,
    /// The device's pose track and time counters (its last Stats, i = 30 ..= 35).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_pose_track: Option<DevicePoseTrack>,
}

/// The device's own counters of the stamped poses and the time exchange (Stats 30 ..= 35).
#[derive(Serialize, Debug, Clone, Copy)]
pub struct DevicePoseTrack {
    /// Stamped poses taken into the track.
    pub poses_stamped: u32,
    /// Stamped poses refused (not newer than the newest, or over 1 s ahead of its clock).
    pub poses_refused: u32,
    /// Stamped poses over 500 ms after the newest (the track restarted at them).
    pub pose_gaps: u32,
    /// Returns placed with a pose extrapolated past the newest.
    pub returns_extrapolated: u32,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u32,
    /// TimeRequests answered.
    pub time_requests: u32,
}

impl DevicePoseTrack {
    pub(super) fn of(s: &Stats) -> Self {
        Self {
            poses_stamped: s.poses_stamped,
            poses_refused: s.poses_refused,
            pose_gaps: s.pose_gaps,
            returns_extrapolated: s.returns_extrapolated,
            returns_without_pose: s.returns_without_pose,
            time_requests: s.time_requests,
        }
    }
}

/// FNV-1a 64 of raw cells as `i16` little-endian.
#[must_use]
pub fn cells_fnv1a64(cells: &[i16]) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for byte in cells.iter().flat_map(|c| c.to_le_bytes()) {
        h ^= u64::from(byte);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

/// The sensor's mark on the picture: the host does not know it, so the finest layer's
/// window centre (the device recentres the windows on the robot).
fn window_centre(mirror: &Mirror) -> (f64, f64) {
    mirror.layer(0).map_or((0.0, 0.0), |l| {
        #[allow(clippy::cast_precision_loss)]
        let half = mirror.cells_per_side() as f64 / 2.0;
        let r = f64::from(l.resolution_q16) / 65_536.0;
        (
            (f64::from(l.origin.0) + half) * r,
            (f64::from(l.origin.1) + half) * r,
        )
    })
}

/// Writes the maps and the summary of a finished session.
pub(super) fn write_out(
    session: &Session,
    args: &Args,
    source: &str,
    ending: Ending,
    elapsed: Duration,
    outputs: Option<OutputsReport>,
) -> Result<Summary, String> {
    let mirror = session.host.mirror();
    let rx = session.host.rx_counters();
    let Some(snapshot) = MapSnapshot::from_mirror(
        mirror,
        export::default_fused_margin(),
        window_centre(mirror),
    ) else {
        let hint = crate::link::version_hint(&rx);
        return Err(format!(
            "no maps to write: the device sent no usable Hello in {:.1} s ({} good frames, {} bad){hint}",
            elapsed.as_secs_f64(),
            rx.frames_ok,
            total_errors(&rx)
        ));
    };
    let title = format!(
        "pyramid listen: {source} ({:.0} s, {} patches{})",
        elapsed.as_secs_f64(),
        mirror.counters().patches,
        if mirror.is_synced() {
            ""
        } else {
            ", NOT synced"
        }
    );
    let written = export::write_maps(&args.summary.out, &snapshot, &title)?;
    let MapSummary { layers, fused } = written.summary;
    let c = mirror.counters();
    let mut files: Vec<String> = written
        .files
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    files.push("summary.json".to_string());
    let summary = Summary {
        layers,
        fused,
        frames: c.frames,
        crc_errors: u64::from(rx.crc),
        patches: c.patches,
        gaps: c.gaps,
        snapshots_requested: session.snapshots_requested,
        bad_frames: total_errors(&rx),
        missing_frames: c.missing,
        out_of_order: c.out_of_order,
        hellos: c.hellos,
        patches_refused: c.patches_refused,
        synced: mirror.is_synced(),
        firmware: mirror.firmware().map_or_else(String::new, |f| {
            format!("{}.{}.{}", f.major, f.minor, f.patch)
        }),
        clock: clock_name(mirror.clock()).to_string(),
        ended_by: ending,
        duration_s: (elapsed.as_secs_f64() * 1000.0).round() / 1000.0,
        layer_cells_fnv1a64: snapshot
            .layers
            .iter()
            .map(|l| format!("{:016x}", cells_fnv1a64(&l.cells)))
            .collect(),
        files,
        reconnects: session.reconnects,
        setups_sent: session.setups_sent,
        configures_sent: session.configures_sent,
        outputs,
        time_sync: session.timing.report(),
        poses: session.timing.poses_report(),
        device_pose_track: mirror.last_stats().map(|s| DevicePoseTrack::of(&s)),
    };
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| format!("cannot encode the summary as JSON: {e}"))?;
    export::write_file(
        &args.summary.out.join("summary.json"),
        format!("{json}\n").as_bytes(),
    )?;
    Ok(summary)
}
