//! `flexshape rig refine`: the camera poses refined from tracked frames
//! ([`flexshape_track::refine_cameras`]), written as a new rig.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flexshape_rig::Rig;
use flexshape_track::{
    MAX_SIGMA_MM, OutlineResiduals, Refinement, Verdict, refine_cameras, refined_camera_file,
    sample_frames,
};

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
    eprintln!(
        "refining the poses from {} frames: {} held (the world frame stays attached to it), and the rig's scale (the other cameras' summed distance from it) kept as calibrated …",
        frames.len(),
        input.rig.cameras[hold].name
    );
    let refinement = refine_cameras(&pipeline, &frames, hold)
        .with_context(|| format!("rig {}", input.rig_name))?;
    if stop.requested() {
        bail!("interrupted: nothing written");
    }
    print_refinement(&refinement, pipeline.fit_settings().max_residual_px);
    if !worth_writing(&refinement) {
        return Ok(());
    }
    let (before, after) = refinement.overall_rms();
    let gain = 100.0 * (1.0 - after / before.max(1e-12));
    let rig = refinement.rig(volume, input.rig.processing.clone());
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

/// The camera `--hold` names (rig order), the first by default.
fn held_camera(rig: &Rig, hold: Option<&str>) -> anyhow::Result<usize> {
    let Some(name) = hold else {
        return Ok(0);
    };
    rig.cameras
        .iter()
        .position(|c| c.name == name)
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
    if let Some(p) = planned
        .iter()
        .find(|p| input.files.iter().any(|f| frames::within(p, f)))
    {
        bail!(
            "{} is or lies inside an input: write the refined rig elsewhere",
            p.display()
        );
    }
    super::rig_import::refuse_existing(&planned, args.overwrite)
}

/// Whether the refined poses are worth writing; says why not when they are not.
fn worth_writing(refinement: &Refinement) -> bool {
    let (before, after) = refinement.overall_rms();
    let gain = 100.0 * (1.0 - after / before.max(1e-12));
    match refinement.verdict() {
        Verdict::Better => true,
        Verdict::NoBetter => {
            println!(
                "the rig's poses already explain the outlines ({before:.3} → {after:.3} px RMS, {gain:.0} % better, {} → {} frames right): the refinement is within its own noise; keep the rig (nothing written)",
                refinement.right_before, refinement.right_after
            );
            false
        }
        Verdict::Undetermined { camera, sigma_mm } => {
            println!(
                "the frames do not pin camera {camera}'s pose down (±{sigma_mm:.2} mm at the tube, 1 σ; at most {MAX_SIGMA_MM}): the tubes fit a family of poses — with two cameras they always do; with more, record the tube in more varied shapes across the volume. Nothing written: calibrate the rig again instead"
            );
            false
        }
    }
}

fn camera_names(rig: &Rig) -> String {
    rig.cameras
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The before/after table, and a warning for cameras the refined pose still leaves off.
fn print_refinement(r: &Refinement, limit_px: f64) {
    println!(
        "{} of {} frames used ({} steps of the joint fit); frames right (tracked from scratch): {} with the rig's poses, {} with the refined ones",
        r.used, r.frames, r.steps, r.right_before, r.right_after
    );
    println!(
        "{:<12} {:>5} {:>22} {:>32} {:>9} {:>9} {:>9}",
        "camera", "held", "outline RMS px", "image shift px (x, y)", "turned °", "moved mm", "± mm"
    );
    let shift = |o: &OutlineResiduals| format!("({:+.2}, {:+.2})", o.shift_px[0], o.shift_px[1]);
    for c in &r.cameras {
        println!(
            "{:<12} {:>5} {:>22} {:>32} {:>9.3} {:>9.2} {:>9.3}",
            c.name,
            if c.held { "yes" } else { "" },
            format!("{:.3} → {:.3}", c.before.rms_px, c.after.rms_px),
            format!("{} → {}", shift(&c.before), shift(&c.after)),
            c.rotation_rad.to_degrees(),
            c.centre_moved_mm,
            c.sigma_mm
        );
    }
    for c in &r.cameras {
        if c.after.rms_px > limit_px {
            eprintln!(
                "warning: camera {} still leaves its outlines {:.2} px RMS off (the self-check allows {limit_px:.2}): its lens model (intrinsics, distortion) may be off too, which refining the pose cannot mend; calibrate it again",
                c.name, c.after.rms_px
            );
        }
    }
}
