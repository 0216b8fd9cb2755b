//! The picture of a [`MapSnapshot`] for people (`maps.png`):
//! - the fused map over the observed area (the smallest square around every observed fused
//!   cell and the sensor, plus a margin), with axes in metres and the layers' windows that
//!   fit in it outlined; the whole export is mostly unknown (a 64-cell window of the coarsest
//!   layer spans well over 100 m), so it is named in the caption, not drawn;
//! - beside it, every layer over that same area, each panel the same size, so that the
//!   layers compare place for place: a coarse layer shows as big blocks, the part of the
//!   region outside a layer's window is white. A caption per layer gives its index, cell size,
//!   band, window and counts.
//!
//! A legend explains the colours and the sensor's mark. Maps are rasterised here (nearest
//! neighbour when a panel has more pixels than cells; when it has fewer, a pixel shows the
//! "worst" of the cells it covers, obstacle over navigable over unknown, so that a thin
//! obstacle never vanishes) and blitted; plotters draws the text, axes and marks, with the
//! embedded DejaVu Sans (no system font needed).
use super::{FusedMap, LayerSnapshot, MapSnapshot};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use terrain_pyramid::{CellClass, Fused};

/// The font family; the embedded font is registered under this name.
const FONT: &str = "sans-serif";

/// Obstacle: dark red.
pub const OBSTACLE_RGB: RGBColor = RGBColor(150, 24, 32);
/// Navigable: light green.
pub const FREE_RGB: RGBColor = RGBColor(168, 219, 158);
/// Unknown (or undecided): grey.
pub const UNKNOWN_RGB: RGBColor = RGBColor(200, 200, 200);
/// Outside a layer's window: white.
pub const OUTSIDE_RGB: RGBColor = RGBColor(255, 255, 255);
/// The sensor's mark: blue.
const SENSOR_RGB: RGBColor = RGBColor(32, 96, 230);
/// The outlines of the layers' windows.
const WINDOW_RGB: RGBColor = RGBColor(40, 40, 90);

/// The outer margin, pixels.
const MARGIN: i32 = 24;
/// The side of the fused map's plotting area, pixels.
const BIG: i32 = 800;
/// The space for the y axis labels and the x axis labels of a big panel.
const Y_LABELS: i32 = 70;
const X_LABELS: i32 = 44;
/// The space right of the fused map's plotting area, and between it and the layers.
const BIG_RIGHT: i32 = 16;
const BIG_GAP: i32 = 40;
/// The side of each layer panel, pixels.
const LAYER_PANEL: i32 = 208;
/// Layer panels per row, beside the fused map.
const LAYERS_PER_ROW: usize = 4;
/// The space between layer panels, and the caption height below each.
const LAYER_GAP: i32 = 24;
const LAYER_CAPTION: i32 = 70;
/// The title band and the legend band heights.
const TITLE_H: i32 = 44;
const LEGEND_H: i32 = 40;
/// The caption above a panel.
const PANEL_TITLE_H: i32 = 30;

/// What a pixel shows, in the order a pixel that covers several cells picks the maximum of:
/// outside the map < unknown < navigable < obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Paint {
    Outside,
    Unknown,
    Free,
    Obstacle,
}

impl Paint {
    const fn of_fused(f: Fused) -> Self {
        match f {
            Fused::Unknown => Self::Unknown,
            Fused::Navigable { .. } => Self::Free,
            Fused::Obstacle { .. } => Self::Obstacle,
        }
    }

    const fn of_cell(c: CellClass) -> Self {
        match c {
            CellClass::Unknown | CellClass::Undecided => Self::Unknown,
            CellClass::Navigable => Self::Free,
            CellClass::Obstacle => Self::Obstacle,
        }
    }

    const fn rgb(self) -> RGBColor {
        match self {
            Self::Outside => OUTSIDE_RGB,
            Self::Unknown => UNKNOWN_RGB,
            Self::Free => FREE_RGB,
            Self::Obstacle => OBSTACLE_RGB,
        }
    }
}

/// Any drawing error, as text.
fn text<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

fn px(v: usize) -> i32 {
    i32::try_from(v).unwrap_or(i32::MAX)
}

