//! The model's parameters: tendons, section lengths and stiffnesses. Lengths in mm, forces in N.

use serde::{Deserialize, Serialize};

use crate::ModelError;

/// One tendon.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tendon {
    /// Position in the section's cross-section, mm: x and z in the section frame (axis along y).
    pub dx: f64,
    /// See `dx`.
    pub dz: f64,
    /// Free length of the tendon (from its actuator to the tip), mm: `Lt`.
    pub length: f64,
    /// Axial stiffness of the tendon material, N per unit strain: `Kt`.
    pub stiffness: f64,
}

/// The manipulator's stiffness matrix `Km = diag(Kx, Kz, Ka0, Ka1)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stiffness {
    /// Bending about x, N·mm² (moment N·mm per curvature 1/mm).
    pub kx: f64,
    /// Bending about z, N·mm².
    pub kz: f64,
    /// Axial, proximal section, N per unit strain.
    pub ka0: f64,
    /// Axial, distal (bending) section, N per unit strain.
    pub ka1: f64,
}

impl Stiffness {
    /// The diagonal as `[Kx, Kz, Ka0, Ka1]`.
    pub fn diagonal(&self) -> [f64; 4] {
        [self.kx, self.kz, self.ka0, self.ka1]
    }

    /// The two axial springs in series, N per unit strain.
    pub fn serial_axial(&self) -> f64 {
        1.0 / (1.0 / self.ka0 + 1.0 / self.ka1)
    }
}

/// A two-section tendon-driven manipulator: a straight proximal section of length `L0` and a
/// bending section of length `L1`, all tendons terminated at the tip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManipulatorParams {
    /// Proximal section length `L0`, mm.
    pub proximal_length: f64,
    /// Bending section length `L1`, mm.
    pub distal_length: f64,
    /// The tendons.
    pub tendons: Vec<Tendon>,
    /// `Km`.
    pub stiffness: Stiffness,
}

impl ManipulatorParams {
    /// The paper's catheter shape (Section V): four tendons at 90° on a 1.5 mm radius, a 160 mm
    /// bending section, and stiffnesses of the order of Table I's.
    pub fn paper_like() -> Self {
        let tendon = |dx: f64, dz: f64| Tendon {
            dx,
            dz,
            length: 1200.0,
            stiffness: 1.4e4,
        };
        ManipulatorParams {
            proximal_length: 1000.0,
            distal_length: 160.0,
            // At 90° on a 1.5 mm radius.
            tendons: vec![
                tendon(1.5, 0.0),
                tendon(0.0, 1.5),
                tendon(-1.5, 0.0),
                tendon(0.0, -1.5),
            ],
            stiffness: Stiffness {
                kx: 352.0,
                kz: 611.0,
                ka0: 4000.0,
                ka1: 6000.0,
            },
        }
    }

    /// `D` (4 × n): per tendon the column `[dz, −dx, 1, 1]` — its moment arms about x and z and
    /// its share of the axial load of each section.
    pub fn moment_arms(&self) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_fn(4, self.tendons.len(), |r, c| {
            let t = &self.tendons[c];
            match r {
                0 => t.dz,
                1 => -t.dx,
                _ => 1.0,
            }
        })
    }

    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        let positive = |field: String, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::Parameter {
                    field,
                    problem: format!("{v} must be a positive number"),
                })
            }
        };
        positive("proximal_length".into(), self.proximal_length)?;
        positive("distal_length".into(), self.distal_length)?;
        let s = &self.stiffness;
        for (name, v) in [("kx", s.kx), ("kz", s.kz), ("ka0", s.ka0), ("ka1", s.ka1)] {
            positive(format!("stiffness.{name}"), v)?;
        }
        if self.tendons.len() < 2 {
            return Err(ModelError::Parameter {
                field: "tendons".into(),
                problem: format!("{} tendons; the model needs at least 2", self.tendons.len()),
            });
        }
        for (i, t) in self.tendons.iter().enumerate() {
            positive(format!("tendons[{i}].length"), t.length)?;
            positive(format!("tendons[{i}].stiffness"), t.stiffness)?;
            if !(t.dx.is_finite() && t.dz.is_finite()) || t.dx.hypot(t.dz) == 0.0 {
                return Err(ModelError::Parameter {
                    field: format!("tendons[{i}]"),
                    problem: "dx, dz must be finite and off the axis".into(),
                });
            }
        }
        Ok(())
    }
}
