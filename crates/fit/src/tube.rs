//! The tube the fit moves: a smooth centerline (clamped cubic B-spline from the proximal end,
//! `u = 0`, to the tip, `u = 1`), a constant radius and, at each end, whether the tube ends
//! there in a hemispherical cap (a free end) or runs on out of the volume (an open end).
//! World frame, mm.

use flexshape_curve::{BSpline3, CurveError, Polyline};
use nalgebra::{Point3, Vector3};

/// A swept sphere along a B-spline centerline.
#[derive(Debug, Clone, PartialEq)]
pub struct Tube {
    /// Centerline, world mm, proximal end at `u = 0`.
    pub centerline: BSpline3,
    /// Radius, mm.
    pub radius: f64,
    /// Whether the proximal end (`[0]`) and the tip (`[1]`) end in hemispherical caps; an
    /// end without one runs on out of the working volume.
    pub capped: [bool; 2],
}

impl Tube {
    /// A tube through `points` (proximal first, world mm) with control points about `span_mm`
    /// apart. An open end is continued straight by `extend_mm`, so that the fitted curve still
    /// reaches the volume's boundary when it moves.
    pub fn through(
        points: &[[f64; 3]],
        radius: f64,
        capped: [bool; 2],
        span_mm: f64,
        extend_mm: f64,
    ) -> Result<Self, CurveError> {
        let poly = Polyline::new(points.iter().map(|&p| Point3::from(p)).collect())?;
        let length = poly.length();
        let (start, end) = (poly.tangent_at(0.0), poly.tangent_at(length));
        let mut pts: Vec<Point3<f64>> = Vec::new();
        let mut arcs: Vec<f64> = Vec::new();
        let ext = [
            if capped[0] { 0.0 } else { extend_mm },
            if capped[1] { 0.0 } else { extend_mm },
        ];
        let total = length + ext[0] + ext[1];
        let step = 0.5;
        let n = (total / step).ceil().max(2.0) as usize;
        for i in 0..=n {
            let s = total * i as f64 / n as f64 - ext[0];
            let p = if s < 0.0 {
                poly.point_at(0.0) + start * s
            } else if s > length {
                poly.point_at(length) + end * (s - length)
            } else {
                poly.point_at(s)
            };
            pts.push(p);
            arcs.push((s + ext[0]) / total);
        }
        let spans = (total / span_mm).round().max(1.0) as usize;
        let data: Vec<[f64; 3]> = pts.iter().map(|p| [p.x, p.y, p.z]).collect();
        Ok(Tube {
            centerline: BSpline3::fit(&arcs, &data, spans + 3)?,
            radius,
            capped,
        })
    }

    /// Number of free parameters: three per control point, and the radius.
    pub fn parameters(&self) -> usize {
        3 * self.centerline.control().len() + 1
    }

    /// Moves the tube by a parameter step (control points, then the radius, as
    /// [`Tube::parameters`] counts them; mm); the radius stays above 0.05 mm.
    pub(crate) fn apply(&mut self, step: &nalgebra::DVector<f64>) {
        let n = step.len();
        self.centerline.displace(&step.rows(0, n - 1).into_owned());
        self.radius = (self.radius + step[n - 1]).max(0.05);
    }

    /// Unit direction of the control polygon at control point `k` (from its neighbour before
    /// to its neighbour after): the direction along the tube in which moving that point
    /// hardly moves the outline.
    pub fn control_tangent(&self, k: usize) -> Vector3<f64> {
        let ctrl = self.centerline.control();
        let last = ctrl.len() - 1;
        let t = Vector3::from(ctrl[(k + 1).min(last)]) - Vector3::from(ctrl[k.saturating_sub(1)]);
        t / t.norm().max(1e-12)
    }

    /// Centre and unit tangent (toward the tip) at `u`.
    pub fn frame(&self, u: f64) -> (Point3<f64>, Vector3<f64>) {
        let d = self.centerline.eval(u);
        let t = Vector3::from(d.d1);
        (Point3::from(d.value), t / t.norm().max(1e-300))
    }

    /// Where an end is and which way the tube goes on beyond it (unit, pointing out of the
    /// tube): the chord over its last 20 mm (or a quarter of the tube), steadier than the end
    /// tangent, which the last few millimetres of outline hardly fix. `end` 0 is the proximal
    /// end, 1 the tip.
    pub fn beyond(&self, end: usize) -> (Point3<f64>, Vector3<f64>) {
        let reach = (20.0 / self.length().max(1e-9)).min(0.25);
        let (u, inner) = if end == 0 {
            (0.0, reach)
        } else {
            (1.0, 1.0 - reach)
        };
        let (p, t) = self.frame(u);
        let chord = p - self.frame(inner).0;
        let n = chord.norm();
        let dir = if n > 1e-9 {
            chord / n
        } else if end == 0 {
            -t
        } else {
            t
        };
        (p, dir)
    }

    /// Length of the centerline, mm (Simpson's rule over 4 points a span).
    pub fn length(&self) -> f64 {
        let n = 4 * (self.centerline.control().len() - 3);
        let speed = |u: f64| Vector3::from(self.centerline.eval(u).d1).norm();
        let h = 1.0 / (2 * n) as f64;
        (0..n)
            .map(|i| {
                let a = 2.0 * i as f64 * h;
                h / 3.0 * (speed(a) + 4.0 * speed(a + h) + speed(a + 2.0 * h))
            })
            .sum()
    }
}
