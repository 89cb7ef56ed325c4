//! Camera poses refined from tracked frames: a rig whose cameras are a few pixels off (the
//! frames all `inconsistent`) comes back to the true poses and its frames to `ok`; a rig that
//! is right is not worth refining.

use crate::common;

use flexshape_camera::{Camera, Pose};
use flexshape_lab::refine::{Refinement, Verdict, refine_cameras};
use flexshape_sim::{SimConfig, SimRigConfig};
use flexshape_sim::{SimFrame, Simulator};
use flexshape_track::Pipeline;
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

/// `n` frames of the default sweep, rendered, and their images.
fn frames(sim: &Simulator, n: usize) -> (Vec<SimFrame>, Vec<Vec<RgbImage>>) {
    let rendered: Vec<_> = sim
        .sweep(n)
        .iter()
        .enumerate()
        .map(|(n, pose)| sim.render(n as u64, pose).unwrap())
        .collect();
    let images = rendered
        .iter()
        .map(|f| f.views.iter().map(|v| v.image.clone()).collect())
        .collect();
    (rendered, images)
}

/// Each frame tracked with `cameras` against the truth: centerline RMS, mm, sorted.
fn errors(
    truth: &Pipeline,
    cameras: Vec<Camera>,
    sim: &Simulator,
    rendered: &[SimFrame],
    images: &[Vec<RgbImage>],
) -> Vec<f64> {
    let pipeline = truth.with_cameras(cameras).unwrap();
    let mut e: Vec<f64> = rendered
        .iter()
        .zip(images)
        .map(|(f, images)| {
            let t = pipeline
                .process(&images.iter().collect::<Vec<_>>())
                .unwrap();
            common::errors(&f.truth, sim, &t.shape).map_or(f64::INFINITY, |e| e.centerline_rms)
        })
        .collect();
    e.sort_by(f64::total_cmp);
    e
}

fn print(r: &Refinement) {
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
    println!(
        "frames {} used {} steps {}; right {} → {}; overall rms {:?}",
        r.frames,
        r.used,
        r.steps,
        r.right_before,
        r.right_after,
        r.overall_rms()
    );
}

#[test]
fn cameras_a_few_pixels_off_come_back() {
    let (sim, truth) = common::simulated_chain();
    let (rendered, images) = frames(&sim, 12);
    let cams = truth.cameras().to_vec();
    let mut off = vec![
        cams[0].clone(),
        disturbed(&cams[1], [0.002, -0.0015, 0.001], [0.6, -0.4, 1.0]),
        disturbed(&cams[2], [-0.001, 0.001, -0.002], [-0.3, 0.5, -0.8]),
    ];
    // A calibration target fixes the rig's scale well, and the refinement keeps it: the
    // disturbance leaves the cameras' summed distance from the held one as it was (0.08 % off
    // places the tube 0.5 mm off at 600 mm, which the images cannot show).
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
    let pipeline = truth.with_cameras(off.clone()).unwrap();
    let r = refine_cameras(&pipeline, &images, Some(0)).unwrap();
    print(&r);
    let refined: Vec<Camera> = r.cameras.iter().map(|c| c.camera.clone()).collect();
    let after: Vec<f64> = (1..3).map(|i| worst_apart(&cams[i], &refined[i])).collect();
    let e_off = errors(&truth, off, &sim, &rendered, &images);
    let e = errors(&truth, refined, &sim, &rendered, &images);
    println!(
        "worst apart from truth {before:?} → {after:?} px; centerline rms median {:.3} → {:.3}, worst {:.3} → {:.3} mm",
        e_off[6], e[6], e_off[11], e[11]
    );
    assert!(r.cameras[0].held && r.cameras[0].camera == cams[0]);
    for i in 1..3 {
        assert!(before[i - 1] > 1.5, "the disturbance is a few pixels");
        assert!(
            after[i - 1] < 0.2,
            "camera {i}: {after:?} px from the truth"
        );
    }
    for c in &r.cameras {
        assert!(c.before.rms_px > 0.3, "{}: {}", c.name, c.before.rms_px);
        assert!(c.after.rms_px < 0.12, "{}: {}", c.name, c.after.rms_px);
    }
    // The disagreement shows as image shifts of the outlines (in every camera: the tube settles
    // between them), gone after.
    let norm = |s: [f64; 2]| s[0].hypot(s[1]);
    assert!(r.cameras.iter().any(|c| norm(c.before.shift_px) > 0.5));
    assert!(r.cameras.iter().all(|c| norm(c.after.shift_px) < 0.05));
    // Measured: median 0.063 mm, worst 0.067 (cameras 0.09 and 0.11 px from the truth). The
    // figure moves with what the refinement is given more than with its cameras' distance
    // from the truth: 0.036 mm on 12 frames, 0.055 on 14 and 0.066 on 16 before outline
    // points beside another part of the tube were left out (session 17), 0.063, 0.083 and
    // 0.095 since, every refined camera within 0.17 px of the truth.
    assert!(e[6] < 0.08 && e[11] < 0.09, "{e:?}");
    assert!(r.used == 12 && r.right_before <= 2 && r.right_after == 12);
    assert_eq!(r.verdict(), Verdict::Better);
    assert!(r.cameras.iter().all(|c| c.sigma_mm < 0.15), "pinned down");
}

