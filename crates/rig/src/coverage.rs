//! What the cameras see of a volume, and the box they all see: to check a rig's volume and to
//! propose one when a calibration comes without it.
//!
//! The common box is grown around the point nearest all optical axes (least squares), first as
//! a cube, then one face at a time, while every point of its faces' 5 × 5 grids projects into every image (a margin
//! of [`MARGIN_PX`] inside the border) in front of every camera. It is a box every camera sees
//! whole, not the largest one: the cameras' views meet in a polyhedron.

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Matrix3, Point3, Vector3};

use crate::Volume;

/// Pixels kept clear of the image border.
pub const MARGIN_PX: f64 = 8.0;

/// For each of the volume's 8 corners, how many cameras see it.
pub fn corners_seen(cameras: &[Camera], volume: &Volume) -> [usize; 8] {
    volume
        .corners()
        .map(|p| cameras.iter().filter(|c| sees(c, &p, 0.0)).count())
}

/// Whether `camera` sees `p` at least `margin` pixels inside its image.
fn sees(camera: &Camera, p: &Point3<f64>, margin: f64) -> bool {
    let Ok(q) = camera.project(p) else {
        return false;
    };
    let i = &camera.intrinsics;
    q.pixel.x >= margin - 0.5
        && q.pixel.y >= margin - 0.5
        && q.pixel.x <= i.width as f64 - 0.5 - margin
        && q.pixel.y <= i.height as f64 - 0.5 - margin
}

/// The point nearest every camera's optical axis (least squares), or `None` with fewer than
/// two cameras or parallel axes.
pub fn axes_meet(cameras: &[Camera]) -> Option<Point3<f64>> {
    if cameras.len() < 2 {
        return None;
    }
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for c in cameras {
        let d = c.pose.optical_axis();
        let p = Matrix3::identity() - d * d.transpose();
        a += p;
        b += p * c.centre().coords;
    }
    let x = a.try_inverse()? * b;
    // Nearly parallel axes meet far away or nowhere useful.
    (a.determinant() > 1e-6 && x.iter().all(|v| v.is_finite())).then(|| Point3::from(x))
}

/// A box (minimum and maximum corner, world mm) that every camera sees whole, around the point
/// nearest their optical axes; `None` when the cameras see nothing in common there.
pub fn common_box(cameras: &[Camera]) -> Option<([f64; 3], [f64; 3])> {
    let centre = axes_meet(cameras)?;
    let seen = |lo: &[f64; 3], hi: &[f64; 3]| {
        face_points(lo, hi).all(|p| cameras.iter().all(|c| sees(c, &p, MARGIN_PX)))
    };
    let c = [centre.x, centre.y, centre.z];
    if !seen(&c, &c) {
        return None;
    }
    // Grow every face in turn by halving steps, starting at a tenth of the nearest camera's
    // distance.
    let reach = cameras
        .iter()
        .map(|cam| (cam.centre() - centre).norm())
        .fold(f64::INFINITY, f64::min);
    // First a cube, so that no axis takes the view from the others; then each face.
    // Views that widen with depth (a parallel stereo pair) would let a box grow without end:
    // no face goes farther from the centre than the nearest camera is.
    let mut half = 0.0;
    let mut step = reach / 10.0;
    while step > reach * 1e-4 {
        let h = half + step;
        if h <= reach
            && seen(
                &[c[0] - h, c[1] - h, c[2] - h],
                &[c[0] + h, c[1] + h, c[2] + h],
            )
        {
            half = h;
        } else {
            step /= 2.0;
        }
    }
    let (mut lo, mut hi) = (c.map(|v| v - half), c.map(|v| v + half));
    let mut step = reach / 10.0;
    while step > reach * 1e-4 {
        let mut grew = false;
        for face in 0..6 {
            let (axis, upper) = (face / 2, face % 2 == 1);
            let (mut l, mut h) = (lo, hi);
            if upper {
                h[axis] += step;
            } else {
                l[axis] -= step;
            }
            if (h[axis] - c[axis]).max(c[axis] - l[axis]) <= reach && seen(&l, &h) {
                (lo, hi) = (l, h);
                grew = true;
            }
        }
        if !grew {
            step /= 2.0;
        }
    }
    (hi.iter().zip(&lo).all(|(h, l)| h > l)).then_some((lo, hi))
}

