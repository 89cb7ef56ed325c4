//! Shape estimation (paper, Section II-C and the circular approximation of Section V-B): from
//! the carved voxels of a tube and its marker bands to one smooth centerline with arc length,
//! curvature, torsion, tip, band positions, axial strains and constant-curvature fits.
//!
//! Pipeline ([`ShapeEstimator::estimate`]):
//! 1. `order`: the cloud is ordered along the tube by geodesic distance over a coarse voxel
//!    graph (ends by a double sweep), then cut into slices square to the tube; the proximal end
//!    is the one entering the volume. [`angle_order`] is the paper's ordering, kept as a
//!    baseline.
//! 2. `centerline`: slice centroids smoothed into one cubic spline in arc length
//!    ([`Smoothing`]: smoothing spline by default, or the paper's moving average or polynomial),
//!    ends corrected for the cloud's extent and the tip's cap, sampled at uniform arc length.
//! 3. `bands`: band centres on the curve; strains between bands of known nominal spacing.
//! 4. `arcfit`: constant-curvature (and two-piece) fits of a section.
//!
//! Everything is in the world frame, millimetres and radians; arc lengths run from the
//! proximal end. The output is a [`ShapeRecord`] whose [`Status`] says whether there is a shape.
//!
//! ```
//! use flexshape_carve::{HierarchicalCarver, OutsideImage};
//! use flexshape_shape::{ShapeEstimator, ShapeSettings, Status};
//! use flexshape_silhouette::BitMask;
//! use flexshape_sim::{CatheterPose, SimConfig, Simulator};
//!
//! // The hull of a simulated catheter from its exact masks, as in `flexshape_carve`.
//! let sim = Simulator::new(SimConfig::default())?;
//! let pose = CatheterPose::arc(&sim.config().catheter, [0.006, -0.002], [0.0, 0.0], 0.0);
//! let frame = sim.render(0, &pose)?;
//! let masks: Vec<BitMask> = frame.views.iter().map(|v| BitMask::from_gray(&v.mask)).collect();
//! let hull = HierarchicalCarver::new(&sim.cameras(), &sim.rig().volume)?
//!     .carve(&masks.iter().collect::<Vec<_>>(), OutsideImage::Carve)?;
//! // The rig's `[processing.shape]` describes the catheter (radius, bands, sections).
//! let estimator = ShapeEstimator::new(ShapeSettings::from_processing(&sim.rig().processing)?)?;
//! let shape = estimator.estimate(&hull, &[]);
//! // No bands were given, so the status says they are missing; the centerline is there.
//! assert!(shape.status != Status::Ok && shape.points.len() > 100);
//! let tip_error = frame.truth.tip_off(shape.tip);
//! assert!(tip_error < 1.5, "{tip_error} mm");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod arcfit;
mod bands;
mod centerline;
mod graph;
mod order;
mod pieces;
mod record;
mod settings;
mod spline;

use std::time::Instant;

use flexshape_carve::{Band, Occupancy};
use flexshape_curve::BSpline3;
use flexshape_rig::Volume;
use thiserror::Error;

pub use arcfit::section_frame;
pub use order::angle_order;
pub use record::{
    ArcFit, BandOnCurve, Compression, CurveBand, ShapeRecord, Status, Timings, TwoSectionFit,
};
pub use settings::{
    ArcFitSettings, DIRECTION_SETTINGS, NominalSection, ShapeSettings, Smoothing, TipEnd,
};
pub use spline::{CubicSpline3, Derivatives, moving_average, polynomial_fit};

/// Why the shape stage cannot be set up.
#[derive(Debug, Error)]
pub enum ShapeError {
    /// A setting is out of range.
    #[error("shape setting `{field}`: {problem}")]
    Setting {
        /// The setting, e.g. `smoothing.window`.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
}

/// A centerline found another way than from the hull's slices (the tube fitted to the images),
/// for [`ShapeEstimator::record_from_curve`].
pub struct FittedCurve<'a> {
    /// The curve, proximal end at `u = 0`, tip at `u = 1`, world mm.
    pub curve: BSpline3,
    /// Tube radius, mm.
    pub radius: f64,
    /// Whether the tube runs on through the volume's boundary at its proximal end and at its
    /// tip (the curve is then cut where it crosses the boundary).
    pub open: [bool; 2],
    /// Bands found on the curve itself, if any (else the hull's are carried over).
    pub bands: Option<&'a [CurveBand]>,
    /// 1-σ uncertainty across the tube (mm) at a curve parameter, for the record's `sigma`.
    pub sigma: Option<&'a dyn Fn(f64) -> f64>,
}

