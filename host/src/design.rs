//! `pyramid design`: derive a pyramid design (the bound δ(d) of eq. 17, the layers' resolutions
//! and range bands of eq. 20, the gates, the RAM) from a sensor and a schedule, print it as a
//! table or as JSON, and optionally draw the paper's Figure 2 as a PNG.
//!
//! The maths is the library's ([`terrain_pyramid::design`]); this module only converts the
//! command line's units (degrees) to the library's (radians, metres), and formats the result.
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use terrain_pyramid::design::BoundTerms;
use terrain_pyramid::{
    DefaultDesign, Design, DesignError, GateShape, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE,
};

/// What a 2-D lidar nodding on an actuator shows of a step (`--revolution-hz`).
pub mod nod;
/// Figure 2 as a PNG (`pyramid design --plot`, and the lab's experiments).
pub mod plot;

/// The number of layers the pyramid is compiled for: the `L` of `Design::<L>`.
pub const LAYER_CAPACITY: usize = 16;

/// The design this command derives.
pub type PyramidDesign = Design<LAYER_CAPACITY>;

/// The distances, metres, at which the bound δ(d) is listed (those within the maximum range,
/// plus the maximum range itself).
pub const BOUND_DISTANCES_M: [f32; 7] = [0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0];

/// Arguments of `pyramid design`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The sensor, the schedule, the window and the gate.
    #[command(flatten)]
    pub design: DesignArgs,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Also draw the bound, its terms and the bands (the paper's Figure 2) into this PNG file.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,
    /// Fit the design to a board that holds N layers (1 ..= 16; the `qemu-mps2` and `stm32f4`
    /// firmware hold 8, the micro:bit's 4): γ is raised from `--gamma` in steps of 0.5 until
    /// the bands need at most N layers and each window holds its band, and the design of
    /// that γ is reported (docs/lidars.md, "On a board").
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=16))]
    pub fit_layers: Option<u8>,
    /// The design of a rig file's `[design]` (docs/rig.md): what `pyramid listen --rig FILE`
    /// sends a device of `--cells` cells a side. Its values replace the sensor and schedule
    /// flags, which may not be given with it.
    #[arg(long, value_name = "FILE", conflicts_with_all = [
        "phi_deg", "psi_deg", "sigma_m", "height_m", "base_m", "gamma", "max_range_m",
        "gate", "gate_width", "uniform_resolution", "fit_layers",
    ])]
    pub rig: Option<PathBuf>,
    /// For a lidar on a nodding actuator: what the nod shows of a step.
    #[command(flatten)]
    pub nod: nod::NodArgs,
}

/// The step by which `--fit-layers` raises γ.
pub const FIT_GAMMA_STEP: f64 = 0.5;

/// The largest γ `--fit-layers` tries: beyond it layer 1's cells are 6.4 m at Δd = 0.1 m.
pub const FIT_GAMMA_MAX: f64 = 64.0;

/// Raises `args.gamma` in steps of [`FIT_GAMMA_STEP`] until the design needs at most
/// `layers` layers (≤ [`LAYER_CAPACITY`]) and every window holds its band: the arguments of
/// that γ and their design. A refusal that γ cannot mend (a bad φ, σ, range, window or gate;
/// γ ≤ 1) is returned at once.
///
/// # Errors
/// That refusal, or no γ up to [`FIT_GAMMA_MAX`] fits: the refusal at that γ, in words.
pub fn fit(args: &DesignArgs, layers: usize) -> Result<(DesignArgs, PyramidDesign), String> {
    let mut tried = args.clone();
    loop {
        let outcome = build(&tried);
        let mendable = match &outcome {
            Ok(design) => design.layers().len() > layers,
            Err(DesignError::TooManyLayers { .. } | DesignError::WindowTooSmall { .. }) => true,
            Err(_) => false,
        };
        if !mendable {
            return outcome
                .map(|design| (tried, design))
                .map_err(|e| e.to_string());
        }
        if tried.gamma + FIT_GAMMA_STEP > FIT_GAMMA_MAX {
            let needed = match outcome {
                Ok(design) => format!("needs {} layers", design.layers().len()),
                Err(e) => e.to_string(),
            };
            return Err(format!(
                "--fit-layers: no gamma from {} to {FIT_GAMMA_MAX} fits {layers} layers (at {}: {needed}); lower --max-range-m or raise --base-m",
                args.gamma, tried.gamma
            ));
        }
        tried.gamma += FIT_GAMMA_STEP;
    }
}

