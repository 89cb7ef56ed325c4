//! One camera's calibration file, in OpenCV `cv::FileStorage` YAML or JSON.
//!
//! Keys (as OpenCV's calibration samples write them): `image_width`, `image_height`,
//! `camera_matrix` (3×3), `distortion_coefficients` (4, 5, 8, 12 or 14 values), and the
//! extrinsics as `R` (3×3) or `rvec` (Rodrigues, radians), plus `T` or `tvec` (mm), with
//! `x_cam = R · X_world + T`. Other keys are ignored. Matrices are `!!opencv-matrix` nodes
//! (YAML), `{"type_id": "opencv-matrix", …}` objects (JSON) or plain (nested) arrays (JSON).
//! The format is chosen by extension: `.json` is JSON, anything else YAML.

use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Vector3};
use flexshape_camera::{Camera, CameraError, Distortion, Intrinsics, Pose};
use serde::{Deserialize, Serialize};

use crate::error::RigError;
use crate::opencv_matrix::{JsonMatrix, RawMatrix, yaml_matrix};

/// A camera file's content: intrinsics always, extrinsics when the file has them.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraFile {
    /// Image size, focal lengths, principal point, distortion.
    pub intrinsics: Intrinsics,
    /// World → camera pose, if the file has `R`/`rvec` and `T`/`tvec`.
    pub pose: Option<Pose>,
}

#[derive(Debug, Deserialize)]
struct RawCameraFile {
    image_width: Option<f64>,
    image_height: Option<f64>,
    camera_matrix: Option<RawMatrix>,
    distortion_coefficients: Option<RawMatrix>,
    #[serde(rename = "R")]
    r: Option<RawMatrix>,
    rvec: Option<RawMatrix>,
    #[serde(rename = "T")]
    t: Option<RawMatrix>,
    tvec: Option<RawMatrix>,
}

pub(crate) fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Reads and validates a camera file (format by extension).
pub fn read(path: &Path) -> Result<CameraFile, RigError> {
    let text = crate::files::read_text(path, "camera file").map_err(RigError::from)?;
    parse(&text, is_json(path), path)
}

/// Parses a camera file's text; `path` names it in errors.
pub fn parse(text: &str, json: bool, path: &Path) -> Result<CameraFile, RigError> {
    let syntax = |message: String| RigError::Syntax {
        file: path.to_path_buf(),
        message,
    };
    let raw: RawCameraFile = if json {
        serde_json::from_str(text).map_err(|e| syntax(format!("invalid JSON: {e}")))?
    } else {
        // The `!!opencv-matrix` tag adds nothing the mapping's keys do not say, and a tagged
        // node cannot be matched against the plain-list alternatives of `RawMatrix`.
        let untagged = text.replace("!!opencv-matrix", "");
        // Non-finite numbers are let through so that validation can name their field.
        let mut options = serde_saphyr::Options::default();
        options.non_finite_float_policy = serde_saphyr::NonFiniteFloatPolicy::PassThrough;
        serde_saphyr::from_str_with_options(&untagged, options)
            .map_err(|e| syntax(format!("invalid YAML: {e}")))?
    };
    validate(raw, path)
}

