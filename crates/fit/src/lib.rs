//! The tube fitted to the images: shape from the sub-pixel outlines in every camera, and a
//! self-check of every frame against them.
//!
//! The visual hull of a round tube seen by a few cameras is a polygon around it; its centerline
//! is biased and cannot get much below a fifth of a voxel. The images hold far more: the
//! tube's outline in each camera is sharp to a tenth of a pixel. [`TubeFitter::fit`] starts
//! from the hull's centerline ([`Tube::through`]) and moves a swept-sphere tube (a cubic
//! B-spline centerline, a radius, hemispherical caps at free ends) until its predicted outline
//! — the contour generators projected through the lens model — lies on the boundaries
//! measured in every camera (`edges`: the ½ crossing of the background-difference coverage
//! along each outline normal), by Gauss–Newton with analytic Jacobians (`outline`) and Huber
//! weights (`solve`). [`TubeFitter::refine`] turns the result into the frame's
//! [`ShapeRecord`], with a 1-σ uncertainty per sample from the normal equations, and checks it
//! (`check`): a fit that does not explain a camera's image gets status `inconsistent`.
//!
//! World frame, millimetres, radians; image positions in pixels (OpenCV convention).

mod bands;
mod check;
mod edges;
mod outline;
mod settings;
mod solve;
mod tube;

use flexshape_camera::Camera;
use flexshape_rig::Volume;
use flexshape_shape::{FittedCurve, ShapeEstimator, ShapeRecord, Status};
use flexshape_silhouette::BitMask;
use image::RgbImage;
use nalgebra::{DMatrix, Matrix3, Vector3};
use thiserror::Error;

pub use check::{CameraCheck, debug_image};
pub use settings::{FitSettings, Method};
pub use tube::Tube;

use edges::EdgeImage;
use solve::{against, measure, normal_equations};

/// Why the fit cannot be set up or run.
#[derive(Debug, Error)]
pub enum FitError {
    /// A setting is out of range.
    #[error("fit setting `{field}`: {problem}")]
    Setting {
        /// The setting, e.g. `search_px`.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The inputs do not match the rig.
    #[error("camera {camera} (in the rig's order): {problem}")]
    Input {
        /// Camera index in the rig's order.
        camera: usize,
        /// What does not match.
        problem: String,
    },
}

/// One camera's frame as the fit reads it.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The frame (8-bit RGB).
    pub image: &'a RgbImage,
    /// The background model's mean colour per pixel, row-major, same size.
    pub background: &'a [[f32; 3]],
    /// The frame's silhouette (for the self-check).
    pub silhouette: &'a BitMask,
    /// The frame's marker-band pixels (which tell tape from body colour).
    pub markers: &'a BitMask,
}

/// One predicted outline point and its measured boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutlineResidual {
    /// Predicted pixel (OpenCV convention).
    pub pixel: [f64; 2],
    /// Unit image normal, out of the tube's image.
    pub normal: [f64; 2],
    /// Centerline parameter (0 proximal end, 1 tip).
    pub u: f64,
    /// Whether the point is on an end cap.
    pub cap: bool,
    /// Predicted minus measured position along `normal`, pixels (`None`: no boundary found).
    pub residual: Option<f64>,
}

/// The fitted tube and how well it explains the images.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The tube.
    pub tube: Tube,
    /// Per camera, in the rig's order.
    pub cameras: Vec<CameraCheck>,
    /// Gauss–Newton iterations run.
    pub iterations: usize,
    /// Estimated noise of one outline residual, pixels.
    pub sigma_px: f64,
    /// Carved hull away from the fitted tube, as a length of tube, mm (see
    /// [`TubeFitter::refine`]); 0 when no hull was given.
    pub ghost_mm: f64,
    /// Covariance of the parameters (control points, then radius), mm².
    covariance: DMatrix<f64>,
}

impl Fit {
    /// 1-σ uncertainty of the centerline point at `u` across the tube (the root of the trace of
    /// its covariance perpendicular to the tangent), mm.
    pub fn sigma_across(&self, u: f64) -> f64 {
        let (cov, t) = self.point_covariance(u);
        let p = Matrix3::identity() - t * t.transpose();
        (p * cov * p).trace().max(0.0).sqrt()
    }

