//! The bright textured backdrop behind the volume, as each camera sees it, and its lighting.
//!
//! Each camera looks at its own backdrop plane, perpendicular to its optical axis at depth
//! `backdrop_depth`, lit by a lamp mounted beside the camera. A point `(x, y)` in normalized
//! coordinates sees the backdrop point `D · (x, y, 1)` (camera frame), so backdrop and image
//! bounds share one parameter plane.

use flexshape_camera::nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::scene::Albedo;

/// Hash of an integer lattice point to `[0, 1)`.
fn lattice(ix: i64, iy: i64, seed: u64) -> f64 {
    let mut h = seed
        ^ (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    h ^= h >> 31;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 33;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in `[-1, 1]` with unit feature size.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let smooth = |t: f64| t * t * (3.0 - 2.0 * t);
    let (tx, ty) = (smooth(x - fx), smooth(y - fy));
    let v00 = lattice(ix, iy, seed);
    let v10 = lattice(ix + 1, iy, seed);
    let v01 = lattice(ix, iy + 1, seed);
    let v11 = lattice(ix + 1, iy + 1, seed);
    let v = v00 + (v10 - v00) * tx + (v01 - v00) * ty + (v00 - v10 - v01 + v11) * tx * ty;
    2.0 * v - 1.0
}

/// Brightness factor of the backdrop's texture at backdrop point `(u, v)` mm: cloth-like
/// variation of a few percent at 40, 9 and 2.5 mm scales.
pub(crate) fn texture(u: f64, v: f64, seed: u64) -> f64 {
    1.0 + 0.05 * value_noise(u / 40.0, v / 40.0, seed)
        + 0.03 * value_noise(u / 9.0, v / 9.0, seed ^ 1)
        + 0.015 * value_noise(u / 2.5, v / 2.5, seed ^ 2)
}

/// Distance between neighbouring folds of the backdrop cloth, mm.
const FOLD_PERIOD: f64 = 70.0;

/// Brightness factor of cloth folds at backdrop point `(u, v)` mm: soft dark valleys about
/// 13 mm wide (half depth) and [`FOLD_PERIOD`] apart, running diagonally and wavy, losing
/// `depth` of the light at their bottom; `shift` mm moves them across.
pub(crate) fn folds(u: f64, v: f64, depth: f64, shift: f64, seed: u64) -> f64 {
    if depth == 0.0 {
        return 1.0;
    }
    let across = 0.8 * u + 0.6 * v + 25.0 * value_noise(u / 150.0, v / 150.0, seed ^ 3) + shift;
    let valley = 0.5 + 0.5 * (std::f64::consts::TAU * across / FOLD_PERIOD).cos();
    1.0 - depth * valley.powi(8)
}

/// A flat printed plate lying on the backdrop under the volume's image (in each camera's
/// backdrop plane): what a lab puts on the bench — a calibration plate, a sheet with a grid
/// of dots — that the tube then crosses. Rigid: the cloth's folds stop at its edge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plate {
    /// What is printed on it.
    pub pattern: PlatePattern,
    /// Its centre on the backdrop plane, mm (camera frame: x right, y down).
    pub centre_mm: [f64; 2],
    /// Half its width and height, mm.
    pub half_size_mm: [f64; 2],
    /// Distance between neighbouring dots' centres, or a square's side, mm.
    pub pitch_mm: f64,
    /// The dots' radius, mm (dots only).
    pub dot_radius_mm: f64,
    /// Reflectance of the plate.
    pub paper: Albedo,
    /// Reflectance of the print.
    pub ink: Albedo,
}

/// What a [`Plate`] shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlatePattern {
    /// A square grid of black dots on white.
    Dots,
    /// Black and white squares.
    Chessboard,
}

impl Plate {
    /// A white plate 520 × 400 mm at a 1 m deep backdrop (about two thirds of the default
    /// image's width), a little below the image's centre, printed with `pattern` at a 20 mm
    /// pitch (dots 8 mm across: 6–7 px in the default 640 × 480 camera, about as wide as the
    /// default tube).
    pub fn new(pattern: PlatePattern) -> Self {
        Plate {
            pattern,
            centre_mm: [0.0, 60.0],
            half_size_mm: [260.0, 200.0],
            pitch_mm: 20.0,
            dot_radius_mm: 4.0,
            paper: [0.86, 0.86, 0.84],
            ink: [0.05, 0.05, 0.05],
        }
    }

    /// The plate's reflectance at backdrop point `(u, v)` mm, `None` off the plate.
    pub(crate) fn albedo_at(&self, u: f64, v: f64) -> Option<Albedo> {
        let (x, y) = (u - self.centre_mm[0], v - self.centre_mm[1]);
        if x.abs() > self.half_size_mm[0] || y.abs() > self.half_size_mm[1] {
            return None;
        }
        let p = self.pitch_mm;
        let inked = match self.pattern {
            PlatePattern::Dots => {
                // The nearest grid point, dots centred on the plate's centre.
                let (dx, dy) = (x - (x / p).round() * p, y - (y / p).round() * p);
                dx.hypot(dy) <= self.dot_radius_mm
            }
            PlatePattern::Chessboard => {
                ((x / p).floor() as i64 + (y / p).floor() as i64).rem_euclid(2) == 0
            }
        };
        Some(if inked { self.ink } else { self.paper })
    }
}

