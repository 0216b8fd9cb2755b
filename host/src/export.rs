//! Exporting the pyramid's maps: ROS `map_server` files (PGM + YAML) per layer and for the
//! fused map, a picture for people, and the numbers for a summary.
//!
//! Everything here works on a [`MapSnapshot`], plain data that can be filled from a library
//! [`Pyramid`] ([`MapSnapshot::from_pyramid`]) or from a host-side mirror of the device's maps
//! (the later `pyramid listen` and `pyramid run`), so every command writes the same files.
//!
//! # The files (ROS `map_server` convention)
//! - `NAME.pgm`: binary PGM (`P5`, maxval 255), the first row is the map's top (largest y),
//!   x grows to the right; 0 = obstacle, 254 = navigable, 205 = unknown. A cell is written as
//!   obstacle or navigable exactly when it is observed with L > 0 or L < 0; observed with
//!   L = 0 (undecided) is written as unknown.
//! - `NAME.yaml`: `image`, `mode: trinary`, `resolution` (the exact fixed-point cell size the
//!   library uses, `round(r · 2¹⁶) / 2¹⁶` m), `origin: [x, y, 0.0]` (the lower-left corner of
//!   the lower-left cell, metres), `negate: 0`, `occupied_thresh: 0.65`, `free_thresh: 0.196`.
//!
//! Layer K's map (`layer-K`) is its whole window. The fused map (`fused`) samples the fused
//! query at the finest layer's resolution over the coarsest layer's window, exactly as the
//! library's [`Pyramid::fused_region`] does.
use crate::link::Mirror;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use terrain_pyramid::grid::cell_of;
use terrain_pyramid::logodds::round_to_log_odds;
use terrain_pyramid::{
    Cell, CellClass, Config, Design, Fused, LayerCounts, LogOddsFixed, Meters, Pyramid, Resolution,
};

pub mod picture;

/// The PGM value of an obstacle cell.
pub const PGM_OBSTACLE: u8 = 0;
/// The PGM value of a navigable cell.
pub const PGM_FREE: u8 = 254;
/// The PGM value of an unknown (or undecided) cell.
pub const PGM_UNKNOWN: u8 = 205;

/// The file name of the picture of all the maps.
pub const PICTURE_FILE: &str = "maps.png";

/// The fused query's margin for maps read from a device (which does not send its own): the
/// library's default, [`terrain_pyramid::DEFAULT_FUSED_MARGIN`], in Q8.8 (14/256 nats), the
/// margin `pyramid run` and `pyramid replay` configure their pyramids with.
#[must_use]
pub fn default_fused_margin() -> LogOddsFixed {
    round_to_log_odds(terrain_pyramid::DEFAULT_FUSED_MARGIN)
}

/// The library's fused rule, which the host applies to the maps a device sends.
pub use terrain_pyramid::fused_answer;

/// One layer's window, as plain data.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerSnapshot {
    /// The layer's index, 0 = finest.
    pub index: usize,
    /// The cell size exactly as the library uses it (Q16.16). A mirror gets it from the
    /// design with [`Resolution::from_m`], the library's own rounding.
    pub resolution: Resolution,
    /// The layer's range band `[d_k, d_{k+1}]`, metres.
    pub band_m: [f64; 2],
    /// The world cell index `(i, j)` of the window's lower-left cell.
    pub origin_cells: (i32, i32),
    /// The window, cells per side.
    pub cells_per_side: usize,
    /// Raw Q8.8 log-odds (`i16::MIN` = unknown), row-major, row 0 = the lowest y,
    /// `cells_per_side²` of them.
    pub cells: Vec<i16>,
}

impl LayerSnapshot {
    /// The cell size, metres.
    #[must_use]
    pub fn resolution_m(&self) -> f64 {
        f64::from(self.resolution.to_bits()) / 65_536.0
    }

    /// The lower-left corner of the window, metres: origin cell × resolution, as the library
    /// computes cell edges (Q16.16).
    #[must_use]
    pub fn origin_m(&self) -> (f64, f64) {
        let (i, j) = self.origin_cells;
        (
            self.resolution.cell_edge(i).to_num(),
            self.resolution.cell_edge(j).to_num(),
        )
    }

