//! Per-camera data computed once per rig: undistorted rays of every pixel corner, tile bounds
//! and the lit, textured backdrop.

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Point2, Vector2, Vector3};
use rayon::prelude::*;

use super::RenderSettings;
use super::backdrop::{folds, lamp_shading, texture};
use super::cull::Rect;
use crate::error::SimError;

/// Tile edge in pixels: primitives are culled per tile.
pub(crate) const TILE: usize = 8;

pub(crate) struct CameraView {
    pub camera: Camera,
    pub width: usize,
    pub height: usize,
    /// Normalized coordinates of pixel corners: corner `(i, j)` is pixel position
    /// `(i − ½, j − ½)`, `i ∈ 0..=width`, `j ∈ 0..=height`, row-major.
    corners: Vec<[f64; 2]>,
    pub tiles_x: usize,
    /// Bound of each tile's rays in normalized coordinates.
    pub tile_rects: Vec<Rect>,
    /// Lit, textured backdrop per pixel (linear RGB, supersampled, no shadows).
    pub backdrop: Vec<[f64; 3]>,
    /// The backdrop as it was when the backgrounds were captured, where it differs (folds
    /// that moved since).
    pub captured: Option<Vec<[f64; 3]>>,
    /// Lamp position, camera frame (mm).
    pub lamp: Vector3<f64>,
}

impl CameraView {
    pub fn new(index: usize, camera: &Camera, settings: &RenderSettings) -> Result<Self, SimError> {
        let k = &camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        // Rows are independent; along a row each corner starts Newton from its neighbour.
        let rows: Vec<Result<Vec<[f64; 2]>, SimError>> = (0..=h)
            .into_par_iter()
            .map(|j| {
                let mut row = Vec::with_capacity(w + 1);
                let mut guess: Option<Vector2<f64>> = None;
                for i in 0..=w {
                    let px = Point2::new(i as f64 - 0.5, j as f64 - 0.5);
                    let n = match guess {
                        Some(g) => k.normalized_from_pixel_near(px, g),
                        None => k.normalized_from_pixel(px),
                    }
                    .map_err(|e| SimError::Camera {
                        camera: index,
                        problem: format!("{e}; use less lens distortion for this image size"),
                    })?;
                    guess = Some(n);
                    row.push([n.x, n.y]);
                }
                Ok(row)
            })
            .collect();
        let mut corners = Vec::with_capacity((w + 1) * (h + 1));
        for r in rows {
            corners.extend(r?);
        }
        let tiles_x = w.div_ceil(TILE);
        let tiles_y = h.div_ceil(TILE);
        let mut tile_rects = Vec::with_capacity(tiles_x * tiles_y);
        for ty in 0..tiles_y {
            for tx in 0..tiles_x {
                let mut r = Rect::EMPTY;
                for j in ty * TILE..=((ty + 1) * TILE).min(h) {
                    for i in tx * TILE..=((tx + 1) * TILE).min(w) {
                        r.include(corners[j * (w + 1) + i]);
                    }
                }
                tile_rects.push(r);
            }
        }
        let lamp = Vector3::from(settings.lamp_offset);
        let mut view = CameraView {
            camera: camera.clone(),
            width: w,
            height: h,
            corners,
            tiles_x,
            tile_rects,
            backdrop: Vec::new(),
            captured: None,
            lamp,
        };
        view.backdrop = view.render_backdrop(settings, settings.fold_shift_mm);
        if settings.fold_depth > 0.0 && settings.fold_shift_mm != 0.0 {
            view.captured = Some(view.render_backdrop(settings, 0.0));
        }
        Ok(view)
    }

    /// Normalized coordinates at position `(fx, fy) ∈ [0, 1)²` inside pixel `(px, py)`,
    /// interpolated bilinearly between the pixel's corners (distortion is smooth at that
    /// scale: the error is far below 1e-6 px).
    /// The normalized-plane bounds of pixel `(px, py)`: every ray through the pixel passes
    /// inside.
    #[inline]
    pub fn pixel_rect(&self, px: usize, py: usize) -> Rect {
        let stride = self.width + 1;
        let i = py * stride + px;
        let mut r = Rect::EMPTY;
        for c in [i, i + 1, i + stride, i + stride + 1] {
            r.include(self.corners[c]);
        }
        r
    }

    #[inline]
    pub fn normalized(&self, px: usize, py: usize, fx: f64, fy: f64) -> [f64; 2] {
        let stride = self.width + 1;
        let i = py * stride + px;
        let (c00, c10, c01, c11) = (
            self.corners[i],
            self.corners[i + 1],
            self.corners[i + stride],
            self.corners[i + stride + 1],
        );
        let lerp = |a: f64, b: f64, c: f64, d: f64| {
            let top = a + (b - a) * fx;
            let bottom = c + (d - c) * fx;
            top + (bottom - top) * fy
        };
        [
            lerp(c00[0], c10[0], c01[0], c11[0]),
            lerp(c00[1], c10[1], c01[1], c11[1]),
        ]
    }

    /// The lit backdrop per pixel, its folds moved by `fold_shift` mm.
    fn render_backdrop(&self, s: &RenderSettings, fold_shift: f64) -> Vec<[f64; 3]> {
        // The texture's finest scale is about 2 px, so 2×2 samples already average it well; a
        // plate's print has sharp edges and gets as many as the tube.
        let most = if s.plate.is_some() { 4 } else { 2 };
        let n = s.supersampling.clamp(1, most) as usize;
        let depth = s.backdrop_depth;
        (0..self.height)
            .into_par_iter()
            .flat_map_iter(|py| {
                (0..self.width).map(move |px| {
                    let mut acc = [0.0; 3];
                    for sy in 0..n {
                        for sx in 0..n {
                            let [x, y] = self.normalized(
                                px,
                                py,
                                (sx as f64 + 0.5) / n as f64,
                                (sy as f64 + 0.5) / n as f64,
                            );
                            let p = Vector3::new(x * depth, y * depth, depth);
                            let grain = texture(p.x, p.y, s.seed);
                            let (albedo, b) =
                                match s.plate.as_ref().and_then(|pl| pl.albedo_at(p.x, p.y)) {
                                    // Smooth paper: a third of the cloth's grain, no folds.
                                    Some(a) => (a, 1.0 + (grain - 1.0) / 3.0),
                                    None => (
                                        s.backdrop_albedo,
                                        grain * folds(p.x, p.y, s.fold_depth, fold_shift, s.seed),
                                    ),
                                };
                            let b = b * lamp_shading(&p, &self.lamp, depth);
                            for c in 0..3 {
                                acc[c] += albedo[c] * b;
                            }
                        }
                    }
                    acc.map(|a| a / (n * n) as f64)
                })
            })
            .collect()
    }
}
