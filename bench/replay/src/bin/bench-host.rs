//! The host side of `cargo xtask bench` (built with `--release`):
//!
//! - `bench-host throughput REC SECONDS`: replays the recording through the application core
//!   (the default co-processor: pyramid, pipeline and link, as the firmware runs them) again
//!   and again for at least SECONDS and prints `returns_per_second=… returns=… runs=…
//!   seconds=…`. Each run starts from a freshly booted core (outside the timed part).
//! - `bench-host export REC OUT`: writes the recording's world points as the library's
//!   geometry computes them, for the OctoMap harness: per line a `u32` point count, the
//!   scanner's origin (3 × `f32`) and the points (3 × `f32` each), little-endian.
//! - `bench-host fed-layers REC`: how many layers of the default design each return feeds
//!   (the classifier's per-layer work is paid that many times), their mean and histogram.
//! - `bench-host bins REC`: how many returns the classifier's gate bin (of the distance's
//!   square, its root rounded down) puts in another bin than their rounded distance's.

use std::process::ExitCode;
use std::time::{Duration, Instant};
use terrain_pyramid::angle::FineAngle;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::gate::Gates;
use terrain_pyramid::geometry::{BeamTable, LineTransform, Pose, PoseFrame};
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::recording::{Payload, Reader};
use terrain_pyramid::wire::sick::{MeasuredValues, SickAccumulator};
use terrain_pyramid::{Config, DefaultCoProcessor};
use terrain_pyramid_bench::{boot, default_design, frontend_config, replay, setup, Core, Pipeline};

fn throughput(rec: &[u8], seconds: f64) -> Result<(), String> {
    let design = default_design::<64, 8>().ok_or("the default design")?;
    let mut core: Box<DefaultCoProcessor> = Box::default();
    let mut returns = 0_u64;
    let mut runs = 0_u64;
    let mut timed = Duration::ZERO;
    while timed.as_secs_f64() < seconds || runs == 0 {
        *core = DefaultCoProcessor::new();
        if !boot(&mut core, rec, &design) {
            return Err("the recording has no usable setup".into());
        }
        let t = Instant::now();
        let mut p = Core {
            core: &mut core,
            angle: HostSuppliedAngle::new(),
        };
        replay(std::hint::black_box(rec), &mut p);
        timed += t.elapsed();
        returns += u64::from(std::hint::black_box(p.returns()));
        runs += 1;
    }
    let s = timed.as_secs_f64();
    println!(
        "returns_per_second={} returns={returns} runs={runs} seconds={s}",
        returns as f64 / s
    );
    Ok(())
}

/// Every measured-values telegram of the recording with the line transform in force when it
/// arrived (the recording's pose and actuator angle), in order.
fn each_line(
    rec: &[u8],
    mut on_line: impl FnMut(&LineTransform<'_>, &MeasuredValues<'_>, &FrontendConfig),
) -> Result<(), String> {
    let config: FrontendConfig = setup(rec)
        .as_ref()
        .and_then(frontend_config)
        .ok_or("the recording has no usable setup")?;
    let beams = BeamTable::new(config.variant);
    let mut frame = PoseFrame::from(&Pose::default());
    let mut actuator = FineAngle::ZERO;
    let mut acc: Box<SickAccumulator> = Box::new(SickAccumulator::new());
    for event in Reader::new(rec).map_err(|e| e.to_string())? {
        let event = event.map_err(|e| e.to_string())?;
        match event.payload {
            Payload::Angle(t) => actuator = FineAngle::from_bits(u32::from(t) << 16),
            Payload::Pose([x, y, z, r, p, yaw]) => {
                if let Ok(pose) = Pose::from_f32(x, y, z, r, p, yaw) {
                    frame = pose.frame();
                }
            }
            Payload::Laser(chunk) => {
                terrain_pyramid_bench::each_line(&mut acc, chunk, |values| {
                    let tr = LineTransform::new(&beams, &config.mount, actuator, &frame);
                    on_line(&tr, values, &config);
                });
            }
            _ => {}
        }
    }
    Ok(())
}

