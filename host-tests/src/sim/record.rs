//! Output: a whole simulated run as a recording in the library's format
//! (`docs/recording.md`), and the ground truth that goes with it.
//!
//! # What a recording holds
//! - The 16-byte file header, then a **setup** event at t = 0: the mount (from the actuator),
//!   the measuring mode's 0x77 code, the field and resolution, the scan centre in the robot
//!   frame, and the lines per observation ([`SimConfig::lines_per_observation`]: by default
//!   [`PAN_LINES_PER_OBSERVATION`] = 8 for the panned vertical plane, whose every line is a
//!   radial height profile — 8 lines are 16° of pan with the paper's sweep —, and 0 = one
//!   observation per sweep for the tilted horizontal plane, whose single line looks flat).
//! - For line i, at `t_i = i / rate` (rounded to the microsecond; 37.5 lines/s at 0.5°, see
//!   [`super::laser`]; with [`SimConfig::beam_times`], the arrival of its telegram instead),
//!   all with the same time stamp, in this order:
//!   1. a **pose** event, when the pose (as `f32`) differs from the previous one (so once
//!      while the robot stands, every line while it drives);
//!   2. **markers** due at this line (below);
//!   3. an **angle** event: the actuator angle at `t_i`, in 2⁻¹⁶ turn;
//!   4. the **laser bytes** of one measured-values telegram (0xB0, real framing and CRC),
//!      in one event, or — every [`SimConfig::split_every`]-th telegram — in two events cut
//!      at a random byte, to exercise the reassembly over chunks.
//! - Lines run from t = 0 until the first line at or after the trajectory's end (so the last
//!   one sees the robot at its stop): `⌈duration · rate⌉ + 1` of them.
//!
//! # Markers
//! | id | when |
//! | --- | --- |
//! | [`MARKER_DRIVE_START`] (1) | the first line at or after the robot starts driving |
//! | [`MARKER_DISTANCE`] (2) | the first line at which the robot's remaining distance to the scene's target x (`target_x − x`) is at or below a multiple of 0.5 m it was above when driving began (one marker per multiple crossed; the pose event just before it says where the robot is) |
//! | [`MARKER_STOPPED`] (3) | the first line at or after the robot stops |
//!
//! No marker is written for a trajectory that does not drive; no distance marker for a scene
//! without a target.
//!
//! # Determinism
//! Everything random (range noise, the split points) comes from generators seeded with
//! [`SimConfig::seed`]: the same configuration gives the same bytes, run after run.

use super::laser::{angle_to_u16, measuring_mode_code, Laser, LaserConfig};
use super::rng::Rng;
use super::scene::{GroundTruthSpec, ObstacleCell, Scene, StairsSpec};
use super::trajectory::{Phase, Pose, Trajectory};
use core::fmt;
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{
    emit_header_version, Event, MountKind, Payload, VERSION_WITHOUT_RIG,
};

/// Marker id: the robot starts driving.
pub const MARKER_DRIVE_START: u32 = 1;
/// Marker id: the remaining distance to the target crossed a multiple of 0.5 m.
pub const MARKER_DISTANCE: u32 = 2;
/// Marker id: the robot has stopped.
pub const MARKER_STOPPED: u32 = 3;

/// The spacing of the distance markers, metres.
pub const MARKER_SPACING_M: f64 = 0.5;

/// Lines per observation for the panned vertical plane, by default.
pub const PAN_LINES_PER_OBSERVATION: u32 = 8;

/// Everything a simulated run needs.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// The world.
    pub scene: Scene,
    /// The laser and its actuator.
    pub laser: LaserConfig,
    /// The robot's motion.
    pub trajectory: Trajectory,
    /// The setup's lines per observation (0 = one observation per sweep).
    pub lines_per_observation: u32,
    /// The seed of every random draw.
    pub seed: u64,
    /// Every `split_every`-th telegram goes into two laser events; 0 = never. Default 10.
    pub split_every: u32,
    /// The grid and rule of the ground truth returned with the recording.
    pub truth: GroundTruthSpec,
    /// Each beam cast at its own moment (default `false`: a whole line at `t_i`). When set,
    /// line i's mirror starts at `t_i`, beam k is cast with the robot's true pose and the
    /// actuator's angle at `t_i +` [`LaserConfig::beam_offsets_s`]`[k]`, and the telegram
    /// is sent when its last beam is measured and arrives after its transmission at
    /// [`SICK_BAUD`]: the line's events are stamped with that arrival, its pose event and
    /// angle event hold the pose and the angle at the mean of its beams' times. A device
    /// given stamped poses can place such a line exactly; one played with the recording's
    /// poses in lock-step (`pyramid run`) places the whole line at that one pose.
    pub beam_times: bool,
}