    fn point_covariance(&self, u: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let b = self.tube.centerline.basis(u);
        let mut cov = Matrix3::zeros();
        for j in 0..4 {
            for k in 0..4 {
                let w = b.weights[0][j] * b.weights[0][k];
                if w == 0.0 {
                    continue;
                }
                let (r, c) = (3 * (b.first + j), 3 * (b.first + k));
                cov += self.covariance.fixed_view::<3, 3>(r, c) * w;
            }
        }
        (cov, self.tube.frame(u).1)
    }
}

/// A step across the tube below this ends the iterations, mm.
const CONVERGED_MM: f64 = 0.005;

/// Boundary measurements per fit at most (each followed by Gauss–Newton steps on them).
const MEASUREMENTS: usize = 4;

/// The largest move of a control point across the tube (perpendicular to the control
/// polygon there) in a parameter step, mm.
fn across_tube(tube: &Tube, step: &nalgebra::DVector<f64>) -> f64 {
    (0..tube.centerline.control().len())
        .map(|k| {
            let t = tube.control_tangent(k);
            let d = Vector3::new(step[3 * k], step[3 * k + 1], step[3 * k + 2]);
            (d - t * d.dot(&t)).norm()
        })
        .fold(0.0, f64::max)
}

/// How far `p` lies inside the volume's box (negative outside), mm.
fn depth_inside(volume: &Volume, p: [f64; 3]) -> f64 {
    let max = volume.max_corner();
    (0..3)
        .map(|k| (p[k] - volume.origin[k]).min(max[k] - p[k]))
        .fold(f64::INFINITY, f64::min)
}

/// Fits tubes to one rig's images.
#[derive(Debug, Clone)]
pub struct TubeFitter {
    cameras: Vec<Camera>,
    names: Vec<String>,
    settings: FitSettings,
}

impl TubeFitter {
    /// A fitter for these cameras (the rig's order) and their names.
    pub fn new(
        cameras: Vec<Camera>,
        names: Vec<String>,
        settings: FitSettings,
    ) -> Result<Self, FitError> {
        settings.validate()?;
        if names.len() != cameras.len() {
            return Err(FitError::Input {
                camera: names.len().min(cameras.len()),
                problem: format!("{} names for {} cameras", names.len(), cameras.len()),
            });
        }
        Ok(TubeFitter {
            cameras,
            names,
            settings,
        })
    }

    /// The settings.
    pub fn settings(&self) -> &FitSettings {
        &self.settings
    }

    /// Moves `start` until its outline explains every view; the radius stays fixed unless
    /// `fit_radius`.
    pub fn fit(&self, views: &[View<'_>], start: Tube, fit_radius: bool) -> Result<Fit, FitError> {
        let images = self.edge_images(views)?;
        let s = &self.settings;
        let mut tube = start.clone();
        let mut iterations = 0;
        let mut normal = None;
        // Boundaries are measured around the predicted outline, then the tube is fitted to
        // them as fixed data; re-measured once it stops moving across itself.
        // The last measurement, if the tube has not moved since (then it serves the check).
        let mut settled = None;
        'outer: for _ in 0..MEASUREMENTS {
            let measured = measure(&self.cameras, &images, &tube, s);
            let mut current = measured.clone();
            for inner in 0.. {
                if iterations >= s.max_iterations {
                    break 'outer;
                }
                let eq = normal_equations(&tube, &start, &current, s, fit_radius);
                let Some(chol) = eq.h.clone().cholesky() else {
                    break 'outer;
                };
                let mut step = -chol.solve(&eq.g);
                // Hold each step within a millimetre: the boundaries are only searched a few
                // pixels away, so a longer step leaves what was measured.
                let largest = step.amax();
                if largest > 1.0 {
                    step /= largest;
                }
                let n = step.len();
                let across = across_tube(&tube, &step).max(step[n - 1].abs());
                tube.centerline.displace(&step.rows(0, n - 1).into_owned());
                tube.radius = (tube.radius + step[n - 1]).max(0.05);
                normal = Some(eq);
                iterations += 1;
                if across < CONVERGED_MM {
                    // Converged on these boundaries; converged for good when measuring again
                    // moved nothing.
                    if inner == 0 {
                        settled = Some(measured);
                        break 'outer;
                    }
                    break;
                }
                current = against(&self.cameras, &tube, &measured);
            }
        }
        let measured = settled.unwrap_or_else(|| measure(&self.cameras, &images, &tube, s));
        let eq = normal_equations(&tube, &start, &measured, s, fit_radius);
        let dof = (eq.rows as f64 - tube.parameters() as f64).max(1.0);
        let sigma_px = (eq.cost / dof).sqrt();
        let covariance =
            eq.h.clone()
                .try_inverse()
                .or_else(|| normal.and_then(|n| n.h.try_inverse()))
                .unwrap_or_else(|| DMatrix::zeros(tube.parameters(), tube.parameters()))
                * sigma_px.powi(2);
        let cameras = self
            .cameras
            .iter()
            .zip(&self.names)
            .zip(views)
            .zip(&measured)
            .map(|(((cam, name), view), m)| {
                let res = check::residual_stats(m);
                let rendered = check::render(cam, &tube);
                let (iou, unexplained_px) =
                    check::overlap(&rendered, view.silhouette, s.explain_px);
                CameraCheck {
                    camera: name.clone(),
                    samples: res.samples,
                    found: res.found,
                    residual_px: res.rms,
                    offset_px: res.mean,
                    p90_px: res.p90,
                    iou,
                    unexplained_px,
                }
            })
            .collect();
        Ok(Fit {
            tube,
            cameras,
            iterations,
            sigma_px,
            ghost_mm: 0.0,
            covariance,
        })
    }

