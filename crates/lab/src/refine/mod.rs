//! Camera poses refined from many tracked frames (`flexshape rig refine`).
//!
//! On a real rig a thin tube sits next to a few pixels of calibration error: every fit then
//! compromises between cameras that disagree, and its self-check calls the frames
//! `inconsistent`. The tubes of frames of different shapes pin the cameras down better than
//! one frame can: every frame is tracked with the rig's poses, and the poses and the tubes of
//! the frames every camera saw are then fitted together ([`flexshape_fit::TubeFitter::bundle`]).
//!
//! Which cameras move: as few as explain the frames. A knocked camera's frames are
//! `inconsistent` in every camera (the tube settles between them), so the outlines' residuals
//! do not say which one moved; refitting does. Every set of cameras (the rest held at the
//! rig's poses) is fitted once; a set explains the frames when its outline RMS is within
//! [`MIN_GAIN`] of the best any set gives. The smallest such set moves (one camera knocked is
//! likelier than two), and the cameras it holds keep the world frame where the calibration
//! put it. Other sets may explain the frames as well — with two cameras either may have
//! moved; with three, the two a knocked camera leaves can always be moved to agree with it —
//! and the report says so. A camera the user names (`hold`) is known to be right: the
//! smallest set that explains the frames without it moves instead. Every moved pose is drawn
//! toward the rig's ([`PosePrior`]): what the outlines hardly see stays as calibrated.

use flexshape_camera::Camera;
use flexshape_fit::{Bundle, Fit, PosePrior, Tube};
use flexshape_shape::Status;
use image::RgbImage;
use rayon::prelude::*;

use flexshape_track::{Pipeline, Tracked};

use crate::LabError;

mod report;

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
    /// Residuals of the same frames tracked from scratch with the refined poses.
    pub after: OutlineResiduals,
    /// Angle of the rotation from the rig's pose to the refined one, radians.
    pub rotation_rad: f64,
    /// How far the camera centre moved, mm (world).
    pub centre_moved_mm: f64,
    /// How well the frames pin the refined pose down: the 1-σ move of the camera along the
    /// least determined combination of its pose parameters, its turn counted as the move it
    /// makes at the tube, mm (0 for a held camera).
    pub sigma_mm: f64,
    /// How many of its pose's six directions the outlines pin down less well than the
    /// calibration does ([`PRIOR_PX`]): those were held as calibrated (0 for a held camera).
    pub held_directions: usize,
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
    /// Gauss–Newton steps of the joint fit.
    pub steps: usize,
    /// Other sets of cameras whose moving explains the frames as well as the cameras moved
    /// do (by name): the images cannot tell which moved, and the world frame stays with the
    /// cameras held — if one of those was knocked, the world moved with it (by about
    /// `world_open_mm`). Empty when the images decide.
    pub alternatives: Vec<Vec<String>>,
    /// How far the world frame may have moved, mm at the tubes, when the images could not
    /// tell which cameras moved (`alternatives`): the most a moved camera's new pose moves the
    /// tubes' points in its own frame, which holding it instead would have given the world
    /// frame. 0 when the images decided which moved.
    pub world_open_mm: f64,
}

/// The refined poses are worth using when they lower the outline RMS over all cameras by at
/// least this share: on a simulated rig that is right, refining from 20 frames lowered the RMS
/// by 2–4 % (fitting the noise) and moved a camera by 0.3 mm, and the tracked centerlines' error
/// grew from 0.029 to 0.060 mm (median).
pub const MIN_GAIN: f64 = 0.1;

