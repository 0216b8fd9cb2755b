//! The simulator's recordings, read back with the library: the recording reader, the SICK
//! telegram accumulator, the per-line pipeline and the default pyramid.

use terrain_pyramid::angle::Angle;
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::pipeline::{Frontend, FrontendConfig};
use terrain_pyramid::wire::recording::SetupEvent as Setup;
use terrain_pyramid::wire::recording::{MountKind, Payload, Reader};
use terrain_pyramid::wire::sick::{
    range_mm, MeasuredValues, MeasuringMode, SickAccumulator, SickItem, Unit,
};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Fused, Meters, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS,
};
use terrain_pyramid_host_tests::sim::laser::{
    angle_to_u16, u16_to_angle_deg, Actuator, Laser, LaserConfig, RETURN_FLAG,
};
use terrain_pyramid_host_tests::sim::record::{
    simulate, SimConfig, MARKER_DISTANCE, MARKER_DRIVE_START, MARKER_STOPPED,
};
use terrain_pyramid_host_tests::sim::scene::{FeatureKind, Scenario, Scene, StairsSpec};
use terrain_pyramid_host_tests::sim::trajectory::{self, Trajectory};

/// One decoded line: when, the actuator angle and pose in force, the values.
struct Line {
    time_us: u64,
    angle: u16,
    pose: [f32; 6],
    count: u16,
    unit: Unit,
    raw: Vec<u16>,
    values_le: Vec<u8>,
}

/// What reading a recording gave.
struct Decoded {
    setup: Setup,
    lines: Vec<Line>,
    markers: Vec<(u64, u32)>,
    laser_events: u32,
    pose_events: u32,
    rejected: u32,
}

/// Reads a recording with the library's reader and feeds its laser bytes through the
/// accumulator; every event must be valid and every candidate telegram good.
fn decode(bytes: &[u8]) -> Decoded {
    let mut setup = None;
    let mut lines = Vec::new();
    let mut markers = Vec::new();
    let (mut laser_events, mut pose_events, mut rejected) = (0, 0, 0);
    let mut angle = None;
    let mut pose = None;
    let mut acc: SickAccumulator = SickAccumulator::new();
    for event in Reader::new(bytes).unwrap() {
        let event = event.unwrap();
        match event.payload {
            Payload::Setup(s) => {
                assert!(setup.is_none(), "one setup");
                assert!(
                    lines.is_empty() && laser_events == 0,
                    "setup before laser bytes"
                );
                setup = Some(s);
            }
            Payload::Pose(p) => {
                pose = Some(p);
                pose_events += 1;
            }
            Payload::Angle(a) => angle = Some(a),
            Payload::Marker(m) => markers.push((event.time_us, m)),
            Payload::Laser(chunk) => {
                laser_events += 1;
                let mut chunk = chunk;
                loop {
                    match acc.feed(chunk) {
                        FeedResult::Consumed => break,
                        FeedResult::Item {
                            item: SickItem::Telegram(telegram),
                            remaining,
                            ..
                        } => {
                            let mv = MeasuredValues::parse(&telegram).unwrap();
                            lines.push(Line {
                                time_us: event.time_us,
                                angle: angle.expect("an angle before the first telegram"),
                                pose: pose.expect("a pose before the first telegram"),
                                count: mv.count(),
                                unit: mv.unit(),
                                raw: mv.raw_values().collect(),
                                values_le: mv.values_le().to_vec(),
                            });
                            chunk = remaining;
                        }
                        other => {
                            rejected += 1;
                            chunk = other.remaining();
                        }
                    }
                }
            }
            // The simulator's SICK recordings carry no sensor event.
            Payload::Sensor(e) => panic!("a sensor event in a SICK recording: {e:?}"),
            Payload::Rig(r) => panic!("a rig event in a preset SICK recording: {r:?}"),
            Payload::Unknown { kind, .. } => panic!("unknown event kind {kind}"),
        }
    }
    let stats = acc.stats();
    assert_eq!(stats.crc_errors + stats.length_errors + stats.truncated, 0);
    assert_eq!(stats.garbage_bytes, 0);
    Decoded {
        setup: setup.expect("a setup event"),
        lines,
        markers,
        laser_events,
        pose_events,
        rejected,
    }
}

fn frontend_config(setup: &Setup) -> FrontendConfig {
    terrain_pyramid::link::convert::frontend_config_of_event(setup, &ClassifierConfig::default())
        .unwrap()
}

/// Classifier slots of the test pipeline: 8 lines of 361 beams with room to spare.
const SLOTS: usize = 8192;

/// The default pyramid design (10 m, Δd = 0.1 m, γ = 2, soft gate) over the default window.
fn default_design() -> DefaultDesign {
    DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap()
}

