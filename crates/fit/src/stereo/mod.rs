//! A start that needs no hull, for two cameras: with two views the carved hull grows ghost
//! branches (and often falls into pieces), so its centerline may follow a ghost. Instead each
//! camera's silhouette gives an image centerline (`skeleton`), the two are matched along
//! epipolar lines both ways round (`matching`), and each triangulated candidate is fitted to
//! the images. The candidate that explains both images is the frame's shape; when two
//! different shapes both explain them, the frame is `ambiguous`.

mod matching;
mod skeleton;

pub(crate) use matching::MIN_CROSSING_SINE;

use flexshape_rig::Volume;
use flexshape_shape::{ShapeEstimator, ShapeRecord, Status};
use flexshape_silhouette::BitMask;
use nalgebra::Point3;

use crate::outline::Spheres;
use crate::{Fit, FitError, Tube, TubeFitter, View};

/// Spacing of the image centerlines' points, pixels.
const SPACING_PX: f64 = 2.0;

/// Least share of a matched path within a pixel and a half of the epipolar lines for a
/// candidate to be fitted.
const MIN_MATCHED: f64 = 0.3;

/// Two fits that explain the images and lie farther apart than this somewhere are different
/// shapes, mm.
const DIFFERENT_MM: f64 = 1.0;

impl TubeFitter {
    /// The frame's shape from a two-camera rig's images alone, without the hull: the
    /// silhouettes' image centerlines matched along epipolar lines and triangulated, each
    /// candidate fitted to the images. `None` when the rig does not have two cameras, a
    /// silhouette holds no tube, or no candidate explains both images. The ends are open where
    /// the tube leaves a camera's view or reaches the volume's boundary; the proximal end is
    /// the open one (or the one nearer `proximal_hint`), and when neither decides the status is
    /// `ambiguous`; so it is when two different candidates both explain the images. `radius`
    /// is the tube's, if known (else estimated from the silhouettes' widths and fitted).
    pub fn from_two_views(
        &self,
        estimator: &ShapeEstimator,
        volume: &Volume,
        views: &[View<'_>],
        radius: Option<f64>,
    ) -> Result<Option<(ShapeRecord, Fit)>, FitError> {
        if self.cameras.len() != 2 || views.len() != 2 {
            return Ok(None);
        }
        let found = self.two_views_of(
            estimator,
            volume,
            views,
            radius,
            [views[0].silhouette, views[1].silhouette],
        )?;
        if found.is_some() {
            return Ok(found);
        }
        // A sharp shadow beside the tube is part of a silhouette, and the image centerline may
        // run into it: once more without the shadow-coloured pixels, where a view has any and
        // something is left (a tube of the backdrop's colour is shadow-coloured all over).
        let coloured: Vec<Option<BitMask>> = views
            .iter()
            .map(|v| {
                v.shadow_like
                    .filter(|s| s.count() > 0)
                    .map(|s| v.silhouette.and_not(s))
                    .filter(|c| c.count() > 0)
            })
            .collect();
        if coloured.iter().all(Option::is_none) {
            return Ok(None);
        }
        let pick = |i: usize| coloured[i].as_ref().unwrap_or(views[i].silhouette);
        self.two_views_of(estimator, volume, views, radius, [pick(0), pick(1)])
    }

    /// [`TubeFitter::from_two_views`] with the image centerlines taken from `silhouettes`.
    fn two_views_of(
        &self,
        estimator: &ShapeEstimator,
        volume: &Volume,
        views: &[View<'_>],
        radius: Option<f64>,
        silhouettes: [&BitMask; 2],
    ) -> Result<Option<(ShapeRecord, Fit)>, FitError> {
        let curves = silhouettes.map(|s| skeleton::image_curve(s, SPACING_PX));
        let [Some(a), Some(b)] = &curves else {
            return Ok(None);
        };
        let cams = [&self.cameras[0], &self.cameras[1]];
        let s = &self.settings;
        let voxel = volume
            .voxel_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let mut explaining: Vec<(Fit, Vec<Spheres>, ShapeRecord)> = Vec::new();
        for reversed in [false, true] {
            let Some(tri) = matching::triangulate(cams, [a, b], reversed) else {
                continue;
            };
            if tri.matched < MIN_MATCHED {
                continue;
            }
            let r0 = radius.unwrap_or_else(|| self.radius_from_widths(&tri.points, [a, b]));
            let Some((mut points, open, base)) = oriented(tri, volume, r0 + 2.0 * voxel, estimator)
            else {
                continue;
            };
            // An image centerline runs to the far edge of a closed end's rounded image, its
            // radius beyond the end's centre: left there, a wide tube's cap starts farther
            // off than its boundaries are searched (15 px at 2500 px across).
            for end in [0, 1].into_iter().filter(|&e| !open[e]) {
                trim(&mut points, end, r0);
            }
            let Ok(start) = Tube::through(&points, r0, open.map(|o| !o), s.span_mm, s.extend_mm)
                .map(|t| t.with_steps(&estimator.settings().radius_steps))
            else {
                continue;
            };
            let fit_radius = radius.is_none() && s.fit_radius;
            let fitted = self.fit_with(s, views, start, fit_radius, crate::ONE_MEASUREMENT_MM)?;
            let mut base = base;
            let (fit, spheres) =
                self.orient_by_band(estimator, views, fitted, &mut base, fit_radius)?;
            if self.verdict(&fit, volume).is_none() {
                explaining.push((fit, spheres, base));
            }
        }
        // The one that explains the images best; another that explains them too but lies
        // elsewhere makes the frame ambiguous.
        explaining.sort_by(|x, y| mean_residual(&x.0).total_cmp(&mean_residual(&y.0)));
        let mut fits = explaining.into_iter();
        let Some((fit, spheres, base)) = fits.next() else {
            return Ok(None);
        };
        let other = fits
            .map(|(f, _, _)| apart(&fit.tube, &f.tube))
            .fold(0.0, f64::max);
        let mut record = self.conclude(estimator, volume, views, (&fit, &spheres, None), &base);
        if other > DIFFERENT_MM && record.status.is_right() {
            record.status = Status::Ambiguous {
                reason: format!(
                    "two shapes up to {other:.0} mm apart both explain the two cameras' images: add a camera that sees the tube from another side"
                ),
            };
        }
        Ok(Some((record, fit)))
    }

    /// The tube's radius from the silhouettes' widths at the middle of `points` (world mm),
    /// mm.
    fn radius_from_widths(&self, points: &[[f64; 3]], curves: [&skeleton::ImageCurve; 2]) -> f64 {
        let middle = Point3::from(points[points.len() / 2]);
        let radii: Vec<f64> = self
            .cameras
            .iter()
            .zip(curves)
            .filter_map(|(cam, curve)| {
                let p = cam.project(&middle).ok()?;
                let f = (cam.intrinsics.fx + cam.intrinsics.fy) / 2.0;
                Some(curve.width_px / 2.0 * p.depth / f)
            })
            .collect();
        radii.iter().sum::<f64>() / radii.len().max(1) as f64
    }
}

/// A triangulated centerline from its proximal end, which ends are open, and what the hull's
/// record would have said (the status the direction and the ends give), or `None` when it has
/// too few points.
fn oriented(
    tri: matching::Triangulated,
    volume: &Volume,
    near_boundary: f64,
    estimator: &ShapeEstimator,
) -> Option<(Vec<[f64; 3]>, [bool; 2], ShapeRecord)> {
    let mut points = tri.points;
    let ends = [points[0], points[points.len() - 1]];
    let mut open =
        [0, 1].map(|k| tri.leaves_view[k] || volume.depth(&ends[k].into()) <= near_boundary);
    let hint = estimator.settings().proximal_hint;
    let flip = match open {
        [false, true] => true,
        [false, false] => hint.is_some_and(|h| {
            let d = |p: [f64; 3]| (Point3::from(p) - Point3::from(h)).norm();
            d(ends[1]) < d(ends[0])
        }),
        _ => false,
    };
    if flip {
        points.reverse();
        open.reverse();
    }
    let guessed = open == [false, false] && hint.is_none();
    let status = match open {
        [true, true] => Status::LeavesVolume,
        _ if guessed => {
            estimator.undirected("leaves the cameras' views or reaches the volume's boundary")
        }
        _ => Status::Ok,
    };
    let mut base = ShapeRecord::empty(status);
    base.enters_volume = open[0];
    base.direction_guessed = guessed;
    (points.len() >= 4).then_some((points, open, base))
}

/// `points` (a polyline, world mm) shortened by `length` mm at `end` (0 the first point, 1
/// the last), keeping at least its first or last segment's other point.
fn trim(points: &mut Vec<[f64; 3]>, end: usize, length: f64) {
    if end == 0 {
        points.reverse();
    }
    let mut left = length;
    while points.len() > 2 && left > 0.0 {
        let n = points.len();
        let (a, b) = (Point3::from(points[n - 2]), Point3::from(points[n - 1]));
        let d = (b - a).norm();
        if d > left {
            points[n - 1] = (b + (a - b) * (left / d)).into();
            break;
        }
        left -= d;
        points.pop();
    }
    if end == 0 {
        points.reverse();
    }
}

/// Mean outline residual over the cameras, pixels.
fn mean_residual(fit: &Fit) -> f64 {
    fit.cameras.iter().map(|c| c.residual_px).sum::<f64>() / fit.cameras.len().max(1) as f64
}

/// The largest distance from a point of either centerline to the other, mm (sampled every
/// ~2 mm).
fn apart(a: &Tube, b: &Tube) -> f64 {
    let samples = |t: &Tube| -> Vec<Point3<f64>> {
        let n = (t.length() / 2.0).ceil().max(2.0) as usize;
        (0..=n).map(|i| t.frame(i as f64 / n as f64).0).collect()
    };
    let (pa, pb) = (samples(a), samples(b));
    let farthest = |from: &[Point3<f64>], to: &[Point3<f64>]| {
        from.iter()
            .map(|p| {
                to.iter()
                    .map(|q| (p - q).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    };
    farthest(&pa, &pb).max(farthest(&pb, &pa))
}

#[cfg(test)]
mod tests {
    use flexshape_shape::ShapeSettings;

    use super::*;

    fn straight(from: [f64; 3], to: [f64; 3], leaves_view: [bool; 2]) -> matching::Triangulated {
        let points = (0..=20)
            .map(|i| {
                let t = i as f64 / 20.0;
                [0, 1, 2].map(|k| from[k] + (to[k] - from[k]) * t)
            })
            .collect();
        matching::Triangulated {
            points,
            leaves_view,
            matched: 1.0,
        }
    }

    fn estimator(hint: Option<[f64; 3]>) -> ShapeEstimator {
        ShapeEstimator::new(ShapeSettings {
            proximal_hint: hint,
            ..ShapeSettings::default()
        })
        .unwrap()
    }

    #[test]
    fn the_open_end_is_proximal_and_two_closed_ends_without_a_hint_are_ambiguous() {
        // The default volume spans ±128 mm; the curve runs from inside down to its floor.
        let volume = Volume::default();
        let down = straight([0.0, 0.0, 0.0], [0.0, 0.0, -127.0], [false, false]);
        let (points, open, base) = oriented(down, &volume, 5.0, &estimator(None)).unwrap();
        assert_eq!(open, [true, false]);
        assert_eq!(points[0], [0.0, 0.0, -127.0]);
        assert_eq!(base.status, Status::Ok);
        assert!(base.enters_volume);
        // Where a camera loses the tube counts as an open end too.
        let cut = straight([0.0, 0.0, 0.0], [0.0, 0.0, 50.0], [false, true]);
        let (points, open, _) = oriented(cut, &volume, 5.0, &estimator(None)).unwrap();
        assert_eq!((open, points[0]), ([true, false], [0.0, 0.0, 50.0]));
        // Floating: nothing tells, unless a hint does.
        let floating = || straight([0.0, 0.0, 0.0], [0.0, 0.0, 50.0], [false, false]);
        let (_, _, base) = oriented(floating(), &volume, 5.0, &estimator(None)).unwrap();
        assert!(matches!(base.status, Status::Ambiguous { .. }));
        let hint = estimator(Some([0.0, 0.0, 60.0]));
        let (points, _, base) = oriented(floating(), &volume, 5.0, &hint).unwrap();
        assert_eq!((base.status, points[0]), (Status::Ok, [0.0, 0.0, 50.0]));
        // Both ends open: the tube runs through.
        let through = straight([0.0, 0.0, -127.0], [0.0, 0.0, 127.0], [false, false]);
        let (_, _, base) = oriented(through, &volume, 5.0, &estimator(None)).unwrap();
        assert_eq!(base.status, Status::LeavesVolume);
    }

    #[test]
    fn a_closed_end_is_trimmed_along_the_curve() {
        let line = || straight([0.0, 0.0, 0.0], [0.0, 0.0, 20.0], [false, false]).points;
        // 1 mm apart: 2.5 mm off the tip leaves the point at 17.5.
        let mut p = line();
        trim(&mut p, 1, 2.5);
        assert_eq!(p.len(), 19);
        assert!((p[18][2] - 17.5).abs() < 1e-12, "{:?}", p[18]);
        let mut p = line();
        trim(&mut p, 0, 2.5);
        assert!((p[0][2] - 2.5).abs() < 1e-12 && p[p.len() - 1][2] == 20.0);
        // Never below one segment.
        let mut p = line();
        trim(&mut p, 1, 100.0);
        assert_eq!(p.len(), 2);
    }

    #[test]
    fn tubes_apart_by_their_farthest_points_either_way() {
        let tube = |to: [f64; 3]| {
            Tube::through(&[[0.0, 0.0, 0.0], to], 1.0, [true, true], 15.0, 0.0).unwrap()
        };
        let a = tube([0.0, 0.0, 100.0]);
        assert!(apart(&a, &tube([0.0, 0.0, 100.0])) < 1e-6);
        // One that stops 30 mm short is 30 mm from the other's tip.
        let d = apart(&a, &tube([0.0, 0.0, 70.0]));
        assert!((d - 30.0).abs() < 0.5, "{d}");
        // The same centerline the other way round is the same shape.
        let back = Tube::through(
            &[[0.0, 0.0, 100.0], [0.0, 0.0, 0.0]],
            1.0,
            [true, true],
            15.0,
            0.0,
        )
        .unwrap();
        assert!(apart(&a, &back) < 1e-6);
    }
}
