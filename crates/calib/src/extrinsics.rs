//! Cameras of a rig in one frame, from views of the board they saw at the same instant: each
//! shared view gives camera j's pose relative to camera i (`T_j · T_i⁻¹` of the two board
//! poses); the relative poses are averaged (rotations by their chordal mean, translations by
//! their mean) and chained from the reference camera, with the spread over views reported as a
//! consistency check.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::Serialize;

use crate::CalibError;

/// A board pose in one camera: `x_cam = R·X_board + t` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardPose {
    /// Rotation.
    pub rotation: Rotation3<f64>,
    /// Translation, mm.
    pub translation: Vector3<f64>,
}

/// One camera's pose relative to the reference camera, with its consistency.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelativePose {
    /// `x_cam = R·x_ref + t`: rotation (rows) …
    pub rotation: [[f64; 3]; 3],
    /// … and translation, mm.
    pub translation: [f64; 3],
    /// Shared views it rests on.
    pub shared_views: usize,
    /// RMS deviation of the per-view rotations from the mean, degrees.
    pub rotation_spread_deg: f64,
    /// RMS deviation of the per-view translations from the mean, mm.
    pub translation_spread_mm: f64,
}

/// The pose of a camera relative to the reference from the board poses both saw in the same
/// views (`pairs`: reference's pose, this camera's pose).
pub fn relative_pose(pairs: &[(BoardPose, BoardPose)]) -> Result<RelativePose, CalibError> {
    if pairs.is_empty() {
        return Err(CalibError::Degenerate(
            "no view shows the board to both cameras at the same instant; take views both see (same file names)"
                .into(),
        ));
    }
    let each: Vec<(Rotation3<f64>, Vector3<f64>)> = pairs
        .iter()
        .map(|(a, b)| {
            let r = b.rotation * a.rotation.inverse();
            (r, b.translation - r * a.translation)
        })
        .collect();
    // Chordal mean: the rotation nearest the sum of the matrices.
    let sum: Matrix3<f64> = each.iter().map(|(r, _)| *r.matrix()).sum();
    let svd = sum.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CalibError::Degenerate("no mean rotation".into()));
    };
    let d = (u * v_t).determinant().signum();
    let mean = Rotation3::from_matrix_unchecked(
        u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t,
    );
    let t = each.iter().map(|(_, t)| t).sum::<Vector3<f64>>() / each.len() as f64;
    let n = each.len() as f64;
    let rot_spread = (each
        .iter()
        .map(|(r, _)| r.angle_to(&mean).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let t_spread = (each
        .iter()
        .map(|(_, ti)| (ti - t).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    let m = mean.matrix();
    Ok(RelativePose {
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        translation: t.into(),
        shared_views: pairs.len(),
        rotation_spread_deg: rot_spread.to_degrees(),
        translation_spread_mm: t_spread,
    })
}
