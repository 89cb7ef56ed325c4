//! The tube the fit moves: a smooth centerline (clamped cubic B-spline from the proximal end,
//! `u = 0`, to the tip, `u = 1`), a radius (constant, or stepping up at given distances from
//! the tip) and, at each end, whether the tube ends there in a hemispherical cap (a free end)
//! or runs on out of the volume (an open end). World frame, mm.

use flexshape_curve::{BSpline3, CurveError, Polyline, RadiusStep, radius_at, section_at};
use nalgebra::{Point3, Vector3};

/// Half-millimetre steps an open end that stops inside the volume is run on by at most, to
/// reach its boundary (2 m).
const MAX_RUN_ON: usize = 4000;

/// Samples (an eighth of a span apart, about 2 mm) over which an open end's direction is
/// taken when it is run on.
const CHORD_SAMPLES: usize = 3;

/// A swept sphere along a B-spline centerline.
#[derive(Debug, Clone, PartialEq)]
pub struct Tube {
    /// Centerline, world mm, proximal end at `u = 0`.
    pub centerline: BSpline3,
    /// Radius, mm: the tip section's when the tube steps in diameter (`steps`). The fit may
    /// move it; the steps' radii are known and stay.
    pub radius: f64,
    /// Where the radius steps, by arc length from the tip (empty: constant).
    pub steps: Vec<RadiusStep>,
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
            steps: Vec::new(),
            capped,
        })
    }

    /// The same tube stepping in radius at `steps` (by arc length from the tip).
    pub fn with_steps(mut self, steps: &[RadiusStep]) -> Self {
        self.steps = steps.to_vec();
        self
    }

    /// The radius at `u` of a tube `length` mm long (the parameter taken as proportional to
    /// arc length, as [`Tube::through`] makes it and the fit keeps it to well within the
    /// margin left around each step), mm.
    pub fn radius_at(&self, u: f64, length: f64) -> f64 {
        radius_at(self.radius, &self.steps, (1.0 - u) * length)
    }

    /// Which radius section `u` lies in (0: the tip's; see [`Tube::radius_at`]).
    pub(crate) fn section_at(&self, u: f64, length: f64) -> usize {
        section_at(&self.steps, (1.0 - u) * length)
    }

    /// The radius of section `k` (0: the tip's, [`Tube::radius`]; `k`: proximal of step
    /// `k − 1`), mm.
    pub(crate) fn section_radius(&self, k: usize) -> f64 {
        match k {
            0 => self.radius,
            k => self.steps[(k - 1).min(self.steps.len() - 1)].radius_mm,
        }
    }

    /// The largest radius along the tube, mm.
    pub fn largest_radius(&self) -> f64 {
        self.steps
            .iter()
            .map(|s| s.radius_mm)
            .fold(self.radius, f64::max)
    }

    /// Each radius step's shoulder: where it is, arc length from the tip, mm, and the larger
    /// of the radii it joins (its rounded end's), mm.
    pub(crate) fn shoulders(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        let before = std::iter::once(self.radius).chain(self.steps.iter().map(|s| s.radius_mm));
        self.steps
            .iter()
            .zip(before)
            .map(|(s, before)| (s.from_tip_mm, before.max(s.radius_mm)))
    }

    /// Whether `u` lies at a step's shoulder: within the larger radius plus a millimetre of
    /// it, where the outline turns from one radius to the other in a way the model leaves out.
    pub(crate) fn at_shoulder(&self, u: f64, length: f64) -> bool {
        let from_tip = (1.0 - u) * length;
        self.shoulders()
            .any(|(at, larger)| (from_tip - at).abs() < larger + 1.0)
    }

    /// Number of free parameters: three per control point, then the radius of every section
    /// (the tip's, then each step's).
    pub fn parameters(&self) -> usize {
        self.radius_column(0) + 1 + self.steps.len()
    }

    /// The parameter column of section `k`'s radius (0: the tip's).
    pub(crate) fn radius_column(&self, k: usize) -> usize {
        3 * self.centerline.control().len() + k
    }

    /// Moves the tube by a parameter step (control points, then the radii, as
    /// [`Tube::parameters`] counts them; mm); radii stay above 0.05 mm.
    pub(crate) fn apply(&mut self, step: &nalgebra::DVector<f64>) {
        let r0 = self.radius_column(0);
        self.centerline.displace(&step.rows(0, r0).into_owned());
        self.radius = (self.radius + step[r0]).max(0.05);
        for (k, s) in self.steps.iter_mut().enumerate() {
            s.radius_mm = (s.radius_mm + step[r0 + 1 + k]).max(0.05);
        }
    }

    /// Whether `other` steps at the same places (whatever its radii).
    pub fn steps_at_same_places(&self, other: &[RadiusStep]) -> bool {
        self.steps.len() == other.len()
            && self
                .steps
                .iter()
                .zip(other)
                .all(|(a, b)| a.from_tip_mm == b.from_tip_mm)
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

    /// The part of a move `d` of control point `k` across the tube: its part along
    /// [`Tube::control_tangent`] left out.
    pub fn across(&self, k: usize, d: Vector3<f64>) -> Vector3<f64> {
        let t = self.control_tangent(k);
        d - t * d.dot(&t)
    }

    /// Whether the control points are still about evenly spread along the tube: every side
    /// of the control polygon, the clamped ends' first two scaled to a whole span (a clamped
    /// uniform spline places them a third and two thirds of a span apart), within a factor of
    /// 1.5 of the others. A tube moved from frame to frame lets them drift along it (a tip's
    /// last control points creep toward it, which its cap hardly resists); one fitted afresh
    /// through its centerline spreads them again. Everything that places a
    /// point on the tube by its length (`u · length`) relies on this.
    pub fn evenly_spread(&self) -> bool {
        let ctrl = self.centerline.control();
        let n = ctrl.len();
        if n < 7 {
            return true;
        }
        let design = |k: usize| match k.min(n - 2 - k) {
            0 => 3.0,
            1 => 1.5,
            _ => 1.0,
        };
        let sides: Vec<f64> = (0..n - 1)
            .map(|k| design(k) * (Vector3::from(ctrl[k + 1]) - Vector3::from(ctrl[k])).norm())
            .collect();
        let lo = sides.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = sides.iter().copied().fold(0.0, f64::max);
        hi <= 1.5 * lo
    }

    /// This tube, or when its control points are no longer about evenly spread
    /// ([`Tube::evenly_spread`]) the same curve through control points about `span_mm` apart,
    /// as [`Tube::through`] places them (ends, radii and steps kept). `None` when that fit
    /// fails.
    pub fn spread_again(&self, span_mm: f64) -> Option<Tube> {
        if self.evenly_spread() {
            return Some(self.clone());
        }
        // Sampled far closer than the control points are spaced: the new curve follows the
        // old one to a few hundredths of a millimetre (what the followed fit then corrects,
        // against a frame's motion lost by starting from the previous shape).
        let n = 8 * self.centerline.control().len();
        let points: Vec<[f64; 3]> = (0..=n)
            .map(|i| self.frame(i as f64 / n as f64).0.into())
            .collect();
        // Already continued beyond any open end: continued no further.
        let mut tube = Tube::through(&points, self.radius, self.capped, span_mm, 0.0).ok()?;
        tube.steps = self.steps.clone();
        Some(tube)
    }

    /// This tube with each open end again `extend_mm` beyond where it leaves the region that
    /// `depth` measures (mm inside it, negative outside: the working volume), through control
    /// points about `span_mm` apart; `None` when every open end is already within half of
    /// `extend_mm` of that, or the tube never enters the region. Nothing in the images ends an
    /// open end, so a followed fit only holds it where it started: carried on frame after
    /// frame, one slid 21 mm along a tube being inserted, 11 mm into the volume, and the
    /// reported centerline's base, continued straight from there, stood 0.6 mm off.
    pub fn reopened(
        &self,
        depth: impl Fn(Point3<f64>) -> f64,
        extend_mm: f64,
        span_mm: f64,
    ) -> Option<Tube> {
        // Sampled far closer than the control points are spaced (as `spread_again`).
        let n = 8 * self.centerline.control().len();
        // How far each end runs on beyond the region, found walking in from it over a few
        // samples (nearly always each open end is where it belongs): the whole tube is
        // sampled only when one is not.
        let beyond = [0, 1].map(|e| self.beyond_from(e, n, &depth));
        let in_place = |e: usize| {
            self.capped[e] || beyond[e].is_some_and(|b| (b - extend_mm).abs() <= 0.5 * extend_mm)
        };
        if in_place(0) && in_place(1) {
            return None;
        }
        // `None`: no sample inside.
        let beyond = [beyond[0]?, beyond[1]?];
        let points: Vec<Point3<f64>> = (0..=n).map(|i| self.frame(i as f64 / n as f64).0).collect();
        let depths: Vec<f64> = points.iter().map(|&p| depth(p)).collect();
        let first = depths.iter().position(|&d| d > 0.0)?;
        let last = depths.iter().rposition(|&d| d > 0.0)?;
        // Where the tube crosses the boundary between samples `inner` (inside) and `outer`.
        let crossing = |inner: usize, outer: usize| {
            let f = depths[inner] / (depths[inner] - depths[outer]);
            points[inner] + (points[outer] - points[inner]) * f
        };
        // The part inside, from where it enters to where it leaves.
        let mut kept: Vec<Point3<f64>> = Vec::with_capacity(last - first + 3);
        if first > 0 {
            kept.push(crossing(first, first - 1));
        }
        kept.extend_from_slice(&points[first..=last]);
        if last < n {
            kept.push(crossing(last, last + 1));
        }
        // An open end that stops inside runs on straight to the region's boundary first, in
        // its direction over the last few millimetres (a chord: a clamped spline's last
        // samples may bend a little).
        let chord = CHORD_SAMPLES.min(kept.len() - 1);
        for (e, (&capped, &beyond)) in self.capped.iter().zip(&beyond).enumerate() {
            if capped || beyond > 0.0 || chord == 0 {
                continue;
            }
            if e == 0 {
                let run = run_on(kept[0], kept[chord], &depth);
                kept.splice(0..0, run.into_iter().rev());
            } else {
                let n = kept.len() - 1;
                let run = run_on(kept[n], kept[n - chord], &depth);
                kept.extend(run);
            }
        }
        let kept: Vec<[f64; 3]> = kept.iter().map(|p| [p.x, p.y, p.z]).collect();
        let mut tube = Tube::through(&kept, self.radius, self.capped, span_mm, extend_mm).ok()?;
        tube.steps = self.steps.clone();
        Some(tube)
    }

    /// How far end `end` (0 proximal, 1 tip) runs on beyond the region `depth` measures, mm
    /// (negative: it stops inside), walking in from it over the `n + 1` samples `reopened`
    /// takes; `None` when no sample is inside.
    fn beyond_from(
        &self,
        end: usize,
        n: usize,
        depth: &impl Fn(Point3<f64>) -> f64,
    ) -> Option<f64> {
        let at = |k: usize| {
            let i = if end == 0 { k } else { n - k };
            self.frame(i as f64 / n as f64).0
        };
        let mut outer = at(0);
        let mut outer_depth = depth(outer);
        if outer_depth > 0.0 {
            return Some(-outer_depth);
        }
        let mut arc = 0.0;
        for k in 1..=n {
            let p = at(k);
            let d = depth(p);
            let step = (p - outer).norm();
            if d > 0.0 {
                return Some(arc + step * outer_depth / (outer_depth - d));
            }
            arc += step;
            (outer, outer_depth) = (p, d);
        }
        None
    }

    /// This tube carried on as it moved since `earlier`: each control point moved again by
    /// `ratio` times its move since then (the next frame of a smooth motion, `ratio` its
    /// frames ahead over the frames between the two). Should an inner control point's move
    /// exceed `slide_mm`, every inner point is moved across the tube only: such a move is a
    /// slide along the tube (the fit spreads its control points again now and then, and a
    /// tip's crowd them), which carries no motion on, and discarding the whole prediction for
    /// it started a fast-moving frame a frame's motion behind. `None` when the tubes do not
    /// pair up point for point (another number of control points, other ends), or an end, or
    /// an inner point across the tube, would move more than `limit_mm`.
    pub fn carried_on(
        &self,
        earlier: &Tube,
        ratio: f64,
        slide_mm: f64,
        limit_mm: f64,
    ) -> Option<Tube> {
        let (now, then) = (self.centerline.control(), earlier.centerline.control());
        if now.len() != then.len()
            || self.capped != earlier.capped
            || ratio.is_nan()
            || ratio <= 0.0
        {
            return None;
        }
        let last = now.len() - 1;
        let moves: Vec<Vector3<f64>> = now
            .iter()
            .zip(then)
            .map(|(a, b)| (Vector3::from(*a) - Vector3::from(*b)) * ratio)
            .collect();
        // NaN moves fail every comparison, so `!(‖d‖ ≤ limit)` catches them too.
        let within = |d: &Vector3<f64>, limit: f64| d.norm() <= limit;
        let slid = moves[1..last].iter().any(|d| !within(d, slide_mm));
        let mut step = nalgebra::DVector::zeros(3 * now.len());
        for (k, d) in moves.into_iter().enumerate() {
            let d = if slid && k > 0 && k < last {
                self.across(k, d)
            } else {
                d
            };
            if !within(&d, limit_mm) {
                return None;
            }
            step.fixed_rows_mut::<3>(3 * k).copy_from(&d);
        }
        let mut tube = self.clone();
        tube.centerline.displace(&step);
        Some(tube)
    }

    /// The same tube taken from its other end (the tip becomes the proximal end, the caps
    /// change ends), or `None` for a tube that steps in radius: its steps are placed from the
    /// tip, so the other way round it is another tube.
    pub fn reversed(&self) -> Option<Tube> {
        self.steps.is_empty().then(|| Tube {
            centerline: self.centerline.reversed(),
            radius: self.radius,
            steps: Vec::new(),
            capped: [self.capped[1], self.capped[0]],
        })
    }

    /// Centre and unit tangent (toward the tip) at `u`.
    pub fn frame(&self, u: f64) -> (Point3<f64>, Vector3<f64>) {
        let (p, d1) = self.centerline.point_and_d1(u);
        let t = Vector3::from(d1);
        (Point3::from(p), t / t.norm().max(1e-300))
    }

    /// The centerline parameter of the point nearest `p` (world mm): the nearest of points
    /// about half a millimetre apart, refined by a golden-section search between its
    /// neighbours.
    pub fn nearest_u(&self, p: &Point3<f64>) -> f64 {
        let n = ((self.length() / 0.5).ceil() as usize).clamp(2, 4096);
        let d2 = |u: f64| (Point3::from(self.centerline.point_and_d1(u).0) - p).norm_squared();
        let step = 1.0 / n as f64;
        let k = (0..=n)
            .min_by(|&a, &b| d2(a as f64 * step).total_cmp(&d2(b as f64 * step)))
            .unwrap_or(0);
        let (mut lo, mut hi) = ((k as f64 - 1.0) * step, (k as f64 + 1.0) * step);
        (lo, hi) = (lo.max(0.0), hi.min(1.0));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..20 {
            let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if d2(a) < d2(b) {
                hi = b;
            } else {
                lo = a;
            }
        }
        (lo + hi) / 2.0
    }

    /// Where an end is and which way the tube goes on beyond it (unit, pointing out of the
    /// tube): the chord over its last 20 mm (or a quarter of the tube), steadier than the end
    /// tangent, which the last few millimetres of outline hardly fix. `end` 0 is the proximal
    /// end, 1 the tip.
    pub fn beyond(&self, end: usize) -> (Point3<f64>, Vector3<f64>) {
        // The control polygon's length stands in for the curve's (a little longer; this only
        // chooses how far back the chord reaches, and is far cheaper than integrating).
        let polygon: f64 = self
            .centerline
            .control()
            .windows(2)
            .map(|w| (Vector3::from(w[1]) - Vector3::from(w[0])).norm())
            .sum();
        let reach = (20.0 / polygon.max(1e-9)).min(0.25);
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
        let speed = |u: f64| Vector3::from(self.centerline.point_and_d1(u).1).norm();
        let h = 1.0 / (2 * n) as f64;
        (0..n)
            .map(|i| {
                let a = 2.0 * i as f64 * h;
                h / 3.0 * (speed(a) + 4.0 * speed(a + h) + speed(a + 2.0 * h))
            })
            .sum()
    }
}

