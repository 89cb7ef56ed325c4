//! Histograms of errors, one panel per series on a shared axis.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::style::{FONT, font, rgb};
use crate::{Colour, PlotError, draw_error, outputs};

/// One distribution.
#[derive(Debug, Clone, PartialEq)]
pub struct HistogramSeries {
    /// Panel caption, e.g. `"x error"`.
    pub label: String,
    /// The values.
    pub values: Vec<f64>,
    /// Bar colour.
    pub colour: Colour,
}

/// Draws each series as a histogram in its own panel, all on one value axis (`x_label`,
/// symmetric about 0 when values have both signs), and writes `stem.png` and `stem.svg`.
pub fn histograms(
    title: &str,
    x_label: &str,
    series: &[HistogramSeries],
    stem: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    font();
    let finite = || {
        series
            .iter()
            .flat_map(|s| &s.values)
            .filter(|v| v.is_finite())
    };
    if series.is_empty() || finite().next().is_none() {
        return Err(PlotError::Empty(title.into()));
    }
    let (lo, hi) = finite().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
        (l.min(v), h.max(v))
    });
    let range = if lo < 0.0 && hi > 0.0 {
        let m = lo.abs().max(hi) * 1.05;
        (-m, m)
    } else if lo >= 0.0 {
        (0.0, hi.max(1e-9) * 1.05)
    } else {
        (lo * 1.05, 0.0)
    };
    let [png, svg] = outputs(stem);
    let size = (
        500 * series.len().min(3) as u32,
        400 * series.len().div_ceil(3) as u32,
    );
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw(&root, title, x_label, series, range).map_err(|e| draw_error(&png, e))?;
        root.present().map_err(|e| draw_error(&png, e))?;
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&root, title, x_label, series, range).map_err(|e| draw_error(&svg, e))?;
        root.present().map_err(|e| draw_error(&svg, e))?;
    }
    Ok(vec![png, svg])
}

const BINS: usize = 24;

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    series: &[HistogramSeries],
    (lo, hi): (f64, f64),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 20))?;
    let panels = root.split_evenly((series.len().div_ceil(3), series.len().min(3)));
    let width = (hi - lo) / BINS as f64;
    for (panel, s) in panels.iter().zip(series) {
        let mut counts = [0usize; BINS];
        for v in s.values.iter().filter(|v| v.is_finite()) {
            let k = (((v - lo) / width) as usize).min(BINS - 1);
            counts[k] += 1;
        }
        let top = counts.iter().copied().max().unwrap_or(0).max(1) as f64 * 1.1;
        let mut chart = ChartBuilder::on(panel)
            .caption(&s.label, (FONT, 15))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(44)
            .build_cartesian_2d(lo..hi, 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc("count")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 12))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        let colour = rgb(s.colour);
        chart.draw_series(counts.iter().enumerate().map(|(k, &c)| {
            let x0 = lo + k as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width * 0.92, c as f64)], colour.filled())
        }))?;
    }
    Ok(())
}
