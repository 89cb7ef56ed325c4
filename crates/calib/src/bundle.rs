//! One joint bundle adjustment of a rig: every camera's intrinsics, every camera's pose
//! relative to the first, and every board pose (one per instant, in the first camera's frame),
//! by Levenberg–Marquardt on all reprojection errors at once — so views one camera alone saw
//! still inform the others through the shared instants.

use std::collections::BTreeMap;

use flexshape_camera::{Distortion, Intrinsics};
use flexshape_lsq::{Arrowhead, Normal, NormalEquations, Settings, minimize_normal};
use nalgebra::{
    DMatrix, DVector, Matrix2, Matrix2x3, Matrix2x4, Matrix2x5, Matrix3, Point2, Point3, Rotation3,
    SMatrix, SVector, Vector2, Vector3,
};

use crate::{BoardPose, CalibError, Calibration, Detection};

/// One camera's input to the adjustment.
pub struct RigCamera<'a> {
    /// Its single-camera calibration (the start).
    pub calibration: &'a Calibration,
    /// Its detections, named by instant (the same name in every camera that saw it).
    pub views: &'a [(String, Detection)],
    /// Its pose relative to the first camera (`x_cam = R·x_cam0 + t`); the identity for the
    /// first.
    pub pose: BoardPose,
}

/// The adjusted rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigAdjustment {
    /// Per camera: intrinsics.
    pub intrinsics: Vec<Intrinsics>,
    /// Per camera: pose relative to the first.
    pub poses: Vec<BoardPose>,
    /// Per camera: reprojection RMS over its views, px.
    pub rms_px: Vec<f64>,
    /// Over everything, px.
    pub total_rms_px: f64,
}

/// What the joint adjustment does with the cameras' intrinsics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointIntrinsics {
    /// They stay as calibrated per camera, as OpenCV's `stereoCalibrate` with
    /// `CALIB_FIX_INTRINSIC` does.
    Fixed,
    /// They are refined too; with `fix_k3` every k3 stays as calibrated.
    Refined {
        /// Keep k3.
        fix_k3: bool,
    },
}

/// Adjusts the cameras' poses and every board pose jointly, and the intrinsics as
/// `intrinsics` says.
pub fn adjust_rig(
    cameras: &[RigCamera],
    intrinsics: JointIntrinsics,
) -> Result<RigAdjustment, CalibError> {
    if cameras.is_empty() {
        return Err(CalibError::TooFewViews {
            found: 0,
            needed: 1,
        });
    }
    // Board poses per instant, in cam0's frame: from the first camera (in order) that saw it.
    let mut instants: BTreeMap<&str, usize> = BTreeMap::new();
    let mut boards: Vec<BoardPose> = Vec::new();
    for cam in cameras {
        for (v, result) in cam.calibration.views.iter().enumerate() {
            let name = result.name.as_str();
            if instants.contains_key(name) || cam.views.get(v).is_none() {
                continue;
            }
            let p = result.board_pose();
            let inv = cam.pose.rotation.inverse();
            instants.insert(name, boards.len());
            boards.push(BoardPose {
                rotation: inv * p.rotation,
                translation: inv * (p.translation - cam.pose.translation),
            });
        }
    }
    let mut x = Vec::new();
    for cam in cameras {
        let k = &cam.calibration.intrinsics;
        let d = k.distortion.to_opencv();
        x.extend([
            k.fx,
            k.fy,
            k.cx,
            k.cy,
            d[0],
            d[1],
            d[2],
            d[3],
            d.get(4).copied().unwrap_or(0.0),
        ]);
    }
    for cam in &cameras[1..] {
        x.extend(cam.pose.rotation.scaled_axis().iter());
        x.extend(cam.pose.translation.iter());
    }
    for b in &boards {
        x.extend(b.rotation.scaled_axis().iter());
        x.extend(b.translation.iter());
    }
    // Observations: (camera, instant, corners), in the calibrations' view order.
    let mut observations = Vec::new();
    for (k, cam) in cameras.iter().enumerate() {
        for (name, d) in cam.views {
            if let Some(&b) = instants.get(name.as_str()) {
                observations.push(Observation {
                    camera: k,
                    board: b,
                    corners: d.corners.clone(),
                    points: d.points.clone(),
                });
            }
        }
    }
    let mut problem = Problem::new(
        observations,
        cameras.len(),
        intrinsics != JointIntrinsics::Fixed,
        intrinsics == JointIntrinsics::Refined { fix_k3: true },
        DVector::from_vec(x),
    );
    let settings = Settings {
        xtol: 1e-10,
        ftol: 1e-12,
        ..Settings::default()
    };
    problem.x = minimize_normal(&problem, problem.x.clone(), &settings)
        .ok_or_else(|| CalibError::Degenerate("the rig adjustment started out of range".into()))?
        .x;
    let r = problem
        .residuals_at(&problem.x)
        .ok_or_else(|| CalibError::Degenerate("the rig adjustment left the valid range".into()))?;
    let x = &problem.x;
    let mut intrinsics = Vec::new();
    for (k, cam) in cameras.iter().enumerate() {
        let p = &x.as_slice()[9 * k..9 * k + 9];
        let distortion =
            Distortion::from_opencv(&p[4..9]).map_err(|e| CalibError::Degenerate(e.to_string()))?;
        let old = &cam.calibration.intrinsics;
        intrinsics.push(
            Intrinsics::new(old.width, old.height, p[0], p[1], p[2], p[3], distortion)
                .map_err(|e| CalibError::Degenerate(e.to_string()))?,
        );
    }
    let poses = (0..cameras.len())
        .map(|k| problem.camera_pose(x, k))
        .collect();
    let mut sums = vec![(0.0, 0usize); cameras.len()];
    for (i, o) in problem.observations.iter().enumerate() {
        sums[o.camera].0 += problem.rows_of(i).map(|k| r[k] * r[k]).sum::<f64>();
        sums[o.camera].1 += o.points.len();
    }
    Ok(RigAdjustment {
        intrinsics,
        poses,
        rms_px: sums
            .iter()
            .map(|(s, n)| (s / (*n).max(1) as f64).sqrt())
            .collect(),
        total_rms_px: (r.norm_squared() / (r.len() / 2).max(1) as f64).sqrt(),
    })
}