fn export(rec: &[u8], out: &str) -> Result<(), String> {
    let mut bytes = Vec::new();
    let (mut lines, mut points) = (0_u64, 0_u64);
    each_line(rec, |tr, values, config| {
        let o = tr.sensor_origin();
        let mut pts = Vec::new();
        for (j, r) in values.ranges_mm(config.measuring_mode).enumerate() {
            if let Some(p) = r.and_then(|r| tr.locate(j, r)) {
                pts.push([p.point.x, p.point.y, p.point.z].map(|m| m.to_num::<f32>()));
            }
        }
        bytes.extend_from_slice(&u32::try_from(pts.len()).unwrap_or(0).to_le_bytes());
        for v in [o.x, o.y, o.z] {
            bytes.extend_from_slice(&v.to_num::<f32>().to_le_bytes());
        }
        for p in &pts {
            for v in p {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        lines += 1;
        points += pts.len() as u64;
    })?;
    std::fs::write(out, bytes).map_err(|e| format!("{out}: {e}"))?;
    println!("lines={lines} points={points}");
    Ok(())
}

/// The gating of the default design with the default increments, as the classifier holds it.
fn default_gates() -> Result<Box<Gates<8>>, String> {
    let design = default_design::<64, 8>().ok_or("the default design")?;
    let increments = Config::default()
        .model
        .increments()
        .map_err(|e| format!("{e:?}"))?;
    let mut gates: Box<Gates<8>> = Box::new(Gates::new());
    gates
        .configure(&design, increments)
        .map_err(|e| format!("{e:?}"))?;
    Ok(gates)
}

/// How many layers of the default design each return feeds: the layers whose gate weight at
/// the return's distance bin reaches the feeding minimum (as the classifier decides it). Prints
/// `returns=… fed=… mean=…` and the count of returns feeding 0, 1, 2, … layers.
fn fed_layers(rec: &[u8]) -> Result<(), String> {
    let gates = default_gates()?;
    let (mut returns, mut fed) = (0_u64, 0_u64);
    let mut histogram = [0_u64; 9];
    each_line(rec, |tr, values, config| {
        for (j, r) in values.ranges_mm(config.measuring_mode).enumerate() {
            let Some(p) = r.and_then(|r| tr.locate(j, r)) else {
                continue;
            };
            let bin = gates.distance_bins().bin(p.horizontal);
            let n = (0..gates.layer_count())
                .filter(|&k| {
                    gates
                        .table(k)
                        .is_some_and(|t| t.weight(bin) >= gates.min_feeding_weight())
                })
                .count();
            returns += 1;
            fed += n as u64;
            if let Some(h) = histogram.get_mut(n) {
                *h += 1;
            }
        }
    })?;
    println!(
        "returns={returns} fed={fed} mean={:.3} histogram={histogram:?}",
        fed as f64 / returns.max(1) as f64
    );
    Ok(())
}

/// How many returns the per-line path bins differently from their rounded distance: the
/// classifier bins the square root of `Δx² + Δy²` rounded down
/// (`DistanceBins::bin_of_squared`), `LineTransform::locate` rounds the distance to the
/// nearest raw unit. Prints `returns=… differ=…` and, over the differing returns, the largest
/// change of any layer's gate weight (raw Q1.15).
fn bins(rec: &[u8]) -> Result<(), String> {
    let gates = default_gates()?;
    let bins = gates.distance_bins();
    let (mut returns, mut differ, mut weight_change) = (0_u64, 0_u64, 0_i32);
    each_line(rec, |tr, values, config| {
        for (j, r) in values.ranges_mm(config.measuring_mode).enumerate() {
            let (Some(p), Some(q)) = (
                r.and_then(|r| tr.locate(j, r)),
                r.and_then(|r| tr.locate_squared(j, r)),
            ) else {
                continue;
            };
            returns += 1;
            let (rounded, floored) = (
                bins.bin(p.horizontal),
                bins.bin_of_squared(q.horizontal_squared),
            );
            if rounded != floored {
                differ += 1;
                for t in (0..gates.layer_count()).filter_map(|k| gates.table(k)) {
                    let change = i32::from(t.weight(rounded).to_bits())
                        - i32::from(t.weight(floored).to_bits());
                    weight_change = weight_change.max(change.abs());
                }
            }
        }
    })?;
    println!("returns={returns} differ={differ} largest_weight_change={weight_change}");
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.as_slice() {
        [cmd, rec, arg] => match std::fs::read(rec) {
            Err(e) => Err(format!("{rec}: {e}")),
            Ok(data) => match cmd.as_str() {
                "throughput" => arg
                    .parse::<f64>()
                    .map_err(|e| e.to_string())
                    .and_then(|s| throughput(&data, s)),
                "export" => export(&data, arg),
                _ => Err(format!("unknown command {cmd}")),
            },
        },
        [cmd, rec] if cmd == "fed-layers" => std::fs::read(rec)
            .map_err(|e| format!("{rec}: {e}"))
            .and_then(|data| fed_layers(&data)),
        [cmd, rec] if cmd == "bins" => std::fs::read(rec)
            .map_err(|e| format!("{rec}: {e}"))
            .and_then(|data| bins(&data)),
        _ => Err(
            "usage: bench-host throughput REC SECONDS | export REC OUT | fed-layers REC | bins REC"
                .into(),
        ),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bench-host: {e}");
            ExitCode::FAILURE
        }
    }
}
