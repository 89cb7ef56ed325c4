//! Estimating where the tendons are (the paper's future work, Section VI: "the registration
//! could also be reversed to estimate the locations of the tendons"): non-linear least squares
//! for every tendon's `(dx, dz)`, optionally with `Km`, from sensed configurations and their
//! tendon displacements.
//!
//! The fit uses the taut model `q = A·y` (give it poses without slack tendons). Residuals
//! are in mm: curvature errors as tip deflection (`Δκ·L1²/2`), strain errors as
//! section shortening (`Δε0·L0`, `Δε1·L1`). Identifiability is judged from the Jacobian at the
//! solution: a direction of the parameters the data do not see (e.g. tendons that no pose
//! loads differently) makes it rank-deficient and the estimate is refused.

use flexshape_lsq::{LevenbergMarquardt, Residuals, minimize};
use nalgebra::{DMatrix, DVector};

use crate::{ManipulatorParams, Model, ModelError, Observation, Stiffness};

/// Largest (column-scaled) Jacobian condition number accepted. Exact data from the paper's
/// minimum-norm commands, whose displacements span only a 3-D subspace for 4 tendons, exceed
/// it by orders of magnitude.
const MAX_CONDITION: f64 = 1e6;

/// What the tendon estimate found.
#[derive(Debug, Clone, PartialEq)]
pub struct TendonEstimate {
    /// The parameters with the estimated tendon positions (and `Km`, if estimated).
    pub params: ManipulatorParams,
    /// RMS of the residuals at the solution, mm.
    pub rms_mm: f64,
    /// Condition number of the Jacobian at the solution, its columns scaled to unit length
    /// (large: weakly determined).
    pub condition: f64,
    /// Standard error of each tendon's `(dx, dz)`, mm.
    pub standard_error: Vec<[f64; 2]>,
}

/// Fits the tendons' positions (starting from `params`' own) and, with `with_stiffness`, the
/// diagonal of `Km`, to fully measured observations.
pub fn estimate_tendons(
    params: &ManipulatorParams,
    data: &[Observation],
    with_stiffness: bool,
) -> Result<TendonEstimate, ModelError> {
    Model::new(params.clone())?;
    let n = params.tendons.len();
    let unknowns = 2 * n + if with_stiffness { 4 } else { 0 };
    if let Some(index) = data.iter().position(|o| o.measured.iter().any(|m| !m)) {
        return Err(ModelError::Observation {
            index,
            problem: "the tendon estimate needs all of κx, κz, ε0, ε1 measured".into(),
        });
    }
    if let Some(index) = data.iter().position(|o| o.y.len() != n) {
        return Err(ModelError::Observation {
            index,
            problem: format!(
                "{} tendon displacements for {n} tendons",
                data[index].y.len()
            ),
        });
    }
    if 4 * data.len() < unknowns {
        return Err(ModelError::Unobservable {
            what: "the tendon positions (fewer residuals than unknowns)",
            observations: data.len(),
        });
    }
    let mut start = Vec::with_capacity(unknowns);
    for t in &params.tendons {
        start.extend([t.dx, t.dz]);
    }
    if with_stiffness {
        start.extend(params.stiffness.diagonal().map(f64::ln));
    }
    let mut problem = Problem {
        base: params,
        data,
        with_stiffness,
        x: DVector::from_vec(start),
    };
    problem.x = minimize(&problem, problem.x.clone(), stiff_solver()).x;
    let r = problem.residuals(&problem.x).ok_or(ModelError::NoTautSet)?;
    let j = problem.jacobian(&problem.x).ok_or(ModelError::NoTautSet)?;
    let condition = flexshape_lsq::scaled_condition(&j);
    if condition.is_nan() || condition >= MAX_CONDITION {
        return Err(ModelError::Unobservable {
            what: "the tendon positions (the poses do not load the tendons independently: \
                   vary the co-contraction, e.g. commands beyond the minimum-norm inverse)",
            observations: data.len(),
        });
    }
    let dof = (r.len() - unknowns).max(1) as f64;
    let sigma2 = r.norm_squared() / dof;
    let cov = (j.transpose() * &j)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(unknowns, unknowns, f64::NAN));
    let se = |k: usize| (sigma2 * cov[(k, k)]).max(0.0).sqrt();
    Ok(TendonEstimate {
        params: problem.params_at(&problem.x),
        rms_mm: (r.norm_squared() / r.len() as f64).sqrt(),
        condition,
        standard_error: (0..n).map(|i| [se(2 * i), se(2 * i + 1)]).collect(),
    })
}

struct Problem<'a> {
    base: &'a ManipulatorParams,
    data: &'a [Observation],
    with_stiffness: bool,
    x: DVector<f64>,
}

