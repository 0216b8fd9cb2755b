//! `pyramid replay`: integrates a recorded 3-D point file (3DTK `uos` format) as ONE
//! observation, through the library's classifier and pyramid (the firmware's code), and writes
//! the maps (see [`crate::export`]) and a summary.
//!
//! # Frames
//! 3DTK's files are left-handed (x right, y up, z forward, centimetres). The project's frame is
//! right-handed (x forward, y left, z up, metres): `x = z_file/100, y = −x_file/100,
//! z = y_file/100`. A pose file's translation is converted the same way and added to every
//! point; its rotation must be zero (refused otherwise). `--sensor-origin-m` is the sensor's
//! position in the scan's own frame (project axes, metres; the scanner of a 3DTK scan sits at
//! 0,0,0); the pose moves it with the points.
//!
//! # The scanner's mount
//! `--mount-rpy-deg R,P,Y` turns the scan's own frame (converted as above) into the robot's:
//! roll, pitch, yaw in degrees (REP-103, as a URDF joint and `pyramid run`'s flag of the same
//! name), about the sensor's position. The points of a scanner mounted tilted or turned are
//! then where the robot sees them. A 3-D point file has no actuator to describe and no laser
//! returns to mask: `pyramid run`'s other rig flags do not apply, and the sensor's position
//! is `--sensor-origin-m` with `--height-m` above the ground.
//!
//! # One observation
//! The pyramid is recentred on the sensor's (x, y), then every point (but the scanner's
//! "no echo" value) goes to the classifier with its horizontal distance from the sensor and the
//! robot's ground plane `sensor z − --height-m`; the observation is then finished into the
//! pyramid.
//!
//! # The ground
//! The design's height (`--height-m`) sets its far cells (the paper's bound grows as 1/h) and
//! puts the classifier's ground plane below the sensor. Replay finds how far below the sensor
//! the scan's own ground lies ([`crate::ground_height`]: where the points 1–8 m away gather most
//! densely in depth), reports it as the summary's `ground_found_m`, and warns (stderr and the
//! summary's `warnings`) when `--height-m` lies more than
//! [`crate::ground_height::TOLERANCE_M`] from it. The maps are made with `--height-m` all the
//! same.
//!
//! # The order of the points
//! The classifier's pair test compares each return with the one before it in the same cell
//! (`docs/core.md`, "Why the pair test"): a far kerb's face shows where two beams' returns at
//! one azimuth stand on each other, and they follow each other only when the points come as
//! a spinning laser fires them. `--order file` gives the points in the file's order.
//! `--order firing` sorts them first by their azimuth about the sensor in steps of the
//! design's ψ (`--psi-deg`), from −180°, and within one step by elevation from the lowest up
//! (a stable sort: equal keys keep the file's order): for a spinning multi-beam laser's file
//! held beam by beam (a whole revolution of one beam, then the next). The default, `--order
//! auto`, sorts when the file holds such revolutions ([`held_beam_by_beam`]: a quarter of the
//! points in runs of one elevation that turn 270° or more) and keeps the file's order
//! otherwise; the summary's `order` says which. In firing order the plane rule's pair test pairs
//! each return with the last three of its cell
//! ([`FIRING_ORDER_PAIR_DEPTH`](terrain_pyramid::classify::FIRING_ORDER_PAIR_DEPTH): between a
//! return and its neighbour along the ring come the other beams' returns of the same azimuth step;
//! `docs/core.md`, "How far back the pair test looks"), unless `--pair-depth` says otherwise;
//! the summary's `rule` says `pairs 3 back`. Not for a scanner whose
//! lines already sweep the scene in order, such as a tilting 2-D laser: the classifier keeps a
//! cell's points below its overhang cut as they come, and a point far below those before it
//! restarts the cell's plane from the best bound still known, which in firing order happens
//! at every azimuth step on a wall (`docs/core.md`, "The navigability rule"; measured on the
//! 3DTK scan: 89.6 % of the obstacle returns marked against 100.0 % in the file's order).
use crate::design;
use crate::export::{self, MapSnapshot, MapSummary};
use crate::ground_height::{self, GroundDepths};
use crate::pyramid_args::PyramidArgs;
use crate::rule;
use crate::summary_args::SummaryArgs;
use crate::uos::{self, UosReader};
use serde::Serialize;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;
use terrain_pyramid::classify::{Classifier, ClassifierConfig, ClassifierStats};
use terrain_pyramid::{Config, Design, Meters, Point3, Pyramid, PyramidStats};

/// The layer capacity: the design's.
const L: usize = design::LAYER_CAPACITY;

/// The classifier's scratch slots: a whole 3-D sweep touches up to a window's worth of cells
/// per layer it feeds.
pub const CLASSIFIER_SLOTS: usize = 65_536;

