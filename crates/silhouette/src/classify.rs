//! Foreground classification against the background model, per pixel, into bit masks.
//!
//! Three classifiers, chosen per camera:
//! - [`Classifier::GreenMatte`], the paper's: foreground where the green channel is darker
//!   than the background's by more than `max(fraction · bg, min_difference, noise_factor · σ)`.
//!   With `fraction` ≈ 0.45 the boundary sits at half contrast for a dark object on a bright
//!   backdrop. Shadows darker than that fraction become foreground.
//! - [`Classifier::Difference`]: foreground where any channel differs from the background by
//!   more than `max(min_difference, noise_factor · σ)` — for black cloth or a lit screen,
//!   where no shadow falls on the backdrop.
//! - [`Classifier::ColourShadow`], after Horprasert et al. and Cheung et al.: with `E` the
//!   background colour and `I` the pixel, the brightness distortion `α = I·E / E·E` and the
//!   chromaticity distortion `CD = ‖I − αE‖ / ‖E‖` (≈ the angle between the two RGB vectors).
//!   A shadow keeps the background's chromaticity (`CD ≈ 0`) at `α < 1`, so only colour or a
//!   darkness beyond any shadow makes a pixel foreground. Mixed pixels at a dark object's edge
//!   look like shadows, so the classifier uses hysteresis: pixels passing the strict test are
//!   foreground; a pixel passing a looser test that touches them is foreground when its
//!   estimated coverage `c = (I − E)·(S − E) / ‖S − E‖²` is at least ½, with `S` the mean
//!   colour of its strict neighbours (the pure surface colour). That puts the boundary at half
//!   contrast whatever the surface colour. A loose pixel whose colour is the object's own —
//!   off the backdrop's chromaticity, and off the line from `E` to `S` (no mix of the two) or
//!   of `S`'s chromaticity — joins too, a few pixels deep: a silvery tube's colourless
//!   highlight on green, a grey tube's lit side. A tube too thin for any pixel to be wholly
//!   covered (3–4 px) reaches the strict test only in specks; the object is followed from them
//!   along loose pixels that are off the backdrop's chromaticity beyond the noise and lie
//!   within a few pixels of the plain backdrop — a shadow keeps the chromaticity, and a soft
//!   one's darkest core lies inside its penumbra. A grey or silvery object on a white backdrop is
//!   shadow-like all over; what tells it from a shadow is its edge: a shadow cast from across
//!   the room fades in over its penumbra, an object in focus is whole within a pixel or two. So
//!   a connected region of shadow-like pixels (`α < shade`) whose outline reaches its own
//!   darkness within two pixels (the median of `Δα` over its boundary, relative to `1 − ᾱ`, at
//!   least `edge`; or at least eight such steps away from the foreground: a grey tube across a
//!   lamp's long soft shadow) is foreground too, down to its pixels at least half as dark as its
//!   mean, where they lie nearer a sharp stretch of its outline than a soft one.

use flexshape_rig::quoted;
use image::RgbImage;
use serde::{Deserialize, Serialize};

use crate::background::BackgroundModel;
use crate::bitmask::BitMask;
use crate::error::SilhouetteError;
use crate::markers::for_each_set;

/// A rectangle of an image to classify (pixels, end exclusive; clipped to the image). A
/// tracker that knows where the object is classifies only around it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Region {
    /// The whole image, whatever its size.
    pub const ALL: Region = Region {
        x0: 0,
        y0: 0,
        x1: usize::MAX,
        y1: usize::MAX,
    };
}

/// The part of an image to classify, row by row: row `y0 + i` within columns `columns[i]`
/// (pixels, end exclusive; clipped to the image), no row outside. What a tracker classifies
/// around a tube that crosses the image at a slant, where a rectangle around it would be
/// mostly backdrop.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Rows {
    /// First row.
    pub y0: usize,
    /// Each row's columns, from row `y0` on.
    pub columns: Vec<std::ops::Range<usize>>,
}

/// Where in an image to classify: a [`Region`] or [`Rows`]. Pixels outside are background.
pub trait Area {
    /// The rows to classify, in an image `h` pixels high.
    fn rows(&self, h: usize) -> std::ops::Range<usize>;
    /// The columns of row `y` to classify, in an image `w` pixels wide (empty for none).
    fn columns(&self, y: usize, w: usize) -> std::ops::Range<usize>;
}

impl Area for Region {
    fn rows(&self, h: usize) -> std::ops::Range<usize> {
        self.y0.min(h)..self.y1.min(h)
    }

    fn columns(&self, _y: usize, w: usize) -> std::ops::Range<usize> {
        self.x0.min(w)..self.x1.min(w)
    }
}

impl Area for Rows {
    fn rows(&self, h: usize) -> std::ops::Range<usize> {
        self.y0.min(h)..(self.y0 + self.columns.len()).min(h)
    }

    fn columns(&self, y: usize, w: usize) -> std::ops::Range<usize> {
        match y.checked_sub(self.y0).and_then(|i| self.columns.get(i)) {
            Some(c) => c.start.min(w)..c.end.min(w),
            None => 0..0,
        }
    }
}

/// Parameters of green matting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GreenMatte {
    /// Share of the background's green a pixel must lose (0.45: half contrast for a dark
    /// object).
    pub fraction: f32,
    /// Smallest difference that counts, grey levels.
    pub min_difference: f32,
    /// Smallest difference in units of the pixel's background spread.
    pub noise_factor: f32,
}

impl Default for GreenMatte {
    fn default() -> Self {
        GreenMatte {
            fraction: 0.45,
            min_difference: 20.0,
            noise_factor: 4.0,
        }
    }
}

/// Parameters of plain background subtraction (for dark or uniform backdrops without
/// shadows on them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Difference {
    /// Smallest difference in any channel that makes a pixel foreground, grey levels.
    pub min_difference: f32,
    /// Smallest difference in units of the pixel's background spread.
    pub noise_factor: f32,
}

impl Default for Difference {
    /// About a fifth of the range: a lit object on black cloth.
    fn default() -> Self {
        Difference {
            min_difference: 48.0,
            noise_factor: 4.0,
        }
    }
}

