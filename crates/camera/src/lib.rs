//! Camera models for flexshape, following OpenCV's conventions exactly.
//!
//! - World → camera: `x_cam = R · X_world + t` ([`Pose`]), millimetres, right-handed; the camera
//!   looks along +z, x to the right of the image, y down.
//! - Pixels: `(0, 0)` is the centre of the top-left pixel, so an image of width `W` spans
//!   `u ∈ [-0.5, W - 0.5)`.
//! - Lens distortion: OpenCV's model with `k1, k2, p1, p2, k3`, the rational `k4, k5, k6` and the
//!   thin-prism `s1..s4` ([`Distortion`]).
//!
//! [`Camera`] combines [`Intrinsics`] and [`Pose`] and offers projection with Jacobians and
//! unprojection of a pixel to a world ray.

mod camera;
mod distortion;
mod error;
mod intrinsics;
mod pose;

pub use camera::{Camera, Projection, Ray};
pub use distortion::{Distortion, UNDISTORT_TOLERANCE};
pub use error::{CameraError, ProjectError, UndistortError};
pub use intrinsics::Intrinsics;
pub use pose::{Pose, angle_between};

/// Re-exported so users of this crate name the same nalgebra types.
pub use nalgebra;
