//! Marker bands on the fitted centerline, from the colour along its projection in every
//! camera.
//!
//! Along the tube every half millimetre, each camera that sees the tube side-on enough
//! reads the colour at the centerline's pixel. Tape and body colours come from the samples the
//! silhouette's marker mask does and does not mark (the body's from those within 10 mm when
//! they spread widely: a silvery tube shows its highlight at the centerline in one place and
//! its dark body in another); the tape's share `q = (I − B)·(T − B) / ‖T − B‖²` is linear in
//! how much of the pixel the tape covers, so a band's edge is where `q` crosses halfway
//! between its level inside and outside the band. The surface a camera sees
//! at the centerline's pixel is not the centerline's own section: the ray meets the tube's
//! near side `r·cot α` closer to the camera along the tube (`α` the angle between ray and
//! tangent), which is taken off. Cameras' edges are averaged, each weighted by `sin⁴ α`: an
//! edge's arc length from a camera that sees the tube obliquely errs as `1/sin α` with its
//! pixels and as `r·δ/sin² α` with a tangent off by `δ` (through the shift), and seen at 30°
//! one such camera put a tip band 0.19 mm off where the side-on ones agreed within 0.05. A
//! band that runs into the tip ends there.

use flexshape_camera::Camera;
use flexshape_shape::CurveBand;
use flexshape_silhouette::BitMask;
use image::RgbImage;
use nalgebra::{Point3, Vector2, Vector3};

use crate::outline::Spheres;
use crate::tube::Tube;

/// Spacing of the colour samples along the tube, mm.
const STEP: f64 = 0.5;
/// Smallest sine of the angle between a camera's ray and the tube for its colour to count.
const MIN_SIN: f64 = 0.5;
/// Smallest step of the tape's share `q` across a band's end for the end to count (tape 1,
/// body 0): a camera that sees the tip obliquely read `q` ≈ 0.45–0.6 over 4 mm before a tip
/// band (its pixels mixing cap and side), and the halfway crossing of that plateau put the
/// band's end 5.6 mm off where the side-on cameras agreed within 0.01 mm.
const MIN_STEP: f64 = 0.5;

/// One camera's colour sample at one place along the tube.
#[derive(Clone, Copy)]
struct Sample {
    colour: [f32; 3],
    marked: bool,
    /// Arc-length shift of the seen surface, mm (`r·cot α`).
    shift: f64,
    /// `sin α`: how side-on the camera sees the tube here.
    sin: f64,
}

/// One camera's bands: arc lengths (from the tube's start) of their ends; `None` for an end cut
/// by the tube's open start; the upper end at the tube's end means the band reaches the tip.
struct Seen {
    lower: Option<Edge>,
    upper: Edge,
    at_tip: bool,
}

/// A band end's arc length, mm, and the weight its camera's view gives it.
#[derive(Clone, Copy)]
struct Edge {
    at: f64,
    weight: f64,
}

/// The bands on `tube`, as curve parameters, from every camera's image and marker mask;
/// `spheres` are the tube's visibility spheres in each camera. With `each`, camera `k` saw
/// the tube as `each[k]` (cameras that captured apart, [`crate::AcrossTime`]): its colours
/// are read along that one, at the same parameters.
pub(crate) fn locate(
    cameras: &[Camera],
    images: &[&RgbImage],
    markers: &[&BitMask],
    (tube, each): (&Tube, Option<&[Tube]>),
    spheres: &[Spheres],
) -> Vec<CurveBand> {
    let table = ArcTable::new(tube);
    let length = table.length();
    let last = (length / STEP).floor() as usize;
    // The centerline at every KNOT_EVERY-th sample and the last, shared by the cameras.
    let knots_of = |seen: &Tube| -> Vec<Frame> {
        knot_samples(last)
            .map(|k| {
                let u = table.u_of(k as f64 * STEP);
                let (c, t) = seen.frame(u);
                (c, t, u)
            })
            .collect()
    };
    let shared = knots_of(tube);
    let radius = |u: f64| tube.radius_at(u, length);
    let mut seen: Vec<Seen> = Vec::new();
    for (k, (((camera, image), mask), spheres)) in cameras
        .iter()
        .zip(images)
        .zip(markers)
        .zip(spheres)
        .enumerate()
    {
        let own = each.and_then(|e| e.get(k)).map(knots_of);
        let knots = own.as_deref().unwrap_or(&shared);
        let samples = sample(camera, image, mask, (knots, &radius), last, spheres);
        seen.extend(runs(&samples, tube.capped[1]));
    }
    merge(seen, length)
        .into_iter()
        .map(|(lower, upper, at_tip)| CurveBand {
            u: [table.u_of(lower), table.u_of(upper)],
            at_tip,
        })
        .collect()
}

