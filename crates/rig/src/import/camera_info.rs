//! ROS `sensor_msgs/CameraInfo` YAML, as `camera_calibration` writes and
//! `camera_info_manager` reads it: `image_width`, `image_height`, `camera_name`,
//! `camera_matrix`, `distortion_model` (`plumb_bob` or `rational_polynomial`, OpenCV's
//! coefficients), `distortion_coefficients`, `rectification_matrix`, `projection_matrix`, each
//! matrix as `{rows, cols, data}`.
//!
//! Poses follow ROS's stereo convention: the rectification matrix `R` rotates the camera frame
//! into the rectified one and the projection matrix's `Tx = −fx'·B`, `Ty = −fy'·B'` place the
//! camera's rectified frame at `(−Tx/fx', −Ty/fy', 0)` in the first camera's. The world frame
//! is that of the camera with `Tx = Ty = 0` (a lone camera, or a stereo pair's left one), so
//! `x_cam = Rᵀ·(X + (Tx/fx', Ty/fy', 0))`. Lengths are in metres (REP 103) unless told.
//!
//! Written files carry the intrinsics with `R = I` and `P = [K | 0]`: CameraInfo has no place
//! for a general rig's poses (ROS keeps them in TF; flexshape in the camera files). The poses
//! go beside them in [`EXTRINSICS_FILE`], as TF has them; an import that finds that file beside
//! its CameraInfo files takes each named camera's pose from it instead.

use std::collections::BTreeMap;
use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use serde::Deserialize;

use super::{Imported, Unit, camera_error, finite, sanitize};
use crate::RigError;

#[derive(Debug, Deserialize)]
struct Raw {
    image_width: u32,
    image_height: u32,
    camera_matrix: RawMatrix,
    #[serde(default)]
    distortion_model: Option<String>,
    #[serde(default)]
    distortion_coefficients: Option<RawMatrix>,
    #[serde(default)]
    rectification_matrix: Option<RawMatrix>,
    #[serde(default)]
    projection_matrix: Option<RawMatrix>,
}

#[derive(Debug, Deserialize)]
struct RawMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl RawMatrix {
    fn values(
        &self,
        path: &Path,
        field: &str,
        shape: (usize, usize),
    ) -> Result<Vec<f64>, RigError> {
        if (self.rows, self.cols) != shape || self.data.len() != shape.0 * shape.1 {
            return Err(RigError::field(
                path,
                field,
                format!(
                    "{}×{} with {} values: expected {}×{}",
                    self.rows,
                    self.cols,
                    self.data.len(),
                    shape.0,
                    shape.1
                ),
            ));
        }
        for v in &self.data {
            finite(path, field, *v)?;
        }
        Ok(self.data.clone())
    }
}

/// The camera of one CameraInfo YAML file, named after the file, lengths in `unit`.
pub fn read(path: &Path, unit: Unit) -> Result<Imported, RigError> {
    let text = crate::files::read_text(path, "CameraInfo file").map_err(RigError::from)?;
    let raw: Raw = serde_saphyr::from_str(&text).map_err(|e| RigError::Syntax {
        file: path.to_path_buf(),
        message: format!("not a ROS CameraInfo YAML file: {e}"),
    })?;
    let k = Matrix3::from_row_slice(&raw.camera_matrix.values(path, "camera_matrix", (3, 3))?);
    let coefficients = match &raw.distortion_coefficients {
        Some(d) => {
            if d.rows != 1 || d.cols != d.data.len() {
                return Err(RigError::field(
                    path,
                    "distortion_coefficients",
                    format!(
                        "{}×{} with {} values: expected 1×N",
                        d.rows,
                        d.cols,
                        d.data.len()
                    ),
                ));
            }
            d.values(path, "distortion_coefficients", (1, d.data.len()))?
        }
        None => Vec::new(),
    };
    match raw.distortion_model.as_deref() {
        None | Some("plumb_bob") | Some("rational_polynomial") => {}
        Some(other) => {
            return Err(RigError::field(
                path,
                "distortion_model",
                format!(
                    "`{other}`: only plumb_bob and rational_polynomial (OpenCV's pinhole model) are read"
                ),
            ));
        }
    }
    let distortion = Distortion::from_opencv(&coefficients)
        .map_err(|e| camera_error(path, "distortion_coefficients", e))?;
    let intrinsics = Intrinsics::from_matrix(raw.image_width, raw.image_height, &k, distortion)
        .map_err(|e| camera_error(path, "camera_matrix", e))?;
    let r = match &raw.rectification_matrix {
        Some(m) => Matrix3::from_row_slice(&m.values(path, "rectification_matrix", (3, 3))?),
        None => Matrix3::identity(),
    };
    let baseline = match &raw.projection_matrix {
        Some(m) => {
            let p = m.values(path, "projection_matrix", (3, 4))?;
            let (fx, fy) = (p[0], p[5]);
            if !(fx > 0.0 && fy > 0.0) {
                return Err(RigError::field(
                    path,
                    "projection_matrix",
                    "its focal lengths must be positive",
                ));
            }
            Vector3::new(p[3] / fx, p[7] / fy, 0.0)
        }
        None => Vector3::zeros(),
    };
    let rotation = r.transpose();
    let pose = Pose::from_matrix(&rotation, rotation * baseline * unit.mm())
        .map_err(|e| camera_error(path, "rectification_matrix", e))?;
    let name = sanitize(path.file_stem().and_then(|s| s.to_str()).unwrap_or("cam"));
    Ok(Imported {
        name,
        camera: Camera::new(intrinsics, pose),
    })
}

