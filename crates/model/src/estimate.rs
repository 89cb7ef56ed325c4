//! Tensionless estimation of the manipulator's stiffnesses (paper, Section V-B, eq. 6):
//! eliminating the tensions, `Km·q = D Kt Lt⁻¹ (y − Dᵀ L0 q)`. With `D`, `Kt`, `Lt`, `L0`, `L1`
//! known, every data point (a sensed configuration `q` and its tendon displacements `y`) gives
//! the right-hand side `b`, and since `Km` is diagonal each stiffness is the least-squares
//! ratio `K_j = Σ q_j b_j / Σ q_j²` over the data.
//!
//! Beyond the paper: components of `q` a rig does not measure (e.g. `ε0` without a relaxed
//! reference pose) are taken from the nominal model and their stiffness is not estimated;
//! every estimate comes with its standard error from the fit's residuals; and the tip error
//! is measured against the sensed tip when one is given (the paper's Table I), not against
//! the arc approximation.

use nalgebra::{DMatrix, DVector, Point3, Vector4};

use crate::{ManipulatorParams, Model, ModelError, Stiffness, geometry};

/// One observation: a configuration `[κx, κz, ε0, ε1]` and the tendon displacements (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Sensed configuration (unmeasured components are ignored).
    pub q: Vector4<f64>,
    /// Which components of `q` were measured.
    pub measured: [bool; 4],
    /// Tendon displacements, mm.
    pub y: DVector<f64>,
    /// The sensed tip in the bending section's base frame (mm), when known.
    pub tip: Option<Point3<f64>>,
}

impl Observation {
    /// A fully measured configuration without a separate tip.
    pub fn new(q: Vector4<f64>, y: DVector<f64>) -> Self {
        Observation {
            q,
            measured: [true; 4],
            y,
            tip: None,
        }
    }
}

/// What the estimation found: the paper's Table I, second column.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The estimated `Km` (entries not estimated keep the nominal value).
    pub stiffness: Stiffness,
    /// Which of `[Kx, Kz, Ka0, Ka1]` were estimated from the data.
    pub estimated: [bool; 4],
    /// Standard error of each estimate from the fit's residuals, in its own unit (0 when not
    /// estimated).
    pub standard_error: [f64; 4],
    /// How strongly each estimate reacts to errors in the sensed configuration: the relative
    /// error of `K_j` per relative error of `q_j`, `1 + (D Kt Lt⁻¹ Dᵀ L)_jj / K_j` (for an
    /// axial stiffness the row's two axial terms, a strain bias being alike in both
    /// sections). Large when the tendons are stiff next to the manipulator (their stretch,
    /// which reveals the load, is then a small difference of large path lengths): a 0.3 %
    /// curvature bias becomes a 7.5 % stiffness bias at 25.
    pub sensitivity: [f64; 4],
    /// Ka0 and Ka1 in series, N per unit strain.
    pub serial_axial: f64,
    /// Mean distance between the bending section's tip predicted by the fitted model from `y`
    /// and the sensed one (or, without one, the tip of the sensed `q`), as a percentage of
    /// `L1`.
    pub tip_error_percent: f64,
    /// The largest such distance, % of `L1`.
    pub max_tip_error_percent: f64,
    /// Observations used.
    pub observations: usize,
    /// Every stiffness the data do not determine — held at its nominal value — with why and
    /// what experiment would determine it.
    pub held: Vec<Held>,
}

/// A stiffness held at its nominal value.
#[derive(Debug, Clone, PartialEq)]
pub struct Held {
    /// `Kx`, `Kz`, `Ka0` or `Ka1`.
    pub parameter: &'static str,
    /// Why the data do not determine it.
    pub reason: String,
    /// What poses would.
    pub remedy: &'static str,
}

/// How well sensed configurations are known beyond their scatter (1 σ): the biases of the
/// sensing, which no number of poses averages away.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensingAccuracy {
    /// Relative error of a sensed curvature (0.001: 0.1 %).
    pub curvature_share: f64,
    /// Error of a sensed axial strain (absolute).
    pub strain: f64,
    /// Error of a sensed tip or bending base position, mm (used by the joint
    /// identification, which fits positions rather than configurations).
    pub position_mm: f64,
}

impl Default for SensingAccuracy {
    /// The image fit's on the simulator: curvature bias within 0.1 % (`crates/fit/tests/
    /// accuracy.rs`), band spacing biased by about 0.05 mm over a 155 mm section (strain 3e-4),
    /// tips and bands within 0.1 mm.
    fn default() -> Self {
        SensingAccuracy {
            curvature_share: 0.001,
            strain: 3e-4,
            position_mm: 0.1,
        }
    }
}

/// Largest relative error (standard and sensing together) of a stiffness the poses determine.
pub const DETERMINED_SHARE: f64 = 0.10;

