//! The JSON Lines records of `flexshape track`: one per frame, then one summary. The fields
//! documented in `docs/formats.md` are a stable contract; others may be added. World frame,
//! mm, radians.

use flexshape_fit::CameraCheck;
use flexshape_recording::{Command, PoseRole};
use flexshape_shape::Status;
use serde::{Deserialize, Serialize};

use crate::backdrop::BackgroundUpdate;
use crate::camera_clocks::{CameraClock, ClockTally};
use crate::instants::Instants;
use crate::pipeline::{StageTimings, Start, Tracked};
use crate::runner::{Processed, RunEnd};
use crate::status::RecordStatus;

/// A band on the centerline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackBand {
    /// Centre, world mm.
    #[serde(serialize_with = "crate::precision::point")]
    pub position: [f64; 3],
    /// Arc length of the centre from the proximal end, mm.
    #[serde(serialize_with = "crate::precision::mm")]
    pub arc_length: f64,
}

/// The circular-arc fit of the bending section, in world coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackArcFit {
    /// Curvature, 1/mm.
    #[serde(serialize_with = "crate::precision::per_mm")]
    pub curvature: f64,
    /// Start of the section, world mm.
    #[serde(serialize_with = "crate::precision::point")]
    pub base: [f64; 3],
    /// Unit tangent at the start.
    #[serde(serialize_with = "crate::precision::unit")]
    pub base_tangent: [f64; 3],
    /// Unit direction toward which the section bends, perpendicular to the tangent.
    #[serde(serialize_with = "crate::precision::unit")]
    pub bend_direction: [f64; 3],
    /// Mean distance between the curve and the arc, mm.
    #[serde(serialize_with = "crate::precision::mm")]
    pub residual_mm: f64,
    /// Section length, mm.
    #[serde(serialize_with = "crate::precision::mm")]
    pub length: f64,
    /// Curvature about the manipulator model's x axis, 1/mm (with a registered model frame).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::per_mm_opt"
    )]
    pub kappa_x: Option<f64>,
    /// Curvature about the model's z axis, 1/mm (with a registered model frame).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::per_mm_opt"
    )]
    pub kappa_z: Option<f64>,
}

/// The manipulator model's frame registered to the world (`flexshape model fit --save-frame`
/// writes it): with it, arc fits also give κx and κz as the model defines them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFrame {
    /// Model frame → world rotation, rows (the columns are the model's x, y, z axes in world;
    /// y runs along the proximal section toward the tip).
    pub rotation: [[f64; 3]; 3],
    /// The bending base of the relaxed reference pose, world mm, if one was sensed.
    #[serde(default)]
    pub reference_base: Option<[f64; 3]>,
    /// Registration residuals, degrees: base axis, bending directions.
    #[serde(default)]
    pub residual_deg: [f64; 2],
}

impl ModelFrame {
    /// Checks that `rotation` is a proper rotation (orthonormal to 1e-6, determinant +1).
    pub fn validate(&self) -> Result<(), String> {
        let r = &self.rotation;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                if !dot.is_finite() || (dot - want).abs() > 1e-6 {
                    return Err(format!(
                        "`rotation` is not orthonormal (columns {i}·{j} = {dot:.6})"
                    ));
                }
            }
        }
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
            - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        if det < 0.0 {
            return Err("`rotation` is a reflection (determinant −1)".into());
        }
        Ok(())
    }

    /// `[κx, κz]` of an arc fit in the model frame, 1/mm: the world curvature vector (the arc's
    /// rotation axis, tangent × bend direction, times its curvature) turned into the model.
    pub fn kappa(&self, fit: &TrackArcFit) -> [f64; 2] {
        let (t, b) = (fit.base_tangent, fit.bend_direction);
        let axis = [
            t[1] * b[2] - t[2] * b[1],
            t[2] * b[0] - t[0] * b[2],
            t[0] * b[1] - t[1] * b[0],
        ];
        let r = &self.rotation;
        // Rᵀ · axis · κ, components x and z.
        let component = |c: usize| (0..3).map(|k| r[k][c] * axis[k]).sum::<f64>() * fit.curvature;
        [component(0), component(2)]
    }
}

