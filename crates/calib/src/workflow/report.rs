//! What a rig's calibration reports per camera, as `calibration.json` and `calibration.txt`.

use std::fmt::Write as _;

use serde::Serialize;

use crate::{Calibration, RelativePose};

/// One camera's calibration, as written to `calibration.json` (pixels, mm).
#[derive(Debug, Clone, Serialize)]
pub struct CameraReport {
    /// The camera's name.
    pub name: String,
    /// Reprojection RMS over its kept views, px.
    pub rms_px: f64,
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
    /// OpenCV's distortion coefficients k1, k2, p1, p2, k3.
    pub distortion_k1_k2_p1_p2_k3: Vec<f64>,
    /// Standard deviations of fx, fy, cx, cy, k1, k2, p1, p2, k3.
    pub std_dev: [f64; 9],
    /// Every view used, with its RMS.
    pub views: Vec<ViewReport>,
    /// Images without a usable board, each with the reason.
    pub rejected: Vec<String>,
    /// Outlier views left out (`drop_outliers`).
    pub dropped: Vec<String>,
    /// Pose relative to the reference camera from the shared views (absent for the
    /// reference); the written pose is the joint adjustment's.
    pub relative_to_reference: Option<RelativePose>,
    /// Reprojection RMS over this camera's views after the joint adjustment of the rig, px.
    pub joint_rms_px: Option<f64>,
}

/// One view of a camera's calibration.
#[derive(Debug, Clone, Serialize)]
pub struct ViewReport {
    /// The image's file name.
    pub image: String,
    /// Its reprojection RMS, px.
    pub rms_px: f64,
    /// Whether its RMS is far above the camera's.
    pub outlier: bool,
}

impl CameraReport {
    /// The report of camera `name`'s calibration.
    pub(super) fn new(
        name: &str,
        cal: &Calibration,
        rejected: &[String],
        relative: Option<RelativePose>,
        joint_rms_px: Option<f64>,
    ) -> Self {
        let k = &cal.intrinsics;
        CameraReport {
            name: name.to_string(),
            rms_px: cal.rms_px,
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
            distortion_k1_k2_p1_p2_k3: k.distortion.to_opencv().into_iter().take(5).collect(),
            std_dev: cal.std_dev,
            views: cal
                .views
                .iter()
                .map(|v| ViewReport {
                    image: v.name.clone(),
                    rms_px: v.rms_px,
                    outlier: v.outlier,
                })
                .collect(),
            rejected: rejected.to_vec(),
            dropped: cal.dropped.clone(),
            relative_to_reference: relative,
            joint_rms_px,
        }
    }

    /// The camera's lines of `calibration.txt`.
    pub fn summary(&self) -> String {
        let mut text = String::new();
        let r = self;
        let _ = writeln!(
            text,
            "{}: {} views, rms {:.3} px; fx {:.2} ± {:.2}, fy {:.2} ± {:.2}, cx {:.2} ± {:.2}, cy {:.2} ± {:.2}; k1..k3 {:?}",
            r.name,
            r.views.len(),
            r.rms_px,
            r.fx,
            r.std_dev[0],
            r.fy,
            r.std_dev[1],
            r.cx,
            r.std_dev[2],
            r.cy,
            r.std_dev[3],
            r.distortion_k1_k2_p1_p2_k3
                .iter()
                .map(|v| (v * 1e5).round() / 1e5)
                .collect::<Vec<_>>()
        );
        for v in r.views.iter().filter(|v| v.outlier) {
            let _ = writeln!(
                text,
                "  outlier view {} (rms {:.3} px); --drop-outliers leaves it out",
                v.image, v.rms_px
            );
        }
        for d in &r.dropped {
            let _ = writeln!(text, "  dropped outlier view {d}");
        }
        for why in &r.rejected {
            let _ = writeln!(text, "  rejected {why}");
        }
        if let Some(j) = r.joint_rms_px {
            let _ = writeln!(
                text,
                "  after the joint adjustment of the rig: rms {j:.3} px"
            );
        }
        if let Some(rel) = &r.relative_to_reference {
            let _ = writeln!(
                text,
                "  pose relative to the reference: t [{:.2}, {:.2}, {:.2}] mm from {} shared views (spread {:.3}°, {:.2} mm)",
                rel.translation[0],
                rel.translation[1],
                rel.translation[2],
                rel.shared_views,
                rel.rotation_spread_deg,
                rel.translation_spread_mm
            );
        }
        text
    }
}
