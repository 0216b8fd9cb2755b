//! The benchmark's replay loop: a recording (`docs/recording.md`) through a pipeline, exactly
//! as the firmware's main loop would run it. `no_std` and allocation-free, so the bench
//! firmware (`boards/bench`) and the host timing (`bench-host`, `benches/pipeline.rs`) run the
//! same code.
//!
//! - [`replay`]: the event loop: laser bytes, angles and poses handed to a [`Pipeline`] in the
//!   recording's order.
//! - [`Core`]: the application core ([`CoProcessor`]) as the firmware runs it: the laser's
//!   bytes, the recording's angle as the board's angle source, the host link polled after
//!   every chunk and its queue drained at once.
//! - [`Fixed`]: the library's per-line pipeline ([`Frontend`] → [`Pyramid`]) without the link
//!   or the application: the fixed-point side of the f32 comparison.
//! - [`F32`]: the f32 counterpart (`terrain-pyramid-f32`).
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

use terrain_pyramid::angle::{Angle, FineAngle};
use terrain_pyramid::app::CoProcessor;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::link::convert::frontend_config_of_event;
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::wire::recording::{Payload, Reader, SetupEvent};
use terrain_pyramid::wire::sick::{MeasuredValues, SickAccumulator, SickItem};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::Pyramid;

pub use terrain_pyramid_f32 as f32_pipeline;

/// One pipeline as the replay loop drives it.
pub trait Pipeline {
    /// The actuator angle, a fraction of a turn (`value / 65536`).
    fn set_actuator(&mut self, turns: u16);
    /// A pose event: x, y, z (m), roll, pitch, yaw (rad).
    fn set_pose(&mut self, pose: [f32; 6]);
    /// A pose event with the recording's time of it (µs): [`set_pose`](Self::set_pose)
    /// unless the pipeline takes stamped poses ([`TimedCore`]).
    fn set_pose_at(&mut self, pose: [f32; 6], _time_us: u64) {
        self.set_pose(pose);
    }
    /// Laser bytes as the UART delivers them, at the recording's clock (ms).
    fn laser(&mut self, bytes: &[u8], now_ms: u32);
    /// The end of the recording: the last observation is applied.
    fn finish(&mut self);
    /// Laser returns (values with a distance) seen so far.
    fn returns(&self) -> u32;
    /// Measured-values telegrams taken so far.
    fn lines(&self) -> u32;
}

/// The recording's setup event, if it has one.
#[must_use]
pub fn setup(recording: &[u8]) -> Option<SetupEvent> {
    Reader::new(recording)
        .ok()?
        .find_map(|e| match e.ok()?.payload {
            Payload::Setup(s) => Some(s),
            _ => None,
        })
}

/// The library pipeline's configuration from a recording's setup (as `pyramid run`'s).
#[must_use]
pub fn frontend_config(setup: &SetupEvent) -> Option<FrontendConfig> {
    frontend_config_of_event(setup, &ClassifierConfig::default()).ok()
}

/// Plays `recording` through `pipeline`.
pub fn replay<P: Pipeline>(recording: &[u8], pipeline: &mut P) {
    let Ok(reader) = Reader::new(recording) else {
        return;
    };
    for event in reader {
        let Ok(event) = event else { break };
        match event.payload {
            Payload::Angle(turns) => pipeline.set_actuator(turns),
            Payload::Pose(pose) => pipeline.set_pose_at(pose, event.time_us),
            Payload::Laser(bytes) => {
                let now_ms = u32::try_from(event.time_us / 1000).unwrap_or(u32::MAX);
                pipeline.laser(bytes, now_ms);
            }
            // The setup, sensor and rig events are read once at boot (`setup`, `rig`,
            // `boot_with_sensor`).
            Payload::Setup(_)
            | Payload::Sensor(_)
            | Payload::Rig(_)
            | Payload::Marker(_)
            | Payload::Unknown { .. } => {}
        }
    }
    pipeline.finish();
}

/// A pose event as the geometry takes it (`None`: refused).
fn pose_of([x, y, z, roll, pitch, yaw]: [f32; 6]) -> Option<Pose> {
    Pose::from_f32(x, y, z, roll, pitch, yaw).ok()
}

