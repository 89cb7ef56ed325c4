//! Sub-pixel silhouette boundaries measured in the image itself: where, along a line across
//! the tube's predicted outline, the pixels turn from the background model's colour to the
//! tube's.
//!
//! A pixel that the boundary crosses mixes the two colours, `I = c·S + (1 − c)·E` (`E` the
//! background, `S` the surface, `c` the covered share), and the boundary is where `c` crosses
//! ½ (the truth masks' convention: the pixel centre's ray grazes the tube). The surface's
//! colour at the boundary is not the one read inside the outline, though: a round tube's
//! shading darkens toward its limbs, and on a dark backdrop the limb fades into it, so
//! projecting onto the colour read inside, `c = (I − E)·(S − E) / ‖S − E‖²`, puts the boundary
//! about a pixel inside the tube. Shading changes the surface's brightness, not its hue: with
//! `Ŝ` the colour read inside, `I − E = a·Ŝ − c·E` for some brightness `a`, and least squares
//! over the three channels give `c` whatever `a` is. That needs the surface's and the
//! background's colours to differ in hue; where they hardly do (a grey tube on a grey
//! backdrop), the projection is used. Colours are sampled bilinearly, which turns the pixels'
//! box-filtered step into a ramp whose ½ crossing is unbiased on average over the boundary's
//! sub-pixel phase.
//!
//! A sharp shadow of the tube on the backdrop beside it keeps the backdrop's hue at a fraction
//! `β` of its light, and read against the lit backdrop it looks partly covered (`c ≈ 1 − β`),
//! which moves the boundary into it. Where a line reaches into the silhouette's
//! shadow-coloured pixels and the tube's hue differs from the backdrop's, the backdrop-hued
//! samples outside the boundary are taken as backdrop and the rest read against the backdrop
//! as dark as the last of them.

use flexshape_silhouette::BitMask;
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
    /// Where the silhouette holds shadow-coloured pixels (a sharp shadow on the backdrop);
    /// only lines reaching into them are read for a shadow beside the boundary.
    shade: Option<&'a BitMask>,
    /// Whether the image is a camera's, of a shaded tube (a mask's flat colours are not):
    /// only then is a boundary read against the tube's rim.
    shaded: bool,
    /// Where something in front of the volume hides it from the camera (the rig's occlusion
    /// mask): a line that reads any of it says nothing of the tube.
    hidden: Option<&'a BitMask>,
}

/// A boundary found along a search line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Edge {
    /// Where the coverage crosses ½, pixels along the line's direction from its origin
    /// (positive: outward of the predicted outline).
    pub offset: f64,
    /// The grey levels the coverage is read from: how far the colour moves, along what the
    /// coverage measures, from the backdrop to the tube — `‖S − E‖` where it is projected on
    /// the surface's colour, the backdrop's colour across the surface's hue where it is
    /// unmixed. The image's noise moves the coverage by the noise over this, and the boundary
    /// by that over the coverage's slope.
    pub contrast: f64,
    /// Whether the surface there is lighter than the background (their difference summed
    /// over the channels is positive).
    pub lighter: bool,
    /// How far the coverage takes to rise from ¼ to ¾ across the boundary, pixels: about
    /// [`SHARP_RAMP_PX`] for an edge in focus and still, wider where optics or motion blur it
    /// (`None` where it does not rise to ¾ within the line).
    pub ramp: Option<f64>,
    /// How far inside `offset` the boundary may lie because the tube's rim is finer than the
    /// pixels, pixels (at least 0): see [`rim_slack`]. 0 where the surface's hue unmixes the
    /// coverage, where the surface is lighter than the backdrop, where the edge is blurred
    /// (its rise wider than [`crate::check::STILL_RAMP_PX`]), and for a mask.
    pub rim: f64,
    /// How far either way of `offset` the boundary may lie because the backdrop changes
    /// within the pixels it was read from, pixels (at least 0; see
    /// [`EdgeImage::backdrop_doubt`]): a printed dot's or square's edge under the tube's
    /// outline. 0 where the backdrop does not change along the line.
    pub backdrop: f64,
}

/// Why a search line gives no boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Miss {
    /// The image does not show one there: the line leaves the image, the tube's contrast is
    /// too low, the line's far end is not background, or the coverage never crosses ½.
    NotFound,
    /// The backdrop somewhere between the line's outer end and the tube's inside has the
    /// tube's own colour (within `min_contrast`: a printed dot behind a dark tube): there the
    /// tube cannot be told from the backdrop, and the boundary may lie anywhere over it. Not
    /// a miss of the fit: the image holds no evidence either way.
    Unseen,
}