fn upx(v: i32) -> u32 {
    u32::try_from(v.max(0)).unwrap_or(0)
}

/// A square of the world, metres: lower-left corner and side.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Square {
    x0: f64,
    y0: f64,
    side: f64,
}

impl Square {
    fn x1(self) -> f64 {
        self.x0 + self.side
    }

    fn y1(self) -> f64 {
        self.y0 + self.side
    }

    fn contains(self, (x, y): (f64, f64)) -> bool {
        (self.x0..self.x1()).contains(&x) && (self.y0..self.y1()).contains(&y)
    }
}

/// A grid of cells in the world: lower-left corner, cell size, columns × rows, and what a
/// cell shows (`paint(col, row)`, row 0 = lowest y).
struct Grid<F: Fn(usize, usize) -> Paint> {
    x0: f64,
    y0: f64,
    cell: f64,
    cols: usize,
    rows: usize,
    paint: F,
}

impl<F: Fn(usize, usize) -> Paint> Grid<F> {
    /// The cells along one axis that the world interval `[a, b)` covers, clipped to `n`;
    /// when the interval is smaller than a cell, only the cell under its middle.
    fn span(a: f64, b: f64, origin: f64, cell: f64, n: usize) -> (usize, usize) {
        let to_index = |v: f64| -> i64 {
            // Grid sizes are far below 2⁵³.
            #[allow(clippy::cast_possible_truncation)]
            let i = v.floor() as i64;
            i
        };
        let (lo, hi) = if b - a <= cell {
            let c = to_index((0.5 * (a + b) - origin) / cell);
            (c, c + 1)
        } else {
            let lo = to_index((a - origin) / cell + 1e-9);
            let hi = to_index((b - origin) / cell - 1e-9) + 1;
            (lo, hi.max(lo + 1))
        };
        let n = i64::try_from(n).unwrap_or(i64::MAX);
        let clip = |v: i64| usize::try_from(v.clamp(0, n)).unwrap_or(0);
        (clip(lo), clip(hi))
    }

    /// Rasterises the world square `view` into `w × h` RGB pixels, the top row first.
    fn raster(&self, view: Square, w: usize, h: usize) -> Vec<u8> {
        #[allow(clippy::cast_precision_loss)]
        let (dx, dy) = (view.side / w as f64, view.side / h as f64);
        #[allow(clippy::cast_precision_loss)]
        let cols: Vec<(usize, usize)> = (0..w)
            .map(|p| {
                let a = view.x0 + p as f64 * dx;
                Self::span(a, a + dx, self.x0, self.cell, self.cols)
            })
            .collect();
        let mut buf = Vec::with_capacity(w * h * 3);
        for p in 0..h {
            // Pixel row p counts from the top.
            #[allow(clippy::cast_precision_loss)]
            let b = view.y1() - p as f64 * dy;
            let (r0, r1) = Self::span(b - dy, b, self.y0, self.cell, self.rows);
            for &(c0, c1) in &cols {
                let mut best = Paint::Outside;
                'cells: for r in r0..r1 {
                    for c in c0..c1 {
                        best = best.max((self.paint)(c, r));
                        if best == Paint::Obstacle {
                            break 'cells;
                        }
                    }
                }
                let RGBColor(red, green, blue) = best.rgb();
                buf.extend_from_slice(&[red, green, blue]);
            }
        }
        buf
    }
}

fn fused_grid(f: &FusedMap) -> Grid<impl Fn(usize, usize) -> Paint + '_> {
    Grid {
        x0: f.origin.0.to_num(),
        y0: f.origin.1.to_num(),
        cell: step_m(f),
        cols: f.width,
        rows: f.height,
        paint: move |c, r| {
            f.cells
                .get(r * f.width + c)
                .map_or(Paint::Outside, |&v| Paint::of_fused(v))
        },
    }
}

fn layer_grid(l: &LayerSnapshot) -> Grid<impl Fn(usize, usize) -> Paint + '_> {
    let (x0, y0) = l.origin_m();
    Grid {
        x0,
        y0,
        cell: l.resolution_m(),
        cols: l.cells_per_side,
        rows: l.cells_per_side,
        paint: move |c, r| {
            l.at_offset(c, r)
                .map_or(Paint::Outside, |cell| Paint::of_cell(cell.class()))
        },
    }
}

