//! Camera poses and tubes fitted together over many frames (`flexshape rig refine`).
//!
//! Each frame's tube is fitted as [`TubeFitter::fit`] does; every outline residual also
//! depends on its camera's pose ([`crate::pose`]). The joint normal equations have one block
//! per frame's tube, coupled only through the poses, so each Gauss–Newton step eliminates the
//! tubes (Schur complement: `S = A − Σ Bᵀ D⁻¹ B`), solves for the poses, and back-substitutes
//! each tube's step. Fitting poses and tubes in turn instead crawls: each tube absorbs part of
//! a camera's error, and along the directions the images pin down weakly it had not arrived
//! after 40 rounds.
//!
//! Gauge: the cameras not free are held (the world frame stays attached to them). With one
//! held, the rig's scale — the other cameras' summed distance from it — is kept too: the
//! images show it only through the tube's width of a few pixels, while the calibration target
//! fixed it well.
//!
//! Prior: every free camera's pose is drawn toward where the calibration put it, a move of
//! `prior_px` at the tube counting as much as a boundary `sigma_px` off. Along the directions
//! the outlines pin down (thousands of boundaries) that weighs nothing; along those they
//! hardly see (a camera sliding along its line of sight, two cameras' baseline turning about
//! the tube) it holds the pose where it was, instead of letting it drift wherever the noise
//! leads — moving the world frame the lab registered its robot in.

use flexshape_camera::Camera;
use nalgebra::{DMatrix, DVector, Point3, Vector6};
use rayon::prelude::*;

use crate::pose::{moved, pose_row};
use crate::solve::{Measured, Seen, against, for_each_row, measure, normal_equations};
use crate::{FitError, Tube, TubeFitter, View};

/// Cameras and tubes fitted together.
#[derive(Debug, Clone)]
pub struct Bundle {
    /// The cameras with their refined poses, in the rig's order (intrinsics unchanged; the
    /// held camera as it was).
    pub cameras: Vec<Camera>,
    /// Each frame's tube.
    pub tubes: Vec<Tube>,
    /// Gauss–Newton steps run.
    pub steps: usize,
    /// Boundary measurements made.
    pub measurements: usize,
    /// Per camera (rig order), how well the images pin its pose down: the 1-σ move along the
    /// least determined combination of its six pose parameters, its turn counted as the move
    /// it makes at the tube, mm (0 for a held camera). From the joint normal equations, the
    /// prior and the outline residuals' scatter; the scale held.
    pub sigma_mm: Vec<f64>,
    /// Per camera (rig order), how many of its pose's six directions (eigenvectors of its
    /// block of the outlines' normal equations, the other cameras as they are) the outlines
    /// pin down less well than the prior does: those stay where the calibration put them
    /// (0 for a held camera).
    pub held_directions: Vec<usize>,
    /// RMS of the outline residuals over every frame and camera at the end, pixels (each
    /// boundary weighted as the fit weighs it).
    pub rms_px: f64,
}

/// How far the calibration may have put a pose from the truth, and what a boundary's place
/// scatters by: together they weigh the pose's prior against the outlines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PosePrior<'a> {
    /// The poses the calibration gave, rig order (also the scale kept with one camera held).
    pub poses: &'a [Camera],
    /// A pose's 1-σ error at the tube, pixels of its own image (each of its six directions,
    /// a turn counted as the move it makes at the tube).
    pub prior_px: f64,
    /// One boundary's scatter, pixels.
    pub sigma_px: f64,
}

/// Boundary measurements at most.
const MEASUREMENTS: usize = 8;

/// Gauss–Newton steps on one measurement's boundaries at most.
const INNER_STEPS: usize = 6;

/// A step moving no camera (at the tube) and no tube by more than this ends the steps on one
/// measurement's boundaries, mm.
const CONVERGED_MM: f64 = 0.002;

/// A first step on fresh boundaries below this ends the fit, mm (as in the fit:
/// the boundaries are read where the outline was predicted, so they move a little each time).
const SETTLED_MM: f64 = 0.01;

/// Damping of the poses' reduced system, relative to its diagonal.
const DAMPING: f64 = 1e-4;

