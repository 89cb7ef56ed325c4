//! OpenCV's lens distortion model on normalized image coordinates.
//!
//! For a normalized point `(x, y) = (X/Z, Y/Z)` with `r² = x² + y²`:
//!
//! ```text
//! g  = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
//! x' = x g + 2 p1 x y + p2 (r² + 2 x²) + s1 r² + s2 r⁴
//! y' = y g + p1 (r² + 2 y²) + 2 p2 x y + s3 r² + s4 r⁴
//! ```
//!
//! exactly as `cv::projectPoints` computes it. The tilted-sensor terms (τx, τy) are not supported.

use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

use crate::error::{CameraError, UndistortError};

/// Newton iterations stop when `|distort(x) - x_d|∞` is below this, in normalized units
/// (1e-12 ≈ 1e-9 px for a focal length of 1000 px).
pub const UNDISTORT_TOLERANCE: f64 = 1e-12;

const MAX_NEWTON_ITERATIONS: usize = 60;

/// Lens distortion coefficients in OpenCV's order and meaning (dimensionless, on normalized
/// coordinates). All zero means an ideal pinhole.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Distortion {
    /// Radial numerator `[k1, k2, k3]`.
    pub radial: [f64; 3],
    /// Rational denominator `[k4, k5, k6]`.
    pub rational: [f64; 3],
    /// Tangential `[p1, p2]`.
    pub tangential: [f64; 2],
    /// Thin prism `[s1, s2, s3, s4]`.
    pub prism: [f64; 4],
}

impl Distortion {
    /// No distortion.
    pub const NONE: Distortion = Distortion {
        radial: [0.0; 3],
        rational: [0.0; 3],
        tangential: [0.0; 2],
        prism: [0.0; 4],
    };

    /// Builds the model from OpenCV's coefficient vector
    /// `k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [τx τy]]]]` (length 0, 4, 5, 8, 12 or 14).
    /// A 14-vector is accepted only with τx = τy = 0.
    pub fn from_opencv(c: &[f64]) -> Result<Self, CameraError> {
        if !matches!(c.len(), 0 | 4 | 5 | 8 | 12 | 14) {
            return Err(CameraError::DistortionLength { len: c.len() });
        }
        const NAMES: [&str; 14] = [
            "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tauX", "tauY",
        ];
        for (name, &value) in NAMES.iter().zip(c) {
            if !value.is_finite() {
                return Err(CameraError::InvalidParameter {
                    name,
                    value,
                    reason: "distortion coefficients must be finite",
                });
            }
        }
        if c.len() == 14 && (c[12] != 0.0 || c[13] != 0.0) {
            return Err(CameraError::TiltedSensor {
                tau_x: c[12],
                tau_y: c[13],
            });
        }
        let at = |i: usize| c.get(i).copied().unwrap_or(0.0);
        Ok(Distortion {
            radial: [at(0), at(1), at(4)],
            tangential: [at(2), at(3)],
            rational: [at(5), at(6), at(7)],
            prism: [at(8), at(9), at(10), at(11)],
        })
    }

    /// OpenCV's coefficient vector, in the shortest of the lengths 5, 8 or 12 that holds every
    /// non-zero coefficient.
    pub fn to_opencv(&self) -> Vec<f64> {
        let [k1, k2, k3] = self.radial;
        let [p1, p2] = self.tangential;
        let mut c = vec![k1, k2, p1, p2, k3];
        if self.rational != [0.0; 3] || self.prism != [0.0; 4] {
            c.extend_from_slice(&self.rational);
        }
        if self.prism != [0.0; 4] {
            c.extend_from_slice(&self.prism);
        }
        c
    }

    /// Radial factor `g(r²)` and its derivative `dg/d(r²)`.
    fn radial_factor(&self, r2: f64) -> (f64, f64) {
        let [k1, k2, k3] = self.radial;
        let [k4, k5, k6] = self.rational;
        let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
        let dnum = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
        let dden = k4 + r2 * (2.0 * k5 + r2 * 3.0 * k6);
        (num / den, (dnum * den - num * dden) / (den * den))
    }

