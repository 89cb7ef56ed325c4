//! The image fit against the simulator's truth, end to end: rendered frames → silhouettes →
//! carving → hull shape → tube fitted to the outlines. Default scene (3 cameras, 640×480 with
//! lens distortion, noise σ = 2, r = 3 mm), 20 frames over the workspace, fixed seed.

use crate::common;

use common::*;
use flexshape_shape::Status;
use flexshape_sim::SimConfig;

#[test]
fn default_scene_fit_beats_the_hull() {
    let chain = Chain::new(SimConfig::default());
    let sim = &chain.sim;
    let (mut rms, mut hull_rms, mut tips, mut bands, mut kappa, mut strain) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for (n, pose) in sim.sweep(20).iter().enumerate() {
        let frame = sim.render(n as u64, pose).unwrap();
        let b = chain.run(frame);
        let truth = &b.frame.truth;
        let fit = b.fit.as_ref().unwrap();
        let e = centerline_rms(truth, sim, &b.fitted.points);
        let eh = centerline_rms(truth, sim, &b.hull.points);
        println!(
            "frame {n:2}: rms {e:.3} (hull {eh:.3}) mm, tip {:.3} (hull {:.3}), band {:.3} (hull {:.3}), κ {:?} (hull {:?}), r {:.3}, it {}, σ {:.3} px, ghost {:.1} mm, cams {:?}, status {:?}",
            tip_error(truth, &b.fitted),
            tip_error(truth, &b.hull),
            band_error(truth, sim, &b.fitted),
            band_error(truth, sim, &b.hull),
            curvature_error(truth, &b.fitted).map(|k| format!("{:.3} %", 100.0 * k)),
            curvature_error(truth, &b.hull).map(|k| format!("{:.3} %", 100.0 * k)),
            fit.tube.radius,
            fit.iterations,
            fit.sigma_px,
            fit.ghost_mm.unwrap_or(f64::NAN),
            fit.cameras
                .iter()
                .map(|c| format!(
                    "{}/{} {:.3}px p90 {:.3} {:+.3} iou {:.3} un {}",
                    c.found,
                    c.samples,
                    c.residual_px,
                    c.p90_px,
                    c.offset_px,
                    c.iou,
                    c.unexplained_px
                ))
                .collect::<Vec<_>>(),
            b.fitted.status,
        );
        assert_eq!(b.fitted.status, Status::Ok, "frame {n}");
        if let (Some(c), Some(eps)) = (b.fitted.compression.first(), truth.eps) {
            strain.push(c.strain - eps[1]);
        }
        rms.push(e);
        hull_rms.push(eh);
        tips.push(tip_error(truth, &b.fitted));
        bands.push(band_error(truth, sim, &b.fitted));
        if let Some(k) = curvature_error(truth, &b.fitted) {
            kappa.push(k);
        }
    }
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let strain_bias = strain.iter().sum::<f64>() / strain.len() as f64;
    println!(
        "bending-section strain: bias {strain_bias:+.5}, worst {:.5} over {}",
        strain.iter().map(|s| s.abs()).fold(0.0, f64::max),
        strain.len()
    );
    let bias = kappa.iter().sum::<f64>() / kappa.len() as f64;
    println!(
        "centerline rms median {:.3} worst {:.3} mm (hull median {:.3} worst {:.3}); tip worst {:.3} mm; band worst {:.3} mm; curvature bias {:+.3} % worst {:.3} % over {}",
        median(&rms),
        worst(&rms),
        median(&hull_rms),
        worst(&hull_rms),
        worst(&tips),
        worst(&bands),
        bias * 100.0,
        kappa.iter().map(|k| k.abs()).fold(0.0, f64::max) * 100.0,
        kappa.len()
    );
    // Measured: median 0.030, worst 0.035 mm (hull 0.138 / 0.202); tip worst 0.10 mm; band
    // centres worst 0.14 mm, most below 0.07 (hull 0.45); curvature bias +0.021 %, worst
    // 0.098 % (the issue asks ≤ 0.08 / 0.12 mm, tip ≤ 0.3 mm, bands ≤ 0.2 mm, bias ≤ 0.1 %).
    assert!(median(&rms) <= 0.05, "median {:.3}", median(&rms));
    assert!(worst(&rms) <= 0.08, "worst {:.3}", worst(&rms));
    assert!(median(&rms) * 2.5 < median(&hull_rms));
    assert!(worst(&tips) <= 0.2, "tip {:.3}", worst(&tips));
    assert!(worst(&bands) <= 0.2, "band {:.3}", worst(&bands));
    assert!(bias.abs() <= 0.001, "curvature bias {:.3} %", bias * 100.0);
    assert!(kappa.iter().all(|k| k.abs() <= 0.005), "{kappa:?}");
    assert!(kappa.len() >= 10);
}

/// The sweep's seventh pose points the tip band at one camera at about 30° to its ray: that
/// camera's edge, averaged with the side-on cameras' on equal terms, put the band 0.19 mm off
/// along the tube (seed 3; 0.09–0.10 mm on seeds 1 and 4) where the others agreed within
/// 0.05 mm. Weighted by how side-on each camera sees the tube, the band is where they put it.
#[test]
fn a_band_seen_obliquely_by_one_camera_is_placed_by_the_side_on_ones() {
    for seed in [1, 3, 4] {
        let chain = Chain::new(SimConfig {
            seed,
            ..SimConfig::default()
        });
        let sim = &chain.sim;
        let pose = &sim.sweep(10)[6];
        let b = chain.run(sim.render(6, pose).unwrap());
        assert_eq!(b.fitted.status, Status::Ok);
        let e = band_error(&b.frame.truth, sim, &b.fitted);
        println!("seed {seed}: band worst {e:.3} mm");
        // Measured: 0.065–0.087 mm (0.091–0.192 before).
        assert!(e < 0.1, "seed {seed}: a band {e:.3} mm off");
    }
}