/// The stack of the thread that runs the replay: the classifier's scratch (about 1.4 MB) and
/// the pyramid are built in place on it before they are boxed.
const STACK_BYTES: usize = 64 << 20;

/// The SICK's "no echo" range is 3276.7 cm (32767 mm). In the 3DTK file those returns sit
/// between 3275.9 and 3276.7 cm from the origin (the tilt axis is not exactly at the mirror),
/// and no real return of that scanner comes near them, so a point from 3270 cm up to
/// [`NO_ECHO_END_CM`] from the sensor is taken as "no echo" and is not a point.
pub const NO_ECHO_CM: f64 = 3270.0;

/// The end of the "no echo" band, cm (exclusive): a point farther than this is a real return
/// of a longer-ranged laser (a Velodyne reaches 120 m), counted beyond the max range when it
/// is, never as "no echo".
pub const NO_ECHO_END_CM: f64 = 3280.0;

/// The windows, cells per side, that `replay` is compiled for (the pyramid's `W` is a const
/// generic); `--cells` must be one of them.
pub const SUPPORTED_CELLS: [usize; 5] = [32, 64, 128, 256, 512];

/// Arguments of `pyramid replay`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The point file, 3DTK `uos` format (`x y z` in cm per line, optional `W x H` header).
    #[arg(long, value_name = "FILE.3d")]
    pub points: PathBuf,
    /// The scan's pose file (translation x y z in cm, rotation rx ry rz in degrees; the
    /// rotation must be zero).
    #[arg(long, value_name = "FILE.pose")]
    pub pose: Option<PathBuf>,
    /// The sensor's position in the scan's own frame, converted (x forward, y left, z up),
    /// metres; the pose moves it with the points. Ranges ("no echo") are measured from it.
    #[arg(
        long,
        value_name = "X,Y,Z",
        default_value = "0,0,0",
        allow_hyphen_values = true
    )]
    pub sensor_origin_m: Xyz,
    /// The order in which the points reach the classifier: `auto` (the default: `firing` when
    /// the file holds a spinning laser's revolutions beam by beam, else `file`), `file`, or
    /// `firing` (sorted by azimuth in steps of ψ, then by elevation from the bottom, as a
    /// spinning laser fires them: for a multi-beam laser's file held beam by beam).
    #[arg(long, value_enum, default_value_t = PointOrder::Auto)]
    pub order: PointOrder,
    /// The scan's frame relative to the robot's: roll, pitch, yaw in degrees (REP-103,
    /// each within ±360), the points turned about the sensor's position; `0,0,0` by default.
    #[arg(long, value_name = "R,P,Y", allow_hyphen_values = true)]
    pub mount_rpy_deg: Option<Xyz>,
    /// The output directory, and whether the summary is also printed.
    #[command(flatten)]
    pub summary: SummaryArgs,
    /// The design, the clamping and the classifier.
    #[command(flatten)]
    pub pyramid: PyramidArgs,
}

/// The order in which `replay` gives the points to the classifier (see the module
/// documentation).
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PointOrder {
    /// The firing order when the file holds a spinning laser's returns beam by beam
    /// ([`held_beam_by_beam`]), else the file's (the default).
    #[default]
    Auto,
    /// As the file holds them.
    File,
    /// By azimuth about the sensor in steps of the design's ψ, then by elevation from the
    /// bottom: as a spinning laser fires them.
    Firing,
}

impl PointOrder {
    /// Its name on the command line and in the summary.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::File => "file",
            Self::Firing => "firing",
        }
    }
}

/// The azimuth a run of one beam sweeps, at least, for [`held_beam_by_beam`]: 270°, radians.
const BEAM_RUN_SWEEP_RAD: f64 = 1.5 * std::f64::consts::PI;
/// The largest turn in azimuth between two consecutive returns of one beam's run: 30°, radians
/// (a beam's gaps where nothing answered, the sky, are shorter).
const BEAM_RUN_TURN_RAD: f64 = std::f64::consts::PI / 6.0;
/// The largest change of elevation between two consecutive returns of one beam's run: 2°,
/// radians (a beam's emitter sits a few centimetres off the sensor's origin, so its returns'
/// elevation seen from the origin moves with their range).
const BEAM_RUN_ELEVATION_RAD: f64 = std::f64::consts::PI / 90.0;

