//! A camera's pose refined against tubes fitted in many frames: each boundary the fit found
//! is a point on the tube's surface (the grazing point of its outline) that this camera must
//! project onto the measured boundary line. Moving the camera moves every outline; the pose
//! that puts them on their boundaries, over frames of different shapes, is the one the images
//! agree with (`flexshape rig refine`).
//!
//! The grazing point slides over the surface as the camera moves, but only along the
//! surface: to first order the outline's distance from its boundary does not change, so the
//! points are held fixed (as the fit's own Jacobian holds them).
//!
//! Parameters: a rotation `ω` (radians, camera frame) and a translation `τ` (mm, camera
//! frame), applied after the pose: `x_cam' = exp(ω)·x_cam + τ`, i.e. `R' = exp(ω)·R`,
//! `t' = exp(ω)·t + τ`. Residuals: pixels along the outline normal, Huber-weighted.

use flexshape_camera::{Camera, Pose};
use nalgebra::{Matrix6, Point3, Rotation3, Vector2, Vector3, Vector6};

use crate::solve::huber;

/// A boundary found by the fit, as a camera's pose sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeSample {
    /// The tube's surface point whose image is the outline there (world, mm).
    pub world: Point3<f64>,
    /// The measured boundary (pixel, OpenCV convention).
    pub edge: Vector2<f64>,
    /// Unit image normal of the outline there, out of the tube's image.
    pub normal: Vector2<f64>,
    /// Share of an independent measurement the sample is (outline pixels it stands for, ≤ 1).
    pub weight: f64,
}

/// A camera's pose refined against [`EdgeSample`]s.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseFit {
    /// The camera with its refined pose (intrinsics unchanged).
    pub camera: Camera,
    /// Weighted RMS of the samples' residuals before, pixels.
    pub rms_before: f64,
    /// And after, pixels.
    pub rms_after: f64,
    /// Samples used.
    pub samples: usize,
    /// Angle of the rotation between the two poses, radians.
    pub rotation_rad: f64,
    /// How far the camera centre moved, mm (world).
    pub centre_moved_mm: f64,
}

/// Levenberg–Marquardt steps at most.
const STEPS: usize = 50;

/// A step moving no sample by more than this ends the iterations, pixels.
const CONVERGED_PX: f64 = 1e-4;

/// The pose of `camera` that best puts `samples` on their boundaries, Huber-weighted with
/// threshold `huber_px`. `None` with fewer than 12 samples (a pose has 6 degrees of freedom,
/// and outline samples come in correlated pairs).
pub fn refine_pose(camera: &Camera, samples: &[EdgeSample], huber_px: f64) -> Option<PoseFit> {
    if samples.len() < 12 {
        return None;
    }
    // Rotations are scaled by the samples' mean depth so that both kinds of parameter are in
    // millimetres at the tube, and one damping suits them.
    let depth = samples
        .iter()
        .map(|s| camera.pose.to_camera(&s.world).z)
        .filter(|z| z.is_finite() && *z > 0.0)
        .sum::<f64>()
        / samples.len() as f64;
    if depth.is_nan() || depth <= 0.0 {
        return None;
    }
    let rms_before = rms(camera, samples)?;
    let mut current = camera.clone();
    let mut cost = robust_cost(&current, samples, huber_px)?;
    let mut lambda = 1e-3;
    for _ in 0..STEPS {
        let (h, g) = normal_equations(&current, samples, huber_px, depth);
        let mut damped = h;
        for k in 0..6 {
            damped[(k, k)] += lambda * h[(k, k)].max(1e-9);
        }
        let Some(chol) = damped.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let step = -chol.solve(&g);
        let trial = Camera::new(
            current.intrinsics.clone(),
            moved(&current.pose, &step, depth),
        );
        match robust_cost(&trial, samples, huber_px) {
            Some(c) if c <= cost => {
                // How far the step moved the samples' images, at most (to first order).
                let moved_px = (h * step).dot(&step).max(0.0).sqrt()
                    / samples
                        .iter()
                        .map(|s| s.weight)
                        .sum::<f64>()
                        .max(1e-9)
                        .sqrt();
                current = trial;
                cost = c;
                lambda = (lambda / 3.0).max(1e-9);
                if moved_px < CONVERGED_PX {
                    break;
                }
            }
            _ => {
                lambda *= 4.0;
                if lambda > 1e6 {
                    break;
                }
            }
        }
    }
    let rms_after = rms(&current, samples)?;
    let rotation = current.pose.rotation * camera.pose.rotation.inverse();
    Some(PoseFit {
        rotation_rad: rotation.angle(),
        centre_moved_mm: (current.centre() - camera.centre()).norm(),
        camera: current,
        rms_before,
        rms_after,
        samples: samples.len(),
    })
}

/// `pose` moved by `step` (rotation scaled by `depth`, then translation; camera frame).
fn moved(pose: &Pose, step: &Vector6<f64>, depth: f64) -> Pose {
    let omega = Vector3::new(step[0], step[1], step[2]) / depth;
    let tau = Vector3::new(step[3], step[4], step[5]);
    let r = Rotation3::from_scaled_axis(omega);
    Pose {
        rotation: r * pose.rotation,
        translation: r * pose.translation + tau,
    }
}

