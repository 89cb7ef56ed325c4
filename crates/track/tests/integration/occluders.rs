//! Fixtures in front of the volume: spheres between each camera and the tube hide a stretch of
//! it, or its tip, from that camera. Undeclared, the camera's silhouette carves the hidden
//! stretch away; declared in the rig as the camera's occlusion mask (`occluded`, what
//! `flexshape simulate --occluders` writes), the camera neither carves there nor counts its
//! outline there. Every frame the chain calls `ok` must be right either way.

use crate::common;

use flexshape_camera::{Camera, Pose};
use flexshape_recording::RightBounds;
use flexshape_sim::{RenderSettings, SimConfig, Simulator};
use flexshape_track::Pipeline;
use nalgebra::{Rotation3, Vector3};

/// Three occluders, one before each camera (`flexshape simulate --occluders 3 --seed 1`).
fn occluded_rig() -> (Simulator, Pipeline) {
    let defaults = SimConfig::default();
    common::chain_of(SimConfig {
        occluders: 3,
        seed: 1,
        render: RenderSettings {
            seed: 1,
            ..defaults.render
        },
        ..defaults
    })
}

/// The same chain without the rig's occlusion masks.
fn undeclared(sim: &Simulator) -> Pipeline {
    let mut rig = sim.rig().clone();
    for c in &mut rig.cameras {
        c.occluded = None;
    }
    let backgrounds = flexshape_silhouette::BackgroundModel::each(&sim.backgrounds()).unwrap();
    Pipeline::new(&rig, &backgrounds, &rig.volume).unwrap()
}

/// The `ok` frames of ten of the sweep's poses through `pipeline`, each checked against the
/// truth (within the right bounds: 0.15 mm RMS, tip 0.3 mm).
fn ok_and_right(sim: &Simulator, pipeline: &Pipeline) -> usize {
    let mut ok = 0;
    for (i, pose) in sim.sweep(10).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let record = t.record(i as u64);
        println!("frame {i}: {} {:?}", record.status, record.reason);
        if record.status == "ok" {
            ok += 1;
            let e = common::errors(&frame.truth, sim, &t.shape).unwrap();
            println!("  {:.3} mm RMS, tip {:.2} mm", e.centerline_rms, e.tip);
            assert!(e.within(RightBounds::default()), "frame {i}: {e:?}");
        }
    }
    ok
}

#[test]
fn a_declared_occluder_neither_carves_the_tube_away_nor_counts_against_it() {
    let (sim, pipeline) = occluded_rig();
    assert!(sim.rig().cameras.iter().all(|c| c.occluded.is_some()));
    let declared = ok_and_right(&sim, &pipeline);
    let plain = ok_and_right(&sim, &undeclared(&sim));
    println!("{declared} of 10 ok with the occlusion masks, {plain} without");
    // Measured: 8 and 4 (without: the hull cut in two, a free end "found at 0 of 13").
    assert!(declared >= 8 && plain <= 5, "{declared} / {plain}");
}

#[test]
fn a_declared_occluder_does_not_excuse_a_camera_that_is_off() {
    // cam2 turned and shifted by a pixel or two: what it does see of the tube is off, and
    // the masks hide only the occluders.
    let (sim, pipeline) = occluded_rig();
    let mut cameras = pipeline.cameras().to_vec();
    let c = &cameras[2];
    let turn = Rotation3::from_scaled_axis(Vector3::new(0.0015, -0.002, 0.001));
    cameras[2] = Camera::new(
        c.intrinsics.clone(),
        Pose {
            rotation: turn * c.pose.rotation,
            translation: turn * c.pose.translation + Vector3::new(0.5, -0.3, 0.8),
        },
    );
    let knocked = pipeline.with_cameras(cameras).unwrap();
    let ok = ok_and_right(&sim, &knocked);
    println!("{ok} of 10 ok with cam2 knocked");
    // Measured: 0 (`inconsistent`, most for cam0 or cam2's outline as a whole).
    assert!(ok <= 1, "{ok}");
}

#[test]
fn a_camera_masked_whole_says_nothing_and_the_others_are_judged_alone() {
    // cam0's mask covers its whole image: it neither carves nor counts, and its silhouette
    // (the tube, in plain view) is not held against the fit either (it was: IoU 0 with a
    // tube whose every pixel is hidden). Two cameras are left; every `ok` must be right.
    let (sim, _) = occluded_rig();
    let mut rig = sim.rig().clone();
    let o = rig.cameras[0].occluded.as_mut().unwrap();
    o.mask.pixels_mut().for_each(|p| p.0 = [255]);
    let backgrounds = flexshape_silhouette::BackgroundModel::each(&sim.backgrounds()).unwrap();
    let pipeline = Pipeline::new(&rig, &backgrounds, &rig.volume).unwrap();
    for (i, pose) in sim.sweep(6).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let record = t.record(i as u64);
        let reason = record.reason.clone().unwrap_or_default();
        println!("frame {i}: {} {reason}", record.status);
        assert!(!reason.contains("camera cam0"), "frame {i}: {reason}");
        if record.status == "ok" {
            let e = common::errors(&frame.truth, &sim, &t.shape).unwrap();
            assert!(e.within(RightBounds::default()), "frame {i}: {e:?}");
        }
    }
}

/// Frame 1 of the three occluders: camera 2's occluder hides the tip, and camera 1 sees its
/// cap folded over the shaft, so only camera 0 sees where the tip is. The frame says so, and
/// says why camera 2 does not see it: none of the cap is measured there (before, "finds 0
/// samples … the tube hides it", which blamed the tube for the fixture).
#[test]
fn a_tip_an_occluder_hides_is_said_to_be_hidden_by_it() {
    let (sim, pipeline) = occluded_rig();
    let pose = &sim.sweep(10)[1];
    let frame = sim.render(1, pose).unwrap();
    let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
    let t = pipeline.process(&images).unwrap();
    let record = t.record(1);
    let reason = record.reason.unwrap_or_default();
    println!("{}: {reason}", record.status);
    assert_eq!(record.status, "ambiguous");
    assert!(
        reason.contains(
            "camera cam2 measures none of the tip's rounded outline (its occlusion mask hides it"
        ),
        "{reason}"
    );
}
