//! COLMAP's text model (`cameras.txt`, `images.txt`; `points3D.txt` is not needed): every
//! registered image is a camera of the rig, named after its image file. Camera models
//! `SIMPLE_PINHOLE`, `PINHOLE`, `SIMPLE_RADIAL`, `RADIAL`, `OPENCV` and `FULL_OPENCV` are
//! OpenCV's; fisheye models are refused. COLMAP puts pixel centres at +0.5 (the image's
//! corner at 0), OpenCV at 0, so principal points move by half a pixel. An image's pose is
//! `QW QX QY QZ TX TY TZ`, world to camera (OpenCV's convention); reconstructions have no
//! intrinsic scale, so the length unit must be given.
//!
//! Written models carry one camera and one image (`NAME.png`) per rig camera, and an empty
//! `points3D.txt`.

use std::collections::BTreeMap;
use std::path::Path;

use flexshape_camera::nalgebra::{Quaternion, UnitQuaternion, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};

use super::{Imported, Unit, camera_error, sanitize};
use crate::RigError;

/// COLMAP's pixel centres lie this far from OpenCV's, pixels.
const HALF_PIXEL: f64 = 0.5;

/// The cameras of the COLMAP text model in folder `dir`, one per image in `images.txt`'s
/// order, lengths in `unit`.
pub fn read(dir: &Path, unit: Unit) -> Result<Vec<Imported>, RigError> {
    let cameras_path = dir.join("cameras.txt");
    let images_path = dir.join("images.txt");
    let read_text =
        |p: &Path| crate::files::read_text(p, "COLMAP model file").map_err(RigError::from);
    let intrinsics = read_cameras(&cameras_path, &read_text(&cameras_path)?)?;
    let text = read_text(&images_path)?;
    let p = images_path.as_path();
    let mut images = Vec::new();
    // Image ids and the lines that defined them.
    let mut ids = BTreeMap::new();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.starts_with('#'));
    while let Some((n, line)) = lines.next() {
        if line.trim().is_empty() {
            continue;
        }
        let field = format!("line {}", n + 1);
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.len() < 10 {
            return Err(RigError::field(
                p,
                field,
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME",
            ));
        }
        let image_id: u64 = t[0]
            .parse()
            .map_err(|_| RigError::field(p, &field, format!("`{}` is not an image id", t[0])))?;
        if let Some(first) = ids.insert(image_id, n + 1) {
            return Err(RigError::field(
                p,
                field,
                format!(
                    "image id {image_id} is defined twice (first on line {first}): give each image its own id"
                ),
            ));
        }
        let v = t[1..8]
            .iter()
            .map(|s| number(p, &field, s))
            .collect::<Result<Vec<f64>, _>>()?;
        let camera_id: u64 = t[8]
            .parse()
            .map_err(|_| RigError::field(p, &field, format!("`{}` is not a camera id", t[8])))?;
        let Some(i) = intrinsics.get(&camera_id) else {
            return Err(RigError::field(
                p,
                field,
                format!("camera {camera_id} is not in cameras.txt"),
            ));
        };
        let q = Quaternion::new(v[0], v[1], v[2], v[3]);
        if !(q.norm() > 0.5 && q.norm() < 2.0) {
            return Err(RigError::field(p, &field, "QW QX QY QZ is not a rotation"));
        }
        let r = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
        let t_mm = Vector3::new(v[4], v[5], v[6]) * unit.mm();
        let pose = Pose::from_matrix(r.matrix(), t_mm).map_err(|e| camera_error(p, &field, e))?;
        let name = t[9..].join(" ");
        images.push((name, Camera::new(i.clone(), pose)));
        // Each image line is followed by its 2-D points' line (possibly empty).
        lines.next();
    }
    if images.is_empty() {
        return Err(RigError::field(p, "images", "no registered image"));
    }
    Ok(named(images))
}

