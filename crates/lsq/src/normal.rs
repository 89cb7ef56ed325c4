//! Levenberg–Marquardt on the normal equations, for problems too large for a dense QR of
//! their Jacobian: the problem accumulates JᵀJ and Jᵀr itself (exploiting whatever sparsity
//! it has) and may declare the arrowhead structure of bundle adjustment — a few parameters
//! every residual may touch, then many small blocks that no residual shares — which the
//! solver eliminates by the Schur complement.

use nalgebra::{DMatrix, DVector};

/// The Gauss–Newton normal equations at a parameter vector.
#[derive(Debug, Clone)]
pub struct Normal {
    /// JᵀJ (parameters × parameters).
    pub jtj: DMatrix<f64>,
    /// Jᵀr.
    pub jtr: DVector<f64>,
    /// ½‖r‖².
    pub cost: f64,
}

/// How the parameters are laid out: the first `global` may be coupled to anything; after
/// them come blocks of `block` parameters, each coupled only to itself and the global ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Arrowhead {
    /// Parameters every residual may touch.
    pub global: usize,
    /// Size of each independent block after them.
    pub block: usize,
}

/// A least-squares problem that builds its own normal equations.
pub trait NormalEquations {
    /// ½‖r(x)‖², or `None` where `x` is outside the problem's domain.
    fn cost(&self, x: &DVector<f64>) -> Option<f64>;

    /// The normal equations at `x`, or `None` outside the domain. A parameter whose JᵀJ
    /// diagonal is zero is held where it is (that is how a problem fixes parameters).
    fn normal(&self, x: &DVector<f64>) -> Option<Normal>;

    /// The parameters' structure, when it is the arrowhead of bundle adjustment; `None`
    /// solves the damped system densely.
    fn arrowhead(&self) -> Option<Arrowhead> {
        None
    }
}

/// When [`minimize_normal`] stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// At most this many accepted or rejected steps.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction of it.
    pub ftol: f64,
    /// Stop when a step is shorter than this fraction of ‖x‖.
    pub xtol: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            max_iterations: 200,
            ftol: 1e-14,
            xtol: 1e-12,
        }
    }
}

/// Where [`minimize_normal`] ended.
#[derive(Debug, Clone)]
pub struct NormalSolution {
    /// The parameters found.
    pub x: DVector<f64>,
    /// ½‖r‖² there.
    pub cost: f64,
    /// Steps tried.
    pub iterations: usize,
    /// A tolerance was met (rather than the iteration limit or a singular system).
    pub converged: bool,
}

/// Minimises ½‖r(x)‖² from `x0` by Levenberg–Marquardt with Marquardt's scaling (the damping
/// is λ·diag(JᵀJ)) and Nielsen's update of λ. `None` when `x0` is outside the domain.
pub fn minimize_normal<P: NormalEquations + ?Sized>(
    problem: &P,
    x0: DVector<f64>,
    settings: &Settings,
) -> Option<NormalSolution> {
    let mut x = x0;
    let mut normal = problem.normal(&x)?;
    let (mut lambda, mut nu) = (1e-3, 2.0);
    let mut converged = false;
    let mut iterations = 0;
    while iterations < settings.max_iterations {
        iterations += 1;
        if normal.cost == 0.0 {
            converged = true;
            break;
        }
        let Some(step) = damped_step(&normal, lambda, problem.arrowhead()) else {
            lambda *= nu;
            nu *= 2.0;
            continue;
        };
        if step.norm() <= settings.xtol * (x.norm() + settings.xtol) {
            converged = true;
            break;
        }
        let moved = &x + &step;
        let cost = problem.cost(&moved);
        // The model's decrease: −gᵀδ − ½δᵀJᵀJδ.
        let predicted = -normal.jtr.dot(&step) - 0.5 * step.dot(&(&normal.jtj * &step));
        match cost {
            Some(cost) if cost < normal.cost && predicted > 0.0 => {
                let rho = (normal.cost - cost) / predicted;
                let drop = normal.cost - cost;
                let Some(next) = problem.normal(&moved) else {
                    lambda *= nu;
                    nu *= 2.0;
                    continue;
                };
                x = moved;
                normal = next;
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                if drop <= settings.ftol * normal.cost.max(f64::MIN_POSITIVE) {
                    converged = true;
                    break;
                }
            }
            _ => {
                lambda *= nu;
                nu *= 2.0;
            }
        }
    }
    Some(NormalSolution {
        cost: normal.cost,
        x,
        iterations,
        converged,
    })
}