/// The LMS2xx's serial rate the simulator's telegrams travel at with
/// [`SimConfig::beam_times`], baud (its RS-422 rate; 10 bits a byte).
pub const SICK_BAUD: u32 = 500_000;

impl SimConfig {
    /// A run over `scene` along `trajectory` with `laser`: the default lines per observation
    /// for the laser's mount, seed 1, every 10th telegram split, the default truth grid.
    #[must_use]
    pub fn new(scene: Scene, laser: LaserConfig, trajectory: Trajectory) -> Self {
        let lines_per_observation = match laser.actuator.mount_kind() {
            MountKind::PannedVertical => PAN_LINES_PER_OBSERVATION,
            MountKind::TiltedHorizontal => 0,
        };
        Self {
            scene,
            laser,
            trajectory,
            lines_per_observation,
            seed: 1,
            split_every: 10,
            truth: GroundTruthSpec::default(),
            beam_times: false,
        }
    }

    /// The paper's stairs experiment (Figs 5-7): the default stairs (first riser 5.05 m
    /// ahead), the paper's laser; the robot stands for `stand_s`, then drives at
    /// `speed_mps` until it is `distance_m` from the first riser.
    #[must_use]
    pub fn paper_stairs(stand_s: f64, speed_mps: f64, distance_m: f64) -> Self {
        let spec = StairsSpec::default();
        Self::new(
            Scene::stairs(spec),
            LaserConfig::paper(),
            Trajectory::approach(stand_s, speed_mps, spec.first_riser_x, distance_m),
        )
    }

    /// Checks the configuration.
    ///
    /// # Errors
    /// The first field out of bounds.
    pub fn validate(&self) -> Result<(), SimError> {
        self.laser.validate().map_err(SimError)?;
        self.trajectory.validate().map_err(SimError)?;
        let t = &self.truth;
        if !(t.cell_m > 0.0 && t.x_max >= t.x_min && t.y_max >= t.y_min) {
            return Err(SimError("truth: bad grid or region".into()));
        }
        Ok(())
    }

    /// The setup event's content.
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn setup(&self) -> Setup {
        Setup {
            mount: self.laser.actuator.mount_kind(),
            measuring_mode: measuring_mode_code(self.laser.mode),
            field_deg: self.laser.variant.scan_angle_deg(),
            resolution_cdeg: self.laser.variant.resolution_centideg(),
            sensor_m: self.laser.position_m.map(|v| v as f32),
            lines_per_observation: self.lines_per_observation,
        }
    }
}

/// A configuration the simulator refuses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimError(pub String);

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SimError {}

/// A simulated run: the recording's bytes and what is known about them.
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// The recording, header included.
    pub bytes: Vec<u8>,
    /// The setup it was recorded with.
    pub setup: Setup,
    /// Scan lines, one telegram each.
    pub lines: u32,
    /// Laser-byte events (lines plus the split ones' second halves).
    pub laser_events: u32,
    /// Pose events.
    pub pose_events: u32,
    /// The time of the last line, microseconds.
    pub duration_us: u64,
    /// Every marker written: (time µs, id).
    pub markers: Vec<(u64, u32)>,
    /// The cells that hold an obstacle ([`Scene::obstacle_cells`] with
    /// [`SimConfig::truth`]).
    pub ground_truth: Vec<ObstacleCell>,
}

/// Appends one event to `out`.
///
/// # Errors
/// The event could not be written.
pub(crate) fn push(out: &mut Vec<u8>, event: &Event<'_>) -> Result<(), SimError> {
    let start = out.len();
    out.resize(start + event.buffer_len(), 0);
    let tail = out.get_mut(start..).unwrap_or_default();
    event
        .emit(tail)
        .map_err(|e| SimError(format!("emit: {e}")))?;
    Ok(())
}