impl Estimate {
    /// Each estimate's error from `accuracy` (1 σ, its own unit; 0 where not estimated): a
    /// systematic error of the sensed component, relative to its RMS over `data`, amplified by
    /// [`Estimate::sensitivity`].
    pub fn sensing_error(&self, data: &[Observation], accuracy: &SensingAccuracy) -> [f64; 4] {
        let k = self.stiffness.diagonal();
        std::array::from_fn(|j| {
            if !self.estimated[j] {
                return 0.0;
            }
            let relative = if j < 2 {
                accuracy.curvature_share
            } else {
                let measured: Vec<f64> = data
                    .iter()
                    .filter(|o| o.measured[j])
                    .map(|o| o.q[j] * o.q[j])
                    .collect();
                let rms = (measured.iter().sum::<f64>() / measured.len().max(1) as f64).sqrt();
                if rms > 0.0 {
                    accuracy.strain / rms
                } else {
                    f64::INFINITY
                }
            };
            k[j] * self.sensitivity[j] * relative
        })
    }

    /// The standard and the sensing error together (root sum of squares).
    pub fn total_error(&self, data: &[Observation], accuracy: &SensingAccuracy) -> [f64; 4] {
        let sensing = self.sensing_error(data, accuracy);
        std::array::from_fn(|j| self.standard_error[j].hypot(sensing[j]))
    }

    /// Whether each stiffness is estimated to [`DETERMINED_SHARE`] or better, sensing
    /// included; when not, why, and what poses would do better.
    pub fn determined(
        &self,
        data: &[Observation],
        accuracy: &SensingAccuracy,
    ) -> [Result<(), Held>; 4] {
        let total = self.total_error(data, accuracy);
        let k = self.stiffness.diagonal();
        std::array::from_fn(|j| {
            let share = total[j] / k[j];
            if !self.estimated[j] || share <= DETERMINED_SHARE {
                return Ok(());
            }
            Err(Held {
                parameter: NAMES[j],
                reason: format!(
                    "±{:.0} % with the sensing accuracy ({} ±{}, amplified {:.1}× by the tendons): {} is too small next to what the sensing can tell",
                    100.0 * share,
                    if j < 2 { "curvature" } else { "strain" },
                    if j < 2 {
                        format!("{:.2} %", 100.0 * accuracy.curvature_share)
                    } else {
                        format!("{:.1e}", accuracy.strain)
                    },
                    self.sensitivity[j],
                    COMPONENTS[j]
                ),
                remedy: REMEDIES[j],
            })
        })
    }
}

const NAMES: [&str; 4] = ["Kx", "Kz", "Ka0", "Ka1"];

/// The configuration component each stiffness acts on.
const COMPONENTS: [&str; 4] = [
    "bending about x (κx)",
    "bending about z (κz)",
    "proximal compression (ε0)",
    "distal compression (ε1)",
];

/// What poses determine each stiffness.
const REMEDIES: [&str; 4] = [
    "add poses that bend the section about the model's x axis (pull the tendons on one side of it)",
    "add poses that bend the section about the model's z axis (pull the tendons on one side of it)",
    "add a relaxed reference pose and poses with all tendons pulled, with bands that measure the proximal section's length",
    "add poses with all tendons pulled, with bands that measure the distal section's length",
];

