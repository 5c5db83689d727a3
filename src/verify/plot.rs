//! SVG plots of a [`Plot`]: analytic curves as lines (approximations dashed, each in its own dash
//! pattern), measured points with error bars (each series its own marker shape), and the legend in
//! a strip below the chart so it never covers data; drawn with `plotters` (SVG backend).
//! [`Plot::legend`] is no longer used for placement.

use super::check::Plot;
use plotters::prelude::*;
use std::path::Path;

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Dash patterns (dash, gap in px) of successive dashed curves that share a colour class, so two
/// approximations in one plot differ in pattern as well as colour.
const DASHES: [(u32, u32); 3] = [(8, 5), (2, 4), (12, 4)];

/// Legend entries per row below the chart.
const LEGEND_COLUMNS: usize = 2;
const LEGEND_ROW_PX: u32 = 20;

/// How a series is drawn, for the chart and its legend.
#[derive(Clone, Copy)]
enum Style {
    Line { color: RGBColor, dash: Option<(u32, u32)> },
    Marker { color: RGBColor, shape: usize },
}

/// Writes `plot` as an SVG file in `dir`: the chart on top, its legend in a strip below it (so the
/// legend never covers data).
pub fn write_svg(dir: &Path, plot: &Plot) -> Result<(), String> {
    let path = dir.join(&plot.file);
    let entries = plot.curves.len() + plot.points.len();
    let legend_h = (entries.div_ceil(LEGEND_COLUMNS) as u32) * LEGEND_ROW_PX + 12;
    let root = SVGBackend::new(&path, (800, 520 + legend_h)).into_drawing_area();
    draw(&root, plot, legend_h).map_err(|e| format!("{}: {e}", path.display()))?;
    root.present().map_err(|e| format!("{}: {e}", path.display()))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    plot: &Plot,
    legend_h: u32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (_, h) = root.dim_in_pixel();
    let (upper, lower) = root.split_vertically(h - legend_h);
    let mut xs: Vec<f64> = vec![];
    let mut ys: Vec<f64> = vec![];
    for s in plot.curves.iter().chain(&plot.points) {
        xs.extend(s.x.iter().copied().filter(|v| v.is_finite()));
        for (i, &y) in s.y.iter().enumerate() {
            if y.is_finite() {
                let e = s.err.as_ref().map(|e| e[i]).unwrap_or(0.0);
                ys.push(y - e);
                ys.push(y + e);
            }
        }
    }
    let (x0, x1) = range(&xs);
    let (y0, y1) = range(&ys);
    let mut chart = ChartBuilder::on(&upper)
        .caption(&plot.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart.configure_mesh().x_desc(&plot.x_label).y_desc(&plot.y_label).draw()?;
    let mut legend: Vec<(String, Style)> = vec![];
    // Colours pair up: a dashed approximation takes the colour of the exact curve before it, and
    // successive dashed curves of one colour take different dash patterns.
    let mut ci = 0usize;
    let mut dashes_in_class = 0usize;
    for s in &plot.curves {
        if !s.dashed {
            ci += 1;
            dashes_in_class = 0;
        }
        let color = COLORS[(ci + COLORS.len() - 1) % COLORS.len()];
        let pts: Vec<(f64, f64)> = s.x.iter().zip(&s.y).map(|(&x, &y)| (x, y)).collect();
        let dash = s.dashed.then(|| {
            dashes_in_class += 1;
            DASHES[(dashes_in_class - 1) % DASHES.len()]
        });
        match dash {
            Some((d, g)) => {
                chart.draw_series(DashedLineSeries::new(pts, d, g, color.stroke_width(2)))?;
            }
            None => {
                chart.draw_series(LineSeries::new(pts, color.stroke_width(2)))?;
            }
        }
        legend.push((s.name.clone(), Style::Line { color, dash }));
    }
    // Measured points take the colour of their curve when there is one solid curve per point
    // series (Figure 4, the horizon study); otherwise colours after the curves'. Each series has its
    // own marker shape.
    let solid = plot.curves.iter().filter(|s| !s.dashed).count();
    for (i, s) in plot.points.iter().enumerate() {
        let idx = if plot.points.len() == solid { i } else { solid + i };
        let color = COLORS[idx % COLORS.len()];
        if let Some(err) = &s.err {
            // Vertical error bars ±σ as line segments (the `errorbar` feature is not enabled).
            chart.draw_series(
                s.x.iter()
                    .zip(&s.y)
                    .zip(err)
                    .map(|((&x, &y), &e)| PathElement::new(vec![(x, y - e), (x, y + e)], color.stroke_width(2))),
            )?;
        }
        let shape = i % 4;
        let pts: Vec<(f64, f64)> = s.x.iter().zip(&s.y).map(|(&x, &y)| (x, y)).collect();
        match shape {
            0 => chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))?,
            1 => chart.draw_series(pts.iter().map(|&p| TriangleMarker::new(p, 6, color.filled())))?,
            2 => chart.draw_series(
                pts.iter().map(|&p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], color.filled())),
            )?,
            _ => chart.draw_series(pts.iter().map(|&p| Cross::new(p, 5, color.stroke_width(2))))?,
        };
        legend.push((s.name.clone(), Style::Marker { color, shape }));
    }
    draw_legend(&lower, &legend)
}

/// The legend, in [`LEGEND_COLUMNS`] columns on its own strip below the chart.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(String, Style)],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (w, _) = area.dim_in_pixel();
    let col_w = (w as i32 - 40) / LEGEND_COLUMNS as i32;
    for (j, (name, style)) in entries.iter().enumerate() {
        let x = 20 + (j % LEGEND_COLUMNS) as i32 * col_w;
        let y = 8 + (j / LEGEND_COLUMNS) as i32 * LEGEND_ROW_PX as i32 + LEGEND_ROW_PX as i32 / 2;
        match *style {
            Style::Line { color, dash: None } => {
                area.draw(&PathElement::new(vec![(x, y), (x + 36, y)], color.stroke_width(2)))?;
            }
            Style::Line { color, dash: Some((d, g)) } => {
                let mut a = x;
                while a < x + 36 {
                    let b = (a + d as i32).min(x + 36);
                    area.draw(&PathElement::new(vec![(a, y), (b, y)], color.stroke_width(2)))?;
                    a = b + g as i32;
                }
            }
            Style::Marker { color, shape } => {
                let c = (x + 18, y);
                match shape {
                    0 => area.draw(&Circle::new(c, 4, color.filled()))?,
                    1 => area.draw(&TriangleMarker::new(c, 6, color.filled()))?,
                    2 => area.draw(&Rectangle::new([(c.0 - 4, c.1 - 4), (c.0 + 4, c.1 + 4)], color.filled()))?,
                    _ => area.draw(&Cross::new(c, 5, color.stroke_width(2)))?,
                }
                area.draw(&PathElement::new(vec![(c.0, y - 7), (c.0, y + 7)], color.stroke_width(1)))?;
            }
        }
        area.draw(&Text::new(name.clone(), (x + 44, y - 8), ("sans-serif", 15).into_font().color(&BLACK)))?;
    }
    Ok(())
}

fn range(v: &[f64]) -> (f64, f64) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9);
    (lo - pad, hi + pad)
}
