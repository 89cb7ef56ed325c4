//! Non-linear least squares as every fit in flexshape uses it: a problem says what its
//! residuals are at a parameter vector (and, when it can, its Jacobian there), and
//! [`minimize`] runs Levenberg–Marquardt on it from a start. Problems without an analytic
//! Jacobian get central differences ([`central_differences`]) with steps they may choose.
//! Problems too large for a dense QR of their Jacobian (a calibration's hundreds of board
//! poses) build their own normal equations instead and are solved by [`minimize_normal`],
//! which eliminates bundle adjustment's independent blocks by the Schur complement.
//!
//! ```
//! use flexshape_lsq::{Residuals, minimize, nalgebra::DVector};
//! // The circle through three points: centre (a, b) and radius r.
//! struct Circle(Vec<[f64; 2]>);
//! impl Residuals for Circle {
//!     fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
//!         Some(DVector::from_iterator(self.0.len(), self.0.iter().map(|p| {
//!             (p[0] - x[0]).hypot(p[1] - x[1]) - x[2]
//!         })))
//!     }
//! }
//! let circle = Circle(vec![[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]);
//! let solved = minimize(&circle, DVector::from_vec(vec![0.1, 0.1, 2.0]), flexshape_lsq::solver());
//! assert!((solved.x[2] - 1.0).abs() < 1e-9);
//! ```

mod band;
mod normal;

pub use band::banded_inverse;
pub use levenberg_marquardt::{LevenbergMarquardt, MinimizationReport, TerminationReason};
pub use nalgebra;
pub use normal::{
    Arrowhead, Normal, NormalEquations, NormalSolution, Settings, global_inverse, minimize_normal,
};

use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn};

/// A least-squares problem: residuals (and their Jacobian) as functions of the parameters.
pub trait Residuals {
    /// The residuals at `x`, or `None` where `x` is outside the problem's domain (the solver
    /// then steps back).
    fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>>;

    /// The Jacobian of the residuals at `x` (rows: residuals, columns: parameters). By
    /// default central differences with steps from [`Residuals::step`].
    fn jacobian(&self, x: &DVector<f64>) -> Option<DMatrix<f64>> {
        central_differences(x, |k, v| self.step(k, v), |x| self.residuals(x))
    }

    /// The finite-difference step for parameter `k` at value `v`: by default 1e-6 of its
    /// size, at least 1e-8.
    fn step(&self, k: usize, v: f64) -> f64 {
        let _ = k;
        1e-6 * v.abs().max(1e-2)
    }
}

/// The solver's settings as most fits here use them: the crate's defaults.
pub fn solver() -> LevenbergMarquardt<f64> {
    LevenbergMarquardt::new()
}

/// Where a minimisation ended.
#[derive(Debug)]
pub struct Solution {
    /// The parameters found.
    pub x: DVector<f64>,
    /// The solver's report (termination reason, evaluations, objective ½‖r‖²).
    pub report: MinimizationReport<f64>,
}

/// Minimises ½‖r(x)‖² from `x0` with `solver`.
pub fn minimize<R: Residuals + ?Sized>(
    problem: &R,
    x0: DVector<f64>,
    solver: LevenbergMarquardt<f64>,
) -> Solution {
    let (adapter, report) = solver.minimize(Adapter { problem, x: x0 });
    Solution {
        x: adapter.x,
        report,
    }
}

/// The Jacobian of `residuals` at `x` by central differences, parameter `k` stepped by
/// `step(k, x[k])`; `None` where a residual is.
pub fn central_differences(
    x: &DVector<f64>,
    step: impl Fn(usize, f64) -> f64,
    residuals: impl Fn(&DVector<f64>) -> Option<DVector<f64>>,
) -> Option<DMatrix<f64>> {
    let mut j: Option<DMatrix<f64>> = None;
    let mut moved = x.clone();
    for k in 0..x.len() {
        let h = step(k, x[k]);
        moved[k] = x[k] + h;
        let up = residuals(&moved)?;
        moved[k] = x[k] - h;
        let down = residuals(&moved)?;
        moved[k] = x[k];
        let j = j.get_or_insert_with(|| DMatrix::zeros(up.len(), x.len()));
        j.set_column(k, &((up - down) / (2.0 * h)));
    }
    j.or_else(|| Some(DMatrix::zeros(residuals(x)?.len(), 0)))
}

/// The condition number of `j` with its columns scaled to unit length (largest singular value
/// over the smallest), so that it does not depend on the parameters' units (mm against a
/// log-stiffness): how nearly some combination of the parameters leaves the residuals
/// unchanged. ∞ when one does exactly, NaN when `j` holds a NaN.
pub fn scaled_condition(j: &DMatrix<f64>) -> f64 {
    let mut unit = j.clone();
    for mut c in unit.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    let (lo, hi) = unit
        .singular_values()
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &s| {
            (lo.min(s), hi.max(s))
        });
    hi / lo
}

/// The `levenberg-marquardt` crate's view of a [`Residuals`] problem.
struct Adapter<'a, R: ?Sized> {
    problem: &'a R,
    x: DVector<f64>,
}

impl<R: Residuals + ?Sized> LeastSquaresProblem<f64, Dyn, Dyn> for Adapter<'_, R> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.problem.residuals(&self.x)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.problem.jacobian(&self.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r(x) = (x0² − 2, x0·x1 − 3).
    struct Quadratic;

    impl Residuals for Quadratic {
        fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
            Some(DVector::from_vec(vec![
                x[0] * x[0] - 2.0,
                x[0] * x[1] - 3.0,
            ]))
        }
    }

    #[test]
    fn a_scaled_condition_ignores_units_and_sees_a_dependence() {
        let j = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1000.0, 1.0, 0.0]);
        // Orthogonal columns, one a thousand times longer: as well conditioned as any.
        assert!(
            (scaled_condition(&j) - 1.0).abs() < 1e-9,
            "{}",
            scaled_condition(&j)
        );
        let dependent = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        assert!(scaled_condition(&dependent) > 1e12);
    }

    #[test]
    fn central_differences_match_the_analytic_jacobian() {
        let x = DVector::from_vec(vec![1.3, -0.7]);
        let j = Quadratic.jacobian(&x).unwrap();
        let exact = DMatrix::from_row_slice(2, 2, &[2.6, 0.0, -0.7, 1.3]);
        assert!((j - exact).amax() < 1e-8);
    }

    #[test]
    fn minimize_finds_the_root() {
        let s = minimize(&Quadratic, DVector::from_vec(vec![1.0, 1.0]), solver());
        assert!((s.x[0] - 2f64.sqrt()).abs() < 1e-10, "{}", s.x);
        assert!((s.x[1] - 3.0 / 2f64.sqrt()).abs() < 1e-10, "{}", s.x);
        assert!(s.report.termination.was_successful());
    }

    #[test]
    fn a_residual_outside_the_domain_has_no_jacobian() {
        struct Sqrt;
        impl Residuals for Sqrt {
            fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
                (x[0] >= 0.0).then(|| DVector::from_vec(vec![x[0].sqrt() - 1.0]))
            }
        }
        assert!(Sqrt.jacobian(&DVector::from_vec(vec![0.0])).is_none());
        assert!(Sqrt.jacobian(&DVector::from_vec(vec![4.0])).is_some());
    }
}