/// One camera's view of one board: its detected corners.
pub(crate) struct Observation {
    /// The camera.
    pub camera: usize,
    /// The board pose (instant).
    pub board: usize,
    /// Pixels.
    pub corners: Vec<Point2<f64>>,
    /// Where each corner lies on the board, board frame, mm.
    pub points: Vec<Point3<f64>>,
}

/// Reprojection of boards into cameras. Parameters: 9 intrinsics per camera (fx fy cx cy k1
/// k2 p1 p2 k3), 6 per camera after the first (rotation vector, translation relative to the
/// first), 6 per board (its pose in the first camera). One camera is the single-camera
/// calibration ([`crate::calibrate`]).
pub(crate) struct Problem {
    /// What was seen.
    pub observations: Vec<Observation>,
    /// Each observation's first residual row; the last entry is the rows in all.
    offsets: Vec<usize>,
    /// Cameras.
    pub cameras: usize,
    /// Refine the intrinsics (else they stay at their start).
    pub free_intrinsics: bool,
    /// Keep every k3 at its start.
    pub fix_k3: bool,
    /// The parameters.
    pub x: DVector<f64>,
}

impl Problem {
    /// The problem of `observations` seen by `cameras` cameras from the start `x`.
    pub fn new(
        observations: Vec<Observation>,
        cameras: usize,
        free_intrinsics: bool,
        fix_k3: bool,
        x: DVector<f64>,
    ) -> Self {
        let mut offsets = vec![0];
        for o in &observations {
            offsets.push(offsets[offsets.len() - 1] + 2 * o.points.len());
        }
        Problem {
            observations,
            offsets,
            cameras,
            free_intrinsics,
            fix_k3,
            x,
        }
    }

    /// The residual rows of observation `i` (x then y of each corner).
    pub fn rows_of(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    fn pose_at(x: &DVector<f64>, at: usize) -> BoardPose {
        BoardPose {
            rotation: Rotation3::from_scaled_axis(Vector3::new(x[at], x[at + 1], x[at + 2])),
            translation: Vector3::new(x[at + 3], x[at + 4], x[at + 5]),
        }
    }

    fn camera_pose(&self, x: &DVector<f64>, k: usize) -> BoardPose {
        if k == 0 {
            BoardPose {
                rotation: Rotation3::identity(),
                translation: Vector3::zeros(),
            }
        } else {
            Self::pose_at(x, 9 * self.cameras + 6 * (k - 1))
        }
    }

    fn board_at(&self, b: usize) -> usize {
        9 * self.cameras + 6 * (self.cameras - 1) + 6 * b
    }

    fn block(&self, x: &DVector<f64>, o: &Observation, out: &mut [f64]) -> Option<()> {
        let p = &x.as_slice()[9 * o.camera..9 * o.camera + 9];
        let d = Distortion::from_opencv(&p[4..9]).ok()?;
        let cam = self.camera_pose(x, o.camera);
        let board = Self::pose_at(x, self.board_at(o.board));
        let r = cam.rotation * board.rotation;
        let t = cam.rotation * board.translation + cam.translation;
        for (j, (pt, obs)) in o.points.iter().zip(&o.corners).enumerate() {
            let c = r * pt + t;
            if c.z <= 1e-9 {
                return None;
            }
            let n = d.distort(Vector2::new(c.x / c.z, c.y / c.z));
            out[2 * j] = obs.x - (p[0] * n.x + p[2]);
            out[2 * j + 1] = obs.y - (p[1] * n.y + p[3]);
        }
        Some(())
    }

    /// The residuals (observed − projected, px; x then y of each corner) at `x`.
    pub fn residuals_at(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        let mut r = DVector::zeros(self.offsets[self.offsets.len() - 1]);
        for (i, o) in self.observations.iter().enumerate() {
            self.block(x, o, &mut r.as_mut_slice()[self.rows_of(i)])?;
        }
        Some(r)
    }
}

impl NormalEquations for Problem {
    fn cost(&self, x: &DVector<f64>) -> Option<f64> {
        Some(0.5 * self.residuals_at(x)?.norm_squared())
    }

