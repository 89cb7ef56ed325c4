//! One frame through the sensing chain: silhouettes (cameras in parallel) → hierarchical
//! carving → marker bands → the hull's shape → the tube fitted to the images and checked
//! against them.
//!
//! Two-camera rigs: when the fit from the hull gives no right shape (the hull's ghosts mislead
//! its centerline), the fit starts again from the two silhouettes matched along epipolar
//! lines ([`TubeFitter::from_two_views`]).
//!
//! Tracking ([`Pipeline::process_after`]): when an earlier frame's shape was right (a
//! [`Prior`]), the frame starts from it instead: silhouettes only around the tube, no carve,
//! no hull, the fit warm-started. When that fit does not explain the images, the frame runs
//! the whole chain after all.

use std::sync::Arc;
use std::time::Instant;

use flexshape_camera::Camera;
use flexshape_carve::{
    Band, BandRule, HierarchicalCarver, Occupancy, OutsideImage, find_bands, shadow_carved,
};
use flexshape_fit::{AcrossTime, Fit, FitSettings, Method, Motion, Tube, TubeFitter, View};
use flexshape_input::FrameImage;
use flexshape_rig::{Rig, Volume};
use flexshape_shape::{ShapeEstimator, ShapeRecord, ShapeSettings, Status};
use flexshape_silhouette::{
    BackgroundModel, BitMask, GROWTH_FLOOR, Region, Silhouette, SilhouetteSettings,
    SilhouetteStatus, Silhouetter,
};
use image::RgbImage;
use rayon::prelude::*;

use crate::backdrop::{Backdrop, hull_pixels, models};
use crate::instants::{CameraTimes, Instants, MotionEstimate, judge_instant, largest_sigma};
use crate::state::{RunState, Shared, Turn};
use crate::usual::share;
use flexshape_record::{BackgroundUpdate, RecordStatus, StageTimings, Start};

use crate::TrackError;

/// What one frame gave at every stage.
#[derive(Debug, Clone)]
pub struct Tracked {
    /// Per camera, in the rig's order.
    pub silhouettes: Vec<Silhouette>,
    /// The carved voxels.
    pub occupancy: Occupancy,
    /// Marker bands in them.
    pub bands: Vec<Band>,
    /// The shape: fitted to the images (method `fit`), or the hull's.
    pub shape: ShapeRecord,
    /// The fitted tube and how well it explains each camera's image (method `fit`, when the
    /// hull gave a shape to start from).
    pub fit: Option<Fit>,
    /// Time per stage.
    pub timings: StageTimings,
    /// Where the fit started: the hull, or an earlier frame's shape (then nothing was carved
    /// and `occupancy` and `bands` are empty).
    pub start: Start,
    /// Voxels dropped from the hull as a sharp shadow's (see [`shadow_carved`]) before the
    /// shape was found again from the rest; 0 when the hull as carved gave the shape.
    pub shadow_voxels: usize,
    /// Cameras whose background took this frame's colours before the frame was processed
    /// again (see [`Pipeline::process`]).
    pub background_updated: Vec<BackgroundUpdate>,
    /// Cameras whose background, which had followed the backdrop, took the captured one back
    /// where this frame shows the backdrop as it was captured, before the frame was processed
    /// again (`changed_px`: the pixels taken back; see [`Pipeline::process`]).
    pub background_restored: Vec<BackgroundUpdate>,
    /// Whether the cameras captured together, or apart and how the fit dealt with it.
    pub instants: Instants,
}

/// One frame's visual hull ([`Pipeline::hull`]).
#[derive(Debug, Clone)]
pub struct Hull {
    /// Per camera, in the rig's order.
    pub silhouettes: Vec<Silhouette>,
    /// The carved voxels (none when a silhouette is implausible).
    pub occupancy: Occupancy,
    /// Why nothing was carved: a camera's silhouette covers more of its image than its
    /// `max_foreground`, or (for [`Pipeline::hull`]) many times its usual share.
    pub implausible: Option<String>,
    /// Why the frame is suspect though carved: a camera's silhouette covers more than
    /// `max_foreground_growth` times its usual share. The whole chain refuses the frame for it
    /// only when the tube fitted to it does not explain every camera.
    pub grown: Option<String>,
    /// Milliseconds of the silhouettes and the carving.
    pub timings: StageTimings,
}

/// The largest share of the working volume a tube's carved hull may fill; beyond it the
/// frame gets status `bad_silhouette` and no shape.
pub const MAX_HULL_SHARE: f64 = 0.1;

/// Fits across time for a frame whose cameras captured apart with no motion known: each
/// measures the motion again from the better shape. With two, shapes 60 Hz apart stayed
/// 0.11–0.15 mm RMS off (the motion measured from each fit keeps part of its error); with
/// four, 0.06, as a followed frame's.
const CARRY_ROUNDS: usize = 4;

/// A frame's shape that later frames may start from: one fitted to the images whose status
/// says it is right (`ok`, `bands_missing`, `leaves_volume`), and whose direction was decided
/// — or one whose cameras captured apart with no motion known well enough
/// ([`Instants::Unknown`]), from which the next frame measures it.
#[derive(Debug, Clone)]
pub struct Prior {
    record: ShapeRecord,
    tube: Tube,
    /// The tube fitted at `at_s` (`tube` may be it carried on to a later frame): what
    /// motions are measured from.
    fitted: Arc<Tube>,
    /// The instant the shape refers to, seconds (its frame's capture time), where known.
    at_s: Option<f64>,
    /// How far from `at_s` the shape may be, seconds (its frame's [`Instants::lag_s`]).
    lag_s: f64,
    /// How the tube moved into this shape from an earlier right one, where their instants are
    /// known ([`Prior::predicted`]).
    motion: Option<MotionEstimate>,
}

impl Prior {
    /// The fitted tube a later frame starts from.
    pub fn tube(&self) -> &Tube {
        &self.tube
    }

    /// This shape carried on as it moved since `earlier` ([`Tube::carried_on`]; `ratio`:
    /// frames from this shape to the one to start, over frames from `earlier` to this one).
    /// A start this close to where a smoothly moving tube is saves the fit a round of
    /// boundary measurements. `None` (start from this shape as it is) when the tubes do not
    /// pair up or the motion is a jerk. `slide_mm` and `limit_mm` as in [`Tube::carried_on`].
    /// The prediction also keeps the motion between the two when both instants are known
    /// (for frames whose cameras captured at different instants, [`CameraTimes`]).
    pub fn predicted(
        &self,
        earlier: &Prior,
        ratio: f64,
        slide_mm: f64,
        limit_mm: f64,
    ) -> Option<Prior> {
        let motion = self.motion_since(earlier);
        Some(Prior {
            record: self.record.clone(),
            tube: self
                .tube
                .carried_on(&earlier.tube, ratio, slide_mm, limit_mm)?,
            fitted: self.fitted.clone(),
            at_s: self.at_s,
            lag_s: self.lag_s,
            motion,
        })
    }

    /// `start` (this shape carried on, [`Prior::predicted`]) with the motion measured from
    /// `earlier` to this shape, when both instants are known and the tubes pair up (else
    /// `start` as it was): for cameras that captured apart, a motion over a longer time
    /// carries less of each shape's own error into the next. Its difference from `start`'s
    /// own motion (over a shorter time) says how far it may be off.
    pub fn moving_since(&self, earlier: &Prior, start: Prior) -> Prior {
        match self.motion_since(earlier) {
            Some(m) => {
                let m = match &start.motion {
                    Some(short) => m.compared_with(short),
                    None => m,
                };
                Prior {
                    motion: Some(m),
                    ..start
                }
            }
            None => start,
        }
    }

