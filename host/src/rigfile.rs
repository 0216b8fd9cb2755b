//! The rig: one description of a robot's laser (which sensor, how it is mounted, what moves
//! it, what is masked and filtered, how its lines make observations, the classifier's
//! thresholds), read from a TOML file (`--rig FILE`, `docs/rig.md`) by `pyramid run`,
//! `record` and `listen`, with command-line flags that override the file's values.
//!
//! The file and the flags become a [`Rig`]: plain data, in the units the file uses (metres,
//! degrees). Nothing here knows the wire formats except the two functions at the end,
//! [`device_setup`] and [`recording_setup`], which are the only places a rig is turned into
//! what the device's link (its Setup) and a recording (its setup and sensor events) carry.
//! Where one of them cannot carry a value the rig holds, they say so by name and refuse.

use crate::rule::RuleArgs;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::laser::{Sensor, SensorKind};
use terrain_pyramid::link::convert::rule_setup;
use terrain_pyramid::wire::link::{FilterSetup, LaserSetup, MountSetup, Setup};
use terrain_pyramid::wire::recording::{MountKind, RigEvent, SensorEvent, SetupEvent};
use terrain_pyramid::Meters;
use toml::Spanned;

/// The most masked sectors a rig holds.
pub const MAX_MASKS: usize = 8;

/// The largest magnitude of a position or range, metres (exclusive), as the link's Setup
/// takes positions.
const LIMIT_M: f64 = 1_000.0;

// ------------------------------------------------------------------ the rig as plain data

/// A sensor as the rig names it (`ld06` and `ld19` are one kind on the wire).
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorName {
    /// SICK LMS2xx.
    Sick,
    /// LDROBOT LD06.
    Ld06,
    /// LDROBOT LD19 (the LD06's protocol).
    Ld19,
    /// Slamtec RPLIDAR.
    Rplidar,
    /// YDLIDAR X4 / X2.
    Ydlidar,
}

impl SensorName {
    /// The name as the file and the flags spell it.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sick => "sick",
            Self::Ld06 => "ld06",
            Self::Ld19 => "ld19",
            Self::Rplidar => "rplidar",
            Self::Ydlidar => "ydlidar",
        }
    }

    /// The library's kind.
    #[must_use]
    pub const fn kind(self) -> SensorKind {
        match self {
            Self::Sick => SensorKind::Sick,
            Self::Ld06 | Self::Ld19 => SensorKind::Ld06,
            Self::Rplidar => SensorKind::Rplidar,
            Self::Ydlidar => SensorKind::Ydlidar,
        }
    }

    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "sick" => Self::Sick,
            "ld06" => Self::Ld06,
            "ld19" => Self::Ld19,
            "rplidar" => Self::Rplidar,
            "ydlidar" => Self::Ydlidar,
            _ => return None,
        })
    }
}

/// The rig's sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSpec {
    /// Which sensor.
    pub name: SensorName,
    /// Its mode, as the link's Setup codes it: a SICK's 0x77 measuring mode (0 ..= 6, 15);
    /// RPLIDAR 0 standard, 1 express; YDLIDAR 0 with the X4/X2 angle correction, 1 without;
    /// LD06/LD19 0.
    pub mode: u8,
    /// The laser UART's baud rate; 0 = the sensor's default.
    pub baud: u32,
    /// SICK only: field of view, degrees (100 or 180).
    pub field_deg: u16,
    /// SICK only: angular resolution, centidegrees (25, 50 or 100).
    pub resolution_cdeg: u16,
}

impl SensorSpec {
    /// `name` in mode 0 at its default baud rate (a SICK 180° at 0.5°).
    #[must_use]
    pub const fn of(name: SensorName) -> Self {
        Self {
            name,
            mode: 0,
            baud: 0,
            field_deg: 180,
            resolution_cdeg: 50,
        }
    }

    /// The baud rate the laser's UART runs at (the default when 0).
    #[must_use]
    pub const fn effective_baud(&self) -> u32 {
        if self.baud == 0 {
            self.name.kind().default_baud()
        } else {
            self.baud
        }
    }
}

pub use crate::rig::Axis;

/// A servo the device itself commands along a triangle sweep (the link's Setup laser block).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSweep {
    /// The sweep's lower end, degrees (−179 ..= 179).
    pub min_deg: f64,
    /// The sweep's upper end, degrees (above `min_deg`, at most 179).
    pub max_deg: f64,
    /// The sweep rate, degrees per second (0 < v ≤ 1 000).
    pub rate_deg_s: f64,
    /// How long the servo lags its command, milliseconds (0 ≤ v < 1 000).
    pub latency_ms: f64,
}

/// What moves the sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ActuatorSpec {
    /// The axis.
    pub axis: Axis,
    /// The actuator's reading at the mount's pose (its zero), degrees.
    pub zero_deg: f64,
    /// Whether the actuator's angle grows against the axis' positive sense.
    pub reversed: bool,
    /// A servo the device commands; `None`: an external actuator whose angle the device reads
    /// (its encoder, or the host's PanAngle).
    pub servo: Option<ServoSweep>,
}

/// Where the sensor sits and how it is turned, at actuator zero.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MountSpec {
    /// The sensor's centre in the robot's frame (x forward, y left, z up above the ground
    /// contact), metres.
    pub xyz_m: [f64; 3],
    /// The sensor's frame (x its 0, z its top) relative to the actuator's frame (x forward,
    /// z up): roll, pitch, yaw, degrees (REP-103). `None`: the actuator's preset (pan
    /// `90,0,0`, tilt and none `0,0,0`).
    pub rpy_deg: Option<[f64; 3]>,
}

impl MountSpec {
    /// The roll, pitch and yaw in force: the given ones, else the axis' preset.
    #[must_use]
    pub const fn rpy_or_preset(&self, axis: Axis) -> [f64; 3] {
        match (self.rpy_deg, axis) {
            (Some(rpy), _) => rpy,
            (None, Axis::Pan) => [90.0, 0.0, 0.0],
            (None, Axis::Tilt | Axis::None) => [0.0, 0.0, 0.0],
        }
    }
}

