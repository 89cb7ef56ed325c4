//! `flexshape simulate`: write a simulated recording or calibration session with a progress
//! bar (`flexshape_lab::simulate`).

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_lab::simulate::{
    BoardSession, Scenario, simulate_boards, simulate_drawn_masks, simulate_recording,
};
use flexshape_model::ExperimentPlan;
use flexshape_sim::FreeRunning;
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::{ChessboardsArgs, SimulateArgs, SimulateWhat};
use crate::interrupt::Interrupt;

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    if let Some(SimulateWhat::Chessboards(a)) = &args.what {
        return chessboards(a);
    }
    let Some(out) = &args.out else {
        anyhow::bail!("give the folder to write the recording to with --out DIR");
    };
    let scenario = scenario(args)?;
    if let Some(width) = args.drawn_masks {
        anyhow::ensure!(
            width.is_finite() && width >= 1.0,
            "--drawn-masks {width}: give the drawn line's width in pixels, at least 1"
        );
    }
    let stop = Interrupt::install();
    let bar = ProgressBar::new(scenario.frames() as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating into {}", out.display()));
    let start = Instant::now();
    let config = super::sim_config(&args.sim);
    let on_frame = || {
        bar.inc(1);
        if stop.requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let (written, planned) = match args.drawn_masks {
        Some(width) => simulate_drawn_masks(config, &scenario, width, out, args.overwrite, |_| {
            on_frame()
        }),
        None => simulate_recording(config, &scenario, out, args.overwrite, |_| on_frame()),
    }
    .with_context(|| format!("cannot write the recording to {}", out.display()))?;
    bar.finish_and_clear();
    println!(
        "wrote {written} {} × {} cameras to {} in {:.1} s{}",
        if args.drawn_masks.is_some() {
            "drawn masks"
        } else {
            "frames"
        },
        args.sim.cams,
        out.display(),
        start.elapsed().as_secs_f64(),
        if (written as usize) < planned {
            " (stopped early by Ctrl-C; every written frame is whole)"
        } else {
            ""
        }
    );
    println!(
        "  layout: docs/formats.md; check its rig with: flexshape rig check {}",
        out.join("rig.toml").display()
    );
    Ok(())
}

/// What the options ask to film.
fn scenario(args: &SimulateArgs) -> anyhow::Result<Scenario> {
    if let Some(path) = &args.model {
        anyhow::ensure!(
            args.preload.is_finite() && args.preload > 0.0 && args.preload <= 0.5,
            "--preload {}: give a compression strain above 0 and at most 0.5",
            args.preload
        );
        let plan = ExperimentPlan {
            poses: args.poses,
            preload_strain: args.preload,
            ..ExperimentPlan::default()
        };
        let model = super::model::load(path)?;
        return Scenario::experiment(model, &plan).with_context(|| path.display().to_string());
    }
    Ok(match args.motion {
        Some(hz) => {
            anyhow::ensure!(
                hz.is_finite() && hz > 0.0,
                "--motion must be a positive number of frames per second"
            );
            anyhow::ensure!(
                (0.0..=1.0).contains(&args.shutter),
                "--shutter {}: give the share of the frame interval the shutter is open, 0–1",
                args.shutter
            );
            anyhow::ensure!(
                args.pace.is_finite() && args.pace > 0.0 && args.pace <= 100.0,
                "--pace {}: give the motion's speed against the default, above 0 and at most 100",
                args.pace
            );
            Scenario::Motion {
                frames: args.frames,
                rate_hz: hz,
                shutter: args.shutter,
                clocks: free_running(args)?,
                pace: args.pace,
            }
        }
        None => Scenario::Sweep {
            frames: args.frames,
        },
    })
}

/// The cameras' clocks `--phases` and `--jitter` ask for, or `None` when every camera captures
/// at the frame's instant.
fn free_running(args: &SimulateArgs) -> anyhow::Result<Option<FreeRunning>> {
    for &ms in &args.phases {
        anyhow::ensure!(
            ms.is_finite() && ms.abs() <= 10_000.0,
            "--phases: {ms} ms is not a capture delay; give each camera's delay after the frame's instant in ms, at most 10 s either way"
        );
    }
    anyhow::ensure!(
        args.jitter.is_finite() && (0.0..=10_000.0).contains(&args.jitter),
        "--jitter {}: give how early or late a capture may be, ms, from 0 to 10 s",
        args.jitter
    );
    if let Some(extra) = args.phases.get(args.sim.cams) {
        anyhow::bail!(
            "--phases gives {} delays for {} cameras (the first extra: {extra} ms): give one per camera at most",
            args.phases.len(),
            args.sim.cams
        );
    }
    Ok(
        (args.phases.iter().any(|&p| p != 0.0) || args.jitter > 0.0).then(|| FreeRunning {
            phases_s: args.phases.iter().map(|ms| ms / 1e3).collect(),
            jitter_s: args.jitter / 1e3,
        }),
    )
}

/// `flexshape simulate chessboards`.
fn chessboards(args: &ChessboardsArgs) -> anyhow::Result<()> {
    let board =
        flexshape_calib::Board::from_spec(&args.board, args.square, args.marker, &args.dictionary)
            .map_err(|e| anyhow::anyhow!("--board/--square: {e}"))?;
    let session = BoardSession {
        own: args.own,
        shared: args.shared,
        noise: args.sim.noise,
        seed: args.sim.seed,
    };
    let bar = ProgressBar::new_spinner();
    let written = simulate_boards(
        &super::sim_config(&args.sim),
        &board,
        &session,
        &args.out,
        || bar.inc(1),
    )?;
    bar.finish_and_clear();
    println!(
        "wrote {} images of a {} board ({} mm squares) to {} and the true rig to {}",
        written.images,
        args.board,
        args.square,
        args.out.join("images").display(),
        written.truth.display()
    );
    let images: Vec<String> = written
        .folders
        .iter()
        .map(|(name, dir)| format!("--images {name}={}", dir.display()))
        .collect();
    let markers = args
        .marker
        .map(|m| format!(" --marker {m} --dictionary {}", args.dictionary))
        .unwrap_or_default();
    println!(
        "  calibrate with: flexshape calibrate --board {} --square {}{markers} {} --out {}",
        args.board,
        args.square,
        images.join(" "),
        args.out.join("calibration").display()
    );
    Ok(())
}
