//! The background model: per-pixel mean colour and spread from one or more frames without the
//! object.

use std::path::{Path, PathBuf};

use image::{ImageBuffer, Luma, RgbImage};

use crate::bitmask::BitMask;
use crate::error::SilhouetteError;

/// Spread assumed when the model comes from a single frame, grey levels.
pub const DEFAULT_SPREAD: f32 = 2.5;

/// A pixel [`BackgroundModel::absorb`] counts as changed moved by this many spreads...
pub const CHANGED_SPREADS: f32 = 4.0;
/// ...and at least this many grey levels.
pub const CHANGED_LEVELS: f32 = 8.0;

/// Window half-widths [`BackgroundModel::absorb`] tries in turn, pixels: the first whose window
/// holds [`FILL_SAMPLES`] unmarked pixels gives a pixel's change.
const FILL_RADII: [usize; 6] = [1, 2, 4, 8, 16, 32];
/// Unmarked pixels a window needs.
const FILL_SAMPLES: u32 = 6;
/// A window's mean change [`BackgroundModel::absorb`] takes in is at least this many times
/// the noise of a mean over its pixels (`spread / √n`) in some channel: below, it is the
/// frame's noise, which taken in again and again would walk the background away from the
/// backdrop (a run that followed its backdrop a few dozen times had moved a third of one
/// camera's pixels by more than 4 grey levels, and the tube's silhouette grew ghosts).
const SIGNIFICANT_NOISES: f32 = 4.0;

/// Summed-area table of `frame − mean` (per channel) and of the count over unmarked pixels.
struct ChangeTable {
    width: usize,
    height: usize,
    /// `(width + 1) × (height + 1)`: sums over `[0, x) × [0, y)`.
    sums: Vec<([f64; 3], u32)>,
}

impl ChangeTable {
    fn new(mean: &[[f32; 3]], frame: &RgbImage, keep: &BitMask) -> Self {
        let (w, h) = (keep.width(), keep.height());
        let stride = w + 1;
        let mut sums = vec![([0f64; 3], 0u32); stride * (h + 1)];
        let raw = frame.as_raw();
        for y in 0..h {
            let mut row = ([0f64; 3], 0u32);
            for x in 0..w {
                if !keep.get(x, y) {
                    let i = y * w + x;
                    for c in 0..3 {
                        row.0[c] += f64::from(raw[3 * i + c]) - f64::from(mean[i][c]);
                    }
                    row.1 += 1;
                }
                let above = sums[y * stride + x + 1];
                sums[(y + 1) * stride + x + 1] = (
                    std::array::from_fn(|c| above.0[c] + row.0[c]),
                    above.1 + row.1,
                );
            }
        }
        ChangeTable {
            width: w,
            height: h,
            sums,
        }
    }

    /// The mean change over the unmarked pixels within `r` of `(x, y)` (a square window cut by
    /// the image), if there are at least `min` of them.
    fn mean_change(&self, x: usize, y: usize, r: usize, min: u32) -> Option<([f32; 3], u32)> {
        let stride = self.width + 1;
        let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
        let (x1, y1) = ((x + r + 1).min(self.width), (y + r + 1).min(self.height));
        let at = |x: usize, y: usize| self.sums[y * stride + x];
        let (a, b, c, d) = (at(x1, y1), at(x0, y1), at(x1, y0), at(x0, y0));
        let n = a.1 + d.1 - b.1 - c.1;
        (n >= min).then(|| {
            let mean = std::array::from_fn(|k| {
                ((a.0[k] + d.0[k] - b.0[k] - c.0[k]) / f64::from(n)) as f32
            });
            (mean, n)
        })
    }
}

/// Per-pixel statistics of the empty scene (0–255 scale).
#[derive(Debug, Clone, PartialEq)]
pub struct BackgroundModel {
    width: u32,
    height: u32,
    /// Mean RGB per pixel, row-major.
    mean: Vec<[f32; 3]>,
    /// Standard deviation per pixel (over frames, pooled over channels), grey levels.
    spread: Vec<f32>,
}

