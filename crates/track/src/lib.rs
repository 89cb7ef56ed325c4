//! Tracking: the whole sensing chain for one frame ([`Pipeline`]), run over a source of frames
//! ([`run`]), each frame's result made into the record `flexshape track` writes
//! ([`Processed::record`]; the record types are [`flexshape_record`]'s). World frame, mm.
//!
//! A recording folder tracked, following the tube from frame to frame, each frame's record
//! printed (the crate's `examples/` also feed frames from your own cameras and read a record
//! stream):
//!
//! ```no_run
//! use std::ops::ControlFlow;
//! use std::sync::atomic::AtomicBool;
//!
//! use flexshape_track::{Recording, run};
//!
//! let mut recording = Recording::open("recording".as_ref())?;
//! let pipeline = recording.pipeline()?.following(true)?;
//! let stop = AtomicBool::new(false); // set it to stop early: frames taken still arrive
//! run(&mut recording.source, &pipeline, 2, &stop, |processed| {
//!     let record = processed.record();
//!     println!("frame {}: {} tip {:?} mm", record.frame, record.status, record.tip);
//!     ControlFlow::Continue(())
//! });
//! # Ok::<(), flexshape_track::TrackError>(())
//! ```

mod backdrop;
mod hull_record;
mod instants;
mod open;
pub mod output;
mod pipeline;
mod recorded;
mod runner;
mod source;
mod state;
mod usual;

use flexshape_carve::CarveError;
use std::path::PathBuf;

use flexshape_fit::FitError;
use flexshape_recording::RecordingError;
use flexshape_shape::ShapeError;
use flexshape_silhouette::SilhouetteError;
use thiserror::Error;

pub use instants::{CameraTimes, Instants};
pub use open::{Recording, load_backgrounds};
pub use pipeline::{Hull, MASK_P90_PX, MAX_HULL_SHARE, Pipeline, Prior, Tracked};
pub use recorded::{Tally, captured_from};
pub use runner::{Processed, Recent, RunEnd, run};
pub use source::{Input, SourceSpec};

/// Why a frame (or the pipeline's setup) failed.
#[derive(Debug, Error)]
pub enum TrackError {
    /// A table of the rig's `[processing]` that no stage reads, or that names a camera the
    /// rig does not have.
    #[error("[{table}]: {problem}")]
    Processing {
        /// The table, e.g. `processing.shap`.
        table: String,
        /// What is wrong and what to do.
        problem: String,
    },
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
    /// A recording folder.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A camera's background model could not be read.
    #[error(
        "camera {camera}: tracking needs its background image {} (make one with `flexshape background`): {source}",
        path.display()
    )]
    Background {
        /// Camera name.
        camera: String,
        /// The background image.
        path: PathBuf,
        /// What went wrong.
        source: SilhouetteError,
    },
    /// A JSON Lines file of tracking records.
    #[error(transparent)]
    Records(#[from] flexshape_record::RecordError),
    /// Inputs that do not go together.
    #[error("{0}")]
    Input(String),
    /// A rig file or folder.
    #[error("{} is not a valid rig: {source}", path.display())]
    Rig {
        /// The rig file or folder.
        path: PathBuf,
        /// What is wrong.
        source: flexshape_rig::RigError,
    },
    /// An output could not be opened or written.
    #[error("{0}")]
    Output(String),
    /// Opening a frame source.
    #[error(transparent)]
    Source(#[from] flexshape_input::InputError),
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