/// Turns carved clouds into shapes with fixed settings.
#[derive(Debug, Clone)]
pub struct ShapeEstimator {
    settings: ShapeSettings,
}

impl ShapeEstimator {
    /// Checks the settings.
    pub fn new(settings: ShapeSettings) -> Result<Self, ShapeError> {
        settings.validate()?;
        Ok(ShapeEstimator { settings })
    }

    /// The settings.
    pub fn settings(&self) -> &ShapeSettings {
        &self.settings
    }

    /// The shape of the tube in `occupancy`, with `bands` as [`flexshape_carve::find_bands`]
    /// found them in it. Never fails: a cloud that is not one open tube gives a record whose
    /// status says why.
    pub fn estimate(&self, occupancy: &Occupancy, bands: &[Band]) -> ShapeRecord {
        self.estimate_with(occupancy, bands, false).0
    }

    /// As [`ShapeEstimator::estimate`], for a hull in pieces that lie end to end along one
    /// tube, each running on toward the next (a camera's silhouette lost a stretch of it): the
    /// shape of the pieces chained across their gaps, and the gaps (each the two facing end
    /// cells' centroids, world mm), which nothing carved: only the images can say the tube
    /// runs through them. `None` when the hull is not in such pieces.
    pub fn estimate_across_gaps(
        &self,
        occupancy: &Occupancy,
        bands: &[Band],
    ) -> Option<(ShapeRecord, Vec<[[f64; 3]; 2]>)> {
        let (record, gaps) = self.estimate_with(occupancy, bands, true);
        (!gaps.is_empty()).then_some((record, gaps))
    }

    fn estimate_with(
        &self,
        occupancy: &Occupancy,
        bands: &[Band],
        across_gaps: bool,
    ) -> (ShapeRecord, Vec<[[f64; 3]; 2]>) {
        let s = &self.settings;
        let t0 = Instant::now();
        // The carvers refuse such a volume; an occupancy built by hand may still hold one,
        // and nothing measured in it would mean anything.
        if let Err(e) = occupancy.volume.validate() {
            let status = Status::Ambiguous {
                reason: format!("the occupancy's volume cannot be sliced: {e}"),
            };
            return (ShapeRecord::empty(status), Vec::new());
        }
        let mut slices = match order::slice(occupancy, s, across_gaps) {
            Ok(slices) => slices,
            Err(status) => {
                let mut r = ShapeRecord::empty(status);
                r.timings.order_ms = ms(t0);
                return (r, Vec::new());
            }
        };
        let vs = occupancy.volume.voxel_size;
        let voxel = vs.iter().copied().fold(f64::INFINITY, f64::min);
        let undecided = !slices.oriented && !bands::orient(occupancy, bands, &mut slices, s, voxel);
        let t1 = Instant::now();
        let radius = s.radius_mm.unwrap_or_else(|| estimate_radius(&slices, vs));
        let curve = centerline::Centerline::new(&slices, s, &occupancy.volume, radius);
        let mut record = self.sampled(&curve, radius, slices.enters_volume);
        let t2 = Instant::now();
        record.bands = bands::locate(occupancy, bands, &slices, &curve, voxel);
        if slices.leaves_volume {
            record.status = Status::LeavesVolume;
        } else if undecided {
            record.status = self.undirected("reaches the volume's boundary");
            record.direction_guessed = true;
        }
        let t3 = Instant::now();
        self.finish(&mut record, &curve);
        record.timings = Timings {
            order_ms: (t1 - t0).as_secs_f64() * 1e3,
            smooth_ms: (t2 - t1).as_secs_f64() * 1e3,
            bands_ms: (t3 - t2).as_secs_f64() * 1e3,
            arc_fit_ms: ms(t3),
        };
        (record, std::mem::take(&mut slices.gaps))
    }

    /// The status of a shape whose direction nothing decided: neither end `open_by` (what
    /// makes an end the proximal one, e.g. "reaches the volume's boundary"), no hint, and no
    /// band seen running into one end only when `tip_band` says one marks the tip.
    pub fn undirected(&self, open_by: &str) -> Status {
        let cue = if self.settings.tip_band {
            "no band was seen running into one end only (tip_band): set [processing.shape] proximal_hint"
        } else {
            settings::DIRECTION_SETTINGS
        };
        Status::Ambiguous {
            reason: format!(
                "neither end of the tube {open_by} and nothing tells its tip from its proximal end (the centerline's direction is a guess): {cue}"
            ),
        }
    }