/// The application core as the firmware runs it.
pub struct Core<'a, const W: usize, const L: usize, const C: usize, const Q: usize> {
    /// The co-processor, booted.
    pub core: &'a mut CoProcessor<W, L, C, Q>,
    /// The recording's actuator angle, read as a board reads its encoder.
    pub angle: HostSuppliedAngle,
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize> Pipeline
    for Core<'_, W, L, C, Q>
{
    fn set_actuator(&mut self, turns: u16) {
        self.angle.set(Angle::from_bits(turns));
    }

    fn set_pose(&mut self, pose: [f32; 6]) {
        if let Some(pose) = pose_of(pose) {
            self.core.set_pose(pose);
        }
    }

    fn laser(&mut self, bytes: &[u8], now_ms: u32) {
        self.core
            .laser(bytes, now_ms.wrapping_mul(1_000), &mut self.angle);
        self.core.poll(now_ms);
        // The UART takes everything at once: a drained queue.
        let mut uart = [0_u8; 64];
        while self.core.take_output(&mut uart) > 0 {}
    }

    fn finish(&mut self) {
        self.core.end_observation();
    }

    fn returns(&self) -> u32 {
        self.core.frontend().stats().returns
    }

    fn lines(&self) -> u32 {
        self.core.frontend().stats().lines_applied
    }
}

/// [`Core`] taking the recording's poses as stamped poses at their recording times (the
/// device's µs clock is the recording's): every return is placed with the pose interpolated
/// at its own time (`CoProcessor::stamped_pose`), the timed path's cost.
pub struct TimedCore<'a, const W: usize, const L: usize, const C: usize, const Q: usize>(
    pub Core<'a, W, L, C, Q>,
);

impl<const W: usize, const L: usize, const C: usize, const Q: usize> Pipeline
    for TimedCore<'_, W, L, C, Q>
{
    fn set_actuator(&mut self, turns: u16) {
        self.0.set_actuator(turns);
    }

    fn set_pose(&mut self, pose: [f32; 6]) {
        self.0.set_pose(pose);
    }

    fn set_pose_at(&mut self, pose: [f32; 6], time_us: u64) {
        if let Some(pose) = pose_of(pose) {
            // The device's clock wraps as the recording's µs do.
            #[allow(clippy::cast_possible_truncation)]
            self.0.core.stamped_pose(time_us as u32, pose);
        }
    }

    fn laser(&mut self, bytes: &[u8], now_ms: u32) {
        self.0.laser(bytes, now_ms);
    }

    fn finish(&mut self) {
        self.0.finish();
    }

    fn returns(&self) -> u32 {
        self.0.returns()
    }

    fn lines(&self) -> u32 {
        self.0.lines()
    }
}

/// Feeds `bytes` (one laser chunk) to `accumulator` and hands every measured-values telegram
/// the chunk completes, parsed, to `line`, in stream order; other telegrams, telegrams that do
/// not parse and what the accumulator refuses are passed over.
pub fn each_line<const N: usize>(
    accumulator: &mut SickAccumulator<N>,
    bytes: &[u8],
    mut line: impl FnMut(&MeasuredValues<'_>),
) {
    let mut rest = bytes;
    loop {
        rest = match accumulator.feed(rest) {
            FeedResult::Consumed => return,
            FeedResult::Item {
                item: SickItem::Telegram(telegram),
                remaining,
                ..
            } => {
                if let Ok(values) = MeasuredValues::parse(&telegram) {
                    line(&values);
                }
                remaining
            }
            other => other.remaining(),
        };
    }
}

/// The library's per-line pipeline into a pyramid, no link, no application.
pub struct Fixed<'a, const C: usize, const W: usize, const L: usize> {
    /// The laser's accumulator.
    pub accumulator: &'a mut SickAccumulator,
    /// The per-line pipeline (its design adopted).
    pub frontend: &'a mut Frontend<C, L>,
    /// The pyramid.
    pub pyramid: &'a mut Pyramid<W, L>,
}

impl<const C: usize, const W: usize, const L: usize> Pipeline for Fixed<'_, C, W, L> {
    fn set_actuator(&mut self, turns: u16) {
        self.frontend
            .set_actuator(FineAngle::from(Angle::from_bits(turns)));
    }

    fn set_pose(&mut self, pose: [f32; 6]) {
        if let Some(pose) = pose_of(pose) {
            self.frontend.set_pose(pose);
        }
    }

    fn laser(&mut self, bytes: &[u8], _now_ms: u32) {
        let (frontend, pyramid) = (&mut *self.frontend, &mut *self.pyramid);
        each_line(self.accumulator, bytes, |values| {
            // A refused line is counted by the pipeline.
            let _ = frontend.line(pyramid, values);
        });
    }

    fn finish(&mut self) {
        self.frontend.end_observation(self.pyramid);
    }

    fn returns(&self) -> u32 {
        self.frontend.stats().returns
    }

    fn lines(&self) -> u32 {
        self.frontend.stats().lines_applied
    }
}