/// Draws the picture of `snapshot` (and its fused map) into the PNG file `path`.
///
/// # Errors
/// The font or the file could not be used; the message says why.
pub fn draw(
    path: &Path,
    snapshot: &MapSnapshot,
    fused: Option<&FusedMap>,
    title: &str,
) -> Result<(), String> {
    register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())?;
    let n_layers = snapshot.layers.len();
    let rows = n_layers.div_ceil(LAYERS_PER_ROW).max(1);
    let per_row = n_layers.clamp(1, LAYERS_PER_ROW);
    let big_w = Y_LABELS + BIG + BIG_RIGHT;
    let big_h = PANEL_TITLE_H + 8 + BIG + X_LABELS;
    let layers_w = px(per_row) * (LAYER_PANEL + LAYER_GAP) - LAYER_GAP;
    let layers_h = PANEL_TITLE_H + px(rows) * (PANEL_TITLE_H + LAYER_PANEL + LAYER_CAPTION);
    let width = 2 * MARGIN + big_w + BIG_GAP + layers_w;
    let height = 2 * MARGIN + TITLE_H + LEGEND_H + big_h.max(layers_h);

    let root = BitMapBackend::new(path, (upx(width), upx(height))).into_drawing_area();
    root.fill(&WHITE).map_err(text)?;
    let title_style = TextStyle::from((FONT, 28).into_font()).color(&BLACK);
    root.draw_text(title, &title_style, (MARGIN, MARGIN))
        .map_err(text)?;
    legend(&root, MARGIN, MARGIN + TITLE_H)?;

    let region = observed_region(snapshot, fused);
    let top = MARGIN + TITLE_H + LEGEND_H;
    if let Some(f) = fused {
        #[allow(clippy::cast_precision_loss)]
        let export_side = f.width.min(f.height) as f64 * step_m(f);
        let caption = format!(
            "Fused map, the observed area ({:.1} m square of the {:.1} m export, {} m cells)",
            region.side,
            export_side,
            num(step_m(f))
        );
        big_panel(&root, (MARGIN, top), snapshot, f, region, &caption)?;
    }

    let x_layers = MARGIN + big_w + BIG_GAP;
    let caption_style = TextStyle::from((FONT, 20).into_font()).color(&BLACK);
    root.draw_text(
        "Each layer over the same area (white: outside the layer's window)",
        &caption_style,
        (x_layers, top),
    )
    .map_err(text)?;
    let y = top + PANEL_TITLE_H;
    for (n, layer) in snapshot.layers.iter().enumerate() {
        let x = x_layers + px(n % LAYERS_PER_ROW) * (LAYER_PANEL + LAYER_GAP);
        let y = y + px(n / LAYERS_PER_ROW) * (PANEL_TITLE_H + LAYER_PANEL + LAYER_CAPTION);
        layer_panel(&root, (x, y), layer, region, snapshot.sensor_xy)?;
    }
    root.present().map_err(text)?;
    Ok(())
}

