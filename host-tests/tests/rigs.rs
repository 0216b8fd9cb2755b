//! Lidars mounted as a robot has them, in the simulator, mapped through the library with the
//! mount the recording's rig event (version 3) gives the Setup's mount block (protocol
//! version 5), against the same lidar on its actuator's preset mount over the same scene,
//! trajectory and noise seed:
//! - an LD19 upside down with its 0° to the left (roll 180°, yaw 90°) on a nodding servo
//!   that reports its angle the other way round from a zero of 5°;
//! - an RPLIDAR (standard scan) standing with its 0° up (roll 90°, pitch −90°) panned about z.
//!
//! The simulator writes each sensor's bytes as that sensor sends them on that mount (its
//! angles its own) and the actuator's reported angles. Both mounts see the same rays, but at
//! other moments of the revolution (the upside-down LD19 turns the other way round, the
//! standing RPLIDAR's 0° is a quarter turn on) while the actuator moves, so their maps agree
//! in most cells, not in all: the tests hold the share of observed cells of the same class
//! (free, obstacle) above what was measured less a margin, a wrong mount far below it; each
//! rig's map as right as its preset's against the scene's truth (navigable cells mapped
//! navigable, obstacle cells mapped obstacle); and no return lost to a full scratch (`cargo test -p terrain-pyramid-host-tests --release --test
//! rigs -- --nocapture` prints the figures).

use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::geometry::Pose;
use terrain_pyramid::laser::{LaserDecoder, Sensor, SensorKind};
use terrain_pyramid::link::convert::{frontend_config, setup_message_with_sensor, setup_with_rig};
use terrain_pyramid::logodds::CellClass;
use terrain_pyramid::pipeline::{Frontend, PacketActuator};
use terrain_pyramid::wire::link::MountSetup;
use terrain_pyramid::wire::recording::{Payload, Reader, RigEvent};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE,
    DEFAULT_LAYERS,
};
use terrain_pyramid_host_tests::sim::lidar::{
    feed_packets, simulate_lidar, LidarActuator, LidarKind, LidarSimConfig, SimRig,
};
use terrain_pyramid_host_tests::sim::scene::{Scenario, Scene};
use terrain_pyramid_host_tests::sim::terrain::{cell_truth, Truth};
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

/// Classifier slots of the test pipeline (as the STM32F4's).
const SLOTS: usize = 1024;

/// What a run left: the pyramid and the classifier's overflow.
struct Mapped {
    /// The recording's rig event.
    rig: Option<RigEvent>,
    pyramid: Box<DefaultPyramid>,
    overflow_points: u32,
    points: u32,
}

fn design() -> DefaultDesign {
    DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .unwrap()
}

/// Maps a lidar recording as a co-processor would (as `pyramid run` plays it): the Setup of its
/// setup and sensor events with its rig event over it (unless `ignore_rig`), the pose and
/// angle in force, each packet at the angle of its chunk.
fn map(bytes: &[u8], ignore_rig: bool) -> Mapped {
    let mut pyramid = Box::new(DefaultPyramid::new());
    pyramid.configure(&design(), &Config::default()).unwrap();
    let mut frontend = Box::new(Frontend::<SLOTS, DEFAULT_LAYERS>::unconfigured());
    frontend
        .adopt_design(&design(), &Config::default())
        .unwrap();
    let mut setup_event = None;
    let mut rig = None;
    let mut sensor_event = None;
    let mut decoder: Option<Box<LaserDecoder>> = None;
    let mut angle = FineAngle::ZERO;
    for event in Reader::new(bytes).unwrap() {
        match event.unwrap().payload {
            Payload::Setup(s) => setup_event = Some(s),
            Payload::Sensor(s) => {
                let kind = SensorKind::from_code(s.sensor).unwrap();
                decoder = Some(Box::new(LaserDecoder::new(
                    Sensor::from_kind_and_mode(kind, s.mode).unwrap(),
                )));
                sensor_event = Some(s);
            }
            Payload::Rig(r) => rig = Some(r),
            Payload::Pose([x, y, z, roll, pitch, yaw]) => {
                frontend.set_pose(Pose::from_f32(x, y, z, roll, pitch, yaw).unwrap());
            }
            Payload::Angle(a) => angle = FineAngle::from_bits(u32::from(a) << 16),
            Payload::Laser(chunk) => {
                if !frontend.is_configured() {
                    let mut setup = setup_message_with_sensor(
                        &setup_event.unwrap(),
                        &sensor_event.unwrap(),
                        &ClassifierConfig::default(),
                    );
                    if let (Some(r), false) = (&rig, ignore_rig) {
                        setup = setup_with_rig(setup, r);
                    }
                    frontend.configure(frontend_config(&setup).unwrap());
                }
                feed_packets(decoder.as_mut().unwrap(), chunk, |p| {
                    let returns: Vec<_> = p.returns().collect();
                    frontend
                        .packet(
                            &mut pyramid,
                            returns,
                            p.starts_revolution(),
                            PacketActuator::still(angle),
                        )
                        .unwrap();
                });
            }
            _ => {}
        }
    }
    frontend.end_observation(&mut pyramid);
    let c = frontend.classifier_stats();
    Mapped {
        rig,
        pyramid,
        overflow_points: c.overflow_points,
        points: c.points,
    }
}