/// Parameters of colour subtraction with shadow rejection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ColourShadow {
    /// Chromaticity distortion that alone makes a pixel foreground (strict test).
    pub chroma: f32,
    /// Chromaticity distortion of the loose test.
    pub chroma_weak: f32,
    /// Brightness ratio below which a pixel is foreground (strict; darker than any shadow).
    pub dark: f32,
    /// Brightness ratio of the loose test (≈ half contrast for a dark object).
    pub dark_weak: f32,
    /// Brightness ratio above which a pixel is foreground (brighter than the backdrop).
    pub bright: f32,
    /// The chromaticity thresholds are at least this many noise spreads.
    pub noise_factor: f32,
    /// Brightness ratio below which a shadow-like pixel may belong to a sharp-edged region
    /// (see `edge`).
    pub shade: f32,
    /// How sharp a shadow-like region's outline must be for the region to count as an object,
    /// as a share of its darkness reached within two pixels (0: shadow-like regions never
    /// count).
    pub edge: f32,
}

impl Default for ColourShadow {
    /// For a dark object on a bright backdrop, with shadows removing up to half the light.
    fn default() -> Self {
        ColourShadow {
            chroma: 0.25,
            chroma_weak: 0.08,
            dark: 0.40,
            dark_weak: 0.57,
            bright: 1.40,
            noise_factor: 4.0,
            shade: 0.85,
            edge: 0.9,
        }
    }
}

/// How pixels are told from the background (`kind = "green_matte"`, `"colour_shadow"` or
/// `"difference"` in the rig file, with any parameters beside it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Classifier {
    /// Green-channel difference (the paper's colour matting).
    GreenMatte(GreenMatte),
    /// Colour subtraction with shadow rejection and hysteresis.
    ColourShadow(ColourShadow),
    /// Any channel differing from the background by more than a margin.
    Difference(Difference),
}

impl Classifier {
    /// The paper's green matting with half-contrast defaults.
    pub fn green_matte() -> Self {
        Classifier::GreenMatte(GreenMatte::default())
    }

    /// Shadow-rejecting colour subtraction with its defaults.
    pub fn colour_shadow() -> Self {
        Classifier::ColourShadow(ColourShadow::default())
    }

    pub(crate) fn validate(&self) -> Result<(), SilhouetteError> {
        let check = |field: &'static str, v: f32, lo: f32, hi: f32| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(SilhouetteError::Setting {
                    field,
                    problem: format!("{} is outside [{lo}, {hi}]", quoted(v)),
                })
            }
        };
        match self {
            Classifier::GreenMatte(g) => {
                check("fraction", g.fraction, 0.0, 1.0)?;
                check("min_difference", g.min_difference, 0.0, 255.0)?;
                check("noise_factor", g.noise_factor, 0.0, 100.0)
            }
            Classifier::Difference(d) => {
                check("min_difference", d.min_difference, 0.0, 255.0)?;
                check("noise_factor", d.noise_factor, 0.0, 100.0)
            }
            Classifier::ColourShadow(c) => {
                check("chroma", c.chroma, 0.0, 2.0)?;
                check("chroma_weak", c.chroma_weak, 0.0, c.chroma)?;
                check("dark", c.dark, 0.0, 1.0)?;
                check("dark_weak", c.dark_weak, c.dark, 1.0)?;
                check("bright", c.bright, 1.0, 100.0)?;
                check("noise_factor", c.noise_factor, 0.0, 100.0)?;
                check("shade", c.shade, c.dark_weak, 1.0)?;
                check("edge", c.edge, 0.0, 2.0)
            }
        }
    }
}

/// The squared chromaticity distortion the frame's noise alone exceeds in one pixel of the
/// backdrop in twenty, read from a sparse sample of `area` (every 4th row, every 8th column):
/// with noise of equal spread across the chromaticity's two directions, `CD²` is exponential,
/// its lower quartile `0.575 s²` and its 95th percentile `6 s²`. The lower quartile holds
/// while up to half of the sample is object (a tracker's area around the tube).
fn chroma_noise2(
    area: &impl Area,
    w: usize,
    h: usize,
    cd2_at: &impl Fn(usize, usize) -> f32,
) -> f32 {
    let mut sample: Vec<f32> = area
        .rows(h)
        .step_by(4)
        .flat_map(|y| area.columns(y, w).step_by(8).map(move |x| (x, y)))
        .map(|(x, y)| cd2_at(x, y))
        .collect();
    if sample.len() < 16 {
        return 0.0;
    }
    let q = sample.len() / 4;
    let (_, lower_quartile, _) = sample.select_nth_unstable_by(q, f32::total_cmp);
    *lower_quartile * (6.0 / 0.575)
}

/// How far from the plain backdrop a loose pixel may lie and still be followed along a thin
/// tube, px: every pixel of a tube up to 6 px wide in focus is within 3 px of the backdrop
/// (its boundary pixels mix the two over one pixel); a soft shadow's darkest core lies
/// inside its penumbra, farther from it.
const THIN_REACH: usize = 3;

/// Follows the object from `out` (updated in place), 8-connected, through the pixels of
/// `weak` (loose ones the half-contrast ring has not already refused) that are `tinted` (off
/// the backdrop's chromaticity beyond the noise) and lie within [`THIN_REACH`] of the plain
/// backdrop (neither `loose`, shadow-like nor strict). A tube 3–4 px
/// wide covers no pixel wholly: a grey one reaches the strict test nowhere along most of its
/// length (half covered, it is as dark as a shadow), and its strict specks left the
/// silhouette in pieces that carved two objects. A shadow keeps the backdrop's chromaticity,
/// and a soft one's darkest core lies inside its penumbra: neither is followed.
fn along_thin_tube(
    out: &mut BitMask,
    loose: &BitMask,
    weak: &BitMask,
    shady: &BitMask,
    strong: &BitMask,
    tinted: impl Fn(usize, usize) -> bool,
) {
    let (w, h) = (out.width(), out.height());
    let plain = |x: usize, y: usize| !loose.get(x, y) && !shady.get(x, y) && !strong.get(x, y);
    let near_plain = |x: usize, y: usize| {
        (y.saturating_sub(THIN_REACH)..=(y + THIN_REACH).min(h - 1)).any(|yy| {
            (x.saturating_sub(THIN_REACH)..=(x + THIN_REACH).min(w - 1)).any(|xx| plain(xx, yy))
        })
    };
    let mut seen = out.clone();
    let mut stack = Vec::new();
    let edge = weak.and(&out.dilate(1)).and_not(out);
    for_each_set(&edge, |x, y| {
        seen.set(x, y, true);
        stack.push((x, y));
    });
    while let Some((x, y)) = stack.pop() {
        if !tinted(x, y) || !near_plain(x, y) {
            continue;
        }
        out.set(x, y, true);
        for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                if weak.get(xx, yy) && !seen.get(xx, yy) {
                    seen.set(xx, yy, true);
                    stack.push((xx, yy));
                }
            }
        }
    }
}

