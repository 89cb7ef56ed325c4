//! The self-check: does the fitted tube explain each camera's image? Per camera, the outline
//! residuals (RMS and their mean, which a calibration error shows as a systematic offset), the
//! share of outline samples where a boundary was found, and the fitted tube re-rendered into
//! a mask and compared with the measured silhouette (IoU, and silhouette pixels it leaves
//! unexplained — a missed distal part, a ghost of the hull).

use flexshape_camera::Camera;
use flexshape_silhouette::BitMask;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::median;
use crate::outline::Spheres;
use crate::solve::Measured;
use crate::tube::Tube;
use crate::width::WidthProfile;

/// How well the fitted tube explains one camera's image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct CameraCheck {
    /// The camera's name in the rig.
    pub camera: String,
    /// Outline samples predicted in the image.
    pub samples: usize,
    /// Samples where a boundary was found.
    pub found: usize,
    /// Samples where none could be: the backdrop behind them has the tube's own colour (a
    /// printed dot behind a dark tube), so the image shows neither a boundary nor its absence.
    /// The found share is taken over the other samples.
    #[serde(default)]
    pub unseen: usize,
    /// RMS of the outline residuals (predicted − measured, along the outline normal), pixels.
    pub residual_px: f64,
    /// Their mean, pixels (positive: the fitted outline lies outside the measured one). A mean
    /// far from zero in one camera points at its calibration.
    pub offset_px: f64,
    /// The image translation that best moves the fitted outline onto the measured one, pixels
    /// (x right, y down; least squares over the samples' normals, a direction they do not
    /// decide left at 0). Shifts of half a pixel or more mean the cameras disagree about where
    /// the tube is: the rig's calibration is off (`flexshape rig refine`). They do not tell
    /// which camera is off (the fitted tube settles between them), and the mean residual does
    /// not show them at all (a shift pushes one side of the outline out and the other in).
    #[serde(default)]
    pub shift_px: [f64; 2],
    /// 90th percentile of the residuals' size, pixels: a fit that explains the image keeps
    /// nearly all of its outline within a few tenths of a pixel, whatever a few outliers do to
    /// the RMS.
    pub p90_px: f64,
    /// The scatter one boundary's place has from the image alone, pixels: the RMS over the
    /// outline of each boundary's own — a floor every boundary has, and the image's noise
    /// over the grey levels its coverage is read from (the tube's contrast against the
    /// backdrop behind that boundary) — read from the outline itself, from the differences
    /// between neighbouring samples' residuals along each side, where what a wrong shape or
    /// calibration puts off the outline, smooth along it, cancels (0 with fewer than 10
    /// pairs). The residual RMS limits widen by it in quadrature.
    #[serde(default)]
    pub noise_px: f64,
    /// The least and the most of the boundaries' own scatter over the outline, pixels (equal
    /// where the tube's contrast is the same all along).
    #[serde(default)]
    pub noise_range_px: [f64; 2],
    /// The share of the outline (by the length each sample stands for, among the samples
    /// where a boundary was found) whose residual's size lies beyond its own limit,
    /// `max_p90_px` widened in quadrature by 1.645 times that boundary's scatter: a fit that
    /// explains the image keeps at least nine tenths of its outline within it (with one
    /// scatter for the whole outline, the same as a 90th percentile within one limit).
    #[serde(default)]
    pub outlying_share: f64,
    /// Overlap of the re-rendered tube with the silhouette (intersection over union).
    pub iou: f64,
    /// The least overlap this view allows: the setting's `min_iou`, or for a tube imaged
    /// thinner than 7 px the IoU of two strips of its mean width one pixel apart,
    /// `(w − 1)/(w + 1)`, when that is less (a pixel's disagreement at its edges costs more).
    #[serde(default)]
    pub iou_limit: f64,
    /// Asked only when `iou` is below `iou_limit`: the IoU with the silhouette completed by
    /// the tube's pixels where the outline found the image's boundary on both sides of the
    /// tube (each within `max_residual_px`). Where the tube's colour is close to the
    /// backdrop's, the silhouette's classifier leaves out what the boundary search, reading
    /// the colour along whole lines, still finds; there the image shows the tube although
    /// the silhouette does not, and the check holds this IoU against the limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iou_outlined: Option<f64>,
    /// Silhouette pixels farther than the check's distance from the re-rendered tube.
    pub unexplained_px: usize,
    /// Shadow-coloured silhouette pixels that far from it, left out of `iou` and
    /// `unexplained_px`: a shadow on the backdrop sharp enough to be taken for an object (the
    /// tube's own pixels, grey or not, lie near it and always count).
    #[serde(default)]
    pub shadow_px: usize,
    /// Outline samples around the tube's free ends (their caps and the last two radii of
    /// the sides), where a tip that stopped short or ran on shows; few among the whole
    /// outline, so they are checked apart.
    #[serde(default)]
    pub end_samples: usize,
    /// Of those, samples where a boundary was found.
    #[serde(default)]
    pub end_found: usize,
    /// Of those, samples against a backdrop of the tube's colour (as `unseen`).
    #[serde(default)]
    pub end_unseen: usize,
    /// RMS of their residuals, pixels, over all but the tenth farthest off (the whole
    /// outline, too, may keep a tenth beyond its limits).
    #[serde(default)]
    pub end_residual_px: f64,
    /// The RMS of their boundaries' own scatter, pixels (as `noise_px`), by which their
    /// residual limit widens.
    #[serde(default)]
    pub end_noise_px: f64,
    /// Samples of each capped end's rounded outline (proximal end, tip) where a boundary was
    /// found: where this camera sees the cap. An end the tube hides in this view (the tip
    /// folded over the shaft, or seen end-on) has none or few.
    #[serde(default)]
    pub cap_found: [usize; 2],
    /// Samples of each capped end's rounded outline this camera measures at all (proximal
    /// end, tip): none where the camera's occlusion mask hides the whole cap. Not written.
    #[serde(skip)]
    #[schemars(skip)]
    pub cap_samples: [usize; 2],
    /// Per capped end (proximal end, tip): whether the image shows the tube going on straight
    /// beyond it, where the fit capped it — its silhouette lost there, the tube too close to
    /// the backdrop's colour ([`crate::TubeFitter`]'s `goes_on`). False for an open end.
    #[serde(default)]
    pub goes_on: [bool; 2],
    /// 90th percentile of the boundaries' ¼–¾ rise, pixels (over those found): up to about 1
    /// for a still tube in focus ([`STILL_RAMP_PX`]), wider where it moved while the shutter
    /// was open (its fastest part, often the tip, first) or is out of focus.
    #[serde(default)]
    pub ramp_px: f64,
    /// The outline residuals' statistics with each boundary's size less what its blur adds
    /// to its rise: the least the residuals may be (the same as `residual_px`, `p90_px` and
    /// `end_residual_px` where every edge is still and in focus). A camera that fails the
    /// checks as measured but passes them so is excused while two others pass them
    /// `with_blur`.
    #[serde(default)]
    pub beyond_blur: OutlineResiduals,
    /// The same with each boundary's size plus what its blur adds: the most they may be. A
    /// camera that passes the checks so places the tube whatever its blur hides.
    #[serde(default)]
    pub with_blur: OutlineResiduals,
    /// Share of the outline, among its samples where a boundary was found, along which the
    /// tube is lighter than the background. A lit tube darkens toward its outline, so against
    /// a darker backdrop its edges fade into it and its outline is faint.
    #[serde(default)]
    pub lighter_share: f64,
    /// With free widths ([`crate::OutlineWidth::Free`]: masks), how much wider each side of
    /// the silhouette lies than the fitted tube's image, the median along it, pixels (negative:
    /// narrower; 0 when widths follow the tube). A line drawn a fixed width shows the
    /// difference between that width and the tube's image; a segmentation, how much it grows
    /// the tube.
    #[serde(default)]
    pub width_offset_px: f64,
}

