//! Backdrops we did not choose: a light grey tube over white paper, under a lamp that casts
//! its soft shadow on the paper. The tube darkens the paper without changing its
//! chromaticity, as its shadow does; the colour classifier tells them apart by the tube's
//! sharp outline. Every frame the chain calls `ok` must be right.

mod common;

use flexshape_sim::{Catheter, RenderSettings, SimConfig};
use flexshape_track::{Pipeline, TrackRecord};

/// The grey-tube scene: body reflectance 0.5 (grey), paper 0.9, shadows.
fn grey_on_white() -> SimConfig {
    let defaults = SimConfig::default();
    SimConfig {
        render: RenderSettings {
            shadows: true,
            backdrop_albedo: [0.9, 0.9, 0.9],
            ..defaults.render
        },
        catheter: Catheter {
            albedo: [0.5, 0.5, 0.5],
            ..defaults.catheter
        },
        ..defaults
    }
}

#[test]
fn a_grey_tube_on_white_paper_is_not_a_shadow() {
    let (sim, pipeline) = common::chain_of(grey_on_white());
    // The same chain without the outline test: shadow-like regions never count.
    let mut rig = sim.rig().clone();
    rig.processing.insert(
        "silhouette".into(),
        toml::toml! { classifier = { kind = "colour_shadow", edge = 0.0 } }.into(),
    );
    let backgrounds: Vec<_> = sim
        .backgrounds()
        .iter()
        .map(|b| {
            flexshape_silhouette::BackgroundModel::from_frames(std::slice::from_ref(b)).unwrap()
        })
        .collect();
    let without = Pipeline::new(&rig, &backgrounds, &rig.volume).unwrap();
    let (mut ok, mut ok_without) = (0, 0);
    for (i, pose) in sim.sweep(10).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let record = TrackRecord::from_tracked(i as u64, &t);
        if record.status == "ok" {
            ok += 1;
            let (rms, tip) = (
                common::rms(&frame.truth, &sim, &t.shape),
                common::tip_error(&frame.truth, &t.shape),
            );
            println!("frame {i}: ok, {rms:.3} mm RMS, tip {tip:.2} mm");
            assert!(rms < 0.1 && tip < 0.4, "frame {i}: {rms} mm, tip {tip} mm");
        } else {
            println!("frame {i}: {} {:?}", record.status, record.reason);
        }
        let t = without.process(&images).unwrap();
        ok_without += usize::from(TrackRecord::from_tracked(i as u64, &t).status == "ok");
    }
    println!("{ok} of 10 ok ({ok_without} without the outline test)");
    assert!(ok >= 7 && ok_without <= 1, "{ok} / {ok_without}");
}
