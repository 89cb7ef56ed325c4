//! The linear tendon mechanics (paper, eqs. 2–5): `Km·q = D·τ`, `y = Dᵀ·L0·q + Lt·Kt⁻¹·τ`, so
//! `y = Cm·τ` with `Cm = Dᵀ L0 Km⁻¹ D + Lt Kt⁻¹` and `q = A·y` with `A = Km⁻¹ D Cm⁻¹`.
//!
//! `q = [κx, κz, ε0, ε1]` (1/mm, 1/mm, strain, strain; compression positive), `y` the tendon
//! displacements (mm, pulled positive), `τ` the tensions (N). Beyond the paper, tendons cannot
//! push: [`Model::forward`] finds the set of slack tendons (an active set: a tendon whose
//! tension would be negative goes slack; a slack one is taken back when the shape would stretch
//! it) and solves with the others.

use nalgebra::{DMatrix, DVector, Matrix4, Vector4};

use crate::{ManipulatorParams, ModelError};

/// The model for one set of parameters.
#[derive(Debug, Clone)]
pub struct Model {
    params: ManipulatorParams,
    /// Moment arms and axial rows, 4 × n.
    d: DMatrix<f64>,
    /// `diag(L1, L1, L0, L1)`.
    l0: Matrix4<f64>,
    /// `Km⁻¹`.
    km_inv: Matrix4<f64>,
    /// `Lt Kt⁻¹` (diagonal, n).
    tendon_compliance: DVector<f64>,
}

/// The state for a set of tendon displacements.
#[derive(Debug, Clone, PartialEq)]
pub struct Forward {
    /// `[κx, κz, ε0, ε1]`.
    pub q: Vector4<f64>,
    /// Tensions, N (0 for slack tendons).
    pub tensions: DVector<f64>,
    /// Indices of slack tendons.
    pub slack: Vec<usize>,
}

impl Model {
    /// Builds `D`, `L0`, `Km⁻¹` and `Lt Kt⁻¹` and checks that `Cm` is invertible.
    pub fn new(params: ManipulatorParams) -> Result<Self, ModelError> {
        params.validate()?;
        let n = params.tendons.len();
        let d = params.moment_arms();
        let (l0, l1) = (params.proximal_length, params.distal_length);
        let km = params.stiffness.diagonal();
        let model = Model {
            d,
            l0: Matrix4::from_diagonal(&Vector4::new(l1, l1, l0, l1)),
            km_inv: Matrix4::from_diagonal(&Vector4::from(km.map(|k| 1.0 / k))),
            tendon_compliance: DVector::from_iterator(
                n,
                params.tendons.iter().map(|t| t.length / t.stiffness),
            ),
            params,
        };
        model.compliance_inverse(&(0..n).collect::<Vec<_>>())?;
        Ok(model)
    }

    /// The parameters.
    pub fn params(&self) -> &ManipulatorParams {
        &self.params
    }

    /// `D` (4 × n).
    pub fn moment_arms(&self) -> &DMatrix<f64> {
        &self.d
    }

    /// `Cm` over all tendons (n × n).
    pub fn compliance(&self) -> DMatrix<f64> {
        let all: Vec<usize> = (0..self.d.ncols()).collect();
        self.compliance_of(&all)
    }

    fn compliance_of(&self, taut: &[usize]) -> DMatrix<f64> {
        let d = self.d.select_columns(taut);
        let mut c = d.transpose() * (self.l0 * self.km_inv) * &d;
        for (i, &t) in taut.iter().enumerate() {
            c[(i, i)] += self.tendon_compliance[t];
        }
        c
    }

    fn compliance_inverse(&self, taut: &[usize]) -> Result<DMatrix<f64>, ModelError> {
        let c = self.compliance_of(taut);
        // Relative conditioning check: a near-singular Cm gives meaningless tensions.
        let sv = c.singular_values();
        let (max, min) = (sv.max(), sv.min());
        if min.is_nan() || min <= 1e-12 * max {
            return Err(ModelError::SingularCompliance {
                condition: max / min.max(f64::MIN_POSITIVE),
            });
        }
        c.try_inverse().ok_or(ModelError::SingularCompliance {
            condition: f64::INFINITY,
        })
    }

    /// `A = Km⁻¹ D Cm⁻¹` (4 × n), all tendons taut.
    pub fn forward_matrix(&self) -> Result<DMatrix<f64>, ModelError> {
        let all: Vec<usize> = (0..self.d.ncols()).collect();
        let a = self.km_inv * &self.d * self.compliance_inverse(&all)?;
        Ok(DMatrix::from_fn(4, a.ncols(), |r, c| a[(r, c)]))
    }

