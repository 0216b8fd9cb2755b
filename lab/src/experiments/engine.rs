//! The machinery every experiment shares: a simulated recording decoded once into its scan
//! lines (by the host tool's player, [`terrain_pyramid_host::play::steps`]), and maps (library
//! pyramids of any shape) fed line by line through the library's own pipeline
//! ([`Frontend::line`]) with the design's gating, as the co-processor feeds them.
//!
//! Decoding the recording (events, SICK reassembly, CRC) happens once, before any map sees a
//! line; each map then parses the stored measured-values payload itself, so a timed line
//! costs the parse, the geometry, the classifier and the pyramid updates, and nothing else.
//! As in the co-processor, a line that comes before any actuator angle is dropped.

use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::laser::{LaserDecoder, Sensor, SensorKind};
use terrain_pyramid::link::convert::{frontend_config, setup_message_with_sensor};
use terrain_pyramid::pipeline::{Frontend, FrontendConfig, PacketActuator};
use terrain_pyramid::wire::recording::SensorEvent;
use terrain_pyramid::wire::sick::{MeasuredValues, Telegram};
use terrain_pyramid::wire::LaserReturn;
use terrain_pyramid::{Config, Design, Fused, Meters, Pyramid, PyramidStats};
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::play::{each_packet, steps, Step};
use terrain_pyramid_host_tests::navigability::pyramid_cell;
use terrain_pyramid_host_tests::sim::terrain::Rect;

/// One scan line of a recording, with the pose and actuator angle in force for it.
#[derive(Debug, Clone)]
pub struct Line {
    /// The recording's time stamp of the line, microseconds.
    pub time_us: u64,
    /// A new pose that takes effect with this line (x, y, z, roll, pitch, yaw), when it changed.
    pub pose: Option<[f32; 6]>,
    /// The robot's pose in force for this line.
    pub robot_xy: (f64, f64),
    /// The actuator angle, 2⁻¹⁶ turn; `None` before the recording's first angle.
    pub angle: Option<u16>,
    /// The measured-values payload of the line's telegram (empty for a lidar's packet).
    pub payload: Vec<u8>,
    /// A spinning lidar's packet instead of a telegram: its returns and whether it starts a
    /// revolution (the pipeline takes it through `Frontend::packet`, at the line's angle).
    pub packet: Option<(Vec<LaserReturn>, bool)>,
}

/// A recording decoded into lines.
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The pipeline's configuration from the recording's setup.
    pub frontend: FrontendConfig,
    /// The lines, in order.
    pub lines: Vec<Line>,
}

/// Decodes a whole recording: its setup (with the classifier's thresholds and rule, as the
/// link's Setup carries them) and every valid measured-values telegram as a line.
///
/// # Errors
/// A recording that cannot be read, lines before the setup, or an invalid setup.
pub fn decode(data: &[u8], classifier: &ClassifierConfig) -> Result<Decoded, String> {
    let decoded = steps(data)?;
    let setup = decoded.setup().ok_or("the recording has no setup")?;
    let frontend = frontend_config(&setup_message_with_sensor(
        &setup,
        &decoded.sensor,
        classifier,
    ))
    .map_err(|e| format!("the recording's setup: {e}"))?;
    let mut lidar = lidar_decoder(&decoded.sensor)?;
    let mut lines = Vec::new();
    let mut pending_pose: Option<[f32; 6]> = None;
    let mut robot_xy = (0.0, 0.0);
    let mut angle = None;
    for step in &decoded.steps {
        match step {
            Step::Setup(_) => {}
            Step::Laser { bytes, time_us, .. } => {
                let decoder = lidar.as_mut().ok_or("lidar bytes in a SICK recording")?;
                for (returns, starts) in lidar_packets(decoder, bytes) {
                    lines.push(Line {
                        time_us: *time_us,
                        pose: pending_pose.take(),
                        robot_xy,
                        angle,
                        payload: Vec::new(),
                        packet: Some((returns, starts)),
                    });
                }
            }
            Step::Angle(turns) => angle = Some(*turns),
            Step::Pose(pose) => {
                robot_xy = (f64::from(pose[0]), f64::from(pose[1]));
                pending_pose = Some(*pose);
            }
            Step::Telegram {
                measured: false, ..
            } => continue,
            Step::Telegram { bytes, time_us, .. } => {
                let telegram = Telegram::new_checked(&bytes[..])
                    .map_err(|e| format!("a decoded telegram: {e:?}"))?;
                lines.push(Line {
                    time_us: *time_us,
                    pose: pending_pose.take(),
                    robot_xy,
                    angle,
                    payload: telegram.payload().to_vec(),
                    packet: None,
                });
            }
        }
    }
    Ok(Decoded { frontend, lines })
}

/// The library's decoder of a recording's lidar (`None` for a SICK).
fn lidar_decoder(sensor: &SensorEvent) -> Result<Option<Box<LaserDecoder>>, String> {
    let s = SensorKind::from_code(sensor.sensor)
        .and_then(|k| Sensor::from_kind_and_mode(k, sensor.mode))
        .ok_or("the recording's sensor is unknown")?;
    Ok(s.is_lidar().then(|| Box::new(LaserDecoder::new(s))))
}