/// The ¼–¾ rise of a sharp step edge as [`EdgeImage::find`] reads it, pixels: a step
/// integrated over a pixel (a box 1 px wide) and read bilinearly (a triangle 2 px wide) rises
/// as a Gaussian of variance 1/12 + 1/6 = ¼ px² does, over 1.349·½ px. A boundary cannot be
/// placed better than its rise allows, and a wider rise tells of blur (optics out of focus,
/// the tube moving while the shutter was open) that moves the ½ crossing off a sharp tube's
/// outline where the outline curves or the motion is not uniform.
pub const SHARP_RAMP_PX: f64 = 0.67;

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
            shade: None,
            shaded: true,
            hidden: None,
        }
    }

    /// The same, with the pixels `hidden` (same size as the image) where something in front
    /// of the volume hides it from the camera.
    pub fn with_hidden(self, hidden: Option<&'a BitMask>) -> Self {
        EdgeImage {
            hidden: hidden.filter(|h| h.width() == self.width && h.height() == self.height),
            ..self
        }
    }

    /// Whether any pixel is hidden (see [`EdgeImage::with_hidden`]).
    pub fn hides_any(&self) -> bool {
        self.hidden.is_some()
    }

    /// Whether the search line `origin + t·direction`, `t ∈ [−inside, search]`, reads a
    /// hidden pixel (see [`EdgeImage::with_hidden`]): a boundary there, or none, would be the
    /// occluder's.
    pub fn hides(
        &self,
        origin: Vector2<f64>,
        direction: Vector2<f64>,
        inside: f64,
        search: f64,
    ) -> bool {
        let Some(hidden) = self.hidden else {
            return false;
        };
        let steps = (inside + search).ceil().max(1.0) as usize;
        (0..=steps).any(|k| {
            let t = -inside + (inside + search) * k as f64 / steps as f64;
            self.reads(hidden, origin + direction * t)
        })
    }

    /// Whether reading the image at `p` (bilinearly) reads a pixel of `mask` (same size).
    fn reads(&self, mask: &BitMask, p: Vector2<f64>) -> bool {
        self.corners(p).is_some_and(|c| {
            c.iter()
                .any(|&(i, _)| mask.get(i % self.width, i / self.width))
        })
    }

    /// Whether the image is a camera's, of a shaded tube, rather than a mask.
    pub(crate) fn shaded(&self) -> bool {
        self.shaded
    }

    /// The same for a mask (white on black, no shading): its boundaries are the ½ crossings
    /// against the colour inside, not against a rim.
    pub fn of_mask(self) -> Self {
        EdgeImage {
            shaded: false,
            ..self
        }
    }

    /// The same, reading a shadow beside a boundary where a line's outer part meets `shade`
    /// (the silhouette's shadow-coloured pixels, same size as the image; an empty one is
    /// never asked).
    pub fn with_shade(self, shade: Option<&'a BitMask>) -> Self {
        EdgeImage {
            shade: shade.filter(|s| s.words().iter().any(|&w| w != 0)),
            ..self
        }
    }

    /// Whether the samples `0..outer` of a line (`at`) read a pixel of the shade.
    fn meets_shade(&self, outer: usize, at: &impl Fn(usize) -> Vector2<f64>) -> bool {
        let Some(shade) = self.shade.filter(|s| s.width() == self.width) else {
            return false;
        };
        (0..outer).any(|k| self.reads(shade, at(k)))
    }

    /// The four pixels around a sub-pixel position and their bilinear weights, or `None`
    /// outside the image.
    #[inline]
    fn corners(&self, p: Vector2<f64>) -> Option<[(usize, f32); 4]> {
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
        Some([
            (i, (1.0 - fx) * (1.0 - fy)),
            (i + 1, fx * (1.0 - fy)),
            (i + self.width, (1.0 - fx) * fy),
            (i + self.width + 1, fx * fy),
        ])
    }

    /// `I − E` at a sub-pixel position (bilinear), or `None` outside the image.
    pub(crate) fn difference(&self, p: Vector2<f64>) -> Option<[f32; 3]> {
        self.difference_within(p, &mut ([f32::MAX; 3], [f32::MIN; 3]))
    }

    /// As [`EdgeImage::difference`], widening `range` (per channel, least and most) to take in
    /// the background of the four pixels read.
    fn difference_within(&self, p: Vector2<f64>, range: &mut BackdropRange) -> Option<[f32; 3]> {
        let mut d = [0f32; 3];
        for (k, w) in self.corners(p)? {
            let bg = self.background[k];
            for c in 0..3 {
                d[c] += w * (self.pixels[3 * k + c] as f32 - bg[c]);
                range.0[c] = range.0[c].min(bg[c]);
                range.1[c] = range.1[c].max(bg[c]);
            }
        }
        Some(d)
    }

    /// `E` at a sub-pixel position (bilinear), black outside the image. Only the unmixing needs
    /// it, and only at the few samples it reads: computed on demand.
    #[inline]
    fn background_at(&self, p: Vector2<f64>) -> [f32; 3] {
        let mut e = [0f32; 3];
        let Some(corners) = self.corners(p) else {
            return e;
        };
        for (k, w) in corners {
            let bg = self.background[k];
            for c in 0..3 {
                e[c] += w * bg[c];
            }
        }
        e
    }

    /// The coverage at `p` read pixel by pixel: `per_pixel(I − E, E)` of each of the four
    /// pixels around it (`E` at `shadow` of its light), mixed bilinearly. Mixing `I − E`
    /// first, as the search does, weighs each pixel's coverage by its own contrast: where the
    /// backdrop changes between the pixels (a printed pattern's edge), that moved boundaries
    /// by up to half a pixel.
    fn pixelwise(
        &self,
        p: Vector2<f64>,
        shadow: f32,
        per_pixel: &impl Fn(&[f32; 3], &[f32; 3]) -> f32,
    ) -> f32 {
        let Some(corners) = self.corners(p) else {
            return 0.0;
        };
        corners
            .iter()
            .map(|&(i, w)| {
                let e = self.background[i].map(|v| v * shadow);
                let d: [f32; 3] = std::array::from_fn(|c| self.pixels[3 * i + c] as f32 - e[c]);
                w * per_pixel(&d, &e)
            })
            .sum()
    }

    /// The brightness of each of a line's samples `diffs` (`I − E`, from outside inward, the
    /// `k`-th at `at(k)`) as a share of the backdrop's, up to the first that is not of the
    /// backdrop's hue ([`backdrop_brightness`]): the backdrop, lit or in shadow, beside the
    /// tube.
    fn backdrop_light<'s>(
        &'s self,
        diffs: &'s [[f32; 3]],
        at: &'s impl Fn(usize) -> Vector2<f64>,
    ) -> impl Iterator<Item = f32> + 's {
        diffs
            .iter()
            .enumerate()
            .map_while(|(k, d)| backdrop_brightness(d, &self.background_at(at(k))))
    }

    /// Where some of the line's outer samples (`diffs`, `I − E`, from outside inward, up to the
    /// first that is not the backdrop's hue) are the backdrop in shadow — its hue, at most
    /// [`MAX_SHADOW`] of its light, as a tube's shadow beside it falls — those outer samples
    /// are made the backdrop itself (`I − E` = 0, `E` scaled to each one's brightness in
    /// `lit`), and the samples inward of them are read against the backdrop as dark as the
    /// last of them (`I − βE`, `lit` = β): read against the lit backdrop, a shadow counts as
    /// partly covered and moves the boundary out. Only when the surface (the `strongest`
    /// sample) differs in hue from the backdrop, or a tube of the backdrop's hue would read as
    /// its shadow. Returns whether any sample was shadow; otherwise nothing changed.
    fn shadow_beside(
        &self,
        diffs: &mut [[f32; 3]],
        lit: &mut [f32; 64],
        strongest: usize,
        at: &impl Fn(usize) -> Vector2<f64>,
        min_contrast: f64,
    ) -> bool {
        let surface = self.background_at(at(strongest));
        let raw = std::array::from_fn(|c| diffs[strongest][c] + surface[c]);
        if unmixing(raw, &self.background_at(at(0)), min_contrast).is_none() {
            return false;
        }
        let mut stop = 0;
        for (k, b) in self.backdrop_light(diffs, at).enumerate() {
            lit[k] = b;
            stop = k + 1;
        }
        let any = lit[..stop].iter().any(|&b| b <= MAX_SHADOW);
        if !any {
            lit[..stop].fill(1.0);
            return false;
        }
        diffs[..stop].fill([0.0; 3]);
        let beta = stop.checked_sub(1).map_or(1.0, |k| lit[k]);
        for (k, d) in diffs.iter_mut().enumerate().skip(stop) {
            let e = self.background_at(at(k));
            for c in 0..3 {
                d[c] += (1.0 - beta) * e[c];
            }
            lit[k] = beta;
        }
        any
    }

    /// The boundary along the line `origin + t·direction` (`direction` a unit vector pointing
    /// out of the tube), searched over `t ∈ [−inside, search]`: the tube's colour is taken
    /// where it differs most from the background inside the outline, and the boundary is the
    /// first ½ crossing of the coverage coming in from outside. [`Miss::NotFound`] when the
    /// line leaves the image, the contrast is below `min_contrast` grey levels, or the far end
    /// of the line is not background (another object, or the tube crossing itself);
    /// [`Miss::Unseen`] when the backdrop along the line, up to the tube's inside, has the
    /// tube's colour somewhere.
    pub fn find(
        &self,
        origin: Vector2<f64>,
        direction: Vector2<f64>,
        inside: f64,
        search: f64,
        min_contrast: f64,
    ) -> Result<Edge, Miss> {
        let (edge, seen) = self
            .crossing_along(origin, direction, inside, search, min_contrast)
            .ok_or(Miss::NotFound)?;
        if seen { Ok(edge) } else { Err(Miss::Unseen) }
    }

    /// [`EdgeImage::find`]'s boundary, and whether the backdrop along the line (its samples
    /// from the outer end to [`INSIDE`] past the crossing) everywhere differs from the
    /// surface's colour by `min_contrast`.
    fn crossing_along(
        &self,
        origin: Vector2<f64>,
        direction: Vector2<f64>,
        inside: f64,
        search: f64,
        min_contrast: f64,
    ) -> Option<(Edge, bool)> {
        let line = self.line(origin, direction, inside, search)?;
        let at = |k: usize| line.at(k);
        // The samples read against the backdrop in a shadow beside the boundary, where
        // [`EdgeImage::shadow_beside`] finds one.
        let in_shadow = || {
            let (mut diffs, mut lit) = (line.diffs, [1f32; 64]);
            self.shadow_beside(
                &mut diffs[..line.count],
                &mut lit,
                line.strongest,
                &at,
                min_contrast,
            )
            .then_some((diffs, lit))
        };
        // Lines reaching into the silhouette's shadow-coloured pixels are asked for a shadow
        // beside the boundary; the rest are read as they are, and asked only when that finds
        // no boundary and the line, from its outer end in to the predicted outline, reads the
        // backdrop in shadow before anything else: the soft edge of a lamp's shadow hugging
        // the tube is often taken into the silhouette, not marked as shade, and the line's
        // outer end, read against the lit backdrop, counted as covered.
        if self.meets_shade(line.outer as usize, &at) {
            return match in_shadow() {
                Some((diffs, lit)) => self.read_line(&line, &diffs, Some(&lit), min_contrast),
                None => self.read_line(&line, &line.diffs, None, min_contrast),
            };
        }
        self.read_line(&line, &line.diffs, None, min_contrast)
            .or_else(|| {
                let outer = &line.diffs[..=line.outer as usize];
                let shadowed = self.backdrop_light(outer, &at).any(|b| b <= MAX_SHADOW);
                let (diffs, lit) = shadowed.then(in_shadow).flatten()?;
                self.read_line(&line, &diffs, Some(&lit), min_contrast)
            })
    }

    /// The samples of the line `origin + t·direction` over `t ∈ [−inside, search]` (see
    /// [`Line`]); `None` when it leaves the image or holds more than 64 samples.
    fn line(
        &self,
        origin: Vector2<f64>,
        direction: Vector2<f64>,
        inside: f64,
        search: f64,
    ) -> Option<Line> {
        // Rounded by casts (floor and ceil are library calls without SSE4.1); both ≥ 0 here.
        let (q_out, q_in) = (search / STEP, inside / STEP);
        let outer = q_out as i32 + i32::from((q_out as i32 as f64) < q_out);
        let inner = (q_in as i32).max(1);
        let mut line = Line {
            origin,
            direction,
            diffs: [[0f32; 3]; 64],
            count: (outer + inner + 1) as usize,
            outer,
            range: ([f32::MAX; 3], [f32::MIN; 3]),
            strongest: 0,
        };
        if line.count > line.diffs.len() {
            return None;
        }
        for k in 0..line.count {
            line.diffs[k] = self.difference_within(line.at(k), &mut line.range)?;
        }
        // The surface colour: first the strongest difference at or inside the predicted
        // outline; then the colour just inside the boundary found with it (a band's edge or
        // shading can change the tube's colour along the line).
        line.strongest = (outer as usize..line.count)
            .max_by(|&a, &b| norm2(&line.diffs[a]).total_cmp(&norm2(&line.diffs[b])))?;
        Some(line)
    }

    /// How far a boundary crossed between samples `k − 1` and `k` (placed by `at`; `count` on
    /// the line) may lie from where it was read because the backdrop changes within the
    /// pixels it was read from (the corners of the samples from a pixel outside the crossing
    /// to where the surface's colour is read, [`INSIDE`] samples in), pixels. The reading
    /// takes each pixel's uncovered part for the pixel's whole backdrop; where a pixel's
    /// backdrop is two colours `ΔE` apart (a dot's or a square's edge) and the tube covers a
    /// share `c` of it, all of one colour, its colour is off by up to `c(1 − c)·ΔE ≤ ΔE / 4`
    /// from the mix the reading assumes, its coverage by that over the `contrast` it is read
    /// by, and the crossing by about as much of a pixel — at most [`BACKDROP_REACH_PX`].
    fn backdrop_doubt(
        &self,
        at: impl Fn(usize) -> Vector2<f64>,
        k: usize,
        count: usize,
        contrast: f64,
    ) -> f64 {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        let outside = (1.0 / STEP) as usize;
        for j in k.saturating_sub(outside)..=(k + INSIDE).min(count - 1) {
            let Some(corners) = self.corners(at(j)) else {
                continue;
            };
            for (i, _) in corners {
                let e = self.background[i];
                for c in 0..3 {
                    lo[c] = lo[c].min(e[c]);
                    hi[c] = hi[c].max(e[c]);
                }
            }
        }
        let change: [f32; 3] = std::array::from_fn(|c| (hi[c] - lo[c]).max(0.0));
        let change = f64::from(norm2(&change).sqrt());
        (change / (4.0 * contrast.max(1.0))).min(BACKDROP_REACH_PX)
    }

    /// [`EdgeImage::crossing_along`]'s boundary on `line` from its samples `diffs` (`I − E`;
    /// where a shadow lies beside the boundary, against the shadowed backdrop, `lit` giving
    /// the share of the backdrop's light at each).
    fn read_line(
        &self,
        line: &Line,
        diffs: &[[f32; 3]; 64],
        lit: Option<&[f32; 64]>,
        min_contrast: f64,
    ) -> Option<(Edge, bool)> {
        let (count, outer, strongest, range) =
            (line.count, line.outer, line.strongest, &line.range);
        let at = |k: usize| line.at(k);
        let diffs = &diffs[..count];
        // The share of the backdrop's light at sample `k`, less in the shadow where one lies
        // beside the tube, and the backdrop's colour there.
        let shadow = |k: usize| lit.map_or(1.0, |lit| lit[k]);
        let bg = |k: usize| self.background_at(at(k)).map(|v| v * shadow(k));
        let (k, _) = crossing(count, projection(diffs, &diffs[strongest], min_contrast)?)?;
        let local = (k + INSIDE).min(count - 1);
        let surface = if norm2(&diffs[local]) >= min_contrast.powi(2) as f32 {
            local
        } else {
            strongest
        };
        let projected = projection(diffs, &diffs[surface], min_contrast)?;
        let inside_colour = bg(surface);
        let raw = std::array::from_fn(|c| diffs[surface][c] + inside_colour[c]);
        let contrast = (norm2(&diffs[surface]) as f64).sqrt();
        // Read pixel by pixel where the backdrop changes along the line.
        let varies = backdrop_varies(range, contrast as f32);
        let ((k, frac), ramp, evidence, rim) = match unmixing(raw, &bg(0), min_contrast) {
            Some(unmix) => {
                // The unmixed crossing lies near the projected one (shading moves it by a
                // pixel or so): searched from there, it reads a few samples, not the line.
                let (near, _) = crossing(count, &projected)?;
                let coverage = |k: usize| unmix(&diffs[k], &bg(k));
                let found = crossing_near(near, count, coverage)?;
                let found = if varies {
                    let coverage = |k: usize| self.pixelwise(at(k), shadow(k), &unmix);
                    let found = crossing_near(found.0, count, coverage)?;
                    (found, ramp(found.0, count, coverage))
                } else {
                    (found, ramp(found.0, count, coverage))
                };
                (found.0, found.1, across(&raw, &bg(found.0.0)), 0.0)
            }
            None => {
                // Without a hue to unmix by, the boundary pixel mixes the backdrop with the
                // surface at the limb, which shading makes the most unlike the backdrop where
                // the backdrop is the lighter (a lit tube's rim is its darkest part): read
                // against the strongest colour between the crossing and the sample read as
                // the surface, not against that one.
                // A mask has no shading and no rim: its boundary is read as it is.
                let (near, _) = crossing(count, &projected)?;
                let rim = (near..=local)
                    .filter(|_| self.shaded)
                    .max_by(|&a, &b| norm2(&diffs[a]).total_cmp(&norm2(&diffs[b])))
                    .unwrap_or(surface);
                let projected = projection(diffs, &diffs[rim], min_contrast)?;
                let found = crossing(count, &projected)?;
                let evidence = f64::from(norm2(&diffs[rim]).sqrt());
                let darker = self.shaded && dot(&diffs[rim], &GREY) < 0.0;
                // The coverage a black surface would give: the share of the backdrop's light
                // each sample has lost.
                let black = |k: usize| {
                    let e = bg(k);
                    -dot(&diffs[k], &e) / norm2(&e).max(1.0)
                };
                let (found, ramp) = if varies {
                    // The rim's own colour, projected on against each pixel's backdrop.
                    let e = bg(rim);
                    let colour: [f32; 3] = std::array::from_fn(|c| diffs[rim][c] + e[c]);
                    let against = |d: &[f32; 3], e: &[f32; 3]| {
                        let s: [f32; 3] = std::array::from_fn(|c| colour[c] - e[c]);
                        dot(d, &s) / norm2(&s).max(1.0)
                    };
                    let coverage = |k: usize| self.pixelwise(at(k), shadow(k), &against);
                    let found = crossing_near(found.0, count, coverage)?;
                    (found, ramp(found.0, count, coverage))
                } else {
                    (found, ramp(found.0, count, projected))
                };
                // A blurred edge smears the rim over its rise, which the check allows for
                // as blur ([`crate::check::blur_allowance`]); only one still and in focus
                // leaves the rim unread.
                let still = ramp.is_some_and(|r| r <= crate::check::STILL_RAMP_PX);
                let slack = if darker && still {
                    rim_slack(found, rim, crossing_near(found.0, count, black))
                } else {
                    0.0
                };
                (found, ramp, evidence, slack)
            }
        };
        // Where the backdrop behind some sample is of the surface's colour, the tube there
        // reads as backdrop: the coverage, and the crossing, are not decided by the image.
        // Each of the four pixels a sample reads is asked, not their bilinear mix: beside
        // such a backdrop's edge the mix still differs, but what it is mixed from does not.
        let reach = (k + INSIDE).min(count - 1);
        // Most lines' backdrop is far from the surface's colour all along: said by the range
        // of the pixels read, without reading them again.
        let far = lit.is_none() && f64::from(distance_to_range(&raw, range)) >= min_contrast;
        let seen = far
            || (0..=reach).all(|j| {
                self.corners(at(j)).is_some_and(|corners| {
                    corners.iter().all(|&(i, _)| {
                        let e = self.background[i];
                        let d: [f32; 3] = std::array::from_fn(|c| raw[c] - shadow(j) * e[c]);
                        norm2(&d) as f64 >= min_contrast * min_contrast
                    })
                })
            });
        let backdrop = if varies {
            self.backdrop_doubt(at, k, count, evidence)
        } else {
            0.0
        };
        let edge = Edge {
            offset: (outer - k as i32 + 1) as f64 * STEP - frac * STEP,
            contrast: evidence,
            lighter: diffs[surface].iter().sum::<f32>() > 0.0,
            ramp,
            rim,
            backdrop,
        };
        Some((edge, seen))
    }
}

