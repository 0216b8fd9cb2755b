//! The maps as grids to publish: each layer's window, and the fused map over a bounded square
//! around the robot, in the conventions of `nav_msgs/OccupancyGrid` (0 ..= 100 percent, −1
//! unknown) and with the log-odds themselves for viewers.
use crate::export::{LayerSnapshot, MapSnapshot};
use terrain_pyramid::{Fused, Meters};

/// OccupancyGrid's value of an unknown cell.
pub const OCCUPANCY_UNKNOWN: i8 = -1;
/// OccupancyGrid's value of an obstacle in the fused map.
pub const OCCUPANCY_OBSTACLE: i8 = 100;
/// OccupancyGrid's value of a navigable cell in the fused map.
pub const OCCUPANCY_FREE: i8 = 0;

/// One grid, row-major from the lowest y, each row from the lowest x.
#[derive(Debug, Clone, PartialEq)]
pub struct GridData {
    /// The lower-left corner of cell (0, 0), metres in the maps' frame.
    pub origin_m: (f64, f64),
    /// The cell size, metres (the exact Q16.16 value the device uses).
    pub resolution_m: f64,
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// `width · height` values: −1 unknown, else 0 ..= 100.
    pub occupancy: Vec<i8>,
    /// Layers only: the log-odds, nats (`NaN` = unknown), `width · height` of them.
    pub log_odds: Option<Vec<f32>>,
}

/// A layer cell's occupancy percent: `round(100 / (1 + e^−L))` for log-odds L (raw Q8.8), −1
/// when unknown. L > 0 gives ≥ 50, L < 0 ≤ 50, undecided (L = 0) exactly 50.
#[must_use]
pub fn occupancy_of_raw(raw: i16) -> i8 {
    if raw == i16::MIN {
        return OCCUPANCY_UNKNOWN;
    }
    let l = f64::from(raw) / 256.0;
    let p = 100.0 / (1.0 + (-l).exp());
    // 0 ..= 100 by construction.
    #[allow(clippy::cast_possible_truncation)]
    let v = p.round().clamp(0.0, 100.0) as i8;
    v
}

/// A fused answer as OccupancyGrid's trinary value: obstacle 100, navigable 0, unknown −1.
#[must_use]
pub const fn occupancy_of_fused(f: Fused) -> i8 {
    match f {
        Fused::Obstacle { .. } => OCCUPANCY_OBSTACLE,
        Fused::Navigable { .. } => OCCUPANCY_FREE,
        Fused::Unknown => OCCUPANCY_UNKNOWN,
    }
}

/// Layer `layer`'s window as a grid.
#[must_use]
pub fn layer_grid(layer: &LayerSnapshot) -> GridData {
    let n = layer.cells_per_side;
    GridData {
        origin_m: layer.origin_m(),
        resolution_m: layer.resolution_m(),
        width: n,
        height: n,
        occupancy: layer.cells.iter().map(|&c| occupancy_of_raw(c)).collect(),
        log_odds: Some(
            layer
                .cells
                .iter()
                .map(|&c| {
                    if c == i16::MIN {
                        f32::NAN
                    } else {
                        f32::from(c) / 256.0
                    }
                })
                .collect(),
        ),
    }
}

/// Q16.16 bits of `v` metres, saturating.
fn bits_of(v: f64) -> i64 {
    #[allow(clippy::cast_possible_truncation)]
    let b = (v * 65_536.0).round().clamp(-9.0e15, 9.0e15) as i64;
    b
}

/// The fused map. `half_extent_m > 0`: a square of side `2 · half_extent_m` (rounded up to whole
/// cells) around `centre` at the finest layer's resolution, on the same lattice as the fused
/// map `pyramid listen` writes (`fused.pgm`, which starts at the coarsest window's corner), so
/// the cells both cover are equal; `half_extent_m ≤ 0`: exactly that map (the coarsest window).
/// `None` without layers.
#[must_use]
pub fn fused_grid(
    snapshot: &MapSnapshot,
    centre: (f64, f64),
    half_extent_m: f64,
) -> Option<GridData> {
    if half_extent_m.is_nan() || half_extent_m <= 0.0 {
        let map = snapshot.fused_map()?;
        return Some(GridData {
            origin_m: (map.origin.0.to_num(), map.origin.1.to_num()),
            resolution_m: f64::from(map.step.to_bits()) / 65_536.0,
            width: map.width,
            height: map.height,
            occupancy: map.cells.iter().map(|&f| occupancy_of_fused(f)).collect(),
            log_odds: None,
        });
    }
    let (finest, coarsest) = (snapshot.layers.first()?, snapshot.layers.last()?);
    let step = i64::from(finest.resolution.to_bits()).max(1);
    let (ox, oy) = coarsest.origin_cells;
    let lattice = (
        i64::from(coarsest.resolution.cell_edge(ox).to_bits()),
        i64::from(coarsest.resolution.cell_edge(oy).to_bits()),
    );
    let half = bits_of(half_extent_m.min(30_000.0));
    let cells = usize::try_from((2 * half + step - 1) / step).unwrap_or(0);
    // The lattice point at or below centre − half, in whole fine steps from the lattice origin.
    let start = |c: f64, l: i64| -> Meters {
        let k = (bits_of(c) - half - l).div_euclid(step);
        let b = (l + k * step).clamp(i64::from(i32::MIN), i64::from(i32::MAX));
        #[allow(clippy::cast_possible_truncation)]
        Meters::from_bits(b as i32)
    };
    let (x0, y0) = (start(centre.0, lattice.0), start(centre.1, lattice.1));
    let values = snapshot.fused_region(x0, y0, finest.resolution.meters(), cells, cells);
    Some(GridData {
        origin_m: (x0.to_num(), y0.to_num()),
        resolution_m: finest.resolution_m(),
        width: cells,
        height: cells,
        occupancy: values.iter().map(|&f| occupancy_of_fused(f)).collect(),
        log_odds: None,
    })
}

