//! Work on a rig from your own program, as the `flexshape` commands do it:
//!
//! - [`identify`]: the manipulator model's stiffnesses (and tendon positions) identified from
//!   a tracked experiment — records that carry the commanded tendon displacements — as the
//!   paper's Table I (`flexshape model fit`).
//! - [`bench`](mod@bench): the chain's per-stage times and throughput on the simulated rig (`flexshape
//!   bench`).
//! - [`carve`]: the visual hull of every frame, for objects that are not tubes (`flexshape
//!   carve`).
//! - [`demo`]: the model-driven catheter on the simulated rig, tracked and measured against
//!   the simulator's truth (`flexshape demo`).
//! - [`soak`]: the demo left running for many thousand frames, reported per window of frames
//!   (`flexshape bench --soak N`): whether a long run keeps saying `ok` to right shapes.
//! - [`refine`]: camera poses refined from many tracked frames, as few cameras moved as
//!   explain them (`flexshape rig refine`).
//! - [`inspect`]: one frame looked at closely — every stage's figures, each classifier's
//!   silhouette, images of what the chain saw (`flexshape silhouettes`).
//! - [`simulate`]: simulated recordings (sweep, motion, a model experiment) and calibration
//!   sessions with their ground truth (`flexshape simulate`).
//!
//! ```no_run
//! use flexshape_lab::identify::{Experiment, IdentifySettings, identify, load_model};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = load_model("catheter.toml".as_ref())?;
//! let records = flexshape_record::read_records("experiment.jsonl".as_ref())?;
//! let experiment = Experiment::from_records(records, &Default::default(), &model, "experiment.jsonl".as_ref())?;
//! let found = identify(&model, &experiment, &IdentifySettings::default())?;
//! print!("{}", found.report.table());
//! # Ok(())
//! # }
//! ```

pub mod bench;
pub mod carve;
pub mod demo;
pub mod identify;
pub mod inspect;
pub mod refine;
pub mod simulate;
pub mod soak;

use std::path::PathBuf;

use thiserror::Error;

/// Why a workflow failed; each names the file, frame or step.
#[derive(Debug, Error)]
pub enum LabError {
    /// Opening or tracking failed.
    #[error(transparent)]
    Track(#[from] flexshape_track::TrackError),
    /// The tube could not be fitted to the images (refining poses, inspecting a frame).
    #[error(transparent)]
    Fit(#[from] flexshape_fit::FitError),
    /// Reading records failed.
    #[error(transparent)]
    Records(#[from] flexshape_record::RecordError),
    /// A file could not be read.
    #[error(transparent)]
    File(#[from] flexshape_rig::files::FileError),
    /// A file or record does not hold what it should.
    #[error("{place}: {reason}")]
    Data {
        /// The file (and line or frame).
        place: String,
        /// What is wrong, and what to do.
        reason: String,
    },
    /// A model step failed.
    #[error("{step}: {source}")]
    Model {
        /// What was being done.
        step: String,
        /// Why it failed.
        source: flexshape_model::ModelError,
    },
    /// A file could not be written.
    #[error("cannot write {}: {reason}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// Camera poses cannot be refined from the frames given.
    #[error("cannot refine the camera poses: {0}")]
    Refine(String),
    /// Stopped on request.
    #[error("interrupted while tracking {}", path.display())]
    Interrupted {
        /// What was being tracked.
        path: PathBuf,
    },
}

impl LabError {
    fn data(place: impl std::fmt::Display, reason: impl Into<String>) -> Self {
        LabError::Data {
            place: place.to_string(),
            reason: reason.into(),
        }
    }

    /// The simulated rig could not be set up or render.
    fn simulator(e: flexshape_sim::SimError) -> Self {
        LabError::data("the simulated rig", e.to_string())
    }

    fn model(step: impl Into<String>) -> impl FnOnce(flexshape_model::ModelError) -> Self {
        let step = step.into();
        move |source| LabError::Model { step, source }
    }
}