/// A recording's beginning: the file header of `version` (`docs/recording.md`), then each of
/// `payloads` as an event at t = 0, in order.
///
/// # Errors
/// An event the library's writer refuses.
pub(crate) fn start_recording(version: u16, payloads: &[Payload<'_>]) -> Result<Vec<u8>, SimError> {
    let mut bytes = vec![0_u8; 16];
    emit_header_version(&mut bytes, version).map_err(|e| SimError(format!("emit: {e}")))?;
    for &payload in payloads {
        push(
            &mut bytes,
            &Event {
                time_us: 0,
                payload,
            },
        )?;
    }
    Ok(bytes)
}

/// Writes a pose event of `pose` (x, y, z m, roll, pitch, yaw rad) at `time_us` (µs) unless
/// `last`, the pose written last, is the same; `last` becomes `pose`. Returns whether it
/// wrote one.
///
/// # Errors
/// The event could not be written.
pub(crate) fn push_pose_change(
    out: &mut Vec<u8>,
    time_us: u64,
    pose: [f32; 6],
    last: &mut Option<[f32; 6]>,
) -> Result<bool, SimError> {
    if *last == Some(pose) {
        return Ok(false);
    }
    push(
        out,
        &Event {
            time_us,
            payload: Payload::Pose(pose),
        },
    )?;
    *last = Some(pose);
    Ok(true)
}

/// Writes `chunk` as laser-byte events at `time_us` (µs): cut in two at a point drawn from
/// `splits` (both halves non-empty) when `split` and it has 2 bytes or more, else whole.
/// Returns the number of events written (0 for an empty chunk, else 1 or 2).
///
/// # Errors
/// An event could not be written.
pub(crate) fn push_laser(
    out: &mut Vec<u8>,
    time_us: u64,
    chunk: &[u8],
    split: bool,
    splits: &mut Rng,
) -> Result<u32, SimError> {
    let cut = if split && chunk.len() > 1 {
        // 1 ..= len − 1: both halves non-empty.
        let len = chunk.len() as u64;
        usize::try_from(1 + splits.below(len - 1)).unwrap_or(1)
    } else {
        chunk.len()
    };
    let mut events = 0;
    for part in [chunk.get(..cut), chunk.get(cut..)]
        .into_iter()
        .flatten()
        .filter(|p| !p.is_empty())
    {
        push(
            out,
            &Event {
                time_us,
                payload: Payload::Laser(part),
            },
        )?;
        events += 1;
    }
    Ok(events)
}

/// Salt of the split-point generator's seed, so that the noise does not depend on chunking.
const SPLIT_SALT: u64 = 0x5EED_C0DE_5EED_C0DE;

/// Runs the simulation and writes the recording.
///
/// # Errors
/// A configuration that [`SimConfig::validate`] refuses.
pub fn simulate(config: &SimConfig) -> Result<Simulation, SimError> {
    simulate_with(config, &|_| None, &mut |_| {})
}

/// One scan line as the simulator made it, for a caller that watches ([`simulate_with`]).
#[derive(Debug)]
pub struct LineView<'a> {
    /// The line's index, from 0.
    pub index: u32,
    /// Its time, seconds.
    pub t_s: f64,
    /// The robot's pose (as the recording has it).
    pub pose: &'a Pose,
    /// The actuator angle, 2⁻¹⁶ turn.
    pub angle: u16,
    /// The scene the line was cast into.
    pub scene: &'a Scene,
    /// The laser (its rays: [`Laser::rays`]).
    pub laser: &'a Laser,
}

