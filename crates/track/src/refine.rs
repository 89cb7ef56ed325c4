//! Camera poses refined from many tracked frames (`flexshape rig refine`).
//!
//! On a real rig a thin tube sits next to a few pixels of calibration error: every fit then
//! compromises between cameras that disagree, and its self-check calls the frames
//! `inconsistent`. The tubes fitted in frames of different shapes pin the cameras down
//! better than one frame can: each camera's pose is moved until its outlines lie on the
//! boundaries it measured ([`refine_pose`]), the tubes are fitted again with the moved
//! cameras, and so on until the poses stop moving. One camera is held: the world frame stays
//! attached to it (nothing in the images fixes the world frame). So is the rig's scale, the
//! cameras' summed distance from the held one: the images show it only through the tube's
//! width of a few pixels.

use flexshape_camera::Camera;
use flexshape_fit::{EdgeSample, Fit, Tube, TubeFitter, refine_pose};
use flexshape_shape::Status;
use flexshape_silhouette::Silhouette;
use image::RgbImage;
use rayon::prelude::*;

use crate::{Pipeline, TrackError};

/// How the poses are refined.
#[derive(Debug, Clone, PartialEq)]
pub struct RefineSettings {
    /// The camera held fixed (rig order): the world frame stays attached to it.
    pub hold: usize,
    /// Rounds (poses against the tubes, then tubes against the poses) at most.
    pub rounds: usize,
}

impl Default for RefineSettings {
    fn default() -> Self {
        RefineSettings {
            hold: 0,
            rounds: 40,
        }
    }
}

/// Outline residuals of one camera over the frames used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutlineResiduals {
    /// RMS over every found outline sample, pixels.
    pub rms_px: f64,
    /// Mean of the frames' image shifts ([`flexshape_fit::CameraCheck::shift_px`]), pixels.
    pub shift_px: [f64; 2],
    /// Outline samples with a boundary found.
    pub found: usize,
}

/// One camera's refinement.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraRefinement {
    /// Its name in the rig.
    pub name: String,
    /// Whether it was held fixed.
    pub held: bool,
    /// Residuals of the tubes fitted with the rig's poses.
    pub before: OutlineResiduals,
    /// Residuals of the tubes fitted again with the refined poses.
    pub after: OutlineResiduals,
    /// Angle of the rotation from the rig's pose to the refined one, radians.
    pub rotation_rad: f64,
    /// How far the camera centre moved, mm (world).
    pub centre_moved_mm: f64,
    /// The camera with its refined pose (intrinsics unchanged).
    pub camera: Camera,
}

/// What [`refine_cameras`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct Refinement {
    /// Per camera, in the rig's order.
    pub cameras: Vec<CameraRefinement>,
    /// Frames given.
    pub frames: usize,
    /// Frames used: a fitted tube that every camera saw along most of its outline.
    pub used: usize,
    /// Frames whose shape was right (`ok`, `bands_missing`, `leaves_volume`) with the rig's
    /// poses, tracked from scratch.
    pub right_before: usize,
    /// And with the refined poses.
    pub right_after: usize,
    /// Rounds run.
    pub rounds: usize,
}

/// Fewest frames a refinement needs.
pub const MIN_FRAMES: usize = 3;

/// A frame is used when every camera found the boundary along at least this share of the
/// fitted tube's outline…
const MIN_FOUND: f64 = 0.5;

/// …and the re-rendered tube overlaps every silhouette at least this much.
const MIN_IOU: f64 = 0.5;

/// Rounds end when no camera's refinement moved its outline samples by more than this, on
/// average, pixels.
const SETTLED_PX: f64 = 0.005;

/// One frame kept for the refinement.
struct Kept<'a> {
    images: Vec<&'a RgbImage>,
    silhouettes: Vec<Silhouette>,
    tube: Tube,
}

