//! Rigs and their cameras: what a lab reads of its calibration from Python.

use std::path::PathBuf;

use flexshape_camera::Camera;
use flexshape_rig::Rig;
use nalgebra::Point3;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyIndexError, PyKeyError, PyValueError};
use pyo3::prelude::*;

use crate::arrays::{rows_to, vector_to};
use crate::{chain, fail_with};

/// A camera rig: every camera's intrinsics, lens distortion and pose in one world frame, the
/// carving volume and the processing settings (the `rig.toml` of docs/formats.md).
#[pyclass(name = "Rig", module = "flexshape", frozen)]
#[derive(Clone)]
pub(crate) struct PyRig {
    pub(crate) rig: Rig,
}

#[pymethods]
impl PyRig {
    /// Opens a rig: a rig TOML file, or a folder of OpenCV camera files (with the default
    /// volume). Files in such a folder that are not camera files are skipped.
    #[staticmethod]
    fn open(path: PathBuf) -> PyResult<Self> {
        let (rig, _skipped) = Rig::open(&path).map_err(|e| {
            fail_with(format!(
                "{} is not a valid rig: {}",
                path.display(),
                chain(&e)
            ))
        })?;
        Ok(PyRig { rig })
    }

    /// The cameras' names, in the rig's order (the order images are given in).
    #[getter]
    fn cameras(&self) -> Vec<String> {
        self.rig.cameras.iter().map(|c| c.name.clone()).collect()
    }

    /// Each camera's image size, `(width, height)` px, in the rig's order.
    #[getter]
    fn image_sizes(&self) -> Vec<(u32, u32)> {
        self.rig
            .cameras
            .iter()
            .map(|c| (c.camera.intrinsics.width, c.camera.intrinsics.height))
            .collect()
    }

    /// Projects world points `(N, 3)` (mm) into camera `camera` (index in the rig's order) with
    /// its lens distortion: `(N, 2)` pixels, OpenCV's convention (pixel (0, 0) is the centre of
    /// the top-left pixel); NaN for a point behind the camera.
    fn project<'py>(
        &self,
        py: Python<'py>,
        camera: usize,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let index = camera;
        let cam = &self
            .rig
            .cameras
            .get(index)
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "camera {index}: the rig has {} cameras",
                    self.rig.cameras.len()
                ))
            })?
            .camera;
        project(py, cam, points)
    }

    /// One camera by name (`"cam0"`) or index (rig order, negative from the end): its
    /// intrinsics, distortion and pose as OpenCV has them.
    fn camera(&self, key: &Bound<'_, PyAny>) -> PyResult<PyCamera> {
        let index = self.index_of(key)?;
        let c = &self.rig.cameras[index];
        Ok(PyCamera {
            name: c.name.clone(),
            camera: c.camera.clone(),
        })
    }

    /// `rig["cam0"]` or `rig[0]`: as [`Self::camera`].
    fn __getitem__(&self, key: &Bound<'_, PyAny>) -> PyResult<PyCamera> {
        self.camera(key)
    }

    fn __len__(&self) -> usize {
        self.rig.cameras.len()
    }

    /// The rig in a few lines: each camera, where it looks from, and the volume.
    fn summary(&self) -> String {
        self.rig.summary()
    }

    fn __repr__(&self) -> String {
        let names: Vec<String> = self.cameras().iter().map(|n| format!("'{n}'")).collect();
        format!("Rig(cameras=[{}])", names.join(", "))
    }
}

