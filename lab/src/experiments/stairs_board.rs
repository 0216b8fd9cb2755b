//! The stairs experiment through the emulated firmware (`lab experiments --board qemu`).
//!
//! The same recording, the same four maps, but each one is the firmware's own: QEMU's MPS2
//! AN386 running `boards/qemu-mps2`'s binary `qemu-mps2-paper-stairs` (`--features
//! paper-stairs`: 32 layers of 488² cells in PSRAM), configured over the link exactly as the
//! host experiment configures its library pyramids (Configure with the design's flags, Setup
//! from the recording), fed the recording's telegrams on UART0 lock-step by the host tool's
//! player ([`terrain_pyramid_host::play::play_watched`]). At every point where the host
//! experiment looks at its maps (the end of each observation, and the end of standing), the harness
//! waits until the device has sent every changed tile ([`Device::sync`]) and asks
//! the fused question of its mirror of the device's maps. At the end, the mirror is compared
//! cell for cell with the host's library map.

use super::designs;
use super::stairs::{self, Cell, Setup, Shares, StairsResult, CELLS, CELL_M, FIRST_STEP_SHARE};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;
use terrain_pyramid::classify::ClassifierConfig;
use terrain_pyramid::grid::cell_of;
use terrain_pyramid::link::convert::frontend_config_of_event;
use terrain_pyramid::logodds::round_to_log_odds;
use terrain_pyramid::{Cell as MapCell, Config, Design, Fused, GateShape, Meters};
use terrain_pyramid_host::device::Device;
use terrain_pyramid_host::emulator::{build_firmware_variant, Emulator, Machine, BOARD_DIR};
use terrain_pyramid_host::export::{fused_answer, MapSnapshot};
use terrain_pyramid_host::link::HostLink;
use terrain_pyramid_host::play::{play_watched, steps, Moment, Steps};
use terrain_pyramid_host_tests::sim::record::simulate;

/// The board feature that builds the stairs firmware.
pub const FEATURE: &str = "paper-stairs";
/// The firmware's layer capacity (`boards/qemu-mps2`, `sizes::LAYERS` of `paper-stairs`).
pub const BOARD_LAYERS: usize = 32;

/// One map as the firmware made it.
#[derive(Debug, Clone, Serialize)]
pub struct BoardMapResult {
    /// Share of the step cells the firmware's map calls obstacle at the stop.
    pub detected_fraction: f64,
    /// Distance to the first riser when half its cells first read obstacle; null when never.
    pub detect_distance_m: Option<f64>,
    /// The step cells at the end of standing.
    pub far: Shares,
    /// Whether every cell of every layer of the firmware's map equals the host's library map
    /// at the end of the run.
    pub map_equal_to_host: bool,
    /// Cells (over all layers) that differ from the host's map.
    pub cells_differing: u64,
    /// Layers of the firmware's map.
    pub layers: usize,
    /// Telegrams written to the firmware's laser UART.
    pub telegrams: u64,
    /// Evidence records that changed a cell, by the firmware's Stats.
    pub evidence_applied: u32,
    /// The firmware's stack high-water mark, bytes.
    pub stack_bytes: u32,
    /// Wall-clock time of the run, seconds.
    pub wall_s: f64,
}

/// The four maps through the firmware.
#[derive(Debug, Clone, Serialize)]
pub struct BoardStairsResult {
    /// The flat grid, no clamping.
    pub flat: BoardMapResult,
    /// The flat grid with OctoMap's clamping.
    pub flat_clamped: BoardMapResult,
    /// The uniform pyramid, hard gate.
    pub pyramid: BoardMapResult,
    /// The same, soft gate.
    pub pyramid_soft: BoardMapResult,
    /// Whether every figure (detected share, detection distance, far shares) and every cell
    /// equals the host experiment's.
    pub same_outcome_as_host: bool,
}

impl BoardStairsResult {
    /// The four maps, in the order of [`StairsResult::maps`].
    #[must_use]
    pub const fn maps(&self) -> [&BoardMapResult; 4] {
        [
            &self.flat,
            &self.flat_clamped,
            &self.pyramid,
            &self.pyramid_soft,
        ]
    }
}

