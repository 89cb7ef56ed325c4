//! `flexshape calibrate` on the real stereo photographs in `../shared/data/stereo-9x6` (skipped
//! with a message when absent): intrinsics per camera, the right camera's pose, files that load
//! back as a rig.

use crate::common;

use common::{fails, run};

use std::path::Path;

/// The real stereo photographs, or `None` (with a message) when `../shared` is absent.
fn stereo_data() -> Option<std::path::PathBuf> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/stereo-9x6");
    if data.is_dir() {
        Some(data)
    } else {
        assert!(
            std::env::var("FLEXSHAPE_REQUIRE_SHARED").as_deref() != Ok("1"),
            "FLEXSHAPE_REQUIRE_SHARED=1 but {} is missing",
            data.display()
        );
        println!("SKIPPED: {} not found", data.display());
        None
    }
}

#[test]
fn stereo_photographs_calibrate_into_a_rig() {
    let Some(data) = stereo_data() else { return };
    // One folder per camera; the same file name means the same instant.
    let dir = tempfile::tempdir().unwrap();
    for cam in ["left", "right"] {
        let folder = dir.path().join(cam);
        std::fs::create_dir_all(&folder).unwrap();
        for i in 1..=15 {
            std::fs::copy(
                data.join(format!("{cam}{i:02}.jpg")),
                folder.join(format!("{i:02}.jpg")),
            )
            .unwrap();
        }
    }
    // A corrupt image is reported and left out, not fatal.
    std::fs::write(dir.path().join("left/99.jpg"), b"not a jpeg").unwrap();
    let out = dir.path().join("calibration");
    let arg = |cam: &str| format!("{cam}={}", dir.path().join(cam).display());
    let (left, right) = (arg("left"), arg("right"));
    let calibrate = |out: &Path| {
        [
            "calibrate",
            "--board",
            "9x6",
            "--square",
            "25",
            "--images",
            left.as_str(),
            "--images",
            right.as_str(),
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
    };
    fn strs(a: &[String]) -> Vec<&str> {
        a.iter().map(String::as_str).collect()
    }
    // Never among the images: the next calibration would read its plots as views.
    let inside = dir.path().join("left/calibration");
    let e = common::fails(&strs(&calibrate(&inside)));
    assert!(e.contains("the input") && e.contains("elsewhere"), "{e}");
    assert!(!inside.exists());
    let text = run(&strs(&calibrate(&out)));
    assert!(
        text.contains("rejected 99.jpg: cannot read the image"),
        "{text}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("calibration.json")).unwrap())
            .unwrap();
    // ROS's CameraInfo YAML beside OpenCV's files reads back as the rig's intrinsics.
    let rig = flexshape_rig::Rig::load(&out.join("rig.toml")).unwrap();
    let ros: Vec<_> = ["left", "right"]
        .map(|c| out.join("ros").join(format!("{c}.yaml")))
        .to_vec();
    let read = flexshape_rig::import::read(
        flexshape_rig::import::Format::CameraInfo,
        &ros,
        flexshape_rig::import::ImportOptions::default(),
    )
    .unwrap();
    for (got, want) in read.cameras.iter().zip(&rig.cameras) {
        let (a, b) = (&got.camera.intrinsics, &want.camera.intrinsics);
        assert_eq!((a.width, a.height), (b.width, b.height));
        for (x, y) in [(a.fx, b.fx), (a.fy, b.fy), (a.cx, b.cx), (a.cy, b.cy)] {
            assert!((x - y).abs() < 1e-6, "{x} {y}");
        }
        let (da, db) = (a.distortion.to_opencv(), b.distortion.to_opencv());
        assert!(
            da.iter().zip(&db).all(|(x, y)| (x - y).abs() < 1e-9),
            "{da:?} {db:?}"
        );
    }
    // OpenCV on the same images: rms 0.128 / 0.131 px, fx 516.55 / 518.25; baseline 3.87
    // squares = 96.8 mm.
    for (k, fx) in [(0, 516.55), (1, 518.25)] {
        let cam = &report[k];
        assert!(cam["rms_px"].as_f64().unwrap() < 0.131, "{cam}");
        assert!(
            (cam["fx"].as_f64().unwrap() - fx).abs() < 0.005 * fx,
            "{cam}"
        );
        assert_eq!(cam["views"].as_array().unwrap().len(), 15);
    }
    let t = &report[1]["relative_to_reference"]["translation"];
    let baseline = (0..3)
        .map(|i| t[i].as_f64().unwrap().powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        (baseline - 96.79).abs() < 0.02 * 96.79,
        "baseline {baseline}"
    );
    // The written pose (the joint adjustment's, intrinsics fixed) against OpenCV's
    // stereoCalibrate (intrinsics fixed): T = [3.8228, −0.0939, 0.6048] squares of 25 mm.
    let yml = std::fs::read_to_string(out.join("right.yml")).unwrap();
    let t_line = yml
        .split("T:")
        .nth(1)
        .unwrap()
        .lines()
        .find(|l| l.contains("data"))
        .unwrap();
    let t: Vec<f64> = t_line
        .split(['[', ']'])
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    let opencv = [3.8227986 * 25.0, -0.0938641 * 25.0, 0.6047747 * 25.0];
    let d = (0..3)
        .map(|i| (t[i] - opencv[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(d < 0.5, "T {t:?} vs OpenCV {opencv:?}");
    // The rig loads back, with both cameras.
    assert!(run(&["rig", "check", out.join("rig.toml").to_str().unwrap()]).contains("2 cameras"));
    for f in ["left.yml", "right.yml", "residuals.png", "residuals.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // No shared views between the cameras: a clear error.
    let lone = dir.path().join("lone");
    std::fs::create_dir_all(&lone).unwrap();
    for i in 1..=4 {
        std::fs::copy(
            data.join(format!("right{i:02}.jpg")),
            lone.join(format!("r{i}.jpg")),
        )
        .unwrap();
    }
    let e = fails(&[
        "calibrate",
        "--board",
        "9x6",
        "--square",
        "25",
        "--images",
        &arg("left"),
        "--images",
        &format!("lone={}", lone.display()),
        "--out",
        dir.path().join("x").to_str().unwrap(),
    ]);
    assert!(e.contains("same file name"), "{e}");
}

/// The numbers after `key` on the lines of `rig check`'s report that hold it.
fn numbers(text: &str, key: &str) -> Vec<f64> {
    text.lines()
        .filter_map(|l| l.split(key).nth(1))
        .map(|rest| {
            rest.split_whitespace()
                .next()
                .unwrap()
                .parse::<f64>()
                .unwrap()
        })
        .collect()
}

/// The camera centres in `rig check`'s report, world mm.
fn centres(text: &str) -> Vec<[f64; 3]> {
    text.lines()
        .filter_map(|l| l.split("centre (").nth(1))
        .map(|rest| {
            let inside = rest.split(')').next().unwrap();
            let v: Vec<f64> = inside
                .split(',')
                .map(|x| x.trim().parse().unwrap())
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Boards of `board` (the options naming it) through the simulated rig, calibrated: the
/// focal lengths within `fx_share` of the truth's and the distances between camera centres
/// within `baseline_mm`. Returns the `--images` options.
fn calibrates_to_the_true_rig(
    out: &Path,
    board: &[&str],
    fx_share: f64,
    baseline_mm: f64,
) -> Vec<String> {
    let mut args = vec!["simulate", "chessboards", "--out", out.to_str().unwrap()];
    args.extend_from_slice(&["--own", "5", "--shared", "3"]);
    args.extend_from_slice(board);
    run(&args);
    let cal = out.join("calibration");
    let images: Vec<String> = (0..3)
        .map(|k| {
            format!(
                "cam{k}={}",
                out.join("images").join(format!("cam{k}")).display()
            )
        })
        .collect();
    let mut args = vec!["calibrate", "--out", cal.to_str().unwrap()];
    args.extend_from_slice(board);
    for i in &images {
        args.extend_from_slice(&["--images", i]);
    }
    run(&args);
    let read = |path: &Path| run(&["rig", "check", path.to_str().unwrap()]);
    let (truth, got) = (
        read(&out.join("truth/rig.toml")),
        read(&cal.join("rig.toml")),
    );
    let (ft, fg) = (numbers(&truth, " fx "), numbers(&got, " fx "));
    assert_eq!((ft.len(), fg.len()), (3, 3));
    for (t, g) in ft.iter().zip(&fg) {
        println!("{board:?}: fx {g} (truth {t})");
        assert!((t - g).abs() < fx_share * t, "fx {g} vs {t}");
    }
    let (ct, cg) = (centres(&truth), centres(&got));
    for k in 1..3 {
        let (t, g) = (distance(&ct[0], &ct[k]), distance(&cg[0], &cg[k]));
        println!("{board:?}: cam0 to cam{k}: {g:.2} mm (truth {t:.2})");
        assert!((t - g).abs() < baseline_mm, "cam0 to cam{k}: {g} vs {t}");
    }
    images
}

/// An asymmetric circle grid (4 × 11, OpenCV's layout) calibrates the simulated rig.
#[test]
fn simulated_asymmetric_circle_grids_calibrate_to_the_true_rig() {
    let dir = tempfile::tempdir().unwrap();
    calibrates_to_the_true_rig(
        dir.path(),
        &["--board", "acircles:4x11", "--square", "20"],
        0.003,
        1.0,
    );
}

/// A symmetric circle grid (7 × 5) calibrates the simulated rig although it cannot tell its
/// ends apart: shared views a camera labelled the other way round are turned to agree (the
/// rig's cameras see this grid upside down from one another in some views). Fewer, less
/// varied dots than the other boards: the focal lengths within 0.5 %, baselines within 2 mm.
#[test]
fn simulated_symmetric_circle_grids_calibrate_to_the_true_rig() {
    let dir = tempfile::tempdir().unwrap();
    calibrates_to_the_true_rig(
        dir.path(),
        &["--board", "circles:7x5", "--square", "20"],
        0.005,
        2.0,
    );
}

/// ChArUco boards (10 × 7 squares, 4×4 markers) calibrate the simulated rig.
#[test]
fn simulated_charuco_boards_calibrate_to_the_true_rig() {
    let dir = tempfile::tempdir().unwrap();
    let board = [
        "--board",
        "charuco:10x7",
        "--square",
        "25",
        "--marker",
        "18",
        "--dictionary",
        "DICT_4X4_50",
    ];
    let images = calibrates_to_the_true_rig(dir.path(), &board, 0.003, 1.0);
    // A ChArUco board needs its marker size; a chessboard has none; dictionaries by name.
    let base = [
        "calibrate",
        "--square",
        "25",
        "--out",
        "x",
        "--images",
        &images[0],
    ];
    let e = fails(&[&base[..], &["--board", "charuco:10x7"]].concat());
    assert!(e.contains("--marker"), "{e}");
    let e = fails(&[&base[..], &["--board", "9x6", "--marker", "18"]].concat());
    assert!(e.contains("charuco:"), "{e}");
    let e = fails(
        &[
            &base[..],
            &board[..2],
            &["--marker", "18", "--dictionary", "DICT_9X9"],
        ]
        .concat(),
    );
    assert!(e.contains("unknown ArUco dictionary `DICT_9X9`"), "{e}");
}

#[test]
fn simulated_chessboards_calibrate_to_the_true_rig() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    run(&[
        "simulate",
        "chessboards",
        "--out",
        out.to_str().unwrap(),
        "--own",
        "5",
        "--shared",
        "3",
    ]);
    let images = |cam: &str| format!("{cam}={}", out.join("images").join(cam).display());
    let calibrate = |to: &Path, extra: &[&str]| {
        let (a, b, c) = (images("cam0"), images("cam1"), images("cam2"));
        let mut args = vec![
            "calibrate",
            "--board",
            "9x6",
            "--square",
            "30",
            "--images",
            &a,
            "--images",
            &b,
            "--images",
            &c,
            "--out",
        ];
        args.push(to.to_str().unwrap());
        args.extend_from_slice(extra);
        run(&args);
    };
    let cal = out.join("calibration");
    calibrate(&cal, &[]);
    // Both rigs through `rig check`'s reading code: compare focal lengths and camera centres.
    let read = |path: &Path| run(&["rig", "check", path.to_str().unwrap()]);
    let truth = read(&out.join("truth/rig.toml"));
    let got = read(&cal.join("rig.toml"));
    let (ft, fg) = (numbers(&truth, " fx "), numbers(&got, " fx "));
    assert_eq!(ft.len(), 3);
    for (t, g) in ft.iter().zip(&fg) {
        assert!((t - g).abs() < 0.005 * t, "fx {g} vs {t}");
    }
    // The world frame from measured points: five corners of the board in cam0_00, at their
    // true world positions (truth/boards.json); the cameras' centres then land on the truth's.
    let boards: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth/boards.json")).unwrap())
            .unwrap();
    let view = boards
        .as_array()
        .unwrap()
        .iter()
        .find(|b| b["image"] == "cam0_00")
        .unwrap();
    let m = |r: usize, c: usize| view["rotation"][r][c].as_f64().unwrap();
    let t = |r: usize| view["translation"][r].as_f64().unwrap();
    let mut csv = String::from("image,col,row,x,y,z\n");
    for (c, r) in [(0, 0), (8, 0), (0, 5), (8, 5), (4, 3)] {
        let (x, y) = (c as f64 * 30.0, r as f64 * 30.0);
        let w: Vec<f64> = (0..3).map(|i| m(i, 0) * x + m(i, 1) * y + t(i)).collect();
        csv += &format!("cam0_00,{c},{r},{},{},{}\n", w[0], w[1], w[2]);
    }
    let points = out.join("points.csv");
    std::fs::write(&points, csv).unwrap();
    let cal2 = out.join("calibration-world");
    calibrate(&cal2, &["--world", &format!("points:{}", points.display())]);
    let (ct, cg) = (centres(&truth), centres(&read(&cal2.join("rig.toml"))));
    assert_eq!(ct.len(), 3);
    for (a, b) in ct.iter().zip(&cg) {
        let d = distance(a, b);
        println!("camera centre {b:?} vs truth {a:?}: {d:.2} mm");
        assert!(d < 2.0, "camera centre {b:?} vs truth {a:?}");
    }
    // Every shared view gives the same relative pose (the library test checks it against
    // the truth).
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cal.join("calibration.json")).unwrap())
            .unwrap();
    for k in 1..3 {
        let rel = &report[k]["relative_to_reference"];
        assert!(rel["rotation_spread_deg"].as_f64().unwrap() < 0.1, "{rel}");
        assert!(
            rel["translation_spread_mm"].as_f64().unwrap() < 1.0,
            "{rel}"
        );
    }
}

#[test]
fn calibration_input_errors_name_the_problem() {
    let Some(data) = stereo_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("left");
    std::fs::create_dir_all(&folder).unwrap();
    for i in 1..=2 {
        std::fs::copy(
            data.join(format!("left{i:02}.jpg")),
            folder.join(format!("{i:02}.jpg")),
        )
        .unwrap();
    }
    let images = format!("left={}", folder.display());
    let out = dir.path().join("out");
    let calibrate = |board: &str| {
        fails(&[
            "calibrate",
            "--board",
            board,
            "--square",
            "25",
            "--images",
            &images,
            "--out",
            out.to_str().unwrap(),
        ])
    };
    // Two views are too few.
    let e = calibrate("9x6");
    assert!(
        e.contains("camera left") && e.contains("2 usable views"),
        "{e}"
    );
    // A board size that does not match: no view is usable.
    let e = calibrate("8x6");
    assert!(e.contains("0 usable views"), "{e}");
    // An image of another size in one camera's folder.
    image::RgbImage::new(20, 10)
        .save(folder.join("03.png"))
        .unwrap();
    let e = calibrate("9x6");
    assert!(
        e.contains("03.png is 20×10") && e.contains("640×512"),
        "{e}"
    );
}

#[test]
fn stereo_photographs_by_pattern_and_views_out_of_step() {
    let Some(data) = stereo_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let calibrate = |left: &str, right: &str, out: &str| {
        common::flexshape(&[
            "calibrate",
            "--board",
            "9x6",
            "--square",
            "25",
            "--images",
            left,
            "--images",
            right,
            "--out",
            dir.path().join(out).to_str().unwrap(),
        ])
    };
    // OpenCV's sample layout, both cameras in one folder: patterns pair left07 with right07.
    let left = format!("left={}", data.join("left*.jpg").display());
    let right = format!("right={}", data.join("right*.jpg").display());
    let o = calibrate(&left, &right, "by_pattern");
    let text = common::text(&o);
    assert!(o.status.success(), "{text}");
    assert!(text.contains("from 15 shared views"), "{text}");
    // The same images for two cameras: refused.
    let same = format!("other={}", data.join("left*.jpg").display());
    let e = common::text(&calibrate(&left, &same, "same"));
    assert!(e.contains("are given the same images"), "{e}");
    // Two right views swapped (not taken with the left views of their names): refused,
    // naming them.
    let right_dir = dir.path().join("right");
    std::fs::create_dir_all(&right_dir).unwrap();
    for i in 1..=15 {
        let j = match i {
            4 => 9,
            9 => 4,
            i => i,
        };
        std::fs::copy(
            data.join(format!("right{j:02}.jpg")),
            right_dir.join(format!("right{i:02}.jpg")),
        )
        .unwrap();
    }
    let swapped = format!("right={}", right_dir.join("right*.jpg").display());
    let o = calibrate(&left, &swapped, "swapped");
    let e = common::text(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("2 of 15 shared views disagree") && e.contains("right04.jpg, right09.jpg"),
        "{e}"
    );
}