/// The flags that describe a design: the sensor, the resolution schedule, the window and the
/// gate. Shared by every command that builds a pyramid (`design`, `replay`), with the same
/// names and defaults.
///
/// The numeric flags accept values that start with a hyphen (`--height-m -1`, `--sigma-m -inf`)
/// so that the library, not the parser, refuses them with its own message.
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct DesignArgs {
    /// φ, the sensor's vertical angular resolution, degrees.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.5,
        allow_hyphen_values = true
    )]
    pub phi_deg: f64,
    /// ψ, the horizontal angular resolution (pan step between scan lines), degrees.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 2.0,
        allow_hyphen_values = true
    )]
    pub psi_deg: f64,
    /// σ, the standard deviation of the range noise, metres.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.15,
        allow_hyphen_values = true
    )]
    pub sigma_m: f64,
    /// h, the height of the sensor above the ground, metres.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 1.0,
        allow_hyphen_values = true
    )]
    pub height_m: f64,
    /// Δd, the finest cell size (layer 0), metres; must exceed φ·h.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.1,
        allow_hyphen_values = true
    )]
    pub base_m: f64,
    /// γ, the linear scaling parameter of the schedule `r_k = k·γ·Δd`; must exceed 1.
    #[arg(
        long,
        value_name = "G",
        default_value_t = 2.0,
        allow_hyphen_values = true
    )]
    pub gamma: f64,
    /// The sensor's maximum range, metres: the last band ends there.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 10.0,
        allow_hyphen_values = true
    )]
    pub max_range_m: f64,
    /// The window of every layer, cells per side (even).
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub cells: usize,
    /// The gate that assigns an observation to the layers: the top-hat over the band (hard) or
    /// the paper's Gaussian (soft).
    #[arg(long, value_enum, default_value_t = GateArg::Soft)]
    pub gate: GateArg,
    /// The soft gate's width σ_g as a fraction of its band's width (ignored by the hard gate).
    #[arg(
        long,
        value_name = "F",
        default_value_t = 0.5,
        allow_hyphen_values = true
    )]
    pub gate_width: f64,
    /// Every layer at the base cell size, the bands still those of the linear schedule (the
    /// paper's stairs experiment); the window must then hold each band at the base cell.
    /// Not for a lidar on a nodding actuator: its scan lines lie d²·φ/h apart on the ground,
    /// so where that exceeds the base cell (beyond 2 m for an LD19 nodding at 15 °/s, h 1 m,
    /// 0.1 m cells) a cell holds at most one line a sweep and cannot tell a riser from the
    /// ground (docs/lidars.md, "Why the design's resolutions").
    #[arg(long)]
    pub uniform_resolution: bool,
}

impl Default for DesignArgs {
    /// The flags' defaults: the library's default sensor and schedule (the design the
    /// firmware boots with), 64 cells per side.
    fn default() -> Self {
        Self {
            phi_deg: 0.5,
            psi_deg: 2.0,
            sigma_m: 0.15,
            height_m: 1.0,
            base_m: 0.1,
            gamma: 2.0,
            max_range_m: 10.0,
            cells: 64,
            gate: GateArg::Soft,
            gate_width: 0.5,
            uniform_resolution: false,
        }
    }
}

/// The gate shape, as the command line names it.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum GateArg {
    /// The top-hat over the band (eq. 8).
    Hard,
    /// `exp(−½ (d − c_k)² / σ_g,k²)`, centred on the band.
    Soft,
}

/// A value the user gave, in the library's `f32`: non-finite and negative values stay what they
/// are, so that the library's validation names them.
#[allow(clippy::cast_possible_truncation)]
fn to_f32(value: f64) -> f32 {
    value as f32
}

/// The sensor model the arguments describe, in the library's units (radians, metres).
#[must_use]
pub fn sensor_model(args: &DesignArgs) -> SensorModel {
    SensorModel {
        phi_rad: to_f32(args.phi_deg.to_radians()),
        psi_rad: to_f32(args.psi_deg.to_radians()),
        sigma_m: to_f32(args.sigma_m),
        height_m: to_f32(args.height_m),
        max_range_m: to_f32(args.max_range_m),
    }
}

