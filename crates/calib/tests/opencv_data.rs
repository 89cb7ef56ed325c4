//! Real photographs (`../shared/data`) against OpenCV 5's own calibration of the same images
//! (`opencv-reference.json`: findChessboardCorners + cornerSubPix + calibrateCamera). Skipped
//! with a message when the shared data are absent.

use std::path::{Path, PathBuf};

use flexshape_calib::{Board, CalibrationSettings, Detection, calibrate, detect};

fn data(set: &str) -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(set);
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("SKIPPED: {} not found", dir.display());
        None
    }
}

fn reference(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("opencv-reference.json")).unwrap())
        .unwrap()
}

/// Named detections, the images without a whole board, and the image size.
type Found = (Vec<(String, Detection)>, Vec<String>, (u32, u32));

/// Detections of every `prefix*.jpg`, and the names of the images without a whole board.
fn detections(dir: &Path, prefix: &str, board: &Board) -> Found {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            name.starts_with(prefix) && name.ends_with(".jpg")
        })
        .collect();
    files.sort();
    let (mut found, mut missed, mut size) = (Vec::new(), Vec::new(), (0, 0));
    for f in files {
        let img = image::open(&f).unwrap().to_luma8();
        size = img.dimensions();
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        match detect(&img, board) {
            Ok(d) => found.push((name, d)),
            Err(e) => {
                println!("{name}: {e}");
                missed.push(name);
            }
        }
    }
    (found, missed, size)
}

/// `reference`: OpenCV's figures (`key` picks a sub-object), with the standard deviations of
/// fx, fy, cx, cy when known.
fn compare(
    set: &str,
    prefix: &str,
    reference_file: Option<&str>,
    key: Option<&str>,
    max_missed: usize,
) {
    let Some(dir) = data(set) else { return };
    let board = Board::parse("9x6", 1.0).unwrap();
    let (views, missed, (w, h)) = detections(&dir, prefix, &board);
    assert!(missed.len() <= max_missed, "missed {missed:?}");
    let cal = calibrate(&board, &views, w, h, &CalibrationSettings::default()).unwrap();
    let all = match reference_file {
        Some(f) => serde_json::from_str(
            &std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(f)).unwrap(),
        )
        .unwrap(),
        None => reference(&dir),
    };
    let r = key.map_or(&all, |k| &all[k]);
    let k = &cal.intrinsics;
    let f = |name: &str| r[name].as_f64().unwrap();
    println!(
        "{set}/{prefix}: {} views, rms {:.4} px (OpenCV {:.4}); fx {:.2} ({:.2}), fy {:.2} ({:.2}), cx {:.2} ({:.2}), cy {:.2} ({:.2}); dist {:?} ({}); σ fx {:.2}",
        views.len(),
        cal.rms_px,
        f("rms_px"),
        k.fx,
        f("fx"),
        k.fy,
        f("fy"),
        k.cx,
        f("cx"),
        k.cy,
        f("cy"),
        k.distortion.to_opencv(),
        r["dist_k1_k2_p1_p2_k3"],
        cal.std_dev[0]
    );
    // As good as OpenCV: a reprojection RMS no worse than its own, and the intrinsics within
    // three standard deviations of the difference (ours and, when known, OpenCV's) or 0.5 %.
    assert!(cal.rms_px <= f("rms_px"), "rms {}", cal.rms_px);
    for (a, (got, name)) in [(k.fx, "fx"), (k.fy, "fy"), (k.cx, "cx"), (k.cy, "cy")]
        .into_iter()
        .enumerate()
    {
        let want = f(name);
        let theirs = r["std_fx_fy_cx_cy"][a].as_f64().unwrap_or(0.0);
        let sd = cal.std_dev[a].hypot(theirs);
        assert!(
            (got - want).abs() <= (3.0 * sd).max(0.005 * want),
            "{name}: {got} vs OpenCV {want} (σ {sd})"
        );
    }
}

