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