/// The least and the most background colour (per channel) over the pixels a search line
/// reads.
type BackdropRange = ([f32; 3], [f32; 3]);

/// A search line's samples, read once: `diffs[k]` (`I − E`) at `t = (outer − k)·STEP` along
/// `origin + t·direction`, from outside inward, over `count` samples; the least and the most
/// background colour of the pixels they read; and the strongest difference at or inside the
/// predicted outline (`t ≤ 0`).
struct Line {
    origin: Vector2<f64>,
    direction: Vector2<f64>,
    diffs: [[f32; 3]; 64],
    count: usize,
    outer: i32,
    range: BackdropRange,
    strongest: usize,
}

impl Line {
    /// Where sample `k` is.
    fn at(&self, k: usize) -> Vector2<f64> {
        self.origin + self.direction * ((self.outer - k as i32) as f64 * STEP)
    }
}

/// Whether the backdrop changes along a line, over the pixels its samples read (`range`), by
/// more than [`MAX_BACKDROP_CHANGE`] of the tube's `contrast` against it: then
/// [`EdgeImage::pixelwise`] reads the crossing.
fn backdrop_varies(range: &BackdropRange, contrast: f32) -> bool {
    let change: [f32; 3] = std::array::from_fn(|c| (range.1[c] - range.0[c]).max(0.0));
    norm2(&change) > (MAX_BACKDROP_CHANGE * contrast).powi(2)
}

