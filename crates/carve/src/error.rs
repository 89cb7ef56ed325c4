//! Typed errors of carving.

use thiserror::Error;

/// Why a volume cannot be carved.
#[derive(Debug, Error)]
pub enum CarveError {
    /// Carving needs at least two views to bound anything.
    #[error("carving needs at least two cameras; the rig has {cameras}")]
    TooFewCameras {
        /// Cameras in the rig.
        cameras: usize,
    },
    /// The lookup table would not fit the memory budget.
    #[error(
        "a lookup table for this volume would take {bytes} bytes (limit 4 GiB); use larger voxels or a smaller volume"
    )]
    TableTooLarge {
        /// Bytes needed.
        bytes: u64,
    },
    /// A camera sees none of the volume's voxels.
    #[error(
        "camera {camera} sees none of the volume's voxels; check the volume (rig [volume]) and the camera's extrinsics"
    )]
    VolumeNotInView {
        /// Camera index.
        camera: usize,
    },
    /// The number of masks differs from the number of cameras.
    #[error("{masks} silhouette masks for {cameras} cameras")]
    MaskCount {
        /// Masks given.
        masks: usize,
        /// Cameras in the table.
        cameras: usize,
    },
    /// A mask's size differs from its camera's image size.
    #[error(
        "mask of camera {camera} is {width}×{height} but the camera's images are {expected_width}×{expected_height}"
    )]
    MaskSize {
        /// Camera index.
        camera: usize,
        /// Mask width.
        width: usize,
        /// Mask height.
        height: usize,
        /// Image width.
        expected_width: u32,
        /// Image height.
        expected_height: u32,
    },
    /// `min_views` of [`crate::OutsideImage::Ignore`] is 0 or more than the cameras.
    #[error("min_views = {min_views} must be between 1 and the number of cameras ({cameras})")]
    MinViews {
        /// The setting.
        min_views: usize,
        /// Cameras in the rig.
        cameras: usize,
    },
    /// The volume breaks [`flexshape_rig::Volume::new`]'s invariants (a literal built
    /// without it, e.g. voxels 1e-300 mm deep).
    #[error("the volume: {0}")]
    Volume(#[from] flexshape_rig::VolumeError),
    /// Writing a PLY file failed.
    #[error("{path}: {source}")]
    Write {
        /// The file.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
}
