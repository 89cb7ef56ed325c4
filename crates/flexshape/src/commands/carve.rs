//! `flexshape carve`: the visual hull of every frame, for objects that are not tubes —
//! silhouettes and carving only, written as a PLY cloud and a PLY surface per frame and one
//! JSON record per frame in `hull.jsonl`.

use anyhow::{Context, bail};
use flexshape_lab::carve::{Carved, carve_all};
use flexshape_record::RecordStatus;
use flexshape_track::output::{refuse_existing, refuse_inputs};

use super::frames;
use crate::cli::CarveArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &CarveArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    frames::warn_unseen(&input.rig, &volume);
    refuse_inputs([&args.out], &input.files)?;
    let pipeline = input
        .pipeline(&volume)
        .with_context(|| format!("cannot set up carving for {}", input.rig_name))?;
    let records = args.out.join("hull.jsonl");
    refuse_existing([&records], args.overwrite)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let done = carve_all(
        input.source.as_mut(),
        &pipeline,
        &args.out,
        super::ply_encoding(args.ascii_ply),
        stop.flag(),
        |record| {
            if record.status == RecordStatus::Error {
                eprintln!(
                    "frame {:06}: {}",
                    record.frame,
                    record.reason.as_deref().unwrap_or("")
                );
            }
        },
    )?;
    let Carved {
        frames: frames_done,
        carved,
        failed,
        ..
    } = done;
    eprintln!(
        "{frames_done} frames ({carved} carved) into {}: NNNNNN.ply (voxel centres), NNNNNN.surface.ply (hull surface), hull.jsonl",
        args.out.display()
    );
    // As `track`: an interrupted run, or one in which every frame failed, did not do what was
    // asked.
    if done.stopped || stop.requested() {
        bail!("interrupted after {frames_done} frames (every record written is whole)");
    }
    if frames_done > 0 && failed == frames_done {
        bail!("every one of the {frames_done} frames failed (see hull.jsonl's `reason`)");
    }
    Ok(())
}