/// Over the cells observed in either map: the share of the same class and the share of
/// exactly equal cells, and how many.
fn agreement(a: &DefaultPyramid, b: &DefaultPyramid) -> (f64, f64, u32) {
    let (mut either, mut same_class, mut equal) = (0_u32, 0_u32, 0_u32);
    for k in 0..a.layer_count() {
        let (la, lb) = (a.layer(k).unwrap(), b.layer(k).unwrap());
        assert_eq!(
            la.origin(),
            lb.origin(),
            "layer {k}: the windows follow the robot"
        );
        for dy in 0..DEFAULT_CELLS_PER_SIDE {
            for dx in 0..DEFAULT_CELLS_PER_SIDE {
                let (ca, cb) = (la.at_offset(dx, dy).unwrap(), lb.at_offset(dx, dy).unwrap());
                if !(ca.is_observed() || cb.is_observed()) {
                    continue;
                }
                either += 1;
                same_class += u32::from(ca.class() == cb.class());
                equal += u32::from(ca == cb);
            }
        }
    }
    (
        f64::from(same_class) / f64::from(either),
        f64::from(equal) / f64::from(either),
        either,
    )
}

/// A map against the scene's truth (`cell_truth`, a robot 1 m tall), over the observed
/// cells of every layer at that layer's resolution: how many truly navigable cells were
/// observed and how many of them are mapped navigable; the same for the true obstacles.
#[derive(Debug, Clone, Copy, Default)]
struct TruthScore {
    navigable: u32,
    navigable_mapped: u32,
    obstacle: u32,
    obstacle_mapped: u32,
}

impl TruthScore {
    fn of(p: &DefaultPyramid, scene: &Scene) -> Self {
        let mut t = Self::default();
        for k in 0..p.layer_count() {
            let layer = p.layer(k).unwrap();
            let cell_m = layer.resolution().meters().to_num::<f64>();
            let (ox, oy) = layer.origin();
            for dy in 0..DEFAULT_CELLS_PER_SIDE {
                for dx in 0..DEFAULT_CELLS_PER_SIDE {
                    let cell = layer.at_offset(dx, dy).unwrap();
                    if !cell.is_observed() {
                        continue;
                    }
                    let (ix, iy) = (i64::from(ox) + dx as i64, i64::from(oy) + dy as i64);
                    match cell_truth(scene, cell_m, ix, iy, 1.0).truth() {
                        Truth::Navigable => {
                            t.navigable += 1;
                            t.navigable_mapped += u32::from(cell.class() == CellClass::Navigable);
                        }
                        Truth::Obstacle => {
                            t.obstacle += 1;
                            t.obstacle_mapped += u32::from(cell.class() == CellClass::Obstacle);
                        }
                        Truth::Between => {}
                    }
                }
            }
        }
        t
    }

    fn add(self, o: Self) -> Self {
        Self {
            navigable: self.navigable + o.navigable,
            navigable_mapped: self.navigable_mapped + o.navigable_mapped,
            obstacle: self.obstacle + o.obstacle,
            obstacle_mapped: self.obstacle_mapped + o.obstacle_mapped,
        }
    }

    /// The share of the truly navigable cells mapped navigable.
    fn navigable_share(&self) -> f64 {
        f64::from(self.navigable_mapped) / f64::from(self.navigable.max(1))
    }

    /// The share of the true obstacle cells mapped obstacle.
    fn obstacle_share(&self) -> f64 {
        f64::from(self.obstacle_mapped) / f64::from(self.obstacle.max(1))
    }
}

