//! Marker bands (coloured tape) inside the object mask.
//!
//! At the object's edge a pixel mixes tape (or body) with the backdrop, and its colour says
//! little; inside, it is pure surface colour. So interior pixels (the object eroded by one
//! pixel) are tested by colour — the angle between their RGB vector and the tape's — and each
//! edge pixel takes the majority label of the interior pixels around it.

use flexshape_rig::quoted;
use image::RgbImage;
use serde::{Deserialize, Serialize};

use crate::bitmask::BitMask;
use crate::error::SilhouetteError;

/// What the tape looks like.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MarkerSettings {
    /// Tape colour as RGB proportions (only the direction counts); default red.
    pub colour: [f32; 3],
    /// Largest angle between a pixel's RGB vector and `colour`, degrees.
    pub max_angle_deg: f32,
    /// Darkest tape pixel that is tested (sum of R, G, B), so noise in black is ignored.
    pub min_level: f32,
}

impl Default for MarkerSettings {
    fn default() -> Self {
        MarkerSettings {
            colour: [0.78, 0.09, 0.08],
            max_angle_deg: 25.0,
            min_level: 40.0,
        }
    }
}

/// A [`MarkerSettings::min_level`] above any pixel's R + G + B: no pixel is tested as tape.
pub const MARKERS_OFF: f32 = 766.0;

impl MarkerSettings {
    pub(crate) fn validate(&self) -> Result<(), SilhouetteError> {
        let norm = self.colour.iter().map(|c| c * c).sum::<f32>().sqrt();
        if !(norm.is_finite() && norm > 0.0) || self.colour.iter().any(|c| *c < 0.0) {
            return Err(SilhouetteError::Setting {
                field: "markers.colour",
                problem: "must be three non-negative numbers, not all zero".into(),
            });
        }
        // A sum of three 8-bit channels, or one past the brightest: no pixel is tested (masks
        // carry no bands). NaN left every band unfound.
        if !(0.0..=MARKERS_OFF).contains(&self.min_level) {
            return Err(SilhouetteError::Setting {
                field: "markers.min_level",
                problem: format!(
                    "{} must lie in [0, 765] (the sum of R, G and B), or be {MARKERS_OFF}: no band is read",
                    quoted(self.min_level)
                ),
            });
        }
        if !(self.max_angle_deg > 0.0 && self.max_angle_deg < 90.0) {
            return Err(SilhouetteError::Setting {
                field: "markers.max_angle_deg",
                problem: "must lie in (0, 90)".into(),
            });
        }
        Ok(())
    }
}

/// Calls `f(x, y)` for every set pixel.
pub(crate) fn for_each_set(mask: &BitMask, mut f: impl FnMut(usize, usize)) {
    for y in 0..mask.height() {
        for (i, &w) in mask.row(y).iter().enumerate() {
            let mut w = w;
            while w != 0 {
                let b = w.trailing_zeros() as usize;
                f(i * 64 + b, y);
                w &= w - 1;
            }
        }
    }
}

/// The marker mask of `frame` within `object`.
pub(crate) fn find_markers(frame: &RgbImage, object: &BitMask, s: &MarkerSettings) -> BitMask {
    let interior = object.erode(1).and(object);
    let tape = tape_inside(frame, &interior, s);
    let mut out = tape.clone();
    // An edge pixel with no tape within 2 pixels has no vote for it: only those near tape
    // are counted (tape is a few bands; the edge runs all along the object).
    let edge = object.and_not(&interior).and(&tape.dilate(2));
    for_each_set(&edge, |x, y| {
        if voted_tape(&interior, &tape, x, y) {
            out.set(x, y, true);
        }
    });
    out
}

/// The pixels of `interior` whose colour is the tape's.
fn tape_inside(frame: &RgbImage, interior: &BitMask, s: &MarkerSettings) -> BitMask {
    let w = interior.width();
    let norm = s.colour.iter().map(|c| c * c).sum::<f32>().sqrt();
    let t = s.colour.map(|c| c / norm);
    let cos_min = s.max_angle_deg.to_radians().cos();
    let px = frame.as_raw();
    let mut tape = BitMask::new(w, interior.height());
    for_each_set(interior, |x, y| {
        let i = (y * w + x) * 3;
        let (r, g, b) = (px[i] as f32, px[i + 1] as f32, px[i + 2] as f32);
        let len = (r * r + g * g + b * b).sqrt();
        if r + g + b >= s.min_level && (r * t[0] + g * t[1] + b * t[2]) >= cos_min * len {
            tape.set(x, y, true);
        }
    });
    tape
}

/// Whether the edge pixel `(x, y)` is tape: the majority of the interior pixels within 1 of
/// it, or within 2 when none is within 1.
fn voted_tape(interior: &BitMask, tape: &BitMask, x: usize, y: usize) -> bool {
    let (w, h) = (interior.width(), interior.height());
    for r in 1..=2usize {
        let (mut yes, mut no) = (0, 0);
        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                if interior.get(xx, yy) {
                    if tape.get(xx, yy) { yes += 1 } else { no += 1 }
                }
            }
        }
        if yes + no > 0 {
            return yes > no;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitmask::random_mask;

    /// A NaN level left every band unfound (`bands_missing` on every frame) without a word.
    #[test]
    fn a_level_outside_the_channels_sum_is_refused() {
        for level in [f32::NAN, -1.0, 767.0, f32::INFINITY] {
            let s = MarkerSettings {
                min_level: level,
                ..MarkerSettings::default()
            };
            let e = s.validate().unwrap_err().to_string();
            assert!(e.contains("markers.min_level"), "{level}: {e}");
        }
        for level in [0.0, 40.0, 765.0, MARKERS_OFF] {
            let s = MarkerSettings {
                min_level: level,
                ..MarkerSettings::default()
            };
            assert!(s.validate().is_ok(), "{level}");
        }
    }

    /// Every edge pixel voted on (the reference for the rule that skips those far from tape).
    fn every_edge_voted(frame: &RgbImage, object: &BitMask, s: &MarkerSettings) -> BitMask {
        let interior = object.erode(1).and(object);
        let tape = tape_inside(frame, &interior, s);
        let mut out = tape.clone();
        for_each_set(&object.and_not(&interior), |x, y| {
            out.set(x, y, voted_tape(&interior, &tape, x, y));
        });
        out
    }

    #[test]
    fn edge_pixels_far_from_tape_are_left_out_without_changing_the_vote() {
        let s = MarkerSettings::default();
        for seed in 0..6 {
            // Blobs of object (a dense random mask closed), tape-red in patches.
            let object = random_mask(150, 90, 9, seed).close(1);
            let colours = random_mask(150, 90, 3, seed + 100).dilate(2);
            let frame = RgbImage::from_fn(150, 90, |x, y| {
                if colours.get(x as usize, y as usize) {
                    image::Rgb([200, 25, 20])
                } else {
                    image::Rgb([40, 60, 120])
                }
            });
            let found = find_markers(&frame, &object, &s);
            assert!(
                found.count() > 100,
                "seed {seed}: {} tape pixels",
                found.count()
            );
            assert_eq!(found, every_edge_voted(&frame, &object, &s), "seed {seed}");
        }
    }
}
