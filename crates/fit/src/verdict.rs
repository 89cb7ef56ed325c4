//! Whether a fit explains the images: each camera's outline and overlap checks, the tube's own
//! shape (no tube bends tighter than its radius or passes through itself) — and, apart, whether
//! the tube is at least where the images show it, whatever else they show.

use flexshape_camera::Camera;
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use flexshape_silhouette::components::touching;

use crate::check::{self, CameraCheck, OutlineResiduals, STILL_RAMP_PX};
use crate::edges::EdgeImage;
use crate::outline;
use crate::{Fit, FitSettings, Tube, TubeFitter};
use nalgebra::Vector2;

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

/// Stretches beyond a capped end's apex, along its tangent, mm, each of which must show the
/// tube for [`TubeFitter::goes_on`] to say it goes on: a sliver of a real end's cap, or blur,
/// at the start of the first cannot pass both.
pub(crate) const GOES_ON_STRETCHES_MM: [(f64, f64); 2] = [(4.0, 9.0), (9.0, 14.0)];

/// How far off an end's tangent [`TubeFitter::goes_on`] also looks for the tube going on,
/// radians (25°): a tube bending with a radius of 25 mm turns its chord over the goes-on
/// stretches by about that much. A fit capped where the tube bends (its silhouettes lost the
/// rest) saw nothing straight on, and a tip 35 mm short passed as `ok`.
const BEND_PROBE_RAD: f64 = 25.0 * std::f64::consts::PI / 180.0;

/// The four directions [`BEND_PROBE_RAD`] off the unit vector `dir`, in two planes through it
/// at right angles.
fn bent_off(dir: nalgebra::Vector3<f64>) -> [nalgebra::Vector3<f64>; 4] {
    let across = dir
        .cross(&nalgebra::Vector3::z())
        .try_normalize(1e-6)
        .unwrap_or_else(|| dir.cross(&nalgebra::Vector3::x()).normalize());
    let other = dir.cross(&across);
    let (c, s) = (BEND_PROBE_RAD.cos(), BEND_PROBE_RAD.sin());
    [across, -across, other, -other].map(|n| dir * c + n * s)
}

/// Shortest stretch of tube along two cameras' epipolar plane that a refusal names, mm: over
/// shorter ones the curve's smoothness bridges the depth the cameras leave open (the drawn-mask
/// frames refused for it ran along the plane for 30–50 mm).
const EPIPOLAR_STRETCH_MM: f64 = 10.0;