impl BackgroundModel {
    /// From background frames of equal size. One frame gives the mean and a uniform spread of
    /// [`DEFAULT_SPREAD`]; several give per-pixel spreads (never below 0.5 grey levels).
    pub fn from_frames(frames: &[RgbImage]) -> Result<Self, SilhouetteError> {
        let first = frames.first().ok_or(SilhouetteError::NoBackground)?;
        let (width, height) = first.dimensions();
        if width == 0 || height == 0 {
            return Err(SilhouetteError::EmptyFrame);
        }
        for f in frames {
            if f.dimensions() != (width, height) {
                return Err(SilhouetteError::SizeMismatch {
                    width: f.width(),
                    height: f.height(),
                    expected_width: width,
                    expected_height: height,
                });
            }
        }
        let n = (width * height) as usize;
        let mut sum = vec![[0f64; 3]; n];
        let mut sum2 = vec![0f64; n];
        for f in frames {
            for (i, p) in f.pixels().enumerate() {
                for c in 0..3 {
                    let v = p[c] as f64;
                    sum[i][c] += v;
                    sum2[i] += v * v;
                }
            }
        }
        let k = frames.len() as f64;
        let mean: Vec<[f32; 3]> = sum.iter().map(|s| s.map(|v| (v / k) as f32)).collect();
        let spread = if frames.len() == 1 {
            vec![DEFAULT_SPREAD; n]
        } else {
            sum2.iter()
                .zip(&sum)
                .map(|(&s2, s)| {
                    let m2: f64 = s.iter().map(|v| (v / k) * (v / k)).sum();
                    let var = (s2 / k - m2) / 3.0 * k / (k - 1.0);
                    (var.max(0.0).sqrt() as f32).max(0.5)
                })
                .collect()
        };
        Ok(BackgroundModel {
            width,
            height,
            mean,
            spread,
        })
    }

    /// One model per camera, each from its camera's single empty frame (the simulator's
    /// backgrounds, or one captured frame each), in order.
    pub fn each(frames: &[RgbImage]) -> Result<Vec<Self>, SilhouetteError> {
        frames
            .iter()
            .map(|f| Self::from_frames(std::slice::from_ref(f)))
            .collect()
    }

    /// A backdrop of one colour everywhere (e.g. black cloth or a lit screen), when no empty
    /// frame was recorded. `colour` is RGB and `spread` the noise, both in grey levels.
    pub fn uniform(
        width: u32,
        height: u32,
        colour: [f32; 3],
        spread: f32,
    ) -> Result<Self, SilhouetteError> {
        if width == 0 || height == 0 {
            return Err(SilhouetteError::EmptyFrame);
        }
        if colour.iter().any(|c| !(0.0..=255.0).contains(c)) || !(0.0..=255.0).contains(&spread) {
            return Err(SilhouetteError::Setting {
                field: "background",
                problem: format!("colour {colour:?} and spread {spread} must lie in [0, 255]"),
            });
        }
        let n = (width * height) as usize;
        Ok(BackgroundModel {
            width,
            height,
            mean: vec![colour; n],
            spread: vec![spread; n],
        })
    }

    /// Image width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Mean colour of pixel index `i` (row-major).
    pub fn mean(&self, i: usize) -> [f32; 3] {
        self.mean[i]
    }

    /// Mean colours of every pixel, row-major (0–255 scale).
    pub fn means(&self) -> &[[f32; 3]] {
        &self.mean
    }

    /// Whether the background is in colour: some pixel's channels differ by more than 4 grey
    /// levels (a greyscale camera's are equal). Looks at every pixel: call it once.
    pub fn in_colour(&self) -> bool {
        self.mean.iter().any(|m| {
            let (lo, hi) = m
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            hi - lo > 4.0
        })
    }

