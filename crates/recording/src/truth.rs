//! Ground truth of one simulated frame (`DIR/truth/NNNNNN.json`).

use flexshape_curve::Polyline;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::{Layout, RecordingError};

/// A marker band: the centerline point at the band's centre.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthBand {
    /// Centerline point at the band's centre, world mm.
    pub position: [f64; 3],
    /// Arc length of that point from the centerline's first sample, mm.
    pub arc_length: f64,
    /// Band width along the centerline, mm (additive field).
    #[serde(default)]
    pub width: f64,
}

/// One constant-curvature section of a simulated catheter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthSection {
    /// Material (unstrained) length, mm.
    pub length: f64,
    /// `[κx, κz]`, 1/mm, about the section's local x and z axes (local axis along y).
    pub kappa: [f64; 2],
    /// Axial strain, compression positive.
    pub strain: f64,
}

/// Ground truth of one frame. Keys `frame`, `centerline`, `radius`, `tip`, `tip_direction`,
/// `bands`, `kappa`, `eps` are a contract; others are additive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Frame number.
    pub frame: u64,
    /// Centerline samples, world mm, from the proximal end to the tip, ≤ 0.5 mm apart.
    pub centerline: Vec<[f64; 3]>,
    /// Tube radius, mm.
    pub radius: f64,
    /// Tip point (end of the centerline), world mm.
    pub tip: [f64; 3],
    /// Unit tangent at the tip, world.
    pub tip_direction: [f64; 3],
    /// Marker bands, proximal to distal.
    pub bands: Vec<TruthBand>,
    /// `[κx, κz]` of the bending section (1/mm, in its frame), or null for a free-form curve.
    pub kappa: Option<[f64; 2]>,
    /// `[ε0, ε1]`: axial strain of the proximal and bending sections (compression positive),
    /// or null for a free-form curve.
    pub eps: Option<[f64; 2]>,
    /// Arc length (mm) where the bending section starts (additive).
    #[serde(default)]
    pub bend_start_arc_length: Option<f64>,
    /// All constant-curvature sections from the proximal end (additive).
    #[serde(default)]
    pub sections: Vec<TruthSection>,
    /// The bending section's base frame, world: origin (mm) and axes x, y (tangent), z as
    /// columns `[[x0, y0, z0], [x1, y1, z1], [x2, y2, z2]]` (additive).
    #[serde(default)]
    pub bend_base: Option<BendBase>,
}

/// Position and orientation of the bending section's base (the model frame of the paper).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BendBase {
    /// Origin, world mm.
    pub origin: [f64; 3],
    /// Rotation local → world, row-major.
    pub rotation: [[f64; 3]; 3],
}

/// How far from the truth a shape may be and still be right: the third wave's bounds, held
/// alike by `flexshape bench`, the soak run and `flexshape validate`. On the default 640×480
/// rig a pixel spans about 0.6 mm at the volume's centre; scale both with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RightBounds {
    /// Centerline RMS distance from the truth, mm.
    pub rms_mm: f64,
    /// Tip distance from the true tip, mm.
    pub tip_mm: f64,
}

/// A sensed shape against a true centerline, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthErrors {
    /// RMS distance from the true centerline's samples (those inside the volume) to the
    /// sensed centerline.
    pub centerline_rms: f64,
    /// Distance between the sensed tip and the true one (the true centerline's last sample).
    pub tip: f64,
}

impl TruthErrors {
    /// The errors of the `sensed` centerline (world mm, any sampling, at least two points) and
    /// its `tip` against `truth` (world mm, proximal to distal, ending at the true tip) where
    /// `inside` holds (the working volume: outside it no shape is reported); `None` when the
    /// sensed centerline has fewer than two distinct points or no true sample is inside.
    pub fn between(
        truth: &[[f64; 3]],
        sensed: &[[f64; 3]],
        tip: [f64; 3],
        inside: impl Fn(&Point3<f64>) -> bool,
    ) -> Option<Self> {
        let curve = Polyline::new(sensed.iter().map(|&p| Point3::from(p)).collect()).ok()?;
        let d2: Vec<f64> = truth
            .iter()
            .map(|&p| Point3::from(p))
            .filter(|p| inside(p))
            .map(|p| curve.closest(&p).1.powi(2))
            .collect();
        if d2.is_empty() {
            return None;
        }
        Some(TruthErrors {
            centerline_rms: (d2.iter().sum::<f64>() / d2.len() as f64).sqrt(),
            tip: (Point3::from(tip) - Point3::from(*truth.last()?)).norm(),
        })
    }

    /// Whether the shape is right within `bounds`.
    pub fn within(&self, bounds: RightBounds) -> bool {
        self.centerline_rms <= bounds.rms_mm && self.tip <= bounds.tip_mm
    }
}

impl Truth {
    /// Reads frame `frame`'s truth from the recording `layout` describes
    /// (`truth/NNNNNN.json`): `None` when there is none (a recording not simulated).
    pub fn read(layout: &Layout, frame: u64) -> Result<Option<Truth>, RecordingError> {
        crate::reader::read_json(layout.truth(frame), |path, message| RecordingError::Truth {
            path,
            message,
        })
    }

    /// How far a sensed tip (world mm) lies from the true one, mm.
    pub fn tip_off(&self, tip: [f64; 3]) -> f64 {
        (Point3::from(tip) - Point3::from(self.tip)).norm()
    }

    /// [`TruthErrors::between`] this frame's true centerline and a sensed one.
    pub fn errors(
        &self,
        sensed: &[[f64; 3]],
        tip: [f64; 3],
        inside: impl Fn(&Point3<f64>) -> bool,
    ) -> Option<TruthErrors> {
        TruthErrors::between(&self.centerline, sensed, tip, inside)
    }
}

impl Default for RightBounds {
    fn default() -> Self {
        RightBounds {
            rms_mm: 0.15,
            tip_mm: 0.3,
        }
    }
}
