//! The rig file (`--rig FILE`, `docs/rig.md`): its TOML as it is written, and its parsing
//! into a [`Rig`], each value checked and each error naming the file, the line and the key.
use super::{Axis, DesignSpec, Rig, SensorName, SensorSpec, ServoSweep, LIMIT_M, MAX_MASKS};
use serde::Deserialize;
use std::path::Path;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::laser::Sensor;
use toml::Spanned;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileRig {
    sensor: Option<FileSensor>,
    mount: Option<FileMount>,
    actuator: Option<FileActuator>,
    filters: Option<FileFilters>,
    observation: Option<FileObservation>,
    classifier: Option<FileClassifier>,
    design: Option<FileDesign>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDesign {
    phi_deg: Option<Spanned<f64>>,
    psi_deg: Option<Spanned<f64>>,
    sigma_m: Option<Spanned<f64>>,
    height_m: Option<Spanned<f64>>,
    max_range_m: Option<Spanned<f64>>,
    base_m: Option<Spanned<f64>>,
    gamma: Option<Spanned<f64>>,
    fit_layers: Option<Spanned<i64>>,
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
        // An optional number of `[classifier]` in [0, `limit`), `rule` saying so in the
        // refusal.
        let below = |v: &Option<Spanned<f64>>,
                     key: &str,
                     limit: f64,
                     rule: &str|
         -> Result<Option<f64>, String> {
            let key = format!("classifier.{key}");
            v.as_ref()
                .map(|v| c.num(v, &key, |x| (0.0..limit).contains(&x), rule))
                .transpose()
        };
        let metres = |v: &Option<Spanned<f64>>, key: &str| below(v, key, LIMIT_M, "in [0, 1000) m");
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
        spec.rule.step_m = metres(&k.step_m, "step_m")?;
        spec.rule.residual_m = metres(&k.residual_m, "residual_m")?;
        spec.rule.noise_sigma_m = metres(&k.noise_sigma_m, "noise_sigma_m")?;
        spec.rule.max_slope_deg = below(&k.max_slope_deg, "max_slope_deg", 89.0, "in [0, 89)")?;
        spec.rule.angle_sigma_deg =
            below(&k.angle_sigma_deg, "angle_sigma_deg", 45.0, "in [0, 45)")?;
        spec.rule.noise_factor = below(&k.noise_factor, "noise_factor", 100.0, "in [0, 100)")?;
        if let Some(v) = &k.robot_height_m {
            spec.robot_height_m = Some(c.num(
                v,
                "classifier.robot_height_m",
                |x| x > 0.0 && x < LIMIT_M,
                "in (0, 1000) m",
            )?);
        }
        spec.drop_m = metres(&k.drop_m, "drop_m")?;
        spec.ceiling_m = metres(&k.ceiling_m, "ceiling_m")?;
        // A plane parameter under the paper's rule is refused here, with its line.
        if let Err(e) = spec.rule.apply(ClassifierConfig::DEFAULT) {
            return Err(format!("{}: [classifier]: {e}", path.display()));
        }
    }
    if let Some(d) = &file.design {
        rig.design = Some(design_spec(&c, d)?);
    }
    Ok(rig)
}

/// `[design]`: each value finite and positive here (the library's own rules, with the
/// device's window, are checked when the design is built: `pyramid listen` does so before
/// it connects).
fn design_spec(c: &Checker<'_>, d: &FileDesign) -> Result<DesignSpec, String> {
    let positive = |v: &Option<Spanned<f64>>, key: &str| {
        let key = format!("design.{key}");
        v.as_ref()
            .map(|v| c.num(v, &key, |x| x > 0.0, "a positive number"))
            .transpose()
    };
    let fit_layers = d
        .fit_layers
        .as_ref()
        .map(|v| c.int(v, "design.fit_layers", 1, 16))
        .transpose()?
        .map(|n| u8::try_from(n).unwrap_or(u8::MAX));
    Ok(DesignSpec {
        phi_deg: positive(&d.phi_deg, "phi_deg")?,
        psi_deg: positive(&d.psi_deg, "psi_deg")?,
        sigma_m: positive(&d.sigma_m, "sigma_m")?,
        height_m: positive(&d.height_m, "height_m")?,
        max_range_m: positive(&d.max_range_m, "max_range_m")?,
        base_m: positive(&d.base_m, "base_m")?,
        gamma: positive(&d.gamma, "gamma")?,
        fit_layers,
    })
}