/// One frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackRecord {
    /// Frame number.
    pub frame: u64,
    /// `ok`, `no_object`, `ambiguous`, `leaves_volume`, `inconsistent`, `bad_silhouette`,
    /// `bands_missing` or `error`.
    pub status: RecordStatus,
    /// Why, when the status is not `ok`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Points from the proximal end to the tip, ≤ 1 mm apart, world mm.
    #[serde(serialize_with = "crate::precision::points")]
    pub centerline: Vec<[f64; 3]>,
    /// The centerline's end, world mm.
    #[serde(serialize_with = "crate::precision::point_opt")]
    pub tip: Option<[f64; 3]>,
    /// Unit tangent at the tip.
    #[serde(serialize_with = "crate::precision::unit_opt")]
    pub tip_direction: Option<[f64; 3]>,
    /// Centerline length, mm.
    #[serde(serialize_with = "crate::precision::mm")]
    pub arc_length: f64,
    /// Bands from proximal to distal.
    pub bands: Vec<TrackBand>,
    /// The bending section's arc fit.
    pub arc_fit: Option<TrackArcFit>,
    /// Occupied voxels (0 when nothing was carved: `start` = `previous`).
    pub voxels: usize,
    /// Milliseconds per stage.
    pub timings_ms: StageTimings,
    /// Curvature at each centerline point, 1/mm (additive).
    #[serde(default, serialize_with = "crate::precision::per_mm_vec")]
    pub curvature: Vec<f64>,
    /// Axial strains of the sections named in `[processing.shape]` (e.g. the bending
    /// section's, between its bands).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub compression: Vec<TrackCompression>,
    /// The tendon displacements commanded for this frame (mm), when the recording has them
    /// (`commands/`): what `flexshape model fit` pairs with the shape.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tendon_displacements: Option<Vec<f64>>,
    /// The frame's role in a model experiment, with `tendon_displacements`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub role: Option<PoseRole>,
    /// The input's name of the frame (plain image folders: the file name without extension).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// From capture (live) or reading (offline) to the end of the chain, ms.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::ms_opt"
    )]
    pub latency_ms: Option<f64>,
    /// When the frame was captured, seconds since the Unix epoch (UTC) — from a recording's
    /// `timestamps.csv`, a video's timeline or a caller, in that time base — where the input
    /// knows it (additive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub captured_s: Option<f64>,
    /// Where `captured_s` comes from: `clock` (live network cameras and the simulator: the
    /// wall clock when the frame arrived), `timestamps` (the recording's `timestamps.csv`),
    /// `file_time` (the first camera's image file's modification time), `stream` (videos'
    /// timelines, live devices' driver timestamps) or `given` (the Python `Tracker`'s caller).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub captured_from: Option<String>,
    /// Each camera's own capture time, rig order, seconds in `captured_s`'s time base, where
    /// the input knows them (a recording's `timestamps/<cam>.csv`): cameras that
    /// are not triggered together see the tube at these instants (additive; empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub camera_captured_s: Vec<f64>,
    /// When the chain finished the frame, seconds since the Unix epoch (UTC) (additive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub processed_s: Option<f64>,
    /// How the centerline was found: `fit` (the tube fitted to every camera's outline) or
    /// `hull` (the visual hull's centerline alone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Tube radius, mm: fitted to the images, given in the rig, or the hull's estimate.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::mm_opt"
    )]
    pub radius: Option<f64>,
    /// Where the tube steps up in radius going back from the tip, and the radius behind each
    /// step, mm (a rig with `radius_steps`: as given, or fitted to the images when the rig
    /// gives no `radius_mm`; `radius` is then the tip section's).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        serialize_with = "crate::precision::steps"
    )]
    pub radius_steps: Vec<flexshape_curve::RadiusStep>,
    /// 1-σ uncertainty of each centerline point across the tube, mm (method `fit`), from the
    /// fit's normal equations: how much a controller may trust each point.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        serialize_with = "crate::precision::mm_vec"
    )]
    pub centerline_sigma: Vec<f64>,
    /// How well the fitted tube explains each camera's image (method `fit`), in the rig's
    /// order: outline residuals, their systematic offset, overlap with the silhouette.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<CameraCheck>,
    /// Carved hull away from the fitted tube, as a length of tube, mm (method `fit`): where the
    /// images would allow the tube to be instead; beyond the rig's limit the status is
    /// `ambiguous`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::mm_opt"
    )]
    pub ghost_mm: Option<f64>,
    /// With cameras that captured apart (`camera_captured_s`), fitted across time: the
    /// farthest the tube was carried by its recent motion for a camera, mm — each camera was
    /// held to the tube where it was at its capture, and the shape is the tube at
    /// `captured_s` (additive; absent when the cameras captured together or the motion was
    /// not known, which the status then says).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::mm_opt"
    )]
    pub carried_mm: Option<f64>,
    /// With cameras that captured apart and the tube's motion between their captures not
    /// known well enough (status `ambiguous`): how far from `captured_s` the shape may be, ms
    /// (additive).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "crate::precision::ms_opt"
    )]
    pub lag_ms: Option<f64>,
    /// Where the fit started: `hull` (this frame's visual hull, carved) or `previous` (an
    /// earlier frame's shape, tracking: nothing carved, `voxels` is 0 and `ghost_mm` absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
    /// Voxels dropped from the hull as a sharp shadow's before the shape was found from the
    /// rest: held in one camera by pixels of the backdrop's colour, darker (a shadow cast on
    /// it), and in another by the tube's own colour (absent: none, the hull as carved gave
    /// the shape).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shadow_voxels: usize,
    /// Cameras whose background took this frame's colours away from the tube, the backdrop
    /// having changed since the background was captured; the frame was then processed again
    /// (absent: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub background_updated: Vec<BackgroundUpdate>,
    /// Cameras whose background, having followed the backdrop, took the captured background
    /// back where this frame shows the backdrop as captured (a ghost of something it had taken
    /// in; `changed_px`: the pixels taken back); the frame was then processed again (absent:
    /// none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub background_restored: Vec<BackgroundUpdate>,
    /// Nothing told the proximal end from the tip, so the centerline's direction is a guess
    /// and the status `ambiguous` (absent: false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub direction_guessed: bool,
}

