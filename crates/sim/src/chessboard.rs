//! Chessboards rendered through a camera with known truth, for testing calibration: a planar
//! board of `cols × rows` inner corners with one extra square all round and a white margin,
//! on a grey background, antialiased by 4 × 4 supersampling, with Gaussian noise. A ChArUco
//! board is the same chessboard with an ArUco marker in every light square (OpenCV's layout
//! since 4.6: the top-left square dark, markers numbered row by row over the light squares).
//! A circle grid is dark dots on a light board, OpenCV's symmetric or asymmetric layout.
//!
//! Board frame (as the calibration uses it): origin at the first inner corner, x along `cols`,
//! y along `rows`, z = 0 on the board; the outer square at the origin is dark (so for
//! `cols + rows` odd the origin is unambiguous).

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{
    Isometry3, Point2, Rotation3, Translation3, UnitQuaternion, Vector2, Vector3,
};
use image::{GrayImage, Luma};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

/// A printed chessboard, ChArUco board or circle grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintedBoard {
    /// Inner corners (circles) along x.
    pub cols: usize,
    /// Inner corners (circles) along y.
    pub rows: usize,
    /// Square edge, mm (circle grids: the distance between neighbouring circles of a
    /// symmetric grid, half that between neighbours in a row of an asymmetric one).
    pub square: f64,
    /// What is printed.
    pub pattern: PrintedPattern,
}

/// What a [`PrintedBoard`] shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PrintedPattern {
    /// Dark and light squares.
    Chessboard,
    /// A chessboard with ArUco markers in the light squares.
    Charuco(PrintedMarkers),
    /// Dark dots of `diameter` mm centred at `(c·square, r·square)` (symmetric) or
    /// `((2c + r mod 2)·square, r·square)` (asymmetric, OpenCV's layout).
    Circles {
        /// OpenCV's asymmetric layout.
        asymmetric: bool,
        /// Dot diameter, mm.
        diameter: f64,
    },
}

/// The ArUco markers of a ChArUco board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintedMarkers {
    /// Marker edge, mm (centred in its square).
    pub side: f64,
    /// Bits per marker side (without the one-cell black border).
    bits: usize,
    /// Marker codes by id: bit `y·bits + x` set where cell `(x, y)` is black.
    codes: &'static [u64],
}

impl PrintedMarkers {
    /// Markers of `side` mm from the ArUco dictionary named `dictionary` (OpenCV's names, e.g.
    /// `DICT_4X4_50`); `None` for a name it does not know.
    pub fn new(side: f64, dictionary: &str) -> Option<Self> {
        let d = calib_targets_aruco::resolve_dictionary(dictionary)?;
        Some(PrintedMarkers {
            side,
            bits: d.marker_size(),
            codes: d.codes(),
        })
    }

    /// Whether the marker `id` is dark at `(x, y)`, its position in the marker's square
    /// from that square's top-left corner, mm (`square` its edge); `None` outside the marker.
    fn dark(&self, id: usize, x: f64, y: f64, square: f64) -> Option<bool> {
        let margin = (square - self.side) / 2.0;
        let cells = self.bits + 2;
        let cell = self.side / cells as f64;
        let (u, v) = ((x - margin) / cell, (y - margin) / cell);
        if !(u >= 0.0 && v >= 0.0 && u < cells as f64 && v < cells as f64) {
            return None;
        }
        let (cx, cy) = (u as usize, v as usize);
        if cx == 0 || cy == 0 || cx == cells - 1 || cy == cells - 1 {
            return Some(true);
        }
        let code = self.codes.get(id).copied().unwrap_or(0);
        Some((code >> ((cy - 1) * self.bits + cx - 1)) & 1 == 1)
    }
}

const SUB: usize = 4;
const DARK: f64 = 35.0;
const LIGHT: f64 = 215.0;
const BACKGROUND: f64 = 120.0;

/// Renders boards through one camera; the undistorted ray of every pixel corner is computed
/// once.
pub struct BoardRenderer {
    camera: Camera,
    /// Normalized coordinates of pixel corners, `(width + 1) × (height + 1)`, row-major.
    corners: Vec<Vector2<f64>>,
}

impl BoardRenderer {
    /// Precomputes `camera`'s rays; `None` if part of the image cannot be undistorted.
    pub fn new(camera: &Camera) -> Option<Self> {
        let k = &camera.intrinsics;
        let mut corners = Vec::with_capacity(((k.width + 1) * (k.height + 1)) as usize);
        for y in 0..=k.height {
            for x in 0..=k.width {
                let px = Point2::new(x as f64 - 0.5, y as f64 - 0.5);
                corners.push(k.normalized_from_pixel(px).ok()?);
            }
        }
        Some(BoardRenderer {
            camera: camera.clone(),
            corners,
        })
    }

