//! `flexshape rig refine`: a rig whose camera is turned a few pixels makes every frame
//! `inconsistent`; the refined rig it writes makes them `ok` again.

use crate::common;

use common::{fails, run};
use flexshape_camera::nalgebra::{Rotation3, Vector3};
use flexshape_rig::Rig;
use serde_json::Value;

/// The statuses `track` gives the recording `rec` with the rig `rig`.
fn statuses(rec: &str, rig: &str) -> Vec<String> {
    let out = run(&["track", rec, "--rig", rig]);
    out.lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|v| v.get("frame").is_some())
        .map(|v| v["status"].as_str().unwrap_or_default().to_string())
        .collect()
}

#[test]
fn a_turned_camera_is_found_and_its_frames_are_ok_again() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let r = rec.to_str().unwrap();
    run(&["simulate", "--out", r, "--frames", "8"]);
    // cam1 turned by 0.17° about its own centre (2.4 px at the image centre): the scale stays.
    let mut rig = Rig::load(&rec.join("rig.toml")).unwrap();
    let turn = Rotation3::from_scaled_axis(Vector3::new(0.002, -0.0015, 0.001));
    let cam = &mut rig.cameras[1].camera;
    cam.pose.rotation = turn * cam.pose.rotation;
    cam.pose.translation = turn * cam.pose.translation;
    let bad = dir.path().join("bad/rig.toml");
    rig.save(&bad).unwrap();
    let b = bad.to_str().unwrap();
    let before = statuses(r, b);
    assert!(
        before.iter().all(|s| s == "inconsistent"),
        "the turned camera shows: {before:?}"
    );

    let out = dir.path().join("refined");
    let o = out.to_str().unwrap();
    let printed = run(&["rig", "refine", r, "--rig", b, "-o", o]);
    assert!(
        printed.contains("better") && printed.contains("cam1"),
        "{printed}"
    );
    assert!(out.join("calibration/cam1.yml").is_file());
    let refined = out.join("rig.toml");
    let refined_rig = Rig::load(&refined).unwrap();
    assert_eq!(
        refined_rig.cameras[0].camera, rig.cameras[0].camera,
        "cam0 held"
    );
    assert_eq!(refined_rig.volume, rig.volume);
    let after = statuses(r, refined.to_str().unwrap());
    assert_eq!(after.len(), 8);
    assert!(after.iter().all(|s| s == "ok"), "{after:?}");

    // Nothing is replaced unasked, and nothing is written into the inputs.
    let again = fails(&["rig", "refine", r, "--rig", b, "-o", o]);
    assert!(again.contains("--overwrite"), "{again}");
    let inside = fails(&["rig", "refine", r, "-o", r, "--overwrite"]);
    assert!(inside.contains("inside the input folder"), "{inside}");
    let calibration = rec.join("calibration");
    let inside = fails(&["rig", "refine", r, "-o", calibration.to_str().unwrap()]);
    assert!(inside.contains("inside the input folder"), "{inside}");
    let hold = fails(&["rig", "refine", r, "--hold", "cam9", "-o", o, "--overwrite"]);
    assert!(hold.contains("cam0, cam1, cam2"), "{hold}");
}
