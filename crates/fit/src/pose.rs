//! How a camera's pose moves the outline: the Jacobian of an outline residual by a small
//! change of the pose, for fitting poses and tubes together ([`crate::bundle`]).
//!
//! The change is a rotation `ω` (radians) and a translation `τ` (mm), both in the camera
//! frame, applied after the pose: `x_cam' = exp(ω)·x_cam + τ`, i.e. `R' = exp(ω)·R`,
//! `t' = exp(ω)·t + τ`. Rotations are scaled by a depth (mm), so that both kinds of parameter
//! are millimetres at the tube and one damping suits them.
//!
//! The outline's grazing point slides over the surface as the camera moves, but only along
//! the surface: to first order the outline's distance from its boundary does not change, so
//! the point is held fixed (as the tube's own Jacobian holds it).

use flexshape_camera::{Camera, Pose};
use nalgebra::{Point3, Vector2, Vector3, Vector6};

/// `pose` moved by `step` (rotation scaled by `depth` mm, then translation mm; camera frame).
pub(crate) fn moved(pose: &Pose, step: &Vector6<f64>, depth: f64) -> Pose {
    let omega = Vector3::new(step[0], step[1], step[2]) / depth;
    pose.moved_by(omega, Vector3::new(step[3], step[4], step[5]))
}

/// The derivative of `normal · pixel(world)` by the pose change (scaled by `depth`), pixels
/// per mm; `None` when the camera cannot project the point.
pub(crate) fn pose_row(
    camera: &Camera,
    world: &Point3<f64>,
    normal: &Vector2<f64>,
    depth: f64,
) -> Option<Vector6<f64>> {
    let (_, j_world) = camera.project_with_jacobian(world).ok()?;
    // ∂pixel/∂x_cam = ∂pixel/∂X · Rᵀ, along the normal.
    let d = (normal.transpose() * j_world * camera.pose.rotation.matrix().transpose()).transpose();
    let x = camera.pose.to_camera(world).coords;
    // ∂x_cam/∂ω = −[x]×, and dᵀ(ω × x) = ωᵀ(x × d).
    let dw = x.cross(&d) / depth;
    Some(Vector6::new(dw[0], dw[1], dw[2], d[0], d[1], d[2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_camera::{Distortion, Intrinsics};

    #[test]
    fn the_pose_row_is_the_derivative_of_the_projection() {
        let d = Distortion::from_opencv(&[-0.2, 0.08, 0.001, -0.001, -0.01]).unwrap();
        let k = Intrinsics::new(640, 480, 800.0, 800.0, 320.0, 240.0, d).unwrap();
        let pose = Pose::look_at(
            Point3::new(40.0, -600.0, 30.0),
            Point3::origin(),
            Vector3::z(),
        );
        let camera = Camera::new(k, pose);
        let world = Point3::new(30.0, 20.0, -50.0);
        let normal = Vector2::new(0.6, -0.8);
        let depth = 600.0;
        let row = pose_row(&camera, &world, &normal, depth).unwrap();
        let f = |c: &Camera| normal.dot(&c.project(&world).unwrap().pixel.coords);
        let h = 1e-4;
        for k in 0..6 {
            let mut step = Vector6::zeros();
            step[k] = h;
            let plus = Camera::new(camera.intrinsics.clone(), moved(&pose, &step, depth));
            step[k] = -h;
            let minus = Camera::new(camera.intrinsics.clone(), moved(&pose, &step, depth));
            let numeric = (f(&plus) - f(&minus)) / (2.0 * h);
            assert!(
                (numeric - row[k]).abs() < 1e-5 * (1.0 + numeric.abs()),
                "parameter {k}: {numeric} against {}",
                row[k]
            );
        }
    }
}
