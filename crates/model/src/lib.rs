//! The tendon-driven continuum manipulator model (paper, Section V): a straight proximal
//! section and a constant-curvature bending section driven by `n` tendons terminated at the
//! tip.
//!
//! - [`ManipulatorParams`]: tendons (moment arms, lengths, stiffnesses), section lengths, `Km`.
//! - [`Model`]: `Cm`, the forward map `q = A·y` with tensions and slack tendons, and the
//!   minimum-norm inverse.
//! - [`geometry`]: configuration → sections and tip (model frame: +y along the axis).
//! - [`experiment`]: the commands of the paper's experiment (reference, registration and
//!   workspace poses).
//! - [`SensorFrame`]: sensed shapes → configurations in the model frame (Section V-A).
//! - [`estimate_tendons`]: the tendons' positions (and optionally `Km`) by non-linear least
//!   squares, refused when the data do not determine them.
//! - [`estimate_stiffness`]: the tensionless estimation of `Km` from sensed shapes and tendon
//!   displacements (eq. 6), with the tip error of Table I.
//! - [`plan_experiment`]: the preload that lets every stiffness be determined, and the
//!   intervals a sensing accuracy gives.
//! - [`TipController`]: the tip steered to targets from sensed shapes, the stiffnesses
//!   refined online (the paper's future work).
//! - [`identify_jointly`]: stiffnesses, registration and tendon positions fitted together to
//!   the sensed tips (output error), from the two-step estimate.
//!
//! Units: mm, N, radians; curvature 1/mm; strains compression-positive.
//!
//! ```
//! use flexshape_model::nalgebra_types::Vector4;
//! use flexshape_model::{ManipulatorParams, Model};
//!
//! let model = Model::new(ManipulatorParams::paper_like())?;
//! // The tendon displacements (mm) that bend the section to 1/200 mm about x, 0.1 % compressed.
//! let y = model.inverse(&Vector4::new(0.005, 0.0, 0.001, 0.0))?;
//! // … and back: the configuration they give, and the tendons' tensions (N).
//! let f = model.forward(&y)?;
//! assert!((f.q[0] - 0.005).abs() < 1e-9 && f.q[1].abs() < 1e-9, "{:?}", f.q);
//! assert!(f.slack.is_empty() && f.tensions.iter().all(|t| *t > 0.0));
//! # Ok::<(), flexshape_model::ModelError>(())
//! ```

mod control;
mod estimate;
mod experiment;
pub mod geometry;
mod joint;
mod mechanics;
mod params;
mod plan;
mod plan_report;
mod sensing;
mod tendons;

use thiserror::Error;

pub use control::{ControlSettings, TipController};
pub use estimate::{
    DETERMINED_SHARE, Estimate, Held, Observation, SensingAccuracy, estimate_stiffness, tip_error,
};
pub use experiment::{CommandedPose, ExperimentPlan, Role, Sweep, experiment, taut_command};
pub use joint::{JointEstimate, JointPose, identify_jointly};
pub use mechanics::{Forward, Model};
pub use params::{ManipulatorParams, Stiffness, Tendon};
pub use plan::{ExperimentDesign, PlannedDesign, plan_experiment};
pub use plan_report::{PlanCandidate, PlanReport, candidate_preloads};
pub use sensing::{SensedPose, SensorFrame};
pub use tendons::{TendonEstimate, estimate_tendons};

/// The nalgebra types in this crate's signatures.
pub mod nalgebra_types {
    pub use nalgebra::{DVector, Point3, Rotation3, Vector3, Vector4};
}

/// Why the model cannot be built or evaluated.
#[derive(Debug, Error, PartialEq)]
pub enum ModelError {
    /// A parameter is out of range.
    #[error("model parameter `{field}`: {problem}")]
    Parameter {
        /// The parameter, e.g. `tendons[2].length`.
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// `Cm` cannot be inverted (e.g. two tendons at the same place).
    #[error(
        "the compliance matrix Cm is singular (condition {condition:.3e}); check for tendons at the same position"
    )]
    SingularCompliance {
        /// Its condition number.
        condition: f64,
    },
    /// A vector has the wrong number of tendon entries.
    #[error("{found} tendon values for a model with {expected} tendons")]
    TendonCount {
        /// Given.
        found: usize,
        /// Tendons in the model.
        expected: usize,
    },
    /// The active-set search for slack tendons did not settle.
    #[error("no consistent set of taut tendons was found for these displacements")]
    NoTautSet,
    /// An observation is malformed.
    #[error("observation {index}: {problem}")]
    Observation {
        /// Its index.
        index: usize,
        /// What is wrong.
        problem: String,
    },
    /// The sensor-to-model registration is not determined.
    #[error("cannot register the model frame: {0}")]
    Registration(String),
    /// The data do not determine a stiffness.
    #[error("cannot estimate {what} from {observations} observations; add poses that exercise it")]
    Unobservable {
        /// The stiffness and why.
        what: &'static str,
        /// Observations given.
        observations: usize,
    },
}
