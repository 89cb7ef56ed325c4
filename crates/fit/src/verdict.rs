//! Whether a fit explains the images: each camera's outline and overlap checks, the tube's own
//! shape (no tube bends tighter than its radius or passes through itself) — and, apart, whether
//! the tube is at least where the images show it, whatever else they show.

use flexshape_camera::Camera;
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use flexshape_silhouette::components::touching;

use crate::check::{self, CameraCheck, OutlineResiduals, STILL_RAMP_PX};
use crate::outline;
use crate::{Fit, Tube, TubeFitter};

/// Samples around a free end needed in a camera before its end is checked apart.
const END_SAMPLES: usize = 4;

/// Pixels beyond the re-rendered tube's image and the silhouette near it that still count as
/// the tube's (its blurred edge, where the outline is measured; a classifier may leave a
/// shaded edge's last pixel out) when the background takes a frame's colours.
const KEEP_PX: usize = 2;

/// Pixels around a capped end's image, beyond its radius and the check's distance, where a
/// silhouette part the tube does not explain is taken for more of the tube (a missed distal
/// part), never for backdrop.
const END_ZONE_PX: f64 = 4.0;

/// Smallest angle between a camera's line of sight and the tube at a capped end for that
/// camera to see where the end is, radians (15°). A camera looking along the tube sees the end
/// (or the body in front of it) as a disc, which sections over several millimetres share: on a
/// two-camera rig, tips within 8.7–14.1° of one camera's line of sight were fitted 0.5–1.4 mm
/// off across the tube, every camera's outline explained.
const MIN_END_VIEW: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// Samples of a cap's outline a camera must find to see the end: three points place a circle.
/// (A cap seen side-on has five at the default spacing; on a two-camera rig, tips whose cap
/// one camera saw at 0–2 samples, folded over the shaft, were fitted up to 2.7 mm off along
/// the other camera's rays, every outline explained.)
const MIN_CAP_FOUND: usize = 3;

impl TubeFitter {
    /// Why a capped end's place is not seen, if it is not: fewer than two cameras see it —
    /// have it in their image, find [`MIN_CAP_FOUND`] samples of its cap's outline
    /// (`checks`, the rig's order), and look at the tube there from the side
    /// ([`MIN_END_VIEW`] or more) — so where it lies along the one camera's rays that does
    /// is only the curve's continuation.
    pub(crate) fn end_unseen(&self, tube: &Tube, checks: &[CameraCheck]) -> Option<String> {
        for end in [0, 1].into_iter().filter(|&e| tube.capped[e]) {
            let (at, along) = tube.frame(end as f64);
            let mut seen = 0;
            let mut end_on = None;
            let mut hidden = None;
            for ((cam, name), check) in self.cameras.iter().zip(&self.names).zip(checks) {
                let Ok(projected) = cam.project(&at) else {
                    continue;
                };
                if !cam.intrinsics.contains(projected.pixel) {
                    continue;
                }
                let ray = (at - cam.centre()).normalize();
                let angle = ray.dot(&along).abs().min(1.0).acos();
                if angle < MIN_END_VIEW {
                    end_on = Some((name, angle));
                } else if check.cap_found[end] < MIN_CAP_FOUND {
                    hidden = Some((name, check.cap_found[end]));
                } else {
                    seen += 1;
                }
            }
            if seen >= 2 {
                continue;
            }
            let which = if end == 1 { "tip" } else { "proximal end" };
            let why = match (end_on, hidden) {
                (Some((name, angle)), _) => format!(
                    "the {which} points along camera {name}'s line of sight ({:.0}° from it; at least {:.0}° for a camera to see where it is)",
                    angle.to_degrees(),
                    MIN_END_VIEW.to_degrees()
                ),
                (None, Some((name, found))) => format!(
                    "camera {name} finds {found} samples of the {which}'s rounded outline (at least {MIN_CAP_FOUND}): the tube hides it there"
                ),
                (None, None) => format!("the {which} is in the image of {seen} camera(s)"),
            };
            return Some(format!(
                "{why}: fewer than two cameras see the {which}, so where it lies along the other's rays is not seen; add a camera that sees it from another side"
            ));
        }
        None
    }