/// One frame's share of a joint step.
struct FrameSystem {
    /// `D⁻¹ g` and `D⁻¹ B` of its tube's block.
    dinv_g: DVector<f64>,
    dinv_b: DMatrix<f64>,
    /// Its contribution to the reduced system: `A − Bᵀ D⁻¹ B` and `g_p − Bᵀ D⁻¹ g`.
    s: DMatrix<f64>,
    rhs: DVector<f64>,
    /// Weighted squared residuals, rows and tube parameters of its image rows.
    cost: f64,
    rows: usize,
    params: usize,
}

impl TubeFitter {
    /// Fits the `free` cameras' poses (rig order; the others held, at least one) and every
    /// frame's tube together, from the fitter's poses, each free pose drawn toward the
    /// calibrated one by `prior`: `frames` holds each frame's views, `tubes` each frame's tube
    /// fitted with the rig's poses (the start). The radius is fitted per frame if
    /// `fit_radius`. With no camera free, the tubes alone are fitted.
    pub fn bundle(
        &self,
        frames: &[Vec<View<'_>>],
        tubes: &[Tube],
        free: &[usize],
        prior: PosePrior<'_>,
        fit_radius: bool,
    ) -> Result<Bundle, FitError> {
        let n = self.cameras.len();
        let held: Vec<usize> = (0..n).filter(|c| !free.contains(c)).collect();
        if frames.len() != tubes.len() || held.is_empty() || free.iter().any(|&c| c >= n) {
            return Err(FitError::Input {
                camera: free.iter().copied().find(|&c| c >= n).unwrap_or(0),
                problem: format!(
                    "{} frames with {} tubes, cameras {free:?} free of {n}",
                    frames.len(),
                    tubes.len(),
                ),
            });
        }
        let hold = held[0];
        if prior.poses.len() != n {
            return Err(FitError::Input {
                camera: 0,
                problem: format!("{} calibrated poses for {n} cameras", prior.poses.len()),
            });
        }
        let images = frames
            .iter()
            .map(|v| self.edge_images(v))
            .collect::<Result<Vec<_>, _>>()?;
        let s = &self.settings;
        // Free widths say nothing of the radius (see `width`).
        let fit_radius = fit_radius && !s.free_width();
        let depths: Vec<f64> = self
            .cameras
            .iter()
            .map(|cam| mean_depth(cam, tubes))
            .collect();
        let rig = prior.poses;
        let mut cameras = self.cameras.clone();
        let mut tubes = tubes.to_vec();
        let starts = tubes.clone();
        let (mut steps, mut measurements) = (0, 0);
        // The prior's weight per free camera (pixels² per mm²): a move of `prior_px` of its
        // image at the tube counts as a boundary `sigma_px` off.
        let stiffness: Vec<f64> = free
            .iter()
            .map(|&c| {
                let prior_mm = prior.prior_px * depths[c] / self.cameras[c].intrinsics.fx;
                (prior.sigma_px / prior_mm.max(1e-9)).powi(2)
            })
            .collect();
        // The last reduced system, its outlines' part, and the residuals' variance, for the
        // poses' uncertainty; the last cost and rows.
        let mut last: Option<(DMatrix<f64>, DMatrix<f64>, f64)> = None;
        let mut fitted = (0.0, 0usize);
        'outer: for _ in 0..MEASUREMENTS {
            let measured: Vec<Vec<Vec<Measured>>> = tubes
                .par_iter()
                .zip(&images)
                .map(|(tube, img)| measure(&cameras, img, Seen::All(tube), s))
                .collect();
            measurements += 1;
            let mut current = measured.clone();
            for inner in 0..INNER_STEPS {
                let systems: Vec<Option<FrameSystem>> = tubes
                    .par_iter()
                    .zip(&starts)
                    .zip(&current)
                    .map(|((tube, start), m)| {
                        self.frame_system(&cameras, free, &depths, tube, start, m, fit_radius)
                    })
                    .collect();
                let np = 6 * free.len();
                let mut s_total = DMatrix::<f64>::zeros(np, np);
                let mut rhs = DVector::<f64>::zeros(np);
                for sys in systems.iter().flatten() {
                    s_total += &sys.s;
                    rhs += &sys.rhs;
                }
                let outlines = s_total.clone();
                for (i, &c) in free.iter().enumerate() {
                    let off = offset(&rig[c], &cameras[c], depths[c]);
                    for k in 0..6 {
                        s_total[(6 * i + k, 6 * i + k)] += stiffness[i];
                        rhs[6 * i + k] += stiffness[i] * off[k];
                    }
                }
                for k in 0..np {
                    s_total[(k, k)] += DAMPING * s_total[(k, k)].max(1e-9);
                }
                if held.len() == 1 {
                    hold_scale(&mut s_total, &mut rhs, &cameras, rig, free, hold);
                }
                let (cost, rows, dof) =
                    systems
                        .iter()
                        .flatten()
                        .fold((0.0, 0, 0.0), |(c, r, d), sys| {
                            (
                                c + sys.cost,
                                r + sys.rows,
                                d + sys.rows as f64 - sys.params as f64,
                            )
                        });
                fitted = (cost, rows);
                last = Some((s_total.clone(), outlines, cost / (dof - np as f64).max(1.0)));
                let Some(chol) = s_total.cholesky() else {
                    break 'outer;
                };
                let mut dp = -chol.solve(&rhs);
                let mut dts: Vec<DVector<f64>> = systems
                    .iter()
                    .map(|sys| match sys {
                        Some(sys) => -(&sys.dinv_g + &sys.dinv_b * &dp),
                        None => DVector::zeros(0),
                    })
                    .collect();
                // Hold each step within a millimetre, as the fit does: the boundaries were only
                // searched a few pixels away.
                let largest = dts.iter().map(|d| d.amax()).fold(dp.amax(), f64::max);
                if largest > 1.0 {
                    dp /= largest;
                    for d in &mut dts {
                        *d /= largest;
                    }
                }
                for (i, &c) in free.iter().enumerate() {
                    let step = Vector6::from_iterator(dp.rows(6 * i, 6).iter().copied());
                    cameras[c].pose = moved(&cameras[c].pose, &step, depths[c]);
                }
                if held.len() == 1 {
                    keep_scale(&mut cameras, rig, hold);
                }
                let mut across = dp.amax();
                for (tube, dt) in tubes.iter_mut().zip(&dts) {
                    if dt.is_empty() {
                        continue;
                    }
                    tube.apply(dt);
                    across = across.max(crate::across_tube(tube, dt));
                }
                steps += 1;
                if inner == 0 && across < SETTLED_MM {
                    break 'outer;
                }
                if across < CONVERGED_MM {
                    break;
                }
                current = tubes
                    .par_iter()
                    .zip(&measured)
                    .map(|(tube, m)| against(&cameras, Seen::All(tube), m, false, s.free_width()))
                    .collect();
            }
        }
        let mut sigma_mm = vec![0.0; n];
        let mut held_directions = vec![0; n];
        if let Some((s, outlines, var)) = last {
            if let Some(cov) = s.try_inverse().map(|i| i * var) {
                for (i, &c) in free.iter().enumerate() {
                    let block = cov.view((6 * i, 6 * i), (6, 6)).into_owned();
                    let largest = block.symmetric_eigenvalues().amax();
                    sigma_mm[c] = largest.max(0.0).sqrt();
                }
            }
            for (i, &c) in free.iter().enumerate() {
                let block = outlines.view((6 * i, 6 * i), (6, 6)).into_owned();
                held_directions[c] = block
                    .symmetric_eigenvalues()
                    .iter()
                    .filter(|&&e| e < stiffness[i])
                    .count();
            }
        }
        let rms_px = (fitted.0 / (fitted.1 as f64).max(1.0)).sqrt();
        Ok(Bundle {
            cameras,
            tubes,
            steps,
            measurements,
            sigma_mm,
            held_directions,
            rms_px,
        })
    }

