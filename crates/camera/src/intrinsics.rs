//! Image size, pinhole parameters and lens distortion of one camera.

use nalgebra::{Matrix2, Matrix3, Point2, Vector2};

use crate::distortion::Distortion;
use crate::error::{CameraError, UndistortError};

/// Normalized radius up to which the lens model's validity is searched (≈ 84° off-axis).
const FOLD_SEARCH_LIMIT: f64 = 10.0;

/// Intrinsic parameters in OpenCV's meaning: focal lengths and principal point in pixels
/// (pixel (0, 0) is the centre of the top-left pixel), image size in pixels, and lens distortion.
/// Skew is not modelled (OpenCV's `projectPoints` ignores it).
#[derive(Debug, Clone, PartialEq)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point column, pixels.
    pub cx: f64,
    /// Principal point row, pixels.
    pub cy: f64,
    /// Lens distortion on normalized coordinates.
    pub distortion: Distortion,
    /// Largest normalized radius where the radial distortion is monotonic (derived).
    valid_radius: f64,
}

impl Intrinsics {
    /// Validated constructor: positive finite focal lengths, finite principal point, non-zero
    /// image size.
    pub fn new(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        distortion: Distortion,
    ) -> Result<Self, CameraError> {
        let positive = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(CameraError::InvalidParameter {
                    name,
                    value,
                    reason: "focal length must be positive and finite",
                })
            }
        };
        positive("fx", fx)?;
        positive("fy", fy)?;
        for (name, value) in [("cx", cx), ("cy", cy)] {
            if !value.is_finite() {
                return Err(CameraError::InvalidParameter {
                    name,
                    value,
                    reason: "principal point must be finite",
                });
            }
        }
        for (name, value) in [("width", width), ("height", height)] {
            if value == 0 {
                return Err(CameraError::InvalidParameter {
                    name,
                    value: 0.0,
                    reason: "image size must be at least 1 pixel",
                });
            }
        }
        Ok(Intrinsics {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            distortion,
            valid_radius: distortion.monotonic_radius(FOLD_SEARCH_LIMIT),
        })
    }

    /// From a 3×3 camera matrix `[fx 0 cx; 0 fy cy; 0 0 1]`. Skew above 1e-9·fx and a last row
    /// other than `[0 0 1]` are rejected.
    pub fn from_matrix(
        width: u32,
        height: u32,
        k: &Matrix3<f64>,
        distortion: Distortion,
    ) -> Result<Self, CameraError> {
        let skew = k[(0, 1)];
        if !skew.is_finite() || skew.abs() > 1e-9 * k[(0, 0)].abs().max(1.0) {
            return Err(CameraError::InvalidParameter {
                name: "skew",
                value: skew,
                reason: "camera_matrix[0][1] must be 0: OpenCV's model has no skew",
            });
        }
        let bottom = [k[(1, 0)], k[(2, 0)], k[(2, 1)], k[(2, 2)]];
        if bottom != [0.0, 0.0, 0.0, 1.0] {
            return Err(CameraError::InvalidParameter {
                name: "camera_matrix",
                value: k[(2, 2)],
                reason: "camera matrix must have the form [fx 0 cx; 0 fy cy; 0 0 1]",
            });
        }
        Self::new(
            width,
            height,
            k[(0, 0)],
            k[(1, 1)],
            k[(0, 2)],
            k[(1, 2)],
            distortion,
        )
    }

    /// The camera matrix `K = [fx 0 cx; 0 fy cy; 0 0 1]`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Largest normalized radius `sqrt(x² + y²)` where the lens model is one-to-one; points
    /// beyond it are not projected.
    pub fn valid_radius(&self) -> f64 {
        self.valid_radius
    }

    /// Normalized point (x = X/Z, y = Y/Z) → distorted pixel.
    pub fn pixel_from_normalized(&self, n: Vector2<f64>) -> Point2<f64> {
        let d = self.distortion.distort(n);
        Point2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy)
    }

    /// Normalized point → pixel and `∂pixel/∂(x, y)`.
    pub fn pixel_from_normalized_with_jacobian(
        &self,
        n: Vector2<f64>,
    ) -> (Point2<f64>, Matrix2<f64>) {
        let (d, j) = self.distortion.distort_with_jacobian(n);
        let scale = Matrix2::new(self.fx, 0.0, 0.0, self.fy);
        (
            Point2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy),
            scale * j,
        )
    }

    /// Pixel → undistorted normalized point, by Newton iteration to
    /// [`crate::UNDISTORT_TOLERANCE`].
    pub fn normalized_from_pixel(&self, px: Point2<f64>) -> Result<Vector2<f64>, UndistortError> {
        let d = Vector2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        self.distortion
            .undistort(d, self.valid_radius, (px.x, px.y))
    }

    /// Pixel → normalized point, with Newton started at `guess` (a neighbour's solution); falls
    /// back to [`Intrinsics::normalized_from_pixel`] if that does not converge.
    pub fn normalized_from_pixel_near(
        &self,
        px: Point2<f64>,
        guess: Vector2<f64>,
    ) -> Result<Vector2<f64>, UndistortError> {
        let d = Vector2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        self.distortion
            .undistort_from(d, guess, self.valid_radius, (px.x, px.y))
            .or_else(|_| self.normalized_from_pixel(px))
    }

    /// True when `px` lies on the image: `u ∈ [−0.5, width − 0.5)`, `v ∈ [−0.5, height − 0.5)`.
    pub fn contains(&self, px: Point2<f64>) -> bool {
        px.x >= -0.5
            && px.y >= -0.5
            && px.x < self.width as f64 - 0.5
            && px.y < self.height as f64 - 0.5
    }

    /// Column and row of the pixel containing `px`, if it is on the image.
    pub fn pixel_index(&self, px: Point2<f64>) -> Option<(u32, u32)> {
        self.contains(px)
            .then(|| ((px.x + 0.5).floor() as u32, (px.y + 0.5).floor() as u32))
    }
}
