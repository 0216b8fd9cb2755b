//! The emulated board's own timeline of a `lab live` run: when the board took each laser chunk
//! and each PanAngle, on the wall clock, and the recording re-timed to it for the in-process
//! reference run "as the board took it".
//!
//! QEMU's CMSDK UART hands the firmware one byte per pass of its main loop: on a loaded host
//! the board takes the LD19's bytes behind their time (up to seconds), and stamps each packet
//! when its last byte is taken. A PanAngle on the other UART is in force when its frame has
//! been taken, which the host link's lighter stream reaches sooner. The device thus places
//! late returns at the pose and the angle of the moment it took them. The on-time reference
//! takes every chunk at its recorded time: against it, the live maps measure the emulator's
//! backlog, not the pose chain. The relay times both: the Stats the lab asks for every
//! [`STATS_PERIOD`] carry the laser bytes the board had taken, and the PanAngles' writes are
//! timed as they go.
use super::clock::Spread;
use crate::experiments::timing::LatePose;
use std::time::Duration;
use terrain_pyramid_host::play::{Step, Steps};

/// How often the lab asks the board for its Stats (RequestStats, 10 bytes on the host link):
/// the resolution of the board's laser timeline.
pub const STATS_PERIOD: Duration = Duration::from_millis(20);

/// How far behind its time the board took the laser's bytes.
#[derive(Debug, Clone, Default, serde::Serialize, PartialEq)]
pub struct BoardLag {
    /// Stats the relay read (the timeline's samples).
    pub samples: usize,
    /// Chunks the board took before the run ended (of all written).
    pub chunks_taken: usize,
    /// When the board took each chunk's last byte minus the chunk's recorded time, ms.
    pub chunk_lag_ms: Spread,
    /// When the board took the host-link frame that carries the reference's pose (written
    /// `POSE_DELAY_US` (30 ms) after its time) minus the pose's time, ms.
    pub pose_lag_ms: Spread,
}

/// When the board's count (laser bytes, host-link frames) reached `count`, wall-clock µs:
/// between the Stats before and after, as if the board took the bytes between them evenly,
/// and never before `written_us` (the chunk's write); `None` when no Stats show it taken.
fn taken_at(samples: &[(u64, u32)], count: u64, written_us: u64) -> Option<u64> {
    let k = samples.iter().position(|&(_, n)| u64::from(n) >= count)?;
    let (w1, n1) = samples[k];
    let Some(&(w0, n0)) = k.checked_sub(1).and_then(|i| samples.get(i)) else {
        return Some(w1.max(written_us));
    };
    let (n0, n1) = (u64::from(n0), u64::from(n1));
    let span = n1.saturating_sub(n0).max(1);
    let at = w0 + (w1.saturating_sub(w0)) * count.saturating_sub(n0).min(span) / span;
    Some(at.max(written_us).min(w1.max(written_us)))
}

/// The frames the board had taken on its host link before the relay's first: the Setup.
const FRAMES_BEFORE_RELAY: u64 = 1;

/// The delay from a pose's time to its write on the host link that the board-timed reference
/// gives its perfect poses, µs: the robot's feed's 30 ms ([`crate::experiments::timing::PoseFeed::ROBOT`]).
pub const POSE_DELAY_US: u64 = 30_000;

/// What the relay timed, for [`board_timed`].
pub(super) struct Timed<'a> {
    /// The recording's t = 0 on the wall clock, µs since the epoch.
    pub start_us: u64,
    /// The Stats as read: (when, the board's laser bytes, its host-link frames taken).
    pub stats: &'a [(u64, u32, u32)],
    /// When each laser chunk's write began.
    pub written_us: &'a [u64],
    /// When each PanAngle was written, in the order sent (one before each chunk that follows
    /// a new angle).
    pub angles_at: &'a [u64],
    /// When each frame was written to the board's host link, in the stream's order.
    pub frames_at: &'a [u64],
}

/// The board's timeline from the Stats: one counter's samples (when, count), made
/// non-decreasing (a Stats read late holds an older count).
fn series(stats: &[(u64, u32, u32)], counter: impl Fn(&(u64, u32, u32)) -> u32) -> Vec<(u64, u32)> {
    let mut out: Vec<(u64, u32)> = Vec::with_capacity(stats.len());
    for s in stats {
        let n = counter(s);
        let n = out.last().map_or(n, |&(_, m)| n.max(m));
        out.push((s.0, n));
    }
    out
}