    /// Why the fit does not explain the images, if it does not (the first failing check).
    /// A camera that fails only for its blur — its residuals within what blur adds to its
    /// edges' rise ([`CameraCheck::beyond_blur`]) — is excused while two other cameras pass
    /// every check even with their own blur added ([`CameraCheck::with_blur`]): they place
    /// the tube, and the fit weighted the blurred boundaries less.
    pub(crate) fn verdict(&self, fit: &Fit, volume: &Volume) -> Option<String> {
        // Asked only of a frame some camera fails as measured (most frames pass every check).
        let placing = || {
            fit.cameras
                .iter()
                .filter(|c| self.camera_verdict(c, Outline::with_blur(c)).is_none())
                .count()
        };
        fit.cameras
            .iter()
            .find_map(|c| {
                let why = self.camera_verdict(c, Outline::measured(c))?;
                let within_blur = self.camera_verdict(c, Outline::beyond_blur(c)).is_none();
                if within_blur && placing() >= 2 {
                    return None;
                }
                // A mask's soft edge is its segmentation's, not a shutter's.
                if self.settings.masks {
                    return Some(why);
                }
                Some(why + &blurred(c, within_blur))
            })
            .or_else(|| shape_verdict(&fit.tube, volume))
    }

    /// Whether the fitted tube is where the images show it — every camera finds its outline
    /// (sides and free ends) within the self-check's limits, and it is a shape a tube can take
    /// — though the rest of an image may not match (outline residuals' tail, overlap,
    /// silhouette pixels beyond the tube). Then what does not match is not the tube.
    pub fn located(&self, fit: &Fit, volume: &Volume) -> bool {
        fit.cameras.iter().all(|c| {
            let o = Outline::measured(c);
            self.outline_placed(c, o).is_none() && self.end_placed(c, o).is_none()
        }) && shape_verdict(&fit.tube, volume).is_none()
    }

    /// Whether one camera's image passes every check of the fit as measured (no allowance
    /// for blur).
    pub fn explains(&self, check: &CameraCheck) -> bool {
        self.camera_verdict(check, Outline::measured(check))
            .is_none()
    }

    /// The pixels of camera `camera`'s image that are the tube's as far as its background is
    /// concerned: the re-rendered `tube` (and its open ends' continuations) with a margin,
    /// `silhouette` within 4 px beyond the check's `explain_px` of it (a camera the fit does
    /// not explain may see its tube a few pixels off the rendered one: seen along its length,
    /// the tube's far part was taken for backdrop and came back as a ghost), and the parts of
    /// `silhouette` beyond it that meet a capped end (a missed distal part looks like that).
    /// `None` for a camera outside the rig.
    pub fn tube_pixels(&self, camera: usize, tube: &Tube, silhouette: &BitMask) -> Option<BitMask> {
        let cam = self.cameras.get(camera)?;
        let (body, beyond) = self.render(camera, tube)?;
        let drawn = body.or(&beyond);
        let unexplained = silhouette.and_not(&drawn.dilate(self.settings.explain_px));
        let zones = self.end_zones(cam, tube, drawn.width(), drawn.height());
        let near = silhouette.and(&drawn.dilate(self.settings.explain_px + END_ZONE_PX as usize));
        Some(
            drawn
                .or(&near)
                .dilate(KEEP_PX)
                .or(&touching(&unexplained, &zones)),
        )
    }

