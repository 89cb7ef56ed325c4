//! Rig files for flexshape: the on-disk description of the cameras and the working volume.
//!
//! - [`camera_file`]: one camera's calibration in OpenCV `cv::FileStorage` YAML (OpenCV 4's
//!   `%YAML:1.0` and OpenCV 5's `%YAML 1.2`, with `!!opencv-matrix`) or JSON, read and written.
//! - [`Volume`]: the carving volume (minimum corner, voxel size, dimensions), in world mm.
//! - [`Rig`]: named cameras + volume + per-stage processing settings, in one TOML file that
//!   points at the per-camera files.
//!
//! - [`coverage`]: which cameras see a volume's corners, and a volume they all see.
//! - [`files`]: bounded reading of what users name (regular files only, size limits, image
//!   sizes checked from the header).
//! - [`import`]: other tools' calibrations (projection matrices, ROS CameraInfo, Kalibr,
//!   COLMAP; Middlebury in [`middlebury`]) read into cameras, and written back.
//!
//! Every loader validates what it reads and names the file and field of any problem.
//!
//! ```no_run
//! use flexshape_rig::{Rig, coverage};
//!
//! // A rig TOML, or a folder of OpenCV camera files (`NAME.yml`) such as a calibration's.
//! let (rig, skipped) = Rig::open("calibration".as_ref())?;
//! for file in &skipped {
//!     eprintln!("not a camera file: {file}");
//! }
//! let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
//! if coverage::corners_seen(&cameras, &rig.volume).iter().any(|&n| n < cameras.len()) {
//!     let seen = coverage::suggest_volume(&cameras, 1.0);
//!     println!("some camera misses part of the volume; every camera sees {seen:?}");
//! }
//! # Ok::<(), flexshape_rig::RigError>(())
//! ```

pub mod camera_file;
mod check;
pub mod coverage;
mod error;
pub mod files;
pub mod import;
pub mod middlebury;
mod opencv_matrix;
mod rig;
mod volume;

pub use check::{CameraView, RigCheck, quoted, short};
pub use error::RigError;
pub use rig::{Occluded, Refined, Rig, RigCamera, SkippedFile, valid_name};
pub use volume::{MAX_VOXELS, VOXEL_MM, Volume, VolumeError};

/// Per-stage processing settings (`[processing.<stage>]` tables of the rig file).
pub use toml::Table as ProcessingTable;
