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
        let truth = &b.frame.truth;
        let rms = centerline_rms(truth, sim, &b.fitted.points);
        let tip = tip_error(truth, &b.fitted);
        println!(
            "frame {n:2}: {:?}, rms {rms:.3} mm (hull {:.3}), tip {tip:.2} mm",
            b.fitted.status,
            centerline_rms(truth, sim, &b.hull.points)
        );
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