/// The packets a chunk of lidar bytes completes: their returns and revolution flags.
fn lidar_packets(decoder: &mut LaserDecoder, bytes: &[u8]) -> Vec<(Vec<LaserReturn>, bool)> {
    let mut out = Vec::new();
    each_packet(decoder, bytes, |p, _| {
        out.push((p.returns().collect(), p.starts_revolution()));
    });
    out
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
    /// Observations the classifier ended so far (each integrated into the maps, evidence or
    /// not).
    fn observations(&self) -> u64;
    /// Point-to-cell additions the classifier's full scratch dropped so far (its overflow).
    fn dropped(&self) -> u64;
    /// The maps as plain data, for pictures.
    fn snapshot(&self, sensor_xy: (f64, f64)) -> MapSnapshot;
    /// The number of layers.
    fn layer_count(&self) -> usize;
    /// Forgets every observation and restarts the pipeline (same configuration, at the origin).
    fn reset(&mut self);
    /// Layer `k`'s log-odds at world point `(x, y)`, nats: `None` when the cell is unknown,
    /// outside the window, or there is no layer `k` (for diagnostics).
    fn layer_log_odds(&self, k: usize, x: f64, y: f64) -> Option<f32>;
    /// The footprint (world metres) of layer `k`'s cell at world point `(x, y)`, wherever the
    /// window stands: `None` when there is no layer `k` in force (for the far obstacles'
    /// ground-only cells).
    fn cell_footprint(&self, k: u8, x: f64, y: f64) -> Option<Rect>;
}

/// A library pyramid of `L` layers of `W × W` cells behind a pipeline with `C` classifier
/// slots, with the design and configuration it was built from.
pub struct Runner<const W: usize, const L: usize, const C: usize> {
    name: String,
    design: Design<L>,
    config: Config,
    frontend_config: FrontendConfig,
    pyramid: Box<Pyramid<W, L>>,
    frontend: Box<Frontend<C, L>>,
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
        // As the co-processor's Configure, then Setup: the design's gating, the recording's
        // mount, scanner and classifier.
        let mut frontend: Box<Frontend<C, L>> = Box::new(Frontend::unconfigured());
        frontend
            .adopt_design(&design, &config)
            .map_err(|e| format!("{name}: {e}"))?;
        frontend.configure(frontend_config);
        Ok(Self {
            name: name.to_string(),
            design,
            config,
            frontend_config,
            pyramid,
            frontend,
        })
    }
}

impl<const W: usize, const L: usize, const C: usize> Map for Runner<W, L, C> {
    fn name(&self) -> &str {
        &self.name
    }

    fn line(&mut self, line: &Line) {
        if self.config.decay.is_on() {
            // The decay owed by the line's time, as a board's poll pays it (ms, wrapping).
            #[allow(clippy::cast_possible_truncation)]
            self.pyramid.decay((line.time_us / 1_000) as u32);
        }
        if let Some([x, y, z, roll, pitch, yaw]) = line.pose {
            if let Ok(pose) = Pose::from_f32(x, y, z, roll, pitch, yaw) {
                self.frontend.set_pose(pose);
            }
        }
        // No angle yet: the co-processor drops the line (it would be placed at a wrong angle).
        let Some(angle) = line.angle else {
            return;
        };
        let angle = FineAngle::from_bits(u32::from(angle) << 16);
        if let Some((returns, starts)) = &line.packet {
            // Refused packets are counted by the pipeline.
            let _ = self.frontend.packet(
                &mut self.pyramid,
                returns.iter().copied(),
                *starts,
                PacketActuator::still(angle),
            );
            return;
        }
        self.frontend.set_actuator(angle);
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

    fn observations(&self) -> u64 {
        u64::from(self.frontend.classifier_stats().observations)
    }

    fn dropped(&self) -> u64 {
        u64::from(self.frontend.classifier_stats().overflow_points)
    }

    fn snapshot(&self, sensor_xy: (f64, f64)) -> MapSnapshot {
        MapSnapshot::from_pyramid(&self.pyramid, &self.design, &self.config, sensor_xy)
    }

    fn layer_count(&self) -> usize {
        self.pyramid.layer_count()
    }

    fn layer_log_odds(&self, k: usize, x: f64, y: f64) -> Option<f32> {
        let layer = self.pyramid.layer(k)?;
        let r = layer.resolution();
        let cell = layer.get(
            r.cell_of(Meters::saturating_from_num(x)),
            r.cell_of(Meters::saturating_from_num(y)),
        )?;
        cell.log_odds().map(|v| v.to_num::<f32>())
    }

    fn cell_footprint(&self, k: u8, x: f64, y: f64) -> Option<Rect> {
        pyramid_cell(&self.pyramid, k, x, y)
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
