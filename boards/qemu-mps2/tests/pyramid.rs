//! On-target tests of the pyramid's configuration and data path: the default design, the
//! hard gates, the classifier on a tiny scene, and a small `Pyramid<16, 4>` end to end, in
//! QEMU on the emulated Cortex-M.
//!
//! Expected band edges are literals computed independently (Python, f64 bisection of eq. 17).
#![no_std]
#![no_main]

use qemu_mps2 as _; // defmt logger, panic and HardFault handlers, semihosting exit

use terrain_pyramid::gate::Gates;
use terrain_pyramid::{
    Config, Design, Evidence, EvidenceClass, GateShape, Meters, Schedule, SensorModel,
};

/// A 4-layer design whose windows fit 16 cells: σ = 0.3 m, 3 m range, Δd = 0.1 m, γ = 2,
/// hard gates. Layers of 0.1 / 0.2 / 0.4 / 0.6 m over [0, 0.280), [0.280, 0.656),
/// [0.656, 2.191), [2.191, 3] m.
fn small_design() -> Design<4> {
    let sensor = SensorModel {
        sigma_m: 0.3,
        max_range_m: 3.0,
        ..SensorModel::default()
    };
    let schedule = Schedule {
        gate: GateShape::Hard,
        ..Schedule::default()
    };
    Design::new(sensor, schedule, 16).unwrap()
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

fn m(v: f32) -> Meters {
    Meters::from_num(v)
}

/// The gating of [`small_design`] with the default increments.
fn small_gates() -> Gates<4> {
    let mut gates = Gates::new();
    let increments = Config::default().model.increments().unwrap();
    gates.configure(&small_design(), increments).unwrap();
    gates
}

/// A record of `layer` seen at distance `d`, weighted by the small design's gate.
fn record(gates: &Gates<4>, layer: u8, x: i32, y: i32, class: EvidenceClass, d: f32) -> Evidence {
    Evidence {
        layer,
        cell_x: x,
        cell_y: y,
        class,
        weight: gates.weight_at(usize::from(layer), m(d)),
    }
}

#[defmt_test::tests]
mod tests {
    use super::{close, m, record, small_design, small_gates};
    use defmt::{assert, assert_eq};
    use terrain_pyramid::classify::{Classifier, ClassifierConfig};
    use terrain_pyramid::gate::{DistanceBins, GateTable, GATE_BINS};
    use terrain_pyramid::{
        Applied, Config, DefaultDesign, Design, EvidenceClass, Fused, GateShape, Meters, Point3,
        Pyramid, Schedule, SensorModel, Weight, DEFAULT_CELLS_PER_SIDE,
    };

    type Small = Pyramid<16, 4>;

    #[test]
    fn design_default_has_eight_layers() {
        let d = DefaultDesign::new(
            SensorModel::default(),
            Schedule::default(),
            DEFAULT_CELLS_PER_SIDE,
        )
        .unwrap();
        let layers = d.layers();
        assert_eq!(layers.len(), 8);
        assert_eq!(layers[0].band_inner_m, 0.0);
        // sup{d : δ(d) ≤ 0.1 m} = 0.530 537 8 m (f64).
        assert!(close(layers[0].band_outer_m, 0.530_537_83, 1e-4));
        assert_eq!(layers[7].band_outer_m, 10.0);
        for (k, layer) in layers.iter().enumerate() {
            let expected = if k == 0 { 0.1 } else { k as f32 * 0.2 };
            assert!(close(layer.resolution_m, expected, 1e-6));
        }
        for pair in layers.windows(2) {
            assert_eq!(pair[0].band_outer_m, pair[1].band_inner_m);
        }
    }

    #[test]
    fn design_small_bands() {
        let d = small_design();
        let layers = d.layers();
        assert_eq!(layers.len(), 4);
        let edges = [0.280, 0.656, 2.191, 3.0];
        for (layer, edge) in layers.iter().zip(edges) {
            assert!(close(layer.band_outer_m, edge, 2e-3));
        }
        // Too few layers compiled in, and a window too small, are refused.
        let too_few = Design::<2>::new(*d.sensor(), *d.schedule(), 16);
        assert!(too_few.is_err());
        let too_small = Design::<4>::new(*d.sensor(), *d.schedule(), 8);
        assert!(too_small.is_err());
    }

    #[test]
    fn gate_hard_gates_partition_the_bins() {
        let schedule = Schedule {
            gate: GateShape::Hard,
            ..Schedule::default()
        };
        let d = DefaultDesign::new(SensorModel::default(), schedule, 64).unwrap();
        let bins = DistanceBins::for_range(10.0);
        assert!(close(bins.width_m(), 1.0 / 32.0, 0.0));
        let mut owners = [0_u8; GATE_BINS];
        let mut sum = [0_u32; GATE_BINS];
        for k in 0..d.layers().len() {
            let table = GateTable::build(&d, k, bins);
            for (i, w) in table.weights().iter().enumerate() {
                assert!(*w == Weight::ZERO || *w == Weight::ONE);
                if *w == Weight::ONE {
                    owners[i] += 1;
                }
                sum[i] += u32::from(w.to_bits());
            }
        }
        // Bins up to the 10 m range belong to exactly one layer; those that start beyond it
        // (i · 1/32 m > 10 m, from bin 321 on) feed none.
        for i in 0..GATE_BINS {
            let owned = if i <= 320 { 1 } else { 0 };
            assert_eq!(owners[i], owned, "bin {=usize}", i);
            assert_eq!(sum[i], u32::from(owned) << 15);
        }
        // Bin 16 (0.5–0.53 m, centre 0.516 m) belongs to layer 0, bin 17 (centre 0.547 m)
        // to layer 1.
        assert!(GateTable::build(&d, 0, bins).weight(16) == Weight::ONE);
        assert!(GateTable::build(&d, 1, bins).weight(17) == Weight::ONE);
    }

    #[test]
    fn classifier_tiny_scene() {
        let mut pyramid = Small::new();
        pyramid
            .configure(&small_design(), &Config::default())
            .unwrap();
        let mut classifier: Classifier<64, 4> = Classifier::new();
        classifier.configure(ClassifierConfig::default());
        let increments = Config::default().model.increments().unwrap();
        classifier
            .adopt_design(&small_design(), increments)
            .unwrap();
        classifier.begin(Meters::ZERO);
        let ground = Meters::ZERO;
        let point = |x: f32, y: f32, z: f32| Point3 {
            x: m(x),
            y: m(y),
            z: m(z),
        };
        // Layer 0 (0.1 m cells, band [0, 0.28) m): a 12 cm curb in cell (1, 0) ...
        classifier.add_point(point(0.12, 0.05, 0.0), m(0.13), ground);
        classifier.add_point(point(0.18, 0.05, 0.12), m(0.187), ground);
        // ... flat ground in cell (2, 0), with a branch overhead (ignored: above 1 m).
        classifier.add_point(point(0.22, 0.02, 0.0), m(0.221), ground);
        classifier.add_point(point(0.26, 0.04, 0.01), m(0.263), ground);
        classifier.add_point(point(0.25, 0.05, 1.6), m(0.255), ground);
        // Layer 2 (0.4 m cells, band [0.656, 2.191) m): one far point in cell (2, 0).
        classifier.add_point(point(1.0, 0.1, 0.3), m(1.005), ground);
        assert_eq!(classifier.cells_in_use(), 3);
        assert_eq!(classifier.stats().points_used, 6);

        let mut records = [None; 4];
        let mut n = 0;
        classifier.finish(|e| {
            records[n] = Some(e);
            n += 1;
        });
        assert_eq!(n, 3);
        // Records come out in slot order: find each by its cell.
        let find = |layer: u8, x: i32| {
            records
                .iter()
                .flatten()
                .find(|e| (e.layer, e.cell_x, e.cell_y) == (layer, x, 0))
                .copied()
                .unwrap()
        };
        let curb = find(0, 1);
        assert_eq!(curb.class, EvidenceClass::Obstacle);
        // The closest look, 0.13 m, lies in layer 0's band: full weight.
        assert!(curb.weight == Weight::ONE);
        let flat = find(0, 2);
        assert_eq!(flat.class, EvidenceClass::Navigable);
        let far = find(2, 2);
        assert_eq!(far.class, EvidenceClass::Navigable);
        assert_eq!(classifier.cells_in_use(), 0);

        // The same scene straight into the pyramid.
        classifier.begin(Meters::ZERO);
        classifier.add_point(point(0.12, 0.05, 0.0), m(0.13), ground);
        classifier.add_point(point(0.18, 0.05, 0.12), m(0.187), ground);
        classifier.add_point(point(0.22, 0.02, 0.0), m(0.221), ground);
        classifier.finish_into(&mut pyramid);
        assert_eq!(
            pyramid.fused(m(0.15), m(0.05)),
            Fused::Obstacle { layer: 0 }
        );
        assert_eq!(
            pyramid.fused(m(0.25), m(0.05)),
            Fused::Navigable { layer: 0 }
        );
        assert_eq!(pyramid.stats().applied, 2);
    }

    #[test]
    fn pyramid_16x4_integration() {
        let gates = small_gates();
        let record = |layer, x, y, class, d| record(&gates, layer, x, y, class, d);
        let mut p = Small::new();
        assert_eq!(p.layer_count(), 0);
        assert_eq!(
            p.apply(&record(0, 0, 0, EvidenceClass::Obstacle, 0.1)),
            Applied::BadLayer
        );
        p.configure(&small_design(), &Config::default()).unwrap();
        assert_eq!(p.layer_count(), 4);

        // Hard gates: 0.2 m feeds layer 0 only.
        assert_eq!(
            p.apply(&record(0, 1, 1, EvidenceClass::Obstacle, 0.2)),
            Applied::Updated
        );
        assert_eq!(
            p.apply(&record(1, 0, 0, EvidenceClass::Obstacle, 0.2)),
            Applied::GatedOut
        );
        assert_eq!(p.layer(0).unwrap().get(1, 1).unwrap().to_raw(), 217);
        // Outside layer 0's window (cells −8 ..< 8).
        assert_eq!(
            p.apply(&record(0, 8, 0, EvidenceClass::Obstacle, 0.2)),
            Applied::OutsideWindow
        );
        // Far free ground cannot mask the close obstacle: it lands in layer 2.
        for _ in 0..50 {
            p.apply(&record(2, 0, 0, EvidenceClass::Navigable, 1.5));
        }
        assert_eq!(p.fused(m(0.15), m(0.15)), Fused::Obstacle { layer: 0 });
        assert_eq!(p.fused(m(0.35), m(0.05)), Fused::Navigable { layer: 2 });
        // Clamped at −2 nats.
        assert_eq!(p.layer(2).unwrap().get(0, 0).unwrap().to_raw(), -512);
        let stats = p.stats();
        assert_eq!(stats.applied, 51);
        assert_eq!(stats.gated_out, 1);
        assert_eq!(stats.outside_window, 1);

        // Driving 0.55 m along x: layer 0 shifts 5 columns (5 × 16 cells), layer 1 two
        // (0.55 / 0.2 → cell 2), layer 2 one (cell 1), layer 3 none (cell 0).
        let reset = p.recentre(m(0.55), m(0.0));
        assert_eq!(reset, 5 * 16 + 2 * 16 + 16);
        assert_eq!(p.layer(0).unwrap().origin(), (5 - 8, -8));
        // The obstacle cell (1, 1) is still inside layer 0's window ([−3, 13)).
        assert_eq!(p.fused(m(0.15), m(0.15)), Fused::Obstacle { layer: 0 });
        // Layer 2's window is [−7, 9) now: cell (0, 0) stayed.
        assert_eq!(p.fused(m(0.35), m(0.05)), Fused::Navigable { layer: 2 });

        // The fused region: a 4 × 1 strip of 0.1 m cells from (0, 0.1).
        let mut out = [Fused::Unknown; 4];
        p.fused_region(m(0.0), m(0.1), m(0.1), 4, 1, &mut out)
            .unwrap();
        assert_eq!(out[1], Fused::Obstacle { layer: 0 });
        assert_eq!(out[0], Fused::Navigable { layer: 2 });

        p.clear();
        assert_eq!(p.fused(m(0.15), m(0.15)), Fused::Unknown);
        assert_eq!(p.layer(0).unwrap().origin(), (5 - 8, -8));
    }
}
