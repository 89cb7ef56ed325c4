//! One camera's intrinsics (pinhole + OpenCV's k1 k2 p1 p2 k3) and every view's board pose by
//! Levenberg–Marquardt on the reprojection error, from the closed-form start.

use flexshape_camera::{Distortion, Intrinsics};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{
    DMatrix, DVector, Dyn, Matrix3, Owned, Point2, Point3, Rotation3, Vector2, Vector3,
};
use serde::Serialize;

use crate::{Board, CalibError, Detection, homography, zhang};

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

/// Calibrates one camera from `views` (name and detection) of `board` in images of
/// `width × height`.
pub fn calibrate(
    board: &Board,
    views: &[(String, Detection)],
    width: u32,
    height: u32,
    settings: &CalibrationSettings,
) -> Result<Calibration, CalibError> {
    let first = solve(board, views, width, height, settings)?;
    if !settings.drop_outliers || first.views.iter().all(|v| !v.outlier) {
        return Ok(first);
    }
    let kept: Vec<(String, Detection)> = views
        .iter()
        .zip(&first.views)
        .filter(|(_, r)| !r.outlier)
        .map(|(v, _)| v.clone())
        .collect();
    let mut again = solve(board, &kept, width, height, settings)?;
    again.dropped = first
        .views
        .iter()
        .filter(|v| v.outlier)
        .map(|v| v.name.clone())
        .collect();
    Ok(again)
}

fn solve(
    board: &Board,
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
    let points = board.points();
    let plane: Vec<Point2<f64>> = points.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let homographies = views
        .iter()
        .map(|(name, d)| {
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
    let observed: Vec<&[Point2<f64>]> = views.iter().map(|(_, d)| d.corners.as_slice()).collect();
    let problem = Problem {
        points: &points,
        observed: &observed,
        fix_k3: settings.fix_k3,
        x: DVector::from_vec(x),
    };
    let (problem, _) = LevenbergMarquardt::new()
        .with_xtol(1e-12)
        .with_ftol(1e-14)
        .minimize(problem);
    let x = problem.x.clone();
    let r = problem
        .residuals()
        .ok_or_else(|| CalibError::Degenerate("the refinement left the valid range".into()))?;
    let j = problem
        .jacobian()
        .ok_or_else(|| CalibError::Degenerate("the refinement left the valid range".into()))?;
    let distortion = Distortion::from_opencv(&[x[4], x[5], x[6], x[7], x[8]])
        .map_err(|e| CalibError::Degenerate(e.to_string()))?;
    let intrinsics = Intrinsics::new(width, height, x[0], x[1], x[2], x[3], distortion)
        .map_err(|e| CalibError::Degenerate(e.to_string()))?;
    let n = points.len();
    let mut results: Vec<ViewResult> = views
        .iter()
        .enumerate()
        .map(|(i, (name, _))| {
            let res: Vec<[f64; 2]> = (0..n)
                .map(|c| [r[2 * (i * n + c)], r[2 * (i * n + c) + 1]])
                .collect();
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
    let cov = (j.transpose() * &j).try_inverse();
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

/// Parameters: fx fy cx cy k1 k2 p1 p2 k3, then per view a rotation vector and translation.
struct Problem<'a> {
    points: &'a [Point3<f64>],
    observed: &'a [&'a [Point2<f64>]],
    fix_k3: bool,
    x: DVector<f64>,
}

impl Problem<'_> {
    /// Observed − projected for view `i`, appended to `out`; `None` when a point falls behind
    /// the camera or a parameter is not finite.
    fn view_residuals(&self, x: &DVector<f64>, i: usize, out: &mut Vec<f64>) -> Option<()> {
        let k3 = if self.fix_k3 { 0.0 } else { x[8] };
        let d = Distortion::from_opencv(&[x[4], x[5], x[6], x[7], k3]).ok()?;
        let p = 9 + 6 * i;
        let r = Rotation3::from_scaled_axis(Vector3::new(x[p], x[p + 1], x[p + 2]));
        let t = Vector3::new(x[p + 3], x[p + 4], x[p + 5]);
        for (pt, obs) in self.points.iter().zip(self.observed[i]) {
            let c = r * pt + t;
            if c.z <= 1e-9 {
                return None;
            }
            let n = d.distort(Vector2::new(c.x / c.z, c.y / c.z));
            out.push(obs.x - (x[0] * n.x + x[2]));
            out.push(obs.y - (x[1] * n.y + x[3]));
        }
        Some(())
    }

    fn residuals_at(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        let mut out = Vec::with_capacity(2 * self.points.len() * self.observed.len());
        for i in 0..self.observed.len() {
            self.view_residuals(x, i, &mut out)?;
        }
        Some(DVector::from_vec(out))
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.residuals_at(&self.x)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        // Central differences, exploiting the structure: a view's pose moves only its own
        // residuals.
        let per_view = 2 * self.points.len();
        let views = self.observed.len();
        let mut j = DMatrix::zeros(per_view * views, self.x.len());
        let step = |v: f64| 1e-6 * v.abs().max(1e-3);
        for k in 0..9 {
            if self.fix_k3 && k == 8 {
                continue;
            }
            let h = step(self.x[k]);
            let (mut up, mut down) = (self.x.clone(), self.x.clone());
            up[k] += h;
            down[k] -= h;
            let d = (self.residuals_at(&up)? - self.residuals_at(&down)?) / (2.0 * h);
            j.set_column(k, &d);
        }
        for i in 0..views {
            for k in 9 + 6 * i..9 + 6 * (i + 1) {
                let h = step(self.x[k]);
                let (mut up, mut down) = (self.x.clone(), self.x.clone());
                up[k] += h;
                down[k] -= h;
                let (mut a, mut b) = (Vec::new(), Vec::new());
                self.view_residuals(&up, i, &mut a)?;
                self.view_residuals(&down, i, &mut b)?;
                for (row, (a, b)) in a.iter().zip(&b).enumerate() {
                    j[(i * per_view + row, k)] = (a - b) / (2.0 * h);
                }
            }
        }
        Some(j)
    }
}
