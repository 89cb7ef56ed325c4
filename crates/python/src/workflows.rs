//! Calibrating a rig from target images, and identifying the manipulator model.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use flexshape_calib::Board;
use flexshape_calib::workflow::{
    CameraImages, RigCalibration, RigSettings, WorldFrame, calibrate_rig,
};
use flexshape_lab::identify::{
    Experiment, Identification, IdentifySettings, identify, load_model, read_displacements,
    records_of,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays::to_python;
use crate::rig::PyRig;
use crate::{fail, fail_with};

/// A calibrated rig and the reports it rests on (`flexshape calibrate`).
#[pyclass(name = "Calibration", module = "flexshape", frozen)]
pub(crate) struct PyCalibration {
    calibrated: RigCalibration,
}

#[pymethods]
impl PyCalibration {
    /// The calibrated rig: every camera in the world frame.
    #[getter]
    fn rig(&self) -> PyRig {
        PyRig {
            rig: self.calibrated.rig.clone(),
        }
    }

    /// Per camera: its calibration's report (intrinsics, distortion, reprojection RMS px,
    /// views kept and rejected), as `calibration.json` holds it.
    fn reports<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.calibrated.reports)
    }

    /// What the user should know (a failed joint adjustment, a moved volume, ...).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.calibrated.notes.clone()
    }

    /// Writes `rig.toml`, one OpenCV `NAME.yml` and ROS `ros/NAME.yaml` per camera,
    /// `calibration.json`, `calibration.txt` and the residual plots into the folder `out`
    /// (created if missing).
    fn write(&self, out: PathBuf) -> PyResult<()> {
        self.calibrated.write(&out).map_err(|e| fail(&e))
    }

    /// The summary `flexshape calibrate` prints, naming the files in `out`.
    #[pyo3(signature = (out = PathBuf::from(".")))]
    fn summary(&self, out: PathBuf) -> String {
        self.calibrated.summary(&out)
    }
}

/// Calibrates every camera from its images of a target and places them in one world frame
/// (the first camera's), as `flexshape calibrate` does. `images` maps each camera's name to
/// its image folder (or `DIR/PATTERN` with `*` and `?`), the first being the reference;
/// images taken together share a file name. `board` is `COLSxROWS` inner corners of a
/// chessboard or `charuco:SXxSY` squares of a ChArUco board (then give `marker_mm`);
/// `square_mm` the square size.
#[pyfunction]
#[pyo3(signature = (images, board, square_mm, marker_mm = None, dictionary = "DICT_4X4_50", fix_k3 = false))]
pub(crate) fn calibrate(
    py: Python<'_>,
    images: Vec<(String, PathBuf)>,
    board: &str,
    square_mm: f64,
    marker_mm: Option<f64>,
    dictionary: &str,
    fix_k3: bool,
) -> PyResult<PyCalibration> {
    let board = Board::from_spec(board, square_mm, marker_mm, dictionary)
        .map_err(|e| PyValueError::new_err(format!("board: {e}")))?;
    let cameras = CameraImages::find_all(&images).map_err(|e| fail(&e))?;
    let settings = RigSettings {
        calibration: flexshape_calib::CalibrationSettings {
            fix_k3,
            ..Default::default()
        },
        world: WorldFrame::Reference,
        ..Default::default()
    };
    let calibrated = py
        .detach(|| calibrate_rig(&cameras, &board, &settings, &mut || {}))
        .map_err(|e| fail(&e))?;
    Ok(PyCalibration { calibrated })
}

/// An identified manipulator model (`flexshape model fit`).
#[pyclass(name = "ModelFit", module = "flexshape", frozen)]
pub(crate) struct PyModelFit {
    found: Identification,
}

#[pymethods]
impl PyModelFit {
    /// The report as `flexshape model fit --json` prints it (stiffnesses Kx, Kz in N·mm²,
    /// Ka in N per unit strain, with their uncertainties and the fit's residuals).
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.found.report)
    }

    /// The model frame registered to the sensor, as `--save-frame` writes it.
    fn model_frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.found.model_frame())
    }

    fn __str__(&self) -> String {
        self.found.report.table()
    }
}

/// Identifies the tendon-driven model's stiffnesses from sensed shapes and tendon
/// displacements, tensionless, as `flexshape model fit` does. `params` is the model file
/// (TOML); `data` a `flexshape track` JSON Lines file or a recording folder (tracked here)
/// whose records carry the commanded displacements, or whose displacements are given per
/// frame in the CSV file `displacements` (`frame,y0,…`, mm). `tendons=True` estimates the
/// tendon positions too.
#[pyfunction]
#[pyo3(signature = (params, data, displacements = None, tendons = false, threads = 2))]
pub(crate) fn fit_model(
    py: Python<'_>,
    params: PathBuf,
    data: PathBuf,
    displacements: Option<PathBuf>,
    tendons: bool,
    threads: usize,
) -> PyResult<PyModelFit> {
    let model = load_model(&params).map_err(|e| fail(&e))?;
    let logged: BTreeMap<u64, Vec<f64>> = match &displacements {
        None => BTreeMap::new(),
        Some(path) => {
            read_displacements(path, model.params().tendons.len()).map_err(|e| fail(&e))?
        }
    };
    let stop = AtomicBool::new(false);
    let found = py.detach(|| {
        let records = records_of(&data, threads.max(1), &stop)?;
        let experiment = Experiment::from_records(records, &logged, &model, &data)?;
        let settings = IdentifySettings {
            tendons,
            ..Default::default()
        };
        identify(&model, &experiment, &settings)
    });
    let found =
        found.map_err(|e| fail_with(format!("{}: {}", data.display(), crate::chain(&e))))?;
    Ok(PyModelFit { found })
}
