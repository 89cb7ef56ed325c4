//! One camera's intrinsics (pinhole + OpenCV's k1 k2 p1 p2 k3) and every view's board pose by
//! Levenberg–Marquardt on the reprojection error, from the closed-form start.

use flexshape_camera::{Distortion, Intrinsics};
use flexshape_lsq::{NormalEquations, Settings, global_inverse, minimize_normal};

use nalgebra::{DVector, Matrix3, Point2, Rotation3, Vector3};
use serde::Serialize;

use crate::bundle::{Observation, Problem};
use crate::{CalibError, Detection, homography, zhang};

/// Options of [`calibrate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationSettings {
    /// A view whose RMS exceeds this many times the median view's is an outlier.
    pub outlier_factor: f64,
    /// Drop outlier views and solve again (once).
    pub drop_outliers: bool,
    /// Keep k3 at zero (for lenses with little distortion, where it only fits noise).
    pub fix_k3: bool,
}

impl ViewResult {
    /// The board's pose in the camera.
    pub fn board_pose(&self) -> crate::BoardPose {
        crate::BoardPose {
            rotation: Rotation3::from_scaled_axis(Vector3::from(self.rvec)),
            translation: Vector3::from(self.tvec),
        }
    }

    /// The view with its corners labelled the other way round (see
    /// [`crate::Detection::half_turned`]): its pose after `half_turn`, its residuals reversed.
    pub fn half_turn(&mut self, half_turn: &crate::BoardPose) {
        let turned = self.board_pose().then(half_turn);
        self.rvec = turned.rotation.scaled_axis().into();
        self.tvec = turned.translation.into();
        self.residuals.reverse();
    }
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        CalibrationSettings {
            outlier_factor: 3.0,
            drop_outliers: false,
            fix_k3: false,
        }
    }
}

/// One view's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ViewResult {
    /// The view's name (e.g. its file name).
    pub name: String,
    /// Reprojection RMS over its corners, px.
    pub rms_px: f64,
    /// Board → camera rotation vector (rad) and translation (mm).
    pub rvec: [f64; 3],
    /// See `rvec`.
    pub tvec: [f64; 3],
    /// Its RMS exceeds `outlier_factor` × the median's.
    pub outlier: bool,
    /// Per corner, observed − projected, px.
    pub residuals: Vec<[f64; 2]>,
}

/// A calibrated camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The intrinsics.
    pub intrinsics: Intrinsics,
    /// Reprojection RMS over every corner of every view used, px (OpenCV's `rms`).
    pub rms_px: f64,
    /// The views used, in input order.
    pub views: Vec<ViewResult>,
    /// Views dropped as outliers.
    pub dropped: Vec<String>,
    /// Standard deviations of fx, fy, cx, cy (px) and k1, k2, p1, p2, k3.
    pub std_dev: [f64; 9],
}

/// Calibrates one camera from `views` (name and detection of the board) in images of
/// `width × height`.
pub fn calibrate(
    views: &[(String, Detection)],
    width: u32,
    height: u32,
    settings: &CalibrationSettings,
) -> Result<Calibration, CalibError> {
    let first = solve(views, width, height, settings)?;
    if !settings.drop_outliers || first.views.iter().all(|v| !v.outlier) {
        return Ok(first);
    }
    let kept: Vec<(String, Detection)> = views
        .iter()
        .zip(&first.views)
        .filter(|(_, r)| !r.outlier)
        .map(|(v, _)| v.clone())
        .collect();
    let mut again = solve(&kept, width, height, settings)?;
    again.dropped = first
        .views
        .iter()
        .filter(|v| v.outlier)
        .map(|v| v.name.clone())
        .collect();
    Ok(again)
}

