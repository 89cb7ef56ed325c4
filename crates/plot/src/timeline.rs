//! Quantities over time (frames), one panel per quantity, stacked on a shared time axis.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::style::{FONT, font, rgb};
use crate::{Colour, PlotError, draw_error, outputs};

/// One line of a panel.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeSeries {
    /// Legend text.
    pub label: String,
    /// `(time, value)` points in order; non-finite values leave gaps.
    pub points: Vec<(f64, f64)>,
    /// Line colour.
    pub colour: Colour,
}

/// One panel: its quantity, its lines and whether its axis is logarithmic (for errors that
/// fall by orders of magnitude; values ≤ 0 are then left out).
#[derive(Debug, Clone, PartialEq)]
pub struct TimePanel {
    /// The quantity and unit, e.g. `"tip error (mm)"`.
    pub y_label: String,
    /// Its lines.
    pub series: Vec<TimeSeries>,
    /// Logarithmic value axis.
    pub log: bool,
}

/// Draws `panels` stacked over a shared `x_label` axis and writes `stem.png` and `stem.svg`.
pub fn timelines(
    title: &str,
    x_label: &str,
    panels: &[TimePanel],
    stem: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    font();
    let usable = |p: &TimePanel, v: f64| v.is_finite() && (!p.log || v > 0.0);
    let points = || {
        panels
            .iter()
            .flat_map(|p| {
                p.series
                    .iter()
                    .flat_map(move |s| s.points.iter().map(move |q| (p, q)))
            })
            .filter(|(p, q)| q.0.is_finite() && usable(p, q.1))
    };
    if points().next().is_none() {
        return Err(PlotError::Empty(title.into()));
    }
    let (t0, t1) = points().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (_, q)| {
        (a.min(q.0), b.max(q.0))
    });
    let [png, svg] = outputs(stem);
    let size = (900, 320 * panels.len() as u32);
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw(&root, title, x_label, panels, (t0, t1.max(t0 + 1.0)))
            .map_err(|e| draw_error(&png, e))?;
        root.present().map_err(|e| draw_error(&png, e))?;
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&root, title, x_label, panels, (t0, t1.max(t0 + 1.0)))
            .map_err(|e| draw_error(&svg, e))?;
        root.present().map_err(|e| draw_error(&svg, e))?;
    }
    Ok(vec![png, svg])
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    panels: &[TimePanel],
    (t0, t1): (f64, f64),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 20))?;
    let areas = root.split_evenly((panels.len(), 1));
    for (area, panel) in areas.iter().zip(panels) {
        let values: Vec<f64> = panel
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|q| q.1))
            .filter(|v| v.is_finite() && (!panel.log || *v > 0.0))
            .collect();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        if !lo.is_finite() {
            continue;
        }
        let mut builder = ChartBuilder::on(area);
        builder
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60);
        let style = |s: &TimeSeries| rgb(s.colour).stroke_width(2);
        if panel.log {
            let mut chart =
                builder.build_cartesian_2d(t0..t1, (lo * 0.8..hi * 1.25).log_scale())?;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(&panel.y_label)
                .label_style((FONT, 12))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()?;
            for s in &panel.series {
                let line = s
                    .points
                    .iter()
                    .copied()
                    .filter(|q| q.1.is_finite() && q.1 > 0.0);
                chart
                    .draw_series(LineSeries::new(line, style(s)))?
                    .label(&s.label)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], rgb(s.colour)));
            }
            chart
                .configure_series_labels()
                .label_font((FONT, 12))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        } else {
            let pad = ((hi - lo) * 0.08).max(1e-9);
            let mut chart = builder.build_cartesian_2d(t0..t1, lo - pad..hi + pad)?;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(&panel.y_label)
                .label_style((FONT, 12))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()?;
            for s in &panel.series {
                let line = s.points.iter().copied().filter(|q| q.1.is_finite());
                chart
                    .draw_series(LineSeries::new(line, style(s)))?
                    .label(&s.label)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], rgb(s.colour)));
            }
            chart
                .configure_series_labels()
                .label_font((FONT, 12))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_log_and_linear_panels_and_refuses_nothing_to_draw() {
        let dir = tempfile::tempdir().unwrap();
        let stem = dir.path().join("t");
        let error = TimeSeries {
            label: "error".into(),
            points: (0..20).map(|i| (i as f64, 5.0 * 0.5f64.powi(i))).collect(),
            colour: crate::PALETTE[0],
        };
        let k = TimeSeries {
            label: "Kx".into(),
            points: (0..20)
                .map(|i| (i as f64, if i < 6 { -20.0 } else { 0.3 }))
                .collect(),
            colour: crate::PALETTE[1],
        };
        let panels = [
            TimePanel {
                y_label: "mm".into(),
                series: vec![error],
                log: true,
            },
            TimePanel {
                y_label: "%".into(),
                series: vec![k],
                log: false,
            },
        ];
        let files = timelines("test", "frame", &panels, &stem).unwrap();
        let img = image::open(&files[0]).unwrap().to_rgb8();
        let inked = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(inked > 2000, "{inked}");
        let empty = [TimePanel {
            y_label: "mm".into(),
            series: Vec::new(),
            log: true,
        }];
        assert!(timelines("none", "frame", &empty, &stem).is_err());
    }
}
