//! Binary images packed 64 pixels to a word, with square-window morphology done by word shifts.

use image::GrayImage;

/// A binary image; bit `x % 64` of word `x / 64` of row `y` is pixel `(x, y)`. Bits past the
/// width are always zero.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BitMask {
    width: usize,
    height: usize,
    stride: usize,
    words: Vec<u64>,
}

impl BitMask {
    /// An all-zero mask.
    pub fn new(width: usize, height: usize) -> Self {
        let stride = width.div_ceil(64);
        BitMask {
            width,
            height,
            stride,
            words: vec![0; stride * height],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Words per row.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// All words, row after row (`stride` words a row). Pixel `(x, y)` is bit `a % 64` of
    /// word `a / 64` with the bit address `a = 64·stride·y + x`.
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    /// Bit address of pixel `(x, y)` (see [`BitMask::words`]).
    pub fn bit_address(&self, x: usize, y: usize) -> usize {
        64 * self.stride * y + x
    }

    /// Row `y` as words.
    pub fn row(&self, y: usize) -> &[u64] {
        &self.words[y * self.stride..(y + 1) * self.stride]
    }

    /// Row `y` as words, mutable. Callers keep the bits past the width zero.
    pub fn row_mut(&mut self, y: usize) -> &mut [u64] {
        &mut self.words[y * self.stride..(y + 1) * self.stride]
    }

    /// Pixel value.
    pub fn get(&self, x: usize, y: usize) -> bool {
        self.words[y * self.stride + x / 64] >> (x % 64) & 1 == 1
    }

    /// The value of the pixel whose centre is nearest the point `(x, y)`, pixels ((0, 0) is
    /// the centre of the top-left pixel); `false` outside the mask (or for a NaN).
    pub fn at(&self, x: f64, y: f64) -> bool {
        let (x, y) = (x.round(), y.round());
        x >= 0.0
            && y >= 0.0
            && (x as usize) < self.width
            && (y as usize) < self.height
            && self.get(x as usize, y as usize)
    }

    /// Sets a pixel.
    pub fn set(&mut self, x: usize, y: usize, v: bool) {
        let w = &mut self.words[y * self.stride + x / 64];
        if v {
            *w |= 1 << (x % 64);
        } else {
            *w &= !(1 << (x % 64));
        }
    }

    /// Sets pixels `x0..=x1` of row `y` (clipped to the width), a word at a time.
    pub fn set_span(&mut self, y: usize, x0: usize, x1: usize) {
        let x1 = x1.min(self.width.saturating_sub(1));
        if x0 > x1 || y >= self.height {
            return;
        }
        let row = &mut self.words[y * self.stride..(y + 1) * self.stride];
        let (w0, w1) = (x0 / 64, x1 / 64);
        let from = u64::MAX << (x0 % 64);
        let to = u64::MAX >> (63 - x1 % 64);
        if w0 == w1 {
            row[w0] |= from & to;
            return;
        }
        row[w0] |= from;
        for w in &mut row[w0 + 1..w1] {
            *w = u64::MAX;
        }
        row[w1] |= to;
    }

    /// Number of set pixels.
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Mask of the valid bits of a row's last word.
    fn tail_mask(&self) -> u64 {
        match self.width % 64 {
            0 => u64::MAX,
            r => (1u64 << r) - 1,
        }
    }

    /// 255 where set, 0 elsewhere.
    pub fn to_gray(&self) -> GrayImage {
        GrayImage::from_fn(self.width as u32, self.height as u32, |x, y| {
            image::Luma([if self.get(x as usize, y as usize) {
                255
            } else {
                0
            }])
        })
    }

    /// Set where the grey value is at least 128.
    pub fn from_gray(img: &GrayImage) -> Self {
        let mut m = BitMask::new(img.width() as usize, img.height() as usize);
        for (x, y, p) in img.enumerate_pixels() {
            if p[0] >= 128 {
                m.set(x as usize, y as usize, true);
            }
        }
        m
    }

    /// Pixel-wise OR.
    pub fn or(&self, o: &BitMask) -> BitMask {
        self.zip(o, |a, b| a | b)
    }

    /// Pixel-wise AND.
    pub fn and(&self, o: &BitMask) -> BitMask {
        self.zip(o, |a, b| a & b)
    }

    /// Set here and not in `o` (`self AND NOT o`).
    pub fn and_not(&self, o: &BitMask) -> BitMask {
        self.zip(o, |a, b| a & !b)
    }

    fn zip(&self, o: &BitMask, f: impl Fn(u64, u64) -> u64) -> BitMask {
        debug_assert_eq!((self.width, self.height), (o.width, o.height));
        BitMask {
            words: self
                .words
                .iter()
                .zip(&o.words)
                .map(|(&a, &b)| f(a, b))
                .collect(),
            ..*self
        }
    }

    /// Complement (within the image).
    pub fn not(&self) -> BitMask {
        let tail = self.tail_mask();
        let mut m = BitMask {
            words: self.words.iter().map(|w| !w).collect(),
            ..*self
        };
        for y in 0..m.height {
            let last = (y + 1) * m.stride - 1;
            m.words[last] &= tail;
        }
        m
    }

    /// Dilation by the square window of side `2r + 1` (outside the image counts as unset).
    /// Empty rows cost next to nothing: a tracker's mask is empty but for a band of rows.
    pub fn dilate(&self, r: usize) -> BitMask {
        if r == 0 || self.words.is_empty() {
            return self.clone();
        }
        let r = r.min(63) as u32;
        let stride = self.stride;
        let tail = self.tail_mask();
        // Horizontal pass: pixel x takes x ± k for k ≤ r, with bits carried across words.
        let mut horizontal = vec![0u64; self.words.len()];
        // busy[y + 1] − busy[y − 2r]: non-empty rows among y − 2r … y (prefix counts).
        let mut busy = vec![0usize; self.height + 1];
        for (y, (src, dst)) in self
            .words
            .chunks_exact(stride)
            .zip(horizontal.chunks_exact_mut(stride))
            .enumerate()
        {
            let full = src.iter().any(|&w| w != 0);
            busy[y + 1] = busy[y] + usize::from(full);
            if !full {
                continue;
            }
            for i in 0..stride {
                let cur = src[i];
                let prev = if i > 0 { src[i - 1] } else { 0 };
                let next = if i + 1 < stride { src[i + 1] } else { 0 };
                dst[i] = if r == 1 {
                    cur | (cur >> 1) | (next << 63) | (cur << 1) | (prev >> 63)
                } else {
                    (1..=r).fold(cur, |acc, k| {
                        acc | (cur >> k) | (next << (64 - k)) | (cur << k) | (prev >> (64 - k))
                    })
                };
            }
            dst[stride - 1] &= tail;
        }
        // Vertical pass: OR of the non-empty rows within r.
        let r = r as usize;
        let mut words = vec![0u64; self.words.len()];
        for y in 0..self.height {
            let (lo, hi) = (y.saturating_sub(r), (y + r).min(self.height - 1));
            if busy[hi + 1] == busy[lo] {
                continue;
            }
            let dst = &mut words[y * stride..(y + 1) * stride];
            for yy in lo..=hi {
                if busy[yy + 1] == busy[yy] {
                    continue;
                }
                let src = &horizontal[yy * stride..(yy + 1) * stride];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d |= s;
                }
            }
        }
        BitMask { words, ..*self }
    }

    /// Erosion by the square window of side `2r + 1`; outside the image counts as set, so the
    /// border does not eat into objects touching it. (The dual of [`BitMask::dilate`], done
    /// directly so that empty rows are skipped: their erosion is empty.)
    pub fn erode(&self, r: usize) -> BitMask {
        if r == 0 || self.words.is_empty() {
            return self.clone();
        }
        let stride = self.stride;
        let tail = self.tail_mask();
        let r = r.min(63);
        let mut words = vec![0u64; self.words.len()];
        let mut column = vec![0u64; stride];
        for y in 0..self.height {
            if self.row(y).iter().all(|&w| w == 0) {
                continue;
            }
            // Vertical pass: AND of the rows within r (rows beyond the image count as set).
            column.copy_from_slice(self.row(y));
            for yy in y.saturating_sub(r)..=(y + r).min(self.height - 1) {
                for (c, s) in column.iter_mut().zip(self.row(yy)) {
                    *c &= s;
                }
            }
            // Bits past the width count as set.
            column[stride - 1] |= !tail;
            // Horizontal pass: pixel x keeps its bit only if x ± k are set for every k ≤ r.
            let dst = &mut words[y * stride..(y + 1) * stride];
            for i in 0..stride {
                let cur = column[i];
                if cur == 0 {
                    continue;
                }
                let prev = if i > 0 { column[i - 1] } else { u64::MAX };
                let next = if i + 1 < stride {
                    column[i + 1]
                } else {
                    u64::MAX
                };
                dst[i] = (1..=r as u32).fold(cur, |acc, k| {
                    acc & ((cur >> k) | (next << (64 - k))) & ((cur << k) | (prev >> (64 - k)))
                });
            }
            dst[stride - 1] &= tail;
        }
        BitMask { words, ..*self }
    }

    /// Closing (dilation then erosion): fills gaps narrower than `2r + 1` without moving
    /// straight boundaries.
    pub fn close(&self, r: usize) -> BitMask {
        self.dilate(r).erode(r)
    }

    /// Intersection over union with another mask of the same size (1 when both are empty).
    pub fn iou(&self, o: &BitMask) -> f64 {
        let inter = self.and(o).count();
        let union = self.or(o).count();
        if union == 0 {
            1.0
        } else {
            inter as f64 / union as f64
        }
    }
}

/// A reproducible random mask for tests: each pixel set with probability `density / 16`.
#[cfg(test)]
pub(crate) fn random_mask(w: usize, h: usize, density: u64, seed: u64) -> BitMask {
    let mut m = BitMask::new(w, h);
    let mut s = seed;
    for y in 0..h {
        for x in 0..w {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            m.set(x, y, (s >> 60) < density);
        }
    }
    m
}

#[cfg(test)]
mod tests {

