//! The simulated rig: rendered cameras looking at a catheter with known ground truth.

use std::ops::ControlFlow;
use std::path::PathBuf;

use flexshape_lab::identify::load_model;
use flexshape_lab::simulate::{Scenario, simulate_recording};
use flexshape_model::{ExperimentPlan, ManipulatorParams};
use flexshape_sim::{CatheterPose, SimConfig, SimFrame, SimRigConfig, Simulator};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays::{image_to, rows_to, to_python, vector_to};
use crate::fail;
use crate::rig::PyRig;

/// The simulator's settings from the few a Python user sets (the rest as `flexshape simulate`
/// defaults them): `cams` cameras of `width` × `height` px (focal length 800 px at 640 px
/// width, scaled with it), seeded by `seed`, soft shadows when `shadows`.
fn config(seed: u64, cams: usize, size: (u32, u32), shadows: bool) -> PyResult<SimConfig> {
    if !(2..=8).contains(&cams) {
        return Err(PyValueError::new_err(format!(
            "cams={cams}: give 2 to 8 cameras"
        )));
    }
    let (width, height) = size;
    if width < 64 || height < 48 {
        return Err(PyValueError::new_err(format!(
            "size {width}x{height}: give at least 64x48 px"
        )));
    }
    let defaults = SimConfig::default();
    Ok(SimConfig {
        rig: SimRigConfig {
            cameras: cams,
            width,
            height,
            focal: 800.0 * f64::from(width) / 640.0,
            ..defaults.rig
        },
        render: flexshape_sim::RenderSettings {
            shadows,
            seed,
            ..defaults.render
        },
        seed,
        ..defaults
    })
}

/// A simulated rig: cameras around a catheter whose shape is known exactly. Use it to try
/// flexshape without hardware, or to plan a rig (how many cameras, where, what resolution).
#[pyclass(name = "Simulator", module = "flexshape", frozen)]
pub(crate) struct PySimulator {
    sim: Simulator,
}

#[pymethods]
impl PySimulator {
    /// The simulated rig of `cams` cameras at `width` × `height` px; `seed` fixes the
    /// poses, textures and noise; `shadows` casts soft shadows on the backdrops.
    #[new]
    #[pyo3(signature = (seed = 1, cams = 3, width = 640, height = 480, shadows = false))]
    fn new(
        py: Python<'_>,
        seed: u64,
        cams: usize,
        width: u32,
        height: u32,
        shadows: bool,
    ) -> PyResult<Self> {
        let config = config(seed, cams, (width, height), shadows)?;
        let sim = py.detach(|| Simulator::new(config)).map_err(|e| fail(&e))?;
        Ok(PySimulator { sim })
    }

    /// The rig the cameras form.
    #[getter]
    fn rig(&self) -> PyRig {
        PyRig {
            rig: self.sim.rig().clone(),
        }
    }

    /// Each camera's image of the empty scene, `(height, width, 3)` `uint8` RGB, in the rig's
    /// order: what `Tracker` takes as backgrounds.
    fn backgrounds<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray3<u8>>> {
        let images = py.detach(|| self.sim.backgrounds());
        images.iter().map(|i| image_to(py, i)).collect()
    }

    /// `frames` poses spread over the catheter's workspace (insertion and bending), as
    /// `flexshape simulate` films them.
    fn sweep(&self, frames: usize) -> Vec<PyPose> {
        self.sim
            .sweep(frames)
            .into_iter()
            .map(|pose| PyPose { pose })
            .collect()
    }

    /// `frames` poses of a smooth motion filmed at `rate_hz` frames per second (at 120 the
    /// tip moves up to about 1 mm a frame).
    #[pyo3(signature = (frames, rate_hz = 120.0))]
    fn motion(&self, frames: usize, rate_hz: f64) -> PyResult<Vec<PyPose>> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(PyValueError::new_err(format!(
                "rate_hz={rate_hz}: give a positive rate"
            )));
        }
        Ok(self
            .sim
            .motion(frames, rate_hz)
            .into_iter()
            .map(|pose| PyPose { pose })
            .collect())
    }

    /// Renders frame number `frame` of the catheter in `pose`: every camera's image and the
    /// ground truth.
    fn render(&self, py: Python<'_>, frame: u64, pose: &PyPose) -> PyResult<PySimFrame> {
        let rendered = py
            .detach(|| self.sim.render(frame, &pose.pose))
            .map_err(|e| fail(&e))?;
        Ok(PySimFrame { frame: rendered })
    }
}