/// How many pixels deep the object's own colours are followed from its strict pixels (a
/// highlight is a stripe a few pixels wide).
const OWN_COLOUR_STEPS: usize = 4;

/// Pixels per skip test (a quarter of a mask word).
const BLOCK: usize = 16;

#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    kind: Kind,
    bg_bytes: Vec<u8>,
    /// Per block of `BLOCK` pixels.
    chunk_tolerance: Vec<u8>,
    /// Per 64-pixel word: the smallest tolerance of its blocks.
    word_tolerance: Vec<u8>,
}

#[derive(Debug, Clone)]
enum Kind {
    /// Foreground iff the green value is below `limit[i]`.
    Green { limit: Vec<u8> },
    /// Foreground iff some channel differs from `bg[i]` by more than `margin[i]`.
    Difference { bg: Vec<[f32; 3]>, margin: Vec<f32> },
    /// Per pixel, each in its own plane (a block of pixels is read as whole vectors):
    /// background colour channel by channel, `1 / E·E`, the strict and loose squared
    /// chromaticity thresholds, and the squared chromaticity distortion the noise alone gives
    /// one pixel in twenty, `(2σ / ‖E‖)²`.
    Colour {
        bg: [Vec<f32>; 3],
        inv_e2: Vec<f32>,
        cd2: [Vec<f32>; 2],
        noise_cd2: Vec<f32>,
        dark: f32,
        dark_weak: f32,
        bright: f32,
        /// Shadow-like below this brightness ratio; `edge` (0: off) as in [`ColourShadow`].
        shade: f32,
        edge: f32,
    },
}

