//! The tube's image centerline in one camera: the longest path through the silhouette's largest
//! component (chamfer distances, 8-connected), recentred across the tube and smoothed.
//!
//! The longest geodesic path runs from the tip's cap to where the tube leaves the image (or to
//! its other end); it hugs the inside of bends, so each point is moved to the middle of the
//! silhouette's cross-section along the path's normal. A tube that crosses itself in the image
//! gives a path that takes a short cut at the crossing: the two-view start then finds no match
//! that explains the images and the frame starts from the hull.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use flexshape_silhouette::BitMask;
use flexshape_silhouette::components::{self, Run};
use nalgebra::Vector2;

/// The centerline of a tube's image, pixels (OpenCV convention), from one end to the other.
#[derive(Debug, Clone)]
pub(crate) struct ImageCurve {
    /// Points about `spacing` apart.
    pub points: Vec<Vector2<f64>>,
    /// Median width of the silhouette across the curve, pixels.
    pub width_px: f64,
    /// Whether each end (first, last) lies on the image's border: the tube leaves the view
    /// there.
    pub at_border: [bool; 2],
}

/// Chamfer steps: 2 along a row or column, 3 diagonally (≈ 1 : √2).
const STEPS: [(i32, i32, u32); 8] = [
    (1, 0, 2),
    (-1, 0, 2),
    (0, 1, 2),
    (0, -1, 2),
    (1, 1, 3),
    (1, -1, 3),
    (-1, 1, 3),
    (-1, -1, 3),
];

/// Widest cross-section searched, pixels.
const MAX_WIDTH_PX: f64 = 200.0;

/// The image centerline of `mask`'s largest component, points `spacing_px` apart, or `None`
/// when the mask is empty or its largest component is too short for a tube (under 4 widths).
pub(crate) fn image_curve(mask: &BitMask, spacing_px: f64) -> Option<ImageCurve> {
    let (w, h) = (mask.width(), mask.height());
    let component = Component::largest(mask)?;
    let (dist, _) = component.geodesic(0);
    let far = farthest(&dist)?;
    let (dist, from) = component.geodesic(far);
    let other = farthest(&dist)?;
    let mut pixels = vec![other];
    let mut at = other;
    while at != far {
        at = from[at] as usize;
        pixels.push(at);
    }
    let raw: Vec<Vector2<f64>> = pixels
        .iter()
        .map(|&i| {
            let (x, y) = component.pixels[i];
            Vector2::new(x as f64, y as f64)
        })
        .collect();
    let coarse = resample(&raw, spacing_px)?;
    let (centred, widths) = recentre(mask, &coarse, spacing_px);
    let smooth = moving_average(&centred, 2);
    let points = resample(&smooth, spacing_px)?;
    let mut sorted = widths;
    sorted.sort_by(f64::total_cmp);
    let width_px = sorted[sorted.len() / 2];
    let length: f64 = points.windows(2).map(|p| (p[1] - p[0]).norm()).sum();
    if points.len() < 4 || length < 4.0 * width_px {
        return None;
    }
    let border =
        |p: &Vector2<f64>| p.x < 2.5 || p.y < 2.5 || p.x > w as f64 - 3.5 || p.y > h as f64 - 3.5;
    let ends = [raw[0], raw[raw.len() - 1]];
    Some(ImageCurve {
        at_border: ends.map(|p| border(&p)),
        points,
        width_px,
    })
}

/// One 8-connected component of a mask, its pixels numbered in row-major order: the paths
/// are searched over them alone (a 2500 × 2500 mask's full-image distance tables cost more
/// than the search, most of it the kernel zeroing fresh pages).
struct Component {
    /// Each pixel's column and row.
    pixels: Vec<(u32, u32)>,
    /// The component's runs, row by row, each with the number of its first pixel.
    runs: Vec<(Run, u32)>,
    /// The first row, and per row from it the range of `runs` on it.
    first_row: u32,
    rows: Vec<std::ops::Range<usize>>,
}