/// Whether points (their offsets from the sensor, metres, in the file's order) are a spinning
/// laser's returns held beam by beam (a whole revolution of one beam, then the next): at least
/// a quarter of them lie in runs that turn 270° or more in azimuth, each step of a run turning
/// by at most 30° and changing the elevation by at most 2°. A spinning laser's file in firing
/// order (a column of beams at one azimuth, then the next) has no such run (its columns end
/// in a jump of elevation), nor has a tilting or panning 2-D laser's (a line sweeps 180° at
/// most). False for no points.
#[must_use]
pub fn held_beam_by_beam(offsets: impl IntoIterator<Item = [f64; 3]>) -> bool {
    let (mut total, mut in_runs) = (0_usize, 0_usize);
    // The previous point's azimuth and elevation, the run's signed sweep and its points.
    let mut previous: Option<(f64, f64)> = None;
    let (mut sweep, mut run) = (0.0_f64, 0_usize);
    for o in offsets {
        let (azimuth, elevation) = azimuth_elevation(o);
        total += 1;
        let step = previous.map(|(a, e)| {
            let turn = (azimuth - a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            (turn, (elevation - e).abs())
        });
        match step {
            Some((turn, rise))
                if turn.abs() <= BEAM_RUN_TURN_RAD && rise <= BEAM_RUN_ELEVATION_RAD =>
            {
                sweep += turn;
                run += 1;
            }
            _ => {
                if sweep.abs() >= BEAM_RUN_SWEEP_RAD {
                    in_runs += run;
                }
                sweep = 0.0;
                run = 1;
            }
        }
        previous = Some((azimuth, elevation));
    }
    if sweep.abs() >= BEAM_RUN_SWEEP_RAD {
        in_runs += run;
    }
    total > 0 && in_runs * 4 >= total
}

/// The firing order's key of a point at `offset` (metres) from the sensor: its azimuth step
/// (of `psi_rad` > 0, counted from −π) and its elevation (radians; the lowest first).
#[must_use]
pub fn firing_key(offset: [f64; 3], psi_rad: f64) -> (i64, f64) {
    let (azimuth, elevation) = azimuth_elevation(offset);
    // At most 2π / ψ steps: the cast saturates only for a ψ below 1e-18 rad.
    #[allow(clippy::cast_possible_truncation)]
    let step = ((azimuth + std::f64::consts::PI) / psi_rad).floor() as i64;
    (step, elevation)
}

/// The azimuth (−π ..= π, from x towards y) and elevation (radians) of a point at `offset`
/// (metres) from the sensor.
fn azimuth_elevation(offset: [f64; 3]) -> (f64, f64) {
    (
        offset[1].atan2(offset[0]),
        offset[2].atan2(offset[0].hypot(offset[1])),
    )
}

/// Three comma-separated numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xyz(pub [f64; 3]);

impl FromStr for Xyz {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let [x, y, z] = parts.as_slice() else {
            return Err(format!("expected three numbers X,Y,Z, got {s:?}"));
        };
        let mut out = [0.0; 3];
        for (slot, text) in out.iter_mut().zip([x, y, z]) {
            let v: f64 = text
                .parse()
                .map_err(|_| format!("{text:?} is not a number"))?;
            if !v.is_finite() {
                return Err(format!("{text:?} is not a finite number"));
            }
            *slot = v;
        }
        Ok(Self(out))
    }
}

/// A 3DTK vector (cm, left-handed: x right, y up, z forward) in the project's frame (m,
/// right-handed: x forward, y left, z up).
#[must_use]
pub fn from_3dtk_cm([x, y, z]: [f64; 3]) -> [f64; 3] {
    [z / 100.0, -x / 100.0, y / 100.0]
}

/// The inverse of [`from_3dtk_cm`].
#[must_use]
pub fn to_3dtk_cm([x, y, z]: [f64; 3]) -> [f64; 3] {
    [-y * 100.0, z * 100.0, x * 100.0]
}

/// Metres to the library's fixed point, saturating.
fn meters(v: f64) -> Meters {
    Meters::saturating_from_num(v)
}

fn point3([x, y, z]: [f64; 3]) -> Point3 {
    Point3 {
        x: meters(x),
        y: meters(y),
        z: meters(z),
    }
}

/// The horizontal distance from the sensor to a point, metres.
///
/// The horizontal distance from the sensor to a point, as the firmware computes it
/// ([`terrain_pyramid::geometry::horizontal_distance`]), so replay gates exactly as the device.
#[must_use]
pub fn horizontal_distance(sensor: Point3, point: Point3) -> Meters {
    terrain_pyramid::geometry::horizontal_distance(sensor, point)
}

