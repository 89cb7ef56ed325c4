//! Scenes built to break assumptions: soft shadows on the backdrops, occluders hiding parts of
//! the views, and a strongly distorting lens. Every `ok` frame must still be right.

use crate::common;

use common::*;
use flexshape_shape::Status;
use flexshape_sim::{RenderSettings, SimConfig, SimRigConfig};

#[test]
fn shadows_occluders_and_strong_distortion_never_give_a_wrong_ok() {
    let config = SimConfig {
        rig: SimRigConfig {
            // A wide-angle lens: 6 % barrel distortion at the image corners.
            distortion: [-0.32, 0.14, 0.0008, -0.0005, -0.03],
            ..SimRigConfig::default()
        },
        render: RenderSettings {
            shadows: true,
            ..RenderSettings::default()
        },
        occluders: 2,
        seed: 5,
        ..SimConfig::default()
    };
    let chain = Chain::new(config);
    let sim = &chain.sim;
    let mut ok = 0;
    for (n, pose) in sim.sweep(12).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        println!(
            "frame {n:2}: {:?}, rms {rms:.3} mm (hull {:.3}), tip {tip:.2} mm",
            b.fitted.status,
            centerline_rms(&b.frame.truth, sim, &b.hull.points)
        );
        if let Status::Inconsistent { reason } = &b.fitted.status {
            // The tube is darker than this backdrop: no word of a lighter one.
            assert!(!reason.contains("lighter than the backdrop"), "{reason}");
        }
        if b.fitted.status == Status::Ok {
            ok += 1;
            assert!(rms <= 0.12, "frame {n}: ok with rms {rms:.3} mm");
            assert!(tip <= 0.3, "frame {n}: ok with the tip {tip:.2} mm off");
        }
    }
    // Measured: 9 of 12 ok (rms 0.029–0.077 mm, tips ≤ 0.19 mm); an occluder cutting the hull
    // short gives `inconsistent`, one splitting it `ambiguous`, and one frame whose top view
    // has a shadow along the tube fails the p90 check (0.35 px) though it is 0.07 mm right.
    println!("{ok} of 12 ok");
    assert!(ok >= 6, "only {ok} of 12 ok");
}

/// A tip pointing at a camera lies, in its image, just beside the outline of the tube behind
/// it (seed 15's motion, frame 38, camera cam0). Where the two parts' edges are less than a
/// pixel apart they merge in the image, and the boundary found for the near part's outline
/// was the pair's: residuals grew along it to 0.95 px, the outline's p90 reached 0.28 px and
/// the right shape (0.08 mm RMS) was `inconsistent`. Outline points with another part's edge
/// that close beside them are left out, as those with it farther out always were.
#[test]
fn a_part_just_beside_another_outline_does_not_move_it() {
    let chain = Chain::new(SimConfig {
        seed: 15,
        ..SimConfig::default()
    });
    let sim = &chain.sim;
    let pose = &sim.motion(60, 120.0)[38];
    let b = chain.run(sim.render(38, pose).unwrap());
    let fit = b.fit.as_ref().unwrap();
    let rms = centerline_rms(&b.frame.truth, sim, &b.fitted.points);
    for c in &fit.cameras {
        println!(
            "{}: {}/{} found, residual {:.3} px, p90 {:.3} px",
            c.camera, c.found, c.samples, c.residual_px, c.p90_px
        );
    }
    println!("{:?}, rms {rms:.3} mm", b.fitted.status);
    assert_eq!(b.fitted.status, Status::Ok);
    // Measured: cam0 0.074 px RMS (0.209 before), p90 at most 0.15 px in every camera; the
    // centerline 0.045 mm RMS (0.079).
    for c in &fit.cameras {
        assert!(c.residual_px < 0.1, "{}: {:.3} px", c.camera, c.residual_px);
        assert!(c.p90_px < 0.2, "{}: p90 {:.3} px", c.camera, c.p90_px);
    }
    assert!(rms < 0.06, "rms {rms:.3} mm");
}

/// A lit tube darkens toward its outline, and against a near-black backdrop its limbs fade
/// into it: read against the colour inside the outline, every boundary of the blue tube was
/// found 0.6–0.9 px inside the true one, the fitted radius shrank to 2.1 mm for 3 and the
/// centerline was 0.40 mm RMS off (every frame `inconsistent`). Read by hue, the shape is
/// right; the outline stays noisier than on a light backdrop, and every `ok` frame is right.
#[test]
fn a_tube_whose_limbs_fade_into_a_dark_backdrop_is_placed_by_its_hue() {
    let chain = Chain::new(SimConfig {
        render: RenderSettings {
            backdrop_albedo: [0.1, 0.1, 0.1],
            ..RenderSettings::default()
        },
        ..SimConfig::default()
    });
    let sim = &chain.sim;
    let mut errors = Vec::new();
    for (n, pose) in sim.sweep(6).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        println!(
            "frame {n}: {:?}, rms {rms:.3} mm, tip {tip:.2} mm",
            b.fitted.status
        );
        // A frame that is not `ok` says why its outline is faint.
        if let Status::Inconsistent { reason } = &b.fitted.status {
            assert!(
                reason.contains("lighter than the backdrop along"),
                "{reason}"
            );
        }
        if b.fitted.status == Status::Ok {
            assert!(
                rms <= 0.12 && tip <= 0.3,
                "frame {n}: ok with rms {rms:.3}, tip {tip:.2}"
            );
        }
        errors.push(rms);
    }
    // Measured: median 0.045 mm, worst 0.049; 3 of 6 ok, the rest a p90 of 0.26–0.28 px.
    let (median, worst) = (median(&errors), errors.iter().copied().fold(0.0, f64::max));
    assert!(
        median <= 0.06 && worst <= 0.1,
        "median {median:.3} mm, worst {worst:.3}"
    );
}
