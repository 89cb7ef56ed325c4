//! `flexshape capture` from cameras played live (simulated frames as videos in real time):
//! one folder per camera that `background` and `track --images` read as they are.

use crate::common;

use std::path::Path;

use serde_json::Value;

/// The simulated recording's frames of camera `cam`, each held for a second in a lossless
/// video played at 10 frames/s (a scene that stays still while it is captured).
fn held_video(rec: &Path, cam: &str, out: &Path) -> String {
    let video = out.join(format!("{cam}.mkv"));
    let status = std::process::Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate", "1", "-i"])
        .arg(rec.join("frames").join(cam).join("%06d.png"))
        .args(["-c:v", "png", "-fps_mode", "cfr", "-r", "10"])
        .arg(&video)
        .status()
        .unwrap();
    assert!(status.success());
    format!("{cam}={}", video.display())
}

#[test]
fn captured_sets_are_the_cameras_frames_and_track_as_a_folder() {
    if !common::ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    common::run(&["simulate", "--out", rec.to_str().unwrap(), "--frames", "3"]);
    let cams = ["cam0", "cam1", "cam2"];
    let cameras: Vec<String> = cams
        .iter()
        .map(|c| held_video(&rec, c, dir.path()))
        .collect();
    let out = dir.path().join("captured");
    let mut args = vec!["capture", "--out", out.to_str().unwrap(), "--sets", "3"];
    args.extend(["--interval", "0.27"]);
    for c in &cameras {
        args.extend(["--camera", c.as_str()]);
    }
    let printed = common::run(&args);
    assert!(printed.contains("3 set(s) written"), "{printed}");
    // Every captured image is one of the camera's frames, pixel for pixel.
    for cam in cams {
        let recorded: Vec<_> = (0..3)
            .map(|f| {
                image::open(rec.join("frames").join(cam).join(format!("{f:06}.png")))
                    .unwrap()
                    .to_rgb8()
            })
            .collect();
        for set in 0..3 {
            let path = out.join(cam).join(format!("{set:06}.png"));
            let got = image::open(&path).unwrap().to_rgb8();
            assert!(
                recorded.contains(&got),
                "{} is no frame of {cam}",
                path.display()
            );
        }
    }
    let stamps = std::fs::read_to_string(out.join("timestamps.csv")).unwrap();
    assert_eq!(stamps.lines().count(), 4, "{stamps}");
    // Capturing into the same folder again would overwrite: refused.
    let e = common::fails(&args);
    assert!(e.contains("exists already"), "{e}");

    // The folders track as they are.
    let records = dir.path().join("records.jsonl");
    let mut track = vec![
        "track".to_string(),
        "--rig".into(),
        rec.join("rig.toml").display().to_string(),
        "--backgrounds".into(),
        rec.join("background").display().to_string(),
        "--out".into(),
        records.display().to_string(),
    ];
    for cam in cams {
        track.push("--images".into());
        track.push(format!("{cam}={}", out.join(cam).display()));
    }
    let track: Vec<&str> = track.iter().map(String::as_str).collect();
    common::run(&track);
    let text = std::fs::read_to_string(&records).unwrap();
    let frames: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|r| r.get("frame").is_some() && r.get("status").is_some())
        .collect();
    assert_eq!(frames.len(), 3, "{text}");
    assert!(frames.iter().all(|r| r["status"] != "error"), "{text}");
}

#[test]
fn capture_refuses_a_camera_given_twice_and_bad_intervals() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    let e = common::fails(&[
        "capture",
        "--out",
        o,
        "--size",
        "64x48",
        "--camera",
        "a=/dev/null",
        "--camera",
        "a=/dev/null",
    ]);
    assert!(e.contains("given twice"), "{e}");
    let e = common::fails(&["capture", "--out", o, "--interval", "-1", "--camera", "a=x"]);
    assert!(e.contains("not a time"), "{e}");
}