fn solve(
    views: &[(String, Detection)],
    width: u32,
    height: u32,
    settings: &CalibrationSettings,
) -> Result<Calibration, CalibError> {
    if views.len() < 3 {
        return Err(CalibError::TooFewViews {
            found: views.len(),
            needed: 3,
        });
    }
    let homographies = views
        .iter()
        .map(|(name, d)| {
            let plane: Vec<Point2<f64>> = d.points.iter().map(|p| Point2::new(p.x, p.y)).collect();
            homography::fit(&plane, &d.corners)
                .ok_or_else(|| CalibError::Degenerate(format!("view {name}: no homography")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (cx, cy) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
    let (fx, fy) = zhang::focal_lengths(&homographies, cx, cy).ok_or_else(|| {
        CalibError::Degenerate(
            "the views do not determine the focal length: tilt the board in different directions"
                .into(),
        )
    })?;
    let k = Matrix3::new(fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0);
    let mut x = vec![fx, fy, cx, cy, 0.0, 0.0, 0.0, 0.0, 0.0];
    for ((name, _), h) in views.iter().zip(&homographies) {
        let (r, t) = zhang::pose(h, &k)
            .ok_or_else(|| CalibError::Degenerate(format!("view {name}: no pose")))?;
        x.extend(r.scaled_axis().iter());
        x.extend(t.iter());
    }
    let mut problem = Problem::new(
        views
            .iter()
            .enumerate()
            .map(|(board, (_, d))| Observation {
                camera: 0,
                board,
                corners: d.corners.clone(),
                points: d.points.clone(),
            })
            .collect(),
        1,
        true,
        settings.fix_k3,
        DVector::from_vec(x),
    );
    problem.x = minimize_normal(&problem, problem.x.clone(), &Settings::default())
        .ok_or_else(|| CalibError::Degenerate("the refinement started out of range".into()))?
        .x;
    let x = problem.x.clone();
    let out_of_range = || CalibError::Degenerate("the refinement left the valid range".into());
    let r = problem.residuals_at(&problem.x).ok_or_else(out_of_range)?;
    let normal = problem.normal(&problem.x).ok_or_else(out_of_range)?;
    let distortion = Distortion::from_opencv(&[x[4], x[5], x[6], x[7], x[8]])
        .map_err(|e| CalibError::Degenerate(e.to_string()))?;
    let intrinsics = Intrinsics::new(width, height, x[0], x[1], x[2], x[3], distortion)
        .map_err(|e| CalibError::Degenerate(e.to_string()))?;
    let mut results: Vec<ViewResult> = views
        .iter()
        .enumerate()
        .map(|(i, (name, _))| {
            let res: Vec<[f64; 2]> = problem
                .rows_of(i)
                .step_by(2)
                .map(|k| [r[k], r[k + 1]])
                .collect();
            let n = res.len().max(1);
            let ss: f64 = res.iter().map(|e| e[0] * e[0] + e[1] * e[1]).sum();
            let p = 9 + 6 * i;
            ViewResult {
                name: name.clone(),
                rms_px: (ss / n as f64).sqrt(),
                rvec: [x[p], x[p + 1], x[p + 2]],
                tvec: [x[p + 3], x[p + 4], x[p + 5]],
                outlier: false,
                residuals: res,
            }
        })
        .collect();
    let mut sorted: Vec<f64> = results.iter().map(|v| v.rms_px).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    for v in &mut results {
        v.outlier = v.rms_px > settings.outlier_factor * median;
    }
    let dof = (r.len() as f64 - x.len() as f64).max(1.0);
    let sigma2 = r.norm_squared() / dof;
    // Held parameters (k3 when fixed) get a unit diagonal so the others' covariance exists.
    let cov = problem
        .arrowhead()
        .and_then(|a| global_inverse(&normal.jtj, a));
    let std_dev = std::array::from_fn(|k| match &cov {
        Some(c) if !(settings.fix_k3 && k == 8) => (sigma2 * c[(k, k)]).max(0.0).sqrt(),
        _ => 0.0,
    });
    Ok(Calibration {
        intrinsics,
        rms_px: (r.norm_squared() / (r.len() / 2) as f64).sqrt(),
        views: results,
        dropped: Vec::new(),
        std_dev,
    })
}
