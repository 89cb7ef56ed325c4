//! Errors of reading and writing recordings; each names the file or folder.

use std::path::PathBuf;

use flexshape_rig::RigError;
use thiserror::Error;

/// A problem with a recording folder.
#[derive(Debug, Error)]
pub enum RecordingError {
    /// The rig or a camera file is missing or invalid.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// A file or folder could not be read or created.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// An image could not be decoded or encoded.
    #[error("{}: {message}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong (decoder message).
        message: String,
    },
    /// An image has a size other than its camera's calibration says.
    #[error(
        "{}: image is {width}×{height} but camera `{camera}` is calibrated for {expected_width}×{expected_height}; use frames from the calibrated camera or recalibrate",
        path.display()
    )]
    ImageSize {
        /// The image file.
        path: PathBuf,
        /// Camera name.
        camera: String,
        /// Image width found.
        width: u32,
        /// Image height found.
        height: u32,
        /// Calibrated width.
        expected_width: u32,
        /// Calibrated height.
        expected_height: u32,
    },
    /// A ground-truth file is not valid JSON of the expected shape.
    #[error("{}: invalid ground truth: {message}", path.display())]
    Truth {
        /// The JSON file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// A command file is not valid JSON of the expected shape.
    #[error("{}: invalid command file: {message}", path.display())]
    Command {
        /// The JSON file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// The recording's structure is inconsistent (e.g. cameras with different frame counts).
    #[error("{}: {problem}", path.display())]
    Layout {
        /// The recording folder.
        path: PathBuf,
        /// What is inconsistent and what to do.
        problem: String,
    },
}

impl RecordingError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        RecordingError::Io {
            path: path.into(),
            source,
        }
    }
}
