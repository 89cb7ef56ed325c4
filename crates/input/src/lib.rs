//! Frames for tracking. A [`FrameSource`] hands out [`FrameSet`]s — one image per camera, in
//! the rig's order — from a recording folder ([`RecordingSource`]), plain per-camera image
//! folders ([`FolderSource`]), one video file per camera ([`VideoSource`]) or live cameras
//! ([`LiveSource`]); the last two run the `ffmpeg` program. [`NewestSource`] wraps any producer
//! thread (the simulated rig of the live demo). Offline sources hand out every
//! frame; a live source hands out the newest set — live cameras' frames paired by capture
//! time — and counts the frames it had to drop and the sets it could not pair.
//! [`capture`] writes a source's frame sets into per-camera folders (chessboards, backgrounds,
//! frames to track later).
//!
//! ```
//! use flexshape_input::{FrameSet, FrameSource, NewestSource};
//!
//! // A producer thread delivering frame sets on its own clock (here three, without images).
//! let mut n = 0;
//! let mut source = NewestSource::spawn(move || {
//!     n += 1;
//!     (n <= 3).then(|| Ok(FrameSet::new(n, Vec::new())))
//! });
//! let mut taken = Vec::new();
//! while let Some(set) = source.next_frame() {
//!     taken.push(set?.frame);
//! }
//! // A slow taker sees the newest; the frames it missed are counted.
//! assert_eq!(taken.last(), Some(&3));
//! assert_eq!(taken.len() as u64 + source.dropped(), 3);
//! # Ok::<(), flexshape_input::InputError>(())
//! ```

mod capture;
mod error;
mod ffmpeg;
mod folders;
mod frame;
mod latest;
mod live;
mod newest;
mod recording;
mod video;

pub use capture::{CaptureOptions, CaptureReport, capture, capture_path};
pub use error::InputError;
pub use ffmpeg::{FFMPEG_PACKAGE_HINT, ffmpeg_available, probe_size};
pub use folders::{FolderSource, natural_order};
pub use frame::{CaptureSource, CaptureTime, FrameImage, FrameSet, unix_seconds};

pub use live::{LiveCamera, LiveSource};
pub use newest::NewestSource;
pub use recording::RecordingSource;
pub use video::{CameraVideo, VideoSource};

/// Where frames come from.
pub trait FrameSource: Send {
    /// The next frame set; `None` at the end of the input. An `Err` whose
    /// [`InputError::ends_input`] is false concerns one frame only (the caller records it and
    /// asks for the next).
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>>;

    /// Frames in the input, when known in advance (offline input).
    fn len_hint(&self) -> Option<usize> {
        None
    }

    /// True for live input (cameras): frames arrive on their own clock and the newest set
    /// wins.
    fn is_live(&self) -> bool {
        false
    }

    /// Frame sets dropped so far because newer ones arrived before they were taken (live
    /// input; the largest count over the cameras).
    fn dropped(&self) -> u64 {
        0
    }

    /// Frame sets not taken because a camera had no frame near the others' capture instant
    /// (live cameras paired by time).
    fn unpaired(&self) -> u64 {
        0
    }
}
