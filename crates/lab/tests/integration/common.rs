//! Shared by the lab crate's tests.

use flexshape_recording::{Truth, TruthErrors};
use flexshape_shape::ShapeRecord;
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::Pipeline;

/// The default simulated rig and the sensing chain set up for it.
pub fn simulated_chain() -> (Simulator, Pipeline) {
    chain_of(SimConfig::default())
}

/// The simulated rig of `config` and the chain set up for it.
pub fn chain_of(config: SimConfig) -> (Simulator, Pipeline) {
    let sim = Simulator::new(config).unwrap();
    let pipeline = flexshape_lab::simulate::chain(&sim).unwrap();
    (sim, pipeline)
}

/// A shape against the frame's truth (inside the volume); `None` without a shape.
pub fn errors(truth: &Truth, sim: &Simulator, r: &ShapeRecord) -> Option<TruthErrors> {
    truth.errors(&r.points, r.tip, |p| sim.rig().volume.contains(p))
}