/// Points of a 5 × 5 grid on each face of the box `lo..hi`.
fn face_points(lo: &[f64; 3], hi: &[f64; 3]) -> impl Iterator<Item = Point3<f64>> {
    const N: usize = 5;
    let (lo, hi) = (*lo, *hi);
    (0..6).flat_map(move |face| {
        let (axis, upper) = (face / 2, face % 2 == 1);
        (0..N * N).map(move |k| {
            let (u, v) = (
                (k % N) as f64 / (N - 1) as f64,
                (k / N) as f64 / (N - 1) as f64,
            );
            let mut p = [0.0; 3];
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            p[axis] = if upper { hi[axis] } else { lo[axis] };
            p[a] = lo[a] + u * (hi[a] - lo[a]);
            p[b] = lo[b] + v * (hi[b] - lo[b]);
            Point3::from(p)
        })
    })
}

/// A volume over [`common_box`] with cubic voxels of `voxel` mm (coarser when that would need
/// more than 256 voxels along an axis: the default volume's size).
pub fn suggest_volume(cameras: &[Camera], voxel: f64) -> Option<Volume> {
    let (lo, hi) = common_box(cameras)?;
    let longest = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    // Tenths of a millimetre.
    let voxel = voxel.max((longest / 256.0 * 10.0).ceil() / 10.0);
    Volume::from_bounds(lo, hi, voxel).ok()
}

#[cfg(test)]
mod tests {
    use flexshape_camera::{Distortion, Intrinsics, Pose};

    use super::*;

    /// Three cameras 500 mm from the origin, looking at it.
    fn ring() -> Vec<Camera> {
        [0.0f64, 2.1, 4.2]
            .iter()
            .map(|a| {
                let eye = Point3::new(500.0 * a.cos(), 500.0 * a.sin(), 150.0);
                let i = Intrinsics::new(640, 480, 800.0, 800.0, 319.5, 239.5, Distortion::NONE)
                    .unwrap();
                Camera::new(i, Pose::look_at(eye, Point3::origin(), Vector3::z()))
            })
            .collect()
    }

    #[test]
    fn the_suggested_box_is_around_where_the_axes_meet_and_seen_by_all() {
        let cams = ring();
        let meet = axes_meet(&cams).unwrap();
        assert!(meet.coords.norm() < 1e-6, "{meet}");
        let v = suggest_volume(&cams, 1.0).unwrap();
        assert!(corners_seen(&cams, &v).iter().all(|&n| n == 3));
        // About the cameras' field at 500 mm (±200 mm across the 640-px width, less the
        // depth of the box): a box of the order of 200 mm.
        let size = v.dims[0] as f64 * v.voxel_size[0];
        assert!((100.0..400.0).contains(&size), "{v:?}");
        // A far larger volume is mostly unseen.
        let big = Volume::from_bounds([-2000.0; 3], [2000.0; 3], 10.0).unwrap();
        assert!(corners_seen(&cams, &big).iter().all(|&n| n == 0));
    }

    #[test]
    fn a_stereo_pair_whose_views_widen_with_depth_gives_a_bounded_box() {
        // Two cameras 120 mm apart, toed in by 2°: their views overlap ever wider with depth.
        let cams: Vec<Camera> = [-60.0f64, 60.0]
            .iter()
            .map(|&x| {
                let i = Intrinsics::new(640, 480, 800.0, 800.0, 319.5, 239.5, Distortion::NONE)
                    .unwrap();
                let target = Point3::new(0.0, 0.0, 60.0 / 0.035f64.tan());
                Camera::new(
                    i,
                    Pose::look_at(Point3::new(x, 0.0, 0.0), target, -Vector3::y()),
                )
            })
            .collect();
        let v = suggest_volume(&cams, 1.0).unwrap();
        assert!(corners_seen(&cams, &v).iter().all(|&n| n == 2));
        let meet = axes_meet(&cams).unwrap();
        let reach = (cams[0].centre() - meet).norm();
        let hi = v.max_corner();
        for a in 0..3 {
            assert!(
                hi[a] - v.origin[a] <= 2.0 * reach + 2.0 * v.voxel_size[a],
                "{v:?}"
            );
        }
    }

    #[test]
    fn one_camera_or_parallel_axes_suggest_nothing() {
        let cams = ring();
        assert!(suggest_volume(&cams[..1], 1.0).is_none());
        let twin = vec![cams[0].clone(), cams[0].clone()];
        assert!(axes_meet(&twin).is_none());
    }
}
