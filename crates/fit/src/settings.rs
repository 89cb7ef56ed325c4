//! Settings of the image fit and its self-check (`[processing.fit]` in the rig file).

use serde::{Deserialize, Serialize};

use crate::FitError;

/// How the centerline is estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// The tube fitted to the sub-pixel outlines in every camera, started from the hull.
    #[default]
    Fit,
    /// The visual hull's centerline alone (the paper's method), not checked against the
    /// images.
    Hull,
}

/// Whether a silhouette's width across the tube is the tube's image or the silhouette's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutlineWidth {
    /// `free` for masks, `tube` for camera images.
    #[default]
    Auto,
    /// The outline lies where the tube's radius puts it: each boundary places the tube (and,
    /// unless the rig gives it, the radius) on its own.
    Tube,
    /// Only the middle between the two boundaries across the tube places it; how far apart
    /// they lie is the silhouette's own (a line drawn a fixed number of pixels wide, a
    /// segmentation that grows or shrinks the tube): the radius is not fitted, and a cap is
    /// placed with its end's width as measured.
    Free,
}

/// Everything the fit can be told. Lengths in mm, image distances in pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitSettings {
    /// Fit, or keep the hull's centerline.
    pub method: Method,
    /// Control-point spacing of the centerline, mm (fewer points: smoother, faster).
    pub span_mm: f64,
    /// Outline samples along the tube, mm apart.
    pub spacing_mm: f64,
    /// How far from the predicted outline a boundary is searched, pixels.
    pub search_px: f64,
    /// Residual beyond which a sample's weight falls (Huber), pixels.
    pub huber_px: f64,
    /// Weakest tube-to-background contrast a boundary may have, grey levels.
    pub min_contrast: f64,
    /// Gauss–Newton iterations at most.
    pub max_iterations: usize,
    /// Fit the radius (when the rig's `[processing.shape] radius_mm` does not give it).
    pub fit_radius: bool,
    /// An open end (running out of the volume) is continued by this much before fitting, mm.
    pub extend_mm: f64,
    /// Weight of the prior holding each control point near where it started along the tube,
    /// px/mm.
    pub slide_prior: f64,
    /// Weight holding an open end in place along the tube, px/mm.
    pub end_anchor: f64,
    /// Weight holding a capped end's last span from curling, px per mm: its third derivative
    /// along the tube (κ² on an arc of constant curvature) as the displacement it makes over a
    /// span is held near zero. Without it a followed tip, which only its cap's outline holds,
    /// can curl back into its own outline frame after frame (0 turns it off).
    pub tip_curl_prior: f64,
    /// Weight holding a span the cameras see from too few sides (every span when fewer than
    /// three cameras see the tube; else one seen from directions less than 30° apart) from
    /// changing its curvature in the direction they see least, px per mm, as `tip_curl_prior`
    /// a capped end's: two cameras leave a stretch near their epipolar plane free to wiggle
    /// within it (0 turns it off).
    pub weak_span_prior: f64,
    /// Self-check: largest outline residual RMS in any camera, pixels, on a quiet image
    /// (widened by each camera's boundary noise, [`crate::CameraCheck::noise_px`]).
    pub max_residual_px: f64,
    /// Self-check: the limit nine tenths of each camera's outline residuals keep their size
    /// within, pixels, on a quiet image (sharp, low-noise images keep them near 0.1; each
    /// boundary's limit widens by its own scatter, [`crate::CameraCheck::outlying_share`];
    /// raise it for blurred ones).
    pub max_p90_px: f64,
    /// Self-check: largest image translation between a camera's fitted and measured outline
    /// ([`crate::CameraCheck::shift_px`]), pixels. Noise scatters single boundaries, not a
    /// whole outline (its shift's own scatter is the boundaries' over the root of their
    /// number, hundredths of a pixel): an outline off as a whole by this much means the
    /// cameras disagree about where the tube is — a calibration error — however noisy the
    /// image (right shapes: at most 0.51 px in the simulator's scenes, with motion blur; a
    /// camera turned by 0.2°: 1.8–2.2 px).
    pub max_shift_px: f64,
    /// Self-check: smallest share of a camera's outline samples with a boundary found.
    pub min_found: f64,
    /// Self-check: smallest overlap (IoU) of the re-rendered tube with a camera's silhouette.
    pub min_iou: f64,
    /// Self-check: silhouette pixels farther than `explain_px` from the re-rendered tube that
    /// may stay unexplained in a camera.
    pub max_unexplained_px: usize,
    /// Distance within which the re-rendered tube explains a silhouette pixel, pixels.
    pub explain_px: usize,
    /// Carved hull away from the fitted tube (farther than 1.5 radii + 1.5 voxels from its
    /// centerline), as a length of tube, mm, beyond which the shape is `ambiguous`.
    pub max_ghost_mm: f64,
    /// Largest 1-σ uncertainty across the tube anywhere along the reported centerline, mm,
    /// beyond which the shape is `ambiguous`: the cameras do not pin it down (too few of them,
    /// or the tube lying in a plane two of them share). The default, 0.15 mm, is the
    /// centerline accuracy an `ok` claims (the RMS bound `validate` and a simulated
    /// recording's truth judge by): a frame whose worst point the cameras place only more
    /// loosely than that cannot vouch for it. Measured on 714 simulated frames of 22 scenes:
    /// frames at σ 0.10–0.15 mm lay 0.03–0.10 mm RMS from the truth, every one right.
    pub max_sigma_mm: f64,
    /// Tracking: start each frame from the previous frame's fit (when that one was right;
    /// carried on as it moved since the right frame before), classify silhouettes only around
    /// it, and carve only to start again when the fit does not explain the images. Off by
    /// default: under fast motion (several millimetres a frame) a followed fit can settle with
    /// its tip a few tenths of a millimetre off and still pass the self-check. Needs two
    /// cameras or more.
    pub track: bool,
    /// Tracking: how far around the previous frame's tube the silhouettes are classified,
    /// pixels (more than the tube's image moves between frames).
    pub track_margin_px: f64,
    /// Tracking: a followed fit whose tip moved farther than this from where it started (the
    /// previous frame's, carried on) is not trusted (the frame is carved again), mm; also the
    /// largest move a prediction may give a control point per frame it looks ahead.
    pub track_max_move_mm: f64,
    /// Tracking: outline samples along the sides of a followed frame's tube, mm apart, on
    /// rigs of three cameras or more (`spacing_mm` for a frame fitted from its hull, and on
    /// two-camera rigs, whose two views pin a shape down only just). A followed fit starts
    /// within a few tenths of a millimetre of its shape; every sample costs a few
    /// microseconds. The caps are sampled at least every 2 mm whatever the spacing.
    pub track_spacing_mm: f64,
    /// Whether the silhouettes' width across the tube follows its radius (see
    /// [`OutlineWidth`]).
    pub outline_width: OutlineWidth,
    /// The frames are masks, not camera images (set by the chain that reads masks, not by the
    /// rig file): nothing is said of the tube's colour, and [`OutlineWidth::Auto`] is `free`.
    #[serde(skip)]
    pub masks: bool,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            method: Method::Fit,
            span_mm: 15.0,
            spacing_mm: 2.0,
            search_px: 3.0,
            huber_px: 0.5,
            min_contrast: 20.0,
            max_iterations: 16,
            fit_radius: true,
            extend_mm: 10.0,
            slide_prior: 0.5,
            end_anchor: 5.0,
            tip_curl_prior: 3.0,
            weak_span_prior: 3.0,
            max_residual_px: 0.6,
            max_p90_px: 0.25,
            max_shift_px: 1.0,
            min_found: 0.6,
            min_iou: 0.75,
            max_unexplained_px: 60,
            explain_px: 2,
            max_ghost_mm: 6.0,
            max_sigma_mm: 0.15,
            track: false,
            track_margin_px: 24.0,
            track_max_move_mm: 3.0,
            track_spacing_mm: 4.0,
            outline_width: OutlineWidth::Auto,
            masks: false,
        }
    }
}