/// Relative irradiance of the lamp at `lamp` on the backdrop point `p` (camera frame), scaled
/// to 1 where the optical axis meets the backdrop; `0.3 + 0.7 ·` that keeps some ambient light.
pub(crate) fn lamp_shading(p: &Vector3<f64>, lamp: &Vector3<f64>, depth: f64) -> f64 {
    let irradiance = |q: &Vector3<f64>| {
        let to_lamp = lamp - q;
        let d2 = to_lamp.norm_squared();
        // The backdrop faces the camera: its normal is −z.
        (-to_lamp.z / d2.sqrt()).max(0.0) / d2
    };
    let centre = irradiance(&Vector3::new(0.0, 0.0, depth));
    0.3 + 0.7 * (irradiance(p) / centre)
}

/// Fraction of the lamp (a sphere of radius `lamp_radius`) visible from backdrop point `p`
/// past an occluder of radius `r` whose axis passes at distance `d` from the segment `p → lamp`,
/// at fraction `t` of the way from `p`. There the light cone has radius `lamp_radius · t`; the
/// occluder is a strip `[d − r, d + r]` across it, and the covered share of the cone's width is
/// the share of light blocked. A thin occluder in a wide cone therefore casts only a partial
/// shadow, as it does in reality.
pub(crate) fn lamp_visibility(d: f64, r: f64, t: f64, lamp_radius: f64) -> f64 {
    let half = (lamp_radius * t).max(1e-6);
    let covered = ((d + r).min(half) - (d - r).max(-half)).max(0.0);
    1.0 - (covered / (2.0 * half)).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_lose_up_to_their_depth_and_move_with_the_shift() {
        assert_eq!(folds(3.0, 4.0, 0.0, 10.0, 1), 1.0);
        let samples: Vec<f64> = (0..20_000)
            .map(|i| folds(i as f64 * 0.37, i as f64 * 0.11, 0.3, 0.0, 1))
            .collect();
        let (lo, hi) = samples
            .iter()
            .fold((2.0f64, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(
            (0.7 - 1e-12..0.71).contains(&lo) && hi <= 1.0 && hi > 0.999,
            "{lo} {hi}"
        );
        // Moving the cloth by its whole period leaves it as it was; by half, a valley's
        // bottom becomes a ridge.
        let (u, v) = (10.0, 20.0);
        let at = |shift: f64| folds(u, v, 0.3, shift, 1);
        assert!((at(FOLD_PERIOD) - at(0.0)).abs() < 1e-9);
        let bottom = (0..700)
            .map(|k| k as f64 * 0.1)
            .min_by(|a, b| at(*a).total_cmp(&at(*b)))
            .unwrap();
        assert!(at(bottom) < 0.701 && at(bottom + FOLD_PERIOD / 2.0) > 0.999);
    }

    #[test]
    fn a_plate_shows_its_print_and_nothing_beyond_its_edge() {
        let dots = Plate::new(PlatePattern::Dots);
        let [cx, cy] = dots.centre_mm;
        assert_eq!(dots.albedo_at(cx, cy), Some(dots.ink));
        assert_eq!(dots.albedo_at(cx + 3.9, cy), Some(dots.ink));
        assert_eq!(dots.albedo_at(cx + 4.1, cy), Some(dots.paper));
        assert_eq!(dots.albedo_at(cx + 10.0, cy + 10.0), Some(dots.paper));
        assert_eq!(dots.albedo_at(cx + 40.0, cy - 60.0), Some(dots.ink));
        assert_eq!(dots.albedo_at(cx + 261.0, cy), None);
        assert_eq!(dots.albedo_at(cx, cy - 201.0), None);
        // A dot's share of the plate: π·4² / 20².
        let n = 400;
        let inked = (0..n * n)
            .filter(|i| {
                let (x, y) = ((i % n) as f64 * 0.5, (i / n) as f64 * 0.5);
                dots.albedo_at(cx + x, cy + y) == Some(dots.ink)
            })
            .count() as f64
            / (n * n) as f64;
        assert!(
            (inked - std::f64::consts::PI * 16.0 / 400.0).abs() < 0.01,
            "{inked}"
        );
        let board = Plate::new(PlatePattern::Chessboard);
        let at = |x: f64, y: f64| board.albedo_at(cx + x, cy + y);
        assert_eq!(at(5.0, 5.0), Some(board.ink));
        assert_eq!(at(25.0, 5.0), Some(board.paper));
        assert_eq!(at(-5.0, 5.0), Some(board.paper));
        assert_eq!(at(-5.0, -5.0), Some(board.ink));
    }

    #[test]
    fn texture_is_bright_and_bounded() {
        let mut lo: f64 = 2.0;
        let mut hi: f64 = 0.0;
        for i in 0..10_000 {
            let t = texture(i as f64 * 0.37, i as f64 * 0.11, 7);
            lo = lo.min(t);
            hi = hi.max(t);
        }
        assert!(lo > 0.9 && hi < 1.1 && hi - lo > 0.05, "{lo} {hi}");
    }

    #[test]
    fn visibility_umbra_penumbra_and_partial_shadows() {
        // Narrow cone (occluder near the backdrop): a full umbra, lit far away.
        assert_eq!(lamp_visibility(0.0, 3.0, 0.1, 20.0), 0.0);
        assert_eq!(lamp_visibility(30.0, 3.0, 0.1, 20.0), 1.0);
        // The occluder's edge through the cone's axis blocks half the light.
        assert!((lamp_visibility(3.0, 3.0, 0.05, 20.0) - 0.5).abs() < 1e-12);
        // Wide cone (occluder near the lamp): even dead centre only 6 of 20 mm are covered.
        assert!((lamp_visibility(0.0, 3.0, 0.5, 20.0) - 0.7).abs() < 1e-12);
    }
}
