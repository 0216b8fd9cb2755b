//! The rig: one description of a robot's laser (which sensor, how it is mounted, what moves
//! it, what is masked and filtered, how its lines make observations, the classifier's
//! thresholds), read from a TOML file (`--rig FILE`, `docs/rig.md`) by `pyramid run`,
//! `record` and `listen`, with command-line flags that override the file's values.
//!
//! The file and the flags become a [`Rig`]: plain data, in the units the file uses (metres,
//! degrees). Nothing here knows the wire formats except two functions (the `to_wire` module),
//! [`device_setup`] and [`recording_setup`], which are the only places a rig is turned into
//! what the device's link (its Setup) and a recording (its setup and sensor events) carry.
//! Where one of them cannot carry a value the rig holds, they say so by name and refuse.

mod flags;
mod parse;
mod to_wire;

pub use flags::{merged_rule, RigArgs};
pub use parse::{parse_rig, read_rig_file};
pub use to_wire::{device_setup, mount_rig, recording_setup, rig_event};

use crate::design::{build, fit, DesignArgs, PyramidDesign};
use crate::rule::RuleArgs;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::laser::SensorKind;
use terrain_pyramid::Meters;

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
    /// of the actuator; `None`: [`DEFAULT_LINES_PER_OBSERVATION`].
    pub lines_per_observation: Option<u32>,
    /// The classifier's thresholds.
    pub classifier: ClassifierSpec,
    /// The pyramid the device is to run (`[design]`); `None`: the device keeps its own.
    pub design: Option<DesignSpec>,
}

/// The pyramid a rig asks its device to run (the file's `[design]`, sent by `pyramid listen`
/// as a Configure, `docs/rig.md`): each value is `pyramid design`'s flag of the same name, in
/// its units, `None` taking that flag's default (the design the firmware boots with). The
/// window is the device's (its Hello's W); the gate is the soft one of width 0.5, the
/// library's default.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DesignSpec {
    /// φ, the angle between two scan lines, degrees (a nodding lidar: the servo's rate ÷ the
    /// revolutions a second).
    pub phi_deg: Option<f64>,
    /// ψ, the angle between two returns of a line, degrees.
    pub psi_deg: Option<f64>,
    /// σ, the range noise's standard deviation, metres.
    pub sigma_m: Option<f64>,
    /// h, the sensor's height above the ground, metres.
    pub height_m: Option<f64>,
    /// The range the last band ends at, metres.
    pub max_range_m: Option<f64>,
    /// Δd, layer 0's cell, metres.
    pub base_m: Option<f64>,
    /// γ, the schedule's slope (`r_k = k·γ·Δd`); the start of the search with `fit_layers`.
    pub gamma: Option<f64>,
    /// Raise γ in steps of 0.5 until the design needs at most this many layers (1 ..= 16;
    /// `pyramid design --fit-layers`); `None`: γ as given.
    pub fit_layers: Option<u8>,
}

impl DesignSpec {
    /// `pyramid design`'s arguments for a window of `cells` per side: the rig's values over
    /// the flags' defaults.
    #[must_use]
    pub fn args(&self, cells: usize) -> DesignArgs {
        let d = DesignArgs::default();
        DesignArgs {
            phi_deg: self.phi_deg.unwrap_or(d.phi_deg),
            psi_deg: self.psi_deg.unwrap_or(d.psi_deg),
            sigma_m: self.sigma_m.unwrap_or(d.sigma_m),
            height_m: self.height_m.unwrap_or(d.height_m),
            max_range_m: self.max_range_m.unwrap_or(d.max_range_m),
            base_m: self.base_m.unwrap_or(d.base_m),
            gamma: self.gamma.unwrap_or(d.gamma),
            cells,
            ..d
        }
    }

    /// The design for a window of `cells` per side, fitted to `fit_layers` when set, and γ.
    ///
    /// # Errors
    /// The library's refusal (naming the value and its rule), or no γ fits.
    pub fn design(&self, cells: usize) -> Result<(f64, PyramidDesign), String> {
        let args = self.args(cells);
        match self.fit_layers {
            Some(n) => fit(&args, usize::from(n)).map(|(a, d)| (a.gamma, d)),
            None => build(&args)
                .map(|d| (args.gamma, d))
                .map_err(|e| e.to_string()),
        }
    }
}

/// The design `pyramid design` is asked for and its fit: with `--rig FILE` the file's
/// `[design]` for a window of `--cells` (its values and `fit_layers`), else the flags'.
///
/// # Errors
/// The file's errors, or a rig file without `[design]`.
pub fn asked_design(args: &crate::design::Args) -> Result<(DesignArgs, Option<u8>), String> {
    let Some(path) = &args.rig else {
        return Ok((args.design.clone(), args.fit_layers));
    };
    let spec = read_rig_file(path)?
        .design
        .ok_or_else(|| format!("--rig: {} has no [design] (docs/rig.md)", path.display()))?;
    Ok((spec.args(args.design.cells), spec.fit_layers))
}

