//! Ray-cast rendering of a [`Scene`] through every camera of a rig.
//!
//! Each pixel is shaded from `supersampling²` rays through stratified positions inside it, but
//! only in 8×8 tiles that some primitive's conservative bound touches; elsewhere the
//! precomputed backdrop is used. Rays come from a per-camera grid of undistorted pixel corners,
//! so lens distortion is exact to far below a micro-pixel. Noise is drawn per image row from a
//! seeded generator, so images are byte-identical for the same seed whatever the thread count.

mod backdrop;
mod cull;
mod intersect;
mod view;

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Point3, Vector3};
use image::{GrayImage, RgbImage};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::scene::{Albedo, Gloss, Scene};
use backdrop::lamp_visibility;
pub use backdrop::{Plate, PlatePattern};
use cull::{Rect, RectIndex, box_corners};
pub(crate) use intersect::ray_sphere;
use intersect::{Capsule, closest_on_segment, ray_capsule, segment_distance};
use view::{CameraView, TILE};

/// How images are rendered.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Rays per pixel along each axis where an object may be (4 → 16 rays).
    pub supersampling: u32,
    /// Standard deviation of the Gaussian sensor noise, grey levels (0–255 scale), per channel.
    pub noise_sigma: f64,
    /// Cast soft shadows of the objects on the backdrops.
    pub shadows: bool,
    /// Distance of each camera's backdrop plane along its optical axis, mm.
    pub backdrop_depth: f64,
    /// Lamp position relative to its camera (camera frame: x right, y down, z forward), mm.
    pub lamp_offset: [f64; 3],
    /// Lamp radius, mm (larger → softer shadows).
    pub lamp_radius: f64,
    /// Fraction of the light a full shadow removes, in `[0, 1]`.
    pub shadow_strength: f64,
    /// Backdrop colour (linear RGB reflectance).
    pub backdrop_albedo: Albedo,
    /// Seed of the backdrop texture and of the noise.
    pub seed: u64,
    /// Folds in the backdrop cloth: the share of the light their valleys lose (0: a flat
    /// backdrop), see [`RenderSettings::fold_shift_mm`].
    #[serde(default)]
    pub fold_depth: f64,
    /// How far the folds moved across the backdrop between the background capture and the
    /// frames, mm (cloth that slid or sagged; 0: the backgrounds show the frames' backdrop).
    #[serde(default)]
    pub fold_shift_mm: f64,
    /// A printed plate on the backdrop under the volume's image (`None`: cloth only).
    #[serde(default)]
    pub plate: Option<Plate>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            supersampling: 4,
            noise_sigma: 2.0,
            shadows: false,
            backdrop_depth: 1000.0,
            lamp_offset: [120.0, -160.0, 0.0],
            lamp_radius: 6.0,
            shadow_strength: 0.45,
            backdrop_albedo: [0.70, 0.88, 0.66],
            seed: 1,
            fold_depth: 0.0,
            fold_shift_mm: 0.0,
            plate: None,
        }
    }
}

impl RenderSettings {
    fn validate(&self) -> Result<(), SimError> {
        let bad = |field: &str, why: &str| {
            Err(SimError::Config {
                field: field.into(),
                problem: why.into(),
            })
        };
        if !(1..=16).contains(&self.supersampling) {
            return bad("supersampling", "must be between 1 and 16");
        }
        if !(self.noise_sigma.is_finite() && self.noise_sigma >= 0.0) {
            return bad(
                "noise_sigma",
                "must be a non-negative number of grey levels",
            );
        }
        if !(self.backdrop_depth.is_finite() && self.backdrop_depth > 0.0) {
            return bad("backdrop_depth", "must be a positive distance in mm");
        }
        if !(self.lamp_radius.is_finite() && self.lamp_radius > 0.0) {
            return bad("lamp_radius", "must be a positive radius in mm");
        }
        if !(0.0..=1.0).contains(&self.shadow_strength) {
            return bad("shadow_strength", "must lie in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.fold_depth) {
            return bad("fold_depth", "must lie in [0, 1]");
        }
        if !self.fold_shift_mm.is_finite() {
            return bad("fold_shift_mm", "must be a distance in mm");
        }
        if let Some(p) = &self.plate {
            let sizes = [p.pitch_mm, p.half_size_mm[0], p.half_size_mm[1]];
            if !sizes.iter().all(|v| v.is_finite() && *v > 0.0) {
                return bad("plate", "its size and pitch must be positive lengths in mm");
            }
            if !(p.dot_radius_mm.is_finite() && p.dot_radius_mm >= 0.0) {
                return bad("plate.dot_radius_mm", "must be a non-negative length in mm");
            }
        }
        Ok(())
    }
}

/// One camera's rendering of a frame.
#[derive(Debug, Clone)]
pub struct View {
    /// The camera image, 8-bit RGB.
    pub image: RgbImage,
    /// 255 where the ray through the pixel centre meets a tube before anything else, else 0.
    pub mask: GrayImage,
    /// 255 where that first hit is on a marker band, else 0.
    pub markers: GrayImage,
    /// Fraction of the pixel's rays that meet a tube first (row-major, `width × height`).
    pub coverage: Vec<f32>,
}

/// Renders scenes through a fixed set of cameras.
pub struct Renderer {
    views: Vec<CameraView>,
    settings: RenderSettings,
}

/// A scene moved into one camera's frame, with culling indices.
struct Prepared<'a> {
    scene: &'a Scene,
    capsules: Vec<Capsule>,
    spheres: Vec<(Vector3<f64>, f64, Albedo)>,
    /// Bounds in normalized image coordinates: capsules first, then spheres.
    primary: RectIndex,
    /// Bounds of the shadows on the backdrop, same parameter plane.
    shadow: RectIndex,
}