/// A measured axial strain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackCompression {
    /// The section's name.
    pub name: String,
    /// `1 − length / nominal` (compression positive).
    #[serde(serialize_with = "crate::precision::fraction")]
    pub strain: f64,
    /// Measured length, mm.
    #[serde(serialize_with = "crate::precision::mm")]
    pub length: f64,
}

impl TrackRecord {
    /// The record of a processed frame.
    pub fn from_tracked(frame: u64, t: &Tracked) -> Self {
        let s = &t.shape;
        let reason = match &s.status {
            Status::Ok => None,
            Status::NoObject { voxels } => Some(format!("{voxels} voxels carved")),
            Status::Ambiguous { reason }
            | Status::Inconsistent { reason }
            | Status::BadSilhouette { reason } => Some(reason.clone()),
            Status::LeavesVolume => {
                Some("the tube leaves the volume: the tip is outside it; enlarge the volume".into())
            }
            Status::BandsMissing { found, expected } => {
                Some(format!("{found} of {expected} bands found"))
            }
        };
        let status = RecordStatus::from(&s.status);
        let has_shape = !s.points.is_empty();
        let arc_fit = s.arc_fit.as_ref().map(|f| {
            let [x, y, z] = f.axes;
            let k = f.curvature.max(1e-300);
            // The bend direction is (−κz, 0, κx)/κ in the section frame.
            let (bx, bz) = (-f.kappa[1] / k, f.kappa[0] / k);
            TrackArcFit {
                curvature: f.curvature,
                base: f.origin,
                base_tangent: y,
                bend_direction: std::array::from_fn(|i| bx * x[i] + bz * z[i]),
                residual_mm: f.residual_mean,
                length: f.length,
                kappa_x: None,
                kappa_z: None,
            }
        });
        TrackRecord {
            frame,
            status,
            reason,
            centerline: s.points.clone(),
            tip: has_shape.then_some(s.tip),
            tip_direction: has_shape.then_some(s.tip_direction),
            arc_length: s.length,
            bands: s
                .bands
                .iter()
                .map(|b| TrackBand {
                    position: b.position,
                    arc_length: b.arc_length,
                })
                .collect(),
            arc_fit,
            voxels: t.occupancy.len(),
            timings_ms: t.timings,
            curvature: s.curvature.clone(),
            compression: s
                .compression
                .iter()
                .map(|c| TrackCompression {
                    name: c.name.clone(),
                    strain: c.strain,
                    length: c.length,
                })
                .collect(),
            tendon_displacements: None,
            role: None,
            image: None,
            latency_ms: None,
            captured_s: None,
            captured_from: None,
            camera_captured_s: Vec::new(),
            processed_s: None,
            method: Some(if t.fit.is_some() { "fit" } else { "hull" }.into()),
            radius: has_shape.then_some(s.radius),
            radius_steps: t
                .fit
                .as_ref()
                .filter(|_| has_shape)
                .map_or_else(Vec::new, |f| f.tube.steps.clone()),
            centerline_sigma: s.sigma.clone(),
            cameras: t.fit.as_ref().map_or_else(Vec::new, |f| f.cameras.clone()),
            ghost_mm: t.fit.as_ref().and_then(|f| f.ghost_mm),
            carried_mm: match t.instants {
                Instants::Carried { shift_mm } => Some(shift_mm),
                _ => None,
            },
            lag_ms: match t.instants {
                Instants::Unknown { lag_s, centre_s } => Some((centre_s.abs() + lag_s) * 1e3),
                _ => None,
            },
            start: t.fit.as_ref().map(|_| {
                match t.start {
                    Start::Hull => "hull",
                    Start::Previous => "previous",
                    Start::Views => "views",
                }
                .into()
            }),
            background_updated: t.background_updated.clone(),
            shadow_voxels: t.shadow_voxels,
            background_restored: t.background_restored.clone(),
            direction_guessed: s.direction_guessed,
        }
    }