impl Prepared {
    pub fn new(model: &BackgroundModel, classifier: &Classifier) -> Self {
        let (w, h) = (model.width() as usize, model.height() as usize);
        let n = w * h;
        // Per pixel, the largest |I − round(E)| (every channel) that keeps it background.
        let mut tolerance = vec![0f32; n];
        let kind = match *classifier {
            Classifier::GreenMatte(GreenMatte {
                fraction,
                min_difference,
                noise_factor,
            }) => Kind::Green {
                limit: (0..n)
                    .map(|i| {
                        let g = model.mean(i)[1];
                        let margin = (fraction * g)
                            .max(min_difference)
                            .max(noise_factor * model.spread(i));
                        // G ≥ round(g) − t ≥ g − ½ − t stays ≥ ceil(g − margin) if t ≤ margin − 1.5.
                        tolerance[i] = margin - 1.5;
                        // G < g − margin ⇔ G < ceil(g − margin) for integer G.
                        (g - margin).ceil().clamp(0.0, 255.0) as u8
                    })
                    .collect(),
            },
            Classifier::Difference(Difference {
                min_difference,
                noise_factor,
            }) => {
                let margin: Vec<f32> = (0..n)
                    .map(|i| {
                        let m = min_difference.max(noise_factor * model.spread(i));
                        // |I − round(E)| ≤ t keeps |I − E| ≤ t + ½ ≤ m when t ≤ m − 1.5.
                        tolerance[i] = m - 1.5;
                        m
                    })
                    .collect();
                Kind::Difference {
                    bg: (0..n).map(|i| model.mean(i)).collect(),
                    margin,
                }
            }
            Classifier::ColourShadow(ColourShadow {
                chroma,
                chroma_weak,
                dark,
                dark_weak,
                bright,
                noise_factor,
                shade,
                edge,
            }) => {
                // Shadow-like pixels are only looked for when sharp regions count.
                let shade = if edge > 0.0 { shade } else { 0.0 };
                let mut bg: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
                let mut inv_e2 = Vec::with_capacity(n);
                let mut cd2: [Vec<f32>; 2] = std::array::from_fn(|_| Vec::with_capacity(n));
                let mut noise_cd2 = Vec::with_capacity(n);
                for (i, tol) in tolerance.iter_mut().enumerate() {
                    let e = model.mean(i);
                    let e2 = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).max(1.0);
                    // Noise of σ per channel moves CD by about σ/‖E‖.
                    let floor = noise_factor * model.spread(i) / e2.sqrt();
                    let (s, w) = (chroma.max(floor), chroma_weak.max(floor));
                    // A deviation of at most t per channel (plus ½ of rounding) moves CD and α
                    // by at most √3·(t + ½)/‖E‖: keep both inside the loose test.
                    let room = w.min(1.0 - dark_weak.max(shade)).min(bright - 1.0) * e2.sqrt()
                        / 3f32.sqrt();
                    *tol = room - 0.5 - 1e-3;
                    for (plane, v) in bg.iter_mut().zip(e) {
                        plane.push(v);
                    }
                    inv_e2.push(1.0 / e2);
                    cd2[0].push(s * s);
                    cd2[1].push(w * w);
                    noise_cd2.push((2.0 * model.spread(i)).powi(2) / e2);
                }
                Kind::Colour {
                    bg,
                    inv_e2,
                    cd2,
                    noise_cd2,
                    dark,
                    dark_weak,
                    bright,
                    shade,
                    edge,
                }
            }
        };
        let bg_bytes = (0..n)
            .flat_map(|i| model.mean(i).map(|v| v.round().clamp(0.0, 255.0) as u8))
            .collect();
        let blocks = w.div_ceil(BLOCK);
        let mut chunk_tolerance = Vec::with_capacity(blocks * h);
        for row in tolerance.chunks_exact(w) {
            for block in row.chunks(BLOCK) {
                let t = block.iter().copied().fold(f32::INFINITY, f32::min);
                chunk_tolerance.push(t.floor().clamp(0.0, 255.0) as u8);
            }
        }
        let per_word = 64 / BLOCK;
        let word_tolerance = chunk_tolerance
            .chunks_exact(blocks)
            .flat_map(|row| {
                row.chunks(per_word)
                    .map(|c| c.iter().copied().min().unwrap_or(0))
            })
            .collect();
        Prepared {
            kind,
            bg_bytes,
            chunk_tolerance,
            word_tolerance,
        }
    }

    /// Asks for row `y`'s bytes of the frame and of the background mean within `columns`
    /// (rounded out to 64-pixel words) to be brought into cache ahead of their comparison
    /// ([`PREFETCH_ROWS`] rows ahead): a region's part of each row is a few hundred bytes,
    /// a whole row apart from the next, which the hardware's own prefetching follows late,
    /// and a frame just captured is not in cache (tracking: silhouettes 0.40 → 0.37 ms a
    /// frame on one thread).
    ///
    /// Whole rows are one stream, which the hardware follows: nothing is asked for them
    /// (asking cost the whole frame's classification 8 %).
    fn prefetch_row(&self, frame: &[u8], y: usize, w: usize, columns: std::ops::Range<usize>) {
        if columns.start == 0 && columns.end >= w {
            return;
        }
        let (x0, x1) = (columns.start / 64 * 64, columns.end.div_ceil(64) * 64);
        let span = y * w * 3 + x0 * 3..(y * w * 3 + x1.min(w) * 3).min(frame.len());
        if span.is_empty() {
            return;
        }
        for bytes in [&frame[span.clone()], &self.bg_bytes[span]] {
            for line in bytes.chunks(64) {
                prefetch(line);
            }
        }
    }

    /// The blocks of row `y` that need classifying: for each 64-pixel word whose bytes all
    /// stay within its tolerance nothing, otherwise each of its blocks that does not.
    fn busy_blocks(
        &self,
        row: &[u8],
        bg_row: &[u8],
        y: usize,
        w: usize,
        columns: std::ops::Range<usize>,
        mut f: impl FnMut(usize, usize),
    ) {
        let blocks = w.div_ceil(BLOCK);
        let words = w.div_ceil(64);
        for c in columns.start / 64..columns.end.div_ceil(64).min(words) {
            let (x0, x1) = (c * 64, (c * 64 + 64).min(w));
            if Self::plain_backdrop(
                &row[x0 * 3..x1 * 3],
                &bg_row[x0 * 3..x1 * 3],
                self.word_tolerance[y * words + c],
            ) {
                continue;
            }
            for b in x0 / BLOCK..x1.div_ceil(BLOCK) {
                let (b0, b1) = (b * BLOCK, ((b + 1) * BLOCK).min(w));
                if !Self::plain_backdrop(
                    &row[b0 * 3..b1 * 3],
                    &bg_row[b0 * 3..b1 * 3],
                    self.chunk_tolerance[y * blocks + b],
                ) {
                    f(b0, b1);
                }
            }
        }
    }

    /// True when no byte of the chunk deviates from the background by more than `t > 0`: then
    /// every pixel in it is background under either classifier.
    #[inline]
    fn plain_backdrop(frame: &[u8], bg: &[u8], t: u8) -> bool {
        t > 0 && max_deviation(frame, bg) <= t
    }

    /// The pixels of `frame` that show the backdrop in shadow: darker than the background by
    /// more than twice its noise but not beyond any shadow (`dark`), with its chromaticity
    /// (within the loose test's limit). Only the colour-shadow classifier knows shadows
    /// (`None` for the others), and it never takes a soft one for foreground.
    pub fn shadowed(&self, frame: &RgbImage) -> Option<BitMask> {
        let Kind::Colour {
            bg,
            inv_e2,
            cd2,
            noise_cd2,
            dark,
            ..
        } = &self.kind
        else {
            return None;
        };
        let w = frame.width() as usize;
        let mut out = BitMask::new(w, frame.height() as usize);
        for (k, p) in frame.as_raw().chunks_exact(3).enumerate() {
            let i = [p[0] as f32, p[1] as f32, p[2] as f32];
            let e = [bg[0][k], bg[1][k], bg[2][k]];
            let alpha = (i[0] * e[0] + i[1] * e[1] + i[2] * e[2]) * inv_e2[k];
            let chroma = (i[0] * i[0] + i[1] * i[1] + i[2] * i[2]) * inv_e2[k] - alpha * alpha;
            // `noise_cd2` is (2σ)² / ‖E‖²: α moves by σ / ‖E‖ with noise σ per channel.
            if alpha >= *dark && alpha < 1.0 - noise_cd2[k].sqrt() && chroma <= cd2[1][k] {
                out.set(k % w, k / w, true);
            }
        }
        Some(out)
    }

    /// Classifies a frame into the foreground mask (before clean-up): the pixels of `region`
    /// (rounded out to whole 64-pixel words across), the rest background; and the part of it
    /// that is shadow-coloured: the sharp-edged shadow-like regions taken in (a grey object, or
    /// a shadow sharp enough to pass for one; colour alone cannot tell them apart).
    pub fn foreground_and_shade(&self, frame: &RgbImage, region: &impl Area) -> (BitMask, BitMask) {
        let (strong, weak, shady) = self.classify(frame, region);
        let Kind::Colour {
            bg,
            inv_e2,
            cd2,
            noise_cd2,
            edge,
            ..
        } = &self.kind
        else {
            let none = BitMask::new(strong.width(), strong.height());
            return (strong, none);
        };
        let (w, h) = (strong.width(), strong.height());
        let beside = strong.dilate(1);
        let px = frame.as_raw();
        let colour = |x: usize, y: usize| {
            let i = (y * w + x) * 3;
            [px[i] as f32, px[i + 1] as f32, px[i + 2] as f32]
        };
        // A loose pixel beside the object joins it when it is at least half covered by the
        // colour of its object neighbours (`S`, the mean of those in `own`, the object's own
        // colours): a boundary pixel, mixing the backdrop `E` and `S`, keeps the boundary at
        // half contrast and joins `out` only. It joins `own` too when its colour is the
        // object's own: differing from the backdrop's chromaticity, and either off the mixing
        // line E→S (a silvery tube's colourless highlight on green cloth, which no mix of
        // backdrop and body gives) or of `S`'s chromaticity at another brightness (the lit
        // side of a grey tube whose shaded side alone is strict), each by the loose chroma
        // limit. The pixels beside those are looked at again, up to `OWN_COLOUR_STEPS` deep,
        // by that test alone: a mix judged against a mixed neighbour would creep outward a
        // pixel a step. A step's joins are set after it, so all its pixels are judged against
        // the same neighbours (`own` is `strong` until a pixel joins so).
        // Brightness distortion `α = I·E / E·E`, and the squared chromaticity distortion
        // against the backdrop over ‖E‖².
        let alpha = |x: usize, y: usize| {
            let k = y * w + x;
            let (p, e) = (colour(x, y), bg.each_ref().map(|plane| plane[k]));
            (p[0] * e[0] + p[1] * e[1] + p[2] * e[2]) * inv_e2[k]
        };
        let cd2_at = |x: usize, y: usize| {
            let i = colour(x, y);
            let a = alpha(x, y);
            (i[0] * i[0] + i[1] * i[1] + i[2] * i[2]) * inv_e2[y * w + x] - a * a
        };
        let mut out = strong.clone();
        let mut own: Option<BitMask> = None;
        let mut ring = weak.and(&beside).and_not(&strong);
        for step in 0..=OWN_COLOUR_STEPS {
            let (mut owned, mut mixed) = (Vec::new(), Vec::new());
            let own_now = own.as_ref().unwrap_or(&strong);
            for_each_set(&ring, |x, y| {
                let (mut sum, mut n) = ([0f32; 3], 0f32);
                for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                    for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                        if own_now.get(xx, yy) {
                            let c = colour(xx, yy);
                            for k in 0..3 {
                                sum[k] += c[k];
                            }
                            n += 1.0;
                        }
                    }
                }
                let k = y * w + x;
                let e = bg.each_ref().map(|plane| plane[k]);
                let i = colour(x, y);
                let d: [f32; 3] = std::array::from_fn(|c| sum[c] / n - e[c]);
                let f: [f32; 3] = std::array::from_fn(|c| i[c] - e[c]);
                let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let c = (f[0] * d[0] + f[1] * d[1] + f[2] * d[2]) / dd.max(1e-6);
                // Squared chromaticity distortion against the backdrop, and the squared
                // distance from the mixing line, both over ‖E‖².
                let chroma = cd2_at(x, y);
                let r: [f32; 3] = std::array::from_fn(|m| f[m] - c * d[m]);
                let off = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) * inv_e2[k];
                // Squared distance from the neighbours' chromaticity (their colour at any
                // brightness), over ‖E‖²: the object's colour, lit or shaded otherwise.
                let s: [f32; 3] = std::array::from_fn(|m| sum[m] / n);
                let ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
                let beta = (i[0] * s[0] + i[1] * s[1] + i[2] * s[2]) / ss.max(1.0);
                let g: [f32; 3] = std::array::from_fn(|m| i[m] - beta * s[m]);
                let hue = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * inv_e2[k];
                let coloured = chroma > cd2[1][k];
                if coloured && (off > cd2[1][k] || (ss >= 1.0 && hue <= cd2[1][k])) {
                    owned.push((x, y));
                } else if step == 0 && c >= 0.5 {
                    mixed.push((x, y));
                }
            });
            for &(x, y) in mixed.iter().chain(&owned) {
                out.set(x, y, true);
            }
            if owned.is_empty() {
                break;
            }
            let own = own.get_or_insert_with(|| strong.clone());
            let mut joined = BitMask::new(w, h);
            for &(x, y) in &owned {
                own.set(x, y, true);
                joined.set(x, y, true);
            }
            ring = weak.and(&joined.dilate(1)).and_not(&out);
        }
        // Off the backdrop's chromaticity beyond its noise, one pixel of the backdrop in
        // twenty: a shadow keeps the chromaticity, and the few of its pixels the noise lifts
        // past this do not join up; a grey tube half covering a pixel of green cloth is 4–6
        // noise spreads off it. The noise is the larger of the background model's and the
        // frame's own (a model from one frame knows only a default spread).
        let seen_noise = std::cell::OnceCell::new();
        let tinted = |x: usize, y: usize| {
            let seen = *seen_noise.get_or_init(|| chroma_noise2(region, w, h, &cd2_at));
            cd2_at(x, y) > noise_cd2[y * w + x].max(seen)
        };
        let judged = weak.and(&beside).and_not(&out);
        along_thin_tube(
            &mut out,
            &weak,
            &weak.and_not(&judged),
            &shady,
            &strong,
            tinted,
        );
        if *edge > 0.0 {
            // Pixels beside the strict foreground are its outline, which the ring above
            // decided; what is left are regions of their own.
            let apart = shady.and_not(&beside);
            // The backdrop: neither foreground nor shadow-like.
            let backdrop = |x: usize, y: usize| !shady.get(x, y) && !strong.get(x, y);
            let object = |x: usize, y: usize| out.get(x, y);
            let sharp = crate::shade::sharp_regions(&apart, backdrop, object, alpha, *edge);
            out = out.or(&sharp);
            return (out, sharp);
        }
        let none = BitMask::new(w, h);
        (out, none)
    }

    /// A classifier with one test per pixel (`fg(pixel index, [r, g, b])`), run on the blocks
    /// that are not plain backdrop; strict and loose foreground are the same mask.
    fn single_test(
        &self,
        frame: &RgbImage,
        region: &impl Area,
        fg: impl Fn(usize, &[u8]) -> bool,
    ) -> (BitMask, BitMask, BitMask) {
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let px = frame.as_raw();
        let mut strong = BitMask::new(w, h);
        let rows = region.rows(h);
        for y in rows.clone() {
            if rows.contains(&(y + PREFETCH_ROWS)) {
                self.prefetch_row(
                    px,
                    y + PREFETCH_ROWS,
                    w,
                    region.columns(y + PREFETCH_ROWS, w),
                );
            }
            let row = &px[y * w * 3..(y + 1) * w * 3];
            let bg_row = &self.bg_bytes[y * w * 3..(y + 1) * w * 3];
            let words = strong.row_mut(y);
            self.busy_blocks(row, bg_row, y, w, region.columns(y, w), |x0, x1| {
                let mut bits = 0u64;
                for x in x0..x1 {
                    bits |= (fg(y * w + x, &row[x * 3..x * 3 + 3]) as u64) << (x - x0);
                }
                words[x0 / 64] |= bits << (x0 % 64);
            });
        }
        let weak = strong.clone();
        let shady = BitMask::new(w, h);
        (strong, weak, shady)
    }

    /// Classifies a frame: the strict foreground, the loose candidates (equal for green
    /// matting and plain difference) and the shadow-like pixels (none but for colour).
    fn classify(&self, frame: &RgbImage, region: &impl Area) -> (BitMask, BitMask, BitMask) {
        match &self.kind {
            Kind::Green { limit } => self.single_test(frame, region, |i, p| p[1] < limit[i]),
            Kind::Difference { bg, margin } => self.single_test(frame, region, |i, p| {
                let (e, m) = (bg[i], margin[i]);
                (0..3).any(|c| (p[c] as f32 - e[c]).abs() > m)
            }),
            Kind::Colour {
                bg,
                inv_e2,
                cd2,
                dark,
                dark_weak,
                bright,
                shade,
                ..
            } => {
                let (w, h) = (frame.width() as usize, frame.height() as usize);
                let px = frame.as_raw();
                let mut strong = BitMask::new(w, h);
                let mut weak = BitMask::new(w, h);
                let mut shady = BitMask::new(w, h);
                let rows = region.rows(h);
                for y in rows.clone() {
                    if rows.contains(&(y + PREFETCH_ROWS)) {
                        self.prefetch_row(
                            px,
                            y + PREFETCH_ROWS,
                            w,
                            region.columns(y + PREFETCH_ROWS, w),
                        );
                    }
                    let row = &px[y * w * 3..(y + 1) * w * 3];
                    let bg_row = &self.bg_bytes[y * w * 3..(y + 1) * w * 3];
                    let (s_row, w_row, d_row) =
                        (strong.row_mut(y), weak.row_mut(y), shady.row_mut(y));
                    self.busy_blocks(row, bg_row, y, w, region.columns(y, w), |x0, x1| {
                        let (i0, n) = (y * w + x0, x1 - x0);
                        let mut c = [[0f32; BLOCK]; 3];
                        let mut bytes = [0u8; 3 * BLOCK];
                        bytes[..3 * n].copy_from_slice(&row[x0 * 3..x1 * 3]);
                        for (k, p) in bytes.chunks_exact(3).enumerate() {
                            for ch in 0..3 {
                                c[ch][k] = p[ch] as f32;
                            }
                        }
                        // A whole block's planes as they lie; the row's last, partial one
                        // padded.
                        let whole = [&bg[0], &bg[1], &bg[2], inv_e2, &cd2[0], &cd2[1]];
                        let mut padded = [[0f32; BLOCK]; 6];
                        let [e0, e1, e2, inv, strict, loose]: [&[f32]; 6] = if n == BLOCK {
                            whole.map(|v| &v[i0..i0 + BLOCK])
                        } else {
                            for (pad, v) in padded.iter_mut().zip(whole) {
                                pad[..n].copy_from_slice(&v[i0..i0 + n]);
                            }
                            padded.each_ref().map(|p| p.as_slice())
                        };
                        let planes = BlockPlanes {
                            e: [e0, e1, e2],
                            inv,
                            limits: [strict, loose],
                        };
                        let tests = planes.tests(&c, [*dark, *dark_weak, *bright, *shade]);
                        // Bits past the row's end (a partial block) stay clear.
                        let keep = if n == BLOCK { !0 } else { (1u64 << n) - 1 };
                        let [s_bits, w_bits, d_bits] = tests.map(|t| pack_bits(&t) & keep);
                        s_row[x0 / 64] |= s_bits << (x0 % 64);
                        w_row[x0 / 64] |= w_bits << (x0 % 64);
                        d_row[x0 / 64] |= d_bits << (x0 % 64);
                    });
                }
                (strong, weak, shady)
            }
        }
    }
}

