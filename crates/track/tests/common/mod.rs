//! Shared by the track crate's tests.

use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::Pipeline;

/// The default simulated rig and the sensing chain set up for it.
pub fn simulated_chain() -> (Simulator, Pipeline) {
    chain_of(SimConfig::default())
}

/// The simulated rig of `config` and the chain set up for it.
pub fn chain_of(config: SimConfig) -> (Simulator, Pipeline) {
    let sim = Simulator::new(config).unwrap();
    let backgrounds: Vec<_> = sim
        .backgrounds()
        .iter()
        .map(|b| BackgroundModel::from_frames(std::slice::from_ref(b)).unwrap())
        .collect();
    let rig = sim.rig();
    let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume).unwrap();
    (sim, pipeline)
}
