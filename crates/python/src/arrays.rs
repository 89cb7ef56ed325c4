//! NumPy arrays to and from the library's images and point lists.

use image::RgbImage;
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDescrMethods, PyReadonlyArray3,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// An RGB image from a `(height, width, 3)` `uint8` array (copied: the pipeline keeps its
/// images in its own layout); `what` names it in an error.
pub(crate) fn image_from(array: &PyReadonlyArray3<'_, u8>, what: &str) -> PyResult<RgbImage> {
    let shape = array.shape();
    if shape[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: an image must have shape (height, width, 3), RGB, uint8; got {shape:?}"
        )));
    }
    let (height, width) = (shape[0], shape[1]);
    // `as_slice` also takes Fortran order (column-major bytes): only C order is copied whole.
    let bytes = match array.as_slice() {
        Ok(contiguous) if array.is_c_contiguous() => contiguous.to_vec(),
        // Strided or Fortran-ordered: copied in row-major order.
        _ => array.as_array().iter().copied().collect(),
    };
    let size = |n: usize| {
        u32::try_from(n).map_err(|_| PyValueError::new_err(format!("{what}: too large")))
    };
    RgbImage::from_raw(size(width)?, size(height)?, bytes)
        .ok_or_else(|| PyValueError::new_err(format!("{what}: the pixels do not fill the image")))
}

/// The order of a colour image's three channels: `"rgb"` (NumPy images from imageio, PIL,
/// flexshape) or `"bgr"` (OpenCV's `cv2.imread` and `VideoCapture`).
pub(crate) fn bgr(channels: &str) -> PyResult<bool> {
    match channels.to_ascii_lowercase().as_str() {
        "rgb" => Ok(false),
        "bgr" => Ok(true),
        _ => Err(PyValueError::new_err(format!(
            "channels={channels:?}: give \"rgb\", or \"bgr\" for OpenCV's images (cv2.imread, VideoCapture)"
        ))),
    }
}

/// Images from a list of arrays, one per camera, their channels in the order `channels`
/// names ([`bgr`]); `what` names them in errors. Anything but a `(height, width, 3)` `uint8`
/// array is a `ValueError` naming the item (`images[1]`), its shape or type, and what to give.
pub(crate) fn images_from(
    arrays: Vec<Bound<'_, PyAny>>,
    what: &str,
    channels: &str,
) -> PyResult<Vec<RgbImage>> {
    let swap = bgr(channels)?;
    arrays
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let name = format!("{what}[{k}]");
            let mut image = image_from(&image_array(a, &name)?, &name)?;
            if swap {
                for p in image.pixels_mut() {
                    p.0.swap(0, 2);
                }
            }
            Ok(image)
        })
        .collect()
}

/// A shape as NumPy prints it: `(480, 640)`, `(5,)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `object` as a `(height, width, 3)` `uint8` array, or a `ValueError` saying why not.
fn image_array<'py>(object: &Bound<'py, PyAny>, what: &str) -> PyResult<PyReadonlyArray3<'py, u8>> {
    let wanted = "give a NumPy array of shape (height, width, 3), dtype uint8, RGB";
    let Ok(array) = object.cast::<PyUntypedArray>() else {
        let kind = object
            .get_type()
            .name()
            .map_or_else(|_| "?".to_string(), |n| n.to_string());
        return Err(PyValueError::new_err(format!(
            "{what}: {wanted}; got a {kind}"
        )));
    };
    if array.ndim() != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: {wanted}; got shape {}{}",
            shape_text(array.shape()),
            if array.ndim() == 2 {
                " (a grey image: stack it to three channels)"
            } else {
                ""
            }
        )));
    }
    let dtype = array.dtype();
    if !dtype.is_equiv_to(&numpy::dtype::<u8>(object.py())) {
        return Err(PyValueError::new_err(format!(
            "{what}: {wanted}; got dtype {dtype} (convert with .astype(np.uint8) after scaling to 0–255)"
        )));
    }
    object.extract::<PyReadonlyArray3<'py, u8>>()
}

/// An RGB image as a `(height, width, 3)` `uint8` array.
pub(crate) fn image_to<'py>(py: Python<'py>, image: &RgbImage) -> Bound<'py, PyArray3<u8>> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    Array3::from_shape_vec((h, w, 3), image.as_raw().clone())
        .expect("an RgbImage holds height × width × 3 bytes")
        .into_pyarray(py)
}

/// Rows of `K` numbers (e.g. points, pixels) as an `(N, K)` `float64` array.
pub(crate) fn rows_to<'py, const K: usize>(
    py: Python<'py>,
    rows: &[[f64; K]],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), K), flat)
        .expect("N rows hold K N numbers")
        .into_pyarray(py)
}

/// Numbers as a 1-D `float64` array.
pub(crate) fn vector_to<'py>(py: Python<'py>, values: &[f64]) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(values.to_vec()).into_pyarray(py)
}

/// A JSON text as Python objects (dicts, lists, numbers, strings, None), by Python's `json`.
pub(crate) fn json_to_python<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// `value` as Python objects through its documented JSON form.
pub(crate) fn to_python<'py>(
    py: Python<'py>,
    value: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| crate::fail(&e))?;
    json_to_python(py, &text)
}