impl Refinement {
    /// The refined rig of `original`: every camera at its refined pose, its file
    /// `calibration/NAME.yml` beside the rig file, with `volume`, `original`'s processing and
    /// its cameras' occlusion masks kept, and `[refined]` saying which cameras moved and how
    /// far the world frame may have.
    pub fn rig(
        &self,
        original: &flexshape_rig::Rig,
        volume: flexshape_rig::Volume,
    ) -> flexshape_rig::Rig {
        let processing = original.processing.clone();
        flexshape_rig::Rig {
            cameras: self
                .cameras
                .iter()
                .map(|c| flexshape_rig::RigCamera {
                    name: c.name.clone(),
                    file: refined_camera_file(&c.name),
                    camera: c.camera.clone(),
                    occluded: original.camera(&c.name).and_then(|o| o.occluded.clone()),
                })
                .collect(),
            volume,
            processing,
            refined: Some(flexshape_rig::Refined {
                moved: self
                    .cameras
                    .iter()
                    .filter(|c| !c.held)
                    .map(|c| c.name.clone())
                    .collect(),
                // To the micrometre: what the file says need not carry float noise.
                world_open_mm: (self.world_open_mm * 1e3).round() / 1e3,
            }),
        }
    }

    /// RMS of every camera's outline samples together, before and after, pixels.
    pub fn overall_rms(&self) -> (f64, f64) {
        let total = |f: fn(&CameraRefinement) -> &OutlineResiduals| {
            let (sq, n) = self
                .cameras
                .iter()
                .map(f)
                .fold((0.0, 0usize), |(sq, n), o| {
                    (sq + o.rms_px.powi(2) * o.found as f64, n + o.found)
                });
            (sq / (n as f64).max(1.0)).sqrt()
        };
        (total(|c| &c.before), total(|c| &c.after))
    }

    /// Whether the refined poses are worth using.
    pub fn verdict(&self) -> Verdict {
        let (before, after) = self.overall_rms();
        if after <= (1.0 - MIN_GAIN) * before && self.right_after >= self.right_before {
            Verdict::Better
        } else {
            Verdict::NoBetter
        }
    }
}

/// Whether a [`Refinement`] is worth using.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The refined poses explain the outlines clearly better: overall RMS lower by
    /// [`MIN_GAIN`] or more, no fewer frames right.
    Better,
    /// The rig's poses already explain them about as well: the refinement is within its own
    /// noise.
    NoBetter,
}

/// A calibrated pose's 1-σ error assumed where the rig does not say, pixels of its image at
/// the tube (each of its six directions): a target calibration reprojects to 0.1–0.3 px RMS,
/// and its poses are pinned less well than its points. Measured on simulated rigs with
/// cameras knocked 2 px (3 seeds each): one of three knocked is refined to 0.030–0.045 mm
/// whatever this is (0.1–4 px); where the outlines hardly see some directions (two cameras;
/// two of three knocked, the third held) 0.5 px left the shapes 0.33–0.89 mm off, 0.25 px
/// 0.43–0.80, 1 px 0.59–1.35, 4 px 1.7–2.1: held less, those directions drift with the noise
/// farther than the knock put them.
pub const PRIOR_PX: f64 = 0.5;

/// A boundary's scatter assumed when the tracked fits measured none, pixels.
const SIGMA_PX: f64 = 0.1;

/// Rigs with more cameras than this try only the sets of one or two cameras to move (and all
/// but the held one), not every set.
const EVERY_SET_UP_TO: usize = 4;

/// Passes at most: track every frame, fit the poses and the usable frames' tubes together.
/// A tube fitted with poses a few pixels off may be cut short where the hull broke; the next
/// pass starts from the frames tracked again with the refined poses.
const PASSES: usize = 3;

/// A pass that moved no camera by more than this (at 600 mm from it) ends the refinement, mm.
const SETTLED_MM: f64 = 0.05;

/// Fewest frames a refinement needs.
pub const MIN_FRAMES: usize = 3;

/// A frame is used when every camera found the boundary along at least this share of the
/// fitted tube's outline…
const MIN_FOUND: f64 = 0.5;

/// …and the re-rendered tube overlaps every silhouette at least this much.
const MIN_IOU: f64 = 0.5;

/// Where a refined rig keeps camera `name`'s file, relative to its rig file.
pub fn refined_camera_file(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from("calibration").join(format!("{name}.yml"))
}

