//! Two image centerlines of one tube matched along epipolar lines, and the matches
//! triangulated into a 3-D centerline.
//!
//! Both curves are images of the same 3-D curve, so the matches run monotonically along both:
//! dynamic programming over (point in camera A, point in camera B) pairs finds the monotone
//! path of least epipolar distance (one point may match several where a curve runs along its
//! epipolar lines; an end seen by one camera only is left unmatched). Pairs that are far from
//! each other's epipolar line or where the curve runs along the epipolar lines (depth is not
//! determined there) are not triangulated; the spline through the rest bridges them.

use flexshape_camera::Camera;
use nalgebra::{Matrix3, Point2, Point3, Vector2, Vector3};

use super::skeleton::ImageCurve;

/// A 3-D centerline triangulated from two image centerlines, in camera A's curve order.
#[derive(Debug, Clone)]
pub(crate) struct Triangulated {
    /// Centerline points, world mm.
    pub points: Vec<[f64; 3]>,
    /// Whether each end (first, last) is where the tube leaves a camera's view.
    pub leaves_view: [bool; 2],
    /// Share of the matched path within [`MATCH_PX`] of the epipolar lines.
    pub matched: f64,
}

/// Epipolar distance beyond which a pair costs the same as leaving a point unmatched, px.
const TRUNCATE_PX: f64 = 4.0;
/// Epipolar distance of a pair that is triangulated, px.
const MATCH_PX: f64 = 1.5;
/// Least sine of the angle between a curve and the epipolar line it is matched along for a
/// pair to be triangulated (below, depth along the line is not determined).
pub(crate) const MIN_CROSSING_SINE: f64 = 0.3;
/// Samples from a curve's end within which a match still counts as reaching it.
const END_SAMPLES: usize = 3;

/// One camera's curve in the terms the matching needs.
struct Side<'a> {
    cam: &'a Camera,
    /// Undistorted normalized points (`None`: outside the lens model's valid range).
    normalized: Vec<Option<Vector2<f64>>>,
    /// Unit tangents in the normalized plane.
    tangent: Vec<Vector2<f64>>,
    /// Pixels per normalized unit (the mean focal length).
    focal: f64,
}

impl<'a> Side<'a> {
    fn new(cam: &'a Camera, curve: &ImageCurve, reversed: bool) -> Self {
        let mut pixels = curve.points.clone();
        if reversed {
            pixels.reverse();
        }
        let normalized: Vec<Option<Vector2<f64>>> = pixels
            .iter()
            .map(|p| cam.intrinsics.normalized_from_pixel(Point2::from(*p)).ok())
            .collect();
        let n = normalized.len();
        let tangent = (0..n)
            .map(|i| {
                let a = normalized[i.saturating_sub(2)].or(normalized[i]);
                let b = normalized[(i + 2).min(n - 1)].or(normalized[i]);
                match (a, b) {
                    (Some(a), Some(b)) => (b - a) / (b - a).norm().max(1e-12),
                    _ => Vector2::zeros(),
                }
            })
            .collect();
        let focal = (cam.intrinsics.fx + cam.intrinsics.fy) / 2.0;
        Side {
            cam,
            normalized,
            tangent,
            focal,
        }
    }

    /// The world ray of point `i`.
    fn ray(&self, i: usize) -> Option<(Point3<f64>, Vector3<f64>)> {
        let n = self.normalized[i]?;
        let dir = self.cam.pose.rotation.inverse() * Vector3::new(n.x, n.y, 1.0).normalize();
        Some((self.cam.centre(), dir))
    }
}

/// The essential matrix taking camera A's normalized points to epipolar lines in camera B's.
fn essential(a: &Camera, b: &Camera) -> Matrix3<f64> {
    let r = b.pose.rotation * a.pose.rotation.inverse();
    let t = b.pose.translation - r * a.pose.translation;
    t.cross_matrix() * r.matrix()
}

/// Distance of normalized point `p` from line `l` (homogeneous), normalized units.
fn line_distance(l: &Vector3<f64>, p: &Vector2<f64>) -> f64 {
    (l.x * p.x + l.y * p.y + l.z).abs() / l.xy().norm().max(1e-12)
}

