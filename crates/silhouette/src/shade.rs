//! Shadow-like regions with sharp outlines: a grey or silvery object on a white backdrop,
//! which darkens the backdrop's colour without changing its chromaticity, as a shadow does.
//! A shadow cast from a lamp across the room fades in over its penumbra; an object in focus
//! reaches its full darkness within a pixel or two of its outline.

use std::collections::VecDeque;

use crate::bitmask::BitMask;
use crate::components::{label, runs};

/// How far outside a region's outline the backdrop is read, and inside it the region, px.
const OUTSIDE: isize = 2;
const INSIDE: isize = 1;
/// Fewest outline samples for a region to be judged.
const MIN_SAMPLES: usize = 8;
/// How far along a region's outline an outline pixel's neighbours vote on whether it is sharp,
/// px (chessboard): one noisy sample does not cut a notch into a tube.
const VOTE_REACH: isize = 2;

/// One outline sample: the outline pixel (row-major index), its region, and the step (over
/// the region's darkness, once that is known).
struct Sample {
    pixel: usize,
    region: usize,
    step: f32,
    /// Read within the region alone, away from the foreground (no pixel around the outline
    /// pixel or the one inside it is foreground already).
    own: bool,
}

/// The pixels of the sharp-edged regions of `shady` (shadow-like pixels). For each 8-connected
/// region, along its outline where it meets the `backdrop` (pixels neither foreground nor
/// shadow-like): the step in brightness ratio (`alpha`) from two pixels outside to the pixel
/// one inside, or to the outline pixel where that is the darker, the pixel inside is of the
/// region too and neither is `object` (foreground already); over the region's darkness
/// `1 − ᾱ`. A region whose median step is at least `edge` holds an object, as does one with
/// [`MIN_SAMPLES`] such steps read within itself away from the foreground (a grey tube across
/// a lamp's long soft shadow, whose soft outline outnumbers the tube's); of it are returned
/// the pixels at least half as dark as its mean that lie nearer a sharp stretch of its
/// outline than a soft one ([`sharp_parts`]): a lamp's shadow that touches a grey tube joins
/// its region, and the tube's sharp outline, the most of it, would take the shadow in too.
pub(crate) fn sharp_regions(
    shady: &BitMask,
    backdrop: impl Fn(usize, usize) -> bool,
    object: impl Fn(usize, usize) -> bool,
    alpha: impl Fn(usize, usize) -> f32,
    edge: f32,
) -> BitMask {
    let (w, h) = (shady.width(), shady.height());
    let mut out = BitMask::new(w, h);
    let runs = runs(shady);
    if runs.is_empty() {
        return out;
    }
    let (labels, areas) = label(&runs);
    let mut darkness = vec![0f32; areas.len()];
    let mut samples: Vec<Sample> = Vec::new();
    let is_backdrop = backdrop;
    let backdrop = |x: isize, y: isize| -> bool {
        x >= 0
            && y >= 0
            && (x as usize) < w
            && (y as usize) < h
            && is_backdrop(x as usize, y as usize)
    };
    let inside = |x: isize, y: isize| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h;
    // No foreground pixel among the eight around (x, y).
    let clear = |x: isize, y: isize| {
        (y - 1..=y + 1).all(|yy| {
            (x - 1..=x + 1).all(|xx| !inside(xx, yy) || !object(xx as usize, yy as usize))
        })
    };
    for (r, &l) in runs.iter().zip(&labels) {
        let y = r.y as isize;
        for x in r.x0 as usize..r.x1 as usize {
            darkness[l] += 1.0 - alpha(x, r.y as usize);
            let x = x as isize;
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                if !backdrop(x + dx, y + dy) {
                    continue;
                }
                let (ox, oy) = (x + OUTSIDE * dx, y + OUTSIDE * dy);
                let (ix, iy) = (x - INSIDE * dx, y - INSIDE * dy);
                if backdrop(ox, oy) && inside(ix, iy) {
                    // Within the region, the darker of the outline pixel and the one inside
                    // it: across a tube 2–4 px wide the pixel inside is its lit middle or its
                    // far side, no darker than the outline pixel, while a penumbra darkens
                    // inward. A strip a pixel wide, and an outline pixel or the pixel inside
                    // it already foreground (the partly covered pixels beside a tube's own,
                    // mixing its limb with the backdrop, and its own), are read one pixel
                    // in.
                    let within = shady.get(ix as usize, iy as usize)
                        && !object(x as usize, r.y as usize)
                        && !object(ix as usize, iy as usize);
                    let inner = alpha(ix as usize, iy as usize);
                    let dark = if within {
                        inner.min(alpha(x as usize, r.y as usize))
                    } else {
                        inner
                    };
                    samples.push(Sample {
                        pixel: y as usize * w + x as usize,
                        region: l,
                        step: alpha(ox as usize, oy as usize) - dark,
                        own: within && clear(x, y) && clear(ix, iy),
                    });
                }
            }
        }
    }
    let mean_dark: Vec<f32> = darkness
        .iter()
        .zip(&areas)
        .map(|(&d, &a)| d / a as f32)
        .collect();
    // Each sample's step over its region's darkness.
    let mut by_region: Vec<Vec<f32>> = vec![Vec::new(); areas.len()];
    let mut own_sharp = vec![0usize; areas.len()];
    for s in &mut samples {
        s.step /= mean_dark[s.region].max(1e-6);
        by_region[s.region].push(s.step);
        own_sharp[s.region] += usize::from(s.own && s.step >= edge);
    }
    let sharp: Vec<Option<f32>> = by_region
        .iter_mut()
        .zip(&mean_dark)
        .zip(&own_sharp)
        .map(|((s, &dark), &own_sharp)| {
            if s.len() < MIN_SAMPLES || dark <= 0.0 {
                return None;
            }
            s.sort_by(f32::total_cmp);
            // Sharp over most of its outline, or, read within itself, over as many samples
            // as a region needs to be judged: a lamp's soft shadow that a grey tube crosses
            // joins the tube's region, and its long soft outline outvotes the tube's. (A
            // strip of partly covered pixels beside the object steps sharply only into the
            // object.)
            // Kept: pixels at least half as dark as the region's mean.
            (s[s.len() / 2] >= edge || own_sharp >= MIN_SAMPLES).then_some(1.0 - dark / 2.0)
        })
        .collect();
    if sharp.iter().all(Option::is_none) {
        return out;
    }
    samples.retain(|s| sharp[s.region].is_some());
    // The sharp regions' bounds.
    let mut bounds = [w, h, 0, 0];
    for (r, &l) in runs.iter().zip(&labels) {
        if sharp[l].is_some() {
            let y = r.y as usize;
            bounds = [
                bounds[0].min(r.x0 as usize),
                bounds[1].min(y),
                bounds[2].max(r.x1 as usize),
                bounds[3].max(y + 1),
            ];
        }
    }
    let kept = sharp_parts(shady, &samples, edge, bounds);
    for (r, &l) in runs.iter().zip(&labels) {
        if let Some(limit) = sharp[l] {
            let y = r.y as usize;
            for x in r.x0 as usize..r.x1 as usize {
                if alpha(x, y) <= limit && kept(x, y) {
                    out.set(x, y, true);
                }
            }
        }
    }
    out
}