    fn normal(&self, x: &DVector<f64>) -> Option<Normal> {
        let n = x.len();
        let mut normal = Normal {
            jtj: DMatrix::zeros(n, n),
            jtr: DVector::zeros(n),
            cost: 0.0,
        };
        for o in &self.observations {
            self.accumulate(x, o, &mut normal)?;
        }
        Some(normal)
    }

    fn arrowhead(&self) -> Option<Arrowhead> {
        Some(Arrowhead {
            global: self.board_at(0),
            block: 6,
        })
    }
}

/// Columns of one observation's Jacobian: its camera's 9 intrinsics, its camera's pose (6),
/// its board's pose (6).
const LOCAL: usize = 21;

impl Problem {
    /// Adds observation `o`'s residuals to the normal equations, with their analytic
    /// Jacobian (rotations by their exact derivative in the rotation vector).
    fn accumulate(&self, x: &DVector<f64>, o: &Observation, normal: &mut Normal) -> Option<()> {
        let p = &x.as_slice()[9 * o.camera..9 * o.camera + 9];
        let d = Distortion::from_opencv(&p[4..9]).ok()?;
        let (fx, fy) = (p[0], p[1]);
        let cam_at = 9 * self.cameras + 6 * o.camera.saturating_sub(1);
        let board_at = self.board_at(o.board);
        let cam = self.camera_pose(x, o.camera);
        let board = Self::pose_at(x, board_at);
        let cam_jl = left_jacobian(cam.rotation.scaled_axis());
        let board_jl = left_jacobian(board.rotation.scaled_axis());
        let mut jtj = SMatrix::<f64, LOCAL, LOCAL>::zeros();
        let mut jtr = SVector::<f64, LOCAL>::zeros();
        for (pt, obs) in o.points.iter().zip(&o.corners) {
            let q = board.rotation * pt.coords + board.translation;
            let c = cam.rotation * q + cam.translation;
            if c.z <= 1e-9 {
                return None;
            }
            let u = Vector2::new(c.x / c.z, c.y / c.z);
            let (n, jd) = d.distort_with_jacobian(u);
            let r = Vector2::new(obs.x - (fx * n.x + p[2]), obs.y - (fy * n.y + p[3]));
            // ∂r/∂c = −diag(fx, fy)·∂n/∂u·∂u/∂c.
            let du = Matrix2x3::new(1.0 / c.z, 0.0, -u.x / c.z, 0.0, 1.0 / c.z, -u.y / c.z);
            let dr_dc = -(Matrix2::new(fx, 0.0, 0.0, fy) * jd * du);
            let mut j = SMatrix::<f64, 2, LOCAL>::zeros();
            if self.free_intrinsics {
                let (x2, y2) = (u.x * u.x, u.y * u.y);
                let r2 = x2 + y2;
                let xy = 2.0 * u.x * u.y;
                // ∂n/∂(k1, k2, p1, p2, k3) of the plumb-bob model.
                let dn = Matrix2x5::new(
                    u.x * r2,
                    u.x * r2 * r2,
                    xy,
                    r2 + 2.0 * x2,
                    u.x * r2 * r2 * r2,
                    u.y * r2,
                    u.y * r2 * r2,
                    r2 + 2.0 * y2,
                    xy,
                    u.y * r2 * r2 * r2,
                );
                j.fixed_view_mut::<2, 4>(0, 0)
                    .copy_from(&-Matrix2x4::new(n.x, 0.0, 1.0, 0.0, 0.0, n.y, 0.0, 1.0));
                j.fixed_view_mut::<2, 5>(0, 4)
                    .copy_from(&-(Matrix2::new(fx, 0.0, 0.0, fy) * dn));
                if self.fix_k3 {
                    j.fixed_view_mut::<2, 1>(0, 8).fill(0.0);
                }
            }
            if o.camera > 0 {
                let rq = cam.rotation * q;
                j.fixed_view_mut::<2, 3>(0, 9)
                    .copy_from(&(dr_dc * -(rq.cross_matrix() * cam_jl)));
                j.fixed_view_mut::<2, 3>(0, 12).copy_from(&dr_dc);
            }
            let dr_dq = dr_dc * cam.rotation.matrix();
            let rp = board.rotation * pt.coords;
            j.fixed_view_mut::<2, 3>(0, 15)
                .copy_from(&(dr_dq * -(rp.cross_matrix() * board_jl)));
            j.fixed_view_mut::<2, 3>(0, 18).copy_from(&dr_dq);
            jtj += j.transpose() * j;
            jtr += j.transpose() * r;
            normal.cost += 0.5 * r.norm_squared();
        }
        let column = |k: usize| match k {
            0..9 => 9 * o.camera + k,
            9..15 => cam_at + k - 9,
            _ => board_at + k - 15,
        };
        let used: Vec<usize> = (0..LOCAL)
            .filter(|&k| (o.camera > 0 || !(9..15).contains(&k)) && jtj[(k, k)] != 0.0)
            .collect();
        for &a in &used {
            normal.jtr[column(a)] += jtr[a];
            for &b in &used {
                normal.jtj[(column(a), column(b))] += jtj[(a, b)];
            }
        }
        Some(())
    }
}

/// The left Jacobian of SO(3) at rotation vector `w`: d(exp(w + δ)) = exp(J·δ)·exp(w), so
/// ∂(exp(w)·q)/∂w = −[exp(w)·q]×·J.
fn left_jacobian(w: Vector3<f64>) -> Matrix3<f64> {
    let theta2 = w.norm_squared();
    let k = w.cross_matrix();
    let (a, b) = if theta2 < 1e-8 {
        (0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0)
    } else {
        let theta = theta2.sqrt();
        (
            (1.0 - theta.cos()) / theta2,
            (theta - theta.sin()) / (theta2 * theta),
        )
    };
    Matrix3::identity() + k * a + k * k * b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two cameras, two boards, distortion everywhere: the analytic normal equations must be
    /// those of the residuals' central differences.
    #[test]
    fn the_analytic_normal_equations_match_finite_differences() {
        let points: Vec<Point3<f64>> = (0..12)
            .map(|i| Point3::new(30.0 * (i % 4) as f64, 30.0 * (i / 4) as f64, 0.0))
            .collect();
        let observation = |camera, board, shift: f64| Observation {
            camera,
            board,
            corners: (0..12)
                .map(|i| {
                    Point2::new(
                        300.0 + 40.0 * (i % 4) as f64 + shift,
                        200.0 + 35.0 * (i / 4) as f64,
                    )
                })
                .collect(),
            points: points.clone(),
        };
        let x = DVector::from_vec(vec![
            800.0, 790.0, 320.0, 240.0, -0.2, 0.08, 0.001, -0.002, 0.01, // camera 0
            700.0, 705.0, 330.0, 250.0, 0.1, -0.05, -0.001, 0.003, -0.02, // camera 1
            0.1, -0.4, 0.05, -300.0, 10.0, 80.0, // camera 1's pose
            0.2, 0.1, -0.3, -40.0, -30.0, 600.0, // board 0
            -0.3, 0.25, 1.2, 10.0, -20.0, 550.0, // board 1
        ]);
        for (free_intrinsics, fix_k3) in [(true, false), (true, true), (false, false)] {
            let problem = Problem::new(
                vec![
                    observation(0, 0, 0.0),
                    observation(1, 0, 3.0),
                    observation(0, 1, -2.0),
                    observation(1, 1, 1.0),
                ],
                2,
                free_intrinsics,
                fix_k3,
                x.clone(),
            );
            let normal = problem.normal(&x).unwrap();
            let r = problem.residuals_at(&x).unwrap();
            let mut j = flexshape_lsq::central_differences(
                &x,
                |_, v| 1e-6 * v.abs().max(1e-3),
                |x| problem.residuals_at(x),
            )
            .unwrap();
            for col in 0..x.len() {
                let held = (!free_intrinsics && col < 18) || (fix_k3 && col < 18 && col % 9 == 8);
                if held {
                    j.column_mut(col).fill(0.0);
                }
            }
            let jtj = j.transpose() * &j;
            let jtr = j.transpose() * &r;
            assert!((normal.cost - 0.5 * r.norm_squared()).abs() < 1e-9 * normal.cost);
            let scale = jtj.amax();
            assert!((normal.jtj - &jtj).amax() < 1e-6 * scale, "JᵀJ differs");
            assert!(
                (normal.jtr - &jtr).amax() < 1e-6 * jtr.amax(),
                "Jᵀr differs"
            );
        }
    }
}