impl std::fmt::Display for TruthScore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "navigable {}/{} ({:.3}), obstacle {}/{} ({:.3})",
            self.navigable_mapped,
            self.navigable,
            self.navigable_share(),
            self.obstacle_mapped,
            self.obstacle,
            self.obstacle_share()
        )
    }
}

/// What one rig gave against its preset over one scene.
struct Compared {
    /// Same class, equal: the rig's map against the preset's.
    rig: (f64, f64),
    /// Against the scene's truth: the preset, the rig, the reseeded preset.
    truth: [TruthScore; 3],
    preset: Mapped,
    mounted: Mapped,
}

/// The figures of one rig against its preset over one scene, printed for the record.
fn compare(
    name: &str,
    scenario: Scenario,
    preset: &LidarSimConfig,
    rig: SimRig,
    block: MountSetup,
) -> Compared {
    let mounted = LidarSimConfig {
        rig: Some(rig),
        ..preset.clone()
    };
    let reseeded = LidarSimConfig {
        seed: preset.seed + 1,
        ..preset.clone()
    };
    let a = map(&simulate_lidar(preset).unwrap().bytes, false);
    let b = map(&simulate_lidar(&mounted).unwrap().bytes, false);
    let c = map(&simulate_lidar(&reseeded).unwrap().bytes, false);
    // The recording carries the rig (version 3), the preset's does not.
    assert_eq!(b.rig.map(|r| (r.mount, r.mount_block)), Some((2, block)));
    assert_eq!(a.rig, None);
    let (class, equal, cells) = agreement(&a.pyramid, &b.pyramid);
    let (base_class, base_equal, _) = agreement(&a.pyramid, &c.pyramid);
    let truth = [&a, &b, &c].map(|m| TruthScore::of(&m.pyramid, &preset.scene));
    println!(
        "{name} {scenario:?} against the truth: preset {}; rig {}; reseeded preset {}",
        truth[0], truth[1], truth[2]
    );
    println!(
        "{name} {scenario:?}: {cells} cells observed, same class {class:.4} (reseeded preset \
         {base_class:.4}), equal {equal:.4} ({base_equal:.4}); points {} / {}, overflow {} / {} \
         (preset / rig)",
        a.points, b.points, a.overflow_points, b.overflow_points
    );
    Compared {
        rig: (class, equal),
        truth,
        preset: a,
        mounted: b,
    }
}

/// The rig maps like the preset: at least `floor` of the observed cells of the same class,
/// and no return lost to a full scratch, for both.
fn holds(scenario: Scenario, c: &Compared, floor: f64) {
    let (class, _) = c.rig;
    assert!(class >= floor, "{scenario:?}: same class {class}");
    for m in [&c.preset, &c.mounted] {
        assert_eq!(
            m.overflow_points, 0,
            "{scenario:?}: overflow {} of {}",
            m.overflow_points, m.points
        );
    }
}

/// Over the three scenes, the rig's map is as right as the preset's against the scene's
/// truth: the share of the truly navigable cells mapped navigable at most 0.5 % below the
/// preset's, the share of the true obstacles mapped obstacle at most 5 % below (measured:
/// every truly navigable cell observed mapped navigable by both, but one RPLIDAR cell in
/// each map; obstacles, the LD19 upside down 72/156 against the preset's 50/157, the
/// RPLIDAR standing 78/115 against 74/125: each rig's sampling moments differ from its
/// preset's, and these short runs observe few obstacle cells).
fn as_right_as_the_preset(name: &str, compared: &[Compared]) {
    let total = |i: usize| {
        compared
            .iter()
            .fold(TruthScore::default(), |t, c| t.add(c.truth[i]))
    };
    let (preset, rig) = (total(0), total(1));
    println!("{name}, the three scenes against the truth: preset {preset}; rig {rig}");
    assert!(
        rig.navigable_share() >= preset.navigable_share() - 0.005,
        "{name}: navigable {rig} against {preset}"
    );
    assert!(
        rig.obstacle_share() >= preset.obstacle_share() - 0.05,
        "{name}: obstacles {rig} against {preset}"
    );
}

/// The least share of cells of the same class a rig's map and its preset's keep (measured:
/// 0.79 ..= 0.86 over the three scenes for both rigs; the same lidar turned 180° in yaw, the
/// same rays half a revolution later, 0.82; a reseeded preset run 0.95 ..= 0.99; the rig taken
/// for the preset 0.15).
const FLOOR: f64 = 0.75;

