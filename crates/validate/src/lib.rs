//! The paper's validation experiments (Section III) as library code:
//!
//! - [`accuracy`]: sensed points against a reference instrument's (a digitizer's stylus tip),
//!   registered rigidly (Section III-A): per-axis RMS, 3-D RMS, max.
//! - [`compare_shape`] and [`precision`]: sensed shapes of a rigid object against its known
//!   shape (CAD), paired along the length and registered per pose: per-axis RMS along the whole
//!   length and at the marked points (Section III-B).
//! - [`extract`]: the sensed point of a frame (tip, a band, or the extreme along a direction).
//! - [`simulated`]: both experiments on the simulated rig with known truth;
//!   [`SimulatedValidation`] runs them with the image fit and the hull alone, and prints them
//!   beside the paper's figures ([`PAPER`]).
//! - [`figures`]: the experiments' figures and a tracking output's (PNG + SVG).
//!
//! World frame and mm throughout; per-axis errors are in the tracking system's frame, as in
//! the paper.
//!
//! ```
//! use flexshape_validate::accuracy;
//! use nalgebra::Point3;
//!
//! // A digitizer's points and the tracked tip at the same places, in another frame and
//! // 0.1 mm off along x at one of them.
//! let reference = [[0.0, 0.0, 0.0], [40.0, 0.0, 0.0], [0.0, 40.0, 0.0], [0.0, 0.0, 40.0]];
//! let mut sensed = reference.map(|[x, y, z]| Point3::new(y + 100.0, -x, z));
//! sensed[1].x += 0.1;
//! let report = accuracy(&sensed, &reference.map(Point3::from))?;
//! assert!(report.rms < 0.1 && report.max > 0.0);
//! println!("rms x {:.3}, y {:.3}, z {:.3} mm", report.rms_x, report.rms_y, report.rms_z);
//! # Ok::<(), flexshape_validate::ValidateError>(())
//! ```

mod accuracy;
mod extract;
pub mod figures;
mod records;
mod report;
mod shape;
pub mod simulated;

use thiserror::Error;

pub use accuracy::{AccuracyReport, accuracy};
pub use extract::{Extraction, extract};
pub use records::{ShapeRun, compare_records};
pub use report::{HullReport, PAPER, PaperFigures, SimulatedValidation};
pub use shape::{KnownShape, PoseComparison, PrecisionReport, compare_shape, precision};

/// Why an experiment cannot be evaluated.
#[derive(Debug, Error)]
pub enum ValidateError {
    /// Registration failed (too few, collinear or unpaired points).
    #[error(transparent)]
    Register(#[from] flexshape_register::RegisterError),
    /// The inputs do not fit together.
    #[error("{0}")]
    Input(String),
    /// The simulator or the sensing chain failed.
    #[error("{0}")]
    Pipeline(String),
    /// A figure could not be written.
    #[error("{0}")]
    Figure(String),
}
