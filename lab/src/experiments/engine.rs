//! The machinery every experiment shares: a simulated recording decoded once into its scan
//! lines, and maps (library pyramids of any shape) fed line by line through the library's own
//! pipeline ([`Frontend::line`]), exactly as `pyramid run` and the firmware feed them.
//!
//! Decoding the recording (events, SICK reassembly, CRC) happens once, before any map sees a
//! line; each map then parses the stored measured-values payload itself, so a timed line
//! costs the parse, the geometry, the classifier and the pyramid updates, and nothing else.

use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{Payload, Reader};
use terrain_pyramid::wire::sick::{MeasuredValues, SickAccumulator, SickItem};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{Config, Design, Fused, Meters, Pyramid, PyramidStats};

use crate::export::MapSnapshot;

/// One scan line of a recording, with the pose and actuator angle in force for it.
#[derive(Debug, Clone)]
pub struct Line {
    /// The recording's time stamp of the line, microseconds.
    pub time_us: u64,
    /// A new pose that takes effect with this line (x, y, z, roll, pitch, yaw), when it changed.
    pub pose: Option<[f32; 6]>,
    /// The robot's pose in force for this line.
    pub robot_xy: (f64, f64),
    /// The actuator angle, 2⁻¹⁶ turn.
    pub angle: u16,
    /// The measured-values payload of the line's telegram.
    pub payload: Vec<u8>,
}

/// A recording decoded into lines.
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The pipeline's configuration from the recording's setup.
    pub frontend: FrontendConfig,
    /// The lines, in order.
    pub lines: Vec<Line>,
}

/// The pipeline's configuration from a recording's setup (as `pyramid run` derives it).
fn frontend_config(setup: &Setup) -> Result<FrontendConfig, String> {
    FrontendConfig::from_setup(setup, ClassifierConfig::default())
        .map_err(|e| format!("the recording's setup: {e}"))
}

/// Decodes a whole recording: its setup and every valid measured-values telegram as a line.
///
/// # Errors
/// A recording that cannot be read, or lines before the setup.
pub fn decode(data: &[u8]) -> Result<Decoded, String> {
    let reader = Reader::new(data).map_err(|e| format!("the recording: {e}"))?;
    let mut accumulator: Box<SickAccumulator> = Box::new(SickAccumulator::new());
    let mut frontend = None;
    let mut lines = Vec::new();
    let mut pending_pose: Option<[f32; 6]> = None;
    let mut robot_xy = (0.0, 0.0);
    let mut angle = 0_u16;
    for event in reader {
        let event = event.map_err(|e| format!("the recording: {e}"))?;
        match event.payload {
            Payload::Setup(setup) => frontend = Some(frontend_config(&setup)?),
            Payload::Angle(turns) => angle = turns,
            Payload::Pose(pose) => {
                robot_xy = (f64::from(pose[0]), f64::from(pose[1]));
                pending_pose = Some(pose);
            }
            Payload::Laser(bytes) => {
                if frontend.is_none() {
                    return Err("the recording has laser bytes before its setup".into());
                }
                let mut rest = bytes;
                loop {
                    match accumulator.feed(rest) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: SickItem::Telegram(telegram),
                            remaining,
                            ..
                        } => {
                            if MeasuredValues::parse(&telegram).is_ok() {
                                lines.push(Line {
                                    time_us: event.time_us,
                                    pose: pending_pose.take(),
                                    robot_xy,
                                    angle,
                                    payload: telegram.payload().to_vec(),
                                });
                            }
                            rest = remaining;
                        }
                        other => rest = other.remaining(),
                    }
                }
            }
            Payload::Marker(_) | Payload::Unknown { .. } => {}
        }
    }
    let frontend = frontend.ok_or("the recording has no setup")?;
    Ok(Decoded { frontend, lines })
}

