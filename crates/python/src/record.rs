//! One frame's record, as `flexshape track` writes it to JSON Lines.

use flexshape_record::TrackRecord;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::{json_to_python, rows_to, vector_to};

/// One frame's shape and how far to trust it (the JSON Lines record of `flexshape track`,
/// documented in docs/formats.md). World frame of the rig, millimetres.
#[pyclass(name = "Record", module = "flexshape", frozen)]
pub(crate) struct PyRecord {
    pub(crate) record: TrackRecord,
}

impl PyRecord {
    /// The record of `record`.
    pub(crate) fn new(record: TrackRecord) -> Self {
        PyRecord { record }
    }
}

#[pymethods]
impl PyRecord {
    /// A record from its JSON (a line of `flexshape track`'s output, or `Record.json()`):
    /// how records are pickled and sent to other processes.
    #[new]
    fn from_json(json: &str) -> PyResult<Self> {
        let record: TrackRecord = serde_json::from_str(json).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!("json: not a flexshape record ({e})"))
        })?;
        Ok(PyRecord { record })
    }

    /// Pickling: the record rebuilt from its JSON, whole.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let class = py.get_type::<PyRecord>().into_any();
        Ok((class, (self.json()?,)))
    }

    /// Records are equal when their JSON records are (a value JSON cannot hold, a NaN,
    /// is `null` in both).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .extract::<PyRef<'_, PyRecord>>()
            .is_ok_and(|o| matches!((o.json(), self.json()), (Ok(a), Ok(b)) if a == b))
    }

    /// Frame number.
    #[getter]
    fn frame(&self) -> u64 {
        self.record.frame
    }

    /// Status: `ok` only when the shape explains every image; otherwise why not
    /// (e.g. `inconsistent`, `ambiguous`, `no_object`; docs/formats.md lists them).
    #[getter]
    fn status(&self) -> &str {
        self.record.status.as_str()
    }

    /// Whether the status is `ok`.
    #[getter]
    fn ok(&self) -> bool {
        self.record.status.is_ok()
    }

    /// Why the status is not `ok`, when it is not.
    #[getter]
    fn reason(&self) -> Option<&str> {
        self.record.reason.as_deref()
    }

    /// Centerline samples from the proximal end to the tip, `(N, 3)`, world mm.
    #[getter]
    fn centerline<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_to(py, &self.record.centerline)
    }

    /// The tip, `(3,)` world mm, or None without a shape.
    #[getter]
    fn tip<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.record.tip.map(|t| vector_to(py, &t))
    }

    /// Unit tangent at the tip, `(3,)` world, or None.
    #[getter]
    fn tip_direction<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.record.tip_direction.map(|t| vector_to(py, &t))
    }

    /// Length of the centerline, mm.
    #[getter]
    fn arc_length(&self) -> f64 {
        self.record.arc_length
    }

    /// Curvature at each centerline sample, 1/mm, `(N,)`.
    #[getter]
    fn curvature<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, &self.record.curvature)
    }

    /// Marker band centres, proximal to distal, `(B, 3)` world mm.
    #[getter]
    fn bands<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let centres: Vec<[f64; 3]> = self.record.bands.iter().map(|b| b.position).collect();
        rows_to(py, &centres)
    }

    /// The record as JSON (one line of `flexshape track`'s output).
    fn json(&self) -> PyResult<String> {
        serde_json::to_string(&self.record).map_err(|e| crate::fail(&e))
    }

    /// The record as a dict, every field of the JSON Lines record (docs/formats.md).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_python(py, &self.json()?)
    }

    fn __repr__(&self) -> String {
        let tip = match self.record.tip {
            Some([x, y, z]) => format!("[{x:.2}, {y:.2}, {z:.2}]"),
            None => "None".into(),
        };
        format!(
            "Record(frame={}, status='{}', tip={tip}, arc_length={:.2})",
            self.record.frame, self.record.status, self.record.arc_length
        )
    }
}
