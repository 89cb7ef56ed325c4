//! A capped end the images show going on is lengthened along them, and the tube fitted again.
//!
//! Where the tube's colour is close to the backdrop's, one camera's silhouette can lose a
//! stretch of it (a proximal shaft against cloth of its own hue); the hull, the intersection
//! of every camera's silhouette, then stops short, and the fit from it caps the tube where
//! the hull ends. The images still show the tube there: averaged along a stretch, `I − E`
//! across it stands out of the noise at the tube's width ([`TubeFitter::goes_on`]). When two
//! cameras or more see that beyond an end, the end is walked on along its tangent while two
//! cameras still see the tube, to where they stop seeing it (the end stays capped there, and
//! the check asks its cap's outline) or to the volume's boundary (the end becomes open), and
//! the tube is fitted again from there. A walk that stopped short of the boundary stopped
//! where the tube ends or where it turns off the tangent; the fit turns the tangent, and the
//! next round walks on from the fitted end. The check judges the result as any other fit.

use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use nalgebra::Point3;

use crate::tube::Tube;
use crate::{Fit, FitError, TubeFitter, View};

/// Length of each stretch the walk asks the cameras about, mm: long enough for the average
/// along it to stand out of the noise (the first of [`crate::verdict`]'s goes-on stretches
/// is as long).
const STEP_MM: f64 = 5.0;

/// Shortest stretch the walk asks about where the tube stops showing, mm (a stretch must
/// project to 3 px or more for a profile across it).
const MIN_STEP_MM: f64 = 1.25;

/// Where the walk starts beyond the end's apex, mm: where the goes-on stretches start (a
/// sliver of the end's own cap, or its blur, lies before it).
const FROM_MM: f64 = crate::verdict::GOES_ON_STRETCHES_MM[0].0;

/// Longest walk from one end, mm (a run-away walk along a stripe of the backdrop stops
/// here; the volume's boundary stops most walks far sooner).
const MAX_WALK_MM: f64 = 600.0;

/// Rounds of lengthening and fitting again at most: a walk along the end's tangent drifts off
/// a bending continuation within 10–25 mm, and the fit from where it stopped turns the
/// tangent for the next (60 mm lost from a bent shaft took 3–4 rounds).
pub(crate) const ROUNDS: usize = 8;

impl TubeFitter {
    /// `fit`'s tube lengthened at each capped end that at least two cameras see going on
    /// ([`crate::CameraCheck::goes_on`]), or that `again` names (lengthened in the round
    /// before): on along the end's tangent, in [`STEP_MM`] stretches, while two cameras or
    /// more show the tube along each ([`TubeFitter::shows_tube`]), then by halves of the
    /// stretch where they stop; open where the walk leaves `volume`. With the ends to walk
    /// again in the next round; `None` when no end goes on, or the walks gain less than a
    /// stretch.
    pub(crate) fn lengthened(
        &self,
        views: &[View<'_>],
        volume: &Volume,
        fit: &Fit,
        again: [bool; 2],
    ) -> Result<Option<(Tube, [bool; 2])>, FitError> {
        let going_on =
            |end: usize| again[end] || fit.cameras.iter().filter(|c| c.goes_on[end]).count() >= 2;
        if !(0..2).any(going_on) {
            return Ok(None);
        }
        let images = self.edge_images(views)?;
        let own: Vec<Option<BitMask>> = (0..self.cameras.len())
            .map(|i| self.render(i, &fit.tube).map(|(body, _)| body))
            .collect();
        let tube = &fit.tube;
        let length = tube.length();
        let mut ends: [Option<(Point3<f64>, bool)>; 2] = [None, None];
        for end in (0..2).filter(|&e| going_on(e) && tube.capped[e]) {
            let (at, tangent) = tube.frame(end as f64);
            let dir = if end == 0 { -tangent } else { tangent };
            let r = tube.radius_at(end as f64, length);
            let seen = |from: f64, to: f64| {
                self.cameras
                    .iter()
                    .zip(&images)
                    .zip(&own)
                    .filter(|((cam, img), own)| {
                        own.as_ref().is_some_and(|own| {
                            self.shows_tube(cam, (img, own), at + dir * from, at + dir * to, r)
                        })
                    })
                    .count()
                    >= 2
            };
            // How far beyond the end's centre the images show the tube (mm; the goes-on
            // stretches showed it past `FROM_MM` beyond the apex), and whether it runs out of
            // the volume.
            let mut reach = r + FROM_MM;
            let mut open = false;
            while reach < MAX_WALK_MM {
                let to = reach + STEP_MM;
                if volume.depth(&(at + dir * to)) <= 0.0 {
                    // Runs out of the volume within this stretch: open at the boundary. (The
                    // stretches before it were seen, or the goes-on stretches were: the rest
                    // may be too short for a profile.)
                    let (mut lo, mut hi) = (0.0, to);
                    for _ in 0..30 {
                        let mid = 0.5 * (lo + hi);
                        if volume.depth(&(at + dir * mid)) > 0.0 {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    reach = lo;
                    open = true;
                    break;
                }
                if seen(reach, to) {
                    reach = to;
                    continue;
                }
                // The tube ends within this stretch, or turns off the tangent: its shown
                // part, by halves down to `MIN_STEP_MM`.
                let mut half = 0.5 * STEP_MM;
                while half >= MIN_STEP_MM {
                    if seen(reach, reach + half) {
                        reach += half;
                    }
                    half *= 0.5;
                }
                break;
            }
            if open || reach >= r + FROM_MM + STEP_MM {
                // An open end's centre is where it meets the boundary; a capped end's lies a
                // radius inside its apex.
                let centre = at + dir * if open { reach } else { reach - r };
                ends[end] = Some((centre, open));
            }
        }
        if ends.iter().all(Option::is_none) {
            return Ok(None);
        }
        // The fitted curve sampled every millimetre or so, with the straight stretches each
        // end gained, proximal end first.
        let n = length.ceil().max(8.0) as usize;
        let stretch = |from: Point3<f64>, to: Point3<f64>| {
            let k = (to - from).norm().ceil().max(1.0) as usize;
            (1..=k).map(move |i| from + (to - from) * (i as f64 / k as f64))
        };
        let mut points: Vec<Point3<f64>> = Vec::with_capacity(n + 64);
        let (first, last) = (tube.frame(0.0).0, tube.frame(1.0).0);
        if let Some((p, _)) = ends[0] {
            let before: Vec<Point3<f64>> = stretch(first, p).collect();
            points.extend(before.into_iter().rev());
        }
        points.extend((0..=n).map(|i| tube.frame(i as f64 / n as f64).0));
        if let Some((p, _)) = ends[1] {
            points.extend(stretch(last, p));
        }
        let points: Vec<[f64; 3]> = points.into_iter().map(Into::into).collect();
        let capped = [0, 1].map(|e| tube.capped[e] && !ends[e].is_some_and(|(_, open)| open));
        let s = &self.settings;
        // An end lengthened and still capped is walked on again from the fitted tube's end,
        // whether or not the images show it going on straight from there: the walk stopped
        // where the tube ends, or where it turns off the end's tangent, which the fit turns.
        let walk_again = [0, 1].map(|e| ends[e].is_some() && capped[e]);
        Ok(
            Tube::through(&points, tube.radius, capped, s.span_mm, s.extend_mm)
                .ok()
                .map(|t| (t.with_steps(&tube.steps), walk_again)),
        )
    }
}
