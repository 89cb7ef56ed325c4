//! Rig and camera files: OpenCV-written files load, ours round-trip and load in OpenCV, and
//! every kind of bad file gives an error naming the file and field.

use std::path::{Path, PathBuf};

use flexshape_camera::nalgebra::{Matrix3, Rotation3, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use flexshape_rig::camera_file::{self, CameraFile};
use flexshape_rig::{Occluded, Rig, RigCamera, RigError, Volume};
use serde::Deserialize;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

#[derive(Deserialize)]
struct Expected {
    camera_matrix: [[f64; 3]; 3],
    distortion: Vec<f64>,
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    #[serde(rename = "T")]
    t: [f64; 3],
}

#[test]
fn files_written_by_opencv_4_and_5_load() {
    let text = std::fs::read_to_string(fixture("opencv_expected.json")).unwrap();
    let e: Expected = serde_json::from_str(&text).unwrap();
    for name in [
        "opencv4_R_T.yml",
        "opencv4_rvec_tvec.yml",
        "opencv4_R_T.json",
        "opencv5_R_T.yml",
        "opencv5_rvec_tvec.yml",
        "opencv5_R_T.json",
    ] {
        let f = camera_file::read(&fixture(name)).unwrap_or_else(|err| panic!("{name}: {err}"));
        let k = f.intrinsics.matrix();
        for r in 0..3 {
            for c in 0..3 {
                assert_eq!(k[(r, c)], e.camera_matrix[r][c], "{name} K[{r}][{c}]");
            }
        }
        assert_eq!((f.intrinsics.width, f.intrinsics.height), (640, 480));
        assert_eq!(f.intrinsics.distortion.to_opencv(), e.distortion, "{name}");
        let pose = f.pose.expect("extrinsics");
        let r = pose.rotation.matrix();
        for i in 0..3 {
            for j in 0..3 {
                // rvec files hold R only through Rodrigues: equal to rounding.
                assert!((r[(i, j)] - e.r[i][j]).abs() < 1e-14, "{name} R[{i}][{j}]");
            }
        }
        assert_eq!(pose.translation, Vector3::from(e.t), "{name}");
    }
}

fn sample_camera() -> Camera {
    let d =
        Distortion::from_opencv(&[-0.2, 0.071, 0.00031, -0.00042, -0.013, 0.0, 0.0, 0.0]).unwrap();
    let k = Intrinsics::new(640, 480, 805.25, 803.5, 317.75, 244.125, d).unwrap();
    let pose = Pose {
        rotation: Rotation3::from_euler_angles(0.3, -1.1, 2.4),
        translation: Vector3::new(-3.5, 20.25, 598.0),
    };
    Camera::new(k, pose)
}

#[test]
fn ours_round_trip_through_yaml_and_json() {
    let cam = sample_camera();
    for json in [false, true] {
        let text = if json {
            camera_file::to_json(&cam.intrinsics, Some(&cam.pose))
        } else {
            camera_file::to_yaml(&cam.intrinsics, Some(&cam.pose))
        };
        let back = camera_file::parse(&text, json, Path::new("mem")).unwrap();
        assert_eq!(back.intrinsics, cam.intrinsics);
        let pose = back.pose.unwrap();
        assert_eq!(pose.translation, cam.pose.translation);
        assert!((pose.rotation.matrix() - cam.pose.rotation.matrix()).amax() < 1e-15);
    }
}

#[derive(serde::Serialize)]
struct Expect {
    image_width: u32,
    camera_matrix: Vec<Vec<f64>>,
    distortion: Vec<f64>,
    #[serde(rename = "R")]
    r: Vec<Vec<f64>>,
    #[serde(rename = "T")]
    t: Vec<f64>,
}

/// Our writer's output is pinned to golden files that `fixtures/make_opencv_files.py` loads in
/// OpenCV 4 and 5. Set FLEXSHAPE_WRITE_GOLDEN=1 to regenerate them (then rerun the script).
#[test]
fn write_golden_files() {
    let cam = sample_camera();
    let yaml = camera_file::to_yaml(&cam.intrinsics, Some(&cam.pose));
    let json = camera_file::to_json(&cam.intrinsics, Some(&cam.pose));
    let rows = |m: &Matrix3<f64>| {
        (0..3)
            .map(|r| (0..3).map(|c| m[(r, c)]).collect())
            .collect()
    };
    let expect = Expect {
        image_width: cam.intrinsics.width,
        camera_matrix: rows(&cam.intrinsics.matrix()),
        distortion: cam.intrinsics.distortion.to_opencv(),
        r: rows(cam.pose.rotation.matrix()),
        t: cam.pose.translation.as_slice().to_vec(),
    };
    let expect = serde_json::to_string_pretty(&expect).unwrap();
    if std::env::var_os("FLEXSHAPE_WRITE_GOLDEN").is_some() {
        for (name, text) in [("ours_camera.yml", &yaml), ("ours_camera.json", &json)] {
            std::fs::write(fixture(name), text).unwrap();
            std::fs::write(fixture(&format!("{name}.expect")), &expect).unwrap();
        }
    }
    assert_eq!(
        yaml,
        std::fs::read_to_string(fixture("ours_camera.yml")).unwrap()
    );
    assert_eq!(
        json,
        std::fs::read_to_string(fixture("ours_camera.json")).unwrap()
    );
}

fn yaml_with(replace: &str, with: &str) -> String {
    let base = camera_file::to_yaml(&sample_camera().intrinsics, Some(&sample_camera().pose));
    assert!(
        base.contains(replace),
        "test setup: `{replace}` not in base file"
    );
    base.replacen(replace, with, 1)
}

fn field_error(text: &str) -> (String, String) {
    match camera_file::parse(text, false, Path::new("bad.yml")) {
        Err(RigError::Field {
            file,
            field,
            problem,
        }) => {
            assert_eq!(file, Path::new("bad.yml"));
            (field, problem)
        }
        other => panic!("expected a field error, got {other:?}"),
    }
}

#[test]
fn bad_camera_files_name_the_field() {
    let k_line = "data: [ 805.25, 0.0, 317.75, 0.0, 803.5, 244.125, 0.0, 0.0, 1.0 ]";
    let cases: Vec<(String, &str, &str)> = vec![
        (yaml_with("805.25", "-805.25"), "camera_matrix", "positive"),
        (yaml_with("803.5,", "0.0,"), "camera_matrix", "positive"),
        (yaml_with("805.25", ".nan"), "camera_matrix", "finite"),
        (yaml_with("805.25", ".Nan"), "camera_matrix", "finite"),
        (
            yaml_with("-0.2,", ".inf,"),
            "distortion_coefficients",
            "finite",
        ),
        (
            yaml_with(k_line, "data: [ 805.25, 0.0, 317.75, 0.0, 803.5, 244.125 ]"),
            "camera_matrix",
            "data has 6 values",
        ),
        (
            yaml_with("cols: 5", "cols: 6"),
            "distortion_coefficients",
            "data has 5",
        ),
        (
            yaml_with("image_width: 640", "image_width: -640"),
            "image_width",
            "image size",
        ),
        (
            yaml_with("image_height: 480\n", ""),
            "image_height",
            "missing",
        ),
        (yaml_with("317.75", "9317.75"), "camera_matrix", "outside"),
        (
            yaml_with("0.0, 317.75", "3.0, 317.75"),
            "camera_matrix",
            "skew",
        ),
        (
            yaml_with("T: !!opencv-matrix", "Tx: !!opencv-matrix"),
            "T",
            "without translation",
        ),
        // Absurd values that parse: refused before anything projects through them.
        (
            yaml_with("distortion_coefficients:", "distortion:"),
            "distortion_coefficients",
            "missing; a lens without distortion has five zeros",
        ),
        (
            yaml_with("805.25", "1e308"),
            "camera_matrix",
            "not plausible",
        ),
        (
            yaml_with("-0.2,", "1e200,"),
            "distortion_coefficients",
            "coefficient 1 is 1e200",
        ),
        (yaml_with("598.0 ]", "1e308 ]"), "T", "beyond 1e7 mm"),
    ];
    for (text, field, needle) in cases {
        let (f, problem) = field_error(&text);
        assert_eq!(f, field, "{problem}");
        assert!(
            problem.contains(needle),
            "`{problem}` should mention `{needle}`"
        );
    }
    // A rotation that is not orthonormal, and one that is a reflection.
    let cam = sample_camera();
    let mut r = *cam.pose.rotation.matrix();
    r[(0, 0)] += 1e-3;
    let bad_r = format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: [[800, 0, 320], [0, 800, 240], [0, 0, 1]]\ndistortion_coefficients: [0, 0, 0, 0, 0]\nR: [{}]\nT: [1, 2, 3]\n",
        (0..3)
            .map(|i| format!("[{}, {}, {}]", r[(i, 0)], r[(i, 1)], r[(i, 2)]))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let (f, p) = field_error(&bad_r);
    assert_eq!(f, "R");
    assert!(p.contains("RᵀR"), "{p}");
    let reflect = "%YAML 1.2\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: [[800, 0, 320], [0, 800, 240], [0, 0, 1]]\ndistortion_coefficients: [0, 0, 0, 0, 0]\nR: [[1, 0, 0], [0, 1, 0], [0, 0, -1]]\nT: [1, 2, 3]\n";
    let (f, p) = field_error(reflect);
    assert_eq!(f, "R");
    assert!(p.contains("determinant"), "{p}");
}

#[test]
fn syntax_errors_name_the_file() {
    let err = camera_file::parse("image_width: [1, 2\n", false, Path::new("x.yml")).unwrap_err();
    assert!(matches!(err, RigError::Syntax { .. }), "{err}");
    assert!(err.to_string().starts_with("x.yml: invalid YAML"), "{err}");
    let err = camera_file::parse("{", true, Path::new("x.json")).unwrap_err();
    assert!(err.to_string().starts_with("x.json: invalid JSON"), "{err}");
}

fn write_rig(dir: &Path) -> PathBuf {
    let cams = (0..3)
        .map(|i| {
            let mut camera = sample_camera();
            camera.pose.translation.x += i as f64 * 10.0;
            RigCamera {
                name: format!("cam{i}"),
                file: PathBuf::from(format!(
                    "calibration/cam{i}.{}",
                    if i == 2 { "json" } else { "yml" }
                )),
                camera,
                occluded: None,
            }
        })
        .collect();
    let mut processing = toml::Table::new();
    processing.insert(
        "silhouette".into(),
        toml::Value::Table(toml::Table::from_iter([(
            "threshold".to_string(),
            toml::Value::Integer(30),
        )])),
    );
    let rig = Rig {
        cameras: cams,
        volume: Volume::new([-100.0, -90.0, -80.0], [0.5, 0.5, 1.0], [400, 360, 160]).unwrap(),
        processing,
        refined: None,
    };
    let path = dir.join("rig.toml");
    rig.save(&path).unwrap();
    assert_eq!(Rig::load(&path).unwrap(), rig);
    path
}

#[test]
fn rig_round_trips_with_its_camera_files() {
    let dir = tempfile::tempdir().unwrap();
    write_rig(dir.path());
    let from_dir =
        Rig::from_calibration_dir(&dir.path().join("calibration"), Volume::default()).unwrap();
    let names: Vec<_> = from_dir.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "cam2"]);
}

