//! A thin tube: 1 mm radius, 2.7 px wide in the default rig's 640×480 images, three 5 mm bands
//! and lamp shadows. The hull's voxels hardly hold a band: the bands are read from the images
//! along the fitted tube, they orient a tube that floats in the volume, and a pixel's
//! disagreement at the silhouette's edges is allowed for in the overlap check.

use crate::common;

use common::*;
use flexshape_shape::Status;
use flexshape_sim::{Catheter, RenderSettings, SimConfig};
use nalgebra::Point3;

fn config(seed: u64, floating: bool) -> SimConfig {
    let mut catheter = Catheter {
        radius: 1.0,
        extra_bands: vec![80.0],
        ..Catheter::default()
    };
    if floating {
        catheter.base.position = Point3::new(0.0, 0.0, -115.0);
        catheter.proximal_length = 20.0;
    }
    SimConfig {
        catheter,
        render: RenderSettings {
            shadows: true,
            ..RenderSettings::default()
        },
        seed,
        ..SimConfig::default()
    }
}

/// What a sweep of 12 frames gave: `ok` frames, and `ok` frames that are wrong (rms > 0.1 mm,
/// tip > 0.3 mm, a band > 0.3 mm off, or reversed).
fn sweep(chain: &Chain, label: &str) -> (usize, usize) {
    let sim = &chain.sim;
    let (mut ok, mut wrong) = (0, 0);
    for (n, pose) in sim.sweep(12).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        let band = band_error(&b.frame.truth, sim, &b.fitted);
        let truth_tip = Point3::from(b.frame.truth.tip);
        let reversed = b
            .fitted
            .points
            .first()
            .is_some_and(|p| (Point3::from(*p) - truth_tip).norm() < 20.0);
        println!(
            "{label} frame {n:2}: {:?}, rms {rms:.3} mm, tip {tip:.2}, band {band:.2}, hull bands {}",
            b.fitted.status,
            b.hull.bands.len()
        );
        if b.fitted.status == Status::Ok {
            ok += 1;
            if rms > 0.1 || tip > 0.3 || band > 0.3 || reversed {
                wrong += 1;
            }
        }
    }
    println!("{label}: {ok} of 12 ok, {wrong} of them wrong");
    (ok, wrong)
}

#[test]
fn a_thin_tube_is_measured_with_its_bands_and_its_direction() {
    for floating in [false, true] {
        for seed in [1, 2, 3] {
            let label = format!("floating {floating} seed {seed}");
            let (ok, wrong) = sweep(&Chain::new(config(seed, floating)), &label);
            // Measured: 11, 12, 12 of 12 ok with the base entering the volume, 12, 12, 11
            // floating (rms ≤ 0.04 mm, tips ≤ 0.21 mm, bands ≤ 0.15 mm). Before the bands were
            // counted on the fitted curve and the overlap allowed for the tube's width: 0, 0,
            // 0 and 7, 8, 7 (`bands_missing` with every band found, IoU 0.64–0.74 against
            // 0.75); before shadow-coloured pixels away from the tube were left out of the
            // overlap check, 11, 11, 12 and 11, 12, 10 (a thin shadow beside the tube: 103–268
            // pixels unexplained). The rest: a shadow carved as a second object, a band not
            // seen.
            assert!(ok >= 10, "{label}: only {ok} of 12 ok");
            assert_eq!(wrong, 0, "{label}: {wrong} ok frames wrong");
        }
    }
}

/// The same thin tube with one camera's pose turned by 0.2° (about 2 px at the tube): the
/// overlap check allows a thin tube more, and the outline checks must still refuse it.
#[test]
fn a_thin_tube_seen_by_a_miscalibrated_camera_is_not_ok() {
    let chain = Chain::with_camera_turned(config(1, false), 1, 0.2);
    let (ok, wrong) = sweep(&chain, "miscalibrated");
    assert_eq!(wrong, 0, "{wrong} ok frames wrong");
    assert!(ok <= 1, "{ok} of 12 ok with a camera 0.2° off");
}