    /// Discs around `tube`'s capped ends in `cam`'s image (`w` × `h`), reaching
    /// [`END_ZONE_PX`] beyond the check's distance from the cap: a silhouette part the tube
    /// does not explain that meets one is taken for more of the tube (a missed distal part).
    pub(crate) fn end_zones(&self, cam: &Camera, tube: &Tube, w: usize, h: usize) -> BitMask {
        let mut zones = BitMask::new(w, h);
        for end in [0, 1].into_iter().filter(|&e| tube.capped[e]) {
            let (centre, _) = tube.frame(end as f64);
            let r = tube.radius_at(end as f64, tube.length());
            let Some((c, px, rp)) = outline::sphere(cam, centre, r) else {
                continue;
            };
            let reach = rp + self.settings.explain_px as f64 + END_ZONE_PX;
            check::disc(&mut zones, (c, px, reach));
        }
        zones
    }

    /// The parts of `away` (silhouette pixels the tube leaves unexplained, in `cam`'s image)
    /// that go on from a capped end of `tube`: a component meeting the end's zone
    /// ([`TubeFitter::end_zones`]) at least half of whose pixels lie nearer that end than
    /// any other point of the tube's projected centerline. A distal part the fit missed
    /// continues beyond the end; a shadow that meets the end's zone lies beside the tube,
    /// nearest its body.
    pub(crate) fn continuations(&self, cam: &Camera, tube: &Tube, away: &BitMask) -> BitMask {
        let (w, h) = (away.width(), away.height());
        let mut out = BitMask::new(w, h);
        let candidates = touching(away, &self.end_zones(cam, tube, w, h));
        if candidates.count() == 0 {
            return out;
        }
        const SAMPLES: usize = 200;
        let centreline: Vec<Option<[f64; 2]>> = (0..=SAMPLES)
            .map(|i| {
                let (p, _) = tube.frame(i as f64 / SAMPLES as f64);
                cam.project(&p).ok().map(|q| [q.pixel.x, q.pixel.y])
            })
            .collect();
        let nearest = |x: f64, y: f64| {
            centreline
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.map(|[u, v]| (i, (u - x).powi(2) + (v - y).powi(2))))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(i, _)| i)
        };
        let runs = flexshape_silhouette::components::runs(&candidates);
        let (labels, areas) = flexshape_silhouette::components::label(&runs);
        let mut beyond = vec![0usize; areas.len()];
        for (r, &l) in runs.iter().zip(&labels) {
            for x in r.x0..r.x1 {
                let end = match nearest(x as f64, r.y as f64) {
                    Some(0) => 0,
                    Some(SAMPLES) => 1,
                    _ => continue,
                };
                beyond[l] += usize::from(tube.capped[end]);
            }
        }
        for (r, &l) in runs.iter().zip(&labels) {
            if 2 * beyond[l] >= areas[l] {
                for x in r.x0..r.x1 {
                    out.set(x as usize, r.y as usize, true);
                }
            }
        }
        out
    }

    /// Why camera `c`'s image is not explained, its outline's residuals `o`, if it is not
    /// (the first failing check).
    fn camera_verdict(&self, c: &CameraCheck, o: Outline) -> Option<String> {
        let s = &self.settings;
        let i = &c.camera;
        self.outline_placed(c, o)
            .or_else(|| {
                (o.p90 > s.max_p90_px).then(|| format!(
                    "camera {i}: a tenth of the outline lies more than {:.2} px from the image's boundary (limit {:.2}): the shape does not explain this camera, or its calibration is off",
                    o.p90, s.max_p90_px
                ))
            })
            .or_else(|| self.end_placed(c, o))
            .map(|why| why + &lighter_than_backdrop(c))
            .or_else(|| {
                (c.iou < c.iou_limit).then(|| format!(
                    "camera {i}: the fitted tube overlaps the silhouette by IoU {:.2} (at least {:.2} expected)",
                    c.iou, c.iou_limit
                ))
            })
            .or_else(|| {
                (c.unexplained_px > s.max_unexplained_px).then(|| format!(
                    "camera {i}: {} silhouette pixels lie beyond the fitted tube (at most {})",
                    c.unexplained_px, s.max_unexplained_px
                ))
            })
    }

    /// Why camera `c`'s outline, its residuals `o`, is not where the image's boundary is, if
    /// it is not.
    fn outline_placed(&self, c: &CameraCheck, o: Outline) -> Option<String> {
        let s = &self.settings;
        let i = &c.camera;
        if c.samples == 0 {
            return None;
        }
        let found = c.found as f64 / c.samples as f64;
        if found < s.min_found {
            return Some(format!(
                "camera {i}: the fitted outline found the image's boundary at {:.0} % of its samples (at least {:.0} % expected)",
                found * 100.0,
                s.min_found * 100.0
            ));
        }
        (o.residual > s.max_residual_px).then(|| {
            format!(
                "camera {i}: outline residual {:.2} px RMS (limit {:.2}; mean {:+.2} px)",
                o.residual, s.max_residual_px, c.offset_px
            )
        })
    }

    /// Why camera `c`'s outline around the tube's free ends is off, if it is: where the tip
    /// is. Its few samples hardly move the statistics of the whole outline, so a tip that
    /// stopped short passes them.
    fn end_placed(&self, c: &CameraCheck, o: Outline) -> Option<String> {
        let s = &self.settings;
        if c.samples == 0 || c.end_samples < END_SAMPLES {
            return None;
        }
        let found = c.end_found as f64 / c.end_samples as f64;
        (found < s.min_found || o.end_residual > s.max_residual_px).then(|| format!(
            "camera {}: the outline around the tube's free end is not where the image shows it (boundary found at {}/{} samples, residual {:.2} px RMS; limits {:.0} %, {:.2} px): the tip has moved farther than the fit could follow, or is hidden",
            c.camera,
            c.end_found,
            c.end_samples,
            o.end_residual,
            s.min_found * 100.0,
            s.max_residual_px
        ))
    }
}

