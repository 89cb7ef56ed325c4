//! Rigid registration of paired point sets (paper, Section III-A): the closed-form least-squares
//! rotation and translation (Kabsch, with Umeyama's reflection guard), a non-linear
//! least-squares refinement over an orthonormal rotation (rotation vector) and translation —
//! the form the paper uses, which also takes per-point weights — and per-axis and 3-D RMS
//! reports. Units are the caller's (mm in flexshape); frames are "source" and "target":
//! `target ≈ R·source + t`.
//!
//! ```
//! use flexshape_register::{RigidTransform, register};
//! use flexshape_register::nalgebra::{Point3, Rotation3, Vector3};
//!
//! // Reference points (a digitizer's, say) and the same points as a sensor sees them.
//! let reference = [[0.0, 0.0, 0.0], [50.0, 0.0, 0.0], [0.0, 80.0, 0.0], [10.0, 20.0, 30.0]]
//!     .map(Point3::from);
//! let truth = RigidTransform {
//!     rotation: Rotation3::from_euler_angles(0.1, -0.3, 0.7),
//!     translation: Vector3::new(5.0, -2.0, 100.0),
//! };
//! let sensed = reference.map(|p| truth.apply(&p));
//! let (found, residuals) = register(&reference, &sensed)?;
//! assert!(residuals.rms < 1e-9);
//! assert!((found.translation - truth.translation).norm() < 1e-9);
//! # Ok::<(), flexshape_register::RegisterError>(())
//! ```

use nalgebra::{DVector, Matrix3, Point3, Rotation3, Vector3};

/// Re-exported so users of this crate name the same nalgebra types.
pub use nalgebra;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why two point sets cannot be registered.
#[derive(Debug, Error, PartialEq)]
pub enum RegisterError {
    /// The sets differ in size.
    #[error(
        "{source_points} source points but {target_points} target points: registration needs pairs"
    )]
    Unpaired {
        /// Source points.
        source_points: usize,
        /// Target points.
        target_points: usize,
    },
    /// Fewer than three points, or all on one line: the rotation is not determined.
    #[error(
        "the {points} source points do not span a plane (they are fewer than 3, or on one line); the rotation is undetermined"
    )]
    Degenerate {
        /// Points given.
        points: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a NaN or infinite coordinate")]
    NotFinite {
        /// Index of the point.
        index: usize,
    },
}

/// `target ≈ rotation · source + translation` (`apply`, `inverse`, `then`): flexshape's one
/// rigid transform.
pub type RigidTransform = flexshape_camera::Pose;

/// Residuals of a registration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Residuals {
    /// RMS of the x, y and z components of `target − R·source − t`.
    pub rms_axis: [f64; 3],
    /// RMS of the 3-D distances.
    pub rms: f64,
    /// Largest 3-D distance.
    pub max: f64,
}

/// Residuals of `transform` mapping `source` onto `target` (paired).
pub fn residuals(
    transform: &RigidTransform,
    source: &[Point3<f64>],
    target: &[Point3<f64>],
) -> Residuals {
    let n = source.len().max(1) as f64;
    let mut sq = [0.0; 3];
    let mut max: f64 = 0.0;
    for (s, t) in source.iter().zip(target) {
        let d = t - transform.apply(s);
        for a in 0..3 {
            sq[a] += d[a] * d[a];
        }
        max = max.max(d.norm());
    }
    Residuals {
        rms_axis: sq.map(|v| (v / n).sqrt()),
        rms: (sq.iter().sum::<f64>() / n).sqrt(),
        max,
    }
}

/// Checks that `source` and `target` pair up and hold only finite coordinates (points or
/// directions alike).
fn check<P: std::ops::Index<usize, Output = f64>>(
    source: &[P],
    target: &[P],
) -> Result<(), RegisterError> {
    if source.len() != target.len() {
        return Err(RegisterError::Unpaired {
            source_points: source.len(),
            target_points: target.len(),
        });
    }
    if let Some(index) = source
        .iter()
        .chain(target)
        .position(|p| (0..3).any(|a| !p[a].is_finite()))
    {
        return Err(RegisterError::NotFinite {
            index: index % source.len().max(1),
        });
    }
    Ok(())
}

/// The least-squares rigid transform (Kabsch; Umeyama's sign correction keeps it a rotation when
/// the best orthogonal fit would be a reflection).
pub fn kabsch(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
) -> Result<RigidTransform, RegisterError> {
    check(source, target)?;
    let n = source.len();
    let degenerate = Err(RegisterError::Degenerate { points: n });
    if n < 3 {
        return degenerate;
    }
    let mean = |p: &[Point3<f64>]| p.iter().fold(Vector3::zeros(), |a, q| a + q.coords) / n as f64;
    let (cs, ct) = (mean(source), mean(target));
    let mut h = Matrix3::zeros();
    for (s, t) in source.iter().zip(target) {
        h += (t.coords - ct) * (s.coords - cs).transpose();
    }
    // The source must span at least a plane.
    let spread = source.iter().fold(Matrix3::zeros(), |a, s| {
        a + (s.coords - cs) * (s.coords - cs).transpose()
    });
    let sv = spread.symmetric_eigenvalues();
    let mut sorted = [sv[0], sv[1], sv[2]];
    sorted.sort_by(f64::total_cmp);
    if sorted[1] <= 1e-12 * sorted[2].max(f64::MIN_POSITIVE) {
        return degenerate;
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return degenerate;
    };
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    let rotation = Rotation3::from_matrix_unchecked(r);
    Ok(RigidTransform {
        rotation,
        translation: ct - rotation * cs,
    })
}

