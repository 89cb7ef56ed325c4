//! Errors of the simulator: bad settings, unusable cameras, file output.

use flexshape_curve::CurveError;
use flexshape_recording::RecordingError;
use thiserror::Error;

/// Why a simulation cannot run.
#[derive(Debug, Error)]
pub enum SimError {
    /// A setting is out of range; `field` names it.
    #[error("simulator setting `{field}`: {problem}")]
    Config {
        /// The setting.
        field: String,
        /// What is wrong and what to do.
        problem: String,
    },
    /// A camera cannot be rendered (e.g. its distortion folds inside the image).
    #[error("simulated camera {camera}: {problem}")]
    Camera {
        /// Camera index.
        camera: usize,
        /// What is wrong.
        problem: String,
    },
    /// The catheter's centerline is degenerate.
    #[error("catheter shape: {0}")]
    Curve(#[from] CurveError),
    /// Writing the recording failed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

pub(crate) fn config_error(field: &str, problem: impl Into<String>) -> SimError {
    SimError::Config {
        field: field.into(),
        problem: problem.into(),
    }
}
