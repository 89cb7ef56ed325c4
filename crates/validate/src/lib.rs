//! The paper's validation experiments (Section III) as library code:
//!
//! - [`accuracy`]: sensed points against a reference instrument's (a digitizer's stylus tip),
//!   registered rigidly (Section III-A): per-axis RMS, 3-D RMS, max.
//! - [`compare_shape`] and [`precision`]: sensed shapes of a rigid object against its known
//!   shape (CAD), paired along the length and registered per pose: per-axis RMS along the whole
//!   length and at the marked points (Section III-B).
//! - [`extract`]: the sensed point of a frame (tip, a band, or the extreme along a direction).
//! - [`simulated`]: both experiments on the simulated rig with known truth.
//!
//! World frame and mm throughout; per-axis errors are in the tracking system's frame, as in
//! the paper.

mod accuracy;
mod extract;
mod shape;
pub mod simulated;

use thiserror::Error;

pub use accuracy::{AccuracyReport, accuracy};
pub use extract::{Extraction, extract};
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
}
