//! Sub-pixel silhouette boundaries measured in the image itself: where, along a line across
//! the tube's predicted outline, the pixels turn from the background model's colour to the
//! tube's.
//!
//! A pixel that the boundary crosses mixes the two colours, `I = c·S + (1 − c)·E` (`E` the
//! background, `S` the surface, `c` the covered share), so `c = (I − E)·(S − E) / ‖S − E‖²`
//! is linear in the coverage whatever the colours are; the boundary is where `c` crosses ½
//! (the truth masks' convention: the pixel centre's ray grazes the tube). Colours are sampled
//! bilinearly, which turns the pixels' box-filtered step into a ramp whose ½ crossing is
//! unbiased on average over the boundary's sub-pixel phase.

use image::RgbImage;
use nalgebra::Vector2;

/// Spacing of the samples along a search line, pixels.
const STEP: f64 = 0.5;

/// One camera's frame and its background, ready for boundary searches.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EdgeImage<'a> {
    pixels: &'a [u8],
    background: &'a [[f32; 3]],
    width: usize,
    height: usize,
}

/// A boundary found along a search line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Edge {
    /// Where the coverage crosses ½, pixels along the line's direction from its origin
    /// (positive: outward of the predicted outline).
    pub offset: f64,
    /// Colour contrast between the tube's surface and the background there, grey levels.
    pub contrast: f64,
}

impl<'a> EdgeImage<'a> {
    /// `background` holds the mean colour of every pixel of `image`, row-major.
    pub fn new(image: &'a RgbImage, background: &'a [[f32; 3]]) -> Self {
        let (w, h) = image.dimensions();
        debug_assert_eq!(background.len(), (w * h) as usize);
        EdgeImage {
            pixels: image.as_raw(),
            background,
            width: w as usize,
            height: h as usize,
        }
    }

    /// `I − E` at a sub-pixel position (bilinear), or `None` outside the image.
    fn difference(&self, p: Vector2<f64>) -> Option<[f32; 3]> {
        // Truncation is the floor here (negative positions are refused first), and much
        // cheaper than `floor`, which is a library call without SSE4.1.
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return None;
        }
        let (x0, y0) = (p.x as usize, p.y as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            return None;
        }
        let (fx, fy) = ((p.x - x0 as f64) as f32, (p.y - y0 as f64) as f32);
        let i = y0 * self.width + x0;
        let corners = [
            (i, (1.0 - fx) * (1.0 - fy)),
            (i + 1, fx * (1.0 - fy)),
            (i + self.width, (1.0 - fx) * fy),
            (i + self.width + 1, fx * fy),
        ];
        let mut d = [0f32; 3];
        for (k, w) in corners {
            let bg = self.background[k];
            for c in 0..3 {
                d[c] += w * (self.pixels[3 * k + c] as f32 - bg[c]);
            }
        }
        Some(d)
    }

    /// The boundary along the line `origin + t·direction` (`direction` a unit vector pointing
    /// out of the tube), searched over `t ∈ [−inside, search]`: the tube's colour is taken
    /// where it differs most from the background inside the outline, and the boundary is the
    /// first ½ crossing of the coverage coming in from outside. `None` when the line leaves
    /// the image, the contrast is below `min_contrast` grey levels, or the far end of the line
    /// is not background (another object, or the tube crossing itself).
    pub fn find(
        &self,
        origin: Vector2<f64>,
        direction: Vector2<f64>,
        inside: f64,
        search: f64,
        min_contrast: f64,
    ) -> Option<Edge> {
        // Rounded by casts (floor and ceil are library calls without SSE4.1); both ≥ 0 here.
        let (q_out, q_in) = (search / STEP, inside / STEP);
        let outer = q_out as i32 + i32::from((q_out as i32 as f64) < q_out);
        let inner = (q_in as i32).max(1);
        let mut diffs = [[0f32; 3]; 64];
        let count = (outer + inner + 1) as usize;
        if count > diffs.len() {
            return None;
        }
        // diffs[k] is at t = (outer − k)·STEP: from outside inward.
        for (k, d) in diffs[..count].iter_mut().enumerate() {
            let t = (outer - k as i32) as f64 * STEP;
            *d = self.difference(origin + direction * t)?;
        }
        let norm2 = |d: &[f32; 3]| d.iter().map(|v| v * v).sum::<f32>();
        let diffs = &diffs[..count];
        // The surface colour: first the strongest difference at or inside the predicted
        // outline; then the colour just inside the boundary found with it (a band's edge or
        // shading can change the tube's colour along the line).
        let strongest = diffs[outer as usize..]
            .iter()
            .max_by(|a, b| norm2(a).total_cmp(&norm2(b)))?;
        let (k, _) = crossing(diffs, strongest, min_contrast)?;
        let local = &diffs[(k + INSIDE).min(count - 1)];
        let surface = if norm2(local) >= min_contrast.powi(2) as f32 {
            local
        } else {
            strongest
        };
        let (k, frac) = crossing(diffs, surface, min_contrast)?;
        Some(Edge {
            offset: (outer - k as i32 + 1) as f64 * STEP - frac * STEP,
            contrast: (norm2(surface) as f64).sqrt(),
        })
    }
}