#[test]
fn opencv_sample_images_calibrate_like_opencv() {
    // OpenCV on the same 11 views (our detector rejects left12.jpg as ambiguous): the
    // fixture and the script that made it are in tests/fixtures/.
    compare(
        "opencv-left",
        "left",
        Some("tests/fixtures/opencv-left-without-12.json"),
        None,
        1,
    );
}

#[test]
fn stereo_rig_cameras_calibrate_like_opencv() {
    compare("stereo-9x6", "left", None, None, 0);
    compare("stereo-9x6", "right", None, Some("right"), 0);
}

#[test]
fn stereo_rig_relative_pose_matches_opencv() {
    let Some(dir) = data("stereo-9x6") else {
        return;
    };
    let board = Board::parse("9x6", 1.0).unwrap();
    let settings = CalibrationSettings::default();
    let (left, _, (w, h)) = detections(&dir, "left", &board);
    let (right, _, _) = detections(&dir, "right", &board);
    let l = calibrate(&board, &left, w, h, &settings).unwrap();
    let r = calibrate(&board, &right, w, h, &settings).unwrap();
    let pairs: Vec<_> = l
        .views
        .iter()
        .filter_map(|a| {
            let twin = a.name.replacen("left", "right", 1);
            r.views
                .iter()
                .find(|b| b.name == twin)
                .map(|b| (a.board_pose(), b.board_pose()))
        })
        .collect();
    let rel = flexshape_calib::relative_pose(&pairs).unwrap();
    let want = &reference(&dir)["stereo"];
    let t: Vec<f64> = (0..3)
        .map(|i| want["T_squares"][i].as_f64().unwrap())
        .collect();
    let baseline = rel.translation.iter().map(|v| v * v).sum::<f64>().sqrt();
    println!(
        "relative pose from {} views: t {:?} (OpenCV {t:?}), baseline {baseline:.4} ({:.4}); spread {:.3}°, {:.4} squares",
        rel.shared_views,
        rel.translation,
        want["baseline_squares"],
        rel.rotation_spread_deg,
        rel.translation_spread_mm
    );
    assert_eq!(rel.shared_views, 15);
    let d = (0..3)
        .map(|i| (rel.translation[i] - t[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(d < 0.02 * baseline, "translation off by {d} squares");
    let mut angle: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            angle = angle.max((rel.rotation[i][j] - want["R"][i][j].as_f64().unwrap()).abs());
        }
    }
    assert!(angle < 0.005, "rotation entries off by {angle}");
}

#[test]
fn fixing_k3_keeps_it_zero_and_still_reports_standard_deviations() {
    let Some(dir) = data("stereo-9x6") else {
        return;
    };
    let board = Board::parse("9x6", 1.0).unwrap();
    let (views, _, (w, h)) = detections(&dir, "left", &board);
    let settings = CalibrationSettings {
        fix_k3: true,
        ..CalibrationSettings::default()
    };
    let cal = calibrate(&board, &views, w, h, &settings).unwrap();
    assert_eq!(cal.intrinsics.distortion.to_opencv()[4], 0.0);
    assert_eq!(cal.std_dev[8], 0.0);
    for (k, sd) in cal.std_dev[..8].iter().enumerate() {
        assert!(*sd > 0.0 && sd.is_finite(), "std_dev[{k}] = {sd}");
    }
    // The joint adjustment, refining intrinsics, keeps it too.
    let rig = [flexshape_calib::RigCamera {
        calibration: &cal,
        views: &views,
        pose: flexshape_calib::BoardPose {
            rotation: nalgebra::Rotation3::identity(),
            translation: nalgebra::Vector3::zeros(),
        },
    }];
    let adjusted = flexshape_calib::adjust_rig(
        &board,
        &rig,
        flexshape_calib::JointIntrinsics::Refined { fix_k3: true },
    )
    .unwrap();
    assert_eq!(adjusted.intrinsics[0].distortion.to_opencv()[4], 0.0);
}
