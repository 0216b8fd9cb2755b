//! Project automation for terrain-pyramid (the ecosystem's `xtask` convention).
//!
//! - `cargo xtask test [--lint] [--jobs N]`: the whole test suite on a fresh machine: installs
//!   what it needs (the Cortex-M targets, QEMU, `defmt-print`), runs every host test (including
//!   the bit-exact run of the firmware in QEMU; the test binaries `N` at a time, by default one
//!   per core: module `pool`), then the boards' checks: release builds, the
//!   firmware on the emulated board, the on-target tests for thumbv7em and thumbv6m code, and
//!   the firmware's flash, RAM and stack. `--lint` adds the boards' fmt and clippy.
//! - `cargo xtask bench [--json] [--quick]`: exact per-return instruction counts on the
//!   emulated Cortex-M (M4F, M0 code, fixed point and f32), host throughput against OctoMap,
//!   the bench firmware's memory (BENCHMARKS.md).
//! - `cargo xtask demo [--board qemu|host] [--out DIR]`: the main job on the emulated board
//!   (installing what it needs as `test` does): the 3DTK scan and the simulated stairs
//!   through the firmware in QEMU, maps and pictures.
//! - `cargo xtask experiments [FLAGS]`: the paper's claims on the simulator (`lab experiments`).
//! - `cargo xtask faults [--json] [--quick]`: fault injection through the emulated board, one
//!   run per fault kind against a reference co-processor (RELIABILITY.md); fails when any
//!   outcome is bad.
//! - `cargo xtask soak [--json] [--quick]`: an hour of simulated driving through the
//!   in-process co-processor and ten minutes through the firmware on QEMU: counters, memory,
//!   map bounds, throughput (RELIABILITY.md, "Soak"); `--quick` is CI's five and half a minute.
//! - `cargo xtask size [--json]`: the firmware's flash, static RAM and stack (`lab size`).
//! - `cargo xtask latency [--quick] [--json] [--no-ros2]`: telegram into the emulated board →
//!   each live output's message out of the host at the SICK's full rate, every output on; ROS 2
//!   inside a network namespace of its own (`lab latency`).
//! - `cargo xtask live [--json]`: a recording played as a robot lives: the laser paced into the
//!   emulated board, Odometry published late by a Cyclone DDS process, `pyramid listen --ros2
//!   --odom-topic /odom` forwarding it; inside a network namespace of its own (`lab live`).
//!
//! - `cargo xtask layers [--json]`: the code's shape, checked: imports only point down the
//!   library's layers, no import cycle, one definition per public type name.
//!
//! The lab's tasks run `cargo run --profile tools -p terrain-pyramid-lab -- COMMAND FLAGS`
//! (release without fat LTO, see the root Cargo.toml).
use std::process::ExitCode;

mod bench;
mod install;
mod lab;
mod layers;
mod pool;
mod prebuild;
mod test;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (task, rest) = match args.split_first() {
        Some((task, rest)) => (task.as_str(), rest),
        None => ("", &[][..]),
    };
    let result = match task {
        "test" => test::run(rest),
        "bench" => bench::task(rest),
        "demo" => lab::demo(rest),
        "experiments" => lab::experiments(rest),
        "faults" => lab::faults(rest),
        "soak" => lab::soak(rest),
        "latency" => lab::latency(rest),
        "live" => lab::live(rest),
        "size" => lab::size(rest),
        "layers" => layers::task(rest),
        _ => Err(
            "usage: cargo xtask test [--lint] [--jobs N] | cargo xtask bench [--json] [--quick] \
                  | cargo xtask demo [--board qemu|host] [--out DIR] \
                  | cargo xtask experiments [--out DIR] [--quick] [--json] [...] \
                  | cargo xtask faults [--json] [--quick] | cargo xtask soak [--json] [--quick] \
                  | cargo xtask size [--json] | cargo xtask layers [--json] \
                  | cargo xtask latency [--quick] [--json] [--no-ros2] [--publish-hz HZ] \
                  | cargo xtask live [--json]"
                .to_string(),
        ),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("xtask {task}: {message}");
            ExitCode::FAILURE
        }
    }
}
