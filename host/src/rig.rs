//! The rig: how the lidar is mounted on the robot (position, roll/pitch/yaw, the actuator's
//! axis, zero and sense) and which returns the device refuses before geometry (masked
//! sectors, a range window, a quality floor), as the user gives them.
//!
//! [`Rig`] is plain data, independent of any command-line parser: [`RigArgs`] fills it from
//! `pyramid run`'s flags, and [`Rig::apply`] writes it into the link's Setup (its sensor
//! position, mount byte and version-5 mount and filter blocks, `docs/protocol.md`, "0x87
//! Setup"). Every value is checked here as the device checks it, and an error names the flag.

use std::fmt;

use terrain_pyramid::link::convert::{frontend_config, MOUNT_LIMIT_DEG, SETUP_LIMIT_M};
use terrain_pyramid::wire::link::{FilterSetup, Setup, SETUP_SECTORS};

/// The actuator's axis, as the flags and the rig file name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Axis {
    /// About the robot's z axis, counter-clockwise seen from above.
    Pan,
    /// About the robot's y axis, positive looking down ahead.
    Tilt,
    /// No actuator (the actuator's angle is ignored).
    #[default]
    None,
}

impl Axis {
    /// The name as the file and the flags spell it.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Pan => "pan",
            Self::Tilt => "tilt",
            Self::None => "none",
        }
    }

    /// The axis of a name as the file spells it.
    pub(crate) fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "pan" => Self::Pan,
            "tilt" => Self::Tilt,
            "none" => Self::None,
            _ => return None,
        })
    }

    /// The wire code of Setup's mount block: 0 pan, 1 tilt, 2 none.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Pan => 0,
            Self::Tilt => 1,
            Self::None => 2,
        }
    }
}

/// A masked sector of the sensor's own angle, degrees: `[start, end)` in the angle's growing
/// sense (a spinning lidar: clockwise from its 0° seen from its top), wrapping past 0° when
/// `end < start`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mask {
    /// The first masked angle, degrees, 0 ≤ v < 360.
    pub start_deg: f64,
    /// The first angle past the sector, degrees, 0 ≤ v < 360.
    pub end_deg: f64,
}

/// The rig as the user describes it. `None` (or empty) leaves the recording's value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rig {
    /// The sensor's centre in the robot frame at actuator zero, metres (x forward, y left, z
    /// up): Setup's sensor position.
    pub xyz_m: Option<[f64; 3]>,
    /// The sensor's frame (x its 0°, z its top) relative to the actuator's frame at zero, roll,
    /// pitch, yaw in degrees (REP-103, `R_z(yaw)·R_y(pitch)·R_x(roll)`). Given, the mount is
    /// the general mount (Setup's mount 2).
    pub rpy_deg: Option<[f64; 3]>,
    /// The actuator's axis. Given, the mount is the general mount.
    pub axis: Option<Axis>,
    /// The reported actuator angle that is the geometry's 0, degrees.
    pub zero_deg: Option<f64>,
    /// The actuator reports its angle against the axis's positive sense.
    pub reversed: bool,
    /// Masked sectors, at most [`SETUP_SECTORS`].
    pub masks: Vec<Mask>,
    /// Returns nearer than this are refused, metres.
    pub min_range_m: Option<f64>,
    /// Returns farther than this are refused, metres.
    pub max_range_m: Option<f64>,
    /// Returns of a lower quality (the sensor's byte) are refused.
    pub min_quality: Option<u8>,
}

/// A rig value that cannot be sent: the flag it came from and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RigError {
    /// The flag (or rig-file key) the value came from, e.g. `--mount-rpy-deg`.
    pub field: &'static str,
    /// What is wrong with it.
    pub reason: String,
}

impl fmt::Display for RigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.reason)
    }
}

impl std::error::Error for RigError {}

fn err(field: &'static str, reason: impl Into<String>) -> RigError {
    RigError {
        field,
        reason: reason.into(),
    }
}

