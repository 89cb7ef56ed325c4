//! Shared by the track crate's tests.
#![allow(dead_code)] // each test binary uses its own part

use flexshape_recording::{Truth, TruthErrors};
use flexshape_shape::ShapeRecord;
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{RenderSettings, SimConfig, Simulator};
use flexshape_track::Pipeline;

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

/// The record's shape against the frame's truth (inside the volume); `None` without a shape.
pub fn errors(truth: &Truth, sim: &Simulator, r: &ShapeRecord) -> Option<TruthErrors> {
    truth.errors(&r.points, r.tip, |p| sim.rig().volume.contains(p))
}

/// The record's centerline RMS distance from the truth inside the volume, mm (infinite
/// without a shape).
pub fn rms(truth: &Truth, sim: &Simulator, r: &ShapeRecord) -> f64 {
    errors(truth, sim, r).map_or(f64::INFINITY, |e| e.centerline_rms)
}

/// Distance between the record's tip and the true one, mm.
pub fn tip_error(truth: &Truth, r: &ShapeRecord) -> f64 {
    truth.tip_off(r.tip)
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
