//! Kalibr's camera chain (`camchain.yaml`, `camchain-imucam.yaml`): `cam0`, `cam1`, … each
//! with `camera_model` (`pinhole`), `intrinsics` `[fu, fv, pu, pv]`, `distortion_model`
//! (`radtan`: `[k1, k2, r1, r2]`, OpenCV's k1, k2, p1, p2; or `none`), `resolution`
//! `[width, height]`, and from `cam1` on `T_cn_cnm1`, the 4×4 transform taking points from the
//! previous camera's frame into this one's. The world frame is `cam0`'s; lengths are in metres
//! (Kalibr's) unless told. Other fields (`T_cam_imu`, `rostopic`, …) are ignored.

use std::collections::BTreeMap;
use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Matrix4, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use serde::Deserialize;

use super::{Imported, Unit, camera_error, finite};
use crate::RigError;

#[derive(Debug, Deserialize)]
struct RawCamera {
    #[serde(default)]
    camera_model: Option<String>,
    intrinsics: Vec<f64>,
    #[serde(default)]
    distortion_model: Option<String>,
    #[serde(default)]
    distortion_coeffs: Vec<f64>,
    resolution: [u32; 2],
    #[serde(default, rename = "T_cn_cnm1")]
    t_cn_cnm1: Option<Vec<Vec<f64>>>,
}

/// The cameras of a Kalibr camchain file in chain order, named by their keys (`cam0`, …),
/// lengths in `unit`.
pub fn read(path: &Path, unit: Unit) -> Result<Vec<Imported>, RigError> {
    let text = crate::files::read_text(path, "Kalibr camchain").map_err(RigError::from)?;
    let raw: BTreeMap<String, RawCamera> =
        serde_saphyr::from_str(&text).map_err(|e| RigError::Syntax {
            file: path.to_path_buf(),
            message: format!("not a Kalibr camchain YAML file: {e}"),
        })?;
    // cam0, cam1, … in chain order (cam10 after cam9).
    let mut keys: Vec<(usize, String)> = raw
        .keys()
        .filter_map(|k| Some((k.strip_prefix("cam")?.parse().ok()?, k.clone())))
        .collect();
    keys.sort();
    if keys.is_empty() {
        return Err(RigError::field(
            path,
            "cam0",
            "no cameras (cam0, cam1, …) in the file",
        ));
    }
    let mut world_to_cam = Matrix4::<f64>::identity();
    let mut out = Vec::new();
    for (n, (index, key)) in keys.iter().enumerate() {
        if *index != n {
            return Err(RigError::field(
                path,
                format!("cam{n}"),
                "missing: the chain must run cam0, cam1, … without gaps",
            ));
        }
        let cam = &raw[key];
        let field = |f: &str| format!("{key}.{f}");
        match cam.camera_model.as_deref() {
            None | Some("pinhole") => {}
            Some(other) => {
                return Err(RigError::field(
                    path,
                    field("camera_model"),
                    format!("`{other}`: only pinhole cameras are read"),
                ));
            }
        }
        let coefficients = match cam.distortion_model.as_deref() {
            None | Some("none") => Vec::new(),
            Some("radtan") if cam.distortion_coeffs.len() == 4 => cam.distortion_coeffs.clone(),
            Some("radtan") => {
                return Err(RigError::field(
                    path,
                    field("distortion_coeffs"),
                    format!(
                        "{} values: radtan has 4 (k1, k2, r1, r2)",
                        cam.distortion_coeffs.len()
                    ),
                ));
            }
            Some(other) => {
                return Err(RigError::field(
                    path,
                    field("distortion_model"),
                    format!("`{other}`: only radtan (OpenCV's k1, k2, p1, p2) and none are read"),
                ));
            }
        };
        let [fu, fv, pu, pv] = cam.intrinsics[..] else {
            return Err(RigError::field(
                path,
                field("intrinsics"),
                format!("{} values: expected [fu, fv, pu, pv]", cam.intrinsics.len()),
            ));
        };
        let distortion = Distortion::from_opencv(&coefficients)
            .map_err(|e| camera_error(path, &field("distortion_coeffs"), e))?;
        let intrinsics = Intrinsics::new(
            cam.resolution[0],
            cam.resolution[1],
            fu,
            fv,
            pu,
            pv,
            distortion,
        )
        .map_err(|e| camera_error(path, &field("intrinsics"), e))?;
        if n > 0 {
            let Some(t) = &cam.t_cn_cnm1 else {
                return Err(RigError::field(
                    path,
                    field("T_cn_cnm1"),
                    "missing: every camera after cam0 needs its transform from the previous one",
                ));
            };
            world_to_cam = transform(path, &field("T_cn_cnm1"), t)? * world_to_cam;
        }
        let r: Matrix3<f64> = world_to_cam.fixed_view::<3, 3>(0, 0).into_owned();
        let t: Vector3<f64> = world_to_cam.fixed_view::<3, 1>(0, 3).into_owned() * unit.mm();
        let pose =
            Pose::from_matrix(&r, t).map_err(|e| camera_error(path, &field("T_cn_cnm1"), e))?;
        out.push(Imported {
            name: key.clone(),
            camera: Camera::new(intrinsics, pose),
        });
    }
    Ok(out)
}

