//! `flexshape rig refine`: the camera poses refined from tracked frames
//! ([`flexshape_lab::refine::refine_cameras`]), written as a new rig.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flexshape_lab::refine::{refine_cameras, refined_camera_file, sample_frames};
use flexshape_rig::Rig;
use flexshape_track::output::{refuse_existing, refuse_inputs};

use super::frames;
use crate::cli::RigRefineArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &RigRefineArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    frames::warn_unseen(&input.rig, &volume);
    let hold = held_camera(&input.rig, args.hold.as_deref())?;
    let rig_path = args.out.join("rig.toml");
    refuse_outputs(&input, args)?;
    let pipeline = input
        .pipeline(&volume)
        .with_context(|| format!("cannot set up tracking for {}", input.rig_name))?;

    let (frames, left_out) = sample_frames(
        input.source.as_mut(),
        &pipeline,
        args.use_frames as usize,
        stop.flag(),
    )?;
    for note in &left_out {
        eprintln!("{note}");
    }
    let held = match hold {
        Some(h) => format!(", never {}", input.rig.cameras[h].name),
        None => String::new(),
    };
    eprintln!(
        "refining the poses from {} frames: as few cameras move as explain them{held}, the others hold the world frame where the calibration put it …",
        frames.len(),
    );
    let refinement = refine_cameras(&pipeline, &frames, hold)
        .with_context(|| format!("rig {}", input.rig_name))?;
    if stop.requested() {
        bail!("interrupted: nothing written");
    }
    print!("{refinement}");
    for note in refinement.undecided() {
        println!("{note}");
    }
    for w in refinement.warnings(pipeline.fit_settings().max_residual_px) {
        eprintln!("warning: {w}");
    }
    if let Some(why) = refinement.not_worth_writing() {
        println!("{why}");
        return Ok(());
    }
    let (before, after) = refinement.overall_rms();
    let gain = refinement.gain_percent();
    let rig = refinement.rig(&input.rig, volume);
    rig.save(&rig_path)
        .with_context(|| format!("cannot write the refined rig to {}", args.out.display()))?;
    let source = args
        .frames
        .recording
        .as_ref()
        .map_or("…".to_string(), |r| r.display().to_string());
    println!(
        "the refined poses explain the outlines {gain:.0} % better ({before:.3} → {after:.3} px RMS); wrote {} and its camera files; track with: flexshape track {source} --rig {}",
        rig_path.display(),
        rig_path.display()
    );
    Ok(())
}

/// The camera `--hold` names (rig order), if it names one.
fn held_camera(rig: &Rig, hold: Option<&str>) -> anyhow::Result<Option<usize>> {
    let Some(name) = hold else {
        return Ok(None);
    };
    rig.cameras
        .iter()
        .position(|c| c.name == name)
        .map(Some)
        .with_context(|| {
            format!(
                "--hold {name}: the rig has no such camera (its cameras: {})",
                camera_names(rig)
            )
        })
}

/// Refuses outputs that are or lie in an input, and existing ones without `--overwrite`.
fn refuse_outputs(input: &flexshape_track::Input, args: &RigRefineArgs) -> anyhow::Result<()> {
    let mut planned: Vec<PathBuf> = input
        .rig
        .cameras
        .iter()
        .map(|c| args.out.join(refined_camera_file(&c.name)))
        .collect();
    planned.push(args.out.join("rig.toml"));
    planned.push(args.out.clone());
    refuse_inputs(&planned, &input.files)?;
    Ok(refuse_existing(&planned, args.overwrite)?)
}

fn camera_names(rig: &Rig) -> String {
    rig.cameras
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}