/// The finest layer's window centre, metres: where the device keeps the robot (it recentres
/// the windows on the poses it is sent).
#[must_use]
pub fn window_centre(snapshot: &MapSnapshot) -> Option<(f64, f64)> {
    let l = snapshot.layers.first()?;
    let (x, y) = l.origin_m();
    let half = l.extent_m() / 2.0;
    Some((x + half, y + half))
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::{LogOddsFixed, Resolution};

    fn layer(index: usize, r: f32, origin: (i32, i32), cells: Vec<i16>) -> LayerSnapshot {
        let n = (cells.len() as f64).sqrt() as usize;
        LayerSnapshot {
            index,
            resolution: Resolution::from_m(r).unwrap(),
            band_m: [0.0, 1.0],
            origin_cells: origin,
            cells_per_side: n,
            cells,
        }
    }

    #[test]
    fn occupancy_follows_the_log_odds() {
        assert_eq!(occupancy_of_raw(i16::MIN), -1);
        assert_eq!(occupancy_of_raw(0), 50);
        assert_eq!(occupancy_of_raw(i16::MAX), 100);
        assert_eq!(occupancy_of_raw(-i16::MAX), 0);
        // ln 3 nats: p = 0.75.
        assert_eq!(occupancy_of_raw((3.0_f64.ln() * 256.0).round() as i16), 75);
        assert!(occupancy_of_raw(1) >= 50 && occupancy_of_raw(-1) <= 50);
        assert_eq!(occupancy_of_fused(Fused::Obstacle { layer: 3 }), 100);
        assert_eq!(occupancy_of_fused(Fused::Navigable { layer: 0 }), 0);
        assert_eq!(occupancy_of_fused(Fused::Unknown), -1);
    }

    #[test]
    fn a_bounded_fused_grid_agrees_with_the_whole_map_where_they_overlap() {
        // Two layers, 8 × 8: 0.1 m at (−4, −4) cells, 0.3 m at (−4, −4) cells.
        let mut fine = vec![i16::MIN; 64];
        fine[3 * 8 + 5] = 300; // obstacle
        fine[4 * 8 + 4] = -300; // free
        let mut coarse = vec![-200_i16; 64];
        coarse[0] = 500;
        let snapshot = MapSnapshot {
            layers: vec![
                layer(0, 0.1, (-4, -4), fine),
                layer(1, 0.3, (-4, -4), coarse),
            ],
            sensor_xy: (0.0, 0.0),
            fused_margin: LogOddsFixed::ZERO,
        };
        let whole = fused_grid(&snapshot, (0.0, 0.0), 0.0).unwrap();
        assert_eq!(whole.width, 24);
        let part = fused_grid(&snapshot, (0.07, -0.33), 0.5).unwrap();
        assert_eq!(part.width, 10);
        let r = whole.resolution_m;
        let mut overlap = 0;
        let mut outside = 0;
        for j in 0..part.height {
            for i in 0..part.width {
                let v = part.occupancy[j * part.width + i];
                let x = part.origin_m.0 + (i as f64 + 0.5) * r;
                let y = part.origin_m.1 + (j as f64 + 0.5) * r;
                let wi = ((x - whole.origin_m.0) / r).floor();
                let wj = ((y - whole.origin_m.1) / r).floor();
                // The lattices coincide: the part's cell centres are the whole map's.
                let off = (x - whole.origin_m.0) / r - wi - 0.5;
                assert!(off.abs() < 1e-6, "{off}");
                if (0.0..24.0).contains(&wi) && (0.0..24.0).contains(&wj) {
                    overlap += 1;
                    assert_eq!(v, whole.occupancy[wj as usize * 24 + wi as usize]);
                } else {
                    outside += 1;
                    assert_eq!(v, -1);
                }
            }
        }
        assert!(overlap > 50 && outside == 0, "{overlap} {outside}");
        assert!(whole.occupancy.contains(&100) && whole.occupancy.contains(&0));
        // Far away: nothing known.
        let far = fused_grid(&snapshot, (50.0, 50.0), 0.5).unwrap();
        assert!(far.occupancy.iter().all(|&v| v == -1));
    }
}