/// The distance from `colour` to the nearest colour within `range` (per channel between its
/// least and most): every background in the range differs from `colour` by at least that.
fn distance_to_range(colour: &[f32; 3], range: &BackdropRange) -> f32 {
    let d: [f32; 3] = std::array::from_fn(|c| {
        colour[c] - colour[c].clamp(range.0[c], range.1[c].max(range.0[c]))
    });
    norm2(&d).sqrt()
}

/// Largest change of the backdrop along a search line, as a share of the tube's contrast
/// against it, that the bilinear reading of `I − E` is left to: it moves the boundary by
/// about a quarter of that share of a pixel at most (a cloth's grain, a few percent, by
/// well under a hundredth).
const MAX_BACKDROP_CHANGE: f32 = 0.1;

/// The farthest a backdrop's change within the pixels a boundary is read from can move it,
/// pixels ([`EdgeImage::backdrop_doubt`]): a pixel's coverage is off by at most the whole of
/// it.
const BACKDROP_REACH_PX: f64 = 1.0;

/// Samples from a boundary to where the surface colour is read: 1.5 px, past the mixed pixels.
const INSIDE: usize = 3;

fn dot(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm2(a: &[f32; 3]) -> f32 {
    dot(a, a)
}

/// The coverage of sample `k` of `diffs` (`I − E`), projected onto the surface's difference
/// from the background `surface` (`I − E` inside the outline); `None` below `min_contrast`
/// grey levels.
fn projection<'a>(
    diffs: &'a [[f32; 3]],
    surface: &'a [f32; 3],
    min_contrast: f64,
) -> Option<impl Fn(usize) -> f32 + 'a> {
    let s2 = norm2(surface);
    ((s2 as f64) >= min_contrast * min_contrast)
        .then_some(move |k: usize| dot(&diffs[k], surface) / s2)
}

/// Least hue difference, as the squared sine of the angle between the surface's and the
/// background's colours, at which a coloured surface's coverage is unmixed from the hue
/// (13°): below it the brightness and the coverage can hardly be told apart, and the noise
/// and the highlight's white would swamp the boundary.
const MIN_HUE_SIN2: f32 = 0.05;

/// The grey axis: the hue of a white lamp's light, which a highlight adds to any surface.
const GREY: [f32; 3] = [1.0, 1.0, 1.0];

/// The coverage of a sample, `(I − E, E)`, unmixed by hue (the module's doc): the share of the
/// background's colour that a surface of the hue of `raw` (its colour `I` inside the outline),
/// at any brightness, replaces. `None` when the backdrop's colour across the surface's hue is
/// below a quarter of `min_contrast` grey levels (a near-black backdrop: its loss is too
/// faint to measure), or when the image cannot hold the surface to one hue:
/// - a coloured surface's highlight adds the lamp's white to it and turns its hue toward
///   grey, which counts only where the hues differ by [`MIN_HUE_SIN2`];
/// - a grey or silvery surface keeps its hue in its highlight; it is unmixed wherever its
///   colour across the backdrop's hue (what tells it from the backdrop) is at least half of
///   `min_contrast`, and four times its own distance from grey (a tint that a highlight
///   would turn, or the noise of the one sample it is read from). A grey tube on green
///   cloth is 7° from it, 20 grey levels: projected on the colour read inside instead, a
///   3 px wide silvery tube's boundaries were read 0.3 px off its limbs where its highlight
///   or its dark rim was that colour.
fn unmixing(
    raw: [f32; 3],
    outside: &[f32; 3],
    min_contrast: f64,
) -> Option<impl Fn(&[f32; 3], &[f32; 3]) -> f32> {
    let (a11, a12, a22) = (norm2(&raw), dot(&raw, outside), norm2(outside));
    let det = a11 * a22 - a12 * a12;
    if a11 <= 0.0 || across(&raw, outside) < min_contrast / 4.0 {
        return None;
    }
    let distinct = across(outside, &raw);
    let grey = distinct >= min_contrast / 2.0 && distinct >= 4.0 * across(&GREY, &raw);
    if det < MIN_HUE_SIN2 * a11 * a22 && !grey {
        return None;
    }
    // Least squares of `d = a·raw − c·e` in (a, c).
    Some(move |d: &[f32; 3], e: &[f32; 3]| {
        let (b12, b22) = (dot(&raw, e), norm2(e));
        let det = (a11 * b22 - b12 * b12).max(1e-6);
        (b12 * dot(&raw, d) - a11 * dot(e, d)) / det
    })
}