/// A camera's occlusion mask (`occluded`): saved beside the rig and read back as hidden where
/// its brightest channel reaches 128 (any colour type); a mask of another size, or a missing
/// one, names the camera's field and the file.
#[test]
fn an_occlusion_mask_round_trips_and_a_wrong_one_names_its_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_rig(dir.path());
    let mut rig = Rig::load(&path).unwrap();
    let mask = image::GrayImage::from_fn(640, 480, |x, y| {
        image::Luma([if (100..140).contains(&x) && y < 50 {
            255
        } else {
            0
        }])
    });
    rig.cameras[1].occluded = Some(Occluded {
        file: PathBuf::from("calibration/cam1_occluded.png"),
        mask: mask.clone(),
    });
    rig.save(&path).unwrap();
    let back = Rig::load(&path).unwrap();
    assert_eq!(back, rig);
    let o = back.cameras[1].occluded.as_ref().unwrap();
    assert!(o.hides(120, 10) && !o.hides(99, 10) && !o.hides(120, 50) && !o.hides(700, 10));
    // `rig check` says what each mask hides.
    let report = flexshape_rig::RigCheck::of(&back).to_string();
    assert!(
        report.contains("occluded 0.7 % of the image (calibration/cam1_occluded.png)"),
        "{report}"
    );
    // A colour mask drawn in an editor, grey-ish where hidden: read by its brightest channel.
    let drawn = image::RgbImage::from_fn(640, 480, |x, y| {
        image::Rgb(if (100..140).contains(&x) && y < 50 {
            [200, 20, 20]
        } else {
            [90, 90, 90]
        })
    });
    drawn
        .save(dir.path().join("calibration/cam1_occluded.png"))
        .unwrap();
    assert_eq!(
        Rig::load(&path).unwrap().cameras[1]
            .occluded
            .as_ref()
            .unwrap()
            .mask,
        mask
    );
    // Another size.
    image::GrayImage::new(320, 240)
        .save(dir.path().join("calibration/cam1_occluded.png"))
        .unwrap();
    match Rig::load(&path) {
        Err(RigError::Field { field, problem, .. }) => {
            assert_eq!(field, "cameras[1].occluded");
            assert!(
                problem.contains("cam1_occluded.png") && problem.contains("320×240"),
                "{problem}"
            );
        }
        other => panic!("expected a field error, got {other:?}"),
    }
    // Missing.
    std::fs::remove_file(dir.path().join("calibration/cam1_occluded.png")).unwrap();
    match Rig::load(&path) {
        Err(RigError::Field { field, problem, .. }) => {
            assert_eq!(field, "cameras[1].occluded");
            assert!(problem.contains("cam1_occluded.png"), "{problem}");
        }
        other => panic!("expected a field error, got {other:?}"),
    }
}