/// Statistics of a camera's outline residuals with each boundary's blur allowed for: the
/// residual's size less, or plus, what blur adds to its ¼–¾ rise beyond [`STILL_RAMP_PX`]
/// (at least 0), pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct OutlineResiduals {
    /// Their RMS.
    pub residual_px: f64,
    /// Their 90th percentile.
    pub p90_px: f64,
    /// Their RMS around the tube's free ends.
    pub end_residual_px: f64,
    /// The share of the outline whose size lies beyond its own limit
    /// ([`CameraCheck::outlying_share`]).
    #[serde(default)]
    pub outlying_share: f64,
}

/// Per end (proximal end, tip), the samples of its cap outline in `measured` where a
/// boundary was found, and all of them.
pub(crate) fn cap_samples(measured: &[Measured]) -> [(usize, usize); 2] {
    let mut out = [(0, 0); 2];
    for m in measured {
        if let crate::outline::Part::Cap(end) = m.point.part {
            let e = &mut out[end.min(1)];
            e.0 += usize::from(m.residual.is_some());
            e.1 += 1;
        }
    }
    out
}

/// Residual statistics of one camera's measured outline: samples, found, RMS and mean, each
/// sample weighted by the outline length it stands for (a tube seen end-on crowds many
/// samples into a few pixels).
///
/// Each sample's size is held to `max_p90` widened by its boundary's `scatter`
/// ([`CameraCheck::outlying_share`]). The RMS are over the `kept` share of the outline
/// best explained (1: all of it).
pub(crate) fn residual_stats(
    measured: &[Measured],
    scatter: &Scatter,
    max_p90: f64,
    kept: f64,
) -> Residuals {
    let limit = |m: &Measured| noisy_limit(max_p90, scatter.at(m.contrast), Z90);
    let found = || measured.iter().filter(|m| m.residual.is_some());
    let w = found().map(|m| m.point.weight).sum::<f64>().max(1e-12);
    let residual = |m: &Measured| m.residual.unwrap_or(0.0);
    let mut sizes: Vec<(f64, f64)> = Vec::with_capacity(measured.len());
    let mut spread = |size: &dyn Fn(&Measured) -> f64| {
        let outlying = found()
            .filter(|m| size(m) > limit(m))
            .fold(0.0, |acc, m| acc + m.point.weight)
            / w;
        sizes.clear();
        sizes.extend(found().map(|m| (size(m), m.point.weight)));
        let p90 = weighted_quantile(&mut sizes, 0.9, w);
        // Over the smallest `kept` of the weight (sorted by now).
        let (mut sum, mut acc) = (0.0, 0.0);
        for &(r, k) in sizes.iter() {
            if acc >= kept * w {
                break;
            }
            sum += k * r * r;
            acc += k;
        }
        ((sum / acc.max(1e-12)).sqrt(), p90, outlying)
    };
    let (rms, p90, outlying) = spread(&|m| m.size());
    let (rms_beyond, p90_beyond, outlying_beyond) =
        spread(&|m| (m.size() - blur_allowance(m.ramp)).max(0.0));
    let (rms_with, p90_with, outlying_with) = spread(&|m| m.size() + blur_allowance(m.ramp));
    // Over the boundaries whose rise was measured (one that never reaches ¾ has none).
    sizes.clear();
    sizes.extend(found().filter_map(|m| Some((m.ramp?, m.point.weight))));
    let measured_w = sizes.iter().map(|s| s.1).sum::<f64>();
    let ramp = weighted_quantile(&mut sizes, 0.9, measured_w);
    let mean = found().map(|m| m.point.weight * residual(m)).sum::<f64>() / w;
    // A fold from +0 (a float sum of nothing is −0).
    let lighter = found()
        .filter(|m| m.lighter)
        .fold(0.0, |acc, m| acc + m.point.weight)
        / w;
    Residuals {
        samples: measured.len(),
        found: found().count(),
        unseen: measured.iter().filter(|m| m.unseen).count(),
        rms,
        mean,
        p90,
        outlying,
        noise: scatter.over(measured),
        shift: shift(measured),
        lighter,
        ramp,
        beyond_blur: OutlineResiduals {
            residual_px: rms_beyond,
            p90_px: p90_beyond,
            end_residual_px: 0.0,
            outlying_share: outlying_beyond,
        },
        with_blur: OutlineResiduals {
            residual_px: rms_with,
            p90_px: p90_with,
            end_residual_px: 0.0,
            outlying_share: outlying_with,
        },
    }
}

/// Fewest pairs of neighbouring side samples that give a [`Scatter`].
const NOISE_PAIRS: usize = 10;

/// How far one boundary's place scatters from the image alone, pixels: a floor every
/// boundary has (its sub-pixel phase, the shading the reading leaves) and the image's noise
/// over the grey levels its coverage is read from ([`Measured::contrast`]), through the
/// edge's slope. Over a backdrop of several colours (a chessboard under the tube) a boundary
/// over a square of nearly the tube's colour scatters several times as far as one over a
/// square far from it, and one figure for the outline holds the first to the second's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Scatter {
    /// The floor, pixels.
    pub floor: f64,
    /// The noise's part at a contrast of one grey level, pixels × grey levels.
    pub grey: f64,
}