/// Up to `wanted` frames of `source`, spread evenly over it when its length is known, read
/// and decoded for [`refine_cameras`]; frames that cannot be read or decoded are left out and
/// listed (`frame N: left out: why`). Stops with an error when the input breaks or `stop`
/// is set.
pub fn sample_frames(
    source: &mut dyn flexshape_input::FrameSource,
    pipeline: &Pipeline,
    wanted: usize,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<(Vec<Vec<RgbImage>>, Vec<String>), LabError> {
    let stride = source.len_hint().map_or(1, |n| n.div_ceil(wanted).max(1));
    let (mut frames, mut left_out) = (Vec::new(), Vec::new());
    let mut seen = 0usize;
    while let Some(next) = source.next_frame() {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(LabError::Refine(
                "interrupted while reading frames: nothing written".into(),
            ));
        }
        let index = seen;
        seen += 1;
        let set = match next {
            Ok(set) => set,
            Err(e) if e.ends_input() => {
                return Err(LabError::Refine(format!(
                    "the input broke after {index} frames: {e}"
                )));
            }
            Err(e) => {
                left_out.push(format!("frame {index}: left out: {e}"));
                continue;
            }
        };
        if !index.is_multiple_of(stride) {
            continue;
        }
        let frame = set.frame;
        match pipeline.load(set.images) {
            Ok((images, _)) => frames.push(images),
            Err(e) => left_out.push(format!("frame {frame:06}: left out: {e}")),
        }
        if frames.len() >= wanted {
            break;
        }
    }
    Ok((frames, left_out))
}

/// The poses of `pipeline`'s cameras refined from `frames` (each one image per camera, in the
/// rig's order): every frame is tracked, those whose tube every camera saw are kept, and the
/// poses of the cameras that must move (module doc; never `hold`, rig order, a camera known to
/// be right, when the others can explain the frames) and those tubes are fitted together.
/// Refused with fewer than [`MIN_FRAMES`] usable frames.
pub fn refine_cameras(
    pipeline: &Pipeline,
    frames: &[Vec<RgbImage>],
    hold: Option<usize>,
) -> Result<Refinement, LabError> {
    let names = pipeline.camera_names().to_vec();
    if let Some(hold) = hold.filter(|&h| h >= names.len()) {
        return Err(LabError::Refine(format!(
            "the camera to hold is number {} but the rig has {}",
            hold + 1,
            names.len()
        )));
    }
    if names.len() < 2 {
        return Err(LabError::Refine(
            "a rig of one camera has nothing to refine against".into(),
        ));
    }
    let fit_settings = pipeline.fit_settings();
    let fit_radius = pipeline.shape_settings().radius_mm.is_none() && fit_settings.fit_radius;
    let track = |p: &Pipeline| {
        frames
            .par_iter()
            .map(|f| p.process(&f.iter().collect::<Vec<_>>()))
            .collect::<Result<Vec<_>, _>>()
    };
    let mut tracked = track(pipeline)?;
    let right_before = tracked.iter().filter(|t| t.shape.status.is_right()).count();
    // The residuals are compared over the frames used at first.
    let (first, _) = usable_frames(&tracked);
    if first.len() < MIN_FRAMES {
        return Err(LabError::Refine(format!(
            "{} of {} frames have a fitted tube that every camera sees along most of its outline; at least {MIN_FRAMES} are needed (track the recording to see why frames fail: a tube that leaves a view, a camera off by more than the fit's search_px)",
            first.len(),
            frames.len()
        )));
    }
    let mut before = Tally::new(names.len());
    for fit in first.iter().filter_map(|&i| tracked[i].fit.as_ref()) {
        before.add(fit);
    }
    let prior = PosePrior {
        poses: pipeline.cameras(),
        prior_px: PRIOR_PX,
        sigma_px: boundary_scatter(first.iter().filter_map(|&i| tracked[i].fit.as_ref())),
    };
    let (free, mut first_pass, alternatives) = to_move(names.len(), hold, |free: &[usize]| {
        bundle_frames(pipeline, frames, &tracked, free, prior, fit_radius)
    })?;
    let alternatives: Vec<Vec<String>> = alternatives
        .iter()
        .map(|set| set.iter().map(|&c| names[c].clone()).collect())
        .collect();
    let mut current = pipeline.clone();
    let mut steps = 0;
    let mut sigma_mm = vec![0.0; names.len()];
    let mut held_directions = vec![0; names.len()];
    for _ in 0..PASSES {
        if free.is_empty() {
            break;
        }
        // From the last pass's poses, drawn toward the rig's (the first pass's, from the
        // rig's own, was fitted while choosing the cameras to move).
        let bundle = match first_pass.take() {
            Some(bundle) => bundle,
            None => bundle_frames(&current, frames, &tracked, &free, prior, fit_radius)?,
        };
        steps += bundle.steps;
        sigma_mm = bundle.sigma_mm;
        held_directions = bundle.held_directions;
        let moved = largest_move(current.cameras(), &bundle.cameras);
        current = current.with_cameras(bundle.cameras)?;
        // The frames tracked from scratch with the refined poses, as `track` will: whole
        // tubes where the rig's poses cut them short, the start of the next pass.
        tracked = track(&current)?;
        if moved < SETTLED_MM {
            break;
        }
    }
    let right_after = tracked.iter().filter(|t| t.shape.status.is_right()).count();
    let mut after = Tally::new(names.len());
    for fit in first.iter().filter_map(|&i| tracked[i].fit.as_ref()) {
        after.add(fit);
    }
    let cameras = current.cameras().to_vec();
    let rig_cameras = pipeline.cameras();
    // Where the other choice would have put the world frame: each moved camera's change of
    // pose as it sees the tubes (a world frame held by it instead moves them by as much).
    let world_open_mm = if alternatives.is_empty() {
        0.0
    } else {
        let points: Vec<_> = first
            .iter()
            .filter_map(|&i| tracked[i].fit.as_ref())
            .flat_map(|f| (0..=8).map(|k| f.tube.frame(k as f64 / 8.0).0))
            .collect();
        let (now, was) = (&cameras, rig_cameras);
        free.iter()
            .flat_map(|&c| {
                points
                    .iter()
                    .map(move |p| (now[c].pose.to_camera(p) - was[c].pose.to_camera(p)).norm())
            })
            .fold(0.0, f64::max)
    };
    Ok(Refinement {
        cameras: cameras
            .into_iter()
            .enumerate()
            .map(|(i, camera)| CameraRefinement {
                name: names[i].clone(),
                held: !free.contains(&i),
                before: before.summary(i),
                after: after.summary(i),
                rotation_rad: flexshape_camera::angle_between(
                    &rig_cameras[i].pose.rotation,
                    &camera.pose.rotation,
                ),
                centre_moved_mm: (camera.centre() - rig_cameras[i].centre()).norm(),
                sigma_mm: sigma_mm[i],
                held_directions: held_directions[i],
                camera,
            })
            .collect(),
        frames: frames.len(),
        used: first.len(),
        right_before,
        right_after,
        steps,
        alternatives,
        world_open_mm,
    })
}