/// A pose of the simulated catheter (from `Simulator.sweep` or `Simulator.motion`).
#[pyclass(name = "Pose", module = "flexshape", frozen)]
pub(crate) struct PyPose {
    pose: CatheterPose,
}

#[pymethods]
impl PyPose {
    fn __repr__(&self) -> String {
        format!("{:?}", self.pose)
    }
}

/// One rendered frame: the cameras' images and the ground truth.
#[pyclass(name = "SimFrame", module = "flexshape", frozen)]
pub(crate) struct PySimFrame {
    frame: SimFrame,
}

#[pymethods]
impl PySimFrame {
    /// Every camera's image, `(height, width, 3)` `uint8` RGB, in the rig's order.
    #[getter]
    fn images<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray3<u8>>> {
        self.frame
            .views
            .iter()
            .map(|v| image_to(py, &v.image))
            .collect()
    }

    /// The true centerline from the proximal end to the tip, `(N, 3)` world mm (≤ 0.5 mm
    /// apart).
    #[getter]
    fn truth_centerline<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_to(py, &self.frame.truth.centerline)
    }

    /// The true tip, `(3,)` world mm.
    #[getter]
    fn truth_tip<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, &self.frame.truth.tip)
    }

    /// The whole ground truth as a dict (the recording's `truth/NNNNNN.json`, docs/formats.md).
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.frame.truth)
    }
}

/// Writes a simulated recording into the folder `out` (as `flexshape simulate` does; an
/// existing one only with `overwrite`): `frames` frames of poses spread over the workspace,
/// or of a smooth motion filmed at `rate_hz` when given. With `model` (a model file, see
/// `model_template`), the paper's experiment instead: the catheter posed by the tendon
/// model (a relaxed reference, one registration pose per tendon, then `frames` poses), the
/// commanded tendon displacements written beside the frames, as `flexshape simulate --model`
/// does. Returns the frames written.
#[pyfunction]
#[pyo3(signature = (out, frames = 10, seed = 1, cams = 3, rate_hz = None, model = None, overwrite = false))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments
pub(crate) fn simulate(
    py: Python<'_>,
    out: PathBuf,
    frames: usize,
    seed: u64,
    cams: usize,
    rate_hz: Option<f64>,
    model: Option<PathBuf>,
    overwrite: bool,
) -> PyResult<u64> {
    let config = config(seed, cams, (640, 480), false)?;
    let scenario = match (rate_hz, model) {
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "give rate_hz (a smooth motion) or model (the model's experiment), not both",
            ));
        }
        (None, Some(path)) => {
            let model = load_model(&path).map_err(|e| fail(&e))?;
            let plan = ExperimentPlan {
                poses: frames,
                ..ExperimentPlan::default()
            };
            Scenario::experiment(model, &plan).map_err(|e| fail(&e))?
        }
        (None, None) => Scenario::Sweep { frames },
        (Some(r), None) if r.is_finite() && r > 0.0 => Scenario::Motion {
            frames,
            rate_hz: r,
            shutter: 0.0,
            clocks: None,
            pace: 1.0,
        },
        (Some(r), None) => {
            return Err(PyValueError::new_err(format!(
                "rate_hz={r}: give a positive rate"
            )));
        }
    };
    let written = py.detach(|| {
        simulate_recording(config, &scenario, &out, overwrite, |_| {
            ControlFlow::Continue(())
        })
    });
    Ok(written.map_err(|e| fail(&e))?.0)
}

/// A model file to start from: the paper's catheter (lengths mm, forces N, Kx/Kz N·mm², Ka/Kt
/// N per unit strain), as `flexshape model template` prints it.
#[pyfunction]
pub(crate) fn model_template() -> PyResult<String> {
    let text = toml::to_string_pretty(&ManipulatorParams::paper_like())
        .map_err(|e| crate::fail_with(format!("cannot write the template: {e}")))?;
    Ok(format!(
        "# flexshape manipulator model: lengths mm, forces N, Kx/Kz N·mm², Ka/Kt N per unit strain\n{text}"
    ))
}
