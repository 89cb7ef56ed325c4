//! `flexshape carve`: the visual hull of every frame, for objects that are not tubes —
//! silhouettes and carving only, written as a PLY cloud and a PLY surface per frame and one
//! JSON record per frame in `hull.jsonl`.

use std::io::Write;

use anyhow::{Context, bail};
use flexshape_record::HullRecord;
use flexshape_record::RecordStatus;
use flexshape_track::carve_frame;
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
    let mut out = std::fs::File::create(&records)
        .with_context(|| format!("cannot create {}", records.display()))?;
    let (mut frames_done, mut carved, mut failed) = (0usize, 0usize, 0usize);
    while let Some(next) = input.source.next_frame() {
        if stop.requested() {
            break;
        }
        let record = match next {
            Ok(set) => carve_frame(
                &pipeline,
                set,
                &args.out,
                super::ply_encoding(args.ascii_ply),
            )?,
            Err(e) if e.ends_input() => bail!("the input broke after {frames_done} frames: {e}"),
            Err(e) => HullRecord::error(frames_done as u64, None, e.to_string()),
        };
        if record.status == RecordStatus::Error {
            eprintln!(
                "frame {:06}: {}",
                record.frame,
                record.reason.as_deref().unwrap_or("")
            );
        }
        carved += usize::from(record.status.is_ok());
        failed += usize::from(record.status == RecordStatus::Error);
        let line = serde_json::to_string(&record).context("cannot encode a record")?;
        writeln!(out, "{line}")
            .and_then(|_| out.flush())
            .with_context(|| format!("cannot write {}", records.display()))?;
        frames_done += 1;
    }
    eprintln!(
        "{frames_done} frames ({carved} carved) into {}: NNNNNN.ply (voxel centres), NNNNNN.surface.ply (hull surface), hull.jsonl",
        args.out.display()
    );
    // As `track`: an interrupted run, or one in which every frame failed, did not do what was
    // asked.
    if stop.requested() {
        bail!("interrupted after {frames_done} frames (every record written is whole)");
    }
    if frames_done > 0 && failed == frames_done {
        bail!("every one of the {frames_done} frames failed (see hull.jsonl's `reason`)");
    }
    Ok(())
}