/// A number as a person writes it: at most 3 decimals, no trailing zeros.
fn num(value: f64) -> String {
    let s = format!("{value:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

fn step_m(f: &FusedMap) -> f64 {
    f64::from(f.step.to_bits()) / 65_536.0
}

/// The smallest square around every observed fused cell and the sensor, padded by 5 % (at
/// least one coarsest cell); without observations, the sensor's maximum range around it.
fn observed_region(snapshot: &MapSnapshot, fused: Option<&FusedMap>) -> Square {
    let (sx, sy) = snapshot.sensor_xy;
    let (mut x0, mut y0, mut x1, mut y1) = (sx, sy, sx, sy);
    let mut any = false;
    if let Some(f) = fused {
        let s = step_m(f);
        let (ox, oy): (f64, f64) = (f.origin.0.to_num(), f.origin.1.to_num());
        for (k, cell) in f.cells.iter().enumerate() {
            if *cell == Fused::Unknown {
                continue;
            }
            any = true;
            #[allow(clippy::cast_precision_loss)]
            let (c, r) = ((k % f.width) as f64, (k / f.width) as f64);
            x0 = x0.min(ox + c * s);
            y0 = y0.min(oy + r * s);
            x1 = x1.max(ox + (c + 1.0) * s);
            y1 = y1.max(oy + (r + 1.0) * s);
        }
    }
    let coarsest = snapshot
        .layers
        .last()
        .map_or(1.0, LayerSnapshot::resolution_m);
    if !any {
        let reach = snapshot.layers.last().map_or(1.0, |l| l.band_m[1]).max(1.0);
        return Square {
            x0: sx - reach,
            y0: sy - reach,
            side: 2.0 * reach,
        };
    }
    let side = (x1 - x0).max(y1 - y0);
    let pad = (0.05 * side).max(coarsest);
    let side = side + 2.0 * pad;
    Square {
        x0: 0.5 * (x0 + x1) - 0.5 * side,
        y0: 0.5 * (y0 + y1) - 0.5 * side,
        side,
    }
}

/// A colour swatch with a border.
fn swatch<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    colour: RGBColor,
) -> Result<(), String> {
    root.draw(&Rectangle::new(
        [(x, y - 9), (x + 28, y + 9)],
        colour.filled(),
    ))
    .map_err(text)?;
    root.draw(&Rectangle::new(
        [(x, y - 9), (x + 28, y + 9)],
        BLACK.mix(0.5).stroke_width(1),
    ))
    .map_err(text)?;
    Ok(())
}

/// The legend: one swatch per class, the sensor's mark, a window's outline.
fn legend<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, x: i32, y: i32) -> Result<(), String> {
    let font = (FONT, 18).into_font();
    let style = TextStyle::from(font.clone())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let width = |s: &str| -> i32 {
        font.box_size(s)
            .map_or(px(s.chars().count()) * 10, |(w, _)| {
                i32::try_from(w).unwrap_or(0)
            })
    };
    let mid = y + 14;
    let mut cx = x;
    for (colour, label) in [
        (OBSTACLE_RGB, "obstacle (observed, L > 0)"),
        (FREE_RGB, "navigable (observed, L < 0)"),
        (UNKNOWN_RGB, "unknown (never observed, or L = 0)"),
        (OUTSIDE_RGB, "outside the window"),
    ] {
        swatch(root, (cx, mid), colour)?;
        root.draw_text(label, &style, (cx + 36, mid))
            .map_err(text)?;
        cx += 36 + width(label) + 32;
    }
    sensor_mark(root, (cx + 10, mid))?;
    root.draw_text("sensor", &style, (cx + 26, mid))
        .map_err(text)?;
    cx += 26 + width("sensor") + 32;
    root.draw(&Rectangle::new(
        [(cx, mid - 9), (cx + 28, mid + 9)],
        WINDOW_RGB.stroke_width(1),
    ))
    .map_err(text)?;
    root.draw_text("layer k's window (Lk)", &style, (cx + 36, mid))
        .map_err(text)?;
    Ok(())
}

/// The sensor's mark at a pixel: a blue disc with a white rim and a cross.
fn sensor_mark<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
) -> Result<(), String> {
    area.draw(&Circle::new((x, y), 8, WHITE.filled()))
        .map_err(text)?;
    area.draw(&Circle::new((x, y), 6, SENSOR_RGB.filled()))
        .map_err(text)?;
    area.draw(&PathElement::new(
        vec![(x - 3, y), (x + 3, y)],
        WHITE.stroke_width(1),
    ))
    .map_err(text)?;
    area.draw(&PathElement::new(
        vec![(x, y - 3), (x, y + 3)],
        WHITE.stroke_width(1),
    ))
    .map_err(text)?;
    Ok(())
}

