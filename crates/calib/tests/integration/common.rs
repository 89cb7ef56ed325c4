//! Shared by the calib crate's tests.

use flexshape_calib::{CalibrationSettings, Detection, calibrate};
use flexshape_camera::Camera;
use flexshape_sim::SimRigConfig;

/// The default simulated rig's cameras.
pub fn rig_cameras() -> Vec<Camera> {
    SimRigConfig::default()
        .cameras()
        .unwrap()
        .into_iter()
        .map(|(_, c)| c)
        .collect()
}

/// Calibrates `cam`'s intrinsics from `detections` (what `label` names) and checks them
/// against the truth: RMS under 0.1 px, focal lengths within 0.3 %, principal point within
/// 1.5 px.
pub fn intrinsics_recovered(label: &str, cam: &Camera, detections: &[(String, Detection)]) {
    let (w, h) = (cam.intrinsics.width, cam.intrinsics.height);
    let cal = calibrate(detections, w, h, &CalibrationSettings::default()).unwrap();
    let (t, g) = (&cam.intrinsics, &cal.intrinsics);
    println!(
        "{label}: rms {:.3} px; fx {:.2} ({:.2}), fy {:.2} ({:.2}), cx {:.2} ({:.2}), cy {:.2} ({:.2})",
        cal.rms_px, g.fx, t.fx, g.fy, t.fy, g.cx, t.cx, g.cy, t.cy
    );
    assert!(cal.rms_px < 0.1, "{label}: {}", cal.rms_px);
    assert!(
        (g.fx / t.fx - 1.0).abs() < 0.003 && (g.fy / t.fy - 1.0).abs() < 0.003,
        "{label}"
    );
    assert!(
        (g.cx - t.cx).abs() < 1.5 && (g.cy - t.cy).abs() < 1.5,
        "{label}"
    );
}
