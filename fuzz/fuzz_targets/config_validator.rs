//! Arbitrary f32 bit patterns into the configuration validator: `Design::new`,
//! `InverseSensorModel::increments`, `Clamp::bounds` and `Pyramid::configure`.
//!
//! Input layout (little-endian, missing bytes read as zero): 15 f32 — φ, ψ, σ, h, max range,
//! Δd, γ, gate width, p_obstacle, p_free, prior, clamp min, clamp max, margin, spare — then
//! u16 cells per side, a flags byte (bit 0 hard gate, bit 1 uniform resolution, bit 2 clamp
//! off, bit 3 force 64 cells), and a byte that picks "nice" values for some fields so the
//! fuzzer reaches the later checks.
//!
//! Invariants: no panic; an accepted design has 1..=L layers whose bands start at 0, are
//! contiguous, non-decreasing (see the known gaps), and end at the maximum range; resolutions are finite and
//! positive and each layer's window holds its band; accepted increments have
//! obstacle ≥ 0 ≥ free and accepted clamp bounds min ≤ 0 ≤ max (the documented strict
//! inequalities do not hold: see the known gaps in RELIABILITY.md); a pyramid refusing a
//! configuration is left unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use terrain_pyramid::decay::Decay;
use terrain_pyramid::design::cells_to_hold;
use terrain_pyramid::{
    Clamp, Config, Design, GateShape, InverseSensorModel, Pyramid, Schedule, SensorModel,
};

const L: usize = 8;
const W: usize = 64;

fn f32_at(data: &[u8], i: usize) -> f32 {
    let mut b = [0_u8; 4];
    for (k, slot) in b.iter_mut().enumerate() {
        *slot = data.get(4 * i + k).copied().unwrap_or(0);
    }
    f32::from_le_bytes(b)
}

fuzz_target!(|data: &[u8]| {
    let mut v: [f32; 15] = core::array::from_fn(|i| f32_at(data, i));
    let cells = u16::from_le_bytes([
        data.get(60).copied().unwrap_or(0),
        data.get(61).copied().unwrap_or(0),
    ]);
    let flags = data.get(62).copied().unwrap_or(0);
    let nice = data.get(63).copied().unwrap_or(0);
    // Defaults for the fields whose `nice` bit is set: the rest stay arbitrary.
    let defaults = [
        0.5_f32.to_radians(),
        2.0_f32.to_radians(),
        0.15,
        1.0,
        10.0,
        0.1,
        2.0,
        0.5,
        0.7,
        0.4,
        0.5,
        -2.0,
        3.5,
        0.0,
        0.0,
    ];
    for (i, (slot, d)) in v.iter_mut().zip(defaults).enumerate() {
        // Bit i % 8 of `nice`: groups of fields share a bit.
        if nice & (1 << (i % 8)) != 0 {
            *slot = d;
        }
    }
    let sensor = SensorModel {
        phi_rad: v[0],
        psi_rad: v[1],
        sigma_m: v[2],
        height_m: v[3],
        max_range_m: v[4],
    };
    let schedule = Schedule {
        base_m: v[5],
        gamma: v[6],
        gate: if flags & 1 != 0 {
            GateShape::Hard
        } else {
            GateShape::Soft { width_factor: v[7] }
        },
        uniform_resolution: flags & 2 != 0,
    };
    let cells = if flags & 8 != 0 {
        W
    } else {
        usize::from(cells)
    };

    let design = Design::<L>::new(sensor, schedule, cells);
    if let Ok(design) = &design {
        let layers = design.layers();
        assert!(!layers.is_empty() && layers.len() <= L);
        assert_eq!(layers[0].band_inner_m, 0.0);
        for pair in layers.windows(2) {
            assert_eq!(
                pair[0].band_outer_m, pair[1].band_inner_m,
                "bands not contiguous"
            );
        }
        for (k, layer) in layers.iter().enumerate() {
            // Documented: strictly increasing (empty bands are refused).
            assert!(
                layer.band_outer_m > layer.band_inner_m,
                "band {k} decreasing: {layer:?}"
            );
            assert!(layer.resolution_m.is_finite() && layer.resolution_m > 0.0);
            assert!(layer.gate_sigma_m.is_finite() && layer.gate_sigma_m >= 0.0);
            assert!(layer.gate_center_m.is_finite());
            assert!(cells_to_hold(layer.band_outer_m, layer.resolution_m) <= cells);
        }
        assert_eq!(
            layers.last().map(|l| l.band_outer_m),
            Some(sensor.max_range_m)
        );
    }

    let model = InverseSensorModel {
        p_obstacle: v[8],
        p_free: v[9],
        prior: v[10],
    };
    if let Ok(inc) = model.increments() {
        // Documented: obstacle > 0 > free (an increment that rounds to 0 is refused).
        assert!(
            inc.obstacle.to_bits() > 0,
            "obstacle increment <= 0: {model:?}"
        );
        assert!(inc.free.to_bits() < 0, "free increment >= 0: {model:?}");
    }
    let clamp = if flags & 4 != 0 {
        Ok(Clamp::Off)
    } else {
        Clamp::bounds(v[11], v[12])
    };
    if let Ok(Clamp::Bounds { min, max }) = clamp {
        // Documented: min < 0 < max (bounds that round to 0 are refused).
        assert!(min.to_bits() < 0 && max.to_bits() > 0, "bounds {min} {max}");
    }

    if let (Ok(design), Ok(clamp)) = (design, clamp) {
        let config = Config {
            model,
            clamp,
            fused_margin: v[13],
            decay: Decay::OFF,
        };
        let mut pyramid = Box::new(Pyramid::<W, L>::new());
        match pyramid.configure(&design, &config) {
            Ok(()) => {
                assert_eq!(pyramid.layer_count(), design.layers().len());
                assert_eq!(design.cells_per_side(), W);
            }
            Err(_) => assert_eq!(pyramid.layer_count(), 0, "a refused configure changed it"),
        }
    }
});