impl Scatter {
    /// Read from the outline itself: the differences between neighbouring samples' residuals
    /// along each side. Samples are a few pixels apart, so each is a reading of other pixels,
    /// while what a wrong shape or calibration puts off the outline changes smoothly along it
    /// and cancels in the difference. A difference scatters by `σᵢ² + σⱼ²`, `2·floor² +
    /// grey²·h` with `h = 1/Cᵢ² + 1/Cⱼ²`: the pairs are split at the median `h`, and each
    /// half's median difference (over 0.6745, a normal scatter's), against its median `h`,
    /// gives the two — medians, which a few boundaries pulled off (a shadow's edge, a
    /// crossing) hardly move. Where the contrast hardly varies (the halves' `h` within half
    /// again of each other) or the noise does not grow as it falls, the scatter is one figure
    /// for every boundary, the median difference over 0.6745·√2. Nothing (0) with fewer than
    /// [`NOISE_PAIRS`] pairs.
    pub(crate) fn of(measured: &[Measured]) -> Scatter {
        let mut pairs: Vec<(f64, f64)> = Vec::new();
        let faint = |c: f64| 1.0 / c.max(1.0).powi(2);
        for side in [-1.0, 1.0] {
            let mut along: Vec<(f64, f64, f64)> = measured
                .iter()
                .filter(|m| matches!(m.point.part, crate::outline::Part::Side(_)))
                .filter(|m| m.point.which == side)
                .filter_map(|m| Some((m.point.u, m.residual?, m.contrast)))
                .collect();
            along.sort_by(|a, b| a.0.total_cmp(&b.0));
            pairs.extend(
                along
                    .windows(2)
                    .map(|w| ((w[1].1 - w[0].1).abs(), faint(w[0].2) + faint(w[1].2))),
            );
        }
        if pairs.len() < NOISE_PAIRS {
            return Scatter::default();
        }
        let variance = |d: f64| (d / 0.6745).powi(2);
        let one_figure = |pairs: &[(f64, f64)]| Scatter {
            floor: (variance(median(pairs.iter().map(|p| p.0))) / 2.0).sqrt(),
            grey: 0.0,
        };
        pairs.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (low, high) = pairs.split_at(pairs.len() / 2);
        let half = |ps: &[(f64, f64)]| {
            (
                variance(median(ps.iter().map(|p| p.0))),
                median(ps.iter().map(|p| p.1)),
            )
        };
        let ((v_low, h_low), (v_high, h_high)) = (half(low), half(high));
        if h_high <= 1.5 * h_low || v_high <= v_low {
            return one_figure(&pairs);
        }
        let grey2 = (v_high - v_low) / (h_high - h_low);
        let floor2 = (v_low - grey2 * h_low) / 2.0;
        if floor2 < 0.0 {
            // The noise alone: every difference over its own root of `h`.
            let grey = median(pairs.iter().map(|p| p.0 / p.1.sqrt())) / 0.6745;
            return Scatter { floor: 0.0, grey };
        }
        Scatter {
            floor: floor2.sqrt(),
            grey: grey2.sqrt(),
        }
    }

    /// The scatter of a boundary read from `contrast` grey levels, pixels.
    pub(crate) fn at(&self, contrast: f64) -> f64 {
        self.floor.hypot(self.grey / contrast.max(1.0))
    }

    /// The RMS of the scatter over `measured`'s found samples, each weighted by the outline
    /// it stands for, and its least and most there, pixels (0 for none).
    pub(crate) fn over(&self, measured: &[Measured]) -> (f64, [f64; 2]) {
        let (mut sum, mut w, mut range) = (0.0, 0.0, [f64::INFINITY, 0.0f64]);
        for m in measured.iter().filter(|m| m.residual.is_some()) {
            let s = self.at(m.contrast);
            sum += m.point.weight * s * s;
            w += m.point.weight;
            range = [range[0].min(s), range[1].max(s)];
        }
        if w <= 0.0 {
            return (0.0, [0.0; 2]);
        }
        ((sum / w).sqrt(), range)
    }
}

/// The 90th percentile of a normal scatter's sizes, in standard deviations.
pub(crate) const Z90: f64 = 1.645;

/// A residual limit (`limit`, what the setting allows a right shape on a quiet image) widened
/// by what noise of `noise` pixels adds to the statistic in quadrature, `z` of it (1 for an
/// RMS, 1.645 for a 90th percentile of sizes: a normal scatter's).
pub(crate) fn noisy_limit(limit: f64, noise: f64, z: f64) -> f64 {
    limit.hypot(z * noise)
}

/// How far off a sharp tube's outline a boundary whose ¼–¾ rise is `ramp` pixels may lie,
/// pixels: what blur adds to the rise beyond [`STILL_RAMP_PX`]. A blurred edge's ½ crossing
/// is a sharp outline's only where the blur is symmetric about it: where the outline curves
/// (a cap), or the motion while the shutter was open was not uniform, it moves within the
/// rise.
pub(crate) fn blur_allowance(ramp: Option<f64>) -> f64 {
    ramp.map_or(0.0, |r| (r - STILL_RAMP_PX).max(0.0))
}

/// How much wider than a still, focused edge's a boundary's ¼–¾ rise is (at least 1; a rise
/// not measured counts as still): the fit weights the boundary by its inverse square, as a
/// blurred boundary places the outline that much less well.
pub(crate) fn blur_scale(ramp: Option<f64>) -> f64 {
    ramp.map_or(1.0, |r| (r / STILL_RAMP_PX).max(1.0))
}

/// The widest ¼–¾ rise of a boundary taken for still and in focus, pixels: half again a step
/// edge's (0.67 px: a step integrated over a pixel and read bilinearly), for a round tube's
/// shading toward its limb and the noise (the simulator's still edges rise over 0.74–0.82 px
/// in the median, up to 1.03 at the 90th percentile).
pub const STILL_RAMP_PX: f64 = 1.5 * crate::edges::SHARP_RAMP_PX;

/// The `q` quantile of `values` by size (all at least 0), each weighted (`total` their
/// weights' sum); sorts them. 0 for none.
fn weighted_quantile(values: &mut [(f64, f64)], q: f64, total: f64) -> f64 {
    values.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut acc = 0.0;
    values
        .iter()
        .find(|(_, k)| {
            acc += k;
            acc >= q * total
        })
        .map_or(0.0, |(r, _)| *r)
}

/// The image translation `d` minimising `Σ w (n·d + r)²` over the found samples (outline
/// normal `n`, residual `r`: the measured boundary lies `r` inside the prediction), pixels;
/// a small ridge leaves a direction the normals do not span at 0.
fn shift(measured: &[Measured]) -> [f64; 2] {
    let mut a = nalgebra::Matrix2::<f64>::zeros();
    let mut b = nalgebra::Vector2::<f64>::zeros();
    for m in measured {
        let Some(r) = m.residual else { continue };
        let n = m.point.normal;
        a += n * n.transpose() * m.point.weight;
        b -= n * (r * m.point.weight);
    }
    let ridge = 1e-3 * a.trace().max(1e-12);
    a[(0, 0)] += ridge;
    a[(1, 1)] += ridge;
    a.try_inverse().map_or([0.0; 2], |inv| (inv * b).into())
}

/// The share of the outline around the free ends whose residuals' RMS is checked: all but the
/// tenth farthest off, as the whole outline may keep a tenth beyond its limits
/// ([`CameraCheck::outlying_share`]). An end has a dozen samples or so, and where the tube is
/// faint against the backdrop (a dark tip over a black square) one of them may be read
/// several pixels off, which alone lifts their RMS past its limit; an end that is not where
/// the image has it is off at most of them.
const END_KEPT: f64 = 0.9;

/// Residual statistics of the outline samples around `tube`'s capped ends: the caps and the
/// sides within two radii of them (`length` the centerline's, mm); the RMS over
/// [`END_KEPT`] of them.
pub(crate) fn end_stats(
    measured: &[Measured],
    tube: &Tube,
    length: f64,
    scatter: &Scatter,
    max_p90: f64,
) -> Residuals {
    let reach = 2.0 * tube.radius / length.max(1e-9);
    let near_end: Vec<Measured> = measured
        .iter()
        .filter(|m| match m.point.part {
            crate::outline::Part::Cap(_) => true,
            crate::outline::Part::Side(_) => {
                (tube.capped[0] && m.point.u < reach) || (tube.capped[1] && m.point.u > 1.0 - reach)
            }
        })
        // Held to what they read, as the caps are: a short tip's last stretch of side reads
        // outward of its prediction as an unresolved rim does.
        .map(|m| Measured { rim: 0.0, ..*m })
        .collect();
    residual_stats(&near_end, scatter, max_p90, END_KEPT)
}