impl PyRig {
    /// The rig index `key` (a camera's name, or an index counted from the end when negative)
    /// names; a `KeyError` or `IndexError` naming the cameras otherwise.
    fn index_of(&self, key: &Bound<'_, PyAny>) -> PyResult<usize> {
        let n = self.rig.cameras.len();
        if let Ok(name) = key.extract::<String>() {
            return self
                .rig
                .cameras
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| {
                    PyKeyError::new_err(format!(
                        "no camera {name:?}: the rig has {}",
                        self.cameras().join(", ")
                    ))
                });
        }
        let i: isize = key.extract().map_err(|_| {
            PyValueError::new_err("camera: give a camera's name (str) or its index (int)")
        })?;
        let at = if i < 0 { i + n as isize } else { i };
        if (0..n as isize).contains(&at) {
            Ok(at as usize)
        } else {
            Err(PyIndexError::new_err(format!(
                "camera {i}: the rig has {n} cameras"
            )))
        }
    }
}

/// One camera of a rig, as OpenCV has it: `x_cam = R · X_world + t` (mm), pixels from `K`
/// and the distortion coefficients `D` (k1, k2, p1, p2, k3[, k4, k5, k6, s1…s4, τx, τy]);
/// pixel (0, 0) is the centre of the top-left pixel. The arrays are copies.
#[pyclass(name = "Camera", module = "flexshape", frozen)]
#[derive(Clone)]
pub(crate) struct PyCamera {
    name: String,
    camera: Camera,
}

#[pymethods]
impl PyCamera {
    /// Its name in the rig.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// `(width, height)` px.
    #[getter]
    fn image_size(&self) -> (u32, u32) {
        (self.camera.intrinsics.width, self.camera.intrinsics.height)
    }

    /// The camera matrix `[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`, `(3, 3)` px.
    #[getter]
    #[allow(non_snake_case)]
    fn K<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix_to(py, &self.camera.intrinsics.matrix())
    }

    /// The distortion coefficients in OpenCV's order, `(5,)` (or more for the rational and
    /// thin-prism models).
    #[getter]
    #[allow(non_snake_case)]
    fn D<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, &self.camera.intrinsics.distortion.to_opencv())
    }

    /// The rotation world → camera, `(3, 3)`.
    #[getter]
    #[allow(non_snake_case)]
    fn R<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix_to(py, self.camera.pose.rotation.matrix())
    }

    /// The translation world → camera, `(3,)` mm.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, self.camera.pose.translation.as_slice())
    }

    /// The rotation as OpenCV's Rodrigues vector, `(3,)` rad (`cv2.Rodrigues(R)`).
    #[getter]
    fn rvec<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, self.camera.pose.rvec().as_slice())
    }

    /// The camera's centre in the world frame, `(3,)` mm (`−Rᵀ t`).
    #[getter]
    fn centre<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_to(py, self.camera.centre().coords.as_slice())
    }

    /// Projects world points `(N, 3)` (mm) with the lens distortion: `(N, 2)` pixels; NaN
    /// for a point behind the camera.
    fn project<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        project(py, &self.camera, points)
    }

    fn __repr__(&self) -> String {
        let k = &self.camera.intrinsics;
        format!(
            "Camera('{}', {}x{}, fx={:.1}, fy={:.1})",
            self.name, k.width, k.height, k.fx, k.fy
        )
    }
}

/// A 3×3 matrix as a `(3, 3)` array, rows as rows.
fn matrix_to<'py>(py: Python<'py>, m: &nalgebra::Matrix3<f64>) -> Bound<'py, PyArray2<f64>> {
    let rows: Vec<[f64; 3]> = (0..3).map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]).collect();
    rows_to(py, &rows)
}

/// World points `(N, 3)` (mm) projected by `camera`: `(N, 2)` pixels, NaN behind it.
fn project<'py>(
    py: Python<'py>,
    camera: &Camera,
    points: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    if points.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "points: give an (N, 3) array of world points, mm; got {:?}",
            points.shape()
        )));
    }
    let pixels: Vec<[f64; 2]> = points
        .as_array()
        .rows()
        .into_iter()
        .map(|p| match camera.project(&Point3::new(p[0], p[1], p[2])) {
            Ok(q) => [q.pixel.x, q.pixel.y],
            Err(_) => [f64::NAN, f64::NAN],
        })
        .collect();
    Ok(rows_to(py, &pixels))
}