/// The images' cameras named after their file names (without folders and extension), or
/// after their whole paths when those names repeat.
fn named(images: Vec<(String, Camera)>) -> Vec<Imported> {
    let stem = |n: &str| {
        let file = n.rsplit(['/', '\\']).next().unwrap_or(n);
        sanitize(file.rsplit_once('.').map_or(file, |(s, _)| s))
    };
    let whole = |n: &str| sanitize(n.rsplit_once('.').map_or(n, |(s, _)| s));
    let stems: Vec<String> = images.iter().map(|(n, _)| stem(n)).collect();
    let unique = stems
        .iter()
        .enumerate()
        .all(|(i, s)| !stems[..i].contains(s));
    images
        .into_iter()
        .zip(stems)
        .map(|((n, camera), s)| Imported {
            name: if unique { s } else { whole(&n) },
            camera,
        })
        .collect()
}

fn number(path: &Path, field: &str, s: &str) -> Result<f64, RigError> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| RigError::field(path, field, format!("`{s}` is not a number")))
}

/// `cameras.txt`: intrinsics by camera id.
fn read_cameras(path: &Path, text: &str) -> Result<BTreeMap<u64, Intrinsics>, RigError> {
    let mut out = BTreeMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let field = format!("line {}", n + 1);
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.len() < 5 {
            return Err(RigError::field(
                path,
                field,
                "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS…",
            ));
        }
        let id: u64 = t[0]
            .parse()
            .map_err(|_| RigError::field(path, &field, format!("`{}` is not a camera id", t[0])))?;
        let size = |s: &str| {
            s.parse::<u32>()
                .map_err(|_| RigError::field(path, &field, format!("`{s}` is not an image size")))
        };
        let (w, h) = (size(t[2])?, size(t[3])?);
        let p = t[4..]
            .iter()
            .map(|s| number(path, &field, s))
            .collect::<Result<Vec<f64>, _>>()?;
        let model = t[1];
        let expected = match model {
            "SIMPLE_PINHOLE" => 3,
            "PINHOLE" | "SIMPLE_RADIAL" => 4,
            "RADIAL" => 5,
            "OPENCV" => 8,
            "FULL_OPENCV" => 12,
            other => {
                return Err(RigError::field(
                    path,
                    field,
                    format!(
                        "camera model {other}: only SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV and FULL_OPENCV (OpenCV's pinhole model) are read"
                    ),
                ));
            }
        };
        if p.len() != expected {
            return Err(RigError::field(
                path,
                field,
                format!("{model} has {expected} parameters, the line {}", p.len()),
            ));
        }
        // fx, fy, cx, cy and OpenCV's coefficients.
        let (f, d): ([f64; 4], Vec<f64>) = match model {
            "SIMPLE_PINHOLE" => ([p[0], p[0], p[1], p[2]], vec![]),
            "PINHOLE" => ([p[0], p[1], p[2], p[3]], vec![]),
            "SIMPLE_RADIAL" => ([p[0], p[0], p[1], p[2]], vec![p[3], 0.0, 0.0, 0.0]),
            "RADIAL" => ([p[0], p[0], p[1], p[2]], vec![p[3], p[4], 0.0, 0.0]),
            _ => ([p[0], p[1], p[2], p[3]], p[4..].to_vec()),
        };
        let distortion = Distortion::from_opencv(&d).map_err(|e| camera_error(path, &field, e))?;
        let i = Intrinsics::new(
            w,
            h,
            f[0],
            f[1],
            f[2] - HALF_PIXEL,
            f[3] - HALF_PIXEL,
            distortion,
        )
        .map_err(|e| camera_error(path, &field, e))?;
        // COLMAP keeps the later of two lines with one id: which one was meant is not known.
        if let Some((_, first)) = out.insert(id, (i, n + 1)) {
            return Err(RigError::field(
                path,
                field,
                format!(
                    "camera id {id} is defined twice (first on line {first}): give each camera its own id"
                ),
            ));
        }
    }
    Ok(out.into_iter().map(|(id, (i, _))| (id, i)).collect())
}