/// Samples between two knots: over two millimetres the centerline, its image and its tangent
/// are straight to far below a pixel and a milliradian (a bend of 50 mm radius), so they are
/// interpolated, and a sample counts as hidden when either neighbouring knot is (visibility
/// edges move out by at most this).
const KNOT_EVERY: usize = 4;

/// A centerline point and its unit tangent (world mm), and its curve parameter.
type Frame = (Point3<f64>, Vector3<f64>, f64);

/// The indices of the knots among samples `0..=last`: every [`KNOT_EVERY`]-th and the last.
fn knot_samples(last: usize) -> impl Iterator<Item = usize> {
    (0..=last.div_ceil(KNOT_EVERY)).map(move |i| (i * KNOT_EVERY).min(last))
}

/// Colour samples of one camera at the centerline every `STEP` mm from the tube's start
/// (samples `0..=last`; the knots' `frames` given, and the tube's radius against the curve
/// parameter; `None` where it does not see the tube's side there).
fn sample(
    camera: &Camera,
    image: &RgbImage,
    mask: &BitMask,
    (frames, radius): (&[Frame], &dyn Fn(f64) -> f64),
    last: usize,
    spheres: &Spheres,
) -> Vec<Option<Sample>> {
    let eye = camera.centre();
    // The pixel and visibility of every knot.
    let knots: Vec<Option<Vector2<f64>>> = frames
        .iter()
        .map(|&(c, t, u)| {
            let r = radius(u);
            let to = c - eye;
            let d = to / to.norm();
            let sin = d.cross(&t).norm().max(1e-9);
            let pixel = camera.project(&c).ok()?.pixel.coords;
            // The near side, where the ray enters the tube.
            let front: Point3<f64> = c - d * (r / sin);
            (!spheres.blocks(&eye, &front, pixel)).then_some(pixel)
        })
        .collect();
    (0..=last)
        .map(|k| {
            let i = k / KNOT_EVERY;
            let a = knots[i]?;
            let ((c, t, u), pixel) = if k % KNOT_EVERY == 0 {
                (frames[i], a)
            } else {
                let b = knots[i + 1]?;
                let (from, to) = (i * KNOT_EVERY, ((i + 1) * KNOT_EVERY).min(last));
                let f = (k - from) as f64 / (to - from) as f64;
                let ((ca, ta, ua), (cb, tb, ub)) = (frames[i], frames[i + 1]);
                let t = ta + (tb - ta) * f;
                (
                    (ca + (cb - ca) * f, t / t.norm(), ua + (ub - ua) * f),
                    a + (b - a) * f,
                )
            };
            let r = radius(u);
            let to = c - eye;
            let d = to / to.norm();
            let sin = d.cross(&t).norm();
            if sin < MIN_SIN {
                return None;
            }
            Some(Sample {
                colour: bilinear(image, pixel)?,
                marked: mask.get(pixel.x.round() as usize, pixel.y.round() as usize),
                shift: r * d.dot(&t) / sin,
                sin,
            })
        })
        .collect()
}