impl Component {
    /// The largest component of `mask` (the first found of equal ones), `None` for an empty
    /// mask.
    fn largest(mask: &BitMask) -> Option<Self> {
        let all = components::runs(mask);
        let (labels, areas) = components::label(&all);
        let best = (0..areas.len()).fold(None, |best: Option<usize>, l| match best {
            Some(b) if areas[b] >= areas[l] => Some(b),
            _ => Some(l),
        })?;
        let mut runs = Vec::new();
        let mut pixels = Vec::new();
        for (run, _) in all.iter().zip(&labels).filter(|(_, l)| **l == best) {
            runs.push((*run, pixels.len() as u32));
            pixels.extend((run.x0..run.x1).map(|x| (x, run.y)));
        }
        let first_row = runs.first()?.0.y;
        let last_row = runs.last()?.0.y;
        let mut rows = vec![0..0; (last_row - first_row + 1) as usize];
        let mut k = 0;
        for (r, range) in rows.iter_mut().enumerate() {
            let y = first_row + r as u32;
            let start = k;
            while k < runs.len() && runs[k].0.y == y {
                k += 1;
            }
            *range = start..k;
        }
        Some(Component {
            pixels,
            runs,
            first_row,
            rows,
        })
    }

    /// The number of the component's pixel at column `x`, row `y`, if it is one.
    fn at(&self, x: i64, y: i64) -> Option<usize> {
        let r = usize::try_from(y - i64::from(self.first_row)).ok()?;
        let runs = &self.runs[self.rows.get(r)?.clone()];
        let x = u32::try_from(x).ok()?;
        runs.iter()
            .find(|(run, _)| run.x0 <= x && x < run.x1)
            .map(|(run, first)| (first + (x - run.x0)) as usize)
    }

    /// The neighbours of pixel `i` in the component and the chamfer step to each.
    fn neighbours(&self, i: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (x, y) = self.pixels[i];
        STEPS.iter().filter_map(move |&(dx, dy, c)| {
            self.at(i64::from(x) + i64::from(dx), i64::from(y) + i64::from(dy))
                .map(|j| (j, c))
        })
    }

    /// Chamfer distances from pixel `source` to every pixel, and each pixel's predecessor on a
    /// shortest path.
    fn geodesic(&self, source: usize) -> (Vec<u32>, Vec<u32>) {
        let n = self.pixels.len();
        let mut dist = vec![u32::MAX; n];
        let mut from = vec![u32::MAX; n];
        let mut heap = BinaryHeap::new();
        dist[source] = 0;
        heap.push(Reverse((0u32, source)));
        while let Some(Reverse((d, i))) = heap.pop() {
            if d > dist[i] {
                continue;
            }
            for (j, c) in self.neighbours(i) {
                if d + c < dist[j] {
                    dist[j] = d + c;
                    from[j] = i as u32;
                    heap.push(Reverse((d + c, j)));
                }
            }
        }
        (dist, from)
    }
}

/// The reached pixel farthest from the source (the last of equally far ones).
fn farthest(dist: &[u32]) -> Option<usize> {
    dist.iter()
        .enumerate()
        .filter(|&(_, &d)| d != u32::MAX)
        .max_by_key(|&(_, &d)| d)
        .map(|(i, _)| i)
}

/// Points `step` apart along the polyline through `points` (its ends kept).
fn resample(points: &[Vector2<f64>], step: f64) -> Option<Vec<Vector2<f64>>> {
    let mut arcs = vec![0.0];
    for p in points.windows(2) {
        arcs.push(arcs[arcs.len() - 1] + (p[1] - p[0]).norm());
    }
    let length = arcs[arcs.len() - 1];
    if length < step {
        return None;
    }
    let n = (length / step).round().max(1.0) as usize;
    let mut out = Vec::with_capacity(n + 1);
    let mut k = 0;
    for i in 0..=n {
        let s = length * i as f64 / n as f64;
        while k + 2 < arcs.len() && arcs[k + 1] < s {
            k += 1;
        }
        let span = (arcs[k + 1] - arcs[k]).max(1e-12);
        let t = ((s - arcs[k]) / span).clamp(0.0, 1.0);
        out.push(points[k] + (points[k + 1] - points[k]) * t);
    }
    Some(out)
}