    /// Attaches the frame's commanded tendon displacements.
    pub fn with_command(mut self, command: Option<Command>) -> Self {
        if let Some(c) = command {
            self.tendon_displacements = Some(c.tendon_displacements);
            self.role = Some(c.role);
        }
        self
    }

    /// Adds κx, κz in the model frame to the arc fit, if there is one.
    pub fn with_model_frame(mut self, frame: &ModelFrame) -> Self {
        if let Some(fit) = &mut self.arc_fit {
            let [kx, kz] = frame.kappa(fit);
            (fit.kappa_x, fit.kappa_z) = (Some(kx), Some(kz));
        }
        self
    }

    /// The record of a frame from the runner: its shape or its error, command, name and
    /// latency.
    pub fn from_processed(p: &Processed) -> Self {
        let record = match &p.result {
            Ok(t) => TrackRecord::from_tracked(p.frame, t),
            Err(e) => TrackRecord::error(p.frame, e.clone()),
        };
        TrackRecord {
            image: p.name.clone(),
            latency_ms: Some(p.latency_ms),
            captured_s: p.capture_time.map(|c| c.seconds),
            captured_from: p.capture_time.map(|c| c.source.name().to_string()),
            camera_captured_s: p.camera_times.clone().unwrap_or_default(),
            processed_s: p.processed_s,
            ..record.with_command(p.command.clone())
        }
    }

    /// The record of a frame that could not be processed.
    pub fn error(frame: u64, reason: String) -> Self {
        TrackRecord {
            frame,
            status: RecordStatus::Error,
            reason: Some(reason),
            centerline: Vec::new(),
            tip: None,
            tip_direction: None,
            arc_length: 0.0,
            bands: Vec::new(),
            arc_fit: None,
            voxels: 0,
            timings_ms: StageTimings::default(),
            curvature: Vec::new(),
            compression: Vec::new(),
            tendon_displacements: None,
            role: None,
            image: None,
            latency_ms: None,
            captured_s: None,
            captured_from: None,
            camera_captured_s: Vec::new(),
            processed_s: None,
            method: None,
            radius: None,
            radius_steps: Vec::new(),
            centerline_sigma: Vec::new(),
            cameras: Vec::new(),
            ghost_mm: None,
            carried_mm: None,
            lag_ms: None,
            start: None,
            background_updated: Vec::new(),
            shadow_voxels: 0,
            background_restored: Vec::new(),
            direction_guessed: false,
        }
    }
}