/// Returns dropped before geometry, in the sensor's own frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Filters {
    /// Masked sectors, degrees `[from, to]` counter-clockwise in the sensor's frame, each
    /// within 0 ..= 360; at most [`MAX_MASKS`].
    pub masks_deg: Vec<[f64; 2]>,
    /// Returns nearer than this are dropped, metres.
    pub min_range_m: Option<f64>,
    /// Returns farther than this are dropped, metres.
    pub max_range_m: Option<f64>,
    /// Returns of a lower quality (the sensor's own 0 ..= 255 scale) are dropped.
    pub min_quality: Option<u8>,
}

impl Filters {
    /// Whether any filter is set.
    #[must_use]
    pub fn any(&self) -> bool {
        !self.masks_deg.is_empty()
            || self.min_range_m.is_some()
            || self.max_range_m.is_some()
            || self.min_quality.is_some()
    }
}

/// The classifier's thresholds the rig sets (each `None` keeps the library's default).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClassifierSpec {
    /// The navigability rule and its parameters (the names of `crate::rule`'s flags).
    pub rule: RuleArgs,
    /// Points higher than a cell's ground plus this are overhang, metres (> 0).
    pub robot_height_m: Option<f64>,
    /// Returns this far below the robot's ground mark a drop-off, metres.
    pub drop_m: Option<f64>,
    /// Returns higher than this above the robot's ground are overhang, metres.
    pub ceiling_m: Option<f64>,
}

impl ClassifierSpec {
    /// The classifier's configuration: `base` with the rig's values.
    ///
    /// # Errors
    /// A value out of its range, named by its key.
    pub fn apply(&self, base: ClassifierConfig) -> Result<ClassifierConfig, String> {
        let mut config = self.rule.apply(base)?;
        if let Some(v) = self.robot_height_m {
            if !(v > 0.0 && v < LIMIT_M) {
                return Err(format!("robot_height_m: {v} is not in (0, 1000) m"));
            }
            config.robot_height = Meters::saturating_from_num(v);
        }
        config.drop_threshold = self.drop_m.map(Meters::saturating_from_num);
        config.ceiling = self.ceiling_m.map(Meters::saturating_from_num);
        Ok(config)
    }
}

/// A robot's laser, described once.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rig {
    /// The sensor; `None` when neither the file nor a flag names it.
    pub sensor: Option<SensorSpec>,
    /// The mount.
    pub mount: MountSpec,
    /// The actuator.
    pub actuator: ActuatorSpec,
    /// Masks and range and quality filters.
    pub filters: Filters,
    /// Lines (a SICK's telegrams, a lidar's revolutions) per observation; 0 = one per sweep
    /// of the actuator; `None`: the sensor's default ([`default_lines_per_observation`]).
    pub lines_per_observation: Option<u32>,
    /// The classifier's thresholds.
    pub classifier: ClassifierSpec,
}

/// The observation policy of a sensor when the rig gives none: a spinning lidar, one
/// observation per revolution (a 360° lidar touches far more cells per actuator sweep than
/// a classifier's scratch holds); a SICK, one per sweep (the paper's).
#[must_use]
pub const fn default_lines_per_observation(kind: SensorKind) -> u32 {
    match kind {
        SensorKind::Sick => 0,
        _ => 1,
    }
}