/// The summary of a replay: what `summary.json` holds and `--json` prints.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Summary {
    /// Point lines read.
    pub points_read: u64,
    /// Points that fed at least one layer cell (the classifier's count).
    pub points_used: u64,
    /// Points that were the SICK's "no echo" value (3270 ..< 3280 cm from the sensor,
    /// [`NO_ECHO_CM`]); a farther point is a return.
    pub no_return: u64,
    /// Per layer: counts of the cells of its window.
    pub layers: Vec<export::LayerSummary>,
    /// The fused map's counts.
    pub fused: export::FusedSummary,
    /// Point-to-cell additions dropped because the classifier's scratch was full.
    pub overflow_points: u64,
    /// Points that fed no layer (every gate zero at their distance).
    pub points_gated_out: u64,
    /// Points farther (horizontally) from the sensor than the maximum range; they are still
    /// given to the classifier, whose gates decide.
    pub points_beyond_max_range: u64,
    /// Evidence records the observation produced.
    pub records: u64,
    /// Records that changed a cell.
    pub records_applied: u64,
    /// Records outside their layer's window (dropped by the pyramid).
    pub records_outside_window: u64,
    /// The sensor's position, metres (project frame, after the pose).
    pub sensor_m: [f64; 3],
    /// The robot's ground plane given to the classifier, metres.
    pub ground_z_m: f64,
    /// How far below the sensor the scan's ground lies, metres, found in the points themselves
    /// ([`ground_height::GroundDepths::found_m`]: where the points 1–8 m away gather most
    /// densely in depth); `null` when too few points lie there.
    pub ground_found_m: Option<f64>,
    /// What the run noticed that the user may want to change, one sentence each (also printed
    /// on stderr, `warning: ` first): the scan's ground more than
    /// [`ground_height::TOLERANCE_M`] from `--height-m`.
    pub warnings: Vec<String>,
    /// The navigability rule in force and its parameters ([`rule::describe`]).
    pub rule: String,
    /// The order in which the points reached the classifier: `firing` or `file`.
    pub order: &'static str,
    /// The order asked for (`--order`): `auto` (the default: `firing` for a spinning laser's
    /// file held beam by beam, else `file`), `file` or `firing`.
    pub order_asked: &'static str,
    /// The files written.
    pub files: Vec<String>,
}

/// What went wrong, and the exit status it gives.
#[derive(Debug)]
pub struct Failure {
    /// 1 for input and output problems, 2 for a refused configuration.
    pub code: u8,
    /// One line, without the `error: ` prefix.
    pub message: String,
}

impl Failure {
    fn input(message: String) -> Self {
        Self { code: 1, message }
    }

    fn config(message: String) -> Self {
        Self { code: 2, message }
    }
}

/// An unreadable input file, said clearly (the real data lives outside the project).
fn unreadable(what: &str, path: &Path, e: &std::io::Error) -> Failure {
    let hint = if e.kind() == std::io::ErrorKind::NotFound {
        " (file not found; the recorded data lives in ../shared/data/ and is never copied into the project)"
    } else {
        ""
    };
    Failure::input(format!(
        "cannot read the {what} {}: {e}{hint}",
        path.display()
    ))
}

/// No rotation.
const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation of roll, pitch, yaw (degrees, REP-103: `Rz(yaw)·Ry(pitch)·Rx(roll)`),
/// row-major.
#[must_use]
pub fn rotation_of_rpy_deg(rpy_deg: [f64; 3]) -> [[f64; 3]; 3] {
    let [(sr, cr), (sp, cp), (sy, cy)] = rpy_deg.map(|a| a.to_radians().sin_cos());
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// `point` (the scan's converted frame, metres) turned by `rotation` about `origin`.
fn mounted(rotation: &[[f64; 3]; 3], origin: [f64; 3], point: [f64; 3]) -> [f64; 3] {
    let d = [
        point[0] - origin[0],
        point[1] - origin[1],
        point[2] - origin[2],
    ];
    let r = rotation.map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2]);
    [r[0] + origin[0], r[1] + origin[1], r[2] + origin[2]]
}

/// The validated inputs of one replay, read before any work is done.
struct Plan {
    design: Design<L>,
    config: Config,
    classifier: ClassifierConfig,
    /// The pose's translation, metres, project frame.
    translation: [f64; 3],
    /// The sensor, project frame, metres (after the pose).
    sensor: [f64; 3],
    /// The sensor in the file's own frame, cm (for the "no echo" test).
    sensor_file_cm: [f64; 3],
    /// The sensor in the scan's converted frame, before the pose, metres.
    origin: [f64; 3],
    /// The scan's frame in the robot's (`--mount-rpy-deg`), row-major.
    rotation: [[f64; 3]; 3],
    ground_z: f64,
}

