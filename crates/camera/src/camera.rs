//! A calibrated camera: intrinsics plus world → camera pose.

use nalgebra::{Matrix2x3, Point2, Point3, Vector2, Vector3};

use crate::error::{ProjectError, UndistortError};
use crate::intrinsics::Intrinsics;
use crate::pose::Pose;

/// A world point's image: pixel (OpenCV convention) and depth `z_cam` in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Pixel coordinates (u right, v down; (0, 0) = centre of the top-left pixel).
    pub pixel: Point2<f64>,
    /// Depth along the optical axis, mm (always > 0).
    pub depth: f64,
}

/// A half-line in world coordinates (mm): `origin + s · direction`, `s ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start point, the camera centre (world, mm).
    pub origin: Point3<f64>,
    /// Unit direction (world).
    pub direction: Vector3<f64>,
}

impl Ray {
    /// Point at distance `s` mm along the ray.
    pub fn at(&self, s: f64) -> Point3<f64> {
        self.origin + self.direction * s
    }
}

/// A calibrated camera in OpenCV's conventions.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Image size, focal lengths, principal point, distortion.
    pub intrinsics: Intrinsics,
    /// World → camera transform.
    pub pose: Pose,
}

impl Camera {
    /// Combines intrinsics and pose.
    pub fn new(intrinsics: Intrinsics, pose: Pose) -> Self {
        Camera { intrinsics, pose }
    }

    /// Projects a world point (mm) to its pixel and depth, as `cv::projectPoints` does.
    /// Fails for points at or behind the camera and beyond the lens model's fold.
    pub fn project(&self, world: &Point3<f64>) -> Result<Projection, ProjectError> {
        let c = self.pose.to_camera(world);
        let n = self.normalize(&c)?;
        Ok(Projection {
            pixel: self.intrinsics.pixel_from_normalized(n),
            depth: c.z,
        })
    }

    /// Projects a world point and returns `∂(u, v)/∂X_world` (pixels per mm).
    /// `∂(u, v)/∂x_cam`, which is also `∂(u, v)/∂t`, is that times `Rᵀ`.
    pub fn project_with_jacobian(
        &self,
        world: &Point3<f64>,
    ) -> Result<(Projection, Matrix2x3<f64>), ProjectError> {
        let c = self.pose.to_camera(world);
        let n = self.normalize(&c)?;
        let (pixel, j_n) = self.intrinsics.pixel_from_normalized_with_jacobian(n);
        let iz = 1.0 / c.z;
        // ∂(X/Z, Y/Z)/∂(X, Y, Z)
        let j_c = Matrix2x3::new(iz, 0.0, -c.x * iz * iz, 0.0, iz, -c.y * iz * iz);
        let j_world = j_n * j_c * self.pose.rotation.matrix();
        Ok((Projection { pixel, depth: c.z }, j_world))
    }

    fn normalize(&self, c: &Point3<f64>) -> Result<Vector2<f64>, ProjectError> {
        // NaN depths are rejected too.
        if c.z.is_nan() || c.z <= 0.0 {
            return Err(ProjectError::BehindCamera { depth: c.z });
        }
        let n = Vector2::new(c.x / c.z, c.y / c.z);
        let radius = n.norm();
        let valid = self.intrinsics.valid_radius();
        if radius > valid {
            return Err(ProjectError::BeyondDistortionFold { radius, valid });
        }
        Ok(n)
    }

    /// The world ray through a pixel, undistorted by Newton iteration (see
    /// [`crate::UNDISTORT_TOLERANCE`]).
    pub fn ray(&self, pixel: Point2<f64>) -> Result<Ray, UndistortError> {
        let n = self.intrinsics.normalized_from_pixel(pixel)?;
        let dir_cam = Vector3::new(n.x, n.y, 1.0).normalize();
        Ok(Ray {
            origin: self.pose.centre(),
            direction: self.pose.rotation.inverse() * dir_cam,
        })
    }

    /// Camera centre in world coordinates (mm).
    pub fn centre(&self) -> Point3<f64> {
        self.pose.centre()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Distortion;
    use nalgebra::Rotation3;

    fn camera() -> Camera {
        let d = Distortion::from_opencv(&[-0.25, 0.1, 0.001, -0.002, -0.01]).unwrap();
        let k = Intrinsics::new(640, 480, 800.0, 790.0, 322.0, 241.0, d).unwrap();
        let pose = Pose {
            rotation: Rotation3::from_euler_angles(0.1, -0.2, 0.3),
            translation: Vector3::new(10.0, -20.0, 600.0),
        };
        Camera::new(k, pose)
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let cam = camera();
        let p = Point3::new(30.0, -40.0, 25.0);
        let (_, j) = cam.project_with_jacobian(&p).unwrap();
        let h = 1e-4;
        for c in 0..3 {
            let mut e = Vector3::zeros();
            e[c] = h;
            let a = cam.project(&(p + e)).unwrap().pixel;
            let b = cam.project(&(p - e)).unwrap().pixel;
            let fd = (a - b) / (2.0 * h);
            assert!((fd.x - j[(0, c)]).abs() < 1e-6 && (fd.y - j[(1, c)]).abs() < 1e-6);
        }
    }

    #[test]
    fn ray_passes_through_the_point_it_came_from() {
        let cam = camera();
        let p = Point3::new(-50.0, 60.0, 80.0);
        let proj = cam.project(&p).unwrap();
        let ray = cam.ray(proj.pixel).unwrap();
        let s = (p - ray.origin).dot(&ray.direction);
        assert!((ray.at(s) - p).norm() < 1e-8);
    }

    #[test]
    fn behind_camera_is_rejected() {
        let cam = camera();
        let behind = cam.pose.to_world(&Point3::new(0.0, 0.0, -5.0));
        assert!(matches!(
            cam.project(&behind),
            Err(ProjectError::BehindCamera { .. })
        ));
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        assert!(cam.project(&nan).is_err());
    }

    #[test]
    fn far_off_axis_point_beyond_fold_is_rejected() {
        let d = Distortion::from_opencv(&[-0.5, 0.0, 0.0, 0.0]).unwrap();
        let k = Intrinsics::new(640, 480, 500.0, 500.0, 320.0, 240.0, d).unwrap();
        let cam = Camera::new(k, Pose::identity());
        // Normalized radius 2 is far beyond the fold at sqrt(2/3) and would map back on-image.
        let r = cam.project(&Point3::new(200.0, 0.0, 100.0));
        assert!(matches!(r, Err(ProjectError::BeyondDistortionFold { .. })));
    }

    #[test]
    fn pixel_convention_centre_of_top_left_pixel_is_origin() {
        let k = Intrinsics::new(4, 3, 1.0, 1.0, 0.0, 0.0, Distortion::NONE).unwrap();
        assert_eq!(k.pixel_index(Point2::new(0.0, 0.0)), Some((0, 0)));
        assert_eq!(k.pixel_index(Point2::new(-0.5, -0.5)), Some((0, 0)));
        assert_eq!(k.pixel_index(Point2::new(3.49, 2.49)), Some((3, 2)));
        assert_eq!(k.pixel_index(Point2::new(3.5, 0.0)), None);
        assert_eq!(k.pixel_index(Point2::new(-0.51, 0.0)), None);
    }
}
