//! Host-to-device bytes into the device's receive path (`Link::receive`) with a real
//! `DefaultPyramid`.
//!
//! The input is a list of segments `[flags, type, len, body...]` that the harness turns into
//! valid frames (or raw bytes, a wrong version, a flipped bit: see `common::link_stream`), so
//! the fuzzer reaches every command's parser, not only the COBS and CRC checks.
//!
//! Invariants: no panic; the pyramid (layers, resolutions, origins, cells, increments, gates)
//! changes only in a `receive` call that reported `Configured` or `Reset`; after `Configured`
//! the pyramid has at least one layer; every byte the device queues decodes on the host side
//! as a whole frame.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::link::{Event, Link, SensorCounters};
use terrain_pyramid::wire::link::{Accumulator, FeedResult, MAX_FRAME};
use terrain_pyramid::{
    Config, DefaultDesign, DefaultPyramid, Evidence, EvidenceClass, Meters, Schedule, SensorModel,
    DEFAULT_CELLS_PER_SIDE,
};

/// Everything of the pyramid a command may change, as plain numbers.
fn fingerprint(p: &DefaultPyramid) -> Vec<i64> {
    let mut out = vec![p.layer_count() as i64];
    let inc = p.increments();
    out.extend([
        i64::from(inc.obstacle.to_bits()),
        i64::from(inc.free.to_bits()),
        i64::from(inc.initial.to_bits()),
    ]);
    for k in 0..p.layer_count() {
        let layer = p.layer(k).expect("an active layer");
        out.push(i64::from(layer.resolution().to_bits()));
        let (ox, oy) = layer.origin();
        out.extend([i64::from(ox), i64::from(oy)]);
        for dy in 0..DEFAULT_CELLS_PER_SIDE {
            for dx in 0..DEFAULT_CELLS_PER_SIDE {
                out.push(i64::from(layer.at_offset(dx, dy).expect("inside").to_raw()));
            }
        }
        let gate = p.gate(k).expect("an active gate");
        out.extend(gate.weights().iter().map(|w| i64::from(w.to_bits())));
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let (sizes, rest) = common::split_sizes(data);
    let stream = common::link_stream(rest);

    let mut pyramid = Box::new(DefaultPyramid::new());
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        DEFAULT_CELLS_PER_SIDE,
    )
    .expect("the default design");
    pyramid
        .configure(&design, &Config::default())
        .expect("the default config");
    // Some evidence, so that a reset is visible.
    for i in 0..20 {
        pyramid.apply(&Evidence {
            layer: (i % 3) as u8,
            cell_x: i - 10,
            cell_y: 3 - i,
            class: if i % 2 == 0 {
                EvidenceClass::Obstacle
            } else {
                EvidenceClass::Navigable
            },
            distance: Meters::from_num(0.5 + f64::from(i) * 0.3),
        });
    }
    let mut link: Box<Link> = Box::default();
    link.configure(&mut pyramid, &design, &Config::default())
        .expect("the default config");

    let mut host = Box::new(Accumulator::<MAX_FRAME>::new());
    let mut uart = [0_u8; 256];
    let mut now_ms = 0_u32;
    for chunk in common::chunks(&stream, sizes) {
        let before = fingerprint(&pyramid);
        let mut changed_by_command = false;
        let mut configured = false;
        link.receive(chunk, &mut pyramid, |event| match event {
            Event::Configured => {
                changed_by_command = true;
                configured = true;
            }
            Event::Reset => changed_by_command = true,
            _ => {}
        });
        if !changed_by_command {
            assert_eq!(
                fingerprint(&pyramid),
                before,
                "the pyramid changed without a command"
            );
        }
        if configured {
            assert!(pyramid.layer_count() >= 1);
        }
        now_ms = now_ms.wrapping_add(7);
        link.poll(now_ms, &mut pyramid, &SensorCounters::default());
        // What the device sends must decode whole on the host's side.
        loop {
            let n = link.pop_bytes(&mut uart);
            if n == 0 {
                break;
            }
            let mut window = &uart[..n];
            loop {
                match host.feed(window) {
                    FeedResult::Consumed => break,
                    FeedResult::Frame { remaining, .. } => window = remaining,
                    FeedResult::Error { error, .. } => {
                        panic!("the device sent a bad frame: {error:?}")
                    }
                }
            }
        }
    }
});