/// A 4×4 rigid transform given as four rows.
fn transform(path: &Path, field: &str, rows: &[Vec<f64>]) -> Result<Matrix4<f64>, RigError> {
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err(RigError::field(path, field, "expected 4 rows of 4 numbers"));
    }
    let mut m = Matrix4::zeros();
    for (i, row) in rows.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            m[(i, j)] = finite(path, field, v)?;
        }
    }
    if (m.row(3) - Matrix4::<f64>::identity().row(3)).amax() > 1e-9 {
        return Err(RigError::field(
            path,
            field,
            "the last row must be [0, 0, 0, 1]",
        ));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use flexshape_camera::nalgebra::Point3;

    use super::*;

    #[test]
    fn chains_the_transforms_from_cam0() {
        // cam1 is 100 mm along cam0's x; cam2 a further 100 mm along cam1's x, turned 90° about
        // its y axis.
        let text = "\
cam0:
  camera_model: pinhole
  intrinsics: [800.0, 801.0, 320.5, 240.5]
  distortion_model: radtan
  distortion_coeffs: [-0.1, 0.01, 0.001, 0.002]
  resolution: [640, 480]
  rostopic: /cam0/image_raw
cam1:
  T_cn_cnm1:
  - [1.0, 0.0, 0.0, -0.1]
  - [0.0, 1.0, 0.0, 0.0]
  - [0.0, 0.0, 1.0, 0.0]
  - [0.0, 0.0, 0.0, 1.0]
  camera_model: pinhole
  intrinsics: [800.0, 800.0, 320.0, 240.0]
  distortion_model: radtan
  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]
  resolution: [640, 480]
cam2:
  T_cn_cnm1:
  - [0.0, 0.0, -1.0, 0.0]
  - [0.0, 1.0, 0.0, 0.0]
  - [1.0, 0.0, 0.0, -0.1]
  - [0.0, 0.0, 0.0, 1.0]
  camera_model: pinhole
  intrinsics: [800.0, 800.0, 320.0, 240.0]
  distortion_model: none
  distortion_coeffs: []
  resolution: [640, 480]
";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("camchain.yaml");
        std::fs::write(&path, text).unwrap();
        let cams = read(&path, Unit::Metre).unwrap();
        assert_eq!(
            cams.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
            ["cam0", "cam1", "cam2"]
        );
        assert_eq!(cams[0].camera.pose, Pose::identity());
        assert_eq!(
            cams[0].camera.intrinsics.distortion.to_opencv()[..4],
            [-0.1, 0.01, 0.001, 0.002]
        );
        let centre = |i: usize| cams[i].camera.centre();
        assert!((centre(1) - Point3::new(100.0, 0.0, 0.0)).norm() < 1e-9);
        // cam2's centre: 100 mm along cam1's x from cam1 (x_cam2 = R·x_cam1 + t).
        assert!(
            (centre(2) - Point3::new(200.0, 0.0, 0.0)).norm() < 1e-9,
            "{}",
            centre(2)
        );
    }

    #[test]
    fn refuses_other_models_and_broken_chains_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.yaml");
        let cam = |extra: &str| {
            format!(
                "  camera_model: pinhole\n  intrinsics: [800.0, 800.0, 320.0, 240.0]\n  resolution: [640, 480]\n{extra}"
            )
        };
        std::fs::write(
            &path,
            format!(
                "cam0:\n{}",
                cam("  distortion_model: equidistant\n  distortion_coeffs: [0.1, 0.0, 0.0, 0.0]\n")
            ),
        )
        .unwrap();
        let e = read(&path, Unit::Metre).unwrap_err().to_string();
        assert!(e.contains("cam0.distortion_model"), "{e}");
        std::fs::write(&path, format!("cam0:\n{}cam1:\n{}", cam(""), cam(""))).unwrap();
        let e = read(&path, Unit::Metre).unwrap_err().to_string();
        assert!(e.contains("cam1.T_cn_cnm1") && e.contains("missing"), "{e}");
        std::fs::write(&path, format!("cam0:\n{}cam2:\n{}", cam(""), cam(""))).unwrap();
        let e = read(&path, Unit::Metre).unwrap_err().to_string();
        assert!(e.contains("cam1"), "{e}");
    }
}