/// Parses `A,B,C` as three finite numbers, for `field`'s errors.
///
/// # Errors
/// Not three comma-separated finite numbers.
pub fn parse_triple(field: &'static str, text: &str) -> Result<[f64; 3], RigError> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [a, b, c] = parts.as_slice() else {
        return Err(err(
            field,
            format!("expected three numbers X,Y,Z, got {text:?}"),
        ));
    };
    let num = |s: &str| -> Result<f64, RigError> {
        let v: f64 = s
            .parse()
            .map_err(|_| err(field, format!("{s:?} is not a number")))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(err(field, format!("{s:?} is not finite")))
        }
    };
    Ok([num(a)?, num(b)?, num(c)?])
}

/// Parses a masked sector `A:B` (degrees, each 0 ≤ v < 360).
///
/// # Errors
/// Not two numbers separated by `:`, or an angle outside [0, 360).
pub fn parse_mask(text: &str) -> Result<Mask, RigError> {
    const FIELD: &str = "--mask-deg";
    let Some((a, b)) = text.split_once(':') else {
        return Err(err(
            FIELD,
            format!("expected START:END in degrees, got {text:?}"),
        ));
    };
    let angle = |s: &str| -> Result<f64, RigError> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| err(FIELD, format!("{s:?} is not a number")))?;
        if (0.0..360.0).contains(&v) {
            Ok(v)
        } else {
            Err(err(FIELD, format!("{v} is not within [0, 360)")))
        }
    };
    Ok(Mask {
        start_deg: angle(a)?,
        end_deg: angle(b)?,
    })
}

/// Centidegrees of an angle in [0, 360), rounded (360 wraps to 0).
fn centidegrees(deg: f64) -> u16 {
    // 0 ≤ deg < 360: the product is below 36 000.5.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let c = (deg * 100.0).round() as u32 % 36_000;
    u16::try_from(c).unwrap_or(0)
}

/// Centimetres of a range in metres (0 ≤ v ≤ 655.35), rounded.
fn centimetres(field: &'static str, m: f64) -> Result<u16, RigError> {
    if !(m.is_finite() && (0.0..=655.35).contains(&m)) {
        return Err(err(field, format!("{m} m is not within [0, 655.35]")));
    }
    // Checked above: below 65 535.5.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    Ok((m * 100.0).round() as u16)
}

impl Rig {
    /// This rig with `over`'s values where `over` gives them (flags over a rig file): each
    /// given value replaces this one's, the masks as a whole, a reversed sense stays.
    #[must_use]
    pub fn then(self, over: Self) -> Self {
        Self {
            xyz_m: over.xyz_m.or(self.xyz_m),
            rpy_deg: over.rpy_deg.or(self.rpy_deg),
            axis: over.axis.or(self.axis),
            zero_deg: over.zero_deg.or(self.zero_deg),
            reversed: over.reversed || self.reversed,
            masks: if over.masks.is_empty() {
                self.masks
            } else {
                over.masks
            },
            min_range_m: over.min_range_m.or(self.min_range_m),
            max_range_m: over.max_range_m.or(self.max_range_m),
            min_quality: over.min_quality.or(self.min_quality),
        }
    }

