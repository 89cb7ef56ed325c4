//! Holes in a silhouette that the object itself makes: a silvery tube's highlight runs along
//! its middle in the backdrop's own colour, and the classifier leaves a slit there that
//! carving turns into a hollow tube (cross-sections that fall apart). A hole the object
//! encloses and that is thinner than the object is wide cannot be backdrop seen through a loop
//! or past a crossing — a tube does not bend tighter than its own width — so it is filled;
//! wider holes stay.

use crate::bitmask::BitMask;
use crate::components::{Run, fill_run, label_with, runs, touching};

/// `mask` with its thin holes filled: 4-connected regions of unset pixels that do not reach
/// the image's border and hold no square as wide as the object's mean width (twice its area
/// over its outline's pixels, holes included).
pub(crate) fn fill_thin_holes(mask: &BitMask) -> BitMask {
    let holes = holes(mask);
    if holes.count() == 0 {
        return mask.clone();
    }
    let filled = mask.or(&holes);
    let outline = filled.and_not(&filled.erode(1)).count();
    // The widest square a hole may hold: one pixel narrower than the object.
    let width = 2.0 * filled.count() as f64 / outline.max(1) as f64;
    let r = ((width - 1.0) / 2.0).floor().max(0.0) as usize;
    if r == 0 {
        return mask.clone();
    }
    // A hole keeps its pixels when a square of side 2r + 1 fits inside it.
    let wide = touching(&holes, &holes.erode(r));
    mask.or(&holes.and_not(&wide))
}

/// The unset pixels of `mask` that are cut off from the image's border (4-connected). Only the
/// gaps between a row's set runs can be: a stretch before a row's first run or after its last
/// reaches the border along the row, and a gap is open when it meets such a stretch, or an
/// empty row, in the row above or below.
fn holes(mask: &BitMask) -> BitMask {
    let mut out = BitMask::new(mask.width(), mask.height());
    let set = runs(mask);
    let gaps: Vec<Run> = set
        .windows(2)
        .filter(|p| p[0].y == p[1].y)
        .map(|p| Run {
            y: p[0].y,
            x0: p[0].x1,
            x1: p[1].x0,
        })
        .collect();
    if gaps.is_empty() {
        return out;
    }
    // Each row's first set column and one past its last.
    let mut extent: Vec<Option<(u32, u32)>> = vec![None; mask.height()];
    for r in &set {
        let e = extent[r.y as usize].get_or_insert((r.x0, r.x1));
        e.1 = r.x1;
    }
    let beyond = |y: Option<u32>, g: &Run| match y.and_then(|y| extent.get(y as usize)) {
        Some(Some((lo, hi))) => g.x0 < *lo || g.x1 > *hi,
        _ => true,
    };
    let (labels, areas) = label_with(&gaps, false);
    let mut open = vec![false; areas.len()];
    for (g, &l) in gaps.iter().zip(&labels) {
        open[l] |= beyond(g.y.checked_sub(1), g) || beyond(Some(g.y + 1), g);
    }
    for (g, &l) in gaps.iter().zip(&labels) {
        if !open[l] {
            fill_run(&mut out, g);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The unset pixels no 4-connected path of unset pixels joins to the border: a flood
    /// fill from the border, pixel by pixel.
    fn flooded_holes(m: &BitMask) -> BitMask {
        let (w, h) = (m.width(), m.height());
        let mut outside = vec![false; w * h];
        let mut stack: Vec<(usize, usize)> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| (x == 0 || y == 0 || x + 1 == w || y + 1 == h) && !m.get(x, y))
            .collect();
        for &(x, y) in &stack {
            outside[y * w + x] = true;
        }
        while let Some((x, y)) = stack.pop() {
            let near = [
                (x.wrapping_sub(1), y),
                (x + 1, y),
                (x, y.wrapping_sub(1)),
                (x, y + 1),
            ];
            for (nx, ny) in near {
                if nx < w && ny < h && !m.get(nx, ny) && !outside[ny * w + nx] {
                    outside[ny * w + nx] = true;
                    stack.push((nx, ny));
                }
            }
        }
        let mut out = BitMask::new(w, h);
        for y in 0..h {
            for x in 0..w {
                out.set(x, y, !m.get(x, y) && !outside[y * w + x]);
            }
        }
        out
    }

    proptest! {
        #[test]
        fn holes_match_a_flood_fill_from_the_border(w in 1usize..140, h in 1usize..30, density in 1u64..15, seed in any::<u64>()) {
            let m = crate::bitmask::random_mask(w, h, density, seed);
            prop_assert_eq!(holes(&m), flooded_holes(&m));
        }
    }

    /// A vertical bar `width` pixels wide over rows 5..45 of a 40×50 mask, with a slit
    /// `slit` pixels wide down its middle over rows 10..40.
    fn slit_bar(width: usize, slit: usize) -> BitMask {
        let mut m = BitMask::new(40, 50);
        let x0 = 20 - width / 2;
        for y in 5..45 {
            m.set_span(y, x0, x0 + width - 1);
        }
        let s0 = 20 - slit / 2;
        for y in 10..40 {
            for x in s0..s0 + slit {
                m.set(x, y, false);
            }
        }
        m
    }

    #[test]
    fn a_slit_thinner_than_the_bar_is_filled() {
        let m = slit_bar(9, 3);
        let filled = fill_thin_holes(&m);
        assert_eq!(filled.count(), 9 * 40);
        assert!(filled.get(20, 20));
    }

    #[test]
    fn backdrop_seen_through_a_loop_stays() {
        // A tube 7 px wide and 200 long that makes a loop (outer radius 20 px, inner 13):
        // the backdrop inside is wider than the tube.
        let mut m = BitMask::new(260, 60);
        for y in 27..34 {
            m.set_span(y, 10, 209);
        }
        for y in 0..60usize {
            for x in 200..260usize {
                let d2 = (x as f64 - 230.0).powi(2) + (y as f64 - 30.0).powi(2);
                if (169.0..400.0).contains(&d2) {
                    m.set(x, y, true);
                }
            }
        }
        let kept = fill_thin_holes(&m);
        assert!(!kept.get(230, 30), "the loop's inside was filled");
        assert_eq!(kept, m);
    }

    #[test]
    fn a_gap_open_to_the_border_or_the_backdrop_stays() {
        // The slit reaches the bar's end: it is a notch, not a hole.
        let mut m = slit_bar(9, 3);
        for y in 40..45 {
            for x in 19..22 {
                m.set(x, y, false);
            }
        }
        assert_eq!(fill_thin_holes(&m), m);
        // A mask cut by the image border on its left: the gap touching the border stays.
        let mut b = BitMask::new(20, 20);
        for y in 2..18 {
            b.set_span(y, 0, 9);
        }
        for y in 5..15 {
            b.set(0, y, false);
        }
        assert_eq!(fill_thin_holes(&b), b);
    }

    #[test]
    fn holes_joined_only_at_a_corner_are_apart() {
        // Two unset pixels meeting diagonally inside a solid block, the second one touching
        // a notch open to the outside: only the first is a hole.
        let mut m = BitMask::new(20, 20);
        for y in 2..18 {
            m.set_span(y, 2, 17);
        }
        m.set(9, 9, false);
        for y in 10..18 {
            m.set(10, y, false);
        }
        let h = holes(&m);
        assert_eq!(h.count(), 1);
        assert!(h.get(9, 9));
    }
}
