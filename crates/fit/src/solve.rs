//! Gauss–Newton on the outline residuals: the outline is predicted in every camera and the
//! boundary measured along each outline normal (`measure`); then the control points and radius
//! move to close the gaps to those fixed boundaries (`against`: point to line), with Huber
//! weights against outliers (the tube crossing itself, clutter), until the tube stops moving;
//! then the boundaries are measured again around the new outline.
//!
//! Parameters: the control points (3 per point, world mm), then the radius (mm). Residuals:
//! pixels. A weak prior holds each control point near where it started along the tube (the
//! outline hardly sees a control point slide along it), a firm one an open end (nothing in the
//! images ends it), a capped end's last span and any span the cameras see from too few sides
//! are held from changing curvature where the images leave them free, and a tiny ridge keeps
//! spans no camera sees in place.

use flexshape_camera::Camera;
use flexshape_curve::Basis;
use nalgebra::{DMatrix, DVector, Matrix3, Vector2, Vector3};

use crate::edges::{EdgeImage, Miss};
use crate::outline::{OutlinePoint, Part, Sampled, again, outline};
use crate::settings::FitSettings;
use crate::tube::Tube;

/// A measured outline point: its prediction and the boundary found for it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Measured {
    /// The prediction.
    pub point: OutlinePoint,
    /// Predicted minus measured position along the outline normal, pixels (`None`: no
    /// boundary found).
    pub residual: Option<f64>,
    /// The boundary found: its pixel and the outline normal it was searched along.
    pub edge: Option<(Vector2<f64>, Vector2<f64>)>,
    /// Whether the tube is lighter than the background at the boundary found.
    pub lighter: bool,
    /// The boundary's ¼–¾ rise, pixels ([`crate::edges::Edge::ramp`]).
    pub ramp: Option<f64>,
    /// The grey levels the coverage was read from there ([`crate::edges::Edge::contrast`]; 0
    /// where no boundary was found).
    pub contrast: f64,
    /// With free widths, how much narrower the silhouette is than the tube's image here,
    /// taken out of `residual` (pixels; 0 when widths follow the tube).
    pub narrowing: f64,
    /// No boundary because the backdrop there has the tube's colour ([`Miss::Unseen`]): the
    /// image holds no evidence here either way, and the found share leaves it out.
    pub unseen: bool,
    /// How far inside the boundary found the tube's outline may lie because its rim is finer
    /// than the pixels ([`crate::edges::Edge::rim`]), pixels: the residual may be up to this
    /// much larger. 0 on the caps, which alone place the tip along the tube: a short tip's
    /// cap reads outward of its prediction, as an unresolved rim does.
    pub rim: f64,
    /// How far either way the boundary found may lie from the tube's outline because the
    /// backdrop changes within the pixels it was read from
    /// ([`crate::edges::Edge::backdrop`]), pixels.
    pub backdrop: f64,
}

impl Measured {
    /// The residual's size: the distance from 0 to the residuals the image allows, from
    /// `residual − backdrop` to `residual + rim + backdrop` (0 where no boundary was found).
    pub(crate) fn size(&self) -> f64 {
        match self.residual {
            Some(r) if r < 0.0 => (-r - self.rim - self.backdrop).max(0.0),
            Some(r) => (r - self.backdrop).max(0.0),
            None => 0.0,
        }
    }
}

/// The tube as each camera saw it: the same for all (cameras triggered together), or each
/// camera's own ([`crate::AcrossTime`]: the tube where it was at that camera's capture).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Seen<'a> {
    /// Every camera saw this tube.
    All(&'a Tube),
    /// Camera `k` saw the `k`-th.
    Each(&'a [Tube]),
}

impl<'a> Seen<'a> {
    /// `each` camera's own tube when given, else `tube` for all.
    pub(crate) fn of(tube: &'a Tube, each: Option<&'a [Tube]>) -> Self {
        match each {
            Some(tubes) => Seen::Each(tubes),
            None => Seen::All(tube),
        }
    }

    /// The tube camera `camera` saw (the last one for a camera past the list).
    pub(crate) fn by(&self, camera: usize) -> &'a Tube {
        match *self {
            Seen::All(tube) => tube,
            Seen::Each(tubes) => &tubes[camera.min(tubes.len() - 1)],
        }
    }
}