/// The outline residuals a camera is judged on, pixels: as measured, or beyond its blur.
#[derive(Debug, Clone, Copy)]
struct Outline {
    residual: f64,
    p90: f64,
    end_residual: f64,
}

impl Outline {
    fn measured(c: &CameraCheck) -> Self {
        Outline {
            residual: c.residual_px,
            p90: c.p90_px,
            end_residual: c.end_residual_px,
        }
    }

    fn beyond_blur(c: &CameraCheck) -> Self {
        Self::of(&c.beyond_blur)
    }

    fn with_blur(c: &CameraCheck) -> Self {
        Self::of(&c.with_blur)
    }

    fn of(r: &OutlineResiduals) -> Self {
        Outline {
            residual: r.residual_px,
            p90: r.p90_px,
            end_residual: r.end_residual_px,
        }
    }
}

/// What a camera whose check failed should know of its edges' blur (empty when they are
/// still and in focus): how wide they rise, and when its residuals lie within what that blur
/// allows (`within`), that fewer than two other cameras placed the tube without it.
fn blurred(c: &CameraCheck, within: bool) -> String {
    if c.ramp_px <= STILL_RAMP_PX {
        return String::new();
    }
    let cause = format!(
        "its edges rise over {:.1} px where a still tube in focus gives at most {:.1}: the tube moved while the shutter was open, or is out of focus",
        c.ramp_px, STILL_RAMP_PX
    );
    if within {
        format!(
            " ({cause}; its outline is within what that blur allows, but fewer than two cameras see the tube sharply enough to place it whatever their blur hides: shorten the exposure, or focus)"
        )
    } else {
        format!(" ({cause})")
    }
}

/// Share of a camera's outline along which a tube lighter than its backdrop is worth a word
/// when the outline is not where the image shows it.
const LIGHTER_SHARE: f64 = 0.5;

