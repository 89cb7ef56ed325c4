//! Plane-to-image homographies by the normalised direct linear transform.

use nalgebra::{DMatrix, Matrix3, Point2};

/// The homography `H` with `pixel ~ H·(x, y, 1)` from board-plane points (mm) to pixels, or
/// `None` when the points are degenerate (fewer than 4, or collinear).
pub fn fit(plane: &[Point2<f64>], pixels: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    if plane.len() < 4 || plane.len() != pixels.len() {
        return None;
    }
    let (tp, tq) = (normaliser(plane)?, normaliser(pixels)?);
    let mut a = DMatrix::zeros(2 * plane.len(), 9);
    for (i, (p, q)) in plane.iter().zip(pixels).enumerate() {
        let p = tp * p.to_homogeneous();
        let q = tq * q.to_homogeneous();
        let (x, y, u, v) = (p.x, p.y, q.x, q.y);
        a.row_mut(2 * i)
            .copy_from_slice(&[-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u]);
        a.row_mut(2 * i + 1)
            .copy_from_slice(&[0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v]);
    }
    // The right singular vector of the smallest singular value: via AᵀA (9 × 9).
    let ata = a.transpose() * &a;
    let eig = ata.symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let h = eig.eigenvectors.column(k);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = tq.try_inverse()? * hn * tp;
    let scale = h[(2, 2)];
    (scale.abs() > 1e-12).then(|| h / scale)
}

/// Hartley's normalisation: centroid to the origin, mean distance √2.
fn normaliser(points: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.x / n, y + p.y / n));
    let d = points
        .iter()
        .map(|p| (p.x - mx).hypot(p.y - my))
        .sum::<f64>()
        / n;
    (d > 1e-12).then(|| {
        let s = 2f64.sqrt() / d;
        Matrix3::new(s, 0.0, -s * mx, 0.0, s, -s * my, 0.0, 0.0, 1.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_homography() {
        let h = Matrix3::new(1.2, 0.1, 320.0, -0.05, 0.9, 240.0, 1e-4, 2e-4, 1.0);
        let plane: Vec<Point2<f64>> = (0..20)
            .map(|i| Point2::new((i % 5) as f64 * 20.0, (i / 5) as f64 * 20.0))
            .collect();
        let pixels: Vec<Point2<f64>> = plane
            .iter()
            .map(|p| Point2::from_homogeneous(h * p.to_homogeneous()).unwrap())
            .collect();
        let got = fit(&plane, &pixels).unwrap();
        assert!((got - h).norm() < 1e-8 * h.norm(), "{got}");
        let line: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(i as f64, 0.0)).collect();
        assert!(fit(&line, &line).is_none() || fit(&plane[..3], &pixels[..3]).is_none());
    }
}
