//! Each import format against files written by the original tools' conventions
//! (`fixtures/import/make_fixtures.py`): the imported cameras must project test points to the
//! pixels OpenCV's `projectPoints` gives with the original calibration.

use std::path::{Path, PathBuf};

use flexshape_camera::nalgebra::{Matrix3, Matrix3x4, Point3, Vector3};
use flexshape_camera::{Camera, Pose};
use flexshape_rig::import::{self, Format, ImportOptions, Unit};
use serde_json::Value;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/import")
}

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(fixtures().join("expected.json")).unwrap())
        .unwrap()
}

fn points(v: &Value) -> Vec<Point3<f64>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let c: Vec<f64> = p
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            Point3::new(c[0], c[1], c[2])
        })
        .collect()
}

/// The largest distance between `camera`'s projections of `points` and OpenCV's pixels.
fn worst(camera: &Camera, points: &[Point3<f64>], pixels: &Value) -> f64 {
    points
        .iter()
        .zip(pixels.as_array().unwrap())
        .map(|(p, px)| {
            let q = camera.project(p).unwrap().pixel;
            let (u, v) = (px[0].as_f64().unwrap(), px[1].as_f64().unwrap());
            ((q.x - u).powi(2) + (q.y - v).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

fn read(
    format: Format,
    inputs: &[&str],
    unit: Option<Unit>,
    size: Option<(u32, u32)>,
) -> import::Import {
    let inputs: Vec<PathBuf> = inputs.iter().map(|f| fixtures().join(f)).collect();
    import::read(format, &inputs, ImportOptions { unit, size }).unwrap()
}

#[test]
fn projection_matrices_in_text_kitti_lines_and_npy_project_as_opencv() {
    let e = expected();
    let pts = points(&e["points_mm"]);
    let px = &e["projection_pixels"];
    let size = Some((640, 480));
    let text = read(
        Format::Projection,
        &["cam0_P.txt"],
        Some(Unit::Millimetre),
        size,
    );
    assert_eq!(text.cameras[0].name, "cam0_P");
    assert!(worst(&text.cameras[0].camera, &pts, &px["cam0"]) < 1e-6);
    let npy = read(Format::Projection, &["P_all.npy"], Some(Unit::Metre), size);
    let kitti = read(
        Format::Projection,
        &["kitti_calib.txt"],
        Some(Unit::Metre),
        size,
    );
    assert_eq!(kitti.notes.len(), 2, "{:?}", kitti.notes);
    for (i, name) in ["cam0", "cam1", "cam2"].iter().enumerate() {
        assert!(
            worst(&npy.cameras[i].camera, &pts, &px[name]) < 1e-6,
            "{name}"
        );
        assert!(
            worst(&kitti.cameras[i].camera, &pts, &px[name]) < 1e-6,
            "{name}"
        );
    }
    assert_eq!(kitti.cameras[2].name, "P2");
    // The unit must be given: the files do not say.
    let e = import::read(
        Format::Projection,
        &[fixtures().join("cam0_P.txt")],
        ImportOptions { unit: None, size },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("unit"), "{e}");
}

#[test]
fn a_ros_stereo_pair_projects_as_opencv_in_the_left_rectified_frame() {
    let e = expected();
    let pts = points(&e["camera_info_points_mm"]);
    let pair = read(Format::CameraInfo, &["left.yaml", "right.yaml"], None, None);
    assert_eq!(pair.cameras[0].name, "left");
    assert!(worst(&pair.cameras[0].camera, &pts, &e["cameras"]["cam0"]) < 1e-6);
    assert!(worst(&pair.cameras[1].camera, &pts, &e["cameras"]["cam1"]) < 1e-6);
}

#[test]
fn a_kalibr_chain_projects_as_opencv_in_cam0s_frame() {
    let e = expected();
    let pts = points(&e["kalibr_points_mm"]);
    let chain = read(Format::Kalibr, &["camchain.yaml"], None, None);
    for (i, name) in ["cam0", "cam1", "cam2"].iter().enumerate() {
        assert_eq!(chain.cameras[i].name, *name);
        assert!(
            worst(&chain.cameras[i].camera, &pts, &e["cameras"][name]) < 1e-6,
            "{name}"
        );
    }
}

#[test]
fn a_colmap_model_projects_as_opencv() {
    let e = expected();
    let pts = points(&e["points_mm"]);
    let model = read(Format::Colmap, &["colmap"], Some(Unit::Metre), None);
    for (i, name) in ["cam0", "cam1", "cam2"].iter().enumerate() {
        assert_eq!(model.cameras[i].name, *name);
        assert!(
            worst(&model.cameras[i].camera, &pts, &e["cameras"][name]) < 1e-6,
            "{name}"
        );
    }
}

#[test]
fn an_imported_rig_exports_and_imports_back() {
    let chain = read(Format::Kalibr, &["camchain.yaml"], None, None);
    let rig = import::rig_of(
        chain.cameras.clone(),
        Default::default(),
        Path::new("camchain.yaml"),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    rig.save(&dir.path().join("rig.toml")).unwrap();
    let loaded = flexshape_rig::Rig::load(&dir.path().join("rig.toml")).unwrap();
    assert_eq!(loaded.cameras.len(), 3);
    let out = dir.path().join("colmap");
    import::export(
        &loaded,
        import::ExportFormat::Colmap,
        &out,
        Unit::Millimetre,
    )
    .unwrap();
    let back = import::read(
        Format::Colmap,
        &[out],
        ImportOptions {
            unit: Some(Unit::Millimetre),
            size: None,
        },
    )
    .unwrap();
    let pts = [
        Point3::new(10.0, 20.0, 600.0),
        Point3::new(-40.0, 0.0, 550.0),
    ];
    for (a, b) in chain.cameras.iter().zip(&back.cameras) {
        assert_eq!(a.name, b.name);
        for p in &pts {
            let d = a.camera.project(p).unwrap().pixel - b.camera.project(p).unwrap().pixel;
            assert!(d.norm() < 1e-6);
        }
    }
    let info = dir.path().join("info");
    let files = import::export(
        &loaded,
        import::ExportFormat::CameraInfo,
        &info,
        Unit::Metre,
    )
    .unwrap();
    // The CameraInfo files and, last, the poses beside them as TF has them.
    let (yamls, extrinsics) = files.split_at(files.len() - 1);
    assert!(extrinsics[0].ends_with("extrinsics.yaml"));
    let one = import::read(Format::CameraInfo, &yamls[..1], ImportOptions::default()).unwrap();
    assert_eq!(
        one.cameras[0].camera.intrinsics,
        chain.cameras[0].camera.intrinsics
    );
    // All of them back, placed where the rig had them.
    let all = import::read(Format::CameraInfo, yamls, ImportOptions::default()).unwrap();
    assert_eq!(all.cameras.len(), chain.cameras.len());
    for (a, b) in chain.cameras.iter().zip(&all.cameras) {
        assert_eq!(a.name, b.name);
        for p in &pts {
            let d = a.camera.project(p).unwrap().pixel - b.camera.project(p).unwrap().pixel;
            assert!(d.norm() < 1e-6, "{}: {} px", a.name, d.norm());
        }
    }
    let said = all.notes.join("\n");
    assert!(
        said.contains("poses of") && said.contains("extrinsics.yaml"),
        "{said}"
    );
    assert!(!said.contains("one pose"), "{said}");
    // Without the poses' file the CameraInfo files hold none, and the import says so.
    std::fs::remove_file(&extrinsics[0]).unwrap();
    let all = import::read(Format::CameraInfo, yamls, ImportOptions::default()).unwrap();
    let said = all.notes.join("\n");
    assert!(
        said.contains("imported at one pose") && said.contains(&all.cameras[1].name),
        "{said}"
    );
    // A stereo pair's own CameraInfo files place the right camera: nothing to say.
    let pair = read(Format::CameraInfo, &["left.yaml", "right.yaml"], None, None);
    assert!(pair.notes.is_empty(), "{:?}", pair.notes);
    // Two cameras of one name are refused.
    let twice = vec![chain.cameras[0].clone(), chain.cameras[0].clone()];
    let e = import::rig_of(twice, Default::default(), Path::new("x"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("two cameras are named `cam0`"), "{e}");
}

/// `cv2.stereoCalibrate`'s output as labs save it (`fixtures/opencv_stereo/make.py`): every
/// form imports to cameras that project as OpenCV's `projectPoints` does.
#[test]
fn an_opencv_stereo_calibration_projects_as_opencv_in_every_saved_form() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/opencv_stereo");
    let reference: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("reference.json")).unwrap())
            .unwrap();
    let pts = points(&reference["points_mm"]);
    let read = |file: &str, size: Option<(u32, u32)>| {
        import::read(
            Format::OpencvStereo,
            &[dir.join(file)],
            ImportOptions {
                unit: Some(Unit::Millimetre),
                size,
            },
        )
    };
    for (file, size) in [
        ("stereo.yml", None),
        ("stereo.json", Some((1280, 720))),
        ("stereo.npz", None),
        ("stereo_compressed.npz", Some((1280, 720))),
    ] {
        let got = read(file, size).unwrap_or_else(|e| panic!("{file}: {e}"));
        let names: Vec<&str> = got.cameras.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["cam0", "cam1"], "{file}");
        for (camera, px) in got.cameras.iter().zip(["cam0_px", "cam1_px"]) {
            let k = &camera.camera.intrinsics;
            assert_eq!((k.width, k.height), (1280, 720), "{file}");
            let err = worst(&camera.camera, &pts, &reference[px]);
            assert!(err < 1e-6, "{file} {}: {err} px", camera.name);
        }
        assert!(
            got.notes.iter().any(|n| n.contains("world frame")),
            "{file}"
        );
    }
    // Without the image size the files that lack it are refused, saying what to give; a
    // length unit must be given (T is in the calibration target's unit).
    let e = read("stereo.json", None).unwrap_err().to_string();
    assert!(e.contains("stereo.json") && e.contains("WxH"), "{e}");
    let e = import::read(
        Format::OpencvStereo,
        &[dir.join("stereo.yml")],
        ImportOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("unit"), "{e}");
    // A file without the second camera names what it looked for and what it found.
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(dir.join("stereo.yml")).unwrap();
    let cut = tmp.path().join("cut.yml");
    std::fs::write(&cut, text.replace("K2:", "Kx:")).unwrap();
    let in_mm = |path: PathBuf| {
        let options = ImportOptions {
            unit: Some(Unit::Millimetre),
            size: None,
        };
        import::read(Format::OpencvStereo, &[path], options)
            .unwrap_err()
            .to_string()
    };
    let e = in_mm(cut);
    assert!(
        e.contains("K2") && e.contains("cameraMatrix2") && e.contains("Kx"),
        "{e}"
    );
    // Bytes that are not an .npz say so instead of printing them.
    let junk = tmp.path().join("junk.npz");
    std::fs::write(&junk, [0x93, b'N', 0xff, 0x00, 0x12]).unwrap();
    let e = in_mm(junk);
    assert!(
        e.contains("not a NumPy .npz") && !e.contains('\u{fffd}'),
        "{e}"
    );
}

/// Three cameras 0.5 m from the origin looking at it, as projection-matrix text files in
/// `dir` (`cam0.txt` …, made if need be), lengths in mm; `change` alters camera 1's matrix.
fn three_projections(
    dir: &Path,
    change: impl Fn(Matrix3x4<f64>) -> Matrix3x4<f64>,
) -> Vec<PathBuf> {
    std::fs::create_dir_all(dir).unwrap();
    let k = Matrix3::new(800.0, 0.0, 319.5, 0.0, 800.0, 239.5, 0.0, 0.0, 1.0);
    let centres = [
        Point3::new(500.0, 0.0, 100.0),
        Point3::new(0.0, 500.0, 150.0),
        Point3::new(-350.0, -350.0, 50.0),
    ];
    centres
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            let pose = Pose::look_at(c, Point3::origin(), Vector3::z());
            let mut rt = Matrix3x4::zeros();
            rt.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(pose.rotation.matrix());
            rt.set_column(3, &pose.translation);
            let p = if i == 1 { change(k * rt) } else { k * rt };
            let text: Vec<String> = p
                .row_iter()
                .map(|r| format!("{} {} {} {}", r[0], r[1], r[2], r[3]))
                .collect();
            let path = dir.join(format!("cam{i}.txt"));
            std::fs::write(&path, text.join("\n")).unwrap();
            path
        })
        .collect()
}