/// Every camera's outline of the tube it saw, measured (with free widths, only the middles
/// between the sides place it: [`crate::width::middles`]).
pub(crate) fn measure(
    cameras: &[Camera],
    images: &[EdgeImage<'_>],
    seen: Seen<'_>,
    settings: &FitSettings,
) -> Vec<Vec<Measured>> {
    // One sampling serves every camera that saw the same tube.
    let shared = match seen {
        Seen::All(tube) => Some(Sampled::new(tube, settings.spacing_mm)),
        Seen::Each(_) => None,
    };
    let mut measured: Vec<Vec<Measured>> = cameras
        .iter()
        .zip(images)
        .enumerate()
        .map(|(k, (cam, img))| {
            let tube = seen.by(k);
            let own;
            let sampled = match &shared {
                Some(s) => s,
                None => {
                    own = Sampled::new(tube, settings.spacing_mm);
                    &own
                }
            };
            let mut points = outline(
                cam,
                tube,
                sampled,
                settings.spacing_mm,
                settings.search_px.min(2.0) + 0.5,
            );
            let inside = |p: &crate::outline::OutlinePoint| {
                p.half_width.min(settings.search_px + 1.0).max(1.0)
            };
            // Hidden by something in front of the volume: left out, as points outside the
            // image are.
            if img.hides_any() {
                points.retain(|p| !img.hides(p.pixel, p.normal, inside(p), settings.search_px));
            }
            points
                .into_iter()
                .map(|p| {
                    let inside = inside(&p);
                    let edge = img.find(
                        p.pixel,
                        p.normal,
                        inside,
                        settings.search_px,
                        settings.min_contrast,
                    );
                    let unseen = edge == Err(Miss::Unseen);
                    let edge = edge.ok();
                    Measured {
                        point: p,
                        residual: edge.map(|e| -e.offset),
                        edge: edge.map(|e| (p.pixel + p.normal * e.offset, p.normal)),
                        lighter: edge.is_some_and(|e| e.lighter),
                        ramp: edge.and_then(|e| e.ramp),
                        contrast: edge.map_or(0.0, |e| e.contrast),
                        narrowing: 0.0,
                        unseen,
                        // The caps alone place the tip along the tube: held to what they read.
                        rim: match p.part {
                            Part::Side(_) => edge.map_or(0.0, |e| e.rim),
                            Part::Cap(_) => 0.0,
                        },
                        backdrop: edge.map_or(0.0, |e| e.backdrop),
                    }
                })
                .collect::<Vec<_>>()
        })
        .collect();
    for (m, img) in measured.iter_mut().zip(images) {
        if img.shaded() {
            caps_unshrunk(m);
        }
    }
    if settings.free_width() {
        for m in &mut measured {
            crate::width::middles(m);
        }
    }
    measured
}

/// A camera's cap boundaries moved out by what its blur shrinks them: the image of a round
/// cap of radius `ρ` pixels, blurred as a Gaussian of variance `σ²`, reaches half its contrast
/// `σ²/2ρ` inside its outline (a straight boundary keeps its place), and the cap's boundaries
/// are read there. `σ` comes from the camera's own boundaries: the median ¼–¾ rise of those
/// found along the sides over 1.349, never below a sharp edge's
/// ([`crate::edges::SHARP_RAMP_PX`]: a pixel's box read bilinearly, ¼ px²). A tube 1.2 mm in
/// radius filmed at 640×480 has caps about 1.5 px in radius, shrunk by 0.1–0.15 px: fitted
/// through them, its tips fell 0.2–0.37 mm short.
pub(crate) fn caps_unshrunk(measured: &mut [Measured]) {
    let ramps = measured
        .iter()
        .filter(|m| matches!(m.point.part, Part::Side(_)))
        .filter_map(|m| m.ramp);
    let ramp = crate::median(ramps).max(crate::edges::SHARP_RAMP_PX);
    if !ramp.is_finite() {
        return;
    }
    let variance = (ramp / 1.349).powi(2);
    for m in measured {
        let (Part::Cap(_), Some(residual), Some((pixel, normal))) =
            (m.point.part, m.residual, m.edge)
        else {
            continue;
        };
        let shrink = variance / (2.0 * m.point.half_width.max(0.5));
        m.residual = Some(residual - shrink);
        m.edge = Some((pixel + normal * shrink, normal));
    }
}

/// The same boundaries against the outline of a moved `tube`: each found boundary keeps its
/// pixel and search direction, and its residual is the moved prediction's distance from it
/// (point to line). Between re-measurements this makes Gauss–Newton converge on fixed data.
/// Samples where no boundary was found are left out, or with `keep_unfound` kept as they were
/// (for the self-check, which counts them). With `free_width` only the middles between the
/// sides place the tube ([`crate::width::middles`]).
pub(crate) fn against(
    cameras: &[Camera],
    seen: Seen<'_>,
    measured: &[Vec<Measured>],
    keep_unfound: bool,
    free_width: bool,
) -> Vec<Vec<Measured>> {
    let mut moved: Vec<Vec<Measured>> = cameras
        .iter()
        .zip(measured)
        .enumerate()
        .map(|(k, (cam, ms))| {
            let tube = seen.by(k);
            ms.iter()
                .filter_map(|m| {
                    let Some((pixel, normal)) = m.edge else {
                        return keep_unfound.then_some(*m);
                    };
                    let mut p = again(cam, tube, &m.point, 1.0)?;
                    p.weight = m.point.weight;
                    Some(Measured {
                        point: p,
                        residual: Some(normal.dot(&(p.pixel - pixel))),
                        edge: m.edge,
                        lighter: m.lighter,
                        ramp: m.ramp,
                        contrast: m.contrast,
                        narrowing: 0.0,
                        unseen: false,
                        rim: m.rim,
                        backdrop: m.backdrop,
                    })
                })
                .collect()
        })
        .collect();
    if free_width {
        for m in &mut moved {
            crate::width::middles(m);
        }
    }
    moved
}

/// Normal equations `H δ = −g` of one linearisation.
pub(crate) struct Normal {
    pub h: DMatrix<f64>,
    pub g: DVector<f64>,
    /// Weighted squared residuals of the image rows, px².
    pub cost: f64,
    /// Image rows used.
    pub rows: usize,
}

/// Weighs and accumulates the measured rows and the priors around `start`.
pub(crate) fn normal_equations(
    tube: &Tube,
    start: &Tube,
    measured: &[Vec<Measured>],
    settings: &FitSettings,
    fit_radius: bool,
) -> Normal {
    let n = tube.parameters();
    let mut h = DMatrix::<f64>::zeros(n, n);
    let mut g = DVector::<f64>::zeros(n);
    let (mut cost, mut rows) = (0.0, 0usize);
    let spans = tube.centerline.control().len() - 3;
    // Which cameras see each span (the knots are uniform in the parameter).
    let mut cameras = vec![0u64; spans];
    for_each_row(tube, measured, settings, fit_radius, |row| {
        add_row(&mut h, &mut g, row.entries, row.r, row.w);
        cost += row.w * row.r * row.r;
        rows += 1;
        let p = &row.measured.point;
        if let Part::Side(_) = p.part {
            cameras[((p.u * spans as f64) as usize).min(spans - 1)] |= 1 << row.camera.min(63);
        }
    });
    // How a span is seen: the images' information on its two middle control points, the
    // diagonal blocks of `h` so far (upper triangles), Σ w·b²·d·dᵀ over the rows on them.
    let block = |k: usize| Matrix3::from_fn(|r, c| h[(3 * k + r.min(c), 3 * k + r.max(c))]);
    let seen: Vec<SpanSeen> = cameras
        .iter()
        .enumerate()
        .map(|(k, &cameras)| SpanSeen {
            information: block(k + 1) + block(k + 2),
            cameras,
        })
        .collect();
    priors(tube, start, &seen, settings, fit_radius, &mut h, &mut g);
    mirror_upper(&mut h);
    Normal { h, g, cost, rows }
}

/// One image row of the normal equations.
pub(crate) struct Row<'a> {
    /// The camera (rig order).
    pub camera: usize,
    /// The measured outline point.
    pub measured: &'a Measured,
    /// The tube parameters the residual depends on, and its derivative by each (px per mm).
    pub entries: &'a [(usize, f64)],
    /// The residual, pixels.
    pub r: f64,
    /// Its weight (Huber's times the sample's share).
    pub w: f64,
}