/// The f32 counterpart as a [`Pipeline`].
pub struct F32<'a, const C: usize, const W: usize, const L: usize> {
    /// The laser's accumulator.
    pub accumulator: &'a mut SickAccumulator,
    /// The f32 pipeline.
    pub frontend: &'a mut terrain_pyramid_f32::Frontend<C>,
    /// Its pyramid.
    pub pyramid: &'a mut terrain_pyramid_f32::Pyramid<W, L>,
}

impl<const C: usize, const W: usize, const L: usize> Pipeline for F32<'_, C, W, L> {
    fn set_actuator(&mut self, turns: u16) {
        self.frontend.set_actuator(turns);
    }

    fn set_pose(&mut self, pose: [f32; 6]) {
        self.frontend.set_pose(pose);
    }

    fn laser(&mut self, bytes: &[u8], _now_ms: u32) {
        let (frontend, pyramid) = (&mut *self.frontend, &mut *self.pyramid);
        each_line(self.accumulator, bytes, |values| {
            frontend.line(pyramid, values)
        });
    }

    fn finish(&mut self) {
        self.frontend.end_observation(self.pyramid);
    }

    fn returns(&self) -> u32 {
        self.frontend.returns()
    }

    fn lines(&self) -> u32 {
        self.frontend.lines()
    }
}

/// The default design (sensor model and schedule) at a window of `W` cells.
#[must_use]
pub fn default_design<const W: usize, const L: usize>() -> Option<terrain_pyramid::Design<L>> {
    terrain_pyramid::Design::new(
        terrain_pyramid::SensorModel::default(),
        terrain_pyramid::Schedule::default(),
        W,
    )
    .ok()
}

/// Boots `core` as the bench firmware does: `design`, the default configuration and link,
/// the recording's setup. `false` when the recording has no usable setup or the design does
/// not fit the core.
pub fn boot<const W: usize, const L: usize, const C: usize, const Q: usize>(
    core: &mut CoProcessor<W, L, C, Q>,
    recording: &[u8],
    design: &terrain_pyramid::Design<L>,
) -> bool {
    boot_with(core, recording, design, &terrain_pyramid::Config::default())
}

/// [`boot`] with a configuration of the pyramid (the decay bench's, with decay on).
pub fn boot_with<const W: usize, const L: usize, const C: usize, const Q: usize>(
    core: &mut CoProcessor<W, L, C, Q>,
    recording: &[u8],
    design: &terrain_pyramid::Design<L>,
    config: &terrain_pyramid::Config,
) -> bool {
    let Some(setup) = setup(recording).as_ref().and_then(frontend_config) else {
        return false;
    };
    core.boot(
        terrain_pyramid::link::LinkConfig::DEFAULT,
        design,
        config,
        setup,
    )
    .is_ok()
}

/// The recording's sensor event ([`SensorEvent::SICK`] when it has none: version 1).
#[must_use]
pub fn sensor(recording: &[u8]) -> terrain_pyramid::wire::recording::SensorEvent {
    Reader::new(recording)
        .ok()
        .and_then(|mut r| {
            r.find_map(|e| match e.ok()?.payload {
                Payload::Sensor(s) => Some(s),
                _ => None,
            })
        })
        .unwrap_or(terrain_pyramid::wire::recording::SensorEvent::SICK)
}

/// The recording's rig event (version 3), if it has one: its mount and its masks and
/// filters.
#[must_use]
pub fn rig(recording: &[u8]) -> Option<terrain_pyramid::wire::recording::RigEvent> {
    Reader::new(recording)
        .ok()?
        .find_map(|e| match e.ok()?.payload {
            Payload::Rig(r) => Some(r),
            _ => None,
        })
}

/// As [`boot`], with the recording's sensor event and its rig event when it has one: a
/// lidar's recording goes through the laser path the Setup names (`Frontend::packet`), its
/// mount and its masks and filters the rig event's.
pub fn boot_with_sensor<const W: usize, const L: usize, const C: usize, const Q: usize>(
    core: &mut CoProcessor<W, L, C, Q>,
    recording: &[u8],
    design: &terrain_pyramid::Design<L>,
) -> bool {
    let Some(event) = setup(recording) else {
        return false;
    };
    let mut message = terrain_pyramid::link::convert::setup_message_with_sensor(
        &event,
        &sensor(recording),
        &ClassifierConfig::default(),
    );
    if let Some(rig) = rig(recording) {
        message = terrain_pyramid::link::convert::setup_with_rig(message, &rig);
    }
    let Ok(config) = terrain_pyramid::link::convert::frontend_config(&message) else {
        return false;
    };
    core.boot(
        terrain_pyramid::link::LinkConfig::DEFAULT,
        design,
        &terrain_pyramid::Config::default(),
        config,
    )
    .is_ok()
}