/// One block's background planes, each [`BLOCK`] values, a pixel's at its place.
struct BlockPlanes<'a> {
    /// The background colour, channel by channel.
    e: [&'a [f32]; 3],
    /// `1 / ‖E‖²`.
    inv: &'a [f32],
    /// The squared chroma limits: strict, loose.
    limits: [&'a [f32]; 2],
}

impl BlockPlanes<'_> {
    /// Each test for every pixel of colours `c` (channel by channel) as one byte, 0 or 1:
    /// strict foreground, loose foreground, shadow-like. `[dark, dark_weak, bright, shade]`
    /// are the classifier's brightness limits. The planes cut to [`BLOCK`] values first, so
    /// the loop runs as vectors of a known length.
    #[inline]
    fn tests(
        &self,
        c: &[[f32; BLOCK]; 3],
        [dark, dark_weak, bright, shade]: [f32; 4],
    ) -> [[u8; BLOCK]; 3] {
        let e = self.e.map(|v| &v[..BLOCK]);
        let inv = &self.inv[..BLOCK];
        let limits = self.limits.map(|v| &v[..BLOCK]);
        let mut tests = [[0u8; BLOCK]; 3];
        for k in 0..BLOCK {
            let (r, g, b) = (c[0][k], c[1][k], c[2][k]);
            let alpha = (r * e[0][k] + g * e[1][k] + b * e[2][k]) * inv[k];
            let cd = (r * r + g * g + b * b) * inv[k] - alpha * alpha;
            let strict = cd > limits[0][k] || alpha < dark || alpha > bright;
            let loose = cd > limits[1][k] || alpha < dark_weak || alpha > bright;
            let dim = !strict && alpha < shade;
            tests[0][k] = strict as u8;
            tests[1][k] = loose as u8;
            tests[2][k] = dim as u8;
        }
        tests
    }
}

