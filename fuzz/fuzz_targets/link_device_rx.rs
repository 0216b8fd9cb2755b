//! Host-to-device bytes into the application core's host side (`CoProcessor::host`: the link's
//! receive path, then the commands carried out) with the default co-processor.
//!
//! The input is a list of segments `[flags, type, len, body...]` that the harness turns into
//! valid frames (or raw bytes, a wrong version, a flipped bit: see `common::link_stream`), so
//! the fuzzer reaches every command's parser, not only the COBS and CRC checks.
//!
//! Invariants: no panic; the maps (layers, resolutions, origins, cells, increments, gates)
//! change only in a chunk after which the device announces it to the host with a Hello that
//! clears the host's maps (reason configured or reset); after such a Hello the pyramid has at
//! least one layer; every byte the device queues decodes on the host side as a whole frame.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::link::LinkConfig;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::link::{Decoded, FrameAccumulator, Message, MAX_FRAME};
use terrain_pyramid::wire::FeedResult;
use terrain_pyramid::{Config, DefaultCoProcessor, DefaultDesign, Schedule, SensorModel};

/// Everything of the maps a command may change, as plain numbers.
fn fingerprint(core: &DefaultCoProcessor) -> Vec<i64> {
    let p = core.pyramid();
    let mut out = vec![p.layer_count() as i64];
    let inc = p.increments();
    out.extend([
        i64::from(inc.obstacle.to_bits()),
        i64::from(inc.free.to_bits()),
        i64::from(inc.initial.to_bits()),
    ]);
    let w = terrain_pyramid::DEFAULT_CELLS_PER_SIDE;
    for k in 0..p.layer_count() {
        let layer = p.layer(k).expect("an active layer");
        out.push(i64::from(layer.resolution().to_bits()));
        let (ox, oy) = layer.origin();
        out.extend([i64::from(ox), i64::from(oy)]);
        for dy in 0..w {
            for dx in 0..w {
                out.push(i64::from(layer.at_offset(dx, dy).expect("inside").to_raw()));
            }
        }
        let gate = core.frontend().gates().table(k).expect("an active gate");
        out.extend(gate.weights().iter().map(|w| i64::from(w.to_bits())));
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let (sizes, rest) = common::split_sizes(data);
    let stream = common::link_stream(rest);

    let mut core: Box<DefaultCoProcessor> = Box::default();
    let design = DefaultDesign::new(
        SensorModel::default(),
        Schedule::default(),
        terrain_pyramid::DEFAULT_CELLS_PER_SIDE,
    )
    .expect("the default design");
    let setup = FrontendConfig::lms291_boot(ScanPlane::TiltedHorizontal);
    core.boot(LinkConfig::DEFAULT, &design, &Config::default(), setup)
        .expect("the default boot");
    // Some evidence, so that a reset is visible: a line of floor seen at a known angle.
    let mut frame = [0_u8; 32];
    let n = terrain_pyramid::wire::link::encode(
        0,
        &Message::PanAngle(terrain_pyramid::wire::link::PanAngle {
            turns: 0x0E39,
            timestamp_ms: 0,
        }),
        &mut frame,
    )
    .expect("a PanAngle frame");
    core.host(&frame[..n]);
    core.laser(
        &common::floor_telegram(),
        0,
        &mut terrain_pyramid::app::NoAngleSource,
    );

    let mut host = Box::new(FrameAccumulator::<MAX_FRAME>::new());
    let mut uart = [0_u8; 256];
    let mut now_ms = 0_u32;
    for chunk in common::chunks(&stream, sizes) {
        let before = fingerprint(&core);
        core.host(chunk);
        now_ms = now_ms.wrapping_add(7);
        core.poll(now_ms);
        // What the device sends must decode whole on the host's side.
        let mut announced = false;
        loop {
            let n = core.take_output(&mut uart);
            if n == 0 {
                break;
            }
            // Every frame takes at least one byte: no more calls than bytes.
            common::feed_chunks(
                &[&uart[..n]],
                |len| len,
                |window| match host.feed(window) {
                    FeedResult::Consumed => (&[], false),
                    FeedResult::Item {
                        item: Decoded { message, .. },
                        remaining,
                        ..
                    } => {
                        if let Message::Hello(hello) = message {
                            announced |= hello.reason.clears_maps();
                        }
                        (remaining, true)
                    }
                    FeedResult::Rejected { error, .. } => {
                        panic!("the device sent a bad frame: {error:?}")
                    }
                },
            );
        }
        if !announced {
            assert_eq!(
                fingerprint(&core),
                before,
                "the maps changed without the host being told"
            );
        } else {
            assert!(core.pyramid().layer_count() >= 1);
        }
        if core.shutdown_requested() {
            core.answer_shutdown(terrain_pyramid::app::StackUsage::default());
        }
    }
});