/// The bands one camera's samples show.
fn runs(samples: &[Option<Sample>], tip_capped: bool) -> Vec<Seen> {
    let mean = |marked: bool| {
        let picked: Vec<[f32; 3]> = samples
            .iter()
            .flatten()
            .filter(|s| s.marked == marked)
            .map(|s| s.colour)
            .collect();
        (!picked.is_empty()).then(|| {
            let k = picked.len() as f32;
            [0, 1, 2].map(|c| picked.iter().map(|p| p[c]).sum::<f32>() / k)
        })
    };
    let (Some(tape), Some(body)) = (mean(true), mean(false)) else {
        return Vec::new();
    };
    let (tape, whole) = (
        Vector3::from(tape.map(f64::from)),
        Vector3::from(body.map(f64::from)),
    );
    if (tape - whole).norm() < 20.0 {
        return Vec::new();
    }
    // The body's colour: the mean of the unmarked samples; where they spread along the tube
    // by more than BODY_UNEVEN of the tape's contrast, the mean of those within
    // BODY_WINDOW_MM of each sample instead. A silvery tube's centerline shows its highlight
    // in one place and its dark body in another (spread 0.47–0.58; a plastic tube's
    // 0.02–0.05): against their mean, the dark body before a band read as half tape.
    let axis = tape - whole;
    let unmarked: Vec<f64> = samples
        .iter()
        .flatten()
        .filter(|s| !s.marked)
        .map(|s| (Vector3::from(s.colour.map(f64::from)) - whole).dot(&axis) / axis.norm_squared())
        .collect();
    let spread = (unmarked.iter().map(|q| q * q).sum::<f64>() / unmarked.len() as f64).sqrt();
    let body_near = if spread > BODY_UNEVEN {
        local_body(samples, whole)
    } else {
        vec![whole; samples.len()]
    };
    let q: Vec<Option<f64>> = samples
        .iter()
        .zip(&body_near)
        .map(|(s, b)| {
            s.map(|s| {
                let axis = tape - b;
                (Vector3::from(s.colour.map(f64::from)) - b).dot(&axis)
                    / axis.norm_squared().max(1.0)
            })
        })
        .collect();
    let last = q.len() - 1;
    let mut out = Vec::new();
    let mut k = 0;
    while k <= last {
        if !q[k].is_some_and(|v| v > 0.5) {
            k += 1;
            continue;
        }
        let start = k;
        while k < last && q[k + 1].is_some_and(|v| v > 0.5) {
            k += 1;
        }
        let end = k;
        k += 1;
        // At least a millimetre of tape.
        if (end - start) as f64 * STEP < 1.0 {
            continue;
        }
        let inside = median(&q[start..=end]);
        let lower = (start > 0)
            .then(|| edge(&q, samples, start, -1, inside))
            .flatten();
        let reaches_tip = end == last && tip_capped;
        let upper = if reaches_tip {
            // Never averaged: a band that reaches the tip ends at the tube's end (`merge`).
            Some(Edge {
                at: last as f64 * STEP,
                weight: 1.0,
            })
        } else if end < last {
            edge(&q, samples, end, 1, inside)
        } else {
            None
        };
        if let (Some(upper), true) = (upper, lower.is_some() || start > 0) {
            out.push(Seen {
                lower,
                upper,
                at_tip: reaches_tip,
            });
        }
    }
    out
}

/// Spread of the unmarked samples' tape share (RMS about the body's mean, the tape 1) beyond
/// which the body's colour is taken near each sample rather than over the whole tube.
const BODY_UNEVEN: f64 = 0.2;
/// Half the span of samples along the tube whose unmarked colours give the body's colour near
/// a sample, mm.
const BODY_WINDOW_MM: f64 = 10.0;
/// Fewest unmarked samples in that span for their mean to stand for the body there.
const BODY_SAMPLES: usize = 6;

/// The body's colour near each sample (see [`runs`]): the mean of the unmarked samples within
/// [`BODY_WINDOW_MM`], or `whole`, the mean of them all, where fewer than [`BODY_SAMPLES`] are.
fn local_body(samples: &[Option<Sample>], whole: Vector3<f64>) -> Vec<Vector3<f64>> {
    // Prefix sums of the unmarked samples' colours and count.
    let mut sums = vec![(Vector3::zeros(), 0usize)];
    for s in samples {
        let (mut sum, mut n) = sums[sums.len() - 1];
        if let Some(s) = s.filter(|s| !s.marked) {
            sum += Vector3::from(s.colour.map(f64::from));
            n += 1;
        }
        sums.push((sum, n));
    }
    let reach = (BODY_WINDOW_MM / STEP).round() as usize;
    (0..samples.len())
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(reach), (k + reach + 1).min(samples.len()));
            let (sum, n) = (sums[hi].0 - sums[lo].0, sums[hi].1 - sums[lo].1);
            if n >= BODY_SAMPLES {
                sum / n as f64
            } else {
                whole
            }
        })
        .collect()
}