#[test]
fn a_rig_that_is_right_is_not_worth_refining() {
    let (sim, truth) = common::simulated_chain();
    let (_, images) = frames(&sim, 12);
    let r = refine_cameras(&truth, &images, None).unwrap();
    print(&r);
    assert_eq!(r.verdict(), Verdict::NoBetter);
    assert!(
        r.cameras
            .iter()
            .all(|c| c.before.shift_px[0].hypot(c.before.shift_px[1]) < 0.05)
    );
    assert_eq!(r.right_before, r.right_after);
    for c in &r.cameras {
        assert!(c.rotation_rad.to_degrees() < 0.05 && c.centre_moved_mm < 0.5);
    }
}

#[test]
fn too_few_frames_are_refused() {
    let (sim, truth) = common::simulated_chain();
    let (_, images) = frames(&sim, 12);
    let e = refine_cameras(&truth, &images[..2], None).unwrap_err();
    assert!(e.to_string().contains("2 of 2 frames"), "{e}");
    let e = refine_cameras(&truth, &images, Some(3)).unwrap_err();
    assert!(e.to_string().contains("number 4 but the rig has 3"), "{e}");
}

#[test]
fn two_cameras_leave_what_they_cannot_see_as_calibrated() {
    // Two cameras see a tube consistently from a family of relative poses: before the pose
    // prior, one refinement of this kind explained every frame at the noise level and left
    // the shapes 1.5 mm off. Now the directions the outlines hardly see stay as calibrated,
    // and the report says which camera it cannot tell moved.
    let (sim, truth) = common::chain_of(SimConfig {
        rig: SimRigConfig {
            cameras: 2,
            ..SimRigConfig::default()
        },
        ..SimConfig::default()
    });
    let (rendered, images) = frames(&sim, 16);
    let cams = truth.cameras().to_vec();
    let off = vec![
        cams[0].clone(),
        disturbed(&cams[1], [0.002, -0.0015, 0.001], [0.0; 3]),
    ];
    let r = refine_cameras(&truth.with_cameras(off.clone()).unwrap(), &images, None).unwrap();
    print(&r);
    for line in r.undecided() {
        println!("{line}");
    }
    // Either camera may have moved: the rig's first stays.
    assert!(r.cameras[0].held && r.cameras[0].camera == off[0]);
    assert_eq!(r.alternatives, vec![vec!["cam0".to_string()]]);
    assert!(r.world_open_mm > 0.0);
    assert!(r.cameras[1].held_directions > 0, "{:?}", r.cameras[1]);
    // No drift: the shapes are no farther from the truth than with the knocked rig.
    let refined: Vec<Camera> = r.cameras.iter().map(|c| c.camera.clone()).collect();
    let e_off = errors(&truth, off, &sim, &rendered, &images);
    let e = errors(&truth, refined, &sim, &rendered, &images);
    println!("centerline rms median {:.3} → {:.3} mm", e_off[8], e[8]);
    assert!(e[8] <= e_off[8] + 0.05, "{e:?} against {e_off:?}");
}

