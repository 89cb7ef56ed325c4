//! Tracking: the whole sensing chain for one frame ([`Pipeline`]) and the JSON Lines records
//! `flexshape track` writes ([`TrackRecord`], then one [`SummaryLine`]). World frame, mm.

mod backdrop;
mod pipeline;
mod precision;
mod record;
mod refine;
mod runner;
mod usual;

use flexshape_carve::CarveError;
use flexshape_fit::FitError;
use flexshape_shape::ShapeError;
use flexshape_silhouette::SilhouetteError;
use thiserror::Error;

pub use backdrop::BackgroundUpdate;
pub use pipeline::{
    Hull, MASK_P90_PX, MAX_HULL_SHARE, Pipeline, Prior, StageTimings, Start, Tracked,
};
pub use record::{
    ModelFrame, StageSummary, SummaryLine, Tally, TrackArcFit, TrackBand, TrackCompression,
    TrackRecord, TrackSummary, quantile, stage_summaries,
};
pub use refine::{
    CameraRefinement, MAX_SIGMA_MM, MIN_FRAMES, MIN_GAIN, OutlineResiduals, Refinement, Verdict,
    refine_cameras,
};
pub use runner::{Processed, Recent, RunEnd, run};

/// Why a frame (or the pipeline's setup) failed.
#[derive(Debug, Error)]
pub enum TrackError {
    /// A camera's silhouette stage.
    #[error("camera {camera}: {source}")]
    Silhouette {
        /// Camera name.
        camera: String,
        /// What went wrong.
        source: SilhouetteError,
    },
    /// Carving or bands.
    #[error(transparent)]
    Carve(#[from] CarveError),
    /// Shape settings.
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// The image fit.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// Camera poses cannot be refined from the frames given.
    #[error("cannot refine the camera poses: {0}")]
    Refine(String),
    /// One item per camera was expected.
    #[error("{found} {what} for a rig of {expected} cameras")]
    CameraCount {
        /// What was counted.
        what: &'static str,
        /// How many were given.
        found: usize,
        /// Cameras in the rig.
        expected: usize,
    },
}