/// A map the experiments feed and query, whatever its shape.
pub trait Map {
    /// A short name for reports.
    fn name(&self) -> &str;
    /// Feeds one line through the pipeline.
    fn line(&mut self, line: &Line);
    /// Ends the observation in progress (if any) and applies it.
    fn flush(&mut self);
    /// The fused query at a world point, metres.
    fn fused(&self, x: f64, y: f64) -> Fused;
    /// The pyramid's counters.
    fn stats(&self) -> PyramidStats;
    /// Evidence records the classifier produced so far.
    fn records(&self) -> u64;
    /// The maps as plain data, for pictures.
    fn snapshot(&self, sensor_xy: (f64, f64)) -> MapSnapshot;
    /// The number of layers.
    fn layer_count(&self) -> usize;
    /// Forgets every observation and restarts the pipeline (same configuration, at the origin).
    fn reset(&mut self);
}

/// A library pyramid of `L` layers of `W × W` cells behind a pipeline with `C` classifier
/// slots, with the design and configuration it was built from.
pub struct Runner<const W: usize, const L: usize, const C: usize> {
    name: String,
    design: Design<L>,
    config: Config,
    frontend_config: FrontendConfig,
    pyramid: Box<Pyramid<W, L>>,
    frontend: Box<Frontend<C>>,
}

impl<const W: usize, const L: usize, const C: usize> Runner<W, L, C> {
    /// A configured pyramid and a fresh pipeline. Build it on a thread with a stack big enough
    /// for `Pyramid<W, L>` (the experiments run on one, see `super::run`).
    ///
    /// # Errors
    /// The library refused the design or the configuration.
    pub fn new(
        name: &str,
        design: Design<L>,
        config: Config,
        frontend_config: FrontendConfig,
    ) -> Result<Self, String> {
        let mut pyramid = Box::new(Pyramid::<W, L>::new());
        pyramid
            .configure(&design, &config)
            .map_err(|e| format!("{name}: {e}"))?;
        Ok(Self {
            name: name.to_string(),
            design,
            config,
            frontend_config,
            pyramid,
            frontend: Box::new(Frontend::new(frontend_config)),
        })
    }
}

impl<const W: usize, const L: usize, const C: usize> Map for Runner<W, L, C> {
    fn name(&self) -> &str {
        &self.name
    }

    fn line(&mut self, line: &Line) {
        if let Some([x, y, z, roll, pitch, yaw]) = line.pose {
            if let Ok(pose) = Pose::from_f32(x, y, z, roll, pitch, yaw) {
                self.frontend.set_pose(pose);
            }
        }
        self.frontend
            .set_actuator(FineAngle::from_bits(u32::from(line.angle) << 16));
        if let Ok(values) = MeasuredValues::parse_payload(&line.payload) {
            // A line the variant refuses is counted by the pipeline; nothing else to do.
            let _ = self.frontend.line(&mut self.pyramid, &values);
        }
    }

    fn flush(&mut self) {
        self.frontend.end_observation(&mut self.pyramid);
    }

    fn fused(&self, x: f64, y: f64) -> Fused {
        self.pyramid.fused(
            Meters::saturating_from_num(x),
            Meters::saturating_from_num(y),
        )
    }

    fn stats(&self) -> PyramidStats {
        self.pyramid.stats()
    }

    fn records(&self) -> u64 {
        u64::from(self.frontend.classifier_stats().records)
    }

    fn snapshot(&self, sensor_xy: (f64, f64)) -> MapSnapshot {
        MapSnapshot::from_pyramid(&self.pyramid, &self.design, &self.config, sensor_xy)
    }

    fn layer_count(&self) -> usize {
        self.pyramid.layer_count()
    }

    fn reset(&mut self) {
        // Reconfiguring re-centres every window on the origin and forgets the maps.
        // In place: no allocation, so a timed run after a reset pays no first-touch faults.
        // The pipeline's counters keep counting.
        let _ = self.pyramid.configure(&self.design, &self.config);
        self.frontend.configure(self.frontend_config);
        self.frontend.set_pose(Pose::default());
    }
}