/// Which pixels of the regions of `shady` holding `samples` lie nearer a sharp stretch of
/// their outline than a soft one (by 8-connected steps through the region): an outline pixel
/// is sharp when most of the samples of the outline pixels within [`VOTE_REACH`] of it, its
/// own among them, step by at least `edge` of their region's darkness (`Sample::step`). The
/// regions lie within `bounds` (`[x0, y0, x1, y1)`, pixels); the labels are kept for them
/// alone.
fn sharp_parts<'a>(
    shady: &'a BitMask,
    samples: &[Sample],
    edge: f32,
    [x0, y0, x1, y1]: [usize; 4],
) -> impl Fn(usize, usize) -> bool + 'a {
    let (w, bw, bh) = (shady.width(), x1 - x0, y1 - y0);
    let local = |pixel: usize| (pixel / w - y0) * bw + pixel % w - x0;
    // Per outline pixel: its samples' votes, sharp less soft.
    let mut votes = vec![0i32; bw * bh];
    let mut outline = Vec::with_capacity(samples.len());
    for s in samples {
        let sharp = s.step >= edge;
        let k = local(s.pixel);
        if votes[k] == 0 {
            outline.push(k);
        }
        votes[k] += if sharp { 1 } else { -1 };
    }
    // Labels, in the image's order: a pixel as near a sharp outline pixel as a soft one takes
    // the first's to reach it. −1: not reached.
    outline.sort_unstable();
    outline.dedup();
    let mut nearest = vec![-1i8; bw * bh];
    let mut queue = VecDeque::with_capacity(outline.len());
    for &k in &outline {
        let (x, y) = ((k % bw) as isize, (k / bw) as isize);
        let mut sum = 0;
        for yy in (y - VOTE_REACH).max(0)..(y + VOTE_REACH + 1).min(bh as isize) {
            for xx in (x - VOTE_REACH).max(0)..(x + VOTE_REACH + 1).min(bw as isize) {
                sum += votes[yy as usize * bw + xx as usize];
            }
        }
        nearest[k] = i8::from(sum >= 0);
        queue.push_back(k);
    }
    while let Some(k) = queue.pop_front() {
        let label = nearest[k];
        let (x, y) = (k % bw, k / bw);
        for yy in y.saturating_sub(1)..=(y + 1).min(bh - 1) {
            for xx in x.saturating_sub(1)..=(x + 1).min(bw - 1) {
                let next = yy * bw + xx;
                if nearest[next] < 0 && shady.get(x0 + xx, y0 + yy) {
                    nearest[next] = label;
                    queue.push_back(next);
                }
            }
        }
    }
    move |x, y| {
        (x0..x1).contains(&x) && (y0..y1).contains(&y) && nearest[(y - y0) * bw + x - x0] == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: usize = 64;
    const H: usize = 48;

    /// `sharp_regions` over a brightness-ratio field `alpha` (row-major, `W` × `H`), its
    /// shadow-like pixels those below 0.85, none of them foreground unless `object` says so.
    fn sharp(alpha: &[f32], object: impl Fn(usize, usize) -> bool) -> BitMask {
        let mut shady = BitMask::new(W, H);
        for y in 0..H {
            for x in 0..W {
                shady.set(x, y, alpha[y * W + x] < 0.85);
            }
        }
        let backdrop = |x: usize, y: usize| !shady.get(x, y) && !object(x, y);
        sharp_regions(&shady, backdrop, &object, |x, y| alpha[y * W + x], 0.9)
    }

    /// A grey tube 3 px wide down columns 20–22 (rows 4–43): its limbs darkest, its middle
    /// lit.
    fn tube(alpha: &mut [f32]) {
        for y in 4..44 {
            alpha[y * W + 20..y * W + 23].copy_from_slice(&[0.45, 0.7, 0.45]);
        }
    }

    /// A lamp's shadow: 60 % of the light at its core, a penumbra 6 px wide around a core
    /// 4 px in radius centred at `c`.
    fn shadow(alpha: &mut [f32], c: (f32, f32)) {
        for y in 0..H {
            for x in 0..W {
                let d = ((x as f32 - c.0).powi(2) + (y as f32 - c.1).powi(2)).sqrt();
                let t = ((d - 4.0) / 6.0).clamp(0.0, 1.0);
                let a = 0.6 + 0.4 * t * t * (3.0 - 2.0 * t);
                alpha[y * W + x] = alpha[y * W + x].min(a);
            }
        }
    }

    fn count(m: &BitMask, xs: std::ops::Range<usize>) -> usize {
        (0..H)
            .map(|y| xs.clone().filter(|&x| m.get(x, y)).count())
            .sum()
    }

    #[test]
    fn a_thin_grey_tube_with_a_lit_middle_is_sharp() {
        // Read one pixel in from each side, the step reaches the lit middle: 0.3 of the
        // light over a darkness of 0.47, below the 0.9 asked; the tube was taken for a
        // shadow.
        let mut alpha = vec![1.0f32; W * H];
        tube(&mut alpha);
        let out = sharp(&alpha, |_, _| false);
        assert_eq!(count(&out, 20..23), 3 * 40);
        assert_eq!(out.count(), 3 * 40);
    }

    #[test]
    fn a_soft_shadow_is_not_and_one_touching_a_tube_stays_out() {
        let mut alpha = vec![1.0f32; W * H];
        shadow(&mut alpha, (40.0, 24.0));
        assert_eq!(sharp(&alpha, |_, _| false).count(), 0);
        // The shadow's edge meeting the tube joins them in one region, most of whose outline
        // is the tube's: the tube is taken, the shadow is not.
        let mut alpha = vec![1.0f32; W * H];
        shadow(&mut alpha, (30.0, 24.0));
        tube(&mut alpha);
        let out = sharp(&alpha, |_, _| false);
        assert!(count(&out, 20..23) >= 3 * 40 - 6, "{}", count(&out, 20..23));
        assert_eq!(count(&out, 24..W), 0);
    }

    #[test]
    fn a_tube_across_a_long_soft_shadow_is_taken_and_the_shadow_is_not() {
        // A lamp's shadow across the whole image (rows 14–33, its core 60 % of the light,
        // penumbrae 6 px) crossed by the tube: one region, whose soft outline (2 × 64 px)
        // outnumbers the tube's sharp one (2 × 20 px); judged by the median alone, the tube
        // was taken for shadow, and its hull lost the stretch.
        let mut alpha = vec![1.0f32; W * H];
        for y in 0..H {
            let d = (y as f32 - 23.5).abs();
            let t = ((d - 4.0) / 6.0).clamp(0.0, 1.0);
            let a = 0.6 + 0.4 * t * t * (3.0 - 2.0 * t);
            for x in 0..W {
                alpha[y * W + x] = a;
            }
        }
        tube(&mut alpha);
        let out = sharp(&alpha, |_, _| false);
        // The tube outside the shadow, whole; in it, what is darker than the shadow.
        let tube_px = (4..44)
            .filter(|&y| !(14..34).contains(&y))
            .map(|y| (20..23).filter(|&x| out.get(x, y)).count())
            .sum::<usize>();
        assert!(tube_px >= 3 * 20 - 6, "{tube_px}");
        assert_eq!(count(&out, 0..18) + count(&out, 25..W), 0);
        // A strip of the shadow with no tube across it stays shadow, however long.
        let mut alpha = vec![1.0f32; W * H];
        for y in 0..H {
            let d = (y as f32 - 23.5).abs();
            let t = ((d - 4.0) / 6.0).clamp(0.0, 1.0);
            alpha[y * W..(y + 1) * W].fill(0.6 + 0.4 * t * t * (3.0 - 2.0 * t));
        }
        assert_eq!(sharp(&alpha, |_, _| false).count(), 0);
    }

    #[test]
    fn a_strip_of_partly_covered_pixels_beside_the_object_is_not() {
        // A silvery tube's own pixels (columns 20–25, found already, as dark as a shadow) and,
        // beside them, a strip a pixel wide that its dark limb, partly covering it, darkens
        // to 0.6: read from the strip to itself, its step would be its whole darkness, half
        // again the region's.
        let mut alpha = vec![1.0f32; W * H];
        for y in 4..44 {
            alpha[y * W + 19] = 0.6;
            alpha[y * W + 26] = 0.6;
            for x in 20..26 {
                alpha[y * W + x] = 0.8;
            }
        }
        let object = |x: usize, y: usize| (20..26).contains(&x) && (4..44).contains(&y);
        assert_eq!(sharp(&alpha, object).count(), 0);
    }
}
