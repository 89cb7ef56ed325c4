//! flexshape's camera model against OpenCV's own `projectPoints` and `undistortPoints`
//! (fixture made by `fixtures/make_opencv_reference.py` with OpenCV 5.0).

use flexshape_camera::nalgebra::{Matrix3, Point2, Point3, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use serde::Deserialize;

#[derive(Deserialize)]
struct Fixture {
    cameras: Vec<RefCamera>,
}

#[derive(Deserialize)]
struct RefCamera {
    name: String,
    image_size: [u32; 2],
    camera_matrix: [[f64; 3]; 3],
    distortion: Vec<f64>,
    rvec: [f64; 3],
    tvec: [f64; 3],
    world_points: Vec<[f64; 3]>,
    pixels: Vec<[f64; 2]>,
    jacobian_wrt_camera_point: Vec<[[f64; 3]; 2]>,
    undistort_pixels: Vec<[f64; 2]>,
    undistort_normalized: Vec<[f64; 2]>,
}

fn load() -> Vec<(RefCamera, Camera)> {
    let text = include_str!("fixtures/opencv_reference.json");
    let fixture: Fixture = serde_json::from_str(text).expect("fixture parses");
    fixture
        .cameras
        .into_iter()
        .map(|c| {
            let k = Matrix3::from_fn(|r, col| c.camera_matrix[r][col]);
            let d = Distortion::from_opencv(&c.distortion).unwrap();
            let intr = Intrinsics::from_matrix(c.image_size[0], c.image_size[1], &k, d).unwrap();
            let pose = Pose::from_rvec_tvec(Vector3::from(c.rvec), Vector3::from(c.tvec));
            let cam = Camera::new(intr, pose);
            (c, cam)
        })
        .collect()
}

#[test]
fn projection_matches_opencv_project_points() {
    for (r, cam) in load() {
        let mut worst: f64 = 0.0;
        for (w, px) in r.world_points.iter().zip(&r.pixels) {
            let p = cam.project(&Point3::from(*w)).unwrap();
            worst = worst.max((p.pixel.x - px[0]).abs().max((p.pixel.y - px[1]).abs()));
        }
        assert!(worst < 1e-9, "{}: worst pixel difference {worst:e}", r.name);
    }
}

#[test]
fn jacobian_matches_opencv_tvec_jacobian() {
    for (r, cam) in load() {
        let rt = cam.pose.rotation.matrix().transpose();
        for (w, jref) in r.world_points.iter().zip(&r.jacobian_wrt_camera_point) {
            let (_, j_world) = cam.project_with_jacobian(&Point3::from(*w)).unwrap();
            // ∂/∂X_world = ∂/∂x_cam · R, so ∂/∂x_cam = ∂/∂X_world · Rᵀ.
            let j_cam = j_world * rt;
            for row in 0..2 {
                for col in 0..3 {
                    let (a, b) = (j_cam[(row, col)], jref[row][col]);
                    assert!(
                        (a - b).abs() < 1e-8 * (1.0 + b.abs()),
                        "{}: J[{row},{col}] {a} vs OpenCV {b}",
                        r.name
                    );
                }
            }
        }
    }
}

#[test]
fn undistortion_matches_opencv_undistort_points() {
    for (r, cam) in load() {
        assert!(
            r.undistort_pixels.len() >= 50,
            "{}: too few reference pixels",
            r.name
        );
        for (px, n) in r.undistort_pixels.iter().zip(&r.undistort_normalized) {
            let ours = cam
                .intrinsics
                .normalized_from_pixel(Point2::new(px[0], px[1]))
                .unwrap();
            let diff = (ours.x - n[0]).abs().max((ours.y - n[1]).abs());
            assert!(diff < 1e-10, "{}: pixel {px:?}: {diff:e}", r.name);
        }
    }
}

#[test]
fn project_unproject_round_trip_below_1e6_px() {
    for (r, cam) in load() {
        let (w, h) = (r.image_size[0] as f64, r.image_size[1] as f64);
        let mut worst: f64 = 0.0;
        for i in 0..=20 {
            for j in 0..=20 {
                let px = Point2::new(-0.5 + w * i as f64 / 20.0, -0.5 + h * j as f64 / 20.0);
                let ray = cam.ray(px).unwrap_or_else(|e| panic!("{}: {e}", r.name));
                let back = cam.project(&ray.at(700.0)).unwrap().pixel;
                worst = worst.max((back - px).amax());
            }
        }
        assert!(worst < 1e-6, "{}: round trip {worst:e} px", r.name);
    }
}