/// The observation policy when the rig gives none, every sensor: 0, the policy that suits the
/// mount (`docs/lidars.md`, "Observations"): a SICK or a nodding lidar one observation per
/// sweep of its actuator, a panned lidar or one without an actuator one per revolution. A
/// full classifier scratch splits an observation (no return is lost), so a sweep's many
/// revolutions need no smaller policy. (Until 2026-12-06 a lidar's was 1: on a nodding rig
/// each revolution, one tilt, was judged alone, and the stairs went unseen;
/// `docs/lidars.md`, "On a board".)
pub const DEFAULT_LINES_PER_OBSERVATION: u32 = 0;

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use terrain_pyramid::wire::recording::{MountKind, SensorEvent};

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
    fn a_nodding_lidar_without_an_observation_policy_gets_one_observation_a_sweep() {
        // The library's 0: a sweep of the servo on a tilt, a revolution on a pan (one tilt a
        // revolution judged alone leaves a nodding rig's stairs unseen: docs/lidars.md).
        let text = "[sensor]\nkind = \"ld19\"\n[actuator]\naxis = \"tilt\"\n";
        let rig = parse(text).unwrap();
        assert_eq!(rig.lines_per_observation, None);
        let setup = device_setup(&rig, &ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(setup.lines_per_observation, 0);
        let (event, _) = recording_setup(&rig).unwrap();
        assert_eq!(event.lines_per_observation, 0);
        let frontend = terrain_pyramid::link::convert::frontend_config(&setup).unwrap();
        assert_eq!(frontend.lines_per_observation, 0);
        // The nodding example says so too.
        let (name, example) = EXAMPLES[0];
        let rig = parse_rig(Path::new(name), example).unwrap();
        assert_eq!(rig.lines_per_observation, Some(0));
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
        assert_eq!(setup.laser.servo_min_deg, 2.0);
        assert_eq!(setup.sensor_m, [0.10, 0.0, 1.00]);
        let rp = parse(EXAMPLES[1].1).unwrap();
        let setup = device_setup(&rp, &ClassifierConfig::DEFAULT).unwrap();
        assert_eq!(
            (setup.mount, setup.laser.sensor, setup.laser.actuator),
            (0, 2, 0)
        );
        assert_eq!(
            (setup.laser.baud, setup.lines_per_observation),
            (115_200, 0)
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
    fn the_nodding_example_s_design_fits_a_board_at_the_smallest_gamma() {
        let rig = parse(EXAMPLES[0].1).unwrap();
        let spec = rig.design.unwrap();
        assert_eq!(spec.fit_layers, Some(8));
        let (gamma, design) = spec.design(64).unwrap();
        assert!(design.layers().len() <= 8, "{}", design.layers().len());
        assert!((f64::from(design.schedule().gamma) - gamma).abs() < 1e-6);
        // Half a step less needs more than the board's 8 layers (or cannot hold its bands).
        let less = build(&DesignArgs {
            gamma: gamma - crate::design::FIT_GAMMA_STEP,
            ..spec.args(64)
        });
        assert!(less.map_or(true, |d| d.layers().len() > 8));
        // The sensor is the file's: φ = 15 °/s ÷ 10 Hz, the mount's 1 m.
        assert!((design.sensor().phi_rad - 1.5_f32.to_radians()).abs() < 1e-7);
        assert!((design.sensor().height_m - 1.0).abs() < 1e-7);
        // The other examples ask for no design: their devices keep their own.
        assert!(parse(EXAMPLES[1].1).unwrap().design.is_none());
        // A key left out takes `pyramid design`'s default.
        let rig = parse("[design]\nmax_range_m = 6\n").unwrap();
        let args = rig.design.unwrap().args(32);
        assert_eq!(
            args,
            DesignArgs {
                max_range_m: 6.0,
                cells: 32,
                ..DesignArgs::default()
            }
        );
    }

    #[test]
    fn a_bad_design_value_is_named_with_its_key_and_line() {
        for (text, start) in [
            ("[design]\nphi_deg = 0\n", "rig.toml:2: design.phi_deg"),
            ("[design]\n\ngamma = -2\n", "rig.toml:3: design.gamma"),
            (
                "[design]\nfit_layers = 17\n",
                "rig.toml:2: design.fit_layers",
            ),
            (
                "[design]\nmax_range_m = inf\n",
                "rig.toml:2: design.max_range_m",
            ),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.starts_with(start), "{text:?}: {e}");
        }
        let e = parse("[design]\ncells = 64\n").unwrap_err();
        assert!(e.contains("unknown field `cells`"), "{e}");
        // The library's own rules come with the design: Δd must exceed φ·h.
        let rig = parse("[design]\nphi_deg = 10\nheight_m = 2\n").unwrap();
        let e = rig.design.unwrap().design(64).unwrap_err();
        assert!(e.contains("base"), "{e}");
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
