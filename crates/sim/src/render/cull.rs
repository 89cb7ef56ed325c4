//! Conservative 2-D bounds and a small index to find the primitives that can touch a tile.

/// An axis-aligned rectangle in a 2-D parameter plane (normalized image coordinates or backdrop
/// coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Rect {
    pub min: [f64; 2],
    pub max: [f64; 2],
}

impl Rect {
    /// Covers the whole plane (used when a bound cannot be computed).
    pub const EVERYTHING: Rect = Rect {
        min: [f64::NEG_INFINITY; 2],
        max: [f64::INFINITY; 2],
    };
    /// Covers nothing; the identity of [`Rect::union`].
    pub const EMPTY: Rect = Rect {
        min: [f64::INFINITY; 2],
        max: [f64::NEG_INFINITY; 2],
    };

    pub fn include(&mut self, p: [f64; 2]) {
        for (a, v) in p.into_iter().enumerate() {
            self.min[a] = self.min[a].min(v);
            self.max[a] = self.max[a].max(v);
        }
    }

    pub fn union(&self, o: &Rect) -> Rect {
        Rect {
            min: [self.min[0].min(o.min[0]), self.min[1].min(o.min[1])],
            max: [self.max[0].max(o.max[0]), self.max[1].max(o.max[1])],
        }
    }

    pub fn overlaps(&self, o: &Rect) -> bool {
        self.min[0] <= o.max[0]
            && o.min[0] <= self.max[0]
            && self.min[1] <= o.max[1]
            && o.min[1] <= self.max[1]
    }

    /// Bound of the central projection of a convex set given by its vertices: a perspective
    /// map takes segments to segments when every vertex is in front, so the image of the convex
    /// hull is the hull of the vertex images. `project` returns `None` for a vertex that is not
    /// in front; then no bound is known.
    pub fn of_projected<const N: usize>(
        vertices: [[f64; 3]; N],
        project: impl Fn([f64; 3]) -> Option<[f64; 2]>,
    ) -> Rect {
        let mut r = Rect::EMPTY;
        for v in vertices {
            match project(v) {
                Some(p) => r.include(p),
                None => return Rect::EVERYTHING,
            }
        }
        r
    }
}

/// The 8 corners of the axis-aligned box around segment `a → b` grown by `pad`.
pub(crate) fn box_corners(a: [f64; 3], b: [f64; 3], pad: f64) -> [[f64; 3]; 8] {
    let lo = [
        a[0].min(b[0]) - pad,
        a[1].min(b[1]) - pad,
        a[2].min(b[2]) - pad,
    ];
    let hi = [
        a[0].max(b[0]) + pad,
        a[1].max(b[1]) + pad,
        a[2].max(b[2]) + pad,
    ];
    std::array::from_fn(|n| {
        [
            if n & 1 == 0 { lo[0] } else { hi[0] },
            if n & 2 == 0 { lo[1] } else { hi[1] },
            if n & 4 == 0 { lo[2] } else { hi[2] },
        ]
    })
}

const CHUNK: usize = 16;

/// Rectangles grouped in chunks of consecutive items (neighbouring capsules of a tube are
/// neighbours in space), each chunk with its union, for quick rejection.
#[derive(Debug, Default)]
pub(crate) struct RectIndex {
    rects: Vec<Rect>,
    chunks: Vec<Rect>,
}

impl RectIndex {
    pub fn new(rects: Vec<Rect>) -> Self {
        let chunks = rects
            .chunks(CHUNK)
            .map(|c| c.iter().fold(Rect::EMPTY, |u, r| u.union(r)))
            .collect();
        RectIndex { rects, chunks }
    }

    pub fn is_empty(&self) -> bool {
        self.rects.is_empty()
    }

    /// Rectangle `i`.
    pub fn rect(&self, i: usize) -> &Rect {
        &self.rects[i]
    }

    /// Appends to `out` the indices of all rectangles overlapping `query`.
    pub fn query(&self, query: &Rect, out: &mut Vec<usize>) {
        for (c, chunk) in self.chunks.iter().enumerate() {
            if !chunk.overlaps(query) {
                continue;
            }
            let start = c * CHUNK;
            let end = (start + CHUNK).min(self.rects.len());
            out.extend((start..end).filter(|&i| self.rects[i].overlaps(query)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_finds_exactly_the_overlapping_rects() {
        let rects: Vec<Rect> = (0..40)
            .map(|i| {
                let x = i as f64;
                Rect {
                    min: [x, 0.0],
                    max: [x + 0.5, 1.0],
                }
            })
            .collect();
        let index = RectIndex::new(rects);
        let mut out = Vec::new();
        index.query(
            &Rect {
                min: [9.7, 0.5],
                max: [17.2, 0.6],
            },
            &mut out,
        );
        assert_eq!(out, (10..=17).collect::<Vec<_>>());
        out.clear();
        index.query(
            &Rect {
                min: [9.7, 2.0],
                max: [17.2, 3.0],
            },
            &mut out,
        );
        assert!(out.is_empty());
    }
}