    /// Tensions `τ = Cm⁻¹ y` with every tendon taut (may be negative: see [`Model::forward`]).
    pub fn tensions(&self, y: &DVector<f64>) -> Result<DVector<f64>, ModelError> {
        self.check_len(y.len())?;
        let all: Vec<usize> = (0..self.d.ncols()).collect();
        Ok(self.compliance_inverse(&all)? * y)
    }

    /// The configuration for tendon displacements `y` (mm), with slack tendons found.
    pub fn forward(&self, y: &DVector<f64>) -> Result<Forward, ModelError> {
        self.check_len(y.len())?;
        let n = y.len();
        let mut taut: Vec<usize> = (0..n).collect();
        // Each step removes or restores one tendon; 4n steps is far beyond what a consistent
        // problem needs.
        for _ in 0..4 * n {
            let tau_taut = if taut.is_empty() {
                DVector::zeros(0)
            } else {
                self.compliance_inverse(&taut)?
                    * DVector::from_iterator(taut.len(), taut.iter().map(|&i| y[i]))
            };
            let mut tensions = DVector::zeros(n);
            for (k, &i) in taut.iter().enumerate() {
                tensions[i] = tau_taut[k];
            }
            let q = self.km_inv * &self.d * &tensions;
            // The most negative tension goes slack first.
            if let Some((k, _)) = tau_taut
                .iter()
                .enumerate()
                .filter(|(_, t)| **t < -1e-12)
                .min_by(|a, b| a.1.total_cmp(b.1))
            {
                taut.remove(k);
                continue;
            }
            // A slack tendon whose displacement exceeds what the shape takes up is pulled taut.
            let path = self.d.transpose() * (self.l0 * q);
            if let Some(i) = (0..n)
                .filter(|i| !taut.contains(i))
                .find(|&i| y[i] > path[i] + 1e-12)
            {
                taut.push(i);
                taut.sort_unstable();
                continue;
            }
            let slack = (0..n).filter(|i| !taut.contains(i)).collect();
            return Ok(Forward {
                q: Vector4::new(q[0], q[1], q[2], q[3]),
                tensions,
                slack,
            });
        }
        Err(ModelError::NoTautSet)
    }

    /// The minimum-norm tendon displacements (mm) giving `[κx, κz, ε0]` of `q` (the last row of
    /// `A` is pruned as in the paper: `ε1` follows from `ε0`, the axial rows being dependent).
    pub fn inverse(&self, q: &Vector4<f64>) -> Result<DVector<f64>, ModelError> {
        let a = self.forward_matrix()?;
        let pruned = a.rows(0, 3).into_owned();
        let target = DVector::from_column_slice(&[q[0], q[1], q[2]]);
        pruned
            .svd(true, true)
            .solve(&target, 1e-12)
            .map_err(|_| ModelError::SingularCompliance {
                condition: f64::INFINITY,
            })
    }

    fn check_len(&self, n: usize) -> Result<(), ModelError> {
        if n != self.d.ncols() {
            return Err(ModelError::TendonCount {
                found: n,
                expected: self.d.ncols(),
            });
        }
        Ok(())
    }
}

impl Forward {
    /// The header of [`Forward::csv_row`] for `tendons` tendons.
    pub fn csv_header(tendons: usize) -> String {
        let t: Vec<String> = (0..tendons).map(|i| format!("tension{i}_n")).collect();
        format!(
            "kappa_x_per_mm,kappa_z_per_mm,eps0,eps1,{},slack",
            t.join(",")
        )
    }

    /// The tensions (N, six decimals) and the slack tendons' indices as text.
    fn texts(&self) -> (Vec<String>, Vec<String>) {
        let tensions = self.tensions.iter().map(|t| format!("{t:.6}")).collect();
        let slack = self.slack.iter().map(|i| i.to_string()).collect();
        (tensions, slack)
    }

    /// `κx,κz,ε0,ε1` (1/mm), the tensions (N), and the slack tendons separated by spaces.
    pub fn csv_row(&self) -> String {
        let (tensions, slack) = self.texts();
        format!(
            "{:.9},{:.9},{:.9},{:.9},{},{}",
            self.q[0],
            self.q[1],
            self.q[2],
            self.q[3],
            tensions.join(","),
            slack.join(" ")
        )
    }
}

/// Three lines: the configuration, the tensions, the slack tendons.
impl std::fmt::Display for Forward {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let (tensions, slack) = self.texts();
        write!(
            f,
            "κx {:.6} 1/mm, κz {:.6} 1/mm, ε0 {:.6}, ε1 {:.6}\ntensions (N): {}\nslack tendons: {}",
            self.q[0],
            self.q[1],
            self.q[2],
            self.q[3],
            tensions.join(", "),
            if slack.is_empty() {
                "none".into()
            } else {
                slack.join(", ")
            }
        )
    }
}