/// The file of a CameraInfo export's poses, beside its `NAME.yaml` files.
pub const EXTRINSICS_FILE: &str = "extrinsics.yaml";

/// One camera's pose as TF has it: its optical frame (OpenCV's axes: x right, y down, z
/// forward) in the world frame.
#[derive(Debug, Deserialize)]
struct RawExtrinsic {
    /// The optical frame's origin (the camera's centre), metres.
    translation: [f64; 3],
    /// Its orientation, `[x, y, z, w]`.
    rotation: [f64; 4],
}

/// The file: `cameras` by name (a `frame_id` key names the world frame; any is taken).
#[derive(Debug, Deserialize)]
struct RawExtrinsics {
    cameras: BTreeMap<String, RawExtrinsic>,
}

/// The poses of `cameras` as [`EXTRINSICS_FILE`]'s text: per camera its centre (m) and the
/// rotation of its optical frame in the world frame, with the `static_transform_publisher`
/// line that publishes it.
pub fn extrinsics_yaml(cameras: &[(String, Camera)]) -> String {
    let mut s = String::from(
        "# flexshape rig export: each camera's pose as ROS TF has it, the camera's optical frame\n\
         # (OpenCV axes: x right, y down, z forward) in the world frame; translation in metres,\n\
         # rotation as a quaternion [x, y, z, w]. `rig import camera-info` reads it back.\n\
         frame_id: world\ncameras:\n",
    );
    for (name, camera) in cameras {
        // TF's transform is the pose's inverse: the optical frame placed at the centre and
        // turned by Rᵀ. `+ 0.0` writes a negative zero as 0.
        let frame = camera.pose.inverse();
        let c = frame.translation.map(|v| v / 1e3 + 0.0);
        let q = UnitQuaternion::from_rotation_matrix(&frame.rotation);
        let q = q.coords.map(|v| v + 0.0);
        s.push_str(&format!(
            "  # ros2 run tf2_ros static_transform_publisher --x {} --y {} --z {} --qx {} --qy {} --qz {} --qw {} --frame-id world --child-frame-id {name}\n  {name}:\n    translation: [{}, {}, {}]\n    rotation: [{}, {}, {}, {}]\n",
            c.x, c.y, c.z, q.x, q.y, q.z, q.w, c.x, c.y, c.z, q.x, q.y, q.z, q.w
        ));
    }
    s
}

/// The poses in `path` (an [`EXTRINSICS_FILE`]) by camera name, world frame, millimetres.
pub fn read_extrinsics(path: &Path) -> Result<BTreeMap<String, Pose>, RigError> {
    let text = crate::files::read_text(path, "extrinsics file").map_err(RigError::from)?;
    let raw: RawExtrinsics = serde_saphyr::from_str(&text).map_err(|e| RigError::Syntax {
        file: path.to_path_buf(),
        message: format!("not a flexshape extrinsics file ({e})"),
    })?;
    let mut poses = BTreeMap::new();
    for (name, e) in raw.cameras {
        let field = format!("cameras.{name}");
        for v in e.translation.iter().chain(&e.rotation) {
            finite(path, &field, *v)?;
        }
        let [x, y, z, w] = e.rotation;
        let q = Quaternion::new(w, x, y, z);
        if (q.norm() - 1.0).abs() > 1e-6 {
            return Err(RigError::field(
                path,
                &field,
                format!("rotation has norm {:.6}: not a unit quaternion", q.norm()),
            ));
        }
        // The optical frame in the world (TF's transform) is the pose's inverse.
        let frame = Pose {
            rotation: UnitQuaternion::from_quaternion(q).to_rotation_matrix(),
            translation: Vector3::from(e.translation) * 1e3,
        };
        poses.insert(name, frame.inverse());
    }
    Ok(poses)
}

