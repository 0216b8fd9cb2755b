//! The poses a timing run gives the device: the robot's late feed (rate, delay, jitter),
//! the on-time feed and the reference's true poses, each sampled from the trajectory.
use super::{ON_TIME_PERIOD_US, TRUTH_PERIOD_US};
use serde::Serialize;
use terrain_pyramid_host_tests::sim::rng::Rng;
use terrain_pyramid_host_tests::sim::scene::Scene;
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// How the late poses come: rate, delay and its jitter.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct PoseFeed {
    /// Poses a second (the trajectory sampled every 1 / rate s from t = 0).
    pub rate_hz: f64,
    /// The mean delay from a pose's time to its arrival at the device, ms.
    pub late_ms: f64,
    /// The delay's jitter: uniform in ± this, ms.
    pub jitter_ms: f64,
    /// The jitter's seed.
    pub seed: u64,
}

impl PoseFeed {
    /// 50 Hz, 30 ± 10 ms late.
    pub const ROBOT: Self = Self {
        rate_hz: 50.0,
        late_ms: 30.0,
        jitter_ms: 10.0,
        seed: 29,
    };
}

/// One pose of the late feed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatePose {
    /// When the robot was there: the recording's time, µs.
    pub stamp_us: u64,
    /// When it reaches the device: the recording's time, µs (≥ `stamp_us`).
    pub arrival_us: u64,
    /// x, y, z (m), roll, pitch, yaw (rad), as the recording's pose events carry them.
    pub pose: [f32; 6],
}

/// The trajectory over `scene` sampled at `feed.rate_hz` for `duration_us`, each pose with its
/// late arrival; in the order of arrival (a pose overtaken by the next keeps its place after
/// it, as a transport that reorders would deliver it).
pub fn late_poses(
    trajectory: &Trajectory,
    scene: &Scene,
    duration_us: u64,
    feed: &PoseFeed,
) -> Vec<LatePose> {
    let mut rng = Rng::new(feed.seed);
    let period_us = 1e6 / feed.rate_hz;
    let mut out = Vec::new();
    for k in 0_u32.. {
        let t_us = (f64::from(k) * period_us).round();
        #[allow(clippy::cast_precision_loss)]
        if t_us > duration_us as f64 {
            break;
        }
        let late_us = 1e3 * (feed.late_ms + feed.jitter_ms * (2.0 * rng.uniform() - 1.0));
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        out.push(LatePose {
            stamp_us: t_us as u64,
            arrival_us: (t_us + late_us.max(0.0)).round() as u64,
            pose: trajectory.pose_at(t_us * 1e-6, scene).to_f32(),
        });
    }
    out.sort_by_key(|p| p.arrival_us);
    out
}

/// The trajectory every [`ON_TIME_PERIOD_US`] for `duration_us`, each pose arriving at its
/// stamp.
pub fn on_time_poses(trajectory: &Trajectory, scene: &Scene, duration_us: u64) -> Vec<LatePose> {
    poses_every(trajectory, scene, duration_us, ON_TIME_PERIOD_US)
}

/// The trajectory every [`TRUTH_PERIOD_US`] for `duration_us`, each pose arriving at its
/// stamp: the reference's.
pub fn true_poses(trajectory: &Trajectory, scene: &Scene, duration_us: u64) -> Vec<LatePose> {
    poses_every(trajectory, scene, duration_us, TRUTH_PERIOD_US)
}

/// The trajectory every `period_us` (> 0) for `duration_us`, each pose arriving at its stamp.
fn poses_every(
    trajectory: &Trajectory,
    scene: &Scene,
    duration_us: u64,
    period_us: u64,
) -> Vec<LatePose> {
    let period_us = period_us.max(1);
    (0..=duration_us / period_us)
        .map(|k| {
            let t_us = k * period_us;
            #[allow(clippy::cast_precision_loss)]
            let pose = trajectory.pose_at(t_us as f64 * 1e-6, scene).to_f32();
            LatePose {
                stamp_us: t_us,
                arrival_us: t_us,
                pose,
            }
        })
        .collect()
}
