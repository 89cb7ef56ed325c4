//! flexshape for Python: the extension module `flexshape._flexshape`, which the Python
//! package `flexshape` (in `python/flexshape`, with its type hints) re-exports.
//!
//! What a lab calls from Python, each a thin wrapper over the library function the `flexshape`
//! program calls: open a rig (`Rig.open`), track a recording (`track`) or frames from the
//! lab's own cameras (`Tracker.process`), read a record stream (`read_records`), simulate a
//! rig (`Simulator`, `simulate`), calibrate cameras (`calibrate`) and identify the manipulator
//! model (`fit_model`). Units and frames are the library's: millimetres and radians, the
//! rig's world frame, OpenCV camera conventions. Images are NumPy arrays of shape
//! `(height, width, 3)`, `uint8`, RGB; point sets are `(N, 3)` `float64` arrays.
//!
//! Build and install the package with `pip install ./crates/python` (maturin builds the
//! module); the Python suite runs in the workspace's tests (`tests/pytest.rs`). The
//! computation runs without the interpreter's lock, so other Python threads go on.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

mod arrays;
mod record;
mod sim;
mod tracker;
mod workflows;

create_exception!(
    _flexshape,
    FlexshapeError,
    PyException,
    "A flexshape error: bad input (a file, a field, a frame) or a failed computation; the \
     message says what and what to do."
);

/// `error` as a [`FlexshapeError`], with its causes.
pub(crate) fn fail(error: &dyn std::error::Error) -> PyErr {
    FlexshapeError::new_err(chain(error))
}

/// `error` and its causes as one line, each cause appended where the text before leaves it
/// out.
pub(crate) fn chain(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let said = cause.to_string();
        if !text.contains(&said) {
            text = format!("{text}: {said}");
        }
        source = cause.source();
    }
    text
}

/// A [`FlexshapeError`] with `text`.
pub(crate) fn fail_with(text: impl Into<String>) -> PyErr {
    FlexshapeError::new_err(text.into())
}

/// The module: its classes, functions and error type.
#[pymodule]
fn _flexshape(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FlexshapeError", m.py().get_type::<FlexshapeError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<record::PyRecord>()?;
    m.add_class::<tracker::PyRig>()?;
    m.add_class::<tracker::PyTracker>()?;
    m.add_function(wrap_pyfunction!(tracker::track, m)?)?;
    m.add_function(wrap_pyfunction!(tracker::read_records, m)?)?;
    m.add_class::<sim::PySimulator>()?;
    m.add_class::<sim::PyPose>()?;
    m.add_class::<sim::PySimFrame>()?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::model_template, m)?)?;
    m.add_class::<workflows::PyCalibration>()?;
    m.add_class::<workflows::PyModelFit>()?;
    m.add_function(wrap_pyfunction!(workflows::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(workflows::fit_model, m)?)?;
    Ok(())
}
