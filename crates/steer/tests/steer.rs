//! The closed loop end to end on rendered frames: the tip reaches each target within 1 mm
//! (the target) and the stiffnesses learnt online come within 5 % of the truth.

use std::ops::ControlFlow;

use flexshape_model::ManipulatorParams;
use flexshape_sim::SimConfig;
use flexshape_steer::{SteerSettings, reachable_targets, steer, steer_with_frames};

#[test]
fn the_sensed_tip_is_steered_to_its_targets_and_the_stiffnesses_are_learnt() {
    // Polymer tendons, and a catheter 25 % stiffer about x and 20 % softer about z than the
    // controller believes.
    let mut nominal = ManipulatorParams::paper_like();
    for t in &mut nominal.tendons {
        t.stiffness = 1500.0;
    }
    let mut truth = nominal.clone();
    truth.stiffness.kx *= 1.25;
    truth.stiffness.kz *= 0.8;
    let targets = reachable_targets(&truth, 3, 0.004).unwrap();
    let settings = SteerSettings::default();
    let (steps, learnt) = steer(
        &SimConfig::default(),
        &truth,
        &nominal,
        &targets,
        &settings,
        |s| {
            println!(
                "frame {} target {}: {} sensed {:?} true {:.3} mm",
                s.frame,
                s.target_index,
                s.status,
                s.sensed_error_mm.map(|e| (e * 1000.0).round() / 1000.0),
                s.true_error_mm
            );
            ControlFlow::Continue(())
        },
    )
    .unwrap();
    assert_eq!(steps.len(), 3 * settings.steps_per_target);
    assert!(steps.iter().all(|s| s.status == "ok"));
    for t in 0..3 {
        let last = steps.iter().rfind(|s| s.target_index == t).unwrap();
        assert!(
            last.true_error_mm < 1.0,
            "target {t}: {:.3} mm off",
            last.true_error_mm
        );
    }
    // What the controller's model expected of each command against what was sensed: the
    // nominal model's first command bends the catheter 6.9 % less than it expects (measured
    // 1.0686), the learnt model's last within 0.1 % (0.9990).
    let kappa = |k: [f64; 2]| k[0].hypot(k[1]);
    let (first, last) = (&steps[0], steps.last().unwrap());
    let ratio =
        |s: &flexshape_steer::SteerStep| kappa(s.commanded_kappa) / kappa(s.sensed_kappa.unwrap());
    println!(
        "expected/sensed curvature: first {:.4}, last {:.4}",
        ratio(first),
        ratio(last)
    );
    assert!((ratio(first) - 1.0).abs() > 0.03, "{first:?}");
    assert!((ratio(last) - 1.0).abs() < 0.01, "{last:?}");
    let learnt = learnt.expect("an online estimate");
    for (got, want) in [
        (learnt.kx, truth.stiffness.kx),
        (learnt.kz, truth.stiffness.kz),
    ] {
        println!("learnt {got:.1} for {want:.1}");
        assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
    }
    // Stopping from the callback ends the loop at once.
    let (few, _) = steer(
        &SimConfig::default(),
        &truth,
        &nominal,
        &targets,
        &settings,
        |s| {
            if s.frame == 2 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    )
    .unwrap();
    assert_eq!(few.len(), 3);
}

/// Each frame handed over with its images and record; the target placed in the world at the
/// sensed bending base, so the sensed tip lies as far from it there as in the model frame.
#[test]
fn each_frame_comes_with_its_images_and_the_target_in_the_world() {
    let nominal = ManipulatorParams::paper_like();
    let targets = reachable_targets(&nominal, 1, 0.004).unwrap();
    let settings = SteerSettings {
        steps_per_target: 3,
        ..SteerSettings::default()
    };
    let mut seen = 0;
    steer_with_frames(
        &SimConfig::default(),
        &nominal,
        &nominal,
        &targets,
        &settings,
        |s, frame| {
            seen += 1;
            assert_eq!(frame.images.len(), frame.pipeline.camera_names().len());
            assert_eq!(frame.record.frame, s.frame);
            assert_eq!(frame.record.status, s.status);
            let tip = frame.record.tip.unwrap();
            let apart = (0..3)
                .map(|i| (tip[i] - s.target_world[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            let sensed = s.sensed_error_mm.unwrap();
            println!(
                "frame {}: {apart:.4} mm in the world, {sensed:.4} sensed",
                s.frame
            );
            assert!((apart - sensed).abs() < 1e-6, "{apart} vs {sensed}");
            ControlFlow::Continue(())
        },
    )
    .unwrap();
    assert_eq!(seen, 3);
}