/// Residual statistics of one camera's outline.
pub(crate) struct Residuals {
    pub samples: usize,
    pub found: usize,
    /// [`CameraCheck::unseen`].
    pub unseen: usize,
    pub rms: f64,
    pub mean: f64,
    pub p90: f64,
    /// [`CameraCheck::outlying_share`].
    pub outlying: f64,
    /// [`CameraCheck::noise_px`] and [`CameraCheck::noise_range_px`].
    pub noise: (f64, [f64; 2]),
    /// [`CameraCheck::shift_px`].
    pub shift: [f64; 2],
    /// [`CameraCheck::lighter_share`].
    pub lighter: f64,
    /// [`CameraCheck::ramp_px`].
    pub ramp: f64,
    /// [`CameraCheck::beyond_blur`] (its end residual left at 0).
    pub beyond_blur: OutlineResiduals,
    /// [`CameraCheck::with_blur`] (its end residual left at 0).
    pub with_blur: OutlineResiduals,
}

/// The tube drawn into masks of `camera`'s image size from its `spheres` (every half radius
/// along the centerline, [`crate::outline::sphere_centres`]): a disc per sphere of the swept
/// surface, and separately the straight continuation of each open end until it leaves the
/// image (the tube goes on beyond the volume, how far is not known: the check neither asks
/// for nor objects to silhouette pixels there). Each disc is as much narrower as `widths` says
/// the silhouette is there (free widths; an empty profile changes nothing).
pub(crate) fn render(
    camera: &Camera,
    spheres: &Spheres,
    widths: &WidthProfile,
) -> (BitMask, BitMask) {
    let (w, h) = (
        camera.intrinsics.width as usize,
        camera.intrinsics.height as usize,
    );
    let draw = |items: &[crate::outline::Projected], us: &[f64]| {
        let mut mask = BitMask::new(w, h);
        for (&(c, px, r), &u) in items.iter().zip(us) {
            disc(&mut mask, (c, px, (r - widths.at(u)).max(0.5)));
        }
        mask
    };
    let (tube_us, beyond_us) = spheres.parameters();
    (
        draw(spheres.tube(), tube_us),
        draw(spheres.beyond(), beyond_us),
    )
}

/// Draws the image of a sphere (centre, pixel, image radius; as a disc), clipped to the mask.
pub(crate) fn disc(mask: &mut BitMask, (_, c, radius): (Point3<f64>, nalgebra::Vector2<f64>, f64)) {
    let (w, h) = (mask.width() as f64, mask.height() as f64);
    let (cx, cy) = (c.x, c.y);
    if cx + radius < 0.0 || cy + radius < 0.0 || cx - radius > w - 1.0 || cy - radius > h - 1.0 {
        return;
    }
    let y0 = (cy - radius).ceil().max(0.0) as usize;
    let y1 = (cy + radius).floor().min(h - 1.0) as usize;
    for y in y0..=y1 {
        let dy = y as f64 - cy;
        let half = (radius * radius - dy * dy).max(0.0).sqrt();
        let x0 = (cx - half).ceil().max(0.0) as usize;
        let x1 = (cx + half).floor().min(w - 1.0);
        if x1 < 0.0 {
            continue;
        }
        mask.set_span(y, x0, x1 as usize);
    }
}

/// The least IoU of a silhouette with the rendered tube that a right shape can give in a view
/// where the tube's image is `spheres` wide: `min_iou`, or for a thin image the IoU of two
/// strips of its mean width one pixel apart, `(w − 1)/(w + 1)`, when that is less. A
/// silhouette's edge may lie a pixel off the tube's image however right the shape (the
/// classifier leaves out a shaded edge's last pixel or takes in a blurred one of backdrop, and
/// the rendering rounds each disc to whole pixels), and across a tube 2.7 px wide that pixel
/// alone takes the IoU to 0.46; the default 0.75 is that pixel across a tube 7 px wide.
pub(crate) fn iou_limit(min_iou: f64, spheres: &Spheres) -> f64 {
    let radii = spheres.tube();
    if radii.is_empty() {
        return min_iou;
    }
    let width = 2.0 * radii.iter().map(|s| s.2).sum::<f64>() / radii.len() as f64;
    min_iou.min((width - 1.0) / (width + 1.0)).max(0.0)
}

/// The discs of the tube's spheres in `spheres` (its image in one camera, each `widths`
/// narrower as [`render`] draws them) on both sides of which `measured` found the image's
/// boundary within `max_px` of the predicted outline: a side sample within 3 px of the
/// sphere's image found, and another whose normal points the other way (the samples lie
/// `spacing_mm` apart along the tube, a few pixels).
pub(crate) fn outlined(
    (w, h): (usize, usize),
    spheres: &Spheres,
    widths: &WidthProfile,
    measured: &[Measured],
    max_px: f64,
) -> BitMask {
    let found: Vec<_> = measured
        .iter()
        .filter(|m| matches!(m.point.part, crate::outline::Part::Side(_)))
        .filter(|m| m.residual.is_some() && m.size() <= max_px)
        .map(|m| (m.point.pixel, m.point.normal))
        .collect();
    let mut mask = BitMask::new(w, h);
    let (us, _) = spheres.parameters();
    for (&(c, px, r), &u) in spheres.tube().iter().zip(us) {
        // Both sides: a nearby sample whose normal opposes the first nearby one's.
        let mut near = found
            .iter()
            .filter(|(p, _)| (p - px).norm() <= r + 3.0)
            .map(|&(_, n)| n);
        let both = near
            .next()
            .is_some_and(|n0| near.any(|n| n0.dot(&n) < -0.5));
        if both {
            disc(&mut mask, (c, px, (r - widths.at(u)).max(0.5)));
        }
    }
    mask
}

/// How a view's silhouette overlaps the rendered tube.
pub(crate) struct Overlap {
    /// [`CameraCheck::iou`].
    pub iou: f64,
    /// [`CameraCheck::iou_outlined`].
    pub iou_outlined: Option<f64>,
    /// [`CameraCheck::unexplained_px`].
    pub unexplained_px: usize,
    /// [`CameraCheck::shadow_px`].
    pub shadow_px: usize,
}

/// IoU of the rendered tube with `view`'s silhouette (leaving out the pixels only the open
/// ends' continuations cover, and, of both, those `view` says are hidden), and the silhouette
/// pixels farther than `explain_px` from both; shadow-coloured silhouette pixels that far are
/// counted apart, in neither — unless `continuations` takes them for the tube's continuing
/// beyond a capped end: a grey distal part the fit missed looks so. Below `limit`, the IoU again with the silhouette completed
/// by the tube's pixels that `outlined` gives (see [`CameraCheck::iou_outlined`]).
pub(crate) fn overlap(
    (tube, beyond): &(BitMask, BitMask),
    view: &crate::View<'_>,
    explain_px: usize,
    continuations: impl FnOnce(&BitMask) -> BitMask,
    (limit, outlined): (f64, impl FnOnce() -> BitMask),
) -> Overlap {
    // Where the camera cannot see into the volume, the tube is neither shown nor missed.
    let seen;
    let (tube, beyond, view_silhouette) = match view.hidden {
        Some(hidden) => {
            seen = (
                tube.and_not(hidden),
                beyond.and_not(hidden),
                view.silhouette.and_not(hidden),
            );
            (&seen.0, &seen.1, &seen.2)
        }
        None => (tube, beyond, view.silhouette),
    };
    let near = tube.or(beyond).dilate(explain_px);
    let shadow = view
        .shadow_like
        .map(|s| s.and_not(&near))
        .filter(|away| away.count() > 0)
        .map(|away| {
            let missed = continuations(&away);
            away.and_not(&missed)
        });
    let kept;
    let silhouette = match &shadow {
        Some(shadow) if shadow.count() > 0 => {
            kept = view_silhouette.and_not(shadow);
            &kept
        }
        _ => view_silhouette,
    };
    let iou = tube_iou(tube, beyond, silhouette);
    let iou_outlined = (iou < limit).then(|| {
        let completed = silhouette.or(&tube.and(&outlined()));
        tube_iou(tube, beyond, &completed)
    });
    Overlap {
        iou,
        iou_outlined,
        unexplained_px: silhouette.and_not(&near).count(),
        shadow_px: shadow.map_or(0, |s| s.count()),
    }
}

