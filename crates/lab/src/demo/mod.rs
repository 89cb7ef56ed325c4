//! The demo on the simulated rig (`flexshape demo`): the tendon-driven model sweeps the
//! simulated catheter through its workspace (the bending plane turning while the bend swings
//! from straight to the maximum), the simulated cameras film it, and every frame, tracked by
//! the same chain as `flexshape track`, is measured against the simulator's ground truth.
//!
//! ```no_run
//! use std::ops::ControlFlow;
//! use std::sync::atomic::AtomicBool;
//! use flexshape_lab::demo::{Demo, DemoFigures};
//! use flexshape_model::{ManipulatorParams, Model};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = Model::new(ManipulatorParams::paper_like())?;
//! let demo = Demo::new(flexshape_sim::SimConfig::default(), model, None, 2)?;
//! let mut source = demo.on_demand(Some(20), 30.0);
//! let mut figures = DemoFigures::default();
//! flexshape_track::run(&mut source, &demo.pipeline, 1, &AtomicBool::new(false), |p| {
//!     if let Some(e) = demo.errors(&p) {
//!         figures.add(&e);
//!     }
//!     ControlFlow::Continue(())
//! });
//! println!("centerline rms median {:.3} mm", DemoFigures::median(&figures.rms));
//! # Ok(())
//! # }
//! ```

mod errors;
mod report;
mod rig;

use std::path::Path;
use std::sync::Arc;

use flexshape_input::NewestSource;
use flexshape_model::{Model, Sweep};
use flexshape_record::{ModelFrame, TrackRecord};
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::{Pipeline, Processed};

pub use errors::{DemoFigures, ShapeErrors};
pub use flexshape_recording::RightBounds;
pub use report::table_header;
pub use rig::{DemoRig, OnDemand};

use crate::LabError;

/// The simulated rig filming the model-driven catheter, and the chain that tracks it.
pub struct Demo {
    /// The rig (simulator, model, sweep).
    pub rig: Arc<DemoRig>,
    /// The sensing chain, with the simulated backgrounds.
    pub pipeline: Pipeline,
    /// The model's frame in the world: the simulator built the catheter in it, so records
    /// carry κx, κz as a registered rig's do.
    pub model_frame: ModelFrame,
}

impl Demo {
    /// Sets up the rig of `config` with its catheter made as `model` describes it (lengths,
    /// radius), each camera's background modelled from its rendered empty scene, and the
    /// chain; with `out`, every rendered frame (with its command and truth) is also written
    /// there as a recording. Rendering runs on `render_threads` threads of its own.
    pub fn new(
        mut config: SimConfig,
        model: Model,
        out: Option<&Path>,
        render_threads: usize,
    ) -> Result<Self, LabError> {
        let setup = |step: &str| {
            let step = step.to_string();
            move |e: &dyn std::fmt::Display| {
                LabError::data("the simulated rig", format!("{step}: {e}"))
            }
        };
        config.catheter = flexshape_steer::catheter_for(&config.catheter, model.params());
        let sim = Simulator::new(config).map_err(|e| setup("cannot set it up")(&e))?;
        let backgrounds = BackgroundModel::each(&sim.backgrounds())
            .map_err(|e| setup("cannot model its backgrounds")(&e))?;
        // The simulated rig's `[processing.shape]` describes its catheter (bands, sections).
        let pipeline = Pipeline::new(sim.rig(), &backgrounds, &sim.rig().volume)?;
        let writer = match out {
            Some(dir) => Some(
                sim.create_recording(dir, false)
                    .map_err(|e| LabError::Write {
                        path: dir.to_path_buf(),
                        reason: e.to_string(),
                    })?,
            ),
            None => None,
        };
        let m = sim.config().catheter.base.rotation.into_inner();
        let model_frame = ModelFrame {
            rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
            reference_base: None,
            residual_deg: [0.0, 0.0],
        };
        let rig = DemoRig::new(sim, model, Sweep::default(), writer, render_threads)
            .map_err(|e| setup("cannot start the simulator's threads")(&e))?;
        Ok(Demo {
            rig: Arc::new(rig),
            pipeline,
            model_frame,
        })
    }

    /// The simulator.
    pub fn simulator(&self) -> &Simulator {
        &self.rig.sim
    }

    /// Frames rendered when tracking asks for them (`frames` of them, or without end), the
    /// command of frame `n` the sweep's at `n / fps` seconds.
    pub fn on_demand(&self, frames: Option<u64>, fps: f64) -> OnDemand {
        OnDemand::new(self.rig.clone(), frames, fps)
    }

    /// The first `frames` frames of the sweep tracked on one thread, each with its record:
    /// material for what consumes tracked frames (outputs, live carriers) and its tests.
    pub fn tracked(&self, frames: u64) -> Vec<(TrackRecord, Processed)> {
        let mut tracked = Vec::new();
        let mut source = self.on_demand(Some(frames), 30.0);
        flexshape_track::run(
            &mut source,
            &self.pipeline,
            1,
            &std::sync::atomic::AtomicBool::new(false),
            |p| {
                tracked.push((p.record(), p));
                std::ops::ControlFlow::Continue(())
            },
        );
        tracked
    }

    /// Live cameras: frames rendered on their own clock at `fps`; tracking takes the newest
    /// (the rest are dropped and counted).
    pub fn live(&self, frames: Option<u64>, fps: f64) -> NewestSource {
        rig::live_source(self.rig.clone(), frames, fps)
    }

    /// A tracked frame's shape against the simulator's truth (`None` without truth or shape).
    pub fn errors(&self, p: &Processed) -> Option<ShapeErrors> {
        match (&p.truth, &p.result) {
            (Some(truth), Ok(t)) => ShapeErrors::of(&self.pipeline, truth, t),
            _ => None,
        }
    }
}