// ------------------------------------------------------------------ the file

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileRig {
    sensor: Option<FileSensor>,
    mount: Option<FileMount>,
    actuator: Option<FileActuator>,
    filters: Option<FileFilters>,
    observation: Option<FileObservation>,
    classifier: Option<FileClassifier>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSensor {
    kind: Spanned<String>,
    mode: Option<Spanned<i64>>,
    baud: Option<Spanned<i64>>,
    field_deg: Option<Spanned<i64>>,
    resolution_cdeg: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMount {
    xyz_m: Option<Spanned<Vec<f64>>>,
    rpy_deg: Option<Spanned<Vec<f64>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileActuator {
    axis: Option<Spanned<String>>,
    zero_deg: Option<Spanned<f64>>,
    reversed: Option<bool>,
    servo_min_deg: Option<Spanned<f64>>,
    servo_max_deg: Option<Spanned<f64>>,
    servo_rate_deg_s: Option<Spanned<f64>>,
    servo_latency_ms: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileFilters {
    masks_deg: Option<Spanned<Vec<Vec<f64>>>>,
    min_range_m: Option<Spanned<f64>>,
    max_range_m: Option<Spanned<f64>>,
    min_quality: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileObservation {
    lines_per_observation: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileClassifier {
    rule: Option<Spanned<String>>,
    step_m: Option<Spanned<f64>>,
    max_slope_deg: Option<Spanned<f64>>,
    residual_m: Option<Spanned<f64>>,
    noise_sigma_m: Option<Spanned<f64>>,
    angle_sigma_deg: Option<Spanned<f64>>,
    noise_factor: Option<Spanned<f64>>,
    robot_height_m: Option<Spanned<f64>>,
    drop_m: Option<Spanned<f64>>,
    ceiling_m: Option<Spanned<f64>>,
}

/// Checks the values of one file, each error naming the file, the line and the key.
struct Checker<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Checker<'_> {
    fn line(&self, span: &std::ops::Range<usize>) -> usize {
        let head = self.text.get(..span.start).unwrap_or(self.text);
        head.bytes().filter(|&b| b == b'\n').count() + 1
    }

    fn error<T>(&self, span: &std::ops::Range<usize>, key: &str, why: &str) -> Result<T, String> {
        Err(format!(
            "{}:{}: {key}: {why}",
            self.path.display(),
            self.line(span)
        ))
    }

    /// An integer in `lo ..= hi`.
    fn int(&self, v: &Spanned<i64>, key: &str, lo: i64, hi: i64) -> Result<i64, String> {
        let x = *v.get_ref();
        if (lo..=hi).contains(&x) {
            Ok(x)
        } else {
            self.error(&v.span(), key, &format!("{x} is not in {lo} ..= {hi}"))
        }
    }

    /// A finite number that `ok` accepts (`rule` says which).
    fn num(
        &self,
        v: &Spanned<f64>,
        key: &str,
        ok: impl Fn(f64) -> bool,
        rule: &str,
    ) -> Result<f64, String> {
        let x = *v.get_ref();
        if x.is_finite() && ok(x) {
            Ok(x)
        } else {
            self.error(&v.span(), key, &format!("{x} is not {rule}"))
        }
    }

    fn triple(&self, v: &Spanned<Vec<f64>>, key: &str, limit: f64) -> Result<[f64; 3], String> {
        match v.get_ref().as_slice() {
            &[a, b, c] if [a, b, c].iter().all(|x| x.is_finite() && x.abs() < limit) => {
                Ok([a, b, c])
            }
            &[_, _, _] => self.error(
                &v.span(),
                key,
                &format!("each value must be finite with |v| < {limit}"),
            ),
            other => self.error(
                &v.span(),
                key,
                &format!(
                    "needs 3 values (x, y, z or roll, pitch, yaw), not {}",
                    other.len()
                ),
            ),
        }
    }
}

/// Reads a rig file.
///
/// # Errors
/// The file cannot be read, is not TOML, has a key the rig does not know, or a value out of
/// its range: each error names the file, the line and the key.
pub fn read_rig_file(path: &Path) -> Result<Rig, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read the rig file {}: {e}", path.display()))?;
    parse_rig(path, &text)
}

/// Parses a rig file's text (`path` names it in errors).
///
/// # Errors
/// As [`read_rig_file`].
#[allow(clippy::too_many_lines)]
pub fn parse_rig(path: &Path, text: &str) -> Result<Rig, String> {
    let file: FileRig = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text.get(..s.start).unwrap_or(text).matches('\n').count() + 1);
        let message = e.message().trim_end();
        match line {
            Some(l) => format!("{}:{l}: {message}", path.display()),
            None => format!("{}: {message}", path.display()),
        }
    })?;
    let c = Checker { path, text };
    let mut rig = Rig::default();
    if let Some(s) = &file.sensor {
        let Some(name) = SensorName::parse(s.kind.get_ref()) else {
            return c.error(
                &s.kind.span(),
                "sensor.kind",
                &format!(
                    "{:?} is not one of sick, ld06, ld19, rplidar, ydlidar",
                    s.kind.get_ref()
                ),
            );
        };
        let mut spec = SensorSpec::of(name);
        if let Some(v) = &s.mode {
            let hi = Sensor::max_mode(name.kind()).map_or(15, i64::from);
            let mode = c.int(v, "sensor.mode", 0, hi)?;
            if name == SensorName::Sick && (7..=14).contains(&mode) {
                return c.error(&v.span(), "sensor.mode", "SICK modes 7 ..= 14 do not exist");
            }
            spec.mode = u8::try_from(mode).unwrap_or_default();
        }
        if let Some(v) = &s.baud {
            let baud = *v.get_ref();
            if baud != 0 && !(9_600..=3_000_000).contains(&baud) {
                return c.error(
                    &v.span(),
                    "sensor.baud",
                    &format!("{baud} is neither 0 (the default) nor in 9600 ..= 3000000"),
                );
            }
            spec.baud = u32::try_from(baud).unwrap_or_default();
        }
        if let Some(v) = &s.field_deg {
            let f = *v.get_ref();
            if !matches!(f, 100 | 180) {
                return c.error(
                    &v.span(),
                    "sensor.field_deg",
                    &format!("{f} is not 100 or 180"),
                );
            }
            spec.field_deg = u16::try_from(f).unwrap_or_default();
        }
        if let Some(v) = &s.resolution_cdeg {
            let r = *v.get_ref();
            if !matches!(r, 25 | 50 | 100) {
                return c.error(
                    &v.span(),
                    "sensor.resolution_cdeg",
                    &format!("{r} is not 25, 50 or 100"),
                );
            }
            spec.resolution_cdeg = u16::try_from(r).unwrap_or_default();
        }
        rig.sensor = Some(spec);
    }
    if let Some(m) = &file.mount {
        if let Some(v) = &m.xyz_m {
            rig.mount.xyz_m = c.triple(v, "mount.xyz_m", LIMIT_M)?;
        }
        if let Some(v) = &m.rpy_deg {
            rig.mount.rpy_deg = Some(c.triple(v, "mount.rpy_deg", 360.1)?);
        }
    }
    if let Some(a) = &file.actuator {
        if let Some(v) = &a.axis {
            rig.actuator.axis = Axis::parse(v.get_ref()).map_or_else(
                || {
                    c.error(
                        &v.span(),
                        "actuator.axis",
                        &format!("{:?} is not one of pan, tilt, none", v.get_ref()),
                    )
                },
                Ok,
            )?;
        }
        if let Some(v) = &a.zero_deg {
            rig.actuator.zero_deg = c.num(
                v,
                "actuator.zero_deg",
                |x| x.abs() <= 360.0,
                "in -360 ..= 360",
            )?;
        }
        rig.actuator.reversed = a.reversed.unwrap_or(false);
        let servo = [
            &a.servo_min_deg,
            &a.servo_max_deg,
            &a.servo_rate_deg_s,
            &a.servo_latency_ms,
        ];
        if servo.iter().any(|v| v.is_some()) {
            fn need<'v>(
                v: &'v Option<Spanned<f64>>,
                key: &str,
                path: &Path,
            ) -> Result<&'v Spanned<f64>, String> {
                v.as_ref().ok_or_else(|| {
                    format!(
                        "{}: actuator.{key} is missing: a servo needs servo_min_deg, servo_max_deg, servo_rate_deg_s and servo_latency_ms",
                        path.display()
                    )
                })
            }
            let min_v = need(&a.servo_min_deg, "servo_min_deg", path)?;
            let min = c.num(
                min_v,
                "actuator.servo_min_deg",
                |x| x.abs() <= 179.0,
                "in -179 ..= 179",
            )?;
            let max_v = need(&a.servo_max_deg, "servo_max_deg", path)?;
            let max = c.num(
                max_v,
                "actuator.servo_max_deg",
                |x| x > min && x <= 179.0,
                "above servo_min_deg and at most 179",
            )?;
            let rate = c.num(
                need(&a.servo_rate_deg_s, "servo_rate_deg_s", path)?,
                "actuator.servo_rate_deg_s",
                |x| x > 0.0 && x <= 1_000.0,
                "in (0, 1000]",
            )?;
            let latency = c.num(
                need(&a.servo_latency_ms, "servo_latency_ms", path)?,
                "actuator.servo_latency_ms",
                |x| (0.0..1_000.0).contains(&x),
                "in [0, 1000)",
            )?;
            rig.actuator.servo = Some(ServoSweep {
                min_deg: min,
                max_deg: max,
                rate_deg_s: rate,
                latency_ms: latency,
            });
        }
    }
    if let Some(f) = &file.filters {
        if let Some(v) = &f.masks_deg {
            if v.get_ref().len() > MAX_MASKS {
                return c.error(
                    &v.span(),
                    "filters.masks_deg",
                    &format!("{} sectors: at most {MAX_MASKS}", v.get_ref().len()),
                );
            }
            for sector in v.get_ref() {
                match sector.as_slice() {
                    &[from, to]
                        if [from, to]
                            .iter()
                            .all(|x| x.is_finite() && (0.0..=360.0).contains(x)) =>
                    {
                        rig.filters.masks_deg.push([from, to]);
                    }
                    _ => {
                        return c.error(
                            &v.span(),
                            "filters.masks_deg",
                            &format!(
                                "{sector:?}: each sector is [from, to], degrees within 0 ..= 360"
                            ),
                        )
                    }
                }
            }
        }
        if let Some(v) = &f.min_range_m {
            rig.filters.min_range_m = Some(c.num(
                v,
                "filters.min_range_m",
                |x| (0.0..LIMIT_M).contains(&x),
                "in [0, 1000) m",
            )?);
        }
        if let Some(v) = &f.max_range_m {
            let lo = rig.filters.min_range_m.unwrap_or(0.0);
            rig.filters.max_range_m = Some(c.num(
                v,
                "filters.max_range_m",
                |x| x > lo && x < LIMIT_M,
                "above min_range_m and below 1000 m",
            )?);
        }
        if let Some(v) = &f.min_quality {
            rig.filters.min_quality =
                Some(u8::try_from(c.int(v, "filters.min_quality", 0, 255)?).unwrap_or_default());
        }
    }
    if let Some(o) = &file.observation {
        if let Some(v) = &o.lines_per_observation {
            let n = c.int(
                v,
                "observation.lines_per_observation",
                0,
                i64::from(u32::MAX),
            )?;
            rig.lines_per_observation = Some(u32::try_from(n).unwrap_or_default());
        }
    }
    if let Some(k) = &file.classifier {
        let metres = |v: &Option<Spanned<f64>>, key: &str| -> Result<Option<f64>, String> {
            v.as_ref()
                .map(|v| c.num(v, key, |x| (0.0..LIMIT_M).contains(&x), "in [0, 1000) m"))
                .transpose()
        };
        let spec = &mut rig.classifier;
        if let Some(v) = &k.rule {
            spec.rule.rule = Some(match v.get_ref().as_str() {
                "plane" => crate::rule::RuleArg::Plane,
                "paper" => crate::rule::RuleArg::Paper,
                other => {
                    return c.error(
                        &v.span(),
                        "classifier.rule",
                        &format!("{other:?} is not plane or paper"),
                    )
                }
            });
        }
        spec.rule.step_m = metres(&k.step_m, "classifier.step_m")?;
        spec.rule.residual_m = metres(&k.residual_m, "classifier.residual_m")?;
        spec.rule.noise_sigma_m = metres(&k.noise_sigma_m, "classifier.noise_sigma_m")?;
        spec.rule.max_slope_deg = k
            .max_slope_deg
            .as_ref()
            .map(|v| {
                c.num(
                    v,
                    "classifier.max_slope_deg",
                    |x| (0.0..89.0).contains(&x),
                    "in [0, 89)",
                )
            })
            .transpose()?;
        spec.rule.angle_sigma_deg = k
            .angle_sigma_deg
            .as_ref()
            .map(|v| {
                c.num(
                    v,
                    "classifier.angle_sigma_deg",
                    |x| (0.0..45.0).contains(&x),
                    "in [0, 45)",
                )
            })
            .transpose()?;
        spec.rule.noise_factor = k
            .noise_factor
            .as_ref()
            .map(|v| {
                c.num(
                    v,
                    "classifier.noise_factor",
                    |x| (0.0..100.0).contains(&x),
                    "in [0, 100)",
                )
            })
            .transpose()?;
        if let Some(v) = &k.robot_height_m {
            spec.robot_height_m = Some(c.num(
                v,
                "classifier.robot_height_m",
                |x| x > 0.0 && x < LIMIT_M,
                "in (0, 1000) m",
            )?);
        }
        spec.drop_m = metres(&k.drop_m, "classifier.drop_m")?;
        spec.ceiling_m = metres(&k.ceiling_m, "classifier.ceiling_m")?;
        // A plane parameter under the paper's rule is refused here, with its line.
        if let Err(e) = spec.rule.apply(ClassifierConfig::DEFAULT) {
            return Err(format!("{}: [classifier]: {e}", path.display()));
        }
    }
    Ok(rig)
}