impl TubeFitter {
    /// On a two-camera rig, the longest stretch of `tube` whose tangent lies within
    /// [`MIN_CROSSING_SINE`](crate::stereo::MIN_CROSSING_SINE) of the cameras' epipolar plane
    /// through it, said as a clause for a refusal when it is [`EPIPOLAR_STRETCH_MM`] or
    /// longer: there both images show the tube along the same epipolar lines, and nothing in
    /// them places it within that plane. Sampled every ~0.5 mm.
    pub(crate) fn along_epipolar_plane(&self, tube: &Tube) -> Option<String> {
        let [a, b] = self.cameras.as_slice() else {
            return None;
        };
        let (ca, cb) = (a.centre(), b.centre());
        let n = ((tube.length() / 0.5).ceil() as usize).clamp(16, 4000);
        let (mut arc, mut prev) = (0.0, tube.frame(0.0).0);
        let (mut best, mut run): ((f64, f64), Option<f64>) = ((0.0, 0.0), None);
        for i in 0..=n {
            let (p, t) = tube.frame(i as f64 / n as f64);
            arc += (p - prev).norm();
            prev = p;
            let normal = (p - ca).cross(&(p - cb));
            let along = normal.norm() > 1e-9
                && t.dot(&normal).abs() / normal.norm() < crate::stereo::MIN_CROSSING_SINE;
            run = match (along, run) {
                (true, None) => Some(arc),
                (true, from) => from,
                (false, _) => None,
            };
            if let Some(from) = run
                && arc - from > best.1 - best.0
            {
                best = (from, arc);
            }
        }
        let (from, to) = best;
        (to - from >= EPIPOLAR_STRETCH_MM).then(|| {
            format!(
                "; over {:.0} mm (from {from:.0} to {to:.0} mm along it) the tube runs within {:.0}° of the epipolar plane of {} and {}, where neither image places it within that plane: add a camera that sees it from another side",
                to - from,
                crate::stereo::MIN_CROSSING_SINE.asin().to_degrees(),
                self.names[0],
                self.names[1],
            )
        })
    }

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
                    hidden = Some((name, check.cap_found[end], check.cap_samples[end]));
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
                // The end is in the image, yet none of its cap's samples was measured: every
                // search line read the camera's occlusion mask, or left the image.
                (None, Some((name, _, 0))) => format!(
                    "camera {name} measures none of the {which}'s rounded outline (its occlusion mask hides it, or it lies at the image's edge)"
                ),
                (None, Some((name, found, _))) => format!(
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

    /// Per capped end of `tube` (proximal end, tip): whether `img` (camera `cam`'s) shows the
    /// tube going on beyond it ([`TubeFitter::shows_tube`] along each of
    /// [`GOES_ON_STRETCHES_MM`]) — a tube whose silhouette was lost there (too little contrast
    /// against the backdrop) and that the fit capped short. Straight on, and, where some of
    /// the end's cap samples found no boundary (`caps`: found and all, per end), bending off
    /// by [`BEND_PROBE_RAD`]: a tube going on at an angle crosses the search lines of the cap
    /// samples facing it, which then meet no backdrop; a cap found all round shows none.
    /// Beyond a real end the profile is the backdrop's, or whatever lies there at another
    /// width.
    pub(crate) fn goes_on(
        &self,
        cam: &Camera,
        img: &EdgeImage<'_>,
        tube: &Tube,
        own: &BitMask,
        caps: [(usize, usize); 2],
    ) -> [bool; 2] {
        let mut out = [false; 2];
        for end in [0, 1].into_iter().filter(|&e| tube.capped[e]) {
            // Along the end's own tangent (the chord over the last 20 mm takes in a bend
            // just before the end and points off a straight part lost beyond it).
            let (at, tangent) = tube.frame(end as f64);
            let dir = if end == 0 { -tangent } else { tangent };
            let r = tube.radius_at(end as f64, tube.length());
            let along = |dir: nalgebra::Vector3<f64>| {
                GOES_ON_STRETCHES_MM.iter().all(|&(from, to)| {
                    self.shows_tube(
                        cam,
                        (img, own),
                        at + dir * (r + from),
                        at + dir * (r + to),
                        r,
                    )
                })
            };
            let (found, all) = caps[end];
            out[end] = along(dir) || (found < all && bent_off(dir).iter().any(|&d| along(d)));
        }
        out
    }

    /// Whether `img` (camera `cam`'s) shows a tube of radius `r` mm along the segment
    /// `a → b`: `I − E` across it, averaged along it (the noise falls as the root of the
    /// samples, a faint tube's limbs stand out of it), rises above four times what the average
    /// leaves of the backdrop beside it (and half `min_contrast`) over a band as wide as the
    /// tube's image (within 30 % or 2 px), with backdrop on both sides — backdrop that reads
    /// within a quarter of `min_contrast` of the background (a changed backdrop beside the
    /// probe leaves it silent). Never where the
    /// profile meets `own`, the fitted tube's image, within [`OWN_CLEARANCE_PX`]: a part of
    /// the tube lying on past its own end is the tube, not a lost continuation.
    pub(crate) fn shows_tube(
        &self,
        cam: &Camera,
        (img, own): (&EdgeImage<'_>, &BitMask),
        a: nalgebra::Point3<f64>,
        b: nalgebra::Point3<f64>,
        r: f64,
    ) -> bool {
        let Some((_, p0, rp)) = outline::sphere(cam, a, r) else {
            return false;
        };
        let Ok(far) = cam.project(&b) else {
            return false;
        };
        let along = far.pixel.coords - p0;
        let length = along.norm();
        if length < 3.0 {
            return false; // seen end-on: no profile across it
        }
        let d = along / length;
        let normal = Vector2::new(-d.y, d.x);
        let reach = rp + 6.0;
        let offsets: Vec<f64> = (0..=((2.0 * reach) / 0.5) as usize)
            .map(|k| -reach + 0.5 * k as f64)
            .collect();
        let steps = length.ceil() as usize;
        let mut profile = Vec::with_capacity(offsets.len());
        for &o in &offsets {
            let mut sum = [0f64; 3];
            for k in 0..=steps {
                let q = p0 + d * (length * k as f64 / steps as f64) + normal * o;
                if meets(own, q) {
                    return false;
                }
                let Some(v) = img.difference(q) else {
                    return false;
                };
                for c in 0..3 {
                    sum[c] += v[c] as f64;
                }
            }
            let n = (steps + 1) as f64;
            profile.push(sum.iter().map(|v| (v / n).powi(2)).sum::<f64>().sqrt());
        }
        // The backdrop's level beside the band, from the quieter side: a tube going on
        // along a gentle bend drifts a pixel or two off the end's tangent, into one side.
        let side = |sign: f64| {
            let (sum, n) = offsets
                .iter()
                .zip(&profile)
                .filter(|(o, _)| sign * **o > rp + 2.0)
                .fold((0.0, 0usize), |(s, n), (_, c)| (s + c * c, n + 1));
            (sum / n.max(1) as f64).sqrt()
        };
        let floor = side(-1.0).min(side(1.0));
        if floor > self.settings.min_contrast / 4.0 {
            // The backdrop beside reads far from the background (folds that moved, a
            // shadow, strong noise): nothing tells a tube's band from its changes.
            return false;
        }
        let threshold = (4.0 * floor).max(self.settings.min_contrast / 2.0);
        let above: Vec<f64> = offsets
            .iter()
            .zip(&profile)
            .filter(|(_, c)| **c > threshold)
            .map(|(&o, _)| o)
            .collect();
        let (Some(&first), Some(&last)) = (above.first(), above.last()) else {
            return false;
        };
        let width = last - first + 0.5;
        let flanked = first > -reach + 1.5 && last < reach - 1.5;
        flanked && (width - 2.0 * rp).abs() <= (0.3 * 2.0 * rp).max(2.0)
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
            .or_else(|| goes_on(&fit.cameras))
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
        }) && goes_on(&fit.cameras).is_none()
            && shape_verdict(&fit.tube, volume).is_none()
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
                (o.outlying > OUTLYING_SHARE).then(|| format!(
                    "camera {i}: {:.0} % of the outline lies farther from the image's boundary than its limit (at most {:.0} %; a tenth lies more than {:.2} px off, limit {}): the shape does not explain this camera, or its calibration is off",
                    o.outlying * 100.0,
                    OUTLYING_SHARE * 100.0,
                    o.p90,
                    p90_limits(s, c)
                ))
            })
            .or_else(|| {
                let [dx, dy] = c.shift_px;
                let shift = dx.hypot(dy);
                (shift > s.max_shift_px).then(|| format!(
                    "camera {i}: its outline lies {shift:.1} px ({dx:+.1}, {dy:+.1}) off the image's as a whole (limit {:.1}): the cameras disagree about where the tube is, the rig's calibration is off (`flexshape rig refine`)",
                    s.max_shift_px
                ))
            })
            .or_else(|| self.end_placed(c, o))
            .map(|why| why + &lighter_than_backdrop(c))
            .or_else(|| {
                let iou = c.iou_outlined.unwrap_or(c.iou);
                let outlined = match c.iou_outlined {
                    Some(with) => format!(
                        ", {with:.2} with the tube's pixels between boundaries the outline found"
                    ),
                    None => String::new(),
                };
                (iou < c.iou_limit).then(|| format!(
                    "camera {i}: the fitted tube overlaps the silhouette by IoU {:.2}{outlined} (at least {:.2} expected)",
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
        if let Some(why) = found_too_rarely(c, s.min_found) {
            return Some(why);
        }
        let limit = residual_limit(s, c);
        (o.residual > limit).then(|| {
            format!(
                "camera {i}: outline residual {:.2} px RMS (limit {limit:.2}{}; mean {:+.2} px)",
                o.residual,
                with_noise(c.noise_px),
                c.offset_px
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
        let found = seen_share(c.end_found, c.end_samples, c.end_unseen);
        let limit = check::noisy_limit(s.max_residual_px, c.end_noise_px, 1.0);
        (found < s.min_found || o.end_residual > limit).then(|| format!(
            "camera {}: the outline around the tube's free end is not where the image shows it (boundary found at {}/{} samples, residual {:.2} px RMS; limits {:.0} %, {limit:.2} px{}): the tip has moved farther than the fit could follow, or is hidden",
            c.camera,
            c.end_found,
            c.end_samples,
            o.end_residual,
            s.min_found * 100.0,
            with_noise(c.end_noise_px)
        ))
    }
}

/// Why camera `c`'s outline found the image's boundary too rarely to be placed by it, if it
/// did: at fewer than `min_found` of its samples. Samples against a backdrop of the tube's
/// colour ([`CameraCheck::unseen`]) show nothing either way, so the share is over the others,
/// as long as they are `min_found` of the outline.
fn found_too_rarely(c: &CameraCheck, min_found: f64) -> Option<String> {
    let i = &c.camera;
    let seen = c.samples.saturating_sub(c.unseen);
    if (seen as f64) < min_found * c.samples as f64 {
        return Some(format!(
            "camera {i}: the backdrop behind {:.0} % of the fitted outline has the tube's colour, where the image cannot show the tube (at most {:.0} %): the camera hardly sees it against that backdrop",
            c.unseen as f64 / c.samples as f64 * 100.0,
            (1.0 - min_found) * 100.0
        ));
    }
    let found = seen_share(c.found, c.samples, c.unseen);
    (found < min_found).then(|| {
        let over = if c.unseen > 0 {
            format!(" where the backdrop differs from the tube ({} of {seen})", c.found)
        } else {
            String::new()
        };
        format!(
            "camera {i}: the fitted outline found the image's boundary at {:.0} % of its samples{over} (at least {:.0} % expected)",
            found * 100.0,
            min_found * 100.0
        )
    })
}

/// The share of `samples` less the `unseen` ones where a boundary was `found` (0 when none
/// was seen).
fn seen_share(found: usize, samples: usize, unseen: usize) -> f64 {
    found as f64 / samples.saturating_sub(unseen).max(1) as f64
}

/// The limit on camera `c`'s outline residual RMS (the whole outline's and its free ends'):
/// `max_residual_px` widened by the camera's boundary noise.
fn residual_limit(s: &FitSettings, c: &CameraCheck) -> f64 {
    check::noisy_limit(s.max_residual_px, c.noise_px, 1.0)
}

/// How a limit widened by boundaries' scatter of `noise` pixels (RMS) says so (empty
/// without any).
fn with_noise(noise: f64) -> String {
    if noise > 0.0 {
        format!(", with {noise:.2} px of scatter the image's noise gives each boundary")
    } else {
        String::new()
    }
}

/// Largest share of the outline whose size may lie beyond its own limit: a tenth (the
/// outline's 90th percentile, each boundary held to its own scatter).
const OUTLYING_SHARE: f64 = 0.1;

/// The limits camera `c`'s boundaries are held to ([`CameraCheck::outlying_share`]), said:
/// one figure where they are all the same, else the range, with the scatter behind them.
fn p90_limits(s: &FitSettings, c: &CameraCheck) -> String {
    let [lo, hi] = c
        .noise_range_px
        .map(|n| check::noisy_limit(s.max_p90_px, n, check::Z90));
    let [nlo, nhi] = c.noise_range_px;
    if hi - lo < 0.005 {
        format!("{hi:.2}{}", with_noise(nhi))
    } else {
        format!(
            "{lo:.2}–{hi:.2} px, with {nlo:.2}–{nhi:.2} px of scatter the image's noise gives each boundary against the backdrop behind it"
        )
    }
}

/// How near the profile of [`TubeFitter::shows_tube`] may come to the fitted tube's own
/// image, pixels: a boundary blurred or merged with the profile's band.
const OWN_CLEARANCE_PX: f64 = 2.0;

/// Whether `q` (pixels) lies in `mask` or within [`OWN_CLEARANCE_PX`] of it along x or y.
fn meets(mask: &BitMask, q: Vector2<f64>) -> bool {
    let c = OWN_CLEARANCE_PX;
    [(0.0, 0.0), (c, 0.0), (-c, 0.0), (0.0, c), (0.0, -c)]
        .iter()
        .any(|&(dx, dy)| mask.at(q.x + dx, q.y + dy))
}

/// Why the images show the tube going on beyond an end the fit capped, if they do: at least
/// two cameras see it there ([`TubeFitter::goes_on`]; one alone may see a stripe of a changed
/// backdrop that happens to lie on from the end at the tube's width). That end is not where
/// the images have it, so the fit is not located there either (a background that followed
/// the frame from it would take the lost part of the tube in).
fn goes_on(cameras: &[CameraCheck]) -> Option<String> {
    (0..2).find_map(|end| {
        let seen: Vec<&str> = cameras
            .iter()
            .filter(|c| c.goes_on[end])
            .map(|c| c.camera.as_str())
            .collect();
        let which = if end == 1 { "tip" } else { "proximal end" };
        (seen.len() >= 2).then(|| format!(
            "cameras {}: the tube goes on beyond its {which}: the images show it 4–14 mm on from where the fit capped it; the silhouettes lost the rest (too little contrast between the tube and the backdrop?)",
            seen.join(", ")
        ))
    })
}

/// The outline residuals a camera is judged on, pixels: as measured, or beyond its blur.
#[derive(Debug, Clone, Copy)]
struct Outline {
    residual: f64,
    p90: f64,
    outlying: f64,
    end_residual: f64,
}

impl Outline {
    fn measured(c: &CameraCheck) -> Self {
        Outline {
            residual: c.residual_px,
            p90: c.p90_px,
            outlying: c.outlying_share,
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
            outlying: r.outlying_share,
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
    if let Some(why) = open_end_inside(tube, volume) {
        return Some(why);
    }
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

/// Why an open end of `tube` is not where the tube runs out of the volume, if it is not. The
/// record runs an open end on to the volume's boundary (`record_from_curve`); a fitted end
/// that stopped more than a radius and two voxels inside — the start's own tolerance for an
/// end on the boundary — leaves that stretch to the curve's extrapolation, not to the
/// images (a two-view start on silhouettes that lost the tube's proximal part: 3.8 mm off at
/// the boundary, 29 mm beyond the fitted end).
fn open_end_inside(tube: &Tube, volume: &Volume) -> Option<String> {
    let voxel = volume
        .voxel_size
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let length = tube.length();
    (0..2).filter(|&e| !tube.capped[e]).find_map(|e| {
        let u = e as f64;
        let depth = volume.depth(&tube.frame(u).0);
        let tolerance = tube.radius_at(u, length) + 2.0 * voxel;
        let which = if e == 1 { "tip" } else { "proximal end" };
        (depth > tolerance).then(|| format!(
            "the tube runs on out of the volume at its {which}, but the fitted shape stops {depth:.0} mm inside it (at most {tolerance:.1}): the stretch between was not measured (the silhouettes lost the tube there?)"
        ))
    })
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
    fn the_found_share_leaves_out_samples_against_a_backdrop_of_the_tubes_colour() {
        let check = |found: usize, unseen: usize| -> CameraCheck {
            serde_json::from_value(serde_json::json!({
                "camera": "cam0", "samples": 100, "found": found, "unseen": unseen,
                "residual_px": 0.2, "offset_px": 0.0, "p90_px": 0.3, "iou": 0.95,
                "unexplained_px": 0,
            }))
            .unwrap()
        };
        // 50 of 70 seen samples found.
        assert_eq!(found_too_rarely(&check(50, 30), 0.6), None);
        let why = found_too_rarely(&check(50, 0), 0.6).unwrap();
        assert!(
            why.contains("at 50 % of its samples (at least 60 %"),
            "{why}"
        );
        let why = found_too_rarely(&check(30, 30), 0.6).unwrap();
        assert!(
            why.contains("43 % of its samples where the backdrop differs from the tube (30 of 70)"),
            "{why}"
        );
        // Too little of the outline seen at all: the camera cannot confirm the shape.
        let why = found_too_rarely(&check(55, 45), 0.6).unwrap();
        assert!(why.contains("behind 45 % of the fitted outline"), "{why}");
    }

    #[test]
    fn a_stretch_along_two_cameras_epipolar_plane_is_named() {
        let sim = Simulator::new(SimConfig::default()).unwrap();
        let cams = &sim.cameras()[..2];
        let names = vec!["left".to_string(), "right".to_string()];
        let fitter = TubeFitter::new(cams.to_vec(), names, FitSettings::default()).unwrap();
        let centre = tube(&sim, 0.0, 0.0, 1.0).frame(0.0).0;
        let (ca, cb) = (cams[0].centre(), cams[1].centre());
        let normal = (centre - ca).cross(&(centre - cb)).normalize();
        let straight = |d: nalgebra::Vector3<f64>, from: f64, to: f64| {
            let at = |s: f64| (centre + d * s).coords.into();
            Tube::through(&[at(from), at(to)], 3.0, [false, true], 10.0, 0.0).unwrap()
        };
        // Within the plane: the whole 100 mm.
        let in_plane = normal.cross(&(cb - ca)).normalize();
        let said = fitter
            .along_epipolar_plane(&straight(in_plane, -50.0, 50.0))
            .expect("named");
        assert!(
            said.contains("over 100 mm (from 0 to 100 mm along it)")
                && said.contains("of the epipolar plane of left and right"),
            "{said}"
        );
        // Across it, or within it for less than 10 mm: nothing to say.
        assert_eq!(
            fitter.along_epipolar_plane(&straight(normal, -50.0, 50.0)),
            None
        );
        assert_eq!(
            fitter.along_epipolar_plane(&straight(in_plane, 0.0, 8.0)),
            None
        );
        // A third camera sees it from another side: nothing to say either.
        let names = (0..3).map(|i| format!("cam{i}")).collect();
        let three = TubeFitter::new(sim.cameras(), names, FitSettings::default()).unwrap();
        assert_eq!(
            three.along_epipolar_plane(&straight(in_plane, -50.0, 50.0)),
            None
        );
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

    /// An open proximal end on the volume's boundary, or within a radius and two voxels of
    /// it, is where the tube runs out; one stopped farther inside leaves the record's stretch
    /// to the boundary unmeasured.
    #[test]
    fn an_open_end_stopped_inside_the_volume_is_not_measured_to_its_boundary() {
        let sim = Simulator::new(SimConfig::default()).unwrap();
        let volume = sim.rig().volume;
        // The volume runs 128 mm below its centre; the tube's radius is 3 mm, its voxels 1 mm.
        for (z0, inside) in [
            (-135.0, false),
            (-128.0, false),
            (-124.0, false),
            (-120.0, true),
            (-60.0, true),
        ] {
            let t = tube(&sim, 0.0, z0, 40.0);
            let why = open_end_inside(&t, &volume);
            assert_eq!(why.is_some(), inside, "from {z0} mm: {why:?}");
            assert_eq!(shape_verdict(&t, &volume), why, "from {z0} mm");
        }
        let why = open_end_inside(&tube(&sim, 0.0, -60.0, 40.0), &volume).unwrap();
        assert!(
            why.contains("proximal end") && why.contains("68 mm inside"),
            "{why}"
        );
        // A capped end is where the fit put it: nothing runs on.
        let mut capped = tube(&sim, 0.0, -60.0, 40.0);
        capped.capped = [true, true];
        assert_eq!(open_end_inside(&capped, &volume), None);
    }
}