/// The grey levels the backdrop `e` loses across the surface's hue (`raw`, its colour) where
/// a surface covers it: what unmixing reads the coverage from, so the noise moves the coverage
/// by the noise over this much.
fn across(raw: &[f32; 3], e: &[f32; 3]) -> f64 {
    let (a11, a12, a22) = (norm2(raw), dot(raw, e), norm2(e));
    f64::from(((a11 * a22 - a12 * a12) / a11.max(1e-6)).max(0.0).sqrt())
}

/// Largest brightness of a shadowed backdrop, as a share of the lit one, that counts as a
/// shadow beside a boundary: darker than the partly covered pixels of a blurred edge read
/// as the backdrop's hue (a tenth covered by a tube of another hue darkens a backdrop by
/// about 7 %), and far beyond the sensor's noise.
const MAX_SHADOW: f32 = 0.85;

/// Largest chromaticity distortion `‖I − βE‖ / ‖E‖` of a sample read as the backdrop, lit or
/// in shadow: a shadow keeps the backdrop's hue (noise of 2 grey levels on a backdrop of 180
/// gives about 0.01; a fifth covered by a tube of another hue about 0.03).
const MAX_SHADOW_HUE: f32 = 0.025;

/// The brightness `β` of a sample `I − E` = `d` as a share of the backdrop `e`'s, when it
/// has the backdrop's hue (within [`MAX_SHADOW_HUE`]): the backdrop, lit or in shadow.
/// `None` for anything else.
fn backdrop_brightness(d: &[f32; 3], e: &[f32; 3]) -> Option<f32> {
    let e2 = norm2(e);
    if e2 <= 0.0 {
        return None;
    }
    let i: [f32; 3] = std::array::from_fn(|c| d[c] + e[c]);
    let beta = dot(&i, e) / e2;
    let off: [f32; 3] = std::array::from_fn(|c| i[c] - beta * e[c]);
    (beta > 0.0 && norm2(&off) <= MAX_SHADOW_HUE.powi(2) * e2).then_some(beta)
}

/// How far inside the ½ crossing `found` (sample, fraction of a step back) read against the
/// darkest colour near it (sample `rim`) a darker surface's boundary may lie, pixels: up to
/// where a black surface would cross (`black`), no farther than the darkest sample, and
/// within [`MAX_RIM_SLACK_PX`]. A lit tube darkens toward its limb, glossy ones steeply,
/// within less than a pixel: the boundary pixel mixes the backdrop with a rim darker than
/// any sample reads, and read against the darkest sample its coverage comes out too high and
/// the boundary too far out (a silvery tube 3.4 px wide on a white plate: 0.3 px at each
/// side). Without a hue to unmix by, the image places the boundary only between the two.
fn rim_slack(found: (usize, f64), rim: usize, black: Option<(usize, f64)>) -> f64 {
    let at = |(k, frac): (usize, f64)| k as f64 - frac;
    let inner = black.map_or(rim as f64, |b| at(b).min(rim as f64));
    ((inner - at(found)).max(0.0) * STEP).min(MAX_RIM_SLACK_PX)
}

/// The farthest an unresolved rim moves a boundary, pixels: it darkens the boundary pixel
/// alone (a rim reaching the next pixel in would be read there), and a sample reads pixels
/// up to a pixel from it.
const MAX_RIM_SLACK_PX: f64 = 1.0;

/// As [`crossing`], reading `coverage` only from a sample a pixel outside `near` (where a
/// close estimate crosses, the line's outer end checked by it) on, or farther out while that
/// one is covered already.
fn crossing_near(
    near: usize,
    count: usize,
    coverage: impl Fn(usize) -> f32,
) -> Option<(usize, f64)> {
    let mut k = near.saturating_sub(2).max(1);
    let mut prev = coverage(k - 1);
    while prev >= 0.5 && k > 1 {
        k -= 1;
        prev = coverage(k - 1);
    }
    if prev >= 0.5 {
        return None;
    }
    half_from(k, prev, count, coverage)
}

/// The first ½ crossing of `coverage` over samples `0..count`, coming in from outside: the
/// sample index reached and the fraction of a step back from it. `None` when the line's outer
/// end is not background, or the coverage never reaches ½.
fn crossing(count: usize, coverage: impl Fn(usize) -> f32) -> Option<(usize, f64)> {
    let outside = coverage(0);
    if outside > 0.3 {
        return None;
    }
    half_from(1, outside, count, coverage)
}

/// The coverage's ¼–¾ rise around its ½ crossing at sample `k` (of `0..count`), pixels:
/// from the last sample outside it below ¼ to the first inside at ¾ or more, each crossing
/// interpolated. `None` when either lies beyond the line.
fn ramp(k: usize, count: usize, coverage: impl Fn(usize) -> f32) -> Option<f64> {
    let cross = |a: usize, b: usize, level: f32| {
        let (ca, cb) = (coverage(a), coverage(b));
        a as f64 + ((level - ca) / (cb - ca).max(1e-6)).clamp(0.0, 1.0) as f64
    };
    let mut lo = k.checked_sub(1)?;
    while coverage(lo) >= 0.25 {
        lo = lo.checked_sub(1)?;
    }
    let mut hi = k;
    while coverage(hi) < 0.75 {
        hi += 1;
        if hi >= count {
            return None;
        }
    }
    let quarter = cross(lo, lo + 1, 0.25);
    let three = cross(hi - 1, hi, 0.75);
    Some((three - quarter).max(0.0) * STEP)
}