    /// Follows a backdrop that changed since the model was made (cloth folds that moved, a
    /// lamp moved) to how `frame` shows it, except for the pixels `keep` marks (an object in
    /// front of it). Such changes are smooth at the scale of a few pixels, so the change
    /// `frame − mean` is averaged over the unmarked pixels of the 3×3 window around each pixel
    /// (a single frame's noise is not taken in), or of a window wide enough to hold
    /// `FILL_SAMPLES` (6) of them — which carries the change in under the marked pixels, where
    /// the backdrop is hidden. A pixel takes its window's change only where that stands out of
    /// the noise of such a mean (4 × `spread / √n` in some channel), so that following the
    /// backdrop many times never adds up noise. The spread stays. Returns how many pixels
    /// changed by more than [`CHANGED_SPREADS`] spreads (at least [`CHANGED_LEVELS`] grey
    /// levels) in some channel.
    pub fn absorb(&mut self, frame: &RgbImage, keep: &BitMask) -> Result<usize, SilhouetteError> {
        let (w, h) = (self.width as usize, self.height as usize);
        if frame.dimensions() != (self.width, self.height)
            || (keep.width(), keep.height()) != (w, h)
        {
            return Err(self.size_mismatch(frame.width(), frame.height()));
        }
        let table = ChangeTable::new(&self.mean, frame, keep);
        let mut changed = 0;
        for y in 0..h {
            for x in 0..w {
                let Some((change, n)) = FILL_RADII
                    .iter()
                    .find_map(|&r| table.mean_change(x, y, r, FILL_SAMPLES))
                else {
                    continue;
                };
                let i = y * w + x;
                let noise = SIGNIFICANT_NOISES * self.spread[i] / (n as f32).sqrt();
                if change.iter().all(|d| d.abs() <= noise) {
                    continue;
                }
                if change.iter().any(|d| d.abs() > self.changed_limit(i)) {
                    changed += 1;
                }
                for (m, d) in self.mean[i].iter_mut().zip(change) {
                    *m = (*m + d).clamp(0.0, 255.0);
                }
            }
        }
        Ok(changed)
    }

    /// How far pixel `i`'s mean may move before it counts as changed: [`CHANGED_SPREADS`]
    /// spreads, at least [`CHANGED_LEVELS`] grey levels.
    fn changed_limit(&self, i: usize) -> f32 {
        (CHANGED_SPREADS * self.spread[i]).max(CHANGED_LEVELS)
    }

    /// Whether `colour` lies farther from pixel `i`'s mean than counts as changed, in some
    /// channel.
    fn departs(&self, i: usize, colour: [f32; 3]) -> bool {
        let limit = self.changed_limit(i);
        self.mean[i]
            .iter()
            .zip(colour)
            .any(|(m, c)| (m - c).abs() > limit)
    }

    /// The pixels whose mean differs from `captured`'s by more than counts as changed (see
    /// [`BackgroundModel::absorb`]): where a background that followed its backdrop is no longer
    /// the one captured. Models of another size differ everywhere.
    pub fn changed_from(&self, captured: &BackgroundModel) -> BitMask {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut mask = BitMask::new(w, h);
        if (captured.width, captured.height) != (self.width, self.height) {
            return mask.not();
        }
        for (i, &colour) in captured.mean.iter().enumerate() {
            if self.departs(i, colour) {
                mask.set(i % w, i / w, true);
            }
        }
        mask
    }

    /// The pixels where `frame` shows this background: every channel within what counts as
    /// changed of the mean (see [`BackgroundModel::absorb`]).
    pub fn shown_by(&self, frame: &RgbImage) -> Result<BitMask, SilhouetteError> {
        let (w, h) = (self.width as usize, self.height as usize);
        if frame.dimensions() != (self.width, self.height) {
            return Err(self.size_mismatch(frame.width(), frame.height()));
        }
        let mut mask = BitMask::new(w, h);
        for (i, p) in frame.pixels().enumerate() {
            if !self.departs(i, p.0.map(f32::from)) {
                mask.set(i % w, i / w, true);
            }
        }
        Ok(mask)
    }