    /// One frame's tube block of the joint normal equations, reduced onto the poses of the
    /// `free` cameras; `None` when its block cannot be solved.
    #[allow(clippy::too_many_arguments)]
    fn frame_system(
        &self,
        cameras: &[Camera],
        free: &[usize],
        depths: &[f64],
        tube: &Tube,
        start: &Tube,
        measured: &[Vec<Measured>],
        fit_radius: bool,
    ) -> Option<FrameSystem> {
        let eq = normal_equations(tube, start, measured, &self.settings, fit_radius);
        let n = tube.parameters();
        let np = 6 * free.len();
        let mut b = DMatrix::<f64>::zeros(n, np);
        let mut a = DMatrix::<f64>::zeros(np, np);
        let mut gp = DVector::<f64>::zeros(np);
        for_each_row(tube, measured, &self.settings, fit_radius, |row| {
            let Some(slot) = free.iter().position(|&c| c == row.camera) else {
                return;
            };
            let Some((_, normal)) = row.measured.edge else {
                return;
            };
            let world: Point3<f64> = row.measured.point.world;
            let Some(p) = pose_row(&cameras[row.camera], &world, &normal, depths[row.camera])
            else {
                return;
            };
            let o = 6 * slot;
            for i in 0..6 {
                gp[o + i] += row.w * p[i] * row.r;
                for j in 0..6 {
                    a[(o + i, o + j)] += row.w * p[i] * p[j];
                }
                for &(col, v) in row.entries {
                    b[(col, o + i)] += row.w * v * p[i];
                }
            }
        });
        let chol = eq.h.cholesky()?;
        let dinv_g = chol.solve(&eq.g);
        let dinv_b = chol.solve(&b);
        let bt = b.transpose();
        Some(FrameSystem {
            cost: eq.cost,
            rows: eq.rows,
            params: n,
            s: a - &bt * &dinv_b,
            rhs: gp - &bt * &dinv_g,
            dinv_g,
            dinv_b,
        })
    }
}