/// The resolution schedule the arguments describe.
#[must_use]
pub fn schedule(args: &DesignArgs) -> Schedule {
    let gate = match args.gate {
        GateArg::Hard => GateShape::Hard,
        GateArg::Soft => GateShape::Soft {
            width_factor: to_f32(args.gate_width),
        },
    };
    Schedule {
        base_m: to_f32(args.base_m),
        gamma: to_f32(args.gamma),
        gate,
        uniform_resolution: args.uniform_resolution,
    }
}

/// Validates the arguments through the library and derives the design.
///
/// # Errors
/// The library's refusal, which names the flag and the rule.
pub fn build(args: &DesignArgs) -> Result<PyramidDesign, DesignError> {
    Design::new(sensor_model(args), schedule(args), args.cells)
}

/// The design the firmware boots with (its link's Configure can change it): the library's
/// default sensor and schedule, [`DEFAULT_CELLS_PER_SIDE`] cells per side.
///
/// # Errors
/// The library's refusal of its own defaults, in words (it never refuses them).
pub fn firmware_design() -> Result<DefaultDesign, String> {
    DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .map_err(|e| e.to_string())
}

/// The static RAM, bytes, of exactly this design's layers: the pyramid's cells and windows
/// and the classifier's gating, by the library's own layouts
/// ([`terrain_pyramid::pyramid::ram_bytes`], [`terrain_pyramid::gate::ram_bytes`]).
#[must_use]
pub fn static_ram_bytes<const L: usize>(design: &Design<L>) -> usize {
    let layers = design.layers().len();
    terrain_pyramid::pyramid::ram_bytes(design.cells_per_side(), layers)
        + terrain_pyramid::gate::ram_bytes(layers)
}

/// The distances at which the bound is listed: [`BOUND_DISTANCES_M`] up to the maximum range,
/// then the maximum range itself (once).
#[must_use]
pub fn bound_distances(max_range_m: f32) -> Vec<f32> {
    let mut ds: Vec<f32> = BOUND_DISTANCES_M
        .iter()
        .copied()
        .filter(|&d| d <= max_range_m)
        .collect();
    if ds.last() != Some(&max_range_m) {
        ds.push(max_range_m);
    }
    ds
}

/// A length in metres for the JSON output: rounded to 0.1 mm, still a number.
fn metres(value: f32) -> f64 {
    (f64::from(value) * 1e4).round() / 1e4
}

/// One layer of the JSON report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct LayerReport {
    /// The layer's index, 0 the finest.
    pub index: usize,
    /// The cell size `r_k`, metres.
    pub resolution_m: f64,
    /// The range band `[d_k, d_{k+1}]`, metres.
    pub band_m: [f64; 2],
    /// The soft gate's centre, metres.
    pub gate_center_m: f64,
    /// The soft gate's width σ_g, metres (0 for the hard gate).
    pub gate_sigma_m: f64,
    /// The window, cells per side.
    pub cells_per_side: usize,
    /// The window's side, metres: cells per side × resolution.
    pub extent_m: f64,
}

/// The bound δ(d) and its terms at one distance, for the JSON report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct BoundReport {
    /// The distance d, metres.
    pub d_m: f64,
    /// The range-noise term, metres.
    pub noise_m: f64,
    /// The horizontal-resolution term, metres.
    pub horizontal_m: f64,
    /// The vertical-resolution term, metres.
    pub vertical_m: f64,
    /// δ(d), metres.
    pub total_m: f64,
}

impl From<BoundTerms> for BoundReport {
    fn from(t: BoundTerms) -> Self {
        Self {
            d_m: metres(t.d_m),
            noise_m: metres(t.noise_m),
            horizontal_m: metres(t.horizontal_m),
            vertical_m: metres(t.vertical_m),
            total_m: metres(t.total_m),
        }
    }
}