/// A three-camera rig `knocked`: camera `which` turned and shifted a few pixels' worth.
fn knocked(truth: &Pipeline, which: usize) -> Vec<Camera> {
    let mut cams = truth.cameras().to_vec();
    cams[which] = disturbed(&cams[which], [0.0015, -0.002, 0.001], [0.5, -0.3, 0.8]);
    cams
}

#[test]
fn a_knocked_camera_moves_alone_and_the_world_stays_where_it_was() {
    // Issue 50: the refinement used to hold the first camera and move the rest, and moved a
    // camera that was right by 0.7–4 mm; the shapes, explained at the noise level, sat 0.4 mm
    // off in the world frame. Whichever camera was knocked, it alone moves now.
    let (sim, truth) = common::simulated_chain();
    let (rendered, images) = frames(&sim, 12);
    let cams = truth.cameras().to_vec();
    for which in [2, 0] {
        let off = knocked(&truth, which);
        let moved_px = worst_apart(&cams[which], &off[which]);
        let r = refine_cameras(&truth.with_cameras(off.clone()).unwrap(), &images, None).unwrap();
        print(&r);
        for line in r.undecided() {
            println!("{line}");
        }
        let refined: Vec<Camera> = r.cameras.iter().map(|c| c.camera.clone()).collect();
        let apart = worst_apart(&cams[which], &refined[which]);
        let e_off = errors(&truth, off.clone(), &sim, &rendered, &images);
        let e = errors(&truth, refined.clone(), &sim, &rendered, &images);
        println!(
            "cam{which} knocked {moved_px:.2} px → {apart:.2} px from the truth; centerline rms median {:.3} → {:.3} mm, worst {:.3}",
            e_off[6], e[6], e[11]
        );
        assert!(moved_px > 1.5, "the knock is a few pixels");
        assert_eq!(r.verdict(), Verdict::Better);
        for (i, c) in r.cameras.iter().enumerate() {
            // The cameras that were right do not move at all.
            assert_eq!(c.held, i != which, "{}", c.name);
            if i != which {
                assert_eq!(c.camera, cams[i], "{}", c.name);
            }
        }
        assert!(apart < 0.5, "{apart} px");
        // In the world frame the calibration gave, with no alignment.
        assert!(e[6] < 0.05 && e[11] < 0.07, "{e:?}");
        assert_eq!(r.right_after, 12);
        // The two others moved together would explain the frames too: said, and how far the
        // world frame would then have gone.
        assert_eq!(r.alternatives.len(), 1, "{:?}", r.alternatives);
        assert!(r.world_open_mm > 0.0);
        // The refined rig says so, and reads back as it was written.
        let rig = r.rig(sim.rig(), flexshape_rig::Volume::default());
        let refined = rig.refined.clone().expect("a refined rig says what moved");
        assert_eq!(refined.moved, vec![format!("cam{which}")]);
        assert!((refined.world_open_mm - r.world_open_mm).abs() < 1e-3);
        let dir = tempfile::tempdir().unwrap();
        rig.save(&dir.path().join("rig.toml")).unwrap();
        let back = flexshape_rig::Rig::load(&dir.path().join("rig.toml")).unwrap();
        assert_eq!(back.refined, Some(refined));
    }
    // A camera named as right is never moved, even where moving it would explain the frames.
    let r = refine_cameras(
        &truth.with_cameras(knocked(&truth, 2)).unwrap(),
        &images,
        Some(2),
    )
    .unwrap();
    assert!(r.cameras[2].held && !r.cameras[0].held && !r.cameras[1].held);
    assert!(r.alternatives.is_empty(), "{:?}", r.alternatives);
}