/// The largest difference between a byte of `frame` and the byte of `bg` at its place (the
/// two of equal length): 64 bytes at a time (a word of pixels is three such), then 16 (a
/// block is three such), each in one vector's lanes; a fold over the zipped bytes vectorised
/// the words but ran a block's 48 bytes byte by byte.
#[inline]
fn max_deviation(frame: &[u8], bg: &[u8]) -> u8 {
    debug_assert_eq!(frame.len(), bg.len());
    let (wide, rest) = frame.as_chunks::<64>();
    let (bg_wide, bg_rest) = bg.as_chunks::<64>();
    let (narrow, tail) = rest.as_chunks::<16>();
    let (bg_narrow, bg_tail) = bg_rest.as_chunks::<16>();
    let wide = lane_max(wide, bg_wide);
    let narrow = lane_max(narrow, bg_narrow);
    let tail = tail
        .iter()
        .zip(bg_tail)
        .fold(0u8, |m, (a, b)| m.max(a.abs_diff(*b)));
    wide.into_iter().chain(narrow).fold(tail, u8::max)
}

/// Lane by lane, the largest difference between the chunks of `a` and those of `b`.
#[inline]
fn lane_max<const N: usize>(a: &[[u8; N]], b: &[[u8; N]]) -> [u8; N] {
    let mut lanes = [0u8; N];
    for (x, y) in a.iter().zip(b) {
        for k in 0..N {
            lanes[k] = lanes[k].max(x[k].abs_diff(y[k]));
        }
    }
    lanes
}

/// The bits of a block's tests, pixel `k`'s at bit `k` (each byte 0 or 1): eight at a time by
/// one multiplication, whose partial products land on distinct bits of the top byte.
fn pack_bits(t: &[u8; BLOCK]) -> u64 {
    t.chunks_exact(8)
        .enumerate()
        .fold(0, |bits, (half, bytes)| {
            let v = u64::from_le_bytes(bytes.try_into().unwrap_or([0; 8]));
            bits | (v.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * half)
        })
}

/// Rows ahead of the classified one whose bytes are asked for ([`Prepared::prefetch_row`]).
const PREFETCH_ROWS: usize = 6;

