//! The smooth centerline from the slices: one cubic spline in the axis parameter, its ends
//! placed from the cloud's extent, and a table from parameter to arc length.
//!
//! End correction: slice centroids stop half a slice short of the cloud's ends, and the
//! cloud's outermost voxel centres sit half a voxel inside its surface. The curve therefore
//! runs (continued straight beyond the last slices) from where it crosses the volume's
//! boundary, when the tube enters there (a tube entering obliquely touches the boundary over
//! a length of r·tan θ, so its outermost voxel is not the entry), to the tip — or to where it
//! leaves the volume, when the tube runs out through the boundary. A free end (the
//! tip, or a proximal end inside the volume) is placed at the mean of two estimates of where
//! the centerline ends:
//! - the apex (the far voxel centre plus half a voxel) less the cap (one radius for a rounded
//!   end): biased outward, because the visual hull runs on past the end where no camera sees
//!   the end side-on (the hull of a sphere seen by three orthogonal cameras reaches 1.22 r
//!   along a diagonal);
//! - the point where the cross-section falls to half the tube's, less the cap's offset there
//!   (r/√2 for a hemisphere, 0 for a flat face): unbiased, but noisy (the last slices hold a
//!   few voxels each).
//!
//! On the default simulated rig (20 frames) the errors along the tip direction were
//! +0.2…+1.3 mm for the first, −1.1…+0.7 mm for the second, and −0.4…+0.65 mm for their mean.

use flexshape_curve::BSpline3;
use flexshape_rig::Volume;
use nalgebra::Point3;

use crate::order::{Slices, dot};
use crate::settings::{ShapeSettings, Smoothing, TipEnd};
use crate::spline::{CubicSpline3, Derivatives, moving_average, polynomial_fit};

/// Parameter step of the arc-length table, mm: its chords fall short of the arc by κ²h²/24 of
/// it, under 1e-5 of the length for bends down to 20 mm radius (0.002 mm over 224 mm); a
/// tenth of a millimetre cost a tracked frame 0.2 ms for nothing the record shows.
const TABLE_STEP: f64 = 0.25;

/// The smooth curve under a centerline.
#[derive(Debug, Clone)]
pub(crate) enum Smooth {
    /// Through the hull's slices.
    Natural(CubicSpline3),
    /// Fitted elsewhere (to the images).
    BSpline(BSpline3),
}

impl Smooth {
    fn eval(&self, x: f64) -> Derivatives {
        match self {
            Smooth::Natural(s) => s.eval(x),
            Smooth::BSpline(b) => b.eval(x),
        }
    }