/// The walk-through's first two steps on cameras played live: a chessboard held still in
/// front of two simulated cameras, the empty scene between poses, as a person moving a board
/// does, captured at a least interval, then calibrated from the captured folders. The second
/// camera lands where the simulator put it. Played three times faster than a person moves (the
/// board 0.33 s per pose, 0.1 s away between poses, captured every 0.27 s at 30 frames/s)
/// with the same share of sets caught between poses: what is tested is the capture and the
/// calibration, not the waiting (26.7 s at 10 frames/s, every 0.8 s).
#[test]
fn chessboards_captured_live_calibrate_the_rig() {
    use flexshape_sim::{
        BoardRenderer, PrintedBoard, PrintedPattern, SimConfig, SimRigConfig, calibration_views,
    };
    if !common::ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let rig = SimConfig {
        rig: SimRigConfig {
            cameras: 2,
            ..SimRigConfig::default()
        },
        ..SimConfig::default()
    }
    .rig
    .rig()
    .unwrap();
    let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let board = PrintedBoard {
        cols: 9,
        rows: 6,
        square: 30.0,
        pattern: PrintedPattern::Chessboard,
    };
    let views = calibration_views(&cameras, &board, 5, 4, 3);
    let mut videos = Vec::new();
    for (k, cam) in rig.cameras.iter().enumerate() {
        let renderer = BoardRenderer::new(&cam.camera).unwrap();
        let frames = dir.path().join(format!("frames{k}"));
        std::fs::create_dir_all(&frames).unwrap();
        let (w, h) = (cam.camera.intrinsics.width, cam.camera.intrinsics.height);
        // Each distinct picture is written once; the video's frames are hard links to them.
        let empty = frames.join("empty.png");
        image::GrayImage::from_pixel(w, h, image::Luma([120]))
            .save(&empty)
            .unwrap();
        let mut n = 0;
        for (i, view) in views.iter().enumerate() {
            // Every camera films every instant, whether or not it sees the whole board.
            let shot = frames.join(format!("shot{i}.png"));
            renderer
                .render(&board, &view.pose, 1.0, i as u64 * 7 + k as u64)
                .save(&shot)
                .unwrap();
            // A third of a second of nothing between shots: two streams started together
            // but drifting apart on a busy machine (by up to that) are never captured on two
            // different shots, which the calibration rightly refuses as not simultaneous (it
            // did, once, with a tenth of a second between them).
            for f in 0..18 {
                let picture = if f < 8 { &empty } else { &shot };
                std::fs::hard_link(picture, frames.join(format!("{n:06}.png"))).unwrap();
                n += 1;
            }
        }
        let video = dir.path().join(format!("{}.mkv", cam.name));
        let status = std::process::Command::new("ffmpeg")
            .args(["-y", "-loglevel", "error", "-framerate", "30", "-i"])
            .arg(frames.join("%06d.png"))
            .args(["-c:v", "libx264rgb", "-preset", "ultrafast", "-qp", "0"])
            .arg(&video)
            .status()
            .unwrap();
        assert!(status.success());
        videos.push(format!("{}={}", cam.name, video.display()));
    }
    let out = dir.path().join("chessboards");
    let mut args = vec!["capture", "--out", out.to_str().unwrap(), "--sets", "1000"];
    args.extend(["--interval", "0.27"]);
    for v in &videos {
        args.extend(["--camera", v.as_str()]);
    }
    let printed = common::run(&args);
    println!("{printed}");
    let cal = dir.path().join("cal");
    let images: Vec<String> = rig
        .cameras
        .iter()
        .map(|c| format!("{0}={1}", c.name, out.join(&c.name).display()))
        .collect();
    let mut args = vec![
        "calibrate",
        "--board",
        "9x6",
        "--square",
        "30",
        "--out",
        cal.to_str().unwrap(),
    ];
    for i in &images {
        args.extend(["--images", i.as_str()]);
    }
    let printed = common::run(&args);
    println!("{printed}");
    // The second camera relative to the first, against the simulator's.
    let got = flexshape_rig::Rig::load(&cal.join("rig.toml")).unwrap();
    let relative = |r: &flexshape_rig::Rig| {
        let (a, b) = (&r.cameras[0].camera.pose, &r.cameras[1].camera.pose);
        let rotation = b.rotation * a.rotation.inverse();
        (rotation, b.translation - rotation * a.translation)
    };
    let ((rt, tt), (rg, tg)) = (relative(&rig), relative(&got));
    let angle = flexshape_camera::angle_between(&rt, &rg).to_degrees();
    let offset = (tg - tt).norm();
    println!("relative pose off by {angle:.3}° and {offset:.2} mm");
    assert!(angle < 0.2 && offset < 2.0, "{angle:.3}°, {offset:.2} mm");
}
