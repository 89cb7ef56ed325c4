//! Typed errors of the silhouette stage.

use std::path::PathBuf;

use thiserror::Error;

/// Why a silhouette cannot be computed or a background model built.
#[derive(Debug, Error)]
pub enum SilhouetteError {
    /// A frame's size differs from the background model's.
    #[error(
        "frame is {width}×{height} but the background model is {expected_width}×{expected_height}; use a background taken with the same camera settings"
    )]
    SizeMismatch {
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
        /// Model width.
        expected_width: u32,
        /// Model height.
        expected_height: u32,
    },
    /// A frame has no pixels.
    #[error("frame is empty (0 pixels)")]
    EmptyFrame,
    /// A frame does not have three 8-bit colour channels.
    #[error("frame has {channels} channel(s) of {bits} bits; silhouettes need 8-bit RGB")]
    ChannelCount {
        /// Channels found.
        channels: u8,
        /// Bits per channel found.
        bits: u16,
    },
    /// No background frames were given.
    #[error("a background model needs at least one background frame")]
    NoBackground,
    /// A setting is out of range.
    #[error("silhouette setting `{field}`: {problem}")]
    Setting {
        /// The setting.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A background model file could not be read or written.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}
