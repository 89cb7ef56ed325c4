//! A tube held inside the volume: neither end touches the boundary, so the boundary cannot
//! tell the proximal end from the tip. A band at the tip can; without it (or a hint) a frame
//! is `ambiguous`, never a reversed `ok`.

use crate::common;

use common::*;
use flexshape_shape::{ShapeEstimator, ShapeRecord, ShapeSettings, Status};
use flexshape_sim::{Catheter, SimConfig};
use nalgebra::Point3;

/// The catheter's proximal end 13 mm above the volume's floor.
fn floating() -> Chain {
    let mut catheter = Catheter::default();
    catheter.base.position = Point3::new(0.0, 0.0, -115.0);
    catheter.proximal_length = 20.0;
    Chain::new(SimConfig {
        catheter,
        ..SimConfig::default()
    })
}

/// Whether a record runs from the tip to the base.
fn reversed(b: &Both) -> bool {
    let tip = Point3::from(b.frame.truth.tip);
    b.fitted
        .points
        .first()
        .is_some_and(|p: &[f64; 3]| (Point3::from(*p) - tip).norm() < 20.0)
}

fn statuses(chain: &Chain, frames: usize) -> Vec<(Status, bool, f64)> {
    let sim = &chain.sim;
    sim.sweep(frames)
        .iter()
        .enumerate()
        .map(|(n, pose)| {
            let b = chain.run(sim.render(n as u64, pose).unwrap());
            let rms = centerline_rms(&b.frame.truth, sim, &b.fitted.points);
            let r: &ShapeRecord = &b.fitted;
            println!(
                "frame {n:2}: {:?}, rms {rms:.3} mm, reversed {}",
                r.status,
                reversed(&b)
            );
            (b.fitted.status.clone(), reversed(&b), rms)
        })
        .collect()
}

#[test]
fn a_band_at_the_tip_orients_a_floating_tube() {
    let chain = floating();
    let all = statuses(&chain, 12);
    for (n, (status, reversed, rms)) in all.iter().enumerate() {
        if *status == Status::Ok {
            assert!(!reversed, "frame {n}: ok but reversed");
            assert!(*rms <= 0.08, "frame {n}: rms {rms:.3}");
        }
    }
    // Measured: 10 of 12 ok; the others' tip band is not seen at the end: `ambiguous`.
    let ok = all.iter().filter(|a| a.0 == Status::Ok).count();
    assert!(ok >= 9, "only {ok} of 12 ok");
}

#[test]
fn without_a_cue_a_floating_tube_is_ambiguous_never_reversed() {
    let mut chain = floating();
    let settings = ShapeSettings {
        tip_band: false,
        ..chain.estimator.settings().clone()
    };
    chain.estimator = ShapeEstimator::new(settings).unwrap();
    let all = statuses(&chain, 12);
    for (n, (status, _, _)) in all.iter().enumerate() {
        match status {
            Status::Ambiguous { reason } => {
                assert!(reason.contains("proximal_hint"), "frame {n}: {reason}")
            }
            other => panic!("frame {n}: {other:?} though nothing tells the tip"),
        }
    }
    // With the centerline kept, in a direction that is only a guess (measured: 5 of 12
    // reversed, which is why none may be `ok`).
    assert!(all.iter().any(|a| a.1) && all.iter().all(|a| a.2 <= 0.08));
}

/// Two cameras and a tube held inside the volume: the hull is often a ghost, so frames start
/// from the two views, and the band at the tip must orient those starts as it does the hull's.
#[test]
fn a_band_at_the_tip_orients_a_floating_tube_seen_by_two_cameras() {
    for seed in [1, 2, 3] {
        let mut catheter = Catheter::default();
        catheter.base.position = Point3::new(0.0, 0.0, -115.0);
        catheter.proximal_length = 20.0;
        let chain = Chain::new(SimConfig {
            catheter,
            rig: flexshape_sim::SimRigConfig {
                cameras: 2,
                ..Default::default()
            },
            seed,
            ..SimConfig::default()
        });
        let sim = &chain.sim;
        let (mut ok, mut views) = (0, 0);
        for (n, pose) in sim.sweep(20).iter().enumerate() {
            let (b, from_views) = chain.run_two_views(sim.render(n as u64, pose).unwrap());
            let rms = centerline_rms(&b.frame.truth, sim, &b.fitted.points);
            println!(
                "seed {seed} frame {n:2}{}: {:?}, rms {rms:.3} mm, reversed {}",
                if from_views { " (two views)" } else { "" },
                b.fitted.status,
                reversed(&b)
            );
            views += usize::from(from_views);
            if b.fitted.status == Status::Ok {
                ok += 1;
                assert!(!reversed(&b), "seed {seed} frame {n}: ok but reversed");
                assert!(rms <= 0.15, "seed {seed} frame {n}: ok with rms {rms:.3}");
            }
        }
        println!("seed {seed}: {ok} of 20 ok, {views} from the two views");
        // Measured: 16, 17 and 18 of 20 ok (11, 15 and 15 started from the two views), none
        // reversed, rms ≤ 0.057 mm; before the two-view start read the band, 5, 2 and 4 (every
        // two-view start `ambiguous`, its guess reversed). The rest: a tip or proximal end
        // seen end-on by one camera, a hull ghost the two views did not resolve, or a fit
        // that does not explain a camera.
        assert!(ok >= 15, "seed {seed}: only {ok} of 20 ok");
    }
}
