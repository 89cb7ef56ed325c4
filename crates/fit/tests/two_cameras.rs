//! Two cameras: the visual hull grows ghost branches that both silhouettes allow. Every frame
//! must be right (sub-0.15 mm, the right length, the right way round) or say it is not `ok`.

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
    let (mut ok, mut ghosts_caught) = (0, 0);
    let mut reasons = Vec::new();
    for (n, pose) in sim.sweep(20).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
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
            "frame {n:2}: {:?}, rms {rms:.3} mm (hull {hull_rms:.3}), tip {tip:.2} mm, length {:.1}/{true_length:.1}, σ max {:.3} tip {:.3}",
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
    // Measured: 5 of 20 ok (rms ≤ 0.081 mm, lengths within 0.2 mm); the 12 frames whose hull
    // is a ghost (rms > 1 mm) are all `ambiguous` or `inconsistent`, and so are the frames the
    // two views leave loose (1-σ across the tube above 0.1 mm: one was 0.35 mm off). The test
    // means something only if both kinds occur.
    println!("{ok} ok, {ghosts_caught} ghosts caught");
    assert!(ok >= 3, "only {ok} frames ok");
    assert!(ghosts_caught >= 4, "only {ghosts_caught} ghost frames");
    // The fit's own checks are among the reasons: outlines the tube does not explain, a shape
    // the two views leave loose, and hull left away from the fitted tube or a free end where
    // the image shows none (whichever comes first; each is also tested apart in `selfcheck`).
    assert!(
        reasons
            .iter()
            .any(|r| r.contains("away from the fitted shape") || r.contains("free end")),
        "{reasons:#?}"
    );
    for kind in ["from the image's boundary", "pin the centerline"] {
        assert!(
            reasons.iter().any(|r| r.contains(kind)),
            "no frame flagged for '{kind}': {reasons:#?}"
        );
    }
}
