//! `flexshape simulate`: write a simulated recording with a progress bar.

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_sim::Simulator;
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::SimulateArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let sim =
        Simulator::new(super::sim_config(&args.sim)).context("cannot set up the simulated rig")?;
    let poses = sim.sweep(args.frames);
    let bar = ProgressBar::new(args.frames as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating into {}", args.out.display()));
    let start = Instant::now();
    let written = sim
        .write_recording(&args.out, &poses, args.overwrite, |_| {
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
        if (written as usize) < args.frames {
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