fn validate(raw: RawCameraFile, path: &Path) -> Result<CameraFile, RigError> {
    let field = |name: &str, problem: String| RigError::field(path, name, problem);
    let size = |name: &str, v: Option<f64>| -> Result<u32, RigError> {
        let v = v.ok_or_else(|| field(name, "missing; add the image size in pixels".into()))?;
        if v.fract() != 0.0 || !(1.0..=1e6).contains(&v) {
            return Err(field(
                name,
                format!("{v} is not a valid image size in pixels"),
            ));
        }
        Ok(v as u32)
    };
    let width = size("image_width", raw.image_width)?;
    let height = size("image_height", raw.image_height)?;

    let k = matrix(&raw.camera_matrix, "camera_matrix", path, Some((3, 3)))?
        .ok_or_else(|| field("camera_matrix", "missing; add the 3×3 camera matrix".into()))?;
    let dist = matrix(
        &raw.distortion_coefficients,
        "distortion_coefficients",
        path,
        None,
    )?
    .ok_or_else(|| {
        field(
            "distortion_coefficients",
            "missing; a lens without distortion has five zeros: [0, 0, 0, 0, 0]".into(),
        )
    })?;
    if let Some((i, v)) = dist
        .iter()
        .enumerate()
        .find(|(_, v)| v.abs() > MAX_DISTORTION)
    {
        return Err(field(
            "distortion_coefficients",
            format!(
                "coefficient {} is {v:e}: no lens model needs more than {MAX_DISTORTION:e}; check the file's units and order (k1 k2 p1 p2 k3 …)",
                i + 1
            ),
        ));
    }
    let distortion = Distortion::from_opencv(&dist)
        .map_err(|e| field("distortion_coefficients", camera_problem(&e)))?;
    let k = Matrix3::from_row_slice(&k);
    let intrinsics = Intrinsics::from_matrix(width, height, &k, distortion)
        .map_err(|e| field("camera_matrix", camera_problem(&e)))?;
    let (w, h) = (width as f64, height as f64);
    if !(-0.5..w - 0.5).contains(&intrinsics.cx) || !(-0.5..h - 0.5).contains(&intrinsics.cy) {
        return Err(field(
            "camera_matrix",
            format!(
                "principal point ({}, {}) lies outside the {width}×{height} image; check that \
                 image_width/image_height belong to this calibration",
                intrinsics.cx, intrinsics.cy
            ),
        ));
    }
    let largest_focal = MAX_FOCAL_PER_PIXEL * w.max(h);
    if intrinsics.fx.max(intrinsics.fy) > largest_focal {
        return Err(field(
            "camera_matrix",
            format!(
                "focal length {:e} px is not plausible for a {width}×{height} image (at most {largest_focal:e}: a field of view under 0.06°); check the file's units",
                intrinsics.fx.max(intrinsics.fy)
            ),
        ));
    }
    let pose = read_pose(&raw, path)?;
    if let Some(p) = &pose
        && p.translation.amax() > MAX_TRANSLATION_MM
    {
        return Err(field(
            "T",
            format!(
                "translation {:e} mm is beyond {MAX_TRANSLATION_MM:e} mm (10 km); check the file's units",
                p.translation.amax()
            ),
        ));
    }
    Ok(CameraFile { intrinsics, pose })
}

/// Focal lengths beyond this many times the image's larger side are refused (a field of view
/// under 0.06°: no real lens, a unit or typing error).
const MAX_FOCAL_PER_PIXEL: f64 = 1000.0;

/// Distortion coefficients beyond this size are refused.
const MAX_DISTORTION: f64 = 1e4;

/// Camera translations beyond this are refused, mm.
const MAX_TRANSLATION_MM: f64 = 1e7;

fn camera_problem(e: &CameraError) -> String {
    format!("{e}")
}

/// Elements of an optional matrix field, checked against an expected shape (`None`: any).
fn matrix(
    m: &Option<RawMatrix>,
    name: &str,
    path: &Path,
    shape: Option<(usize, usize)>,
) -> Result<Option<Vec<f64>>, RigError> {
    let Some(m) = m else { return Ok(None) };
    let (rows, cols, data) = m.elements().map_err(|p| RigError::field(path, name, p))?;
    if let Some((r, c)) = shape
        && (rows, cols) != (r, c)
        && !(r * c == rows * cols && (r == 1 || c == 1) && (rows == 1 || cols == 1))
    {
        return Err(RigError::field(
            path,
            name,
            format!("expected a {r}×{c} matrix, found {rows}×{cols}"),
        ));
    }
    if let Some(bad) = data.iter().find(|v| !v.is_finite()) {
        return Err(RigError::field(
            path,
            name,
            format!("contains {bad}; every element must be a finite number"),
        ));
    }
    Ok(Some(data))
}