/// The fused answer of the host's mirror of the device's maps at world point `(x, y)`: the
/// library's rule ([`terrain_pyramid::Pyramid::fused`]) on the mirror's layers.
fn mirror_fused(link: &HostLink, margin_raw: i16, x: f64, y: f64) -> Fused {
    let mirror = link.mirror();
    let w = mirror.cells_per_side();
    let (xb, yb) = (
        Meters::saturating_from_num(x).to_bits(),
        Meters::saturating_from_num(y).to_bits(),
    );
    let cell = |k: usize| {
        let layer = mirror.layer(k)?;
        let r = layer.resolution_q16;
        let offset = |bits: i32, origin: i32| {
            usize::try_from(i64::from(cell_of(bits, r)) - i64::from(origin))
                .ok()
                .filter(|&o| o < w)
        };
        let dx = offset(xb, layer.origin.0)?;
        let dy = offset(yb, layer.origin.1)?;
        layer
            .cells()
            .get(dy * w + dx)
            .map(|&raw| MapCell::from_raw(raw))
    };
    fused_answer(margin_raw, (0..mirror.layer_count()).map(cell))
}

fn mirror_shares(link: &HostLink, margin_raw: i16, cells: &[Cell]) -> Shares {
    stairs::shares_by(|x, y| mirror_fused(link, margin_raw, x, y), cells)
}

/// Cells of the mirror that differ from `host` (origins, cell sizes and every cell).
fn differing_cells(link: &HostLink, host: &MapSnapshot) -> u64 {
    let mirror = link.mirror();
    let mut differing = 0_u64;
    if mirror.layer_count() != host.layers.len() {
        return u64::MAX;
    }
    for (k, h) in host.layers.iter().enumerate() {
        let Some(m) = mirror.layer(k) else {
            return u64::MAX;
        };
        if m.origin != h.origin_cells || m.resolution_q16 != h.resolution.to_bits() {
            differing += h.cells.len() as u64;
            continue;
        }
        differing += m
            .cells()
            .iter()
            .zip(&h.cells)
            .filter(|(a, b)| a != b)
            .count() as u64;
    }
    differing
}

/// What the four maps are: name, design, configuration (as `stairs::maps` builds them).
fn map_specs(range_m: f64) -> Result<Vec<(&'static str, Design<BOARD_LAYERS>, Config)>, String> {
    #[allow(clippy::cast_possible_truncation)]
    let (r, cell) = (range_m as f32, CELL_M as f32);
    let off = designs::unclamped();
    let clamped = designs::octomap_clamped();
    let e = |e: terrain_pyramid::DesignError| e.to_string();
    Ok(vec![
        ("flat", designs::flat(r, cell, CELLS).map_err(e)?, off),
        (
            "flat_clamped",
            designs::flat(r, cell, CELLS).map_err(e)?,
            clamped,
        ),
        (
            "pyramid",
            designs::pyramid(r, GateShape::Hard, true, CELLS).map_err(e)?,
            off,
        ),
        (
            "pyramid_soft",
            designs::pyramid(r, GateShape::default(), true, CELLS).map_err(e)?,
            off,
        ),
    ])
}

/// Runs the stairs recording of `setup` through the firmware, one emulator per map, and
/// compares each with `host` (the host experiment's result of the same setup). The firmware's
/// defmt logs go to `out/stairs-board-<map>.defmt`.
///
/// # Errors
/// QEMU or the target missing, the firmware refusing a command, or a run that stalls.
pub fn run(setup: &Setup, host: &StairsResult, out: &Path) -> Result<BoardStairsResult, String> {
    let elf = build_firmware_variant(Path::new(BOARD_DIR), "qemu-mps2", Some(FEATURE))?;
    let sim_config = setup.sim();
    let sim = simulate(&sim_config).map_err(|e| e.to_string())?;
    let decoded = steps(&sim.bytes)?;
    let setup_event = decoded.setup().ok_or("the recording has no setup")?;
    let classifier = setup.classifier;
    let per = u64::from(
        frontend_config_of_event(&setup_event, &classifier)
            .map_err(|e| format!("the recording's setup: {e}"))?
            .lines_per_observation
            .max(1),
    );
    let (steps, first) = stairs::step_cells(&sim_config);
    let riser_x = sim_config.scene.target_x.unwrap_or(0.0);
    let drive_start_us = (sim_config.trajectory.drive_start_s() * 1e6).round();
    let host_maps = host.maps();
    let specs = map_specs(setup.range_m)?;
    // One emulator per map, all at once: each run waits on its UARTs far more than it computes.
    let results: Vec<Result<BoardMapResult, String>> = std::thread::scope(|scope| {
        let handles: Vec<_> = specs
            .iter()
            .zip(host_maps)
            .map(|((name, design, config), host_map)| {
                let ctx = BoardRun {
                    elf: &elf,
                    out,
                    recording: &decoded,
                    classifier: &classifier,
                    per,
                    steps: &steps,
                    first: &first,
                    riser_x,
                    drive_start_us,
                };
                scope.spawn(move || ctx.map(name, design, config, host_map))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a firmware run panicked".to_string()))
            })
            .collect()
    });
    let results = results.into_iter().collect::<Result<Vec<_>, _>>()?;
    let same = results.iter().zip(host_maps).all(|(b, h)| {
        b.map_equal_to_host
            && b.detected_fraction == h.detected_fraction
            && b.detect_distance_m == h.detect_distance_m
            && b.far == h.far
            && b.layers == h.layers
    });
    let mut it = results.into_iter();
    let mut next = || it.next().ok_or_else(|| "missing map".to_string());
    Ok(BoardStairsResult {
        flat: next()?,
        flat_clamped: next()?,
        pyramid: next()?,
        pyramid_soft: next()?,
        same_outcome_as_host: same,
    })
}