impl FitSettings {
    /// Whether only the middle between a tube's two boundaries places it ([`OutlineWidth`]).
    pub fn free_width(&self) -> bool {
        match self.outline_width {
            OutlineWidth::Free => true,
            OutlineWidth::Tube => false,
            OutlineWidth::Auto => self.masks,
        }
    }

    /// The defaults overridden by a rig's `[processing.fit]` table, if any.
    pub fn from_processing(processing: &toml::Table) -> Result<Self, FitError> {
        let settings: FitSettings = match processing.get("fit") {
            None => FitSettings::default(),
            Some(v) => v
                .clone()
                .try_into()
                .map_err(|e: toml::de::Error| FitError::Setting {
                    field: "processing.fit",
                    problem: e.message().to_string(),
                })?,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Checks every value's range: the ranges in `docs/formats.md`, wide enough for any rig,
    /// narrow enough that no value makes the fit allocate without bound (a 0.001 mm control
    /// point spacing asked for 432 GB) or run forever.
    pub fn validate(&self) -> Result<(), FitError> {
        let ranges = [
            ("span_mm", self.span_mm, 2.0, 1000.0),
            ("spacing_mm", self.spacing_mm, 0.05, 50.0),
            ("track_spacing_mm", self.track_spacing_mm, 0.05, 50.0),
            ("search_px", self.search_px, 0.5, 12.0),
            ("huber_px", self.huber_px, 0.01, 100.0),
            ("max_residual_px", self.max_residual_px, 0.01, 100.0),
            ("max_p90_px", self.max_p90_px, 0.01, 100.0),
            ("max_shift_px", self.max_shift_px, 0.01, 100.0),
            ("min_contrast", self.min_contrast, 0.0, 765.0),
            ("extend_mm", self.extend_mm, 0.0, 1000.0),
            ("slide_prior", self.slide_prior, 0.0, 1e6),
            ("end_anchor", self.end_anchor, 0.0, 1e6),
            ("tip_curl_prior", self.tip_curl_prior, 0.0, 1e6),
            ("weak_span_prior", self.weak_span_prior, 0.0, 1e6),
            ("max_ghost_mm", self.max_ghost_mm, 0.0, 1e5),
            ("max_sigma_mm", self.max_sigma_mm, 0.0, 1e3),
            ("track_margin_px", self.track_margin_px, 0.0, 1000.0),
            ("track_max_move_mm", self.track_max_move_mm, 0.0, 1000.0),
            ("min_found", self.min_found, 0.0, 1.0),
            ("min_iou", self.min_iou, 0.0, 1.0),
        ];
        for (field, v, lo, hi) in ranges {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(FitError::Setting {
                    field,
                    problem: format!("{} is outside {lo}–{hi}", flexshape_rig::quoted(v)),
                });
            }
        }
        if !(1..=1000).contains(&self.max_iterations) {
            return Err(FitError::Setting {
                field: "max_iterations",
                problem: format!("{} is outside 1–1000", self.max_iterations),
            });
        }
        if self.max_unexplained_px > 100_000_000 || self.explain_px > 1000 {
            return Err(FitError::Setting {
                field: "max_unexplained_px / explain_px",
                problem: "at most 10⁸ pixels / 1000 pixels".into(),
            });
        }
        Ok(())
    }
}
