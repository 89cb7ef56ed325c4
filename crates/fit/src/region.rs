//! Where a tracked frame's silhouettes are computed: the part of an image within a margin of
//! the tube's predicted image, row by row.

use flexshape_camera::Camera;
use flexshape_silhouette::Rows;
use nalgebra::Point3;

use crate::outline;

/// Spheres along the tube (half its radius apart) whose boxes [`around`] joins into one: a
/// run's box is a few pixels wider than each sphere's, and the rows are updated once a run
/// instead of once a sphere.
const RUN: usize = 4;

/// The pixels of `camera`'s image within `margin_px` of the spheres about `centres` (world mm,
/// radius; see [`outline::sphere_centres`]), row by row, or `None` when the camera sees none
/// of them. Each row's columns span the boxes (rounded out to whole pixels and one more) of the
/// runs of [`RUN`] spheres that reach it: a tube across the image at a slant leaves most of
/// a box around it out.
pub(crate) fn around(
    camera: &Camera,
    centres: &[(Point3<f64>, f64)],
    margin_px: f64,
) -> Option<Rows> {
    let spheres: Vec<_> = outline::spheres_along(camera, centres)
        .into_iter()
        .flatten()
        .collect();
    let (w, h) = (
        camera.intrinsics.width as f64,
        camera.intrinsics.height as f64,
    );
    let boxes: Vec<[usize; 4]> = spheres
        .chunks(RUN)
        .filter_map(|run| {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for (_, px, rp) in run {
                for k in 0..2 {
                    lo[k] = lo[k].min(px[k] - rp - margin_px);
                    hi[k] = hi[k].max(px[k] + rp + margin_px);
                }
            }
            let (x0, y0) = (lo[0].floor().max(0.0), lo[1].floor().max(0.0));
            let (x1, y1) = ((hi[0].ceil() + 1.0).min(w), (hi[1].ceil() + 1.0).min(h));
            (x0 < x1 && y0 < y1).then_some([x0 as usize, y0 as usize, x1 as usize, y1 as usize])
        })
        .collect();
    let y0 = boxes.iter().map(|b| b[1]).min()?;
    let y1 = boxes.iter().map(|b| b[3]).max()?;
    // Each row's leftmost start and rightmost end; a row no run reaches keeps (w, 0).
    let mut spans = vec![(camera.intrinsics.width as usize, 0); y1 - y0];
    for &[bx0, by0, bx1, by1] in &boxes {
        for (start, end) in &mut spans[by0 - y0..by1 - y0] {
            (*start, *end) = ((*start).min(bx0), (*end).max(bx1));
        }
    }
    let columns = spans
        .into_iter()
        .map(|(start, end)| if start < end { start..end } else { 0..0 })
        .collect();
    Some(Rows { y0, columns })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outline::tests::camera_at as camera;
    use flexshape_camera::Pose;
    use flexshape_silhouette::Area;
    use nalgebra::Vector3;

    /// A tube of radius 3 mm bent across the view: from lower left to upper right.
    fn centres() -> Vec<(Point3<f64>, f64)> {
        (0..=160)
            .map(|i| {
                let s = i as f64 * 1.5 - 120.0;
                (Point3::new(s, 0.0, 0.6 * s + 0.002 * s * s - 10.0), 3.0)
            })
            .collect()
    }

    #[test]
    fn every_pixel_near_the_tube_is_in_and_most_of_its_box_is_out() {
        let cam = camera(Point3::new(30.0, -500.0, 60.0));
        let margin = 24.0;
        let rows = around(&cam, &centres(), margin).expect("the camera sees the tube");
        let (w, h) = (640, 480);
        let inside =
            |x: usize, y: usize| rows.rows(h).contains(&y) && rows.columns(y, w).contains(&x);
        // Every pixel within the margin of a sphere's image (each sphere projected exactly).
        let images: Vec<_> = centres()
            .iter()
            .filter_map(|&(c, r)| outline::sphere(&cam, c, r))
            .collect();
        let (mut near, mut bounds) = (0usize, [w, h, 0, 0]);
        for y in 0..h {
            for x in 0..w {
                let p = nalgebra::Vector2::new(x as f64, y as f64);
                if images
                    .iter()
                    .any(|(_, px, rp)| (px - p).norm() <= rp + margin)
                {
                    assert!(
                        inside(x, y),
                        "pixel ({x}, {y}) is within the margin but left out"
                    );
                    near += 1;
                    bounds = [
                        bounds[0].min(x),
                        bounds[1].min(y),
                        bounds[2].max(x + 1),
                        bounds[3].max(y + 1),
                    ];
                }
            }
        }
        let covered: usize = rows.rows(h).map(|y| rows.columns(y, w).len()).sum();
        let boxed = (bounds[2] - bounds[0]) * (bounds[3] - bounds[1]);
        assert!(near > 20_000, "{near} pixels near the tube");
        // The rows hold the pixels near the tube and half as many again (the runs' boxes
        // round its slant out); a box around it holds three times as many.
        assert!(
            covered * 2 < near * 3 && boxed * 2 > covered * 5,
            "{covered} pixels in the rows, {near} near the tube, {boxed} in its box"
        );
    }

    #[test]
    fn a_camera_that_sees_none_of_the_tube_has_no_region() {
        // Looking away: every sphere behind it.
        let cam = Camera::new(
            camera(Point3::origin()).intrinsics.clone(),
            Pose::look_at(
                Point3::new(0.0, -500.0, 0.0),
                Point3::new(0.0, -1000.0, 0.0),
                Vector3::z(),
            ),
        );
        assert_eq!(around(&cam, &centres(), 24.0), None);
    }
}