/// The rotation best taking unit directions `source` onto `target` (Wahba's problem, weighted;
/// an SVD with the reflection guard): e.g. a model frame's known bending directions onto the
/// sensed ones, when only orientation is wanted (the paper's Section V-A registration). Needs
/// two non-parallel directions; `weights` may be empty for all 1.
pub fn rotation_between(
    source: &[Vector3<f64>],
    target: &[Vector3<f64>],
    weights: &[f64],
) -> Result<Rotation3<f64>, RegisterError> {
    check(source, target)?;
    if !weights.is_empty() && weights.len() != source.len() {
        return Err(RegisterError::Unpaired {
            source_points: source.len(),
            target_points: target.len(),
        });
    }
    let mut b = Matrix3::zeros();
    for (i, (s, t)) in source.iter().zip(target).enumerate() {
        let w = weights.get(i).copied().unwrap_or(1.0);
        b += w * t.normalize() * s.normalize().transpose();
    }
    let sv = b.singular_values();
    let mut sorted = [sv[0], sv[1], sv[2]];
    sorted.sort_by(f64::total_cmp);
    // One direction, or all parallel: the rotation about them is free.
    if sorted[1] <= 1e-9 * sorted[2].max(f64::MIN_POSITIVE) {
        return Err(RegisterError::Degenerate {
            points: source.len(),
        });
    }
    let svd = b.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(RegisterError::Degenerate {
            points: source.len(),
        });
    };
    let d = (u * v_t).determinant().signum();
    Ok(Rotation3::from_matrix_unchecked(
        u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t,
    ))
}

/// Refines `initial` by weighted non-linear least squares over a rotation vector and a
/// translation (the rotation stays orthonormal by construction). `weights` (one per pair, or
/// empty for all 1) scale each pair's squared distance.
pub fn refine(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
    weights: &[f64],
    initial: &RigidTransform,
) -> Result<RigidTransform, RegisterError> {
    check(source, target)?;
    if source.len() < 3 {
        return Err(RegisterError::Degenerate {
            points: source.len(),
        });
    }
    let w: Vec<f64> = if weights.is_empty() {
        vec![1.0; source.len()]
    } else {
        weights.iter().map(|w| w.max(0.0).sqrt()).collect()
    };
    let problem = Problem {
        source,
        target,
        weights: w,
        base: *initial,
    };
    let solved = flexshape_lsq::minimize(&problem, DVector::zeros(6), flexshape_lsq::solver());
    Ok(problem.transform(&solved.x))
}

/// Closed form then refinement: the usual way to call this crate.
pub fn register(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
) -> Result<(RigidTransform, Residuals), RegisterError> {
    let t = refine(source, target, &[], &kabsch(source, target)?)?;
    Ok((t, residuals(&t, source, target)))
}

/// Parameters: a rotation vector and a translation applied on top of `base`.
struct Problem<'a> {
    source: &'a [Point3<f64>],
    target: &'a [Point3<f64>],
    weights: Vec<f64>,
    base: RigidTransform,
}

impl Problem<'_> {
    fn transform(&self, p: &DVector<f64>) -> RigidTransform {
        self.base.moved_by(
            Vector3::new(p[0], p[1], p[2]),
            Vector3::new(p[3], p[4], p[5]),
        )
    }

    fn residuals_of(&self, p: &DVector<f64>) -> DVector<f64> {
        let t = self.transform(p);
        let mut r = DVector::zeros(3 * self.source.len());
        for (i, ((s, q), w)) in self
            .source
            .iter()
            .zip(self.target)
            .zip(&self.weights)
            .enumerate()
        {
            let d = t.apply(s) - q;
            for a in 0..3 {
                r[3 * i + a] = w * d[a];
            }
        }
        r
    }
}