fn plan(args: &Args) -> Result<Plan, Failure> {
    let design = design::build(&args.pyramid.design).map_err(|e| Failure::config(e.to_string()))?;
    if !SUPPORTED_CELLS.contains(&design.cells_per_side()) {
        return Err(Failure::config(format!(
            "--cells: replay is compiled for windows of {SUPPORTED_CELLS:?} cells per side (got {})",
            design.cells_per_side()
        )));
    }
    let config = Config {
        clamp: args.pyramid.clamp(),
        model: args.pyramid.model().map_err(Failure::config)?,
        ..Config::default()
    };
    let translation = match &args.pose {
        None => [0.0; 3],
        Some(path) => {
            let text =
                std::fs::read_to_string(path).map_err(|e| unreadable("pose file", path, &e))?;
            let pose = uos::parse_pose(&text)
                .map_err(|e| Failure::input(format!("{}: {e}", path.display())))?;
            if pose.rotation_deg.iter().any(|&r| r != 0.0) {
                return Err(Failure::input(format!(
                    "{}: line 2: the rotation {:?} degrees is not zero; replay applies only a translation",
                    path.display(),
                    pose.rotation_deg
                )));
            }
            from_3dtk_cm(pose.translation_cm)
        }
    };
    let origin = args.sensor_origin_m.0;
    let rotation = match args.mount_rpy_deg {
        None => IDENTITY,
        Some(Xyz(rpy)) => {
            if let Some(v) = rpy.iter().find(|v| v.abs() > 360.0) {
                return Err(Failure::config(format!(
                    "--mount-rpy-deg: {v} degrees is outside -360 ..= 360"
                )));
            }
            rotation_of_rpy_deg(rpy)
        }
    };
    let sensor = [
        origin[0] + translation[0],
        origin[1] + translation[1],
        origin[2] + translation[2],
    ];
    let classifier = args.pyramid.classifier().map_err(Failure::config)?;
    Ok(Plan {
        design,
        config,
        classifier,
        translation,
        sensor,
        sensor_file_cm: to_3dtk_cm(origin),
        origin,
        rotation,
        ground_z: sensor[2] - args.pyramid.design.height_m,
    })
}

/// What integrating the point file gave.
struct Integrated {
    snapshot: MapSnapshot,
    points_read: u64,
    no_return: u64,
    beyond_max_range: u64,
    classifier: ClassifierStats,
    pyramid: PyramidStats,
    /// The order the points reached the classifier in (`File` or `Firing`).
    order: PointOrder,
    /// The classifier's configuration the points met ([`for_order`]).
    classifier_config: ClassifierConfig,
    /// The points' depths below the sensor, for the ground's.
    depths: GroundDepths,
}

/// Reads the point file into one observation of a `Pyramid<W, L>`.
fn integrate<const W: usize>(args: &Args, plan: &Plan) -> Result<Integrated, Failure> {
    let file = File::open(&args.points).map_err(|e| unreadable("point file", &args.points, &e))?;
    let mut pyramid: Box<Pyramid<W, L>> = Box::new(Pyramid::new());
    pyramid
        .configure(&plan.design, &plan.config)
        .map_err(|e| Failure::config(e.to_string()))?;
    let mut classifier: Box<Classifier<CLASSIFIER_SLOTS, L>> = Box::new(Classifier::new());
    classifier.configure(plan.classifier);
    let increments = plan
        .config
        .model
        .increments()
        .map_err(|e| Failure::config(e.to_string()))?;
    classifier
        .adopt_design(&plan.design, increments)
        .map_err(|e| Failure::config(e.to_string()))?;
    let sensor = point3(plan.sensor);
    pyramid.recentre(sensor.x, sensor.y);
    classifier.begin(sensor.z);
    let ground_z = meters(plan.ground_z);
    let max_range = f64::from(plan.design.sensor().max_range_m);
    let (mut no_return, mut beyond) = (0_u64, 0_u64);
    let mut depths = GroundDepths::new();
    let mut reader = UosReader::new(BufReader::new(file));
    // One point in the robot's frame (metres) to the classifier.
    let mut add = |classifier: &mut Classifier<CLASSIFIER_SLOTS, L>, world: [f64; 3]| {
        let below = plan.sensor[2] - world[2];
        let world = point3(world);
        let distance = horizontal_distance(sensor, world);
        let distance_m = distance.to_num::<f64>();
        depths.add(below, distance_m);
        if distance_m > max_range {
            beyond += 1;
        }
        classifier.add_point(world, distance, ground_z);
    };
    // Unless the file's order is asked for, the points and their offsets from the sensor,
    // held until the file ends.
    let mut held: Vec<([f64; 3], [f64; 3])> = Vec::new();
    let psi = f64::from(plan.design.sensor().psi_rad).max(1e-9);
    for point in reader.by_ref() {
        let p = point.map_err(|e| Failure::input(format!("{}: {e}", args.points.display())))?;
        let raw = [p.x, p.y, p.z];
        let s = plan.sensor_file_cm;
        let range_cm = (raw[0] - s[0]).hypot(raw[1] - s[1]).hypot(raw[2] - s[2]);
        if (NO_ECHO_CM..NO_ECHO_END_CM).contains(&range_cm) {
            no_return += 1;
            continue;
        }
        let local = mounted(&plan.rotation, plan.origin, from_3dtk_cm(raw));
        let world = [
            local[0] + plan.translation[0],
            local[1] + plan.translation[1],
            local[2] + plan.translation[2],
        ];
        if args.order == PointOrder::File {
            add(&mut classifier, world);
        } else {
            let offset = [
                world[0] - plan.sensor[0],
                world[1] - plan.sensor[1],
                world[2] - plan.sensor[2],
            ];
            held.push((world, offset));
        }
    }
    let order = match args.order {
        PointOrder::Auto if held_beam_by_beam(held.iter().map(|h| h.1)) => PointOrder::Firing,
        PointOrder::Auto => PointOrder::File,
        given => given,
    };
    let classifier_config = for_order(plan.classifier, order, args.pyramid.rule.pair_depth);
    if classifier_config != plan.classifier {
        // No point has reached the classifier yet: they are held until the order is known.
        classifier.configure(classifier_config);
        classifier.begin(sensor.z);
    }
    if order == PointOrder::Firing {
        let mut firing: Vec<([f64; 3], (i64, f64))> = held
            .drain(..)
            .map(|(world, offset)| (world, firing_key(offset, psi)))
            .collect();
        firing.sort_by(|a, b| a.1 .0.cmp(&b.1 .0).then(a.1 .1.total_cmp(&b.1 .1)));
        for (world, _) in firing {
            add(&mut classifier, world);
        }
    } else {
        for (world, _) in held {
            add(&mut classifier, world);
        }
    }
    classifier.finish_into(&mut pyramid);
    let snapshot = MapSnapshot::from_pyramid(
        &pyramid,
        &plan.design,
        &plan.config,
        (plan.sensor[0], plan.sensor[1]),
    );
    Ok(Integrated {
        snapshot,
        points_read: u64::try_from(reader.points_read()).unwrap_or(u64::MAX),
        no_return,
        beyond_max_range: beyond,
        classifier: classifier.stats(),
        pyramid: pyramid.stats(),
        order,
        classifier_config,
        depths,
    })
}

