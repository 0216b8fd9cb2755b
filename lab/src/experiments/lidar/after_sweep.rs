//! The nodding rigs' stairs once the robot, arrived, has stood until the observation in
//! progress ended: a device integrates an observation when the servo turns, so the partial
//! sweep that `lidar::run_stairs` flushes at arrival is a state it never shows; this is the map
//! it shows next (`docs/lidars.md`, "Arrived and stood one sweep").

use super::{nod_period_s, StairsSetup, RIG_LAYERS, STAIRS_CELLS};
use crate::experiments::engine::{Map, Runner};
use crate::experiments::stairs::{self, Watched};
use serde::Serialize;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::{Config, GateShape};

/// What the soft-gated pyramid shows at the end of the first observation after arrival: the
/// first map that holds every tilt of a sweep seen from the stop.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct AfterSweep {
    /// Step cells obstacle (4 decimals).
    pub step_cells: f64,
    /// Flat ground before the stairs obstacle (the same cells as the false-obstacle figure at
    /// the stop, 4 decimals).
    pub false_obstacles: f64,
    /// Seconds from arrival to the end of that observation.
    pub wait_s: f64,
}

/// Runs `setup` again with the robot standing one nod's period at the stop, through the
/// soft-gated pyramid of the rig's design, and measures it at the end of the first
/// observation that ends after arrival (one that ends on the arrival's own line counts);
/// `None` when none ends within the nod.
///
/// # Errors
/// The simulator or the library refused the setup.
pub fn run(
    setup: &StairsSetup,
    classifier: &ClassifierConfig,
) -> Result<Option<AfterSweep>, String> {
    let setup = StairsSetup {
        dwell_s: nod_period_s(setup.kind),
        ..*setup
    };
    let scene_config = setup.scene_config();
    let stop_us = (scene_config.trajectory.stop_s() * 1e6).round();
    let (decoded, _) = setup.decoded(classifier)?;
    let watched = Watched::of(&scene_config);
    let design = setup
        .pyramid::<RIG_LAYERS>(GateShape::default())
        .map_err(|e| e.to_string())?;
    let mut map: Box<dyn Map> =
        Box::new(Runner::<STAIRS_CELLS, RIG_LAYERS, { stairs::SLOTS }>::new(
            "pyramid_soft",
            design,
            Config::default(),
            decoded.frontend,
        )?);
    // The observations ended before the arrival's line, once it comes.
    let mut ended_at_arrival = None;
    for line in &decoded.lines {
        #[allow(clippy::cast_precision_loss)]
        let t_us = line.time_us as f64;
        if t_us >= stop_us && ended_at_arrival.is_none() {
            ended_at_arrival = Some(map.observations());
        }
        map.line(line);
        if ended_at_arrival.is_some_and(|before| map.observations() > before) {
            return Ok(Some(AfterSweep {
                step_cells: stairs::round4(stairs::shares(map.as_ref(), &watched.steps).obstacle),
                false_obstacles: stairs::round4(
                    stairs::shares(map.as_ref(), &watched.ground).obstacle,
                ),
                wait_s: ((t_us - stop_us) * 1e-6 * 1000.0).round() / 1000.0,
            }));
        }
    }
    Ok(None)
}
