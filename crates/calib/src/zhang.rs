//! The closed-form start: focal lengths from the homographies with the principal point at the
//! image centre (the orthogonality of each board's axes, as OpenCV initialises), then each
//! view's pose from `[r1 r2 t] = λ K⁻¹ H`.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

/// Focal lengths `(fx, fy)` in pixels from homographies, with the principal point `(cx, cy)`.
pub fn focal_lengths(homographies: &[Matrix3<f64>], cx: f64, cy: f64) -> Option<(f64, f64)> {
    let shift = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
    let mut a = DMatrix::zeros(2 * homographies.len(), 2);
    let mut b = DVector::zeros(2 * homographies.len());
    for (i, h) in homographies.iter().enumerate() {
        let h = shift * h;
        let (h1, h2) = (h.column(0), h.column(1));
        // h1ᵀ A h2 = 0 and h1ᵀ A h1 = h2ᵀ A h2 with A = diag(1/fx², 1/fy², 1).
        a[(2 * i, 0)] = h1[0] * h2[0];
        a[(2 * i, 1)] = h1[1] * h2[1];
        b[2 * i] = -h1[2] * h2[2];
        a[(2 * i + 1, 0)] = h1[0] * h1[0] - h2[0] * h2[0];
        a[(2 * i + 1, 1)] = h1[1] * h1[1] - h2[1] * h2[1];
        b[2 * i + 1] = -(h1[2] * h1[2] - h2[2] * h2[2]);
    }
    let x = a.svd(true, true).solve(&b, 1e-15).ok()?;
    (x[0] > 0.0 && x[1] > 0.0).then(|| (1.0 / x[0].sqrt(), 1.0 / x[1].sqrt()))
}

/// The board's pose in the camera (rotation, translation in the board's units) from its
/// homography and the camera matrix.
pub fn pose(h: &Matrix3<f64>, k: &Matrix3<f64>) -> Option<(Rotation3<f64>, Vector3<f64>)> {
    let m = k.try_inverse()? * h;
    let mut lambda = 1.0 / m.column(0).norm();
    if m[(2, 2)] * lambda < 0.0 {
        lambda = -lambda; // the board is in front of the camera
    }
    let r1 = m.column(0) * lambda;
    let r2 = m.column(1) * lambda;
    let t = m.column(2) * lambda;
    let r = Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]);
    // The nearest rotation.
    let svd = r.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut rot = u * v_t;
    if rot.determinant() < 0.0 {
        rot = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)) * v_t;
    }
    Some((Rotation3::from_matrix_unchecked(rot), t))
}
