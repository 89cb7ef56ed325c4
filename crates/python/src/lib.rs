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
mod rig;
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

/// `error` as a [`FlexshapeError`], with its causes, in Python's terms.
pub(crate) fn fail(error: &dyn std::error::Error) -> PyErr {
    fail_with(chain(error))
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

/// A [`FlexshapeError`] with `text`, in Python's terms: the library's advice names the
/// program's options, which are keyword arguments here.
pub(crate) fn fail_with(text: impl Into<String>) -> PyErr {
    FlexshapeError::new_err(python_terms(&text.into()))
}

/// The program's options that the library's messages name, as this package's arguments.
fn python_terms(text: &str) -> String {
    text.replace("--overwrite", "overwrite=True")
}

/// The module: its classes, functions and error type.
#[pymodule]
fn _flexshape(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FlexshapeError", m.py().get_type::<FlexshapeError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<record::PyRecord>()?;
    m.add_class::<rig::PyRig>()?;
    m.add_class::<rig::PyCamera>()?;
    m.add_class::<tracker::PyTracker>()?;
    m.add_function(wrap_pyfunction!(tracker::track, m)?)?;
    m.add_function(wrap_pyfunction!(tracker::read_records, m)?)?;
    m.add_function(wrap_pyfunction!(tracker::iter_track, m)?)?;
    m.add_class::<tracker::PyTrackIter>()?;
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