    /// The window's side, metres.
    #[must_use]
    pub fn extent_m(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let n = self.cells_per_side as f64;
        n * self.resolution_m()
    }

    /// The cell at window offset `(dx, dy)` from the lower-left corner, or `None` outside.
    #[must_use]
    pub fn at_offset(&self, dx: usize, dy: usize) -> Option<Cell> {
        if dx >= self.cells_per_side || dy >= self.cells_per_side {
            return None;
        }
        self.cells
            .get(dy * self.cells_per_side + dx)
            .map(|&raw| Cell::from_raw(raw))
    }

    /// The cell at world cell index `(i, j)`, or `None` outside the window.
    #[must_use]
    pub fn get(&self, i: i32, j: i32) -> Option<Cell> {
        let offset =
            |index: i32, origin: i32| usize::try_from(i64::from(index) - i64::from(origin)).ok();
        self.at_offset(
            offset(i, self.origin_cells.0)?,
            offset(j, self.origin_cells.1)?,
        )
    }

    /// Counts of observed, obstacle and free cells, as [`terrain_pyramid::Layer::counts`].
    #[must_use]
    pub fn counts(&self) -> LayerCounts {
        let mut counts = LayerCounts::default();
        for &raw in &self.cells {
            match Cell::from_raw(raw).class() {
                CellClass::Unknown => continue,
                CellClass::Obstacle => counts.obstacle += 1,
                CellClass::Navigable => counts.free += 1,
                CellClass::Undecided => {}
            }
            counts.observed += 1;
        }
        counts
    }

    /// The layer's map: one pixel per cell of its window.
    #[must_use]
    pub fn grey_map(&self) -> GreyMap {
        let n = self.cells_per_side;
        let pixels = (0..n * n)
            .map(|k| {
                self.at_offset(k % n, k / n)
                    .map_or(PGM_UNKNOWN, |c| pgm_value_of_cell(c.class()))
            })
            .collect();
        GreyMap {
            width: n,
            height: n,
            resolution: self.resolution,
            origin_m: self.origin_m(),
            pixels,
        }
    }
}

/// The maps of a pyramid at one moment, as plain data.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSnapshot {
    /// The layers, finest first; `layers[k].index == k`.
    pub layers: Vec<LayerSnapshot>,
    /// The sensor's horizontal position, metres (marked on the picture).
    pub sensor_xy: (f64, f64),
    /// The fused query's margin for "navigable" (Q8.8, ≥ 0), as the pyramid rounds it from
    /// [`Config::fused_margin`].
    pub fused_margin: LogOddsFixed,
}

/// The fused map over a grid: the fused query at the centre of each cell.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FusedMap {
    /// The lower-left corner of the grid, metres (Q16.16).
    pub origin: (Meters, Meters),
    /// The cell size (the finest layer's).
    pub step: Resolution,
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// `width · height` answers, row-major, row 0 = the lowest y.
    pub cells: Vec<Fused>,
}

impl FusedMap {
    /// Counts of the cells: observed (obstacle or navigable), obstacle, navigable.
    #[must_use]
    pub fn counts(&self) -> LayerCounts {
        let mut counts = LayerCounts::default();
        for cell in &self.cells {
            match cell {
                Fused::Unknown => continue,
                Fused::Obstacle { .. } => counts.obstacle += 1,
                Fused::Navigable { .. } => counts.free += 1,
            }
            counts.observed += 1;
        }
        counts
    }