/// IoU of `tube` with `silhouette` where the continuations (`beyond`) alone do not reach (all
/// of the tube is such a place), word by word.
fn tube_iou(tube: &BitMask, beyond: &BitMask, silhouette: &BitMask) -> f64 {
    let (mut inter, mut union) = (0u64, 0u64);
    for ((&t, &b), &s) in tube
        .words()
        .iter()
        .zip(beyond.words())
        .zip(silhouette.words())
    {
        let seen = s & !(b & !t);
        inter += u64::from((t & seen).count_ones());
        union += u64::from((t | seen).count_ones());
    }
    if union == 0 {
        1.0
    } else {
        inter as f64 / union as f64
    }
}

/// A camera's frame with what the self-check saw drawn on it: the fitted tube's outline points
/// (green where the measured boundary lies within half a pixel, orange where it is farther,
/// red where none was found), the re-rendered tube where the silhouette is not (magenta) and
/// silhouette pixels the tube leaves unexplained (cyan; the open ends' straight continuations,
/// whose extent is unknown, excepted).
pub fn debug_image(
    frame: &image::RgbImage,
    outline: &[crate::OutlineResidual],
    (tube, beyond): &(BitMask, BitMask),
    silhouette: &BitMask,
) -> image::RgbImage {
    let mut out = frame.clone();
    for (x, y, p) in out.enumerate_pixels_mut() {
        let (x, y) = (x as usize, y as usize);
        let (t, s) = (tube.get(x, y), silhouette.get(x, y));
        if t && !s {
            p.0 = [255, 0, 255];
        } else if s && !t && !beyond.get(x, y) {
            p.0 = [0, 255, 255];
        }
    }
    for o in outline {
        let (x, y) = (o.pixel[0].round(), o.pixel[1].round());
        if x < 0.0 || y < 0.0 || x >= out.width() as f64 || y >= out.height() as f64 {
            continue;
        }
        let colour = match o.residual {
            Some(r) if r.abs() <= 0.5 => [0, 230, 0],
            Some(_) => [255, 150, 0],
            None => [255, 0, 0],
        };
        out.put_pixel(x as u32, y as u32, image::Rgb(colour));
    }
    out
}

/// How much of the carved hull lies away from the fitted tube — farther than `reach` mm from
/// its centerline — as the length of tube of that volume, mm (`voxel` the voxel volume, mm³).
/// The hull is everything every camera allows; a part of it the tube leaves out is a place the
/// images would let the tube be instead (a ghost of a hull seen by too few cameras).
pub(crate) fn ghost_length(tube: &Tube, hull: &[[f64; 3]], voxel: f64, reach: f64) -> f64 {
    let n = (tube.length() / (reach / 2.0)).ceil().max(2.0) as usize;
    let samples: Vec<Point3<f64>> = (0..=n).map(|i| tube.frame(i as f64 / n as f64).0).collect();
    // Centerline samples in cells over their bounding box (a margin of `reach`): a voxel
    // within `reach` of a sample lies in that sample's cell or a neighbour.
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &samples {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c] - reach);
            hi[c] = hi[c].max(p[c] + reach);
        }
    }
    // Cells at least `reach` wide, and at most 200 a side whatever the tube's extent.
    let size = (0..3)
        .map(|c| (hi[c] - lo[c]) / 200.0)
        .fold(reach, f64::max);
    let dims = [0, 1, 2].map(|c| ((hi[c] - lo[c]) / size).ceil().max(1.0) as usize);
    let cell = |p: &[f64; 3]| -> Option<[usize; 3]> {
        let mut out = [0; 3];
        for c in 0..3 {
            let v = ((p[c] - lo[c]) / size).floor();
            if v < 0.0 || v >= dims[c] as f64 {
                return None;
            }
            out[c] = v as usize;
        }
        Some(out)
    };
    let index = |[i, j, k]: [usize; 3]| (k * dims[1] + j) * dims[0] + i;
    let mut heads = vec![u32::MAX; dims[0] * dims[1] * dims[2]];
    let mut next = vec![u32::MAX; samples.len()];
    for (i, p) in samples.iter().enumerate() {
        if let Some(c) = cell(&[p.x, p.y, p.z]) {
            let h = index(c);
            next[i] = heads[h];
            heads[h] = i as u32;
        }
    }
    let near = |p: &[f64; 3]| -> bool {
        let Some([i, j, k]) = cell(p) else {
            return false;
        };
        let q = Point3::from(*p);
        let span = |v: usize, d: usize| v.saturating_sub(1)..=(v + 1).min(d - 1);
        span(k, dims[2]).any(|z| {
            span(j, dims[1]).any(|y| {
                span(i, dims[0]).any(|x| {
                    let mut s = heads[index([x, y, z])];
                    while s != u32::MAX {
                        if (samples[s as usize] - q).norm() <= reach {
                            return true;
                        }
                        s = next[s as usize];
                    }
                    false
                })
            })
        })
    };
    let away = hull.iter().filter(|p| !near(p)).count();
    away as f64 * voxel / (std::f64::consts::PI * tube.radius * tube.radius)
}

/// A point of a tube's centerline, as the shape checks see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Station {
    /// Arc length from the proximal end, mm.
    pub at: f64,
    /// Position, world mm.
    pub point: Point3<f64>,
    /// The tube's radius there, mm.
    pub radius: f64,
    /// Curvature times radius there.
    pub bend: f64,
    /// Whether the checks judge it (the part a record reports).
    pub judged: bool,
}

/// `tube`'s centerline about every millimetre (`length` its length, mm), judged where `judge`
/// holds (the part a record reports: inside the working volume). A curl or a fold spans
/// several millimetres: finer steps find nothing more. Each station's arc length is summed
/// along the stations themselves, not read as `u · length`: control points that crept along
/// the tube bunch the parameter, and a fold read by it looks shorter or longer than it is.
pub(crate) fn stations(
    tube: &Tube,
    length: f64,
    judge: impl Fn(&Point3<f64>) -> bool,
) -> Vec<Station> {
    let n = length.ceil().max(4.0) as usize;
    let mut at = 0.0;
    let mut previous: Option<Point3<f64>> = None;
    (0..=n)
        .map(|i| {
            let u = i as f64 / n as f64;
            let d = tube.centerline.eval(u);
            let point = Point3::from(d.value);
            if let Some(p) = previous {
                at += (point - p).norm();
            }
            previous = Some(point);
            let (d1, d2) = (Vector3::from(d.d1), Vector3::from(d.d2));
            let speed = d1.norm().max(1e-300);
            let radius = tube.radius_at(u, length);
            Station {
                at,
                point,
                radius,
                bend: d1.cross(&d2).norm() / speed.powi(3) * radius,
                judged: judge(&point),
            }
        })
        .collect()
}

