//! A simulated recording written to disk reads back whole, and broken recordings give errors
//! that name the file.

use std::ops::ControlFlow;

use flexshape_recording::{RecordingError, RecordingReader};
use flexshape_sim::{SimConfig, Simulator};

fn write(dir: &std::path::Path, frames: usize) -> Simulator {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let poses = sim.sweep(frames);
    let mut seen = Vec::new();
    let written = sim
        .write_recording(dir, &poses, false, |f| {
            seen.push(f.truth.frame);
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(written, frames as u64);
    assert_eq!(seen, (0..frames as u64).collect::<Vec<_>>());
    sim
}

#[test]
fn recording_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let sim = write(dir.path(), 2);
    for rel in [
        "rig.toml",
        "calibration/cam0.yml",
        "calibration/cam2.yml",
        "background/cam1.png",
        "frames/cam0/000000.png",
        "frames/cam2/000001.png",
        "truth/000001.json",
        "truth/masks/cam1/000000.png",
        "truth/markers/cam2/000001.png",
    ] {
        assert!(dir.path().join(rel).is_file(), "{rel} missing");
    }
    let rec = RecordingReader::open(dir.path()).unwrap();
    assert_eq!(rec.frames(), &[0, 1]);
    assert_eq!(rec.rig(), sim.rig(), "calibration must round-trip exactly");
    let again = sim.render(1, &sim.sweep(2)[1]).unwrap();
    assert_eq!(
        rec.read_frame(2, 1).unwrap().as_raw(),
        again.views[2].image.as_raw()
    );
    assert_eq!(
        rec.read_truth_mask(0, 1).unwrap().unwrap().as_raw(),
        again.views[0].mask.as_raw()
    );
    assert_eq!(rec.read_truth(1).unwrap().unwrap(), again.truth);
    assert!(rec.read_background(0).unwrap().is_some());
    // The same folder is not overwritten by accident.
    let err = sim
        .write_recording(dir.path(), &sim.sweep(1), false, |_| {
            ControlFlow::Continue(())
        })
        .err()
        .unwrap();
    assert!(err.to_string().contains("--overwrite"), "{err}");
    // Overwriting a longer recording with a shorter one leaves no stale frame behind.
    let keep = dir.path().join("notes.txt");
    std::fs::write(&keep, "mine").unwrap();
    sim.write_recording(dir.path(), &sim.sweep(1), true, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let rec = RecordingReader::open(dir.path()).unwrap();
    assert_eq!(rec.frames(), &[0]);
    assert!(rec.read_truth(1).unwrap().is_none());
    assert_eq!(std::fs::read_to_string(&keep).unwrap(), "mine");
    // A calibration folder alone (no rig.toml) is enough to open it.
    std::fs::remove_file(dir.path().join("rig.toml")).unwrap();
    assert_eq!(
        RecordingReader::open(dir.path())
            .unwrap()
            .rig()
            .cameras
            .len(),
        3
    );
}

#[test]
fn a_calibration_written_off_keeps_the_true_rig_in_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = SimConfig::default();
    config.rig.calibration_error_px = 2.0;
    let sim = Simulator::new(config.clone()).unwrap();
    sim.write_recording(dir.path(), &sim.sweep(1), false, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let rec = RecordingReader::open(dir.path()).unwrap();
    assert_eq!(rec.rig(), sim.rig());
    let truth = flexshape_rig::Rig::load(&dir.path().join("truth/rig.toml")).unwrap();
    let true_rig = config.rig.true_rig().unwrap();
    assert_eq!(truth.cameras, true_rig.cameras);
    assert_ne!(truth.cameras, rec.rig().cameras);
    assert_eq!(truth.processing, rec.rig().processing);
    // An exact calibration writes no second rig.
    let exact = tempfile::tempdir().unwrap();
    write(exact.path(), 1);
    assert!(!exact.path().join("truth/rig.toml").exists());
}

#[test]
fn broken_recordings_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), 2);
    // A corrupt frame is reported with its path when read; the others still read.
    let bad = dir.path().join("frames/cam1/000001.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let rec = RecordingReader::open(dir.path()).unwrap();
    let err = rec.read_frame(1, 1).unwrap_err();
    assert!(
        matches!(&err, RecordingError::Image { path, .. } if *path == bad),
        "{err}"
    );
    assert!(rec.read_frame(1, 0).is_ok());
    // A frame of the wrong size.
    let small = image::RgbImage::new(320, 240);
    small
        .save(dir.path().join("frames/cam0/000001.png"))
        .unwrap();
    let err = rec.read_frame(0, 1).unwrap_err();
    assert!(
        err.to_string().contains("320×240") && err.to_string().contains("640×480"),
        "{err}"
    );
    // Cameras with different frames.
    std::fs::remove_file(dir.path().join("frames/cam2/000001.png")).unwrap();
    let err = RecordingReader::open(dir.path()).unwrap_err();
    assert!(
        err.to_string()
            .contains("frame 000001 exists for `cam0` but not for `cam2`"),
        "{err}"
    );
    // A missing camera folder.
    std::fs::remove_dir_all(dir.path().join("frames/cam2")).unwrap();
    let err = RecordingReader::open(dir.path()).unwrap_err();
    assert!(
        err.to_string()
            .contains("camera `cam2` has no frames folder"),
        "{err}"
    );
    // Not a recording at all.
    let err = RecordingReader::open(&dir.path().join("nope")).unwrap_err();
    assert!(err.to_string().contains("not a folder"), "{err}");
}

#[test]
fn stopping_early_leaves_whole_frames_only() {
    let dir = tempfile::tempdir().unwrap();
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let written = sim
        .write_recording(dir.path(), &sim.sweep(5), false, |f| {
            if f.truth.frame == 1 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    assert_eq!(written, 2);
    let rec = RecordingReader::open(dir.path()).unwrap();
    assert_eq!(rec.frames(), &[0, 1]);
    assert!(rec.read_truth(1).unwrap().is_some() && rec.read_truth(2).unwrap().is_none());
    let partial = walk(dir.path())
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".partial"))
        .count();
    assert_eq!(partial, 0);
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