    /// The motion from `earlier` to this shape.
    fn motion_since(&self, earlier: &Prior) -> Option<MotionEstimate> {
        MotionEstimate::between(
            earlier,
            &self.fitted,
            self.at_s?,
            self.lag_s,
            self.sigma_mm(),
        )
    }

    /// The shape's largest 1-σ across the tube, mm.
    pub(crate) fn sigma_mm(&self) -> f64 {
        largest_sigma(&self.record)
    }

    /// The tube fitted at [`Prior::at_s`].
    pub(crate) fn fitted(&self) -> &Tube {
        &self.fitted
    }

    /// How far from [`Prior::at_s`] the shape may be, seconds.
    pub(crate) fn lag_s(&self) -> f64 {
        self.lag_s
    }

    /// This shape, said to be at `at_s` seconds (its frame's capture time, where known).
    pub fn at(self, at_s: Option<f64>) -> Prior {
        Prior { at_s, ..self }
    }

    /// The instant the shape refers to, seconds, where known.
    pub fn at_s(&self) -> Option<f64> {
        self.at_s
    }

    /// How the tube moved into this shape, where known.
    pub(crate) fn motion(&self) -> Option<&MotionEstimate> {
        self.motion.as_ref()
    }
}

impl Tracked {
    /// [`Tracked::prior`] at the instant its shape refers to, for a frame captured at `at_s`
    /// seconds (where known): a shape between its cameras' captures is at their middle.
    pub fn prior_at(&self, at_s: Option<f64>) -> Option<Prior> {
        let centre = self.instants.centre_s();
        Some(self.prior()?.at(at_s.map(|t| t + centre)))
    }

    /// What a later frame may start from, if this frame's shape is right.
    pub fn prior(&self) -> Option<Prior> {
        let fit = self.fit.as_ref()?;
        // A shape between its cameras' captures still starts the next frame, which measures
        // the motion from it.
        let usable =
            self.shape.status.is_right() || matches!(self.instants, Instants::Unknown { .. });
        (usable && self.shape.points.len() >= 2).then(|| Prior {
            record: self.shape.clone(),
            tube: fit.tube.clone(),
            fitted: Arc::new(fit.tube.clone()),
            at_s: None,
            lag_s: self.instants.lag_s(),
            motion: None,
        })
    }
}

/// The sensing chain, set up once per rig. Its state: each camera's usual silhouette share,
/// learned from the right frames it processes (see `max_foreground_growth`), and each
/// camera's background, which follows a changed backdrop (see [`Pipeline::process`]); a
/// clone keeps what was learned.
#[derive(Debug, Clone)]
pub struct Pipeline {
    names: Vec<String>,
    cameras: Vec<Camera>,
    carver: HierarchicalCarver,
    band_rule: BandRule,
    shape: ShapeEstimator,
    fitter: TubeFitter,
    /// Per camera, where something in front of the volume hides it (the rig's `occluded`
    /// masks, a pixel wider for the occluder's blurred edge): carved as if the tube were
    /// there, and left out of the fit and its check.
    hidden: Vec<Option<Arc<BitMask>>>,
    /// The backdrops, the silhouette shares of recent right frames and the bootstrap
    /// budget, as the frames processed so far left them.
    state: Shared,
}

impl Pipeline {
    /// The chain for `rig` (settings from its `[processing]` tables) carving `volume`, with one
    /// background model per camera in the rig's order.
    pub fn new(
        rig: &Rig,
        backgrounds: &[BackgroundModel],
        volume: &Volume,
    ) -> Result<Self, TrackError> {
        Self::with_silhouettes(rig, backgrounds, volume, |s| s)
    }

    /// Checks every stage's `[processing]` settings of `rig` as [`Pipeline::new`] does (the
    /// silhouettes' of every camera, the shape's, the fit's), without backgrounds or a
    /// volume: what `rig check` runs.
    pub fn check_settings(rig: &Rig) -> Result<(), TrackError> {
        check_tables(rig)?;
        for cam in &rig.cameras {
            SilhouetteSettings::from_processing(&rig.processing, &cam.name).map_err(|source| {
                TrackError::Silhouette {
                    camera: cam.name.clone(),
                    source,
                }
            })?;
        }
        ShapeEstimator::new(ShapeSettings::from_processing(&rig.processing)?)?;
        FitSettings::from_processing(&rig.processing)?.validate()?;
        Ok(())
    }