/// Solves (JᵀJ + λ·diag(JᵀJ))·δ = −Jᵀr, holding parameters with a zero diagonal.
fn damped_step(normal: &Normal, lambda: f64, arrowhead: Option<Arrowhead>) -> Option<DVector<f64>> {
    let mut a = normal.jtj.clone();
    let mut b = -&normal.jtr;
    for k in 0..a.nrows() {
        let d = a[(k, k)];
        if d > 0.0 {
            a[(k, k)] = d * (1.0 + lambda);
        } else {
            a[(k, k)] = 1.0;
            b[k] = 0.0;
        }
    }
    match arrowhead {
        Some(s) if s.block > 0 && s.global < a.nrows() => schur_solve(&a, &b, s),
        _ => Some(a.cholesky()?.solve(&b)),
    }
}

/// Solves `a·δ = b` for an arrowhead `a` by eliminating its blocks.
fn schur_solve(a: &DMatrix<f64>, b: &DVector<f64>, s: Arrowhead) -> Option<DVector<f64>> {
    let (g, n) = (s.global, a.nrows());
    let mut reduced = a.view((0, 0), (g, g)).into_owned();
    let mut rhs = b.rows(0, g).into_owned();
    // Per block: B⁻¹ (its Cholesky) and B⁻¹·Cᵀ, reused for the back substitution.
    let mut blocks = Vec::new();
    for at in (g..n).step_by(s.block) {
        let m = s.block.min(n - at);
        let chol = a.view((at, at), (m, m)).into_owned().cholesky()?;
        let c = a.view((0, at), (g, m));
        let binv_ct = chol.solve(&c.transpose());
        reduced -= c * &binv_ct;
        let binv_b = chol.solve(&b.rows(at, m).into_owned());
        rhs -= c * &binv_b;
        blocks.push((at, m, binv_ct, binv_b));
    }
    let global = reduced.cholesky()?.solve(&rhs);
    let mut step = DVector::zeros(n);
    step.rows_mut(0, g).copy_from(&global);
    for (at, m, binv_ct, binv_b) in blocks {
        step.rows_mut(at, m)
            .copy_from(&(binv_b - binv_ct * &global));
    }
    Some(step)
}