    /// Whether the rig changes nothing.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// Writes the rig into `setup`: the sensor position, and, when the orientation or the
    /// axis is given, the general mount (mount 2; a missing orientation or axis is taken from
    /// the setup's preset); the zero and sense on any mount; the filter block. Then checks the
    /// result as the device will ([`frontend_config`]).
    ///
    /// # Errors
    /// The first value the device would refuse, named by its flag.
    pub fn apply(&self, setup: &mut Setup) -> Result<(), RigError> {
        if let Some(xyz) = self.xyz_m {
            for v in xyz {
                if v.abs() >= f64::from(SETUP_LIMIT_M) {
                    return Err(err(
                        "--mount-xyz-m",
                        format!("{v} m is not within (−1 000, 1 000)"),
                    ));
                }
            }
            // Checked above: within ±1 000 m.
            #[allow(clippy::cast_possible_truncation)]
            let xyz32 = xyz.map(|v| v as f32);
            setup.sensor_m = xyz32;
        }
        let angle = |field: &'static str, v: f64| -> Result<f32, RigError> {
            if v.abs() > f64::from(MOUNT_LIMIT_DEG) {
                return Err(err(field, format!("{v}° is not within [−360, 360]")));
            }
            // Checked above.
            #[allow(clippy::cast_possible_truncation)]
            Ok(v as f32)
        };
        if self.rpy_deg.is_some() || self.axis.is_some() {
            // The preset's own values where the general mount is not given in full.
            let (preset_rpy, preset_axis) = match setup.mount {
                0 => ([90.0, 0.0, 0.0], Axis::Pan),
                1 => ([0.0; 3], Axis::Tilt),
                _ => (
                    setup.mount_block.rpy_deg.map(f64::from),
                    match setup.mount_block.axis {
                        0 => Axis::Pan,
                        1 => Axis::Tilt,
                        _ => Axis::None,
                    },
                ),
            };
            let [r, p, y] = self.rpy_deg.unwrap_or(preset_rpy);
            setup.mount = 2;
            setup.mount_block.axis = self.axis.unwrap_or(preset_axis).code();
            setup.mount_block.rpy_deg = [
                angle("--mount-rpy-deg", r)?,
                angle("--mount-rpy-deg", p)?,
                angle("--mount-rpy-deg", y)?,
            ];
        }
        if let Some(zero) = self.zero_deg {
            setup.mount_block.zero_deg = angle("--actuator-zero-deg", zero)?;
        }
        if self.reversed {
            setup.mount_block.sense = -1;
        }
        if !self.masks.is_empty()
            || self.min_range_m.is_some()
            || self.max_range_m.is_some()
            || self.min_quality.is_some()
        {
            setup.filter = self.filter(setup.filter)?;
        }
        frontend_config(setup).map_err(|e| {
            let field = match e.field() as u8 {
                51..=53 => "--mount-xyz-m",
                71 => "--actuator",
                72 => "--actuator-reversed",
                73 => "--actuator-zero-deg",
                74..=76 => "--mount-rpy-deg",
                77 | 78 => "--filter-min-range-m/--filter-max-range-m",
                79 | 80 => "--mask-deg",
                _ => "the recording's setup",
            };
            err(field, e.to_string())
        })?;
        Ok(())
    }

    /// The filter block of `base` with the rig's filters over it.
    fn filter(&self, base: FilterSetup) -> Result<FilterSetup, RigError> {
        let mut f = base;
        if let Some(m) = self.min_range_m {
            f.min_range_cm = centimetres("--filter-min-range-m", m)?;
        }
        if let Some(m) = self.max_range_m {
            f.max_range_cm = centimetres("--filter-max-range-m", m)?;
            if f.max_range_cm == 0 {
                return Err(err(
                    "--filter-max-range-m",
                    "must be above 0 (omit it for no limit)",
                ));
            }
        }
        if f.max_range_cm != 0 && f.max_range_cm <= f.min_range_cm {
            return Err(err(
                "--filter-max-range-m",
                format!(
                    "{} m is not above the minimum range {} m",
                    f64::from(f.max_range_cm) / 100.0,
                    f64::from(f.min_range_cm) / 100.0
                ),
            ));
        }
        if let Some(q) = self.min_quality {
            f.min_quality = q;
        }
        if !self.masks.is_empty() {
            if self.masks.len() > SETUP_SECTORS {
                return Err(err(
                    "--mask-deg",
                    format!(
                        "{} sectors given, the device holds at most {SETUP_SECTORS}",
                        self.masks.len()
                    ),
                ));
            }
            f.sectors = [(0, 0); SETUP_SECTORS];
            for (slot, m) in f.sectors.iter_mut().zip(&self.masks) {
                *slot = (centidegrees(m.start_deg), centidegrees(m.end_deg));
            }
            f.sector_count = u8::try_from(self.masks.len()).unwrap_or(0);
        }
        Ok(f)
    }
}