// ------------------------------------------------------------------ the flags

/// Parses `A,B` or `A,B,C` numbers.
fn numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!("{s:?}: needs {N} comma-separated numbers"));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{p:?} is not a finite number"))?;
    }
    Ok(out)
}

fn triple_arg(s: &str) -> Result<[f64; 3], String> {
    numbers::<3>(s)
}

fn pair_arg(s: &str) -> Result<[f64; 2], String> {
    numbers::<2>(s)
}

/// The rig's flags: `--rig FILE`, and flags that override the file's values.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct RigArgs {
    /// The rig file (TOML, docs/rig.md): the sensor, mount, actuator, filters, observation
    /// policy and classifier thresholds; the flags below override its values.
    #[arg(long, value_name = "FILE.toml")]
    pub rig: Option<PathBuf>,
    /// The laser.
    #[arg(long, value_enum)]
    pub sensor: Option<SensorName>,
    /// The laser's mode, as Setup codes it (RPLIDAR 0 standard, 1 express; YDLIDAR 0
    /// corrected, 1 not; a SICK's measuring mode).
    #[arg(long, value_name = "N")]
    pub sensor_mode: Option<u8>,
    /// The sensor's centre in the robot's frame at actuator zero, metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = triple_arg, allow_hyphen_values = true)]
    pub mount_xyz_m: Option<[f64; 3]>,
    /// The sensor's frame (x its 0, z its top) relative to the actuator's frame at actuator
    /// zero, degrees: R,P,Y.
    #[arg(long, value_name = "R,P,Y", value_parser = triple_arg, allow_hyphen_values = true)]
    pub mount_rpy_deg: Option<[f64; 3]>,
    /// What moves the sensor.
    #[arg(long, value_enum)]
    pub actuator: Option<Axis>,
    /// The actuator's reading at the mount's pose, degrees.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub actuator_zero_deg: Option<f64>,
    /// The actuator's angle grows against the axis' positive sense.
    #[arg(long)]
    pub actuator_reversed: bool,
    /// A servo the device commands: its sweep MIN,MAX degrees.
    #[arg(long, value_name = "MIN,MAX", value_parser = pair_arg, allow_hyphen_values = true)]
    pub servo_sweep_deg: Option<[f64; 2]>,
    /// The servo's rate, degrees per second [default: 60].
    #[arg(long, value_name = "DEG_S", requires = "servo_sweep_deg")]
    pub servo_rate_deg_s: Option<f64>,
    /// The servo's lag behind its command, milliseconds [default: 0].
    #[arg(long, value_name = "MS", requires = "servo_sweep_deg")]
    pub servo_latency_ms: Option<f64>,
    /// A masked sector FROM,TO, degrees counter-clockwise in the sensor's frame (repeat, at
    /// most 8; replaces the file's masks).
    #[arg(long, value_name = "FROM:TO", value_parser = mask_arg)]
    pub mask_deg: Vec<[f64; 2]>,
    /// Returns nearer than this are dropped, metres.
    #[arg(long = "filter-min-range-m", value_name = "M")]
    pub min_range_m: Option<f64>,
    /// Returns farther than this are dropped, metres.
    #[arg(long = "filter-max-range-m", value_name = "M")]
    pub max_range_m: Option<f64>,
    /// Returns of a lower quality (the sensor's 0 ..= 255) are dropped.
    #[arg(long = "filter-min-quality", value_name = "Q")]
    pub min_quality: Option<u8>,
    /// Lines (SICK telegrams, lidar revolutions) per observation; 0 = one per actuator sweep
    /// [default: SICK 0, a lidar 1].
    #[arg(long, value_name = "N")]
    pub lines_per_observation: Option<u32>,
}