/// The inverse of JᵀJ restricted to the first `s.global` parameters (their covariance up to
/// the residuals' variance), by the Schur complement of the blocks; parameters with a zero
/// diagonal (held) get a unit one. `None` when JᵀJ is singular.
pub fn global_inverse(jtj: &DMatrix<f64>, s: Arrowhead) -> Option<DMatrix<f64>> {
    let mut a = jtj.clone();
    for k in 0..a.nrows() {
        if a[(k, k)] <= 0.0 {
            a[(k, k)] = 1.0;
        }
    }
    let (g, n) = (s.global, a.nrows());
    let mut reduced = a.view((0, 0), (g, g)).into_owned();
    if s.block > 0 {
        for at in (g..n).step_by(s.block) {
            let m = s.block.min(n - at);
            let chol = a.view((at, at), (m, m)).into_owned().cholesky()?;
            let c = a.view((0, at), (g, m));
            reduced -= c * chol.solve(&c.transpose());
        }
    }
    Some(reduced.cholesky()?.inverse())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fits y = a·exp(b·t) + c_i per group i: a, b global; one offset per group (a block of
    /// one), so the arrowhead path and the dense path must agree.
    struct Groups {
        data: Vec<(usize, f64, f64)>,
        groups: usize,
        arrow: bool,
    }

    impl Groups {
        fn residuals(&self, x: &DVector<f64>) -> Vec<(usize, f64, [f64; 3])> {
            self.data
                .iter()
                .map(|&(g, t, y)| {
                    let e = (x[1] * t).exp();
                    (g, x[0] * e + x[2 + g] - y, [e, x[0] * t * e, 1.0])
                })
                .collect()
        }
    }

    impl NormalEquations for Groups {
        fn cost(&self, x: &DVector<f64>) -> Option<f64> {
            Some(0.5 * self.residuals(x).iter().map(|r| r.1 * r.1).sum::<f64>())
        }
        fn normal(&self, x: &DVector<f64>) -> Option<Normal> {
            let n = 2 + self.groups;
            let (mut jtj, mut jtr, mut cost) = (DMatrix::zeros(n, n), DVector::zeros(n), 0.0);
            for (g, r, d) in self.residuals(x) {
                let cols = [0, 1, 2 + g];
                for (i, &ci) in cols.iter().enumerate() {
                    jtr[ci] += d[i] * r;
                    for (j, &cj) in cols.iter().enumerate() {
                        jtj[(ci, cj)] += d[i] * d[j];
                    }
                }
                cost += 0.5 * r * r;
            }
            Some(Normal { jtj, jtr, cost })
        }
        fn arrowhead(&self) -> Option<Arrowhead> {
            self.arrow.then_some(Arrowhead {
                global: 2,
                block: 1,
            })
        }
    }

    fn problem(arrow: bool) -> Groups {
        let truth = [2.0, -0.3, 0.5, -1.0, 0.25];
        let mut data = Vec::new();
        for g in 0..3 {
            for k in 0..10 {
                let t = k as f64 * 0.4;
                // A small deterministic misfit so the minimum is not exact.
                let wobble = 1e-3 * ((k * 7 + g * 3) % 5) as f64;
                data.push((
                    g,
                    t,
                    truth[0] * (truth[1] * t).exp() + truth[2 + g] + wobble,
                ));
            }
        }
        Groups {
            data,
            groups: 3,
            arrow,
        }
    }

    #[test]
    fn the_schur_path_and_the_dense_path_find_the_same_minimum() {
        let x0 = DVector::from_vec(vec![1.0, -0.1, 0.0, 0.0, 0.0]);
        let dense = minimize_normal(&problem(false), x0.clone(), &Settings::default()).unwrap();
        let arrow = minimize_normal(&problem(true), x0, &Settings::default()).unwrap();
        assert!(dense.converged && arrow.converged);
        assert!(
            (dense.x.clone() - arrow.x.clone()).amax() < 1e-9,
            "{dense:?} {arrow:?}"
        );
        assert!((dense.x[0] - 2.0).abs() < 0.01 && (dense.x[1] + 0.3).abs() < 0.01);
        assert!(dense.cost < 1e-4);
    }

    #[test]
    fn a_parameter_with_no_information_is_held() {
        // Group 2's offset gets no data: its column is zero and it must stay at its start.
        let mut p = problem(true);
        p.data.retain(|d| d.0 != 2);
        let x0 = DVector::from_vec(vec![1.0, -0.1, 0.0, 0.0, 7.0]);
        let s = minimize_normal(&p, x0, &Settings::default()).unwrap();
        assert_eq!(s.x[4], 7.0);
        assert!(s.converged);
    }

    #[test]
    fn the_global_inverse_is_the_corner_of_the_full_inverse() {
        let p = problem(true);
        let x = DVector::from_vec(vec![1.5, -0.2, 0.3, -0.5, 0.1]);
        let jtj = p.normal(&x).unwrap().jtj;
        let full = jtj.clone().try_inverse().unwrap();
        let corner = global_inverse(&jtj, p.arrowhead().unwrap()).unwrap();
        assert!((corner - full.view((0, 0), (2, 2))).amax() < 1e-9 * full.amax());
    }
}