fn read_pose(raw: &RawCameraFile, path: &Path) -> Result<Option<Pose>, RigError> {
    let r = matrix(&raw.r, "R", path, Some((3, 3)))?;
    let rvec = matrix(&raw.rvec, "rvec", path, Some((3, 1)))?;
    let t = matrix(&raw.t, "T", path, Some((3, 1)))?;
    let tvec = matrix(&raw.tvec, "tvec", path, Some((3, 1)))?;
    let translation = match (&t, &tvec) {
        (Some(a), Some(b)) if a != b => {
            return Err(RigError::field(
                path,
                "tvec",
                "both `T` and `tvec` are given and differ; keep one",
            ));
        }
        (Some(v), _) | (None, Some(v)) => Some(Vector3::from_row_slice(v)),
        (None, None) => None,
    };
    let from_r = match &r {
        Some(r) => Some(
            Pose::from_matrix(&Matrix3::from_row_slice(r), Vector3::zeros())
                .map_err(|e| RigError::field(path, "R", format!("{e}; recalibrate or fix R")))?
                .rotation,
        ),
        None => None,
    };
    let from_rvec =
        rvec.map(|v| Pose::from_rvec_tvec(Vector3::from_row_slice(&v), Vector3::zeros()).rotation);
    let rotation = match (from_r, from_rvec) {
        (Some(a), Some(b)) => {
            if a.angle_to(&b) > 1e-6 {
                return Err(RigError::field(
                    path,
                    "rvec",
                    format!(
                        "both `R` and `rvec` are given and differ by {:.3e} rad; keep one",
                        a.angle_to(&b)
                    ),
                ));
            }
            Some(a)
        }
        (a, b) => a.or(b),
    };
    match (rotation, translation) {
        (Some(rotation), Some(translation)) => Ok(Some(Pose {
            rotation,
            translation,
        })),
        (None, None) => Ok(None),
        (Some(_), None) => Err(RigError::field(
            path,
            "T",
            "rotation given without translation; add `T` (or `tvec`) in mm",
        )),
        (None, Some(_)) => Err(RigError::field(
            path,
            "R",
            "translation given without rotation; add `R` (3×3) or `rvec`",
        )),
    }
}

/// Writes a camera file in the format its extension names (`.json` → OpenCV JSON, otherwise
/// OpenCV 4 YAML), with `R` and `T` when the camera has a pose.
pub fn write(path: &Path, intrinsics: &Intrinsics, pose: Option<&Pose>) -> Result<(), RigError> {
    let text = if is_json(path) {
        to_json(intrinsics, pose)
    } else {
        to_yaml(intrinsics, pose)
    };
    std::fs::write(path, text).map_err(|source| RigError::Write {
        file: path.to_path_buf(),
        source,
    })
}

/// Writes a full camera (intrinsics and pose).
pub fn write_camera(path: &Path, camera: &Camera) -> Result<(), RigError> {
    write(path, &camera.intrinsics, Some(&camera.pose))
}

fn row_major(m: &Matrix3<f64>) -> Vec<f64> {
    m.transpose().iter().copied().collect()
}

/// OpenCV FileStorage YAML text (OpenCV 4 header `%YAML:1.0`, which OpenCV 5 also reads).
pub fn to_yaml(intrinsics: &Intrinsics, pose: Option<&Pose>) -> String {
    let mut s = String::from("%YAML:1.0\n---\n");
    s.push_str(&format!("image_width: {}\n", intrinsics.width));
    s.push_str(&format!("image_height: {}\n", intrinsics.height));
    yaml_matrix(
        &mut s,
        "camera_matrix",
        3,
        3,
        &row_major(&intrinsics.matrix()),
    );
    let d = intrinsics.distortion.to_opencv();
    yaml_matrix(&mut s, "distortion_coefficients", 1, d.len(), &d);
    if let Some(p) = pose {
        yaml_matrix(&mut s, "R", 3, 3, &row_major(p.rotation.matrix()));
        yaml_matrix(&mut s, "T", 3, 1, p.translation.as_slice());
    }
    s
}

#[derive(Serialize)]
struct JsonCameraFile {
    image_width: u32,
    image_height: u32,
    camera_matrix: JsonMatrix,
    distortion_coefficients: JsonMatrix,
    #[serde(rename = "R", skip_serializing_if = "Option::is_none")]
    r: Option<JsonMatrix>,
    #[serde(rename = "T", skip_serializing_if = "Option::is_none")]
    t: Option<JsonMatrix>,
}

/// OpenCV FileStorage JSON text (matrices as `{"type_id": "opencv-matrix", …}`).
pub fn to_json(intrinsics: &Intrinsics, pose: Option<&Pose>) -> String {
    let d = intrinsics.distortion.to_opencv();
    let file = JsonCameraFile {
        image_width: intrinsics.width,
        image_height: intrinsics.height,
        camera_matrix: JsonMatrix::new(3, 3, row_major(&intrinsics.matrix())),
        distortion_coefficients: JsonMatrix::new(1, d.len(), d),
        r: pose.map(|p| JsonMatrix::new(3, 3, row_major(p.rotation.matrix()))),
        t: pose.map(|p| JsonMatrix::new(3, 1, p.translation.as_slice().to_vec())),
    };
    // Serializing plain numbers and strings cannot fail.
    let mut s = serde_json::to_string_pretty(&file).unwrap_or_default();
    s.push('\n');
    s
}
