//! One timing run: a decoded recording through the library's co-processor in this process,
//! the poses given by one [`PoseRule`], and what the run left (its maps, the first step
//! seen, the device's pose-track counters).
use super::LatePose;
use crate::experiments::stairs::{self, round3, Cell, FIRST_STEP_SHARE};
use serde::Serialize;
use terrain_pyramid::app::{CoProcessor, NoAngleSource};
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{Message, PanAngle};
use terrain_pyramid::{Config, Design, Meters};
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::link::HostLink;
use terrain_pyramid_host::play::{Step, Steps};

/// The link's outgoing queue of the in-process co-processors, bytes.
const QUEUE: usize = 8192;

/// How a run gives the device its poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseRule {
    /// The recording's poses, interleaved with the laser's bytes.
    LockStep,
    /// The late feed, stamped.
    Timed,
    /// The late feed, unstamped, applied on arrival.
    Latest,
    /// The trajectory at 250 Hz ([`ON_TIME_PERIOD_US`]), stamped and delivered the moment
    /// it is stamped: the device's placement with perfect poses, the control that tells the late
    /// feed's effect from the difference between the simulator's timing of a return and the
    /// device's.
    OnTime,
}

/// The period of the on-time feed, µs: 250 Hz, so that the device's track of 16 poses
/// reaches back 64 ms, past a SICK line's first beam (its beams are 15–35 ms old when its
/// telegram is in). Between two poses the device interpolates: exact for the scenes' motions
/// (constant speed, constant yaw rate) but at the start of the drive.
pub const ON_TIME_PERIOD_US: u64 = 4_000;

/// The period of the reference's true poses, µs: 1 kHz, the device's pose quantum.
pub const TRUTH_PERIOD_US: u64 = 1_000;

/// The reference co-processor's track of stamped poses: 64 at 1 kHz, 64 ms.
pub const TRUTH_TRACK: usize = 64;

/// What one run left: its maps, its first-step distance and the device's counters.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// The maps at the end.
    pub snapshot: MapSnapshot,
    /// Its first-step distance and the device's counters.
    pub counters: RunCounters,
}

/// A run's first-step distance and the device's counters.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RunCounters {
    /// The robot's distance to the first riser when the first step was first seen, metres
    /// (a scene with stairs).
    pub first_step_m: Option<f64>,
    /// Returns placed with an extrapolated pose.
    pub returns_extrapolated: u64,
    /// Returns refused for want of a pose.
    pub returns_without_pose: u64,
    /// Stamped poses the device took.
    pub poses_stamped: u64,
    /// Stamped poses the device refused.
    pub poses_refused: u64,
    /// Observations applied.
    pub observations: u64,
}

/// What the runs of a scene need besides the co-processor's shape.
pub struct Input<'a, const L: usize> {
    /// The decoded recording.
    pub steps: &'a Steps,
    /// The late feed.
    pub late: &'a [LatePose],
    /// The on-time feed.
    pub on_time: &'a [LatePose],
    /// The reference's true poses ([`true_poses`](super::true_poses)).
    pub truth: &'a [LatePose],
    /// The design the co-processor boots with.
    pub design: &'a Design<L>,
    /// Its configuration.
    pub config: &'a Config,
    /// The pipeline's configuration (the recording's setup).
    pub frontend: FrontendConfig,
    /// The first riser's cells (0.1 m world cells) and its x, for the first-step distance.
    pub first_riser: Option<(&'a [Cell], f64)>,
    /// Whether the observation under way is applied at the end (a host's EndObservation).
    pub end_observation: bool,
}

fn pose_of(p: &[f32; 6]) -> Option<Pose> {
    Pose::from_f32(p[0], p[1], p[2], p[3], p[4], p[5]).ok()
}

/// The recording's time as the device's wrapping µs clock.
#[allow(clippy::cast_possible_truncation)]
fn device_us(t: u64) -> u32 {
    t as u32
}

/// Hands the device a late pose by `rule`.
fn deliver<const W: usize, const L: usize, const C: usize, const N: usize>(
    core: &mut CoProcessor<W, L, C, QUEUE, N>,
    rule: PoseRule,
    late: &LatePose,
) {
    let Some(pose) = pose_of(&late.pose) else {
        return;
    };
    match rule {
        PoseRule::Latest => core.set_pose(pose),
        PoseRule::LockStep | PoseRule::Timed | PoseRule::OnTime => {
            core.stamped_pose(device_us(late.stamp_us), pose);
        }
    }
}