/// Each point moved to the middle of the silhouette's cross-section along the curve's normal,
/// and the cross-sections' widths (pixels). Points whose cross-section is not closed within
/// [`MAX_WIDTH_PX`] stay where they are.
fn recentre(
    mask: &BitMask,
    points: &[Vector2<f64>],
    spacing: f64,
) -> (Vec<Vector2<f64>>, Vec<f64>) {
    let reach = ((6.0 / spacing).ceil() as usize).max(1);
    let inside = |p: Vector2<f64>| mask.at(p.x, p.y);
    // Distance from `p` along `d` to the last object sample, in 0.5-px steps.
    let extent = |p: Vector2<f64>, d: Vector2<f64>| {
        let mut s = 0.0;
        while s < MAX_WIDTH_PX && inside(p + d * (s + 0.5)) {
            s += 0.5;
        }
        (s < MAX_WIDTH_PX).then_some(s + 0.25)
    };
    let mut centred = Vec::with_capacity(points.len());
    let mut widths = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let a = points[i.saturating_sub(reach)];
        let b = points[(i + reach).min(points.len() - 1)];
        let t = b - a;
        let normal = Vector2::new(-t.y, t.x) / t.norm().max(1e-12);
        match (extent(p, normal), extent(p, -normal)) {
            (Some(plus), Some(minus)) if inside(p) => {
                centred.push(p + normal * (plus - minus) / 2.0);
                widths.push(plus + minus);
            }
            _ => centred.push(p),
        }
    }
    if widths.is_empty() {
        widths.push(1.0);
    }
    (centred, widths)
}

/// Each point averaged with up to `half` neighbours on either side (fewer near the ends, which
/// stay put).
fn moving_average(points: &[Vector2<f64>], half: usize) -> Vec<Vector2<f64>> {
    let n = points.len();
    (0..n)
        .map(|i| {
            let k = half.min(i).min(n - 1 - i);
            let window = &points[i - k..=i + k];
            window.iter().sum::<Vector2<f64>>() / window.len() as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thick arc of radius 150 px drawn into a mask, and its true centre line.
    fn arc_mask() -> (BitMask, impl Fn(Vector2<f64>) -> f64) {
        let (w, h) = (400, 300);
        let centre = Vector2::new(50.0, 320.0);
        let (r, half) = (200.0, 5.0);
        let mut m = BitMask::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let d = (Vector2::new(x as f64, y as f64) - centre).norm();
                let angle = (y as f64 - centre.y).atan2(x as f64 - centre.x);
                if (d - r).abs() <= half && angle < -0.7 {
                    m.set(x, y, true);
                }
            }
        }
        (m, move |p: Vector2<f64>| (p - centre).norm() - r)
    }

    #[test]
    fn follows_the_middle_of_a_bent_band_from_end_to_end() {
        let (mask, off_centre) = arc_mask();
        let curve = image_curve(&mask, 2.0).unwrap();
        // Away from the ends, on the middle of the 11-px band.
        let inner = &curve.points[5..curve.points.len() - 5];
        let worst = inner
            .iter()
            .map(|&p| off_centre(p).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.6, "{worst:.2} px off the centre line");
        assert!((curve.width_px - 11.0).abs() < 1.5, "{}", curve.width_px);
        // The arc leaves the image at its left edge, at one end only.
        assert_eq!(
            curve.at_border.iter().filter(|&&b| b).count(),
            1,
            "{:?}",
            curve.at_border
        );
        let length: f64 = curve.points.windows(2).map(|p| (p[1] - p[0]).norm()).sum();
        assert!(length > 200.0, "{length}");
    }

    #[test]
    fn an_empty_or_tiny_mask_has_no_curve() {
        assert!(image_curve(&BitMask::new(50, 40), 2.0).is_none());
        let mut m = BitMask::new(50, 40);
        for y in 10..16 {
            for x in 10..16 {
                m.set(x, y, true);
            }
        }
        assert!(image_curve(&m, 2.0).is_none());
    }
}