    /// The record of a centerline found another way — the tube fitted to the images (see
    /// [`FittedCurve`]) — from its proximal end to its tip, cut at the volume's boundary at the
    /// ends the tube runs through. The status comes from `hull`, the same frame's hull record,
    /// which must hold a shape, except that the bands are counted again (the hull's
    /// `bands_missing` is not carried over); so do the bands unless the fit found its own: each hull
    /// band keeps its place (its centre's nearest point on the new curve; a band ending at the
    /// tip keeps its distance from the tip).
    pub fn record_from_curve(
        &self,
        fitted: FittedCurve<'_>,
        volume: &Volume,
        hull: &ShapeRecord,
    ) -> ShapeRecord {
        let FittedCurve {
            curve,
            radius,
            open,
            bands,
            sigma,
        } = fitted;
        let t0 = Instant::now();
        let curve = centerline::Centerline::fitted(curve, volume, open[0], open[1]);
        let mut record = self.sampled(&curve, radius, open[0]);
        // Bands are counted again on the new curve: the hull's count was its own.
        record.status = match &hull.status {
            Status::BandsMissing { .. } => Status::Ok,
            other => other.clone(),
        };
        record.direction_guessed = hull.direction_guessed;
        if let Some(sigma) = sigma {
            record.sigma = record
                .arc
                .iter()
                .map(|&a| sigma(curve.param_of(a)))
                .collect();
        }
        let t1 = Instant::now();
        record.bands = match bands {
            Some(found) => bands::on_curve(found, &curve, record.length),
            None => bands::carried_over(&hull.bands, hull.length, &record),
        };
        let t2 = Instant::now();
        self.finish(&mut record, &curve);
        record.timings = Timings {
            order_ms: 0.0,
            smooth_ms: (t1 - t0).as_secs_f64() * 1e3,
            bands_ms: (t2 - t1).as_secs_f64() * 1e3,
            arc_fit_ms: ms(t2),
        };
        record
    }

    /// The curve's samples, length, tip and radius in a record of status `ok`.
    fn sampled(&self, curve: &centerline::Centerline, radius: f64, enters: bool) -> ShapeRecord {
        let s = &self.settings;
        let length = curve.length();
        // Evenly spaced, a little closer than `sample_mm` so that no chord exceeds it (the arc
        // table is exact to ~1e-3 mm).
        let steps = (length / (0.999 * s.sample_mm)).ceil().max(1.0) as usize;
        let mut record = ShapeRecord::empty(Status::Ok);
        for i in 0..=steps {
            let arc = length * i as f64 / steps as f64;
            let sample = curve.sample(arc);
            record.points.push(sample.point);
            record.arc.push(arc);
            record.tangent.push(sample.tangent);
            record.curvature.push(sample.curvature);
            record.torsion.push(sample.torsion);
        }
        record.length = length;
        record.tip = record.points[record.points.len() - 1];
        record.tip_direction = record.tangent[record.tangent.len() - 1];
        record.radius = radius;
        record.enters_volume = enters;
        record
    }

    /// Compression, the `bands_missing` status and the arc fit, once the bands are placed.
    fn finish(&self, record: &mut ShapeRecord, curve: &centerline::Centerline) {
        let s = &self.settings;
        record.compression = bands::compression(&s.sections, &record.bands, record.length);
        if record.status == Status::Ok && record.bands.len() < s.expected_bands {
            record.status = Status::BandsMissing {
                found: record.bands.len(),
                expected: s.expected_bands,
            };
        }
        if s.arc_fit.enabled {
            let start = s
                .arc_fit
                .from_band
                .and_then(|b| record.bands.get(b))
                .map_or(s.arc_fit.start_arc_mm, |b| b.arc_length);
            record.arc_fit = arcfit::fit(curve, start, &s.arc_fit);
        }
    }
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Tube radius from the mean cross-section of the middle 80 % of the slices, mm (the visual
/// hull's cross-section is a little larger than the tube's).
fn estimate_radius(slices: &order::Slices, voxel_size: [f64; 3]) -> f64 {
    let n = slices.count.len();
    let inner = &slices.count[n / 10..(n - n / 10).max(n / 10 + 1)];
    let mean = inner.iter().sum::<f64>() / inner.len() as f64;
    let area = mean * voxel_size.iter().product::<f64>() / slices.spacing;
    (area / std::f64::consts::PI).sqrt()
}
