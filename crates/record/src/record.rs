//! The JSON Lines records of `flexshape track`: one per frame, then one summary. The fields
//! documented in `docs/formats.md` are a stable contract; others may be added. World frame,
//! mm, radians.

use flexshape_fit::CameraCheck;
use flexshape_recording::{Command, PoseRole};
use serde::{Deserialize, Serialize};

use crate::{CapturedFrom, Method, RecordStatus, StageTimings, Start};

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
    pub captured_from: Option<CapturedFrom>,
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
    pub method: Option<Method>,
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
    pub start: Option<Start>,
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

    /// The record of a frame that could not be processed.
    pub fn error(frame: u64, reason: String) -> Self {
        TrackRecord::bare(frame, RecordStatus::Error, Some(reason))
    }

    /// A record of frame `frame` with its status and reason and nothing else yet: no shape, no
    /// times, no checks (whoever makes a record fills in what it has).
    pub fn bare(frame: u64, status: RecordStatus, reason: Option<String>) -> Self {
        TrackRecord {
            frame,
            status,
            reason,
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

/// A camera whose background took a frame's colours: the backdrop had changed there since the
/// background was captured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct BackgroundUpdate {
    /// The camera's name.
    pub camera: String,
    /// Pixels whose colour changed by more than the background model's noise (its
    /// `CHANGED_SPREADS` spreads, at least `CHANGED_LEVELS` grey levels: see
    /// `flexshape_silhouette`).
    pub changed_px: usize,
}

/// Whether `n` is its type's default (serde: fields left out when zero).
pub(crate) fn is_zero<N: Default + PartialEq>(n: &N) -> bool {
    *n == N::default()
}