    /// The image of `board` at `pose` (board → world), with noise `sigma` grey levels.
    pub fn render(
        &self,
        board: &PrintedBoard,
        pose: &Isometry3<f64>,
        sigma: f64,
        seed: u64,
    ) -> GrayImage {
        let k = &self.camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        // Board → camera, and the plane's normal and offset in the camera frame.
        let cam = Isometry3::from_parts(
            self.camera.pose.translation.into(),
            self.camera.pose.rotation.into(),
        ) * pose;
        let normal = cam.rotation * flexshape_camera::nalgebra::Vector3::z();
        let origin = cam.translation.vector;
        let to_board = cam.inverse();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut img = GrayImage::new(k.width, k.height);
        for y in 0..h {
            for x in 0..w {
                let c00 = self.corners[y * (w + 1) + x];
                let c10 = self.corners[y * (w + 1) + x + 1];
                let c01 = self.corners[(y + 1) * (w + 1) + x];
                let c11 = self.corners[(y + 1) * (w + 1) + x + 1];
                let mut sum = 0.0;
                for sy in 0..SUB {
                    let v = (sy as f64 + 0.5) / SUB as f64;
                    for sx in 0..SUB {
                        let u = (sx as f64 + 0.5) / SUB as f64;
                        let n = c00 * (1.0 - u) * (1.0 - v)
                            + c10 * u * (1.0 - v)
                            + c01 * (1.0 - u) * v
                            + c11 * u * v;
                        let dir = flexshape_camera::nalgebra::Vector3::new(n.x, n.y, 1.0);
                        let denom = normal.dot(&dir);
                        sum += if denom.abs() < 1e-12 {
                            BACKGROUND
                        } else {
                            let s = normal.dot(&origin) / denom;
                            if s <= 0.0 {
                                BACKGROUND
                            } else {
                                let p =
                                    to_board * flexshape_camera::nalgebra::Point3::from(dir * s);
                                board.shade(p.x, p.y)
                            }
                        };
                    }
                }
                let noise: f64 = rng.sample::<f64, _>(StandardNormal) * sigma;
                let value = (sum / (SUB * SUB) as f64 + noise).round().clamp(0.0, 255.0);
                img.put_pixel(x as u32, y as u32, Luma([value as u8]));
            }
        }
        img
    }
}

/// A board pose to photograph and the cameras that photograph it at that instant.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationView {
    /// File stem, e.g. `cam1_03` (one camera) or `shared1_02` (cam0 and cam1).
    pub name: String,
    /// Board → world.
    pub pose: Isometry3<f64>,
    /// Indices of the cameras that take this view.
    pub cameras: Vec<usize>,
}

/// A calibration session for `cameras` (all looking at the world origin): per camera `own`
/// views with the board facing it within ±29°, and per camera after the first `shared` views
/// with the board facing halfway between it and the first camera (within ±7°), taken by both.
/// Boards are centred within 30 mm of the origin and turned at random in their plane.
pub fn calibration_views(
    cameras: &[Camera],
    board: &PrintedBoard,
    own: usize,
    shared: usize,
    seed: u64,
) -> Vec<CalibrationView> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0xB0A2_D5E7);
    let toward = |c: &Camera| c.centre().coords.normalize();
    let mut views = Vec::new();
    for (k, cam) in cameras.iter().enumerate() {
        for i in 0..own {
            views.push(CalibrationView {
                name: format!("cam{k}_{i:02}"),
                pose: board.facing(toward(cam), 0.5, &mut rng),
                cameras: vec![k],
            });
        }
    }
    for (k, cam) in cameras.iter().enumerate().skip(1) {
        for i in 0..shared {
            views.push(CalibrationView {
                name: format!("shared{k}_{i:02}"),
                pose: board.facing(toward(&cameras[0]) + toward(cam), 0.12, &mut rng),
                cameras: vec![0, k],
            });
        }
    }
    views
}