/// Where `q` crosses halfway between `inside` and its level just outside the run's end at
/// `at` (the run's first sample going `dir = −1`, its last going `+1`), as the arc length of
/// the surface seen there (the camera's shift taken off), mm.
fn edge(
    q: &[Option<f64>],
    samples: &[Option<Sample>],
    at: usize,
    dir: isize,
    inside: f64,
) -> Option<Edge> {
    let step = |i: usize, by: isize| i.checked_add_signed(by).filter(|&j| j < q.len());
    // Up to 3 mm beyond the crossing, leaving out the first half millimetre of mixed pixels.
    let (near, far) = (
        (0.75 / STEP).round() as isize,
        (3.5 / STEP).round() as isize,
    );
    let outside: Vec<Option<f64>> = (near..far)
        .filter_map(|k| step(at, dir * k))
        .map(|j| q[j])
        .collect();
    if outside.iter().flatten().count() < 3 {
        return None;
    }
    let beyond = median(&outside);
    if inside - beyond < MIN_STEP {
        return None;
    }
    let level = (inside + beyond) / 2.0;
    let next = step(at, dir)?;
    let (a, b) = (q[at]?, q[next]?);
    let frac = ((a - level) / (a - b)).clamp(0.0, 1.0);
    let (s, n) = (samples[at]?, samples[next]?);
    let shift = s.shift * (1.0 - frac) + n.shift * frac;
    let sin = s.sin * (1.0 - frac) + n.sin * frac;
    Some(Edge {
        at: (at as f64 + dir as f64 * frac) * STEP - shift,
        // The inverse of the shift's variance (see the module's doc).
        weight: sin.powi(4),
    })
}

/// Bands seen by several cameras, merged where they overlap: ends averaged over the cameras
/// that saw them, by their weights. `(lower, upper, at_tip)`, arc lengths from the tube's
/// start, mm.
fn merge(mut seen: Vec<Seen>, length: f64) -> Vec<(f64, f64, bool)> {
    seen.sort_by(|a, b| {
        let key = |s: &Seen| s.lower.unwrap_or(s.upper).at;
        key(a).total_cmp(&key(b))
    });
    let mut groups: Vec<Vec<Seen>> = Vec::new();
    for s in seen {
        let low = s.lower.unwrap_or(s.upper).at;
        match groups.last_mut() {
            Some(g) if g.iter().any(|o| low <= o.upper.at) => g.push(s),
            _ => groups.push(vec![s]),
        }
    }
    groups
        .into_iter()
        .filter_map(|g| {
            let lowers: Vec<Edge> = g.iter().filter_map(|s| s.lower).collect();
            let lower = mean(&lowers)?;
            let tips = g.iter().filter(|s| s.at_tip).count();
            let at_tip = 2 * tips > g.len();
            let upper = if at_tip {
                length
            } else {
                mean(
                    &g.iter()
                        .filter(|s| !s.at_tip)
                        .map(|s| s.upper)
                        .collect::<Vec<_>>(),
                )?
            };
            Some((lower, upper, at_tip))
        })
        .collect()
}

fn mean(v: &[Edge]) -> Option<f64> {
    let total: f64 = v.iter().map(|e| e.weight).sum();
    (total > 0.0).then(|| v.iter().map(|e| e.at * e.weight).sum::<f64>() / total)
}

fn median(v: &[Option<f64>]) -> f64 {
    crate::median(v.iter().flatten().copied())
}

/// RGB at a sub-pixel position, bilinear.
fn bilinear(image: &RgbImage, p: Vector2<f64>) -> Option<[f32; 3]> {
    // Truncation is the floor once negative positions are refused (and no library call).
    if !(p.x >= 0.0 && p.y >= 0.0) {
        return None;
    }
    let (x, y) = (p.x as u32, p.y as u32);
    if x + 1 >= image.width() || y + 1 >= image.height() {
        return None;
    }
    let (fx, fy) = ((p.x - x as f64) as f32, (p.y - y as f64) as f32);
    let mut out = [0f32; 3];
    for (dx, dy, w) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let px = image.get_pixel(x + dx, y + dy);
        for c in 0..3 {
            out[c] += w * px[c] as f32;
        }
    }
    Some(out)
}

/// Arc length along the tube against its parameter.
struct ArcTable {
    u: Vec<f64>,
    arc: Vec<f64>,
}

impl ArcTable {
    fn new(tube: &Tube) -> Self {
        let n = 40 * (tube.centerline.control().len() - 3);
        let u: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
        let mut arc = vec![0.0];
        let mut prev = tube.frame(0.0).0;
        for &ui in &u[1..] {
            let p = tube.frame(ui).0;
            arc.push(arc[arc.len() - 1] + (p - prev).norm());
            prev = p;
        }
        ArcTable { u, arc }
    }

