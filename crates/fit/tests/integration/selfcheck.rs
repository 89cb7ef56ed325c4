//! The self-check: a fitted shape that does not explain the images is `inconsistent`, never
//! `ok` — with the camera and the check named. (That well-explained frames are `ok` is shown
//! by the accuracy tests, which require `ok` on every frame.)

use crate::common;

use common::*;
use flexshape_shape::Status;
use flexshape_sim::SimConfig;

/// One camera's calibrated orientation off by 0.2° (≈ 2.8 px at its 800 px focal length): the
/// hull still carves a tube, 1.5–2 mm off, but on almost every frame no tube explains all
/// three outlines. (A single frame cannot reveal every calibration error: a tube's shape can
/// leave it unseen; `rig refine` over many frames is the remedy.)
#[test]
fn a_miscalibrated_camera_makes_frames_inconsistent() {
    let chain = Chain::with_camera_turned(SimConfig::default(), 1, 0.2);
    let sim = &chain.sim;
    let (mut flagged, mut tenth) = (0, 0);
    for (n, pose) in sim.sweep(12).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let fit = b.fit.as_ref().expect("the hull still gives a start");
        let worst = fit
            .cameras
            .iter()
            .max_by(|a, b| a.p90_px.total_cmp(&b.p90_px))
            .unwrap();
        println!(
            "frame {n}: {:?}; rms {:.3} mm (hull {:.3}); residuals {:?} px",
            b.fitted.status,
            centerline_rms(&b.frame.truth, sim, &b.fitted.points),
            centerline_rms(&b.frame.truth, sim, &b.hull.points),
            fit.cameras
                .iter()
                .map(|c| format!("{:.2}/{:.2}", c.residual_px, c.p90_px))
                .collect::<Vec<_>>()
        );
        if b.fitted.status != Status::Ok {
            flagged += 1;
            match &b.fitted.status {
                Status::Inconsistent { reason } => {
                    assert!(reason.contains("camera cam"), "{reason}");
                    tenth += usize::from(reason.contains("of the outline lies farther"));
                }
                other => panic!("frame {n}: {other:?}"),
            }
        } else {
            // What a single frame cannot reveal: the tube's shape leaves this error unseen.
            assert!(worst.p90_px > 0.15, "frame {n}: {worst:?}");
        }
    }
    // Measured: 11 of 12 (the twelfth fits every camera to 0.22 px, 1.7 mm off), 8 of them by
    // the outline's 90th percentile.
    assert!(flagged >= 10, "only {flagged} of 12 frames flagged");
    assert!(
        tenth >= 4,
        "only {tenth} frames flagged by the 90th percentile"
    );
}

