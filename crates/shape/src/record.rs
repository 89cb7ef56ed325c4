//! The shape of one frame as the tracker streams it (one JSON Lines record per frame). World
//! frame, mm, radians; arc lengths from the proximal end.

use serde::{Deserialize, Serialize};

/// Whether the frame gave a shape.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Status {
    /// A shape and every expected band.
    Ok,
    /// Nothing (or only specks) was carved.
    NoObject {
        /// Occupied voxels seen.
        voxels: usize,
    },
    /// The cloud is not one open tube: two separate objects, a closed loop, too short.
    Ambiguous {
        /// What was seen, for the operator.
        reason: String,
    },
    /// The tube reaches the volume's boundary at both ends: its tip is outside the volume, so
    /// the curve stops at the boundary and `tip` is not the instrument's tip.
    LeavesVolume,
    /// A shape was fitted, but it does not explain the images (a camera's outline residuals,
    /// its overlap with a silhouette, or silhouette pixels it leaves unexplained are beyond the
    /// self-check's limits): the shape is not to be trusted.
    Inconsistent {
        /// Which camera and which check, with the figures.
        reason: String,
    },
    /// A camera's silhouette covers more of its image than is plausible for the tube: the
    /// background model does not describe the scene, and nothing was carved.
    BadSilhouette {
        /// Which camera, the share covered and what to do, for the operator.
        reason: String,
    },
    /// A shape, but fewer bands than expected.
    BandsMissing {
        /// Bands found.
        found: usize,
        /// Bands expected.
        expected: usize,
    },
}

impl Status {
    /// Whether a shape with this status is right: `ok`, `bands_missing` (the shape is right,
    /// a band is not seen) or `leaves_volume` (right up to the volume's boundary). A later
    /// frame may start from it; every other status says the shape must not be trusted.
    pub fn is_right(&self) -> bool {
        matches!(
            self,
            Status::Ok | Status::BandsMissing { .. } | Status::LeavesVolume
        )
    }
}

/// A marker band located on the curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandOnCurve {
    /// Arc length of its centre, mm.
    pub arc_length: f64,
    /// Curve point at its centre, world mm.
    pub position: [f64; 3],
    /// Extent along the curve (first and last arc length of its voxels), mm.
    pub extent: [f64; 2],
    /// Its voxels (0 when it was read from the colour along a fitted curve).
    pub voxels: usize,
    /// Whether it reaches the tip (its centre is then placed from its proximal edge and the
    /// tip, since the hull's far end is not the band's).
    pub at_tip: bool,
}

/// A band found on a curve by other means than the carved voxels (the colour along the fitted
/// tube's projection): its ends as the curve's parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveBand {
    /// Curve parameter of its proximal and distal ends.
    pub u: [f64; 2],
    /// Whether it runs into the tip (its distal end is the tip).
    pub at_tip: bool,
}

/// Axial strain of a section of known nominal length.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Compression {
    /// The section's name from the settings.
    pub name: String,
    /// Measured length along the curve, mm.
    pub length: f64,
    /// Nominal length, mm.
    pub nominal: f64,
    /// `1 − length / nominal` (compression positive).
    pub strain: f64,
}

/// A constant-curvature fit of one section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArcFit {
    /// Arc length where the section starts, mm.
    pub start_arc: f64,
    /// Section length (the spline's), mm.
    pub length: f64,
    /// `[κx, κz]`, 1/mm, in the section frame (paper's convention: axis along y, κx bends
    /// toward +z, κz toward −x).
    pub kappa: [f64; 2],
    /// `‖κ‖`, 1/mm.
    pub curvature: f64,
    /// Bending-plane angle: direction of the bend in the frame's x–z plane, from +x toward +z,
    /// radians.
    pub plane_angle: f64,
    /// The fitted section frame: origin (world mm) and its x, y (tangent), z axes (world).
    pub origin: [f64; 3],
    /// Axes x, y, z of the section frame in world coordinates.
    pub axes: [[f64; 3]; 3],
    /// Mean distance between the curve and the arc at equal arc lengths, mm.
    pub residual_mean: f64,
    /// Largest such distance, mm.
    pub residual_max: f64,
    /// `residual_mean` as a percentage of the section length (the paper's 1.9 % figure is
    /// this ratio over its workspace).
    pub residual_percent: f64,
    /// Two constant-curvature pieces (piecewise constant curvature), split at
    /// `two_section_split` of the length.
    pub two_section: Option<TwoSectionFit>,
}

/// Two arcs end to end.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwoSectionFit {
    /// Arc length of the split from the section start, mm.
    pub split: f64,
    /// `[κx, κz]` of each piece, 1/mm, each in its own base frame.
    pub kappa: [[f64; 2]; 2],
    /// Mean distance, mm.
    pub residual_mean: f64,
    /// Largest distance, mm.
    pub residual_max: f64,
}

/// Milliseconds spent per step.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Graph, ordering and slicing.
    pub order_ms: f64,
    /// Smoothing and sampling.
    pub smooth_ms: f64,
    /// Bands and compression.
    pub bands_ms: f64,
    /// Circular-arc fits.
    pub arc_fit_ms: f64,
}

/// The shape of the tube in one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeRecord {
    /// Whether there is a shape (the other fields are empty when not).
    #[serde(flatten)]
    pub status: Status,
    /// Centerline length from the proximal end to the tip, mm.
    pub length: f64,
    /// Samples evenly spaced at most `sample_mm` apart, from the proximal end to the tip (the
    /// last one), world mm.
    pub points: Vec<[f64; 3]>,
    /// Arc length of each sample, mm.
    pub arc: Vec<f64>,
    /// Unit tangent at each sample (toward the tip).
    pub tangent: Vec<[f64; 3]>,
    /// Curvature at each sample, 1/mm.
    pub curvature: Vec<f64>,
    /// Torsion at each sample, 1/mm.
    pub torsion: Vec<f64>,
    /// 1-σ uncertainty of each sample across the tube, mm, when the centerline was fitted to
    /// the images (empty for the hull's centerline).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sigma: Vec<f64>,
    /// Tip (the centerline's end), world mm.
    pub tip: [f64; 3],
    /// Unit tangent at the tip.
    pub tip_direction: [f64; 3],
    /// Tube radius used for the tip (given or estimated), mm.
    pub radius: f64,
    /// Whether the proximal end was placed on the volume's boundary (the tube enters there).
    pub enters_volume: bool,
    /// Whether nothing told the proximal end from the tip, so that the centerline's direction
    /// is a guess (the status is then `ambiguous`); absent when false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub direction_guessed: bool,
    /// Bands from the proximal end to the tip.
    pub bands: Vec<BandOnCurve>,
    /// Measured axial strains.
    pub compression: Vec<Compression>,
    /// Constant-curvature fit of the configured section.
    pub arc_fit: Option<ArcFit>,
    /// Time per step.
    pub timings: Timings,
}

impl ShapeRecord {
    /// A record with this status and no shape.
    pub fn empty(status: Status) -> Self {
        ShapeRecord {
            status,
            length: 0.0,
            points: Vec::new(),
            arc: Vec::new(),
            tangent: Vec::new(),
            curvature: Vec::new(),
            torsion: Vec::new(),
            sigma: Vec::new(),
            tip: [0.0; 3],
            tip_direction: [0.0; 3],
            radius: 0.0,
            enters_volume: false,
            direction_guessed: false,
            bands: Vec::new(),
            compression: Vec::new(),
            arc_fit: None,
            timings: Timings::default(),
        }
    }
}