    #[test]
    fn spans_set_the_same_pixels_as_one_at_a_time() {
        for (x0, x1) in [
            (0, 0),
            (3, 63),
            (63, 64),
            (10, 140),
            (64, 127),
            (0, 199),
            (150, 400),
        ] {
            let mut a = BitMask::new(200, 3);
            a.set_span(1, x0, x1);
            let mut b = BitMask::new(200, 3);
            for x in x0..=x1.min(199) {
                b.set(x, 1, true);
            }
            assert_eq!(a, b, "{x0}..={x1}");
        }
        let mut empty = BitMask::new(200, 3);
        empty.set_span(1, 5, 4);
        empty.set_span(3, 0, 10);
        assert_eq!(empty.count(), 0);
    }

    use super::*;
    use proptest::prelude::*;

    fn naive_dilate(m: &BitMask, r: usize) -> BitMask {
        let mut out = BitMask::new(m.width(), m.height());
        for y in 0..m.height() {
            for x in 0..m.width() {
                let mut v = false;
                for yy in y.saturating_sub(r)..=(y + r).min(m.height() - 1) {
                    for xx in x.saturating_sub(r)..=(x + r).min(m.width() - 1) {
                        v |= m.get(xx, yy);
                    }
                }
                out.set(x, y, v);
            }
        }
        out
    }