    /// The answer at world point `(x, y)` metres, by the cell that contains it, or `None`
    /// outside the grid.
    #[cfg(test)]
    #[must_use]
    pub fn at(&self, x: f64, y: f64) -> Option<Fused> {
        let step = f64::from(self.step.to_bits()) / 65_536.0;
        let col = ((x - self.origin.0.to_num::<f64>()) / step).floor();
        let row = ((y - self.origin.1.to_num::<f64>()) / step).floor();
        #[allow(clippy::cast_precision_loss)]
        let inside =
            col >= 0.0 && row >= 0.0 && col < self.width as f64 && row < self.height as f64;
        if !inside {
            return None;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (col, row) = (col as usize, row as usize);
        self.cells.get(row * self.width + col).copied()
    }

    /// The map as a PGM raster.
    #[must_use]
    pub fn grey_map(&self) -> GreyMap {
        GreyMap {
            width: self.width,
            height: self.height,
            resolution: self.step,
            origin_m: (self.origin.0.to_num(), self.origin.1.to_num()),
            pixels: self.cells.iter().map(|&f| pgm_value_of_fused(f)).collect(),
        }
    }
}

impl MapSnapshot {
    /// The maps of a library pyramid. `design` gives the bands (the pyramid keeps only the
    /// gate tables), `config` the fused margin the pyramid was configured with.
    #[must_use]
    pub fn from_pyramid<const W: usize, const L: usize>(
        pyramid: &Pyramid<W, L>,
        design: &Design<L>,
        config: &Config,
        sensor_xy: (f64, f64),
    ) -> Self {
        let layers = (0..pyramid.layer_count())
            .filter_map(|k| {
                let layer = pyramid.layer(k)?;
                let band_m = design.layers().get(k).map_or([0.0; 2], |l| {
                    [f64::from(l.band_inner_m), f64::from(l.band_outer_m)]
                });
                let cells = (0..W * W)
                    .map(|n| {
                        layer
                            .at_offset(n % W, n / W)
                            .unwrap_or(Cell::UNKNOWN)
                            .to_raw()
                    })
                    .collect();
                Some(LayerSnapshot {
                    index: k,
                    resolution: layer.resolution(),
                    band_m,
                    origin_cells: layer.origin(),
                    cells_per_side: W,
                    cells,
                })
            })
            .collect();
        Self {
            layers,
            sensor_xy,
            fused_margin: round_to_log_odds(config.fused_margin),
        }
    }

