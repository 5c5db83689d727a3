//! SVG plots of a [`Plot`]: analytic curves as lines, measured points with error bars, drawn
//! with `plotters` (SVG backend).

use super::check::{Legend, Plot};
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

/// Writes `plot` as an SVG file in `dir`.
pub fn write_svg(dir: &Path, plot: &Plot) -> Result<(), String> {
    let path = dir.join(&plot.file);
    let root = SVGBackend::new(&path, (800, 520)).into_drawing_area();
    draw(&root, plot).map_err(|e| format!("{}: {e}", path.display()))?;
    root.present().map_err(|e| format!("{}: {e}", path.display()))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    plot: &Plot,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
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
    let mut chart = ChartBuilder::on(root)
        .caption(&plot.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart.configure_mesh().x_desc(&plot.x_label).y_desc(&plot.y_label).draw()?;
    // Colours pair up: a dashed approximation takes the colour of the exact curve before it.
    let mut ci = 0usize;
    for s in &plot.curves {
        if !s.dashed {
            ci += 1;
        }
        let color = COLORS[(ci + COLORS.len() - 1) % COLORS.len()];
        let pts = s.x.iter().zip(&s.y).map(|(&x, &y)| (x, y));
        let drawn = if s.dashed {
            chart.draw_series(DashedLineSeries::new(pts, 6, 4, color.stroke_width(2)))?
        } else {
            chart.draw_series(LineSeries::new(pts, color.stroke_width(2)))?
        };
        drawn
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    // Measured points take the colour of their curve when there is one solid curve per point
    // series (Figure 4, the horizon study); otherwise colours after the curves'.
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
        chart
            .draw_series(s.x.iter().zip(&s.y).map(|(&x, &y)| Circle::new((x, y), 3, color.filled())))?
            .label(s.name.clone())
            .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
    }
    let pos = match plot.legend {
        Legend::MiddleRight => SeriesLabelPosition::MiddleRight,
        Legend::UpperRight => SeriesLabelPosition::UpperRight,
        Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
    };
    chart.configure_series_labels().position(pos).background_style(WHITE.mix(0.85)).border_style(BLACK).draw()?;
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
