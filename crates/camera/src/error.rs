//! Typed errors of camera construction, projection and unprojection.

use thiserror::Error;

/// A camera parameter is out of its valid range.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CameraError {
    /// A parameter is NaN, infinite or out of range; `name` is the parameter (e.g. `fx`).
    #[error("camera parameter `{name}` = {value} is invalid: {reason}")]
    InvalidParameter {
        /// Parameter name as in OpenCV (`fx`, `k1`, `width`, …).
        name: &'static str,
        /// The offending value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The distortion vector has a length OpenCV does not define.
    #[error(
        "distortion vector has {len} coefficients; OpenCV's model takes 4, 5, 8, 12 or 14 (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tx ty]]]])"
    )]
    DistortionLength {
        /// Number of coefficients given.
        len: usize,
    },
    /// The 14-coefficient model with a tilted sensor is not supported.
    #[error(
        "tilted-sensor distortion (tauX = {tau_x}, tauY = {tau_y}) is not supported; recalibrate without CALIB_TILTED_MODEL"
    )]
    TiltedSensor {
        /// tauX (radians).
        tau_x: f64,
        /// tauY (radians).
        tau_y: f64,
    },
    /// The rotation is not orthonormal with determinant +1.
    #[error("rotation is not a proper rotation matrix: {reason}")]
    NotARotation {
        /// What is wrong (orthonormality error or determinant).
        reason: String,
    },
}

/// Why a world point has no pixel.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
pub enum ProjectError {
    /// The point is at or behind the camera plane (`z_cam ≤ 0`, in mm).
    #[error("point is behind the camera (depth {depth} mm)")]
    BehindCamera {
        /// Depth `z_cam` of the point in mm.
        depth: f64,
    },
    /// The point lies beyond the radius where the distortion polynomial folds back, so its pixel
    /// would be meaningless (a far off-axis point would land inside the image).
    #[error(
        "point is at normalized radius {radius:.3}, beyond the lens model's valid radius {valid:.3}"
    )]
    BeyondDistortionFold {
        /// Normalized radius `sqrt(x² + y²)` of the point.
        radius: f64,
        /// Largest radius where the radial distortion is still monotonic.
        valid: f64,
    },
}

/// Why a pixel could not be undistorted.
#[derive(Debug, Error, Clone, Copy, PartialEq)]
pub enum UndistortError {
    /// Newton iteration did not reach [`crate::UNDISTORT_TOLERANCE`].
    #[error(
        "undistortion of pixel ({u:.2}, {v:.2}) did not converge (residual {residual:e} in normalized units)"
    )]
    NotConverged {
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
        /// Remaining residual `|distort(x) - x_d|`.
        residual: f64,
    },
    /// The pixel lies where the lens model is not invertible (beyond its fold).
    #[error("pixel ({u:.2}, {v:.2}) lies where the lens distortion model is not invertible")]
    NotInvertible {
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
    },
}
