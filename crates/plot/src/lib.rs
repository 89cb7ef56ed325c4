//! Figures of the validation experiments and tracking outputs, each written as PNG and SVG:
//!
//! - [`orthographic_views`]: point sets and curves in three orthogonal views at equal scale
//!   (the paper's Figs. 3, 5–7, 10, 11).
//! - [`histograms`]: distributions of errors, one panel per series (e.g. per axis).
//! - [`timelines`]: quantities over frames, one panel per quantity (e.g. a closed loop's tip
//!   error and its stiffness estimate).
//!
//! Coordinates in mm. Text uses the embedded DejaVu Sans (no system fonts needed).
//!
//! ```
//! use flexshape_plot::{Mark, PALETTE, Series3, orthographic_views};
//!
//! let helix: Vec<[f64; 3]> = (0..200)
//!     .map(|i| {
//!         let t = i as f64 * 0.05;
//!         [20.0 * t.cos(), 20.0 * t.sin(), 2.0 * t]
//!     })
//!     .collect();
//! let series = [Series3 { label: "helix".into(), points: helix, mark: Mark::Line, colour: PALETTE[0] }];
//! let stem = std::env::temp_dir().join("flexshape-plot-example");
//! let written = orthographic_views("A helix in three views", &series, &stem)?;
//! assert_eq!(written.len(), 2); // PNG and SVG
//! # Ok::<(), flexshape_plot::PlotError>(())
//! ```

mod histogram;
mod style;
mod timeline;
mod views;

use std::path::{Path, PathBuf};

use thiserror::Error;

pub use histogram::{HistogramSeries, histograms};
pub use style::{Colour, Mark, PALETTE};
pub use timeline::{TimePanel, TimeSeries, timelines};
pub use views::{Series3, orthographic_views};

/// Why a figure could not be drawn or written.
#[derive(Debug, Error)]
pub enum PlotError {
    /// Nothing to plot.
    #[error("{0}: nothing to plot")]
    Empty(String),
    /// The drawing backend failed (e.g. the file cannot be written).
    #[error("{}: {message}", path.display())]
    Draw {
        /// The file.
        path: PathBuf,
        /// Backend message.
        message: String,
    },
}

/// The two files written for `stem`: `stem.png` and `stem.svg`.
pub fn outputs(stem: &Path) -> [PathBuf; 2] {
    [stem.with_extension("png"), stem.with_extension("svg")]
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}