/// A pyramid of the default design.
fn default_pyramid() -> Box<DefaultPyramid> {
    let design = default_design();
    let mut pyramid = Box::new(DefaultPyramid::new());
    pyramid.configure(&design, &Config::default()).unwrap();
    pyramid
}

/// Replays a decoded recording through the pipeline into `pyramid`, as a board would: the
/// pose and angle in force, then the line. Ends the last observation.
fn replay(decoded: &Decoded, pyramid: &mut DefaultPyramid) -> Box<Frontend<SLOTS, DEFAULT_LAYERS>> {
    let mut frontend = Box::new(Frontend::<SLOTS, DEFAULT_LAYERS>::new(frontend_config(
        &decoded.setup,
    )));
    frontend
        .adopt_design(&default_design(), &Config::default())
        .unwrap();
    for line in &decoded.lines {
        let [x, y, z, roll, pitch, yaw] = line.pose;
        frontend.set_pose(Pose::from_f32(x, y, z, roll, pitch, yaw).unwrap());
        frontend.set_actuator(FineAngle::from(Angle::from_bits(line.angle)));
        let mv = MeasuredValues::new(line.unit, 0, &line.values_le, None, 0).unwrap();
        frontend.line(pyramid, &mv).unwrap();
    }
    frontend.end_observation(pyramid);
    frontend
}

/// A short stairs run: stand 0.5 s, drive at 1 m/s to 3 m from the first riser.
fn short_stairs() -> SimConfig {
    SimConfig::paper_stairs(0.5, 1.0, 3.0)
}

#[test]
fn a_recording_decodes_with_the_reader_and_the_accumulator() {
    let config = short_stairs();
    let sim = simulate(&config).unwrap();
    let d = decode(&sim.bytes);
    assert_eq!(d.setup, config.setup());
    assert_eq!(d.setup.mount, MountKind::PannedVertical);
    assert_eq!((d.setup.field_deg, d.setup.resolution_cdeg), (180, 50));
    assert_eq!(d.setup.lines_per_observation, 8);
    assert_eq!(d.rejected, 0);
    // 2.55 s at 37.5 lines/s: ⌈95.6⌉ + 1 lines, one telegram each, 361 values in mm.
    assert_eq!(sim.lines, 97);
    assert_eq!(d.lines.len(), 97);
    assert!(d
        .lines
        .iter()
        .all(|l| l.count == 361 && l.unit == Unit::Millimetre));
    // Every 10th telegram came in two chunks.
    assert_eq!(d.laser_events, 97 + 9);
    assert_eq!(d.laser_events, sim.laser_events);
    assert_eq!(d.pose_events, sim.pose_events);
    // One pose while standing (lines 0 ..= 18), then one per line.
    assert_eq!(sim.pose_events, 1 + (97 - 19));
    assert_eq!(d.lines.last().unwrap().time_us, sim.duration_us);
    assert_eq!(sim.duration_us, 2_560_000);
    assert_eq!(d.markers, sim.markers);
    let ids: Vec<u32> = d.markers.iter().map(|m| m.1).collect();
    // From 5.05 m to 3.0 m: thresholds 5.0, 4.5, 4.0, 3.5, 3.0.
    assert_eq!(
        ids,
        [
            MARKER_DRIVE_START,
            MARKER_DISTANCE,
            MARKER_DISTANCE,
            MARKER_DISTANCE,
            MARKER_DISTANCE,
            MARKER_DISTANCE,
            MARKER_STOPPED
        ]
    );
    // Driving starts at 0.5 s: the first line at or after it is line 19, at 506 667 µs.
    assert_eq!(d.markers[0].0, 506_667);
}