/// [`simulate`] in a world that changes: `scene_at(t)` gives the scene of the line at `t`
/// seconds (`None`: the configuration's own, unchanged), and `on_line` sees every line after
/// it is scanned. The configuration's scene still gives the setup, the markers' target and the
/// ground truth.
///
/// # Errors
/// A configuration that [`SimConfig::validate`] refuses.
pub fn simulate_with(
    config: &SimConfig,
    scene_at: &dyn Fn(f64) -> Option<Scene>,
    on_line: &mut dyn FnMut(&LineView<'_>),
) -> Result<Simulation, SimError> {
    config.validate()?;
    let setup = config.setup();
    // The laser sits where the setup says (f32), so the recording is self-consistent.
    let laser_config = LaserConfig {
        position_m: setup.sensor_m.map(f64::from),
        ..config.laser
    };
    let mut laser = Laser::new(laser_config, config.seed);
    let mut splits = Rng::new(config.seed ^ SPLIT_SALT);
    let scene = &config.scene;
    let trajectory = &config.trajectory;
    let rate = laser_config.line_rate_hz();
    let duration = trajectory.duration_s();
    // ⌈duration · rate⌉ + 1 lines, the last at or after the end (a tiny tolerance keeps an
    // exact product exact).
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let lines = (duration * rate - 1e-9).ceil().max(0.0) as u32 + 1;

    let mut bytes = start_recording(VERSION_WITHOUT_RIG, &[Payload::Setup(setup)])?;

    let drives = trajectory.drive_s() > 0.0;
    let target = scene.target_x;
    // The lowest marker level not yet passed: remaining ≤ level · spacing writes a marker.
    let mut next_level: Option<i64> = None;
    let mut started = false;
    let mut stopped = false;
    let mut last_pose: Option<[f32; 6]> = None;
    let mut markers = Vec::new();
    let (mut laser_events, mut pose_events) = (0_u32, 0_u32);
    let mut time_us = 0;
    let beam_offsets = laser_config.beam_offsets_s();

    for i in 0..lines {
        let t = f64::from(i) / rate;
        let changed = scene_at(t);
        if changed.is_some() {
            // The world moved: what was cast from this pose before no longer holds.
            laser.forget();
        }
        let line_scene = changed.as_ref().unwrap_or(scene);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (now, pose, angle, line) = if config.beam_times {
            let times: Vec<f64> = beam_offsets.iter().map(|o| t + o).collect();
            #[allow(clippy::cast_precision_loss)]
            let mean = times.iter().sum::<f64>() / times.len().max(1) as f64;
            let last = times.iter().copied().fold(t, f64::max);
            let actuator = laser_config.actuator;
            let line = laser.scan_each(line_scene, &|k| {
                let tk = times.get(k).copied().unwrap_or(t);
                (trajectory.pose_at(tk, scene), actuator.angle_deg(tk))
            });
            let sent = laser.telegram(&line).map_err(SimError)?.len();
            #[allow(clippy::cast_precision_loss)]
            let arrival = last + 10.0 * sent as f64 / f64::from(SICK_BAUD);
            (
                (arrival * 1e6).round() as u64,
                trajectory.pose_at(mean, scene).rounded_f32(),
                angle_to_u16(actuator.angle_deg(mean)),
                line,
            )
        } else {
            let pose = trajectory.pose_at(t, scene).rounded_f32();
            let angle = angle_to_u16(laser_config.actuator.angle_deg(t));
            let line = laser.scan(line_scene, &pose, angle);
            (
                (f64::from(i) * 1e6 / rate).round() as u64,
                pose,
                angle,
                line,
            )
        };
        time_us = now;
        pose_events += u32::from(push_pose_change(
            &mut bytes,
            now,
            pose.to_f32(),
            &mut last_pose,
        )?);
        let phase = trajectory.phase(t);
        let mut due = Vec::new();
        if drives && !started && phase != Phase::Standing {
            started = true;
            due.push(MARKER_DRIVE_START);
            if let Some(tx) = target {
                // Multiples of the spacing strictly below the remaining distance at the start.
                let remaining = tx - trajectory.start_x;
                #[allow(clippy::cast_possible_truncation)]
                let level = (remaining / MARKER_SPACING_M).ceil() as i64 - 1;
                next_level = Some(level);
            }
        }
        if started {
            if let (Some(tx), Some(level)) = (target, next_level.as_mut()) {
                // The exact position, with a micrometre of slack for the rounding of x.
                let remaining = tx - trajectory.x_at(t);
                #[allow(clippy::cast_precision_loss)]
                while *level >= 0 && remaining <= *level as f64 * MARKER_SPACING_M + 1e-6 {
                    due.push(MARKER_DISTANCE);
                    *level -= 1;
                }
            }
        }
        if drives && !stopped && phase == Phase::Stopped {
            stopped = true;
            due.push(MARKER_STOPPED);
        }
        for id in due {
            push(
                &mut bytes,
                &Event {
                    time_us: now,
                    payload: Payload::Marker(id),
                },
            )?;
            markers.push((now, id));
        }
        push(
            &mut bytes,
            &Event {
                time_us: now,
                payload: Payload::Angle(angle),
            },
        )?;
        on_line(&LineView {
            index: i,
            t_s: t,
            pose: &pose,
            angle,
            scene: line_scene,
            laser: &laser,
        });
        let telegram = laser.telegram(&line).map_err(SimError)?;
        let split = config.split_every != 0 && (i + 1) % config.split_every == 0;
        laser_events += push_laser(&mut bytes, now, &telegram, split, &mut splits)?;
    }

    Ok(Simulation {
        bytes,
        setup,
        lines,
        laser_events,
        pose_events,
        duration_us: time_us,
        markers,
        ground_truth: scene.obstacle_cells(&config.truth),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scene::Scene;

    #[test]
    fn markers_count_down() {
        // Start 5.05 m from the riser, stop at 1.05 m: thresholds 5.0, 4.5, …, 1.5 → 8 markers
        // while driving, then the stop (the remaining distance never reaches 1.0).
        let config = SimConfig {
            split_every: 0,
            ..SimConfig::new(
                Scene::scenario(crate::sim::scene::Scenario::Stairs),
                LaserConfig::paper(),
                Trajectory::approach(0.2, 2.0, 5.05, 1.05),
            )
        };
        let sim = simulate(&config).unwrap();
        let ids: Vec<u32> = sim.markers.iter().map(|m| m.1).collect();
        assert_eq!(ids.first(), Some(&MARKER_DRIVE_START));
        assert_eq!(ids.last(), Some(&MARKER_STOPPED));
        assert_eq!(ids.iter().filter(|&&id| id == MARKER_DISTANCE).count(), 8);
        assert_eq!(sim.laser_events, sim.lines);
    }
}
