//! The rig's command-line flags (`--rig FILE` and the flags that override the file's
//! values), read into a [`Rig`], and the classifier's rule flags merged over the file's.
use super::{read_rig_file, Axis, Rig, SensorName, SensorSpec, ServoSweep, LIMIT_M, MAX_MASKS};
use crate::rule::RuleArgs;
use std::path::PathBuf;
use terrain_pyramid::laser::Sensor;

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
    /// Lines (SICK telegrams, lidar revolutions) per observation; 0 = the mount's policy: one
    /// per sweep of a tilting or nodding actuator, one per revolution on a pan or without an
    /// actuator [default: 0].
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
        pair_depth: flags.pair_depth.or(file.pair_depth),
    }
}

/// A `--mask-deg FROM:TO` flag, as `pyramid run` reads it ([`crate::rig::parse_mask`]).
fn mask_arg(text: &str) -> Result<[f64; 2], String> {
    crate::rig::parse_mask(text)
        .map(|m| [m.start_deg, m.end_deg])
        .map_err(|e| e.to_string())
}
