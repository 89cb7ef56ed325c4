//! One joint bundle adjustment of a rig: every camera's intrinsics, every camera's pose
//! relative to the first, and every board pose (one per instant, in the first camera's frame),
//! by Levenberg–Marquardt on all reprojection errors at once — so views one camera alone saw
//! still inform the others through the shared instants.

use std::collections::BTreeMap;

use flexshape_camera::{Distortion, Intrinsics};
use flexshape_lsq::{LevenbergMarquardt, Residuals, minimize};
use nalgebra::{DMatrix, DVector, Point2, Point3, Rotation3, Vector2, Vector3};

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
    let solver = LevenbergMarquardt::new().with_xtol(1e-10).with_ftol(1e-12);
    problem.x = minimize(&problem, problem.x.clone(), solver).x;
    let r = problem
        .residuals(&problem.x)
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

    fn residuals_at(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        let mut r = DVector::zeros(self.offsets[self.offsets.len() - 1]);
        for (i, o) in self.observations.iter().enumerate() {
            self.block(x, o, &mut r.as_mut_slice()[self.rows_of(i)])?;
        }
        Some(r)
    }
}

impl Residuals for Problem {
    fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        self.residuals_at(x)
    }

    fn jacobian(&self, x: &DVector<f64>) -> Option<DMatrix<f64>> {
        // Central differences, block by block: a parameter moves only the observations of its
        // camera or its board.
        let rows = self.offsets[self.offsets.len() - 1];
        let mut j = DMatrix::zeros(rows, x.len());
        let most = self
            .observations
            .iter()
            .map(|o| 2 * o.points.len())
            .max()
            .unwrap_or(0);
        let (mut up_block, mut down_block) = (vec![0.0; most], vec![0.0; most]);
        let first = if self.free_intrinsics {
            0
        } else {
            9 * self.cameras
        };
        for col in first..x.len() {
            if self.fix_k3 && col < 9 * self.cameras && col % 9 == 8 {
                continue;
            }
            let touches = |o: &Observation| -> bool {
                if col < 9 * self.cameras {
                    o.camera == col / 9
                } else if col < self.board_at(0) {
                    o.camera == 1 + (col - 9 * self.cameras) / 6
                } else {
                    o.board == (col - self.board_at(0)) / 6
                }
            };
            let h = 1e-6 * x[col].abs().max(1e-3);
            let (mut up, mut down) = (x.clone(), x.clone());
            up[col] += h;
            down[col] -= h;
            for (i, o) in self.observations.iter().enumerate() {
                if !touches(o) {
                    continue;
                }
                let per = 2 * o.points.len();
                self.block(&up, o, &mut up_block[..per])?;
                self.block(&down, o, &mut down_block[..per])?;
                let first = self.offsets[i];
                for row in 0..per {
                    j[(first + row, col)] = (up_block[row] - down_block[row]) / (2.0 * h);
                }
            }
        }
        Some(j)
    }
}