fn ld19_on_a_servo(scene: Scene) -> LidarSimConfig {
    let mut c = LidarSimConfig::new(
        scene,
        LidarKind::Ld19,
        LidarActuator::servo(2.0, 35.0, 20.0, 0.0),
        [0.1, 0.0, 0.6],
        Trajectory::approach(1.0, 0.5, 4.0, 2.0),
    );
    c.servo_lead_s = 0.5;
    c
}

fn rplidar_panned(scene: Scene) -> LidarSimConfig {
    LidarSimConfig::new(
        scene,
        LidarKind::RplidarStandard,
        LidarActuator::Pan {
            half_width_cdeg: 4_500,
            rate_cdeg_s: 3_000,
        },
        [0.1, 0.0, 0.6],
        Trajectory::approach(1.0, 0.5, 4.0, 2.0),
    )
}

/// The LD19 upside down, 0° to the left, on a servo reporting the other way from 5°.
#[test]
fn an_upside_down_ld19_on_a_servo_maps_like_the_preset() {
    let rig = SimRig {
        zero_deg: 5.0,
        reversed: true,
        ..SimRig::UPSIDE_DOWN_ZERO_LEFT
    };
    let block = MountSetup {
        axis: 1,
        sense: -1,
        zero_deg: 5.0,
        rpy_deg: [180.0, 0.0, 90.0],
    };
    let mut compared = Vec::new();
    for scenario in [Scenario::Stairs, Scenario::Gate, Scenario::Curb] {
        let preset = ld19_on_a_servo(Scene::scenario(scenario));
        let c = compare("ld19", scenario, &preset, rig, block);
        holds(scenario, &c, FLOOR);
        compared.push(c);
    }
    as_right_as_the_preset("ld19 upside down", &compared);
}

/// The RPLIDAR standing, 0° up, panned about z.
#[test]
fn a_standing_rplidar_panned_maps_like_the_preset() {
    let block = MountSetup {
        axis: 0,
        sense: 1,
        zero_deg: 0.0,
        rpy_deg: [90.0, -90.0, 0.0],
    };
    let mut compared = Vec::new();
    for scenario in [Scenario::Stairs, Scenario::Gate, Scenario::Curb] {
        let preset = rplidar_panned(Scene::scenario(scenario));
        let c = compare(
            "rplidar",
            scenario,
            &preset,
            SimRig::STANDING_ZERO_UP,
            block,
        );
        holds(scenario, &c, FLOOR);
        compared.push(c);
    }
    as_right_as_the_preset("rplidar standing", &compared);
}

/// The rig ignored (the upside-down LD19's bytes taken for the preset's) maps the scene
/// mirrored: the comparison above can fail.
#[test]
fn a_rig_taken_as_the_preset_does_not_map_like_it() {
    let preset = ld19_on_a_servo(Scene::scenario(Scenario::Stairs));
    let mounted = LidarSimConfig {
        rig: Some(SimRig::UPSIDE_DOWN_ZERO_LEFT),
        ..preset.clone()
    };
    let a = map(&simulate_lidar(&preset).unwrap().bytes, false);
    let b = map(&simulate_lidar(&mounted).unwrap().bytes, true);
    let (class, equal, _) = agreement(&a.pyramid, &b.pyramid);
    println!("ld19 taken as the preset: same class {class:.4}, equal {equal:.4}");
    assert!(class < 0.5, "same class {class}");
}

/// The preset's rotation and axis with another zero and sense: the same rays at the same
/// moments, the reported angles the other way round from 5°: the same map but for the
/// reported angles' rounding to 2⁻¹⁶ turn (measured: 99.83 % of the classes the same, two
/// cells of 1 187 whose lowest returns the rounding moved pair differently with a neighbour's
/// (`docs/core.md`, "The step between neighbouring cells' lowest returns"; every class the
/// same before it), and 99.33 % of the cells equal; the preset with another seed 98.16 %).
#[test]
fn a_reversed_servo_with_a_zero_maps_the_presets_map() {
    let rig = SimRig {
        rpy_deg: [0.0; 3],
        zero_deg: 5.0,
        reversed: true,
    };
    let block = MountSetup {
        axis: 1,
        sense: -1,
        zero_deg: 5.0,
        rpy_deg: [0.0; 3],
    };
    let preset = ld19_on_a_servo(Scene::scenario(Scenario::Stairs));
    let c = compare("ld19 reversed", Scenario::Stairs, &preset, rig, block);
    let (class, equal) = c.rig;
    assert!(class >= 0.995 && equal >= 0.99, "{class} {equal}");
}