    /// The maps of the host's [`Mirror`] of the device's pyramid (`pyramid listen`): the
    /// windows, cells and cell sizes as the device last sent them, the bands from its Hello
    /// (zeros when the device did not know its design), and the fused `margin`, which the
    /// device does not send (0 unless the host knows it). `None` before the first Hello, or
    /// when a layer's cell size is not one the library can hold.
    #[must_use]
    pub fn from_mirror(
        mirror: &Mirror,
        margin: LogOddsFixed,
        sensor_xy: (f64, f64),
    ) -> Option<Self> {
        let w = mirror.cells_per_side();
        mirror.firmware()?;
        let layers = (0..mirror.layer_count())
            .map(|k| {
                let layer = mirror.layer(k)?;
                let bits = layer.resolution_q16;
                // The library's own rounding gives back the exact raw value for every cell
                // size up to 128 m; refuse anything else rather than export a wrong one.
                #[allow(clippy::cast_precision_loss)]
                let resolution =
                    Resolution::from_m(bits as f32 / 65_536.0).filter(|r| r.to_bits() == bits)?;
                Some(LayerSnapshot {
                    index: k,
                    resolution,
                    band_m: [f64::from(layer.band_m.0), f64::from(layer.band_m.1)],
                    origin_cells: layer.origin,
                    cells_per_side: w,
                    cells: layer.cells().to_vec(),
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Self {
            layers,
            sensor_xy,
            fused_margin: margin,
        })
    }

    /// The fused answer at world point `(x, y)`: the library's rule
    /// ([`Pyramid::fused`]) applied to the snapshot's layers.
    // Single queries are for the later commands (and the tests); the export uses the region.
    #[cfg_attr(not(test), allow(dead_code))]
    #[must_use]
    pub fn fused(&self, x: Meters, y: Meters) -> Fused {
        self.first_answer(|_, layer| {
            let r = layer.resolution.to_bits();
            layer.get(cell_of(x.to_bits(), r), cell_of(y.to_bits(), r))
        })
    }

    /// The fused rule ([`fused_answer`]) over each layer's cell at a point
    /// (`cell_of_layer(k, layer)`, `None` outside its window).
    fn first_answer(
        &self,
        mut cell_of_layer: impl FnMut(usize, &LayerSnapshot) -> Option<Cell>,
    ) -> Fused {
        fused_answer(
            self.fused_margin.to_bits(),
            self.layers
                .iter()
                .enumerate()
                .map(|(k, layer)| cell_of_layer(k, layer)),
        )
    }

    /// Samples [`Self::fused`] over `width × height` cells of size `step` from the lower-left
    /// corner `(x0, y0)`, at the cell centres, row 0 (lowest y) first: the same points, in
    /// the same fixed-point arithmetic, as [`Pyramid::fused_region`].
    #[must_use]
    pub fn fused_region(
        &self,
        x0: Meters,
        y0: Meters,
        step: Meters,
        width: usize,
        height: usize,
    ) -> Vec<Fused> {
        // The sample coordinates: the same for every row (columns) and every column (rows).
        let samples = |start: Meters, n: usize| -> Vec<Meters> {
            let mut v = start.saturating_add(step / 2);
            (0..n)
                .map(|_| {
                    let here = v;
                    v = v.saturating_add(step);
                    here
                })
                .collect()
        };
        let (xs, ys) = (samples(x0, width), samples(y0, height));
        // Per layer, the window offset of each column's and each row's cell (`None` outside):
        // the per-point rule of `fused`, with its divisions hoisted out of the loop.
        let offsets =
            |layer: &LayerSnapshot, coords: &[Meters], origin: i32| -> Vec<Option<usize>> {
                let r = layer.resolution.to_bits();
                coords
                    .iter()
                    .map(|c| {
                        let offset = i64::from(cell_of(c.to_bits(), r)) - i64::from(origin);
                        usize::try_from(offset)
                            .ok()
                            .filter(|&o| o < layer.cells_per_side)
                    })
                    .collect()
            };
        let columns: Vec<Vec<Option<usize>>> = self
            .layers
            .iter()
            .map(|l| offsets(l, &xs, l.origin_cells.0))
            .collect();
        let rows: Vec<Vec<Option<usize>>> = self
            .layers
            .iter()
            .map(|l| offsets(l, &ys, l.origin_cells.1))
            .collect();
        let mut out = Vec::with_capacity(width.saturating_mul(height));
        for j in 0..height {
            for i in 0..width {
                out.push(self.first_answer(|k, layer| {
                    let dx = columns.get(k).and_then(|c| c.get(i).copied().flatten());
                    let dy = rows.get(k).and_then(|r| r.get(j).copied().flatten());
                    layer.at_offset(dx?, dy?)
                }));
            }
        }
        out
    }

    /// The fused map at the finest layer's resolution over the coarsest layer's window (the
    /// grid's side rounded up to whole fine cells); `None` without layers.
    #[must_use]
    pub fn fused_map(&self) -> Option<FusedMap> {
        let (finest, coarsest) = (self.layers.first()?, self.layers.last()?);
        let step = finest.resolution;
        let (ox, oy) = coarsest.origin_cells;
        let origin = (
            coarsest.resolution.cell_edge(ox),
            coarsest.resolution.cell_edge(oy),
        );
        let extent = i64::try_from(coarsest.cells_per_side)
            .unwrap_or(i64::MAX)
            .saturating_mul(i64::from(coarsest.resolution.to_bits()));
        let fine = i64::from(step.to_bits()).max(1);
        let cells = usize::try_from((extent + fine - 1) / fine).unwrap_or(0);
        let values = self.fused_region(origin.0, origin.1, step.meters(), cells, cells);
        Some(FusedMap {
            origin,
            step,
            width: cells,
            height: cells,
            cells: values,
        })
    }

    /// The numbers of the maps: per-layer and fused counts.
    #[must_use]
    pub fn summary(&self, fused: Option<&FusedMap>) -> MapSummary {
        let layers = self
            .layers
            .iter()
            .map(|l| {
                let c = l.counts();
                let (x, y) = l.origin_m();
                LayerSummary {
                    index: l.index,
                    resolution_m: round_m(l.resolution_m()),
                    observed_cells: c.observed,
                    obstacle_cells: c.obstacle,
                    free_cells: c.free,
                    band_m: [round_m(l.band_m[0]), round_m(l.band_m[1])],
                    cells_per_side: l.cells_per_side,
                    origin_m: [round_m(x), round_m(y)],
                }
            })
            .collect();
        let fused = fused.map_or_else(FusedSummary::default, |f| {
            let c = f.counts();
            FusedSummary {
                observed_cells: c.observed,
                obstacle_cells: c.obstacle,
                free_cells: c.free,
                resolution_m: round_m(f64::from(f.step.to_bits()) / 65_536.0),
                width: f.width,
                height: f.height,
                origin_m: [round_m(f.origin.0.to_num()), round_m(f.origin.1.to_num())],
            }
        });
        MapSummary { layers, fused }
    }
}

/// A length for a summary: rounded to 0.1 mm (the files carry the exact values).
fn round_m(value: f64) -> f64 {
    (value * 1e4).round() / 1e4
}

/// One layer in a summary.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct LayerSummary {
    /// The layer's index, 0 = finest.
    pub index: usize,
    /// The cell size, metres (rounded to 0.1 mm).
    pub resolution_m: f64,
    /// Observed cells of the window, including undecided ones (L = 0).
    pub observed_cells: u32,
    /// Observed cells with L > 0.
    pub obstacle_cells: u32,
    /// Observed cells with L < 0.
    pub free_cells: u32,
    /// The range band, metres.
    pub band_m: [f64; 2],
    /// The window, cells per side.
    pub cells_per_side: usize,
    /// The window's lower-left corner, metres.
    pub origin_m: [f64; 2],
}

/// The fused map in a summary.
#[derive(Serialize, Debug, Clone, PartialEq, Default)]
pub struct FusedSummary {
    /// Cells that are obstacle or navigable.
    pub observed_cells: u32,
    /// Obstacle cells.
    pub obstacle_cells: u32,
    /// Navigable cells.
    pub free_cells: u32,
    /// The cell size, metres (rounded to 0.1 mm).
    pub resolution_m: f64,
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// The grid's lower-left corner, metres.
    pub origin_m: [f64; 2],
}

/// The numbers of a snapshot's maps.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct MapSummary {
    /// Per layer, finest first.
    pub layers: Vec<LayerSummary>,
    /// The fused map.
    pub fused: FusedSummary,
}

/// The PGM value of a layer cell's class.
#[must_use]
pub const fn pgm_value_of_cell(class: CellClass) -> u8 {
    match class {
        CellClass::Obstacle => PGM_OBSTACLE,
        CellClass::Navigable => PGM_FREE,
        CellClass::Unknown | CellClass::Undecided => PGM_UNKNOWN,
    }
}

/// The PGM value of a fused answer.
#[must_use]
pub const fn pgm_value_of_fused(fused: Fused) -> u8 {
    match fused {
        Fused::Obstacle { .. } => PGM_OBSTACLE,
        Fused::Navigable { .. } => PGM_FREE,
        Fused::Unknown => PGM_UNKNOWN,
    }
}

/// A trinary occupancy raster in the `map_server` convention.
#[derive(Debug, Clone, PartialEq)]
pub struct GreyMap {
    /// Columns (x).
    pub width: usize,
    /// Rows (y).
    pub height: usize,
    /// The cell size.
    pub resolution: Resolution,
    /// The lower-left corner of the lower-left cell, metres.
    pub origin_m: (f64, f64),
    /// `width · height` values, row-major, row 0 = the LOWEST y (flipped when written).
    pub pixels: Vec<u8>,
}

impl GreyMap {
    /// The binary PGM (`P5`, maxval 255): the first row written is the top (largest y).
    #[must_use]
    pub fn pgm_bytes(&self) -> Vec<u8> {
        let header = format!("P5\n{} {}\n255\n", self.width, self.height);
        let mut out = Vec::with_capacity(header.len() + self.pixels.len());
        out.extend_from_slice(header.as_bytes());
        if self.width > 0 {
            for row in self.pixels.chunks(self.width).rev() {
                out.extend_from_slice(row);
            }
        }
        out
    }

