//! Gauss–Newton on the outline residuals: the outline is predicted in every camera and the
//! boundary measured along each outline normal (`measure`); then the control points and radius
//! move to close the gaps to those fixed boundaries (`against`: point to line), with Huber
//! weights against outliers (the tube crossing itself, clutter), until the tube stops moving;
//! then the boundaries are measured again around the new outline.
//!
//! Parameters: the control points (3 per point, world mm), then the radius (mm). Residuals:
//! pixels. A weak prior holds each control point near where it started along the tube (the
//! outline hardly sees a control point slide along it), a firm one an open end (nothing in the
//! images ends it), and a tiny ridge keeps spans no camera sees in place.

use flexshape_camera::Camera;
use nalgebra::{DMatrix, DVector, Vector2, Vector3};

use crate::edges::EdgeImage;
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
}

/// Every camera's outline of `tube`, measured.
pub(crate) fn measure(
    cameras: &[Camera],
    images: &[EdgeImage<'_>],
    tube: &Tube,
    settings: &FitSettings,
) -> Vec<Vec<Measured>> {
    let sampled = Sampled::new(tube, settings.spacing_mm);
    cameras
        .iter()
        .zip(images)
        .map(|(cam, img)| {
            outline(
                cam,
                tube,
                &sampled,
                settings.spacing_mm,
                settings.search_px.min(2.0) + 0.5,
            )
            .into_iter()
            .map(|p| {
                let inside = p.half_width.min(settings.search_px + 1.0).max(1.0);
                let edge = img.find(
                    p.pixel,
                    p.normal,
                    inside,
                    settings.search_px,
                    settings.min_contrast,
                );
                Measured {
                    point: p,
                    residual: edge.map(|e| -e.offset),
                    edge: edge.map(|e| (p.pixel + p.normal * e.offset, p.normal)),
                }
            })
            .collect()
        })
        .collect()
}

/// The same boundaries against the outline of a moved `tube`: each found boundary keeps its
/// pixel and search direction, and its residual is the moved prediction's distance from it
/// (point to line). Between re-measurements this makes Gauss–Newton converge on fixed data.
/// Samples where no boundary was found are left out, or with `keep_unfound` kept as they were
/// (for the self-check, which counts them).
pub(crate) fn against(
    cameras: &[Camera],
    tube: &Tube,
    measured: &[Vec<Measured>],
    keep_unfound: bool,
) -> Vec<Vec<Measured>> {
    cameras
        .iter()
        .zip(measured)
        .map(|(cam, ms)| {
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
                    })
                })
                .collect()
        })
        .collect()
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
    for_each_row(tube, measured, settings, fit_radius, |row| {
        add_row(&mut h, &mut g, row.entries, row.r, row.w);
        cost += row.w * row.r * row.r;
        rows += 1;
    });
    priors(tube, start, settings, fit_radius, &mut h, &mut g);
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
            let w = huber(r, settings.huber_px) * p.weight;
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
        // d³x/ds³·h³/6 over a span h = L/spans, with s = u·L (the parameter is proportional
        // to arc length).
        let scale = settings.tip_curl_prior / (6.0 * spans.powi(3));
        for c in 0..3 {
            entries.clear();
            for j in 0..4 {
                entries.push((3 * (b.first + j) + c, scale * b.weights[3][j]));
            }
            add_row(h, g, &entries, scale * d.d3[c], 1.0);
        }
    }
    if !fit_radius {
        for k in 0..=tube.steps.len() {
            let col = tube.radius_column(k);
            h[(col, col)] += 1.0;
        }
    }
}

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
