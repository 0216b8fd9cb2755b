//! Criterion: the library's per-line pipeline on the host, per laser return.
//!
//! `cargo bench -p terrain-pyramid-bench` after `cargo xtask bench` (which writes the
//! recording `target/bench/stairs.rec`; `BENCH_RECORDING` names another). Throughput is in
//! elements = laser returns. The timed part includes resetting the pyramid (73 KiB) per pass.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use terrain_pyramid::link::{Link, LinkConfig};
use terrain_pyramid::wire::sick::SickAccumulator;
use terrain_pyramid::{
    Config, DefaultDesign, DefaultFrontend, DefaultPyramid, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};
use terrain_pyramid_bench::{frontend_config, replay, setup, Fixed, Pipeline};

fn pipeline(c: &mut Criterion) {
    let path = std::env::var("BENCH_RECORDING").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/bench/stairs.rec").into()
    });
    let Ok(rec) = std::fs::read(&path) else {
        eprintln!("no recording at {path}: run `cargo xtask bench` first or set BENCH_RECORDING");
        return;
    };
    let Some(config) = setup(&rec).as_ref().and_then(frontend_config) else {
        eprintln!("{path}: no usable setup");
        return;
    };
    let Ok(design) = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    ) else {
        return;
    };
    let mut pyramid = Box::new(DefaultPyramid::new());
    let mut link: Box<Link> = Box::new(Link::new(LinkConfig::DEFAULT));
    let mut acc: Box<SickAccumulator> = Box::new(SickAccumulator::new());
    let mut frontend = Box::new(DefaultFrontend::new(config));
    // One pass to count the returns.
    let returns = {
        let _ = link.configure(&mut pyramid, &design, &Config::default());
        let mut p = Fixed {
            frontend: &mut frontend,
            pyramid: &mut pyramid,
            link: Some(&mut link),
        };
        replay(&rec, &mut acc, &mut p);
        p.returns()
    };
    let mut group = c.benchmark_group("pipeline");
    group.throughput(Throughput::Elements(u64::from(returns)));
    group.bench_function("stairs recording, default pyramid + link", |b| {
        b.iter(|| {
            *pyramid = DefaultPyramid::new();
            *link = Link::new(LinkConfig::DEFAULT);
            let _ = link.configure(&mut pyramid, &design, &Config::default());
            *acc = SickAccumulator::new();
            frontend.configure(config);
            let mut p = Fixed {
                frontend: &mut frontend,
                pyramid: &mut pyramid,
                link: Some(&mut link),
            };
            black_box(replay(black_box(&rec), &mut acc, &mut p))
        });
    });
    group.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
