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
//!
//! ```
//! use flexshape_camera::nalgebra::{Point3, Vector3};
//! use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
//!
//! // A 640×480 camera with some barrel distortion, 400 mm from the origin, looking at it.
//! let distortion = Distortion::from_opencv(&[-0.2, 0.05, 0.0, 0.0, 0.0])?;
//! let intrinsics = Intrinsics::new(640, 480, 800.0, 800.0, 319.5, 239.5, distortion)?;
//! let pose = Pose::look_at(Point3::new(0.0, 0.0, -400.0), Point3::origin(), Vector3::y());
//! let camera = Camera::new(intrinsics, pose);
//! let point = Point3::new(10.0, 5.0, 0.0); // world, mm
//! let seen = camera.project(&point)?;
//! assert!((seen.depth - 400.0).abs() < 1e-9);
//! // Back through the lens: the pixel's ray passes through the point.
//! let ray = camera.ray(seen.pixel)?;
//! assert!((point - ray.origin).cross(&ray.direction).norm() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod camera;
mod distortion;
mod error;
mod intrinsics;
mod pose;

pub use camera::{Camera, Projection, Ray};
pub use distortion::{Distortion, UNDISTORT_TOLERANCE};
pub use error::{CameraError, ProjectError, UndistortError};
pub use intrinsics::Intrinsics;
pub use pose::{Pose, ROTATION_TOLERANCE, angle_between};

/// Re-exported so users of this crate name the same nalgebra types.
pub use nalgebra;
