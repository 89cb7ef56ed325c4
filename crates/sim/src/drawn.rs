//! Masks as another tool draws them: the catheter's centerline projected through the lens
//! model and stroked a fixed number of pixels wide with round ends and joins, whatever its
//! radius and depth — a reconstruction tool's fixed-width masks, or a line a person drew over
//! the image. Their width says nothing of the tube; only their middle is its centerline.

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Point3, Vector2};
use image::GrayImage;

/// Longest piece of the projected centerline drawn straight, pixels.
const PIECE_PX: f64 = 0.5;

/// The mask of `camera`'s image (its calibrated size) with every pixel whose centre lies
/// within `width_px / 2` of the projected `centerline` (world mm, in order) set to 255. Parts
/// the camera cannot project (behind it, beyond its lens model) are left out.
pub fn drawn_mask(camera: &Camera, centerline: &[Point3<f64>], width_px: f64) -> GrayImage {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let mut mask = GrayImage::new(w, h);
    let half = (width_px / 2.0).max(0.0);
    let project = |p: &Point3<f64>| camera.project(p).ok().map(|q| q.pixel.coords);
    for pair in centerline.windows(2) {
        let (Some(a), Some(b)) = (project(&pair[0]), project(&pair[1])) else {
            continue;
        };
        // Pieces short enough that the projection is straight along each to far below a
        // pixel, each drawn as the round-ended stroke about it.
        let pieces = ((b - a).norm() / PIECE_PX).ceil().max(1.0) as usize;
        let mut from = a;
        for k in 1..=pieces {
            let t = k as f64 / pieces as f64;
            let Some(to) = project(&(pair[0] + (pair[1] - pair[0]) * t)) else {
                break;
            };
            stroke(&mut mask, from, to, half);
            from = to;
        }
    }
    mask
}

/// Sets the pixels whose centres lie within `half` of the segment `a → b`.
fn stroke(mask: &mut GrayImage, a: Vector2<f64>, b: Vector2<f64>, half: f64) {
    let (w, h) = (mask.width() as f64, mask.height() as f64);
    let x0 = (a.x.min(b.x) - half).ceil().max(0.0);
    let x1 = (a.x.max(b.x) + half).floor().min(w - 1.0);
    let y0 = (a.y.min(b.y) - half).ceil().max(0.0);
    let y1 = (a.y.max(b.y) + half).floor().min(h - 1.0);
    if x0 > x1 || y0 > y1 {
        return;
    }
    let ab = b - a;
    let l2 = ab.norm_squared();
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let p = Vector2::new(x as f64, y as f64);
            let t = if l2 > 0.0 {
                ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if (p - (a + ab * t)).norm_squared() <= half * half {
                mask.put_pixel(x, y, image::Luma([255]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use flexshape_camera::{Distortion, Intrinsics, Pose};

    use super::*;

    fn camera() -> Camera {
        let lens = Distortion::from_opencv(&[-0.1, 0.05, 0.0, 0.0, 0.0]).unwrap();
        Camera::new(
            Intrinsics::new(800, 600, 1000.0, 1000.0, 399.5, 299.5, lens).unwrap(),
            Pose::look_at(
                Point3::new(0.0, 0.0, -500.0),
                Point3::origin(),
                flexshape_camera::nalgebra::Vector3::y(),
            ),
        )
    }

    #[test]
    fn a_straight_line_is_as_wide_as_asked_wherever_it_lies_in_depth() {
        let cam = camera();
        // From near to far: 40 mm nearer at one end than at the other.
        let line = [Point3::new(-60.0, 0.0, -20.0), Point3::new(60.0, 0.0, 20.0)];
        let mask = drawn_mask(&cam, &line, 12.0);
        let px = |p: &Point3<f64>| cam.project(p).unwrap().pixel;
        // A quarter of the way in from either end (the nearer one is imaged 9 % larger).
        let quarters = [0.25, 0.75].map(|t| line[0] + (line[1] - line[0]) * t);
        for end in quarters.iter().map(px) {
            // Across the stroke: 12 or 13 pixel centres within ±6 px of its middle.
            let x = end.x.round() as u32;
            let column: Vec<u32> = (0..600)
                .filter(|&y| mask.get_pixel(x, y).0[0] == 255)
                .collect();
            assert!((12..=13).contains(&column.len()), "{x}: {column:?}");
            let middle = (column[0] + column[column.len() - 1]) as f64 / 2.0;
            assert!((middle - end.y).abs() <= 0.5, "{middle} {}", end.y);
        }
        // Round ends: 6 px beyond each end along the line.
        let ends = [px(&line[0]), px(&line[1])];
        let row = ends[0].y.round() as u32;
        let set: Vec<u32> = (0..800)
            .filter(|&x| mask.get_pixel(x, row).0[0] == 255)
            .collect();
        let (lo, hi) = (ends[0].x.min(ends[1].x), ends[0].x.max(ends[1].x));
        assert!((lo - set[0] as f64 - 6.0).abs() < 1.0, "{lo} {}", set[0]);
        assert!(
            (set[set.len() - 1] as f64 - hi - 6.0).abs() < 1.0,
            "{hi} {set:?}"
        );
    }

    #[test]
    fn what_the_camera_cannot_see_is_not_drawn() {
        let cam = camera();
        let behind = [
            Point3::new(0.0, 0.0, -600.0),
            Point3::new(10.0, 0.0, -700.0),
        ];
        let mask = drawn_mask(&cam, &behind, 10.0);
        assert!(mask.pixels().all(|p| p.0[0] == 0));
    }
}
