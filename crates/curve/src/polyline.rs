//! A sampled 3-D curve with cumulative arc length.

use nalgebra::{Point3, Vector3};
use thiserror::Error;

/// Why a polyline cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CurveError {
    /// Fewer than two points, or zero total length.
    #[error("a curve needs at least two distinct points (got {points} points, length {length} mm)")]
    Degenerate {
        /// Number of points given.
        points: usize,
        /// Total length in mm.
        length: f64,
    },
    /// A coordinate is NaN or infinite.
    #[error("curve point {index} is not finite")]
    NotFinite {
        /// Index of the offending point.
        index: usize,
    },
}

/// A polyline through `points` (world mm), with the arc length at each point measured from the
/// first along the polyline.
#[derive(Debug, Clone, PartialEq)]
pub struct Polyline {
    points: Vec<Point3<f64>>,
    arc: Vec<f64>,
}

impl Polyline {
    /// Builds the polyline; consecutive duplicate points are dropped.
    pub fn new(points: Vec<Point3<f64>>) -> Result<Self, CurveError> {
        if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(CurveError::NotFinite { index });
        }
        let mut kept: Vec<Point3<f64>> = Vec::with_capacity(points.len());
        let mut arc = Vec::with_capacity(points.len());
        for p in points.iter() {
            match kept.last() {
                None => arc.push(0.0),
                Some(q) => {
                    let d = (p - q).norm();
                    if d == 0.0 {
                        continue;
                    }
                    arc.push(arc.last().copied().unwrap_or(0.0) + d);
                }
            }
            kept.push(*p);
        }
        let length = arc.last().copied().unwrap_or(0.0);
        if kept.len() < 2 {
            return Err(CurveError::Degenerate {
                points: points.len(),
                length,
            });
        }
        Ok(Polyline { points: kept, arc })
    }

    /// The vertices, world mm.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Arc length at each vertex, mm (starts at 0).
    pub fn arc_lengths(&self) -> &[f64] {
        &self.arc
    }

    /// Total length, mm.
    pub fn length(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }

    /// Index `i` of the segment `[i, i+1]` holding arc length `s` (clamped to the curve).
    fn segment(&self, s: f64) -> usize {
        let i = self.arc.partition_point(|&a| a <= s);
        i.saturating_sub(1).min(self.points.len() - 2)
    }

    /// Point at arc length `s` mm (clamped to `[0, length]`), linearly interpolated.
    pub fn point_at(&self, s: f64) -> Point3<f64> {
        let s = s.clamp(0.0, self.length());
        let i = self.segment(s);
        let t = (s - self.arc[i]) / (self.arc[i + 1] - self.arc[i]);
        self.points[i] + (self.points[i + 1] - self.points[i]) * t
    }

    /// Unit tangent of the segment holding arc length `s`.
    pub fn tangent_at(&self, s: f64) -> Vector3<f64> {
        let i = self.segment(s.clamp(0.0, self.length()));
        (self.points[i + 1] - self.points[i]).normalize()
    }

    /// The same curve resampled at uniform arc-length spacing of at most `step` mm (both ends
    /// kept).
    pub fn resample(&self, step: f64) -> Polyline {
        let n = (self.length() / step).ceil().max(1.0) as usize;
        let points = (0..=n)
            .map(|k| self.point_at(self.length() * k as f64 / n as f64))
            .collect();
        Polyline::new(points).unwrap_or_else(|_| self.clone())
    }

    /// Closest point on the polyline to `p`: its arc length and distance (mm).
    pub fn closest(&self, p: &Point3<f64>) -> (f64, f64) {
        let mut best = (0.0, f64::INFINITY);
        for i in 0..self.points.len() - 1 {
            let a = self.points[i];
            let ab = self.points[i + 1] - a;
            let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            let d = (a + ab * t - p).norm();
            if d < best.1 {
                best = (self.arc[i] + t * (self.arc[i + 1] - self.arc[i]), d);
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_length_interpolation_and_closest_point() {
        let l = Polyline::new(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(3.0, 4.0, 0.0),
        ])
        .unwrap();
        assert_eq!(l.points().len(), 3);
        assert_eq!(l.length(), 7.0);
        assert_eq!(l.point_at(5.0), Point3::new(3.0, 2.0, 0.0));
        assert_eq!(l.point_at(99.0), Point3::new(3.0, 4.0, 0.0));
        assert_eq!(l.tangent_at(1.0), Vector3::x());
        let (s, d) = l.closest(&Point3::new(4.0, 1.0, 0.0));
        assert!((s - 4.0).abs() < 1e-12 && (d - 1.0).abs() < 1e-12);
        let r = l.resample(0.5);
        assert_eq!(r.points().len(), 15);
        assert!((r.length() - 7.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_and_non_finite_are_rejected() {
        assert!(Polyline::new(vec![Point3::origin(); 3]).is_err());
        assert_eq!(
            Polyline::new(vec![Point3::origin(), Point3::new(f64::NAN, 0.0, 0.0)]),
            Err(CurveError::NotFinite { index: 1 })
        );
    }
}
