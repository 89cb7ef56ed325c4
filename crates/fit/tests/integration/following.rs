//! A followed fit (`TubeFitter::follow`) against the simulator's truth, started from tubes
//! that frames of tracking can leave behind.

use crate::common;

use common::*;
use flexshape_curve::Polyline;
use flexshape_fit::Tube;
use flexshape_sim::SimConfig;
use nalgebra::Point3;

/// How far `p` lies inside the rig's volume (negative outside), mm.
fn depth(chain: &Chain, p: Point3<f64>) -> f64 {
    chain.sim.rig().volume.depth(&p)
}

/// Nothing in the images ends a tube where it runs out of the volume: a followed fit held its
/// open end where the previous frame's tube, carried on, put it, and on a tube being inserted
/// that end slid 21 mm along it, into the volume; the reported base, continued straight from
/// there, then stood 0.6 mm off (seed 3, 60 frames/s, after 150 frames). A start whose open
/// end stops 11 mm inside the volume must give the base where it is, and a tube that runs on
/// out of the volume again.
#[test]
fn a_followed_start_whose_open_end_slid_into_the_volume_reports_the_base_where_it_is() {
    let chain = Chain::new(SimConfig::default());
    let sim = &chain.sim;
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let b = chain.run(frame);
    let fitted = b.fit.as_ref().unwrap().tube.clone();
    assert!(b.fitted.enters_volume && !fitted.capped[0]);
    // The fitted curve from 11 mm inside the volume to the tip, and no further.
    let points: Vec<[f64; 3]> = (0..=2000)
        .map(|i| fitted.frame(i as f64 / 2000.0).0)
        .filter(|&p| depth(&chain, p) > 11.0)
        .map(|p| [p.x, p.y, p.z])
        .collect();
    let slid = Tube::through(&points, fitted.radius, fitted.capped, 15.0, 0.0).unwrap();
    assert!(depth(&chain, slid.frame(0.0).0) > 10.0);

    let sil = chain.silhouettes(&b.frame);
    let views = chain.views(&b.frame, &sil);
    let volume = &sim.rig().volume;
    let (record, fit) = chain
        .fitter
        .follow(
            &chain.estimator,
            volume,
            &views,
            &b.fitted,
            (Some(&slid), None),
            None,
        )
        .unwrap();
    let fit = fit.unwrap();
    let truth = &b.frame.truth;
    let true_curve =
        Polyline::new(truth.centerline.iter().map(|&p| Point3::from(p)).collect()).unwrap();
    let base_off = true_curve.closest(&Point3::from(record.points[0])).1;
    let end = depth(&chain, fit.tube.frame(0.0).0);
    let rms = centerline_rms(truth, sim, &record.points);
    println!(
        "status {:?}, base {base_off:.3} mm off (from the hull {:.3}), rms {rms:.3} mm, open end {end:.1} mm inside",
        record.status,
        true_curve.closest(&Point3::from(b.fitted.points[0])).1
    );
    assert!(record.status.is_right(), "{:?}", record.status);
    assert!(base_off < 0.1, "base {base_off:.3} mm off");
    assert!(rms < 0.08, "rms {rms:.3} mm");
    // Run on out of the volume again, by about the fit's `extend_mm` (10).
    assert!((-15.0..-5.0).contains(&end), "open end {end:.1} mm inside");
}