/// One view's rendering before the sensor: linear light and the truth masks, row-major.
struct Linear {
    rgb: Vec<[f64; 3]>,
    mask: Vec<u8>,
    markers: Vec<u8>,
    coverage: Vec<f32>,
}

enum Hit {
    Capsule(usize),
    Sphere(usize),
}

/// Nearer than this (mm, camera z) a bound is not computed and the primitive is tested
/// everywhere.
const NEAR: f64 = 1.0;

impl Renderer {
    /// Precomputes every camera's ray grid and backdrop (a fraction of a second per camera).
    pub fn new(cameras: &[Camera], settings: RenderSettings) -> Result<Self, SimError> {
        settings.validate()?;
        let views = cameras
            .iter()
            .enumerate()
            .map(|(i, c)| CameraView::new(i, c, &settings))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Renderer { views, settings })
    }

    /// The settings in use.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Number of cameras.
    pub fn camera_count(&self) -> usize {
        self.views.len()
    }

    /// Renders `scene` in every camera; `frame` selects the noise (each frame differs).
    pub fn render(&self, scene: &Scene, frame: u64) -> Vec<View> {
        self.views
            .par_iter()
            .enumerate()
            .map(|(i, v)| {
                self.render_view(v, &v.backdrop, i, scene, frame, self.settings.noise_sigma)
            })
            .collect()
    }

    /// Every camera's image of a moving scene over one exposure: the light of `scenes` (the
    /// scene at evenly spaced instants while the shutter is open) averaged before the sensor's
    /// noise, so whatever moves is blurred along its path. The masks and coverage are those of
    /// the middle scene, the instant a right shape is measured at (an even count takes the
    /// later of the two middle ones). `frame` selects the noise. One scene renders as
    /// [`Renderer::render`]; none renders the backdrop alone.
    pub fn render_exposure(&self, scenes: &[Scene], frame: u64) -> Vec<View> {
        let each = vec![scenes; self.views.len()];
        self.render_exposures(&each, frame)
    }

    /// As [`Renderer::render_exposure`], each camera over its own exposure (`scenes[i]` for
    /// camera `i`): cameras that are not triggered together see the scene at their own
    /// instants. A camera without an entry sees the backdrop alone.
    pub fn render_exposures(&self, scenes: &[&[Scene]], frame: u64) -> Vec<View> {
        let empty = Scene {
            tubes: Vec::new(),
            occluders: Vec::new(),
        };
        self.views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let own = scenes.get(i).copied().unwrap_or_default();
                let own = if own.is_empty() {
                    std::slice::from_ref(&empty)
                } else {
                    own
                };
                let middle = own.len() / 2;
                let mut sum = self.linear_view(v, &v.backdrop, &own[middle]);
                let others = own
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| k != middle)
                    .map(|(_, s)| self.linear_view(v, &v.backdrop, s).rgb);
                for rgb in others {
                    for (acc, add) in sum.rgb.iter_mut().zip(&rgb) {
                        for c in 0..3 {
                            acc[c] += add[c];
                        }
                    }
                }
                let inv = 1.0 / own.len() as f64;
                for acc in &mut sum.rgb {
                    for a in acc.iter_mut() {
                        *a *= inv;
                    }
                }
                self.exposed(v, i, frame, self.settings.noise_sigma, sum)
            })
            .collect()
    }

    /// Every camera's view of `scene` (e.g. the set without the catheter) with noise reduced
    /// by `noise_scale` (¼: as if 16 frames had been averaged), for background images.
    pub fn render_backgrounds(&self, scene: &Scene, noise_scale: f64) -> Vec<RgbImage> {
        let sigma = self.settings.noise_sigma * noise_scale;
        self.views
            .par_iter()
            .enumerate()
            .map(|(i, v)| {
                let backdrop = v.captured.as_ref().unwrap_or(&v.backdrop);
                self.render_view(v, backdrop, i, scene, u64::MAX, sigma)
                    .image
            })
            .collect()
    }

    fn prepare<'a>(&self, view: &CameraView, scene: &'a Scene) -> Prepared<'a> {
        let pose = &view.camera.pose;
        let to_cam = |p: &Point3<f64>| pose.to_camera(p).coords;
        let mut capsules = Vec::new();
        for (t, tube) in scene.tubes.iter().enumerate() {
            let pts = tube.centerline.points();
            let arcs = tube.centerline.arc_lengths();
            for i in 0..pts.len() - 1 {
                capsules.push(Capsule::new(
                    to_cam(&pts[i]),
                    to_cam(&pts[i + 1]),
                    tube.radius_between(arcs[i], arcs[i + 1]),
                    arcs[i],
                    arcs[i + 1],
                    t,
                ));
            }
        }
        let spheres: Vec<_> = scene
            .occluders
            .iter()
            .map(|o| (to_cam(&o.centre), o.radius, o.albedo))
            .collect();
        let image_plane = |v: [f64; 3]| (v[2] > NEAR).then(|| [v[0] / v[2], v[1] / v[2]]);
        let depth = self.settings.backdrop_depth;
        let lamp = view.lamp;
        // Central projection from the lamp onto the backdrop (z = depth), in normalized units.
        let from_lamp = |v: [f64; 3]| {
            let dz = v[2] - lamp.z;
            (dz > NEAR && v[2] < depth).then(|| {
                let s = (depth - lamp.z) / dz;
                [
                    (lamp.x + (v[0] - lamp.x) * s) / depth,
                    (lamp.y + (v[1] - lamp.y) * s) / depth,
                ]
            })
        };
        let bounds = |pad: f64, project: &dyn Fn([f64; 3]) -> Option<[f64; 2]>| {
            let caps = capsules.iter().map(|c| {
                Rect::of_projected(box_corners(c.a.into(), c.b.into(), c.radius + pad), project)
            });
            let sph = spheres.iter().map(|(c, r, _)| {
                Rect::of_projected(box_corners((*c).into(), (*c).into(), r + pad), project)
            });
            RectIndex::new(caps.chain(sph).collect())
        };
        let primary = bounds(0.0, &image_plane);
        let shadow = if self.settings.shadows {
            bounds(self.settings.lamp_radius, &from_lamp)
        } else {
            RectIndex::default()
        };
        Prepared {
            scene,
            capsules,
            spheres,
            primary,
            shadow,
        }
    }

    /// `backdrop`: the lit backdrop behind the scene, per pixel (the view's, or its captured
    /// one for backgrounds).
    fn render_view(
        &self,
        view: &CameraView,
        backdrop: &[[f64; 3]],
        cam: usize,
        scene: &Scene,
        frame: u64,
        sigma: f64,
    ) -> View {
        let linear = self.linear_view(view, backdrop, scene);
        self.exposed(view, cam, frame, sigma, linear)
    }

    /// The view's linear (noise-free, unquantised) image of `scene` and its truth masks.
    fn linear_view(&self, view: &CameraView, backdrop: &[[f64; 3]], scene: &Scene) -> Linear {
        let prep = self.prepare(view, scene);
        let w = view.width;
        let n = w * view.height;
        let mut out = Linear {
            rgb: vec![[0.0; 3]; n],
            mask: vec![0u8; n],
            markers: vec![0u8; n],
            coverage: vec![0f32; n],
        };
        out.rgb
            .par_chunks_mut(w * TILE)
            .zip(out.mask.par_chunks_mut(w * TILE))
            .zip(out.markers.par_chunks_mut(w * TILE))
            .zip(out.coverage.par_chunks_mut(w * TILE))
            .enumerate()
            .for_each(|(ty, (((linear, mask), markers), coverage))| {
                self.render_tile_row(view, backdrop, &prep, ty, linear, mask, markers, coverage);
            });
        out
    }

    /// The 8-bit image a sensor makes of `linear` (its light, its masks kept), with Gaussian
    /// noise `sigma` drawn per row from a generator seeded by the frame, camera and row.
    fn exposed(
        &self,
        view: &CameraView,
        cam: usize,
        frame: u64,
        sigma: f64,
        linear: Linear,
    ) -> View {
        let (w, h) = (view.width, view.height);
        let mut rgb = vec![0u8; w * h * 3];
        rgb.par_chunks_mut(w * 3)
            .zip(linear.rgb.par_chunks(w))
            .enumerate()
            .for_each(|(y, (out, light))| {
                let mut rng = Xoshiro256PlusPlus::seed_from_u64(noise_seed(
                    self.settings.seed,
                    frame,
                    cam as u64,
                    y as u64,
                ));
                for x in 0..w {
                    for c in 0..3 {
                        let noise = if sigma > 0.0 {
                            sigma * Distribution::<f64>::sample(&StandardNormal, &mut rng)
                        } else {
                            0.0
                        };
                        let v = light[x][c] * 255.0 + noise;
                        out[x * 3 + c] = v.round().clamp(0.0, 255.0) as u8;
                    }
                }
            });
        let img = |data: Vec<u8>| GrayImage::from_raw(w as u32, h as u32, data).unwrap_or_default();
        View {
            image: RgbImage::from_raw(w as u32, h as u32, rgb).unwrap_or_default(),
            mask: img(linear.mask),
            markers: img(linear.markers),
            coverage: linear.coverage,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn render_tile_row(
        &self,
        view: &CameraView,
        backdrop: &[[f64; 3]],
        prep: &Prepared,
        ty: usize,
        linear: &mut [[f64; 3]],
        mask: &mut [u8],
        markers: &mut [u8],
        coverage: &mut [f32],
    ) {
        let w = view.width;
        let rows = mask.len() / w;
        let n = self.settings.supersampling as usize;
        let mut cands = Vec::new();
        let mut shadow_cands = Vec::new();
        let mut pixel_cands = Vec::new();
        for tx in 0..view.tiles_x {
            let rect = view.tile_rects[ty * view.tiles_x + tx];
            cands.clear();
            shadow_cands.clear();
            prep.primary.query(&rect, &mut cands);
            if !prep.shadow.is_empty() {
                prep.shadow.query(&rect, &mut shadow_cands);
            }
            for r in 0..rows {
                let py = ty * TILE + r;
                for px in tx * TILE..((tx + 1) * TILE).min(w) {
                    let idx = r * w + px;
                    let mut bg = backdrop[py * w + px];
                    if !shadow_cands.is_empty() {
                        let [x, y] = view.normalized(px, py, 0.5, 0.5);
                        let f = self.shadow_factor(view, prep, &shadow_cands, x, y);
                        bg = [bg[0] * f, bg[1] * f, bg[2] * f];
                    }
                    if cands.is_empty() {
                        linear[idx] = bg;
                        continue;
                    }
                    // Only the tile's candidates whose bounds meet this pixel's can be hit by
                    // its rays (same hits, in the same order, as testing them all).
                    let pixel = view.pixel_rect(px, py);
                    pixel_cands.clear();
                    pixel_cands.extend(
                        cands
                            .iter()
                            .copied()
                            .filter(|&i| prep.primary.rect(i).overlaps(&pixel)),
                    );
                    let cands = &pixel_cands;
                    let centre = view.normalized(px, py, 0.5, 0.5);
                    if let Some((t, Hit::Capsule(i))) = self.trace(prep, cands, centre) {
                        mask[idx] = 255;
                        let c = &prep.capsules[i];
                        let (_, s) = capsule_point(c, &ray_dir(centre), t);
                        if prep.scene.tubes[c.tube].is_band(s) {
                            markers[idx] = 255;
                        }
                    }
                    let mut acc = [0.0; 3];
                    let mut tube_hits = 0;
                    for sy in 0..n {
                        for sx in 0..n {
                            let p = view.normalized(
                                px,
                                py,
                                (sx as f64 + 0.5) / n as f64,
                                (sy as f64 + 0.5) / n as f64,
                            );
                            let col = match self.trace(prep, cands, p) {
                                None => bg,
                                Some((t, hit)) => {
                                    if matches!(hit, Hit::Capsule(_)) {
                                        tube_hits += 1;
                                    }
                                    self.shade(view, prep, &ray_dir(p), t, &hit)
                                }
                            };
                            for c in 0..3 {
                                acc[c] += col[c];
                            }
                        }
                    }
                    let inv = 1.0 / (n * n) as f64;
                    linear[idx] = [acc[0] * inv, acc[1] * inv, acc[2] * inv];
                    coverage[idx] = tube_hits as f32 * inv as f32;
                }
            }
        }
    }

    /// Nearest hit along the ray through normalized point `p` among the candidates.
    fn trace(&self, prep: &Prepared, cands: &[usize], p: [f64; 2]) -> Option<(f64, Hit)> {
        let d = ray_dir(p);
        let o = Vector3::zeros();
        let ncap = prep.capsules.len();
        let mut best: Option<(f64, Hit)> = None;
        for &i in cands {
            let t = if i < ncap {
                ray_capsule(&d, &prep.capsules[i])
            } else {
                let (c, r, _) = &prep.spheres[i - ncap];
                ray_sphere(&o, &d, c, *r)
            };
            if let Some(t) = t
                && best.as_ref().is_none_or(|(b, _)| t < *b)
            {
                best = Some((
                    t,
                    if i < ncap {
                        Hit::Capsule(i)
                    } else {
                        Hit::Sphere(i - ncap)
                    },
                ));
            }
        }
        best
    }

    /// Colour of a surface point: Lambert + a small plastic highlight from the camera's lamp.
    fn shade(
        &self,
        view: &CameraView,
        prep: &Prepared,
        d: &Vector3<f64>,
        t: f64,
        hit: &Hit,
    ) -> [f64; 3] {
        let x = d * t;
        let (normal, albedo, gloss) = match *hit {
            Hit::Capsule(i) => {
                let c = &prep.capsules[i];
                let (q, s) = capsule_point(c, d, t);
                let tube = &prep.scene.tubes[c.tube];
                if tube.is_band(s) {
                    ((x - q) / c.radius, tube.band_albedo, Gloss::default())
                } else {
                    let m = tube.material_at(s);
                    ((x - q) / c.radius, m.albedo, m.gloss)
                }
            }
            Hit::Sphere(j) => {
                let (c, r, a) = &prep.spheres[j];
                ((x - c) / *r, *a, Gloss::default())
            }
        };
        let l = (view.lamp - x).normalize();
        let diffuse = normal.dot(&l).max(0.0);
        let half = (l - d).normalize();
        let cos = normal.dot(&half).max(0.0);
        // Whole exponents as integer powers: the default sheen renders as it always has.
        let peak = if gloss.shininess.fract() == 0.0 && gloss.shininess.abs() < 1e6 {
            cos.powi(gloss.shininess as i32)
        } else {
            cos.powf(gloss.shininess)
        };
        let specular = gloss.strength * peak;
        let k = 0.3 + 0.7 * diffuse;
        [
            albedo[0] * k + specular,
            albedo[1] * k + specular,
            albedo[2] * k + specular,
        ]
    }

    /// Light reaching the backdrop point seen at normalized `(x, y)`: 1 unshadowed, down to
    /// `1 − shadow_strength` in full shadow.
    fn shadow_factor(
        &self,
        view: &CameraView,
        prep: &Prepared,
        cands: &[usize],
        x: f64,
        y: f64,
    ) -> f64 {
        let depth = self.settings.backdrop_depth;
        let p = Vector3::new(x * depth, y * depth, depth);
        let lamp = view.lamp;
        let ncap = prep.capsules.len();
        let mut lit: f64 = 1.0;
        for &i in cands {
            let (d, r, t) = if i < ncap {
                let c = &prep.capsules[i];
                let (d, t) = segment_distance(&p, &lamp, &c.a, &c.b);
                (d, c.radius, t)
            } else {
                let (c, r, _) = &prep.spheres[i - ncap];
                let t = closest_on_segment(c, &p, &lamp);
                (((p + (lamp - p) * t) - c).norm(), *r, t)
            };
            lit = lit.min(lamp_visibility(d, r, t, self.settings.lamp_radius));
        }
        1.0 - self.settings.shadow_strength * (1.0 - lit)
    }
}

/// Unit ray direction (camera frame) through normalized point `p`.
#[inline]
fn ray_dir(p: [f64; 2]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], 1.0).normalize()
}

/// Axis point nearest to the hit at distance `t` along `d`, and its arc length.
fn capsule_point(c: &Capsule, d: &Vector3<f64>, t: f64) -> (Vector3<f64>, f64) {
    let x = d * t;
    let u = closest_on_segment(&x, &c.a, &c.b);
    (c.a + (c.b - c.a) * u, c.s_a + (c.s_b - c.s_a) * u)
}

/// Seed of the noise generator for one image row.
fn noise_seed(seed: u64, frame: u64, cam: u64, row: u64) -> u64 {
    let mut h = seed ^ 0x6A09_E667_F3BC_C908;
    for v in [frame, cam, row] {
        h = (h ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= h >> 29;
    }
    h
}