/// The poses of `pipeline`'s cameras refined from `frames` (each one image per camera, in the
/// rig's order): every frame is tracked, those whose tube every camera saw are kept, and the
/// cameras but `settings.hold` are moved until the tubes' outlines lie on the boundaries in
/// every camera. Refused with fewer than [`MIN_FRAMES`] usable frames.
pub fn refine_cameras(
    pipeline: &Pipeline,
    frames: &[Vec<RgbImage>],
    settings: &RefineSettings,
) -> Result<Refinement, TrackError> {
    let names = pipeline.camera_names().to_vec();
    if settings.hold >= names.len() {
        return Err(TrackError::Refine(format!(
            "the camera to hold is number {} but the rig has {}",
            settings.hold + 1,
            names.len()
        )));
    }
    if names.len() < 2 {
        return Err(TrackError::Refine(
            "a rig of one camera has nothing to refine against".into(),
        ));
    }
    let tracked = frames
        .par_iter()
        .map(|f| {
            let images: Vec<&RgbImage> = f.iter().collect();
            pipeline.process(&images).map(|t| (images, t))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let right_before = tracked
        .iter()
        .filter(|(_, t)| t.shape.status.is_right())
        .count();
    let mut before = Tally::new(names.len());
    let mut kept = Vec::new();
    for (images, t) in tracked {
        let Some(fit) = t.fit.as_ref().filter(|f| usable(f, &t.shape.status)) else {
            continue;
        };
        before.add(fit);
        kept.push(Kept {
            images,
            tube: fit.tube.clone(),
            silhouettes: t.silhouettes,
        });
    }
    if kept.len() < MIN_FRAMES {
        return Err(TrackError::Refine(format!(
            "{} of {} frames have a fitted tube that every camera sees along most of its outline; at least {MIN_FRAMES} are needed (track the recording to see why frames fail: a tube that leaves a view, a camera off by more than the fit's search_px)",
            kept.len(),
            frames.len()
        )));
    }
    let fit_settings = pipeline.fit_settings().clone();
    let fit_radius = pipeline.shape_settings().radius_mm.is_none() && fit_settings.fit_radius;
    let mut cameras = pipeline.cameras().to_vec();
    let fitter_of =
        |cameras: &[Camera]| TubeFitter::new(cameras.to_vec(), names.clone(), fit_settings.clone());
    let refit = |fitter: &TubeFitter, kept: &mut [Kept<'_>]| -> Result<Vec<Fit>, TrackError> {
        kept.par_iter_mut()
            .map(|k| {
                let views = pipeline.views(&k.images, &k.silhouettes);
                let fit = fitter.fit(&views, k.tube.clone(), fit_radius)?;
                k.tube = fit.tube.clone();
                Ok(fit)
            })
            .collect()
    };
    let mut rounds = 0;
    while rounds < settings.rounds {
        let fitter = fitter_of(&cameras)?;
        if rounds > 0 {
            refit(&fitter, &mut kept)?;
        }
        rounds += 1;
        let samples = edge_samples(pipeline, &fitter, &kept, cameras.len())?;
        let mut largest = 0.0_f64;
        for (i, cam) in cameras.iter_mut().enumerate() {
            if i == settings.hold {
                continue;
            }
            let Some(pose) = refine_pose(cam, &samples[i], fit_settings.huber_px) else {
                continue;
            };
            largest = largest.max(mean_move(cam, &pose.camera, &samples[i]));
            *cam = pose.camera;
        }
        keep_scale(&mut cameras, pipeline.cameras(), settings.hold);
        if largest < SETTLED_PX {
            break;
        }
    }
    let fitter = fitter_of(&cameras)?;
    let mut after = Tally::new(names.len());
    for fit in refit(&fitter, &mut kept)? {
        after.add(&fit);
    }
    let refined = pipeline.with_cameras(cameras.clone())?;
    let right_after = frames
        .par_iter()
        .map(|f| {
            let images: Vec<&RgbImage> = f.iter().collect();
            refined.process(&images).map(|t| t.shape.status.is_right())
        })
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .filter(|&r| r)
        .count();
    let rig_cameras = pipeline.cameras();
    Ok(Refinement {
        cameras: cameras
            .into_iter()
            .enumerate()
            .map(|(i, camera)| CameraRefinement {
                name: names[i].clone(),
                held: i == settings.hold,
                before: before.summary(i),
                after: after.summary(i),
                rotation_rad: (camera.pose.rotation * rig_cameras[i].pose.rotation.inverse())
                    .angle(),
                centre_moved_mm: (camera.centre() - rig_cameras[i].centre()).norm(),
                camera,
            })
            .collect(),
        frames: frames.len(),
        used: kept.len(),
        right_before,
        right_after,
        rounds,
    })
}

/// Whether a frame's fit can serve: its shape not left undecided (a ghost or a loose fit may
/// be the wrong tube), and every camera sees the tube along most of its outline.
fn usable(fit: &Fit, status: &Status) -> bool {
    !matches!(
        status,
        Status::Ambiguous { .. } | Status::BadSilhouette { .. }
    ) && fit.cameras.iter().all(|c| {
        c.samples > 0 && c.found as f64 >= MIN_FOUND * c.samples as f64 && c.iou >= MIN_IOU
    })
}

/// Every camera's boundaries around the kept tubes, all frames together.
fn edge_samples(
    pipeline: &Pipeline,
    fitter: &TubeFitter,
    kept: &[Kept<'_>],
    cameras: usize,
) -> Result<Vec<Vec<EdgeSample>>, TrackError> {
    let per_frame = kept
        .par_iter()
        .map(|k| fitter.edge_samples(&pipeline.views(&k.images, &k.silhouettes), &k.tube))
        .collect::<Result<Vec<_>, _>>()?;
    let mut all = vec![Vec::new(); cameras];
    for frame in per_frame {
        for (c, s) in frame.into_iter().enumerate() {
            all[c].extend(s);
        }
    }
    Ok(all)
}

/// Scales the camera centres about the held one's so that their summed distance from it is
/// the rig's (`rig`): the images hardly show the rig's scale — only through the tube's
/// radius, a width of a few pixels — while the calibration target fixed it well.
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

/// Mean distance the samples' images moved from camera `a` to camera `b`, pixels.
fn mean_move(a: &Camera, b: &Camera, samples: &[EdgeSample]) -> f64 {
    let moves: Vec<f64> = samples
        .iter()
        .filter_map(|s| {
            let pa = a.project(&s.world).ok()?.pixel;
            let pb = b.project(&s.world).ok()?.pixel;
            Some((pa - pb).norm())
        })
        .collect();
    moves.iter().sum::<f64>() / moves.len().max(1) as f64
}

/// Residuals accumulated per camera over frames.
struct Tally {
    /// Per camera: Σ found·rms², Σ found, Σ found·shift.
    sums: Vec<(f64, usize, [f64; 2])>,
}

impl Tally {
    fn new(cameras: usize) -> Self {
        Tally {
            sums: vec![(0.0, 0, [0.0; 2]); cameras],
        }
    }

    fn add(&mut self, fit: &Fit) {
        for (sum, c) in self.sums.iter_mut().zip(&fit.cameras) {
            let n = c.found as f64;
            sum.0 += n * c.residual_px.powi(2);
            sum.1 += c.found;
            sum.2[0] += n * c.shift_px[0];
            sum.2[1] += n * c.shift_px[1];
        }
    }

    fn summary(&self, camera: usize) -> OutlineResiduals {
        let (sq, found, shift) = self.sums[camera];
        let n = (found as f64).max(1.0);
        OutlineResiduals {
            rms_px: (sq / n).sqrt(),
            shift_px: [shift[0] / n, shift[1] / n],
            found,
        }
    }
}
