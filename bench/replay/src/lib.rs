//! The benchmark's replay loop: a recording (`docs/recording.md`) through a per-line pipeline,
//! exactly as the firmware's main loop would run it. `no_std` and allocation-free, so the
//! bench firmware (`boards/bench`) and the host timing (`bench-host`, `benches/pipeline.rs`)
//! run the same code.
//!
//! - [`replay`]: the event loop: laser bytes through the SICK [`SickAccumulator`], each valid
//!   measured-values telegram to [`Pipeline::line`], angles and poses handed in, the link
//!   ticked after every line.
//! - [`Fixed`]: the library's pipeline ([`Frontend`] → [`Pyramid`]) and, optionally, the
//!   host link's patch bookkeeping ([`Link::poll`] into a queue that is drained at once).
//! - [`F32`]: the f32 counterpart (`terrain-pyramid-f32`).
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::link::{Link, SensorCounters};
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{Payload, Reader};
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
    /// One valid measured-values telegram.
    fn line(&mut self, values: &MeasuredValues<'_>);
    /// After each line: the link's turn (the recording's clock, ms).
    fn tick(&mut self, now_ms: u32);
    /// The end of the recording: the last observation is applied.
    fn finish(&mut self);
    /// Laser returns (values with a distance) seen so far.
    fn returns(&self) -> u32;
}

/// What a replay went through.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Valid measured-values telegrams.
    pub lines: u32,
    /// Telegrams the accumulator rejected.
    pub rejected: u32,
}

/// The recording's setup event, if it has one.
#[must_use]
pub fn setup(recording: &[u8]) -> Option<Setup> {
    Reader::new(recording)
        .ok()?
        .find_map(|e| match e.ok()?.payload {
            Payload::Setup(s) => Some(s),
            _ => None,
        })
}

/// The library pipeline's configuration from a recording's setup (as `pyramid run`'s).
#[must_use]
pub fn frontend_config(setup: &Setup) -> Option<FrontendConfig> {
    FrontendConfig::from_setup(setup, ClassifierConfig::default()).ok()
}

/// Plays `recording` through `pipeline`, feeding its laser bytes to `accumulator`.
pub fn replay<P: Pipeline, const N: usize>(
    recording: &[u8],
    accumulator: &mut SickAccumulator<N>,
    pipeline: &mut P,
) -> Counts {
    let mut counts = Counts::default();
    let Ok(reader) = Reader::new(recording) else {
        return counts;
    };
    for event in reader {
        let Ok(event) = event else { break };
        match event.payload {
            Payload::Angle(turns) => pipeline.set_actuator(turns),
            Payload::Pose(pose) => pipeline.set_pose(pose),
            Payload::Laser(bytes) => {
                let now_ms = u32::try_from(event.time_us / 1000).unwrap_or(u32::MAX);
                let mut rest = bytes;
                loop {
                    match accumulator.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: SickItem::Telegram(telegram),
                            remaining,
                            ..
                        } => {
                            if let Ok(values) = MeasuredValues::parse(&telegram) {
                                counts.lines = counts.lines.saturating_add(1);
                                pipeline.line(&values);
                                pipeline.tick(now_ms);
                            }
                            rest = remaining;
                        }
                        FeedResult::Rejected { remaining, .. } => {
                            counts.rejected = counts.rejected.saturating_add(1);
                            rest = remaining;
                        }
                        other => rest = other.remaining(),
                    }
                }
            }
            Payload::Setup(_) | Payload::Marker(_) | Payload::Unknown { .. } => {}
        }
    }
    pipeline.finish();
    counts
}

/// The library's pipeline into a pyramid, with or without the host link.
pub struct Fixed<'a, const C: usize, const W: usize, const L: usize, const Q: usize> {
    /// The per-line pipeline.
    pub frontend: &'a mut Frontend<C>,
    /// The pyramid.
    pub pyramid: &'a mut Pyramid<W, L>,
    /// The host link, whose queue is drained after every poll; `None`: no link.
    pub link: Option<&'a mut Link<Q>>,
}

impl<const C: usize, const W: usize, const L: usize, const Q: usize> Pipeline
    for Fixed<'_, C, W, L, Q>
{
    fn set_actuator(&mut self, turns: u16) {
        self.frontend
            .set_actuator(FineAngle::from_bits(u32::from(turns) << 16));
    }

    fn set_pose(&mut self, [x, y, z, roll, pitch, yaw]: [f32; 6]) {
        if let Ok(pose) = Pose::from_f32(x, y, z, roll, pitch, yaw) {
            self.frontend.set_pose(pose);
        }
    }

    fn line(&mut self, values: &MeasuredValues<'_>) {
        let _ = self.frontend.line(self.pyramid, values);
    }

    fn tick(&mut self, now_ms: u32) {
        if let Some(link) = self.link.as_deref_mut() {
            let s = self.frontend.stats();
            let c = self.frontend.classifier_stats();
            let sensor = SensorCounters {
                telegrams_ok: s.lines_applied,
                points: c.points,
                classifier_overflows: c.overflow_points,
                observations: s.observations,
                ..SensorCounters::default()
            };
            link.poll(now_ms, self.pyramid, &sensor);
            // The UART takes everything at once: a drained queue.
            let mut uart = [0_u8; 64];
            while link.pop_bytes(&mut uart) > 0 {}
        }
    }

    fn finish(&mut self) {
        self.frontend.end_observation(self.pyramid);
    }

    fn returns(&self) -> u32 {
        self.frontend.stats().returns
    }
}

/// The f32 counterpart as a [`Pipeline`].
pub struct F32<'a, const C: usize, const W: usize, const L: usize> {
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

    fn line(&mut self, values: &MeasuredValues<'_>) {
        self.frontend.line(self.pyramid, values);
    }

    fn tick(&mut self, _now_ms: u32) {}

    fn finish(&mut self) {
        self.frontend.end_observation(self.pyramid);
    }

    fn returns(&self) -> u32 {
        self.frontend.returns()
    }
}