    fn length(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }

    /// The parameter at arc length `s` (clamped), linear between entries.
    fn u_of(&self, s: f64) -> f64 {
        let i = self
            .arc
            .partition_point(|&a| a < s)
            .clamp(1, self.arc.len() - 1);
        let (a0, a1) = (self.arc[i - 1], self.arc[i]);
        let t = ((s - a0) / (a1 - a0).max(1e-12)).clamp(0.0, 1.0);
        self.u[i - 1] + t * (self.u[i] - self.u[i - 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One camera's side-on samples every `STEP` along a tube, from the tape's share `q` of
    /// each (blue body, red tape; the marker mask marks where `q` ≥ 0.9).
    fn samples(q: &[f64]) -> Vec<Option<Sample>> {
        let (body, tape) = ([30.0, 40.0, 120.0], [160.0, 30.0, 30.0]);
        q.iter()
            .map(|&q| {
                Some(Sample {
                    colour: std::array::from_fn(|c| (body[c] + q * (tape[c] - body[c])) as f32),
                    marked: q >= 0.9,
                    shift: 0.0,
                    sin: 1.0,
                })
            })
            .collect()
    }

    #[test]
    fn a_band_at_the_tip_ends_where_the_tape_share_crosses_halfway() {
        // Body to sample 60, tape from 61 to the tip, sample 60 three-quarters tape.
        let mut q = vec![0.0; 60];
        q.push(0.75);
        q.extend([1.0; 20]);
        let seen = runs(&samples(&q), true);
        assert_eq!(seen.len(), 1);
        let lower = seen[0].lower.expect("the band's lower end");
        // Halfway between 0 and 1 is two thirds of the way from sample 59 to 60.
        let expected = (59.0 + 2.0 / 3.0) * STEP;
        assert!(
            (lower.at - expected).abs() < 1e-9,
            "{} against {expected}",
            lower.at
        );
        assert!(seen[0].at_tip);
    }

    #[test]
    fn a_silvery_tubes_tip_band_is_read_against_the_body_beside_it() {
        // The centerline shows the highlight for 100 mm, then the dark body for 30 mm, then
        // a red tip band: against the whole body's mean the dark body reads as half tape.
        let (highlight, dark, tape) = (
            [200.0, 200.0, 200.0],
            [62.0, 62.0, 62.0],
            [150.0, 18.0, 14.0],
        );
        let sample = |colour: [f32; 3], marked| {
            Some(Sample {
                colour,
                marked,
                shift: 0.0,
                sin: 1.0,
            })
        };
        let mut s = vec![sample(highlight, false); 200];
        s.extend(vec![sample(dark, false); 60]);
        s.extend(vec![sample(tape, true); 8]);
        let seen = runs(&s, true);
        assert_eq!(seen.len(), 1);
        let lower = seen[0].lower.expect("the band's lower end").at;
        // Halfway between sample 259 (body) and 260 (tape).
        assert!((lower - 259.5 * STEP).abs() < 0.01, "{lower}");
        assert!(seen[0].at_tip);
    }

    #[test]
    fn a_band_end_without_a_clear_step_in_the_tape_share_is_not_placed() {
        // What a camera seeing the tip obliquely read before a tip band: the tape's share
        // hovering about a half for 4 mm (cap and side mixed in its pixels), then the tape.
        // The halfway crossing of that plateau put the band's end 5.6 mm off.
        let plateau = [
            0.46, 0.49, 0.48, 0.48, 0.50, 0.50, 0.48, 0.49, 0.51, 0.52, 0.52, 0.53, 0.54, 0.54,
            0.55, 0.54, 0.56, 0.58, 0.61, 0.79,
        ];
        // The body's colour, from the unmarked samples, is the whole tube's below the band.
        let mut q = vec![0.0; 400];
        q.extend(plateau);
        q.extend([1.0; 3]);
        let seen = runs(&samples(&q), true);
        assert_eq!(seen.len(), 1);
        assert!(
            seen[0].lower.is_none(),
            "placed at {:?}",
            seen[0].lower.map(|e| e.at)
        );
        // It still says the band reaches the tip.
        assert!(seen[0].at_tip);
    }
}