/// [`to_move`]'s answer: the cameras to move, their fit from the rig's poses, and the
/// other sets of cameras that explain the frames as well.
type Choice = (Vec<usize>, Option<Bundle>, Vec<Vec<usize>>);

/// The cameras to move (rig order) and their fit, and the other sets that explain the frames
/// as well (module doc; none that merely adds cameras to the chosen one): `fit(set)` fits the
/// frames with that set free and the rest held. Every set up to all but one camera is tried
/// ([`EVERY_SET_UP_TO`]). Empty when the rig's poses already explain them.
fn to_move(
    cameras: usize,
    hold: Option<usize>,
    fit: impl Fn(&[usize]) -> Result<Bundle, flexshape_fit::FitError>,
) -> Result<Choice, LabError> {
    let mut sets: Vec<Vec<usize>> = if cameras <= EVERY_SET_UP_TO {
        (0..1u32 << cameras)
            .map(|bits| (0..cameras).filter(|c| bits >> c & 1 == 1).collect())
            .filter(|set: &Vec<usize>| set.len() < cameras)
            .collect()
    } else {
        let mut sets = vec![vec![]];
        for a in 0..cameras {
            sets.push(vec![a]);
            sets.extend((a + 1..cameras).map(|b| vec![a, b]));
            sets.push((0..cameras).filter(|&c| c != a).collect());
        }
        sets
    };
    sets.sort_by_key(|set| set.len());
    let tried = sets
        .into_iter()
        .map(|set| Ok((fit(&set)?, set)))
        .collect::<Result<Vec<_>, flexshape_fit::FitError>>()?;
    let best = tried
        .iter()
        .map(|t| t.0.rms_px)
        .fold(f64::INFINITY, f64::min);
    let mut explaining: Vec<(Bundle, Vec<usize>)> = tried
        .into_iter()
        .filter(|t| (1.0 - MIN_GAIN) * t.0.rms_px <= best)
        .collect();
    // Without the held camera if any set is; the smallest; with the rig's first camera held
    // where sets are alike (the one calibrations take as the reference); the lower RMS.
    let keeps = |set: &[usize], c: Option<usize>| c.is_some_and(|c| set.contains(&c));
    let any_without = explaining.iter().any(|t| !keeps(&t.1, hold));
    explaining.sort_by(|a, b| {
        (any_without && keeps(&a.1, hold))
            .cmp(&(any_without && keeps(&b.1, hold)))
            .then(a.1.len().cmp(&b.1.len()))
            .then(keeps(&a.1, Some(0)).cmp(&keeps(&b.1, Some(0))))
            .then(a.0.rms_px.total_cmp(&b.0.rms_px))
    });
    let mut sets = explaining.into_iter();
    let (bundle, chosen) = match sets.next() {
        Some((bundle, set)) => (Some(bundle), set),
        None => (None, Vec::new()),
    };
    // A camera the user holds is known to be right: sets moving it are no alternative.
    let others = sets
        .map(|t| t.1)
        .filter(|set| !chosen.iter().all(|c| set.contains(c)) && !keeps(set, hold))
        .collect();
    Ok((chosen, bundle, others))
}