/// Median and 95th percentile of one stage's time, ms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StageSummary {
    /// Stage name.
    pub stage: String,
    /// Median, ms.
    pub median_ms: f64,
    /// 95th percentile, ms.
    pub p95_ms: f64,
}

/// Counts and times of a run so far, for progress and the summary.
#[derive(Debug, Clone)]
pub struct Tally {
    started: std::time::Instant,
    timings: Vec<StageTimings>,
    latencies: Vec<f64>,
    ok: usize,
    errors: usize,
    frames: usize,
    direction_guessed: usize,
    shadow_frames: usize,
    file_times: usize,
    clocks: ClockTally,
}

impl Default for Tally {
    fn default() -> Self {
        Tally {
            started: std::time::Instant::now(),
            timings: Vec::new(),
            latencies: Vec::new(),
            ok: 0,
            errors: 0,
            frames: 0,
            direction_guessed: 0,
            shadow_frames: 0,
            file_times: 0,
            clocks: ClockTally::default(),
        }
    }
}

impl Tally {
    /// Starts counting now.
    pub fn new() -> Self {
        Tally::default()
    }

    /// Counts one record.
    pub fn add(&mut self, record: &TrackRecord) {
        self.frames += 1;
        match record.status {
            RecordStatus::Ok => self.ok += 1,
            RecordStatus::Error => self.errors += 1,
            _ => {}
        }
        self.direction_guessed += usize::from(record.direction_guessed);
        self.shadow_frames += usize::from(record.shadow_voxels > 0);
        self.file_times += usize::from(record.captured_from.as_deref() == Some("file_time"));
        self.clocks.add(
            record.captured_s,
            &record.camera_captured_s,
            record.lag_ms.is_some(),
        );
        if record.status != RecordStatus::Error {
            self.timings.push(record.timings_ms);
        }
        if let Some(l) = record.latency_ms {
            self.latencies.push(l);
        }
    }

    /// Frames counted.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Seconds since the tally started.
    pub fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// The summary of the run, given how it ended.
    pub fn summary(&self, end: &RunEnd) -> TrackSummary {
        let seconds = self.seconds();
        let mut latencies = self.latencies.clone();
        TrackSummary {
            frames: self.frames,
            ok: self.ok,
            errors: self.errors,
            stopped: end.stopped || end.input_error.is_some(),
            seconds,
            fps: self.frames as f64 / seconds.max(1e-9),
            stages: stage_summaries(&self.timings),
            dropped: end.dropped,
            unpaired: end.unpaired,
            latency_ms: (!latencies.is_empty()).then(|| StageSummary {
                stage: "latency".into(),
                median_ms: quantile(&mut latencies, 0.5),
                p95_ms: quantile(&mut latencies, 0.95),
            }),
            input_error: end.input_error.as_ref().map(|e| e.to_string()),
            startup_s: None,
            direction_guessed: self.direction_guessed,
            shadow_frames: self.shadow_frames,
            refined_rig: None,
            file_time_frames: self.file_times,
            camera_clocks: self.clocks.clocks(),
            between_captures: self.clocks.between(),
            truth: None,
        }
    }
}

