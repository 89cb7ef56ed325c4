//! Connected components (8-connected) of a bit mask, computed on horizontal runs.

use serde::{Deserialize, Serialize};

use crate::bitmask::BitMask;

/// Which components of the object mask to keep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KeepComponents {
    /// Only the largest.
    Largest,
    /// Every component of at least this many pixels (an occluded catheter can fall apart).
    MinArea(usize),
}

/// A horizontal run of set pixels `[x0, x1)` on row `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Row.
    pub y: u32,
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
}

/// All runs of a mask, row by row, left to right.
pub fn runs(mask: &BitMask) -> Vec<Run> {
    let mut out = Vec::new();
    for y in 0..mask.height() {
        let row = mask.row(y);
        // A tracker's masks are empty but for a band around the tube.
        if row.iter().all(|&w| w == 0) {
            continue;
        }
        let mut open: Option<u32> = None;
        for (i, &w) in row.iter().enumerate() {
            if w == 0 && open.is_none() {
                continue;
            }
            let base = (i * 64) as u32;
            let mut pos = 0u32;
            // Walk alternating stretches of ones and zeros in this word.
            while pos < 64 {
                if open.is_none() {
                    let skip = (w >> pos).trailing_zeros().min(64 - pos);
                    pos += skip;
                    if pos >= 64 {
                        break;
                    }
                    open = Some(base + pos);
                } else {
                    let ones = (!(w >> pos)).trailing_zeros().min(64 - pos);
                    pos += ones;
                    if pos >= 64 {
                        break;
                    }
                    if let Some(x0) = open.take() {
                        out.push(Run {
                            y: y as u32,
                            x0,
                            x1: base + pos,
                        });
                    }
                }
            }
        }
        if let Some(x0) = open {
            out.push(Run {
                y: y as u32,
                x0,
                x1: mask.width() as u32,
            });
        }
    }
    out
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Labels of the runs' components, 8-connected (an index per run; equal labels = same
/// component) and each label's area in pixels.
pub fn label(runs: &[Run]) -> (Vec<usize>, Vec<usize>) {
    label_with(runs, true)
}

/// [`label`], with runs of consecutive rows that meet only at a corner joined when
/// `diagonal` (8-connected) and apart when not (4-connected: the background between the
/// pixels of an 8-connected object).
pub(crate) fn label_with(runs: &[Run], diagonal: bool) -> (Vec<usize>, Vec<usize>) {
    let mut parent: Vec<usize> = (0..runs.len()).collect();
    // Runs of consecutive rows touch when their column ranges overlap (or, 8-connected, meet
    // diagonally); both rows are sorted, so one sweep finds every pair.
    let reach = u32::from(diagonal);
    let mut start = 0;
    for i in 0..runs.len() {
        let r = runs[i];
        while start < runs.len()
            && (runs[start].y + 1 < r.y || (runs[start].y + 1 == r.y && runs[start].x1 < r.x0))
        {
            start += 1;
        }
        let mut j = start;
        while j < i && runs[j].y + 1 == r.y {
            let p = runs[j];
            if p.x0 < r.x1 + reach && r.x0 < p.x1 + reach {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
            j += 1;
        }
    }
    let mut labels = vec![0; runs.len()];
    let mut ids = vec![usize::MAX; runs.len()];
    let mut areas = Vec::new();
    for i in 0..runs.len() {
        let root = find(&mut parent, i);
        if ids[root] == usize::MAX {
            ids[root] = areas.len();
            areas.push(0);
        }
        labels[i] = ids[root];
        areas[ids[root]] += (runs[i].x1 - runs[i].x0) as usize;
    }
    (labels, areas)
}

/// The mask restricted to the components chosen by `keep`, and how many were kept.
pub fn keep_components(mask: &BitMask, keep: KeepComponents) -> (BitMask, usize) {
    let runs = runs(mask);
    let (labels, areas) = label(&runs);
    let wanted: Vec<bool> = match keep {
        KeepComponents::Largest => {
            let best = areas
                .iter()
                .enumerate()
                .max_by_key(|(_, a)| **a)
                .map(|(i, _)| i);
            (0..areas.len()).map(|i| Some(i) == best).collect()
        }
        KeepComponents::MinArea(min) => areas.iter().map(|&a| a >= min).collect(),
    };
    let mut out = BitMask::new(mask.width(), mask.height());
    for (r, l) in runs.iter().zip(labels) {
        if wanted[l] {
            fill_run(&mut out, r);
        }
    }
    (out, wanted.iter().filter(|&&w| w).count())
}

/// The components of `mask` that share a pixel with `seeds` (same size).
pub fn touching(mask: &BitMask, seeds: &BitMask) -> BitMask {
    let runs = runs(mask);
    let (labels, areas) = label(&runs);
    let mut wanted = vec![false; areas.len()];
    for (r, &l) in runs.iter().zip(&labels) {
        if !wanted[l] && (r.x0..r.x1).any(|x| seeds.get(x as usize, r.y as usize)) {
            wanted[l] = true;
        }
    }
    let mut out = BitMask::new(mask.width(), mask.height());
    for (r, l) in runs.iter().zip(labels) {
        if wanted[l] {
            fill_run(&mut out, r);
        }
    }
    out
}

/// Sets the pixels of a run.
pub(crate) fn fill_run(mask: &mut BitMask, r: &Run) {
    let row = mask.row_mut(r.y as usize);
    let (x0, x1) = (r.x0 as usize, r.x1 as usize);
    let (w0, w1) = (x0 / 64, (x1 - 1) / 64);
    for (w, word) in row.iter_mut().enumerate().take(w1 + 1).skip(w0) {
        let lo = if w == w0 { x0 % 64 } else { 0 };
        let hi = if w == w1 { (x1 - 1) % 64 + 1 } else { 64 };
        let bits = if hi - lo == 64 {
            u64::MAX
        } else {
            ((1u64 << (hi - lo)) - 1) << lo
        };
        *word |= bits;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn touching_keeps_the_components_a_seed_meets() {
        let mut m = BitMask::new(70, 4);
        m.set_span(0, 0, 2); // A: two rows, diagonal contact
        m.set_span(1, 3, 5);
        m.set_span(2, 66, 69); // B, across a word boundary
        m.set_span(3, 63, 66);
        let mut seeds = BitMask::new(70, 4);
        seeds.set(64, 3, true);
        let t = touching(&m, &seeds);
        assert_eq!(t.count(), 8);
        assert!(t.get(67, 2) && !t.get(1, 0));
        seeds.set(4, 1, true);
        assert_eq!(touching(&m, &seeds), m);
        assert_eq!(touching(&m, &BitMask::new(70, 4)).count(), 0);
    }

    fn flood_areas(m: &BitMask) -> Vec<usize> {
        let (w, h) = (m.width(), m.height());
        let mut seen = vec![false; w * h];
        let mut areas = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if !m.get(x, y) || seen[y * w + x] {
                    continue;
                }
                let mut stack = vec![(x, y)];
                seen[y * w + x] = true;
                let mut area = 0;
                while let Some((cx, cy)) = stack.pop() {
                    area += 1;
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                                continue;
                            }
                            let (nx, ny) = (nx as usize, ny as usize);
                            if m.get(nx, ny) && !seen[ny * w + nx] {
                                seen[ny * w + nx] = true;
                                stack.push((nx, ny));
                            }
                        }
                    }
                }
                areas.push(area);
            }
        }
        areas.sort();
        areas
    }

    proptest! {
        #[test]
        fn labels_match_a_flood_fill(w in 1usize..140, h in 1usize..25, density in 1u64..8, seed in any::<u64>()) {
            let m = crate::bitmask::random_mask(w, h, 2 * density, seed);
            let rs = runs(&m);
            let mut rebuilt = BitMask::new(w, h);
            for r in &rs {
                fill_run(&mut rebuilt, r);
            }
            prop_assert_eq!(&rebuilt, &m);
            let (_, mut areas) = label(&rs);
            areas.sort();
            prop_assert_eq!(areas, flood_areas(&m));
        }

        /// A tracker's masks: empty rows and empty words around a band (runs skips them).
        #[test]
        fn runs_rebuild_masks_set_only_in_a_band(w in 1usize..300, h in 1usize..40, x in 0usize..300, width in 0usize..150, y in 0usize..40, rows in 0usize..40, seed in any::<u64>()) {
            let m = crate::bitmask::random_mask(w, h, 2, seed);
            let mut band = BitMask::new(w, h);
            for yy in y.min(h)..(y + rows).min(h) {
                if x < w && width > 0 {
                    band.set_span(yy, x, (x + width - 1).min(w - 1));
                }
            }
            let m = m.and(&band);
            let mut rebuilt = BitMask::new(w, h);
            for r in &runs(&m) {
                fill_run(&mut rebuilt, r);
            }
            prop_assert_eq!(&rebuilt, &m);
        }
    }

    #[test]
    fn keeps_largest_or_big_enough() {
        let mut m = BitMask::new(100, 10);
        for x in 0..30 {
            m.set(x, 2, true);
        }
        for x in 50..60 {
            m.set(x, 5, true);
        }
        m.set(90, 9, true);
        let count = |k| {
            let (mask, n) = keep_components(&m, k);
            (mask.count(), n)
        };
        assert_eq!(count(KeepComponents::Largest), (30, 1));
        assert_eq!(count(KeepComponents::MinArea(5)), (40, 2));
        assert_eq!(count(KeepComponents::MinArea(1)), (41, 3));
    }
}
