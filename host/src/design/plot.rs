//! `pyramid design --plot FILE.png`: the paper's Figure 2, the cell-size bound δ(d) of eq. 17
//! and its three terms against distance, over the layers' range bands.
//!
//! Drawn with plotters' bitmap backend. Its text goes through `ab_glyph` with DejaVu Sans, which
//! the `dejavu` crate ships and embeds (`include_bytes!`), so the binary needs no system font.
use super::{metres, DesignArgs};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use terrain_pyramid::design::{BoundTerms, LayerDesign};
use terrain_pyramid::Design;

/// The picture's size, pixels.
const SIZE: (u32, u32) = (1280, 800);
/// Samples of each curve over `[0, max range]`.
const SAMPLES: usize = 600;
/// The font family the text is drawn with; the embedded font is registered under this name.
const FONT: &str = "sans-serif";

/// The alternating fills of the bands: light blue and light sand.
const BAND_FILLS: [RGBColor; 2] = [RGBColor(219, 233, 248), RGBColor(250, 238, 212)];
/// The vertical term's grey.
const GREY: RGBColor = RGBColor(150, 150, 150);
/// The colour of the cell-size steps and the band labels.
const STEP: RGBColor = RGBColor(31, 78, 140);

/// Any drawing error, as text.
fn text<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Registers the embedded DejaVu Sans as [`FONT`].
fn register_embedded_font() -> Result<(), String> {
    register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
}

/// A number as the user would write it: at most 4 decimals, no trailing zeros.
fn num(value: f64) -> String {
    let s = format!("{value:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// Draws Figure 2 for `design` into the PNG file `path`.
///
/// # Errors
/// The font or the file could not be used; the message says why.
pub fn draw<const L: usize>(
    path: &Path,
    args: &DesignArgs,
    design: &Design<L>,
) -> Result<(), String> {
    register_embedded_font()?;
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(text)?;
    figure(&root, args, design)?;
    root.present().map_err(text)?;
    Ok(())
}

/// The figure on a drawing area.
fn figure<DB: DrawingBackend, const L: usize>(
    root: &DrawingArea<DB, Shift>,
    args: &DesignArgs,
    design: &Design<L>,
) -> Result<(), String> {
    let sensor = design.sensor();
    let layers = design.layers();
    let max_range = sensor.max_range_m;
    let delta_max = sensor.bound(max_range).total_m;
    let r_last = layers.last().map_or(delta_max, |l| l.resolution_m);
    let y_max = 1.12 * delta_max.max(r_last);

    #[allow(clippy::cast_precision_loss)]
    let samples: Vec<_> = (0..=SAMPLES)
        .map(|i| sensor.bound(max_range * i as f32 / SAMPLES as f32))
        .collect();

    let title = format!(
        "Cell-size bound δ(d) (eq. 17):  φ = {}°,  ψ = {}°,  σ = {} m,  h = {} m",
        num(args.phi_deg),
        num(args.psi_deg),
        num(args.sigma_m),
        num(args.height_m)
    );
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 30))
        .margin(24)
        .x_label_area_size(64)
        .y_label_area_size(84)
        .build_cartesian_2d(0f32..max_range, 0f32..y_max)
        .map_err(text)?;

    // The bands first, so that the grid and the curves lie on top of them.
    chart
        .draw_series(layers.iter().enumerate().map(|(k, l)| {
            Rectangle::new(
                [(l.band_inner_m, 0.0), (l.band_outer_m, y_max)],
                BAND_FILLS[k % 2].filled(),
            )
        }))
        .map_err(text)?
        .label("range band of a layer, labelled with its cell size")
        .legend(|(x, y)| Rectangle::new([(x, y - 8), (x + 30, y + 8)], BAND_FILLS[0].filled()));

    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.12))
        .x_desc("horizontal distance d from the sensor [m]")
        .y_desc("cell size [m]")
        .axis_desc_style((FONT, 22))
        .label_style((FONT, 18))
        .draw()
        .map_err(text)?;

    band_labels(&mut chart, layers, max_range, y_max)?;

    // Each layer's cell size over its band: its band ends where δ reaches it.
    chart
        .draw_series(layers.iter().map(|l| {
            PathElement::new(
                vec![
                    (l.band_inner_m, l.resolution_m),
                    (l.band_outer_m, l.resolution_m),
                ],
                STEP.stroke_width(2),
            )
        }))
        .map_err(text)?
        .label("cell size r_k of the band's layer (the band ends where δ(d) = r_k)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 30, y)], STEP.stroke_width(2)));

    solid_curve(
        &mut chart,
        &samples,
        |t| t.vertical_m,
        GREY.stroke_width(3),
        "vertical resolution  φ(d² + h²)/h  (eq. 14)",
    )?;
    solid_curve(
        &mut chart,
        &samples,
        |t| t.horizontal_m,
        BLACK.stroke_width(1),
        "horizontal resolution  2d·atan(ψ/2)  (eq. 16)",
    )?;

    chart
        .draw_series(DashedLineSeries::new(
            samples.iter().map(|t| (t.d_m, t.noise_m)),
            10,
            7,
            BLACK.stroke_width(2),
        ))
        .map_err(text)?
        .label("range noise  σ/√(1 + (h/d)²)  (eq. 10)")
        .legend(|(x, y)| {
            DashedPathElement::new(vec![(x, y), (x + 30, y)], 10, 7, BLACK.stroke_width(2))
        });

    solid_curve(
        &mut chart,
        &samples,
        |t| t.total_m,
        BLACK.stroke_width(4),
        "bound δ(d), the sum of the three",
    )?;

    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::Coordinate(16, 76))
        .legend_area_size(40)
        .margin(12)
        .label_font((FONT, 18))
        .background_style(WHITE.mix(0.92))
        .border_style(BLACK.mix(0.4))
        .draw()
        .map_err(text)?;
    Ok(())
}

/// Draws `value` (metres) of every sample against its distance as a solid line of `style`,
/// with `label` in the legend.
fn solid_curve<DB: DrawingBackend, CT: CoordTranslate<From = (f32, f32)>>(
    chart: &mut ChartContext<'_, DB, CT>,
    samples: &[BoundTerms],
    value: fn(&BoundTerms) -> f32,
    style: ShapeStyle,
    label: &str,
) -> Result<(), String> {
    chart
        .draw_series(LineSeries::new(
            samples.iter().map(|t| (t.d_m, value(t))),
            style,
        ))
        .map_err(text)?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 30, y)], style));
    Ok(())
}

/// Labels each band with its cell size, near the top of the plot. The labels alternate between
/// two rows so that the narrow bands' labels do not collide.
fn band_labels<DB: DrawingBackend, CT: CoordTranslate<From = (f32, f32)>>(
    chart: &mut ChartContext<'_, DB, CT>,
    layers: &[LayerDesign],
    max_range: f32,
    y_max: f32,
) -> Result<(), String> {
    let style = TextStyle::from((FONT, 17).into_font())
        .color(&STEP)
        .pos(Pos::new(HPos::Center, VPos::Top));
    chart
        .draw_series(layers.iter().enumerate().map(|(k, l)| {
            let row = if k % 2 == 0 { 0.985 } else { 0.945 };
            // A narrow band at either end keeps its label inside the plot.
            let x = (0.5 * (l.band_inner_m + l.band_outer_m))
                .clamp(0.025 * max_range, 0.975 * max_range);
            Text::new(
                format!("{} m", num(metres(l.resolution_m))),
                (x, row * y_max),
                style.clone(),
            )
        }))
        .map_err(text)?;
    Ok(())
}
