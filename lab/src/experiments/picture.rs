//! The experiments' pictures: fused maps side by side over the same region (each 0.1 m
//! sample of the fused query one block of pixels, the colours of `pyramid run`'s maps), with
//! the robot and the ground-truth cells marked; and detection curves.

use super::engine::Map;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use terrain_pyramid::Fused;
use terrain_pyramid_host::export::picture::{FREE_RGB, OBSTACLE_RGB, UNKNOWN_RGB};

const FONT: &str = "sans-serif";
/// Pixels per sample, at most; panels are scaled down to fit [`PANEL_W`].
const MAX_PX: usize = 8;
/// A panel's largest width, pixels.
const PANEL_W: usize = 900;
const TITLE_H: i32 = 26;
const GAP: i32 = 16;
const HEADER_H: i32 = 40;

fn text<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

fn register() -> Result<(), String> {
    register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
}

/// A rectangle of the world sampled at `cell` metres.
#[derive(Debug, Clone, Copy, Default)]
pub struct Region {
    /// Lower-left corner and upper-right corner, metres.
    pub x0: f64,
    /// See `x0`.
    pub y0: f64,
    /// See `x0`.
    pub x1: f64,
    /// See `x0`.
    pub y1: f64,
    /// The sample spacing, metres.
    pub cell: f64,
}

impl Region {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn size(&self) -> (usize, usize) {
        (
            ((self.x1 - self.x0) / self.cell).round().max(1.0) as usize,
            ((self.y1 - self.y0) / self.cell).round().max(1.0) as usize,
        )
    }
}

/// One map picture: the fused answers over a region, row 0 = lowest y.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// The caption.
    pub title: String,
    /// The region.
    pub region: Region,
    /// 0 unknown, 1 navigable, 2 obstacle.
    pub cells: Vec<u8>,
    /// The robot, metres.
    pub robot: (f64, f64),
    /// Ground-truth cells to outline (world indices at `region.cell`).
    pub truth: Vec<(i32, i32)>,
}

/// The fused map of `map` over `region`.
pub fn panel(map: &dyn Map, region: &Region, robot: (f64, f64), truth: &[(i32, i32)]) -> Panel {
    let (w, h) = region.size();
    let mut cells = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            #[allow(clippy::cast_precision_loss)]
            let (x, y) = (
                region.x0 + (i as f64 + 0.5) * region.cell,
                region.y0 + (j as f64 + 0.5) * region.cell,
            );
            cells.push(match map.fused(x, y) {
                Fused::Unknown => 0,
                Fused::Navigable { .. } => 1,
                Fused::Obstacle { .. } => 2,
            });
        }
    }
    Panel {
        title: map.name().to_string(),
        region: *region,
        cells,
        robot,
        truth: truth.to_vec(),
    }
}

/// Draws `panels` in rows of `per_row` into the PNG `path`.
///
/// # Errors
/// The font or the file could not be used.
pub fn draw_panels(
    path: &Path,
    title: &str,
    panels: &[Panel],
    per_row: usize,
) -> Result<(), String> {
    register()?;
    let Some(first) = panels.first() else {
        return Ok(());
    };
    let (w, h) = first.region.size();
    let per_row = per_row.max(1).min(panels.len());
    let px = (PANEL_W / w).clamp(1, MAX_PX);
    let (pw, ph) = (w * px, h * px);
    let rows = panels.len().div_ceil(per_row);
    let to_i = |v: usize| i32::try_from(v).unwrap_or(i32::MAX);
    let width = to_i(per_row * pw) + GAP * (to_i(per_row) + 1);
    let height = HEADER_H + to_i(rows) * (to_i(ph) + TITLE_H + GAP) + GAP;
    let size = (
        u32::try_from(width).unwrap_or(1),
        u32::try_from(height).unwrap_or(1),
    );
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(text)?;
    root.draw(&Text::new(
        title.to_string(),
        (GAP, 10),
        (FONT, 20).into_font(),
    ))
    .map_err(text)?;
    for (n, p) in panels.iter().enumerate() {
        let x0 = GAP + to_i(n % per_row) * (to_i(pw) + GAP);
        let y0 = HEADER_H + to_i(n / per_row) * (to_i(ph) + TITLE_H + GAP);
        root.draw(&Text::new(
            p.title.clone(),
            (x0, y0 + 4),
            (FONT, 15).into_font(),
        ))
        .map_err(text)?;
        let top = y0 + TITLE_H;
        let (pw_n, ph_n) = p.region.size();
        for j in 0..ph_n {
            for i in 0..pw_n {
                let colour = match p.cells.get(j * pw_n + i) {
                    Some(2) => OBSTACLE_RGB,
                    Some(1) => FREE_RGB,
                    _ => UNKNOWN_RGB,
                };
                let (x, y) = (x0 + to_i(i * px), top + to_i((ph_n - 1 - j) * px));
                root.draw(&Rectangle::new(
                    [(x, y), (x + to_i(px), y + to_i(px))],
                    colour.filled(),
                ))
                .map_err(text)?;
            }
        }
        // Ground truth outlines.
        let to_px = |wx: f64, wy: f64| -> (i32, i32) {
            #[allow(clippy::cast_possible_truncation)]
            let (i, j) = (
                ((wx - p.region.x0) / p.region.cell * px as f64).round() as i32,
                ((p.region.y1 - wy) / p.region.cell * px as f64).round() as i32,
            );
            (x0 + i, top + j)
        };
        let c = p.region.cell;
        for &(ix, iy) in &p.truth {
            let a = to_px(f64::from(ix) * c, f64::from(iy + 1) * c);
            let b = to_px(f64::from(ix + 1) * c, f64::from(iy) * c);
            root.draw(&Rectangle::new(
                [a, b],
                RGBColor(32, 96, 230).stroke_width(1),
            ))
            .map_err(text)?;
        }
        let inside = p.robot.0 >= p.region.x0
            && p.robot.0 <= p.region.x1
            && p.robot.1 >= p.region.y0
            && p.robot.1 <= p.region.y1;
        if inside {
            let r = to_px(p.robot.0, p.robot.1);
            root.draw(&Circle::new(r, 5, RGBColor(32, 96, 230).filled()))
                .map_err(text)?;
        }
        root.draw(&Rectangle::new(
            [(x0, top), (x0 + to_i(pw_n * px), top + to_i(ph_n * px))],
            BLACK.stroke_width(1),
        ))
        .map_err(text)?;
    }
    root.present().map_err(text)?;
    Ok(())
}

/// Line colours of the curves.
const COLOURS: [RGBColor; 4] = [
    RGBColor(200, 40, 40),
    RGBColor(230, 140, 20),
    RGBColor(30, 90, 200),
    RGBColor(20, 150, 80),
];

/// Draws curves `(x, y)` (x decreasing is fine) into the PNG `path`.
///
/// # Errors
/// The font or the file could not be used.
pub fn draw_curves(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<(), String> {
    register()?;
    let root = BitMapBackend::new(path, (1000, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(text)?;
    let x_max = curves
        .iter()
        .flat_map(|(_, c)| c.iter().map(|p| p.0))
        .fold(1.0_f64, f64::max);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 20))
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max, 0.0..1.05)
        .map_err(text)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT, 14))
        .draw()
        .map_err(text)?;
    for (k, (name, points)) in curves.iter().enumerate() {
        let colour = COLOURS.get(k % COLOURS.len()).copied().unwrap_or(BLACK);
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(2),
            ))
            .map_err(text)?
            .label(name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(text)?;
    root.present().map_err(text)?;
    Ok(())
}