/// The last line of a run: `{"summary": {…}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackSummary {
    /// Frames read.
    pub frames: usize,
    /// Frames with status `ok`.
    pub ok: usize,
    /// Frames with status `error`.
    pub errors: usize,
    /// Whether the run was stopped early (Ctrl-C or a structural input error).
    pub stopped: bool,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Frames per second, wall clock (including reading and decoding images).
    pub fps: f64,
    /// Per-stage times.
    pub stages: Vec<StageSummary>,
    /// Frame sets a live input dropped because newer ones arrived first.
    #[serde(default)]
    pub dropped: u64,
    /// Frame sets live cameras could not pair: one camera had no frame within the pairing
    /// tolerance of the others' capture instant (its frame near it lost), so the others'
    /// frames were not tracked (additive).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unpaired: u64,
    /// From capture or reading to the end of the chain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latency_ms: Option<StageSummary>,
    /// The input error that ended the stream early, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input_error: Option<String>,
    /// Seconds from the command's start to its first frame asked for — reading the rig and
    /// backgrounds, setting up carving and the outputs — not counted in `seconds` (additive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub startup_s: Option<f64>,
    /// Frames `ambiguous` only because nothing told the proximal end from the tip (additive;
    /// absent: none); the summary line then says once which setting decides it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub direction_guessed: usize,
    /// Frames whose hull held a sharp shadow's voxels, dropped before the shape was found
    /// (`shadow_voxels` in their records; additive; absent: none); the summary line then says
    /// once what makes such shadows.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shadow_frames: usize,
    /// The rig's `[refined]` table, when `flexshape rig refine` made it (additive): which
    /// cameras moved, and how far the world frame may have moved with them; the summary line
    /// then says so when that is not 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_rig: Option<flexshape_rig::Refined>,
    /// Frames whose capture time is only their image file's modification time (nothing else
    /// gave one; additive; absent: none): the summary line says so once.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub file_time_frames: usize,
    /// Each camera's clock, rig order, where the input gave every camera's own capture time
    /// (additive; absent otherwise): its frame rate and its captures' offset from the frames'
    /// instants; the summary line says how far apart they captured.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub camera_clocks: Vec<CameraClock>,
    /// Frames `ambiguous` because the tube's motion between their cameras' captures was not
    /// known well enough (`lag_ms` in their records; additive; absent: none); beyond a few the
    /// summary line suggests triggering the cameras together.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub between_captures: usize,
    /// A simulated recording's records held against its truth (additive; absent for any
    /// other input): frames vouched for and right, vouched for but off, refused though right.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<crate::TruthCheck>,
}

fn is_zero<N: Default + PartialEq>(n: &N) -> bool {
    *n == N::default()
}

/// The summary as its own line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SummaryLine {
    /// The summary.
    pub summary: TrackSummary,
}

/// Median and 95th percentile of each stage over per-frame timings.
pub fn stage_summaries(records: &[StageTimings]) -> Vec<StageSummary> {
    StageTimings::default()
        .stages()
        .iter()
        .enumerate()
        .map(|(i, (name, _))| {
            let mut t: Vec<f64> = records.iter().map(|r| r.stages()[i].1).collect();
            StageSummary {
                stage: (*name).into(),
                median_ms: quantile(&mut t, 0.5),
                p95_ms: quantile(&mut t, 0.95),
            }
        })
        .collect()
}

/// The `q`-quantile (nearest rank) of `values`, which it sorts; 0 when empty.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values
        .get(((values.len().max(1) - 1) as f64 * q).round() as usize)
        .copied()
        .unwrap_or(0.0)
}

impl TrackSummary {
    /// The run in one line: frames (with those dropped, for a `live` source), speed, latency
    /// and per-stage times.
    pub fn line(&self, live: bool, stopped: bool) -> String {
        let summary = self;
        let startup_s = self.startup_s.unwrap_or(0.0);
        format!(
            "{} frames ({} ok, {} errors{}{}) in {:.2} s (after {:.2} s of start-up), {:.1} frames/s{}; ms per stage, median/p95: {}",
            summary.frames,
            summary.ok,
            summary.errors,
            if live && summary.unpaired > 0 {
                format!(
                    ", {} dropped, {} sets unpaired",
                    summary.dropped, summary.unpaired
                )
            } else if live {
                format!(", {} dropped", summary.dropped)
            } else {
                String::new()
            },
            if stopped { ", stopped early" } else { "" },
            summary.seconds,
            startup_s,
            summary.fps,
            summary
                .latency_ms
                .as_ref()
                .map(|l| format!(
                    ", latency {:.1} ms median / {:.1} ms p95",
                    l.median_ms, l.p95_ms
                ))
                .unwrap_or_default(),
            summary
                .stages
                .iter()
                .map(|s| format!("{} {:.2}/{:.2}", s.stage, s.median_ms, s.p95_ms))
                .collect::<Vec<_>>()
                .join(", ")
        ) + &self.direction_advice()
            + &self.shadow_advice()
            + &self.refined_advice()
            + &self.file_time_advice()
            + &crate::camera_clocks::advice(&self.camera_clocks, self.between_captures, self.frames)
    }