/// Residual of one sample along its normal, pixels (`None`: the camera cannot project it).
fn residual(camera: &Camera, s: &EdgeSample) -> Option<f64> {
    let p = camera.project(&s.world).ok()?;
    Some(s.normal.dot(&(p.pixel.coords - s.edge)))
}

/// Weighted RMS of the residuals, pixels.
fn rms(camera: &Camera, samples: &[EdgeSample]) -> Option<f64> {
    let (mut sum, mut w) = (0.0, 0.0);
    for s in samples {
        let r = residual(camera, s)?;
        sum += s.weight * r * r;
        w += s.weight;
    }
    (w > 0.0).then(|| (sum / w).sqrt())
}

/// Huber cost of the residuals (`None` when a sample cannot be projected: the step went too
/// far).
fn robust_cost(camera: &Camera, samples: &[EdgeSample], k: f64) -> Option<f64> {
    samples.iter().try_fold(0.0, |acc, s| {
        let r = residual(camera, s)?.abs();
        let rho = if r <= k { r * r } else { k * (2.0 * r - k) };
        Some(acc + s.weight * rho)
    })
}

/// Gauss–Newton normal equations `H δ = −g` of the Huber-weighted residuals in the scaled
/// parameters.
fn normal_equations(
    camera: &Camera,
    samples: &[EdgeSample],
    k: f64,
    depth: f64,
) -> (Matrix6<f64>, Vector6<f64>) {
    let mut h = Matrix6::zeros();
    let mut g = Vector6::zeros();
    let rt = camera.pose.rotation.matrix().transpose();
    for s in samples {
        let Ok((p, j_world)) = camera.project_with_jacobian(&s.world) else {
            continue;
        };
        let r = s.normal.dot(&(p.pixel.coords - s.edge));
        // ∂pixel/∂x_cam, along the normal.
        let d = (s.normal.transpose() * j_world * rt).transpose();
        let x = camera.pose.to_camera(&s.world).coords;
        // ∂x_cam/∂ω = −[x]×, and dᵀ(ω × x) = ωᵀ(x × d).
        let dw = x.cross(&d) / depth;
        let a = Vector6::new(dw[0], dw[1], dw[2], d[0], d[1], d[2]);
        let w = s.weight * huber(r, k);
        h += a * a.transpose() * w;
        g += a * (w * r);
    }
    (h, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_camera::{Distortion, Intrinsics};

    fn camera() -> Camera {
        let d = Distortion::from_opencv(&[-0.2, 0.08, 0.001, -0.001, -0.01]).unwrap();
        let k = Intrinsics::new(640, 480, 800.0, 800.0, 320.0, 240.0, d).unwrap();
        Camera::new(
            k,
            Pose::look_at(
                Point3::new(40.0, -600.0, 30.0),
                Point3::origin(),
                Vector3::z(),
            ),
        )
    }

    /// Samples of a curved 3-D "outline" seen by `truth`: points on a helix with image normals
    /// in many directions, their boundaries where `truth` projects them.
    fn samples(truth: &Camera) -> Vec<EdgeSample> {
        (0..200)
            .map(|i| {
                let a = i as f64 * 0.05;
                let world = Point3::new(40.0 * a.cos(), 30.0 * a.sin(), -60.0 + 0.6 * i as f64);
                let edge = truth.project(&world).unwrap().pixel.coords;
                let normal = Vector2::new(a.cos(), a.sin());
                EdgeSample {
                    world,
                    edge,
                    normal,
                    weight: 1.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_disturbed_pose_returns_to_the_one_the_boundaries_show() {
        let truth = camera();
        let data = samples(&truth);
        let mut off = truth.clone();
        off.pose = moved(
            &truth.pose,
            &Vector6::new(1.5, -1.0, 0.8, 0.7, -0.4, 1.2),
            600.0,
        );
        let fit = refine_pose(&off, &data, 0.5).unwrap();
        assert!(fit.rms_before > 1.0, "{}", fit.rms_before);
        assert!(fit.rms_after < 1e-3, "{}", fit.rms_after);
        let back = fit.camera.pose.rotation * truth.pose.rotation.inverse();
        assert!(back.angle() < 1e-5, "{}", back.angle());
        assert!((fit.camera.centre() - truth.centre()).norm() < 0.01);
    }

    #[test]
    fn outliers_do_not_pull_the_pose() {
        let truth = camera();
        let mut data = samples(&truth);
        for s in data.iter_mut().step_by(10) {
            s.edge += s.normal * 8.0;
        }
        let fit = refine_pose(&truth, &data, 0.5).unwrap();
        // A tenth of the samples 8 px off, all to one side, move the images of the points by
        // 0.09 px (least squares: 0.8). A rotation and a translation that nearly cancel at
        // the tube may move the camera more.
        let worst = data
            .iter()
            .map(|s| {
                let a = truth.project(&s.world).unwrap().pixel;
                let b = fit.camera.project(&s.world).unwrap().pixel;
                (a - b).norm()
            })
            .fold(0.0, f64::max);
        assert!(worst < 0.15, "{worst}");
    }

    #[test]
    fn too_few_samples_give_no_pose() {
        let truth = camera();
        let data = samples(&truth);
        assert!(refine_pose(&truth, &data[..11], 0.5).is_none());
        assert!(refine_pose(&truth, &data[..12], 0.5).is_some());
    }
}