/// A calibration folder holding another tool's files beside the camera files: the cameras
/// load, each other file is skipped with its name; a broken camera file is still an error,
/// and a folder with no camera file is refused.
#[test]
fn a_calibration_folder_skips_files_that_are_not_cameras() {
    let dir = tempfile::tempdir().unwrap();
    write_rig(dir.path());
    let cal = dir.path().join("calibration");
    // Another tool's rig naming each camera's matrix inside its own entries (no image size:
    // read as a camera file it would be an error).
    std::fs::write(
        cal.join("rig.json"),
        r#"{"cameras": [{"name": "cam0", "camera_matrix": [[800, 0, 320], [0, 800, 240], [0, 0, 1]]}], "tool": "other"}"#,
    )
    .unwrap();
    std::fs::write(
        cal.join("notes.yaml"),
        "operator: me\nlens: 8 mm\nprevious:\n  camera_matrix: [800, 0, 320, 0, 800, 240, 0, 0, 1]\n",
    )
    .unwrap();
    std::fs::write(cal.join("README.md"), "calibrated on Monday").unwrap();
    let (rig, skipped) = Rig::from_calibration_dir_skipping(&cal, Volume::default()).unwrap();
    let names: Vec<_> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "cam2"]);
    let files: Vec<_> = skipped
        .iter()
        .map(|s| s.file.file_name().unwrap().to_str().unwrap().to_string())
        .collect();
    assert_eq!(files, ["notes.yaml", "rig.json"]);
    assert!(skipped[0].to_string().contains("not a camera file"));
    assert!(skipped[1].to_string().contains("inside other entries"));
    // A camera file broken so that it is not JSON any more is still a camera file: an error.
    std::fs::write(cal.join("cam9.json"), r#"{"camera_matrix": [1, 2"#).unwrap();
    assert!(matches!(
        Rig::from_calibration_dir(&cal, Volume::default()),
        Err(RigError::Syntax { .. })
    ));
    std::fs::remove_file(cal.join("cam9.json")).unwrap();
    // A camera file with a problem is an error, not a skip.
    let cam1 = cal.join("cam1.yml");
    let text = std::fs::read_to_string(&cam1).unwrap();
    std::fs::write(&cam1, text.replace("image_width", "image_wdth")).unwrap();
    match Rig::from_calibration_dir(&cal, Volume::default()) {
        Err(RigError::Field { field, .. }) => assert_eq!(field, "image_width"),
        other => panic!("{other:?}"),
    }
    // Nothing but other files: refused, naming what was skipped.
    for f in ["cam0.yml", "cam1.yml", "cam2.json"] {
        std::fs::remove_file(cal.join(f)).unwrap();
    }
    let e = Rig::from_calibration_dir(&cal, Volume::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no camera files") && e.contains("rig.json"),
        "{e}"
    );
}