/// Camera `a`'s curve matched to camera `b`'s (taken from its last point to its first when
/// `reversed`) and triangulated, or `None` when fewer than four pairs could be triangulated.
pub(crate) fn triangulate(
    cams: [&Camera; 2],
    curves: [&ImageCurve; 2],
    reversed: bool,
) -> Option<Triangulated> {
    let a = Side::new(cams[0], curves[0], false);
    let b = Side::new(cams[1], curves[1], reversed);
    let (n, m) = (a.normalized.len(), b.normalized.len());
    let e = essential(cams[0], cams[1]);
    // Each point's epipolar line in the other camera.
    let line =
        |p: &Option<Vector2<f64>>, e: &Matrix3<f64>| p.map(|p| e * Vector3::new(p.x, p.y, 1.0));
    let lines_in_b: Vec<_> = a.normalized.iter().map(|p| line(p, &e)).collect();
    let et = e.transpose();
    let lines_in_a: Vec<_> = b.normalized.iter().map(|p| line(p, &et)).collect();
    let distance = |i: usize, j: usize| -> f64 {
        match (
            &lines_in_b[i],
            &b.normalized[j],
            &lines_in_a[j],
            &a.normalized[i],
        ) {
            (Some(lb), Some(pb), Some(la), Some(pa)) => {
                (line_distance(lb, pb) * b.focal + line_distance(la, pa) * a.focal) / 2.0
            }
            _ => f64::INFINITY,
        }
    };
    let path = cheapest_path(n, m, |i, j| distance(i, j).min(TRUNCATE_PX).powi(2));
    let (first, last) = (*path.first()?, *path.last()?);
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut good = 0;
    for &(i, j) in &path {
        if distance(i, j) > MATCH_PX {
            continue;
        }
        good += 1;
        let Some(lb) = lines_in_b[i] else { continue };
        let along = Vector2::new(-lb.y, lb.x) / lb.xy().norm().max(1e-12);
        let t = b.tangent[j];
        if (t.x * along.y - t.y * along.x).abs() < MIN_CROSSING_SINE {
            continue;
        }
        let (Some(ra), Some(rb)) = (a.ray(i), b.ray(j)) else {
            continue;
        };
        let Some(p) = closest_point(ra, rb) else {
            continue;
        };
        if points
            .last()
            .is_none_or(|q| (Vector3::from(*q) - p.coords).norm() > 0.2)
        {
            points.push([p.x, p.y, p.z]);
        }
    }
    if points.len() < 4 {
        return None;
    }
    let b_border = if reversed {
        [curves[1].at_border[1], curves[1].at_border[0]]
    } else {
        curves[1].at_border
    };
    let leaves_view = [
        (first.0 <= END_SAMPLES && curves[0].at_border[0])
            || (first.1 <= END_SAMPLES && b_border[0]),
        (last.0 + END_SAMPLES >= n - 1 && curves[0].at_border[1])
            || (last.1 + END_SAMPLES >= m - 1 && b_border[1]),
    ];
    Some(Triangulated {
        points,
        leaves_view,
        matched: good as f64 / path.len() as f64,
    })
}

/// The midpoint of the shortest segment between two rays (origin, unit direction), or `None`
/// for rays about parallel or meeting behind a camera.
fn closest_point(
    (ca, da): (Point3<f64>, Vector3<f64>),
    (cb, db): (Point3<f64>, Vector3<f64>),
) -> Option<Point3<f64>> {
    let w = ca - cb;
    let (b, d, e) = (da.dot(&db), da.dot(&w), db.dot(&w));
    let denom = 1.0 - b * b;
    if denom < 1e-6 {
        return None;
    }
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    (s > 0.0 && t > 0.0).then(|| Point3::from(((ca + da * s).coords + (cb + db * t).coords) / 2.0))
}

/// The monotone path through an `n × m` grid of pair costs of least total cost, where it may
/// start on the first row or column and end on the last, each point left out at either end
/// costing as much as the most expensive pair. Steps: one along A, one along B, or both.
fn cheapest_path(n: usize, m: usize, cost: impl Fn(usize, usize) -> f64) -> Vec<(usize, usize)> {
    let skip = TRUNCATE_PX * TRUNCATE_PX;
    let mut total = vec![0.0f64; n * m];
    // 0: starts here, 1: from (i−1, j), 2: from (i, j−1), 3: from (i−1, j−1).
    let mut from = vec![0u8; n * m];
    for i in 0..n {
        for j in 0..m {
            let mut best = if i == 0 || j == 0 {
                skip * (i + j) as f64
            } else {
                f64::INFINITY
            };
            let mut how = 0;
            for (k, prev) in [
                (1, (i > 0).then(|| (i - 1) * m + j)),
                (2, (j > 0).then(|| i * m + j - 1)),
                (3, (i > 0 && j > 0).then(|| (i - 1) * m + j - 1)),
            ] {
                if let Some(p) = prev
                    && total[p] < best
                {
                    best = total[p];
                    how = k;
                }
            }
            total[i * m + j] = best + cost(i, j);
            from[i * m + j] = how;
        }
    }
    let end = (0..n)
        .map(|i| (i, m - 1))
        .chain((0..m).map(|j| (n - 1, j)))
        .min_by(|x, y| {
            let left = |(i, j): (usize, usize)| {
                total[i * m + j] + skip * ((n - 1 - i) + (m - 1 - j)) as f64
            };
            left(*x).total_cmp(&left(*y))
        });
    let Some((mut i, mut j)) = end else {
        return Vec::new();
    };
    let mut path = vec![(i, j)];
    loop {
        match from[i * m + j] {
            1 => i -= 1,
            2 => j -= 1,
            3 => {
                i -= 1;
                j -= 1;
            }
            _ => break,
        }
        path.push((i, j));
    }
    path.reverse();
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cheapest_path_follows_the_zero_cost_diagonal_and_skips_unmatched_ends() {
        // B's points 0..5 have no partner; then B[j] matches A[j − 5].
        let (n, m) = (30, 35);
        let path = cheapest_path(n, m, |i, j| if j == i + 5 { 0.0 } else { 16.0 });
        assert_eq!(path.first(), Some(&(0, 5)));
        assert_eq!(path.last(), Some(&(29, 34)));
        assert!(path.iter().all(|&(i, j)| j == i + 5));
    }

    #[test]
    fn rays_through_one_point_meet_there() {
        let p = Point3::new(10.0, -20.0, 300.0);
        let ca = Point3::new(0.0, 0.0, 0.0);
        let cb = Point3::new(200.0, 0.0, 50.0);
        let q = closest_point(((ca), (p - ca).normalize()), (cb, (p - cb).normalize())).unwrap();
        assert!((q - p).norm() < 1e-9);
    }
}
