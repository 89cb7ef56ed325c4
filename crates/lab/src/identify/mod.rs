//! The manipulator model identified from a tracked experiment (the paper's Section IV and
//! Table I, `flexshape model fit`): the model frame registered to the sensor from the
//! articulated poses, the tensionless stiffness estimate (eq. 6) with its errors, optionally
//! the tendon positions, and the joint output-error identification started from it.

mod data;
mod figure;
mod report;

use std::path::Path;

use flexshape_model::nalgebra_types::{DVector, Point3, Rotation3, Vector3};
use flexshape_model::{
    ManipulatorParams, Model, Observation, SensedPose, SensingAccuracy, SensorFrame,
    estimate_stiffness, estimate_tendons, tip_error,
};
use flexshape_record::ModelFrame;
use flexshape_recording::PoseRole;

pub use data::{Experiment, ExperimentPose, read_displacements, records_of};
pub use report::{HeldReport, JointReport, ModelFitReport, TendonReport};

use crate::LabError;

/// A manipulator model from its parameter file (TOML, `flexshape model template` writes
/// one; lengths mm, forces N, Kx/Kz N·mm², Ka/Kt N per unit strain).
pub fn load_model(path: &Path) -> Result<Model, LabError> {
    let text = flexshape_rig::files::read_text(path, "model parameter file")?;
    let params: ManipulatorParams = toml::from_str(&text).map_err(|e| {
        LabError::data(
            path.display(),
            format!("not a model parameter file: {}", e.message()),
        )
    })?;
    Model::new(params).map_err(LabError::model(path.display().to_string()))
}

/// The model frame `flexshape model fit --save-frame` wrote (JSON), checked to be a
/// rotation.
pub fn load_model_frame(path: &Path) -> Result<ModelFrame, LabError> {
    let text = flexshape_rig::files::read_text(path, "model frame")?;
    let frame: ModelFrame = serde_json::from_str(&text).map_err(|e| {
        LabError::data(
            path.display(),
            format!("not a model frame (write one with `flexshape model fit --save-frame`): {e}"),
        )
    })?;
    frame
        .validate()
        .map_err(|e| LabError::data(path.display(), e))?;
    Ok(frame)
}

/// How the model is identified.
#[derive(Debug, Clone, Default)]
pub struct IdentifySettings {
    /// Estimate the tendon positions too.
    pub tendons: bool,
    /// How well the sensing places the sensed configurations, for the stiffnesses' errors.
    pub accuracy: SensingAccuracy,
    /// A model frame already registered (`--frame`): used instead of registering one.
    pub known_frame: Option<ModelFrame>,
}

/// What an identification found.
#[derive(Debug, Clone)]
pub struct Identification {
    /// The report (`flexshape model fit --json`).
    pub report: ModelFitReport,
    /// The model frame registered to the sensor (or the one given).
    pub frame: SensorFrame,
    /// The model with the estimated stiffnesses.
    pub fitted: Model,
}

impl Identification {
    /// The model frame as a file (`--save-frame`; read back by [`load_model_frame`] and by
    /// tracking, which then reports κx, κz in the model's frame).
    pub fn model_frame(&self) -> ModelFrame {
        let m = self.frame.rotation.matrix();
        ModelFrame {
            rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
            reference_base: self.frame.reference_base.map(|p| [p.x, p.y, p.z]),
            residual_deg: self.report.registration_residual_deg,
        }
    }

    /// Draws the sensed shapes against the fitted model's prediction (the paper's Fig. 10)
    /// into `dir` as `model_vs_sensed.png`/`.svg`.
    pub fn figure(&self, experiment: &Experiment, dir: &Path) -> Result<(), LabError> {
        let data: Vec<&ExperimentPose> = experiment
            .poses
            .iter()
            .filter(|p| !p.is_reference())
            .collect();
        figure::model_vs_sensed(dir, &self.fitted, &self.frame, &data)
    }
}