/// The classifier's configuration for points given in `order`: under the plane rule, a
/// spinning laser's points in firing order are paired with the last
/// [`FIRING_ORDER_PAIR_DEPTH`](terrain_pyramid::classify::FIRING_ORDER_PAIR_DEPTH) returns of
/// their cell
/// ([`NavigabilityRule::for_firing_order`](terrain_pyramid::classify::NavigabilityRule::for_firing_order);
/// `docs/core.md`, "How far back the pair test looks") unless `--pair-depth` (`pair_depth_flag`) says otherwise; `config` as it is
/// for the file's order.
#[must_use]
pub fn for_order(
    config: ClassifierConfig,
    order: PointOrder,
    pair_depth_flag: Option<i64>,
) -> ClassifierConfig {
    if order == PointOrder::Firing && pair_depth_flag.is_none() {
        ClassifierConfig {
            rule: config.rule.for_firing_order(),
            ..config
        }
    } else {
        config
    }
}

/// Integrates with the window the design asks for.
fn integrate_any(args: &Args, plan: &Plan) -> Result<Integrated, Failure> {
    match plan.design.cells_per_side() {
        32 => integrate::<32>(args, plan),
        64 => integrate::<64>(args, plan),
        128 => integrate::<128>(args, plan),
        256 => integrate::<256>(args, plan),
        512 => integrate::<512>(args, plan),
        other => Err(Failure::config(format!(
            "--cells: replay is compiled for windows of {SUPPORTED_CELLS:?} cells per side (got {other})"
        ))),
    }
}

/// The whole command, on the current thread.
///
/// # Errors
/// The failure, with its exit status.
pub fn replay(args: &Args) -> Result<Summary, Failure> {
    let plan = plan(args)?;
    let run = integrate_any(args, &plan)?;
    let title = format!(
        "pyramid replay: {} ({} points, one observation)",
        args.points.file_name().map_or_else(
            || args.points.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        ),
        run.points_read
    );
    let written =
        export::write_maps(&args.summary.out, &run.snapshot, &title).map_err(Failure::input)?;
    let MapSummary { layers, fused } = written.summary;
    let c = run.classifier;
    let ground_found_m = run.depths.found_m();
    let warnings: Vec<String> = ground_found_m
        .and_then(|found| ground_height::disagreement(found, args.pyramid.design.height_m))
        .into_iter()
        .collect();
    let mut summary = Summary {
        points_read: run.points_read,
        points_used: u64::from(c.points_used),
        no_return: run.no_return,
        layers,
        fused,
        overflow_points: u64::from(c.overflow_points),
        points_gated_out: u64::from(c.points_gated_out),
        points_beyond_max_range: run.beyond_max_range,
        records: u64::from(c.records),
        records_applied: u64::from(run.pyramid.applied),
        records_outside_window: u64::from(run.pyramid.outside_window),
        sensor_m: plan.sensor,
        ground_z_m: plan.ground_z,
        ground_found_m,
        warnings,
        rule: rule::describe(&run.classifier_config),
        order: run.order.name(),
        order_asked: args.order.name(),
        files: written
            .files
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect(),
    };
    summary.files.push("summary.json".to_string());
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| Failure::input(format!("cannot encode the summary as JSON: {e}")))?;
    export::write_file(
        &args.summary.out.join("summary.json"),
        format!("{json}\n").as_bytes(),
    )
    .map_err(Failure::input)?;
    Ok(summary)
}