/// The whole report: what `--json` prints.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Report {
    /// γ of the schedule, the one `--fit-layers` chose when given.
    pub gamma: f64,
    /// The layers, finest first.
    pub layers: Vec<LayerReport>,
    /// The bound at the listed distances.
    pub bound: Vec<BoundReport>,
    /// The static RAM the design's layers need, bytes: the pyramid's cells and windows and
    /// the classifier's gating.
    pub static_ram_bytes: usize,
    /// With `--revolution-hz`: what the design's nod shows of a step ([`nod::plan`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nodding: Option<nod::NodPlan>,
}

/// The report of a design.
#[must_use]
pub fn report<const L: usize>(design: &Design<L>) -> Report {
    let cells = design.cells_per_side();
    #[allow(clippy::cast_precision_loss)]
    let cells_f = cells as f32;
    let layers = design
        .layers()
        .iter()
        .enumerate()
        .map(|(index, l)| LayerReport {
            index,
            resolution_m: metres(l.resolution_m),
            band_m: [metres(l.band_inner_m), metres(l.band_outer_m)],
            gate_center_m: metres(l.gate_center_m),
            gate_sigma_m: metres(l.gate_sigma_m),
            cells_per_side: cells,
            extent_m: metres(cells_f * l.resolution_m),
        })
        .collect();
    let gamma = metres(design.schedule().gamma);
    let sensor = design.sensor();
    let bound = bound_distances(sensor.max_range_m)
        .into_iter()
        .map(|d| BoundReport::from(sensor.bound(d)))
        .collect();
    Report {
        gamma,
        layers,
        bound,
        static_ram_bytes: static_ram_bytes(design),
        nodding: None,
    }
}

/// The human-readable table.
fn table<const L: usize>(args: &DesignArgs, design: &Design<L>, report: &Report) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let gate = match design.schedule().gate {
        GateShape::Hard => "hard (top-hat over the band)".to_string(),
        GateShape::Soft { width_factor } => {
            format!("soft (Gaussian, sigma_g = {width_factor} x band width)")
        }
    };
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "Sensor:   phi = {}°, psi = {}°, sigma = {} m, h = {} m, max range = {} m",
        args.phi_deg, args.psi_deg, args.sigma_m, args.height_m, args.max_range_m
    );
    let _ = writeln!(
        s,
        "Schedule: base = {} m, gamma = {}, r_0 = base, r_k = k*gamma*base; gate {gate}",
        args.base_m, args.gamma
    );
    let _ = writeln!(
        s,
        "Window:   {} x {} cells per layer\n",
        design.cells_per_side(),
        design.cells_per_side()
    );
    let _ = writeln!(
        s,
        "Layers ({}):\n  layer  resolution       band [m]        gate centre  gate sigma   window extent",
        report.layers.len()
    );
    for l in &report.layers {
        let _ = writeln!(
            s,
            "  {:>5}  {:>8.3} m  {:>7.3} .. {:>7.3}  {:>9.3} m  {:>8.3} m  {:>9.2} m x {:.2} m",
            l.index,
            l.resolution_m,
            l.band_m[0],
            l.band_m[1],
            l.gate_center_m,
            l.gate_sigma_m,
            l.extent_m,
            l.extent_m
        );
    }
    let _ = writeln!(
        s,
        "\nCell-size bound delta(d) = noise + horizontal + vertical (eq. 17), metres:\n  {:>7}  {:>8}  {:>10}  {:>8}  {:>8}",
        "d", "noise", "horizontal", "vertical", "delta"
    );
    for b in &report.bound {
        let _ = writeln!(
            s,
            "  {:>7.2}  {:>8.4}  {:>10.4}  {:>8.4}  {:>8.4}",
            b.d_m, b.noise_m, b.horizontal_m, b.vertical_m, b.total_m
        );
    }
    #[allow(clippy::cast_precision_loss)]
    let kib = report.static_ram_bytes as f64 / 1024.0;
    let _ = writeln!(
        s,
        "\nStatic RAM: {} bytes ({kib:.1} KiB) for {} layers of {} x {} cells (2 B each) + the classifier's gate tables + headers",
        report.static_ram_bytes,
        report.layers.len(),
        design.cells_per_side(),
        design.cells_per_side()
    );
    s
}

