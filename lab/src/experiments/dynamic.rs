//! A world that changes: the decay of stale evidence (`docs/core.md`, "Decay") on the
//! simulator's changing scenes, and the stairs with decay on.
//!
//! - **Changing scenes** ([`terrain_pyramid_host_tests::sim::changing`]: a pedestrian who
//!   waits in front of the robot and walks on, a door that slides open, a car that leaves its
//!   parking space) through the default co-processor in process
//!   ([`terrain_pyramid_host_tests::fading`]), decay off and all evidence at τ = 2, 5 and 20 s:
//!   per layer and in the fused map, the time from the mover leaving a cell until the cell
//!   reads unknown or navigable; the static obstacles in and out of view that the fused map
//!   wrongly clears.
//! - **Stairs with decay**: the stairs experiment's soft-gated pyramid ([`super::stairs`]) with
//!   all evidence decaying at the shortest time constant its 488-cell window allows, against
//!   the same pyramid without decay: the stairs must still be found.

use super::designs;
use super::engine::{decode, Map, Runner};
use super::stairs::{self, MapResult, Shares, Watched};
use serde::Serialize;
use terrain_pyramid::{Clamp, Config, Decay, DecayMode, GateShape, TimeConstant};
use terrain_pyramid_host_tests::fading::{measure, SceneResult};
use terrain_pyramid_host_tests::sim::changing::ChangingScene;
use terrain_pyramid_host_tests::sim::record::simulate;

/// The stairs' soft-gated pyramid with decay on, beside the same pyramid without.
#[derive(Debug, Clone, Serialize)]
pub struct StairsDecay {
    /// The decay mode (`all`).
    pub mode: &'static str,
    /// Every layer's time constant, seconds: the shortest the window allows.
    pub tau_s: f64,
    /// Share of the step cells that read obstacle at the end (1.0 m from the first step).
    pub detected_fraction: f64,
    /// The same without decay (the stairs experiment's `pyramid_soft`).
    pub detected_fraction_without: f64,
    /// Distance to the first step when half its cells first read obstacle, metres.
    pub detect_distance_m: Option<f64>,
    /// The same without decay.
    pub detect_distance_m_without: Option<f64>,
    /// Step cells' answers at the end of standing.
    pub far: Shares,
    /// Share of the flat ground before the stairs that reads obstacle at the end.
    pub false_obstacle_fraction: f64,
    /// Cells the decay made unknown over the run.
    pub cells_faded: u64,
}

/// The `dynamic` section of `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct DynamicResult {
    /// Each changing scene, every decay setting.
    pub scenes: Vec<SceneResult>,
    /// The stairs with decay on.
    pub stairs: StairsDecay,
}

/// The shortest time constant a window of `cells_per_side` cells allows (its sweep within
/// 32 768 cells a second).
fn shortest_tau(cells_per_side: usize) -> Option<TimeConstant> {
    let min = Decay::min_step_ms(cells_per_side);
    (1..=u8::MAX)
        .map(TimeConstant::from_code)
        .find(|t| t.step_ms().is_some_and(|p| u64::from(p) >= min))
}

/// The stairs recording of `setup` through the soft-gated pyramid with decay on.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn stairs_with_decay(
    setup: &stairs::Setup,
    without: &MapResult,
) -> Result<StairsDecay, String> {
    let sim_config = setup.sim();
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let decoded = decode(&sim.bytes, &setup.classifier)?;
    let watched = Watched::of(&sim_config);
    #[allow(clippy::cast_possible_truncation)]
    let design = designs::pyramid(
        setup.range_m as f32,
        GateShape::default(),
        true,
        stairs::CELLS,
    )
    .map_err(|e| e.to_string())?;
    let tau = shortest_tau(stairs::CELLS).ok_or("no time constant fits the stairs window")?;
    let config = Config {
        clamp: Clamp::Off,
        decay: Decay::uniform(DecayMode::All, tau, design.layers().len()),
        ..Config::default()
    };
    let mut maps: [Box<dyn Map>; 1] = [Box::new(Runner::<
        { stairs::CELLS },
        { stairs::LAYERS },
        { stairs::SLOTS },
    >::new(
        "pyramid_soft_decay",
        design,
        config,
        decoded.frontend,
    )?)];
    let per = decoded.frontend.lines_per_observation.max(1) as usize;
    let pass = stairs::watch(&decoded, &mut maps, &watched, per, false, |_, _| {});
    let [map] = maps;
    let with = watched.result(map.as_ref(), &pass, 0);
    Ok(StairsDecay {
        mode: DecayMode::All.name(),
        tau_s: f64::from(tau.seconds().unwrap_or(0.0)),
        detected_fraction: with.detected_fraction,
        detected_fraction_without: without.detected_fraction,
        detect_distance_m: with.detect_distance_m,
        detect_distance_m_without: without.detect_distance_m,
        far: with.far,
        false_obstacle_fraction: with.false_obstacle_fraction,
        cells_faded: u64::from(map.stats().cells_faded),
    })
}

/// Every changing scene with and without decay, and the stairs with decay.
///
/// # Errors
/// The simulator or the library refused a setup.
pub fn run(setup: &stairs::Setup, without: &MapResult) -> Result<DynamicResult, String> {
    let mut scenes = Vec::new();
    for scene in ChangingScene::all() {
        scenes.push(measure(&scene).map_err(|e| format!("{}: {e}", scene.name))?);
    }
    Ok(DynamicResult {
        scenes,
        stairs: stairs_with_decay(setup, without)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shortest_tau_is_the_first_the_window_allows() {
        let tau = shortest_tau(stairs::CELLS).unwrap();
        let min = Decay::min_step_ms(stairs::CELLS);
        assert!(u64::from(tau.step_ms().unwrap()) >= min);
        let before = TimeConstant::from_code(tau.code() - 1);
        assert!(u64::from(before.step_ms().unwrap()) < min);
        // The library takes it, and refuses the one before.
        let d = |t| Decay::uniform(DecayMode::All, t, 1);
        assert!(d(tau).validate(stairs::CELLS, 1).is_ok());
        assert!(d(before).validate(stairs::CELLS, 1).is_err());
        // 64 cells: τ = 1 s, the shortest of all.
        assert_eq!(shortest_tau(64), Some(TimeConstant::MIN));
    }
}