/// The rig's flags (`pyramid run`): each overrides the recording's value.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RigArgs {
    /// The sensor's centre in the robot frame at actuator zero, metres (x forward, y left, z
    /// up), e.g. `0.1,0,0.45`.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub mount_xyz_m: Option<String>,
    /// The sensor's frame (x its 0°, z its top, as its manual) relative to the actuator's
    /// frame at actuator zero (x forward, z up): roll, pitch, yaw in degrees (REP-103, as a
    /// URDF joint's rpy). The panned-vertical preset is `90,0,0`, a lidar lying flat, top up,
    /// 0° forward `0,0,0`, upside down with its 0° to the left `180,0,90`.
    #[arg(long, value_name = "R,P,Y", allow_hyphen_values = true)]
    pub mount_rpy_deg: Option<String>,
    /// The actuator's axis: pan (about z, counter-clockwise from above), tilt (about y,
    /// positive looks down), none.
    #[arg(long, value_enum)]
    pub actuator: Option<Axis>,
    /// The reported actuator angle that is the geometry's 0, degrees.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub actuator_zero_deg: Option<f64>,
    /// The actuator reports its angle against the axis's positive sense.
    #[arg(long)]
    pub actuator_reversed: bool,
    /// A masked sector of the sensor's own angle, START:END degrees (clockwise from its 0°
    /// for a spinning lidar; a SICK's beam angle), END excluded, wrapping past 0 when END <
    /// START. Repeatable, at most 8.
    #[arg(long, value_name = "A:B")]
    pub mask_deg: Vec<String>,
    /// Returns nearer than this are refused before geometry, metres (`--filter-min-range-m`;
    /// the design's `--max-range-m` is the pyramid's reach, not a filter).
    #[arg(long, value_name = "M")]
    pub filter_min_range_m: Option<f64>,
    /// Returns farther than this are refused before geometry, metres
    /// (`--filter-max-range-m`).
    #[arg(long, value_name = "M")]
    pub filter_max_range_m: Option<f64>,
    /// Returns of a lower quality (the sensor's intensity or quality byte) are refused
    /// (`--filter-min-quality`).
    #[arg(long, value_name = "Q")]
    pub filter_min_quality: Option<u8>,
}