impl flexshape_lsq::Residuals for Problem<'_> {
    fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        Some(self.residuals_of(x))
    }

    /// Central differences in the six parameters are cheap for a few hundred pairs, and exact
    /// enough for any rotation vector with these steps.
    fn step(&self, k: usize, _: f64) -> f64 {
        if k < 3 {
            1e-7
        } else {
            1e-6 * (1.0 + self.base.translation.norm())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::Xoshiro256PlusPlus;
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};

    fn random_transform(rng: &mut Xoshiro256PlusPlus) -> RigidTransform {
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        RigidTransform {
            rotation: Rotation3::from_scaled_axis(axis.normalize() * rng.random_range(0.0..3.0)),
            translation: Vector3::new(
                rng.random_range(-200.0..200.0),
                rng.random_range(-200.0..200.0),
                rng.random_range(-200.0..200.0),
            ),
        }
    }

    #[test]
    fn recovers_random_transforms_from_noisy_points_within_the_noise() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.3).unwrap();
        for _ in 0..50 {
            let truth = random_transform(&mut rng);
            let source: Vec<Point3<f64>> = (0..40)
                .map(|_| {
                    Point3::new(
                        rng.random_range(-80.0..80.0),
                        rng.random_range(-80.0..80.0),
                        rng.random_range(-80.0..80.0),
                    )
                })
                .collect();
            let target: Vec<Point3<f64>> = source
                .iter()
                .map(|p| truth.apply(p) + Vector3::from_fn(|_, _| noise.sample(&mut rng)))
                .collect();
            let (found, res) = register(&source, &target).unwrap();
            // The fit's residual is the noise (σ·√3 in 3-D, less 6 fitted parameters).
            assert!(
                (res.rms - 0.3 * 3f64.sqrt()).abs() < 0.12,
                "rms {}",
                res.rms
            );
            // The transform error at the points is well below the noise.
            let err = source
                .iter()
                .map(|p| (found.apply(p) - truth.apply(p)).norm())
                .fold(0.0, f64::max);
            assert!(err < 0.3, "transform error {err}");
            assert!((found.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
            // Exact data: exact recovery.
            let exact: Vec<Point3<f64>> = source.iter().map(|p| truth.apply(p)).collect();
            let t = kabsch(&source, &exact).unwrap();
            assert!((t.rotation.matrix() - truth.rotation.matrix()).amax() < 1e-9);
            assert!((t.translation - truth.translation).amax() < 1e-7);
        }
    }

    #[test]
    fn directions_give_the_rotation() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let noise = Normal::new(0.0, 0.01).unwrap();
        for _ in 0..50 {
            let truth = random_transform(&mut rng).rotation;
            // Four bending directions 90° apart and the axis, as articulating each tendon gives.
            let source = [
                Vector3::x(),
                Vector3::z(),
                -Vector3::x(),
                -Vector3::z(),
                Vector3::y(),
            ];
            let target: Vec<Vector3<f64>> = source
                .iter()
                .map(|s| (truth * s + Vector3::from_fn(|_, _| noise.sample(&mut rng))).normalize())
                .collect();
            let r = rotation_between(&source, &target, &[]).unwrap();
            assert!(r.angle_to(&truth) < 0.03, "{}", r.angle_to(&truth));
            let exact: Vec<Vector3<f64>> = source.iter().map(|s| truth * s).collect();
            let r = rotation_between(&source, &exact, &[]).unwrap();
            // (angle_to is acos-limited near 0: compare the matrices.)
            assert!((r.matrix() - truth.matrix()).amax() < 1e-12);
        }
        let parallel = [Vector3::x(), Vector3::x() * 2.0];
        assert!(matches!(
            rotation_between(&parallel, &parallel, &[]),
            Err(RegisterError::Degenerate { .. })
        ));
        assert!(matches!(
            rotation_between(&parallel, &parallel[..1], &[]),
            Err(RegisterError::Unpaired { .. })
        ));
    }

    #[test]
    fn refinement_honours_weights_and_inverse_undoes() {
        let source = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(10.0, 0.0, 0.0),
            Point3::new(0.0, 10.0, 0.0),
            Point3::new(0.0, 0.0, 10.0),
        ];
        let mut target: Vec<Point3<f64>> = source.to_vec();
        target[3].x += 4.0; // one bad pair
        let unweighted = refine(&source, &target, &[], &RigidTransform::identity()).unwrap();
        let weighted = refine(
            &source,
            &target,
            &[1.0, 1.0, 1.0, 1e-9],
            &RigidTransform::identity(),
        )
        .unwrap();
        let moved = |t: &RigidTransform| (t.apply(&source[0]) - source[0]).norm();
        assert!(moved(&weighted) < 1e-6 && moved(&unweighted) > 0.1);
        let t = random_transform(&mut Xoshiro256PlusPlus::seed_from_u64(9));
        let p = Point3::new(1.0, 2.0, 3.0);
        assert!((t.inverse().apply(&t.apply(&p)) - p).norm() < 1e-12);
    }

    #[test]
    fn reflections_and_bad_input_are_refused_or_guarded() {
        // A mirrored target: the best proper rotation, never a reflection.
        let source = [
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(1.0, 1.0, 1.0),
        ];
        let mirrored: Vec<Point3<f64>> =
            source.iter().map(|p| Point3::new(-p.x, p.y, p.z)).collect();
        let t = kabsch(&source, &mirrored).unwrap();
        assert!((t.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
        let line = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
        ];
        assert_eq!(
            kabsch(&line, &line),
            Err(RegisterError::Degenerate { points: 3 })
        );
        assert!(matches!(
            kabsch(&line, &line[..2]),
            Err(RegisterError::Unpaired { .. })
        ));
        let nan = [
            Point3::new(0.0, f64::NAN, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        assert_eq!(
            kabsch(&nan, &nan),
            Err(RegisterError::NotFinite { index: 0 })
        );
    }
}