impl PrintedBoard {
    /// A pose facing `toward` (from the board to its viewers) within `spread` radians per
    /// axis, turned at random in its plane, centred within 30 mm of the origin. The board's z
    /// points away from its viewers.
    fn facing(
        &self,
        toward: Vector3<f64>,
        spread: f64,
        rng: &mut Xoshiro256PlusPlus,
    ) -> Isometry3<f64> {
        let wobble = Rotation3::from_euler_angles(
            rng.random_range(-spread..spread),
            rng.random_range(-spread..spread),
            rng.random_range(-spread..spread),
        );
        let toward = wobble * toward.normalize();
        let tilt = Rotation3::rotation_between(&Vector3::z(), &-toward).unwrap_or_else(|| {
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        let spin = Rotation3::from_axis_angle(
            &Vector3::z_axis(),
            rng.random_range(0.0..std::f64::consts::TAU),
        );
        let rotation = tilt * spin;
        let centre = Vector3::new(
            rng.random_range(-30.0..30.0),
            rng.random_range(-30.0..30.0),
            rng.random_range(-30.0..30.0),
        );
        let across = match self.pattern {
            PrintedPattern::Circles {
                asymmetric: true, ..
            } => 2.0 * self.cols as f64 - 1.0,
            _ => self.cols as f64,
        };
        let half = Vector3::new(across - 1.0, self.rows as f64 - 1.0, 0.0) * self.square / 2.0;
        Isometry3::from_parts(
            Translation3::from(centre - rotation * half),
            UnitQuaternion::from_rotation_matrix(&rotation),
        )
    }

    /// Grey level at board point `(x, y)` mm.
    fn shade(&self, x: f64, y: f64) -> f64 {
        let s = self.square;
        if let PrintedPattern::Circles {
            asymmetric,
            diameter,
        } = self.pattern
        {
            return self.dots(x, y, asymmetric, diameter);
        }
        // `cols` inner corners lie between `cols + 1` squares, indices −1 to cols − 1 along x;
        // a white margin of one square beyond.
        let (i, j) = ((x / s).floor() as i64, (y / s).floor() as i64);
        let inside = |v: i64, n: usize| v >= -1 && v < n as i64;
        let margin = |v: i64, n: usize| v >= -2 && v <= n as i64;
        if inside(i, self.cols) && inside(j, self.rows) {
            if (i + j).rem_euclid(2) == 0 {
                return DARK;
            }
            let PrintedPattern::Charuco(markers) = &self.pattern else {
                return LIGHT;
            };
            // Squares counted from the board's top-left one; light ones hold markers 0, 1, …
            // row by row.
            let (sx, sy) = ((i + 1) as usize, (j + 1) as usize);
            let across = self.cols + 1;
            let id = (sy * across + sx) / 2;
            let (x0, y0) = (i as f64 * s, j as f64 * s);
            match markers.dark(id, x - x0, y - y0, s) {
                Some(true) => DARK,
                _ => LIGHT,
            }
        } else if margin(i, self.cols) && margin(j, self.rows) {
            LIGHT
        } else {
            BACKGROUND
        }
    }

    /// Grey level at `(x, y)` mm of a circle grid: light within two spacings of the outer
    /// dots' centres, dark within the dots.
    fn dots(&self, x: f64, y: f64, asymmetric: bool, diameter: f64) -> f64 {
        let s = self.square;
        let width = if asymmetric {
            2 * self.cols - 1
        } else {
            self.cols - 1
        } as f64
            * s;
        let height = (self.rows - 1) as f64 * s;
        if x < -2.0 * s || y < -2.0 * s || x > width + 2.0 * s || y > height + 2.0 * s {
            return BACKGROUND;
        }
        let r = (y / s).round();
        if (0.0..self.rows as f64).contains(&r) {
            let (step, offset) = if asymmetric {
                (2.0, (r as usize % 2) as f64)
            } else {
                (1.0, 0.0)
            };
            let c = ((x / s - offset) / step).round();
            let cx = (c * step + offset) * s;
            if (0.0..self.cols as f64).contains(&c) && (x - cx).hypot(y - r * s) <= diameter / 2.0 {
                return DARK;
            }
        }
        LIGHT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_outer_square_at_the_origin_is_dark() {
        let b = PrintedBoard {
            cols: 9,
            rows: 6,
            square: 10.0,
            pattern: PrintedPattern::Chessboard,
        };
        assert_eq!(b.shade(-5.0, -5.0), DARK);
        assert_eq!(b.shade(5.0, -5.0), LIGHT);
        // The far outer corner square is light for 9 × 6 (cols + rows odd).
        assert_eq!(b.shade(85.0, 55.0), LIGHT);
        assert_eq!(b.shade(-15.0, 0.0), LIGHT);
        assert_eq!(b.shade(-25.0, 0.0), BACKGROUND);
    }
}