/// Writes `cameras` (name, camera) as a COLMAP text model into `dir` (created if needed),
/// lengths in `unit`. A camera with thin-prism distortion cannot be written.
pub fn write(dir: &Path, cameras: &[(String, Camera)], unit: Unit) -> Result<(), RigError> {
    let mut cams = String::from(
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n",
    );
    let mut images = String::from(
        "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n",
    );
    for (k, (name, c)) in cameras.iter().enumerate() {
        let i = &c.intrinsics;
        let d = &i.distortion;
        if d.prism != [0.0; 4] {
            return Err(RigError::field(
                dir.join("cameras.txt"),
                name.as_str(),
                "thin-prism distortion has no COLMAP model",
            ));
        }
        let (cx, cy) = (i.cx + HALF_PIXEL, i.cy + HALF_PIXEL);
        let mut params = vec![i.fx, i.fy, cx, cy];
        let model = if *d == Distortion::NONE {
            "PINHOLE"
        } else if d.radial[2] == 0.0 && d.rational == [0.0; 3] {
            params.extend([d.radial[0], d.radial[1], d.tangential[0], d.tangential[1]]);
            "OPENCV"
        } else {
            params.extend([d.radial[0], d.radial[1], d.tangential[0], d.tangential[1]]);
            params.extend([d.radial[2], d.rational[0], d.rational[1], d.rational[2]]);
            "FULL_OPENCV"
        };
        let params: Vec<String> = params.iter().map(|v| format!("{v:?}")).collect();
        cams += &format!(
            "{} {model} {} {} {}\n",
            k + 1,
            i.width,
            i.height,
            params.join(" ")
        );
        let q = UnitQuaternion::from_rotation_matrix(&c.pose.rotation);
        let q = if q.w < 0.0 {
            -q.into_inner()
        } else {
            q.into_inner()
        };
        let t = c.pose.translation / unit.mm();
        images += &format!(
            "{} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {} {name}.png\n\n",
            k + 1,
            q.w,
            q.i,
            q.j,
            q.k,
            t.x,
            t.y,
            t.z,
            k + 1
        );
    }
    std::fs::create_dir_all(dir).map_err(|source| RigError::Write {
        file: dir.to_path_buf(),
        source,
    })?;
    for (file, text) in [
        ("cameras.txt", cams),
        ("images.txt", images),
        (
            "points3D.txt",
            "# 3D point list (empty: flexshape writes cameras only)\n".to_string(),
        ),
    ] {
        let path = dir.join(file);
        std::fs::write(&path, text).map_err(|source| RigError::Write { file: path, source })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cameras() -> Vec<(String, Camera)> {
        let intrinsics =
            |d: Distortion| Intrinsics::new(640, 480, 800.0, 790.0, 319.5, 239.5, d).unwrap();
        let radtan = Distortion::from_opencv(&[-0.2, 0.04, 0.001, -0.001]).unwrap();
        let full =
            Distortion::from_opencv(&[-0.2, 0.04, 0.001, -0.001, 0.01, 0.1, 0.0, 0.02]).unwrap();
        let pose = |r: [f64; 3], t: [f64; 3]| Pose::from_rvec_tvec(r.into(), t.into());
        vec![
            (
                "left".into(),
                Camera::new(
                    intrinsics(Distortion::NONE),
                    pose([0.1, 0.2, 0.3], [10.0, 0.0, 500.0]),
                ),
            ),
            (
                "mid".into(),
                Camera::new(
                    intrinsics(radtan),
                    pose([-0.5, 1.2, 0.0], [0.0, 40.0, 700.0]),
                ),
            ),
            (
                "right".into(),
                Camera::new(
                    intrinsics(full),
                    pose([2.5, 0.0, -0.1], [-30.0, 5.0, 650.0]),
                ),
            ),
        ]
    }

    #[test]
    fn a_written_model_reads_back_as_the_same_cameras() {
        let dir = tempfile::tempdir().unwrap();
        let cams = cameras();
        write(dir.path(), &cams, Unit::Metre).unwrap();
        let text = std::fs::read_to_string(dir.path().join("cameras.txt")).unwrap();
        assert!(
            text.contains("1 PINHOLE 640 480 800.0 790.0 320.0 240.0"),
            "{text}"
        );
        assert!(text.contains(" OPENCV ") && text.contains(" FULL_OPENCV "));
        let back = read(dir.path(), Unit::Metre).unwrap();
        for ((name, c), b) in cams.iter().zip(&back) {
            assert_eq!(&b.name, name);
            assert_eq!(b.camera.intrinsics, c.intrinsics);
            assert!((b.camera.pose.rotation.matrix() - c.pose.rotation.matrix()).amax() < 1e-12);
            assert!((b.camera.pose.translation - c.pose.translation).norm() < 1e-9);
        }
    }

    #[test]
    fn names_repeat_only_when_their_folders_differ_and_fisheyes_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("cameras.txt"),
            "1 SIMPLE_RADIAL 640 480 800 320 240 -0.1\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("images.txt"),
            "# header\n1 1 0 0 0 0 0 1 1 cam0/000001.png\n\n2 1 0 0 0 0.1 0 1 1 cam1/000001.png\n10 20 -1\n",
        )
        .unwrap();
        let cams = read(dir.path(), Unit::Metre).unwrap();
        assert_eq!(
            cams.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
            ["cam0_000001", "cam1_000001"]
        );
        assert_eq!(cams[0].camera.intrinsics.cx, 319.5);
        assert_eq!(cams[0].camera.intrinsics.distortion.radial[0], -0.1);
        assert!((cams[1].camera.pose.translation.x - 100.0).abs() < 1e-9);
        std::fs::write(
            dir.path().join("cameras.txt"),
            "1 OPENCV_FISHEYE 640 480 800 800 320 240 0 0 0 0\n",
        )
        .unwrap();
        let e = read(dir.path(), Unit::Metre).unwrap_err().to_string();
        assert!(
            e.contains("cameras.txt") && e.contains("OPENCV_FISHEYE"),
            "{e}"
        );
        std::fs::write(
            dir.path().join("cameras.txt"),
            "1 PINHOLE 640 480 800 800 320\n",
        )
        .unwrap();
        let e = read(dir.path(), Unit::Metre).unwrap_err().to_string();
        assert!(e.contains("PINHOLE has 4 parameters"), "{e}");
    }

    /// COLMAP keeps the later of two definitions of one id; which was meant is not known, so
    /// neither is taken.
    #[test]
    fn an_id_defined_twice_is_refused_naming_both_lines() {
        let dir = tempfile::tempdir().unwrap();
        let cameras = "1 PINHOLE 640 480 800 800 320 240
";
        let images = "1 1 0 0 0 0 0 1 1 a.png

2 1 0 0 0 0.1 0 1 1 b.png

";
        for (cams, imgs, says) in [
            (
                format!("{cameras}# again\n1 PINHOLE 640 480 900 900 320 240\n"),
                images.to_string(),
                [
                    "cameras.txt",
                    "`line 3`",
                    "camera id 1 is defined twice (first on line 1)",
                ],
            ),
            (
                cameras.to_string(),
                format!("{images}1 1 0 0 0 0.2 0 1 1 c.png\n\n"),
                [
                    "images.txt",
                    "`line 5`",
                    "image id 1 is defined twice (first on line 1)",
                ],
            ),
        ] {
            std::fs::write(dir.path().join("cameras.txt"), cams).unwrap();
            std::fs::write(dir.path().join("images.txt"), imgs).unwrap();
            let e = read(dir.path(), Unit::Metre).unwrap_err().to_string();
            assert!(says.iter().all(|s| e.contains(s)), "{e}");
        }
        std::fs::write(dir.path().join("cameras.txt"), cameras).unwrap();
        std::fs::write(dir.path().join("images.txt"), images).unwrap();
        assert_eq!(read(dir.path(), Unit::Metre).unwrap().len(), 2);
    }
}