impl RigArgs {
    /// Whether a rig file or any rig flag was given.
    #[must_use]
    pub fn given(&self) -> bool {
        self != &Self::default()
    }

    /// The rig: the file's (if any), with the flags' values over it, checked.
    ///
    /// # Errors
    /// The file's errors ([`read_rig_file`]); a flag's value out of its range, named by the
    /// flag.
    pub fn rig(&self) -> Result<Rig, String> {
        let mut rig = match &self.rig {
            Some(path) => read_rig_file(path)?,
            None => Rig::default(),
        };
        if let Some(name) = self.sensor {
            let keep = rig.sensor.filter(|s| s.name.kind() == name.kind());
            rig.sensor = Some(keep.map_or(SensorSpec::of(name), |s| SensorSpec { name, ..s }));
        }
        if let Some(mode) = self.sensor_mode {
            let spec = rig
                .sensor
                .as_mut()
                .ok_or("--sensor-mode needs a sensor (--sensor or the rig file's)")?;
            let hi = Sensor::max_mode(spec.name.kind()).unwrap_or(15);
            if mode > hi || (spec.name == SensorName::Sick && (7..=14).contains(&mode)) {
                return Err(format!(
                    "--sensor-mode: {} has no mode {mode}",
                    spec.name.name()
                ));
            }
            spec.mode = mode;
        }
        if let Some(xyz) = self.mount_xyz_m {
            if xyz.iter().any(|v| v.abs() >= LIMIT_M) {
                return Err("--mount-xyz-m: each value must be below 1000 m".into());
            }
            rig.mount.xyz_m = xyz;
        }
        if let Some(rpy) = self.mount_rpy_deg {
            if rpy.iter().any(|v| v.abs() > 360.0) {
                return Err("--mount-rpy-deg: each angle must be within -360 ..= 360".into());
            }
            rig.mount.rpy_deg = Some(rpy);
        }
        if let Some(axis) = self.actuator {
            rig.actuator.axis = axis;
        }
        if let Some(z) = self.actuator_zero_deg {
            if !(z.is_finite() && z.abs() <= 360.0) {
                return Err("--actuator-zero-deg: must be within -360 ..= 360".into());
            }
            rig.actuator.zero_deg = z;
        }
        rig.actuator.reversed |= self.actuator_reversed;
        if let Some([min, max]) = self.servo_sweep_deg {
            let rate = self.servo_rate_deg_s.unwrap_or(60.0);
            let latency = self.servo_latency_ms.unwrap_or(0.0);
            if !(min.abs() <= 179.0 && min < max && max <= 179.0) {
                return Err("--servo-sweep-deg: needs -179 <= MIN < MAX <= 179".into());
            }
            if !(rate.is_finite() && rate > 0.0 && rate <= 1_000.0) {
                return Err("--servo-rate-deg-s: must be in (0, 1000]".into());
            }
            if !(latency.is_finite() && (0.0..1_000.0).contains(&latency)) {
                return Err("--servo-latency-ms: must be in [0, 1000)".into());
            }
            rig.actuator.servo = Some(ServoSweep {
                min_deg: min,
                max_deg: max,
                rate_deg_s: rate,
                latency_ms: latency,
            });
        }
        if !self.mask_deg.is_empty() {
            if self.mask_deg.len() > MAX_MASKS {
                return Err(format!("--mask-deg: at most {MAX_MASKS} sectors"));
            }
            if self
                .mask_deg
                .iter()
                .flatten()
                .any(|v| !(0.0..=360.0).contains(v))
            {
                return Err("--mask-deg: angles must be within 0 ..= 360".into());
            }
            rig.filters.masks_deg.clone_from(&self.mask_deg);
        }
        if let Some(v) = self.min_range_m {
            if !(v.is_finite() && (0.0..LIMIT_M).contains(&v)) {
                return Err("--filter-min-range-m: must be in [0, 1000)".into());
            }
            rig.filters.min_range_m = Some(v);
        }
        if let Some(v) = self.max_range_m {
            let lo = rig.filters.min_range_m.unwrap_or(0.0);
            if !(v.is_finite() && v > lo && v < LIMIT_M) {
                return Err(
                    "--filter-max-range-m: must be above the minimum range and below 1000".into(),
                );
            }
            rig.filters.max_range_m = Some(v);
        }
        if let Some(q) = self.min_quality {
            rig.filters.min_quality = Some(q);
        }
        if let Some(n) = self.lines_per_observation {
            rig.lines_per_observation = Some(n);
        }
        Ok(rig)
    }
}

