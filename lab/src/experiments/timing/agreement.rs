//! How far one map stays from another, cell by cell and layer by layer: the figure the
//! timing runs are compared by.
use crate::experiments::stairs::round4;
use serde::Serialize;
use std::collections::HashMap;
use terrain_pyramid_host::export::MapSnapshot;

/// How much of one map equals another, cell by cell.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct LayerAgreement {
    /// The layer.
    pub layer: usize,
    /// Cells known (not unknown) in either map.
    pub known: u64,
    /// Of them, cells with exactly the same value in both.
    pub equal: u64,
    /// Of them, cells on the same side of zero in both (both obstacle evidence, both
    /// navigable, or both exactly zero); unknown in one counts as different.
    pub same_side: u64,
}

/// A map against the reference.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Agreement {
    /// Known cells over every layer.
    pub known: u64,
    /// Share of them equal to the reference's.
    pub equal_share: f64,
    /// Share on the same side of zero.
    pub same_side_share: f64,
    /// The lowest per-layer share of equal cells (layers with known cells).
    pub worst_layer_equal_share: f64,
    /// Per layer.
    pub layers: Vec<LayerAgreement>,
}

/// Compares `map` with `reference`, layer by layer, by world cell index.
pub fn agreement(map: &MapSnapshot, reference: &MapSnapshot) -> Agreement {
    let mut layers = Vec::new();
    for (a, b) in map.layers.iter().zip(&reference.layers) {
        let cells = |l: &terrain_pyramid_host::export::LayerSnapshot| {
            let n = l.cells_per_side;
            let mut m: HashMap<(i64, i64), i16> = HashMap::new();
            for (i, &v) in l.cells.iter().enumerate() {
                if v == i16::MIN {
                    continue;
                }
                #[allow(clippy::cast_possible_wrap)]
                let (cx, cy) = ((i % n) as i64, (i / n) as i64);
                m.insert(
                    (
                        i64::from(l.origin_cells.0) + cx,
                        i64::from(l.origin_cells.1) + cy,
                    ),
                    v,
                );
            }
            m
        };
        let (ma, mb) = (cells(a), cells(b));
        let mut la = LayerAgreement {
            layer: a.index,
            ..LayerAgreement::default()
        };
        for (k, va) in &ma {
            la.known += 1;
            if let Some(vb) = mb.get(k) {
                la.equal += u64::from(va == vb);
                la.same_side += u64::from(va.signum() == vb.signum());
            }
        }
        la.known += mb.keys().filter(|k| !ma.contains_key(k)).count() as u64;
        layers.push(la);
    }
    let known: u64 = layers.iter().map(|l| l.known).sum();
    let share = |n: u64, d: u64| {
        #[allow(clippy::cast_precision_loss)]
        if d == 0 {
            1.0
        } else {
            round4(n as f64 / d as f64)
        }
    };
    Agreement {
        known,
        equal_share: share(layers.iter().map(|l| l.equal).sum(), known),
        same_side_share: share(layers.iter().map(|l| l.same_side).sum(), known),
        worst_layer_equal_share: layers
            .iter()
            .filter(|l| l.known > 0)
            .map(|l| share(l.equal, l.known))
            .fold(1.0, f64::min),
        layers,
    }
}
