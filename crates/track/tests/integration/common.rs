//! Shared by the track crate's tests.
#![allow(dead_code)] // each test binary uses its own part

use flexshape_curve::Polyline;
use flexshape_recording::Truth;
use flexshape_shape::ShapeRecord;
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{RenderSettings, SimConfig, Simulator};
use flexshape_track::Pipeline;
use nalgebra::Point3;

/// The default simulated rig and the sensing chain set up for it.
pub fn simulated_chain() -> (Simulator, Pipeline) {
    chain_of(SimConfig::default())
}

/// The simulated rig of `config` and the chain set up for it.
pub fn chain_of(config: SimConfig) -> (Simulator, Pipeline) {
    let sim = Simulator::new(config).unwrap();
    let backgrounds: Vec<_> = BackgroundModel::each(&sim.backgrounds()).unwrap();
    let rig = sim.rig();
    let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume).unwrap();
    (sim, pipeline)
}

/// RMS distance from the true centerline (inside the volume) to the record's, mm.
pub fn rms(truth: &Truth, sim: &Simulator, r: &ShapeRecord) -> f64 {
    let poly = Polyline::new(r.points.iter().map(|&p| Point3::from(p)).collect()).unwrap();
    let d2: Vec<f64> = truth
        .centerline
        .iter()
        .map(|&p| Point3::from(p))
        .filter(|p| sim.rig().volume.contains(p))
        .map(|p| poly.closest(&p).1.powi(2))
        .collect();
    (d2.iter().sum::<f64>() / d2.len() as f64).sqrt()
}

/// Distance between the record's tip and the true one, mm.
pub fn tip_error(truth: &Truth, r: &ShapeRecord) -> f64 {
    (Point3::from(r.tip) - Point3::from(truth.tip)).norm()
}

/// Cloth whose folds (valleys losing 30 % of the light, 70 mm apart) slid `shift` mm between
/// the background capture and the run: where the old valleys were, the backdrop is brighter
/// than the background, which the classifier takes for foreground along the old folds.
pub fn folds_moved(shift: f64) -> SimConfig {
    let defaults = SimConfig::default();
    SimConfig {
        render: RenderSettings {
            fold_depth: 0.3,
            fold_shift_mm: shift,
            ..defaults.render
        },
        ..defaults
    }
}