    /// The position alone (a fitted B-spline's at a third of the cost of all derivatives).
    fn value(&self, x: f64) -> [f64; 3] {
        match self {
            Smooth::Natural(s) => s.eval(x).value,
            Smooth::BSpline(b) => b.point_and_d1(x).0,
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Centerline {
    spline: Smooth,
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
    pub fn new(slices: &Slices, settings: &ShapeSettings, volume: &Volume, radius: f64) -> Self {
        let voxel = volume
            .voxel_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
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
        let spline = Smooth::Natural(spline);
        let cap = match settings.tip_end {
            TipEnd::Rounded => radius,
            TipEnd::Flat => 0.0,
        };
        // A tube that steps in radius: each end is judged against its own section's
        // cross-section (the median over all slices is the thickest section's), and the
        // proximal end's cap is that section's radius.
        let steps = &settings.radius_steps;
        let extent = slices.s_range[1] - slices.s_range[0];
        let tip_window = steps.first().map(|s| s.from_tip_mm);
        let base_window = steps.last().map(|s| extent - s.from_tip_mm);
        let base_cap = match (settings.tip_end, steps.last()) {
            (TipEnd::Rounded, Some(s)) => s.radius_mm,
            _ => cap,
        };
        let start = if slices.enters_volume {
            crossing(&spline, volume, knots[0], -1.0)
        } else {
            -end_param(&mirrored(slices), voxel, base_cap, base_window)
        };
        let end = if slices.leaves_volume {
            crossing(&spline, volume, knots[knots.len() - 1], 1.0)
        } else {
            end_param(slices, voxel, cap, tip_window)
        }
        .max(start + voxel);
        Self::over(spline, start, end, TABLE_STEP)
    }

    /// A fitted curve over its whole parameter range `[0, 1]`, cut where it crosses the
    /// volume's boundary at an end where `enters` / `leaves` say the tube runs through it.
    pub fn fitted(curve: BSpline3, volume: &Volume, enters: bool, leaves: bool) -> Self {
        let spline = Smooth::BSpline(curve);
        let start = if enters {
            crossing(&spline, volume, 0.0, -1.0)
        } else {
            0.0
        };
        let end = if leaves {
            crossing(&spline, volume, 1.0, 1.0)
        } else {
            1.0
        };
        let speed = |u: f64| dot(spline.eval(u).d1, spline.eval(u).d1).sqrt().max(1e-9);
        // About TABLE_STEP mm per entry.
        let step = TABLE_STEP / speed(0.5);
        Self::over(spline, start, end.max(start + step), step)
    }

    fn over(spline: Smooth, start: f64, end: f64, table_step: f64) -> Self {
        let steps = ((end - start) / table_step).ceil().max(1.0) as usize;
        // The last entry is `end` itself: `start + (end − start)` may round past it, and a
        // tip read a rounding beyond the curve's end is on its straight continuation, with
        // no curvature.
        let params: Vec<f64> = (0..=steps)
            .map(|i| {
                if i == steps {
                    end
                } else {
                    start + (end - start) * i as f64 / steps as f64
                }
            })
            .collect();
        let mut arcs = Vec::with_capacity(params.len());
        let mut prev = spline.value(start);
        let mut total = 0.0;
        for &p in &params {
            let v = spline.value(p);
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
        self.spline.value(self.param_of(arc))
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

/// Where the curve, near parameter `from` (an end knot) and continued straight beyond it,
/// crosses the volume's box at that end: `outward` is −1 at the proximal end (the entry) and
/// +1 at the distal one. The end slices of a tube crossing obliquely are partial and their axis
/// point can lie outside the box, so the search runs inward from there, or outward when that
/// point is inside.
fn crossing(spline: &Smooth, volume: &Volume, from: f64, outward: f64) -> f64 {
    let inside = |s: f64| volume.contains(&Point3::from(spline.eval(s).value));
    let d1 = spline.eval(from).d1;
    // A quarter voxel along the curve, in parameter units.
    let speed = dot(d1, d1).sqrt().max(1e-9);
    let step = outward
        * volume
            .voxel_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
        / 4.0
        / speed;
    let diagonal = volume
        .voxel_size
        .iter()
        .zip(&volume.dims)
        .map(|(v, &d)| (v * d as f64).powi(2))
        .sum::<f64>()
        .sqrt();
    let diagonal = diagonal / speed;
    let (mut out, mut inn) = (from, from);
    if inside(from) {
        while inside(out) && (out - from).abs() < diagonal {
            out += step;
        }
    } else {
        while !inside(inn) && (inn - from).abs() < diagonal {
            inn -= step;
        }
    }
    if out == inn {
        return from;
    }
    for _ in 0..40 {
        let mid = (out + inn) / 2.0;
        if inside(mid) {
            inn = mid;
        } else {
            out = mid;
        }
    }
    inn
}

/// Where the centerline ends at the far end of `slices`, for an end cap reaching `cap` mm
/// beyond it (a hemisphere: the radius; a flat face: 0). The mean of two estimates (see the
/// module docs): the apex (outermost voxel centre plus half a voxel) less the cap, and the
/// point where the cross-section falls to half the median slice's, less the cap's offset there
/// (`cap/√2`: a hemisphere of radius r has half its section at r/√2). With `window`, the median
/// is taken over the slices within that many mm of the end only (the end's own section of a
/// tube that steps in radius).
fn end_param(slices: &Slices, voxel: f64, cap: f64, window: Option<f64>) -> f64 {
    let apex = slices.s_range[1] + voxel / 2.0;
    let near: Vec<f64> = match window {
        Some(w) => slices
            .s
            .iter()
            .zip(&slices.count)
            .filter(|(s, _)| **s >= apex - w)
            .map(|(_, c)| *c)
            .collect(),
        None => Vec::new(),
    };
    let mut sorted = if near.len() >= 3 {
        near
    } else {
        slices.count.clone()
    };
    sorted.sort_by(f64::total_cmp);
    let half = sorted[sorted.len() / 2] / 2.0;
    let n = slices.count.len();
    let mut at_half = slices.s[n - 1];
    for i in (0..n).rev() {
        if slices.count[i] >= half {
            at_half = if i + 1 == n {
                slices.s[i] + slices.spacing / 2.0
            } else {
                let (c0, c1) = (slices.count[i], slices.count[i + 1]);
                let t = (c0 - half) / (c0 - c1).max(1e-9);
                slices.s[i] + t * (slices.s[i + 1] - slices.s[i])
            };
            break;
        }
    }
    ((apex - cap) + (at_half - cap * std::f64::consts::FRAC_1_SQRT_2)) / 2.0
}

/// The slices seen from the other end (parameters negated and reversed).
fn mirrored(slices: &Slices) -> Slices {
    let mut m = slices.clone();
    m.s = slices.s.iter().rev().map(|s| -s).collect();
    m.count.reverse();
    m.centroid.reverse();
    m.s_range = [-slices.s_range[1], -slices.s_range[0]];
    m
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A start at which `start + (1 − start)·n/n` rounds past 1 must still leave the tip on the
    /// curve: read on its straight continuation, the tip's curvature would be 0.
    #[test]
    fn the_tip_of_the_table_is_the_curve_end_itself() {
        let curve = BSpline3::new(
            (0..8)
                .map(|i| {
                    let a = i as f64 * 0.3;
                    [60.0 * a.sin(), 0.0, 60.0 * a.cos()]
                })
                .collect(),
        )
        .unwrap();
        let start = 0.005848;
        let steps = 401;
        let step = (1.0 - start) / steps as f64;
        assert!(start + (1.0 - start) * steps as f64 / steps as f64 > 1.0);
        let line = Centerline::over(Smooth::BSpline(curve), start, 1.0, step);
        assert_eq!(line.tip_param(), 1.0);
        let (tip, before) = (line.sample(line.length()), line.sample(line.length() - 0.5));
        assert!(
            tip.curvature > 0.5 * before.curvature,
            "tip {} against {} half a millimetre before",
            tip.curvature,
            before.curvature
        );
    }
}
