//! A tracked shape against the simulator's truth, and figures over many frames.

use flexshape_model::nalgebra_types::Point3;
use flexshape_record::quantile;
use flexshape_recording::{RightBounds, Truth, TruthErrors};
use flexshape_track::{Pipeline, Tracked};

/// A shape against the simulator's truth, mm (curvature in 1/mm).
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeErrors {
    /// RMS distance from the true centerline samples in the volume to the estimated curve.
    pub centerline_rms: f64,
    /// Distance between the estimated and the true tip.
    pub tip: f64,
    /// Worst distance from a true band centre to the nearest estimated one.
    pub band: f64,
    /// Estimated and true curvature of the bending section, 1/mm.
    pub curvature: Option<(f64, f64)>,
    /// Share of the true centerline samples in the volume that lie in occupied voxels.
    pub hull_covers: f64,
}

impl ShapeErrors {
    /// The tracked shape's errors against `truth` (`None` without a shape or a true
    /// centerline in the volume).
    pub fn of(pipeline: &Pipeline, truth: &Truth, t: &Tracked) -> Option<Self> {
        let shape = &t.shape;
        let volume = pipeline.volume();
        let errors = truth.errors(&shape.points, shape.tip, |p| volume.contains(p))?;
        let inside: Vec<Point3<f64>> = truth
            .centerline
            .iter()
            .map(|p| Point3::from(*p))
            .filter(|p| volume.contains(p))
            .collect();
        let band = truth
            .bands
            .iter()
            .map(|b| Point3::from(b.position))
            .filter(|p| inside.iter().any(|q| (q - p).norm() < 1.0))
            .map(|p| {
                shape
                    .bands
                    .iter()
                    .map(|b| (Point3::from(b.position) - p).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max);
        let curvature = match (truth.kappa, &shape.arc_fit) {
            (Some([kx, kz]), Some(fit)) => Some((fit.curvature, kx.hypot(kz))),
            _ => None,
        };
        let covered = inside
            .iter()
            .filter(|p| t.occupancy.contains_point(p))
            .count();
        Some(ShapeErrors {
            centerline_rms: errors.centerline_rms,
            tip: errors.tip,
            band,
            curvature,
            hull_covers: covered as f64 / inside.len() as f64,
        })
    }
}

impl ShapeErrors {
    /// Whether the shape is right by the truth, within `bounds`.
    pub fn within(&self, bounds: RightBounds) -> bool {
        TruthErrors {
            centerline_rms: self.centerline_rms,
            tip: self.tip,
        }
        .within(bounds)
    }
}

/// Figures over the frames so far (mm; curvature relative).
#[derive(Debug, Clone, Default)]
pub struct DemoFigures {
    /// Each frame's centerline RMS.
    pub rms: Vec<f64>,
    /// Each frame's tip error.
    pub tip: Vec<f64>,
    /// Worst band error.
    pub band: f64,
    /// Worst relative curvature error of the arc fit, where the bend is at least 1/200 mm.
    pub curvature: f64,
    /// Least share of the true centerline the hull held.
    pub cover: Option<f64>,
    /// Each frame's time through the chain, ms.
    pub chain_ms: Vec<f64>,
    /// Frames whose status says the shape is right that the truth says is not (or that carry
    /// no shape to hold against it), see [`DemoFigures::judge`].
    pub right_said_wrong: usize,
    /// Frames whose status refuses a shape the truth says is right.
    pub right_refused: usize,
}

impl DemoFigures {
    /// Adds a frame's errors.
    pub fn add(&mut self, e: &ShapeErrors) {
        self.rms.push(e.centerline_rms);
        self.tip.push(e.tip);
        self.band = self.band.max(e.band);
        self.cover = Some(self.cover.map_or(e.hull_covers, |c| c.min(e.hull_covers)));
        if let Some((fit, truth)) = e.curvature
            && truth >= 1.0 / 200.0
        {
            self.curvature = self.curvature.max((fit / truth - 1.0).abs());
        }
    }

    /// Counts a frame's status against the truth: `said_right` is the status's word (`ok`,
    /// `bands_missing` or `leaves_volume`: the shape is right), `errors` its shape's errors (`None` without a
    /// shape or a true centerline in the volume, when nothing is counted unless the status
    /// claimed a shape).
    /// The errors of a frame said right are added ([`DemoFigures::add`]).
    pub fn judge(&mut self, said_right: bool, errors: Option<&ShapeErrors>, bounds: RightBounds) {
        let right = errors.map(|e| e.within(bounds));
        self.right_said_wrong += usize::from(said_right && right != Some(true));
        self.right_refused += usize::from(!said_right && right == Some(true));
        if let Some(e) = errors.filter(|_| said_right) {
            self.add(e);
        }
    }

    /// The largest value (0 when none).
    pub fn worst(v: &[f64]) -> f64 {
        v.iter().copied().fold(0.0, f64::max)
    }

    /// The median.
    pub fn median(v: &[f64]) -> f64 {
        quantile(&mut v.to_vec(), 0.5)
    }
}