/// What every map's run shares.
#[derive(Clone, Copy)]
struct BoardRun<'a> {
    elf: &'a Path,
    out: &'a Path,
    recording: &'a Steps,
    classifier: &'a ClassifierConfig,
    /// Lines per observation: the host experiment looks at its maps after every `per` lines.
    per: u64,
    steps: &'a [Cell],
    first: &'a [Cell],
    riser_x: f64,
    drive_start_us: f64,
}

impl BoardRun<'_> {
    /// One map through its own emulator.
    fn map(
        self,
        name: &str,
        design: &Design<BOARD_LAYERS>,
        config: &Config,
        host_map: &stairs::MapResult,
    ) -> Result<BoardMapResult, String> {
        let BoardRun {
            elf,
            out,
            recording,
            classifier,
            per,
            steps,
            first,
            riser_x,
            drive_start_us,
        } = self;
        eprintln!("stairs through the firmware: {name} ...");
        let started = Instant::now();
        let mut emu = Emulator::start(
            Machine::Mps2An386,
            elf,
            &out.join(format!("stairs-board-{name}.defmt")),
        )?;
        emu.configure_after_hello(design, config)?;
        let margin = round_to_log_odds(config.fused_margin).to_bits();
        // The host experiment's looks at its maps: the step cells at the end of standing
        // (before the first driving line), and whether the first step is seen after every
        // observation.
        let mut far = None;
        let mut detect = None;
        let (counts, robot_xy) = play_watched(&mut emu, recording, classifier, |emu, moment| {
            match moment {
                Moment::Before { time_us, .. } => {
                    #[allow(clippy::cast_precision_loss)]
                    let driving = time_us as f64 >= drive_start_us;
                    if driving && far.is_none() {
                        emu.sync()?;
                        far = Some(mirror_shares(emu.link(), margin, steps));
                    }
                }
                Moment::After {
                    telegrams,
                    robot_xy,
                } => {
                    if telegrams.is_multiple_of(per) && detect.is_none() {
                        emu.sync()?;
                        if mirror_shares(emu.link(), margin, first).obstacle >= FIRST_STEP_SHARE {
                            detect = Some(stairs::round3(riser_x - robot_xy.0));
                        }
                    }
                }
            }
            Ok(())
        })?;
        let stats = emu.sync()?;
        if detect.is_none() && mirror_shares(emu.link(), margin, first).obstacle >= FIRST_STEP_SHARE
        {
            detect = Some(stairs::round3(riser_x - robot_xy.0));
        }
        let near = mirror_shares(emu.link(), margin, steps);
        let differing = host_map
            .final_map
            .as_ref()
            .map_or(u64::MAX, |h| differing_cells(emu.link(), h));
        let layers = emu.link().mirror().layer_count();
        let stack_bytes = emu.shutdown()?;
        let result = BoardMapResult {
            detected_fraction: stairs::round4(near.obstacle),
            detect_distance_m: detect,
            far: far.unwrap_or_default(),
            map_equal_to_host: differing == 0,
            cells_differing: differing,
            layers,
            telegrams: counts.telegrams_sent,
            evidence_applied: stats.evidence_applied,
            stack_bytes,
            wall_s: started.elapsed().as_secs_f64(),
        };
        eprintln!(
            "  {name}: {} telegrams in {:.1} s; step cells obstacle {:.1} % (host {:.1} %), \
         first step at {:?} (host {:?}), {} cells differ from the host's map",
            result.telegrams,
            result.wall_s,
            100.0 * result.detected_fraction,
            100.0 * host_map.detected_fraction,
            result.detect_distance_m,
            host_map.detect_distance_m,
            result.cells_differing
        );
        Ok(result)
    }
}