/// The boundaries' scatter over the tracked fits: the median of their cameras' (or
/// [`SIGMA_PX`] where none was measured), pixels.
fn boundary_scatter<'a>(fits: impl Iterator<Item = &'a Fit>) -> f64 {
    let mut noise: Vec<f64> = fits
        .flat_map(|f| f.cameras.iter().map(|c| c.noise_px))
        .filter(|n| *n > 0.0)
        .collect();
    if noise.is_empty() {
        return SIGMA_PX;
    }
    let mid = noise.len() / 2;
    *noise.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The usable frames of `tracked` (indices) and their fitted tubes.
fn usable_frames(tracked: &[Tracked]) -> (Vec<usize>, Vec<Tube>) {
    tracked
        .iter()
        .enumerate()
        .filter_map(|(i, t)| {
            let fit = t.fit.as_ref().filter(|f| usable(f, &t.shape.status))?;
            Some((i, fit.tube.clone()))
        })
        .unzip()
}

/// The usable frames of `tracked` (`frames`' images) fitted together with the `free` cameras'
/// poses by `pipeline`'s fitter, from its poses ([`flexshape_fit::TubeFitter::bundle`]).
fn bundle_frames(
    pipeline: &Pipeline,
    frames: &[Vec<RgbImage>],
    tracked: &[Tracked],
    free: &[usize],
    prior: PosePrior<'_>,
    fit_radius: bool,
) -> Result<Bundle, flexshape_fit::FitError> {
    let (kept, tubes) = usable_frames(tracked);
    let images: Vec<Vec<&RgbImage>> = kept.iter().map(|&i| frames[i].iter().collect()).collect();
    let backgrounds = pipeline.backgrounds();
    let views: Vec<_> = kept
        .iter()
        .zip(&images)
        .map(|(&i, im)| pipeline.views(im, &tracked[i].silhouettes, &backgrounds))
        .collect();
    pipeline
        .fitter()
        .bundle(&views, &tubes, free, prior, fit_radius)
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

/// The largest move of a camera from `a` to `b`: its centre's, plus its turn at 600 mm, mm.
fn largest_move(a: &[Camera], b: &[Camera]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            (a.centre() - b.centre()).norm()
                + 600.0 * flexshape_camera::angle_between(&a.pose.rotation, &b.pose.rotation)
        })
        .fold(0.0, f64::max)
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