    proptest! {
        #[test]
        fn dilation_matches_the_definition(w in 1usize..150, h in 1usize..20, r in 0usize..4, seed in any::<u64>()) {
            let m = random_mask(w, h, 1, seed);
            prop_assert_eq!(m.dilate(r), naive_dilate(&m, r));
            // Erosion is the dual with the outside counted as set.
            let e = m.erode(r);
            prop_assert_eq!(e.not(), naive_dilate(&m.not(), r));
        }

        #[test]
        fn morphology_of_a_band_of_rows_matches_the_definition(w in 1usize..150, h in 1usize..40, r in 0usize..4, seed in any::<u64>(), band in (0usize..40, 0usize..40)) {
            // Dense inside a band of rows, empty elsewhere (a tracker's mask).
            let mut m = random_mask(w, h, 12, seed);
            for y in 0..h {
                if y < band.0.min(band.1) || y > band.0.max(band.1) {
                    m.row_mut(y).fill(0);
                }
            }
            prop_assert_eq!(m.dilate(r), naive_dilate(&m, r));
            prop_assert_eq!(m.erode(r).not(), naive_dilate(&m.not(), r));
        }
    }

    #[test]
    fn a_point_reads_the_pixel_whose_centre_is_nearest() {
        let mut m = BitMask::new(3, 2);
        m.set(2, 1, true);
        assert!(m.at(2.0, 1.0) && m.at(1.6, 0.6) && m.at(2.49, 1.49));
        assert!(!m.at(1.4, 1.0) && !m.at(2.0, 0.4));
        // Outside the mask, or no point at all.
        for (x, y) in [
            (2.6, 1.0),
            (2.0, 1.6),
            (-0.6, 0.0),
            (f64::NAN, 1.0),
            (f64::INFINITY, 1.0),
        ] {
            assert!(!m.at(x, y), "({x}, {y})");
        }
    }

    #[test]
    fn closing_fills_a_one_pixel_gap_and_keeps_edges() {
        let mut m = BitMask::new(70, 10);
        for y in 2..8 {
            for x in 10..66 {
                m.set(x, y, x != 40);
            }
        }
        let c = m.close(1);
        assert!(c.get(40, 5));
        assert!(!c.get(9, 5) && c.get(10, 5) && c.get(65, 5) && !c.get(66, 5));
        assert!(!c.get(20, 1) && c.get(20, 2) && c.get(20, 7) && !c.get(20, 8));
        assert_eq!(c.count(), 56 * 6);
    }
}