/// The pose step (as [`moved`] takes it: turn scaled by `depth` mm, then translation mm,
/// camera frame) that takes `from` to `to`, to first order for the translation's part.
fn offset(from: &Camera, to: &Camera, depth: f64) -> Vector6<f64> {
    let turn = to.pose.rotation * from.pose.rotation.inverse();
    let omega = turn.scaled_axis();
    let tau = to.pose.translation - turn * from.pose.translation;
    Vector6::new(
        omega[0] * depth,
        omega[1] * depth,
        omega[2] * depth,
        tau[0],
        tau[1],
        tau[2],
    )
}

/// Mean depth of the tubes' centerline points in `camera`, mm (600 when it sees none).
fn mean_depth(camera: &Camera, tubes: &[Tube]) -> f64 {
    let depths: Vec<f64> = tubes
        .iter()
        .flat_map(|t| (0..=8).map(move |i| t.frame(i as f64 / 8.0).0))
        .map(|p| camera.pose.to_camera(&p).z)
        .filter(|z| z.is_finite() && *z > 0.0)
        .collect();
    if depths.is_empty() {
        600.0
    } else {
        depths.iter().sum::<f64>() / depths.len() as f64
    }
}

/// Adds the rig's scale to the poses' reduced system as a stiff constraint: the free cameras'
/// summed distance from the held one stays the rig's. Without it each step would move the
/// cameras along the scale (which the images hardly see), only for [`keep_scale`] to undo it.
fn hold_scale(
    s: &mut DMatrix<f64>,
    rhs: &mut DVector<f64>,
    cameras: &[Camera],
    rig: &[Camera],
    free: &[usize],
    hold: usize,
) {
    let centre = rig[hold].centre();
    let spread = |cams: &[Camera]| -> f64 {
        free.iter()
            .map(|&c| (cams[c].centre() - centre).norm())
            .sum()
    };
    // The centre moves by −R'ᵀτ under a step (the rotation leaves it in place).
    let mut c = DVector::<f64>::zeros(s.nrows());
    for (i, &cam) in free.iter().enumerate() {
        let d = cameras[cam].centre() - centre;
        let Some(u) = d.try_normalize(1e-9) else {
            continue;
        };
        let row = -(cameras[cam].pose.rotation * u);
        for k in 0..3 {
            c[6 * i + 3 + k] = row[k];
        }
    }
    let stiff = 1e3 * s.diagonal().amax().max(1e-9);
    *s += &c * c.transpose() * stiff;
    *rhs += &c * (stiff * (spread(cameras) - spread(rig)));
}

/// Scales the camera centres about the held one's so that their summed distance from it is
/// the rig's (`rig`).
fn keep_scale(cameras: &mut [Camera], rig: &[Camera], hold: usize) {
    let centre = rig[hold].centre();
    let spread = |cams: &[Camera]| -> f64 {
        cams.iter()
            .enumerate()
            .filter(|(i, _)| *i != hold)
            .map(|(_, c)| (c.centre() - centre).norm())
            .sum()
    };
    let now = spread(cameras);
    if now <= 0.0 {
        return;
    }
    let s = spread(rig) / now;
    for (i, cam) in cameras.iter_mut().enumerate() {
        if i != hold {
            let c = centre + (cam.centre() - centre) * s;
            cam.pose.translation = -(cam.pose.rotation * c.coords);
        }
    }
}
