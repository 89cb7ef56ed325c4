//! Lamp shadows other than the simulator's default: a softer lamp nearer the backdrop, whose
//! shadow falls beside the tube in the images, and a small lamp whose sharp shadow passes the
//! silhouettes' edge test for an object. Shadow-coloured silhouette pixels away from the
//! fitted tube are a shadow, not something the fit left unexplained; every `ok` stays right.

use crate::common;

use common::*;
use flexshape_shape::Status;
use flexshape_sim::{RenderSettings, SimConfig};

/// `ok` frames and right-but-refused frames (rms ≤ 0.1 mm, tip ≤ 0.3 mm) of 12, asserting
/// every `ok` frame right.
fn sweep(depth: f64, lamp_radius: f64, seed: u64) -> (usize, usize) {
    let chain = Chain::new(SimConfig {
        render: RenderSettings {
            shadows: true,
            backdrop_depth: depth,
            lamp_radius,
            ..RenderSettings::default()
        },
        seed,
        ..SimConfig::default()
    });
    let sim = &chain.sim;
    let (mut ok, mut refused) = (0, 0);
    for (n, pose) in sim.sweep(12).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        let label = format!("depth {depth} lamp {lamp_radius} seed {seed} frame {n:2}");
        if b.fitted.status == Status::Ok {
            ok += 1;
            assert!(
                rms <= 0.1 && tip <= 0.3,
                "{label}: ok, rms {rms:.3} tip {tip:.2}"
            );
        } else {
            refused += usize::from(rms <= 0.1 && tip <= 0.3);
            println!(
                "{label}: {:?}, rms {rms:.3} mm, tip {tip:.2}",
                b.fitted.status
            );
        }
    }
    println!(
        "depth {depth} lamp {lamp_radius} seed {seed}: {ok} of 12 ok, {refused} refused but right"
    );
    (ok, refused)
}

/// A soft lamp (radius 15 mm) with the backdrop 200 mm behind the volume's centre: its
/// shadow falls beside the tube in the images.
#[test]
fn a_soft_shadow_beside_the_tube_leaves_right_frames_ok() {
    let ok: Vec<usize> = [1, 2, 3].map(|seed| sweep(800.0, 15.0, seed).0).to_vec();
    // Measured: 12, 12, 12 of 12. 11, 11, 12 until a line that finds no boundary is read once
    // more asking for a shadow beside it: the soft edge of the shadow at the tip, taken into
    // the silhouette rather than marked as shade, left the free end's boundary found at 7 of
    // 13 samples. 10, 11, 12 while a shadow meeting the tip's zone counted as a missed distal
    // part.
    assert!(ok.iter().all(|&n| n >= 12), "only {ok:?} of 12 ok");
}

/// A small lamp (radius 3 mm) with the backdrop 160 mm behind the volume's centre: a shadow
/// sharp enough to pass the silhouettes' edge test for an object. Apart from the tube it is
/// dropped (a shadow-coloured part beside a coloured object) or left out of the overlap check;
/// where it touches the tube in an image it still carves a second object or a ghost, and those
/// frames are `ambiguous`, never a wrong `ok`.
#[test]
fn a_sharp_shadow_is_never_taken_for_the_tube() {
    let mut ok = 0;
    for seed in [1, 2, 3] {
        ok += sweep(760.0, 3.0, seed).0;
    }
    // Measured: 8 of 36 ok (4, 3, 1), every one right (7 before the boundaries were read
    // against the shadowed backdrop beside them); 5 while a shadow beside the tube that
    // met the tip's zone counted as a missed distal part (IoU 0.42–0.47); 0 before
    // shadow-coloured parts were told from the tube (the shadow apart from the tube failed
    // the overlap check, IoU 0.44–0.53, in every frame the hull did not already refuse). The
    // chain's retry without the shadow's voxels (track's tests) does the rest.
    assert!(ok >= 6, "only {ok} of 36 ok");
}