    /// Once per run, on a refined rig whose refinement could not tell which cameras moved:
    /// how far the world frame may have gone with them.
    fn refined_advice(&self) -> String {
        match &self.refined_rig {
            Some(r) if r.world_open_mm > 0.0 => format!(
                "
the rig was refined ({} moved), and the images could not tell which cameras had been knocked: positions may be off by up to {:.2} mm in the world frame the calibration gave (shapes are not); refine with --hold NAME naming a camera known to be right, or register to your robot",
                r.moved.join(", "),
                r.world_open_mm
            ),
            _ => String::new(),
        }
    }

    /// Once per run whose capture times are only the image files' modification times.
    fn file_time_advice(&self) -> String {
        match self.file_time_frames {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames' capture times (captured_s) are their image files' modification times, which copying changes: write the real ones to timestamps.csv (docs/formats.md)",
                self.frames
            ),
        }
    }

    /// Once per run, when hulls held a sharp shadow's voxels: what throws such shadows.
    fn shadow_advice(&self) -> String {
        match self.shadow_frames {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames' hulls held a sharp shadow of the tube (dropped, see shadow_voxels): a small lamp near a camera casts it on a backdrop close behind the volume; a larger or more distant lamp, or the backdrop farther back, softens it out of the silhouettes",
                self.frames
            ),
        }
    }

    /// Once per run, when frames were `ambiguous` for want of a cue to the tube's direction:
    /// which setting decides it.
    fn direction_advice(&self) -> String {
        match self.direction_guessed {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames are ambiguous only because nothing tells the tube's tip from its proximal end (neither end leaves the volume or a camera's view): {}",
                self.frames,
                flexshape_shape::DIRECTION_SETTINGS
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_of_frames_without_a_direction_says_once_which_setting_decides_it() {
        let mut tally = Tally::new();
        let mut record = TrackRecord::error(0, String::new());
        record.status = RecordStatus::Ambiguous;
        record.direction_guessed = true;
        for _ in 0..3 {
            tally.add(&record);
        }
        tally.add(&TrackRecord::error(3, String::new()));
        let summary = tally.summary(&RunEnd::default());
        assert_eq!(summary.direction_guessed, 3);
        let line = summary.line(false, false);
        assert_eq!(line.matches("proximal_hint").count(), 1, "{line}");
        assert!(line.contains("3 of 4 frames"), "{line}");
        // Frames that had a direction say nothing of it.
        let quiet = Tally::new().summary(&RunEnd::default()).line(false, false);
        assert!(!quiet.contains("proximal_hint"), "{quiet}");
        assert!(!quiet.contains("shadow"), "{quiet}");
    }

    #[test]
    fn a_run_whose_hulls_held_a_shadow_says_once_what_casts_it() {
        let mut tally = Tally::new();
        let mut record = TrackRecord::error(0, String::new());
        record.status = RecordStatus::Ok;
        tally.add(&record);
        record.shadow_voxels = 1200;
        for _ in 0..2 {
            tally.add(&record);
        }
        let summary = tally.summary(&RunEnd::default());
        assert_eq!(summary.shadow_frames, 2);
        let line = summary.line(false, false);
        assert_eq!(line.matches("lamp").count(), 2, "{line}");
        assert!(line.contains("2 of 3 frames' hulls"), "{line}");
        let json = serde_json::to_string(&summary).unwrap();
        assert!(json.contains("\"shadow_frames\":2"), "{json}");
    }

    #[test]
    fn a_refined_rig_that_could_not_tell_which_camera_moved_says_how_far_the_world_may_have() {
        let refined = |world_open_mm| TrackSummary {
            refined_rig: Some(flexshape_rig::Refined {
                moved: vec!["cam2".into()],
                world_open_mm,
            }),
            ..Tally::new().summary(&RunEnd::default())
        };
        let line = refined(1.92).line(false, false);
        assert!(
            line.contains("cam2 moved") && line.contains("1.92 mm"),
            "{line}"
        );
        let json = serde_json::to_string(&refined(1.92)).unwrap();
        assert!(
            json.contains("\"refined_rig\":{\"moved\":[\"cam2\"]"),
            "{json}"
        );
        // Decided by the images: the field, but nothing to say.
        assert!(!refined(0.0).line(false, false).contains("refined"));
        let plain = Tally::new().summary(&RunEnd::default());
        assert!(!serde_json::to_string(&plain).unwrap().contains("refined"));
    }
}
