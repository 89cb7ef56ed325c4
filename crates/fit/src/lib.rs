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
//!
//! The chain by hand (`flexshape_track::Pipeline` runs it, with the silhouettes, carving and
//! bands): the hull's centerline of a simulated catheter refined on its images.
//!
//! ```
//! use flexshape_carve::{HierarchicalCarver, OutsideImage};
//! use flexshape_fit::{FitSettings, TubeFitter, View};
//! use flexshape_shape::{ShapeEstimator, ShapeSettings};
//! use flexshape_silhouette::{BackgroundModel, BitMask};
//! use flexshape_sim::{CatheterPose, SimConfig, Simulator};
//!
//! let sim = Simulator::new(SimConfig::default())?;
//! let pose = CatheterPose::arc(&sim.config().catheter, [0.006, -0.002], [0.0, 0.0], 0.0);
//! let frame = sim.render(0, &pose)?;
//! let backgrounds = BackgroundModel::each(&sim.backgrounds())?;
//! let masks: Vec<BitMask> = frame.views.iter().map(|v| BitMask::from_gray(&v.mask)).collect();
//! let markers: Vec<BitMask> = frame.views.iter().map(|v| BitMask::from_gray(&v.markers)).collect();
//! let volume = &sim.rig().volume;
//! let carver = HierarchicalCarver::new(&sim.cameras(), volume)?;
//! let hull = carver.carve(&masks.iter().collect::<Vec<_>>(), OutsideImage::Carve)?;
//! let estimator = ShapeEstimator::new(ShapeSettings::from_processing(&sim.rig().processing)?)?;
//! let start = estimator.estimate(&hull, &[]);
//! let views: Vec<View> = (0..masks.len())
//!     .map(|k| View {
//!         image: &frame.views[k].image,
//!         background: backgrounds[k].means(),
//!         silhouette: &masks[k],
//!         markers: &markers[k],
//!         shadow_like: None,
//!         hidden: None,
//!     })
//!     .collect();
//! let names = sim.rig().cameras.iter().map(|c| c.name.clone()).collect();
//! let fitter = TubeFitter::new(sim.cameras(), names, FitSettings::default())?;
//! let (fitted, fit) = fitter.refine(&estimator, volume, &views, &start, &hull.centres(), None)?;
//! // Every camera's outline residual, px; the fitted tip is far closer to the truth.
//! for camera in &fit.expect("a fit").cameras {
//!     assert!(camera.residual_px < 0.5, "{camera:?}");
//! }
//! let tip_error = frame.truth.tip_off(fitted.tip);
//! assert!(tip_error < 0.3, "{tip_error} mm");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod across_time;
mod bands;
mod bundle;
mod check;
mod edges;
mod lengthen;
mod orient;
mod outline;
mod pose;
mod region;
mod settings;
mod solve;
mod stereo;
mod tube;
mod verdict;
mod width;

use flexshape_camera::Camera;
use flexshape_rig::Volume;
use flexshape_shape::{FittedCurve, ShapeEstimator, ShapeRecord, Status};
use flexshape_silhouette::{BitMask, Rows};
use image::RgbImage;
use nalgebra::{DMatrix, Matrix3, Vector3};
use thiserror::Error;

pub use across_time::{AcrossTime, Motion};
pub use bundle::{Bundle, PosePrior};
pub use check::{CameraCheck, OutlineResiduals, STILL_RAMP_PX, debug_image};
pub use settings::{FitSettings, Method, OutlineWidth};
pub use tube::Tube;

/// The median of `values` (the upper one of an even count; 0 for none).
pub(crate) fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

use edges::EdgeImage;
use outline::Spheres;
use solve::{Seen, against, measure, normal_equations};
use width::WidthProfile;

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
    /// The part of the silhouette that is shadow-coloured (see
    /// `flexshape_silhouette::Silhouette::shadow_like`), if known: where it lies away from the
    /// fitted tube the self-check takes it for a shadow on the backdrop, not for something the
    /// fit left unexplained.
    pub shadow_like: Option<&'a BitMask>,
    /// Where something in front of the volume hides it from the camera (the rig's occlusion
    /// mask, same size), if known: the outline there is left out of the fit and the
    /// self-check, and the tube's pixels there out of its overlap with the silhouette.
    pub hidden: Option<&'a BitMask>,
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
    /// Boundary measurements made (each of every camera's outline).
    pub measurements: usize,
    /// Estimated noise of one outline residual, pixels.
    pub sigma_px: f64,
    /// Carved hull away from the fitted tube, as a length of tube, mm (see
    /// [`TubeFitter::refine`]); `None` when no hull was carved.
    pub ghost_mm: Option<f64>,
    /// Covariance of the parameters (control points, then radius), mm²: exact within
    /// [`COVARIANCE_BAND`] of the diagonal and for the radii, zero elsewhere.
    covariance: DMatrix<f64>,
}

