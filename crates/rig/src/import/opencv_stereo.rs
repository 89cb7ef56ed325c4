//! OpenCV's stereo calibration as labs save it: what `cv2.stereoCalibrate` returns —
//! `K1, D1, K2, D2, R, T` (often beside `E, F, R1, R2, P1, P2, Q`, which are not needed) — in
//! a `cv::FileStorage` file (`.yml`/`.yaml`/`.xml` is not read; `.json`), or a NumPy `.npz`
//! (`np.savez`, compressed or not).
//!
//! Names: `K1`, `M1`, `cameraMatrix1`, `mtx1` or `mtxL` for the first camera's matrix, `D1`,
//! `dist1`, `distCoeffs1` or `distL` for its distortion (4, 5, 8, 12 or 14 coefficients),
//! likewise with `2`/`R` for the second; `R` and `T` the second camera's pose in the first's
//! frame (`x₂ = R·x₁ + T`). The image size, where the file has it: `imageSize`,
//! `image_size` or `size` as `[width, height]` (OpenCV's `Size` order), or `image_width`
//! and `image_height`; else it must be given.
//!
//! The first camera (`cam0`) defines the world frame; the second is `cam1`. `T` is in the
//! calibration target's unit, which the file does not say.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use serde::Deserialize;

use super::{Imported, Unit, camera_error, finite, npy};
use crate::RigError;
use crate::opencv_matrix::RawMatrix;

/// Accepted names of each array, first match wins.
const K1: &[&str] = &["K1", "M1", "cameraMatrix1", "mtx1", "mtxL"];
const D1: &[&str] = &["D1", "dist1", "distCoeffs1", "distL"];
const K2: &[&str] = &["K2", "M2", "cameraMatrix2", "mtx2", "mtxR"];
const D2: &[&str] = &["D2", "dist2", "distCoeffs2", "distR"];
const SIZE: &[&str] = &["imageSize", "image_size", "size"];

/// An array read from the file: its shape (rows, columns; a vector is n × 1) and values in
/// row-major order.
type Array = (usize, usize, Vec<f64>);

/// The file's arrays by name.
type Arrays = BTreeMap<String, Array>;

/// A FileStorage entry: a matrix or vector, a number, or something not needed.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Entry {
    Matrix(RawMatrix),
    Number(f64),
    Other(serde::de::IgnoredAny),
}

/// The two cameras of a stereo calibration file, and notes for the user. `size` is the image
/// size where the file lacks it.
pub fn read(
    path: &Path,
    unit: Unit,
    size: Option<(u32, u32)>,
) -> Result<(Vec<Imported>, Vec<String>), RigError> {
    let arrays = arrays(path)?;
    let field = |names: &[&str]| -> Result<(String, Array), RigError> {
        names
            .iter()
            .find_map(|n| arrays.get(*n).map(|a| (n.to_string(), a.clone())))
            .ok_or_else(|| {
                RigError::field(
                    path,
                    names[0],
                    format!(
                        "missing (looked for {}; found {})",
                        names.join(", "),
                        arrays.keys().cloned().collect::<Vec<_>>().join(", ")
                    ),
                )
            })
    };
    let mut notes = Vec::new();
    let from_file = file_size(path, &arrays)?;
    let (w, h) = match (from_file, size) {
        (Some(s), given) => {
            if given.is_some_and(|g| g != s) {
                notes.push(format!(
                    "the file gives the image size {}×{}; the size given was not used",
                    s.0, s.1
                ));
            }
            s
        }
        (None, Some(s)) => s,
        (None, None) => {
            return Err(RigError::field(
                path,
                "imageSize",
                "the file does not hold the image size: give it (WxH)",
            ));
        }
    };
    let intrinsics = |k: &[&str], d: &[&str]| -> Result<Intrinsics, RigError> {
        let (kname, (rows, cols, kv)) = field(k)?;
        if (rows, cols) != (3, 3) {
            return Err(RigError::field(
                path,
                &kname,
                format!("{rows}×{cols}: a camera matrix is 3×3"),
            ));
        }
        for v in &kv {
            finite(path, &kname, *v)?;
        }
        let scale = kv[0].abs().max(kv[4].abs());
        if kv[1].abs() > 1e-9 * scale
            || kv[3] != 0.0
            || kv[6] != 0.0
            || kv[7] != 0.0
            || kv[8] != 1.0
        {
            return Err(RigError::field(
                path,
                &kname,
                "not [fx 0 cx; 0 fy cy; 0 0 1] (a skew or a scaled matrix): not OpenCV's camera model",
            ));
        }
        let (dname, (_, _, dv)) = field(d)?;
        let distortion = Distortion::from_opencv(&dv).map_err(|e| camera_error(path, &dname, e))?;
        Intrinsics::new(w, h, kv[0], kv[4], kv[2], kv[5], distortion)
            .map_err(|e| camera_error(path, &kname, e))
    };
    let first = intrinsics(K1, D1)?;
    let second = intrinsics(K2, D2)?;
    let (_, (rows, cols, r)) = field(&["R"])?;
    if (rows, cols) != (3, 3) {
        return Err(RigError::field(
            path,
            "R",
            format!("{rows}×{cols}: a rotation is 3×3 (a Rodrigues vector is not read here)"),
        ));
    }
    for v in &r {
        finite(path, "R", *v)?;
    }
    let r = Matrix3::from_row_slice(&r);
    let (_, (rows, cols, t)) = field(&["T"])?;
    if rows * cols != 3 {
        return Err(RigError::field(
            path,
            "T",
            format!("{} values: a translation has 3", rows * cols),
        ));
    }
    for v in &t {
        finite(path, "T", *v)?;
    }
    let t = Vector3::new(t[0], t[1], t[2]) * unit.mm();
    notes.push(format!(
        "cam0 is the calibration's first camera and the world frame (origin and axes); cam1 sits {:.1} mm from it",
        t.norm()
    ));
    // The camera files' own test of a rotation (orthonormal within 1e-6, determinant +1).
    let pose = Pose::from_matrix(&r, t).map_err(|e| camera_error(path, "R", e))?;
    Ok((
        vec![
            Imported {
                name: "cam0".into(),
                camera: Camera::new(first, Pose::identity()),
            },
            Imported {
                name: "cam1".into(),
                camera: Camera::new(second, pose),
            },
        ],
        notes,
    ))
}