/// Least squares for the diagonal of `Km`; `params.stiffness` is the nominal value, used for
/// components of `q` that are not measured. A stiffness the data do not determine (its
/// component unmeasured, never exercised, or fitted to a non-positive value) is held at its
/// nominal value and listed in [`Estimate::held`]; the rest are estimated all the same.
/// Fails only for no data or malformed observations.
pub fn estimate_stiffness(
    params: &ManipulatorParams,
    data: &[Observation],
) -> Result<Estimate, ModelError> {
    let n = params.tendons.len();
    check(data, n)?;
    let nominal = Model::new(params.clone())?;
    let mut estimated: [bool; 4] = std::array::from_fn(|j| data.iter().all(|o| o.measured[j]));
    let mut held: Vec<Held> = (0..4)
        .filter(|&j| !estimated[j])
        .map(|j| Held {
            parameter: NAMES[j],
            reason: format!("{} is not measured in every pose", COMPONENTS[j]),
            remedy: REMEDIES[j],
        })
        .collect();
    // Complete each q with the nominal model where it was not measured.
    let mut qs = Vec::with_capacity(data.len());
    for o in data {
        let mut q = o.q;
        if o.measured.iter().any(|m| !m) {
            let predicted = nominal.forward(&o.y)?.q;
            for j in 0..4 {
                if !o.measured[j] {
                    q[j] = predicted[j];
                }
            }
        }
        qs.push(q);
    }
    let d = params.moment_arms();
    let (l0, l1) = (params.proximal_length, params.distal_length);
    let l = Vector4::new(l1, l1, l0, l1);
    let kt_over_lt =
        DVector::from_iterator(n, params.tendons.iter().map(|t| t.stiffness / t.length));
    let bs: Vec<Vector4<f64>> = data
        .iter()
        .zip(&qs)
        .map(|(o, q)| {
            let stretch = &o.y - d.transpose() * l.component_mul(q);
            let b = &d * stretch.component_mul(&kt_over_lt);
            Vector4::new(b[0], b[1], b[2], b[3])
        })
        .collect();
    let mut k = params.stiffness.diagonal();
    let mut standard_error = [0.0; 4];
    for j in 0..4 {
        if !estimated[j] {
            continue;
        }
        let qq: f64 = qs.iter().map(|q| q[j] * q[j]).sum();
        let qb: f64 = qs.iter().zip(&bs).map(|(q, b)| q[j] * b[j]).sum();
        let scale = qs.iter().map(|q| q[j].abs()).fold(0.0, f64::max);
        let kj = qb / qq;
        let why = if scale == 0.0 || qq <= (1e-12 * scale).powi(2) {
            Some(format!("no pose exercises {}", COMPONENTS[j]))
        } else if kj.is_nan() || kj <= 0.0 {
            Some(format!(
                "the poses give a non-positive value ({kj:.3e}): {} is too small next to the sensing noise",
                COMPONENTS[j]
            ))
        } else {
            None
        };
        if let Some(reason) = why {
            estimated[j] = false;
            held.push(Held {
                parameter: NAMES[j],
                reason,
                remedy: REMEDIES[j],
            });
            continue;
        }
        k[j] = kj;
        if data.len() > 1 {
            let rss: f64 = qs
                .iter()
                .zip(&bs)
                .map(|(q, b)| (b[j] - kj * q[j]).powi(2))
                .sum();
            standard_error[j] = (rss / (data.len() - 1) as f64 / qq).sqrt();
        }
    }
    let path_stiffness = &d * DMatrix::from_diagonal(&kt_over_lt) * d.transpose();
    // A strain bias reaches an axial estimate through both sections' compressions (the
    // tendons' path shortens by L0·ε0 + L1·ε1): counted for both, as if both were off alike.
    let sensitivity = std::array::from_fn(|j| {
        let path = if j < 2 {
            path_stiffness[(j, j)] * l[j]
        } else {
            (2..4).map(|m| (path_stiffness[(j, m)] * l[m]).abs()).sum()
        };
        1.0 + path / k[j]
    });
    let stiffness = Stiffness {
        kx: k[0],
        kz: k[1],
        ka0: k[2],
        ka1: k[3],
    };
    let fitted = ManipulatorParams {
        stiffness,
        ..params.clone()
    };
    let completed: Vec<Observation> = data
        .iter()
        .zip(&qs)
        .map(|(o, q)| Observation { q: *q, ..o.clone() })
        .collect();
    let (tip_error_percent, max_tip_error_percent) = tip_error(&fitted, &completed)?;
    Ok(Estimate {
        stiffness,
        estimated,
        standard_error,
        sensitivity,
        serial_axial: stiffness.serial_axial(),
        tip_error_percent,
        max_tip_error_percent,
        observations: data.len(),
        held,
    })
}

/// The Table I figure for a model: mean and largest distance between the bending section's tip
/// predicted from each observation's `y` and the sensed tip (or, without one, the tip of the
/// observation's `q`, which must then be fully measured), as percentages of `L1`.
pub fn tip_error(
    params: &ManipulatorParams,
    data: &[Observation],
) -> Result<(f64, f64), ModelError> {
    check(data, params.tendons.len())?;
    let model = Model::new(params.clone())?;
    let (mut sum, mut max) = (0.0, 0.0f64);
    for o in data {
        let predicted = geometry::bend_tip(params, &model.forward(&o.y)?.q);
        let sensed = o.tip.unwrap_or_else(|| geometry::bend_tip(params, &o.q));
        let e = (predicted - sensed).norm();
        sum += e;
        max = max.max(e);
    }
    let l1 = params.distal_length;
    Ok((100.0 * sum / data.len() as f64 / l1, 100.0 * max / l1))
}

fn check(data: &[Observation], n: usize) -> Result<(), ModelError> {
    if data.is_empty() {
        return Err(ModelError::Unobservable {
            what: "any stiffness",
            observations: 0,
        });
    }
    for (index, o) in data.iter().enumerate() {
        if o.y.len() != n {
            return Err(ModelError::Observation {
                index,
                problem: format!("{} tendon displacements for {n} tendons", o.y.len()),
            });
        }
        let finite = o.q.iter().zip(o.measured).all(|(v, m)| !m || v.is_finite())
            && o.y.iter().all(|v| v.is_finite())
            && o.tip.is_none_or(|t| t.iter().all(|v| v.is_finite()));
        if !finite {
            return Err(ModelError::Observation {
                index,
                problem: "NaN or infinite value".into(),
            });
        }
    }
    Ok(())
}