/// `camera`'s intrinsics as CameraInfo YAML named `name` (`R = I`, `P = [K | 0]`).
pub fn to_yaml(name: &str, camera: &Camera) -> String {
    let i = &camera.intrinsics;
    let d = i.distortion.to_opencv();
    let (model, d) = if d.len() <= 5 {
        let mut d = d;
        d.resize(5, 0.0);
        ("plumb_bob", d)
    } else {
        (
            "rational_polynomial",
            d.into_iter()
                .chain(std::iter::repeat(0.0))
                .take(8)
                .collect(),
        )
    };
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let k = [i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0];
    let p = [
        i.fx, 0.0, i.cx, 0.0, 0.0, i.fy, i.cy, 0.0, 0.0, 0.0, 1.0, 0.0,
    ];
    format!(
        "# ROS CameraInfo (intrinsics only; the pose is in flexshape's camera file)\n\
         image_width: {}\nimage_height: {}\ncamera_name: {name}\n\
         camera_matrix:\n  rows: 3\n  cols: 3\n  data: [{}]\n\
         distortion_model: {model}\n\
         distortion_coefficients:\n  rows: 1\n  cols: {}\n  data: [{}]\n\
         rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]\n\
         projection_matrix:\n  rows: 3\n  cols: 4\n  data: [{}]\n",
        i.width,
        i.height,
        list(&k),
        d.len(),
        list(&d),
        list(&p)
    )
}

#[cfg(test)]
mod tests {
    use flexshape_camera::nalgebra::{Point3, Rotation3};

    use super::*;

    #[test]
    fn a_written_file_reads_back_with_its_intrinsics() {
        let dir = tempfile::tempdir().unwrap();
        let distortion = Distortion::from_opencv(&[-0.2, 0.05, 0.001, -0.002, 0.01]).unwrap();
        let i = Intrinsics::new(1280, 1024, 1500.0, 1490.0, 641.5, 509.25, distortion).unwrap();
        let cam = Camera::new(i, Pose::identity());
        let path = dir.path().join("cam3.yaml");
        std::fs::write(&path, to_yaml("cam3", &cam)).unwrap();
        let back = read(&path, Unit::Metre).unwrap();
        assert_eq!(back.name, "cam3");
        assert_eq!(back.camera, cam);
    }

    #[test]
    fn a_stereo_pairs_rectification_and_baseline_give_the_right_cameras_pose() {
        // The right camera of a pair 120 mm apart, rotated 2° about y before rectification.
        let r = Rotation3::from_euler_angles(0.0, 0.035, 0.0);
        let text = format!(
            "image_width: 640\nimage_height: 480\ncamera_name: narrow_stereo/right\n\
             camera_matrix: {{rows: 3, cols: 3, data: [800.0, 0.0, 320.0, 0.0, 800.0, 240.0, 0.0, 0.0, 1.0]}}\n\
             distortion_model: plumb_bob\n\
             distortion_coefficients: {{rows: 1, cols: 5, data: [0.0, 0.0, 0.0, 0.0, 0.0]}}\n\
             rectification_matrix: {{rows: 3, cols: 3, data: [{}]}}\n\
             projection_matrix: {{rows: 3, cols: 4, data: [780.0, 0.0, 322.0, {}, 0.0, 780.0, 241.0, 0.0, 0.0, 0.0, 1.0, 0.0]}}\n",
            r.matrix()
                .transpose()
                .iter()
                .map(|v| format!("{v:?}"))
                .collect::<Vec<_>>()
                .join(", "),
            -780.0 * 0.12
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("right.yaml");
        std::fs::write(&path, text).unwrap();
        let cam = read(&path, Unit::Metre).unwrap().camera;
        // Its centre is 120 mm along the first camera's rectified x.
        assert!(
            (cam.centre() - Point3::new(120.0, 0.0, 0.0)).norm() < 1e-9,
            "{}",
            cam.centre()
        );
        // A point ahead: its direction in this camera is the rectified one rotated by Rᵀ.
        let x = Point3::new(50.0, 10.0, 900.0);
        let in_cam = cam.pose.to_camera(&x);
        let rect = Vector3::new(x.x - 120.0, x.y, x.z);
        assert!((r.matrix() * in_cam.coords - rect).norm() < 1e-9);
    }

    #[test]
    fn a_fisheye_model_and_a_bad_matrix_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.yaml");
        std::fs::write(
            &path,
            "image_width: 640\nimage_height: 480\n\
             camera_matrix: {rows: 3, cols: 3, data: [800.0, 0.0, 320.0, 0.0, 800.0, 240.0, 0.0, 0.0, 1.0]}\n\
             distortion_model: equidistant\n\
             distortion_coefficients: {rows: 1, cols: 4, data: [0.1, 0.0, 0.0, 0.0]}\n",
        )
        .unwrap();
        let e = read(&path, Unit::Metre).unwrap_err().to_string();
        assert!(
            e.contains("distortion_model") && e.contains("equidistant"),
            "{e}"
        );
        std::fs::write(
            &path,
            "image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 2, cols: 3, data: [1.0, 2.0]}\n",
        )
        .unwrap();
        let e = read(&path, Unit::Metre).unwrap_err().to_string();
        assert!(
            e.contains("camera_matrix") && e.contains("expected 3×3"),
            "{e}"
        );
    }
}