/// Identifies `model`'s stiffnesses from `experiment`: the relaxed reference pose gives ε0's
/// origin, the poses marked `register` (else all) register the model frame, and every
/// other pose is an observation.
pub fn identify(
    model: &Model,
    experiment: &Experiment,
    settings: &IdentifySettings,
) -> Result<Identification, LabError> {
    let reference = experiment
        .poses
        .iter()
        .find(|p| p.is_reference())
        .map(|p| &p.sensed);
    let data: Vec<&ExperimentPose> = experiment
        .poses
        .iter()
        .filter(|p| !p.is_reference())
        .collect();
    let marked: Vec<(DVector<f64>, SensedPose)> = data
        .iter()
        .filter(|p| p.role == Some(PoseRole::Register))
        .map(|p| (p.y.clone(), p.sensed.clone()))
        .collect();
    // Without marked registration poses, every pose registers (by the nominal model).
    let articulated = if marked.is_empty() {
        data.iter()
            .map(|p| (p.y.clone(), p.sensed.clone()))
            .collect()
    } else {
        marked
    };
    let (frame, registered) = match &settings.known_frame {
        // A relaxed pose places ε0's origin where the file does not.
        Some(f) => {
            let mut frame = sensor_frame(f);
            frame.reference_base = frame.reference_base.or(reference.map(|r| r.base));
            (frame, 0)
        }
        None => (
            SensorFrame::register(model, reference, &articulated).map_err(LabError::model(
                "cannot register the model frame to the sensor",
            ))?,
            articulated.len(),
        ),
    };
    let observations: Vec<Observation> = data
        .iter()
        .map(|p| frame.observation(model, &p.sensed, p.y.clone()))
        .collect();
    let estimate = estimate_stiffness(model.params(), &observations)
        .map_err(LabError::model("cannot estimate the stiffnesses"))?;
    let fitted_params = ManipulatorParams {
        stiffness: estimate.stiffness,
        ..model.params().clone()
    };
    let fitted =
        Model::new(fitted_params.clone()).map_err(LabError::model("the estimated stiffnesses"))?;
    // The nominal model's tip error needs complete configurations only where no tip is
    // sensed; every observation here has one.
    let (nominal_mean, nominal_max) = tip_error(model.params(), &observations)
        .map_err(LabError::model("the nominal model's tip error"))?;
    let nominal = model.params().stiffness;
    let tendons = settings
        .tendons
        .then(|| tendon_report(&fitted_params, &observations));
    let accuracy = &settings.accuracy;
    let two_step_error = estimate.total_error(&observations, accuracy);
    let joint = JointReport::new(
        &fitted_params,
        &frame,
        &data,
        settings.tendons,
        accuracy,
        &two_step_error,
    );
    let m = frame.rotation.matrix();
    let report = ModelFitReport {
        nominal: nominal.diagonal(),
        estimated: estimate.stiffness.diagonal(),
        estimated_from_data: estimate.estimated,
        standard_error: estimate.standard_error,
        sensing_error: estimate.sensing_error(&observations, accuracy),
        total_error: two_step_error,
        undetermined: estimate
            .determined(&observations, accuracy)
            .into_iter()
            .filter_map(Result::err)
            .map(HeldReport::from)
            .collect(),
        sensitivity: estimate.sensitivity,
        serial_axial: [nominal.serial_axial(), estimate.serial_axial],
        tip_error_percent: [nominal_mean, estimate.tip_error_percent],
        max_tip_error_percent: [nominal_max, estimate.max_tip_error_percent],
        observations: estimate.observations,
        held: estimate
            .held
            .iter()
            .cloned()
            .map(HeldReport::from)
            .collect(),
        registration_poses: registered,
        reference_pose: frame.reference_base.is_some(),
        skipped: experiment.skipped.clone(),
        registration_residual_deg: [
            frame.axis_residual.to_degrees(),
            frame.direction_residual.to_degrees(),
        ],
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        tendons,
        joint,
    };
    Ok(Identification {
        report,
        frame,
        fitted,
    })
}

/// A saved model frame as the model's sensor frame.
fn sensor_frame(f: &ModelFrame) -> SensorFrame {
    // Rows of an orthonormal matrix (checked when loaded).
    let [x, y, z] =
        [0, 1, 2].map(|c| Vector3::new(f.rotation[0][c], f.rotation[1][c], f.rotation[2][c]));
    SensorFrame {
        rotation: Rotation3::from_basis_unchecked(&[x, y, z]),
        reference_base: f.reference_base.map(Point3::from),
        axis_residual: 0.0,
        direction_residual: 0.0,
    }
}

/// The tendon positions from the observations with every configuration measured.
fn tendon_report(fitted: &ManipulatorParams, observations: &[Observation]) -> TendonReport {
    let complete: Vec<Observation> = observations
        .iter()
        .filter(|o| o.measured.iter().all(|m| *m))
        .cloned()
        .collect();
    match estimate_tendons(fitted, &complete, false) {
        Ok(t) => TendonReport {
            positions: t.params.tendons.iter().map(|t| [t.dx, t.dz]).collect(),
            standard_error: t.standard_error,
            condition: t.condition,
            rms_mm: t.rms_mm,
            refused: None,
        },
        Err(e) => TendonReport {
            positions: Vec::new(),
            standard_error: Vec::new(),
            condition: f64::INFINITY,
            rms_mm: f64::NAN,
            refused: Some(e.to_string()),
        },
    }
}