impl RigArgs {
    /// The rig the flags describe.
    ///
    /// # Errors
    /// A flag's value that does not parse, named by its flag.
    pub fn rig(&self) -> Result<Rig, RigError> {
        Ok(Rig {
            xyz_m: self
                .mount_xyz_m
                .as_deref()
                .map(|t| parse_triple("--mount-xyz-m", t))
                .transpose()?,
            rpy_deg: self
                .mount_rpy_deg
                .as_deref()
                .map(|t| parse_triple("--mount-rpy-deg", t))
                .transpose()?,
            axis: self.actuator,
            zero_deg: self.actuator_zero_deg,
            reversed: self.actuator_reversed,
            masks: self
                .mask_deg
                .iter()
                .map(|t| parse_mask(t))
                .collect::<Result<_, _>>()?,
            min_range_m: self.filter_min_range_m,
            max_range_m: self.filter_max_range_m,
            min_quality: self.filter_min_quality,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::classify::ClassifierConfig;
    use terrain_pyramid::link::convert::setup_message;
    use terrain_pyramid::wire::link::MountSetup;
    use terrain_pyramid::wire::recording::{MountKind, SetupEvent};

    fn setup(mount: MountKind) -> Setup {
        setup_message(
            &SetupEvent {
                mount,
                measuring_mode: 0,
                field_deg: 180,
                resolution_cdeg: 50,
                sensor_m: [0.0, 0.0, 0.5],
                lines_per_observation: 0,
            },
            &ClassifierConfig::default(),
        )
    }

    #[test]
    fn the_flags_become_the_general_mount_and_the_filters() {
        let args = RigArgs {
            mount_xyz_m: Some("0.1, 0, 0.45".into()),
            mount_rpy_deg: Some("180,0,90".into()),
            actuator: Some(Axis::Tilt),
            actuator_zero_deg: Some(-5.0),
            actuator_reversed: true,
            mask_deg: vec!["135:225".into(), "350:10".into()],
            filter_min_range_m: Some(0.05),
            filter_max_range_m: Some(12.0),
            filter_min_quality: Some(10),
        };
        let mut s = setup(MountKind::TiltedHorizontal);
        args.rig().unwrap().apply(&mut s).unwrap();
        assert_eq!(s.mount, 2);
        assert_eq!(s.sensor_m, [0.1, 0.0, 0.45]);
        assert_eq!(
            s.mount_block,
            MountSetup {
                axis: 1,
                sense: -1,
                zero_deg: -5.0,
                rpy_deg: [180.0, 0.0, 90.0]
            }
        );
        assert_eq!(
            (
                s.filter.min_range_cm,
                s.filter.max_range_cm,
                s.filter.min_quality
            ),
            (5, 1200, 10)
        );
        assert_eq!(s.filter.sector_count, 2);
        assert_eq!(s.filter.sectors[..2], [(13_500, 22_500), (35_000, 1_000)]);
        // Only the rotation: the preset's axis stays.
        let mut p = setup(MountKind::PannedVertical);
        Rig {
            rpy_deg: Some([90.0, 0.0, 45.0]),
            ..Rig::default()
        }
        .apply(&mut p)
        .unwrap();
        assert_eq!((p.mount, p.mount_block.axis), (2, 0));
        // Nothing given: nothing changes.
        let mut q = setup(MountKind::PannedVertical);
        Rig::default().apply(&mut q).unwrap();
        assert_eq!(q, setup(MountKind::PannedVertical));
    }

    /// The flags sit beside `pyramid run`'s others without a clash (clap's own checks).
    #[test]
    fn the_flags_fit_pyramid_run() {
        use clap::{CommandFactory, Parser};
        #[derive(Parser)]
        struct Run {
            #[command(flatten)]
            args: crate::run::Args,
        }
        Run::command().debug_assert();
        let parsed = Run::try_parse_from([
            "run",
            "--recording",
            "r.rec",
            "--out",
            "o",
            "--mount-rpy-deg",
            "180,0,90",
            "--actuator",
            "tilt",
            "--actuator-zero-deg",
            "-5",
            "--actuator-reversed",
            "--mask-deg",
            "135:225",
            "--mask-deg",
            "350:10",
            "--filter-min-range-m",
            "0.05",
            "--filter-max-range-m",
            "12",
            "--filter-min-quality",
            "10",
        ])
        .unwrap();
        let rig = parsed.args.mount.rig().unwrap();
        assert_eq!(rig.rpy_deg, Some([180.0, 0.0, 90.0]));
        assert_eq!(rig.zero_deg, Some(-5.0));
        assert!(rig.reversed);
        assert_eq!(rig.masks.len(), 2);
        assert_eq!(
            (rig.min_range_m, rig.max_range_m, rig.min_quality),
            (Some(0.05), Some(12.0), Some(10))
        );
    }

    #[test]
    fn errors_name_the_flag() {
        let field = |a: RigArgs| {
            let mut s = setup(MountKind::TiltedHorizontal);
            match a.rig() {
                Err(e) => e.field,
                Ok(r) => r.apply(&mut s).unwrap_err().field,
            }
        };
        let d = RigArgs::default;
        assert_eq!(
            field(RigArgs {
                mount_xyz_m: Some("1,2".into()),
                ..d()
            }),
            "--mount-xyz-m"
        );
        assert_eq!(
            field(RigArgs {
                mount_xyz_m: Some("0,0,1000".into()),
                ..d()
            }),
            "--mount-xyz-m"
        );
        assert_eq!(
            field(RigArgs {
                mount_rpy_deg: Some("0,400,0".into()),
                ..d()
            }),
            "--mount-rpy-deg"
        );
        assert_eq!(
            field(RigArgs {
                actuator_zero_deg: Some(f64::NAN),
                ..d()
            }),
            "--actuator-zero-deg"
        );
        assert_eq!(
            field(RigArgs {
                mask_deg: vec!["10".into()],
                ..d()
            }),
            "--mask-deg"
        );
        assert_eq!(
            field(RigArgs {
                mask_deg: vec!["0:360".into()],
                ..d()
            }),
            "--mask-deg"
        );
        assert_eq!(
            field(RigArgs {
                mask_deg: vec!["1:2".into(); 9],
                ..d()
            }),
            "--mask-deg"
        );
        assert_eq!(
            field(RigArgs {
                filter_min_range_m: Some(2.0),
                filter_max_range_m: Some(1.0),
                ..d()
            }),
            "--filter-max-range-m"
        );
        assert_eq!(
            field(RigArgs {
                filter_min_range_m: Some(-1.0),
                ..d()
            }),
            "--filter-min-range-m"
        );
    }
}