/// Checks the `--plot` file name: the figure is always a PNG, so the name must say so.
fn check_plot_path(path: &Path) -> Result<(), String> {
    let is_png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        Ok(())
    } else {
        Err(format!(
            "--plot: the file name must end in .png (got {})",
            path.display()
        ))
    }
}

/// Runs `pyramid design` for the design `asked` (the flags', or a rig file's with
/// [`crate::rigfile::asked_design`]) and its `--fit-layers`.
///
/// Exit status: 0 on success; 2 for a refused configuration, with one line on stderr that names
/// the flag and the rule, and nothing on stdout; 1 when the plot cannot be written.
pub fn run(args: &Args, asked: &DesignArgs, fit_layers: Option<u8>) -> ExitCode {
    if let Some(path) = &args.plot {
        if let Err(msg) = check_plot_path(path) {
            eprintln!("error: {msg}");
            return ExitCode::from(2);
        }
    }
    let built = match fit_layers {
        Some(n) => fit(asked, usize::from(n)),
        None => build(asked)
            .map(|design| (asked.clone(), design))
            .map_err(|e| e.to_string()),
    };
    let (design_args, design) = match built {
        Ok(built) => built,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let grade = terrain_pyramid::classify::PlaneRule::DEFAULT
        .max_grade
        .to_num::<f64>();
    // Refused before anything is written.
    let nodding = match nod::plan(
        &args.nod,
        design_args.phi_deg,
        design_args.height_m,
        design_args.max_range_m,
        grade,
    ) {
        Ok(plan) => plan,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(path) = &args.plot {
        if let Err(msg) = plot::draw(path, &design_args, &design) {
            eprintln!("error: --plot: cannot write {}: {msg}", path.display());
            return ExitCode::FAILURE;
        }
    }
    let mut report = report(&design);
    report.nodding = nodding;
    if args.json {
        if !crate::json_line::print(&report, "error: cannot encode the report as JSON: ") {
            return ExitCode::FAILURE;
        }
    } else {
        crate::out!("{}", table(&design_args, &design, &report));
        if let Some(plan) = &report.nodding {
            crate::out!("{}", nod::table(plan));
        }
        if let Some(n) = fit_layers {
            let from = if args.rig.is_some() {
                "the rig's gamma"
            } else {
                "--gamma"
            };
            crate::outln!(
                "\nFitted to {n} layers: gamma {} (from {from} {}).",
                design_args.gamma,
                asked.gamma
            );
        }
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_arguments_are_the_flags_defaults_and_the_firmware_s_design() {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            design: DesignArgs,
        }
        let parsed = <Cli as clap::Parser>::try_parse_from(["design"]).unwrap();
        assert_eq!(parsed.design, DesignArgs::default());
        let ours = build(&DesignArgs::default()).unwrap();
        let firmware = firmware_design().unwrap();
        assert_eq!(ours.layers(), firmware.layers());
        assert_eq!(ours.sensor(), firmware.sensor());
        assert_eq!(ours.schedule(), firmware.schedule());
    }

    #[test]
    fn bound_distances_stop_at_and_include_the_maximum_range() {
        assert_eq!(
            bound_distances(10.0),
            vec![0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0]
        );
        assert_eq!(bound_distances(4.0), vec![0.5, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(
            bound_distances(30.0),
            vec![0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0, 30.0]
        );
        assert_eq!(bound_distances(0.3), vec![0.3]);
    }

    #[test]
    fn static_ram_is_the_size_of_the_compiled_default_pyramid_and_gating() {
        let d = Design::<16>::new(SensorModel::default(), Schedule::default(), 64).unwrap();
        assert_eq!(d.layers().len(), terrain_pyramid::DEFAULT_LAYERS);
        assert_eq!(
            static_ram_bytes(&d),
            core::mem::size_of::<terrain_pyramid::DefaultPyramid>()
                + core::mem::size_of::<terrain_pyramid::gate::Gates<8>>()
        );
    }

    #[test]
    fn only_png_plot_names_are_accepted() {
        assert!(check_plot_path(Path::new("fig2.png")).is_ok());
        assert!(check_plot_path(Path::new("out/FIG.PNG")).is_ok());
        let e = check_plot_path(Path::new("fig2.svg")).unwrap_err();
        assert!(e.starts_with("--plot"));
    }
}
