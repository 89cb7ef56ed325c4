//! Camera calibration from images of a planar chessboard (paper, Section II, step 1):
//!
//! - [`Board`]: the target (inner corners, square size in mm) and its corner coordinates.
//! - [`detect`]: corners in an 8-bit image (calib-targets' ChESS detector with its saddle-point
//!   refiner), checked to be the whole board and labelled in the board's own frame.
//! - [`homography`] and [`zhang`]: the closed-form start (Zhang 2000).
//! - [`relative_pose`]: a camera's pose relative to the rig's reference camera from views
//!   of the board both saw at the same instant.
//! - [`adjust_rig`]: one joint bundle adjustment of every camera's intrinsics and pose and
//!   every board pose.
//! - [`calibrate`]: Levenberg–Marquardt over fx, fy, cx, cy, k1, k2, p1, p2, k3 and every
//!   view's pose; per-view and overall reprojection RMS, outlier views, standard deviations.
//!
//! Conventions: OpenCV's (x_cam = R·X_board + t, pixel (0, 0) the centre of the top-left
//! pixel, distortion k1 k2 p1 p2 k3); board frame: origin at the first inner corner, x along
//! the `cols` direction, y along `rows`, z = 0 on the board, mm.
//!
//! A whole rig from per-camera image folders: [`workflow::calibrate_rig`]. One camera from
//! its views (here rendered by the simulator, with known intrinsics):
//!
//! ```
//! use flexshape_calib::{Board, CalibrationSettings, calibrate, detect};
//! use flexshape_sim::{BoardRenderer, PrintedBoard, PrintedPattern, SimConfig, Simulator};
//!
//! let camera = Simulator::new(SimConfig::default())?.cameras().remove(0);
//! let board = Board::parse("9x6", 20.0)?;
//! let printed = PrintedBoard { cols: 9, rows: 6, square: 20.0, pattern: PrintedPattern::Chessboard };
//! let renderer = BoardRenderer::new(&camera).expect("the lens model covers the image");
//! let mut views = Vec::new();
//! for view in flexshape_sim::calibration_views(std::slice::from_ref(&camera), &printed, 12, 0, 7) {
//!     let image = renderer.render(&printed, &view.pose, 2.0, 1);
//!     if let Ok(found) = detect(&image, &board) {
//!         views.push((view.name, found));
//!     }
//! }
//! let k = &camera.intrinsics;
//! let calibrated = calibrate(&views, k.width, k.height, &CalibrationSettings::default())?;
//! assert!(calibrated.rms_px < 0.3, "{} px", calibrated.rms_px);
//! assert!((calibrated.intrinsics.fx / k.fx - 1.0).abs() < 0.01);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod board;
mod bundle;
mod circles;
mod detect;
mod extrinsics;
pub mod homography;
mod intrinsics;
mod lattice;
pub mod workflow;
pub mod zhang;

use thiserror::Error;

pub use board::{Board, Markers, Pattern};
pub use bundle::{JointIntrinsics, RigAdjustment, RigCamera, adjust_rig};
pub use detect::{Detection, MIN_CHARUCO_CORNERS, detect};
pub use extrinsics::{
    BoardPose, ROTATION_TOLERANCE_DEG, RelativePose, TRANSLATION_TOLERANCE_MM,
    TRANSLATION_TOLERANCE_SHARE, half_turned_views, relative_pose,
};
pub use intrinsics::{Calibration, CalibrationSettings, ViewResult, calibrate};

/// Why a calibration step failed.
#[derive(Debug, Error, PartialEq)]
pub enum CalibError {
    /// The board was not found, or only part of it.
    #[error("board not detected: {0}")]
    NotDetected(String),
    /// Too few usable views.
    #[error("{found} usable views; calibration needs at least {needed}")]
    TooFewViews {
        /// Views with a whole board.
        found: usize,
        /// Needed.
        needed: usize,
    },
    /// The closed-form start failed (degenerate views, e.g. all parallel to the image).
    #[error("closed-form initialisation failed: {0}")]
    Degenerate(String),
    /// Shared views (same instant in two cameras) that disagree about the cameras' relative
    /// pose: they were not taken at the same instant, or a board was misdetected.
    #[error(
        "{} of {views} shared views disagree about where the second camera is ({agreeing} agree with one another, within {ROTATION_TOLERANCE_DEG}° and {TRANSLATION_TOLERANCE_MM} mm or {:.0} % of the baseline)",
        disagreeing.len(),
        100.0 * TRANSLATION_TOLERANCE_SHARE
    )]
    SharedViews {
        /// Indices (in the pairs given) of the views that disagree.
        disagreeing: Vec<usize>,
        /// Views that agree with one another.
        agreeing: usize,
        /// Shared views in all.
        views: usize,
    },
    /// Views of different sizes.
    #[error("view {view} is {found_w}×{found_h} but the first is {width}×{height}")]
    ImageSize {
        /// The view.
        view: String,
        /// Its size.
        found_w: u32,
        /// See `found_w`.
        found_h: u32,
        /// The first view's size.
        width: u32,
        /// See `width`.
        height: u32,
    },
}
