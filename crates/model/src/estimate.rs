//! Tensionless estimation of the manipulator's stiffnesses (paper, Section V-B, eq. 6):
//! eliminating the tensions, `Km·q = D Kt Lt⁻¹ (y − Dᵀ L0 q)`. With `D`, `Kt`, `Lt`, `L0`, `L1`
//! known, every data point (a sensed configuration `q` and its tendon displacements `y`) gives
//! the right-hand side `b`, and since `Km` is diagonal each stiffness is the least-squares
//! ratio `K_j = Σ q_j b_j / Σ q_j²` over the data.

use nalgebra::{DVector, Vector4};

use crate::{ManipulatorParams, Model, ModelError, Stiffness, geometry};

/// One observation: a configuration `[κx, κz, ε0, ε1]` and the tendon displacements (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Sensed configuration.
    pub q: Vector4<f64>,
    /// Tendon displacements, mm.
    pub y: DVector<f64>,
}

/// What the estimation found: the paper's Table I, second column.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The estimated `Km`.
    pub stiffness: Stiffness,
    /// Ka0 and Ka1 in series, N per unit strain.
    pub serial_axial: f64,
    /// Mean distance between the bending section's tip predicted by the fitted model from `y`
    /// and the sensed one, as a percentage of `L1`.
    pub tip_error_percent: f64,
    /// Observations used.
    pub observations: usize,
}

/// Least squares for the diagonal of `Km` (the parameters' own `stiffness` is ignored).
pub fn estimate_stiffness(
    params: &ManipulatorParams,
    data: &[Observation],
) -> Result<Estimate, ModelError> {
    let n = params.tendons.len();
    if let Some(bad) = data.iter().position(|o| o.y.len() != n) {
        return Err(ModelError::Observation {
            index: bad,
            problem: format!("{} tendon displacements for {n} tendons", data[bad].y.len()),
        });
    }
    if let Some(bad) = data
        .iter()
        .position(|o| o.q.iter().chain(o.y.iter()).any(|v| !v.is_finite()))
    {
        return Err(ModelError::Observation {
            index: bad,
            problem: "NaN or infinite value".into(),
        });
    }
    let d = params.moment_arms();
    let (l0, l1) = (params.proximal_length, params.distal_length);
    let l = Vector4::new(l1, l1, l0, l1);
    let kt_over_lt =
        DVector::from_iterator(n, params.tendons.iter().map(|t| t.stiffness / t.length));
    let (mut qb, mut qq) = (Vector4::<f64>::zeros(), Vector4::<f64>::zeros());
    for o in data {
        let stretch = &o.y - d.transpose() * l.component_mul(&o.q);
        let b = &d * stretch.component_mul(&kt_over_lt);
        for j in 0..4 {
            qb[j] += o.q[j] * b[j];
            qq[j] += o.q[j] * o.q[j];
        }
    }
    let names = [
        "Kx (no bending about x)",
        "Kz (no bending about z)",
        "Ka0 (no proximal compression)",
        "Ka1 (no distal compression)",
    ];
    let mut k = [0.0; 4];
    for j in 0..4 {
        let scale = data.iter().map(|o| o.q[j].abs()).fold(0.0, f64::max);
        if data.is_empty() || qq[j] <= (1e-12 * scale).powi(2) || scale == 0.0 {
            return Err(ModelError::Unobservable {
                what: names[j],
                observations: data.len(),
            });
        }
        k[j] = qb[j] / qq[j];
        if k[j].is_nan() || k[j] <= 0.0 {
            return Err(ModelError::Unobservable {
                what: names[j],
                observations: data.len(),
            });
        }
    }
    let stiffness = Stiffness {
        kx: k[0],
        kz: k[1],
        ka0: k[2],
        ka1: k[3],
    };
    let fitted = Model::new(ManipulatorParams {
        stiffness,
        ..params.clone()
    })?;
    let mut error = 0.0;
    for o in data {
        let predicted = fitted.forward(&o.y)?.q;
        error += (geometry::bend_tip(params, &predicted) - geometry::bend_tip(params, &o.q)).norm();
    }
    Ok(Estimate {
        stiffness,
        serial_axial: stiffness.serial_axial(),
        tip_error_percent: 100.0 * error / data.len() as f64 / l1,
        observations: data.len(),
    })
}