    /// The `map_server` YAML that describes this map, stored as `image`.
    #[must_use]
    pub fn yaml(&self, image: &str) -> String {
        let mut s = String::new();
        let resolution = f64::from(self.resolution.to_bits()) / 65_536.0;
        // Writing to a String cannot fail.
        let _ = writeln!(s, "image: {image}");
        let _ = writeln!(s, "mode: trinary");
        let _ = writeln!(s, "resolution: {}", yaml_float(resolution));
        let _ = writeln!(
            s,
            "origin: [{}, {}, 0.0]",
            yaml_float(self.origin_m.0),
            yaml_float(self.origin_m.1)
        );
        let _ = writeln!(s, "negate: 0");
        let _ = writeln!(s, "occupied_thresh: 0.65");
        let _ = writeln!(s, "free_thresh: 0.196");
        s
    }

    /// Writes `STEM.pgm` and `STEM.yaml` into `dir`; returns the two paths.
    ///
    /// # Errors
    /// A file could not be written; the message names it.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<[PathBuf; 2], String> {
        let image = format!("{stem}.pgm");
        let pgm = dir.join(&image);
        let yaml = dir.join(format!("{stem}.yaml"));
        write_file(&pgm, &self.pgm_bytes())?;
        write_file(&yaml, self.yaml(&image).as_bytes())?;
        Ok([pgm, yaml])
    }
}

/// A float as YAML reads it back as a float: the shortest exact text, with a decimal point.
fn yaml_float(value: f64) -> String {
    let value = if value == 0.0 { 0.0 } else { value };
    let s = format!("{value}");
    if s.contains(['.', 'e', 'E', 'n', 'N']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// Writes `bytes` to `path`, naming the file in the error.
///
/// # Errors
/// The file could not be written.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// What [`write_maps`] wrote.
#[derive(Debug, Clone)]
pub struct Written {
    /// The numbers of the maps.
    pub summary: MapSummary,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// Writes every map of `snapshot` into `dir` (created if missing): `layer-K.pgm/.yaml` for
/// each layer, `fused.pgm/.yaml`, and the picture [`PICTURE_FILE`] titled `title`.
///
/// # Errors
/// The directory or a file could not be written, or the picture could not be drawn.
pub fn write_maps(dir: &Path, snapshot: &MapSnapshot, title: &str) -> Result<Written, String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("cannot create the output directory {}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for layer in &snapshot.layers {
        files.extend(
            layer
                .grey_map()
                .write(dir, &format!("layer-{}", layer.index))?,
        );
    }
    let fused = snapshot.fused_map();
    if let Some(f) = &fused {
        files.extend(f.grey_map().write(dir, "fused")?);
    }
    let picture = dir.join(PICTURE_FILE);
    picture::draw(&picture, snapshot, fused.as_ref(), title)
        .map_err(|e| format!("cannot draw {}: {e}", picture.display()))?;
    files.push(picture);
    Ok(Written {
        summary: snapshot.summary(fused.as_ref()),
        files,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::{
        Clamp, DefaultDesign, DefaultPyramid, Evidence, EvidenceClass, GateShape, Schedule,
        SensorModel, DEFAULT_CELLS_PER_SIDE,
    };

    /// A small deterministic generator (SplitMix64), so that the test needs no crate.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn configured(gate: GateShape, config: &Config) -> (DefaultPyramid, DefaultDesign) {
        let schedule = Schedule {
            gate,
            ..Schedule::default()
        };
        let design =
            DefaultDesign::new(SensorModel::default(), schedule, DEFAULT_CELLS_PER_SIDE).unwrap();
        let mut p = DefaultPyramid::new();
        p.configure(&design, config).unwrap();
        (p, design)
    }

    /// Random records in and around every layer's window, with the windows moved between
    /// batches (so that the circular buffers wrap).
    fn scramble(p: &mut DefaultPyramid, rng: &mut Rng) -> (f64, f64) {
        let mut robot = (0.0, 0.0);
        for _ in 0..6 {
            robot = (rng.range(-7.0, 7.0), rng.range(-7.0, 7.0));
            p.recentre(Meters::from_num(robot.0), Meters::from_num(robot.1));
            for _ in 0..3000 {
                let k = rng.below(p.layer_count() as u64) as usize;
                let r = p.layer(k).unwrap().resolution().meters().to_num::<f64>();
                let reach = 40.0 * r;
                let (x, y) = (
                    robot.0 + rng.range(-reach, reach),
                    robot.1 + rng.range(-reach, reach),
                );
                let res = p.layer(k).unwrap().resolution();
                let class = if rng.below(3) == 0 {
                    EvidenceClass::Obstacle
                } else {
                    EvidenceClass::Navigable
                };
                p.apply(&Evidence {
                    layer: k as u8,
                    cell_x: res.cell_of(Meters::from_num(x)),
                    cell_y: res.cell_of(Meters::from_num(y)),
                    class,
                    weight: terrain_pyramid::Weight::from_num(rng.range(0.0, 1.0)),
                });
            }
        }
        robot
    }

    #[test]
    fn the_snapshots_fused_map_equals_the_librarys_fused_region() {
        let mut rng = Rng(0x5EED);
        for (gate, clamp, margin) in [
            (GateShape::default(), Clamp::OCTOMAP, 0.0),
            (GateShape::Hard, Clamp::Off, 0.0),
            (GateShape::default(), Clamp::Off, 0.7),
        ] {
            let config = Config {
                clamp,
                fused_margin: margin,
                ..Config::default()
            };
            let (mut p, design) = configured(gate, &config);
            let robot = scramble(&mut p, &mut rng);
            let snap = MapSnapshot::from_pyramid(&p, &design, &config, robot);
            assert_eq!(snap.layers.len(), p.layer_count());
            for (k, l) in snap.layers.iter().enumerate() {
                assert_eq!(l.counts(), p.counts(k).unwrap(), "layer {k}");
                assert_eq!(l.origin_cells, p.layer(k).unwrap().origin());
            }
            // Single queries, anywhere.
            for _ in 0..20_000 {
                let (x, y) = (
                    Meters::from_num(robot.0 + rng.range(-60.0, 60.0)),
                    Meters::from_num(robot.1 + rng.range(-60.0, 60.0)),
                );
                assert_eq!(snap.fused(x, y), p.fused(x, y));
            }
            // The exported fused map, against the library over the same grid (once: 896² cells
            // in a debug build).
            if margin == 0.0 && clamp == Clamp::OCTOMAP {
                let f = snap.fused_map().unwrap();
                let mut expected = vec![Fused::Unknown; f.width * f.height];
                p.fused_region(
                    f.origin.0,
                    f.origin.1,
                    f.step.meters(),
                    f.width,
                    f.height,
                    &mut expected,
                )
                .unwrap();
                assert_eq!(f.cells, expected);
                assert!(f.counts().obstacle > 0 && f.counts().free > 0);
            }
            // An odd grid, off the cell edges, reaching beyond every window.
            let (x0, y0, step) = (
                Meters::from_num(robot.0 - 50.3),
                Meters::from_num(robot.1 - 47.9),
                Meters::from_num(0.731),
            );
            let (w, h) = (140, 131);
            let mut expected = vec![Fused::Unknown; w * h];
            p.fused_region(x0, y0, step, w, h, &mut expected).unwrap();
            assert_eq!(snap.fused_region(x0, y0, step, w, h), expected);
            if margin > 0.0 {
                // The margin matters: weakly free cells defer to coarser layers.
                let zero = MapSnapshot {
                    fused_margin: LogOddsFixed::ZERO,
                    ..snap.clone()
                };
                assert_ne!(zero.fused_region(x0, y0, step, w, h), expected);
            }
        }
    }

    #[test]
    fn a_synced_mirror_exports_exactly_the_devices_maps() {
        use crate::link::HostLink;
        use terrain_pyramid::link::{Link, LinkConfig, SensorCounters};
        let config = Config::default();
        let design = crate::design::firmware_design().unwrap();
        let mut p = Box::new(DefaultPyramid::new());
        let mut link: Box<Link> = Box::new(Link::new(LinkConfig::DEFAULT));
        let mut host = HostLink::new();
        // Before any Hello the mirror has no maps.
        assert_eq!(
            MapSnapshot::from_mirror(host.mirror(), LogOddsFixed::ZERO, (0.0, 0.0)),
            None
        );
        p.configure(&design, &config).unwrap();
        link.adopt(&design);
        let robot = scramble(&mut p, &mut Rng(0xFEED));
        let mut uart = vec![0_u8; 4096];
        let mut now_ms = 0_u32;
        for _ in 0..100_000 {
            now_ms += 10;
            link.poll(now_ms, &mut *p, &SensorCounters::default());
            let n = link.pop_bytes(&mut uart);
            host.feed(&uart[..n]);
            let quiet = link.queue().is_empty()
                && (0..p.layer_count()).all(|k| p.layer(k).unwrap().dirty() == 0);
            if quiet {
                break;
            }
        }
        assert!(host.mirror().is_synced());
        let mirrored =
            MapSnapshot::from_mirror(host.mirror(), round_to_log_odds(config.fused_margin), robot)
                .unwrap();
        let direct = MapSnapshot::from_pyramid(&p, &design, &config, robot);
        // Cells, windows, cell sizes and bands (from the Hello) all equal the library's.
        assert_eq!(mirrored, direct);
        assert!(mirrored.layers.iter().any(|l| l.counts().obstacle > 0));
        assert!(mirrored.layers.iter().all(|l| l.band_m[1] > l.band_m[0]));
        // The fused margin is the host's to give: the device does not send it.
        let margin = round_to_log_odds(0.5);
        let with = MapSnapshot::from_mirror(host.mirror(), margin, robot).unwrap();
        assert_eq!(with.fused_margin, margin);
    }

    fn layer(cells: Vec<i16>, n: usize) -> LayerSnapshot {
        LayerSnapshot {
            index: 0,
            resolution: Resolution::from_m(0.5).unwrap(),
            band_m: [0.0, 1.0],
            origin_cells: (-1, 2),
            cells_per_side: n,
            cells,
        }
    }

    #[test]
    fn pgm_rows_are_written_top_first() {
        // 2 × 2, row 0 (lowest y): obstacle, free; row 1: unknown, undecided.
        let l = layer(vec![300, -300, i16::MIN, 0], 2);
        let g = l.grey_map();
        assert_eq!(g.pixels, vec![0, 254, 205, 205]);
        let bytes = g.pgm_bytes();
        let header = b"P5\n2 2\n255\n";
        assert_eq!(&bytes[..header.len()], header);
        // The top row (largest y) first.
        assert_eq!(&bytes[header.len()..], &[205, 205, 0, 254]);
        // Non-square, to pin width and height.
        let g = GreyMap {
            width: 3,
            height: 2,
            resolution: Resolution::from_m(0.1).unwrap(),
            origin_m: (0.0, 0.0),
            pixels: vec![1, 2, 3, 4, 5, 6],
        };
        assert_eq!(g.pgm_bytes(), b"P5\n3 2\n255\n\x04\x05\x06\x01\x02\x03");
    }

    #[test]
    fn yaml_has_the_map_server_fields() {
        let g = layer(vec![i16::MIN; 4], 2).grey_map();
        let y = g.yaml("layer-0.pgm");
        assert_eq!(
            y,
            "image: layer-0.pgm\nmode: trinary\nresolution: 0.5\norigin: [-0.5, 1.0, 0.0]\n\
             negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
        );
        // The exact fixed-point cell size: round(0.1 · 2¹⁶) / 2¹⁶.
        let g = GreyMap {
            resolution: Resolution::from_m(0.1).unwrap(),
            ..g
        };
        assert!(g.yaml("x.pgm").contains("resolution: 0.100006103515625\n"));
        assert_eq!(yaml_float(-0.0), "0.0");
        assert_eq!(yaml_float(-3.0), "-3.0");
    }

    #[test]
    fn layer_origin_is_the_window_origin_times_the_resolution() {
        let l = layer(vec![i16::MIN; 16], 4);
        assert_eq!(l.origin_m(), (-0.5, 1.0));
        assert_eq!(l.extent_m(), 2.0);
        assert_eq!(l.get(-1, 2), l.at_offset(0, 0));
        assert_eq!(l.get(-2, 2), None);
        assert_eq!(l.get(3, 2), None);
        assert!(l.get(2, 5).is_some());
    }

    #[test]
    fn fused_map_lookup_by_position() {
        let f = FusedMap {
            origin: (Meters::from_num(-1), Meters::from_num(-1)),
            step: Resolution::from_m(1.0).unwrap(),
            width: 2,
            height: 2,
            cells: vec![
                Fused::Unknown,
                Fused::Obstacle { layer: 0 },
                Fused::Navigable { layer: 1 },
                Fused::Unknown,
            ],
        };
        assert_eq!(f.at(0.5, -0.5), Some(Fused::Obstacle { layer: 0 }));
        assert_eq!(f.at(-0.5, 0.5), Some(Fused::Navigable { layer: 1 }));
        assert_eq!(f.at(1.5, 0.0), None);
        let c = f.counts();
        assert_eq!((c.observed, c.obstacle, c.free), (2, 1, 1));
        // Row 0 is the lowest y; the PGM's first row is the top.
        assert_eq!(f.grey_map().pgm_bytes()[11..], [254, 205, 205, 0]);
    }
}
