//! Shadow-like regions with sharp outlines: a grey or silvery object on a white backdrop,
//! which darkens the backdrop's colour without changing its chromaticity, as a shadow does.
//! A shadow cast from a lamp across the room fades in over its penumbra; an object in focus
//! reaches its full darkness within a pixel or two of its outline.

use crate::bitmask::BitMask;
use crate::components::{Run, label, runs};

/// How far outside a region's outline the backdrop is read, and inside it the region, px.
const OUTSIDE: isize = 2;
const INSIDE: isize = 1;
/// Fewest outline samples for a region to be judged.
const MIN_SAMPLES: usize = 8;

/// The pixels of the sharp-edged regions of `shady` (shadow-like pixels): for each 8-connected
/// region, along its outline where it meets the `backdrop` (pixels neither foreground nor
/// shadow-like), the
/// step in brightness ratio (`alpha`) from two pixels outside to one inside, over the region's
/// darkness `1 − ᾱ`; a region whose median step is at least `edge` is an object, and its
/// pixels at least half as dark as its mean are returned.
pub(crate) fn sharp_regions(
    shady: &BitMask,
    backdrop: impl Fn(usize, usize) -> bool,
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
    let mut steps: Vec<Vec<f32>> = vec![Vec::new(); areas.len()];
    let is_backdrop = backdrop;
    let backdrop = |x: isize, y: isize| -> bool {
        x >= 0
            && y >= 0
            && (x as usize) < w
            && (y as usize) < h
            && is_backdrop(x as usize, y as usize)
    };
    let inside = |x: isize, y: isize| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h;
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
                    let step = alpha(ox as usize, oy as usize) - alpha(ix as usize, iy as usize);
                    steps[l].push(step);
                }
            }
        }
    }
    let sharp: Vec<Option<f32>> = (0..areas.len())
        .map(|l| {
            let mean_dark = darkness[l] / areas[l] as f32;
            let s = &mut steps[l];
            if s.len() < MIN_SAMPLES || mean_dark <= 0.0 {
                return None;
            }
            s.sort_by(f32::total_cmp);
            // Kept: pixels at least half as dark as the region's mean.
            (s[s.len() / 2] / mean_dark >= edge).then_some(1.0 - mean_dark / 2.0)
        })
        .collect();
    for (r, &l) in runs.iter().zip(&labels) {
        if let Some(limit) = sharp[l] {
            fill_darker(&mut out, r, &alpha, limit);
        }
    }
    out
}

/// Sets the pixels of `r` whose brightness ratio is at most `limit`.
fn fill_darker(out: &mut BitMask, r: &Run, alpha: &impl Fn(usize, usize) -> f32, limit: f32) {
    let y = r.y as usize;
    for x in r.x0 as usize..r.x1 as usize {
        if alpha(x, y) <= limit {
            out.set(x, y, true);
        }
    }
}