/// The image size the file holds, if any.
fn file_size(path: &Path, arrays: &Arrays) -> Result<Option<(u32, u32)>, RigError> {
    let size = |field: &str, v: f64| -> Result<u32, RigError> {
        if v.fract() == 0.0 && v >= 1.0 && v <= f64::from(u32::MAX) {
            Ok(v as u32)
        } else {
            Err(RigError::field(
                path,
                field,
                format!("{v} is not an image size in pixels"),
            ))
        }
    };
    if let Some((name, (_, _, v))) = SIZE.iter().find_map(|n| arrays.get(*n).map(|a| (n, a))) {
        if v.len() != 2 {
            return Err(RigError::field(
                path,
                *name,
                format!("{} values: give [width, height]", v.len()),
            ));
        }
        return Ok(Some((size(name, v[0])?, size(name, v[1])?)));
    }
    match (arrays.get("image_width"), arrays.get("image_height")) {
        (Some((_, _, w)), Some((_, _, h))) if w.len() == 1 && h.len() == 1 => Ok(Some((
            size("image_width", w[0])?,
            size("image_height", h[0])?,
        ))),
        _ => Ok(None),
    }
}

/// Every array (and number) in the file, by name.
fn arrays(path: &Path) -> Result<Arrays, RigError> {
    let is = |ext: &str| {
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(ext))
    };
    if is("npz") {
        return npz(path);
    }
    let text = crate::files::read_text(path, "stereo calibration").map_err(RigError::from)?;
    let syntax = |message: String| RigError::Syntax {
        file: path.to_path_buf(),
        message,
    };
    let entries: BTreeMap<String, Entry> = if is("json") {
        serde_json::from_str(&text).map_err(|e| syntax(format!("invalid JSON: {e}")))?
    } else {
        // As for camera files: the tag says nothing the keys do not.
        let untagged = text.replace("!!opencv-matrix", "");
        serde_saphyr::from_str(&untagged).map_err(|e| {
            syntax(format!(
                "invalid YAML ({e}); an .npz must end in .npz, FileStorage XML is not read"
            ))
        })?
    };
    let mut arrays = Arrays::new();
    for (name, entry) in entries {
        match entry {
            Entry::Matrix(m) => {
                let shaped = m
                    .elements()
                    .map_err(|problem| RigError::field(path, &name, problem))?;
                arrays.insert(name, shaped);
            }
            Entry::Number(v) => {
                arrays.insert(name, (1, 1, vec![v]));
            }
            Entry::Other(_) => {}
        }
    }
    Ok(arrays)
}

/// The arrays of a NumPy `.npz` (a zip of `.npy` files), by name.
fn npz(path: &Path) -> Result<Arrays, RigError> {
    let bytes = crate::files::read_bytes(path, crate::files::MAX_TEXT_BYTES, "stereo calibration")
        .map_err(RigError::from)?;
    let not_npz = |e: zip::result::ZipError| {
        RigError::field(
            path,
            "npz",
            format!("not a NumPy .npz (a zip of .npy arrays): {e}"),
        )
    };
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(not_npz)?;
    let mut arrays = Arrays::new();
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).map_err(not_npz)?;
        let Some(name) = entry
            .name()
            .map_err(not_npz)?
            .strip_suffix(".npy")
            .map(str::to_string)
        else {
            continue;
        };
        // A calibration's arrays are small; a member claiming more is not one of them.
        if entry.size() > 1 << 20 {
            continue;
        }
        let mut bytes = Vec::new();
        entry
            .read_to_end(&mut bytes)
            .map_err(|e| RigError::field(path, &name, format!("cannot be unpacked: {e}")))?;
        let member = path.join(format!("{name}.npy"));
        let Ok(a) = npy::parse(&member, &bytes) else {
            // Not an array of floats (a string, an object): not one of the needed arrays.
            continue;
        };
        let shaped = match a.shape.as_slice() {
            [] => (1, 1),
            [n] => (*n, 1),
            [r, c] => (*r, *c),
            _ => continue,
        };
        arrays.insert(name, (shaped.0, shaped.1, a.data));
    }
    Ok(arrays)
}