    /// The chain for frames that are masks — the object white (or light) on black, binary or
    /// 8-bit, as a lab's own segmentation writes them — instead of camera images: a pixel
    /// whose brightest channel reaches [`flexshape_silhouette::MASK_LEVEL`] is object, no
    /// background model is needed, no marker bands are read, and the image fit measures the
    /// outline on the mask itself. A binary mask places the outline only to within half a
    /// pixel, so the self-check allows a tenth of the outline up to [`MASK_P90_PX`] from it
    /// and twice the default 1-σ uncertainty (unless the rig allows more).
    pub fn for_masks(rig: &Rig, volume: &Volume) -> Result<Self, TrackError> {
        let black = rig
            .cameras
            .iter()
            .map(|c| {
                let (w, h) = (c.camera.intrinsics.width, c.camera.intrinsics.height);
                BackgroundModel::uniform(w, h, [0.0; 3], 0.0).map_err(|source| {
                    TrackError::Silhouette {
                        camera: c.name.clone(),
                        source,
                    }
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let pipeline =
            Self::with_silhouettes(rig, &black, volume, |s| SilhouetteSettings::for_masks(&s))?;
        let fit = pipeline.fit_settings();
        let settings = FitSettings {
            masks: true,
            max_p90_px: fit.max_p90_px.max(MASK_P90_PX),
            // The outline's noise doubles (measured: 0.2 px RMS against 0.1 from images), and
            // so does the uncertainty of a fit the cameras do pin down.
            max_sigma_mm: fit.max_sigma_mm.max(MASK_SIGMA_MM),
            ..fit.clone()
        };
        pipeline.with_fit_settings(settings)
    }

    fn with_silhouettes(
        rig: &Rig,
        backgrounds: &[BackgroundModel],
        volume: &Volume,
        adapt: impl Fn(SilhouetteSettings) -> SilhouetteSettings,
    ) -> Result<Self, TrackError> {
        check_tables(rig)?;
        if backgrounds.len() != rig.cameras.len() {
            return Err(TrackError::CameraCount {
                what: "background models",
                found: backgrounds.len(),
                expected: rig.cameras.len(),
            });
        }
        let backdrops = rig
            .cameras
            .iter()
            .zip(backgrounds)
            .map(|(cam, bg)| {
                let err = |source| TrackError::Silhouette {
                    camera: cam.name.clone(),
                    source,
                };
                let settings =
                    SilhouetteSettings::from_processing(&rig.processing, &cam.name).map_err(err)?;
                let silhouetter = Silhouetter::new(bg, adapt(settings)).map_err(err)?;
                Ok(Backdrop::new(bg.clone(), silhouetter))
            })
            .collect::<Result<Vec<_>, TrackError>>()?;
        let cameras: Vec<Camera> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
        let carver = HierarchicalCarver::new(&cameras, volume)?;
        let shape = ShapeEstimator::new(ShapeSettings::from_processing(&rig.processing)?)?;
        let names: Vec<String> = rig.cameras.iter().map(|c| c.name.clone()).collect();
        let fitter = TubeFitter::new(
            cameras.clone(),
            names.clone(),
            FitSettings::from_processing(&rig.processing)?,
        )?;
        let hidden = rig
            .cameras
            .iter()
            .map(|c| {
                c.occluded
                    .as_ref()
                    .map(|o| Arc::new(BitMask::from_gray(&o.mask).dilate(1)))
            })
            .collect();
        Ok(Pipeline {
            names,
            cameras,
            carver,
            band_rule: BandRule::default(),
            shape,
            fitter,
            hidden,
            state: Shared::new(RunState::new(backdrops)),
        })
    }

    /// The same chain with other poses or lenses for its cameras (rig order, same image sizes):
    /// carving and fit set up again, silhouettes and settings kept.
    pub fn with_cameras(&self, cameras: Vec<Camera>) -> Result<Self, TrackError> {
        if cameras.len() != self.cameras.len() {
            return Err(TrackError::CameraCount {
                what: "cameras",
                found: cameras.len(),
                expected: self.cameras.len(),
            });
        }
        let carver = HierarchicalCarver::new(&cameras, self.carver.volume())?;
        let fitter = TubeFitter::new(
            cameras.clone(),
            self.names.clone(),
            self.fitter.settings().clone(),
        )?;
        Ok(Pipeline {
            names: self.names.clone(),
            cameras,
            carver,
            band_rule: self.band_rule.clone(),
            shape: self.shape.clone(),
            fitter,
            hidden: self.hidden.clone(),
            state: self.state.clone(),
        })
    }

    /// A frame set's images decoded (in parallel) and checked against the cameras: one per
    /// camera, each of its calibrated size; else why not. Also a warning per camera whose
    /// frame is greyscale while its background model is in colour: colour cues (marker bands,
    /// colour matting) are lost and the silhouette differs from what the background expects.
    pub fn load(&self, images: Vec<FrameImage>) -> Result<(Vec<RgbImage>, Vec<String>), String> {
        if images.len() != self.names.len() {
            return Err(format!(
                "{} images for a rig of {} cameras",
                images.len(),
                self.names.len()
            ));
        }
        let loaded = images
            .into_par_iter()
            .zip(self.names.par_iter().zip(self.image_sizes()))
            .map(|(image, (name, size))| image.load_with_kind(name, size))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("cannot read the frame: {e}"))?;
        let warnings = loaded
            .iter()
            .zip(&self.names)
            .zip(self.state.get().backdrops)
            .filter(|(((_, grey), _), backdrop)| *grey && backdrop.colour)
            .map(|((_, name), _)| {
                format!(
                    "camera {name}: the frame is greyscale but its background is in colour: marker bands and colour cues are lost and the silhouette may be wrong; give frames as the camera takes them, or make the background from greyscale frames too"
                )
            })
            .collect();
        Ok((loaded.into_iter().map(|(i, _)| i).collect(), warnings))
    }

    /// Replaces the image fit's settings.
    pub fn with_fit_settings(mut self, settings: FitSettings) -> Result<Self, TrackError> {
        self.fitter = TubeFitter::new(self.cameras.clone(), self.names.clone(), settings)?;
        Ok(self)
    }

    /// The same chain following the tube from frame to frame (`follow`, as `track --follow`)
    /// or running the whole chain on every frame: see [`Pipeline::process_after`].
    pub fn following(self, follow: bool) -> Result<Self, TrackError> {
        let settings = FitSettings {
            track: follow,
            ..self.fit_settings().clone()
        };
        self.with_fit_settings(settings)
    }

    /// The run's state as the frames processed so far left it.
    pub(crate) fn run_state(&self) -> RunState {
        self.state.get()
    }

    /// Replaces the run's state (a run that makes its frames' changes in input order keeps
    /// the newest here, for [`Pipeline::backgrounds`] and what comes after the run).
    pub(crate) fn set_run_state(&self, state: RunState) {
        self.state.set(state);
    }

    /// The image fit (to re-render a fitted tube or see its outline residuals).
    pub fn fitter(&self) -> &TubeFitter {
        &self.fitter
    }

    /// Every camera's current background model (rig order): the captured one, or what it
    /// became where the backdrop changed since (see [`Pipeline::process`]).
    pub fn backgrounds(&self) -> Vec<Arc<BackgroundModel>> {
        models(&self.state.get().backdrops)
    }

    /// How the image fit sees a frame: each camera's image (rig order), background (e.g. from
    /// [`Pipeline::backgrounds`]), silhouette, and where the rig's occlusion mask hides the
    /// volume from it.
    pub fn views<'a>(
        &'a self,
        images: &[&'a RgbImage],
        silhouettes: &'a [Silhouette],
        backgrounds: &'a [Arc<BackgroundModel>],
    ) -> Vec<View<'a>> {
        images
            .iter()
            .zip(backgrounds)
            .zip(silhouettes)
            .zip(&self.hidden)
            .map(|(((image, bg), s), hidden)| View {
                image,
                background: bg.means(),
                silhouette: &s.object,
                markers: &s.markers,
                shadow_like: Some(&s.shadow_like),
                hidden: hidden.as_deref(),
            })
            .collect()
    }

    /// The image fit's settings (its `method` says whether the shape is fitted to the images).
    pub fn fit_settings(&self) -> &FitSettings {
        self.fitter.settings()
    }

    /// Replaces the shape stage's settings.
    pub fn with_shape_settings(mut self, settings: ShapeSettings) -> Result<Self, TrackError> {
        self.shape = ShapeEstimator::new(settings)?;
        Ok(self)
    }

    /// The shape stage's settings.
    pub fn shape_settings(&self) -> &ShapeSettings {
        self.shape.settings()
    }

    /// The cameras' names, in order.
    pub fn camera_names(&self) -> &[String] {
        &self.names
    }

    /// The calibrated image size (width, height) of every camera, in order.
    pub fn image_sizes(&self) -> Vec<(u32, u32)> {
        self.cameras
            .iter()
            .map(|c| (c.intrinsics.width, c.intrinsics.height))
            .collect()
    }

    /// The cameras, in order.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The carved volume.
    pub fn volume(&self) -> &Volume {
        self.carver.volume()
    }

    /// Whether frames may start from an earlier frame's shape: the fit is on, its `track`
    /// setting too, and at least two cameras see the tube. (With two, a followed fit starts
    /// from a right shape and moves a few millimetres at most, so the ghosts the two views
    /// allow elsewhere — which only the hull shows — never take it.)
    pub fn tracks(&self) -> bool {
        let s = self.fitter.settings();
        s.method == Method::Fit && s.track && self.cameras.len() >= 2
    }

    /// One frame (one image per camera, in the rig's order), started from `prior` when there
    /// is one and [`Pipeline::tracks`]: silhouettes only within the fit's `track_margin_px`
    /// of the prior tube's image, no carve, the tube fitted from the prior shape. When that
    /// fit does not explain the images (or finds nothing), the frame runs the whole chain
    /// ([`Pipeline::process`]) after all; the failed attempt's time counts in `fit`. So does a
    /// fit the cameras do not pin down (`ambiguous`): the hull may do better.
    pub fn process_after(
        &self,
        images: &[&RgbImage],
        prior: Option<&Prior>,
    ) -> Result<Tracked, TrackError> {
        self.process_after_at(images, prior, None)
    }

    /// As [`Pipeline::process_after`], for a frame whose cameras captured at `times` (where
    /// the input knows them): cameras that captured apart are each held to the tube where it
    /// was at their capture, carried by its motion since `prior` ([`CameraTimes`]), and the
    /// shape is the tube at the frame's instant; without a motion known, the shape lies
    /// between the instants and is not `ok` ([`Instants`]).
    pub fn process_after_at(
        &self,
        images: &[&RgbImage],
        prior: Option<&Prior>,
        times: Option<&CameraTimes>,
    ) -> Result<Tracked, TrackError> {
        let mut turn = Turn::new(self.state.get());
        let tracked = self.process_after_in(images, prior, times, &mut turn)?;
        self.state.apply(&turn.change);
        Ok(tracked)
    }

    /// As [`Pipeline::process_after_at`], reading and changing the run's state in `turn`
    /// only.
    pub(crate) fn process_after_in(
        &self,
        images: &[&RgbImage],
        prior: Option<&Prior>,
        times: Option<&CameraTimes>,
        turn: &mut Turn,
    ) -> Result<Tracked, TrackError> {
        let Some(prior) = prior.filter(|_| self.tracks()) else {
            let tracked = self.process_in(images, turn)?;
            return self.at_one_instant(images, tracked, prior, times, turn);
        };
        // Cameras that captured apart are held to the tube carried by its motion.
        let across = times.and_then(|t| {
            let estimate = prior.motion()?;
            let doubt_mm = estimate.doubt_mm(t.at_s, t.widest_offset_s());
            Some((t.across(&estimate.motion)?, doubt_mm))
        });
        self.check_count(images)?;
        let t = Instant::now();
        let margin = self.fitter.settings().track_margin_px;
        let backdrops = turn.state.backdrops.clone();
        let regions = self.fitter.image_regions(&prior.tube, margin);
        let silhouettes = backdrops
            .par_iter()
            .zip(images)
            .zip(&self.names)
            .zip(&regions)
            .map(|(((b, img), name), region)| {
                match region {
                    Some(rows) => b.silhouetter.process_within(img, rows),
                    None => b.silhouetter.process_within(img, &Region::ALL),
                }
                .map_err(|source| TrackError::Silhouette {
                    camera: name.clone(),
                    source,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let silhouettes_ms = ms(t);
        if self.grown(&silhouettes, &turn.state).is_some() {
            // The whole chain says so, with the whole images' shares.
            let mut full = self.process_in(images, turn)?;
            full.timings.silhouettes += silhouettes_ms;
            return self.at_one_instant(images, full, Some(prior), times, turn);
        }
        let t = Instant::now();
        let backgrounds = models(&backdrops);
        let views = self.views(images, &silhouettes, &backgrounds);
        let radius = self.shape.settings().radius_mm;
        let (shape, fit) = self.fitter.follow(
            &self.shape,
            self.carver.volume(),
            &views,
            &prior.record,
            (Some(&prior.tube), across.as_ref().map(|(a, _)| a)),
            radius,
        )?;
        let fit_ms = ms(t);
        // Anything but a right shape (one that does not explain the images, or that the
        // cameras do not pin down) is tried again from this frame's own hull.
        if fit.is_none() || !shape.status.is_right() {
            let mut full = self.process_in(images, turn)?;
            full.timings.fit += fit_ms + silhouettes_ms;
            return self.at_one_instant(images, full, Some(prior), times, turn);
        }
        turn.learn(&silhouettes);
        let mut followed = Tracked {
            silhouettes,
            occupancy: self.nothing_carved(),
            bands: Vec::new(),
            shape,
            fit,
            timings: StageTimings {
                silhouettes: silhouettes_ms,
                fit: fit_ms,
                ..StageTimings::default()
            },
            start: Start::Previous,
            shadow_voxels: 0,
            background_updated: Vec::new(),
            background_restored: Vec::new(),
            instants: Instants::Together,
        };
        if let Some((across, doubt_mm)) = &across {
            judge_instant(
                &mut followed,
                across,
                *doubt_mm,
                self.fit_settings().max_sigma_mm,
            );
        }
        // Apart, with no motion from the prior: measured from the prior to this fit.
        self.at_one_instant(images, followed, Some(prior), times, turn)
    }

    /// A frame whose cameras captured apart (`times`) and whose fit did not carry the tube to
    /// each camera's capture (a start without a motion, or the hull): the tube is fitted
    /// again from this fit, carried by the motion `prior` measured between two earlier shapes;
    /// without one, on three cameras or more, by the motion from `prior`'s shape to this fit,
    /// [`CARRY_ROUNDS`] times (each measuring it again from the better shape); otherwise the
    /// shape lies between the captures and the frame is `ambiguous`, saying so
    /// ([`Instants::Unknown`]), yet a start for the next. A frame the images refuse keeps its
    /// own reason unless the carried fit explains them.
    fn at_one_instant(
        &self,
        images: &[&RgbImage],
        mut tracked: Tracked,
        prior: Option<&Prior>,
        times: Option<&CameraTimes>,
        turn: &Turn,
    ) -> Result<Tracked, TrackError> {
        let Some(times) = times.filter(|t| t.apart()) else {
            return Ok(tracked);
        };
        if tracked.instants != Instants::Together {
            return Ok(tracked);
        }
        let Some(fitted) = tracked.fit.as_ref().map(|f| f.tube.clone()) else {
            return Ok(tracked);
        };
        let refused = !tracked.shape.status.is_right();
        let t = Instant::now();
        let carried = self.carried_across(images, &tracked, fitted, prior, times, turn)?;
        tracked.timings.fit += ms(t);
        match carried {
            // A fit the images refused keeps its own reason unless carrying explains them.
            Some((shape, _, _, _)) if refused && !shape.status.is_right() => {}
            Some((shape, fit, across, off_mm)) => {
                tracked.shape = shape;
                tracked.fit = Some(fit);
                judge_instant(
                    &mut tracked,
                    &across,
                    off_mm,
                    self.fit_settings().max_sigma_mm,
                );
            }
            None if refused => {}
            None => {
                tracked.shape.status = Status::Ambiguous {
                    reason: times.unknown_motion(),
                };
                let (centre_s, lag_s) = times.between_captures();
                tracked.instants = Instants::Unknown { lag_s, centre_s };
            }
        }
        Ok(tracked)
    }

    /// The fit of `tracked` (whose tube is `fitted`) carried across its cameras' captures
    /// ([`Pipeline::at_one_instant`]), with how far the motion that carried it may put it from
    /// the tube at the frame's instant, mm; `None` when nothing carries it (no motion, and an
    /// earlier shape only on two cameras or none) or no fit came of it.
    fn carried_across(
        &self,
        images: &[&RgbImage],
        tracked: &Tracked,
        fitted: Tube,
        prior: Option<&Prior>,
        times: &CameraTimes,
        turn: &Turn,
    ) -> Result<Option<(ShapeRecord, Fit, AcrossTime, f64)>, TrackError> {
        let motion = prior.and_then(Prior::motion);
        // Without one, a motion measured from the earlier shape to this frame's own fit, again
        // from each better one, on three cameras or more. Two cameras leave what each does not
        // see to the other's instant, so a fit carried by a motion measured from itself
        // settles wherever that motion puts it.
        let earlier = prior
            .and_then(|p| Some((p, times.at_s - p.at_s()?)))
            .filter(|(_, dt)| *dt > 0.0 && motion.is_none() && self.cameras.len() >= 3);
        if motion.is_none() && earlier.is_none() {
            return Ok(None);
        }
        let backgrounds = models(&turn.state.backdrops);
        let views = self.views(images, &tracked.silhouettes, &backgrounds);
        let radius = self.shape.settings().radius_mm;
        let carry = |tube: &Tube, across: &AcrossTime| {
            self.fitter.follow(
                &self.shape,
                self.carver.volume(),
                &views,
                &tracked.shape,
                (Some(tube), Some(across)),
                radius,
            )
        };
        let mut carried = None;
        if let Some(estimate) = motion {
            // The motion between two earlier shapes, as a followed frame uses it.
            if let Some(across) = times.across(&estimate.motion)
                && let (shape, Some(fit)) = carry(&fitted, &across)?
            {
                let off_mm = estimate.doubt_mm(times.at_s, times.widest_offset_s());
                carried = Some((shape, fit, across, off_mm));
            }
        } else if let Some((earlier, dt)) = earlier {
            let mut tube = fitted;
            let mut last = None;
            for _ in 0..CARRY_ROUNDS {
                let Some(across) =
                    Motion::between(earlier.fitted(), &tube, dt).and_then(|m| times.across(&m))
                else {
                    break;
                };
                let (shape, fit) = carry(&tube, &across)?;
                let Some(fit) = fit else { break };
                tube = fit.tube.clone();
                last = Some((shape, fit, across));
            }
            // The motion to the last fit, off by the earlier shape's own lag over the time
            // between, says how far that fit may be from the tube at the frame's instant.
            carried = last.map(|(shape, fit, across)| {
                let sigma = largest_sigma(&shape);
                let estimate = MotionEstimate::between(earlier, &tube, times.at_s, 0.0, sigma)
                    .unwrap_or(MotionEstimate {
                        motion: across.motion.clone(),
                        lag_share: earlier.lag_s / dt,
                        mid_s: times.at_s - dt / 2.0,
                        accel_mm_s2: 0.0,
                        noise_mm_s: 0.0,
                    });
                let off_mm = estimate.doubt_mm(times.at_s, times.widest_offset_s());
                (shape, fit, across, off_mm)
            });
        }
        Ok(carried)
    }

    /// Why a frame's silhouettes cannot be the tube's, if one camera's covers more of its
    /// image than its `max_foreground`.
    fn implausible(
        &self,
        silhouettes: &[Silhouette],
        backdrops: &[Arc<Backdrop>],
    ) -> Option<String> {
        silhouettes
            .iter()
            .zip(&self.names)
            .zip(backdrops)
            .find_map(|((s, name), b)| match s.status {
                SilhouetteStatus::Implausible { fraction } => Some(format!(
                    "camera {name}: {:.0} % of the image is foreground (at most {:.0} %): the background model does not describe the scene (a dark or changed backdrop, changed light, a moved camera); capture the background again or choose another classifier in [processing.silhouette]",
                    fraction * 100.0,
                    b.silhouetter.settings().max_foreground * 100.0
                )),
                _ => None,
            })
    }

    /// Why a frame's silhouettes cannot be the tube's, if one camera's covers more than its
    /// `max_foreground_growth` times its usual share (and [`GROWTH_FLOOR`] of the image more).
    fn grown(&self, silhouettes: &[Silhouette], state: &RunState) -> Option<String> {
        silhouettes
            .iter()
            .zip(&self.names)
            .zip(&state.backdrops)
            .enumerate()
            .find_map(|(i, ((s, name), b))| {
                let growth = b.silhouetter.settings().max_foreground_growth;
                let usual = state.usual_share(i)?;
                let now = share(s);
                (growth > 0.0 && now > growth * usual && now - usual > GROWTH_FLOOR).then(|| {
                    format!(
                        "camera {name}: {:.1} % of the image is foreground, {:.0}× its usual {:.2} % (the most of recent right frames; at most {growth}×) and the fitted tube does not explain every camera: the light changed or something entered the view; capture the background again if the scene changed ([processing.silhouette] max_foreground_growth sets the limit, 0 turns it off)",
                        now * 100.0,
                        now / usual.max(1e-12),
                        usual * 100.0
                    )
                })
            })
    }

    /// Why a frame's carved hull cannot be a tube's, if it fills more than [`MAX_HULL_SHARE`]
    /// of the working volume (a tube 600 mm long and 10 mm thick fills about 1 % of the
    /// default 256 mm cube; the hull of silhouettes that are mostly backdrop, or of a volume
    /// the cameras hardly see, fills a large part of it).
    fn hull_too_large(&self, occupancy: &Occupancy) -> Option<String> {
        let dims = occupancy.volume.dims;
        let total = dims.iter().map(|&d| d as f64).product::<f64>().max(1.0);
        let share = occupancy.voxels.len() as f64 / total;
        (share > MAX_HULL_SHARE).then(|| {
            format!(
                "the carved hull fills {:.0} % of the working volume (a tube fills a few percent at most, here at most {:.0} %): the silhouettes cover far more than the tube, or the cameras hardly see the volume; check the backgrounds (flexshape silhouettes) and the volume (flexshape rig check)",
                share * 100.0,
                MAX_HULL_SHARE * 100.0
            )
        })
    }

    /// The occupancy of a frame that was not carved.
    fn nothing_carved(&self) -> Occupancy {
        Occupancy {
            volume: *self.carver.volume(),
            voxels: Vec::new(),
        }
    }

    fn check_count(&self, images: &[&RgbImage]) -> Result<(), TrackError> {
        if images.len() != self.cameras.len() {
            return Err(TrackError::CameraCount {
                what: "images",
                found: images.len(),
                expected: self.cameras.len(),
            });
        }
        Ok(())
    }

    /// One frame's visual hull alone: silhouettes and carving, no bands, no shape — for
    /// objects that are not tubes (`flexshape carve`). Nothing is carved when a silhouette is
    /// implausible ([`Hull::implausible`] says why).
    pub fn hull(&self, images: &[&RgbImage]) -> Result<Hull, TrackError> {
        self.hull_with(images, &self.state.get(), Pass::Usual, false)
    }

    /// One frame's hull; a silhouette grown past its usual share is carved when `carve_grown`
    /// (a tube fitted to it may still explain every camera), else nothing is.
    fn hull_with(
        &self,
        images: &[&RgbImage],
        state: &RunState,
        pass: Pass,
        carve_grown: bool,
    ) -> Result<Hull, TrackError> {
        self.check_count(images)?;
        let t = Instant::now();
        let silhouettes = state
            .backdrops
            .par_iter()
            .zip(images)
            .zip(&self.names)
            .map(|((b, img), name)| {
                let silhouetter = match pass {
                    Pass::Usual => &b.silhouetter,
                    Pass::Bootstrap => b.bootstrap().unwrap_or(&b.silhouetter),
                };
                silhouetter
                    .process(img)
                    .map_err(|source| TrackError::Silhouette {
                        camera: name.clone(),
                        source,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let silhouettes_ms = ms(t);
        let implausible = self.implausible(&silhouettes, &state.backdrops);
        let grown = implausible
            .is_none()
            .then(|| self.grown(&silhouettes, state))
            .flatten();
        if implausible.is_some() || (grown.is_some() && !carve_grown) {
            return Ok(Hull {
                silhouettes,
                occupancy: self.nothing_carved(),
                implausible: implausible.or(grown),
                grown: None,
                timings: StageTimings {
                    silhouettes: silhouettes_ms,
                    ..StageTimings::default()
                },
            });
        }
        let t = Instant::now();
        let carved = self.carved(&silhouettes);
        let objects: Vec<_> = carved.iter().map(|c| c.as_ref()).collect();
        let mut occupancy = self.carver.carve(&objects, OutsideImage::Carve)?;
        if self.hidden.iter().any(Option::is_some) {
            // Where a camera cannot see, the others' ghosts stand too: only the parts that
            // reach what every camera carved are the tube's (behind the occluder it joins
            // them; a ghost apart from them is its other views' rays crossing).
            let seen: Vec<_> = silhouettes.iter().map(|s| &s.object).collect();
            let plain = self.carver.carve(&seen, OutsideImage::Carve)?;
            occupancy = occupancy.reaching(&plain);
        }
        Ok(Hull {
            silhouettes,
            occupancy,
            implausible: None,
            grown,
            timings: StageTimings {
                silhouettes: silhouettes_ms,
                carve: ms(t),
                ..StageTimings::default()
            },
        })
    }

    /// What each camera carves with: its silhouette's object, and where the camera cannot
    /// see into the volume (`hidden`), that too — it cannot say the tube is not there.
    fn carved<'a>(&self, silhouettes: &'a [Silhouette]) -> Vec<std::borrow::Cow<'a, BitMask>> {
        silhouettes
            .iter()
            .zip(&self.hidden)
            .map(|(s, hidden)| match hidden {
                Some(h) => std::borrow::Cow::Owned(s.object.or(h)),
                None => std::borrow::Cow::Borrowed(&s.object),
            })
            .collect()
    }

    /// One frame: one image per camera, in the rig's order, through the whole chain (the fit
    /// started from this frame's hull).
    ///
    /// A changed backdrop (cloth whose folds moved since the background was captured): when
    /// the fitted tube is where the images show it ([`TubeFitter::located`]) but some camera's
    /// image is not explained, that camera's background takes the frame's colours away from
    /// the tube ([`TubeFitter::tube_pixels`]; cameras whose settings `adapt`) and the frame is
    /// processed again; the record lists the cameras (`background_updated`).
    ///
    /// When the change is so large that the tube cannot be found at all (a backdrop grown
    /// brighter over much of the image gives a hull with branches), the tube is looked for
    /// once more with silhouettes that leave brightening out (colour classifier only, a few
    /// attempts in a row at most), and the backgrounds follow if that finds it; that attempt
    /// is never the frame's record.
    ///
    /// A background that followed its backdrop is taken back to the captured one, before any
    /// of that, where a frame that is not right shows the backdrop as captured and the
    /// followed background does not (a ghost; the record lists the cameras in
    /// `background_restored`): what the run learned never holds it away from what the images
    /// show. A silhouette grown past its usual share is carved and fitted all the same, and
    /// refused (`bad_silhouette`) only when the fitted tube does not explain every camera.
    pub fn process(&self, images: &[&RgbImage]) -> Result<Tracked, TrackError> {
        self.process_after(images, None)
    }

    /// As [`Pipeline::process`], reading and changing the run's state in `turn` only.
    fn process_in(&self, images: &[&RgbImage], turn: &mut Turn) -> Result<Tracked, TrackError> {
        let mut first = self.process_with(images, turn, Pass::Usual)?;
        let mut spent = StageTimings::default();
        let restored = if first.shape.status.is_right() {
            Vec::new()
        } else {
            self.restore_captured(images, &first.silhouettes, turn)?
        };
        if !restored.is_empty() {
            spent += first.timings;
            first = self.process_with(images, turn, Pass::Usual)?;
        }
        first.background_restored = restored;
        if first.shape.status.is_right() {
            turn.bootstrap_reset();
            first.timings += spent;
            return Ok(first);
        }
        spent += first.timings;
        let mut updated = self.follow_backdrop(images, &first, &first.silhouettes, turn, false)?;
        if updated.is_empty() && turn.state.bootstrap_allows() && self.adapts(&turn.state) {
            let found = self.process_with(images, turn, Pass::Bootstrap)?;
            spent += found.timings;
            updated = self.follow_backdrop(images, &found, &first.silhouettes, turn, true)?;
            if updated.is_empty() {
                turn.bootstrap_failed();
            }
        }
        if updated.is_empty() {
            return Ok(Tracked {
                timings: spent,
                ..first
            });
        }
        turn.bootstrap_reset();
        let mut again = self.process_with(images, turn, Pass::Usual)?;
        again.timings += spent;
        again.background_updated = updated;
        again.background_restored = first.background_restored;
        Ok(again)
    }

    /// Where a camera's background followed its backdrop but this frame shows the backdrop as
    /// it was captured, the captured background is taken back: the pixels the followed
    /// background takes for foreground (in `silhouettes`, the frame's own) whose colour is
    /// the captured background's (within what counts as changed), with a margin of
    /// [`GHOST_MARGIN_PX`]. That is a ghost — something a background took in that has left (a
    /// tube it took for backdrop, a hand) — or a backdrop changed back; the frame's own
    /// objects differ from both and stay. A ghost is foreground where no tube is, so the
    /// frames it spoils are the ones that take it back: what a run learned of its backdrops
    /// never holds it away from what the images show. Returns the cameras whose background
    /// changed.
    fn restore_captured(
        &self,
        images: &[&RgbImage],
        silhouettes: &[Silhouette],
        turn: &mut Turn,
    ) -> Result<Vec<BackgroundUpdate>, TrackError> {
        let (now, captured) = (turn.state.backdrops.clone(), turn.state.captured.clone());
        let mut restored = Vec::new();
        for (i, ((now, captured), silhouette)) in
            now.iter().zip(&captured).zip(silhouettes).enumerate()
        {
            if Arc::ptr_eq(now, captured) {
                continue;
            }
            let name = &self.names[i];
            let err = |source| TrackError::Silhouette {
                camera: name.clone(),
                source,
            };
            let ghost = silhouette
                .object
                .and(&captured.model.shown_by(images[i]).map_err(err)?);
            if ghost.count() == 0 {
                continue;
            }
            let mut model = (*now.model).clone();
            let taken_back = model
                .restore(&captured.model, &ghost.dilate(GHOST_MARGIN_PX))
                .map_err(err)?;
            if taken_back == 0 {
                continue;
            }
            let silhouetter =
                Silhouetter::new(&model, now.silhouetter.settings().clone()).map_err(err)?;
            turn.replace(i, Backdrop::new(model, silhouetter));
            restored.push(BackgroundUpdate {
                camera: name.clone(),
                changed_px: taken_back,
            });
        }
        Ok(restored)
    }

    /// Whether some camera's background may follow its backdrop.
    fn adapts(&self, state: &RunState) -> bool {
        state
            .backdrops
            .iter()
            .any(|b| b.silhouetter.settings().adapt)
    }

    /// Where `located`'s fitted tube is where the images show it: each camera's background
    /// takes the frame's colours away from the tube and from what was carved, if the fit does
    /// not explain the camera's image (or `every_camera`: the fit came from other silhouettes
    /// than the frame's own, `silhouettes`). Returns the cameras whose background changed.
    fn follow_backdrop(
        &self,
        images: &[&RgbImage],
        located: &Tracked,
        silhouettes: &[Silhouette],
        turn: &mut Turn,
        every_camera: bool,
    ) -> Result<Vec<BackgroundUpdate>, TrackError> {
        let Some(fit) = located
            .fit
            .as_ref()
            .filter(|f| self.fitter.located(f, self.carver.volume()))
        else {
            return Ok(Vec::new());
        };
        let backdrops = turn.state.backdrops.clone();
        let mut updated = Vec::new();
        for (i, check) in fit.cameras.iter().enumerate() {
            let (b, name) = (&backdrops[i], &self.names[i]);
            let settings = b.silhouetter.settings();
            if !settings.adapt || (!every_camera && self.fitter.explains(check)) {
                continue;
            }
            let Some(tube) = self
                .fitter
                .tube_pixels(i, &fit.tube, &silhouettes[i].object)
            else {
                continue;
            };
            let keep = tube.or(&hull_pixels(&self.cameras[i], &located.occupancy));
            let err = |source| TrackError::Silhouette {
                camera: name.clone(),
                source,
            };
            // A shadow is light, not backdrop: the tube's own moves with it, and a background
            // that took it in would hold it where the tube has left (a classifier that knows
            // shadows takes a soft one for backdrop as it is; a sharp one is dropped from each
            // frame's hull on its own, `without_shadows`).
            let keep = match b.silhouetter.shadowed(images[i]).map_err(err)? {
                Some(shadow) => keep.or(&shadow),
                None => keep,
            };
            let mut model = (*b.model).clone();
            let changed_px = model.absorb(images[i], &keep).map_err(err)?;
            if changed_px == 0 {
                continue;
            }
            let silhouetter = Silhouetter::new(&model, settings.clone()).map_err(err)?;
            turn.replace(i, Backdrop::new(model, silhouetter));
            updated.push(BackgroundUpdate {
                camera: name.clone(),
                changed_px,
            });
        }
        Ok(updated)
    }

    fn process_with(
        &self,
        images: &[&RgbImage],
        turn: &mut Turn,
        pass: Pass,
    ) -> Result<Tracked, TrackError> {
        let Hull {
            silhouettes,
            occupancy,
            implausible,
            grown,
            timings,
        } = self.hull_with(images, &turn.state, pass, true)?;
        let (silhouettes_ms, carve_ms) = (timings.silhouettes, timings.carve);
        if let Some(reason) = implausible.or_else(|| self.hull_too_large(&occupancy)) {
            return Ok(Tracked {
                silhouettes,
                occupancy,
                bands: Vec::new(),
                shape: ShapeRecord::empty(Status::BadSilhouette { reason }),
                fit: None,
                timings,
                start: Start::Hull,
                shadow_voxels: 0,
                background_updated: Vec::new(),
                background_restored: Vec::new(),
                instants: Instants::Together,
            });
        }
        let backgrounds = models(&turn.state.backdrops);
        let views = self.views(images, &silhouettes, &backgrounds);
        let mut shaped = self.shape_of(&views, &occupancy)?;
        let mut occupancy = occupancy;
        let mut shadow_voxels = 0;
        if !shaped.shape.status.is_right() {
            let t = Instant::now();
            match self.without_shadows(&views, &silhouettes, &occupancy)? {
                Some((kept, dropped, again)) => {
                    let mut spent = again.timings;
                    spent.carve = ms(t) - (spent.bands + spent.shape + spent.fit);
                    if again.shape.status.is_right() {
                        (occupancy, shadow_voxels) = (kept, dropped);
                        spent += shaped.timings;
                        shaped = Shaped {
                            timings: spent,
                            ..again
                        };
                    } else {
                        shaped.timings += spent;
                    }
                }
                None => shaped.timings.carve += ms(t),
            }
        }
        let Shaped {
            bands,
            shape,
            fit,
            start,
            timings: shape_timings,
        } = shaped;
        let mut timings = StageTimings {
            silhouettes: silhouettes_ms,
            carve: carve_ms,
            ..StageTimings::default()
        };
        timings += shape_timings;
        // A silhouette grown far past its usual share is the tube's own only when the tube
        // fitted to it explains every camera; otherwise the growth is the frame's verdict
        // (something entered the view), and its fit is no ground to follow a backdrop from.
        let (shape, fit) = match grown {
            Some(reason) if !shape.status.is_right() => {
                (ShapeRecord::empty(Status::BadSilhouette { reason }), None)
            }
            _ => (shape, fit),
        };
        if shape.status.is_right() && pass == Pass::Usual {
            turn.learn(&silhouettes);
        }
        Ok(Tracked {
            silhouettes,
            occupancy,
            bands,
            shape,
            fit,
            timings,
            start,
            shadow_voxels,
            background_updated: Vec::new(),
            background_restored: Vec::new(),
            instants: Instants::Together,
        })
    }

    /// The shape of a frame's hull: its bands, the hull's shape and (method `fit`) the tube
    /// fitted to `views` from it — or, when that is not right on a two-camera rig, from the
    /// two silhouettes themselves. Timings of the bands, the shape and the fit.
    fn shape_of(&self, views: &[View<'_>], occupancy: &Occupancy) -> Result<Shaped, TrackError> {
        let t = Instant::now();
        let markers: Vec<_> = views.iter().map(|v| v.markers).collect();
        let bands = find_bands(occupancy, &self.cameras, &markers, &self.band_rule)?;
        let bands_ms = ms(t);
        let t = Instant::now();
        let hull = self.shape.estimate(occupancy, &bands);
        let shape_ms = ms(t);
        let t = Instant::now();
        let mut start = Start::Hull;
        let (shape, fit) = match self.fitter.settings().method {
            Method::Hull => (hull, None),
            Method::Fit => {
                let radius = self.shape.settings().radius_mm;
                let (shape, fit) = self.fitted(views, occupancy, &hull)?;
                let (shape, fit) = if shape.status.is_right() {
                    (shape, fit)
                } else {
                    match self.across_gaps(views, occupancy, &bands)? {
                        Some(Chained::Shape(chained)) => *chained,
                        Some(Chained::Unshown(why)) => (with_reason(shape, &why), fit),
                        None => (shape, fit),
                    }
                };
                // Two cameras' hull grows ghosts its centerline may follow: a start from the
                // two silhouettes themselves may find the shape that explains them.
                let from_views = if shape.status.is_right() {
                    None
                } else {
                    self.fitter
                        .from_two_views(&self.shape, self.carver.volume(), views, radius)?
                };
                match from_views {
                    Some((shape, fit)) => {
                        start = Start::Views;
                        (shape, Some(fit))
                    }
                    None => (shape, fit),
                }
            }
        };
        Ok(Shaped {
            bands,
            shape,
            fit,
            start,
            timings: StageTimings {
                bands: bands_ms,
                shape: shape_ms,
                fit: ms(t),
                ..StageTimings::default()
            },
        })
    }

    /// The tube fitted to `views` from `hull`, the shape of `occupancy` (whose voxels judge the
    /// fit's ghosts), with the rig's radius where it gives one.
    fn fitted(
        &self,
        views: &[View<'_>],
        occupancy: &Occupancy,
        hull: &ShapeRecord,
    ) -> Result<(ShapeRecord, Option<Fit>), TrackError> {
        Ok(self.fitter.refine(
            &self.shape,
            self.carver.volume(),
            views,
            hull,
            &occupancy.centres(),
            self.shape.settings().radius_mm,
        )?)
    }

    /// A hull in pieces that lie end to end along one tube (a camera's silhouette lost a
    /// stretch of it): the tube fitted from the pieces chained across their gaps
    /// ([`ShapeEstimator::estimate_across_gaps`]) when its shape is right and every camera's
    /// image shows it across each gap ([`shown_across`]); when some image does not, why (the
    /// hull's own refusal, two separate objects, stands with it); nothing when the hull is not
    /// in such pieces or no right shape came of them.
    fn across_gaps(
        &self,
        views: &[View<'_>],
        occupancy: &Occupancy,
        bands: &[Band],
    ) -> Result<Option<Chained>, TrackError> {
        let Some((hull, gaps)) = self.shape.estimate_across_gaps(occupancy, bands) else {
            return Ok(None);
        };
        let (shape, fit) = self.fitted(views, occupancy, &hull)?;
        let Some(tube) = fit
            .as_ref()
            .filter(|_| shape.status.is_right())
            .map(|f| &f.tube)
        else {
            // Why the tube fitted through the gaps is not right, to add to the hull's refusal.
            let why = match &shape.status {
                Status::Ambiguous { reason }
                | Status::Inconsistent { reason }
                | Status::BadSilhouette { reason } => reason,
                _ => return Ok(None),
            };
            let length = |[a, b]: &[[f64; 3]; 2]| {
                ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt()
            };
            let gaps: Vec<String> = gaps.iter().map(|g| format!("{:.0}", length(g))).collect();
            return Ok(Some(Chained::Unshown(format!(
                "; end to end, they would be one tube across {} of {} mm, but the tube fitted through {} is {}: {why}",
                if gaps.len() == 1 { "a gap" } else { "gaps" },
                gaps.join(", "),
                if gaps.len() == 1 { "it" } else { "them" },
                RecordStatus::from(&shape.status).as_str()
            ))));
        };
        let min_found = self.fitter.settings().min_found;
        let stretches: Vec<_> = gaps.iter().map(|g| g.map(Into::into)).collect();
        let found_in = self.fitter.found_between(views, tube, &stretches)?;
        for ([a, b], found) in gaps.iter().zip(&found_in) {
            if !shown_across(found, min_found) {
                let middle: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k]) / 2.0);
                let gap = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt();
                let seen: Vec<String> = found
                    .iter()
                    .zip(&self.names)
                    .filter(|((_, all), _)| *all >= MIN_GAP_SAMPLES)
                    .map(|((found, all), name)| format!("{name} {found} of {all}"))
                    .collect();
                return Ok(Some(Chained::Unshown(format!(
                    "; end to end, they would be one tube across a gap of {gap:.0} mm at ({:.0}, {:.0}, {:.0}) mm, but the images do not show its outline there (found at {} samples; at least {:.0} % in every camera that sees it)",
                    middle[0],
                    middle[1],
                    middle[2],
                    seen.join(", "),
                    min_found * 100.0
                ))));
            }
        }
        Ok(Some(Chained::Shape(Box::new((shape, fit)))))
    }

    /// A frame whose shape is not right, once more from its hull without the voxels a sharp
    /// shadow carved ([`shadow_carved`]: held by shadow-coloured pixels in one camera and by
    /// the tube's colour in another): the hull kept, how many voxels were dropped, and its
    /// shape; `None` when no voxel is a shadow's. The shape is judged on every camera's image
    /// as any other (the shadow's pixels away from the tube are left out of the self-check
    /// already), and the hull kept no longer holds the shadow's ghost.
    fn without_shadows(
        &self,
        views: &[View<'_>],
        silhouettes: &[Silhouette],
        occupancy: &Occupancy,
    ) -> Result<Option<(Occupancy, usize, Shaped)>, TrackError> {
        let carved = self.carved(silhouettes);
        let objects: Vec<_> = carved.iter().map(|c| c.as_ref()).collect();
        let shadow_like: Vec<_> = silhouettes.iter().map(|s| &s.shadow_like).collect();
        let dropped = shadow_carved(
            &self.carver,
            occupancy,
            &objects,
            &shadow_like,
            OutsideImage::Carve,
        )?;
        if dropped.is_empty() {
            return Ok(None);
        }
        let kept = occupancy.without(&dropped);
        let shaped = self.shape_of(views, &kept)?;
        Ok(Some((kept, dropped.len(), shaped)))
    }
}

/// What came of a hull in pieces chained across its gaps ([`Pipeline::across_gaps`]).
enum Chained {
    /// The tube fitted through them, right, and shown across every gap.
    Shape(Box<(ShapeRecord, Option<Fit>)>),
    /// Why not: an image does not show the tube across a gap (to add to the hull's refusal).
    Unshown(String),
}

/// `shape` with `more` added to its refusal's reason (an `ambiguous` or `inconsistent` one;
/// any other is returned as it is).
fn with_reason(mut shape: ShapeRecord, more: &str) -> ShapeRecord {
    if let Status::Ambiguous { reason } | Status::Inconsistent { reason } = &mut shape.status {
        reason.push_str(more);
    }
    shape
}

/// Fewest outline samples a camera must have along a gap between pieces of the hull for its
/// image to count as showing the tube there or not: fewer, it sees the gap nearly end-on.
const MIN_GAP_SAMPLES: usize = 4;

/// Whether the images show the tube across a gap between pieces of its hull, from each
/// camera's (found, samples) along it ([`TubeFitter::found_between`]): every camera that sees
/// the gap ([`MIN_GAP_SAMPLES`]) finds the tube's boundary at `min_found` of its samples there,
/// as the self-check asks of a whole outline, and one camera at least sees it. Where the tube
/// lies along that camera's rays the tube fitted through the gap holds by its pieces on either
/// side, and the fit's own 1-σ across the tube there says how firmly (`max_sigma_mm`): the
/// other cameras' samples over a backdrop of the tube's colour (why their silhouettes lost the
/// stretch) show it neither way. A real gap shows the backdrop in every camera that sees it.
fn shown_across(found: &[(usize, usize)], min_found: f64) -> bool {
    let seeing: Vec<_> = found
        .iter()
        .filter(|(_, all)| *all >= MIN_GAP_SAMPLES)
        .collect();
    !seeing.is_empty()
        && seeing
            .iter()
            .all(|&&(found, all)| found as f64 >= min_found * all as f64)
}

/// A frame's shape from its hull ([`Pipeline::shape_of`]).
struct Shaped {
    bands: Vec<Band>,
    shape: ShapeRecord,
    fit: Option<Fit>,
    start: Start,
    /// Of the bands, the shape and the fit.
    timings: StageTimings,
}

/// Which silhouettes a pass through the whole chain uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// Each camera's own.
    Usual,
    /// Those that leave a brightened backdrop out ([`Backdrop::bootstrap`]), to find the
    /// tube in front of a changed backdrop.
    Bootstrap,
}

/// Pixels around a ghost that take the captured background back with it: a ghost's edge was
/// taken in smoothed over a few pixels (see [`BackgroundModel::absorb`]).
const GHOST_MARGIN_PX: usize = 2;

/// The loosest 1-σ across the tube, mm, at which a shape fitted to binary masks is still
/// pinned down (`max_sigma_mm` at least this): a mask's outline scatters twice as far as an
/// image's (0.2 px RMS against 0.1), and so does the σ of a shape the cameras hold as firmly.
/// Set at twice the 0.1 mm images were held to when drawn masks were measured (18 of 24
/// frames `ok`, every one right); left there when images went to 0.15 mm, as no drawn-mask
/// frame is refused for its σ.
const MASK_SIGMA_MM: f64 = 0.2;

/// The self-check's 90th percentile of outline residuals for frames that are binary masks,
/// pixels: their boundary lies on pixel edges, up to half a pixel from the true outline.
pub const MASK_P90_PX: f64 = 0.5;

/// The stages that read a table of a rig's `[processing]`.
const STAGES: [&str; 3] = ["silhouette", "shape", "fit"];

/// Whether every table of `rig`'s `[processing]` is a stage's, and every camera a
/// `[processing.silhouette.per_camera]` table names is the rig's: a misspelled table's
/// settings would be ignored, values and all (the tables' own keys are checked by each
/// stage).
fn check_tables(rig: &Rig) -> Result<(), TrackError> {
    let wrong = |table: String, problem: String| Err(TrackError::Processing { table, problem });
    if let Some(key) = rig
        .processing
        .keys()
        .find(|k| !STAGES.contains(&k.as_str()))
    {
        return wrong(
            format!("processing.{key}"),
            format!(
                "no stage reads this table (the stages are {}): a typo?",
                STAGES.join(", ")
            ),
        );
    }
    let per_camera = match rig.processing.get("silhouette") {
        Some(toml::Value::Table(t)) => t.get("per_camera"),
        _ => None,
    };
    if let Some(toml::Value::Table(cams)) = per_camera
        && let Some(name) = cams
            .keys()
            .find(|n| !rig.cameras.iter().any(|c| &c.name == *n))
    {
        let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
        return wrong(
            format!("processing.silhouette.per_camera.{name}"),
            format!(
                "the rig has no camera {name:?} (its cameras: {}; names are case-sensitive)",
                names.join(", ")
            ),
        );
    }
    Ok(())
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}
