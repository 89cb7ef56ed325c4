//! Properties over random realistic cameras.

use flexshape_camera::nalgebra::{Point2, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use proptest::prelude::*;

fn camera() -> impl Strategy<Value = Camera> {
    (
        (300.0..2000.0f64, 0.95..1.05f64),
        (
            -0.4..0.2f64,
            -0.2..0.3f64,
            -0.003..0.003f64,
            -0.003..0.003f64,
            -0.1..0.1f64,
        ),
        (-0.3..0.3f64, -0.3..0.3f64, -3.0..3.0f64),
        (-50.0..50.0f64, -50.0..50.0f64, 300.0..900.0f64),
    )
        .prop_filter_map(
            "distortion must stay invertible over the image",
            |((f, aspect), (k1, k2, p1, p2, k3), r, t)| {
                let d = Distortion::from_opencv(&[k1, k2, p1, p2, k3]).ok()?;
                let k = Intrinsics::new(640, 480, f, f * aspect, 319.5, 239.5, d).ok()?;
                let pose =
                    Pose::from_rvec_tvec(Vector3::new(r.0, r.1, r.2), Vector3::new(t.0, t.1, t.2));
                let cam = Camera::new(k, pose);
                // Keep cameras whose image corners undistort (inside the lens model's fold).
                [(-0.5, -0.5), (639.5, -0.5), (-0.5, 479.5), (639.5, 479.5)]
                    .iter()
                    .all(|&(u, v)| cam.ray(Point2::new(u, v)).is_ok())
                    .then_some(cam)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn unproject_then_project_returns_the_pixel(cam in camera(), u in -0.5..639.5f64, v in -0.5..479.5f64, depth in 100.0..2000.0f64) {
        let px = Point2::new(u, v);
        let ray = cam.ray(px).unwrap();
        let back = cam.project(&ray.at(depth)).unwrap();
        prop_assert!((back.pixel - px).amax() < 1e-6, "{:?} -> {:?}", px, back.pixel);
        prop_assert!((ray.direction.norm() - 1.0).abs() < 1e-12);
        prop_assert!((ray.origin - cam.centre()).norm() < 1e-9);
    }

    #[test]
    fn jacobian_matches_finite_differences(cam in camera(), u in 20.0..620.0f64, v in 20.0..460.0f64, depth in 200.0..1500.0f64) {
        let p = cam.ray(Point2::new(u, v)).unwrap().at(depth);
        let (_, j) = cam.project_with_jacobian(&p).unwrap();
        let h = 1e-3;
        for c in 0..3 {
            let mut e = Vector3::zeros();
            e[c] = h;
            let fd = (cam.project(&(p + e)).unwrap().pixel - cam.project(&(p - e)).unwrap().pixel) / (2.0 * h);
            let scale = 1.0 + j.amax();
            prop_assert!((fd.x - j[(0, c)]).abs() < 1e-5 * scale && (fd.y - j[(1, c)]).abs() < 1e-5 * scale);
        }
    }
}