impl Fit {
    /// 1-σ uncertainty of the centerline point at `u` across the tube (the root of the trace of
    /// its covariance perpendicular to the tangent), mm.
    pub fn sigma_across(&self, u: f64) -> f64 {
        let b = self.tube.centerline.basis_to::<1>(u);
        let d1 = Vector3::from(self.tube.centerline.eval_basis(&b).d1);
        let t = d1 / d1.norm().max(1e-300);
        // The trace of P·C·P, P = I − t·tᵀ the projection across the tube (idempotent), is
        // the sum of C's entries weighted by P's. C is the point's covariance, Σ wⱼ·wₖ·Cⱼₖ over
        // the 3×3 blocks of its control points; the covariance is symmetric and so is P, so
        // each block off the diagonal counts twice for its mirror.
        let across = Matrix3::identity() - t * t.transpose();
        let (n, entries) = (self.covariance.nrows(), self.covariance.as_slice());
        let w = &b.weights[0];
        let mut variance = 0.0;
        for j in 0..4 {
            for k in j..4 {
                let weight = w[j] * w[k] * if j == k { 1.0 } else { 2.0 };
                if weight == 0.0 {
                    continue;
                }
                let (r, c) = (3 * (b.first + j), 3 * (b.first + k));
                let mut sum = 0.0;
                for q in 0..3 {
                    let column = &entries[(c + q) * n + r..(c + q) * n + r + 3];
                    sum += column[0] * across[(0, q)]
                        + column[1] * across[(1, q)]
                        + column[2] * across[(2, q)];
                }
                variance += weight * sum;
            }
        }
        variance.max(0.0).sqrt()
    }
}

/// The covariance entries a centerline point's uncertainty reads: those of two coordinates of
/// control points at most 3 apart (a cubic B-spline's point depends on 4).
const COVARIANCE_BAND: usize = 11;

/// A step across the tube below this ends the iterations, mm.
const CONVERGED_MM: f64 = 0.005;

/// A first step on fresh boundaries below this ends the fit, mm: measuring again moves the
/// tube by about half as much each time (the surface colour is read where the outline was
/// predicted), so chasing it further costs whole measurements for a few micrometres.
const SETTLED_MM: f64 = 0.02;

/// A tube that settled on its first boundaries within this of where it started, mm, is not
/// measured again: on followed 120-Hz frames (first moves ~0.1 mm) leaving the second
/// measurement out changed the centerline's error from truth by under 0.001 mm (median and
/// worst RMS over 4 seeds × 40 frames) and saved a fifth of the fit.
const ONE_MEASUREMENT_MM: f64 = 0.3;

/// [`ONE_MEASUREMENT_MM`] for a followed frame, mm. Two workers start from the frame two
/// back, and at 60 Hz their first moves pass 0.3 mm: at 0.6, tracked accuracy over seeds 1–6
/// at 60 and 120 Hz (1 and 2 threads) moved by at most 0.003 mm, and two threads ran 3–10 %
/// faster. A start from the hull is farther off, and there 0.6 left a tip's outline
/// unexplained (floating-base frames `inconsistent` at 0.6–0.9 px that a second measurement
/// fits to 0.1).
const ONE_MEASUREMENT_FOLLOWED_MM: f64 = 0.6;

/// Gauss–Newton steps on one measurement's boundaries at most: where a moved tip left most
/// of its cap unmeasured, fresh boundaries serve better than more steps on the few found.
const INNER_STEPS: usize = 4;

/// Boundary measurements per fit at most (each followed by Gauss–Newton steps on them).
const MEASUREMENTS: usize = 4;