/// A big panel: the fused map over `view`, with axes in metres, the layers' windows that lie
/// inside the view outlined, and the sensor marked.
fn big_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    snapshot: &MapSnapshot,
    f: &FusedMap,
    view: Square,
    caption: &str,
) -> Result<(), String> {
    let caption_style = TextStyle::from((FONT, 20).into_font()).color(&BLACK);
    root.draw_text(caption, &caption_style, (x, y))
        .map_err(text)?;
    let area = root.clone().shrink(
        (x, y + PANEL_TITLE_H),
        (upx(Y_LABELS + BIG + BIG_RIGHT), upx(8 + BIG + X_LABELS)),
    );
    let mut chart = ChartBuilder::on(&area)
        .margin_top(8)
        .margin_right(BIG_RIGHT)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(view.x0..view.x1(), view.y0..view.y1())
        .map_err(text)?;
    let plot = chart.plotting_area().strip_coord_spec();
    let (w, h) = plot.dim_in_pixel();
    let buf = fused_grid(f).raster(view, w as usize, h as usize);
    let image = BitMapElement::<(i32, i32)>::with_owned_buffer((0, 0), (w, h), buf)
        .ok_or("the raster does not match its size")?;
    plot.draw(&image).map_err(text)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x [m] (forward)")
        .y_desc("y [m] (left)")
        .axis_desc_style((FONT, 18))
        .label_style((FONT, 15))
        .draw()
        .map_err(text)?;
    let label_style = TextStyle::from((FONT, 14).into_font())
        .color(&WINDOW_RGB)
        .pos(Pos::new(HPos::Left, VPos::Top));
    for layer in &snapshot.layers {
        let (lx0, ly0) = layer.origin_m();
        let side = layer.extent_m();
        let (lx1, ly1) = (lx0 + side, ly0 + side);
        let eps = 1e-6 * view.side;
        let inside = lx0 >= view.x0 - eps
            && ly0 >= view.y0 - eps
            && lx1 <= view.x1() + eps
            && ly1 <= view.y1() + eps;
        if !inside {
            continue;
        }
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(lx0, ly0), (lx1, ly1)],
                WINDOW_RGB.mix(0.7).stroke_width(1),
            )))
            .map_err(text)?;
        let pad = 0.006 * view.side;
        chart
            .draw_series(std::iter::once(Text::new(
                format!("L{}", layer.index),
                (lx0 + pad, ly1 - pad),
                label_style.clone(),
            )))
            .map_err(text)?;
    }
    if view.contains(snapshot.sensor_xy) {
        let at = chart.backend_coord(&snapshot.sensor_xy);
        sensor_mark(root, at)?;
    }
    Ok(())
}

/// A layer panel: the layer over `view`, its window's edge, the sensor, a caption.
fn layer_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    layer: &LayerSnapshot,
    view: Square,
    sensor: (f64, f64),
) -> Result<(), String> {
    let title_style = TextStyle::from((FONT, 18).into_font()).color(&BLACK);
    root.draw_text(
        &format!(
            "layer {}: {} m cells",
            layer.index,
            num(layer.resolution_m())
        ),
        &title_style,
        (x, y + 4),
    )
    .map_err(text)?;
    let top = y + PANEL_TITLE_H;
    let side = LAYER_PANEL;
    let s = upx(side);
    let buf = layer_grid(layer).raster(view, s as usize, s as usize);
    let image = BitMapElement::<(i32, i32)>::with_owned_buffer((x, top), (s, s), buf)
        .ok_or("the raster does not match its size")?;
    root.draw(&image).map_err(text)?;
    root.draw(&Rectangle::new(
        [(x - 1, top - 1), (x + side, top + side)],
        BLACK.mix(0.6).stroke_width(1),
    ))
    .map_err(text)?;
    let f = f64::from(side);
    let to_px = |(wx, wy): (f64, f64)| -> (i32, i32) {
        #[allow(clippy::cast_possible_truncation)]
        let p = (
            x + ((wx - view.x0) / view.side * f).round() as i32,
            top + ((view.y1() - wy) / view.side * f).round() as i32,
        );
        p
    };
    if view.contains(sensor) {
        sensor_mark(root, to_px(sensor))?;
    }
    let style = TextStyle::from((FONT, 15).into_font()).color(&BLACK);
    let counts = layer.counts();
    let n = layer.cells_per_side;
    let lines = [
        format!("band {} – {} m", num(layer.band_m[0]), num(layer.band_m[1])),
        format!("window {} m ({n} × {n} cells)", num(layer.extent_m())),
        format!("{} obstacle, {} free", counts.obstacle, counts.free),
    ];
    for (k, line) in lines.iter().enumerate() {
        root.draw_text(line, &style, (x, top + side + 6 + px(k) * 20))
            .map_err(text)?;
    }
    Ok(())
}