/// The tightest bend among the judged `stations`: the largest curvature times radius. At 1
/// or more the tube's inner side would have to fold through itself: no tube bends so tightly,
/// and a fitted tube that does has curled an end where the images do not hold it (inside its
/// own outline).
pub(crate) fn tightest_bend(stations: &[Station]) -> Option<&Station> {
    stations
        .iter()
        .filter(|s| s.judged)
        .max_by(|a, b| a.bend.total_cmp(&b.bend))
}

/// Where a tube would pass through itself: two points of its centerline at least two radii
/// apart along it yet closer than a radius in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SelfCrossing {
    /// Arc lengths of the two points from the proximal end, mm.
    pub at_mm: [f64; 2],
    /// Their distance, mm.
    pub distance_mm: f64,
}

/// The closest place where the tube of `stations` passes through itself, if it does. Such a
/// shape explains the images no worse than the right one — a part folded back along the tube
/// hides in its own silhouette, and the fold looks like the tip's cap — but no tube can take
/// it. A tube bent no tighter than its radius keeps points two radii apart along it at least
/// 4/π radii apart in space, so the rule never flags a shape a tube can take.
pub(crate) fn self_crossing(stations: &[Station]) -> Option<SelfCrossing> {
    let largest = stations.iter().map(|s| s.radius).fold(0.0, f64::max);
    let smallest = stations.iter().map(|s| s.radius).fold(largest, f64::min);
    // The longest step between stations: skipping k of them goes at most k of these along.
    let step = stations
        .windows(2)
        .map(|w| w[1].at - w[0].at)
        .fold(0.0, f64::max);
    if step <= 0.0 {
        return None;
    }
    let mut worst: Option<SelfCrossing> = None;
    // The first station at least two of the smallest radii along from `a`: none before can
    // qualify, and it moves only forward with `a`.
    let mut first = 0;
    for (i, a) in stations.iter().enumerate() {
        if !a.judged {
            continue;
        }
        first = first.max(i + 1);
        while stations
            .get(first)
            .is_some_and(|b| b.at - a.at < 2.0 * smallest)
        {
            first += 1;
        }
        let mut j = first;
        while let Some(b) = stations.get(j) {
            let r = a.radius.max(b.radius);
            let d = (b.point - a.point).norm();
            if b.at - a.at >= 2.0 * r
                && d < r
                && b.judged
                && worst.is_none_or(|w| d < w.distance_mm)
            {
                worst = Some(SelfCrossing {
                    at_mm: [a.at, b.at],
                    distance_mm: d,
                });
            }
            // The arc between two points is at least their chord: no station closer along
            // the tube than (d − largest radius) can come within a radius of `a`.
            j += (((d - largest) / step) as usize).max(1);
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Residuals along both sides (100 samples each): a smooth error of the shape (up to
    /// `smooth` px, what a wrong shape or calibration gives) plus normal noise of `sigma(C)` px
    /// for a boundary read from `contrast(k)` grey levels (Box–Muller from a linear
    /// congruential sequence), and a few boundaries pulled 2 px off.
    fn outline_over(
        smooth: f64,
        contrast: impl Fn(usize) -> f64,
        sigma: impl Fn(f64) -> f64,
        pulled: usize,
    ) -> Vec<Measured> {
        let mut x = 7u64;
        let mut uniform = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let mut out = Vec::new();
        for side in [-1.0, 1.0] {
            for k in 0..100 {
                let u = k as f64 / 99.0;
                let n = (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos();
                let pull = if k % 10 == 3 && k / 10 < pulled {
                    2.0
                } else {
                    0.0
                };
                let c = contrast(k);
                let r = smooth * (3.0 * u).sin() * side + sigma(c) * n + pull;
                let mut m = crate::solve::made_up::side(u, side, Some(r));
                m.contrast = c;
                out.push(m);
            }
        }
        out
    }

    /// [`outline_over`] a backdrop of one colour (150 grey levels from the tube), `sigma` px
    /// of noise and a smooth error of 0.6 px.
    fn outline(sigma: f64, pulled: usize) -> Vec<Measured> {
        outline_over(0.6, |_| 150.0, |_| sigma, pulled)
    }

    #[test]
    fn the_scatter_is_read_from_the_noise_not_the_shapes_error() {
        for sigma in [0.05, 0.1, 0.2] {
            let got = Scatter::of(&outline(sigma, 0)).at(150.0);
            let pulled = Scatter::of(&outline(sigma, 6)).at(150.0);
            println!("σ {sigma}: {got:.4}, {pulled:.4} with boundaries pulled off");
            assert!((got / sigma - 1.0).abs() < 0.2, "σ {sigma}: {got}");
            // Six boundaries of each side pulled 2 px off (12 of 198 differences) move it by
            // a fifth at most.
            assert!((pulled / got - 1.0).abs() < 0.2, "σ {sigma}: {pulled}");
        }
        // The shape's smooth error alone: hardly any scatter (0.6 px at most, 0.02 px
        // between neighbours).
        assert!(Scatter::of(&outline(0.0, 0)).at(150.0) < 0.02);
        // Too few samples tell nothing.
        assert_eq!(Scatter::of(&outline(0.1, 0)[..5]), Scatter::default());
    }

    /// A chessboard's squares behind the tube: boundaries read from 8 grey levels over the
    /// dark squares and 150 over the light ones, ten samples a square.
    fn squares(k: usize) -> f64 {
        if (k / 10).is_multiple_of(2) {
            8.0
        } else {
            150.0
        }
    }

    /// A floor of 0.07 px and 1.8 px·grey levels of noise: what the simulator's dark-blue
    /// tube over a chessboard shows (0.2 px over the dark squares, 0.07 over the light).
    fn chessboard_sigma(c: f64) -> f64 {
        0.07f64.hypot(1.8 / c)
    }

    #[test]
    fn the_scatter_grows_where_the_backdrop_takes_the_tubes_contrast() {
        let scatter = Scatter::of(&outline_over(0.6, squares, chessboard_sigma, 0));
        println!("{scatter:?}");
        for c in [8.0, 150.0] {
            let (got, want) = (scatter.at(c), chessboard_sigma(c));
            assert!(
                (got / want - 1.0).abs() < 0.25,
                "{c} grey levels: {got} for {want}"
            );
        }
        // One figure for both (the median's) would put the faint boundaries' at about half
        // what it is, and the clear ones' at about twice.
        let one = Scatter::of(&outline_over(0.6, |_| 150.0, |_| 0.0, 0));
        assert!(one.at(8.0) < 0.02);
    }

    #[test]
    fn each_boundary_is_held_to_its_own_scatter() {
        let held = |m: &[Measured]| residual_stats(m, &Scatter::of(m), 0.25, 1.0);
        // Right over the chessboard: half the outline faint, scattering 0.2 px.
        let right = outline_over(0.0, squares, chessboard_sigma, 0);
        let stats = held(&right);
        println!("right: {:.3} outlying", stats.outlying);
        assert!(stats.outlying <= 0.1, "{}", stats.outlying);
        // A smooth error of 0.6 px (a wrong shape) is outlying wherever the boundaries are
        // clear, and over the faint squares too where it passes their scatter.
        let wrong = outline_over(0.6, squares, chessboard_sigma, 0);
        let stats = held(&wrong);
        println!("wrong: {:.3} outlying", stats.outlying);
        assert!(stats.outlying > 0.3, "{}", stats.outlying);
    }

    #[test]
    fn an_ends_residual_leaves_its_tenth_farthest_off_out() {
        // Twelve boundaries 0.1 px off and one 3 px (read off a printed edge): the RMS over
        // all 0.84 px, over nine tenths 0.1.
        let mut m: Vec<Measured> = (0..13)
            .map(|k| crate::solve::made_up::side(k as f64 / 12.0, 1.0, Some(0.1)))
            .collect();
        m[6].residual = Some(3.0);
        let all = residual_stats(&m, &Scatter::default(), 0.25, 1.0);
        let kept = residual_stats(&m, &Scatter::default(), 0.25, END_KEPT);
        assert!((all.rms - 0.841).abs() < 0.01, "{}", all.rms);
        assert!((kept.rms - 0.1).abs() < 1e-9, "{}", kept.rms);
        // Three of them off (an end that is not there): the RMS still shows it.
        m[2].residual = Some(3.0);
        m[9].residual = Some(3.0);
        let kept = residual_stats(&m, &Scatter::default(), 0.25, END_KEPT);
        assert!(kept.rms > 1.0, "{}", kept.rms);
    }

    #[test]
    fn an_unresolved_rim_excuses_an_outline_read_outward_but_not_a_shifted_one() {
        use crate::solve::made_up::side;
        // Both sides of a thin grey tube read 0.3 px outward (residual −0.3), each with
        // 0.35 px of slack: within it, the outline is explained.
        let station = |k: usize, left: f64, right: f64| {
            let u = k as f64 / 40.0;
            let mut m = [side(u, -1.0, Some(left)), side(u, 1.0, Some(right))];
            for m in &mut m {
                m.rim = 0.35;
            }
            m
        };
        let wide: Vec<Measured> = (0..40).flat_map(|k| station(k, -0.3, -0.3)).collect();
        let held = residual_stats(&wide, &Scatter::default(), 0.25, 1.0);
        assert_eq!(held.outlying, 0.0);
        assert_eq!(held.rms, 0.0);
        // The same tube predicted 0.5 px to one side: the side it moved away from reads
        // +0.2 px (the slack goes outward only), the other −0.8 px: beyond the limit on both.
        let shifted: Vec<Measured> = (0..40).flat_map(|k| station(k, -0.8, 0.2)).collect();
        let held = residual_stats(&shifted, &Scatter::default(), 0.15, 1.0);
        assert!(held.outlying > 0.99, "{}", held.outlying);
        // Without the slack, the outline read outward is beyond it everywhere.
        let bare: Vec<Measured> = wide.iter().map(|m| Measured { rim: 0.0, ..*m }).collect();
        assert_eq!(
            residual_stats(&bare, &Scatter::default(), 0.25, 1.0).outlying,
            1.0
        );
    }

    #[test]
    fn a_backdrop_edge_under_a_boundary_excuses_that_boundary_either_way_and_no_other() {
        use crate::solve::made_up::side;
        // An outline read right everywhere but over a printed dot, where 6 of 40 stations
        // read 0.8 px off (either way) with 0.9 px of doubt: explained.
        let station = |k: usize, off: f64, doubt: f64| {
            let u = k as f64 / 40.0;
            let mut m = [side(u, -1.0, Some(off)), side(u, 1.0, Some(-off))];
            for m in &mut m {
                m.backdrop = doubt;
            }
            m
        };
        let over_dot = |k: usize| (12..18).contains(&k);
        let read: Vec<Measured> = (0..40)
            .flat_map(|k| {
                if over_dot(k) {
                    station(k, 0.8, 0.9)
                } else {
                    station(k, 0.02, 0.0)
                }
            })
            .collect();
        let held = residual_stats(&read, &Scatter::default(), 0.25, 1.0);
        assert_eq!(held.outlying, 0.0);
        assert!(held.p90 < 0.05, "{}", held.p90);
        // Without the doubt, those stations are beyond the limit (15 % of the outline).
        let bare: Vec<Measured> = read
            .iter()
            .map(|m| Measured {
                backdrop: 0.0,
                ..*m
            })
            .collect();
        let held = residual_stats(&bare, &Scatter::default(), 0.25, 1.0);
        assert!((held.outlying - 0.15).abs() < 1e-9, "{}", held.outlying);
        // An outline 0.6 px off everywhere (a tube predicted too narrow): the doubt over the
        // dot leaves every other station beyond the limit.
        let shifted: Vec<Measured> = (0..40)
            .flat_map(|k| station(k, 0.6, if over_dot(k) { 0.9 } else { 0.0 }))
            .collect();
        let held = residual_stats(&shifted, &Scatter::default(), 0.25, 1.0);
        assert!((held.outlying - 0.85).abs() < 1e-9, "{}", held.outlying);
    }

    #[test]
    fn a_noisy_limit_adds_the_noise_in_quadrature() {
        assert_eq!(noisy_limit(0.25, 0.0, 1.645), 0.25);
        assert!((noisy_limit(0.3, 0.4 / 1.645, 1.645) - 0.5).abs() < 1e-12);
    }

    fn tube(points: &[[f64; 3]], span: f64) -> Tube {
        Tube::through(points, 3.0, [true, true], span, 0.0).unwrap()
    }

    fn all(t: &Tube) -> Vec<Station> {
        stations(t, t.length(), |_| true)
    }

    /// A mask of blobs: discs at pseudo-random places (a linear congruential sequence).
    fn blobs(seed: u64, count: usize) -> BitMask {
        let mut m = BitMask::new(150, 40);
        let mut x = seed;
        let mut next = |n: u64| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 33) % n) as f64
        };
        for _ in 0..count {
            let c = nalgebra::Vector2::new(next(150), next(40));
            disc(&mut m, (Point3::origin(), c, 1.0 + next(6)));
        }
        m
    }

    #[test]
    fn overlap_is_the_iou_outside_the_continuations_and_the_unexplained_pixels() {
        let view = |silhouette: &BitMask, shadow: Option<&BitMask>, f: &dyn Fn(&crate::View)| {
            let (w, h) = (silhouette.width(), silhouette.height());
            let image = image::RgbImage::new(w as u32, h as u32);
            let background = vec![[0f32; 3]; w * h];
            let markers = BitMask::new(w, h);
            f(&crate::View {
                image: &image,
                background: &background,
                silhouette,
                markers: &markers,
                shadow_like: shadow,
                hidden: None,
            })
        };
        for seed in 0..20 {
            let (tube, beyond, silhouette) =
                (blobs(seed, 6), blobs(seed + 100, 3), blobs(seed + 200, 8));
            // As the check defines it, with whole masks.
            let sure = beyond.and(&tube.not()).not();
            let near = tube.or(&beyond).dilate(2);
            let expect = |silhouette: &BitMask| {
                let iou = tube.and(&sure).iou(&silhouette.and(&sure));
                (iou, silhouette.and(&near.not()).count())
            };
            let drawn = (tube.clone(), beyond.clone());
            // The overlap of `silhouette` with `shadow_like` and `zones` against the check's
            // definition with whole masks, `left_out` the shadow pixels it should leave out.
            let agrees = |shadow: Option<&BitMask>, zones: &BitMask, left_out: &BitMask| {
                let (iou, unexplained) = expect(&silhouette.and(&left_out.not()));
                // Where the outline shows the tube, its pixels count as seen; asked only below
                // the limit (2: always; 0: never).
                let outlined = blobs(seed + 500, 4);
                let completed = silhouette.and(&left_out.not()).or(&tube.and(&outlined));
                let (iou_outlined, _) = expect(&completed);
                view(&silhouette, shadow, &|v| {
                    let touching =
                        |away: &BitMask| flexshape_silhouette::components::touching(away, zones);
                    let got = overlap(&drawn, v, 2, touching, (2.0, || outlined.clone()));
                    assert!((got.iou - iou).abs() < 1e-12, "seed {seed}: {}", got.iou);
                    assert!(
                        (got.iou_outlined.unwrap() - iou_outlined).abs() < 1e-12,
                        "seed {seed}"
                    );
                    assert!(iou_outlined >= iou, "seed {seed}");
                    assert_eq!(got.unexplained_px, unexplained, "seed {seed}");
                    assert_eq!(got.shadow_px, left_out.count(), "seed {seed}");
                    let unasked = overlap(&drawn, v, 2, touching, (0.0, || unreachable!()));
                    assert_eq!(unasked.iou_outlined, None);
                });
            };
            let none = BitMask::new(150, 40);
            agrees(None, &none, &none);
            // Shadow-coloured pixels away from the tube are left out of both; near it they count.
            let shadow = silhouette.and(&blobs(seed + 300, 10));
            let away = shadow.and(&near.not());
            agrees(Some(&shadow), &none, &away);
            // …except those `continuations` takes for a grey distal part the fit missed.
            let zones = blobs(seed + 400, 3);
            let missed = flexshape_silhouette::components::touching(&away, &zones);
            agrees(Some(&shadow), &zones, &away.and_not(&missed));
        }
        let empty = BitMask::new(150, 40);
        view(&empty, None, &|v| {
            let got = overlap(
                &(empty.clone(), empty.clone()),
                v,
                2,
                |_| empty.clone(),
                (0.75, || empty.clone()),
            );
            assert_eq!((got.iou, got.unexplained_px), (1.0, 0));
        });
    }

    fn arc(radius: f64, turns: f64, pitch: f64) -> Vec<[f64; 3]> {
        let n = (turns * 400.0) as usize;
        (0..=n)
            .map(|i| {
                let a = i as f64 / 400.0 * std::f64::consts::TAU;
                [
                    radius * a.sin(),
                    pitch * a / std::f64::consts::TAU,
                    radius * (1.0 - a.cos()),
                ]
            })
            .collect()
    }

    #[test]
    fn shapes_a_tube_can_take_do_not_cross_themselves() {
        let straight = tube(&[[0.0; 3], [0.0, 0.0, 200.0]], 15.0);
        assert_eq!(self_crossing(&all(&straight)), None);
        // Three quarters of a circle of three radii, and a helix whose turns lie two
        // diameters apart.
        for points in [arc(9.0, 0.75, 0.0), arc(20.0, 2.5, 12.0)] {
            let t = tube(&points, 5.0);
            assert_eq!(self_crossing(&all(&t)), None);
        }
    }

    #[test]
    fn a_fold_and_a_loop_through_the_tube_cross_it() {
        // Out 100 mm, a U-turn, back 40 mm two millimetres beside itself (radius 3).
        let mut fold: Vec<[f64; 3]> = (0..=100).map(|i| [0.0, 0.0, i as f64]).collect();
        fold.extend((0..=40).map(|i| [2.0, 0.0, 100.0 - i as f64]));
        let t = tube(&fold, 15.0);
        let c = self_crossing(&all(&t)).expect("the fold passes through the tube");
        assert!(c.distance_mm < 3.0, "{c:?}");
        assert!(c.at_mm[1] - c.at_mm[0] >= 6.0, "{c:?}");
        // One and a half turns of a circle whose second turn runs a millimetre from the first.
        let t = tube(&arc(20.0, 1.5, 1.0), 5.0);
        let c = self_crossing(&all(&t)).expect("the loop passes through the tube");
        assert!(c.distance_mm < 1.5, "{c:?}");
    }

    #[test]
    fn a_fold_is_placed_by_arc_length_whatever_the_parameter() {
        // The fold above, fitted once with a parameter proportional to arc length and once
        // with one that runs fast at first and bunches the control points toward the tip (as
        // a followed tip's points crept): the fold is found where it is along the tube.
        let mut fold: Vec<[f64; 3]> = (0..=100).map(|i| [0.0, 0.0, i as f64]).collect();
        fold.extend((1..=40).map(|i| [2.0, 0.0, 100.0 - i as f64]));
        let even: Vec<f64> = (0..fold.len()).map(|i| i as f64 / 140.0).collect();
        let bunched: Vec<f64> = even.iter().map(|u| u.powf(0.6)).collect();
        let found = |params: &[f64]| {
            let t = Tube {
                centerline: flexshape_curve::BSpline3::fit(params, &fold, 40).unwrap(),
                radius: 3.0,
                steps: Vec::new(),
                capped: [true, true],
            };
            self_crossing(&all(&t)).expect("the fold passes through the tube")
        };
        // The closest pair moves a little with the fit; the turn between them stays at the
        // fold's 100 mm (read by the parameter, the bunched fit's would be near 115).
        for c in [found(&even), found(&bunched)] {
            let turn = (c.at_mm[0] + c.at_mm[1]) / 2.0;
            assert!((turn - 100.0).abs() < 1.5, "{c:?}");
            assert!(c.at_mm[1] - c.at_mm[0] >= 6.0, "{c:?}");
        }
    }

    #[test]
    fn the_tightest_bend_is_curvature_times_radius() {
        // A circle of 20 mm: 3/20 all along.
        let t = tube(&arc(20.0, 0.5, 0.0), 5.0);
        let kr = tightest_bend(&all(&t)).unwrap().bend;
        assert!((kr - 0.15).abs() < 0.005, "{kr}");
        // A tip curled back on a 1-mm circle: tighter than its radius.
        let mut curl: Vec<[f64; 3]> = (0..=100).map(|i| [0.0, 0.0, i as f64]).collect();
        curl.extend((1..=30).map(|i| {
            let a = i as f64 / 30.0 * std::f64::consts::PI;
            [1.0 - a.cos(), 0.0, 100.0 + a.sin()]
        }));
        let t = tube(&curl, 2.0);
        let every = all(&t);
        let tightest = tightest_bend(&every).unwrap();
        assert!(tightest.bend > 1.0 && tightest.at > 95.0, "{tightest:?}");
        // The same tube where only its first 90 mm are kept (as if the rest left the
        // volume): no curl there.
        let kept = stations(&t, t.length(), |p| p.z < 90.0);
        assert!(kept.iter().any(|s| s.bend > 1.0));
        assert!(tightest_bend(&kept).unwrap().bend < 0.01);
    }
}
