//! Shadows sharp enough to carve: a small lamp near the camera throws the tube's shadow onto
//! a backdrop close behind the volume, with an edge as crisp as the tube's own. The colour
//! classifier keeps such a shadow (it cannot tell it from a grey object by its edge), so the
//! hull holds voxels that one camera sees as shadow and another as the tube — a second object,
//! a branch, a ghost beside the fitted shape. Every frame the chain calls `ok` must be right;
//! a real second object is still refused.

use crate::common;

use flexshape_recording::RightBounds;
use flexshape_sim::{RenderSettings, SimConfig};

/// The sharp-shadow scene: lamp radius 3 mm, the backdrops 160 mm behind the volume's
/// centre.
fn sharp_lamp(seed: u64) -> SimConfig {
    let defaults = SimConfig::default();
    SimConfig {
        render: RenderSettings {
            shadows: true,
            backdrop_depth: 760.0,
            lamp_radius: 3.0,
            ..defaults.render
        },
        seed,
        ..defaults
    }
}

/// `ok` frames, right-but-refused frames and frames whose hull dropped shadow voxels, of
/// `frames` poses of the sweep through the whole chain; asserts every `ok` frame right.
fn sweep(config: SimConfig, frames: usize) -> (usize, usize, usize) {
    let (sim, pipeline) = common::chain_of(config);
    let (mut ok, mut refused, mut dropped) = (0, 0, 0);
    for (i, pose) in sim.sweep(frames).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let record = t.record(i as u64);
        let right = common::errors(&frame.truth, &sim, &t.shape)
            .filter(|e| e.within(RightBounds::default()));
        dropped += usize::from(record.shadow_voxels > 0);
        println!(
            "frame {i}: {} {:?} shadow voxels {} errors {:?}",
            record.status, record.reason, record.shadow_voxels, right
        );
        if record.status == "ok" {
            ok += 1;
            assert!(right.is_some(), "frame {i}: ok but off the truth");
        } else {
            refused += usize::from(right.is_some());
        }
    }
    (ok, refused, dropped)
}

#[test]
fn a_shadow_that_carves_is_dropped_from_the_hull() {
    let (mut ok, mut refused, mut dropped) = (0, 0, 0);
    for seed in [1, 2, 3] {
        let (o, r, d) = sweep(sharp_lamp(seed), 12);
        println!("seed {seed}: {o} of 12 ok, {r} right but refused, {d} dropped shadow voxels");
        (ok, refused, dropped) = (ok + o, refused + r, dropped + d);
    }
    // Measured: 27 of 36 ok (9 / 7 / 11), every one right, 19 of them from a hull without
    // its shadow voxels; before, 7 of 36 (12 right but refused: a second object, a branch or
    // a ghost beside the fitted shape, each of the shadow; a shadow beside the tube meeting
    // the tip's zone taken for a missed distal part; a shadow along the outline read as
    // partly covered, the boundary moved out). Now 3 right but refused (130–134 silhouette
    // pixels beyond the tube, the outline's 90th percentile).
    assert!(ok >= 24 && dropped >= 15, "{ok} ok, {dropped} dropped");
    assert!(refused <= 5, "{refused} right but refused");
}

/// The same scene with two cameras 90° apart, whose hull holds ghosts of its own and where
/// the shape comes from the two views' image centerlines: every `ok` right.
#[test]
fn two_cameras_take_no_shadow_for_the_tube() {
    let (mut ok, mut refused, mut dropped) = (0, 0, 0);
    for seed in [1, 2, 3] {
        let mut config = sharp_lamp(seed);
        config.rig.cameras = 2;
        let (o, r, d) = sweep(config, 12);
        println!("two cameras, seed {seed}: {o} of 12 ok, {r} right but refused, {d} dropped");
        (ok, refused, dropped) = (ok + o, refused + r, dropped + d);
    }
    println!("two cameras: {ok} of 36 ok, {refused} right but refused, {dropped} dropped");
    // Measured: 28 of 36 (9 / 8 / 11), every one right, 1 right but refused; 7 of 36 before
    // the two views' start was tried without the shadow-coloured pixels (the image
    // centerline ran into the shadow; the hull's cross-sections fall apart with two cameras).
    assert!(
        ok >= 25 && refused <= 3,
        "{ok} ok, {refused} right but refused"
    );
}

/// A second catheter beside the first, its base 45 mm along x, in the same sharp-shadow scene
/// (its pixels pasted into the first one's frames): of the tube's colour, or of the backdrop's
/// colour, darker — a thing a shadow looks like. Neither is a shadow to drop: no frame is
/// `ok`. (Where the hull drops such a thing's voxels, its pixels of its own colour are left
/// unexplained by the fitted tube.)
#[test]
fn a_second_instrument_is_no_shadow() {
    let config = sharp_lamp(1);
    let (sim, pipeline) = common::chain_of(config.clone());
    let backdrop = config.render.backdrop_albedo;
    // The backdrop's colour at 50–80 % of its brightness: in part darker than any shadow
    // (the classifier's own colour), in part shadow-coloured, differently in each camera.
    let shadowy = [0.5, 0.65, 0.8].map(|k| backdrop.map(|c| k * c));
    for albedo in std::iter::once(config.catheter.albedo).chain(shadowy) {
        let mut other = config.clone();
        other.catheter.albedo = albedo;
        other.catheter.base.position.x += 45.0;
        let other = flexshape_sim::Simulator::new(other).unwrap();
        let poses = sim.sweep(6);
        for (i, pose) in poses.iter().enumerate() {
            let mut frame = sim.render(i as u64, pose).unwrap();
            let second = other.render(i as u64, &poses[(i + 3) % 6]).unwrap();
            for (view, add) in frame.views.iter_mut().zip(&second.views) {
                for (x, y, m) in add.mask.enumerate_pixels() {
                    if m.0[0] > 0 {
                        view.image.put_pixel(x, y, *add.image.get_pixel(x, y));
                    }
                }
            }
            let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
            let t = pipeline.process(&images).unwrap();
            let record = t.record(i as u64);
            println!(
                "albedo {albedo:?} frame {i}: {} {:?}, shadow voxels {}",
                record.status, record.reason, record.shadow_voxels
            );
            assert_ne!(record.status, "ok", "albedo {albedo:?} frame {i}");
        }
    }
}