/// The recording and the on-time poses re-timed to the board (recording µs: wall clock minus
/// the start): each laser chunk when the board took its last byte, each PanAngle and each
/// pose when the board took the host-link frame written at its time (a pose's: its stamp +
/// [`POSE_DELAY_US`]), so that the reference meets the emulator's backlog as the board did,
/// with perfect poses. Chunks and poses the board never took are left out.
#[allow(clippy::cast_precision_loss)]
pub(super) fn board_timed(
    steps: &Steps,
    on_time: &[LatePose],
    t: &Timed<'_>,
) -> (Steps, Vec<LatePose>, BoardLag) {
    let laser = series(t.stats, |s| s.1);
    let host = series(t.stats, |s| s.2);
    // When the board took the first frame written at or after `w`.
    let host_taken = |w: u64| -> Option<u64> {
        let i = t.frames_at.partition_point(|&f| f < w);
        let written = *t.frames_at.get(i)?;
        taken_at(&host, i as u64 + 1 + FRAMES_BEFORE_RELAY, written)
    };
    let rec = |w: u64| w.saturating_sub(t.start_us);
    let mut events: Vec<(u64, Step)> = Vec::new();
    let mut head = Vec::new();
    let (mut angle, mut poses) = (None, Vec::new());
    let (mut count, mut chunk, mut injected) = (0_u64, 0_usize, 0_usize);
    let mut lags = Vec::new();
    for step in &steps.steps {
        match step {
            Step::Setup(_) => head.push(step.clone()),
            Step::Angle(turns) => angle = Some(*turns),
            Step::Pose(_) => poses.push(step.clone()),
            Step::Telegram { .. } => {}
            Step::Laser {
                bytes,
                packets,
                time_us,
            } => {
                let written = t
                    .written_us
                    .get(chunk)
                    .copied()
                    .unwrap_or(t.start_us + time_us);
                chunk += 1;
                count += bytes.len() as u64;
                if let Some(turns) = angle.take() {
                    let sent = t.angles_at.get(injected).copied().unwrap_or(written);
                    injected += 1;
                    if let Some(at) = host_taken(sent) {
                        events.push((rec(at), Step::Angle(turns)));
                    }
                }
                let Some(at) = taken_at(&laser, count, written) else {
                    continue;
                };
                let at = rec(at);
                lags.push((at as f64 - *time_us as f64) * 1e-3);
                events.extend(poses.drain(..).map(|p| (at, p)));
                events.push((
                    at,
                    Step::Laser {
                        bytes: bytes.clone(),
                        packets: *packets,
                        time_us: at,
                    },
                ));
            }
        }
    }
    // In time order; at equal times as sent (a chunk's angle before it).
    events.sort_by_key(|e| e.0);
    head.extend(events.into_iter().map(|e| e.1));
    let mut pose_lags = Vec::new();
    let mut timed_poses: Vec<LatePose> = on_time
        .iter()
        .filter_map(|p| {
            let at = rec(host_taken(t.start_us + p.stamp_us + POSE_DELAY_US)?);
            pose_lags.push((at as f64 - p.stamp_us as f64) * 1e-3);
            Some(LatePose {
                arrival_us: at,
                ..*p
            })
        })
        .collect();
    timed_poses.sort_by_key(|p| p.arrival_us);
    let lag = BoardLag {
        samples: t.stats.len(),
        chunks_taken: lags.len(),
        chunk_lag_ms: Spread::of(lags),
        pose_lag_ms: Spread::of(pose_lags),
    };
    (
        Steps {
            steps: head,
            ..steps.clone()
        },
        timed_poses,
        lag,
    )
}

#[cfg(test)]
mod tests {
    use super::taken_at;

    #[test]
    fn a_chunk_is_taken_between_the_stats_that_bracket_its_count() {
        let s = [(1_000, 0), (2_000, 100), (3_000, 100), (4_000, 300)];
        // Half-way through the bytes taken between two Stats.
        assert_eq!(taken_at(&s, 50, 0), Some(1_500));
        assert_eq!(taken_at(&s, 200, 0), Some(3_500));
        // Never before it was written.
        assert_eq!(taken_at(&s, 200, 3_800), Some(3_800));
        // Not taken by the last Stats: not known.
        assert_eq!(taken_at(&s, 301, 0), None);
    }
}