/// A hint that `bytes` will be read soon.
#[inline]
fn prefetch(bytes: &[u8]) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it reads nothing into the program, writes nothing and
    // cannot fault, whatever the address; this one is inside a live slice anyway.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(bytes.as_ptr().cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = bytes;
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_sim::{SimConfig, Simulator};

    #[test]
    fn shadowed_pixels_are_the_backdrop_in_shadow_not_the_tube_nor_the_lit_backdrop() {
        // The simulator's lamp shadows on green cloth, the blue tube among them: the colour
        // classifier names the pixels in shadow; the others know no shadow.
        let mut config = SimConfig::default();
        config.render.shadows = true;
        let sim = Simulator::new(config).unwrap();
        let backgrounds = sim.backgrounds();
        let pose = &sim.sweep(2)[1];
        let frame = sim.render(1, pose).unwrap();
        let (mut darker_px, mut tube_px, mut tube_shadowed) = (0, 0, 0);
        for (view, bg) in frame.views.iter().zip(&backgrounds) {
            let model = BackgroundModel::from_frames(std::slice::from_ref(bg)).unwrap();
            let colour = Prepared::new(&model, &Classifier::colour_shadow());
            let shadowed = colour.shadowed(&view.image).unwrap();
            let (w, h) = view.image.dimensions();
            for (x, y) in (0..w).flat_map(|x| (0..h).map(move |y| (x, y))) {
                let sum = |p: &image::Rgb<u8>| p.0.iter().map(|&v| v as f32).sum::<f32>();
                let (i, e) = (sum(view.image.get_pixel(x, y)), sum(bg.get_pixel(x, y)));
                let on_tube = view.mask.get_pixel(x, y).0[0] == 255;
                let is = shadowed.get(x as usize, y as usize);
                // Lit backdrop is never in shadow; backdrop darkened beyond the noise (σ 2 a
                // channel) by a tenth, its channels alike, and not as dark as the tube, always
                // is.
                assert!(!is || i < e, "({x}, {y}): {i} over {e} is not darker");
                let ratios: Vec<f32> = (0..3)
                    .map(|c| {
                        view.image.get_pixel(x, y).0[c] as f32
                            / bg.get_pixel(x, y).0[c].max(1) as f32
                    })
                    .collect();
                let spread = ratios.iter().fold(0f32, |a, &r| a.max(r))
                    - ratios.iter().fold(f32::INFINITY, |a, &r| a.min(r));
                let dark = view.mask.get_pixel(x, y).0[0] == 0
                    && spread < 0.04
                    && i < 0.9 * e
                    && i > 0.45 * e;
                darker_px += usize::from(dark);
                assert!(
                    !dark || is,
                    "({x}, {y}): {:?} over {:?} is in shadow",
                    view.image.get_pixel(x, y),
                    bg.get_pixel(x, y)
                );
                tube_px += usize::from(on_tube);
                tube_shadowed += usize::from(on_tube && is);
            }
            for other in [
                Classifier::green_matte(),
                Classifier::Difference(Difference::default()),
            ] {
                assert!(
                    Prepared::new(&model, &other)
                        .shadowed(&view.image)
                        .is_none()
                );
            }
        }
        assert!(darker_px > 200, "{darker_px}");
        // The blue tube's hue is not the cloth's: at most its darkest limb passes for shade.
        assert!(tube_shadowed * 20 < tube_px, "{tube_shadowed} of {tube_px}");
    }

    #[test]
    fn skipping_plain_backdrop_changes_no_pixel() {
        let mut config = SimConfig::default();
        config.render.shadows = true;
        let sim = Simulator::new(config).unwrap();
        let backgrounds = sim.backgrounds();
        for classifier in [
            Classifier::colour_shadow(),
            Classifier::green_matte(),
            Classifier::Difference(Difference::default()),
        ] {
            let models: Vec<BackgroundModel> = backgrounds
                .iter()
                .map(|b| BackgroundModel::from_frames(std::slice::from_ref(b)).unwrap())
                .collect();
            let mut skipped = 0;
            for (i, pose) in sim.sweep(3).iter().enumerate() {
                let f = sim.render(i as u64, pose).unwrap();
                for (view, model) in f.views.iter().zip(&models) {
                    let fast = Prepared::new(model, &classifier);
                    skipped += fast.chunk_tolerance.iter().filter(|&&t| t > 0).count();
                    let exhaustive = Prepared {
                        chunk_tolerance: vec![0; fast.chunk_tolerance.len()],
                        word_tolerance: vec![0; fast.word_tolerance.len()],
                        ..fast.clone()
                    };
                    assert_eq!(
                        fast.classify(&view.image, &Region::ALL),
                        exhaustive.classify(&view.image, &Region::ALL)
                    );
                }
            }
            assert!(
                skipped > 10_000,
                "the skip test never applied ({skipped} chunks)"
            );
        }
    }

    #[test]
    fn the_largest_deviation_is_the_largest_byte_difference() {
        // Lengths around the 64- and 16-byte lanes (a block is 48 bytes, a word 192), the
        // largest difference at every place in turn.
        for len in [0, 1, 15, 16, 17, 47, 48, 49, 63, 64, 65, 80, 127, 192] {
            for at in 0..len {
                let bg: Vec<u8> = (0..len).map(|i| (i * 37 % 251) as u8).collect();
                let mut frame: Vec<u8> = bg.iter().map(|&b| b.wrapping_add(3)).collect();
                frame[at] = bg[at].wrapping_sub(90);
                let naive = frame.iter().zip(&bg).map(|(a, b)| a.abs_diff(*b)).max();
                assert_eq!(max_deviation(&frame, &bg), naive.unwrap_or(0), "{len} {at}");
            }
        }
        assert_eq!(max_deviation(&[], &[]), 0);
    }

    #[test]
    fn packed_bits_are_the_bytes_in_order() {
        let mut x = 7u64;
        for _ in 0..200 {
            let bytes: [u8; BLOCK] = std::array::from_fn(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 63) as u8
            });
            let one_by_one = (0..BLOCK).fold(0u64, |m, k| m | u64::from(bytes[k]) << k);
            assert_eq!(pack_bits(&bytes), one_by_one, "{bytes:?}");
        }
    }

    /// The colour tests of every pixel, written out one pixel at a time from the model's
    /// planes, against the blocks' vector loop.
    #[test]
    fn the_colour_blocks_test_each_pixel_as_written() {
        let mut config = SimConfig::default();
        config.render.shadows = true;
        let sim = Simulator::new(config).unwrap();
        let mut frame = sim.render(0, &sim.sweep(1)[0]).unwrap().views[0]
            .image
            .clone();
        // Something at the images' right edge, so that a row's last block is classified.
        for y in 100..140 {
            for x in 600..640 {
                frame.put_pixel(x, y, image::Rgb([200, 30, 30]));
            }
        }
        let backdrop = sim.backgrounds()[0].clone();
        // Whole blocks, and rows ending in a partial block (630 = 39·16 + 6).
        for width in [640, 630] {
            let crop =
                |i: &RgbImage| image::imageops::crop_imm(i, 0, 0, width, i.height()).to_image();
            let model = BackgroundModel::from_frames(&[crop(&backdrop)]).unwrap();
            colour_blocks_as_written(&model, &crop(&frame));
        }
    }

    /// The colour classifier's three masks of `frame` against its tests written out per pixel
    /// (skipped blocks included: skipping is exact), with no bit set past the image's width.
    fn colour_blocks_as_written(model: &BackgroundModel, frame: &RgbImage) {
        let colour = ColourShadow {
            edge: 0.5,
            ..ColourShadow::default()
        };
        let prepared = Prepared::new(model, &Classifier::ColourShadow(colour));
        let Kind::Colour {
            bg,
            inv_e2,
            cd2,
            dark,
            dark_weak,
            bright,
            shade,
            ..
        } = &prepared.kind
        else {
            panic!("a colour classifier")
        };
        let (strong, weak, shady) = prepared.classify(frame, &Region::ALL);
        let mut set = [0; 3];
        for (x, y, p) in frame.enumerate_pixels() {
            let (x, y) = (x as usize, y as usize);
            let i = y * frame.width() as usize + x;
            let [r, g, b] = p.0.map(f32::from);
            let alpha = (r * bg[0][i] + g * bg[1][i] + b * bg[2][i]) * inv_e2[i];
            let cd = (r * r + g * g + b * b) * inv_e2[i] - alpha * alpha;
            let strict = cd > cd2[0][i] || alpha < *dark || alpha > *bright;
            let loose = cd > cd2[1][i] || alpha < *dark_weak || alpha > *bright;
            let dim = !strict && alpha < *shade;
            let got = [strong.get(x, y), weak.get(x, y), shady.get(x, y)];
            assert_eq!(got, [strict, loose, dim], "pixel ({x}, {y})");
            for (n, t) in set.iter_mut().zip([strict, loose, dim]) {
                *n += usize::from(t);
            }
        }
        assert!(set[0] > 1000, "{} strict pixels", set[0]);
        assert_eq!([strong.count(), weak.count(), shady.count()], set);
    }

    /// A frame of the green backdrop with vertical stripes over rows 5..45: `(columns,
    /// colour)` each.
    fn striped(stripes: &[(std::ops::Range<u32>, [u8; 3])]) -> RgbImage {
        let mut frame = RgbImage::from_pixel(50, 50, image::Rgb(GREEN));
        for (columns, colour) in stripes {
            for x in columns.clone() {
                for y in 5..45 {
                    frame.put_pixel(x, y, image::Rgb(*colour));
                }
            }
        }
        frame
    }

    const GREEN: [u8; 3] = [177, 222, 167];
    /// A silvery tube's dark body and its colourless highlight (brighter than the green cloth
    /// in red and blue, darker in green: loose, not strict, and no mix of cloth and body).
    const BODY: [u8; 3] = [60, 60, 60];
    const HIGHLIGHT: [u8; 3] = [211, 210, 213];

    /// The colour classifier's foreground, without its sharp-outline rule (which by design
    /// takes a shadow as sharp as these stripes for a grey object).
    fn colour_foreground(frame: &RgbImage) -> BitMask {
        let model = BackgroundModel::uniform(50, 50, GREEN.map(f32::from), 2.0).unwrap();
        let c = Classifier::ColourShadow(ColourShadow {
            edge: 0.0,
            ..ColourShadow::default()
        });
        Prepared::new(&model, &c)
            .foreground_and_shade(frame, &Region::ALL)
            .0
    }

    /// Row 25 of the foreground of [`striped`]`(stripes)` over `columns`: `#` object, `.` not.
    fn foreground_row(
        stripes: &[(std::ops::Range<u32>, [u8; 3])],
        columns: std::ops::Range<usize>,
    ) -> String {
        let fg = colour_foreground(&striped(stripes));
        columns
            .map(|x| if fg.get(x, 25) { '#' } else { '.' })
            .collect()
    }

    #[test]
    fn a_highlight_in_the_objects_own_colour_is_object() {
        // In the middle of the body, and along its edge, 3 px wide: every column of it is
        // object, and the backdrop beside it is not.
        for stripes in [
            [(20..23, BODY), (23..26, HIGHLIGHT), (26..29, BODY)].as_slice(),
            &[(20..26, BODY), (26..29, HIGHLIGHT)],
        ] {
            assert_eq!(foreground_row(stripes, 18..31), "..#########..");
        }
    }

    #[test]
    fn a_grey_tubes_lit_side_is_object() {
        // Only the shaded side (3 px) is darker than any shadow; the lit side (5 px) differs
        // from the green cloth only in chromaticity, by little, and lies near the mix of cloth
        // and shaded body — but it is the body's grey at another brightness.
        let lit = [140, 142, 139];
        let row = foreground_row(&[(20..23, BODY), (23..28, lit)], 18..30);
        assert_eq!(row, "..########..");
    }

    #[test]
    fn a_shadow_beside_the_object_is_not_followed() {
        // A blue body, then its shadow (the cloth at half its light, the cloth's
        // chromaticity) 6 px wide: the shadow's first column mixes like a boundary pixel and
        // may join; the rest is not the object's colour and stays out.
        let shadow = GREEN.map(|c| c / 2);
        let row = foreground_row(&[(20..29, [40, 50, 110]), (29..35, shadow)], 18..37);
        assert_eq!(row, "..##########.......");
    }

    #[test]
    fn difference_marks_pixels_off_the_backdrop_in_any_channel() {
        let model = BackgroundModel::uniform(70, 3, [10.0, 10.0, 10.0], 2.0).unwrap();
        let d = Difference {
            min_difference: 40.0,
            noise_factor: 4.0,
        };
        let mut frame = RgbImage::from_pixel(70, 3, image::Rgb([10, 10, 10]));
        frame.put_pixel(5, 1, image::Rgb([10, 51, 10])); // 41 above: foreground
        frame.put_pixel(66, 1, image::Rgb([10, 10, 49])); // 39 above: background
        frame.put_pixel(67, 2, image::Rgb([200, 0, 0]));
        let fg = Prepared::new(&model, &Classifier::Difference(d))
            .foreground_and_shade(&frame, &Region::ALL)
            .0;
        assert_eq!(fg.count(), 2);
        assert!(fg.get(5, 1) && fg.get(67, 2));
    }
}