/// Runs the recording through a co-processor of `W`² cells, `L` layers and `C` classifier
/// slots with poses by `rule`. Run it on a thread whose stack holds the co-processor.
///
/// # Errors
/// The boot was refused.
pub fn run<const W: usize, const L: usize, const C: usize>(
    input: &Input<'_, L>,
    rule: PoseRule,
) -> Result<RunOutcome, String> {
    if rule == PoseRule::LockStep {
        run_with::<W, L, C, TRUTH_TRACK>(input, rule)
    } else {
        run_with::<W, L, C, 16>(input, rule)
    }
}

/// [`run`] with a track of `N` stamped poses.
fn run_with<const W: usize, const L: usize, const C: usize, const N: usize>(
    input: &Input<'_, L>,
    rule: PoseRule,
) -> Result<RunOutcome, String> {
    let mut core: Box<CoProcessor<W, L, C, QUEUE, N>> = Box::new(CoProcessor::new());
    core.boot(
        LinkConfig::DEFAULT,
        input.design,
        input.config,
        input.frontend,
    )
    .map_err(|e| e.to_string())?;
    let mut host = HostLink::new();
    let feed = match rule {
        PoseRule::OnTime => input.on_time,
        PoseRule::LockStep => input.truth,
        PoseRule::Timed | PoseRule::Latest => input.late,
    };
    let mut late = feed.iter().peekable();
    let mut robot_x = 0.0_f64;
    let mut robot_xy = (0.0, 0.0);
    let mut angle: Option<u16> = None;
    let mut first_step_m = None;
    let mut observations = core.counters().frontend.observations;
    let mut scratch = [0_u8; 1024];
    for step in &input.steps.steps {
        let (bytes, time_us) = match step {
            Step::Setup(_) => continue,
            Step::Angle(turns) => {
                angle = Some(*turns);
                continue;
            }
            Step::Pose(p) => {
                robot_x = f64::from(p[0]);
                robot_xy = (f64::from(p[0]), f64::from(p[1]));
                continue;
            }
            // The simulator stamps a telegram or chunk with its last byte's arrival.
            Step::Telegram { bytes, time_us, .. } | Step::Laser { bytes, time_us, .. } => {
                (bytes, *time_us)
            }
        };
        while let Some(p) = late.next_if(|p| p.arrival_us <= time_us) {
            deliver(&mut core, rule, p);
        }
        if let Some(turns) = angle.take() {
            core.host(&pan_angle_frame(&mut host, turns)?);
        }
        core.laser(bytes, device_us(time_us), &mut NoAngleSource);
        // Nothing reads the link here: keep its queue from filling.
        while core.take_output(&mut scratch) > 0 {}
        let now = core.counters().frontend.observations;
        if now != observations {
            observations = now;
            if let (None, Some((cells, riser_x))) = (first_step_m, input.first_riser) {
                let p = core.pyramid();
                let seen = stairs::shares_by(
                    |x, y| {
                        p.fused(
                            Meters::saturating_from_num(x),
                            Meters::saturating_from_num(y),
                        )
                    },
                    cells,
                );
                if seen.obstacle >= FIRST_STEP_SHARE {
                    first_step_m = Some(round3(riser_x - robot_x));
                }
            }
        }
    }
    if input.end_observation {
        core.end_observation();
    }
    let counters = core.counters();
    let snapshot = MapSnapshot::from_pyramid(core.pyramid(), input.design, input.config, robot_xy);
    let track = track_counters(&core);
    Ok(RunOutcome {
        snapshot,
        counters: RunCounters {
            first_step_m,
            returns_extrapolated: track.0,
            returns_without_pose: track.1,
            poses_stamped: track.2,
            poses_refused: track.3,
            observations: u64::from(counters.frontend.observations),
        },
    })
}

/// The pose track's counters: returns extrapolated, returns without a pose, poses stamped,
/// poses refused.
fn track_counters<const W: usize, const L: usize, const C: usize, const N: usize>(
    core: &CoProcessor<W, L, C, QUEUE, N>,
) -> (u64, u64, u64, u64) {
    let c = core.counters();
    (
        u64::from(c.frontend.returns_extrapolated),
        u64::from(c.frontend.returns_without_pose),
        u64::from(c.app.poses_stamped),
        u64::from(c.app.poses_refused),
    )
}

/// The frame of a PanAngle command to `turns` (2⁻¹⁶ turn; untimed, as `pyramid run` sends
/// the actuator's angle), with `host`'s next sequence number.
///
/// # Errors
/// The command cannot be encoded.
pub fn pan_angle_frame(host: &mut HostLink, turns: u16) -> Result<Vec<u8>, String> {
    host.command(&Message::PanAngle(PanAngle {
        turns,
        timestamp_ms: 0,
    }))
    .map_err(|e| e.to_string())
}