    /// Applies the distortion to a normalized point.
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        self.distort_with_jacobian(p).0
    }

    /// Applies the distortion and returns `∂(x', y')/∂(x, y)`.
    pub fn distort_with_jacobian(&self, p: Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (x, y) = (p.x, p.y);
        let [p1, p2] = self.tangential;
        let [s1, s2, s3, s4] = self.prism;
        let r2 = x * x + y * y;
        let (g, dg) = self.radial_factor(r2);
        let xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2);
        let yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2);
        // d(r²)/dx = 2x, d(r²)/dy = 2y.
        let sx = s1 + 2.0 * s2 * r2;
        let sy = s3 + 2.0 * s4 * r2;
        let j = Matrix2::new(
            g + 2.0 * x * x * dg + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * sx,
            2.0 * x * y * dg + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * sx,
            2.0 * x * y * dg + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * sy,
            g + 2.0 * y * y * dg + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * sy,
        );
        (Vector2::new(xd, yd), j)
    }

    /// Largest normalized radius (searched up to `limit`) below which the radial part
    /// `r · g(r²)` is strictly increasing, i.e. where the model is one-to-one along rays from the
    /// centre. Returns `limit` when it never folds before it.
    pub fn monotonic_radius(&self, limit: f64) -> f64 {
        const STEPS: usize = 4000;
        let increasing = |r: f64| {
            let (g, dg) = self.radial_factor(r * r);
            // d/dr [r g(r²)] = g + 2 r² g'(r²); a pole of the rational part also ends validity.
            g > 0.0 && g + 2.0 * r * r * dg > 0.0
        };
        let step = limit / STEPS as f64;
        for i in 1..=STEPS {
            let r = i as f64 * step;
            if !increasing(r) {
                // Refine the fold by bisection between the last good and this radius.
                let (mut lo, mut hi) = (r - step, r);
                for _ in 0..50 {
                    let mid = 0.5 * (lo + hi);
                    if increasing(mid) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                return lo;
            }
        }
        limit
    }

    /// Inverts the distortion: finds the normalized point inside `valid_radius` (see
    /// [`Distortion::monotonic_radius`]) whose distorted image is `target`.
    ///
    /// The radial part alone is solved first by bisection (unique, since it is monotonic inside
    /// `valid_radius`); damped Newton on the full model then refines to
    /// [`UNDISTORT_TOLERANCE`]. `pixel` only names the point in errors.
    pub fn undistort(
        &self,
        target: Vector2<f64>,
        valid_radius: f64,
        pixel: (f64, f64),
    ) -> Result<Vector2<f64>, UndistortError> {
        let start = self.radial_initial_guess(target, valid_radius);
        self.undistort_from(target, start, valid_radius, pixel)
    }

    /// Like [`Distortion::undistort`], but Newton starts from `start` (e.g. the solution for a
    /// neighbouring pixel), which saves the radial bisection when many nearby points are
    /// undistorted. A poor start can fail where [`Distortion::undistort`] succeeds.
    pub fn undistort_from(
        &self,
        target: Vector2<f64>,
        start: Vector2<f64>,
        valid_radius: f64,
        pixel: (f64, f64),
    ) -> Result<Vector2<f64>, UndistortError> {
        let not_invertible = UndistortError::NotInvertible {
            u: pixel.0,
            v: pixel.1,
        };
        let mut x = start;
        let (f0, mut jac) = self.distort_with_jacobian(x);
        let mut err = f0 - target;
        let mut norm = err.amax();
        for _ in 0..MAX_NEWTON_ITERATIONS {
            if norm < UNDISTORT_TOLERANCE {
                break;
            }
            let Some(inv) = jac.try_inverse() else {
                return Err(not_invertible);
            };
            let step = inv * err;
            // Halve the step until the residual decreases and the point stays where the model
            // is one-to-one.
            let mut scale = 1.0;
            loop {
                let candidate = x - step * scale;
                let (f_c, j_c) = self.distort_with_jacobian(candidate);
                let e_c = f_c - target;
                let inside = candidate.norm() <= valid_radius;
                if (inside && e_c.amax() < norm) || scale < 1e-9 {
                    x = candidate;
                    jac = j_c;
                    err = e_c;
                    norm = e_c.amax();
                    break;
                }
                scale *= 0.5;
            }
            if !norm.is_finite() {
                break;
            }
        }
        if norm.is_nan() || norm >= UNDISTORT_TOLERANCE {
            return Err(UndistortError::NotConverged {
                u: pixel.0,
                v: pixel.1,
                residual: norm,
            });
        }
        if x.norm() > valid_radius || jac.determinant() <= 0.0 {
            return Err(not_invertible);
        }
        Ok(x)
    }

    /// Undistorted point along `target`'s direction whose radial distortion alone maps it to
    /// `|target|`, found by bisection on `[0, valid_radius]`.
    fn radial_initial_guess(&self, target: Vector2<f64>, valid_radius: f64) -> Vector2<f64> {
        let rd = target.norm();
        if rd == 0.0 || !valid_radius.is_finite() {
            return target;
        }
        let radial = |r: f64| r * self.radial_factor(r * r).0;
        let (mut lo, mut hi) = (0.0, valid_radius);
        if radial(hi) <= rd {
            return target * (hi / rd);
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if radial(mid) < rd {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        target * (0.5 * (lo + hi) / rd)
    }

    /// True when every coefficient is zero.
    pub fn is_none(&self) -> bool {
        *self == Self::NONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strong() -> Distortion {
        Distortion::from_opencv(&[
            -0.3, 0.12, 0.001, -0.002, -0.02, 0.05, 0.01, 0.002, 0.001, -0.0005, 0.0007, 0.0002,
        ])
        .unwrap()
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let d = strong();
        for &(x, y) in &[(0.1, -0.2), (-0.35, 0.27), (0.0, 0.0), (0.5, 0.1)] {
            let p = Vector2::new(x, y);
            let (_, j) = d.distort_with_jacobian(p);
            let h = 1e-7;
            for c in 0..2 {
                let mut e = Vector2::zeros();
                e[c] = h;
                let fd = (d.distort(p + e) - d.distort(p - e)) / (2.0 * h);
                for r in 0..2 {
                    assert!((fd[r] - j[(r, c)]).abs() < 1e-7, "J[{r},{c}] at {p:?}");
                }
            }
        }
    }

    #[test]
    fn undistort_inverts_distort() {
        let d = strong();
        let valid = d.monotonic_radius(10.0);
        for i in 0..100 {
            let a = i as f64 * 0.37;
            let r = 0.6 * (i as f64 / 100.0);
            let p = Vector2::new(r * a.cos(), r * a.sin());
            let back = d.undistort(d.distort(p), valid, (0.0, 0.0)).unwrap();
            assert!((back - p).amax() < 1e-11, "{p:?} -> {back:?}");
        }
    }

    #[test]
    fn opencv_vector_round_trips() {
        let d = strong();
        assert_eq!(Distortion::from_opencv(&d.to_opencv()).unwrap(), d);
        let five = [-0.1, 0.01, 0.001, 0.002, 0.003];
        assert_eq!(Distortion::from_opencv(&five).unwrap().to_opencv(), five);
    }

    #[test]
    fn rejects_bad_vectors() {
        assert_eq!(
            Distortion::from_opencv(&[0.0; 6]),
            Err(CameraError::DistortionLength { len: 6 })
        );
        assert!(matches!(
            Distortion::from_opencv(&[f64::NAN, 0.0, 0.0, 0.0]),
            Err(CameraError::InvalidParameter { name: "k1", .. })
        ));
        let mut tilted = [0.0; 14];
        tilted[12] = 0.01;
        assert!(matches!(
            Distortion::from_opencv(&tilted),
            Err(CameraError::TiltedSensor { .. })
        ));
    }

    #[test]
    fn fold_radius_of_strong_barrel() {
        // r (1 - 0.5 r²) has its maximum at r = sqrt(2/3).
        let d = Distortion::from_opencv(&[-0.5, 0.0, 0.0, 0.0]).unwrap();
        let r = d.monotonic_radius(3.0);
        assert!((r - (2.0f64 / 3.0).sqrt()).abs() < 1e-9, "{r}");
        assert_eq!(Distortion::NONE.monotonic_radius(3.0), 3.0);
    }

    #[test]
    fn wide_lens_corner_finds_the_root_inside_the_fold() {
        // A wide rational lens: the image corner is at normalized radius ≈ 3.3, and a second,
        // spurious root lies beyond the fold at ≈ 7.2 (OpenCV 5 agrees on the first).
        let d =
            Distortion::from_opencv(&[-0.05, 0.02, 0.0005, 0.0004, 0.0, 0.3, 0.03, 0.001]).unwrap();
        let valid = d.monotonic_radius(10.0);
        let target = Vector2::new((39.5 - 402.0) / 380.0, (179.5 - 297.0) / 381.0);
        let x = d.undistort(target, valid, (39.5, 179.5)).unwrap();
        assert!(
            (x - Vector2::new(-3.12314847, -1.02272159)).amax() < 1e-7,
            "{x:?}"
        );
    }
}