/// A projection matrix holds no sign of its own (`P` and `−P` project alike), so a camera whose
/// image is mirrored (a negative focal length) or whose rotation is a reflection reads as a
/// camera turned to face backwards, away from what the others look at. `rig import` said
/// nothing and wrote it; now it refuses, naming the camera. The same cameras as they are, and
/// their matrices at another scale and sign, import.
#[test]
fn a_mirrored_or_reflected_projection_is_refused_naming_the_camera() {
    let dir = tempfile::tempdir().unwrap();
    let options = ImportOptions {
        unit: Some(Unit::Millimetre),
        size: Some((640, 480)),
    };
    let read = |inputs: &[PathBuf]| import::read(Format::Projection, inputs, options);
    let as_they_are = three_projections(&dir.path().join("right"), |p| p);
    assert_eq!(read(&as_they_are).unwrap().cameras.len(), 3);
    let scaled = three_projections(&dir.path().join("scaled"), |p| p * -0.001);
    let cameras = read(&scaled).unwrap().cameras;
    let centre = cameras[1].camera.centre();
    assert!(
        (centre - Point3::new(0.0, 500.0, 150.0)).norm() < 1e-6,
        "{centre}"
    );
    // The image flipped left to right: u' = 639 − u.
    let flip = Matrix3::new(-1.0, 0.0, 639.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    let mirrored = three_projections(&dir.path().join("mirrored"), |p| flip * p);
    // x_cam' = diag(−1, 1, 1)·x_cam: [R | t] with R of determinant −1. (A reflection of z,
    // diag(1, 1, −1), is −1 times a turn of 180° about the axis: that camera faces the scene
    // and projects as the matrix says, and imports.)
    let reflect = Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0));
    let reflected = three_projections(&dir.path().join("reflected"), |p| {
        let k = Matrix3::new(800.0, 0.0, 319.5, 0.0, 800.0, 239.5, 0.0, 0.0, 1.0);
        k * reflect * k.try_inverse().unwrap() * p
    });
    for (what, inputs) in [("mirrored", mirrored), ("reflected", reflected)] {
        let e = read(&inputs).unwrap_err().to_string();
        println!("{what}: {e}");
        assert!(e.contains("lies behind camera cam1 ("), "{what}: {e}");
        assert!(
            !e.contains("cam0 (") && !e.contains("cam2 ("),
            "{what}: {e}"
        );
    }
}
