//! The smooth centerline from the slices: one cubic spline in the axis parameter, its ends
//! placed from the cloud's extent, and a table from parameter to arc length.
//!
//! End correction: slice centroids stop half a slice short of the cloud's ends, and the
//! cloud's outermost voxel centres sit half a voxel inside its surface. The curve therefore
//! runs (continued straight beyond the last slices) from the outermost voxel centre's
//! parameter minus half a voxel (the volume's boundary, where the tube enters) to the far
//! one plus half a voxel (the tube's apex); for a rounded tip the centerline ends one radius
//! before the apex.

use crate::order::{Slices, dot};
use crate::settings::{ShapeSettings, Smoothing, TipEnd};
use crate::spline::{CubicSpline3, Derivatives, moving_average, polynomial_fit};

/// Parameter step of the arc-length table, mm.
const TABLE_STEP: f64 = 0.1;

#[derive(Debug, Clone)]
pub(crate) struct Centerline {
    spline: CubicSpline3,
    /// Parameters of the table's entries (uniform, from the proximal end to the tip).
    params: Vec<f64>,
    /// Arc length at each entry, mm.
    arcs: Vec<f64>,
}

/// One output sample.
pub(crate) struct Sample {
    pub point: [f64; 3],
    pub tangent: [f64; 3],
    pub curvature: f64,
    pub torsion: f64,
}

impl Centerline {
    /// The curve through `slices`, from the proximal end to the tip of a tube of `radius` mm.
    pub fn new(slices: &Slices, settings: &ShapeSettings, voxel: f64, radius: f64) -> Self {
        // Knots must increase strictly.
        let mut knots = Vec::with_capacity(slices.s.len());
        let mut data = Vec::with_capacity(slices.s.len());
        let mut weights = Vec::with_capacity(slices.s.len());
        for ((&s, &c), &w) in slices.s.iter().zip(&slices.centroid).zip(&slices.count) {
            if knots.last().is_some_and(|&k: &f64| s <= k + 1e-9) {
                continue;
            }
            knots.push(s);
            data.push(c);
            weights.push(w);
        }
        let mean_w = weights.iter().sum::<f64>() / weights.len() as f64;
        for w in &mut weights {
            *w /= mean_w;
        }
        let spline = match settings.smoothing {
            Smoothing::Spline { bandwidth_mm } => CubicSpline3::smoothing(
                &knots,
                &data,
                &weights,
                bandwidth_mm.powi(4) / slices.spacing,
            ),
            Smoothing::MovingAverage { window } => {
                CubicSpline3::interpolating(&knots, &moving_average(&data, window))
            }
            Smoothing::Polynomial { degree } => {
                CubicSpline3::interpolating(&knots, &polynomial_fit(&knots, &data, degree))
            }
        };
        let [lo, _] = slices.s_range;
        let start = lo - voxel / 2.0;
        let half = half_section(slices);
        let end = match settings.tip_end {
            TipEnd::Rounded => half - radius * std::f64::consts::FRAC_1_SQRT_2,
            TipEnd::Flat => half,
        }
        .max(start + voxel);
        let steps = ((end - start) / TABLE_STEP).ceil().max(1.0) as usize;
        let params: Vec<f64> = (0..=steps)
            .map(|i| start + (end - start) * i as f64 / steps as f64)
            .collect();
        let mut arcs = Vec::with_capacity(params.len());
        let mut prev = spline.eval(start).value;
        let mut total = 0.0;
        for &p in &params {
            let v = spline.eval(p).value;
            total += crate::order::dist(prev, v);
            arcs.push(total);
            prev = v;
        }
        Centerline {
            spline,
            params,
            arcs,
        }
    }

    /// Length from the proximal end to the tip, mm.
    pub fn length(&self) -> f64 {
        self.arcs[self.arcs.len() - 1]
    }

    /// Arc length (mm) at an axis parameter, clamped to the curve.
    pub fn arc_of(&self, param: f64) -> f64 {
        interpolate(&self.params, &self.arcs, param)
    }

    /// Axis parameter at an arc length.
    pub fn param_of(&self, arc: f64) -> f64 {
        interpolate(&self.arcs, &self.params, arc)
    }

    /// Axis parameter of the tip.
    pub fn tip_param(&self) -> f64 {
        self.params[self.params.len() - 1]
    }

    /// Point at an arc length, world mm.
    pub fn point_at(&self, arc: f64) -> [f64; 3] {
        self.spline.eval(self.param_of(arc)).value
    }

    /// Point, tangent, curvature and torsion at an arc length.
    pub fn sample(&self, arc: f64) -> Sample {
        let Derivatives { value, d1, d2, d3 } = self.spline.eval(self.param_of(arc));
        let speed = dot(d1, d1).sqrt().max(1e-12);
        let c = cross(d1, d2);
        let c2 = dot(c, c);
        Sample {
            point: value,
            tangent: d1.map(|v| v / speed),
            curvature: c2.sqrt() / speed.powi(3),
            torsion: if c2 > 1e-18 { dot(c, d3) / c2 } else { 0.0 },
        }
    }
}

/// Axis parameter, from the distal end, where the cloud's cross-section falls to half the
/// tube's (the median slice): a hemispherical cap of radius r is at half its section r/√2
/// beyond the centerline's end; a flat end at its face. Less sensitive than the outermost
/// voxel to the visual hull's overshoot past the end.
fn half_section(slices: &Slices) -> f64 {
    let mut sorted = slices.count.clone();
    sorted.sort_by(f64::total_cmp);
    let half = sorted[sorted.len() / 2] / 2.0;
    let n = slices.count.len();
    for i in (0..n).rev() {
        if slices.count[i] >= half {
            if i + 1 == n {
                return slices.s[i] + slices.spacing / 2.0;
            }
            let (c0, c1) = (slices.count[i], slices.count[i + 1]);
            let t = (c0 - half) / (c0 - c1).max(1e-9);
            return slices.s[i] + t * (slices.s[i + 1] - slices.s[i]);
        }
    }
    slices.s[n - 1]
}

/// Piecewise-linear `y(x)` for increasing `xs`, clamped at the ends.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|&v| v <= x).clamp(1, n - 1);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]).max(1e-300);
    ys[i - 1] + t * (ys[i] - ys[i - 1])
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