/// The rig's classifier section with the command line's rule flags over it (each flag given
/// replaces the file's value; `--rule paper` drops the file's plane parameters).
#[must_use]
pub fn merged_rule(file: &RuleArgs, flags: &RuleArgs) -> RuleArgs {
    let file = if flags.rule == Some(crate::rule::RuleArg::Paper) {
        &RuleArgs {
            rule: file.rule,
            step_m: file.step_m,
            ..RuleArgs::default()
        }
    } else {
        file
    };
    RuleArgs {
        rule: flags.rule.or(file.rule),
        step_m: flags.step_m.or(file.step_m),
        max_slope_deg: flags.max_slope_deg.or(file.max_slope_deg),
        residual_m: flags.residual_m.or(file.residual_m),
        noise_sigma_m: flags.noise_sigma_m.or(file.noise_sigma_m),
        angle_sigma_deg: flags.angle_sigma_deg.or(file.angle_sigma_deg),
        noise_factor: flags.noise_factor.or(file.noise_factor),
    }
}

// ------------------------------------------------------------------ into the wire formats
//
// THE PLACE WHERE A RIG BECOMES WHAT THE DEVICE AND A RECORDING CARRY. The link's Setup
// (protocol version 5) and a recording (version 3) carry the general mount (Setup's mount
// byte 2 and its mount block, the recording's rig event) and the filter block: the rig's
// mount, actuator and filters go through [`crate::rig::Rig::apply`], the one check of them
// that `pyramid run`'s flags use too.

/// A `--mask-deg FROM:TO` flag, as `pyramid run` reads it ([`crate::rig::parse_mask`]).
fn mask_arg(text: &str) -> Result<[f64; 2], String> {
    crate::rig::parse_mask(text)
        .map(|m| [m.start_deg, m.end_deg])
        .map_err(|e| e.to_string())
}

/// The preset a rig's axis starts from: a pan unit the panned-vertical preset, a tilt unit
/// or none the tilted-horizontal one. The rig's own orientation, zero and sense are then
/// written over it ([`mount_rig`]).
const fn preset_of(axis: Axis) -> MountKind {
    match axis {
        Axis::Pan => MountKind::PannedVertical,
        Axis::Tilt | Axis::None => MountKind::TiltedHorizontal,
    }
}

/// The rig's mount, actuator and filters as the flags' [`crate::rig::Rig`] (the rig file's
/// key names in its errors are the flags' names).
#[must_use]
pub fn mount_rig(rig: &Rig) -> crate::rig::Rig {
    let f = &rig.filters;
    let axis = rig.actuator.axis;
    let rpy = rig.mount.rpy_or_preset(axis);
    // A preset's own orientation on its own axis goes as the preset (Setup's mount byte 0
    // or 1); anything else as the general mount.
    let preset = match axis {
        Axis::Pan => rpy == [90.0, 0.0, 0.0],
        Axis::Tilt => rpy == [0.0; 3],
        Axis::None => false,
    };
    crate::rig::Rig {
        xyz_m: Some(rig.mount.xyz_m),
        rpy_deg: (!preset).then_some(rpy),
        axis: (!preset).then_some(axis),
        zero_deg: (rig.actuator.zero_deg != 0.0).then_some(rig.actuator.zero_deg),
        reversed: rig.actuator.reversed,
        masks: f
            .masks_deg
            .iter()
            .map(|&[start_deg, end_deg]| crate::rig::Mask { start_deg, end_deg })
            .collect(),
        min_range_m: f.min_range_m,
        max_range_m: f.max_range_m,
        min_quality: f.min_quality,
    }
}

/// The rig's mount and filters written over `setup` (its preset mount byte already set),
/// checked as the device checks them.
fn with_mount(rig: &Rig, setup: &mut Setup) -> Result<(), String> {
    mount_rig(rig).apply(setup).map_err(|e| e.to_string())
}

/// The sensor a rig must name.
fn sensor_of(rig: &Rig) -> Result<SensorSpec, String> {
    rig.sensor.ok_or_else(|| {
        "the rig names no sensor (--sensor, or [sensor] kind in the rig file)".into()
    })
}

/// The rig as the device's Setup (link protocol version 4), with `classifier`'s thresholds.
///
/// # Errors
/// No sensor, or a value this version's Setup cannot carry (named).
pub fn device_setup(rig: &Rig, classifier: &ClassifierConfig) -> Result<Setup, String> {
    let sensor = sensor_of(rig)?;
    let mount = preset_of(rig.actuator.axis);
    let m = |v: Meters| v.to_num::<f32>();
    let off = |v: Option<Meters>| v.map_or(0.0, m);
    #[allow(clippy::cast_possible_truncation)]
    let f = |v: f64| v as f32;
    let servo = rig.actuator.servo;
    let mut setup = Setup {
        mount: match mount {
            MountKind::PannedVertical => 0,
            MountKind::TiltedHorizontal => 1,
        },
        measuring_mode: sensor.mode,
        field_deg: sensor.field_deg,
        resolution_cdeg: sensor.resolution_cdeg,
        sensor_m: rig.mount.xyz_m.map(f),
        lines_per_observation: rig
            .lines_per_observation
            .unwrap_or(default_lines_per_observation(sensor.name.kind())),
        robot_height_m: m(classifier.robot_height),
        step_threshold_m: m(classifier.step_threshold),
        drop_threshold_m: off(classifier.drop_threshold),
        ceiling_m: off(classifier.ceiling),
        rule: rule_setup(&classifier.rule),
        laser: LaserSetup {
            sensor: sensor.name.kind().code(),
            actuator: u8::from(servo.is_some()),
            baud: sensor.baud,
            servo_min_deg: servo.map_or(0.0, |s| f(s.min_deg)),
            servo_max_deg: servo.map_or(0.0, |s| f(s.max_deg)),
            servo_rate_deg_s: servo.map_or(0.0, |s| f(s.rate_deg_s)),
            servo_latency_ms: servo.map_or(0.0, |s| f(s.latency_ms)),
        },
        mount_block: MountSetup::PRESET,
        filter: FilterSetup::NONE,
    };
    with_mount(rig, &mut setup)?;
    Ok(setup)
}

