//! `flexshape simulate`: write a simulated recording with a progress bar.

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_model::{ExperimentPlan, ManipulatorParams, Role};
use flexshape_recording::PoseRole;
use flexshape_sim::{Catheter, CatheterPose, Simulator};
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::SimulateArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let mut config = super::sim_config(&args.sim);
    let experiment = match &args.model {
        None => None,
        Some(path) => {
            let model = super::model::load(path)?;
            config.catheter = catheter_for(&config.catheter, model.params());
            let plan = ExperimentPlan {
                poses: args.poses,
                ..ExperimentPlan::default()
            };
            Some(
                flexshape_model::experiment(&model, &plan)
                    .with_context(|| format!("{}: cannot plan the experiment", path.display()))?,
            )
        }
    };
    let sim = Simulator::new(config).context("cannot set up the simulated rig")?;
    let (poses, commands) = match &experiment {
        None => (sim.sweep(args.frames), Vec::new()),
        Some(e) => {
            let catheter = &sim.config().catheter;
            e.iter()
                .map(|c| {
                    let q = c.q;
                    let pose = CatheterPose::arc(catheter, [q[0], q[1]], [q[2], q[3]], 0.0);
                    let role = match c.role {
                        Role::Reference => PoseRole::Reference,
                        Role::Register => PoseRole::Register,
                        Role::Pose => PoseRole::Pose,
                    };
                    (pose, (c.y.iter().copied().collect(), role))
                })
                .unzip()
        }
    };
    let frames = poses.len();
    let bar = ProgressBar::new(frames as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating into {}", args.out.display()));
    let start = Instant::now();
    let written = sim
        .write_commanded_recording(&args.out, &poses, &commands, args.overwrite, |_| {
            bar.inc(1);
            if stop.requested() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .with_context(|| format!("cannot write the recording to {}", args.out.display()))?;
    bar.finish_and_clear();
    let cams = sim.rig().cameras.len();
    println!(
        "wrote {written} frames × {cams} cameras to {} in {:.1} s{}",
        args.out.display(),
        start.elapsed().as_secs_f64(),
        if (written as usize) < frames {
            " (stopped early by Ctrl-C; every written frame is whole)"
        } else {
            ""
        }
    );
    println!(
        "  layout: docs/formats.md; check its rig with: flexshape rig check {}",
        args.out.join("rig.toml").display()
    );
    Ok(())
}

/// The simulated catheter built as the model describes it: its proximal section `L0` long
/// (most of it below the volume) and its bending section `L1`, with the bending base where the
/// default catheter has it, so the model's `ε0` moves the bending base as on a real rig.
fn catheter_for(default: &Catheter, params: &ManipulatorParams) -> Catheter {
    let bend_base = default.base.position + default.base.tangent() * default.proximal_length;
    Catheter {
        proximal_length: params.proximal_length,
        bend_length: params.distal_length,
        base: flexshape_curve::Frame {
            position: bend_base - default.base.tangent() * params.proximal_length,
            rotation: default.base.rotation,
        },
        ..default.clone()
    }
}