    /// `tube` drawn into camera `camera`'s image as the self-check sees it: the tube, and the
    /// straight continuations of its open ends, or `None` for a camera index outside the rig.
    pub fn render(&self, camera: usize, tube: &Tube) -> Option<(BitMask, BitMask)> {
        self.cameras.get(camera).map(|c| check::render(c, tube))
    }

    /// Every camera's predicted outline of `tube` and the boundary measured for each point:
    /// what the fit sees (for debug images and viewers).
    pub fn outline_residuals(
        &self,
        views: &[View<'_>],
        tube: &Tube,
    ) -> Result<Vec<Vec<OutlineResidual>>, FitError> {
        let images = self.edge_images(views)?;
        Ok(measure(&self.cameras, &images, tube, &self.settings)
            .into_iter()
            .map(|cam| {
                cam.into_iter()
                    .map(|m| OutlineResidual {
                        pixel: m.point.pixel.into(),
                        normal: m.point.normal.into(),
                        u: m.point.u,
                        cap: matches!(m.point.part, outline::Part::Cap(_)),
                        residual: m.residual,
                    })
                    .collect()
            })
            .collect())
    }

    /// The frame's shape from the images: `hull` (the hull's record of the same frame) gives
    /// the start, the open ends and the bands; the fitted curve replaces its centerline. The
    /// status becomes `inconsistent` when the fit does not explain a camera's image, and
    /// `ambiguous` when the carved hull (`hull_voxels`, voxel centres, world mm) holds more than
    /// `max_ghost_mm` of tube away from the fitted one: the images would allow the tube there
    /// too (a ghost of too few cameras), so nothing shows the fitted shape is the real one.
    /// A hull record without a shape is returned as it is. `radius` is the tube's, if known.
    pub fn refine(
        &self,
        estimator: &ShapeEstimator,
        volume: &Volume,
        views: &[View<'_>],
        hull: &ShapeRecord,
        hull_voxels: &[[f64; 3]],
        radius: Option<f64>,
    ) -> Result<(ShapeRecord, Option<Fit>), FitError> {
        if hull.points.len() < 2 {
            return Ok((hull.clone(), None));
        }
        let s = &self.settings;
        let r0 = radius.unwrap_or(hull.radius);
        // The hull's cut end can stop a little short of the boundary it runs through.
        let voxel = volume
            .voxel_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let open = [
            hull.enters_volume || depth_inside(volume, hull.points[0]) <= r0 + 2.0 * voxel,
            hull.status == Status::LeavesVolume,
        ];
        let capped = open.map(|o| !o);
        let start = match Tube::through(&hull.points, r0, capped, s.span_mm, s.extend_mm) {
            Ok(t) => t,
            Err(_) => return Ok((hull.clone(), None)),
        };
        let mut fit = self.fit(views, start, radius.is_none() && s.fit_radius)?;
        let voxel_volume = volume.voxel_size.iter().product::<f64>();
        let reach = 1.5 * fit.tube.radius + 1.5 * voxel;
        fit.ghost_mm = check::ghost_length(&fit.tube, hull_voxels, voxel_volume, reach);
        let sigma = |u: f64| fit.sigma_across(u);
        let images: Vec<&RgbImage> = views.iter().map(|v| v.image).collect();
        let markers: Vec<&BitMask> = views.iter().map(|v| v.markers).collect();
        let found = bands::locate(&self.cameras, &images, &markers, &fit.tube);
        let fitted = FittedCurve {
            curve: fit.tube.centerline.clone(),
            radius: fit.tube.radius,
            open,
            bands: (!found.is_empty()).then_some(found.as_slice()),
            sigma: Some(&sigma),
        };
        let mut record = estimator.record_from_curve(fitted, volume, hull);
        if let Some(reason) = self.verdict(&fit) {
            record.status = Status::Inconsistent { reason };
        } else if fit.ghost_mm > s.max_ghost_mm {
            record.status = Status::Ambiguous {
                reason: format!(
                    "the carved hull holds {:.0} mm of tube away from the fitted shape (at most {:.0}): the cameras would allow the tube there too; add a camera that sees it from another side",
                    fit.ghost_mm, s.max_ghost_mm
                ),
            };
        } else if let Some((i, worst)) = record
            .sigma
            .iter()
            .copied()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|w| w.1 > s.max_sigma_mm)
        {
            record.status = Status::Ambiguous {
                reason: format!(
                    "the cameras pin the centerline down only to {worst:.2} mm (1 σ) at {:.0} mm along it (at most {:.2}): add a camera that sees it from another side",
                    record.arc[i], s.max_sigma_mm
                ),
            };
        }
        Ok((record, Some(fit)))
    }

    /// Why the fit does not explain the images, if it does not (the first failing check).
    fn verdict(&self, fit: &Fit) -> Option<String> {
        let s = &self.settings;
        for c in &fit.cameras {
            let i = &c.camera;
            if c.samples == 0 {
                continue;
            }
            let found = c.found as f64 / c.samples as f64;
            if found < s.min_found {
                return Some(format!(
                    "camera {i}: the fitted outline found the image's boundary at {:.0} % of its samples (at least {:.0} % expected)",
                    found * 100.0,
                    s.min_found * 100.0
                ));
            }
            if c.residual_px > s.max_residual_px {
                return Some(format!(
                    "camera {i}: outline residual {:.2} px RMS (limit {:.2}; mean {:+.2} px)",
                    c.residual_px, s.max_residual_px, c.offset_px
                ));
            }
            if c.p90_px > s.max_p90_px {
                return Some(format!(
                    "camera {i}: a tenth of the outline lies more than {:.2} px from the image's boundary (limit {:.2}): the shape does not explain this camera, or its calibration is off",
                    c.p90_px, s.max_p90_px
                ));
            }
            if c.iou < s.min_iou {
                return Some(format!(
                    "camera {i}: the fitted tube overlaps the silhouette by IoU {:.2} (at least {:.2} expected)",
                    c.iou, s.min_iou
                ));
            }
            if c.unexplained_px > s.max_unexplained_px {
                return Some(format!(
                    "camera {i}: {} silhouette pixels lie beyond the fitted tube (at most {})",
                    c.unexplained_px, s.max_unexplained_px
                ));
            }
        }
        None
    }

    fn edge_images<'a>(&self, views: &[View<'a>]) -> Result<Vec<EdgeImage<'a>>, FitError> {
        if views.len() != self.cameras.len() {
            return Err(FitError::Input {
                camera: views.len(),
                problem: format!(
                    "{} views for a rig of {} cameras",
                    views.len(),
                    self.cameras.len()
                ),
            });
        }
        views
            .iter()
            .zip(&self.cameras)
            .enumerate()
            .map(|(i, (v, cam))| {
                let (w, h) = v.image.dimensions();
                let size = (cam.intrinsics.width, cam.intrinsics.height);
                if (w, h) != size
                    || v.background.len() != (w * h) as usize
                    || (v.silhouette.width(), v.silhouette.height()) != (w as usize, h as usize)
                {
                    return Err(FitError::Input {
                        camera: i,
                        problem: format!(
                            "image {w}×{h}, background of {} pixels, silhouette {}×{}: the camera is {}×{}",
                            v.background.len(),
                            v.silhouette.width(),
                            v.silhouette.height(),
                            size.0,
                            size.1
                        ),
                    });
                }
                Ok(EdgeImage::new(v.image, v.background))
            })
            .collect()
    }
}
