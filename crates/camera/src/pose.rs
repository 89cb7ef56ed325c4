//! The one rigid transform of flexshape, in OpenCV's convention: a camera's pose (world →
//! camera), a board's pose in a camera (board → camera), a registration (source → target).

use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::CameraError;

/// Tolerance on `‖RᵀR − I‖∞` and `|det R − 1|` for a matrix to count as a rotation.
pub const ROTATION_TOLERANCE: f64 = 1e-6;

/// The angle between two rotations, radians: from the quaternion of `a⁻¹·b` by `atan2`, exact
/// where `acos` of the trace is not (nalgebra's `Rotation3::angle` gives NaN for rotations a
/// rounding error apart).
pub fn angle_between(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&(a.inverse() * b));
    2.0 * q.imag().norm().atan2(q.scalar().abs())
}

/// A rigid transform `x_to = R · x_from + t`, `t` in mm. As a camera's pose it maps world to
/// camera (`x_cam = R · X_world + t`, OpenCV's convention), the sense the methods' names
/// use; as a board's pose, board to camera; as a registration, source to target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// `R`: rotates world vectors into the camera frame.
    pub rotation: Rotation3<f64>,
    /// `t`: the world origin expressed in the camera frame, mm.
    pub translation: Vector3<f64>,
}

impl Pose {
    /// The camera at the world origin looking along world +z.
    pub fn identity() -> Self {
        Pose {
            rotation: Rotation3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// From a Rodrigues vector (axis × angle, radians) and a translation in mm, as OpenCV's
    /// `rvec`/`tvec`.
    pub fn from_rvec_tvec(rvec: Vector3<f64>, tvec: Vector3<f64>) -> Self {
        Pose {
            rotation: Rotation3::from_scaled_axis(rvec),
            translation: tvec,
        }
    }

    /// From a 3×3 matrix that must be a proper rotation (orthonormal within
    /// [`ROTATION_TOLERANCE`], determinant +1). A matrix orthonormal to 1e-12 is kept as is (so
    /// files round-trip bit for bit); a less exact one is re-orthonormalized.
    pub fn from_matrix(r: &Matrix3<f64>, t: Vector3<f64>) -> Result<Self, CameraError> {
        if r.iter().chain(t.iter()).any(|v| !v.is_finite()) {
            return Err(CameraError::NotARotation {
                reason: "contains NaN or infinity".into(),
            });
        }
        let ortho = (r.transpose() * r - Matrix3::identity()).amax();
        if ortho > ROTATION_TOLERANCE {
            return Err(CameraError::NotARotation {
                reason: format!("‖RᵀR − I‖ = {ortho:.2e} exceeds {ROTATION_TOLERANCE:e}"),
            });
        }
        let det = r.determinant();
        if (det - 1.0).abs() > ROTATION_TOLERANCE {
            return Err(CameraError::NotARotation {
                reason: format!("determinant is {det:.6}, not +1 (a reflection?)"),
            });
        }
        let rotation = if ortho < 1e-12 {
            Rotation3::from_matrix_unchecked(*r)
        } else {
            Rotation3::from_matrix(r)
        };
        Ok(Pose {
            rotation,
            translation: t,
        })
    }

    /// Looking from `centre` (world, mm) at `target`, with `up` (world) pointing to the top of
    /// the image (image y points down, so camera −y follows `up`).
    pub fn look_at(centre: Point3<f64>, target: Point3<f64>, up: Vector3<f64>) -> Self {
        let z = (target - centre).normalize();
        let x = z.cross(&up).normalize();
        let y = z.cross(&x);
        let r = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
        let rotation = Rotation3::from_matrix_unchecked(r);
        Pose {
            rotation,
            translation: -(rotation * centre.coords),
        }
    }

    /// Rodrigues vector of `R` (radians), as OpenCV's `rvec`.
    pub fn rvec(&self) -> Vector3<f64> {
        self.rotation.scaled_axis()
    }

    /// World point → camera coordinates (mm).
    pub fn to_camera(&self, p: &Point3<f64>) -> Point3<f64> {
        self.rotation * p + self.translation
    }

    /// Camera-frame point → world coordinates (mm).
    pub fn to_world(&self, p: &Point3<f64>) -> Point3<f64> {
        self.rotation.inverse() * (p - self.translation)
    }

    /// A point mapped by the transform, `R·p + t` (mm); for a camera pose, [`Pose::to_camera`].
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        self.rotation * p + self.translation
    }

    /// The inverse transform (camera → world for a camera pose).
    pub fn inverse(&self) -> Self {
        let r = self.rotation.inverse();
        Pose {
            rotation: r,
            translation: -(r * self.translation),
        }
    }

    /// This transform after `first`: `x ↦ self(first(x))`.
    pub fn then(&self, first: &Pose) -> Pose {
        Pose {
            rotation: self.rotation * first.rotation,
            translation: self.rotation * first.translation + self.translation,
        }
    }

    /// This pose moved by a small change applied after it: the turn by `rotation_vector`
    /// (axis × angle, radians) then the shift `translation` (mm), both in the frame the pose
    /// maps into, `x ↦ δR·(R·x + t) + τ`. The update of every pose fit (camera poses against
    /// outlines, registrations).
    pub fn moved_by(&self, rotation_vector: Vector3<f64>, translation: Vector3<f64>) -> Pose {
        let turn = Rotation3::from_scaled_axis(rotation_vector);
        Pose {
            rotation: turn * self.rotation,
            translation: turn * self.translation + translation,
        }
    }

    /// Camera centre in world coordinates, `−Rᵀ t` (mm).
    pub fn centre(&self) -> Point3<f64> {
        Point3::from(-(self.rotation.inverse() * self.translation))
    }

    /// Viewing direction (camera +z) in world coordinates, unit length.
    pub fn optical_axis(&self) -> Vector3<f64> {
        self.rotation.inverse() * Vector3::z()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_moved_by_a_small_change_turns_then_shifts_what_it_maps() {
        let pose =
            Pose::from_rvec_tvec(Vector3::new(0.2, -0.1, 0.4), Vector3::new(5.0, -3.0, 400.0));
        let (omega, tau) = (
            Vector3::new(0.01, -0.02, 0.005),
            Vector3::new(0.3, 0.1, -0.2),
        );
        let moved = pose.moved_by(omega, tau);
        let x = Point3::new(12.0, -40.0, 7.0);
        let expected = Rotation3::from_scaled_axis(omega) * pose.apply(&x) + tau;
        assert!((moved.apply(&x) - expected).norm() < 1e-9);
        assert_eq!(pose.moved_by(Vector3::zeros(), Vector3::zeros()), pose);
    }

    #[test]
    fn inverse_and_then_compose_as_maps() {
        let a = Pose::from_rvec_tvec(Vector3::new(0.2, -0.4, 1.1), Vector3::new(3.0, -7.0, 40.0));
        let b = Pose::from_rvec_tvec(Vector3::new(-0.9, 0.1, 0.3), Vector3::new(-5.0, 2.0, 9.0));
        let p = Point3::new(1.5, -2.5, 7.0);
        assert!((a.then(&b).apply(&p) - a.apply(&b.apply(&p))).norm() < 1e-12);
        assert!((a.inverse().apply(&a.apply(&p)) - p).norm() < 1e-12);
        assert!((a.inverse().apply(&p) - a.to_world(&p)).norm() < 1e-12);
    }

    #[test]
    fn the_angle_between_equal_rotations_is_zero_not_nan() {
        let r = Rotation3::from_euler_angles(0.3, -1.2, 2.9);
        assert_eq!(angle_between(&r, &r), 0.0);
        let turned = r * Rotation3::from_axis_angle(&Vector3::z_axis(), 0.25);
        assert!((angle_between(&r, &turned) - 0.25).abs() < 1e-12);
        assert!((angle_between(&turned, &r) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn look_at_sees_target_on_axis_and_up_is_image_up() {
        let pose = Pose::look_at(Point3::new(600.0, 0.0, 0.0), Point3::origin(), Vector3::z());
        let t = pose.to_camera(&Point3::origin());
        assert!(t.x.abs() < 1e-12 && t.y.abs() < 1e-12 && (t.z - 600.0).abs() < 1e-12);
        let up = pose.to_camera(&Point3::new(0.0, 0.0, 10.0));
        assert!(up.y < 0.0, "world up must be image up (negative y)");
        assert!((pose.centre() - Point3::new(600.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((pose.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_reflection_and_non_orthonormal() {
        let refl = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!(Pose::from_matrix(&refl, Vector3::zeros()).is_err());
        let skew = Matrix3::new(1.0, 0.01, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(Pose::from_matrix(&skew, Vector3::zeros()).is_err());
        let rot = Rotation3::from_euler_angles(0.1, -0.4, 2.0);
        let pose = Pose::from_matrix(rot.matrix(), Vector3::new(1.0, 2.0, 3.0)).unwrap();
        let back = Pose::from_rvec_tvec(pose.rvec(), pose.translation);
        assert!((back.rotation.matrix() - rot.matrix()).amax() < 1e-12);
    }
}