/// The first sample from `first` on where `coverage` reaches ½, the sample before it covered
/// `prev`: its index and the fraction of a step back from it where the coverage crosses ½.
fn half_from(
    first: usize,
    mut prev: f32,
    count: usize,
    coverage: impl Fn(usize) -> f32,
) -> Option<(usize, f64)> {
    for k in first..count {
        let c = coverage(k);
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

    /// A disc of radius `r` centred at `c` in colour `fg` on a backdrop `bg`, each pixel its
    /// covered share (16×16 supersampled); `shaded`, the disc is a sphere lit from the camera,
    /// `0.3 + 0.7·cos` of its surface's slant, darkest at its rim.
    fn disc(
        c: Vector2<f64>,
        r: f64,
        fg: [f32; 3],
        bg: [f32; 3],
        shaded: bool,
    ) -> (RgbImage, Vec<[f32; 3]>) {
        shadowed_disc(c, r, fg, bg, shaded, (0.0, 1.0))
    }

    /// As [`disc`], the backdrop within `ring.0` px around it darkened to `ring.1` of its light
    /// (the tube's shadow beside it; the background model is the lit backdrop).
    fn shadowed_disc(
        c: Vector2<f64>,
        r: f64,
        fg: [f32; 3],
        bg: [f32; 3],
        shaded: bool,
        ring: (f64, f32),
    ) -> (RgbImage, Vec<[f32; 3]>) {
        let img = RgbImage::from_fn(64, 64, |x, y| {
            let mut colour = [0f32; 3];
            for i in 0..16 {
                for j in 0..16 {
                    let p = Vector2::new(
                        x as f64 - 0.5 + (i as f64 + 0.5) / 16.0,
                        y as f64 - 0.5 + (j as f64 + 0.5) / 16.0,
                    );
                    let u = (p - c).norm() / r;
                    let k = if shaded {
                        0.3 + 0.7 * (1.0 - u * u).max(0.0).sqrt()
                    } else {
                        1.0
                    };
                    let lit = if u * r <= r + ring.0 { ring.1 } else { 1.0 };
                    for ch in 0..3 {
                        colour[ch] += if u <= 1.0 {
                            fg[ch] * k as f32
                        } else {
                            bg[ch] * lit
                        } / 256.0;
                    }
                }
            }
            Rgb(colour.map(|v| v.round() as u8))
        });
        (img, vec![bg; 64 * 64])
    }

    /// A 64×64 image of `frame` (colour at each point, px) and the background model of
    /// `backdrop`, each pixel the mean of 16×16 points inside it.
    fn over_backdrop(
        frame: &dyn Fn(Vector2<f64>) -> [f32; 3],
        backdrop: &dyn Fn(Vector2<f64>) -> [f32; 3],
    ) -> (RgbImage, Vec<[f32; 3]>) {
        let average = |f: &dyn Fn(Vector2<f64>) -> [f32; 3], x: u32, y: u32| {
            let mut colour = [0f32; 3];
            for i in 0..16 {
                for j in 0..16 {
                    let p = Vector2::new(
                        x as f64 - 0.5 + (i as f64 + 0.5) / 16.0,
                        y as f64 - 0.5 + (j as f64 + 0.5) / 16.0,
                    );
                    let v = f(p);
                    for ch in 0..3 {
                        colour[ch] += v[ch] / 256.0;
                    }
                }
            }
            colour
        };
        let img = RgbImage::from_fn(64, 64, |x, y| {
            Rgb(average(frame, x, y).map(|v| v.round() as u8))
        });
        let bg = (0..64 * 64)
            .map(|i| average(backdrop, i % 64, i / 64))
            .collect();
        (img, bg)
    }

    /// Worst and mean error of the boundaries found around `disc`'s image, each searched from
    /// 0.7 px inside the true one, pixels.
    fn errors(image: &(RgbImage, Vec<[f32; 3]>), c: Vector2<f64>, r: f64) -> (f64, f64) {
        errors_in_shade(image, c, r, None)
    }

    /// As [`errors`], the silhouette's shadow-coloured pixels `shade`.
    fn errors_in_shade(
        (img, bg): &(RgbImage, Vec<[f32; 3]>),
        c: Vector2<f64>,
        r: f64,
        shade: Option<&BitMask>,
    ) -> (f64, f64) {
        let e = EdgeImage::new(img, bg).with_shade(shade);
        let mut worst = 0.0f64;
        let mut sum = 0.0;
        let n = 72;
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            let dir = Vector2::new(a.cos(), a.sin());
            let edge = e.find(c + dir * (r - 0.7), dir, 3.0, 3.0, 10.0).unwrap();
            let err = edge.offset - 0.7;
            worst = worst.max(err.abs());
            sum += err;
        }
        (worst, sum / n as f64)
    }

    #[test]
    fn finds_a_round_boundary_to_a_few_hundredths_of_a_pixel() {
        let (c, r) = (Vector2::new(31.3, 32.6), 12.0);
        let image = disc(c, r, [30.0, 40.0, 90.0], [200.0, 190.0, 170.0], false);
        let (worst, mean) = errors(&image, c, r);
        assert!(worst < 0.12, "worst {worst}");
        assert!(mean.abs() < 0.03, "mean {mean}");
    }

    #[test]
    fn finds_a_limb_that_darkens_into_a_dark_backdrop() {
        // A blue tube's limb fades into a near-black backdrop: read against the colour inside,
        // the boundary lands up to 0.7 px inside the true one.
        let (c, r) = (Vector2::new(31.3, 32.6), 6.0);
        let image = disc(c, r, [36.0, 51.0, 102.0], [25.0, 25.0, 25.0], true);
        let (worst, mean) = errors(&image, c, r);
        assert!(worst < 0.15, "worst {worst}");
        assert!(mean.abs() < 0.05, "mean {mean}");
    }

    #[test]
    fn a_boundary_read_across_a_printed_edge_is_allowed_the_doubt_the_edge_leaves() {
        // A thin grey tube (3.4 px) over white paper printed with black dots, one under its
        // lower side: where a dot's edge runs through the pixels a boundary is read from, the
        // reading, which takes a pixel's uncovered part for its whole backdrop, may be off by
        // up to a quarter of the paper's change over the tube's contrast; everywhere else
        // nothing is allowed. Measured: read up to 0.44 px off beside the dot (0.03 px away
        // from it), each within its doubt.
        let (y0, half) = (32.3, 1.7);
        let (white, black) = ([225.0, 222.0, 218.0], [22.0, 22.0, 22.0]);
        let dot = Vector2::new(30.2, 35.4);
        let paper = move |p: Vector2<f64>| {
            if (p - dot).norm() <= 3.5 {
                black
            } else {
                white
            }
        };
        let frame = move |p: Vector2<f64>| {
            let u = (p.y - y0) / half;
            if u.abs() <= 1.0 {
                [105.0, 104.0, 102.0]
            } else {
                paper(p)
            }
        };
        let (img, bg) = over_backdrop(&frame, &paper);
        let e = EdgeImage::new(&img, &bg);
        let (mut doubted, mut worst_beyond, mut worst_err) = (0, 0.0f64, 0.0f64);
        for x in 14..48 {
            for side in [-1.0, 1.0] {
                let dir = Vector2::new(0.0, side);
                let from = Vector2::new(x as f64 + 0.3, y0 + side * (half - 0.7));
                let Ok(edge) = e.find(from, dir, 1.0, 3.0, 10.0) else {
                    continue;
                };
                let err = (edge.offset - 0.7).abs();
                worst_err = worst_err.max(err);
                worst_beyond = worst_beyond.max(err - edge.backdrop);
                if (from - dot).norm() > 3.5 + 4.0 {
                    assert_eq!(edge.backdrop, 0.0, "{x} {side}: {edge:?}");
                }
                doubted += usize::from(edge.backdrop > 0.1);
            }
        }
        println!(
            "worst error {worst_err:.3}, beyond the doubt {worst_beyond:.3}, {doubted} doubted"
        );
        assert!(worst_beyond < 0.12, "{worst_beyond}");
        assert!((4..=16).contains(&doubted), "{doubted}");
    }

    #[test]
    fn a_shadow_beside_the_boundary_is_backdrop() {
        // The tube's own shadow, 45 % of the light gone, in a ring around it, the lines
        // reaching past it (4 px) or ending in it (2 px). Read against the lit backdrop, the
        // boundary lay in the shadow: 1.6 px out at worst, 0.8 px on average (2 px ring).
        let (c, r) = (Vector2::new(31.3, 32.6), 12.0);
        let (fg, bg) = ([30.0, 40.0, 90.0], [180.0, 220.0, 170.0]);
        for width in [2.0, 4.0] {
            let image = shadowed_disc(c, r, fg, bg, false, (width, 0.55));
            // As a silhouette marks it: the ring's pixels a pixel clear of the disc.
            let mut shade = BitMask::new(64, 64);
            for (x, y) in (0..64).flat_map(|x| (0..64).map(move |y| (x, y))) {
                let d = (Vector2::new(x as f64, y as f64) - c).norm();
                shade.set(x, y, d > r + 1.0 && d < r + width);
            }
            // Without the shade, a line that reaches past the shadow reads it as partly covered
            // (the boundary found in it); one that ends in it found no boundary until a line
            // that finds none is read once more asking for a shadow beside it, which places
            // its boundary as the shade does.
            let unshaded = EdgeImage::new(&image.0, &image.1);
            let x = Vector2::x();
            let before = unshaded.find(c + x * (r - 0.7), x, 3.0, 3.0, 10.0);
            match before {
                Ok(e) if width == 2.0 => assert!(e.offset - 0.7 > 0.5, "ring 2 px: {e:?}"),
                Ok(e) => assert!((e.offset - 0.7).abs() < 0.15, "ring 4 px: {e:?}"),
                Err(e) => panic!("ring {width} px: {e:?}"),
            }
            let (worst, mean) = errors_in_shade(&image, c, r, Some(&shade));
            println!("ring {width} px: worst {worst:.3}, mean {mean:.3} (unshaded {before:?})");
            assert!(
                worst < 0.15 && mean.abs() < 0.03,
                "ring {width} px: {worst} {mean}"
            );
        }
    }

    #[test]
    fn a_thin_silvery_tube_on_green_cloth_is_unmixed_through_its_highlight() {
        // A grey tube 3.2 px wide (1.2 mm at 640×480), shaded to a dark rim, with a lamp's
        // white highlight off its middle, on green cloth 7° from its hue. Projected on the
        // colour read 1.6 px inside (the highlight, or the far rim), its boundaries were read
        // up to 0.54 px off; unmixed by hue, 0.10 px.
        let (cx, hw) = (31.37, 1.6);
        let tube = |p: Vector2<f64>| {
            let u = (p.x - cx) / hw;
            if u.abs() > 1.0 {
                return [178.0, 224.0, 168.0];
            }
            let shade = (0.3 + 0.7 * (1.0 - u * u).sqrt()) as f32;
            let highlight = (150.0 * (-((u - 0.35) / 0.25).powi(2)).exp()) as f32;
            [90.0 * shade + highlight; 3]
        };
        let image = over_backdrop(&tube, &|_| [178.0, 224.0, 168.0]);
        let e = EdgeImage::new(&image.0, &image.1);
        let mut worst = 0.0f64;
        for y in 8..56 {
            for side in [-1.0, 1.0] {
                let dir = Vector2::new(side, 0.0);
                let origin = Vector2::new(cx + side * hw, y as f64);
                let edge = e.find(origin, dir, hw, 3.0, 20.0).unwrap();
                worst = worst.max(edge.offset.abs());
            }
        }
        println!("worst {worst:.3} px");
        assert!(worst < 0.15, "worst {worst}");
    }

    #[test]
    fn a_grey_tubes_rim_finer_than_a_pixel_leaves_its_boundary_within_the_slack() {
        // A silvery tube 3.4 px wide (1.2 mm at 640×480) on a white plate: no hue to unmix
        // by, its gloss darkening it steeply toward the limb (to a tenth of the plate's light
        // at grazing), a highlight off its middle. Read against the darkest sample, each
        // boundary lies outward of the true one (as in the study's scenes: 0.3 px); the true
        // one lies within the slack the edge gives.
        let (cx, hw) = (31.37, 1.7);
        let plate = [208.0f32, 208.0, 204.0];
        let tube = |p: Vector2<f64>| {
            let u = (p.x - cx) / hw;
            if u.abs() > 1.0 {
                return plate;
            }
            let cos = (1.0 - u * u).sqrt();
            let glossy = (20.0 + 100.0 * cos.powf(0.4)) as f32;
            let highlight = (60.0 * (-((u - 0.2) / 0.3).powi(2)).exp()) as f32;
            [glossy + highlight; 3]
        };
        let image = over_backdrop(&tube, &|_| plate);
        let e = EdgeImage::new(&image.0, &image.1);
        let (mut outward, mut n) = (0.0, 0);
        for y in 8..56 {
            for side in [-1.0, 1.0] {
                let dir = Vector2::new(side, 0.0);
                let origin = Vector2::new(cx + side * hw, y as f64);
                let edge = e.find(origin, dir, hw, 3.0, 20.0).unwrap();
                assert!(
                    edge.offset > -0.05 && edge.offset - edge.rim < 0.05,
                    "row {y}, side {side}: {edge:?}"
                );
                outward += edge.offset;
                n += 1;
            }
        }
        let outward = outward / n as f64;
        println!("read {outward:.3} px outward on average");
        assert!(outward > 0.15, "{outward}");
        // Nothing to allow where the image leaves no rim unread: a mask, and a tube whose
        // hue unmixes its coverage whatever its brightness.
        let mask = e.of_mask();
        let blue = |p: Vector2<f64>| {
            let [g, _, _] = tube(p);
            if ((p.x - cx) / hw).abs() > 1.0 {
                plate
            } else {
                [g * 0.3, g * 0.5, g]
            }
        };
        let coloured = over_backdrop(&blue, &|_| plate);
        let coloured = EdgeImage::new(&coloured.0, &coloured.1);
        for img in [mask, coloured] {
            let edge = img
                .find(Vector2::new(cx + hw, 30.0), Vector2::x(), hw, 3.0, 20.0)
                .unwrap();
            assert_eq!(edge.rim, 0.0, "{edge:?}");
        }
    }

    /// A thin tube's cap in focus — a disc 2 px in radius — has its boundaries read about
    /// `σ²/2ρ` inside its outline (`σ²` = ¼ px², a pixel's box read bilinearly): 0.05 px, where
    /// a straight boundary is read to a hundredth. Moved out by
    /// [`crate::solve::caps_unshrunk`], they are within a hundredth or two at every size; a cap
    /// of 1.5 px is read 0.12 px inside, and kept 0.04 px inside (what little it has inside
    /// its outline to read its colour from adds the rest).
    #[test]
    fn a_small_caps_boundaries_shrunk_by_blur_are_moved_out_by_it() {
        use crate::outline::Part;
        use crate::solve::{Measured, made_up};
        let n = 48;
        let mean = |m: &[Measured]| m.iter().map(|m| m.residual.unwrap()).sum::<f64>() / n as f64;
        for (r, shrunk_within, kept_within) in [
            (1.5, 0.10..0.15, 0.05),
            (2.0, 0.04..0.07, 0.02),
            (3.0, 0.025..0.045, 0.02),
            (6.0, 0.005..0.025, 0.02),
        ] {
            let c = Vector2::new(31.3, 32.6);
            let (img, bg) = disc(c, r, [60.0, 60.0, 60.0], [220.0, 220.0, 220.0], false);
            let e = EdgeImage::new(&img, &bg);
            let mut measured: Vec<_> = (0..n)
                .map(|i| {
                    let a = i as f64 / n as f64 * std::f64::consts::TAU;
                    let dir = Vector2::new(a.cos(), a.sin());
                    let predicted = c + dir * r;
                    let edge = e.find(predicted, dir, r, 2.0, 10.0).unwrap();
                    let mut m = made_up::sample(Part::Cap(1), 1.0, a, Some(-edge.offset));
                    m.point.pixel = predicted;
                    m.point.normal = dir;
                    m.point.half_width = r;
                    m.edge = Some((predicted + dir * edge.offset, dir));
                    m
                })
                .collect();
            let shrunk = mean(&measured);
            assert!(
                shrunk_within.contains(&shrunk),
                "{r} px: read {shrunk:.3} px inside"
            );
            crate::solve::caps_unshrunk(&mut measured);
            let kept = mean(&measured);
            assert!(
                kept.abs() < kept_within,
                "{r} px: moved out, {kept:.3} px off"
            );
            // The boundary's pixel moved with its residual: a moved tube is measured by it.
            let m = &measured[0];
            let (pixel, normal) = m.edge.unwrap();
            let residual = (m.point.pixel - pixel).dot(&normal);
            assert!((residual - m.residual.unwrap()).abs() < 1e-9);
        }
    }

    #[test]
    fn a_grey_tube_on_a_grey_backdrop_is_read_by_contrast_alone() {
        // No hue tells the surface from the backdrop: the coverage is the projection.
        let (c, r) = (Vector2::new(31.3, 32.6), 12.0);
        let image = disc(c, r, [60.0, 60.0, 60.0], [180.0, 180.0, 180.0], false);
        let (worst, mean) = errors(&image, c, r);
        assert!(worst < 0.12, "worst {worst}");
        assert!(mean.abs() < 0.03, "mean {mean}");
    }

    #[test]
    fn a_dark_limb_on_a_backdrop_of_the_tubes_hue_is_the_boundary() {
        // A lit tube's rim is its darkest part, and on a lighter backdrop of nearly its hue
        // (a blue tube on blue cloth; a grey tube on white paper) only the contrast tells
        // them apart. Read against the colour 1.5 px inside, the rim counted as more than
        // covered and the boundary landed outside the true one: on the first backdrop 0.35
        // px at worst, 0.22 on average. Read against the rim's darkest sample, about half
        // that remains (the boundary pixel's covered part is darker still than any sample:
        // on a disc 6 px in radius the first pixel inside averages 0.55 of the light, the
        // covered part of the boundary pixel under 0.5).
        let (c, r) = (Vector2::new(31.3, 32.6), 6.0);
        for (fg, bg) in [
            ([36.0, 51.0, 102.0], [56.0, 71.0, 115.0]),
            ([36.0, 51.0, 102.0], [110.0, 140.0, 225.0]),
            ([90.0, 90.0, 90.0], [200.0, 200.0, 200.0]),
        ] {
            let image = disc(c, r, fg, bg, true);
            let (worst, mean) = errors(&image, c, r);
            println!("{fg:?} on {bg:?}: worst {worst:.3}, mean {mean:.3}");
            assert!(worst < 0.3, "{fg:?} on {bg:?}: worst {worst}");
            assert!(mean.abs() < 0.15, "{fg:?} on {bg:?}: mean {mean}");
        }
    }

    #[test]
    fn a_backdrop_of_the_tubes_colour_behind_the_boundary_leaves_it_unseen() {
        // A dark tube (a disc 12 px in radius) on a white plate printed with a black dot 4 px
        // in radius whose centre lies on the tube's right boundary; the background model shows
        // the dot. Along lines through the dot the tube differs from the backdrop by less than
        // the least contrast a boundary is read at (before: the crossing found there was the
        // dot's far edge behind the tube, 3.5 px inside the boundary).
        let (c, r) = (Vector2::new(31.3, 32.6), 12.0);
        let dot = (c + Vector2::new(r, 0.0), 4.0);
        let (fg, paper, ink) = (
            [22.0f32, 22.0, 24.0],
            [220.0f32, 220.0, 215.0],
            [12.0f32; 3],
        );
        let backdrop = |p: Vector2<f64>| {
            if (p - dot.0).norm() <= dot.1 {
                ink
            } else {
                paper
            }
        };
        let frame = |p: Vector2<f64>| if (p - c).norm() <= r { fg } else { backdrop(p) };
        let (img, bg) = over_backdrop(&frame, &backdrop);
        let e = EdgeImage::new(&img, &bg);
        let (mut unseen, mut found) = (0, 0);
        for i in 0..72 {
            let a = i as f64 / 72.0 * std::f64::consts::TAU;
            let dir = Vector2::new(a.cos(), a.sin());
            let start = c + dir * (r - 0.7);
            // How near the line, out to 3 px past the boundary or 1.5 px inside it, passes
            // the dot's edge (negative: through the dot).
            let near = (0..=18)
                .map(|k| (start + dir * (k as f64 * 0.25 - 0.8) - dot.0).norm() - dot.1)
                .fold(f64::INFINITY, f64::min);
            // The default `min_contrast`: the tube and the ink differ by 18 grey levels.
            match e.find(start, dir, 3.0, 3.0, 20.0) {
                Ok(edge) => {
                    found += 1;
                    // Lines grazing the dot lay 0.24 and 0.55 px inside the boundary while
                    // only the bilinear mix of the backdrop along them was asked: now unseen.
                    let err = edge.offset - 0.7;
                    println!("{a:.2} rad, {near:.1} px from the dot: {err:+.3} px");
                    assert!(err.abs() < 0.12, "{a:.2} rad: {edge:?}");
                }
                Err(Miss::Unseen) => {
                    unseen += 1;
                    assert!(near < 1.0, "{a:.2} rad: unseen {near:.1} px from the dot");
                    let (_, seen) = e.crossing_along(start, dir, 3.0, 3.0, 20.0).unwrap();
                    assert!(!seen);
                }
                Err(Miss::NotFound) => panic!("{a:.2} rad: not found"),
            }
        }
        // The dot spans about 2·asin(4/12) ≈ 39° of the tube's 360°.
        assert!(
            (5..=12).contains(&unseen) && found + unseen == 72,
            "{unseen} unseen"
        );
    }

    #[test]
    fn a_boundary_over_a_printed_pattern_is_read_pixel_by_pixel() {
        // A blue tube (a disc 12 px in radius) over stripes 5 px wide, white and mid grey,
        // that the background model shows: its boundary crosses the stripes' edges.
        let (c, r) = (Vector2::new(31.3, 32.6), 12.0);
        let (fg, light, grey) = (
            [36.0f32, 51.0, 102.0],
            [220.0f32, 220.0, 215.0],
            [120.0f32; 3],
        );
        let backdrop = |p: Vector2<f64>| {
            if (p.x / 5.0).floor() as i64 % 2 == 0 {
                light
            } else {
                grey
            }
        };
        let frame = |p: Vector2<f64>| if (p - c).norm() <= r { fg } else { backdrop(p) };
        let (worst, mean) = errors(&over_backdrop(&frame, &backdrop), c, r);
        // Mixing `I − E` first: 0.196 px at worst (0.121 so; 0.12 on a plain backdrop).
        assert!(worst < 0.15, "worst {worst}");
        assert!(mean.abs() < 0.03, "mean {mean}");
    }

    #[test]
    fn refuses_lines_without_a_clean_background_or_contrast() {
        let (img, bg) = disc(
            Vector2::new(32.0, 32.0),
            12.0,
            [30.0, 40.0, 90.0],
            [200.0, 190.0, 170.0],
            false,
        );
        let e = EdgeImage::new(&img, &bg);
        // Pointing inward: the far end is the disc.
        let inward = e.find(
            Vector2::new(32.0, 22.0),
            Vector2::new(0.0, 1.0),
            2.0,
            3.0,
            10.0,
        );
        assert!(inward.is_err());
        // Off the image.
        let off = e.find(
            Vector2::new(1.0, 32.0),
            Vector2::new(-1.0, 0.0),
            2.0,
            3.0,
            10.0,
        );
        assert!(off.is_err());
        // Contrast below the floor.
        let dim = e.find(
            Vector2::new(20.5, 32.0),
            Vector2::new(-1.0, 0.0),
            2.0,
            3.0,
            1000.0,
        );
        assert!(dim.is_err());
    }
}