/// Samples from a boundary to where the surface colour is read: 1.5 px, past the mixed pixels.
const INSIDE: usize = 3;

/// The first ½ crossing of the coverage against `surface`, coming in from outside: the sample
/// index reached and the fraction of a step back from it. `None` when the contrast is too weak,
/// the line's outer end is not background, or the coverage never reaches ½.
fn crossing(diffs: &[[f32; 3]], surface: &[f32; 3], min_contrast: f64) -> Option<(usize, f64)> {
    let s2: f32 = surface.iter().map(|v| v * v).sum();
    if (s2 as f64) < min_contrast * min_contrast {
        return None;
    }
    let coverage = |d: &[f32; 3]| (d[0] * surface[0] + d[1] * surface[1] + d[2] * surface[2]) / s2;
    let mut prev = coverage(&diffs[0]);
    if prev > 0.3 {
        return None;
    }
    for (k, d) in diffs.iter().enumerate().skip(1) {
        let c = coverage(d);
        if c >= 0.5 {
            return Some((k, ((0.5 - prev) / (c - prev).max(1e-6)) as f64));
        }
        prev = c;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// A dark disc of radius `r` centred at `c` on a bright backdrop, each pixel its covered
    /// share (16×16 supersampled).
    fn disc(c: Vector2<f64>, r: f64) -> (RgbImage, Vec<[f32; 3]>) {
        let (bg, fg) = ([200.0f32, 190.0, 170.0], [30.0f32, 40.0, 90.0]);
        let img = RgbImage::from_fn(64, 64, |x, y| {
            let mut inside = 0;
            for i in 0..16 {
                for j in 0..16 {
                    let p = Vector2::new(
                        x as f64 - 0.5 + (i as f64 + 0.5) / 16.0,
                        y as f64 - 0.5 + (j as f64 + 0.5) / 16.0,
                    );
                    inside += ((p - c).norm() <= r) as u32;
                }
            }
            let a = inside as f32 / 256.0;
            Rgb(std::array::from_fn(|k| {
                (a * fg[k] + (1.0 - a) * bg[k]).round() as u8
            }))
        });
        (img, vec![bg; 64 * 64])
    }

    #[test]
    fn finds_a_round_boundary_to_a_few_hundredths_of_a_pixel() {
        let c = Vector2::new(31.3, 32.6);
        let r = 12.0;
        let (img, bg) = disc(c, r);
        let e = EdgeImage::new(&img, &bg);
        let mut worst = 0.0f64;
        let mut sum = 0.0;
        let n = 72;
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            let dir = Vector2::new(a.cos(), a.sin());
            // Predicted 0.7 px inside the true boundary.
            let edge = e.find(c + dir * (r - 0.7), dir, 3.0, 3.0, 10.0).unwrap();
            let err = edge.offset - 0.7;
            worst = worst.max(err.abs());
            sum += err;
        }
        assert!(worst < 0.12, "worst {worst}");
        assert!((sum / n as f64).abs() < 0.03, "mean {}", sum / n as f64);
    }

    #[test]
    fn refuses_lines_without_a_clean_background_or_contrast() {
        let (img, bg) = disc(Vector2::new(32.0, 32.0), 12.0);
        let e = EdgeImage::new(&img, &bg);
        // Pointing inward: the far end is the disc.
        let inward = e.find(
            Vector2::new(32.0, 22.0),
            Vector2::new(0.0, 1.0),
            2.0,
            3.0,
            10.0,
        );
        assert!(inward.is_none());
        // Off the image.
        let off = e.find(
            Vector2::new(1.0, 32.0),
            Vector2::new(-1.0, 0.0),
            2.0,
            3.0,
            10.0,
        );
        assert!(off.is_none());
        // Contrast below the floor.
        let dim = e.find(
            Vector2::new(20.5, 32.0),
            Vector2::new(-1.0, 0.0),
            2.0,
            3.0,
            1000.0,
        );
        assert!(dim.is_none());
    }
}