/// The hull cut short (as a thin tube with calibration error gets cut on real footage): the
/// silhouette pixels of the missed distal part stay unexplained, unless the fit, lengthened
/// along what the images show beyond its cut end, finds the rest — then it is right.
/// Measured: frames 0–2 `inconsistent` (their distal parts bend away from the cut end's
/// tangent), frame 3 found (before the lengthening walked on from a fitted end, all four
/// `inconsistent`).
#[test]
fn a_missed_distal_part_makes_the_frame_inconsistent_or_is_found() {
    let chain = Chain::new(SimConfig::default());
    let sim = &chain.sim;
    let mut found = 0;
    for (n, pose) in sim.sweep(4).iter().enumerate() {
        let b = chain.run_from(sim.render(n as u64, pose).unwrap(), |hull| {
            let keep = hull.points.len() * 3 / 5;
            hull.points.truncate(keep);
            hull.length = hull.arc[keep - 1];
        });
        println!("frame {n}: {:?}", b.fitted.status);
        // Nor does the background ever take the missed part for a changed backdrop: either
        // the tube is not taken as located, or the missed part counts as the tube's.
        let fit = b.fit.as_ref().unwrap();
        if chain.fitter.located(fit, &sim.rig().volume) {
            for (i, s) in chain.silhouettes(&b.frame).iter().enumerate() {
                let keep = chain.fitter.tube_pixels(i, &fit.tube, &s.object).unwrap();
                let loose = s.object.and_not(&keep).count();
                println!("  located; camera {i}: {loose} silhouette pixels not the tube's");
                assert!(loose <= 20, "frame {n}, camera {i}: {loose}");
            }
        } else {
            println!("  not located");
        }
        match &b.fitted.status {
            Status::Inconsistent { reason } => assert!(
                reason.contains("beyond the fitted tube")
                    || reason.contains("goes on beyond its tip")
                    || reason.contains("overlaps")
                    || reason.contains("free end"),
                "{reason}"
            ),
            // Found along the images: lengthened from the cut end (`lengthen`), and right.
            Status::Ok => {
                let (rms, tip) = b.fitted_errors(sim);
                println!("  found along the images: rms {rms:.3} mm, tip {tip:.2} mm");
                assert!(
                    rms <= 0.15 && tip <= 0.3,
                    "frame {n}: ok at {rms} mm, tip {tip}"
                );
                found += 1;
            }
            other => panic!("frame {n}: {other:?} with 40 % of the tube missed"),
        }
    }
    // The refusal this test is for still meets three of the four cut fits.
    assert!(found <= 1, "{found} of 4 found");
}

/// Hull voxels the fitted tube leaves out — a branch the cameras would allow — make the frame
/// `ambiguous`; the same frame with its own hull is `ok`.
#[test]
fn hull_away_from_the_fitted_tube_makes_the_frame_ambiguous() {
    let chain = Chain::new(SimConfig::default());
    let sim = &chain.sim;
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let both = chain.run(frame);
    assert_eq!(both.fitted.status, Status::Ok);
    let sil = chain.silhouettes(&both.frame);
    let views = chain.views(&both.frame, &sil);
    // The tube's own voxels: 1-mm voxels within its radius of the fitted centerline.
    let pts = &both.fitted.points;
    let r = both.fitted.radius;
    let mut voxels: Vec<[f64; 3]> = Vec::new();
    for p in pts.iter().step_by(2) {
        for dx in -3..=3 {
            for dy in -3..=3 {
                for dz in -3..=3 {
                    let q = [p[0] + dx as f64, p[1] + dy as f64, p[2] + dz as f64];
                    let d2 = (dx * dx + dy * dy + dz * dz) as f64;
                    if d2 <= (r - 0.5) * (r - 0.5) {
                        voxels.push(q);
                    }
                }
            }
        }
    }
    let run = |voxels: &[[f64; 3]]| {
        chain
            .fitter
            .refine(
                &chain.estimator,
                &sim.rig().volume,
                &views,
                &both.hull,
                voxels,
                None,
            )
            .unwrap()
    };
    let (own, fit) = run(&voxels);
    println!(
        "own voxels: {:?}, ghost {:?} mm",
        own.status,
        fit.unwrap().ghost_mm
    );
    assert_eq!(own.status, Status::Ok);
    // A straight branch of 30 mm, 20 mm off the tube's middle.
    let mid = pts[pts.len() / 2];
    for k in 0..30 {
        for dy in -2..=2 {
            for dz in -2..=2 {
                voxels.push([
                    mid[0] + 20.0 + k as f64,
                    mid[1] + dy as f64,
                    mid[2] + dz as f64,
                ]);
            }
        }
    }
    let (ghosted, fit) = run(&voxels);
    let ghost = fit.unwrap().ghost_mm.unwrap();
    println!("with a branch: {:?}, ghost {ghost:.1} mm", ghosted.status);
    assert!((20.0..40.0).contains(&ghost), "ghost {ghost:.1} mm");
    match ghosted.status {
        Status::Ambiguous { reason } => assert!(reason.contains("away from the fitted shape")),
        other => panic!("{other:?}"),
    }
}
