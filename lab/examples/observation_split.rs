//! Overflow and observation splits per simulated recording and board: every simulated laser
//! (the paper's SICK panned and on a tilt unit; each lidar nodding on a servo and panned)
//! over the paper's stairs, played through the co-processor of each board's size in this
//! process (`--board host` is the QEMU firmware's, equal bit for bit; the STM32F4's 512
//! classifier slots; the micro:bit's 16-cell, 4-layer, 16-slot build), and each board's maps
//! written as raw cells into `DIR` (one file per recording and board), so that two builds can
//! be compared cell for cell.
//!
//! `cargo run -p terrain-pyramid-lab --example observation_split -- DIR`

use clap::Parser;
use std::path::PathBuf;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::{
    Config, Design, Schedule, SensorModel, DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS,
};
use terrain_pyramid_host::device::InProcess;
use terrain_pyramid_host::export::MapSnapshot;
use terrain_pyramid_host::play::{steps, RunCounts};
use terrain_pyramid_host::run::{boot_host_device, drive, run_config, Args};
use terrain_pyramid_host_tests::sim::laser::{Actuator, LaserConfig};
use terrain_pyramid_host_tests::sim::lidar::{
    simulate_lidar, LidarActuator, LidarKind, LidarSimConfig,
};
use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
use terrain_pyramid_host_tests::sim::scene::{Scene, StairsSpec};
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    run: Args,
}

type Stm32 = InProcess<DEFAULT_CELLS_PER_SIDE, DEFAULT_LAYERS, 512, 1024>;
type Microbit = InProcess<16, 4, 16, 400>;

fn recordings() -> Vec<(String, Vec<u8>)> {
    let spec = StairsSpec::default();
    let trajectory = Trajectory::approach(2.0, 0.5, spec.first_riser_x, 2.0);
    let mut out = Vec::new();
    let pan = SimConfig::new(Scene::stairs(spec), LaserConfig::paper(), trajectory);
    out.push(("sick-pan".to_string(), simulate(&pan).unwrap().bytes));
    let tilt = SimConfig::new(
        Scene::stairs(spec),
        LaserConfig {
            actuator: Actuator::DEFAULT_TILT,
            ..LaserConfig::paper()
        },
        trajectory,
    );
    out.push(("sick-tilt".to_string(), simulate(&tilt).unwrap().bytes));
    for kind in LidarKind::ALL {
        for (name, actuator) in [
            ("nod", LidarActuator::servo(2.0, 35.0, 20.0, 0.0)),
            (
                "pan",
                LidarActuator::Pan {
                    half_width_cdeg: 4_500,
                    rate_cdeg_s: 2_000,
                },
            ),
        ] {
            let config = LidarSimConfig::new(
                Scene::stairs(spec),
                kind,
                actuator,
                [0.0, 0.0, 1.0],
                trajectory,
            );
            let sim = simulate_lidar(&config).unwrap();
            out.push((format!("{}-{name}", kind.name()), sim.bytes));
        }
    }
    out
}

fn cells(maps: &MapSnapshot) -> Vec<u8> {
    maps.layers
        .iter()
        .flat_map(|l| l.cells.iter().flat_map(|c| c.to_le_bytes()))
        .collect()
}

fn field(counts: &RunCounts, name: &str) -> String {
    serde_json::to_value(counts)
        .ok()
        .and_then(|v| v.get(name).cloned())
        .map_or_else(|| "-".to_string(), |v| v.to_string())
}

fn main() {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .expect("usage: observation_split DIR"),
    );
    std::fs::create_dir_all(&dir).unwrap();
    let rec = dir.join("recording.rec");
    println!(
        "recording board telegrams observations observations_split overflow_points known_cells"
    );
    for (name, bytes) in recordings() {
        std::fs::write(&rec, &bytes).unwrap();
        let steps = steps(&bytes).unwrap();
        let r = rec.to_str().unwrap();
        let o = dir.to_str().unwrap();
        for board in ["qemu-mps2", "stm32f4", "microbit"] {
            let mut argv = vec!["run", "--recording", r, "--out", o];
            if board == "microbit" {
                argv.extend([
                    "--board",
                    "microbit",
                    "--cells",
                    "16",
                    "--rule",
                    "paper",
                    "--max-range-m",
                    "4",
                    "--height-m",
                    "0.4",
                    "--gamma",
                    "3",
                ]);
            }
            let cli = Cli::try_parse_from(argv).unwrap();
            let (design, config, classifier) = run_config(&cli.run).unwrap();
            let (counts, maps) = match board {
                "qemu-mps2" => {
                    let mut d = boot_host_device().unwrap();
                    drive(&mut d, &steps, &design, &config, &classifier).unwrap()
                }
                "stm32f4" => {
                    let d8 = Design::<8>::new(
                        SensorModel::default(),
                        Schedule::default(),
                        DEFAULT_CELLS_PER_SIDE,
                    )
                    .unwrap();
                    let mut d = Stm32::boot(
                        LinkConfig::DEFAULT,
                        &d8,
                        &Config::default(),
                        FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal),
                    )
                    .unwrap();
                    drive(&mut d, &steps, &design, &config, &classifier).unwrap()
                }
                _ => {
                    let sensor = SensorModel {
                        max_range_m: 4.0,
                        height_m: 0.4,
                        ..SensorModel::default()
                    };
                    let schedule = Schedule {
                        gamma: 3.0,
                        ..Schedule::default()
                    };
                    let d4 = Design::<4>::new(sensor, schedule, 16).unwrap();
                    let mut d = Microbit::boot(
                        LinkConfig::DEFAULT,
                        &d4,
                        &Config::default(),
                        FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal),
                    )
                    .unwrap();
                    drive(&mut d, &steps, &design, &config, &classifier).unwrap()
                }
            };
            let raw = cells(&maps);
            let known = raw
                .chunks(2)
                .filter(|c| i16::from_le_bytes([c[0], c[1]]) != i16::MIN)
                .count();
            std::fs::write(dir.join(format!("{name}.{board}.cells")), &raw).unwrap();
            println!(
                "{name} {board} {} {} {} {} {known}",
                counts.telegrams_sent,
                counts.observations,
                field(&counts, "observations_split"),
                counts.overflow_points
            );
        }
    }
}