/// The human-readable lines printed without `--json`.
fn table(args: &Args, s: &Summary) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {} points read, {} used, {} no echo, {} beyond the max range; {} classifier overflow",
        args.points.display(),
        s.points_read,
        s.points_used,
        s.no_return,
        s.points_beyond_max_range,
        s.overflow_points
    );
    let _ = writeln!(out, "  layer  resolution   observed  obstacle      free");
    for l in &s.layers {
        let _ = writeln!(
            out,
            "  {:>5}  {:>8.3} m  {:>9}  {:>8}  {:>8}",
            l.index, l.resolution_m, l.observed_cells, l.obstacle_cells, l.free_cells
        );
    }
    let _ = writeln!(
        out,
        "  fused  {:>8.3} m  {:>9}  {:>8}  {:>8}   ({} x {} cells)",
        s.fused.resolution_m,
        s.fused.observed_cells,
        s.fused.obstacle_cells,
        s.fused.free_cells,
        s.fused.width,
        s.fused.height
    );
    if let Some(found) = s.ground_found_m {
        let _ = writeln!(
            out,
            "  ground {found:.2} m below the sensor in the scan; the design's ground plane {:.2} m below",
            args.pyramid.design.height_m
        );
    }
    let _ = writeln!(
        out,
        "Wrote {} files into {}",
        s.files.len(),
        args.summary.out.display()
    );
    out
}