impl Problem<'_> {
    fn params_at(&self, x: &DVector<f64>) -> ManipulatorParams {
        let mut p = self.base.clone();
        for (i, t) in p.tendons.iter_mut().enumerate() {
            t.dx = x[2 * i];
            t.dz = x[2 * i + 1];
        }
        if self.with_stiffness {
            let k = 2 * p.tendons.len();
            p.stiffness = Stiffness {
                kx: x[k].exp(),
                kz: x[k + 1].exp(),
                ka0: x[k + 2].exp(),
                ka1: x[k + 3].exp(),
            };
        }
        p
    }

    fn residuals_at(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        let p = self.params_at(x);
        // The taut model, smooth everywhere (the data's poses are taut; an iterate where one
        // would go slack must not stop the search).
        let a = Model::new(p.clone()).ok()?.forward_matrix().ok()?;
        let (l0, l1) = (p.proximal_length, p.distal_length);
        let scale = [l1 * l1 / 2.0, l1 * l1 / 2.0, l0, l1];
        let mut r = DVector::zeros(4 * self.data.len());
        for (i, o) in self.data.iter().enumerate() {
            let q = &a * &o.y;
            for j in 0..4 {
                r[4 * i + j] = (q[j] - o.q[j]) * scale[j];
            }
        }
        Some(r)
    }
}

impl Residuals for Problem<'_> {
    fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        self.residuals_at(x)
    }
}

/// The solver for the model's fits: steps bounded (tensions switch tendons slack), tight
/// tolerances.
pub(crate) fn stiff_solver() -> LevenbergMarquardt<f64> {
    LevenbergMarquardt::new()
        .with_stepbound(0.1)
        .with_xtol(1e-12)
        .with_ftol(1e-14)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ExperimentPlan, experiment};

    fn data(truth: &Model, plan: &ExperimentPlan) -> Vec<Observation> {
        experiment(truth, plan)
            .unwrap()
            .into_iter()
            .skip(1)
            .map(|p| Observation::new(p.q, p.y))
            .collect()
    }

    fn moved(p: &ManipulatorParams) -> ManipulatorParams {
        let mut truth = p.clone();
        // A tendon 0.2 mm off its nominal place and one turned by 5°.
        truth.tendons[1].dx += 0.2;
        let (s, c) = 5f64.to_radians().sin_cos();
        let t = &mut truth.tendons[3];
        (t.dx, t.dz) = (c * t.dx - s * t.dz, s * t.dx + c * t.dz);
        truth
    }

    #[test]
    fn tendon_positions_are_recovered_when_the_commands_vary_co_contraction() {
        let nominal = ManipulatorParams::paper_like();
        let truth = Model::new(moved(&nominal)).unwrap();
        let mut obs = data(&truth, &ExperimentPlan::default());
        // The paper's minimum-norm commands leave the antagonistic pattern (+, −, +, −) out:
        // one combination of the tendon positions is then invisible.
        let e = estimate_tendons(&nominal, &obs, false).unwrap_err();
        assert!(e.to_string().contains("co-contraction"), "{e}");
        // Adding a varying co-contraction (tendons 0 and 2 against 1 and 3) identifies them.
        for (i, o) in obs.iter_mut().enumerate() {
            let c = 0.05 * ((i % 5) as f64 - 2.0) / 2.0;
            let y = &o.y + DVector::from_vec(vec![c, -c, c, -c]);
            let f = truth.forward(&y).unwrap();
            if f.slack.is_empty() {
                *o = Observation::new(f.q, y);
            }
        }
        let e = estimate_tendons(&nominal, &obs, false).unwrap();
        let want = &truth.params().tendons;
        for (got, want) in e.params.tendons.iter().zip(want) {
            assert!(
                (got.dx - want.dx).abs() < 1e-6 && (got.dz - want.dz).abs() < 1e-6,
                "{got:?} vs {want:?}"
            );
        }
        assert!(e.rms_mm < 1e-6 && e.condition < MAX_CONDITION, "{e:?}");
        println!("tendons alone: condition {:.3e}", e.condition);
        // Jointly with Km: identifiable from the same poses.
        let e = estimate_tendons(&nominal, &obs, true).unwrap();
        println!("with Km: condition {:.3e}", e.condition);
        for (got, want) in e.params.tendons.iter().zip(want) {
            assert!((got.dx - want.dx).abs() < 1e-5 && (got.dz - want.dz).abs() < 1e-5);
        }
        for (got, want) in e
            .params
            .stiffness
            .diagonal()
            .iter()
            .zip(truth.params().stiffness.diagonal())
        {
            assert!((got / want - 1.0).abs() < 1e-5, "{got} vs {want}");
        }
    }

    #[test]
    fn poses_that_do_not_separate_the_tendons_are_refused() {
        let nominal = ManipulatorParams::paper_like();
        let model = Model::new(nominal.clone()).unwrap();
        // Straight, only compressed: every tendon is loaded alike, so their positions in the
        // cross-section leave no trace.
        let obs: Vec<Observation> = [0.004, 0.006, 0.008, 0.01]
            .iter()
            .map(|&e0| {
                let y = model
                    .inverse(&nalgebra::Vector4::new(0.0, 0.0, e0, 0.0))
                    .unwrap();
                Observation::new(model.forward(&y).unwrap().q, y)
            })
            .collect();
        let e = estimate_tendons(&nominal, &obs, false).unwrap_err();
        assert!(e.to_string().contains("tendon positions"), "{e}");
        // Too few poses for the unknowns.
        let e = estimate_tendons(&nominal, &obs[..1], true).unwrap_err();
        assert!(e.to_string().contains("fewer residuals"), "{e}");
    }
}