    /// Takes `captured`'s mean and spread back at the pixels `mask` marks (a background that
    /// followed its backdrop, where the frames show the backdrop as it was captured again).
    /// Returns how many of them had changed (see [`BackgroundModel::changed_from`]).
    pub fn restore(
        &mut self,
        captured: &BackgroundModel,
        mask: &BitMask,
    ) -> Result<usize, SilhouetteError> {
        let (w, h) = (self.width as usize, self.height as usize);
        if (captured.width, captured.height) != (self.width, self.height)
            || (mask.width(), mask.height()) != (w, h)
        {
            return Err(self.size_mismatch(captured.width, captured.height));
        }
        let changed = self.changed_from(captured).and(mask);
        for y in 0..h {
            for x in 0..w {
                if mask.get(x, y) {
                    let i = y * w + x;
                    self.mean[i] = captured.mean[i];
                    self.spread[i] = captured.spread[i];
                }
            }
        }
        Ok(changed.count())
    }

    fn size_mismatch(&self, width: u32, height: u32) -> SilhouetteError {
        SilhouetteError::SizeMismatch {
            width,
            height,
            expected_width: self.width,
            expected_height: self.height,
        }
    }

    /// Spread of pixel index `i`, grey levels.
    pub fn spread(&self, i: usize) -> f32 {
        self.spread[i]
    }

    /// The spread file stored beside a background image `camK.png`: `camK.spread.png`.
    pub fn spread_path(image: &Path) -> PathBuf {
        image.with_extension("spread.png")
    }

    /// Saves the mean as an 8-bit PNG at `path` (the recording's `background/camK.png`) and the
    /// spread as a 16-bit grey PNG beside it (`camK.spread.png`, value = spread × 256).
    pub fn save(&self, path: &Path) -> Result<(), SilhouetteError> {
        let file_err = |p: &Path, e: image::ImageError| SilhouetteError::File {
            path: p.to_path_buf(),
            message: e.to_string(),
        };
        let mean = RgbImage::from_fn(self.width, self.height, |x, y| {
            let m = self.mean[(y * self.width + x) as usize];
            image::Rgb(m.map(|v| v.round().clamp(0.0, 255.0) as u8))
        });
        mean.save(path).map_err(|e| file_err(path, e))?;
        let spread: ImageBuffer<Luma<u16>, Vec<u16>> =
            ImageBuffer::from_fn(self.width, self.height, |x, y| {
                Luma([(self.spread[(y * self.width + x) as usize] * 256.0)
                    .round()
                    .clamp(0.0, 65535.0) as u16])
            });
        let sp = Self::spread_path(path);
        spread.save(&sp).map_err(|e| file_err(&sp, e))
    }

    /// Loads a model saved by [`BackgroundModel::save`]; a plain background image without a
    /// spread file gives a uniform spread of [`DEFAULT_SPREAD`].
    pub fn load(path: &Path) -> Result<Self, SilhouetteError> {
        let file_err = |p: &Path, message: String| SilhouetteError::File {
            path: p.to_path_buf(),
            message,
        };
        let img = bounded_image(path)
            .map_err(|e| file_err(path, format!("cannot read background image: {e}")))?
            .to_rgb8();
        let mut model = Self::from_frames(std::slice::from_ref(&img))?;
        let sp = Self::spread_path(path);
        if sp.is_file() {
            let spread = bounded_image(&sp)
                .map_err(|e| file_err(&sp, format!("cannot read spread image: {e}")))?
                .to_luma16();
            if spread.dimensions() != img.dimensions() {
                return Err(file_err(
                    &sp,
                    format!(
                        "spread image is {}×{} but the background is {}×{}",
                        spread.width(),
                        spread.height(),
                        img.width(),
                        img.height()
                    ),
                ));
            }
            model.spread = spread
                .pixels()
                .map(|p| (p[0] as f32 / 256.0).max(0.5))
                .collect();
        }
        Ok(model)
    }
}

