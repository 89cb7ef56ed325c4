//! Errors of reading frames; each names the camera, file or frame and what to do.

use std::path::PathBuf;

use flexshape_recording::RecordingError;
use thiserror::Error;

/// A problem with the input.
#[derive(Debug, Error)]
pub enum InputError {
    /// A recording's file.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A file or folder could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// An image file could not be read or decoded.
    #[error("{}: {message}", path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// Decoder message.
        message: String,
    },
    /// An image or video has another size than its camera's calibration.
    #[error(
        "{what}: {width}×{height} but camera `{camera}` is calibrated for {expected_width}×{expected_height}; use the calibrated camera's frames or recalibrate"
    )]
    Size {
        /// The file, video or device.
        what: String,
        /// Camera name.
        camera: String,
        /// Width found.
        width: u32,
        /// Height found.
        height: u32,
        /// Calibrated width.
        expected_width: u32,
        /// Calibrated height.
        expected_height: u32,
    },
    /// The input names other cameras than the rig, or none.
    #[error("{0}")]
    Cameras(String),
    /// A plain image folder holds no frame that every camera has.
    #[error("{0}")]
    NoFrames(String),
    /// The ffmpeg program is not installed.
    #[error(
        "reading {what} needs the `ffmpeg` program, which is not installed or not on PATH; install it ({})",
        crate::FFMPEG_PACKAGE_HINT
    )]
    FfmpegMissing {
        /// What was to be read.
        what: String,
    },
    /// ffmpeg could not open or decode a camera's stream.
    #[error("camera `{camera}`: ffmpeg cannot read {input}: {message}")]
    Ffmpeg {
        /// Camera name.
        camera: String,
        /// The file, device or URL.
        input: String,
        /// ffmpeg's own message, or what happened.
        message: String,
    },
    /// Any other producer of frames (e.g. the simulator of the live demo) failed.
    #[error("{producer}: {message}")]
    Producer {
        /// What produces the frames.
        producer: String,
        /// What went wrong.
        message: String,
    },
    /// A live camera sent no new frame for a long while (unplugged, stalled, a stream that
    /// never starts).
    #[error(
        "camera `{camera}` sent no new frame for {waited_s} s: check that it is connected and streaming"
    )]
    Silent {
        /// Camera name.
        camera: String,
        /// How long was waited, s.
        waited_s: u64,
    },
    /// Live cameras whose frames could not be paired by capture time for a while.
    #[error(
        "no frame set could be paired for {waited_s} s: camera `{camera}`'s frames were never within the pairing tolerance of the others' captures ({unpaired} sets unpaired). Cameras whose clocks differ (network streams of separate devices) cannot be paired by time; give a wider --pair-within, or cameras of one machine's clock"
    )]
    Unpaired {
        /// The camera whose frames found no partners.
        camera: String,
        /// How long was waited, s.
        waited_s: u64,
        /// Sets unpaired so far.
        unpaired: u64,
    },
    /// One camera's video or stream ended before the others'.
    #[error(
        "camera `{camera}`: its input ended after {frames} frames while other cameras still had frames; the stream stops here (videos of one recording must have the same number of frames)"
    )]
    Ended {
        /// Camera name.
        camera: String,
        /// Frames read from it.
        frames: u64,
    },
}

impl InputError {
    /// True when no further frame can be read after this error (a broken stream), false when
    /// it concerns one frame only.
    pub fn ends_input(&self) -> bool {
        matches!(
            self,
            InputError::FfmpegMissing { .. }
                | InputError::Ffmpeg { .. }
                | InputError::Ended { .. }
                | InputError::Silent { .. }
                | InputError::Unpaired { .. }
                | InputError::Producer { .. }
                | InputError::Cameras(_)
                | InputError::NoFrames(_)
        )
    }

    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        InputError::Io {
            path: path.into(),
            source,
        }
    }
}