/// Points every half millimetre on the straight line from `end` away from `from`, while
/// `depth` says they are inside, then the point where the line crosses the boundary (none
/// beyond [`MAX_RUN_ON`] steps).
fn run_on(
    end: Point3<f64>,
    from: Point3<f64>,
    depth: &impl Fn(Point3<f64>) -> f64,
) -> Vec<Point3<f64>> {
    let dir = (end - from) / (end - from).norm().max(1e-300);
    let mut run = Vec::new();
    let mut inner = (end, depth(end));
    for k in 1..=MAX_RUN_ON {
        let p = end + dir * (0.5 * k as f64);
        let d = depth(p);
        if d <= 0.0 {
            // Between the last point inside and this one.
            run.push(inner.0 + (p - inner.0) * (inner.1 / (inner.1 - d)));
            break;
        }
        run.push(p);
        inner = (p, d);
    }
    run
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check;

    fn bent() -> Tube {
        let points: Vec<[f64; 3]> = (0..=120)
            .map(|i| {
                let a = i as f64 * 0.01;
                [100.0 * a.sin(), 0.0, 100.0 * (1.0 - a.cos())]
            })
            .collect();
        Tube::through(&points, 3.0, [false, true], 15.0, 10.0).unwrap()
    }

    /// How far `p` lies inside the box `lo`–`hi` (negative outside), mm.
    fn depth_in(lo: [f64; 3], hi: [f64; 3]) -> impl Fn(Point3<f64>) -> f64 {
        move |p| {
            (0..3)
                .map(|k| (p[k] - lo[k]).min(hi[k] - p[k]))
                .fold(f64::INFINITY, f64::min)
        }
    }

    /// Largest distance from `tube`'s centerline points inside `depth`'s region to `other`'s
    /// centerline, mm: how far `other` left the part of `tube` inside.
    fn inside_off(tube: &Tube, other: &Tube, depth: &impl Fn(Point3<f64>) -> f64) -> f64 {
        let dense = |t: &Tube| -> Vec<Point3<f64>> {
            (0..=4000).map(|i| t.frame(i as f64 / 4000.0).0).collect()
        };
        let theirs = dense(other);
        dense(tube)
            .into_iter()
            .filter(|&p| depth(p) > 0.0)
            .map(|p| {
                theirs
                    .iter()
                    .map(|q| (p - q).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn an_open_end_that_slid_along_the_tube_is_put_back_beyond_the_volume() {
        // `bent` starts at the origin heading along +x, continued 10 mm straight back.
        let tube = bent();
        let box_from = |x: f64| depth_in([x, -50.0, -50.0], [200.0, 50.0, 150.0]);
        // Entering at x = 0: 10 mm beyond, as it should be.
        assert!(tube.reopened(box_from(0.0), 10.0, 15.0).is_none());
        // Within half the extension either way: left as it is.
        assert!(tube.reopened(box_from(4.0), 10.0, 15.0).is_none());
        assert!(tube.reopened(box_from(-4.0), 10.0, 15.0).is_none());
        // The volume starting 11 mm further on (the end 21 mm beyond it) or 20 mm before (the
        // end 10 mm inside): the end is put 10 mm beyond, the curve inside kept.
        for x in [11.0, -20.0] {
            let depth = box_from(x);
            let again = tube.reopened(&depth, 10.0, 15.0).unwrap();
            let start = again.frame(0.0).0;
            assert!((depth(start) + 10.0).abs() < 0.3, "x {x}: start {start}");
            assert_eq!(again.capped, tube.capped);
            // A few hundredths, as any refit through control points 15 mm apart (here where
            // the straight run meets the bend, a jump in curvature neither spline follows).
            let off = inside_off(&tube, &again, &depth);
            assert!(off < 0.06, "x {x}: {off:.4} mm off the curve");
        }
    }

    #[test]
    fn an_open_end_inside_the_volume_runs_on_straight_out_of_it() {
        let points: Vec<[f64; 3]> = (0..=100).map(|i| [i as f64, 0.0, 0.0]).collect();
        let tube = Tube::through(&points, 3.0, [false, true], 15.0, 10.0).unwrap();
        // The end at x = −10, 10 mm inside.
        let depth = depth_in([-20.0, -50.0, -50.0], [200.0, 50.0, 50.0]);
        let again = tube.reopened(&depth, 10.0, 15.0).unwrap();
        let start = again.frame(0.0).0;
        assert!((start.x + 30.0).abs() < 0.3, "start {start}");
        assert!(
            start.y.abs() < 1e-6 && start.z.abs() < 1e-6,
            "start {start}"
        );
        let off = inside_off(&tube, &again, &depth);
        // Within the dense samples' half spacing.
        assert!(off < 0.03, "{off}");
    }

    #[test]
    fn capped_tubes_and_tubes_outside_the_volume_are_not_reopened() {
        let mut capped = bent();
        capped.capped = [true, true];
        let depth = depth_in([11.0, -50.0, -50.0], [200.0, 50.0, 150.0]);
        assert!(capped.reopened(&depth, 10.0, 15.0).is_none());
        let far = depth_in([500.0, 500.0, 500.0], [600.0, 600.0, 600.0]);
        assert!(bent().reopened(far, 10.0, 15.0).is_none());
    }

    #[test]
    fn a_tube_carried_on_moves_each_control_point_again_by_its_last_move() {
        let then = bent();
        let mut now = then.clone();
        let shift = nalgebra::DVector::from_fn(3 * now.centerline.control().len(), |i, _| {
            [0.3, -0.1, 0.2][i % 3] * (1.0 + (i / 3) as f64 * 0.05)
        });
        now.centerline.displace(&shift);
        let next = now.carried_on(&then, 0.5, 3.0, 3.0).unwrap();
        for ((a, b), k) in next
            .centerline
            .control()
            .iter()
            .zip(now.centerline.control())
            .zip(0..)
        {
            for c in 0..3 {
                assert!((a[c] - b[c] - 0.5 * shift[3 * k + c]).abs() < 1e-12);
            }
        }
        // A jerk beyond the limit, tubes that do not pair up: no prediction.
        assert!(now.carried_on(&then, 10.0, 3.0, 3.0).is_none());
        let mut capped = then.clone();
        capped.capped = [true, true];
        assert!(now.carried_on(&capped, 1.0, 3.0, 3.0).is_none());
        let longer = Tube::through(
            &[[0.0; 3], [0.0, 0.0, 300.0]],
            3.0,
            [false, true],
            15.0,
            10.0,
        )
        .unwrap();
        assert!(now.carried_on(&longer, 1.0, 3.0, 3.0).is_none());
    }

    #[test]
    fn a_control_point_that_slid_along_the_tube_carries_on_only_the_moves_across_it() {
        let then = bent();
        let n = then.centerline.control().len();
        let k = n / 2;
        // Every point 0.5 mm sideways (across the bend's plane), one inner point also 4 mm
        // along the tube: beyond the 3-mm limit, a slide rather than a motion.
        let side = Vector3::new(0.0, 0.5, 0.0);
        let slide = then.control_tangent(k) * 4.0;
        let mut shift = nalgebra::DVector::zeros(3 * n);
        for j in 0..n {
            let d = if j == k { side + slide } else { side };
            shift.fixed_rows_mut::<3>(3 * j).copy_from(&d);
        }
        let mut now = then.clone();
        now.centerline.displace(&shift);
        let next = now.carried_on(&then, 1.0, 3.0, 3.0).unwrap();
        for (j, (a, b)) in next
            .centerline
            .control()
            .iter()
            .zip(now.centerline.control())
            .enumerate()
        {
            let moved = Vector3::from(*a) - Vector3::from(*b);
            let expected = if j == 0 || j == n - 1 {
                side
            } else {
                // Across the tube: the slide and the sideways move's part along it are left out.
                let t = now.control_tangent(j);
                let d = Vector3::from(*b) - Vector3::from(then.centerline.control()[j]);
                d - t * d.dot(&t)
            };
            assert!(
                (moved - expected).norm() < 1e-12,
                "point {j}: {moved} against {expected}"
            );
            assert!(moved.dot(&now.control_tangent(j)).abs() < 1e-12 || j == 0 || j == n - 1);
        }
        // A slide that large at an end, or a move that large across the tube: no prediction.
        let mut end = then.clone();
        let mut at_end = nalgebra::DVector::zeros(3 * n);
        at_end
            .fixed_rows_mut::<3>(3 * (n - 1))
            .copy_from(&(then.control_tangent(n - 1) * 4.0));
        end.centerline.displace(&at_end);
        assert!(end.carried_on(&then, 1.0, 3.0, 3.0).is_none());
        let mut across = then.clone();
        let mut sideways = nalgebra::DVector::zeros(3 * n);
        sideways[3 * k + 1] = 4.0;
        across.centerline.displace(&sideways);
        assert!(across.carried_on(&then, 1.0, 3.0, 3.0).is_none());
    }

    #[test]
    fn control_points_dragged_along_the_tube_are_no_longer_evenly_spread() {
        let tube = bent();
        assert!(tube.evenly_spread());
        // Slide one inner control point most of the way to its neighbour.
        let ctrl = tube.centerline.control();
        let k = ctrl.len() / 2;
        let mut step = nalgebra::DVector::zeros(3 * ctrl.len());
        for c in 0..3 {
            step[3 * k + c] = 0.7 * (ctrl[k + 1][c] - ctrl[k][c]);
        }
        let mut dragged = tube.clone();
        dragged.centerline.displace(&step);
        assert!(!dragged.evenly_spread());
    }

    #[test]
    fn a_tip_whose_control_points_crowded_toward_it_is_no_longer_evenly_spread() {
        // A straight capped tube of 15-mm spans. Followed frame after frame, its last control
        // points crept toward the tip (seen: sides 20.5, 15.5, 5.5 and 1.5 mm where a clamped
        // spline places 15, 15, 10 and 5). The curve still ends at the tip, but its last span
        // covers 3 mm, not 15: read by `u · length`, points 7 mm apart along the tube were
        // under 3 mm apart in space, and the self-check called the tube folded through
        // itself, so the frame was carved again (`check::stations` now sums arc length along
        // the curve; `check`'s tests hold it to a fold read right on such a tube).
        let line: Vec<[f64; 3]> = (0..=150).map(|i| [0.0, 0.0, i as f64]).collect();
        let tube = Tube::through(&line, 3.0, [false, true], 15.0, 0.0).unwrap();
        assert!(tube.evenly_spread());
        let ctrl = tube.centerline.control();
        let n = ctrl.len();
        let sides: Vec<f64> = (n - 4..n - 1)
            .map(|k| ctrl[k + 1][2] - ctrl[k][2])
            .collect();
        for (side, design) in sides.iter().zip([15.0, 10.0, 5.0]) {
            assert!((side - design).abs() < 0.5, "{sides:?}");
        }
        let mut step = nalgebra::DVector::zeros(3 * n);
        for (k, mm) in [(n - 4, 5.0), (n - 3, 8.0), (n - 2, 3.5)] {
            step[3 * k + 2] = mm;
        }
        let mut crowded = tube.clone();
        crowded.centerline.displace(&step);
        // The self-check now sums arc length along the curve itself: no crossing either way.
        let crossing = |t: &Tube| check::self_crossing(&check::stations(t, t.length(), |_| true));
        assert_eq!(crossing(&crowded), None);
        assert!(!crowded.evenly_spread());
        let again = crowded.spread_again(15.0).unwrap();
        assert!(again.evenly_spread());
        assert_eq!(crossing(&again), None);
        assert!((again.frame(1.0).0 - crowded.frame(1.0).0).norm() < 0.01);
    }

    #[test]
    fn a_tube_spread_again_is_the_same_curve_with_even_control_points() {
        let tube = bent();
        assert_eq!(
            tube.spread_again(15.0).as_ref(),
            Some(&tube),
            "already even"
        );
        // The same arc of 120 mm radius, fitted with a parameter that runs slowly at first:
        // control points bunched at the proximal end, as drift along the tube leaves them.
        let data: Vec<[f64; 3]> = (0..=480)
            .map(|i| {
                let a = i as f64 * 0.0025;
                [120.0 * a.sin(), 0.0, 120.0 * (1.0 - a.cos())]
            })
            .collect();
        let warped: Vec<f64> = (0..=480).map(|i| (i as f64 / 480.0).powf(1.6)).collect();
        let drifted = Tube {
            centerline: BSpline3::fit(&warped, &data, 12 + 3).unwrap(),
            radius: 2.5,
            steps: Vec::new(),
            capped: [false, true],
        };
        assert!(!drifted.evenly_spread());
        let again = drifted.spread_again(12.0).unwrap();
        assert!(again.evenly_spread());
        assert_eq!(again.centerline.control().len(), 15);
        assert_eq!((again.radius, again.capped), (2.5, drifted.capped));
        // The same curve: every point of the drifted one within a few hundredths of a
        // millimetre of the new one, no farther from the arc, ends where they were.
        let dense = |t: &Tube| {
            flexshape_curve::Polyline::new(
                (0..=4000).map(|i| t.frame(i as f64 / 4000.0).0).collect(),
            )
            .unwrap()
        };
        let line = dense(&again);
        let worst = (0..=400)
            .map(|i| line.closest(&drifted.frame(i as f64 / 400.0).0).1)
            .fold(0.0, f64::max);
        let off_arc = |t: &Tube| {
            (0..=400)
                .map(|i| {
                    let p = t.frame(i as f64 / 400.0).0;
                    ((p - Point3::new(0.0, 0.0, 120.0)).norm() - 120.0).abs()
                })
                .fold(0.0, f64::max)
        };
        // Measured: 0.021 mm between the two, each 0.08–0.09 mm off the arc.
        assert!(worst < 0.03, "{worst} mm off the drifted curve");
        assert!(off_arc(&again) <= off_arc(&drifted) + 0.005);
        for u in [0.0, 1.0] {
            assert!((again.frame(u).0 - drifted.frame(u).0).norm() < 0.01);
        }
    }
}