/// The largest move of a control point across the tube (perpendicular to the control
/// polygon there) in a parameter step, mm; at a capped end the whole move, since its cap
/// places it along the tube too (a tip still sliding out has not converged).
fn across_tube(tube: &Tube, step: &nalgebra::DVector<f64>) -> f64 {
    let last = tube.centerline.control().len() - 1;
    (0..=last)
        .map(|k| {
            let d = Vector3::new(step[3 * k], step[3 * k + 1], step[3 * k + 2]);
            let capped = (k == 0 && tube.capped[0]) || (k == last && tube.capped[1]);
            if capped {
                d.norm()
            } else {
                tube.across(k, d).norm()
            }
        })
        .fold(0.0, f64::max)
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
        Ok(self
            .fit_with(&self.settings, views, start, fit_radius, ONE_MEASUREMENT_MM)?
            .0)
    }

    /// [`TubeFitter::fit`] with other settings (a followed frame's sample spacing), and the
    /// fitted tube's visibility spheres in each camera (the check drew them; the bands use
    /// them). A tube that settled on its first boundaries within `one_measurement_mm` of
    /// `start` is not measured again (see [`ONE_MEASUREMENT_MM`]; 0: always measured again).
    fn fit_with(
        &self,
        s: &FitSettings,
        views: &[View<'_>],
        start: Tube,
        fit_radius: bool,
        one_measurement_mm: f64,
    ) -> Result<(Fit, Vec<Spheres>), FitError> {
        self.fit_across(s, views, start, fit_radius, one_measurement_mm, None)
    }

    /// [`TubeFitter::fit_with`] for cameras that captured at different instants: with
    /// `across`, each camera's outline is measured around, and compared with, the tube
    /// carried by its motion to that camera's capture ([`AcrossTime`]), and the fitted tube
    /// is the one at the instant the offsets are counted from; the check holds each camera to
    /// its own. `None`: every camera saw the same tube.
    fn fit_across(
        &self,
        s: &FitSettings,
        views: &[View<'_>],
        start: Tube,
        fit_radius: bool,
        one_measurement_mm: f64,
        across: Option<&AcrossTime>,
    ) -> Result<(Fit, Vec<Spheres>), FitError> {
        let images = self.edge_images(views)?;
        let cameras = self.cameras.len();
        let each = |tube: &Tube| across.map(|a| a.seen(tube, cameras));
        // Free widths say nothing of the radius (see `width`).
        let fit_radius = fit_radius && !s.free_width();
        let mut tube = start.clone();
        let mut iterations = 0;
        let mut measurements = 0;
        let mut normal = None;
        // Boundaries are measured around the predicted outline, then the tube is fitted to
        // them as fixed data; re-measured once it stops moving across itself.
        // The last measurement, if the tube has not moved since (then it serves the check).
        let mut settled = None;
        'outer: for round in 0..MEASUREMENTS {
            let moved_tubes = each(&tube);
            let measured = measure(
                &self.cameras,
                &images,
                Seen::of(&tube, moved_tubes.as_deref()),
                s,
            );
            measurements += 1;
            let mut current = measured.clone();
            let mut moved = 0.0;
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
                let radii = step.rows_range(tube.radius_column(0)..).amax();
                let across = across_tube(&tube, &step).max(radii);
                iterations += 1;
                if inner > 0
                    && round == 0
                    && across < CONVERGED_MM
                    && moved + across < one_measurement_mm
                {
                    // Started close (a followed frame) and converged: the boundaries were
                    // searched around nearly where the tube settled, and they and this
                    // linearisation serve the check and the covariance as they are (the step
                    // left is below the fit's resolution).
                    settled = Some((current, Some(eq)));
                    break 'outer;
                }
                tube.apply(&step);
                moved += across;
                normal = Some(eq);
                if inner == 0 && across < SETTLED_MM {
                    // Fresh boundaries hardly moved it: converged for good.
                    settled = Some((measured, None));
                    break 'outer;
                }
                if across < CONVERGED_MM || inner + 1 >= INNER_STEPS {
                    // Converged on these boundaries (or still creeping, as Huber weights make
                    // it when some boundaries were found far off): measure them again.
                    break;
                }
                // Unfound samples kept: should these be the last, the check counts them.
                let moved_tubes = each(&tube);
                let by_camera = Seen::of(&tube, moved_tubes.as_deref());
                current = against(&self.cameras, by_camera, &measured, true, s.free_width());
            }
        }
        let (measured, eq) = match settled {
            Some((measured, Some(eq))) => (measured, eq),
            other => {
                let measured = other.map(|(m, _)| m).unwrap_or_else(|| {
                    measurements += 1;
                    let moved_tubes = each(&tube);
                    measure(
                        &self.cameras,
                        &images,
                        Seen::of(&tube, moved_tubes.as_deref()),
                        s,
                    )
                });
                let eq = normal_equations(&tube, &start, &measured, s, fit_radius);
                (measured, eq)
            }
        };
        let dof = (eq.rows as f64 - tube.parameters() as f64).max(1.0);
        let sigma_px = (eq.cost / dof).sqrt();
        // Only the covariance of control points that share a span (and with the radii) is
        // read (`Fit::sigma_across`): Takahashi's recursion gives those entries of H⁻¹
        // from its Cholesky factor, a few percent of the whole inverse's cost.
        let tail = tube.parameters() - tube.radius_column(0);
        let inverse = |h: DMatrix<f64>| match h.clone().cholesky() {
            Some(chol) => Some(flexshape_lsq::banded_inverse(&chol, COVARIANCE_BAND, tail)),
            None => h.try_inverse(),
        };
        let covariance = inverse(eq.h)
            .or_else(|| normal.and_then(|n| inverse(n.h)))
            .unwrap_or_else(|| DMatrix::zeros(tube.parameters(), tube.parameters()))
            * sigma_px.powi(2);
        let length = tube.length();
        // Each camera's check holds it to the tube it saw.
        let moved_tubes = each(&tube);
        let by_camera = Seen::of(&tube, moved_tubes.as_deref());
        let spheres = self.spheres(by_camera, length);
        let cameras = self
            .cameras
            .iter()
            .zip(&self.names)
            .zip(views)
            .zip(&measured)
            .zip(&spheres)
            .zip(&images)
            .enumerate()
            .map(|(k, (((((cam, name), view), m), spheres), img))| {
                let tube = by_camera.by(k);
                let scatter = check::Scatter::of(m);
                let res = check::residual_stats(m, &scatter, s.max_p90_px, 1.0);
                let ends = check::end_stats(m, tube, length, &scatter, s.max_p90_px);
                let caps = check::cap_samples(m);
                let widths = if s.free_width() {
                    WidthProfile::of(m)
                } else {
                    WidthProfile::default()
                };
                let rendered = check::render(cam, spheres, &widths);
                let missed = |away: &BitMask| self.continuations(cam, tube, away);
                let iou_limit = check::iou_limit(s.min_iou, spheres);
                let size = (rendered.0.width(), rendered.0.height());
                let outlined = || check::outlined(size, spheres, &widths, m, s.max_residual_px);
                let overlap =
                    check::overlap(&rendered, view, s.explain_px, missed, (iou_limit, outlined));
                CameraCheck {
                    camera: name.clone(),
                    samples: res.samples,
                    found: res.found,
                    unseen: res.unseen,
                    residual_px: res.rms,
                    offset_px: res.mean,
                    shift_px: res.shift,
                    p90_px: res.p90,
                    noise_px: res.noise.0,
                    noise_range_px: res.noise.1,
                    outlying_share: res.outlying,
                    iou: overlap.iou,
                    iou_limit,
                    iou_outlined: overlap.iou_outlined,
                    unexplained_px: overlap.unexplained_px,
                    shadow_px: overlap.shadow_px,
                    end_samples: ends.samples,
                    end_found: ends.found,
                    end_unseen: ends.unseen,
                    end_residual_px: ends.rms,
                    end_noise_px: ends.noise.0,
                    cap_found: caps.map(|(found, _)| found),
                    cap_samples: caps.map(|(_, all)| all),
                    goes_on: self.goes_on(cam, img, tube, &rendered.0, caps),
                    // A mask's object is white on black: no colour to speak of.
                    lighter_share: if s.masks { 0.0 } else { res.lighter },
                    // (From +0: a negated zero would be written "-0.0".)
                    width_offset_px: 0.0 - widths.median(),
                    ramp_px: res.ramp,
                    beyond_blur: check::OutlineResiduals {
                        end_residual_px: ends.beyond_blur.residual_px,
                        ..res.beyond_blur
                    },
                    with_blur: check::OutlineResiduals {
                        end_residual_px: ends.with_blur.residual_px,
                        ..res.with_blur
                    },
                }
            })
            .collect();
        let fit = Fit {
            tube,
            cameras,
            iterations,
            measurements,
            sigma_px,
            ghost_mm: None,
            covariance,
        };
        Ok((fit, spheres))
    }

    /// `tube` drawn into camera `camera`'s image as the self-check sees it: the tube, and the
    /// straight continuations of its open ends, or `None` for a camera index outside the rig.
    pub fn render(&self, camera: usize, tube: &Tube) -> Option<(BitMask, BitMask)> {
        let centres = outline::sphere_centres(tube, tube.length());
        self.cameras.get(camera).map(|c| {
            let spheres = Spheres::from_centres(c, tube, &centres, 0.0);
            check::render(c, &spheres, &WidthProfile::default())
        })
    }

    /// Every camera's predicted outline of `tube` and the boundary measured for each point:
    /// what the fit sees (for debug images and viewers).
    pub fn outline_residuals(
        &self,
        views: &[View<'_>],
        tube: &Tube,
    ) -> Result<Vec<Vec<OutlineResidual>>, FitError> {
        let images = self.edge_images(views)?;
        Ok(
            measure(&self.cameras, &images, Seen::All(tube), &self.settings)
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
                .collect(),
        )
    }

    /// For each stretch `[a, b]` (world mm) of `stretches`, per camera: of `tube`'s outline
    /// samples along its sides between the centerline points nearest `a` and `b`, how many
    /// found a boundary in the camera's image and how many there were; samples whose backdrop
    /// has the tube's colour, which the image shows neither way, are left out of both. The
    /// outline is measured once for all. Whether the images show the tube along stretches
    /// nothing else holds it to: gaps between pieces of its carved hull.
    pub fn found_between(
        &self,
        views: &[View<'_>],
        tube: &Tube,
        stretches: &[[nalgebra::Point3<f64>; 2]],
    ) -> Result<Vec<Vec<(usize, usize)>>, FitError> {
        let images = self.edge_images(views)?;
        let measured = measure(&self.cameras, &images, Seen::All(tube), &self.settings);
        Ok(stretches
            .iter()
            .map(|[a, b]| {
                let (ua, ub) = (tube.nearest_u(a), tube.nearest_u(b));
                let stretch = ua.min(ub)..=ua.max(ub);
                measured
                    .iter()
                    .map(|cam| {
                        cam.iter()
                            .filter(|m| {
                                matches!(m.point.part, outline::Part::Side(_))
                                    && !m.unseen
                                    && stretch.contains(&m.point.u)
                            })
                            .fold((0, 0), |(found, all), m| {
                                (found + usize::from(m.residual.is_some()), all + 1)
                            })
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
            hull.enters_volume || volume.depth(&hull.points[0].into()) <= r0 + 2.0 * voxel,
            hull.status == Status::LeavesVolume,
        ];
        let capped = open.map(|o| !o);
        let steps = &estimator.settings().radius_steps;
        let start = match Tube::through(&hull.points, r0, capped, s.span_mm, s.extend_mm) {
            Ok(t) => t.with_steps(steps),
            Err(_) => return Ok((hull.clone(), None)),
        };
        let fit_radius = radius.is_none() && s.fit_radius;
        let mut fitted = self.fit_with(s, views, start, fit_radius, ONE_MEASUREMENT_MM)?;
        // An end the hull stopped short of, where the images show the tube going on.
        let mut again = [false; 2];
        for _ in 0..lengthen::ROUNDS {
            let Some((longer, walk)) = self.lengthened(views, volume, &fitted.0, again)? else {
                break;
            };
            fitted = self.fit_with(s, views, longer, fit_radius, ONE_MEASUREMENT_MM)?;
            again = walk;
        }
        let mut base = hull.clone();
        let (mut fit, spheres) =
            self.orient_by_band(estimator, views, fitted, &mut base, fit_radius)?;
        let voxel_volume = volume.voxel_size.iter().product::<f64>();
        let reach = 1.5 * fit.tube.largest_radius() + 1.5 * voxel;
        fit.ghost_mm = Some(check::ghost_length(
            &fit.tube,
            hull_voxels,
            voxel_volume,
            reach,
        ));
        let record = self.conclude(estimator, volume, views, (&fit, &spheres, None), &base);
        Ok((record, Some(fit)))
    }

    /// The frame's shape from the images, started from an earlier frame's record (tracking):
    /// from `start` — that frame's fitted tube, or a prediction from it — when given (its
    /// control points spread again along the same curve if they drifted, see
    /// [`Tube::spread_again`]), else through the record's centerline (cut where it leaves the
    /// volume) again; its radius and open ends. A fit that settled on its first boundaries
    /// but fails a camera's check is measured again before it is judged. The ends stay open
    /// or capped as they were and the proximal end stays where it was (the tube cannot
    /// turn round between frames). No hull is carved, so nothing is said about ghosts
    /// ([`Fit::ghost_mm`] is `None`); a fit that does not explain the images, or whose tip
    /// moved more than `track_max_move_mm` from where it started, gets status
    /// `inconsistent`, and the caller then starts again from the hull. `radius` is the
    /// tube's, if known. With `across` (beside `start`: cameras that captured at different
    /// instants, and the tube's recent motion), each camera is held to the tube where it was at
    /// its capture and the shape is the tube at the instant the offsets count from
    /// ([`AcrossTime`]).
    pub fn follow(
        &self,
        estimator: &ShapeEstimator,
        volume: &Volume,
        views: &[View<'_>],
        previous: &ShapeRecord,
        (start, across): (Option<&Tube>, Option<&AcrossTime>),
        radius: Option<f64>,
    ) -> Result<(ShapeRecord, Option<Fit>), FitError> {
        let s = &self.settings;
        let r0 = radius.unwrap_or(previous.radius);
        let open = [
            previous.enters_volume,
            previous.status == Status::LeavesVolume,
        ];
        let capped = open.map(|o| !o);
        let steps = &estimator.settings().radius_steps;
        // The previous tube's radii where the fit finds them (none given), else the rig's.
        let start = start.filter(|t| t.capped == capped && t.steps_at_same_places(steps));
        let radii = start
            .filter(|_| radius.is_none())
            .map_or(steps.as_slice(), |t| t.steps.as_slice());
        // A start whose control points drifted along it is spread again along the same curve
        // (it may carry the motion on, which the previous shape does not).
        let given = start.and_then(|t| t.spread_again(s.span_mm)).map(|t| {
            let mut t = t
                .reopened(|p| volume.depth(&p), s.extend_mm, s.span_mm)
                .unwrap_or(t);
            if radius.is_some() {
                t.radius = r0;
                t.steps = steps.clone();
            }
            t
        });
        let start = match given {
            Some(t) => t,
            // Through the previous shape again, so that control points are evenly spread.
            None => match Tube::through(&previous.points, r0, capped, s.span_mm, s.extend_mm) {
                Ok(t) => t.with_steps(radii),
                Err(_) => return Ok((previous.clone(), None)),
            },
        };
        let from = start.frame(1.0).0;
        // Two cameras pin a shape down only just: they keep every sample.
        let followed = FitSettings {
            spacing_mm: if self.cameras.len() >= 3 {
                s.track_spacing_mm
            } else {
                s.spacing_mm
            },
            ..s.clone()
        };
        let fit_radius = radius.is_none() && s.fit_radius;
        let (mut fit, mut spheres) = self.fit_across(
            &followed,
            views,
            start,
            fit_radius,
            ONE_MEASUREMENT_FOLLOWED_MM,
            across,
        )?;
        if fit.measurements == 1 && fit.cameras.iter().any(|c| !self.explains(c)) {
            // Settled on its first boundaries, which a camera's check then faults: the
            // shortcut's assumption (boundaries searched about where the tube settled) may be
            // what failed, and measuring again costs far less than the hull.
            let iterations = fit.iterations;
            (fit, spheres) =
                self.fit_across(&followed, views, fit.tube, fit_radius, 0.0, across)?;
            fit.iterations += iterations;
            fit.measurements += 1;
        }
        // What the hull would have said before the fit: whether the tip runs out of the
        // volume; bands come from the images alone.
        let base = ShapeRecord::empty(if open[1] {
            Status::LeavesVolume
        } else {
            Status::Ok
        });
        let mut record = self.conclude(estimator, volume, views, (&fit, &spheres, across), &base);
        // The boundaries are searched a few pixels from the prediction: a tip that moved
        // farther than that between frames was not followed but pulled, and may have settled
        // short of where it is.
        let moved = (fit.tube.frame(1.0).0 - from).norm();
        if moved > s.track_max_move_mm {
            record.status = Status::Inconsistent {
                reason: format!(
                    "the tip moved {moved:.1} mm from where the previous frames put it (at most {:.1} for a followed fit)",
                    s.track_max_move_mm
                ),
            };
        }
        Ok((record, Some(fit)))
    }

    /// `tube`'s visibility spheres in each camera (rig order); `length` is its length, mm.
    /// `seen`: the tube each camera saw (one for all: its sphere centres placed once).
    fn spheres(&self, seen: Seen<'_>, length: f64) -> Vec<Spheres> {
        let shared = match seen {
            Seen::All(tube) => Some(outline::sphere_centres(tube, length)),
            Seen::Each(_) => None,
        };
        self.cameras
            .iter()
            .enumerate()
            .map(|(k, cam)| {
                let tube = seen.by(k);
                match &shared {
                    Some(centres) => Spheres::from_centres(cam, tube, centres, 0.0),
                    None => {
                        let centres = outline::sphere_centres(tube, length);
                        Spheres::from_centres(cam, tube, &centres, 0.0)
                    }
                }
            })
            .collect()
    }

    /// The part of each camera's image (rig order) within `margin_px` of `tube`'s image (its
    /// ends' continuations left out), row by row (see `region::around`), or `None` for a camera
    /// that does not see the tube.
    pub fn image_regions(&self, tube: &Tube, margin_px: f64) -> Vec<Option<Rows>> {
        let centres = outline::sphere_centres(tube, tube.length());
        self.cameras
            .iter()
            .map(|cam| region::around(cam, &centres, margin_px))
            .collect()
    }

    /// The record of a fitted tube (with its visibility spheres in each camera): its curve
    /// sampled, bands from colour, and the statuses the self-check, the ghost check and the
    /// uncertainty give. With `across`, each camera's colours are read along the tube it saw.
    fn conclude(
        &self,
        estimator: &ShapeEstimator,
        volume: &Volume,
        views: &[View<'_>],
        (fit, spheres, across): (&Fit, &[Spheres], Option<&AcrossTime>),
        hull: &ShapeRecord,
    ) -> ShapeRecord {
        let s = &self.settings;
        let sigma = |u: f64| fit.sigma_across(u);
        let images: Vec<&RgbImage> = views.iter().map(|v| v.image).collect();
        let markers: Vec<&BitMask> = views.iter().map(|v| v.markers).collect();
        let each = across.map(|a| a.seen(&fit.tube, self.cameras.len()));
        let found = bands::locate(
            &self.cameras,
            &images,
            &markers,
            (&fit.tube, each.as_deref()),
            spheres,
        );
        let fitted = FittedCurve {
            curve: fit.tube.centerline.clone(),
            radius: fit.tube.radius,
            open: fit.tube.capped.map(|c| !c),
            bands: (!found.is_empty()).then_some(found.as_slice()),
            sigma: Some(&sigma),
        };
        let mut record = estimator.record_from_curve(fitted, volume, hull);
        let ghost = fit.ghost_mm.unwrap_or(0.0);
        if let Some(reason) = self.verdict(fit, volume) {
            let reason = reason + &self.along_epipolar_plane(&fit.tube).unwrap_or_default();
            record.status = Status::Inconsistent { reason };
        } else if ghost > s.max_ghost_mm {
            record.status = Status::Ambiguous {
                reason: format!(
                    "the carved hull holds {ghost:.0} mm of tube away from the fitted shape (at most {:.0}): the cameras would allow the tube there too; add a camera that sees it from another side",
                    s.max_ghost_mm
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
        } else if let Some(reason) = self.end_unseen(&fit.tube, &fit.cameras) {
            record.status = Status::Ambiguous { reason };
        }
        record
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
                let edges = EdgeImage::new(v.image, v.background)
                    .with_shade(v.shadow_like)
                    .with_hidden(v.hidden);
                Ok(if self.settings.masks {
                    edges.of_mask()
                } else {
                    edges
                })
            })
            .collect()
    }
}
