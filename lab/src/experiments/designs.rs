//! The designs the experiments compare, all through the library's own [`Design::new`].

use terrain_pyramid::{Clamp, Config, Design, DesignError, GateShape, Schedule, SensorModel};

/// The paper's sensor model (φ = 0.5°, ψ = 2°, σ = 0.15 m, h = 1 m) with maximum range `range_m`.
pub fn paper_sensor(range_m: f32) -> SensorModel {
    SensorModel {
        max_range_m: range_m,
        ..SensorModel::default()
    }
}

/// The pyramid: the paper's bands (linear schedule, Δd = 0.1 m, γ = 2) with `gate`, every
/// layer at Δd when `uniform` (the stairs experiment), else at `r_k = k·γ·Δd`.
pub fn pyramid<const L: usize>(
    range_m: f32,
    gate: GateShape,
    uniform: bool,
    cells: usize,
) -> Result<Design<L>, DesignError> {
    pyramid_of(paper_sensor(range_m), gate, uniform, cells)
}

/// The pyramid of `sensor`'s bands (the library's default schedule) with `gate`, every layer
/// at Δd when `uniform`, else at `r_k = k·γ·Δd`.
pub fn pyramid_of<const L: usize>(
    sensor: SensorModel,
    gate: GateShape,
    uniform: bool,
    cells: usize,
) -> Result<Design<L>, DesignError> {
    let schedule = Schedule {
        gate,
        uniform_resolution: uniform,
        ..Schedule::default()
    };
    Design::new(sensor, schedule, cells)
}

/// The library's default configuration with the stored log-odds unclamped (the paper's
/// baseline).
pub fn unclamped() -> Config {
    Config {
        clamp: Clamp::Off,
        ..Config::default()
    }
}

/// The library's default configuration with the stored log-odds clamped to OctoMap's bounds
/// (−2 ..= 3.5 nats).
pub fn octomap_clamped() -> Config {
    Config {
        clamp: Clamp::OCTOMAP,
        ..Config::default()
    }
}

/// The flat grid: one layer of `cell_m` cells fed by every observation out to `range_m`.
///
/// Made with the library's `Design::new` from a sensor model whose bound δ(d) stays below
/// `cell_m` over the whole range (φ = ψ = 10⁻⁶ rad, σ = 1 mm): the design then needs exactly
/// one layer, its band is `[0, range_m]` and the hard gate weighs every distance 1. The sensor
/// model of a design only sets the bands and gates; the pipeline takes the laser's real
/// geometry from the recording, so the flat grid sees exactly the points the pyramid sees.
pub fn flat<const L: usize>(
    range_m: f32,
    cell_m: f32,
    cells: usize,
) -> Result<Design<L>, DesignError> {
    let sensor = SensorModel {
        phi_rad: 1e-6,
        psi_rad: 1e-6,
        sigma_m: 1e-3,
        height_m: 1.0,
        max_range_m: range_m,
    };
    let schedule = Schedule {
        base_m: cell_m,
        gamma: 2.0,
        gate: GateShape::Hard,
        uniform_resolution: false,
    };
    let design = Design::new(sensor, schedule, cells)?;
    debug_assert_eq!(design.layers().len(), 1);
    Ok(design)
}
