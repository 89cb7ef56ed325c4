//! Setup shared by the carving tests.

use flexshape_silhouette::{BackgroundModel, SilhouetteSettings, Silhouetter};
use flexshape_sim::Simulator;

/// The default silhouette stage for each simulated camera, from its background image.
pub fn silhouetters(sim: &Simulator) -> Vec<Silhouetter> {
    sim.backgrounds()
        .iter()
        .map(|b| {
            let model = BackgroundModel::from_frames(std::slice::from_ref(b)).unwrap();
            Silhouetter::new(&model, SilhouetteSettings::default()).unwrap()
        })
        .collect()
}
