//! Criterion: the application core (the default co-processor) on the host, per laser return.
//!
//! `cargo bench -p terrain-pyramid-bench` after `cargo xtask bench` (which writes the
//! recording `target/bench/stairs.rec`; `BENCH_RECORDING` names another). Throughput is in
//! elements = laser returns. The timed part includes booting a fresh core (94 KiB) per pass.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use terrain_pyramid::drivers::angle::HostSuppliedAngle;
use terrain_pyramid::DefaultCoProcessor;
use terrain_pyramid_bench::{boot, default_design, replay, Core, Pipeline};

fn pipeline(c: &mut Criterion) {
    let path = std::env::var("BENCH_RECORDING").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/bench/stairs.rec").into()
    });
    let Ok(rec) = std::fs::read(&path) else {
        eprintln!("no recording at {path}: run `cargo xtask bench` first or set BENCH_RECORDING");
        return;
    };
    let Some(design) = default_design::<64, 8>() else {
        return;
    };
    let mut core: Box<DefaultCoProcessor> = Box::default();
    // One pass to count the returns.
    let returns = {
        if !boot(&mut core, &rec, &design) {
            eprintln!("{path}: no usable setup");
            return;
        }
        let mut p = Core {
            core: &mut core,
            angle: HostSuppliedAngle::new(),
        };
        replay(&rec, &mut p);
        p.returns()
    };
    let mut group = c.benchmark_group("pipeline");
    group.throughput(Throughput::Elements(u64::from(returns)));
    group.bench_function("stairs recording, the default co-processor", |b| {
        b.iter(|| {
            *core = DefaultCoProcessor::new();
            boot(&mut core, &rec, &design);
            let mut p = Core {
                core: &mut core,
                angle: HostSuppliedAngle::new(),
            };
            replay(black_box(&rec), &mut p);
            black_box(p.returns())
        });
    });
    group.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
