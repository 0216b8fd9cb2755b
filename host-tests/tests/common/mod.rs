//! Strategies and helpers shared by the property tests.
#![allow(dead_code)]

pub mod feed;

use proptest::prelude::*;
use terrain_pyramid as tp;
use terrain_pyramid_host_tests::harness;

/// The layer capacity the design tests compile for.
pub const CAPACITY: usize = 32;

/// A valid-looking sensor: φ 0.1°..2°, ψ 0.25°..4°, σ 0.01..0.3 m, h 0.3..2 m, R 3..80 m.
pub fn sensor() -> impl Strategy<Value = tp::SensorModel> {
    (
        0.1f64..2.0,
        0.25f64..4.0,
        0.01f32..0.3,
        0.3f32..2.0,
        3.0f32..80.0,
    )
        .prop_map(|(phi, psi, sigma, h, r)| tp::SensorModel {
            phi_rad: phi.to_radians() as f32,
            psi_rad: psi.to_radians() as f32,
            sigma_m: sigma,
            height_m: h,
            max_range_m: r,
        })
}

/// A gate: hard, or soft with a width factor in 0.05 ..= 4.
pub fn gate() -> impl Strategy<Value = tp::GateShape> {
    prop_oneof![
        1 => Just(tp::GateShape::Hard),
        3 => (0.05f32..=4.0).prop_map(|width_factor| tp::GateShape::Soft { width_factor }),
    ]
}

/// A schedule for `sensor` with γ 1.2..4 and Δd > φ·h: either just above its floor
/// (max(φh, 1 cm)), or sized so that the bands need about `layers` layers (1 ..= 40, so
/// that some configurations exceed the capacity).
pub fn schedule_for(sensor: tp::SensorModel) -> impl Strategy<Value = tp::Schedule> {
    let rs = harness::sensor(&sensor);
    let floor = (rs.phi * rs.height).max(0.01);
    let delta_max = rs.delta(rs.max_range);
    (
        1.2f32..4.0,
        gate(),
        prop::bool::weighted(0.2),
        1.0f64..40.0,
        0.0f64..1.0,
    )
        .prop_map(move |(gamma, gate, near_floor, layers, u)| {
            let base = if near_floor {
                floor * (1.0 + 1e-3 + 0.5 * u)
            } else {
                (delta_max / (f64::from(gamma) * layers)).max(floor * 1.001) * (1.0 + 0.3 * u)
            };
            tp::Schedule {
                base_m: base.min(100.0) as f32,
                gamma,
                gate,
                uniform_resolution: false,
            }
        })
}

/// How the window is chosen relative to what the bands need.
#[derive(Debug, Clone, Copy)]
pub enum WindowChoice {
    /// The smallest even window that holds every band.
    Enough,
    /// Two cells short of that (so some layer's band does not fit).
    TooSmall,
    /// Enough, plus some.
    Larger(usize),
}

/// A whole valid-looking configuration: sensor, schedule, window.
pub fn config() -> impl Strategy<Value = (tp::SensorModel, tp::Schedule, usize)> {
    sensor()
        .prop_flat_map(|s| (Just(s), schedule_for(s)))
        .prop_flat_map(|(s, sch)| {
            let w = prop_oneof![
                6 => Just(WindowChoice::Enough),
                2 => Just(WindowChoice::TooSmall),
                2 => (1usize..50).prop_map(WindowChoice::Larger),
            ];
            (Just(s), Just(sch), w)
        })
        .prop_map(|(s, sch, choice)| {
            let o = harness::reference_design(&s, &sch, 1024, 1 << 20);
            let enough = o.result.map_or(64, |d| {
                d.layers.iter().map(|l| l.cells_needed).max().unwrap_or(4)
            });
            let w = match choice {
                WindowChoice::Enough => enough,
                WindowChoice::TooSmall => enough.saturating_sub(2),
                WindowChoice::Larger(extra) => enough + 2 * extra,
            };
            (s, sch, w.clamp(4, 1024))
        })
}

/// `f32` next up (positive finite values).
pub fn next_up(x: f32) -> f32 {
    f32::from_bits(x.to_bits() + 1)
}

/// A proptest configuration of `cases` cases from a fixed seed (reproducible, no regression
/// files written).
pub fn seeded(cases: u32, seed: u64) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    }
}

/// One piece of a hostile stream, as a stream's strategy draws it; what each piece holds is
/// the stream's (see its alias of this type).
#[derive(Debug, Clone)]
pub enum Piece<Own> {
    /// A valid unit.
    Intact(Vec<u8>),
    /// Bytes between units.
    Garbage(Vec<u8>),
    /// A unit with one bit flipped (bit index modulo its length in bits).
    Flipped(Vec<u8>, usize),
    /// A unit cut short after this many bytes (modulo its length).
    Truncated(Vec<u8>, usize),
    /// A piece only this stream has.
    Own(Own),
}

/// Units of a stream: their offsets (of the first byte in the stream) and bytes.
pub type Units = Vec<(u64, Vec<u8>)>;

/// Cuts `stream` into chunks whose sizes cycle through `sizes`.
pub fn chunks<'a>(stream: &'a [u8], sizes: &[usize]) -> Vec<&'a [u8]> {
    let mut out = Vec::new();
    let mut rest = stream;
    let mut i = 0;
    while !rest.is_empty() {
        let n = sizes[i % sizes.len()].clamp(1, rest.len());
        i += 1;
        let (head, tail) = rest.split_at(n);
        out.push(head);
        rest = tail;
    }
    out
}

/// Feeds every chunk to an accumulator through `feed` (one `feed` call on what is left of
/// the chunk: the rest of it, and whether to call again), until `feed` says stop.
pub fn feed_chunks<'c>(chunks: &[&'c [u8]], mut feed: impl FnMut(&'c [u8]) -> (&'c [u8], bool)) {
    for &chunk in chunks {
        let mut window = chunk;
        loop {
            let (rest, again) = feed(window);
            window = rest;
            if !again {
                break;
            }
        }
    }
}