fn rig_error(edit: impl Fn(&str) -> String) -> (PathBuf, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_rig(dir.path());
    let text = edit(&std::fs::read_to_string(&path).unwrap());
    std::fs::write(&path, text).unwrap();
    match Rig::load(&path) {
        Err(RigError::Field {
            file,
            field,
            problem,
        }) => {
            let rel = file.strip_prefix(dir.path()).unwrap_or(&file).to_path_buf();
            (rel, field, problem)
        }
        other => panic!("expected a field error, got {other:?}"),
    }
}

#[test]
fn bad_rig_files_name_the_file_and_field() {
    let (file, field, p) =
        rig_error(|t| t.replace("dims = [400, 360, 160]", "dims = [4000, 3600, 1600]"));
    assert_eq!(
        (file.as_path(), field.as_str()),
        (Path::new("rig.toml"), "volume.dims")
    );
    assert!(p.contains("2^31"), "{p}");
    let (_, field, _) = rig_error(|t| t.replace("0.5,", "-0.5,"));
    assert_eq!(field, "volume.voxel_size");
    let (_, field, p) =
        rig_error(|t| t.replacen("image_size = [640, 480]", "image_size = [1280, 960]", 1));
    assert_eq!(field, "cameras[0].image_size");
    assert!(p.contains("640×480"), "{p}");
    let (_, field, p) = rig_error(|t| t.replace("name = \"cam1\"", "name = \"cam0\""));
    assert_eq!(field, "cameras[1].name");
    assert!(p.contains("twice"), "{p}");
    let (_, field, _) = rig_error(|t| t.replace("name = \"cam1\"", "name = \"cam 1/x\""));
    assert_eq!(field, "cameras[1].name");
    // A problem inside a camera file is reported against that file.
    let dir = tempfile::tempdir().unwrap();
    let path = write_rig(dir.path());
    let cam1 = dir.path().join("calibration/cam1.yml");
    let text = std::fs::read_to_string(&cam1)
        .unwrap()
        .replace("805.25", "0.0");
    std::fs::write(&cam1, text).unwrap();
    let err = Rig::load(&path).unwrap_err();
    assert!(
        matches!(&err, RigError::Field { file, field, .. } if *file == cam1 && field == "camera_matrix"),
        "{err}"
    );
    // A missing camera file names it.
    std::fs::remove_file(&cam1).unwrap();
    let err = Rig::load(&path).unwrap_err();
    assert!(
        matches!(&err, RigError::Read { file, .. } if *file == cam1),
        "{err}"
    );
    // Intrinsics-only camera files are not enough for a rig.
    let cam0 = dir.path().join("calibration/cam0.yml");
    let cam = sample_camera();
    camera_file::write(&cam0, &cam.intrinsics, None).unwrap();
    let CameraFile { pose, .. } = camera_file::read(&cam0).unwrap();
    assert!(pose.is_none());
}

#[test]
fn rig_structure_errors() {
    let p = Path::new("r.toml");
    let err = Rig::parse(
        "[volume]\norigin = [0, 0, 0]\nvoxel_size = 1\ndims = [1, 1, 1]\n",
        p,
    )
    .unwrap_err();
    assert!(
        matches!(&err, RigError::Field { field, .. } if field == "cameras"),
        "{err}"
    );
    let err = Rig::parse(
        "[[cameras]]\nname = \"a\"\nfile = \"a.yml\"\nfocal = 3\n",
        p,
    )
    .unwrap_err();
    assert!(matches!(&err, RigError::Syntax { .. }), "{err}");
    assert!(
        err.to_string().contains("focal"),
        "unknown key must be named: {err}"
    );
}
