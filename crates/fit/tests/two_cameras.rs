//! Two cameras: the visual hull grows ghost branches that both silhouettes allow (and often
//! falls into pieces). Every frame must be right (sub-0.15 mm, the right length, the right way
//! round) or say it is not `ok`; frames whose hull is a ghost are started again from the two
//! silhouettes matched along epipolar lines, and must then come out right.

mod common;

use common::*;
use flexshape_curve::Polyline;
use flexshape_shape::Status;
use flexshape_sim::{SimConfig, SimRigConfig};
use nalgebra::Point3;

#[test]
fn two_cameras_never_report_a_ghost_as_ok() {
    let config = SimConfig {
        rig: SimRigConfig {
            cameras: 2,
            ..SimRigConfig::default()
        },
        ..SimConfig::default()
    };
    let chain = Chain::new(config);
    let sim = &chain.sim;
    let (mut ok, mut ghosts_resolved, mut ghosts_caught) = (0, 0, 0);
    let mut reasons = Vec::new();
    for (n, pose) in sim.sweep(20).iter().enumerate() {
        let (b, from_views) = chain.run_two_views(sim.render(n as u64, pose).unwrap());
        let truth = &b.frame.truth;
        let inside: Vec<Point3<f64>> = truth
            .centerline
            .iter()
            .map(|&p| Point3::from(p))
            .filter(|p| sim.rig().volume.contains(p))
            .collect();
        let entry = inside[0];
        let true_length = Polyline::new(inside).unwrap().length();
        let rms = centerline_rms(truth, sim, &b.fitted.points);
        let hull_rms = centerline_rms(truth, sim, &b.hull.points);
        let tip = tip_error(truth, &b.fitted);
        println!(
            "frame {n:2}{}: {:?}, rms {rms:.3} mm (hull {hull_rms:.3}), tip {tip:.2} mm, length {:.1}/{true_length:.1}, σ max {:.3} tip {:.3}",
            if from_views { " (two views)" } else { "" },
            b.fitted.status,
            b.fitted.length,
            b.fitted.sigma.iter().copied().fold(0.0, f64::max),
            b.fitted.sigma.last().copied().unwrap_or(0.0)
        );
        if let Status::Ambiguous { reason } | Status::Inconsistent { reason } = &b.fitted.status {
            reasons.push(reason.clone());
        }
        if b.fitted.status == Status::Ok {
            ok += 1;
            if from_views && hull_rms > 1.0 {
                ghosts_resolved += 1;
            }
            // The bound; measured ≤ 0.033 mm.
            assert!(rms <= 0.15, "frame {n}: ok with rms {rms:.3} mm");
            // Measured ≤ 0.09 mm.
            assert!(tip <= 0.3, "frame {n}: ok with the tip {tip:.2} mm off");
            let start = Point3::from(b.fitted.points[0]);
            assert!(
                (start - entry).norm() < 5.0,
                "frame {n}: ok but reversed (starts {:.1} mm from the entry)",
                (start - entry).norm()
            );
            assert!(
                (b.fitted.length / true_length - 1.0).abs() <= 0.05,
                "frame {n}: ok with length {:.1} for {true_length:.1}",
                b.fitted.length
            );
        } else if hull_rms > 1.0 {
            ghosts_caught += 1;
        }
    }
    // Measured: 12 of 20 ok (rms ≤ 0.081 mm, tips ≤ 0.25 mm, lengths within 0.2 mm), 7 of them
    // frames whose hull is a ghost or in pieces (rms > 1 mm), started from the two views (the
    // start from the hull alone gave 5 ok). The rest are `ambiguous` (the two views leave the
    // centerline loose: 1-σ across the tube above 0.1 mm) or `inconsistent`. Over 100 more
    // frames (seeds 2 and 3, a floating base) no frame was `ok` and wrong.
    println!("{ok} ok, {ghosts_resolved} ghosts resolved, {ghosts_caught} caught");
    assert!(ok >= 10, "only {ok} frames ok");
    assert!(
        ghosts_resolved >= 5,
        "only {ghosts_resolved} ghost frames resolved"
    );
    assert!(
        ghosts_caught >= 1,
        "no ghost frame left unresolved: the test says less"
    );
    for kind in ["from the image's boundary", "pin the centerline"] {
        assert!(
            reasons.iter().any(|r| r.contains(kind)),
            "no frame flagged for '{kind}': {reasons:#?}"
        );
    }
}