/// An image file, refused before opening when it is not a regular file (a FIFO would block,
/// `/dev/zero` never ends) and before decoding when it is over 16384 pixels a side.
fn bounded_image(path: &Path) -> Result<image::DynamicImage, String> {
    if !std::fs::metadata(path)
        .map_err(|e| e.to_string())?
        .is_file()
    {
        return Err("not a regular file".into());
    }
    let mut reader = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(16_384);
    limits.max_image_height = Some(16_384);
    reader.limits(limits);
    reader.decode().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_spread_from_frames() {
        let a = RgbImage::from_pixel(4, 3, image::Rgb([100, 150, 200]));
        let b = RgbImage::from_pixel(4, 3, image::Rgb([104, 154, 204]));
        let m = BackgroundModel::from_frames(&[a.clone(), b]).unwrap();
        assert_eq!(m.mean(5), [102.0, 152.0, 202.0]);
        // Sample std of {100, 104} is 2·√2.
        assert!((m.spread(5) - 8f32.sqrt()).abs() < 1e-4);
        let single = BackgroundModel::from_frames(&[a]).unwrap();
        assert_eq!(single.spread(0), DEFAULT_SPREAD);
        assert!(matches!(
            BackgroundModel::from_frames(&[]),
            Err(SilhouetteError::NoBackground)
        ));
        let c = RgbImage::new(5, 3);
        assert!(matches!(
            BackgroundModel::from_frames(&[RgbImage::new(4, 3), c]),
            Err(SilhouetteError::SizeMismatch { .. })
        ));
    }

    #[test]
    fn absorb_follows_a_smooth_change_and_carries_it_under_what_is_kept() {
        let mut m =
            BackgroundModel::from_frames(&[RgbImage::from_pixel(16, 8, image::Rgb([100; 3]))])
                .unwrap();
        // Left of column 8 the backdrop grew 40 levels brighter; columns 8–10 are an object
        // (kept); to the right, only ±6 levels of noise in a checkerboard.
        let frame = RgbImage::from_fn(16, 8, |x, y| match x {
            0..=7 => image::Rgb([140; 3]),
            8..=10 => image::Rgb([0; 3]),
            _ => image::Rgb([if (x + y) % 2 == 0 { 106 } else { 94 }; 3]),
        });
        let mut keep = BitMask::new(16, 8);
        for y in 0..8 {
            keep.set_span(y, 8, 10);
        }
        let changed = m.absorb(&frame, &keep).unwrap();
        assert_eq!(m.mean(4 * 16 + 3), [140.0; 3]);
        // Under the object: the change of the nearest 5×5 window's unmarked pixels, columns 7
        // (+40) and 11 (noise about 0): about +20, never the object's colour.
        let under = m.mean(4 * 16 + 9)[0];
        assert!((under - 120.0).abs() < 2.0, "{under}");
        // The noise averages out over 3×3.
        let right = m.mean(4 * 16 + 13)[0];
        assert!((right - 100.0).abs() < 1.0, "{right}");
        assert_eq!(m.spread(0), DEFAULT_SPREAD);
        // Columns 0–7 changed, some of the kept ones by what was carried in, none right of them.
        assert!((64..=88).contains(&changed), "{changed}");
        assert!(matches!(
            m.absorb(&RgbImage::new(3, 2), &keep),
            Err(SilhouetteError::SizeMismatch { .. })
        ));
    }

    /// Frames of the unchanged backdrop with noise of the model's spread, taken in again and
    /// again (a run that follows its backdrop on every frame that it cannot explain): the
    /// background stays the backdrop. Taking in every window's mean change walked it away
    /// (after 200 frames every pixel was more than 3 levels off, the worst 135; now 6 of
    /// 1,536 are, the worst by 3.5).
    #[test]
    fn absorbing_noise_again_and_again_leaves_the_background() {
        let (w, h) = (48u32, 32u32);
        let mut m =
            BackgroundModel::from_frames(&[RgbImage::from_pixel(w, h, image::Rgb([120; 3]))])
                .unwrap();
        let keep = BitMask::new(w as usize, h as usize);
        // Uniform noise of standard deviation DEFAULT_SPREAD (± √3 · 2.5 levels).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut noise = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 3f64.sqrt() * 2.5
        };
        let mut taken = 0;
        for _ in 0..200 {
            let frame = RgbImage::from_fn(w, h, |_, _| {
                image::Rgb(std::array::from_fn(|_| (120.0 + noise()).round() as u8))
            });
            taken += m.absorb(&frame, &keep).unwrap();
        }
        let worst = m
            .means()
            .iter()
            .flatten()
            .map(|v| (v - 120.0).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 4.0, "worst pixel {worst:.2} levels off");
        assert_eq!(taken, 0);
    }

    #[test]
    fn restore_takes_the_captured_background_back_where_asked() {
        let captured =
            BackgroundModel::from_frames(&[RgbImage::from_pixel(8, 4, image::Rgb([100; 3]))])
                .unwrap();
        let mut followed = captured.clone();
        // A dark patch taken in at columns 2–4 (a ghost), a faint one at column 6.
        followed
            .absorb(
                &RgbImage::from_fn(8, 4, |x, _| match x {
                    2..=4 => image::Rgb([20; 3]),
                    6 => image::Rgb([104; 3]),
                    _ => image::Rgb([100; 3]),
                }),
                &BitMask::new(8, 4),
            )
            .unwrap();
        let changed = followed.changed_from(&captured);
        assert!(
            changed.get(3, 1) && !changed.get(6, 1) && !changed.get(7, 0) && !changed.get(0, 1)
        );
        let mut mask = BitMask::new(8, 4);
        mask.set_span(1, 0, 7);
        let restored = followed.restore(&captured, &mask).unwrap();
        assert_eq!(restored, changed.and(&mask).count());
        assert!(restored >= 3, "{restored}");
        assert_eq!(followed.mean(8 + 3), [100.0; 3]);
        assert!(followed.mean(2 * 8 + 3)[0] < 90.0, "row 2 is not asked for");
        let shown = captured
            .shown_by(&RgbImage::from_fn(8, 4, |x, _| {
                image::Rgb([if x == 5 { 89 } else { 110 }; 3])
            }))
            .unwrap();
        assert_eq!(
            shown.count(),
            28,
            "within 10 levels (4 spreads) but column 5"
        );
        assert!(!shown.get(5, 0));
        assert!(matches!(
            followed.restore(&captured, &BitMask::new(3, 2)),
            Err(SilhouetteError::SizeMismatch { .. })
        ));
    }

    #[test]
    fn save_and_load_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let frames: Vec<RgbImage> = (0..4u8)
            .map(|k| {
                RgbImage::from_fn(6, 5, |x, y| {
                    image::Rgb([x as u8 * 10 + k, y as u8 * 20, 100 + 2 * k])
                })
            })
            .collect();
        let m = BackgroundModel::from_frames(&frames).unwrap();
        let path = dir.path().join("cam0.png");
        m.save(&path).unwrap();
        assert!(dir.path().join("cam0.spread.png").is_file());
        let back = BackgroundModel::load(&path).unwrap();
        for i in 0..30 {
            for c in 0..3 {
                assert!((back.mean(i)[c] - m.mean(i)[c]).abs() <= 0.5);
            }
            assert!((back.spread(i) - m.spread(i)).abs() < 1.0 / 256.0);
        }
    }
}