#[test]
fn ranges_on_flat_ground_are_h_over_sin_depression() {
    let sigma = 0.01;
    for actuator in [Actuator::PAPER_PAN, Actuator::DEFAULT_TILT] {
        let laser = LaserConfig {
            actuator,
            sigma_m: sigma,
            ..LaserConfig::paper()
        };
        let config = SimConfig::new(Scene::flat(), laser, Trajectory::standing(1.0));
        let d = decode(&simulate(&config).unwrap().bytes);
        let h = 1.0;
        let mode = MeasuringMode::Mm8Cm80;
        let (mut returns, mut checked) = (0, 0);
        for line in &d.lines {
            let a = u16_to_angle_deg(line.angle).to_radians();
            for (k, &raw) in line.raw.iter().enumerate() {
                let theta = (k as f64 * 0.5).to_radians();
                // sin(depression): the beam's downward component.
                let down = match actuator {
                    Actuator::Pan { .. } => theta.cos(),
                    Actuator::Tilt { .. } => theta.sin() * a.sin(),
                };
                let range = range_mm(raw, mode, Unit::Millimetre);
                let expected = if down > 1e-9 { h / down } else { f64::INFINITY };
                if expected > 8.191 + 5.0 * sigma {
                    assert_eq!(range, None, "beam {k} at {a}: {expected} m");
                    continue;
                }
                if expected > 8.191 - 5.0 * sigma {
                    continue; // either side of the limit
                }
                let r = range.expect("a return") as f64 / 1000.0;
                returns += 1;
                assert_eq!(raw & 0xE000, RETURN_FLAG, "bit 13 set on a return");
                assert!(
                    (r - expected).abs() < 5.0 * sigma + 0.0005,
                    "beam {k}: {r} vs {expected}"
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
        assert_eq!(returns, checked);
    }
}

#[test]
fn a_noise_free_vertical_scan_over_the_stairs_gives_the_step_heights() {
    let spec = StairsSpec::default();
    let scene = Scene::stairs(spec);
    let mut laser = Laser::new(
        LaserConfig {
            sigma_m: 0.0,
            ..LaserConfig::paper()
        },
        7,
    );
    // 1.0 m from the first riser: the upper treads are seen at 8-10° below the horizon.
    let pose = trajectory::Pose {
        x: 4.05,
        ..trajectory::Pose::default()
    };
    let line = laser.scan(&scene, &pose, angle_to_u16(0.0));
    let bytes = laser.telegram(&line).unwrap();
    let mut acc: SickAccumulator = SickAccumulator::new();
    let FeedResult::Item {
        item: SickItem::Telegram(telegram),
        ..
    } = acc.feed(&bytes)
    else {
        panic!("one telegram");
    };
    let mv = MeasuredValues::parse(&telegram).unwrap();
    let points: Vec<(f64, f64)> = mv
        .ranges_mm(MeasuringMode::Mm8Cm80)
        .enumerate()
        .filter_map(|(k, r)| {
            let theta = (k as f64 * 0.5).to_radians();
            r.map(|mm| {
                let r = f64::from(mm) / 1000.0;
                (pose.x + r * theta.sin(), 1.0 - r * theta.cos())
            })
        })
        .collect();
    for k in 1..=spec.steps {
        // The last "tread" is the top landing, without end.
        let x0 = spec.riser_x(k - 1);
        let x1 = if k == spec.steps {
            f64::INFINITY
        } else {
            x0 + spec.run_m
        };
        let tread: Vec<f64> = points
            .iter()
            .filter(|p| p.0 > x0 + 0.02 && p.0 < x1 - 0.02)
            .map(|p| p.1)
            .collect();
        assert!(tread.len() >= 2, "step {k}: {} points", tread.len());
        let height = f64::from(k) * spec.rise_m;
        for z in &tread {
            assert!((z - height).abs() < 0.002, "step {k}: z {z} vs {height}");
        }
    }
    // Points between two tread heights lie on a riser's face.
    for &(x, z) in &points {
        let level = z / spec.rise_m;
        if (level - level.round()).abs() > 0.05 && z > 0.0 && z < spec.top_m() {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let riser = spec.riser_x(level.floor() as u32);
            assert!((x - riser).abs() < 0.002, "({x}, {z}) off riser {riser}");
        }
    }
}

#[test]
fn the_pyramid_marks_the_stairs_up_close() {
    // Stand 1 s, drive at 1 m/s to 1.0 m from the first riser (x = 4.05 m).
    let config = SimConfig::paper_stairs(1.0, 1.0, 1.0);
    let sim = simulate(&config).unwrap();
    let d = decode(&sim.bytes);
    let mut pyramid = default_pyramid();
    let frontend = replay(&d, &mut pyramid);
    let stats = frontend.stats();
    assert_eq!(stats.lines_applied, sim.lines);
    assert_eq!(stats.lines_rejected, 0);
    assert_eq!(frontend.classifier_stats().overflow_points, 0);
    // The riser cells straight ahead (|y| ≤ 0.5 m), 1.0 to 2.2 m from the robot.
    let cell = config.truth.cell_m;
    let risers: Vec<_> = sim
        .ground_truth
        .iter()
        .filter(|c| c.kind == FeatureKind::StepEdge)
        .filter(|c| {
            let (x, y) = c.centre(cell);
            x < 6.3 && y.abs() <= 0.5
        })
        .collect();
    assert_eq!(risers.len(), 5 * 10);
    let fused = |x: f64, y: f64| pyramid.fused(Meters::from_num(x), Meters::from_num(y));
    let marked = risers
        .iter()
        .filter(|c| {
            let (x, y) = c.centre(cell);
            matches!(fused(x, y), Fused::Obstacle { .. })
        })
        .count();
    let share = marked as f64 / risers.len() as f64;
    eprintln!(
        "riser cells marked obstacle at 1.0 m: {marked}/{}",
        risers.len()
    );
    assert!(share >= 0.8, "{marked} of {}", risers.len());
    // The flat ground between the robot and the stairs is navigable.
    let free = (0..10)
        .filter(|i| {
            let x = 4.2 + 0.07 * f64::from(*i);
            matches!(fused(x.min(4.95), 0.05), Fused::Navigable { .. })
        })
        .count();
    assert!(free >= 8, "{free}");
}

#[test]
fn the_same_seed_gives_the_same_bytes() {
    let a = simulate(&short_stairs()).unwrap();
    let b = simulate(&short_stairs()).unwrap();
    assert_eq!(a, b);
    let c = simulate(&SimConfig {
        seed: 2,
        ..short_stairs()
    })
    .unwrap();
    assert_eq!(a.bytes.len(), c.bytes.len());
    assert_ne!(a.bytes, c.bytes);
}

#[test]
fn every_scenario_and_mount_replays() {
    for scenario in Scenario::ALL {
        for laser in [LaserConfig::paper(), LaserConfig::tilted()] {
            let config = SimConfig::new(
                Scene::scenario(scenario),
                laser,
                Trajectory::approach(0.2, 2.0, 1.0, 0.0),
            );
            let sim = simulate(&config).unwrap();
            let d = decode(&sim.bytes);
            assert_eq!(d.lines.len() as u32, sim.lines, "{scenario:?}");
            let mut pyramid = default_pyramid();
            let frontend = replay(&d, &mut pyramid);
            let stats = frontend.stats();
            assert_eq!(stats.lines_rejected, 0, "{scenario:?}");
            assert!(stats.returns > 0, "{scenario:?}");
            assert!(stats.observations > 0, "{scenario:?}");
        }
    }
}

/// The simulator's beam times (its own reading of the mirror, `docs/lidars.md`) agree with the
/// library's `SickBeamTimes` to the microsecond, for every variant: a device given stamped
/// poses places each simulated beam at the pose it was cast from.
#[test]
fn beam_times_follow_the_mirror_as_the_library_does() {
    use terrain_pyramid::laser::SickBeamTimes;
    use terrain_pyramid::wire::sick::Variant;
    for variant in [
        Variant::Fov180Step1,
        Variant::Fov180StepHalf,
        Variant::Fov100Step1,
        Variant::Fov100StepHalf,
        Variant::Fov100StepQuarter,
    ] {
        let offsets = LaserConfig {
            variant,
            ..LaserConfig::paper()
        }
        .beam_offsets_s();
        assert_eq!(offsets.len(), variant.beam_count());
        let last = offsets.iter().copied().fold(0.0, f64::max);
        let times = SickBeamTimes::new(variant, None, offsets.len() - 1);
        for (k, o) in offsets.iter().enumerate() {
            let sim_us = (last - o) * 1e6;
            let lib_us = f64::from(times.before_last_us(k));
            assert!(
                (sim_us - lib_us).abs() <= 1.0,
                "{variant:?} beam {k}: {sim_us} vs {lib_us}"
            );
        }
    }
    // 0.5°: the odd beams a turn after the even ones; beam 359 (179.5°) 19.98 ms after beam 0.
    let half = LaserConfig::paper().beam_offsets_s();
    assert!((half[359] - (1.0 + 179.5 / 360.0) / 75.0).abs() < 1e-9);
    assert!((half[1] - half[0] - (1.0 + 0.5 / 360.0) / 75.0).abs() < 1e-9);
}

/// With beam times, a line's events are stamped with its telegram's arrival: the last beam's
/// time plus the telegram's bytes at 500 kBd.
#[test]
fn beam_timed_lines_are_stamped_at_their_arrival() {
    let config = SimConfig {
        beam_times: true,
        split_every: 0,
        ..short_stairs()
    };
    let sim = simulate(&config).unwrap();
    let rate = config.laser.line_rate_hz();
    let offsets = config.laser.beam_offsets_s();
    let last = offsets.iter().copied().fold(0.0, f64::max);
    let mut times = Vec::new();
    for event in Reader::new(&sim.bytes).unwrap() {
        let event = event.unwrap();
        if let Payload::Laser(bytes) = event.payload {
            times.push((event.time_us, bytes.len()));
        }
    }
    assert_eq!(times.len() as u32, sim.lines);
    for (i, (t_us, len)) in times.iter().enumerate() {
        let expected = (i as f64 / rate + last + 10.0 * *len as f64 / 500_000.0) * 1e6;
        assert!(
            (*t_us as f64 - expected).abs() <= 1.0,
            "line {i}: {t_us} vs {expected}"
        );
    }
}