/// What a camera whose outline is off should know when the tube is lighter than the backdrop
/// along most of it (empty otherwise): a lit tube darkens toward its outline, and its edges
/// then fade into a darker backdrop (measured on the simulator: a backdrop of albedo 0.1, the
/// outline's 90th percentile 0.25–0.30 px with the shape within 0.05 mm, or a grey tube found
/// a pixel inside its outline).
fn lighter_than_backdrop(c: &CameraCheck) -> String {
    if c.lighter_share < LIGHTER_SHARE {
        return String::new();
    }
    format!(
        " (the tube is lighter than the backdrop along {:.0} % of this outline: a lit tube's edges darken into a darker backdrop and blur its outline; a backdrop lighter than the tube gives a sharp one)",
        c.lighter_share * 100.0
    )
}

/// Why `tube` is no shape a tube can take, if it is not (within `volume`: outside it nothing
/// holds the tube, and the record does not report it).
fn shape_verdict(tube: &Tube, volume: &Volume) -> Option<String> {
    let stations = check::stations(tube, tube.length(), |p| volume.contains(p));
    if let Some(t) = check::tightest_bend(&stations).filter(|t| t.bend >= 1.0) {
        return Some(format!(
            "the fitted tube bends tighter than its radius at {:.0} mm (curvature × radius {:.2}; a tube cannot reach 1): an end curled where the images do not hold it",
            t.at, t.bend
        ));
    }
    check::self_crossing(&stations).map(|c| format!(
        "the fitted tube passes through itself: its centerline at {:.0} mm comes within {:.2} mm of itself at {:.0} mm (radius {:.2}). A part folded back along the tube hides in its own outline; this is not a shape a tube can take",
        c.at_mm[0],
        c.distance_mm,
        c.at_mm[1],
        tube.largest_radius()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FitSettings;
    use flexshape_sim::{SimConfig, Simulator};

    /// A tube along world z through the volume's centre, its tip capped, `dy` mm along y and
    /// from `z0` to `z1` mm about the centre.
    fn tube(sim: &Simulator, dy: f64, z0: f64, z1: f64) -> Tube {
        let v = sim.rig().volume;
        let c: [f64; 3] =
            std::array::from_fn(|a| v.origin[a] + 0.5 * v.voxel_size[a] * v.dims[a] as f64);
        let at = |z: f64| [c[0], c[1] + dy, c[2] + z];
        Tube::through(&[at(z0), at(z1)], 3.0, [false, true], 10.0, 0.0).unwrap()
    }

    #[test]
    fn a_continuation_beyond_the_tip_is_the_tube_and_a_strip_beside_it_is_not() {
        let sim = Simulator::new(SimConfig::default()).unwrap();
        let names = (0..3).map(|i| format!("cam{i}")).collect();
        let fitter = TubeFitter::new(sim.cameras(), names, FitSettings::default()).unwrap();
        let cam = &sim.cameras()[0];
        let fitted = tube(&sim, 0.0, -60.0, 40.0);
        let drawn = |t: &Tube| {
            let (body, beyond) = fitter.render(0, t).unwrap();
            body.or(&beyond)
        };
        let near = drawn(&fitted).dilate(fitter.settings().explain_px);
        let away = |t: &Tube| drawn(t).and_not(&near);
        // 30 mm more beyond the tip: all of it is taken for the tube's.
        let more = away(&tube(&sim, 0.0, 40.0, 70.0));
        let taken = fitter.continuations(cam, &fitted, &more);
        assert!(
            more.count() > 200 && taken == more,
            "{} of {}",
            taken.count(),
            more.count()
        );
        // A strip 7 mm beside the tube along its length, meeting the tip's zone: not the tube's.
        let beside = away(&tube(&sim, 7.0, -60.0, 40.0));
        let zones = fitter.end_zones(cam, &fitted, beside.width(), beside.height());
        assert!(
            beside.and(&zones).count() > 0,
            "the strip does not meet the tip's zone"
        );
        assert_eq!(fitter.continuations(cam, &fitted, &beside).count(), 0);
        // Both at once: each judged as its own part.
        let both = more.or(&beside);
        assert_eq!(fitter.continuations(cam, &fitted, &both), more);
    }
}
