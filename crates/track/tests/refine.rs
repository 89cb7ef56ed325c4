//! Camera poses refined from tracked frames: a rig whose cameras are a few pixels off (the
//! frames all `inconsistent`) comes back to the true poses, and its frames to `ok`.

mod common;

use flexshape_camera::{Camera, Pose};
use flexshape_track::{RefineSettings, refine_cameras};
use image::RgbImage;
use nalgebra::{Point3, Rotation3, Vector3};

/// `camera` turned by `rvec` (radians) about its own centre and shifted by `shift` (mm),
/// both in its own frame.
fn disturbed(camera: &Camera, rvec: [f64; 3], shift: [f64; 3]) -> Camera {
    let r = Rotation3::from_scaled_axis(Vector3::from(rvec));
    let pose = Pose {
        rotation: r * camera.pose.rotation,
        translation: r * camera.pose.translation + Vector3::from(shift),
    };
    Camera::new(camera.intrinsics.clone(), pose)
}

/// Largest distance between the images of points in the tube's working region through two
/// cameras, pixels.
fn worst_apart(a: &Camera, b: &Camera) -> f64 {
    let mut worst = 0.0_f64;
    for x in (-60..=60).step_by(20) {
        for y in (-60..=60).step_by(20) {
            for z in (-100..=40).step_by(20) {
                let p = Point3::new(x as f64, y as f64, z as f64);
                if let (Ok(pa), Ok(pb)) = (a.project(&p), b.project(&p)) {
                    worst = worst.max((pa.pixel - pb.pixel).norm());
                }
            }
        }
    }
    worst
}

#[test]
fn cameras_a_few_pixels_off_come_back() {
    let (sim, truth) = common::simulated_chain();
    let rendered: Vec<_> = sim
        .sweep(12)
        .iter()
        .enumerate()
        .map(|(n, pose)| sim.render(n as u64, pose).unwrap())
        .collect();
    let frames: Vec<Vec<RgbImage>> = rendered
        .iter()
        .map(|f| f.views.iter().map(|v| v.image.clone()).collect())
        .collect();
    let cams = truth.cameras().to_vec();
    let mut off = vec![
        cams[0].clone(),
        disturbed(&cams[1], [0.002, -0.0015, 0.001], [0.6, -0.4, 1.0]),
        disturbed(&cams[2], [-0.001, 0.001, -0.002], [-0.3, 0.5, -0.8]),
    ];
    // A calibration target fixes the rig's scale well, and the refinement keeps it: the
    // disturbance leaves the cameras' summed distance from the held one as it was (off by
    // 0.03 % it costs 0.17 mm at the tube, which the images cannot show).
    let spread = |cams: &[Camera]| -> f64 {
        cams[1..]
            .iter()
            .map(|c| (c.centre() - cams[0].centre()).norm())
            .sum()
    };
    let s = spread(&cams) / spread(&off);
    for cam in &mut off[1..] {
        let c = cams[0].centre() + (cam.centre() - cams[0].centre()) * s;
        cam.pose.translation = -(cam.pose.rotation * c.coords);
    }
    let before: Vec<f64> = (1..3).map(|i| worst_apart(&cams[i], &off[i])).collect();
    let pipeline = truth.with_cameras(off).unwrap();
    let r = refine_cameras(&pipeline, &frames, &RefineSettings::default()).unwrap();
    // The frames tracked with the refined rig, against the truth.
    let refined = truth
        .with_cameras(r.cameras.iter().map(|c| c.camera.clone()).collect())
        .unwrap();
    let mut errors: Vec<f64> = rendered
        .iter()
        .zip(&frames)
        .map(|(f, images)| {
            let t = refined.process(&images.iter().collect::<Vec<_>>()).unwrap();
            common::rms(&f.truth, &sim, &t.shape)
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    for c in &r.cameras {
        println!(
            "{}: rms {:.3} → {:.3} px, shift {:?} → {:?}, turned {:.4}°, moved {:.2} mm",
            c.name,
            c.before.rms_px,
            c.after.rms_px,
            c.before.shift_px,
            c.after.shift_px,
            c.rotation_rad.to_degrees(),
            c.centre_moved_mm
        );
    }
    let after: Vec<f64> = (1..3)
        .map(|i| worst_apart(&cams[i], &r.cameras[i].camera))
        .collect();
    println!(
        "frames {} used {} rounds {}; right {} → {}; worst apart from truth {before:?} → {after:?} px; centerline rms median {:.3} worst {:.3} mm",
        r.frames,
        r.used,
        r.rounds,
        r.right_before,
        r.right_after,
        errors[errors.len() / 2],
        errors[errors.len() - 1]
    );
    assert!(r.cameras[0].held && r.cameras[0].camera == cams[0]);
    for i in 1..3 {
        assert!(before[i - 1] > 1.5, "the disturbance is a few pixels");
        assert!(
            after[i - 1] < 0.3,
            "camera {i}: {after:?} px from the truth"
        );
    }
    for c in &r.cameras {
        assert!(c.before.rms_px > 0.3, "{}: {}", c.name, c.before.rms_px);
        assert!(c.after.rms_px < 0.15, "{}: {}", c.name, c.after.rms_px);
    }
    assert!(errors[errors.len() / 2] < 0.08 && errors[errors.len() - 1] < 0.15);
    assert!(r.right_before <= 2, "{}", r.right_before);
    assert!(r.right_after >= 10, "{}", r.right_after);
}