/// Runs `pyramid replay` on a thread with a large stack.
///
/// Exit status: 0 on success; 1 when a file is missing, unreadable or malformed (one line on
/// stderr naming it, and the line number), or an output cannot be written; 2 for a refused
/// configuration, as `pyramid design`.
pub fn run(args: &Args) -> ExitCode {
    let owned = args.clone();
    let worker = std::thread::Builder::new()
        .name("replay".to_string())
        .stack_size(STACK_BYTES)
        .spawn(move || replay(&owned));
    let result = match worker {
        Ok(handle) => handle
            .join()
            .unwrap_or_else(|_| Err(Failure::input("the replay thread panicked".to_string()))),
        Err(e) => Err(Failure::input(format!(
            "cannot start the replay thread: {e}"
        ))),
    };
    match result {
        Ok(summary) => {
            for warning in &summary.warnings {
                eprintln!("warning: {warning}");
            }
            if args.summary.json {
                if !crate::json_line::print(&summary, "error: cannot encode the summary as JSON: ")
                {
                    return ExitCode::FAILURE;
                }
            } else {
                crate::out!("{}", table(args, &summary));
            }
            ExitCode::SUCCESS
        }
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::classify::NavigabilityRule;

    /// A 16-beam laser 1 m up (beams every 2° from −15°), 0.5° azimuth steps, every beam
    /// meeting flat ground or a wall 8 m away, with 20° of sky in the upper beams: offsets
    /// beam by beam.
    fn ring_laser_beam_by_beam() -> Vec<[f64; 3]> {
        let mut points = Vec::new();
        for k in 0..16 {
            let a = (-15.0 + 2.0 * f64::from(k)).to_radians();
            for j in 0..720 {
                let th = (0.5 * f64::from(j)).to_radians();
                if k >= 8 && (100..140).contains(&j) {
                    continue;
                }
                let range = if a < -0.125 {
                    (1.0 / -a.tan()).min(8.0)
                } else {
                    8.0
                };
                let r = range / a.cos().max(1e-9);
                points.push([r * a.cos() * th.cos(), r * a.cos() * th.sin(), r * a.sin()]);
            }
        }
        points
    }

    #[test]
    fn a_spinning_laser_held_beam_by_beam_is_told_from_other_orders() {
        let beam_by_beam = ring_laser_beam_by_beam();
        assert!(held_beam_by_beam(beam_by_beam.iter().copied()));
        // The same returns as the laser fires them: columns of beams, one azimuth after another.
        let mut firing = beam_by_beam.clone();
        firing.sort_by(|a, b| {
            let (ka, kb) = (
                firing_key(*a, 0.5_f64.to_radians()),
                firing_key(*b, 0.5_f64.to_radians()),
            );
            ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
        });
        assert!(!held_beam_by_beam(firing.iter().copied()));
        // A tilting 2-D laser: lines of 180° at tilts 0°..30° (its level line turns 180° only).
        let tilting: Vec<[f64; 3]> = (0..60)
            .flat_map(|t| {
                let tilt = (0.5 * f64::from(t)).to_radians();
                (0..361).map(move |j| {
                    let th = (-90.0 + 0.5 * f64::from(j)).to_radians();
                    [
                        5.0 * th.cos() * tilt.cos(),
                        5.0 * th.sin(),
                        -5.0 * th.cos() * tilt.sin(),
                    ]
                })
            })
            .collect();
        assert!(!held_beam_by_beam(tilting.iter().copied()));
        // One revolution among many returns in no order: less than a quarter.
        let mut mixed: Vec<[f64; 3]> = beam_by_beam[..720].to_vec();
        mixed.extend(firing.iter().take(3_000));
        assert!(!held_beam_by_beam(mixed.iter().copied()));
        assert!(!held_beam_by_beam(std::iter::empty()));
    }

    #[test]
    fn firing_order_pairs_three_back_unless_told() {
        let plane = ClassifierConfig::DEFAULT;
        let three = for_order(plane, PointOrder::Firing, None);
        assert_eq!(
            three.rule,
            NavigabilityRule::Plane(
                terrain_pyramid::classify::PlaneRule::DEFAULT.with_pair_depth(3)
            )
        );
        assert_eq!(
            ClassifierConfig {
                rule: plane.rule,
                ..three
            },
            plane
        );
        // The file's order, a depth given on the command line, or the paper's rule: as is.
        assert_eq!(for_order(plane, PointOrder::File, None), plane);
        assert_eq!(for_order(plane, PointOrder::Firing, Some(1)), plane);
        let paper = ClassifierConfig {
            rule: NavigabilityRule::Spread,
            ..plane
        };
        assert_eq!(for_order(paper, PointOrder::Firing, None), paper);
    }

    #[test]
    fn frames_round_trip_and_point_the_right_way() {
        // 3DTK forward (z) is our x; 3DTK right (x) is our −y; 3DTK up (y) is our z.
        assert_eq!(from_3dtk_cm([0.0, 0.0, 100.0]), [1.0, 0.0, 0.0]);
        assert_eq!(from_3dtk_cm([100.0, 0.0, 0.0]), [0.0, -1.0, 0.0]);
        assert_eq!(from_3dtk_cm([0.0, -40.0, 0.0]), [0.0, 0.0, -0.4]);
        let v = [1.25, -2.5, 0.75];
        assert_eq!(from_3dtk_cm(to_3dtk_cm(v)), v);
    }

    #[test]
    fn the_mount_turns_points_about_the_sensor() {
        // Yaw 90°: x to y; roll 90°: y to z; pitch 90°: z to x (right-handed).
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(u, v)| (u - v).abs() < 1e-12);
        // (roll, pitch, yaw in degrees, point, where it turns to), about a sensor at 0.
        // Roll first, then pitch, then yaw: (0, 1, 0) by roll 90° is z, by yaw 90° still z.
        for (rpy, point, want) in [
            ([0.0, 0.0, 90.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            ([90.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            ([0.0, 90.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
            ([90.0, 0.0, 90.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            ([90.0, 0.0, 90.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ] {
            let turn = rotation_of_rpy_deg(rpy);
            assert!(
                close(mounted(&turn, [0.0; 3], point), want),
                "{rpy:?} {point:?}"
            );
        }
        let yaw = rotation_of_rpy_deg([0.0, 0.0, 90.0]);
        let both = rotation_of_rpy_deg([90.0, 0.0, 90.0]);
        // About the sensor: the sensor stays where it is.
        let o = [0.5, -0.2, 1.0];
        assert!(close(mounted(&both, o, o), o));
        assert!(close(mounted(&yaw, o, [1.5, -0.2, 1.0]), [0.5, 0.8, 1.0]));
    }

    #[test]
    fn horizontal_distance_ignores_height() {
        let s = point3([1.0, 1.0, 5.0]);
        let p = point3([4.0, 5.0, -3.0]);
        assert_eq!(horizontal_distance(s, p), Meters::from_num(5));
    }

    #[test]
    fn xyz_parses_three_numbers() {
        assert_eq!("0,0,0".parse::<Xyz>().unwrap(), Xyz([0.0; 3]));
        assert_eq!(
            "-1, 2.5,3e-1".parse::<Xyz>().unwrap(),
            Xyz([-1.0, 2.5, 0.3])
        );
        assert!("1,2".parse::<Xyz>().is_err());
        assert!("1,2,x".parse::<Xyz>().is_err());
        assert!("1,2,inf".parse::<Xyz>().is_err());
    }
}