/// Calls `visit` for every measured outline point with a residual: its Jacobian row in the
/// tube's parameters (control points, then its section's radius if `fit_radius`) and its
/// weight.
pub(crate) fn for_each_row(
    tube: &Tube,
    measured: &[Vec<Measured>],
    settings: &FitSettings,
    fit_radius: bool,
    mut visit: impl FnMut(Row<'_>),
) {
    let last = tube.centerline.control().len() - 1;
    let mut entries: Vec<(usize, f64)> = Vec::with_capacity(13);
    for (camera, ms) in measured.iter().enumerate() {
        for m in ms {
            let Some(r) = m.residual else { continue };
            let p = &m.point;
            let blur = crate::check::blur_scale(m.ramp);
            let w = huber(r / blur, settings.huber_px) * p.weight / (blur * blur);
            let dir = p.surface * p.gain;
            entries.clear();
            match p.part {
                Part::Side(b) => {
                    for j in 0..4 {
                        let bj = b.weights[0][j];
                        if bj != 0.0 {
                            for c in 0..3 {
                                entries.push((3 * (b.first + j) + c, bj * dir[c]));
                            }
                        }
                    }
                }
                Part::Cap(end) => {
                    let k = if end == 0 { 0 } else { last };
                    for c in 0..3 {
                        entries.push((3 * k + c, dir[c]));
                    }
                }
            }
            if fit_radius {
                entries.push((tube.radius_column(p.section), p.gain));
            }
            visit(Row {
                camera,
                measured: m,
                entries: &entries,
                r,
                w,
            });
        }
    }
}

/// Adds the priors around `start` to `h` and `g`.
fn priors(
    tube: &Tube,
    start: &Tube,
    seen: &[SpanSeen],
    settings: &FitSettings,
    fit_radius: bool,
    h: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
) {
    let last = tube.centerline.control().len() - 1;
    let mut entries: Vec<(usize, f64)> = Vec::with_capacity(3);
    // Along the tube a control point hardly moves the outline: each is held near where it
    // started along the tube (weakly; an open end, which nothing in the images ends, firmly),
    // in pixels per mm.
    let start_ctrl = start.centerline.control();
    let ctrl = tube.centerline.control();
    for k in 0..=last {
        let t = tube.control_tangent(k);
        let end = (k == 0).then_some(0).or((k == last).then_some(1));
        // A cap's outline places its end along the tube; holding it toward where it started
        // would pull a tip that moved back toward where it was.
        let weight = match end {
            Some(e) if !tube.capped[e] => settings.end_anchor,
            Some(_) => 0.0,
            None => settings.slide_prior,
        };
        let dev = Vector3::from(ctrl[k]) - Vector3::from(start_ctrl[k]);
        entries.clear();
        for c in 0..3 {
            entries.push((3 * k + c, weight * t[c]));
        }
        add_row(h, g, &entries, weight * t.dot(&dev), 1.0);
        for c in 0..3 {
            let col = 3 * k + c;
            h[(col, col)] += RIDGE;
        }
    }
    // A capped end's last span is held by little more than its cap, whose outline hardly
    // changes as the end turns: followed frame after frame it could curl back into its own
    // outline. Its third derivative by arc length (κ² on an arc of constant curvature: 0.06 mm
    // over a 15-mm span at κ = 0.01/mm, against millimetres for a curl) is held near zero,
    // weakly, as the displacement it makes over a span.
    let spans = (last - 2) as f64;
    for e in 0..2 {
        if !tube.capped[e] || settings.tip_curl_prior <= 0.0 {
            continue;
        }
        let b = tube.centerline.basis(e as f64);
        let d = tube.centerline.eval_basis(&b);
        let scale = per_span(settings.tip_curl_prior, spans);
        for c in 0..3 {
            let along = Vector3::ith(c, 1.0);
            hold_third_derivative(&b, &d.d3, &along, scale, &mut entries, h, g);
        }
    }
    hold_weakly_seen_spans(tube, seen, settings, &mut entries, h, g);
    if !fit_radius {
        for k in 0..=tube.steps.len() {
            let col = tube.radius_column(k);
            h[(col, col)] += 1.0;
        }
    }
}

/// Holds the shape of spans the cameras see from too few sides.
///
/// Two cameras see a stretch of tube that lies near their epipolar plane from one direction:
/// both outlines hold it across that plane and neither within it, where noise and a few
/// hundredths of a pixel of edge bias then bend it by up to a millimetre (two-camera motions:
/// wiggles of 0.5–0.9 mm with a 1-σ of 0.1 mm, and the fit lands in one or another of them as
/// it starts). There a span's third derivative along the direction it is seen least (a change
/// of curvature there, or a wiggle) is held near zero as the tip-curl prior holds a capped
/// end's. When fewer than three cameras see the tube, every span is held so: a direction is
/// always weak somewhere, and a tip seen at a glancing angle slid a millimetre along the tube
/// where only the nearly end-on spans were held. When three or more see it, a span is held by
/// how close together the directions it is seen from are, fading to nothing at
/// [`SEEN_APART_DEG`]: a span seen from well apart is the images' alone (a prior there too
/// rounds off the step in curvature where a bending section starts, +0.07 % of curvature bias
/// on the default scene; held wherever two cameras see it, the proximal end beyond the
/// volume made tracked fits take 15 % more steps).
fn hold_weakly_seen_spans(
    tube: &Tube,
    seen: &[SpanSeen],
    settings: &FitSettings,
    entries: &mut Vec<(usize, f64)>,
    h: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
) {
    if settings.weak_span_prior <= 0.0 {
        return;
    }
    let spans = seen.len() as f64;
    // Two directions φ apart, seen equally, give the across-tube information eigenvalues
    // 1 ± cos φ: a ratio of tan²(φ/2).
    let open = (SEEN_APART_DEG.to_radians() / 2.0).tan().powi(2);
    let scale = per_span(settings.weak_span_prior, spans);
    let few = seen
        .iter()
        .fold(0, |all, span| all | span.cameras)
        .count_ones()
        < 3;
    for (k, span) in seen.iter().enumerate() {
        let b = tube.centerline.basis((k as f64 + 0.5) / spans);
        let d = tube.centerline.eval_basis(&b);
        let t = Vector3::from(d.d1).normalize();
        let other = if t.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let n1 = t.cross(&other).normalize();
        let n2 = t.cross(&n1);
        let info = &span.information;
        let (a, c, off) = (
            n1.dot(&(info * n1)),
            n2.dot(&(info * n2)),
            n1.dot(&(info * n2)),
        );
        let (mean, half) = ((a + c) / 2.0, (((a - c) / 2.0).powi(2) + off * off).sqrt());
        let (strong, weak) = (mean + half, mean - half);
        if strong <= 0.0 {
            // No camera sees it: the ridge holds it where it is.
            continue;
        }
        let fade = if few {
            1.0
        } else {
            (1.0 - weak.max(0.0) / (strong * open)).max(0.0)
        };
        if fade == 0.0 {
            continue;
        }
        // The weak eigenvector, from whichever row of (A − weak·I) is better conditioned.
        let (e1, e2) = if (a - weak).abs() > (c - weak).abs() {
            (off, weak - a)
        } else {
            (weak - c, off)
        };
        let norm = e1.hypot(e2);
        let w = if norm > 0.0 {
            (n1 * e1 + n2 * e2) / norm
        } else {
            n1
        };
        hold_third_derivative(&b, &d.d3, &w, scale * fade, entries, h, g);
    }
}

/// The scale [`hold_third_derivative`] takes for a prior of `weight` px per mm: the
/// displacement the third derivative makes over a span, d³x/ds³·h³/6 with h = L/`spans`, from
/// the derivative by the parameter u = s/L (proportional to arc length).
fn per_span(weight: f64, spans: f64) -> f64 {
    weight / (6.0 * spans.powi(3))
}

/// Adds a row holding the centerline's third derivative by its parameter at basis `b` (where
/// it is `d3`) near zero along the unit vector `along`, weighted `scale` (see [`per_span`]).
fn hold_third_derivative(
    b: &Basis,
    d3: &[f64; 3],
    along: &Vector3<f64>,
    scale: f64,
    entries: &mut Vec<(usize, f64)>,
    h: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
) {
    entries.clear();
    for j in 0..4 {
        for c in (0..3).filter(|&c| along[c] != 0.0) {
            entries.push((3 * (b.first + j) + c, scale * b.weights[3][j] * along[c]));
        }
    }
    add_row(h, g, entries, scale * along.dot(&Vector3::from(*d3)), 1.0);
}

/// How the cameras see one span of the centerline.
#[derive(Clone, Copy)]
struct SpanSeen {
    /// Information of the image rows on its middle control points' positions, px²/mm²: Σ
    /// w·b²·d·dᵀ, d the direction the outline moves per mm of the surface, b the point's
    /// weight in the sample.
    information: Matrix3<f64>,
    /// The cameras with a side sample on it, one bit each (the 64th stands for any beyond).
    cameras: u64,
}

/// The angle between the directions cameras see a span from beyond which its outlines alone
/// shape it (see [`hold_weakly_seen_spans`]), degrees.
const SEEN_APART_DEG: f64 = 30.0;

/// The ridge's weight, px² per mm² (far below any camera's: a span no camera sees stays put).
const RIDGE: f64 = 1e-4;

/// Huber's weight for a residual, `k` its threshold.
pub(crate) fn huber(r: f64, k: f64) -> f64 {
    if r.abs() <= k { 1.0 } else { k / r.abs() }
}

/// Adds one weighted row to the normal equations: `g` in full, `h` in its upper triangle only
/// (half the work; [`mirror_upper`] completes it).
fn add_row(h: &mut DMatrix<f64>, g: &mut DVector<f64>, entries: &[(usize, f64)], r: f64, w: f64) {
    let n = h.nrows();
    let hs = h.as_mut_slice();
    for &(i, a) in entries {
        let wa = w * a;
        g[i] += wa * r;
        // Column-major: (i, j) at j·n + i.
        for &(j, b) in entries {
            if j >= i {
                hs[j * n + i] += wa * b;
            }
        }
    }
}

/// Copies the upper triangle of `h` onto its lower one.
fn mirror_upper(h: &mut DMatrix<f64>) {
    let n = h.nrows();
    for j in 0..n {
        for i in j + 1..n {
            h[(i, j)] = h[(j, i)];
        }
    }
}

/// Measured samples made up for tests elsewhere in the crate.
#[cfg(test)]
pub(crate) mod made_up {
    use nalgebra::{Point3, Vector2, Vector3};

    use super::Measured;
    use crate::outline::{OutlinePoint, Part};

    /// A sample of `part` at `u`, grazing point `which`, with `residual` (pixels).
    pub(crate) fn sample(part: Part, u: f64, which: f64, residual: Option<f64>) -> Measured {
        Measured {
            point: OutlinePoint {
                pixel: Vector2::zeros(),
                normal: Vector2::x(),
                gain: 1.0,
                surface: Vector3::x(),
                half_width: 5.0,
                weight: 1.0,
                part,
                section: 0,
                u,
                which,
                world: Point3::origin(),
            },
            residual,
            edge: None,
            lighter: false,
            ramp: None,
            contrast: 0.0,
            narrowing: 0.0,
            unseen: false,
            rim: 0.0,
            backdrop: 0.0,
        }
    }

    /// A side sample at `u` on side `which` (±1).
    pub(crate) fn side(u: f64, which: f64, residual: Option<f64>) -> Measured {
        let basis = flexshape_curve::Basis {
            first: 0,
            weights: [[0.25; 4]; 4],
        };
        sample(Part::Side(basis), u, which, residual)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight capped tube along x, 60 mm in 4 spans, and the normal equations the prior
    /// adds to when every span is seen from `directions`, span k by the cameras in
    /// `cameras[k % cameras.len()]`.
    fn held(directions: &[Vector3<f64>], cameras: &[u64]) -> DMatrix<f64> {
        let points: Vec<[f64; 3]> = (0..=60).map(|i| [i as f64, 0.0, 0.0]).collect();
        let tube = Tube::through(&points, 3.0, [true, true], 15.0, 0.0).unwrap();
        let information = directions.iter().map(|d| d * d.transpose()).sum();
        let spans = tube.centerline.control().len() - 3;
        let seen: Vec<SpanSeen> = (0..spans)
            .map(|k| SpanSeen {
                information,
                cameras: cameras[k % cameras.len()],
            })
            .collect();
        let n = tube.parameters();
        let (mut h, mut g) = (DMatrix::zeros(n, n), DVector::zeros(n));
        let settings = FitSettings::default();
        hold_weakly_seen_spans(&tube, &seen, &settings, &mut Vec::new(), &mut h, &mut g);
        // Straight: nothing to pull towards, only to hold.
        assert!(g.amax() < 1e-12, "{g}");
        h
    }

    /// The largest entry `h` has for coordinate `c` of any control point.
    fn largest(h: &DMatrix<f64>, c: usize) -> f64 {
        (0..h.nrows() / 3)
            .map(|k| h[(3 * k + c, 3 * k + c)].abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn three_cameras_seeing_a_span_from_well_apart_leave_it_to_the_images() {
        let dirs = [
            Vector3::y(),
            Vector3::z(),
            (Vector3::y() + Vector3::z()).normalize(),
        ];
        assert_eq!(held(&dirs, &[0b111]).amax(), 0.0);
    }

    #[test]
    fn a_span_seen_from_one_side_is_held_in_the_direction_seen_least() {
        // Three cameras, 10° apart about the tube: the weak direction is z.
        let tilt = |deg: f64| Vector3::new(0.0, deg.to_radians().cos(), deg.to_radians().sin());
        let h = held(&[tilt(-10.0), tilt(0.0), tilt(10.0)], &[0b111]);
        assert!(largest(&h, 2) > 0.0);
        assert!(largest(&h, 1) < 1e-6 * largest(&h, 2), "{h}");
        assert_eq!(largest(&h, 0), 0.0);
    }

    #[test]
    fn two_cameras_always_leave_a_direction_held() {
        // Seen from 90° apart, more evenly from y: the weak direction is z.
        let h = held(&[Vector3::y() * 2.0, Vector3::z()], &[0b11]);
        assert!(largest(&h, 2) > 0.0);
        assert!(largest(&h, 1) < 1e-6 * largest(&h, 2), "{h}");
        // The same seen by three cameras is left to the images; so it is when only two of
        // them see some spans (as the proximal end beyond the volume often is).
        assert_eq!(
            held(&[Vector3::y() * 2.0, Vector3::z()], &[0b111]).amax(),
            0.0
        );
        assert_eq!(
            held(&[Vector3::y() * 2.0, Vector3::z()], &[0b011, 0b111]).amax(),
            0.0
        );
    }
}
