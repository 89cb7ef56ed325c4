//! Two cameras: the visual hull grows ghost branches that both silhouettes allow (and often
//! falls into pieces). Every frame must be right (sub-0.15 mm, the right length, the right way
//! round) or say it is not `ok`; frames whose hull is a ghost are started again from the two
//! silhouettes matched along epipolar lines, and must then come out right.

use crate::common;

use common::*;
use flexshape_curve::Polyline;
use flexshape_shape::Status;
use flexshape_sim::{CatheterPose, SimConfig, SimRigConfig, Simulator};
use nalgebra::Point3;

/// What a sweep of two-camera frames gave; every `ok` frame is checked against the truth.
struct Tally {
    ok: usize,
    /// Frames whose hull is a ghost (rms > 1 mm) made `ok` by the two-view start.
    ghosts_resolved: usize,
    /// Frames whose hull is a ghost that are not `ok`.
    ghosts_caught: usize,
    /// Reasons of the `ambiguous` and `inconsistent` frames.
    reasons: Vec<String>,
}

/// The simulated two-camera sweep of `seed`, `frames` long, through the chain.
fn sweep(seed: u64, frames: usize) -> Tally {
    tally(seed, |sim| sim.sweep(frames))
}

/// The poses `poses` gives of the simulated two-camera rig of `seed`, through the chain.
fn tally(seed: u64, poses: impl Fn(&Simulator) -> Vec<CatheterPose>) -> Tally {
    tally_from(seed, 0, poses)
}

/// As [`tally`], the frames numbered (their noise drawn) from `first` on, as a recording's.
fn tally_from(seed: u64, first: usize, poses: impl Fn(&Simulator) -> Vec<CatheterPose>) -> Tally {
    let config = SimConfig {
        rig: SimRigConfig {
            cameras: 2,
            ..SimRigConfig::default()
        },
        seed,
        ..SimConfig::default()
    };
    let chain = Chain::new(config);
    let sim = &chain.sim;
    let (mut ok, mut ghosts_resolved, mut ghosts_caught) = (0, 0, 0);
    let mut reasons = Vec::new();
    for (n, pose) in poses(sim).iter().enumerate() {
        let n = first + n;
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
    Tally {
        ok,
        ghosts_resolved,
        ghosts_caught,
        reasons,
    }
}

#[test]
fn two_cameras_never_report_a_ghost_as_ok() {
    let t = sweep(SimConfig::default().seed, 20);
    // Measured: 16 of 20 ok (rms ≤ 0.045 mm, tips ≤ 0.11 mm, lengths within 0.2 mm), 11 of them
    // frames whose hull is a ghost or in pieces (rms > 1 mm), started from the two views (the
    // start from the hull alone gave 5 ok; 12 before spans seen from one side were held, see
    // `two_cameras_hold_a_stretch_along_their_epipolar_plane`). The rest are `ambiguous` (the
    // two views leave the centerline loose: 1-σ across the tube above 0.15 mm, or a tip seen
    // end-on) or `inconsistent` (a tip the fit did not reach). The check of the outline's 90th
    // percentile, which fired here too before, is shown in `selfcheck.rs`.
    println!(
        "{} ok, {} ghosts resolved, {} caught",
        t.ok, t.ghosts_resolved, t.ghosts_caught
    );
    assert!(t.ok >= 14, "only {} frames ok", t.ok);
    assert!(
        t.ghosts_resolved >= 9,
        "only {} ghost frames resolved",
        t.ghosts_resolved
    );
    assert!(
        t.ghosts_caught >= 1,
        "no ghost frame left unresolved: the test says less"
    );
    for kind in ["pin the centerline", "free end"] {
        assert!(
            t.reasons.iter().any(|r| r.contains(kind)),
            "no frame flagged for '{kind}': {:#?}",
            t.reasons
        );
    }
}

/// A sweep the start was not tuned on: every `ok` frame right (checked in `sweep`).
#[test]
fn two_cameras_on_another_seed_report_no_wrong_shape_as_ok() {
    let t = sweep(3, 20);
    // Measured: 18 ok, 14 of them ghost frames resolved (10 and 5 before spans seen from one
    // side were held).
    println!("{} ok, {} ghosts resolved", t.ok, t.ghosts_resolved);
    assert!(t.ok >= 7, "only {} frames ok", t.ok);
}

/// A motion whose first frames point the tip within 8–14° of one camera's line of sight:
/// that camera sees the tip end-on, so where it lies along the other camera's rays is not
/// seen. Frames 3 and 7 were `ok` with the tip 1.25 and 0.61 mm off across the tube (every
/// outline explained, 1-σ at the tip 0.06 and 0.10 mm); every `ok` frame must be right
/// (checked in `tally`), and those say the tip is not seen.
#[test]
fn two_cameras_do_not_report_a_tip_one_of_them_sees_end_on_as_ok() {
    let t = tally(2, |sim| sim.motion(12, 120.0));
    // Measured: all 12 frames flagged for it (5–11°; 1-σ 0.07–0.15 mm, frame 10's tip 4.2 mm
    // off). With a σ limit of 0.1 mm, 8 of them had been said to be loose first.
    let end_on = t
        .reasons
        .iter()
        .filter(|r| r.contains("points along camera"))
        .count();
    assert!(end_on >= 2, "{end_on} frames flagged for a tip seen end-on");
}

/// A motion whose tip folds over the shaft in one camera's view (frames 60–75 of seed 5): that
/// camera finds little or nothing of the tip's rounded outline, so again only the other one
/// sees the tip. From their hulls, frames 65–74 were `ok` with the tip up to 1.1 mm off along
/// the other camera's rays (every outline explained, 1-σ at the tip 0.04–0.06 mm); every `ok`
/// frame must be right (checked in `tally`), and those say the tip is hidden.
#[test]
fn two_cameras_do_not_report_a_tip_one_of_them_cannot_see_as_ok() {
    let t = tally(5, |sim| sim.motion(76, 120.0)[60..].to_vec());
    let hidden = t
        .reasons
        .iter()
        .filter(|r| r.contains("rounded outline"))
        .count();
    // Measured: 11 of the 16 frames flagged for it (0–2 samples found).
    assert!(
        hidden >= 6,
        "{hidden} frames flagged for a tip the tube hides"
    );
}

/// A motion whose tube lies along the two cameras' epipolar plane over a stretch: both
/// outlines hold it across that plane and neither within it. Fitted from their hulls, frames
/// 15–19 of seed 12 came out 0.46–0.49 mm RMS off (a wiggle in that plane; 1-σ 0.09–0.10 mm),
/// each explaining both images, and frame 17 `ok`. Held from bending where the cameras see it
/// from one side, the same frames are within 0.05 mm; every `ok` frame is right (checked in
/// `tally`).
#[test]
fn two_cameras_hold_a_stretch_along_their_epipolar_plane() {
    let t = tally_from(12, 15, |sim| sim.motion(20, 120.0)[15..].to_vec());
    // Measured: frames 17 and 19 ok (rms 0.043–0.045 mm); frames 15 and 16 show a ghost in
    // the hull (10 and 6 mm of tube), frame 18 misses half its tip's outline in one camera.
    println!("{} of 5 ok", t.ok);
    assert!(t.ok >= 2, "{} of 5 ok", t.ok);
}