/// The rig's mount and filters as a recording's rig event (version 3), or `None` when the
/// setup event's preset says it all (a preset orientation, zero 0, sense +1, no filter).
///
/// # Errors
/// No sensor, or a value the device would refuse, named.
pub fn rig_event(rig: &Rig) -> Result<Option<RigEvent>, String> {
    let setup = device_setup(rig, &ClassifierConfig::DEFAULT)?;
    let plain = setup.mount != 2
        && setup.mount_block == MountSetup::PRESET
        && setup.filter == FilterSetup::NONE;
    Ok((!plain).then_some(RigEvent {
        mount: setup.mount,
        mount_block: setup.mount_block,
        filter: setup.filter,
    }))
}

/// The rig as a recording's setup and sensor events (the preset its axis starts from; the
/// rest of the mount and the filters go in the rig event, [`rig_event`]).
///
/// # Errors
/// No sensor, or a value the device would refuse (named).
pub fn recording_setup(rig: &Rig) -> Result<(SetupEvent, SensorEvent), String> {
    let sensor = sensor_of(rig)?;
    let mount = preset_of(rig.actuator.axis);
    rig_event(rig)?;
    let sick = sensor.name == SensorName::Sick;
    #[allow(clippy::cast_possible_truncation)]
    let setup = SetupEvent {
        mount,
        measuring_mode: if sick { sensor.mode } else { 0 },
        field_deg: if sick { sensor.field_deg } else { 180 },
        resolution_cdeg: if sick { sensor.resolution_cdeg } else { 50 },
        sensor_m: rig.mount.xyz_m.map(|v| v as f32),
        lines_per_observation: rig
            .lines_per_observation
            .unwrap_or(default_lines_per_observation(sensor.name.kind())),
    };
    let event = SensorEvent {
        sensor: sensor.name.kind().code(),
        mode: if sick { 0 } else { sensor.mode },
    };
    Ok((setup, event))
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLES: [(&str, &str); 3] = [
        (
            "ld19-nodding.toml",
            include_str!("../../examples/rigs/ld19-nodding.toml"),
        ),
        (
            "rplidar-panned.toml",
            include_str!("../../examples/rigs/rplidar-panned.toml"),
        ),
        (
            "sick-tilt.toml",
            include_str!("../../examples/rigs/sick-tilt.toml"),
        ),
    ];

    fn parse(text: &str) -> Result<Rig, String> {
        parse_rig(Path::new("rig.toml"), text)
    }

    #[test]
    fn every_example_parses_and_becomes_a_setup_and_a_recording_setup() {
        for (name, text) in EXAMPLES {
            let rig = parse_rig(Path::new(name), text).unwrap_or_else(|e| panic!("{e}"));
            let setup = device_setup(&rig, &ClassifierConfig::DEFAULT)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            // The device's own check takes it.
            terrain_pyramid::link::convert::frontend_config(&setup)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
            recording_setup(&rig).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn the_examples_say_what_their_names_say() {
        let ld19 = parse(EXAMPLES[0].1).unwrap();
        let setup = device_setup(&ld19, &ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(ld19.sensor.unwrap().name, SensorName::Ld19);
        assert_eq!(
            (setup.mount, setup.laser.sensor, setup.laser.actuator),
            (1, 1, 1)
        );
        assert_eq!(setup.laser.servo_min_deg, -10.0);
        assert_eq!(setup.sensor_m, [0.10, 0.0, 0.30]);
        let rp = parse(EXAMPLES[1].1).unwrap();
        let setup = device_setup(&rp, &ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(
            (setup.mount, setup.laser.sensor, setup.laser.actuator),
            (0, 2, 0)
        );
        assert_eq!(
            (setup.laser.baud, setup.lines_per_observation),
            (115_200, 1)
        );
        assert_eq!(setup.ceiling_m, 0.0, "the classifier is the caller's");
        let config = rp.classifier.apply(ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(config.ceiling, Some(Meters::from_num(1.8)));
        let sick = parse(EXAMPLES[2].1).unwrap();
        let (event, sensor) = recording_setup(&sick).unwrap();
        assert_eq!(event.mount, MountKind::TiltedHorizontal);
        assert_eq!(
            (event.measuring_mode, event.lines_per_observation),
            (5, 226)
        );
        assert_eq!(sensor, SensorEvent::SICK);
    }

    #[test]
    fn an_unknown_key_is_named_with_its_line() {
        let e = parse("[sensor]\nkind = \"ld06\"\n\n[mount]\nxyz = [0, 0, 1]\n").unwrap_err();
        assert!(e.starts_with("rig.toml:5:"), "{e}");
        assert!(e.contains("unknown field `xyz`"), "{e}");
        let e = parse("[sensors]\nkind = \"ld06\"\n").unwrap_err();
        assert!(e.starts_with("rig.toml:1:") && e.contains("sensors"), "{e}");
    }

    #[test]
    fn a_bad_value_is_named_with_its_key_and_line() {
        let cases = [
            ("[sensor]\nkind = \"ld07\"\n", "rig.toml:2: sensor.kind"),
            ("[sensor]\nkind = \"rplidar\"\nmode = 2\n", "rig.toml:3: sensor.mode"),
            ("[sensor]\nkind = \"sick\"\nbaud = 300\n", "rig.toml:3: sensor.baud"),
            ("[mount]\n\nxyz_m = [0, 0]\n", "rig.toml:3: mount.xyz_m"),
            ("[actuator]\naxis = \"roll\"\n", "rig.toml:2: actuator.axis"),
            (
                "[actuator]\nservo_min_deg = 10\nservo_max_deg = 5\nservo_rate_deg_s = 1\nservo_latency_ms = 0\n",
                "rig.toml:3: actuator.servo_max_deg",
            ),
            (
                "[filters]\nmin_range_m = 2\nmax_range_m = 1\n",
                "rig.toml:3: filters.max_range_m",
            ),
            ("[filters]\nmasks_deg = [[10, 400]]\n", "rig.toml:2: filters.masks_deg"),
            ("[classifier]\nstep_m = -1\n", "rig.toml:2: classifier.step_m"),
            (
                "[observation]\nlines_per_observation = -1\n",
                "rig.toml:2: observation.lines_per_observation",
            ),
        ];
        for (text, start) in cases {
            let e = parse(text).unwrap_err();
            assert!(e.starts_with(start), "{text:?}: {e}");
        }
        // A value of the wrong type: toml's own message, with the line.
        let e = parse("[sensor]\nkind = \"ld06\"\nbaud = \"fast\"\n").unwrap_err();
        assert!(e.starts_with("rig.toml:3:"), "{e}");
        let e = parse("[actuator]\nservo_min_deg = 10\n").unwrap_err();
        assert!(e.contains("actuator.servo_max_deg is missing"), "{e}");
    }

    #[test]
    fn flags_override_the_file() {
        let dir = std::env::temp_dir().join(format!("pyramid-rigfile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("rig.toml");
        std::fs::write(&path, EXAMPLES[1].1).unwrap();
        let args = RigArgs {
            rig: Some(path.clone()),
            sensor_mode: Some(1),
            mount_xyz_m: Some([0.2, 0.0, 0.5]),
            lines_per_observation: Some(4),
            ..RigArgs::default()
        };
        let rig = args.rig().unwrap();
        let spec = rig.sensor.unwrap();
        assert_eq!(
            (spec.name, spec.mode, spec.baud),
            (SensorName::Rplidar, 1, 115_200)
        );
        assert_eq!(rig.mount.xyz_m, [0.2, 0.0, 0.5]);
        assert_eq!(
            rig.mount.rpy_deg,
            Some([90.0, 0.0, 0.0]),
            "kept from the file"
        );
        assert_eq!(rig.lines_per_observation, Some(4));
        // Another sensor kind by flag starts from that sensor's defaults.
        let args = RigArgs {
            rig: Some(path),
            sensor: Some(SensorName::Ld06),
            ..RigArgs::default()
        };
        let spec = args.rig().unwrap().sensor.unwrap();
        assert_eq!((spec.name, spec.mode, spec.baud), (SensorName::Ld06, 0, 0));
        std::fs::remove_dir_all(&dir).unwrap();
        let e = RigArgs {
            sensor: Some(SensorName::Ld19),
            sensor_mode: Some(1),
            ..RigArgs::default()
        }
        .rig()
        .unwrap_err();
        assert!(e.contains("--sensor-mode"), "{e}");
    }

    #[test]
    fn the_general_mount_and_the_filters_reach_the_setup_and_the_rig_event() {
        let base = "[sensor]\nkind = \"ld06\"\n";
        let rig = |extra: &str| parse(&format!("{base}{extra}")).unwrap();
        let setup = |extra: &str| device_setup(&rig(extra), &ClassifierConfig::DEFAULT).unwrap();
        let s = setup("[mount]\nrpy_deg = [180, 0, 90]\n[actuator]\naxis = \"tilt\"\n");
        assert_eq!((s.mount, s.mount_block.axis), (2, 1));
        assert_eq!(s.mount_block.rpy_deg, [180.0, 0.0, 90.0]);
        let s = setup("[actuator]\naxis = \"tilt\"\nzero_deg = 5\nreversed = true\n");
        assert_eq!(
            (s.mount, s.mount_block.zero_deg, s.mount_block.sense),
            (1, 5.0, -1)
        );
        let s = setup("[filters]\nmasks_deg = [[170, 190]]\nmin_quality = 10\n");
        assert_eq!(
            (s.filter.sector_count, s.filter.sectors[0]),
            (1, (17_000, 19_000))
        );
        assert_eq!(s.filter.min_quality, 10);
        // A preset's own orientation needs no rig event; anything else gets one.
        assert_eq!(
            rig_event(&rig("[actuator]\naxis = \"tilt\"\n")).unwrap(),
            None
        );
        let event = rig_event(&rig("[filters]\nmin_range_m = 0.2\n"))
            .unwrap()
            .unwrap();
        assert_eq!(event.filter.min_range_cm, 20);
        // What the device would refuse is refused by name, before anything is sent.
        for (extra, key) in [
            ("[actuator]\naxis = \"pan\"\nrpy = 0\n", "unknown field"),
            ("[mount]\nrpy_deg = [400, 0, 0]\n", "mount.rpy_deg"),
            (
                "[filters]\nmin_range_m = 0.5\nmax_range_m = 0.2\n",
                "filters.max_range_m",
            ),
        ] {
            let e = parse(&format!("{base}{extra}"))
                .and_then(|rig| device_setup(&rig, &ClassifierConfig::DEFAULT).map(|_| ()))
                .unwrap_err();
            assert!(e.contains(key), "{extra:?}: {e}");
        }
        // The setup event's mount: the preset the axis starts from (pan the panned-vertical
        // one, tilt and none the tilted one); the rest goes in the rig event.
        for (axis, rpy, mount) in [
            (Axis::Pan, None, MountKind::PannedVertical),
            (Axis::Tilt, None, MountKind::TiltedHorizontal),
            (Axis::None, None, MountKind::TiltedHorizontal),
            (
                Axis::None,
                Some([90.0, 0.0, 0.0]),
                MountKind::TiltedHorizontal,
            ),
        ] {
            let rig = Rig {
                sensor: Some(SensorSpec::of(SensorName::Ld06)),
                mount: MountSpec {
                    xyz_m: [0.0; 3],
                    rpy_deg: rpy,
                },
                actuator: ActuatorSpec {
                    axis,
                    ..ActuatorSpec::default()
                },
                ..Rig::default()
            };
            assert_eq!(recording_setup(&rig).unwrap().0.mount, mount);
        }
        let e = device_setup(&Rig::default(), &ClassifierConfig::DEFAULT).unwrap_err();
        assert!(e.contains("names no sensor"), "{e}");
    }
}
