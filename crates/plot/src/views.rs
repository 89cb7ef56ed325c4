//! Three orthogonal views (top x–y, front x–z, side y–z) at one common scale.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::style::{FONT, font, rgb};
use crate::{Colour, Mark, PlotError, draw_error, outputs};

/// A named set of 3-D points (mm), drawn with one mark and colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Series3 {
    /// Legend text.
    pub label: String,
    /// The points, in order for lines.
    pub points: Vec<[f64; 3]>,
    /// How to draw them.
    pub mark: Mark,
    /// Colour.
    pub colour: Colour,
}

const VIEWS: [(usize, usize, &str); 3] = [
    (0, 1, "top (x–y)"),
    (0, 2, "front (x–z)"),
    (1, 2, "side (y–z)"),
];
const AXES: [&str; 3] = ["x (mm)", "y (mm)", "z (mm)"];

/// Draws `series` in three views side by side and writes `stem.png` and `stem.svg`.
pub fn orthographic_views(
    title: &str,
    series: &[Series3],
    stem: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    font();
    let all: Vec<&[f64; 3]> = series.iter().flat_map(|s| &s.points).collect();
    if all.is_empty() {
        return Err(PlotError::Empty(title.into()));
    }
    // One scale for every view: the largest extent, centred on each axis's middle.
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &all {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let half = (0..3).map(|a| hi[a] - lo[a]).fold(1.0, f64::max) * 0.55;
    let ranges: [(f64, f64); 3] = std::array::from_fn(|a| {
        let mid = (lo[a] + hi[a]) / 2.0;
        (mid - half, mid + half)
    });
    let [png, svg] = outputs(stem);
    let size = (1500, 560);
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw(&root, title, series, &ranges).map_err(|e| draw_error(&png, e))?;
        root.present().map_err(|e| draw_error(&png, e))?;
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&root, title, series, &ranges).map_err(|e| draw_error(&svg, e))?;
        root.present().map_err(|e| draw_error(&svg, e))?;
    }
    Ok(vec![png, svg])
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    series: &[Series3],
    ranges: &[(f64, f64); 3],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 22))?;
    let panels = root.split_evenly((1, 3));
    for (panel, &(a, b, name)) in panels.iter().zip(&VIEWS) {
        let mut chart = ChartBuilder::on(panel)
            .caption(name, (FONT, 16))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(ranges[a].0..ranges[a].1, ranges[b].0..ranges[b].1)?;
        chart
            .configure_mesh()
            .x_desc(AXES[a])
            .y_desc(AXES[b])
            .label_style((FONT, 12))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for s in series {
            let colour = rgb(s.colour);
            let xy = s.points.iter().map(move |p| (p[a], p[b]));
            let drawn = match s.mark {
                Mark::Dots => {
                    chart.draw_series(xy.map(|p| Circle::new(p, 1, colour.mix(0.35).filled())))?
                }
                Mark::Circles => {
                    chart.draw_series(xy.map(|p| Circle::new(p, 4, colour.stroke_width(2))))?
                }
                Mark::Crosses => {
                    chart.draw_series(xy.map(|p| Cross::new(p, 5, colour.stroke_width(2))))?
                }
                Mark::Line => chart.draw_series(LineSeries::new(xy, colour.stroke_width(2)))?,
                Mark::Dashed => {
                    chart.draw_series(DashedLineSeries::new(xy, 6, 4, colour.stroke_width(2)))?
                }
            };
            if a == 0 && b == 1 && !s.label.is_empty() {
                drawn.label(s.label.as_str()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(3))
                });
            }
        }
        if a == 0 && b == 1 && series.iter().any(|s| !s.label.is_empty()) {
            chart
                .configure_series_labels()
                .label_font((FONT, 12))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }
    }
    Ok(())
}
